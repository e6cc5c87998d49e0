// The delta frame encoding, versions 1 and 2 (proto/DELTA.md): DeltaEncoder and DeltaDecoder.
//
// The format's parts come in twins, in DELTA.md's order, each encode_x beside its decode_x (as
// meshoptimizer pairs its codecs): the header, the camera, the mesh table, the section sizes,
// the new vertices, the new triangles, the facing flips (version 2), the whole set's change, the
// polygons section, the corner codes. DeltaEncoder::encode and DeltaDecoder::decode then read as
// the list of those steps; encode also weighs the frame against its compact frame (version 2).
#include "core/stream/delta.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>

#include "core/error.h"
#include "core/stream/frame_io.h"
#include "core/stream/simplify.h"
#include "core/util/conform.h"
#include "core/util/flat_map.h"
#include "core/write/shared.h"

namespace vismap {

namespace {

using frame_io::get_u32;
using frame_io::put_u32;
using frame_io::put_varint;
using frame_io::unzigzag;
using frame_io::zigzag;

constexpr char kMagic[4] = {'V', 'M', 'D', 'F'};
constexpr uint32_t kMaxVersion = 2;
constexpr size_t kHeaderBytes = 48;
constexpr uint32_t kKeyframe = 1;
constexpr uint32_t kHeld = 2;     // version 2, keyframes: the store starts from the held scene
constexpr uint32_t kSources = 4;  // version 2: the sources message (encode_delta_sources)
constexpr uint32_t kNoBase = 0xFFFFFFFFu;
constexpr uint64_t kMaxRatio = 256;
constexpr uint64_t kMaxSourceCount = 1ull << 26;  // triangles, and vertices, a client holds
constexpr size_t kCameraBytes = 4 + 18 * 8;
constexpr size_t kMeshEntryBytes = 24;
// Polygon corner codes (proto/DELTA.md, "Polygons").
constexpr uint64_t kOwnCorner = 0;  // 0, 1, 2: corner k of the polygon's own source triangle
constexpr uint64_t kVertexRef = 3;  // a source vertex: zigzag(global number - own corner 0's)
constexpr uint64_t kNewPoint = 4;   // a new point: its coordinates follow in the points section
constexpr uint64_t kTwin = 5;       // the corner that came before this one's predecessor in an
                                    // earlier polygon (the edge they share, walked back)
constexpr uint64_t kEdgePoint = 6;  // 6, 7, 8: a new point on own edge k (vertex k to k + 1),
                                    // at step t of the edge (t follows in the edge steps section)
constexpr uint64_t kPointRef = 9;   // version 1: 9 + j, the j-th most recent new point
// Version 2: 9 + 3i + k (i = 0, 1): the i-th point made on own edge k's source edge (codes 6-8)
// earlier in this frame; 15 + j: the j-th most recent new point.
constexpr uint64_t kEdgeRef = 9;
constexpr uint64_t kEdgeRefs = 2;  // points per edge that codes 9-14 name
constexpr uint64_t kPointRef2 = kEdgeRef + 3 * kEdgeRefs;

// The payload's sections, in order (DELTA.md, "Payload").
// Version 1 has the first ten, version 2 all eleven.
enum Section : int {
  kVertices,
  kPositions,
  kTriangles,
  kRemoved,
  kAdded,
  kPolygons,
  kCodes,
  kRefs,
  kPoints,
  kSteps,
  kFlips,
  kSections
};
constexpr const char* kSectionName[kSections] = {
    "vertices",     "vertex positions", "triangles", "removed",    "added", "polygons",
    "corner codes", "vertex refs",      "points",    "edge steps", "flips"};
constexpr int section_count(uint32_t version) {
  return version == 1 ? kFlips : kSections;
}
using Sections = std::array<std::string, kSections>;

[[noreturn]] void malformed(const std::string& element, int64_t index, const std::string& msg,
                            InputErrorKind kind = InputErrorKind::ParseError) {
  throw InputError(kind, "delta frame", "", element, index, msg);
}

// Bounds-checked reading of one section.
struct Stream {
  const unsigned char* p;
  const unsigned char* end;
  const char* name;
  uint64_t varint() {
    uint64_t v = 0;
    for (int shift = 0; shift < 64; shift += 7) {
      if (p == end) malformed(name, -1, "ends inside a number", InputErrorKind::Truncated);
      const unsigned char b = *p++;
      v |= uint64_t(b & 0x7F) << shift;
      if (!(b & 0x80)) return v;
    }
    malformed(name, -1, "a number longer than 64 bits");
  }
  const unsigned char* take(size_t n) {
    if (size_t(end - p) < n) malformed(name, -1, "ends early", InputErrorKind::Truncated);
    const unsigned char* r = p;
    p += n;
    return r;
  }
  uint32_t u32() { return get_u32(reinterpret_cast<const char*>(take(4))); }
  void done() const {
    if (p != end) malformed(name, -1, "trailing bytes");
  }
};
using Streams = std::array<Stream, kSections>;

// A zigzagged number a reader adds to something: at most 2^40 in size (none of ours is near),
// so that no sum can overflow.
int64_t small(Stream& s, const char* what) {
  const uint64_t z = s.varint();
  if (z > (uint64_t(1) << 41)) malformed(what, -1, "a number out of range");
  return unzigzag(z);
}

void put_f64(std::string& s, double d) {
  const uint64_t v = std::bit_cast<uint64_t>(d);
  put_u32(s, uint32_t(v));
  put_u32(s, uint32_t(v >> 32));
}

double get_f64(const unsigned char* p) {
  const char* c = reinterpret_cast<const char*>(p);
  return std::bit_cast<double>(uint64_t(get_u32(c)) | uint64_t(get_u32(c + 4)) << 32);
}

// Ascending ids (or vertex numbers) as a count and gaps: every gap after the first at least 1.
void put_gaps(std::string& s, const std::vector<uint32_t>& ids) {
  put_varint(s, ids.size());
  uint32_t prev = 0;
  for (uint32_t id : ids) put_varint(s, id - prev), prev = id;
}

// Reads one gap of an ascending list of numbers below `limit`, the i-th, onto `at`.
void next_gap(Stream& s, const char* element, uint64_t i, uint64_t limit, uint64_t& at,
              const char* out_of_range = "out of range") {
  const uint64_t d = s.varint();
  if (i > 0 && d == 0) malformed(element, int64_t(i), "not ascending");
  if (d >= limit - at) malformed(element, int64_t(i), out_of_range);
  at += d;
}

double orient_d(const double* a, const double* b, const double* c) {
  return (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
}

std::array<double, 4> clip_of(const Mat4& m, const float* p) {
  std::array<double, 4> r{};
  for (int i = 0; i < 4; ++i) r[i] = m[i] * p[0] + m[4 + i] * p[1] + m[8 + i] * p[2] + m[12 + i];
  return r;
}

}  // namespace

std::array<double, 12> clip_rows(const Mat4& m) {
  return {m[0], m[4], m[8], m[12], m[1], m[5], m[9], m[13], m[3], m[7], m[11], m[15]};
}

bool project_to_grid(const std::array<double, 12>& r, uint32_t width, uint32_t height,
                     uint32_t quantum, const float* p, int32_t* out) {
  const double x = p[0], y = p[1], z = p[2];
  const double cx = r[0] * x + r[1] * y + r[2] * z + r[3];
  const double cy = r[4] * x + r[5] * y + r[6] * z + r[7];
  const double cw = r[8] * x + r[9] * y + r[10] * z + r[11];
  if (!(cw > 0)) return false;
  const double gx = (cx / cw + 1.0) * 0.5 * double(width) * double(quantum);
  const double gy = (1.0 - cy / cw) * 0.5 * double(height) * double(quantum);
  if (!(std::abs(gx) < 1e9 && std::abs(gy) < 1e9)) return false;
  out[0] = int32_t(std::llround(gx));
  out[1] = int32_t(std::llround(gy));
  return true;
}

namespace {

int64_t div_round(int64_t q, int64_t l) {  // floor(q / l + 1/2), l > 0, exactly
  const int64_t n = 2 * q + l, d = 2 * l;
  return n >= 0 ? n / d : -((-n + d - 1) / d);
}

// ---------------------------------------------------------------------------------------------
// Header (DELTA.md, "Header")

struct Header {
  uint32_t version = kMaxVersion, width = 0, height = 0;
  bool keyframe = false, held = false, sources = false;
  uint32_t quantum = 0, index = 0, base = kNoBase, mesh_count = 0, compression = 0;
  uint32_t payload_bytes = 0, whole_count = 0;
};

std::string encode_header(const Header& h) {
  std::string out(kMagic, 4);
  const uint32_t flags =
      (h.keyframe ? kKeyframe : 0u) | (h.held ? kHeld : 0u) | (h.sources ? kSources : 0u);
  for (uint32_t v : {h.version, h.width, h.height, flags, h.quantum, h.index, h.base, h.mesh_count,
                     h.compression, h.payload_bytes, h.whole_count})
    put_u32(out, v);
  return out;
}

// Checks what the header alone can tell; the base against the decoder's state is the caller's.
Header decode_header(const std::string& bytes) {
  if (bytes.size() < kHeaderBytes)
    malformed("header", -1, std::to_string(bytes.size()) + " bytes, the header alone is 48",
              InputErrorKind::Truncated);
  if (std::memcmp(bytes.data(), kMagic, 4) != 0) malformed("header", -1, "magic is not VMDF");
  uint32_t w[11];
  for (int i = 0; i < 11; ++i) w[i] = get_u32(bytes.data() + 4 + 4 * i);
  Header h;
  const uint32_t flags = w[3];
  h.version = w[0], h.width = w[1], h.height = w[2], h.quantum = w[4], h.index = w[5];
  h.base = w[6], h.mesh_count = w[7], h.compression = w[8], h.payload_bytes = w[9];
  h.whole_count = w[10];
  if (h.version < 1 || h.version > kMaxVersion)
    malformed("header", -1, "version " + std::to_string(h.version) + " (this reader knows 1, 2)");
  const uint32_t known = h.version == 1 ? kKeyframe : kKeyframe | kHeld | kSources;
  if (flags & ~known) malformed("header", -1, "unknown flag bits");
  h.keyframe = flags & kKeyframe;
  h.held = flags & kHeld;
  h.sources = flags & kSources;
  if (h.held && !h.keyframe) malformed("header", -1, "held without keyframe");
  if (h.sources && flags != kSources) malformed("header", -1, "sources with other flags");
  if (h.width < 1 || h.height < 1 || h.width > 65536 || h.height > 65536)
    malformed("header", -1, "viewport out of range");
  if (h.quantum < kMinQuantum || h.quantum > kMaxQuantum)
    malformed("header", -1, "quantum out of " + quantum_range_text());
  if (h.compression != uint32_t(Compression::Zstd) &&
      h.compression != uint32_t(Compression::Deflate))
    malformed("header", -1, "unknown compression");
  if (h.mesh_count == 0 || h.mesh_count > (1u << 24))
    malformed("header", -1, "mesh count out of range");
  return h;
}

// ---------------------------------------------------------------------------------------------
// Camera (DELTA.md, "Payload": projection, eye, target, the rows x, y and w)

void encode_camera(std::string& payload, const Camera& camera, const std::array<double, 12>& rows) {
  payload += char(camera.projection == Camera::Projection::Orthographic);
  payload.append(3, '\0');
  for (const Vec3* v : {&camera.eye, &camera.target})
    for (double d : *v) put_f64(payload, d);
  for (double d : rows) put_f64(payload, d);
}

void decode_camera(Stream& head, DeltaFrame& f) {
  const unsigned char* cam = head.take(kCameraBytes);
  auto f64 = [&](int i) { return get_f64(cam + 4 + 8 * i); };
  if (cam[0] > 1) malformed("camera", -1, "unknown projection");
  f.camera.projection = cam[0] ? Camera::Projection::Orthographic : Camera::Projection::Perspective;
  for (int k = 0; k < 3; ++k) {
    f.camera.eye[k] = f64(k);
    f.camera.target[k] = f64(3 + k);
  }
  for (int k = 0; k < 12; ++k) f.rows[k] = f64(6 + k);
  f.camera.width = f.width;
  f.camera.height = f.height;
  for (int k = 0; k < 6; ++k)
    if (!std::isfinite(f64(k))) malformed("camera", -1, "eye or target not finite");
  for (double r : f.rows)
    if (!std::isfinite(r)) malformed("camera", -1, "projection not finite");
}

// ---------------------------------------------------------------------------------------------
// Mesh table (keyframes only): per mesh its first global id, counts and colour

void encode_mesh_table(std::string& payload, const Scene& scene,
                       const std::vector<uint64_t>& base) {
  for (size_t m = 0; m < scene.meshes.size(); ++m) {
    put_u32(payload, uint32_t(base[m]));
    put_u32(payload, scene.meshes[m].source_triangles);
    put_u32(payload, uint32_t(scene.meshes[m].vertex_count()));
    for (int c = 0; c < 3; ++c) put_u32(payload, std::bit_cast<uint32_t>(scene.meshes[m].color[c]));
  }
}

void decode_mesh_table(Stream& head, uint32_t mesh_count, DeltaDecoder::State& s) {
  uint64_t tris = 0, verts = 0;
  for (uint32_t m = 0; m < mesh_count; ++m) {
    const char* e = reinterpret_cast<const char*>(head.take(kMeshEntryBytes));
    const uint32_t first = get_u32(e);
    if (first != tris) malformed("mesh", m, "first ids do not follow the counts");
    s.base.push_back(first);
    s.vertex_base.push_back(verts);
    tris += get_u32(e + 4);
    verts += get_u32(e + 8);
    std::array<float, 3> rgb;
    for (int c = 0; c < 3; ++c) {
      rgb[c] = std::bit_cast<float>(get_u32(e + 12 + 4 * c));
      if (!(rgb[c] >= 0 && rgb[c] <= 1)) malformed("mesh", m, "color not in [0, 1]");
    }
    s.colors.push_back(rgb);
    if (tris > kMaxSourceCount || verts > kMaxSourceCount)
      malformed("mesh", m, "more than 2^26 triangles or vertices");
  }
  s.vertex.assign(3 * verts, std::numeric_limits<float>::quiet_NaN());
  s.tri.assign(3 * tris, ~0u);
}

// ---------------------------------------------------------------------------------------------
// Section sizes, then the sections

void encode_sections(std::string& payload, const Sections& sections, int count) {
  for (int i = 0; i < count; ++i) put_u32(payload, uint32_t(sections[i].size()));
  for (int i = 0; i < count; ++i) payload += sections[i];
}

// The sections a version has; the others are empty.
Streams decode_sections(Stream& head, int count) {
  uint32_t size[kSections] = {};
  for (int i = 0; i < count; ++i) size[i] = head.u32();
  Streams sec;
  for (int i = 0; i < kSections; ++i) {
    const unsigned char* p = head.take(size[i]);
    sec[i] = Stream{p, p + size[i], kSectionName[i]};
  }
  head.done();
  return sec;
}

// ---------------------------------------------------------------------------------------------
// The scene's global numbering, as the encoder sees it: triangles by global id (mesh first
// ids, then face ids), vertices by global number (a mesh's vertices follow the meshes before it).

struct Numbering {
  const Scene& scene;
  const std::vector<uint64_t>& base;         // per mesh: first global id
  const std::vector<uint64_t>& vertex_base;  // per mesh: first global vertex number
  uint32_t mesh_of(uint32_t id) const {
    return uint32_t(std::upper_bound(base.begin(), base.end(), uint64_t(id)) - base.begin() - 1);
  }
  const float* position(uint32_t gv) const {
    const uint32_t m = uint32_t(std::upper_bound(vertex_base.begin(), vertex_base.end(), gv) -
                                vertex_base.begin() - 1);
    return &scene.meshes[m].positions[3 * size_t(gv - vertex_base[m])];
  }
  // Global vertex numbers of a source triangle by global id (face id -> index via face_ids).
  void vertices(uint32_t id, uint32_t* gv) const {
    const uint32_t m = mesh_of(id);
    const Mesh& mesh = scene.meshes[m];
    const uint32_t face = uint32_t(id - base[m]);
    const auto it = std::lower_bound(mesh.face_ids.begin(), mesh.face_ids.end(), face);
    const size_t t = size_t(it - mesh.face_ids.begin());
    for (int k = 0; k < 3; ++k) gv[k] = uint32_t(vertex_base[m] + mesh.indices[3 * t + k]);
  }
};

// Sources the client lacks, as the frame comes to need them: the triangles drawn whole or owning
// a polygon, and the vertices the polygons name.
struct NewSources {
  const Numbering& num;
  std::vector<uint8_t>& known_tri;
  std::vector<uint8_t>& known_vertex;
  std::vector<uint32_t> tris, verts;
  void need_vertex(uint32_t gv) {
    if (!known_vertex[gv]) known_vertex[gv] = 1, verts.push_back(gv);
  }
  void need_triangle(uint32_t id) {
    if (known_tri[id]) return;
    known_tri[id] = 1;
    tris.push_back(id);
    uint32_t gv[3];
    num.vertices(id, gv);
    for (uint32_t v : gv) need_vertex(v);
  }
};

// ---------------------------------------------------------------------------------------------
// New vertices: global number gaps, then float32 x, y, z each

void encode_vertices(Sections& s, const std::vector<uint32_t>& verts, const Numbering& num) {
  put_gaps(s[kVertices], verts);
  for (uint32_t gv : verts)
    for (int c = 0; c < 3; ++c)
      put_u32(s[kPositions], std::bit_cast<uint32_t>(num.position(gv)[c]));
}

void decode_vertices(Streams& sec, DeltaDecoder::State& st) {
  Stream& s = sec[kVertices];
  const uint64_t n_verts = st.vertices();
  const uint64_t n = s.varint();
  if (n > n_verts) malformed("vertices", -1, "more than the scene has");
  uint64_t gv = 0;
  for (uint64_t i = 0; i < n; ++i) {
    next_gap(s, "vertices", i, n_verts, gv);
    const char* p = reinterpret_cast<const char*>(sec[kPositions].take(12));
    for (int c = 0; c < 3; ++c) {
      const float v = std::bit_cast<float>(get_u32(p + 4 * c));
      if (!std::isfinite(v)) malformed("vertices", int64_t(i), "not finite");
      st.vertex[3 * gv + c] = v;
    }
  }
  s.done();
  sec[kPositions].done();
}

// ---------------------------------------------------------------------------------------------
// New triangles: id gaps, each with its vertex numbers as differences from the one before

void encode_triangles(Sections& s, const std::vector<uint32_t>& tris, const Numbering& num) {
  std::string& out = s[kTriangles];
  put_varint(out, tris.size());
  uint32_t prev = 0;
  int64_t last_v = 0;
  for (uint32_t id : tris) {
    put_varint(out, id - prev);
    prev = id;
    uint32_t gv[3];
    num.vertices(id, gv);
    for (uint32_t v : gv) put_varint(out, zigzag(int64_t(v) - last_v)), last_v = v;
  }
}

void decode_triangles(Stream& s, DeltaDecoder::State& st) {
  const uint64_t n_tris = st.triangles(), n_verts = st.vertices();
  const uint64_t n = s.varint();
  if (n > n_tris) malformed("triangles", -1, "more than the scene has");
  uint64_t id = 0;
  int64_t last_v = 0;
  for (uint64_t i = 0; i < n; ++i) {
    next_gap(s, "triangles", i, n_tris, id);
    for (int k = 0; k < 3; ++k) {
      last_v += small(s, "triangles");
      if (last_v < 0 || uint64_t(last_v) >= n_verts || std::isnan(st.vertex[3 * last_v]))
        malformed("triangles", int64_t(i), "names a vertex not sent");
      st.tri[3 * id + k] = uint32_t(last_v);
    }
  }
  s.done();
}

// ---------------------------------------------------------------------------------------------
// Flags: a bit per entry of a list, entry 8i + b in bit b of byte i, ceil(n / 8) bytes.

template <class Bit>
void put_flags(std::string& out, size_t n, Bit&& bit) {
  for (size_t i = 0; i < n; i += 8) {
    uint8_t bits = 0;
    for (size_t b = 0; b < 8 && i + b < n; ++b)
      if (bit(i + b)) bits |= uint8_t(1u << b);
    out += char(bits);
  }
}

template <class Set>
void read_flags(Stream& s, size_t n, Set&& set) {
  for (size_t i = 0; i < n; i += 8) {
    const uint8_t bits = *s.take(1);
    for (size_t b = 0; b < 8; ++b)
      if (bits >> b & 1) {
        if (i + b >= n) malformed(s.name, -1, "a flag past the list's end");
        set(i + b);
      }
  }
}

bool has(const std::vector<uint32_t>& sorted, uint32_t id) {
  return std::binary_search(sorted.begin(), sorted.end(), id);
}

// ---------------------------------------------------------------------------------------------
// Facing flips (version 2): the known triangles whose facing on the grid changed between the
// base frame and this one (turned over, became degenerate, or gained or lost a vertex behind the
// camera). Both sides compute them from the same numbers, project_to_grid and the exact
// orientation; they are the candidates of the flips section's bits and of the polygons'.

struct View {
  std::array<double, 12> rows{};
  uint32_t width = 0, height = 0, quantum = 0;
};

// A triangle's facing: 0 degenerate on the grid, 1 positive, 2 negative, 3 a vertex that does
// not project (behind the camera, or far outside). Each vertex is projected once.
class Facing {
 public:
  Facing(const View& v, size_t n_verts) : v_(v), grid_(2 * n_verts), state_(n_verts, 0) {}
  template <class Position>
  uint8_t of(const uint32_t* gv, Position&& position) {
    const int32_t* p[3];
    for (int k = 0; k < 3; ++k) {
      uint8_t& st = state_[gv[k]];
      int32_t* g = &grid_[2 * size_t(gv[k])];
      if (!st)
        st = project_to_grid(v_.rows, v_.width, v_.height, v_.quantum, position(gv[k]), g) ? 1 : 2;
      if (st == 2) return 3;
      p[k] = g;
    }
    const int64_t o = orient2(p[0], p[1], p[2]);
    return o > 0 ? 1 : o < 0 ? 2 : 0;
  }

 private:
  const View& v_;
  std::vector<int32_t> grid_;
  std::vector<uint8_t> state_;
};

// Ascending ids of the known triangles whose facing differs between `before` and `now`.
// known(id): the client holds triangle id; vertices(id, gv): its global vertex numbers;
// position(gv): its float32 x, y, z.
template <class Known, class Vertices, class Position>
std::vector<uint32_t> facing_flips(size_t n_tris, size_t n_verts, const View& before,
                                   const View& now, Known&& known, Vertices&& vertices,
                                   Position&& position) {
  Facing a(before, n_verts), b(now, n_verts);
  std::vector<uint32_t> flips;
  for (size_t id = 0; id < n_tris; ++id) {
    if (!known(uint32_t(id))) continue;
    uint32_t gv[3];
    vertices(uint32_t(id), gv);
    if (a.of(gv, position) != b.of(gv, position)) flips.push_back(uint32_t(id));
  }
  return flips;
}

// ---------------------------------------------------------------------------------------------
// The whole set's change: the ids that leave it, the ids that enter it. Version 2 first gives a
// bit to each flip (flips section): for those in the base whole set, 1 when it leaves, then for
// the others, 1 when it enters; the lists hold only the changes the flips do not cover.

struct WholeChange {
  std::vector<uint32_t> removed, added;  // all of them, ascending
};

WholeChange encode_whole_change(Sections& s, const std::vector<uint32_t>& before,
                                const std::vector<uint32_t>& after,
                                const std::vector<uint32_t>& flips) {
  WholeChange c;
  std::set_difference(before.begin(), before.end(), after.begin(), after.end(),
                      std::back_inserter(c.removed));
  std::set_difference(after.begin(), after.end(), before.begin(), before.end(),
                      std::back_inserter(c.added));
  std::vector<uint32_t> in, out, removed, added;
  for (uint32_t id : flips) (has(before, id) ? in : out).push_back(id);
  put_flags(s[kFlips], in.size(), [&](size_t i) { return !has(after, in[i]); });
  put_flags(s[kFlips], out.size(), [&](size_t i) { return has(after, out[i]); });
  std::set_difference(c.removed.begin(), c.removed.end(), flips.begin(), flips.end(),
                      std::back_inserter(removed));
  std::set_difference(c.added.begin(), c.added.end(), flips.begin(), flips.end(),
                      std::back_inserter(added));
  put_gaps(s[kRemoved], removed);
  put_gaps(s[kAdded], added);
  return c;
}

std::vector<uint32_t> decode_ids(Stream& s, uint64_t n_tris) {
  std::vector<uint32_t> ids;
  const uint64_t n = s.varint();
  if (n > n_tris) malformed(s.name, -1, "more ids than the scene has");
  uint64_t id = 0;
  for (uint64_t i = 0; i < n; ++i) {
    next_gap(s, s.name, i, n_tris, id);
    ids.push_back(uint32_t(id));
  }
  s.done();
  return ids;
}

// Reads the flips' bits and the lists into both lists, ascending.
std::vector<uint32_t> merged(std::vector<uint32_t> flagged, Stream& list, uint64_t n_tris,
                             const std::vector<uint32_t>& flips) {
  const std::vector<uint32_t> rest = decode_ids(list, n_tris);
  for (uint32_t id : rest)
    if (has(flips, id)) malformed(list.name, id, "an id the flips cover");
  std::vector<uint32_t> all;
  std::merge(flagged.begin(), flagged.end(), rest.begin(), rest.end(), std::back_inserter(all));
  return all;
}

// Applies the change to st.whole and checks it against the header's whole_count.
WholeChange decode_whole_change(Streams& sec, DeltaDecoder::State& st, uint32_t whole_count,
                                const std::vector<uint32_t>& flips) {
  std::vector<uint32_t> in, out, flag_removed, flag_added;
  for (uint32_t id : flips) (has(st.whole, id) ? in : out).push_back(id);
  read_flags(sec[kFlips], in.size(), [&](size_t i) { flag_removed.push_back(in[i]); });
  read_flags(sec[kFlips], out.size(), [&](size_t i) { flag_added.push_back(out[i]); });
  sec[kFlips].done();
  WholeChange c;
  c.removed = merged(std::move(flag_removed), sec[kRemoved], st.triangles(), flips);
  c.added = merged(std::move(flag_added), sec[kAdded], st.triangles(), flips);
  std::vector<uint32_t> kept;
  std::set_difference(st.whole.begin(), st.whole.end(), c.removed.begin(), c.removed.end(),
                      std::back_inserter(kept));
  if (kept.size() + c.removed.size() != st.whole.size())
    malformed("removed", -1, "an id that was not drawn whole");
  st.whole.clear();
  std::set_union(kept.begin(), kept.end(), c.added.begin(), c.added.end(),
                 std::back_inserter(st.whole));
  if (st.whole.size() != kept.size() + c.added.size())
    malformed("added", -1, "an id that is drawn whole already");
  if (st.whole.size() != whole_count) malformed("added", -1, "the whole set has the wrong size");
  return c;
}

// ---------------------------------------------------------------------------------------------
// Polygons section: the polygons' sources, flagged a bit each on three lists both sides know
// (the removed ids; the previous frame's sources; version 2, the flips in neither list nor
// whole now), then the others as gaps, and per source its polygon count - 1. (The corner
// counts, corner count - 3 per polygon, follow in the same section, written with the corners.)

struct Poly {
  uint32_t id;
  uint32_t p;  // polygon index
};

// The flips that may own polygons and are in neither earlier list.
std::vector<uint32_t> flip_candidates(const std::vector<uint32_t>& flips,
                                      const std::vector<uint32_t>& whole,
                                      const std::vector<uint32_t>& removed,
                                      const std::vector<uint32_t>& previous) {
  std::vector<uint32_t> c;
  for (uint32_t id : flips)
    if (!has(whole, id) && !has(removed, id) && !has(previous, id)) c.push_back(id);
  return c;
}

// `partial` sorted by id (stably); returns it in the order written.
std::vector<Poly> encode_polygon_sources(Sections& s,
                                         const std::array<const std::vector<uint32_t>*, 3>& lists,
                                         const std::vector<uint32_t>& partial_ids,
                                         const std::vector<Poly>& partial) {
  std::string& out = s[kPolygons];
  std::vector<uint32_t> order;  // sources in the order written
  for (const std::vector<uint32_t>* list : lists)
    put_flags(out, list->size(), [&](size_t i) {
      const bool mine = has(partial_ids, (*list)[i]);
      if (mine) order.push_back((*list)[i]);
      return mine;
    });
  std::vector<uint32_t> flagged = order, rest;
  std::sort(flagged.begin(), flagged.end());
  std::set_difference(partial_ids.begin(), partial_ids.end(), flagged.begin(), flagged.end(),
                      std::back_inserter(rest));
  put_gaps(out, rest);
  order.insert(order.end(), rest.begin(), rest.end());

  std::vector<Poly> ordered;
  ordered.reserve(partial.size());
  for (uint32_t id : order) {
    auto lo = std::lower_bound(partial.begin(), partial.end(), id,
                               [](const Poly& q, uint32_t v) { return q.id < v; });
    auto hi = lo;
    while (hi != partial.end() && hi->id == id) ++hi;
    put_varint(out, uint64_t(hi - lo) - 1);
    ordered.insert(ordered.end(), lo, hi);
  }
  return ordered;
}

// Returns each polygon's source, in order; st.partial becomes this frame's sorted sources.
std::vector<uint32_t> decode_polygon_sources(
    Stream& s, const std::array<const std::vector<uint32_t>*, 3>& lists, DeltaDecoder::State& st) {
  const uint64_t n_tris = st.triangles();
  std::vector<uint32_t> order;
  for (const std::vector<uint32_t>* list : lists)
    read_flags(s, list->size(), [&](size_t i) { order.push_back((*list)[i]); });
  const uint64_t nr = s.varint();
  if (nr > n_tris) malformed("polygons", -1, "more sources than the scene has");
  uint64_t id = 0;
  for (uint64_t i = 0; i < nr; ++i) {
    next_gap(s, "polygons", i, n_tris, id, "source out of range");
    order.push_back(uint32_t(id));
  }
  std::vector<uint32_t> all = order;
  std::sort(all.begin(), all.end());
  if (std::adjacent_find(all.begin(), all.end()) != all.end())
    malformed("polygons", -1, "a source named twice");
  st.partial = std::move(all);

  std::vector<uint32_t> poly_source;
  for (uint32_t src_id : order) {
    const uint64_t more = s.varint();
    if (more >= (1u << 20) || poly_source.size() + more + 1 > (1ull << 28))
      malformed("polygons", -1, "too many");
    poly_source.insert(poly_source.end(), more + 1, src_id);
  }
  return poly_source;
}

// ---------------------------------------------------------------------------------------------
// The encoder's view of one frame: where the source vertices land on the pipeline's grid (to
// recognise the map's corners) and on the client's (to place edge points), and which triangles
// are drawn whole.

class FrameGeometry {
 public:
  FrameGeometry(const Numbering& num, const ConformedPolygons& P, const ScreenTriangles& screen,
                const Camera& camera, const Mat4& vp, const std::array<double, 12>& rows,
                uint32_t quantum, size_t vertex_count)
      : num_(num),
        P_(P),
        camera_(camera),
        rows_(rows),
        quantum_(quantum),
        gs_(screen.grid_scale),
        at_corner_(3 * screen.size()) {
    const size_t nv = vertex_count;
    vproj_.resize(2 * nv), vstate_.assign(nv, 0);
    cproj_.resize(2 * nv), cstate_.assign(nv, 0);
    match_screen_corners(screen, vp);
  }

  double grid_scale() const { return gs_; }
  uint32_t quantum() const { return quantum_; }
  const ConformedPolygons& polygons() const { return P_; }

  // A source vertex on the pipeline's grid, when a screen triangle had it in front.
  bool in_front(uint32_t gv) const { return vstate_[gv] == 1; }
  int64_t grid(uint32_t gv, int c) const { return vproj_[2 * size_t(gv) + c]; }

  // The global vertex number of a polygon vertex, when it is a projected source vertex.
  uint32_t vertex_number(uint32_t v) const {
    const double x = P_.xy[2 * v] * gs_, y = P_.xy[2 * v + 1] * gs_;
    if (x != std::floor(x) || y != std::floor(y)) return ~0u;
    const uint32_t* gv = at_corner_.find(grid_key(int64_t(x), int64_t(y)));
    return gv ? *gv : ~0u;
  }
  // The corner k of a source triangle (its global vertex numbers) a polygon vertex is at, or
  // -1: by position, so that a mesh whose corners are separate vertices at one place (OBJ
  // faces with their own normals) still finds its own corners.
  int own_corner(uint32_t v, const uint32_t* own) const {
    const double x = P_.xy[2 * v] * gs_, y = P_.xy[2 * v + 1] * gs_;
    for (int k = 0; k < 3; ++k)
      if (in_front(own[k]) && double(grid(own[k], 0)) == x && double(grid(own[k], 1)) == y)
        return k;
    return -1;
  }
  // Version 2: each polygon vertex's source vertex, one for all the polygons that have it (the
  // first polygon in order whose own corner is there, else the screen corner's), so that every
  // side of an edge names the same vertex and the client projects it once. A mesh whose faces
  // have their own vertices at one place (the Cornell box's walls) has several there; its copies
  // can be 3D points a hair apart that the pipeline's grid snaps together (match_screen_corners'
  // 2 grid units) and the client's does not: a whole triangle drawn from its own copy beside a
  // polygon naming another left hairline cracks (the Cornell box's delta frames: 48.6 dB
  // against the exact raster where its compact frames had 59).
  void canonicalize(const PlanarMap& map) {
    canon_.assign(P_.xy.size() / 2, ~0u);
    for (size_t p = 0; p < P_.size(); ++p) {
      uint32_t own[3];
      num_.vertices(
          uint32_t(detail::global_triangle_id(map, num_.scene, num_.base, P_.fragment[p])), own);
      for (uint32_t i = P_.off[p]; i < P_.off[p + 1]; ++i)
        if (canon_[P_.v[i]] == ~0u) {
          const int k = own_corner(P_.v[i], own);
          if (k >= 0) canon_[P_.v[i]] = own[k];
        }
    }
    for (size_t v = 0; v < canon_.size(); ++v)
      if (canon_[v] == ~0u) canon_[v] = vertex_number(uint32_t(v));
  }
  // The source vertex polygon vertex v names (~0u: none, a point), and which own corner that is
  // (-1: another source vertex): version 2, the canonical one; version 1, the own corner by
  // position, else the screen corner's.
  uint32_t source_vertex(uint32_t v, const uint32_t* own, int& own_k) const {
    if (canon_.empty()) {
      own_k = own_corner(v, own);
      return own_k >= 0 ? own[own_k] : vertex_number(v);
    }
    const uint32_t gv = canon_[v];
    own_k = gv == ~0u ? -1 : gv == own[0] ? 0 : gv == own[1] ? 1 : gv == own[2] ? 2 : -1;
    return gv;
  }

  // The client's projection of a source vertex (its grid, the frame's rows), computed here the
  // same way: edge points are steps along the client's own edges.
  bool client_point(uint32_t gv, int32_t* out) {
    if (!cstate_[gv])
      cstate_[gv] = project_to_grid(rows_, camera_.width, camera_.height, quantum_,
                                    num_.position(gv), &cproj_[2 * size_t(gv)])
                        ? 1
                        : 2;
    out[0] = cproj_[2 * size_t(gv)], out[1] = cproj_[2 * size_t(gv) + 1];
    return cstate_[gv] == 1;
  }

  // The map's polygons split into the sources drawn whole (sorted, unique) and the polygons of
  // the others (stably sorted by source): a source is whole when one unclipped screen triangle
  // draws it, as one polygon whose three corners are its own projected vertices.
  void split(const PlanarMap& map, const ScreenTriangles& screen, std::vector<uint32_t>& whole,
             std::vector<Poly>& partial) const;

 private:
  static uint64_t grid_key(int64_t x, int64_t y) {
    return uint64_t(uint32_t(x)) << 32 | uint32_t(y);
  }
  // Each source vertex projected once (on the pipeline's grid), when a screen triangle needs it;
  // screen corners that are projected source vertices: grid point -> global vertex number.
  void match_screen_corners(const ScreenTriangles& screen, const Mat4& vp);

  const Numbering& num_;
  const ConformedPolygons& P_;
  const Camera& camera_;
  const std::array<double, 12>& rows_;
  const uint32_t quantum_;
  const double gs_;
  FlatMap at_corner_;
  std::vector<int64_t> vproj_;
  std::vector<uint8_t> vstate_;  // 1: in front, 2: behind
  std::vector<int32_t> cproj_;
  std::vector<uint8_t> cstate_;
  std::vector<uint32_t> canon_;  // version 2: per polygon vertex, its source vertex (canonicalize)
};

void FrameGeometry::match_screen_corners(const ScreenTriangles& screen, const Mat4& vp) {
  for (size_t t = 0; t < screen.size(); ++t) {
    const Mesh& m = num_.scene.meshes[screen.mesh[t]];
    const uint64_t vbase = num_.vertex_base[screen.mesh[t]];
    int64_t proj[3][2];
    bool front[3];
    for (int k = 0; k < 3; ++k) {
      const uint32_t vi = m.indices[3 * size_t(screen.triangle[t]) + k];
      const size_t gv = vbase + vi;
      if (!vstate_[gv]) {
        const std::array<double, 4> c = clip_of(vp, &m.positions[3 * size_t(vi)]);
        vstate_[gv] = c[3] > 0 ? 1 : 2;
        if (c[3] > 0) {
          vproj_[2 * gv] = std::llround((c[0] / c[3] + 1.0) * 0.5 * camera_.width * gs_);
          vproj_[2 * gv + 1] = std::llround((1.0 - c[1] / c[3]) * 0.5 * camera_.height * gs_);
        }
      }
      front[k] = vstate_[gv] == 1;
      proj[k][0] = vproj_[2 * gv];
      proj[k][1] = vproj_[2 * gv + 1];
    }
    for (int j = 0; j < 3; ++j) {
      const int32_t sx = screen.xy[6 * t + 2 * j], sy = screen.xy[6 * t + 2 * j + 1];
      for (int k = 0; k < 3; ++k)
        if (front[k] && std::abs(proj[k][0] - sx) <= 2 && std::abs(proj[k][1] - sy) <= 2) {
          const uint32_t gv = uint32_t(vbase + m.indices[3 * size_t(screen.triangle[t]) + k]);
          at_corner_.emplace(grid_key(sx, sy), gv);
          break;
        }
    }
  }
}

void FrameGeometry::split(const PlanarMap& map, const ScreenTriangles& screen,
                          std::vector<uint32_t>& whole, std::vector<Poly>& partial) const {
  // Screen triangles per source, and the polygons per source.
  FlatMap screen_of(screen.size());
  std::vector<uint8_t> several(screen.size(), 0);
  for (size_t t = 0; t < screen.size(); ++t) {
    auto [first, fresh] =
        screen_of.emplace(uint64_t(screen.mesh[t]) << 32 | screen.triangle[t], uint32_t(t));
    if (!fresh) several[first] = 1;
  }
  FlatMap count_at(P_.size());
  std::vector<uint32_t> counts;
  for (size_t p = 0; p < P_.size(); ++p) {
    const uint32_t f = P_.fragment[p];
    auto [slot, fresh] =
        count_at.emplace(uint64_t(map.mesh[f]) << 32 | map.triangle[f], uint32_t(counts.size()));
    if (fresh) counts.push_back(0);
    ++counts[slot];
  }
  for (size_t p = 0; p < P_.size(); ++p) {
    const uint32_t f = P_.fragment[p];
    const uint32_t id = uint32_t(detail::global_triangle_id(map, num_.scene, num_.base, f));
    const uint64_t key = uint64_t(map.mesh[f]) << 32 | map.triangle[f];
    const uint32_t* st = screen_of.find(key);
    bool is_whole = st && !several[*st] && counts[*count_at.find(key)] == 1 &&
                    P_.off[p + 1] - P_.off[p] == 3 && P_.original[p] == 3;
    if (is_whole) {
      uint32_t own[3];
      num_.vertices(id, own);
      int seen = 0;
      for (uint32_t i = P_.off[p]; i < P_.off[p + 1] && is_whole; ++i) {
        int k;
        source_vertex(P_.v[i], own, k);
        is_whole = k >= 0 && !(seen >> k & 1);
        seen |= k >= 0 ? 1 << k : 0;
      }
    }
    if (is_whole)
      whole.push_back(id);
    else
      partial.push_back({id, uint32_t(p)});
  }
  std::sort(whole.begin(), whole.end());
  whole.erase(std::unique(whole.begin(), whole.end()), whole.end());
  std::stable_sort(partial.begin(), partial.end(),
                   [](const Poly& a, const Poly& b) { return a.id < b.id; });
}

// ---------------------------------------------------------------------------------------------
// Corner codes (DELTA.md, "Corner codes"), with the vertex refs, points and edge steps they
// draw on; the encoder's and the decoder's walk over a polygon's corners, twins.

// Version 2: the points made on each source edge in this frame (codes 6-8), the first
// kEdgeRefs of each, under the edge's unordered pair of global vertex numbers.
class EdgePoints {
 public:
  explicit EdgePoints(size_t expected) : slot_(expected) {}
  void add(uint32_t a, uint32_t b, uint32_t point) {
    const auto [slot, fresh] = slot_.emplace(key(a, b), uint32_t(pts_.size()));
    if (fresh) pts_.push_back({0, 0, 0});
    std::array<uint32_t, 3>& e = pts_[slot];
    if (e[0] < kEdgeRefs) e[1 + e[0]++] = point;
  }
  // The i-th point made on edge (a, b), or ~0u.
  uint32_t at(uint32_t a, uint32_t b, uint64_t i) const {
    const uint32_t* slot = slot_.find(key(a, b));
    return slot && i < pts_[*slot][0] ? pts_[*slot][1 + i] : ~0u;
  }

 private:
  static uint64_t key(uint32_t a, uint32_t b) {
    return uint64_t(std::min(a, b)) << 32 | std::max(a, b);
  }
  FlatMap slot_;
  std::vector<std::array<uint32_t, 3>> pts_;  // count, then the points
};

// The encoder's side, for the frame's polygons in order: each polygon's corner count (into the
// polygons section) and a code per corner.
class CornerEncoder {
 public:
  CornerEncoder(FrameGeometry& g, NewSources& sources, Sections& s, size_t all_corners,
                uint32_t version)
      : g_(g),
        P_(g.polygons()),
        sources_(sources),
        s_(s),
        version_(version),
        point_of_(P_.xy.size() / 2, ~0u),
        nv_all_(sources.known_vertex.size()),
        twin_of_(all_corners),
        edges_(all_corners) {}

  void polygon(const Poly& q);

  uint64_t corners = 0, edge_refs = 0;
  uint32_t points = 0, edge_points = 0;

 private:
  // The corner to start the fan at: the one with the fewest collinear corners on its two edges.
  size_t fan_start() const;
  // One corner: the code for it and what the code draws on.
  void corner(uint32_t v, const uint32_t* own);
  // A point on own edge k of the exact map, as a step along the client's edge, when that lands
  // within two grid steps of (x, y): returns the code's k, or -1.
  int edge_point(uint32_t v, const uint32_t* own, int64_t& x, int64_t& y);
  // The code of a point made earlier in the frame: by an own edge (version 2), else by recency.
  uint64_t point_code(uint32_t point, const uint32_t* own);
  void after_point(uint32_t v) {
    ring_id_.push_back(nv_all_ + point_of_[v]);
    point_before_ = true;
    px_ = point_xy_[2 * point_of_[v]], py_ = point_xy_[2 * point_of_[v] + 1];
  }

  FrameGeometry& g_;
  const ConformedPolygons& P_;
  NewSources& sources_;
  Sections& s_;
  const uint32_t version_;
  std::vector<uint32_t> point_of_;  // polygon vertex -> new point index
  std::vector<int64_t> point_xy_;   // per new point: where the client puts it
  int64_t last_x_ = 0, last_y_ = 0;
  // Corner identities: a source vertex is its global number, a point NV + its index. For each
  // corner X of an earlier polygon, the corner before it: twin_of[X] predicts the corner after X.
  const uint64_t nv_all_;
  FlatMap twin_of_;
  EdgePoints edges_;
  std::vector<uint32_t> ring_, ring_id_;
  bool point_before_ = false;  // the last corner was a point: predict from it
  int64_t px_ = 0, py_ = 0;
};

void CornerEncoder::polygon(const Poly& q) {
  sources_.need_triangle(q.id);
  uint32_t own[3];
  sources_.num.vertices(q.id, own);
  ring_.assign(P_.v.begin() + P_.off[q.p], P_.v.begin() + P_.off[q.p + 1]);
  const size_t n = ring_.size();
  std::rotate(ring_.begin(), ring_.begin() + fan_start(), ring_.end());
  put_varint(s_[kPolygons], n - 3);
  corners += n;
  point_before_ = false;
  px_ = py_ = 0;
  ring_id_.clear();
  for (uint32_t v : ring_) corner(v, own);
  for (size_t k = 0; k < n; ++k) twin_of_.emplace(ring_id_[(k + 1) % n], uint32_t(ring_id_[k]));
}

size_t CornerEncoder::fan_start() const {
  const size_t n = ring_.size();
  std::vector<uint8_t> flat(n);
  for (size_t i = 0; i < n; ++i) {
    const double* a = &P_.xy[2 * ring_[(i + n - 1) % n]];
    const double* b = &P_.xy[2 * ring_[i]];
    const double* c = &P_.xy[2 * ring_[(i + 1) % n]];
    flat[i] = !(orient_d(a, b, c) > kOnEdge * std::hypot(c[0] - a[0], c[1] - a[1]));
  }
  size_t start = 0, best = SIZE_MAX;
  for (size_t i = 0; i < n; ++i) {
    if (flat[i]) continue;
    size_t chain = 0;
    for (size_t k = 1; k < n && flat[(i + k) % n]; ++k) ++chain;
    for (size_t k = 1; k < n && flat[(i + n - k) % n]; ++k) ++chain;
    if (chain < best) best = chain, start = i;
  }
  return start;
}

void CornerEncoder::corner(uint32_t v, const uint32_t* own) {
  int own_k;
  const uint32_t gv = g_.source_vertex(v, own, own_k);
  const uint64_t id = gv != ~0u ? gv : point_of_[v] != ~0u ? nv_all_ + point_of_[v] : ~0ull;
  if (!ring_id_.empty() && id != ~0ull) {
    const uint32_t* twin = twin_of_.find(ring_id_.back());
    if (twin && *twin == id) {
      put_varint(s_[kCodes], kTwin);
      ring_id_.push_back(id);
      point_before_ = gv == ~0u;
      if (point_before_) px_ = point_xy_[2 * point_of_[v]], py_ = point_xy_[2 * point_of_[v] + 1];
      return;
    }
  }
  if (gv != ~0u) {
    ring_id_.push_back(gv);
    if (own_k >= 0) {
      put_varint(s_[kCodes], kOwnCorner + own_k);
    } else {
      put_varint(s_[kCodes], kVertexRef);
      put_varint(s_[kRefs], zigzag(int64_t(gv) - int64_t(own[0])));
      sources_.need_vertex(gv);
    }
    point_before_ = false;
    return;
  }
  if (point_of_[v] != ~0u) {
    put_varint(s_[kCodes], point_code(point_of_[v], own));
    after_point(v);
    return;
  }
  int64_t x = std::llround(P_.xy[2 * v] * g_.quantum());
  int64_t y = std::llround(P_.xy[2 * v + 1] * g_.quantum());
  if (const int k = edge_point(v, own, x, y); k >= 0) {
    put_varint(s_[kCodes], kEdgePoint + k);
    if (version_ >= 2) edges_.add(own[k], own[(k + 1) % 3], points);
    ++edge_points;
  } else {
    put_varint(s_[kCodes], kNewPoint);
    const int64_t bx = point_before_ ? px_ : last_x_, by = point_before_ ? py_ : last_y_;
    put_varint(s_[kPoints], zigzag(x - bx));
    put_varint(s_[kPoints], zigzag(y - by));
    last_x_ = x, last_y_ = y;
  }
  point_xy_.push_back(x);
  point_xy_.push_back(y);
  point_of_[v] = points++;
  after_point(v);
}

uint64_t CornerEncoder::point_code(uint32_t point, const uint32_t* own) {
  if (version_ >= 2)
    for (uint64_t i = 0; i < kEdgeRefs; ++i)
      for (int k = 0; k < 3; ++k)
        if (edges_.at(own[k], own[(k + 1) % 3], i) == point) {
          ++edge_refs;
          return kEdgeRef + 3 * i + uint64_t(k);
        }
  return (version_ >= 2 ? kPointRef2 : kPointRef) + (points - 1 - point);
}

int CornerEncoder::edge_point(uint32_t v, const uint32_t* own, int64_t& x, int64_t& y) {
  const double gs = g_.grid_scale();
  const uint32_t quantum = g_.quantum();
  for (int k = 0; k < 3; ++k) {
    const uint32_t a = own[k], b = own[(k + 1) % 3];
    if (!g_.in_front(a) || !g_.in_front(b)) continue;
    const double ax = g_.grid(a, 0) / gs, ay = g_.grid(a, 1) / gs;
    const double ex = g_.grid(b, 0) / gs - ax, ey = g_.grid(b, 1) / gs - ay;
    const double len = std::hypot(ex, ey), qx = P_.xy[2 * v] - ax, qy = P_.xy[2 * v + 1] - ay;
    if (!(len > 0) || std::abs(ex * qy - ey * qx) > kOnEdge * len) continue;
    int32_t A[2], B[2];
    if (!g_.client_point(a, A) || !g_.client_point(b, B)) continue;
    const int64_t dx = int64_t(B[0]) - A[0], dy = int64_t(B[1]) - A[1];
    const int64_t steps = std::max(std::abs(dx), std::abs(dy));
    if (steps < 2) continue;
    const double t = ((P_.xy[2 * v] * quantum - A[0]) * double(dx) +
                      (P_.xy[2 * v + 1] * quantum - A[1]) * double(dy)) /
                     (double(dx) * dx + double(dy) * dy);
    const int64_t step = std::clamp<int64_t>(std::llround(t * steps), 1, steps - 1);
    const int64_t ex2 = A[0] + div_round(step * dx, steps);
    const int64_t ey2 = A[1] + div_round(step * dy, steps);
    if (std::abs(ex2 - x) > 2 || std::abs(ey2 - y) > 2) continue;
    put_varint(s_[kSteps], uint64_t(step));
    x = ex2, y = ey2;
    return k;
  }
  return -1;
}

// The decoder's side: projects the source vertices the frame names, collects the output
// vertices (projected source vertices first use a slot each, then the new points) and draws.
class FrameDrawer {
 public:
  FrameDrawer(DeltaFrame& f, const DeltaDecoder::State& st)
      : f_(f),
        st_(st),
        proj_(2 * st.vertices()),
        projected_(st.vertices(), 0),
        slot_of_(st.vertices(), ~0u) {}

  // A source vertex, checked to be sent and in front of the camera.
  uint32_t vertex_at(uint32_t gv, const char* what, int64_t index) {
    if (gv >= st_.vertices() || std::isnan(st_.vertex[3 * size_t(gv)]))
      malformed(what, index, "names a vertex not sent");
    if (!projected_[gv])
      projected_[gv] = project_to_grid(f_.rows, f_.width, f_.height, f_.quantum,
                                       &st_.vertex[3 * size_t(gv)], &proj_[2 * size_t(gv)])
                           ? 1
                           : 2;
    if (projected_[gv] == 2) malformed(what, index, "a vertex behind the camera");
    return gv;
  }
  const int32_t* grid(uint32_t gv) const { return &proj_[2 * size_t(gv)]; }
  uint32_t out_vertex(uint32_t gv) {
    if (slot_of_[gv] == ~0u) {
      slot_of_[gv] = uint32_t(f_.xy.size() / 2);
      f_.xy.push_back(proj_[2 * size_t(gv)]);
      f_.xy.push_back(proj_[2 * size_t(gv) + 1]);
    }
    return slot_of_[gv];
  }
  uint32_t out_point(int64_t x, int64_t y) {
    f_.xy.push_back(int32_t(x));
    f_.xy.push_back(int32_t(y));
    return uint32_t(f_.xy.size() / 2 - 1);
  }
  const int32_t* at(uint32_t slot) const { return &f_.xy[2 * size_t(slot)]; }

  // Triangle (a, b, c) of source id when it has positive area (either orientation: swapped).
  void emit(uint32_t a, uint32_t b, uint32_t c, uint32_t id, bool either) {
    int64_t o = orient2(&f_.xy[2 * a], &f_.xy[2 * b], &f_.xy[2 * c]);
    if (o < 0 && either) std::swap(b, c), o = -o;
    if (o <= 0) return;
    f_.indices.insert(f_.indices.end(), {a, b, c});
    f_.source.push_back(id);
    f_.mesh.push_back(st_.mesh_of(id));
    if (id != shade_id_) shade_id_ = id, shade_ = shade_of(id);
    f_.shade.push_back(shade_);
  }

  void draw_whole() {
    for (uint32_t id : st_.whole) {
      if (st_.tri[3 * size_t(id)] == ~0u) malformed("added", id, "a triangle not sent");
      uint32_t s[3];
      for (int k = 0; k < 3; ++k)
        s[k] = out_vertex(vertex_at(st_.tri[3 * size_t(id) + k], "whole", id));
      emit(s[0], s[1], s[2], id, true);  // either orientation: back faces are drawn too
    }
  }

 private:
  // The Lambert factor of --fill shade (DELTA.md), from the triangle's world vertices.
  uint8_t shade_of(uint32_t id) const {
    double p[3][3];
    for (int k = 0; k < 3; ++k)
      for (int c = 0; c < 3; ++c) p[k][c] = st_.vertex[3 * size_t(st_.tri[3 * size_t(id) + k]) + c];
    double e1[3], e2[3], n[3], l[3];
    for (int c = 0; c < 3; ++c) {
      e1[c] = p[1][c] - p[0][c], e2[c] = p[2][c] - p[0][c];
      l[c] = f_.camera.eye[c] - f_.camera.target[c];  // the headlight (DELTA.md "Shade")
    }
    n[0] = e1[1] * e2[2] - e1[2] * e2[1];
    n[1] = e1[2] * e2[0] - e1[0] * e2[2];
    n[2] = e1[0] * e2[1] - e1[1] * e2[0];
    double ndl = std::abs(n[0] * l[0] + n[1] * l[1] + n[2] * l[2]) /
                 (std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]) *
                  std::sqrt(l[0] * l[0] + l[1] * l[1] + l[2] * l[2]));
    if (!std::isfinite(ndl)) ndl = 1.0;
    return uint8_t(std::lround((0.12 + 0.88 * std::min(ndl, 1.0)) * 255.0));
  }

  DeltaFrame& f_;
  const DeltaDecoder::State& st_;
  std::vector<int32_t> proj_;
  std::vector<uint8_t> projected_;  // 1: done, 2: behind the camera
  std::vector<uint32_t> slot_of_;
  uint32_t shade_id_ = ~0u;
  uint8_t shade_ = 0;
};

// The decoder's side of the corner codes, polygon by polygon, each fanned from its first corner.
class CornerDecoder {
 public:
  CornerDecoder(FrameDrawer& d, const DeltaDecoder::State& st, Streams& sec, const DeltaFrame& f,
                uint32_t version)
      : d_(d),
        st_(st),
        s_(sec[kPolygons]),
        codes_(sec[kCodes]),
        refs_(sec[kRefs]),
        pts_(sec[kPoints]),
        steps_(sec[kSteps]),
        version_(version),
        n_verts_(st.vertices()),
        twin_of_(sec[kCodes].end - sec[kCodes].p),  // a corner takes at least a byte of codes
        edges_(sec[kCodes].end - sec[kCodes].p),
        xmax_(int64_t(f.width) * f.quantum),
        ymax_(int64_t(f.height) * f.quantum) {}

  void polygon(uint64_t i, uint32_t id);
  void done() {
    s_.done();
    codes_.done();
    refs_.done();
    pts_.done();
    steps_.done();
  }

 private:
  void corner(uint64_t i, uint32_t id);
  void source_corner(uint32_t gv, uint64_t i) {
    ring_.push_back(d_.out_vertex(d_.vertex_at(gv, "polygons", int64_t(i))));
    ring_id_.push_back(gv);
    point_before_ = false;
  }
  // A new point: its coordinates (code 4) or its step along own edge k (codes 6-8).
  void new_point(uint64_t code, uint64_t i, uint32_t id);
  void point_corner(uint32_t point) {
    ring_.push_back(point_slot_[point]);
    ring_id_.push_back(n_verts_ + point);
    point_before_ = true;
  }

  FrameDrawer& d_;
  const DeltaDecoder::State& st_;
  Stream &s_, &codes_, &refs_, &pts_, &steps_;
  const uint32_t version_;
  const uint64_t n_verts_;
  FlatMap twin_of_;
  EdgePoints edges_;
  const int64_t xmax_, ymax_;
  std::vector<uint32_t> point_slot_;
  int64_t lx_ = 0, ly_ = 0;
  std::vector<uint32_t> ring_;
  std::vector<uint64_t> ring_id_;
  bool point_before_ = false;
};

void CornerDecoder::polygon(uint64_t i, uint32_t id) {
  if (st_.tri[3 * size_t(id)] == ~0u) malformed("polygons", int64_t(i), "unknown source");
  const uint64_t extra = s_.varint();
  if (extra > 1u << 20) malformed("polygons", int64_t(i), "too many corners");
  const uint64_t corners = extra + 3;
  ring_.clear();
  ring_id_.clear();
  point_before_ = false;
  for (uint64_t k = 0; k < corners; ++k) corner(i, id);
  for (size_t k = 0; k < ring_id_.size(); ++k)
    twin_of_.emplace(ring_id_[(k + 1) % ring_id_.size()], uint32_t(ring_id_[k]));
  for (size_t k = 1; k + 1 < ring_.size(); ++k)
    d_.emit(ring_[0], ring_[k], ring_[k + 1], id, false);
}

void CornerDecoder::corner(uint64_t i, uint32_t id) {
  const uint64_t code = codes_.varint();
  if (code < kVertexRef) {
    source_corner(st_.tri[3 * size_t(id) + code], i);
  } else if (code == kVertexRef) {
    const int64_t gv = int64_t(st_.tri[3 * size_t(id)]) + small(refs_, "vertex refs");
    if (gv < 0 || uint64_t(gv) >= n_verts_) malformed("polygons", int64_t(i), "vertex ref");
    source_corner(uint32_t(gv), i);
  } else if (code == kTwin) {
    const uint32_t* twin = ring_id_.empty() ? nullptr : twin_of_.find(ring_id_.back());
    if (!twin) malformed("polygons", int64_t(i), "a twin corner without an earlier edge");
    const uint32_t t = *twin;
    if (t < n_verts_) {
      source_corner(t, i);
    } else {
      ring_.push_back(point_slot_[t - n_verts_]);
      ring_id_.push_back(t);
      point_before_ = true;
    }
  } else if (code == kNewPoint || (code >= kEdgePoint && code < kEdgePoint + 3)) {
    new_point(code, i, id);
  } else if (version_ >= 2 && code < kPointRef2) {  // a point made on own edge k's source edge
    const uint32_t* tv = &st_.tri[3 * size_t(id)];
    const int k = int((code - kEdgeRef) % 3);
    const uint32_t point = edges_.at(tv[k], tv[(k + 1) % 3], (code - kEdgeRef) / 3);
    if (point == ~0u) malformed("polygons", int64_t(i), "no such point on the edge");
    point_corner(point);
  } else {
    const uint64_t j = code - (version_ >= 2 ? kPointRef2 : kPointRef);
    if (j >= point_slot_.size()) malformed("polygons", int64_t(i), "point ref out of range");
    point_corner(uint32_t(point_slot_.size() - 1 - j));
  }
}

void CornerDecoder::new_point(uint64_t code, uint64_t i, uint32_t id) {
  int64_t x, y;
  if (code == kNewPoint) {
    const int32_t* prev = point_before_ ? d_.at(ring_.back()) : nullptr;
    const int64_t bx = prev ? prev[0] : lx_, by = prev ? prev[1] : ly_;
    x = lx_ = bx + small(pts_, "points");
    y = ly_ = by + small(pts_, "points");
  } else {  // a step along own edge k, as the client projects its ends
    const int k = int(code - kEdgePoint);
    const int32_t* A = d_.grid(d_.vertex_at(st_.tri[3 * size_t(id) + k], "polygons", int64_t(i)));
    const int32_t* B =
        d_.grid(d_.vertex_at(st_.tri[3 * size_t(id) + (k + 1) % 3], "polygons", int64_t(i)));
    const int64_t dx = int64_t(B[0]) - A[0], dy = int64_t(B[1]) - A[1];
    const int64_t n_steps = std::max(std::abs(dx), std::abs(dy));
    const uint64_t step = steps_.varint();
    if (n_steps < 2 || step < 1 || step >= uint64_t(n_steps))
      malformed("edge steps", int64_t(point_slot_.size()), "out of the edge");
    x = A[0] + div_round(int64_t(step) * dx, n_steps);
    y = A[1] + div_round(int64_t(step) * dy, n_steps);
    if (version_ >= 2)
      edges_.add(st_.tri[3 * size_t(id) + k], st_.tri[3 * size_t(id) + (k + 1) % 3],
                 uint32_t(point_slot_.size()));
  }
  if (x < 0 || y < 0 || x > xmax_ || y > ymax_)
    malformed("points", int64_t(point_slot_.size()), "outside the viewport");
  point_slot_.push_back(d_.out_point(x, y));
  ring_.push_back(point_slot_.back());
  ring_id_.push_back(n_verts_ + point_slot_.size() - 1);
  point_before_ = true;
}

}  // namespace

uint32_t DeltaDecoder::State::mesh_of(uint32_t id) const {
  return uint32_t(std::upper_bound(base.begin(), base.end(), uint64_t(id)) - base.begin() - 1);
}

// ---------------------------------------------------------------------------------------------
// Encoder

namespace {

// One frame's map as every candidate codes it: the sources drawn whole (sorted), the polygons of
// the others (sorted by source), the geometry, the camera and its view.
struct FrameParts {
  const Numbering& num;
  FrameGeometry& geometry;
  const std::vector<uint32_t>& whole;
  const std::vector<Poly>& partial;
  const Camera& camera;
  const View& view;
};

// The frame coded against the client's state `m` (a fresh one for a keyframe), which it leaves
// as the client's state after the frame.
std::string code_frame(const FrameParts& in, const DeltaOptions& o, const Scene& scene,
                       const std::vector<uint64_t>& base, DeltaClientState& m, bool key,
                       uint32_t index, DeltaStats& st) {
  std::vector<uint32_t> flips;
  if (o.version >= 2 && !key)
    flips = facing_flips(
        m.known_tri.size(), m.known_vertex.size(), View{m.rows, m.width, m.height, o.quantum},
        in.view, [&](uint32_t id) { return m.known_tri[id] != 0; },
        [&](uint32_t id, uint32_t* gv) { in.num.vertices(id, gv); },
        [&](uint32_t gv) { return in.num.position(gv); });
  NewSources sources{in.num, m.known_tri, m.known_vertex, {}, {}};
  for (uint32_t id : in.whole) sources.need_triangle(id);

  // The sections, in the order the polygons need them written.
  Sections s;
  const WholeChange change = encode_whole_change(s, m.whole, in.whole, flips);
  std::vector<uint32_t> partial_ids;
  for (const Poly& q : in.partial) partial_ids.push_back(q.id);
  partial_ids.erase(std::unique(partial_ids.begin(), partial_ids.end()), partial_ids.end());
  const std::vector<uint32_t> candidates =
      flip_candidates(flips, in.whole, change.removed, m.partial);
  const std::vector<Poly> ordered = encode_polygon_sources(
      s, {&change.removed, &m.partial, &candidates}, partial_ids, in.partial);
  const ConformedPolygons& P = in.geometry.polygons();
  size_t all_corners = 0;
  for (const Poly& q : ordered) all_corners += P.off[q.p + 1] - P.off[q.p];
  CornerEncoder corners(in.geometry, sources, s, all_corners, o.version);
  for (const Poly& q : ordered) corners.polygon(q);
  std::sort(sources.verts.begin(), sources.verts.end());
  std::sort(sources.tris.begin(), sources.tris.end());
  encode_vertices(s, sources.verts, in.num);
  encode_triangles(s, sources.tris, in.num);

  std::string payload;
  encode_camera(payload, in.camera, in.view.rows);
  if (key) encode_mesh_table(payload, scene, base);
  encode_sections(payload, s, section_count(o.version));
  Header h;
  h.version = o.version, h.width = in.view.width, h.height = in.view.height, h.keyframe = key;
  h.held = key && o.version >= 2 && o.client_holds_scene, h.quantum = o.quantum;
  h.index = index, h.base = key ? kNoBase : m.index;
  h.mesh_count = uint32_t(scene.meshes.size()), h.compression = uint32_t(o.compression);
  h.payload_bytes = uint32_t(payload.size()), h.whole_count = uint32_t(in.whole.size());
  std::string out = encode_header(h);
  out += frame_io::compress(payload, o.compression, o.level, "delta writer");

  st = {};
  st.coding = key ? DeltaCoding::Keyframe : DeltaCoding::Delta;
  st.keyframe = key;
  st.delta_bytes = out.size();
  st.whole = in.whole.size();
  st.added = change.added.size();
  st.removed = change.removed.size();
  st.flips = flips.size();
  st.partial = ordered.size();
  st.partial_corners = corners.corners;
  st.points = corners.points;
  st.edge_points = corners.edge_points;
  st.edge_refs = corners.edge_refs;
  st.new_triangles = sources.tris.size();
  st.new_vertices = sources.verts.size();
  st.source_bytes = s[kVertices].size() + s[kPositions].size() + s[kTriangles].size();
  st.set_bytes = s[kRemoved].size() + s[kAdded].size() + s[kFlips].size();
  st.polygon_bytes = s[kPolygons].size() + s[kCodes].size() + s[kRefs].size() + s[kPoints].size() +
                     s[kSteps].size();

  m.valid = true;
  m.index = index;
  m.whole = in.whole;
  m.partial = std::move(partial_ids);
  m.rows = in.view.rows;
  m.width = in.view.width, m.height = in.view.height;
  return out;
}

}  // namespace

DeltaEncoder::DeltaEncoder(const Scene& scene, const DeltaOptions& options)
    : scene_(scene), options_(options) {
  if (options.quantum < 1 || options.quantum > 256)
    throw InputError(InputErrorKind::BadCamera, "delta writer", "", "quantum", -1,
                     "grid steps per pixel must be 1 ... 256");
  if (options.version < 1 || options.version > kMaxVersion)
    throw InputError(InputErrorKind::BadCamera, "delta writer", "", "version", -1,
                     "delta format version must be 1 or 2");
  base_ = scene.triangle_id_base();
  uint64_t tris = 0, verts = 0;
  for (const Mesh& m : scene.meshes) {
    vertex_base_.push_back(verts);
    verts += m.vertex_count();
    tris += m.source_triangles;
  }
  if (tris > kMaxSourceCount || verts > kMaxSourceCount)
    throw InputError(InputErrorKind::TooLarge, "delta writer", "", "scene", -1,
                     "more than 2^26 triangles or vertices");
  client_.known_tri.assign(tris, 0);
  client_.known_vertex.assign(verts, options.client_holds_scene);
  if (options.client_holds_scene)  // the scene's faces (ids past a mesh's faces are no triangle)
    for (size_t m = 0; m < scene.meshes.size(); ++m)
      for (uint32_t face : scene.meshes[m].face_ids) client_.known_tri[base_[m] + face] = 1;
  held_tri_ = client_.known_tri;
}

size_t DeltaEncoder::state_bytes() const {
  return 2 * (client_.known_tri.size() + client_.known_vertex.size()) +
         4 * (client_.whole.capacity() + client_.partial.capacity());
}

std::string DeltaEncoder::encode(const PlanarMap& map, const ScreenTriangles& screen,
                                 const Camera& camera_in, DeltaStats* stats) {
  detail::check_map(map, scene_, "delta writer");
  if (screen.grid_scale == 0 || screen.size() * 6 != screen.xy.size())
    throw std::invalid_argument("delta writer: the render's screen triangles are needed");
  if (options_.keyframe_every && frame_ % options_.keyframe_every == 0) keyframe_ = true;
  if (keyframe_) client_.valid = false;
  Camera camera = camera_in;  // near and far as the render fitted them (they do not move x, y)
  if (!(camera.near_plane > 0 && camera.far_plane > camera.near_plane))
    fit_near_far(camera, scene_);
  const Mat4 vp = camera.view_projection();
  const View view{clip_rows(vp), map.width, map.height, options_.quantum};

  // Which sources are drawn whole, which own polygons.
  const Numbering num{scene_, base_, vertex_base_};
  ConformedPolygons P = conform_polygons(map, options_.quantum);
  if (options_.version >= 2) {  // the pieces of a source that hidden silhouettes cut, as one
    std::vector<uint64_t> source(P.size());
    for (size_t p = 0; p < P.size(); ++p)
      source[p] = uint64_t(map.mesh[P.fragment[p]]) << 32 | map.triangle[P.fragment[p]];
    merge_source_polygons(P, source);
  }
  FrameGeometry geometry(num, P, screen, camera, vp, view.rows, options_.quantum,
                         client_.known_vertex.size());
  if (options_.version >= 2) geometry.canonicalize(map);
  std::vector<uint32_t> whole;
  std::vector<Poly> partial;
  geometry.split(map, screen, whole, partial);
  const FrameParts in{num, geometry, whole, partial, camera, view};
  const uint32_t index = frame_++;

  // The candidates: against the client's state; a keyframe (when there is none, or when the
  // client holds the scene and the state has drifted); version 2, the compact frame. The
  // smallest goes out; a delta candidate wins ties.
  DeltaStats st, kst;
  DeltaClientState next;
  std::string best;
  if (client_.valid) {
    next = client_;
    best = code_frame(in, options_, scene_, base_, next, false, index, st);
  }
  std::string compact;
  if (options_.version >= 2) {
    CompactOptions co;
    co.quantum = options_.quantum;
    co.shade = true;
    co.compression = options_.compression;  // at the coder's default level (DeltaOptions::level)
    compact = write_compact(map, scene_, camera, co);
  }
  const bool beaten = best.empty() || (!compact.empty() && best.size() > compact.size());
  if (beaten && (best.empty() || options_.client_holds_scene)) {
    DeltaClientState fresh;
    fresh.known_tri = held_tri_;
    fresh.known_vertex.assign(client_.known_vertex.size(), options_.client_holds_scene);
    std::string key = code_frame(in, options_, scene_, base_, fresh, true, index, kst);
    if (best.empty() || key.size() < best.size()) {
      best = std::move(key);
      next = std::move(fresh);
      st = kst;
    }
  }
  if (!compact.empty() && best.size() > compact.size()) {
    if (stats) {
      *stats = {};
      stats->coding = DeltaCoding::Compact;
      stats->delta_bytes = best.size();
      stats->compact_bytes = compact.size();
    }
    return compact;  // the client's state stays as it was
  }
  st.compact_bytes = compact.size();
  if (stats) *stats = st;
  client_ = std::move(next);
  keyframe_ = false;
  return best;
}

std::string encode_delta_sources(const Scene& scene, Compression compression, int level) {
  const std::vector<uint64_t> base = scene.triangle_id_base();
  std::vector<uint64_t> vertex_base;
  uint64_t verts = 0;
  for (const Mesh& m : scene.meshes) vertex_base.push_back(verts), verts += m.vertex_count();
  const Numbering num{scene, base, vertex_base};
  std::vector<uint32_t> all_verts(verts), all_tris;
  for (uint64_t v = 0; v < verts; ++v) all_verts[v] = uint32_t(v);
  for (size_t m = 0; m < scene.meshes.size(); ++m)
    for (uint32_t face : scene.meshes[m].face_ids) all_tris.push_back(uint32_t(base[m] + face));
  if (all_tris.size() > kMaxSourceCount || verts > kMaxSourceCount)
    throw InputError(InputErrorKind::TooLarge, "delta writer", "", "scene", -1,
                     "more than 2^26 triangles or vertices");
  Sections s;
  encode_vertices(s, all_verts, num);
  encode_triangles(s, all_tris, num);
  std::string payload;
  encode_mesh_table(payload, scene, base);
  encode_sections(payload, s, kTriangles + 1);
  Header h;
  h.width = h.height = h.quantum = 1;
  h.sources = true;
  h.mesh_count = uint32_t(scene.meshes.size()), h.compression = uint32_t(compression);
  h.payload_bytes = uint32_t(payload.size());
  return encode_header(h) + frame_io::compress(payload, compression, level, "delta writer");
}

// ---------------------------------------------------------------------------------------------
// Decoder

namespace {

// A compact frame in a delta stream (version 2): drawn as it is; it needs no state and leaves
// the decoder's alone.
DeltaFrame compact_frame(const std::string& bytes) {
  CompactFrame c = read_compact(bytes);
  if (!(c.flags & kCompactShade)) malformed("compact frame", -1, "no shades");
  DeltaFrame f;
  f.width = c.width, f.height = c.height, f.quantum = c.quantum, f.compact = true, f.version = 2;
  f.camera.width = c.width, f.camera.height = c.height;
  f.xy = std::move(c.xy);
  f.indices = std::move(c.indices);
  f.source = std::move(c.source);
  f.mesh = std::move(c.mesh);
  f.shade = std::move(c.shade);
  f.mesh_color = std::move(c.mesh_color);
  return f;
}

std::string payload_of(const std::string& bytes, const Header& h) {
  const size_t zbytes = bytes.size() - kHeaderBytes;
  if (h.payload_bytes > kMaxRatio * zbytes + 4096)
    malformed("header", -1, "payload size out of proportion");
  std::string payload(h.payload_bytes, '\0');
  if (const std::string why = frame_io::decompress(bytes.data() + kHeaderBytes, zbytes,
                                                   Compression(h.compression), payload);
      !why.empty())
    malformed("payload", -1, why);
  return payload;
}

Stream head_of(const std::string& payload, const char* first) {
  const auto* p = reinterpret_cast<const unsigned char*>(payload.data());
  return Stream{p, p + payload.size(), first};
}

}  // namespace

void DeltaDecoder::hold_scene(const std::string& bytes) {
  const Header h = decode_header(bytes);
  if (!h.sources) malformed("header", -1, "not a sources message");
  const std::string payload = payload_of(bytes, h);
  Stream head = head_of(payload, "mesh");
  auto st = std::make_shared<State>();
  decode_mesh_table(head, h.mesh_count, *st);
  Streams sec = decode_sections(head, kTriangles + 1);
  decode_vertices(sec, *st);
  decode_triangles(sec[kTriangles], *st);
  for (size_t v = 0; v < st->vertices(); ++v)
    if (std::isnan(st->vertex[3 * v])) malformed("vertices", int64_t(v), "not sent");
  held_ = std::move(st);
}

DeltaFrame DeltaDecoder::decode(const std::string& bytes) {
  if (bytes.size() >= 4 && std::memcmp(bytes.data(), "VMCF", 4) == 0) return compact_frame(bytes);
  const Header h = decode_header(bytes);
  if (h.sources) malformed("header", -1, "a sources message (DeltaDecoder::hold_scene takes it)");
  if (h.held && !held_)
    throw DeltaOutOfSync(InputErrorKind::BadScene, "delta frame", "", "header", -1,
                         "a keyframe of the held scene, and this decoder holds none");
  if (!h.keyframe && !have_state_)
    throw DeltaOutOfSync(InputErrorKind::BadScene, "delta frame", "", "header", -1,
                         "no keyframe decoded yet: ask for one");
  if (!h.keyframe && (h.base != last_ || h.mesh_count != state_.base.size()))
    throw DeltaOutOfSync(InputErrorKind::BadScene, "delta frame", "", "header", -1,
                         "based on frame " + std::to_string(h.base) + ", the last decoded is " +
                             std::to_string(last_) + ": ask for a keyframe");
  const std::string payload = payload_of(bytes, h);

  DeltaFrame f;
  f.width = h.width, f.height = h.height, f.quantum = h.quantum, f.index = h.index;
  f.version = h.version, f.keyframe = h.keyframe;
  Stream head = head_of(payload, "camera");
  decode_camera(head, f);
  // A keyframe starts from nothing, or from the held scene: its mesh table sizes the store (and
  // must be the held one's). Work on a copy so that a malformed frame leaves the state as it was.
  State st = h.keyframe ? (h.held ? *held_ : State{}) : state_;
  if (h.keyframe) {
    State table;
    decode_mesh_table(head, h.mesh_count, table);
    if (h.held && (table.base != st.base || table.vertex_base != st.vertex_base ||
                   table.tri.size() != st.tri.size() || table.colors != st.colors))
      malformed("mesh", -1, "not the held scene's meshes");
    if (!h.held) st = std::move(table);
  }
  Streams sec = decode_sections(head, section_count(h.version));

  // Version 2: the facing flips since the last frame, on the store before this frame's sources.
  std::vector<uint32_t> flips;
  if (h.version >= 2 && !h.keyframe)
    flips = facing_flips(
        st.triangles(), st.vertices(), View{st.rows, st.width, st.height, st.quantum},
        View{f.rows, f.width, f.height, f.quantum},
        [&](uint32_t id) { return st.tri[3 * size_t(id)] != ~0u; },
        [&](uint32_t id, uint32_t* gv) {
          for (int k = 0; k < 3; ++k) gv[k] = st.tri[3 * size_t(id) + k];
        },
        [&](uint32_t gv) { return &st.vertex[3 * size_t(gv)]; });
  decode_vertices(sec, st);
  decode_triangles(sec[kTriangles], st);
  const WholeChange change = decode_whole_change(sec, st, h.whole_count, flips);
  // Triangles: the whole ones projected here, then the polygons fanned.
  FrameDrawer drawer(f, st);
  drawer.draw_whole();
  const std::vector<uint32_t> previous = st.partial;
  const std::vector<uint32_t> candidates =
      flip_candidates(flips, st.whole, change.removed, previous);
  const std::vector<uint32_t> poly_source =
      decode_polygon_sources(sec[kPolygons], {&change.removed, &previous, &candidates}, st);
  CornerDecoder corners(drawer, st, sec, f, h.version);
  for (uint64_t i = 0; i < poly_source.size(); ++i) corners.polygon(i, poly_source[i]);
  corners.done();

  st.rows = f.rows;
  st.width = f.width, st.height = f.height, st.quantum = f.quantum;
  state_ = std::move(st);
  f.mesh_color = state_.colors;
  last_ = h.index;
  have_state_ = true;
  return f;
}

}  // namespace vismap
