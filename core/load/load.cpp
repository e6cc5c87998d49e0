// load_scene: picks the reader by extension and applies the checks every format shares.
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zlib.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>

#include "core/load/internal.h"
#include "core/util/polygon.h"
#include "core/util/weld.h"

namespace vismap {
namespace detail {

// What the formats' unknown-format message lists.
constexpr const char* kFormats =
    ".gltf .glb .ply .ply.gz .obj .off .stl .pbrt .bpt .patches .sexp .json";

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

std::string degenerate_transform(const std::array<double, 16>& m) {
  double n[3];
  for (int c = 0; c < 3; ++c) {
    n[c] = std::hypot(m[4 * c], m[4 * c + 1], m[4 * c + 2]);  // no underflow of the squares
    if (!std::isfinite(n[c])) return "the transform is not finite";
    if (!(n[c] >= std::numeric_limits<float>::min()))
      return "the transform collapses axis " + std::string(1, char('x' + c)) +
             (n[c] == 0 ? " to nothing" : " below float range");
  }
  const double det = m[0] * (m[5] * m[10] - m[9] * m[6]) - m[4] * (m[1] * m[10] - m[9] * m[2]) +
                     m[8] * (m[1] * m[6] - m[5] * m[2]);
  // Relative to the columns' sizes (|det| <= n0 n1 n2): 1e-12 flags only a transform flat to
  // far below what float positions can show.
  if (!(std::abs(det) > 1e-12 * n[0] * n[1] * n[2]))
    return "the transform is singular (it flattens everything onto a plane or a line)";
  return "";
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

void ByteBudget::charge(uint64_t n, const std::string& file, const std::string& what) {
  if (n > left())
    throw InputError(InputErrorKind::TooLarge, file, "", "", -1,
                     what + ": the load would hold more than " + std::to_string(limit_) +
                         " input bytes" + (limit_ == kMaxInputBytes ? "" : " (max_bytes)"));
  used_ += n;
}

void ByteBudget::check_time(const std::string& file, const char* doing) const {
  if (seconds_ == 0 || std::chrono::steady_clock::now() <= until_) return;
  char limit[32];
  std::snprintf(limit, sizeof limit, "%g", seconds_);
  throw InputError(
      InputErrorKind::TimeLimit, file, "", "", -1,
      std::string("the load passed its time limit of ") + limit + " s (in " + doing + ")");
}

namespace {

[[noreturn]] void not_found(const std::string& path, const std::string& msg) {
  throw InputError(InputErrorKind::FileNotFound, path, "", "", -1, msg);
}

const char* file_type(mode_t m) {
  return S_ISDIR(m)                 ? "a directory"
         : S_ISFIFO(m)              ? "a FIFO"
         : S_ISSOCK(m)              ? "a socket"
         : S_ISCHR(m) || S_ISBLK(m) ? "a device"
                                    : "not a regular file";
}

// realpath(3) as a string, or "" when the path does not resolve.
std::string real_path(const std::string& p) {
  char* r = ::realpath(p.c_str(), nullptr);
  if (!r) return {};
  std::string out(r);
  std::free(r);
  return out;
}

}  // namespace

std::string check_input_file(const std::string& path, const LoadOptions& opts) {
  std::string open_path = path;
  if (!opts.confine_to.empty()) {
    std::string root = real_path(opts.confine_to);
    if (root.empty())
      not_found(path, "cannot resolve the confining folder '" + opts.confine_to + "'");
    std::string real = real_path(path);
    if (real.empty()) not_found(path, "cannot open file");
    if (root != "/" && real.compare(0, root.size() + 1, root + "/") != 0)
      not_found(path, "outside the folder loads are confined to");
    open_path = real;  // open what was checked, not the path again (a symlink could move)
  }
  // stat first, so that a device or FIFO is never opened (opening some devices does things).
  struct stat st;
  if (::stat(open_path.c_str(), &st) != 0) not_found(path, "cannot open file");
  if (!S_ISREG(st.st_mode))
    not_found(path, std::string("not a regular file (") + file_type(st.st_mode) + ")");
  return open_path;
}

std::string read_input_file(const std::string& path, const LoadOptions& opts, ByteBudget& budget) {
  std::string open_path = check_input_file(path, opts);
  struct stat st;
  // O_NONBLOCK: if the path was swapped for a FIFO since the stat, open returns at once instead of
  // waiting for a writer, and fstat below refuses it.
  int fd = ::open(open_path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC | O_NOCTTY);
  if (fd < 0) not_found(path, "cannot open file");
  struct Closer {
    int fd;
    ~Closer() { ::close(fd); }
  } closer{fd};
  if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode))
    not_found(path, std::string("not a regular file (") + file_type(st.st_mode) + ")");
  uint64_t size = uint64_t(st.st_size);
  budget.charge(size, path, "file of " + std::to_string(size) + " bytes");
  std::string bytes(size, '\0');
  size_t got = 0;
  while (got < size) {
    ssize_t n = ::read(fd, bytes.data() + got, std::min<size_t>(size - got, size_t(1) << 30));
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) not_found(path, "cannot read file");
    if (n == 0)
      throw InputError(InputErrorKind::Truncated, path, "", "", -1, "file shrank while reading");
    got += size_t(n);
  }
  return bytes;
}

std::string gunzip(const Source& src, std::string_view bytes) {
  // The inflated bytes may take what the load's budget has left, and the buffer never grows past
  // that (+1, to see that there is more): a bomb is refused at the cap, not after allocating.
  const uint64_t cap = src.budget->left();
  z_stream z{};
  if (inflateInit2(&z, 15 + 32) != Z_OK)  // 15 + 32: zlib or gzip header, detected
    fail(InputErrorKind::ParseError, src, "", "", -1, "zlib init failed");
  struct Ender {
    z_stream* z;
    ~Ender() { inflateEnd(z); }
  } ender{&z};
  // Inflate straight into the result, sized from the gzip trailer (uncompressed size mod 2^32;
  // capped, since deflate expands at most ~1032x and a cut file's trailer is garbage).
  uint64_t guess = checked_mul(bytes.size(), 4);
  if (bytes.size() >= 18) {
    uint32_t isize;
    std::memcpy(&isize, bytes.data() + bytes.size() - 4, 4);
    guess = std::min<uint64_t>(isize, checked_mul(bytes.size(), 1032));
  }
  std::string out(std::min(guess, cap) + 1, '\0');  // +1: a full buffer then means "more to come"
  size_t used = 0, fed = 0;
  int rc = Z_OK;
  while (true) {
    if (used == out.size()) {
      if (used > cap)
        fail(InputErrorKind::TooLarge, src, "", "", -1,
             "decompresses to more than " + std::to_string(cap) + " bytes, the " +
                 (cap == src.budget->limit() ? "" : "rest of the ") + "input byte limit" +
                 (src.budget->limit() == kMaxInputBytes ? "" : " (max_bytes)"));
      out.resize(
          std::min<uint64_t>(std::max<uint64_t>(checked_mul(out.size(), 2), 1 << 16), cap + 1));
    }
    if (z.avail_in == 0 && fed < bytes.size()) {  // zlib counts in 32 bits: feed at most 1 GiB
      size_t n = std::min<size_t>(bytes.size() - fed, size_t(1) << 30);
      z.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(bytes.data() + fed));
      z.avail_in = static_cast<uInt>(n);
      fed += n;
    }
    size_t room = std::min<size_t>(out.size() - used, size_t(1) << 30);
    z.next_out = reinterpret_cast<Bytef*>(out.data() + used);
    z.avail_out = static_cast<uInt>(room);
    rc = inflate(&z, Z_NO_FLUSH);
    used += room - z.avail_out;
    if (rc == Z_STREAM_END) break;
    bool input_done = z.avail_in == 0 && fed == bytes.size();
    if (rc == Z_BUF_ERROR || (rc == Z_OK && input_done && z.avail_out != 0))
      fail(InputErrorKind::Truncated, src, "", "gzip byte", static_cast<int64_t>(bytes.size()),
           "compressed stream ends early");
    if (rc != Z_OK) {
      std::string msg = z.msg ? z.msg : "corrupt data";
      int64_t at = static_cast<int64_t>(fed - z.avail_in);
      fail(InputErrorKind::ParseError, src, "", "gzip byte", at, "not a valid gzip stream: " + msg);
    }
  }
  src.budget->charge(used, src.file, "inflated bytes");
  out.resize(used);
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
// position, not by index (STL, OBJ exports that split vertices at seams).
bool has_duplicate_positions(const Mesh& m) {
  size_t nv = m.vertex_count();
  std::vector<uint8_t> used(nv, 0);
  size_t n_used = 0;
  for (uint32_t i : m.indices) n_used += used[i] ? 0 : (used[i] = 1);
  Weld<float, 3> at(n_used);
  for (size_t v = 0; v < nv; ++v)
    if (used[v] && !at.add(&m.positions[3 * v], uint32_t(v)).second) return true;
  return false;
}

}  // namespace

uint64_t finish_mesh(Mesh& m, const Source& src) {
  size_t nv = m.vertex_count();
  if (m.indices.empty()) fail(InputErrorKind::EmptyMesh, src, m.name, "", -1, "no triangles");
  for (size_t i = 0; i < m.positions.size(); ++i)
    if (!std::isfinite(m.positions[i]))
      fail(InputErrorKind::NonFiniteVertex, src, m.name, "vertex", static_cast<int64_t>(i / 3),
           "coordinate " + std::string(1, "xyz"[i % 3]) + " is not finite");
  size_t nt = m.indices.size() / 3;
  if (nt > UINT32_MAX || nv > UINT32_MAX)  // ids and indices are 32-bit
    fail(InputErrorKind::TooLarge, src, m.name, "", -1,
         std::to_string(nt) + " triangles and " + std::to_string(nv) +
             " vertices, limit is 2^32 - 1 of each");
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

void LoadWarnings::move_to(std::vector<std::string>& out) {
  for (std::string& l : lines) out.push_back(std::move(l));
  if (more) out.push_back(std::to_string(more) + " more warnings like these not shown");
  lines.clear();
  more = 0;
}

void add_polygon(std::vector<uint32_t>& indices, const std::vector<float>& positions,
                 const uint32_t* corners, size_t k, const Source& src, const std::string& mesh,
                 int64_t face, int64_t line) {
  const size_t at = indices.size();
  indices.resize(at + 3 * (k - 2));
  const PolygonShape shape = triangulate_polygon(positions.data(), corners, k, indices.data() + at);
  if (shape == PolygonShape::Convex) return;
  if (shape != PolygonShape::Concave && src.warnings) {
    std::string where = src.file + ": mesh '" + mesh + "': face " + std::to_string(face);
    if (line >= 0) where += " (line " + std::to_string(line) + ")";
    src.warnings->add(where + ": polygon of " + std::to_string(k) + " corners " +
                      (shape == PolygonShape::TooLarge
                           ? "is not convex and has more than " +
                                 std::to_string(kMaxEarClipCorners) + ": fanned, not cut into ears"
                           : "is not simple (its edges cross): its triangles may overlap"));
  }
  // Ear clipping is quadratic in the corners: the load's time limit is kept between polygons.
  if (src.budget) src.budget->check_time(src.file, "polygon triangulation");
}

void refuse_utf16(const Source& src, std::string_view b) {
  auto byte = [&](size_t i) { return static_cast<unsigned char>(b[i]); };
  bool utf16 = b.size() >= 2 && ((byte(0) == 0xFE && byte(1) == 0xFF) ||
                                 (byte(0) == 0xFF && byte(1) == 0xFE));  // a byte-order mark
  if (!utf16 && b.size() >= 4) {
    // No mark: ASCII saved as UTF-16 has a NUL in every other byte (and text formats none).
    const size_t n = std::min<size_t>(b.size() & ~size_t(1), 64);
    size_t nul[2] = {0, 0};
    for (size_t i = 0; i < n; ++i) nul[i & 1] += b[i] == '\0';
    utf16 = (nul[0] == n / 2 && nul[1] == 0) || (nul[1] == n / 2 && nul[0] == 0);
  }
  if (utf16)
    fail(InputErrorKind::ParseError, src, "", "", -1, "UTF-16 text: save the file as UTF-8");
}

Scene load_mesh_bytes(const Source& given, std::string_view bytes, const LoadOptions& opts) {
  LoadWarnings warnings;
  Source src = given;
  src.warnings = &warnings;
  std::string ext = format_extension(src.file);
  // Every format but binary STL (any 80-byte header), GLB and gzip is text or starts with some.
  if (ext != ".stl" && ext != ".glb" && ext != ".ply.gz") refuse_utf16(src, bytes);
  if (ext == ".gltf" || ext == ".glb") return read_gltf(src, bytes, ext == ".glb", opts);
  if (ext == ".pbrt") return read_pbrt(src, bytes, opts);
  // Patch meshes have no triangles: the tail below (finish_mesh, "every triangle is degenerate")
  // is for triangle meshes only.
  if (ext == ".bpt") return read_bpt(src, bytes, opts);
  if (ext == ".patches") return read_newell_patches(src, bytes, opts);
  if (ext == ".sexp") return read_sexp(src, bytes, opts);
  std::vector<Mesh> meshes;
  if (ext == ".ply") {
    meshes = read_ply(src, bytes, opts);
  } else if (ext == ".ply.gz") {
    std::string plain = gunzip(src, bytes);
    refuse_utf16(src, plain);
    meshes = read_ply(src, plain, opts);
  } else if (ext == ".obj") {
    meshes = read_obj(src, bytes, opts);
  } else if (ext == ".off") {
    meshes = read_off(src, bytes, opts);
  } else if (ext == ".stl") {
    meshes = read_stl(src, bytes, opts);
  } else {
    fail(InputErrorKind::UnknownFormat, src, "", "", -1,
         "unknown format '" + ext +
             "' (expected " + std::string(kFormats) + ")");
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
  warnings.move_to(s.warnings);
  return s;
}

}  // namespace detail

namespace {
bool known_extension(const std::string& ext) {
  for (const char* e : {".gltf", ".glb", ".ply", ".ply.gz", ".obj", ".off", ".stl", ".pbrt", ".bpt",
                        ".patches", ".sexp", ".json"})
    if (ext == e) return true;
  return false;
}
}  // namespace

namespace detail {
Scene load_file(const std::string& path, const LoadOptions& opts, ByteBudget& budget) {
  Source src{path, dir_of(path), &budget};
  if (src.base_dir.empty()) src.base_dir = "./";
  std::string ext = format_extension(path);
  if (!known_extension(ext))
    fail(InputErrorKind::UnknownFormat, src, "", "", -1,
         "unknown format '" + ext +
             "' (expected " + std::string(kFormats) + ")");
  std::string bytes = read_input_file(path, opts, budget);
  if (ext == ".json") {
    refuse_utf16(src, bytes);
    return read_scene_file(src, bytes, opts);
  }
  return load_mesh_bytes(src, bytes, opts);
}
}  // namespace detail

Scene load_scene(const std::string& path, const LoadOptions& opts) {
  detail::ByteBudget budget(opts);
  return detail::load_file(path, opts, budget);
}

Scene load_scene_from_memory(const std::string& name, const std::string& bytes,
                             const LoadOptions& opts) {
  // The caller holds `bytes` already (and caps them itself, as the server's body limit does):
  // only what the load adds, the inflated bytes of a .gz, is charged.
  detail::ByteBudget budget(opts);
  // No base folder: bytes from memory never reach the file system.
  detail::Source src{name, "", &budget};
  std::string ext = detail::format_extension(name);
  if (!known_extension(ext))
    detail::fail(
        InputErrorKind::UnknownFormat, src, "", "", -1,
        "unknown format '" + ext +
            "' (expected " + std::string(detail::kFormats) + ")");
  if (ext == ".json") {
    detail::refuse_utf16(src, bytes);
    return detail::read_scene_file(src, bytes, opts);
  }
  return detail::load_mesh_bytes(src, bytes, opts);
}

}  // namespace vismap
