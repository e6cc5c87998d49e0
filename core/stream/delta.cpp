// The delta frame encoding, version 1 (proto/DELTA.md): DeltaEncoder and DeltaDecoder.
#include "core/stream/delta.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>

#include "core/error.h"
#include "core/stream/frame_io.h"
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
constexpr uint32_t kVersion = 1;
constexpr size_t kHeaderBytes = 48;
constexpr uint32_t kKeyframe = 1;
constexpr uint32_t kNoBase = 0xFFFFFFFFu;
constexpr uint64_t kMaxRatio = 256;
constexpr uint64_t kMaxSourceCount = 1ull << 26;  // triangles, and vertices, a client holds
constexpr double kOnEdge = 1e-6;                  // as core/util/conform.cpp
constexpr int kSections = 10;
// Polygon corner codes (proto/DELTA.md, "Polygons").
constexpr uint64_t kOwnCorner = 0;  // 0, 1, 2: corner k of the polygon's own source triangle
constexpr uint64_t kVertexRef = 3;  // a source vertex: zigzag(global number - own corner 0's)
constexpr uint64_t kNewPoint = 4;   // a new point: its coordinates follow in the points section
constexpr uint64_t kTwin = 5;       // the corner that came before this one's predecessor in an
                                    // earlier polygon (the edge they share, walked back)
constexpr uint64_t kEdgePoint = 6;  // 6, 7, 8: a new point on own edge k (vertex k to k + 1),
                                    // at step t of the edge (t follows in the edge steps section)
constexpr uint64_t kPointRef = 9;   // 9 + j: the j-th most recent new point of this frame

void put_f64(std::string& s, double d) {
  const uint64_t v = std::bit_cast<uint64_t>(d);
  put_u32(s, uint32_t(v));
  put_u32(s, uint32_t(v >> 32));
}

// A zigzagged number a reader adds to something: at most 2^40 in size (none of ours is near),
// so that no sum can overflow.
struct Stream;
int64_t small(Stream& s, const char* what);

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
  void done() const {
    if (p != end) malformed(name, -1, "trailing bytes");
  }
};

int64_t small(Stream& s, const char* what) {
  const uint64_t z = s.varint();
  if (z > (uint64_t(1) << 41)) malformed(what, -1, "a number out of range");
  return unzigzag(z);
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

int64_t div_round(int64_t q, int64_t l) {  // floor(q / l + 1/2), l > 0, exactly
  const int64_t n = 2 * q + l, d = 2 * l;
  return n >= 0 ? n / d : -((-n + d - 1) / d);
}

// ---------------------------------------------------------------------------------------------
// Encoder

DeltaEncoder::DeltaEncoder(const Scene& scene, const DeltaOptions& options)
    : scene_(scene), options_(options) {
  if (options.quantum < 1 || options.quantum > 256)
    throw InputError(InputErrorKind::BadCamera, "delta writer", "", "quantum", -1,
                     "grid steps per pixel must be 1 ... 256");
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
  known_tri_.assign(tris, options.client_holds_scene);
  known_vertex_.assign(verts, options.client_holds_scene);
}

size_t DeltaEncoder::state_bytes() const {
  return known_tri_.size() + known_vertex_.size() + 4 * whole_.capacity();
}

std::string DeltaEncoder::encode(const PlanarMap& map, const ScreenTriangles& screen,
                                 const Camera& camera_in, DeltaStats* stats) {
  detail::check_map(map, scene_, "delta writer");
  if (screen.grid_scale == 0 || screen.size() * 6 != screen.xy.size())
    throw std::invalid_argument("delta writer: the render's screen triangles are needed");
  if (options_.keyframe_every && frame_ % options_.keyframe_every == 0) keyframe_ = true;
  const bool key = keyframe_;
  if (key) {
    std::fill(known_tri_.begin(), known_tri_.end(), options_.client_holds_scene);
    std::fill(known_vertex_.begin(), known_vertex_.end(), options_.client_holds_scene);
    whole_.clear();
    partial_.clear();
  }
  Camera camera = camera_in;  // near and far as the render fitted them (they do not move x, y)
  if (!(camera.near_plane > 0 && camera.far_plane > camera.near_plane))
    fit_near_far(camera, scene_);
  const Mat4 vp = camera.view_projection();
  const std::array<double, 12> rows = clip_rows(vp);
  const double gs = screen.grid_scale;

  // Screen corners that are projected source vertices: grid point -> global vertex number.
  // Per screen triangle: its corners' global vertex numbers, or ~0 for a clipping point.
  FlatMap at_corner(3 * screen.size());
  std::vector<uint32_t> corner_gv(3 * screen.size(), ~0u);
  auto grid_key = [](int64_t x, int64_t y) { return uint64_t(uint32_t(x)) << 32 | uint32_t(y); };
  // Each source vertex projected once (on the pipeline's grid), when a screen triangle needs it.
  std::vector<int64_t> vproj(2 * known_vertex_.size());
  std::vector<uint8_t> vstate(known_vertex_.size(), 0);  // 1: in front, 2: behind
  // The client's projection of a source vertex (its grid, the frame's rows), computed here the
  // same way: edge points are steps along the client's own edges.
  std::vector<int32_t> cproj(2 * known_vertex_.size());
  std::vector<uint8_t> cstate(known_vertex_.size(), 0);
  auto client_point = [&](uint32_t gv, int32_t* out) {
    if (!cstate[gv]) {
      const uint32_t m = uint32_t(std::upper_bound(vertex_base_.begin(), vertex_base_.end(), gv) -
                                  vertex_base_.begin() - 1);
      const float* p = &scene_.meshes[m].positions[3 * size_t(gv - vertex_base_[m])];
      cstate[gv] = project_to_grid(rows, camera.width, camera.height, options_.quantum, p,
                                   &cproj[2 * size_t(gv)])
                       ? 1
                       : 2;
    }
    out[0] = cproj[2 * size_t(gv)], out[1] = cproj[2 * size_t(gv) + 1];
    return cstate[gv] == 1;
  };
  for (size_t t = 0; t < screen.size(); ++t) {
    const Mesh& m = scene_.meshes[screen.mesh[t]];
    int64_t proj[3][2];
    bool front[3];
    for (int k = 0; k < 3; ++k) {
      const uint32_t vi = m.indices[3 * size_t(screen.triangle[t]) + k];
      const size_t gv = vertex_base_[screen.mesh[t]] + vi;
      if (!vstate[gv]) {
        const std::array<double, 4> c = clip_of(vp, &m.positions[3 * size_t(vi)]);
        vstate[gv] = c[3] > 0 ? 1 : 2;
        if (c[3] > 0) {
          vproj[2 * gv] = std::llround((c[0] / c[3] + 1.0) * 0.5 * camera.width * gs);
          vproj[2 * gv + 1] = std::llround((1.0 - c[1] / c[3]) * 0.5 * camera.height * gs);
        }
      }
      front[k] = vstate[gv] == 1;
      proj[k][0] = vproj[2 * gv];
      proj[k][1] = vproj[2 * gv + 1];
    }
    for (int j = 0; j < 3; ++j) {
      const int32_t sx = screen.xy[6 * t + 2 * j], sy = screen.xy[6 * t + 2 * j + 1];
      for (int k = 0; k < 3; ++k)
        if (front[k] && std::abs(proj[k][0] - sx) <= 2 && std::abs(proj[k][1] - sy) <= 2) {
          const uint32_t gv = uint32_t(vertex_base_[screen.mesh[t]] +
                                       m.indices[3 * size_t(screen.triangle[t]) + k]);
          corner_gv[3 * t + j] = gv;
          at_corner.emplace(grid_key(sx, sy), gv);
          break;
        }
    }
  }
  // Screen triangles per source; a source drawn by one unclipped screen triangle can be whole.
  FlatMap screen_of(screen.size());
  std::vector<uint8_t> several(screen.size(), 0);
  for (size_t t = 0; t < screen.size(); ++t) {
    auto [first, fresh] =
        screen_of.emplace(uint64_t(screen.mesh[t]) << 32 | screen.triangle[t], uint32_t(t));
    if (!fresh) several[first] = 1;
  }

  const ConformedPolygons P = conform_polygons(map, options_.quantum);
  FlatMap count_at(P.size());
  std::vector<uint32_t> counts;
  for (size_t p = 0; p < P.size(); ++p) {
    const uint32_t f = P.fragment[p];
    auto [slot, fresh] =
        count_at.emplace(uint64_t(map.mesh[f]) << 32 | map.triangle[f], uint32_t(counts.size()));
    if (fresh) counts.push_back(0);
    ++counts[slot];
  }

  // The global vertex number of a polygon vertex, when it is a projected source vertex.
  auto vertex_number = [&](uint32_t v) -> uint32_t {
    const double x = P.xy[2 * v] * gs, y = P.xy[2 * v + 1] * gs;
    if (x != std::floor(x) || y != std::floor(y)) return ~0u;
    const uint32_t* gv = at_corner.find(grid_key(int64_t(x), int64_t(y)));
    return gv ? *gv : ~0u;
  };
  auto mesh_of = [&](uint32_t id) {
    return uint32_t(std::upper_bound(base_.begin(), base_.end(), uint64_t(id)) - base_.begin() - 1);
  };
  // Global vertex numbers of a source triangle by global id (face id -> index via face_ids).
  auto tri_vertices = [&](uint32_t id, uint32_t* gv) {
    const uint32_t m = mesh_of(id);
    const Mesh& mesh = scene_.meshes[m];
    const uint32_t face = uint32_t(id - base_[m]);
    const auto it = std::lower_bound(mesh.face_ids.begin(), mesh.face_ids.end(), face);
    const size_t t = size_t(it - mesh.face_ids.begin());
    for (int k = 0; k < 3; ++k) gv[k] = uint32_t(vertex_base_[m] + mesh.indices[3 * t + k]);
  };
  // The corner k of a source triangle (its global vertex numbers) a polygon vertex is at, or
  // -1: by position, so that a mesh whose corners are separate vertices at one place (OBJ
  // faces with their own normals) still finds its own corners.
  auto own_corner = [&](uint32_t v, const uint32_t* own) {
    const double x = P.xy[2 * v] * gs, y = P.xy[2 * v + 1] * gs;
    for (int k = 0; k < 3; ++k)
      if (vstate[own[k]] == 1 && double(vproj[2 * own[k]]) == x &&
          double(vproj[2 * own[k] + 1]) == y)
        return k;
    return -1;
  };

  struct Poly {
    uint32_t id;
    uint32_t p;  // polygon index
  };
  std::vector<uint32_t> whole;
  std::vector<Poly> partial;
  for (size_t p = 0; p < P.size(); ++p) {
    const uint32_t f = P.fragment[p];
    const uint32_t id = uint32_t(detail::global_triangle_id(map, scene_, base_, f));
    const uint64_t key = uint64_t(map.mesh[f]) << 32 | map.triangle[f];
    const uint32_t* st = screen_of.find(key);
    bool is_whole = st && !several[*st] && counts[*count_at.find(key)] == 1 &&
                    P.off[p + 1] - P.off[p] == 3 && P.original[p] == 3;
    if (is_whole) {
      uint32_t own[3];
      tri_vertices(id, own);
      int seen = 0;
      for (uint32_t i = P.off[p]; i < P.off[p + 1] && is_whole; ++i) {
        const int k = own_corner(P.v[i], own);
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

  // Sources the client lacks: the triangles drawn whole or owning a polygon, and the vertices
  // the polygons name.
  std::string s_vert, s_float, s_tri, s_removed, s_added, s_poly, s_codes, s_refs, s_points,
      s_steps;
  std::vector<uint32_t> new_tris, new_verts;
  auto need_vertex = [&](uint32_t gv) {
    if (!known_vertex_[gv]) known_vertex_[gv] = 1, new_verts.push_back(gv);
  };
  auto need_triangle = [&](uint32_t id) {
    if (known_tri_[id]) return;
    known_tri_[id] = 1;
    new_tris.push_back(id);
    uint32_t gv[3];
    tri_vertices(id, gv);
    for (uint32_t v : gv) need_vertex(v);
  };
  for (uint32_t id : whole) need_triangle(id);

  // The whole set's change.
  std::vector<uint32_t> removed, added;
  std::set_difference(whole_.begin(), whole_.end(), whole.begin(), whole.end(),
                      std::back_inserter(removed));
  std::set_difference(whole.begin(), whole.end(), whole_.begin(), whole_.end(),
                      std::back_inserter(added));
  for (auto [ids, out] : {std::pair{&removed, &s_removed}, std::pair{&added, &s_added}}) {
    put_varint(*out, ids->size());
    uint32_t prev = 0;
    for (uint32_t id : *ids) put_varint(*out, id - prev), prev = id;
  }

  // Polygons, grouped by source: the sources are those of the removed list flagged (a bit
  // each), of the previous frame's partial list flagged, then the others as ascending gaps;
  // per source its polygon count - 1, per polygon its corner count - 3.
  std::vector<uint32_t> partial_ids;
  for (const Poly& q : partial) partial_ids.push_back(q.id);
  partial_ids.erase(std::unique(partial_ids.begin(), partial_ids.end()), partial_ids.end());
  auto is_partial = [&](uint32_t id) {
    return std::binary_search(partial_ids.begin(), partial_ids.end(), id);
  };
  std::vector<uint32_t> order;  // sources in the order written
  for (const std::vector<uint32_t>* list : {&removed, &partial_})
    for (size_t i = 0; i < list->size(); i += 8) {
      uint8_t bits = 0;
      for (size_t b = 0; b < 8 && i + b < list->size(); ++b)
        if (is_partial((*list)[i + b])) bits |= uint8_t(1u << b), order.push_back((*list)[i + b]);
      s_poly += char(bits);
    }
  {
    std::vector<uint32_t> flagged = order, rest;
    std::sort(flagged.begin(), flagged.end());
    std::set_difference(partial_ids.begin(), partial_ids.end(), flagged.begin(), flagged.end(),
                        std::back_inserter(rest));
    put_varint(s_poly, rest.size());
    uint32_t prev = 0;
    for (uint32_t id : rest) put_varint(s_poly, id - prev), prev = id;
    order.insert(order.end(), rest.begin(), rest.end());
  }
  std::vector<Poly> ordered;
  ordered.reserve(partial.size());
  for (uint32_t id : order) {
    auto lo = std::lower_bound(partial.begin(), partial.end(), id,
                               [](const Poly& q, uint32_t v) { return q.id < v; });
    auto hi = lo;
    while (hi != partial.end() && hi->id == id) ++hi;
    put_varint(s_poly, uint64_t(hi - lo) - 1);
    ordered.insert(ordered.end(), lo, hi);
  }
  partial = std::move(ordered);
  std::vector<uint32_t> point_of(P.xy.size() / 2, ~0u);  // polygon vertex -> new point index
  uint32_t points = 0, edge_points = 0;
  std::vector<int64_t> point_xy;  // per new point: where the client puts it
  int64_t last_x = 0, last_y = 0;
  uint64_t corners = 0;
  std::vector<uint32_t> ring, ring_id;
  // Corner identities: a source vertex is its global number, a point NV + its index. For each
  // corner X of an earlier polygon, the corner before it: twin_of[X] predicts the corner after X.
  const uint64_t nv_all = known_vertex_.size();
  size_t all_corners = 0;
  for (const Poly& q : partial) all_corners += P.off[q.p + 1] - P.off[q.p];
  FlatMap twin_of(all_corners);
  for (const Poly& q : partial) {
    need_triangle(q.id);
    uint32_t own[3];
    tri_vertices(q.id, own);
    // Start the fan at the corner with the fewest collinear vertices on its two edges.
    ring.assign(P.v.begin() + P.off[q.p], P.v.begin() + P.off[q.p + 1]);
    const size_t n = ring.size();
    std::vector<uint8_t> flat(n);
    for (size_t i = 0; i < n; ++i) {
      const double* a = &P.xy[2 * ring[(i + n - 1) % n]];
      const double* b = &P.xy[2 * ring[i]];
      const double* c = &P.xy[2 * ring[(i + 1) % n]];
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
    std::rotate(ring.begin(), ring.begin() + start, ring.end());
    put_varint(s_poly, n - 3);
    corners += n;
    bool point_before = false;  // the last corner was a point: predict from it
    int64_t px = 0, py = 0;
    ring_id.clear();
    for (uint32_t v : ring) {
      const int own_k = own_corner(v, own);
      const uint32_t gv = own_k >= 0 ? own[own_k] : vertex_number(v);
      const uint64_t id = gv != ~0u ? gv : point_of[v] != ~0u ? nv_all + point_of[v] : ~0ull;
      if (!ring_id.empty() && id != ~0ull) {
        const uint32_t* twin = twin_of.find(ring_id.back());
        if (twin && *twin == id) {
          put_varint(s_codes, kTwin);
          ring_id.push_back(id);
          point_before = gv == ~0u;
          if (point_before) px = point_xy[2 * point_of[v]], py = point_xy[2 * point_of[v] + 1];
          continue;
        }
      }
      if (gv != ~0u) {
        ring_id.push_back(gv);
        if (own_k >= 0) {
          put_varint(s_codes, kOwnCorner + own_k);
        } else {
          put_varint(s_codes, kVertexRef);
          put_varint(s_refs, zigzag(int64_t(gv) - int64_t(own[0])));
          need_vertex(gv);
        }
        point_before = false;
        continue;
      }
      if (point_of[v] != ~0u) {
        put_varint(s_codes, kPointRef + (points - 1 - point_of[v]));
      } else {
        int64_t x = std::llround(P.xy[2 * v] * options_.quantum);
        int64_t y = std::llround(P.xy[2 * v + 1] * options_.quantum);
        // On an own edge of the exact map: one step number along the client's edge, when that
        // lands within two grid steps of the point.
        bool on_edge = false;
        for (int k = 0; k < 3 && !on_edge; ++k) {
          const uint32_t a = own[k], b = own[(k + 1) % 3];
          if (vstate[a] != 1 || vstate[b] != 1) continue;
          const double ax = vproj[2 * a] / gs, ay = vproj[2 * a + 1] / gs;
          const double ex = vproj[2 * b] / gs - ax, ey = vproj[2 * b + 1] / gs - ay;
          const double len = std::hypot(ex, ey), qx = P.xy[2 * v] - ax, qy = P.xy[2 * v + 1] - ay;
          if (!(len > 0) || std::abs(ex * qy - ey * qx) > kOnEdge * len) continue;
          int32_t A[2], B[2];
          if (!client_point(a, A) || !client_point(b, B)) continue;
          const int64_t dx = int64_t(B[0]) - A[0], dy = int64_t(B[1]) - A[1];
          const int64_t steps = std::max(std::abs(dx), std::abs(dy));
          if (steps < 2) continue;
          const double t = ((P.xy[2 * v] * options_.quantum - A[0]) * double(dx) +
                            (P.xy[2 * v + 1] * options_.quantum - A[1]) * double(dy)) /
                           (double(dx) * dx + double(dy) * dy);
          const int64_t step = std::clamp<int64_t>(std::llround(t * steps), 1, steps - 1);
          const int64_t ex2 = A[0] + div_round(step * dx, steps);
          const int64_t ey2 = A[1] + div_round(step * dy, steps);
          if (std::abs(ex2 - x) > 2 || std::abs(ey2 - y) > 2) continue;
          put_varint(s_codes, kEdgePoint + k);
          put_varint(s_steps, uint64_t(step));
          x = ex2, y = ey2;
          on_edge = true;
          ++edge_points;
        }
        if (!on_edge) {
          put_varint(s_codes, kNewPoint);
          const int64_t bx = point_before ? px : last_x, by = point_before ? py : last_y;
          put_varint(s_points, zigzag(x - bx));
          put_varint(s_points, zigzag(y - by));
          last_x = x, last_y = y;
        }
        point_xy.push_back(x);
        point_xy.push_back(y);
        point_of[v] = points++;
      }
      ring_id.push_back(nv_all + point_of[v]);
      point_before = true, px = point_xy[2 * point_of[v]], py = point_xy[2 * point_of[v] + 1];
    }
    for (size_t k = 0; k < n; ++k) twin_of.emplace(ring_id[(k + 1) % n], uint32_t(ring_id[k]));
  }

  // New sources: vertices (global number gaps, then xyz), triangles (id gaps, vertex numbers).
  std::sort(new_verts.begin(), new_verts.end());
  std::sort(new_tris.begin(), new_tris.end());
  put_varint(s_vert, new_verts.size());
  uint32_t prev = 0;
  for (uint32_t gv : new_verts) {
    put_varint(s_vert, gv - prev);
    prev = gv;
    const uint32_t m = uint32_t(std::upper_bound(vertex_base_.begin(), vertex_base_.end(), gv) -
                                vertex_base_.begin() - 1);
    const float* p = &scene_.meshes[m].positions[3 * size_t(gv - vertex_base_[m])];
    for (int c = 0; c < 3; ++c) put_u32(s_float, std::bit_cast<uint32_t>(p[c]));
  }
  put_varint(s_tri, new_tris.size());
  prev = 0;
  int64_t last_v = 0;
  for (uint32_t id : new_tris) {
    put_varint(s_tri, id - prev);
    prev = id;
    uint32_t gv[3];
    tri_vertices(id, gv);
    for (uint32_t v : gv) put_varint(s_tri, zigzag(int64_t(v) - last_v)), last_v = v;
  }

  std::string payload;
  payload += char(camera.projection == Camera::Projection::Orthographic);
  payload.append(3, '\0');
  for (const Vec3* v : {&camera.eye, &camera.target})
    for (double d : *v) put_f64(payload, d);
  for (double d : rows) put_f64(payload, d);
  if (key)
    for (size_t m = 0; m < scene_.meshes.size(); ++m) {
      put_u32(payload, uint32_t(base_[m]));
      put_u32(payload, scene_.meshes[m].source_triangles);
      put_u32(payload, uint32_t(scene_.meshes[m].vertex_count()));
      for (int c = 0; c < 3; ++c)
        put_u32(payload, std::bit_cast<uint32_t>(scene_.meshes[m].color[c]));
    }
  const std::string* sections[kSections] = {&s_vert, &s_float, &s_tri,  &s_removed, &s_added,
                                            &s_poly, &s_codes, &s_refs, &s_points,  &s_steps};
  for (const std::string* s : sections) put_u32(payload, uint32_t(s->size()));
  for (const std::string* s : sections) payload += *s;

  std::string out(kMagic, 4);
  for (uint32_t v :
       {kVersion, map.width, map.height, key ? kKeyframe : 0u, options_.quantum, frame_,
        key ? kNoBase : frame_ - 1, uint32_t(scene_.meshes.size()), uint32_t(options_.compression),
        uint32_t(payload.size()), uint32_t(whole.size())})
    put_u32(out, v);
  out += frame_io::compress(payload, options_.compression, options_.level, "delta writer");

  if (stats) {
    *stats = {};
    stats->keyframe = key;
    stats->whole = whole.size();
    stats->added = added.size();
    stats->removed = removed.size();
    stats->partial = partial.size();
    stats->partial_corners = corners;
    stats->points = points;
    stats->edge_points = edge_points;
    stats->new_triangles = new_tris.size();
    stats->new_vertices = new_verts.size();
    stats->source_bytes = s_vert.size() + s_float.size() + s_tri.size();
    stats->set_bytes = s_removed.size() + s_added.size();
    stats->polygon_bytes =
        s_poly.size() + s_codes.size() + s_refs.size() + s_points.size() + s_steps.size();
  }
  whole_ = std::move(whole);
  partial_ = std::move(partial_ids);
  keyframe_ = false;
  ++frame_;
  return out;
}

// ---------------------------------------------------------------------------------------------
// Decoder

DeltaFrame DeltaDecoder::decode(const std::string& bytes) {
  if (bytes.size() < kHeaderBytes)
    malformed("header", -1, std::to_string(bytes.size()) + " bytes, the header alone is 48",
              InputErrorKind::Truncated);
  if (std::memcmp(bytes.data(), kMagic, 4) != 0) malformed("header", -1, "magic is not VMDF");
  const char* h = bytes.data();
  uint32_t w[11];
  for (int i = 0; i < 11; ++i) w[i] = get_u32(h + 4 + 4 * i);
  const uint32_t version = w[0], flags = w[3], quantum = w[4], index = w[5], base = w[6], nm = w[7],
                 codec = w[8], payload_bytes = w[9], whole_count = w[10];
  if (version != kVersion) malformed("header", -1, "version " + std::to_string(version));
  if (flags & ~kKeyframe) malformed("header", -1, "unknown flag bits");
  const bool key = flags & kKeyframe;
  if (w[1] < 1 || w[2] < 1 || w[1] > 65536 || w[2] > 65536)
    malformed("header", -1, "viewport out of range");
  if (quantum < 1 || quantum > 256) malformed("header", -1, "quantum out of 1 ... 256");
  if (codec != uint32_t(Compression::Zstd) && codec != uint32_t(Compression::Deflate))
    malformed("header", -1, "unknown compression");
  if (nm == 0 || nm > (1u << 24)) malformed("header", -1, "mesh count out of range");
  if (!key && !have_state_)
    throw DeltaOutOfSync(InputErrorKind::BadScene, "delta frame", "", "header", -1,
                         "no keyframe decoded yet: ask for one");
  if (!key && (base != last_ || nm != base_.size()))
    throw DeltaOutOfSync(InputErrorKind::BadScene, "delta frame", "", "header", -1,
                         "based on frame " + std::to_string(base) + ", the last decoded is " +
                             std::to_string(last_) + ": ask for a keyframe");
  const size_t zbytes = bytes.size() - kHeaderBytes;
  if (payload_bytes > kMaxRatio * zbytes + 4096)
    malformed("header", -1, "payload size out of proportion");
  std::string payload(payload_bytes, '\0');
  if (const std::string why =
          frame_io::decompress(h + kHeaderBytes, zbytes, Compression(codec), payload);
      !why.empty())
    malformed("payload", -1, why);

  DeltaFrame f;
  f.width = w[1], f.height = w[2], f.quantum = quantum, f.index = index, f.keyframe = key;
  Stream head{reinterpret_cast<const unsigned char*>(payload.data()),
              reinterpret_cast<const unsigned char*>(payload.data()) + payload.size(), "camera"};
  const unsigned char* cam = head.take(4 + 18 * 8);
  auto f64 = [&](int i) {
    const char* p = reinterpret_cast<const char*>(cam) + 4 + 8 * i;
    return std::bit_cast<double>(uint64_t(get_u32(p)) | uint64_t(get_u32(p + 4)) << 32);
  };
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

  // A keyframe starts from nothing: its mesh table sizes the store. Work on copies so that a
  // malformed frame leaves the state as it was.
  std::vector<uint64_t> base_ids = base_, vbase = vertex_base_;
  std::vector<float> vertex;
  std::vector<uint32_t> tri;
  std::vector<uint32_t> whole, partial;  // partial: the previous frame's polygon sources
  std::vector<std::array<float, 3>> colors = colors_;
  if (key) {
    colors.clear();
    base_ids.clear(), vbase.clear();
    uint64_t tris = 0, verts = 0;
    for (uint32_t m = 0; m < nm; ++m) {
      const unsigned char* e = head.take(24);
      const uint32_t first = get_u32(reinterpret_cast<const char*>(e));
      if (first != tris) malformed("mesh", m, "first ids do not follow the counts");
      base_ids.push_back(first);
      vbase.push_back(verts);
      tris += get_u32(reinterpret_cast<const char*>(e) + 4);
      verts += get_u32(reinterpret_cast<const char*>(e) + 8);
      std::array<float, 3> rgb;
      for (int c = 0; c < 3; ++c) {
        rgb[c] = std::bit_cast<float>(get_u32(reinterpret_cast<const char*>(e) + 12 + 4 * c));
        if (!(rgb[c] >= 0 && rgb[c] <= 1)) malformed("mesh", m, "color not in [0, 1]");
      }
      colors.push_back(rgb);
      if (tris > kMaxSourceCount || verts > kMaxSourceCount)
        malformed("mesh", m, "more than 2^26 triangles or vertices");
    }
    vertex.assign(3 * verts, std::numeric_limits<float>::quiet_NaN());
    tri.assign(3 * tris, ~0u);
  } else {
    vertex = vertex_;
    tri = tri_;
    whole = whole_;
    partial = partial_;
  }
  const size_t n_tris = tri.size() / 3, n_verts = vertex.size() / 3;
  uint32_t size[kSections];
  for (uint32_t& s : size) s = get_u32(reinterpret_cast<const char*>(head.take(4)));
  Stream sec[kSections];
  const char* names[kSections] = {"vertices", "vertex positions", "triangles",    "removed",
                                  "added",    "polygons",         "corner codes", "vertex refs",
                                  "points",   "edge steps"};
  for (int i = 0; i < kSections; ++i) {
    const unsigned char* p = head.take(size[i]);
    sec[i] = Stream{p, p + size[i], names[i]};
  }
  head.done();

  // New vertices and triangles.
  {
    Stream& s = sec[0];
    const uint64_t n = s.varint();
    if (n > n_verts) malformed("vertices", -1, "more than the scene has");
    uint64_t gv = 0;
    for (uint64_t i = 0; i < n; ++i) {
      const uint64_t d = s.varint();
      if (i > 0 && d == 0) malformed("vertices", int64_t(i), "not ascending");
      if (d >= n_verts - gv) malformed("vertices", int64_t(i), "out of range");
      gv += d;
      const unsigned char* p = sec[1].take(12);
      for (int c = 0; c < 3; ++c) {
        const float v = std::bit_cast<float>(get_u32(reinterpret_cast<const char*>(p) + 4 * c));
        if (!std::isfinite(v)) malformed("vertices", int64_t(i), "not finite");
        vertex[3 * gv + c] = v;
      }
    }
    s.done();
    sec[1].done();
  }
  {
    Stream& s = sec[2];
    const uint64_t n = s.varint();
    if (n > n_tris) malformed("triangles", -1, "more than the scene has");
    uint64_t id = 0;
    int64_t last_v = 0;
    for (uint64_t i = 0; i < n; ++i) {
      const uint64_t d = s.varint();
      if (i > 0 && d == 0) malformed("triangles", int64_t(i), "not ascending");
      if (d >= n_tris - id) malformed("triangles", int64_t(i), "out of range");
      id += d;
      for (int k = 0; k < 3; ++k) {
        last_v += small(s, "triangles");
        if (last_v < 0 || uint64_t(last_v) >= n_verts || std::isnan(vertex[3 * last_v]))
          malformed("triangles", int64_t(i), "names a vertex not sent");
        tri[3 * id + k] = uint32_t(last_v);
      }
    }
    s.done();
  }
  // The whole set's change.
  auto read_ids = [&](Stream& s, std::vector<uint32_t>& ids) {
    const uint64_t n = s.varint();
    if (n > n_tris) malformed(s.name, -1, "more ids than the scene has");
    uint64_t id = 0;
    for (uint64_t i = 0; i < n; ++i) {
      const uint64_t d = s.varint();
      if (i > 0 && d == 0) malformed(s.name, int64_t(i), "not ascending");
      if (d >= n_tris - id) malformed(s.name, int64_t(i), "out of range");
      id += d;
      ids.push_back(uint32_t(id));
    }
    s.done();
  };
  std::vector<uint32_t> removed, added, kept;
  read_ids(sec[3], removed);
  read_ids(sec[4], added);
  std::set_difference(whole.begin(), whole.end(), removed.begin(), removed.end(),
                      std::back_inserter(kept));
  if (kept.size() + removed.size() != whole.size())
    malformed("removed", -1, "an id that was not drawn whole");
  whole.clear();
  std::set_union(kept.begin(), kept.end(), added.begin(), added.end(), std::back_inserter(whole));
  if (whole.size() != kept.size() + added.size())
    malformed("added", -1, "an id that is drawn whole already");
  if (whole.size() != whole_count) malformed("added", -1, "the whole set has the wrong size");

  // Triangles: the whole ones projected here, then the polygons fanned.
  auto mesh_of = [&](uint32_t id) {
    return uint32_t(std::upper_bound(base_ids.begin(), base_ids.end(), uint64_t(id)) -
                    base_ids.begin() - 1);
  };
  std::vector<int32_t> proj(2 * n_verts);
  std::vector<uint8_t> projected(n_verts, 0);  // 1: done, 2: behind the camera
  auto vertex_at = [&](uint32_t gv, const char* what, int64_t index) -> uint32_t {
    if (gv >= n_verts || std::isnan(vertex[3 * size_t(gv)]))
      malformed(what, index, "names a vertex not sent");
    if (!projected[gv])
      projected[gv] = project_to_grid(f.rows, f.width, f.height, quantum, &vertex[3 * size_t(gv)],
                                      &proj[2 * size_t(gv)])
                          ? 1
                          : 2;
    if (projected[gv] == 2) malformed(what, index, "a vertex behind the camera");
    return gv;
  };
  // Output vertices: projected source vertices first use a slot each, then the new points.
  std::vector<uint32_t> slot_of(n_verts, ~0u);
  auto out_vertex = [&](uint32_t gv) {
    if (slot_of[gv] == ~0u) {
      slot_of[gv] = uint32_t(f.xy.size() / 2);
      f.xy.push_back(proj[2 * size_t(gv)]);
      f.xy.push_back(proj[2 * size_t(gv) + 1]);
    }
    return slot_of[gv];
  };
  // The Lambert factor of --fill shade (DELTA.md), from the triangle's world vertices.
  auto shade_of = [&](uint32_t id) {
    double p[3][3];
    for (int k = 0; k < 3; ++k)
      for (int c = 0; c < 3; ++c) p[k][c] = vertex[3 * size_t(tri[3 * size_t(id) + k]) + c];
    double e1[3], e2[3], n[3], l[3];
    for (int c = 0; c < 3; ++c) {
      e1[c] = p[1][c] - p[0][c], e2[c] = p[2][c] - p[0][c];
      l[c] = f.camera.eye[c] - f.camera.target[c];  // the headlight (DELTA.md "Shade")
    }
    n[0] = e1[1] * e2[2] - e1[2] * e2[1];
    n[1] = e1[2] * e2[0] - e1[0] * e2[2];
    n[2] = e1[0] * e2[1] - e1[1] * e2[0];
    double ndl = std::abs(n[0] * l[0] + n[1] * l[1] + n[2] * l[2]) /
                 (std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]) *
                  std::sqrt(l[0] * l[0] + l[1] * l[1] + l[2] * l[2]));
    if (!std::isfinite(ndl)) ndl = 1.0;
    return uint8_t(std::lround((0.12 + 0.88 * std::min(ndl, 1.0)) * 255.0));
  };
  uint32_t shade_id = ~0u;
  uint8_t shade = 0;
  auto emit = [&](uint32_t a, uint32_t b, uint32_t c, uint32_t id, bool either) {
    int64_t o = orient2(&f.xy[2 * a], &f.xy[2 * b], &f.xy[2 * c]);
    if (o < 0 && either) std::swap(b, c), o = -o;
    if (o <= 0) return;
    f.indices.insert(f.indices.end(), {a, b, c});
    f.source.push_back(id);
    f.mesh.push_back(mesh_of(id));
    if (id != shade_id) shade_id = id, shade = shade_of(id);
    f.shade.push_back(shade);
  };
  for (uint32_t id : whole) {
    if (tri[3 * size_t(id)] == ~0u) malformed("added", id, "a triangle not sent");
    uint32_t s[3];
    for (int k = 0; k < 3; ++k) s[k] = out_vertex(vertex_at(tri[3 * size_t(id) + k], "whole", id));
    emit(s[0], s[1], s[2], id, true);  // either orientation: back faces are drawn too
  }
  {
    Stream& s = sec[5];
    Stream& codes = sec[6];
    Stream& refs = sec[7];
    Stream& pts = sec[8];
    Stream& steps = sec[9];
    // The sources, in the order the encoder wrote them (DELTA.md, "Polygons").
    std::vector<uint32_t> order;
    for (const std::vector<uint32_t>* list : {&removed, &partial})
      for (size_t i = 0; i < list->size(); i += 8) {
        const uint8_t bits = *s.take(1);
        for (size_t b = 0; b < 8; ++b)
          if (bits >> b & 1) {
            if (i + b >= list->size()) malformed("polygons", -1, "a flag past the list's end");
            order.push_back((*list)[i + b]);
          }
      }
    {
      const size_t flagged = order.size();
      std::vector<uint32_t> rest;
      Stream& ids = s;
      const uint64_t nr = ids.varint();
      if (nr > n_tris) malformed("polygons", -1, "more sources than the scene has");
      uint64_t id = 0;
      for (uint64_t i = 0; i < nr; ++i) {
        const uint64_t d = ids.varint();
        if (i > 0 && d == 0) malformed("polygons", int64_t(i), "not ascending");
        if (d >= n_tris - id) malformed("polygons", int64_t(i), "source out of range");
        id += d;
        order.push_back(uint32_t(id));
      }
      std::vector<uint32_t> all = order;
      std::sort(all.begin(), all.end());
      if (std::adjacent_find(all.begin(), all.end()) != all.end())
        malformed("polygons", -1, "a source named twice");
      (void)flagged;
      partial = std::move(all);
    }
    std::vector<uint32_t> poly_source;
    for (uint32_t src_id : order) {
      const uint64_t more = s.varint();
      if (more >= (1u << 20) || poly_source.size() + more + 1 > (1ull << 28))
        malformed("polygons", -1, "too many");
      const uint64_t count = more + 1;
      poly_source.insert(poly_source.end(), count, src_id);
    }
    const uint64_t n = poly_source.size();
    std::vector<uint32_t> point_slot;
    int64_t lx = 0, ly = 0;
    uint64_t id = 0;
    std::vector<uint32_t> ring;
    std::vector<uint64_t> ring_id;
    FlatMap twin_of(size[6]);  // a corner takes at least a byte of codes
    const int64_t xmax = int64_t(f.width) * quantum, ymax = int64_t(f.height) * quantum;
    for (uint64_t i = 0; i < n; ++i) {
      id = poly_source[i];
      if (tri[3 * id] == ~0u) malformed("polygons", int64_t(i), "unknown source");
      const uint64_t extra = s.varint();
      if (extra > 1u << 20) malformed("polygons", int64_t(i), "too many corners");
      const uint64_t corners = extra + 3;
      ring.clear();
      ring_id.clear();
      bool point_before = false;
      for (uint64_t k = 0; k < corners; ++k) {
        const uint64_t code = codes.varint();
        if (code < kVertexRef) {
          ring.push_back(out_vertex(vertex_at(tri[3 * id + code], "polygons", int64_t(i))));
          ring_id.push_back(tri[3 * id + code]);
          point_before = false;
        } else if (code == kVertexRef) {
          const int64_t gv = int64_t(tri[3 * id]) + small(refs, "vertex refs");
          if (gv < 0 || uint64_t(gv) >= n_verts) malformed("polygons", int64_t(i), "vertex ref");
          ring.push_back(out_vertex(vertex_at(uint32_t(gv), "polygons", int64_t(i))));
          ring_id.push_back(uint64_t(gv));
          point_before = false;
        } else if (code == kTwin) {
          const uint32_t* twin = ring_id.empty() ? nullptr : twin_of.find(ring_id.back());
          if (!twin) malformed("polygons", int64_t(i), "a twin corner without an earlier edge");
          if (*twin < n_verts) {
            ring.push_back(out_vertex(vertex_at(*twin, "polygons", int64_t(i))));
            point_before = false;
          } else {
            ring.push_back(point_slot[*twin - n_verts]);
            point_before = true;
          }
          ring_id.push_back(*twin);
        } else if (code == kNewPoint || (code >= kEdgePoint && code < kPointRef)) {
          int64_t x, y;
          if (code == kNewPoint) {
            const uint32_t prev = ring.empty() ? 0 : ring.back();
            const int64_t bx = point_before ? f.xy[2 * prev] : lx;
            const int64_t by = point_before ? f.xy[2 * prev + 1] : ly;
            x = lx = bx + small(pts, "points");
            y = ly = by + small(pts, "points");
          } else {  // a step along own edge k, as the client projects its ends
            const int k = int(code - kEdgePoint);
            const uint32_t a = vertex_at(tri[3 * id + k], "polygons", int64_t(i));
            const uint32_t b = vertex_at(tri[3 * id + (k + 1) % 3], "polygons", int64_t(i));
            const int64_t dx = int64_t(proj[2 * b]) - proj[2 * a];
            const int64_t dy = int64_t(proj[2 * b + 1]) - proj[2 * a + 1];
            const int64_t n_steps = std::max(std::abs(dx), std::abs(dy));
            const uint64_t step = steps.varint();
            if (n_steps < 2 || step < 1 || step >= uint64_t(n_steps))
              malformed("edge steps", int64_t(point_slot.size()), "out of the edge");
            x = proj[2 * a] + div_round(int64_t(step) * dx, n_steps);
            y = proj[2 * a + 1] + div_round(int64_t(step) * dy, n_steps);
          }
          if (x < 0 || y < 0 || x > xmax || y > ymax)
            malformed("points", int64_t(point_slot.size()), "outside the viewport");
          point_slot.push_back(uint32_t(f.xy.size() / 2));
          f.xy.push_back(int32_t(x));
          f.xy.push_back(int32_t(y));
          ring.push_back(point_slot.back());
          ring_id.push_back(n_verts + point_slot.size() - 1);
          point_before = true;
        } else {
          const uint64_t j = code - kPointRef;
          if (j >= point_slot.size()) malformed("polygons", int64_t(i), "point ref out of range");
          ring.push_back(point_slot[point_slot.size() - 1 - j]);
          ring_id.push_back(n_verts + point_slot.size() - 1 - j);
          point_before = true;
        }
      }
      for (size_t k = 0; k < ring_id.size(); ++k)
        twin_of.emplace(ring_id[(k + 1) % ring_id.size()], uint32_t(ring_id[k]));
      for (size_t k = 1; k + 1 < ring.size(); ++k)
        emit(ring[0], ring[k], ring[k + 1], uint32_t(id), false);
    }
    s.done();
    codes.done();
    refs.done();
    pts.done();
    steps.done();
  }

  // Commit the state.
  base_ = std::move(base_ids);
  vertex_base_ = std::move(vbase);
  vertex_ = std::move(vertex);
  tri_ = std::move(tri);
  whole_ = std::move(whole);
  partial_ = std::move(partial);
  colors_ = std::move(colors);
  f.mesh_color = colors_;
  last_ = index;
  have_state_ = true;
  return f;
}

}  // namespace vismap
