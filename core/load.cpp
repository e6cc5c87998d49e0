// load_scene: picks the reader by extension and applies the checks every format shares.
#include <zlib.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>

#include "core/load_internal.h"

namespace vismap {
namespace detail {

std::string format_extension(const std::string& name) {
  std::string base = name.substr(name.find_last_of('/') + 1);
  std::transform(base.begin(), base.end(), base.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  auto ends = [&](std::string_view e) {
    return base.size() > e.size() && base.compare(base.size() - e.size(), e.size(), e) == 0;
  };
  if (ends(".ply.gz")) return ".ply.gz";
  size_t dot = base.find_last_of('.');
  return dot == std::string::npos || dot == 0 ? std::string() : base.substr(dot);
}

std::string file_stem(const std::string& name) {
  std::string base = name.substr(name.find_last_of('/') + 1);
  std::string ext = format_extension(base);
  return base.substr(0, base.size() - ext.size());
}

std::string dir_of(const std::string& path) {
  size_t slash = path.find_last_of('/');
  return slash == std::string::npos ? std::string() : path.substr(0, slash + 1);
}

std::string read_whole_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(InputErrorKind::FileNotFound, path, "", "", -1, "cannot open file");
  in.seekg(0, std::ios::end);
  std::streamoff size = in.tellg();
  if (size < 0) throw InputError(InputErrorKind::FileNotFound, path, "", "", -1, "cannot read file");
  std::string bytes;
  in.seekg(0);
  bytes.resize(static_cast<size_t>(size));
  in.read(bytes.data(), size);
  if (in.gcount() != size)
    throw InputError(InputErrorKind::Truncated, path, "", "", -1, "file shrank while reading");
  return bytes;
}

std::string gunzip(const Source& src, std::string_view bytes) {
  constexpr size_t kMaxOut = size_t(1) << 32;  // a decompression bomb is refused, not swallowed
  z_stream z{};
  if (inflateInit2(&z, 15 + 32) != Z_OK)  // 15 + 32: zlib or gzip header, detected
    fail(InputErrorKind::ParseError, src, "", "", -1, "zlib init failed");
  // Inflate straight into the result, sized from the gzip trailer (uncompressed size mod 2^32;
  // capped, since deflate expands at most ~1032x and a cut file's trailer is garbage).
  size_t guess = bytes.size() * 4;
  if (bytes.size() >= 18) {
    uint32_t isize;
    std::memcpy(&isize, bytes.data() + bytes.size() - 4, 4);
    guess = std::min<uint64_t>(isize, uint64_t(bytes.size()) * 1032);
  }
  std::string out(guess + 1, '\0');  // +1: a full buffer then means "more to come"
  size_t used = 0;
  z.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(bytes.data()));
  z.avail_in = static_cast<uInt>(bytes.size());
  int rc = Z_OK;
  while (rc != Z_STREAM_END) {
    if (used == out.size()) {
      if (out.size() > kMaxOut) {
        inflateEnd(&z);
        fail(InputErrorKind::TooLarge, src, "", "", -1, "decompresses to more than 4 GiB");
      }
      out.resize(out.size() * 2);
    }
    size_t room = std::min<size_t>(out.size() - used, 1u << 30);
    z.next_out = reinterpret_cast<Bytef*>(out.data() + used);
    z.avail_out = static_cast<uInt>(room);
    rc = inflate(&z, Z_NO_FLUSH);
    used += room - z.avail_out;
    if (rc == Z_STREAM_END) break;
    if (rc == Z_BUF_ERROR || (rc == Z_OK && z.avail_in == 0 && z.avail_out != 0)) {
      inflateEnd(&z);
      fail(InputErrorKind::Truncated, src, "", "gzip byte", static_cast<int64_t>(bytes.size()),
           "compressed stream ends early");
    }
    if (rc != Z_OK) {
      std::string msg = z.msg ? z.msg : "corrupt data";
      int64_t at = static_cast<int64_t>(bytes.size() - z.avail_in);
      inflateEnd(&z);
      fail(InputErrorKind::ParseError, src, "", "gzip byte", at, "not a valid gzip stream: " + msg);
    }
  }
  out.resize(used);
  inflateEnd(&z);
  return out;
}

void check_size(uint64_t triangles, const LoadOptions& opts, const Source& src,
                const std::string& mesh) {
  if (opts.max_triangles != 0 && triangles > opts.max_triangles)
    fail(InputErrorKind::TooLarge, src, mesh, "", -1,
         std::to_string(triangles) + " triangles, limit is " + std::to_string(opts.max_triangles));
}

namespace {

// True when two referenced vertices sit at the same position: edges must then be matched by
// position, not by index (STL, OBJ exports that split vertices at seams). A flat open-addressing
// table: no allocation per vertex.
bool has_duplicate_positions(const Mesh& m) {
  size_t nv = m.vertex_count();
  std::vector<uint8_t> used(nv, 0);
  size_t n_used = 0;
  for (uint32_t i : m.indices) n_used += used[i] ? 0 : (used[i] = 1);
  size_t cap = 16;
  while (cap < 2 * n_used) cap *= 2;
  std::vector<uint32_t> table(cap, UINT32_MAX);
  auto key = [&](size_t v, int k) {
    float f = m.positions[3 * v + k] + 0.0f;  // -0 and +0 are the same place
    uint32_t u;
    std::memcpy(&u, &f, 4);
    return u;
  };
  for (size_t v = 0; v < nv; ++v) {
    if (!used[v]) continue;
    uint32_t x = key(v, 0), y = key(v, 1), z = key(v, 2);
    uint64_t h = x * 0x9E3779B97F4A7C15ull ^ y * 0xC2B2AE3D27D4EB4Full ^ z * 0x165667B19E3779F9ull;
    for (size_t slot = (h ^ (h >> 29)) & (cap - 1);; slot = (slot + 1) & (cap - 1)) {
      uint32_t o = table[slot];
      if (o == UINT32_MAX) {
        table[slot] = uint32_t(v);
        break;
      }
      if (key(o, 0) == x && key(o, 1) == y && key(o, 2) == z) return true;
    }
  }
  return false;
}

}  // namespace

uint64_t finish_mesh(Mesh& m, const Source& src) {
  size_t nv = m.vertex_count();
  if (m.indices.empty())
    fail(InputErrorKind::EmptyMesh, src, m.name, "", -1, "no triangles");
  for (size_t i = 0; i < m.positions.size(); ++i)
    if (!std::isfinite(m.positions[i]))
      fail(InputErrorKind::NonFiniteVertex, src, m.name, "vertex", static_cast<int64_t>(i / 3),
           "coordinate " + std::string(1, "xyz"[i % 3]) + " is not finite");
  size_t nt = m.indices.size() / 3;
  m.source_triangles = static_cast<uint32_t>(nt);
  m.face_ids.clear();
  m.face_ids.reserve(nt);
  size_t kept = 0;
  const float* p = m.positions.data();
  for (size_t t = 0; t < nt; ++t) {
    uint32_t a = m.indices[3 * t], b = m.indices[3 * t + 1], c = m.indices[3 * t + 2];
    if (a >= nv || b >= nv || c >= nv)
      fail(InputErrorKind::IndexOutOfRange, src, m.name, "triangle", static_cast<int64_t>(t),
           "vertex index " + std::to_string(std::max({a, b, c})) + " out of range (" +
               std::to_string(nv) + " vertices)");
    if (a == b || b == c || a == c) continue;
    double u[3], w[3];
    for (int k = 0; k < 3; ++k) {
      u[k] = double(p[3 * b + k]) - double(p[3 * a + k]);
      w[k] = double(p[3 * c + k]) - double(p[3 * a + k]);
    }
    double nx = u[1] * w[2] - u[2] * w[1], ny = u[2] * w[0] - u[0] * w[2],
           nz = u[0] * w[1] - u[1] * w[0];
    if (nx == 0.0 && ny == 0.0 && nz == 0.0) continue;
    m.indices[3 * kept] = a;
    m.indices[3 * kept + 1] = b;
    m.indices[3 * kept + 2] = c;
    m.face_ids.push_back(static_cast<uint32_t>(t));
    ++kept;
  }
  m.indices.resize(3 * kept);
  if (!m.soup) m.soup = has_duplicate_positions(m);
  return nt - kept;
}

Scene load_mesh_bytes(const Source& src, std::string_view bytes, const LoadOptions& opts) {
  std::string ext = format_extension(src.file);
  if (ext == ".gltf" || ext == ".glb") return read_gltf(src, bytes, ext == ".glb", opts);
  std::vector<Mesh> meshes;
  if (ext == ".ply") {
    meshes = read_ply(src, bytes, opts);
  } else if (ext == ".ply.gz") {
    std::string plain = gunzip(src, bytes);
    meshes = read_ply(src, plain, opts);
  } else if (ext == ".obj") {
    meshes = read_obj(src, bytes, opts);
  } else if (ext == ".off") {
    meshes = read_off(src, bytes, opts);
  } else if (ext == ".stl") {
    meshes = read_stl(src, bytes, opts);
  } else {
    fail(InputErrorKind::UnknownFormat, src, "", "", -1,
         "unknown format '" + ext + "' (expected .gltf .glb .ply .ply.gz .obj .off .stl .json)");
  }
  Scene s;
  s.source = src.file;
  uint64_t total = 0;
  for (Mesh& m : meshes) {
    total += m.indices.size() / 3;
    check_size(total, opts, src, m.name);
    s.dropped_degenerate += finish_mesh(m, src);
  }
  s.meshes = std::move(meshes);
  if (s.triangle_count() == 0)
    fail(InputErrorKind::EmptyMesh, src, "", "", -1, "every triangle is degenerate (zero area)");
  return s;
}

}  // namespace detail

namespace {
bool known_extension(const std::string& ext) {
  for (const char* e : {".gltf", ".glb", ".ply", ".ply.gz", ".obj", ".off", ".stl", ".json"})
    if (ext == e) return true;
  return false;
}
}  // namespace

Scene load_scene(const std::string& path, const LoadOptions& opts) {
  detail::Source src{path, detail::dir_of(path)};
  if (src.base_dir.empty()) src.base_dir = "./";
  std::string ext = detail::format_extension(path);
  if (!known_extension(ext))
    detail::fail(InputErrorKind::UnknownFormat, src, "", "", -1,
                 "unknown format '" + ext + "' (expected .gltf .glb .ply .ply.gz .obj .off .stl .json)");
  std::string bytes = detail::read_whole_file(path);
  if (ext == ".json") return detail::read_scene_file(src, bytes, opts);
  return detail::load_mesh_bytes(src, bytes, opts);
}

Scene load_scene_from_memory(const std::string& name, const std::string& bytes,
                             const LoadOptions& opts) {
  detail::Source src{name, ""};  // no base folder: bytes from memory never reach the file system
  std::string ext = detail::format_extension(name);
  if (!known_extension(ext))
    detail::fail(InputErrorKind::UnknownFormat, src, "", "", -1,
                 "unknown format '" + ext + "' (expected .gltf .glb .ply .ply.gz .obj .off .stl .json)");
  if (ext == ".json") return detail::read_scene_file(src, bytes, opts);
  return detail::load_mesh_bytes(src, bytes, opts);
}

}  // namespace vismap
