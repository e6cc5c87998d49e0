// Byte-level pieces the streaming encodings share (core/stream/compact.cpp,
// core/stream/delta.cpp): little-endian words, LEB128 varints, zigzag, and the payload's entropy
// coder (zstd or raw deflate).
#pragma once

#include <cstdint>
#include <string>

#include "core/util/bytes.h"

namespace vismap {

// The entropy coder over the payload: zstd, or raw deflate (RFC 1951) for browsers, whose
// DecompressionStream("deflate-raw") inflates natively and has no zstd.
enum class Compression : uint32_t { Zstd = 1, Deflate = 2 };

}  // namespace vismap

namespace vismap::frame_io {

using le::get_u32;
using le::put_u32;
inline void put_varint(std::string& s, uint64_t v) {
  while (v >= 0x80) {
    s += char((v & 0x7F) | 0x80);
    v >>= 7;
  }
  s += char(v);
}
inline uint64_t zigzag(int64_t d) {
  return d < 0 ? ~(uint64_t(d) << 1) : uint64_t(d) << 1;
}
inline int64_t unzigzag(uint64_t z) {
  return z & 1 ? ~int64_t(z >> 1) : int64_t(z >> 1);
}

// The payload compressed with `c` at `level` (0: the coder's default, zstd 3, deflate 6).
// `writer` names the caller in the exception a coder failure throws.
std::string compress(const std::string& payload, Compression c, int level, const char* writer);

// Decompresses exactly out.size() bytes from in[0, n): one zstd frame of that content size, or
// one raw deflate stream ending exactly at n. Returns "" or what was wrong.
std::string decompress(const char* in, size_t n, Compression c, std::string& out);

}  // namespace vismap::frame_io
