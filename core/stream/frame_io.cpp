// The streaming encodings' entropy coder (core/stream/frame_io.h).
#include "core/stream/frame_io.h"

#include <zlib.h>
#include <zstd.h>

#include <stdexcept>

namespace vismap::frame_io {

std::string compress(const std::string& payload, Compression c, int level, const char* writer) {
  if (c == Compression::Zstd) {
    std::string out(ZSTD_compressBound(payload.size()), '\0');
    const size_t z =
        ZSTD_compress(out.data(), out.size(), payload.data(), payload.size(), level ? level : 3);
    if (ZSTD_isError(z))
      throw std::runtime_error(std::string(writer) + ": zstd: " + ZSTD_getErrorName(z));
    out.resize(z);
    return out;
  }
  z_stream z{};
  if (deflateInit2(&z, level ? level : 6, Z_DEFLATED, -15, 9, Z_DEFAULT_STRATEGY) != Z_OK)
    throw std::runtime_error(std::string(writer) + ": deflateInit2 failed");
  std::string out(deflateBound(&z, payload.size()), '\0');
  z.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(payload.data()));
  z.avail_in = uInt(payload.size());
  z.next_out = reinterpret_cast<Bytef*>(out.data());
  z.avail_out = uInt(out.size());
  const int rc = deflate(&z, Z_FINISH);
  out.resize(z.total_out);
  deflateEnd(&z);
  if (rc != Z_STREAM_END) throw std::runtime_error(std::string(writer) + ": deflate failed");
  return out;
}

std::string decompress(const char* in, size_t n, Compression c, std::string& out) {
  if (c == Compression::Zstd) {
    if (ZSTD_getFrameContentSize(in, n) != out.size())
      return "not one zstd frame of the stated size";
    const size_t got = ZSTD_decompress(out.data(), out.size(), in, n);
    if (ZSTD_isError(got)) return std::string("zstd: ") + ZSTD_getErrorName(got);
    if (got != out.size()) return "zstd: short";
    return "";
  }
  z_stream z{};
  if (inflateInit2(&z, -15) != Z_OK) return "inflateInit2 failed";
  z.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(in));
  z.avail_in = uInt(n);
  z.next_out = reinterpret_cast<Bytef*>(out.data());
  z.avail_out = uInt(out.size());
  const int rc = inflate(&z, Z_FINISH);
  const bool ok = rc == Z_STREAM_END && z.avail_out == 0 && z.avail_in == 0;
  inflateEnd(&z);
  return ok ? "" : "not one raw deflate stream of the stated size";
}

}  // namespace vismap::frame_io
