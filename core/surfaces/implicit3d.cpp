// An implicit surface diced for the camera (issues 19 and 32, docs/IMPLICIT.md "3D").
// Device (kernels/implicit.cl): MPR's region queue over the object's cube, in its own space:
// interval arithmetic culls regions outside the view's planes and those proven full or empty,
// shortens each ambiguous region's tape and hands it to its children; a region becomes a leaf
// once its side h meets the tolerance at its own depth, so far surfaces get larger leaves than
// near ones; then each leaf's 8 corners are evaluated with its shortened tape (the same operations
// on the same values as the full tape, so a corner shared by leaves of any sides gets one value).
// Host: dual contouring on the leaves as an octree (core/surfaces/implicit_octree.h: a vertex per
// leaf from its own corner values, a polygon per sign-changing minimal edge joining the leaves
// around it), so every edge of the mesh inside the view is shared and the surface has no cracks,
// between leaves of one side or of several; back faces left out where they cannot be seen; vertex
// normals from the gradient of the leaf's shortened tape (forward differentiation).
//
// Error bound: a triangle lies in the leaves around its minimal edge, whose corner values differ
// in sign (f = 0 at a point of the edge), so each of its points is within sqrt(3) H of a point
// where f = 0, H the largest of those leaves' sides, and within H of that leaf on every axis. A
// leaf's side h has sqrt(3) h sigma k_px / d at most the tolerance, sigma the transform's largest
// stretch, k_px the projection's largest pixel scale per unit at depth 1 and d the least depth of
// the leaf grown by h on every side: at most the tolerance in pixels at the point's depth.
// What a grid cannot see (a wall thinner than h, a sign change between corners of one cell that
// does not reach an edge) is left out.
#include <algorithm>
#include <cmath>
#include <optional>

#include "core/error.h"
#include "core/implicit/implicit.h"
#include "core/surfaces/implicit.h"
#include "core/surfaces/implicit_octree.h"
#include "core/surfaces/internal.h"
#include "core/util/clock.h"
#include "core/util/weld.h"

namespace vismap::surfaces {

namespace {

constexpr uint32_t kMaxLevels = 16;  // 2^16 cells per axis at most

using M4 = std::array<double, 16>;  // column-major

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

// The view's planes (Gribb-Hartmann rows of the view-projection), in the object's space; the
// queue keeps every region within twice its leaf side of them (a triangle joins the leaves
// around an edge, and one culled would leave a gap at the border). The last is the near plane.
std::vector<std::array<float, 4>> view_planes(const Mat4& vp, const M4& xf) {
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
      planes.push_back({float(po[0]), float(po[1]), float(po[2]), float(po[3])});
    }
  return planes;
}

// What the queue sizes leaves by (VmIView): the view depth of an object-space point, and the
// largest leaf side h at depth d, from sqrt(3) h sigma k_px / d <= the tolerance (perspective;
// orthographic: sqrt(3) h sigma k_px <= the tolerance at any depth).
VmIView sizing_view(const ViewScale& v, const M4& xf, double tol) {
  const Mat4 view = v.cam.view();
  VmIView s{};
  for (int c = 0; c < 4; ++c)  // depth = -(view row 2) . (xf p)
    s.depth[c] = float(-(view[2] * xf[4 * c] + view[6] * xf[4 * c + 1] +
                         view[10] * xf[4 * c + 2] + (c == 3 ? view[14] : 0.0)));
  const double h = tol / (std::sqrt(3.0) * v.sigma * v.k_px);
  s.c0 = v.persp ? 0.0f : float(h);
  s.c1 = v.persp ? float(h) : 0.0f;
  s.near_d = float(v.cam.near_plane);
  return s;
}

// The least and greatest depth over the box [lo - grow, hi + grow], and the leaf side at a depth,
// as the kernels have them (kernels/implicit.cl vm_depth_range, vm_leaf_side), in double.
std::array<double, 2> box_depths(const VmIView& s, const double lo[3], const double hi[3],
                                 double grow) {
  double a = s.depth[3], b = s.depth[3];
  for (int k = 0; k < 3; ++k) {
    const double p = s.depth[k] * (lo[k] - grow), q = s.depth[k] * (hi[k] + grow);
    a += std::min(p, q);
    b += std::max(p, q);
  }
  return {a, b};
}
double leaf_side(const VmIView& s, double d) { return s.c0 + s.c1 * std::max(d, double(s.near_d)); }

// Occlusion (docs/IMPLICIT.md "Hidden regions"): the depth image's mapping for the view, one
// texel a pixel over the viewport, where every ray of the view starts outside the solid: the near
// plane's rectangle in view, grown by three leaf sides there (a leaf touching it is no larger),
// misses the object's box or is proven empty (f >= 0 over it) by interval arithmetic. Then a ray
// that reaches a full box has crossed the surface before it. Perspective views only.
std::optional<VmIOcclusion> occlusion_map(const ViewScale& v, const M4& xf,
                                          const std::array<double, 9>& inv,
                                          const implicit::Tape& clipped, const double blo[3],
                                          const double bhi[3], const VmIView& sizing) {
  if (!v.persp) return std::nullopt;
  const Camera& cam = v.cam;
  const Mat4 V = cam.view(), VP = cam.view_projection();
  const double W = cam.width, Hh = cam.height;
  const double t = std::tan(cam.fov_y_deg * M_PI / 360), aspect = W / Hh;
  VmIOcclusion o{};
  o.width = cam.width;
  o.height = cam.height;
  // The ray through texel point (tx, ty): world direction f + x t aspect r + y t u (x, y in
  // [-1, 1], y up), at view depth 1 per unit; to the object's space by the inverse.
  const auto to_object = [&](const double w[3], float* out) {
    for (int r = 0; r < 3; ++r)
      out[r] = float(inv[3 * r] * w[0] + inv[3 * r + 1] * w[1] + inv[3 * r + 2] * w[2]);
  };
  double d0[3], dx[3], dy[3], eo[3];
  for (int k = 0; k < 3; ++k) {
    const double r = V[4 * k], u = V[4 * k + 1], f = -V[4 * k + 2];
    d0[k] = f - t * aspect * r + t * u;
    dx[k] = 2 * t * aspect / W * r;
    dy[k] = -2 * t / Hh * u;
    eo[k] = cam.eye[k] - xf[12 + k];
  }
  to_object(d0, o.dir);
  to_object(dx, o.dir + 4);
  to_object(dy, o.dir + 8);
  to_object(eo, o.eye);
  // Object point p to (x w, y w, w): the viewport's mapping of the view-projection, times xf.
  for (int c = 0; c < 4; ++c) {
    const auto row = [&](int i) {
      return VP[i] * xf[4 * c] + VP[4 + i] * xf[4 * c + 1] + VP[8 + i] * xf[4 * c + 2] +
             VP[12 + i] * xf[4 * c + 3];
    };
    o.proj[c] = float(W / 2 * (row(0) + row(3)));
    o.proj[4 + c] = float(Hh / 2 * (row(3) - row(1)));
    o.proj[8 + c] = float(row(3));
  }
  for (int c = 0; c < 4; ++c)  // the largest direction component over the viewport
    for (int k = 0; k < 3; ++k)
      o.dmax = std::max(o.dmax, float(std::abs(o.dir[k] + (c & 1 ? W : 0) * o.dir[4 + k] +
                                               (c & 2 ? Hh : 0) * o.dir[8 + k])));
  // The near rectangle in pieces of the viewport, each a box around its 4 corners there.
  const double grow = 3 * leaf_side(sizing, cam.near_plane) + 1e-6 * (1 + cam.near_plane);
  struct Piece {
    double x0, y0, x1, y1;
    int depth;
  };
  std::vector<Piece> todo{{0, 0, W, Hh, 0}};
  while (!todo.empty()) {
    const Piece p = todo.back();
    todo.pop_back();
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (int c = 0; c < 4; ++c)
      for (int k = 0; k < 3; ++k) {
        const double d = o.dir[k] + (c & 1 ? p.x1 : p.x0) * o.dir[4 + k] +
                         (c & 2 ? p.y1 : p.y0) * o.dir[8 + k];
        lo[k] = std::min(lo[k], o.eye[k] + cam.near_plane * d - grow);
        hi[k] = std::max(hi[k], o.eye[k] + cam.near_plane * d + grow);
      }
    bool apart = false;
    for (int k = 0; k < 3; ++k) apart = apart || hi[k] < blo[k] || lo[k] > bhi[k];
    if (apart ||
        implicit::eval_interval(clipped, {lo[0], hi[0]}, {lo[1], hi[1]}, {lo[2], hi[2]}).lo >= 0)
      continue;
    if (p.depth == 8) return std::nullopt;  // the near plane meets the solid, or nearly
    const double xm = (p.x0 + p.x1) / 2, ym = (p.y0 + p.y1) / 2;
    todo.push_back({p.x0, p.y0, xm, ym, p.depth + 1});
    todo.push_back({xm, p.y0, p.x1, ym, p.depth + 1});
    todo.push_back({p.x0, ym, xm, p.y1, p.depth + 1});
    todo.push_back({xm, ym, p.x1, p.y1, p.depth + 1});
  }
  return o;
}

// The least depth of the surface in view: a coarse pass of the queue (16 cells per axis, culled
// to the view with a margin of two of them), its leaves' corners' depths (a box's nearest corner is
// often far nearer than any surface). At least the near plane.
double surface_depth(ClRuntime& rt, const implicit::SlotTape& code, const VmIView& s,
                     const double lo[3], double side, uint64_t max_bytes,
                     const std::vector<std::array<float, 4>>& planes, const TimeCheck& check_time,
                     TessellateStats& st) {
  VmIView coarse_view = s;
  coarse_view.c0 = coarse_view.c1 = 0;
  coarse_view.margin = float(side / 8);
  const float flo[3] = {float(lo[0]), float(lo[1]), float(lo[2])};
  const ImplicitQueue coarse = run_implicit_queue(rt, code, flo, float(side), 3, {4, 4}, max_bytes,
                                                  planes, check_time, &coarse_view);
  st.launches += coarse.launches;
  double d_min = INFINITY;
  for (const VmIRegion& L : coarse.leaves) {
    const double a[3] = {L.lo[0], L.lo[1], L.lo[2]}, b[3] = {a[0] + L.size, a[1] + L.size,
                                                           a[2] + L.size};
    d_min = std::min(d_min, box_depths(s, a, b, 0)[0]);
  }
  return std::max(d_min, double(s.near_d));
}

// The queue's cube and rounds. The cube's side is t 2^L, t the leaf side at the least depth of
// the surface in view (surface_depth) and L the fewest levels that cover the object's box, so the
// nearest leaves are as large as their depth allows; finer levels follow, down to the leaf side at
// the box's least depth (grown by it), where the last round makes every ambiguous region a leaf
// (at most kMaxLevels levels: past that the last round's leaves are checked against their depth).
// The rounds split 4 ways per axis while a region is over 32 times the largest leaf side (the side
// at the box's farthest depth), then 2 ways: a leaf is at most twice smaller than its depth
// allows, an ambiguous region near the leaves has 8 children, not 64 (the architecture model at
// 4 px: 1.7 million regions in the last round, not 5.4 million), and full boxes one level up
// hide the next level's regions.
void plan_rounds(OctreeGrid& g, std::vector<uint32_t>& splits, const VmIView& s, const double lo[3],
                 const double hi[3], double d_surface) {
  double side = 0;
  for (int k = 0; k < 3; ++k) side = std::max(side, hi[k] - lo[k]);
  const double t0 = leaf_side(s, box_depths(s, lo, hi, 0)[0]);
  const double t_min = leaf_side(s, box_depths(s, lo, hi, t0)[0]) * (1 - 1e-4);
  const double t_ref = std::max(t_min, leaf_side(s, d_surface) * (1 - 1e-4));
  const double far_side = leaf_side(s, box_depths(s, lo, hi, 0)[1]);
  uint32_t top = 0;  // the level of side t_ref
  while (top < kMaxLevels && side / double(uint64_t(1) << top) > t_ref) ++top;
  const double cube = std::max(side, t_ref * double(uint64_t(1) << top) * (1 + 1e-6));
  uint32_t levels = top;
  while (levels < kMaxLevels && cube / double(uint64_t(1) << levels) > t_min) ++levels;
  for (int k = 0; k < 3; ++k) g.lo[k] = float(lo[k]);
  g.size = float(cube);
  double at = double(g.size);
  for (uint32_t level = 0; level < levels;) {
    const bool four = at / 2 > 16 * far_side && level + 2 <= levels;
    splits.push_back(four ? 4 : 2);
    at /= four ? 4 : 2;
    level += four ? 2 : 1;
  }
  g.levels = levels;
  g.unit = double(g.size) / double(uint64_t(1) << levels);
}

void count_queue(const ImplicitQueue& q, const implicit::SlotTape& code, uint32_t finest,
                 TessellateStats& st) {
  st.split_rounds += uint32_t(q.rounds.size());
  for (const ImplicitRound& r : q.rounds) st.culled += r.culled, st.implicit_occluded += r.occluded;
  st.launches += q.launches;
  st.pieces += q.leaves.size();
  st.implicit_cells = std::max<uint64_t>(st.implicit_cells, uint64_t(1) << finest);
  st.implicit_clauses_full += code.size();
  for (const VmIRegion& l : q.leaves) {
    st.implicit_leaf_clauses += l.tape_len;
    uint32_t b = 0;
    while (b + 1 < st.implicit_clause_hist.size() && (2u << b) <= l.tape_len) ++b;
    ++st.implicit_clause_hist[b];
  }
  st.implicit_leaves += q.leaves.size();
}

// World positions (float) into out.positions, welded by their bits: edges that meet at a corner
// where f = 0, or vertices a float apart, become one vertex. Returns per surface-nets vertex its
// output vertex (remap) and per output vertex its surface-nets vertex (src).
void weld_world(const DualMesh& nv, const M4& xf, Mesh& out, std::vector<uint32_t>& remap,
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

// Does every ray of the view start outside the solid? The near plane's rectangle in view (the
// rays' starts, perspective or orthographic), grown by `grow`, in pieces each boxed around its
// 4 corners in the object's space, misses the object's box or is proven empty (f >= 0 over it)
// by interval arithmetic; false where a piece 2^-8 of the viewport across is not.
bool rays_start_outside(const Camera& cam, const M4& xf, const std::array<double, 9>& inv,
                        const implicit::Tape& clipped, const double blo[3], const double bhi[3],
                        double grow) {
  const Mat4 V = cam.view();
  const double hh = cam.projection == Camera::Projection::Perspective
                        ? cam.near_plane * std::tan(cam.fov_y_deg * M_PI / 360)
                        : cam.ortho_height / 2;
  const double hw = hh * cam.width / cam.height;
  double c0[3], dx[3], dy[3];  // the near rectangle: c0 + s dx + t dy, s, t in [0, 1]
  for (int k = 0; k < 3; ++k) {
    const double r = V[4 * k], u = V[4 * k + 1], f = -V[4 * k + 2];
    c0[k] = cam.eye[k] + cam.near_plane * f - hw * r - hh * u - xf[12 + k];
    dx[k] = 2 * hw * r;
    dy[k] = 2 * hh * u;
  }
  struct Piece {
    double s0, t0, s1, t1;
    int depth;
  };
  std::vector<Piece> todo{{0, 0, 1, 1, 0}};
  while (!todo.empty()) {
    const Piece p = todo.back();
    todo.pop_back();
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (int c = 0; c < 4; ++c) {
      double w[3];
      for (int k = 0; k < 3; ++k)
        w[k] = c0[k] + (c & 1 ? p.s1 : p.s0) * dx[k] + (c & 2 ? p.t1 : p.t0) * dy[k];
      for (int r = 0; r < 3; ++r) {
        const double o = inv[3 * r] * w[0] + inv[3 * r + 1] * w[1] + inv[3 * r + 2] * w[2];
        lo[r] = std::min(lo[r], o - grow);
        hi[r] = std::max(hi[r], o + grow);
      }
    }
    bool apart = false;
    for (int k = 0; k < 3; ++k) apart = apart || hi[k] < blo[k] || lo[k] > bhi[k];
    if (apart ||
        implicit::eval_interval(clipped, {lo[0], hi[0]}, {lo[1], hi[1]}, {lo[2], hi[2]}).lo >= 0)
      continue;
    if (p.depth == 8) return false;  // the near plane meets the solid, or nearly
    const double sm = (p.s0 + p.s1) / 2, tm = (p.t0 + p.t1) / 2;
    todo.push_back({p.s0, p.t0, sm, tm, p.depth + 1});
    todo.push_back({sm, p.t0, p.s1, tm, p.depth + 1});
    todo.push_back({p.s0, tm, sm, p.t1, p.depth + 1});
    todo.push_back({sm, tm, p.s1, p.t1, p.depth + 1});
  }
  return true;
}

// Back faces: a closed surface seen from outside hides every triangle that faces away (a ray
// reaching one from the eye has entered the solid through a front face first), so they can be
// left out when that holds: the eye outside the solid (f > 0 there), every leaf cell wholly
// beyond the near plane (the near plane cuts nothing open in view), and every ray starting
// outside the solid (rays_start_outside, with the occlusion map's margin of three leaf sides):
// with the near plane inside the solid across the whole view no leaf in view is cut by it, yet
// every ray starts inside and sees only the far surface's inner side (issue 45: a unit sphere
// from (0, 0, 1.3) with near 0.8 was diced to nothing).
bool back_faces_hidden(const ImplicitQueue& q, const implicit::Tape& clipped, const Camera& cam,
                       const M4& xf, const std::array<double, 9>& inv, const double blo[3],
                       const double bhi[3], const VmIView& sizing) {
  const std::array<float, 4> np = view_planes(cam.view_projection(), xf)[4];
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
  if (!hidden || !(implicit::eval(clipped, eo[0], eo[1], eo[2]) > 0)) return false;
  const double grow = 3 * leaf_side(sizing, cam.near_plane) + 1e-6 * (1 + cam.near_plane);
  return rays_start_outside(cam, xf, inv, clipped, blo, bhi, grow);
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
void vertex_normals(Mesh& out, const std::vector<uint32_t>& src, const DualMesh& nv,
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
  const VmIView sizing = sizing_view(v, xf, tol);
  const implicit::Tape clipped = implicit::clipped_to_box(tape, blo, bhi, 3);
  const implicit::SlotTape code = implicit::allocate_slots(clipped);
  const std::vector<std::array<float, 4>> planes = view_planes(v.cam.view_projection(), xf);
  const uint32_t syncs0 = rt.host_syncs();
  auto t0 = Clock::now();

  // The device: the region queue, each region split until it is small enough for its own depth,
  // then the leaves' corners.
  // The queue's buffers under the frame's budget where one is set (issue 35, case 3: its own
  // 4 GiB cap let RSS reach 6.4 GB against a 2 GiB budget), and the time limit per round.
  const uint64_t max_bytes = implicit_queue_cap(o.memory_budget);
  double side = 0;
  for (int k = 0; k < 3; ++k) side = std::max(side, bhi[k] - blo[k]);
  const double d_surface =
      v.persp ? surface_depth(rt, code, sizing, blo, side, max_bytes, planes, check_time, st) : 1;
  OctreeGrid g;
  std::vector<uint32_t> splits;
  plan_rounds(g, splits, sizing, blo, bhi, d_surface);
  const std::array<double, 9> inv = inverse3(xf);  // for the eye's place, the rays, the normals
  std::optional<ImplicitOcclusion> occlusion;
  // Only for a camera whose near and far are given: the frame then starts its rays on the same
  // near plane (the CLI and the server fit them to the scene before dicing).
  if (o.implicit_occlusion && cam_in.near_plane > 0 && cam_in.far_plane > 0)
    if (const auto map = occlusion_map(v, xf, inv, clipped, blo, bhi, sizing)) {
      occlusion.emplace();
      occlusion->map = *map;
      const size_t words = size_t(occlusion_bytes(*map) / 4);
      occlusion->image = rt.alloc(words * 4, "implicit depth image");
      rt.fill_u32(occlusion->image, 0x7f800000u, words, Stage::Implicit);  // +inf
    }
  const ImplicitQueue q = [&] {
    try {
      return run_implicit_queue(rt, code, g.lo, g.size, 3, splits, max_bytes, planes, check_time,
                                &sizing, occlusion ? &*occlusion : nullptr);
    } catch (const InputError& e) {  // say which object, and what would need less
      throw InputError(e.kind(), e.file(), mesh.name, e.element(), e.index(),
                       e.detail() + " (leaves down to " +
                           std::to_string(uint64_t(1) << g.levels) +
                           " cells per axis, for the depth of the nearest surface in view: a "
                           "larger implicit tolerance or a farther eye needs fewer)");
    }
  }();
  st.implicit_queue_ms += ms_since(t0);
  t0 = Clock::now();
  const OctreeLeaves cells = octree_leaves(q, g);
  count_queue(q, code, cells.finest, st);
  for (uint8_t l : cells.level) ++st.implicit_leaf_levels[l];
  for (const VmIRegion& L : q.leaves) {
    const bool first = st.implicit_leaf_side_max == 0;
    st.implicit_leaf_side_min = first ? L.size : std::min(st.implicit_leaf_side_min, double(L.size));
    st.implicit_leaf_side_max = std::max(st.implicit_leaf_side_max, double(L.size));
  }
  const std::vector<float> val =
      eval_leaf_points(rt, code, q, cells.xyz, 8, &st.launches, check_time);
  st.implicit_points_ms += ms_since(t0);
  t0 = Clock::now();

  // The host: dual contouring, welded in the world, back faces out where they cannot be seen.
  Mesh out;
  out.name = mesh.name;
  out.color = mesh.color;
  DualMesh nv = dual_contour(cells, val, g, mesh.name);
  check_time();
  out.indices = std::move(nv.indices);
  check_time();
  const double det = xf[0] * (xf[5] * xf[10] - xf[9] * xf[6]) -
                     xf[4] * (xf[1] * xf[10] - xf[9] * xf[2]) +
                     xf[8] * (xf[1] * xf[6] - xf[5] * xf[2]);
  std::vector<uint32_t> remap, src;
  weld_world(nv, xf, out, remap, src);
  check_time();
  const bool cull_back =
      !o.implicit_back_faces && back_faces_hidden(q, clipped, v.cam, xf, inv, blo, bhi, sizing);
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

}  // namespace vismap::surfaces
