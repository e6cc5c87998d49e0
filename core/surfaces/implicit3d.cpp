// An implicit surface diced for the camera (issue 19, docs/IMPLICIT.md "3D").
// Device (kernels/implicit.cl): MPR's region queue over the object's cube, in its own space:
// interval arithmetic culls regions outside the view's planes and those proven full or empty,
// shortens each ambiguous region's tape and hands it to its children, down to cells of side h;
// then each leaf cell's 8 corners are evaluated with its shortened tape (the same operations on
// the same values as the full tape, so a corner shared by cells gets one value).
// Host: surface nets on the leaf cells (one vertex per cell the surface crosses, placed from the
// cell's own corner values; one quad per crossing edge between the four cells around it), so
// every edge of the mesh inside the view is shared and the surface has no cracks; back faces left
// out where they cannot be seen; vertex normals from the gradient of the cell's shortened tape
// (forward differentiation).
//
// Error bound: a quad lies in the 2 x 2 x 1 block of cells around its edge, whose corner values
// differ in sign (f = 0 at a point of the edge), so each of its points is within sqrt(3) h of a
// point where f = 0. In pixels that is at most sqrt(3) h sigma k_px / d, sigma the transform's
// largest stretch, k_px the projection's largest pixel scale per unit at depth 1 and d the depth;
// h is chosen for the nearest depth of the surface in view (a coarse pass of the queue finds it).
// What a grid cannot see (a wall thinner than h, a sign change between corners of one cell that
// does not reach an edge) is left out.
#include <algorithm>
#include <cmath>

#include "core/error.h"
#include "core/implicit/implicit.h"
#include "core/surfaces/implicit.h"
#include "core/surfaces/internal.h"
#include "core/util/clock.h"
#include "core/util/weld.h"

namespace vismap::stages {

namespace {

constexpr uint64_t kMaxCells = uint64_t(1) << 16;  // cells per axis

using M4 = std::array<double, 16>;  // column-major

// Open addressing from 64-bit keys (never ~0; here grid cells) to 32-bit values.
class KeyTable {
 public:
  explicit KeyTable(size_t expect) {
    size_t cap = 16;
    while (cap < 2 * expect) cap <<= 1;
    keys_.assign(cap, ~uint64_t(0));
    vals_.resize(cap);
  }
  // The slot of `key`: inserted (found = false) when absent.
  uint32_t* find_or_insert(uint64_t key, bool& found) {
    if (2 * (count_ + 1) > keys_.size()) grow();
    size_t i = hash(key) & (keys_.size() - 1);
    while (keys_[i] != ~uint64_t(0) && keys_[i] != key) i = (i + 1) & (keys_.size() - 1);
    found = keys_[i] == key;
    if (!found) keys_[i] = key, ++count_;
    return &vals_[i];
  }

 private:
  static size_t hash(uint64_t k) {
    k ^= k >> 31;
    k *= 0x9E3779B97F4A7C15ull;
    return size_t(k ^ (k >> 29));
  }
  void grow() {
    std::vector<uint64_t> k = std::move(keys_);
    std::vector<uint32_t> v = std::move(vals_);
    keys_.assign(2 * k.size(), ~uint64_t(0));
    vals_.assign(2 * k.size(), 0);
    count_ = 0;
    bool f;
    for (size_t i = 0; i < k.size(); ++i)
      if (k[i] != ~uint64_t(0)) *find_or_insert(k[i], f) = v[i];
  }
  std::vector<uint64_t> keys_;
  std::vector<uint32_t> vals_;
  size_t count_ = 0;
};

std::array<double, 3> place(const M4& m, const double p[3]) {
  return {m[0] * p[0] + m[4] * p[1] + m[8] * p[2] + m[12],
          m[1] * p[0] + m[5] * p[1] + m[9] * p[2] + m[13],
          m[2] * p[0] + m[6] * p[1] + m[10] * p[2] + m[14]};
}

// The inverse of the linear part (row-major 3x3), from the adjugate.
std::array<double, 9> inverse3(const M4& m) {
  const double a = m[0], b = m[4], c = m[8], d = m[1], e = m[5], f = m[9], g = m[2], h = m[6],
               i = m[10];
  const double A = e * i - f * h, B = -(d * i - f * g), C = d * h - e * g;
  const double det = a * A + b * B + c * C;
  return {A / det,
          -(b * i - c * h) / det,
          (b * f - c * e) / det,
          B / det,
          (a * i - c * g) / det,
          -(a * f - c * d) / det,
          C / det,
          -(a * h - b * g) / det,
          (a * e - b * d) / det};
}

// The largest singular value of the linear part (power iteration on A^T A), rounded up.
double spectral_norm(const M4& m) {
  double v[3] = {1, 0.7, 0.4}, s = 0;
  for (int it = 0; it < 100; ++it) {
    double av[3], w[3];
    for (int r = 0; r < 3; ++r) av[r] = m[r] * v[0] + m[4 + r] * v[1] + m[8 + r] * v[2];
    for (int c = 0; c < 3; ++c)
      w[c] = m[4 * c] * av[0] + m[4 * c + 1] * av[1] + m[4 * c + 2] * av[2];
    double l = std::sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
    if (!(l > 0)) break;
    for (int c = 0; c < 3; ++c) v[c] = w[c] / l;
    s = std::sqrt(l);
  }
  // The Frobenius norm bounds it from above: a cap, and the answer if the iteration failed.
  double fro = 0;
  for (int c = 0; c < 3; ++c)
    for (int r = 0; r < 3; ++r) fro += m[4 * c + r] * m[4 * c + r];
  fro = std::sqrt(fro);
  return s > 0 ? std::min(fro, s * 1.001) : fro;
}

// The camera's scale on the object: what the cell size is chosen from (the error bound above).
struct ViewScale {
  Camera cam;          // near and far fitted to the box when not given
  bool persp = false;
  double k_px = 0;     // the projection's largest pixel scale per unit at depth 1
  double sigma = 0;    // the transform's largest stretch
};

ViewScale view_scale(const Mesh& mesh, const Camera& cam_in) {
  // The box's corners in the world, for near/far.
  Bounds wb;
  for (const auto& w : mesh.implicit_corners()) {
    for (int k = 0; k < 3; ++k) {
      wb.lo[k] = wb.empty ? w[k] : std::min(wb.lo[k], w[k]);
      wb.hi[k] = wb.empty ? w[k] : std::max(wb.hi[k], w[k]);
    }
    wb.empty = false;
  }
  ViewScale v;
  v.cam = cam_in;
  if (v.cam.near_plane <= 0 || v.cam.far_plane <= 0) fit_near_far(v.cam, wb);
  const Camera& cam = v.cam;
  v.persp = cam.projection == Camera::Projection::Perspective;
  const double f_px = v.persp ? cam.height / (2 * std::tan(cam.fov_y_deg * M_PI / 360))
                              : cam.height / cam.ortho_height;
  const double r_px = 0.5 * std::hypot(double(cam.width), double(cam.height));
  v.k_px = v.persp ? f_px * std::sqrt(1 + (r_px / f_px) * (r_px / f_px)) : f_px;
  v.sigma = spectral_norm(mesh.implicit_xform);
  return v;
}

// The view's planes (Gribb-Hartmann rows of the view-projection), in the object's space,
// moved out by two cells of side `cell`: every cell next to one in view is kept (a quad joins
// four cells, and one culled would leave a gap at the border). The last is the near plane.
std::vector<std::array<float, 4>> view_planes(const Mat4& vp, const M4& xf, double cell) {
  std::vector<std::array<float, 4>> planes;
  for (int r = 0; r < 3; ++r)
    for (double sgn : {1.0, -1.0}) {
      if (r == 2 && sgn < 0) continue;  // no far plane: far is fitted, the near one matters
      double w[4], po[4];
      for (int k = 0; k < 4; ++k) w[k] = vp[4 * k + 3] + sgn * vp[4 * k + r];
      // w . (M p) = (w^T M) p
      for (int c = 0; c < 4; ++c)
        po[c] = w[0] * xf[4 * c] + w[1] * xf[4 * c + 1] + w[2] * xf[4 * c + 2] +
                w[3] * xf[4 * c + 3];
      po[3] += 2 * cell * (std::abs(po[0]) + std::abs(po[1]) + std::abs(po[2]));
      planes.push_back({float(po[0]), float(po[1]), float(po[2]), float(po[3])});
    }
  return planes;
}


// The object's cube and its grid of N cells per axis of side h (corners canonical: lo + i h in
// double, then float).
struct CellGrid {
  float lo[3];
  float size;
  uint64_t N = 0;
  std::vector<uint32_t> splits;  // the queue's rounds: 4^a m cells per axis
  double h = 0;
  double at(int k, uint32_t i) const { return lo[k] + double(i) * h; }
};

// The nearest depth of the surface in view: a coarse pass (16 cells per axis) of the same
// queue, its leaves' corners' depths (the box's nearest corner is often far nearer than any
// surface). At least the near plane; 1 for an orthographic view (the scale does not depend on it).
double nearest_depth(ClRuntime& rt, const implicit::SlotTape& code, const CellGrid& g,
                     const ViewScale& v, const M4& xf, double side, uint64_t max_bytes,
                     const TimeCheck& check_time, TessellateStats& st) {
  if (!v.persp) return 1;
  const ImplicitQueue coarse =
      run_implicit_queue(rt, code, g.lo, g.size, 3, {4, 4}, max_bytes,
                         view_planes(v.cam.view_projection(), xf, side / 16), check_time);
  st.launches += coarse.launches;
  const Mat4 view = v.cam.view();
  double d_min = INFINITY;
  for (const VmIRegion& L : coarse.leaves)
    for (int c = 0; c < 8; ++c) {
      const double p[3] = {L.lo[0] + (c & 1 ? L.size : 0.0), L.lo[1] + (c & 2 ? L.size : 0.0),
                           L.lo[2] + (c & 4 ? L.size : 0.0)};
      const std::array<double, 3> w = place(xf, p);
      d_min = std::min(d_min, -(view[2] * w[0] + view[6] * w[1] + view[10] * w[2] + view[14]));
    }
  if (coarse.leaves.empty()) d_min = 1;  // nothing in view: the fine pass finds no leaves
  return std::max(d_min, v.cam.near_plane);
}

// Cells per axis: 4^a m (m = 1 .. 6; rounds split 4 ways, the last m ways), the fewest with
// sqrt(3) h sigma k_px / d_min at most the tolerance.
void choose_cells(CellGrid& g, double side, double h_max, const Mesh& mesh) {
  const double need = side / h_max;
  for (uint64_t p4 = 1, a = 0; p4 <= kMaxCells && !g.N; p4 *= 4, ++a)
    for (uint32_t m = 1; m <= 6 && !g.N; ++m)
      if (double(p4 * m) >= need && p4 * m <= kMaxCells) {
        g.N = p4 * m;
        g.splits.assign(a, 4);
        if (m > 1) g.splits.push_back(m);
      }
  if (!g.N)
    throw InputError(InputErrorKind::TooLarge, "", mesh.name, "", -1,
                     "the tolerance needs more than 2^16 cells per axis (the eye is close to "
                     "the surface: give a larger implicit tolerance or tighter bounds)");
  g.h = double(g.size) / double(g.N);
}

void count_queue(const ImplicitQueue& q, const implicit::SlotTape& code, uint64_t N,
                 TessellateStats& st) {
  st.split_rounds += uint32_t(q.rounds.size());
  for (const ImplicitRound& r : q.rounds) st.culled += r.culled;
  st.launches += q.launches;
  st.pieces += q.leaves.size();
  st.implicit_cells = std::max<uint64_t>(st.implicit_cells, N);
  st.implicit_clauses_full += code.size();
  for (const VmIRegion& l : q.leaves) {
    st.implicit_leaf_clauses += l.tape_len;
    uint32_t b = 0;
    while (b + 1 < st.implicit_clause_hist.size() && (2u << b) <= l.tape_len) ++b;
    ++st.implicit_clause_hist[b];
  }
  st.implicit_leaves += q.leaves.size();
}

// The leaf cells: their grid indices (3 each) and their 8 corners (24 floats each).
struct LeafCells {
  std::vector<uint32_t> gi;
  std::vector<float> xyz;
};

LeafCells leaf_cells(const ImplicitQueue& q, const CellGrid& g) {
  const size_t nl = q.leaves.size();
  LeafCells c{std::vector<uint32_t>(3 * nl), std::vector<float>(24 * nl)};
  for (size_t l = 0; l < nl; ++l) {
    for (int k = 0; k < 3; ++k)
      c.gi[3 * l + k] = uint32_t(std::llround((double(q.leaves[l].lo[k]) - g.lo[k]) / g.h));
    for (int v = 0; v < 8; ++v)
      for (int k = 0; k < 3; ++k)
        c.xyz[24 * l + 3 * v + k] = float(g.at(k, c.gi[3 * l + k] + ((v >> k) & 1)));
  }
  return c;
}

// Surface nets, the vertices: one per leaf cell whose corners differ in sign, at the mean of its
// edges' crossings (each crossing from the edge's two corner values, so the vertex is a function
// of the cell's corner values alone).
struct NetVertices {
  explicit NetVertices(size_t leaves) : cells(leaves) {}
  KeyTable cells;            // grid cell -> its vertex
  std::vector<double> opos;  // object-space vertex positions
  std::vector<uint32_t> vleaf;  // per vertex: its leaf
};

uint64_t cell_key(uint64_t N, uint64_t i, uint64_t j, uint64_t k) {
  const uint64_t N1 = N + 1;
  return i + N1 * (j + N1 * k);
}

NetVertices net_vertices(const LeafCells& c, const std::vector<float>& val, const CellGrid& g,
                         const Mesh& mesh) {
  static const int kEdges[12][2] = {{0, 1}, {2, 3}, {4, 5}, {6, 7}, {0, 2}, {1, 3},
                                    {4, 6}, {5, 7}, {0, 4}, {1, 5}, {2, 6}, {3, 7}};
  const size_t nl = c.gi.size() / 3;
  NetVertices nv(nl);
  for (size_t l = 0; l < nl; ++l) {
    const float* f = &val[8 * l];
    const float* P = &c.xyz[24 * l];
    int neg = 0;
    for (int v = 0; v < 8; ++v) {
      if (std::isnan(f[v]))
        throw InputError(InputErrorKind::NonFiniteVertex, "", mesh.name, "expression", -1,
                         "f is not a number at (" + std::to_string(P[3 * v]) + ", " +
                             std::to_string(P[3 * v + 1]) + ", " + std::to_string(P[3 * v + 2]) +
                             ")");
      neg += f[v] < 0;
    }
    if (neg == 0 || neg == 8) continue;
    double acc[3] = {0, 0, 0};
    int nc = 0;
    for (const auto& e : kEdges) {
      const int u = e[0], v = e[1];
      if ((f[u] < 0) == (f[v] < 0)) continue;
      const double fa = f[u], fb = f[v], t = fa / (fa - fb);
      for (int k = 0; k < 3; ++k) {
        const double a = g.at(k, c.gi[3 * l + k] + ((u >> k) & 1));
        const double b = g.at(k, c.gi[3 * l + k] + ((v >> k) & 1));
        acc[k] += a + t * (b - a);
      }
      ++nc;
    }
    bool found;
    *nv.cells.find_or_insert(cell_key(g.N, c.gi[3 * l], c.gi[3 * l + 1], c.gi[3 * l + 2]),
                             found) = uint32_t(nv.vleaf.size());
    for (int k = 0; k < 3; ++k) nv.opos.push_back(acc[k] / nc);
    nv.vleaf.push_back(uint32_t(l));
  }
  return nv;
}

// Surface nets, the quads (as two triangles each, into `indices`): the edges from each cell's
// corner 0 along x, y, z; the four cells around the edge are this one and its neighbours below
// in the other two axes, ordered counter-clockwise about the axis (a, b the other axes with
// a x b = the axis), reversed when the edge's low end is outside so the normal points out of
// the solid.
void net_quads(const LeafCells& c, const std::vector<float>& val, const CellGrid& g,
               NetVertices& nv, std::vector<uint32_t>& indices) {
  const size_t nl = c.gi.size() / 3;
  const std::vector<double>& opos = nv.opos;
  for (size_t l = 0; l < nl; ++l) {
    const float* f = &val[8 * l];
    const uint32_t i0 = c.gi[3 * l], j0 = c.gi[3 * l + 1], k0 = c.gi[3 * l + 2];
    for (int ax = 0; ax < 3; ++ax) {
      if ((f[0] < 0) == (f[1 << ax] < 0)) continue;
      const int a = (ax + 1) % 3, b = (ax + 2) % 3;
      uint32_t gc[3] = {i0, j0, k0};
      if (gc[a] == 0 || gc[b] == 0) continue;  // the cube's faces: f >= 0 there (clipped)
      uint32_t quad[4];
      bool ok = true;
      static const int kAround[4][2] = {{1, 1}, {0, 1}, {0, 0}, {1, 0}};  // (da, db) subtracted
      for (int k = 0; k < 4 && ok; ++k) {
        uint32_t q3[3] = {gc[0], gc[1], gc[2]};
        q3[a] -= kAround[k][0], q3[b] -= kAround[k][1];
        bool found;
        uint32_t* slot = nv.cells.find_or_insert(cell_key(g.N, q3[0], q3[1], q3[2]), found);
        // A neighbour that is not a leaf with a vertex (culled outside the view): no quad.
        if (!found) *slot = ~0u;
        ok = found && *slot != ~0u;
        quad[k] = *slot;
      }
      if (!ok) continue;
      if (!(f[0] < 0)) std::swap(quad[1], quad[3]);
      // Split along the shorter diagonal.
      const auto d2 = [&](uint32_t p, uint32_t q) {
        double s2 = 0;
        for (int k = 0; k < 3; ++k)
          s2 += (opos[3 * p + k] - opos[3 * q + k]) * (opos[3 * p + k] - opos[3 * q + k]);
        return s2;
      };
      if (d2(quad[0], quad[2]) <= d2(quad[1], quad[3])) {
        const uint32_t t[6] = {quad[0], quad[1], quad[2], quad[0], quad[2], quad[3]};
        indices.insert(indices.end(), t, t + 6);
      } else {
        const uint32_t t[6] = {quad[0], quad[1], quad[3], quad[1], quad[2], quad[3]};
        indices.insert(indices.end(), t, t + 6);
      }
    }
  }
}

// World positions (float) into out.positions, welded by their bits: edges that meet at a corner
// where f = 0, or vertices a float apart, become one vertex. Returns per surface-nets vertex its
// output vertex (remap) and per output vertex its surface-nets vertex (src).
void weld_world(const NetVertices& nv, const M4& xf, Mesh& out, std::vector<uint32_t>& remap,
                std::vector<uint32_t>& src) {
  const size_t n = nv.vleaf.size();
  remap.resize(n);
  src.reserve(n);
  Weld<float, 3> weld(n);
  for (size_t v = 0; v < n; ++v) {
    const std::array<double, 3> w = place(xf, &nv.opos[3 * v]);
    float wf[3];
    for (int k = 0; k < 3; ++k) {
      wf[k] = float(w[k]);
      if (!std::isfinite(wf[k]))
        throw InputError(InputErrorKind::NonFiniteVertex, "", out.name, "vertex", int64_t(v),
                         "not finite after the object's transform");
    }
    auto [id, fresh] = weld.add(wf, uint32_t(out.positions.size() / 3));
    remap[v] = id;
    if (!fresh) continue;
    out.positions.insert(out.positions.end(), wf, wf + 3);
    src.push_back(uint32_t(v));
  }
}

// Back faces: a closed surface seen from outside hides every triangle that faces away (a ray
// reaching one from the eye has entered the solid through a front face first), so they can be
// left out when that holds: the eye outside the solid (f > 0 there) and every leaf cell wholly
// beyond the near plane (the near plane cuts nothing open).
bool back_faces_hidden(const ImplicitQueue& q, const implicit::Tape& clipped, const Camera& cam,
                       const M4& xf, const std::array<double, 9>& inv) {
  const std::array<float, 4> np = view_planes(cam.view_projection(), xf, 0)[4];  // unshifted
  bool hidden = true;
  for (size_t l = 0; l < q.leaves.size() && hidden; ++l) {
    const VmIRegion& L = q.leaves[l];
    double lowest = np[3];
    for (int k = 0; k < 3; ++k) lowest += np[k] * (L.lo[k] + (np[k] < 0 ? L.size : 0.0f));
    hidden = lowest > 0;
  }
  const double w[3] = {cam.eye[0] - xf[12], cam.eye[1] - xf[13], cam.eye[2] - xf[14]};
  double eo[3];
  for (int r = 0; r < 3; ++r)
    eo[r] = inv[3 * r] * w[0] + inv[3 * r + 1] * w[1] + inv[3 * r + 2] * w[2];
  return hidden && implicit::eval(clipped, eo[0], eo[1], eo[2]) > 0;
}

// Triangles through the weld, in place; collapsed or exactly flat ones dropped; a mirroring
// transform (det < 0) reverses the winding so normals stay outward; back faces dropped when
// cull_back. Returns the triangles kept.
size_t keep_triangles(Mesh& out, const std::vector<uint32_t>& remap, double det, bool cull_back,
                      const ViewScale& v, TessellateStats& st) {
  const Camera& cam = v.cam;
  const double view_dir[3] = {cam.target[0] - cam.eye[0], cam.target[1] - cam.eye[1],
                              cam.target[2] - cam.eye[2]};
  size_t kept = 0;
  for (size_t t = 0; t < out.indices.size(); t += 3) {
    uint32_t a = remap[out.indices[t]], b = remap[out.indices[t + 1]],
             c = remap[out.indices[t + 2]];
    if (a == b || b == c || a == c) continue;
    const float* pa = &out.positions[3 * size_t(a)];
    const float* pb = &out.positions[3 * size_t(b)];
    const float* pc = &out.positions[3 * size_t(c)];
    const double u[3] = {double(pb[0]) - pa[0], double(pb[1]) - pa[1], double(pb[2]) - pa[2]};
    const double w[3] = {double(pc[0]) - pa[0], double(pc[1]) - pa[1], double(pc[2]) - pa[2]};
    const double n[3] = {u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2],
                         u[0] * w[1] - u[1] * w[0]};
    if (n[0] == 0 && n[1] == 0 && n[2] == 0) continue;
    if (det < 0) std::swap(b, c);
    if (cull_back) {
      const double s = det < 0 ? -1 : 1;  // the kept winding's normal is s n
      const double e[3] = {v.persp ? pa[0] - cam.eye[0] : view_dir[0],
                           v.persp ? pa[1] - cam.eye[1] : view_dir[1],
                           v.persp ? pa[2] - cam.eye[2] : view_dir[2]};
      if (s * (n[0] * e[0] + n[1] * e[1] + n[2] * e[2]) > 0) {
        ++st.implicit_back_faces;
        continue;
      }
    }
    out.indices[kept++] = a, out.indices[kept++] = b, out.indices[kept++] = c;
  }
  out.indices.resize(kept);
  return kept / 3;
}

// Drops the vertices no kept triangle uses (numbered in order of first use), src with them.
void drop_unused_vertices(Mesh& out, std::vector<uint32_t>& src) {
  std::vector<uint32_t> renum(out.vertex_count(), ~0u);
  std::vector<float> pos;
  std::vector<uint32_t> src_kept;
  for (uint32_t& i : out.indices) {
    if (renum[i] == ~0u) {
      renum[i] = uint32_t(src_kept.size());
      pos.insert(pos.end(), &out.positions[3 * size_t(i)], &out.positions[3 * size_t(i)] + 3);
      src_kept.push_back(src[i]);
    }
    i = renum[i];
  }
  out.positions = std::move(pos);
  src = std::move(src_kept);
}

// Normals of the vertices kept: the gradient of the cell's own shortened tape at the vertex, to
// the world by the inverse transpose, unit length.
void vertex_normals(Mesh& out, const std::vector<uint32_t>& src, const NetVertices& nv,
                    const ImplicitQueue& q, const implicit::SlotTape& code,
                    const std::array<double, 9>& inv) {
  out.normals.resize(out.positions.size());
  for (size_t v = 0; v < src.size(); ++v) {
    const uint32_t sv = src[v];
    const VmIRegion& L = q.leaves[nv.vleaf[sv]];
    double g[3];
    implicit::eval_code_grad(q.pool.data() + 4 * size_t(L.tape_off), L.tape_len, code.slots,
                             code.root_slot, nv.opos[3 * size_t(sv)], nv.opos[3 * size_t(sv) + 1],
                             nv.opos[3 * size_t(sv) + 2], g);
    double n[3];
    for (int r = 0; r < 3; ++r)
      n[r] = inv[r] * g[0] + inv[3 + r] * g[1] + inv[6 + r] * g[2];  // A^-T g
    double len = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    if (!(len > 0) || !std::isfinite(len)) n[0] = n[1] = 0, n[2] = 1, len = 1;
    for (int k = 0; k < 3; ++k) out.normals[3 * v + k] = float(n[k] / len);
  }
}

}  // namespace

Mesh dice_implicit(ClRuntime& rt, const Mesh& mesh, const Camera& cam_in,
                   const TessellateOptions& o, TessellateStats& st, const TimeCheck& check_time) {
  const implicit::Tape& tape = *mesh.implicit;
  const M4& xf = mesh.implicit_xform;
  const double* blo = mesh.implicit_box.data();
  const double* bhi = mesh.implicit_box.data() + 3;
  const double tol = o.implicit_tolerance_px;
  if (!(tol > 0) || !std::isfinite(tol))
    throw InputError(InputErrorKind::BadScene, "", mesh.name, "", -1,
                     "the implicit tolerance must be a positive number of pixels");
  const ViewScale v = view_scale(mesh, cam_in);
  double side = 0;
  for (int k = 0; k < 3; ++k) side = std::max(side, bhi[k] - blo[k]);
  CellGrid g;
  for (int k = 0; k < 3; ++k) g.lo[k] = float(blo[k]);
  g.size = float(side);
  const implicit::Tape clipped = implicit::clipped_to_box(tape, blo, bhi, 3);
  const implicit::SlotTape code = implicit::allocate_slots(clipped);
  const uint32_t syncs0 = rt.host_syncs();
  auto t0 = Clock::now();

  // The device: the cell size for the nearest depth in view, the region queue down to it, the
  // leaf cells' corners.
  // The queue's buffers under the frame's budget where one is set (issue 35, case 3: its own
  // 4 GiB cap let RSS reach 6.4 GB against a 2 GiB budget), and the time limit per round.
  const uint64_t max_bytes = implicit_queue_cap(o.memory_budget);
  const double d_min = nearest_depth(rt, code, g, v, xf, side, max_bytes, check_time, st);
  choose_cells(g, side, tol * d_min / (std::sqrt(3.0) * v.sigma * v.k_px), mesh);
  const ImplicitQueue q = [&] {
    try {
      return run_implicit_queue(rt, code, g.lo, g.size, 3, g.splits, max_bytes,
                                view_planes(v.cam.view_projection(), xf, g.h), check_time);
    } catch (const InputError& e) {  // say which object, and what would need less
      throw InputError(e.kind(), e.file(), mesh.name, e.element(), e.index(),
                       e.detail() + " (" + std::to_string(g.N) +
                           " cells per axis for the surface's nearest depth in view, " +
                           std::to_string(d_min) +
                           ": a larger implicit tolerance or a farther eye needs fewer)");
    }
  }();
  st.implicit_queue_ms += ms_since(t0);
  t0 = Clock::now();
  count_queue(q, code, g.N, st);
  const LeafCells cells = leaf_cells(q, g);
  const std::vector<float> val =
      eval_leaf_points(rt, code, q, cells.xyz, 8, &st.launches, check_time);
  st.implicit_points_ms += ms_since(t0);
  t0 = Clock::now();

  // The host: surface nets, welded in the world, back faces out where they cannot be seen.
  Mesh out;
  out.name = mesh.name;
  out.color = mesh.color;
  NetVertices nv = net_vertices(cells, val, g, mesh);
  check_time();
  net_quads(cells, val, g, nv, out.indices);
  check_time();
  const std::array<double, 9> inv = inverse3(xf);  // for the eye's place and the normals
  const double det = xf[0] * (xf[5] * xf[10] - xf[9] * xf[6]) -
                     xf[4] * (xf[1] * xf[10] - xf[9] * xf[2]) +
                     xf[8] * (xf[1] * xf[6] - xf[5] * xf[2]);
  std::vector<uint32_t> remap, src;
  weld_world(nv, xf, out, remap, src);
  check_time();
  const bool cull_back =
      !o.implicit_back_faces && back_faces_hidden(q, clipped, v.cam, xf, inv);
  const size_t ntri = keep_triangles(out, remap, det, cull_back, v, st);
  if (cull_back) drop_unused_vertices(out, src);
  check_time();
  vertex_normals(out, src, nv, q, code, inv);
  if (ntri > kMaxDicedTriangles)
    throw InputError(InputErrorKind::TooLarge, "", mesh.name, "", -1,
                     "more than 2^27 triangles at this tolerance");
  out.face_ids.resize(ntri);
  for (size_t t = 0; t < ntri; ++t) out.face_ids[t] = uint32_t(t);
  out.source_triangles = ntri;
  st.triangles += ntri;
  st.host_syncs += rt.host_syncs() - syncs0;
  st.implicit_mesh_ms += ms_since(t0);
  return out;
}

}  // namespace vismap::stages
