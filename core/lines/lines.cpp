// extract_lines (core/lines/lines.h): the planar map's edges classified by the source triangles on
// their two sides, chained into polylines.
#include "core/lines/lines.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <tuple>

#include "core/error.h"
#include "core/lines/topology.h"
#include "core/util/conform.h"
#include "core/util/flat_map.h"
#include "core/util/weld.h"

namespace vismap {

const char* line_kind_name(LineKind k) {
  switch (k) {
    case LineKind::Contour:
      return "contour";
    case LineKind::Boundary:
      return "boundary";
    case LineKind::Crease:
      return "crease";
    case LineKind::Intersection:
      return "intersection";
    case LineKind::Border:
      return "border";
  }
  return "?";
}

namespace {

using lines_detail::pair_key;
using lines_detail::Topology;

// A map vertex that is exactly on a screen triangle's edge is within ~1e-9 px of it (the map's
// vertices are exact points rounded once to a 2^-20 grid-unit lattice, core/stages/map_build.h; the
// screen triangles' corners are grid points); other vertices are farther than this by far, but
// for edges that meet at a vertex at a vanishing angle.
constexpr double kOnLine = 1e-6;

// A point lies on a plane when it is within this fraction of the scene's extent (its bounding
// box's diagonal) of it: float coordinates hold ~6e-8 of their magnitude, so points that meet
// in the scene's file (a box's bottom at y = 0 on a floor at y = 0) do, and a fold of a dense
// scan two rings away (~1e-5 of the extent on the dragon) does not.
constexpr double kTouch = 1e-6;
// A map edge lies on a crossing line when both its ends are within this many pixels of it (the
// map's vertices are the exact points rounded to 2^-20 grid units, then welded within kOnLine).
constexpr double kOnCrossing = 4 * kOnLine;
// Two pieces of one surface meeting at a T-junction are snapped apart by up to a grid unit's
// half at each corner: their edges are looked for within this many pixels of each other.
constexpr double kSeamPx = 1.0 / 64;

double scene_extent(const Scene& scene) {
  double lo[3] = {HUGE_VAL, HUGE_VAL, HUGE_VAL}, hi[3] = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
  for (const Mesh& m : scene.meshes)
    for (size_t i = 0; i < m.positions.size(); ++i) {
      lo[i % 3] = std::min(lo[i % 3], double(m.positions[i]));
      hi[i % 3] = std::max(hi[i % 3], double(m.positions[i]));
    }
  if (!(hi[0] >= lo[0])) return 0;
  return std::hypot(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]);
}

[[noreturn]] void bad(const std::string& what) {
  throw InputError(InputErrorKind::ParseError, "lines", "", "map", -1, what);
}

struct Vec {
  double x, y, z;
};
Vec sub(Vec a, Vec b) {
  return {a.x - b.x, a.y - b.y, a.z - b.z};
}
Vec cross(Vec a, Vec b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
double dot(Vec a, Vec b) {
  return a.x * b.x + a.y * b.y + a.z * b.z;
}

// One side of a map edge: a source triangle, and the edge k of it the map edge lies on (-1:
// none).
struct Side {
  uint32_t mesh, tri;
  int edge;
};

class Classifier {
 public:
  Classifier(const PlanarMap& map, const ScreenTriangles& screen, const Scene& scene,
             const Camera& camera, const LineOptions& opts)
      : map_(map),
        st_(screen),
        scene_(scene),
        cam_(camera),
        topo_(scene.meshes.size()),
        by_source_(screen.size()),
        next_(screen.size(), kNone),
        edge_of_(screen.size()) {
    if (screen.grid_scale == 0 && screen.size() != 0) bad("screen triangles without a grid scale");
    if (screen.xy.size() != 6 * screen.size() || screen.depth.size() != 3 * screen.size() ||
        screen.triangle.size() != screen.size())
      bad("screen triangle arrays of different lengths");
    cos_crease_ = std::cos(opts.crease_angle_deg * M_PI / 180.0);
    cos_half_crease_ = std::cos(opts.crease_angle_deg * M_PI / 360.0);
    crease_smooth_ = opts.crease_smooth;
    vertex_normals_.resize(scene.meshes.size());
    self_folds_ = opts.self_folds;
    vp_ = camera.view_projection();
    for (uint32_t s = 0; s < screen.size(); ++s) {
      const uint32_t m = screen.mesh[s], t = screen.triangle[s];
      if (m >= scene.meshes.size() || t >= scene.meshes[m].triangle_count())
        bad("screen triangle " + std::to_string(s) + " names no triangle of the scene");
      auto [first, fresh] = by_source_.emplace(pair_key(m, t), s);
      if (!fresh) {
        next_[s] = next_[first];
        next_[first] = s;
      }
      edge_of_[s] = {kUnmapped, kUnmapped, kUnmapped};
    }
    crossing_ = FlatMap(screen.crossings.size());
    index_crossings();
    eps_ = kTouch * scene_extent(scene);
  }

  // The mesh edge a line lies on: mesh, and the edge's key in its Topology (kNoEdge for
  // intersection and border lines, which lie on no edge of the one mesh).
  struct Owner {
    uint32_t mesh = kNone;
    uint64_t edge = kNoEdge;
  };
  static constexpr uint64_t kNoEdge = ~uint64_t(0);

  // The kind of the map edge a-b (pixels) between fragments f and g (g = kNone: background);
  // false when it is no line (docs/LINES.md "How an edge of the map is classified").
  bool classify(const double* a, const double* b, uint32_t f, uint32_t g, LineKind& kind,
                Owner& owner) {
    owner = Owner{};
    const uint32_t m1 = map_.mesh[f], t1 = map_.triangle[f];
    auto own = [&](uint32_t m, uint32_t t, int e) {
      owner.mesh = m;
      owner.edge = topo(m).undirected(scene_.meshes[m], t, e);
    };
    if (g == kNone) {
      if (on_viewport_border(a, b)) return false;
      uint32_t s;
      const int e = source_edge(m1, t1, a, b, &s);
      if (e < 0) return false;  // the near plane's cut
      own(m1, t1, e);
      if (has_neighbour(m1, t1, e)) {
        kind = LineKind::Contour;
        return true;
      }
      return open_edge_kind({m1, t1, e}, a, b, kind);
    }
    const uint32_t m2 = map_.mesh[g], t2 = map_.triangle[g];
    if (m1 == m2 && t1 == t2) return false;
    uint32_t s1 = kNone, s2 = kNone;
    int mask1 = 0, mask2 = 0;
    const int e1 = source_edge(m1, t1, a, b, &s1, &mask1);
    const int e2 = source_edge(m2, t2, a, b, &s2, &mask2);
    const Side side[2] = {{m1, t1, e1}, {m2, t2, e2}};
    // A mesh edge both sides share: a fold, a crease or nothing; a contact where the edge
    // lies on a third surface (a box's bottom edge on the floor its bottom face ties with).
    for (int k1 = 0; k1 < 3 && m1 == m2; ++k1)
      for (int k2 = 0; k2 < 3; ++k2) {
        if (!(mask1 >> k1 & 1) || !(mask2 >> k2 & 1) || !shared_edge(m1, t1, k1, t2, k2)) continue;
        const Side x{m1, t1, k1}, y{m2, t2, k2};
        own(m1, t1, k1);
        if (!edge_kind(x, y, kind)) return false;
        if (touches_third(x, y, a, b)) kind = LineKind::Border;
        return true;
      }
    // A contact: one side's edge lies on the other surface (in 3D, so from every view alike).
    for (int i = 0; i < 2; ++i) {
      if (side[i].edge < 0 || !touches(side[i], side[1 - i], a, b)) continue;
      own(side[i].mesh, side[i].tri, side[i].edge);
      return contact_kind(side[i], side[1 - i], kind);
    }
    // On a crossing line the pipeline clipped with: the surfaces cross.
    // On a crossing line the pipeline clipped with: the surfaces cross, unless an edge of one
    // lies on the other in 3D (a box's bottom edge on the floor: the snapped depth planes cross
    // a rounding away from it), where they are in contact as above.
    if (on_crossing(s1, s2, a, b)) {
      for (int i = 0; i < 2; ++i)
        for (int k = 0; k < 3; ++k) {
          const Side x{side[i].mesh, side[i].tri, k};
          if (!edge_on(x, side[1 - i])) continue;
          own(x.mesh, x.tri, k);
          return contact_kind(x, side[1 - i], kind);
        }
      kind = LineKind::Intersection;
      return true;
    }
    if (e1 < 0 && e2 < 0) {
      // Coplanar surfaces (one plane in 3D) that the tie rule orders cyclically, cut by a
      // third pair's line: one surface, no line.
      if (coplanar(side[0], side[1])) return false;
      ++unplaced;
      return false;
    }
    // One surface ends here in front of the other. The owner: the nearer side when both lie on
    // an edge of theirs, else the one that does.
    const double mx = (a[0] + b[0]) / 2, my = (a[1] + b[1]) / 2;
    const bool first = e1 >= 0 && (e2 < 0 || nearness(s1, mx, my) > nearness(s2, mx, my));
    const Side& n = side[first ? 0 : 1];
    // Unless the surface goes on across n's edge (no fold there) and what shows beyond is the
    // same surface within two rings, less than a pixel from the edge: a neighbour too thin to
    // show (a sliver snapped to nothing) lies between them, and there is no line.
    if (!ends_at(n) && continues_into(n, side[first ? 1 : 0], a, b)) return false;
    own(n.mesh, n.tri, n.edge);
    if (has_neighbour(n.mesh, n.tri, n.edge)) {
      // Selection (LineOptions::self_folds): a contour where what shows beyond is its own
      // surface within two rings separates nothing but the two sides of a fold smaller than
      // its triangles.
      const Side& o = side[first ? 1 : 0];
      if (!self_folds_ && o.mesh == n.mesh && (near_on_mesh(n, o.tri) || grid_fold(n, o, a, b)))
        return false;
      kind = LineKind::Contour;
      return true;
    }
    return open_edge_kind(n, a, b, kind);
  }

  // The edge lines of mesh m that a view can have (contour, boundary, crease: from the mesh,
  // not the map), each as its projected segment clipped to the view volume, in pixels on the
  // pipeline's grid (snapped as transform.cl snaps corners). Calls f(kind, edge key, a, b).
  template <class F>
  void for_each_edge_line(uint32_t m, F&& f) {
    const Mesh& mesh = scene_.meshes[m];
    const Topology& T = topo(m);
    const size_t ne = T.uses.size();
    std::vector<uint64_t> keys(ne);
    for (size_t t = 0; t < mesh.triangle_count(); ++t)
      for (int k = 0; k < 3; ++k) {
        const uint64_t key = T.undirected(mesh, t, k);
        keys[*T.edge.find(key)] = key;
      }
    for (size_t e = 0; e < ne; ++e) {
      if (T.uses[e] > 2) continue;  // non-manifold: no one kind
      const uint32_t t1 = T.tris[2 * e], t2 = T.tris[2 * e + 1];
      const int k1 = T.side[e];
      LineKind kind;
      if (T.uses[e] == 1) {
        kind = LineKind::Boundary;
      } else {
        int k2 = 0;
        while (k2 < 2 && T.undirected(mesh, t2, k2) != keys[e]) ++k2;
        if (!edge_kind({m, t1, k1}, {m, t2, k2}, kind)) continue;
      }
      double a[2], b[2];
      if (!project_edge(mesh, t1, k1, a, b)) continue;
      f(kind, keys[e], a, b);
    }
  }

  static constexpr uint32_t kNone = ~0u;
  uint64_t unplaced = 0;  // map edges between two surfaces no rule places (docs/LINES.md)

 private:
  static constexpr int8_t kUnmapped = -2, kClip = -1;
  static constexpr double kGrid = 256;  // VM_GRID_SCALE (kernels/layout.h)

  // Edge k of triangle t clipped to the view volume (clip space, as transform.cl clips) and
  // projected; false when nothing of it is in view.
  bool project_edge(const Mesh& mesh, uint32_t t, int k, double* a, double* b) const {
    double c[2][4];
    for (int e = 0; e < 2; ++e) {
      const float* p = &mesh.positions[3 * size_t(mesh.indices[3 * size_t(t) + (k + e) % 3])];
      for (int r = 0; r < 4; ++r)
        c[e][r] = vp_[r] * p[0] + vp_[4 + r] * p[1] + vp_[8 + r] * p[2] + vp_[12 + r];
    }
    double t0 = 0, t1 = 1;
    for (int pl = 0; pl < 6; ++pl) {
      auto dist = [pl](const double* q) {
        const double s = pl & 1 ? -1 : 1;
        return q[3] + s * q[pl / 2 == 0 ? 2 : pl / 2 == 1 ? 0 : 1];
      };
      const double d0 = dist(c[0]), d1 = dist(c[1]);
      if (d0 < 0 && d1 < 0) return false;
      if (d0 < 0) t0 = std::max(t0, d0 / (d0 - d1));
      if (d1 < 0) t1 = std::min(t1, d0 / (d0 - d1));
    }
    if (!(t0 < t1)) return false;
    const double G = st_.grid_scale ? st_.grid_scale : kGrid;
    auto put = [&](double u, double* out) {
      double q[4];
      for (int r = 0; r < 4; ++r) q[r] = c[0][r] + u * (c[1][r] - c[0][r]);
      const double sx = map_.width * G * 0.5, sy = map_.height * G * 0.5;
      out[0] = std::clamp(std::rint((q[0] / q[3] + 1.0) * sx), 0.0, map_.width * G) / G;
      out[1] = std::clamp(std::rint((1.0 - q[1] / q[3]) * sy), 0.0, map_.height * G) / G;
    };
    put(t0, a);
    put(t1, b);
    return true;
  }

  bool on_viewport_border(const double* a, const double* b) const {
    const double W = map_.width, H = map_.height, e = 1e-9;
    auto at = [e](double u, double v) { return std::abs(u - v) <= e; };
    return (at(a[0], 0) && at(b[0], 0)) || (at(a[0], W) && at(b[0], W)) ||
           (at(a[1], 0) && at(b[1], 0)) || (at(a[1], H) && at(b[1], H));
  }

  const Topology& topo(uint32_t m) {
    if (!topo_[m].built) topo_[m].build(scene_.meshes[m]);
    return topo_[m];
  }

  // Corner k of triangle t as homogeneous pixel coordinates (x, y, w): x = (cx/cw + 1) W/2
  // etc. times cw.
  void homog(const Mesh& mesh, uint32_t t, int k, double* h) const {
    const float* p = &mesh.positions[3 * size_t(mesh.indices[3 * size_t(t) + k])];
    double c[4];
    for (int r = 0; r < 4; ++r)
      c[r] = vp_[r] * p[0] + vp_[4 + r] * p[1] + vp_[8 + r] * p[2] + vp_[12 + r];
    h[0] = (c[0] + c[3]) * 0.5 * map_.width;
    h[1] = (c[3] - c[1]) * 0.5 * map_.height;
    h[2] = c[3];
  }

  // Which source edge (k: vertices k, k+1) each edge of screen triangle s lies on; kClip where
  // it lies on none (a cut of the view volume's planes). Tested against the source edge's line
  // in homogeneous screen coordinates, which stays right when a corner is behind the eye: the
  // screen edge's ends are grid points (snapped corners or clip points), within 1/(2G) px per
  // axis of that line when they are on it.
  const std::array<int8_t, 3>& edges_of(uint32_t s) {
    std::array<int8_t, 3>& e = edge_of_[s];
    if (e[0] != kUnmapped) return e;
    const Mesh& mesh = scene_.meshes[st_.mesh[s]];
    double h[3][3];
    for (int k = 0; k < 3; ++k) homog(mesh, st_.triangle[s], k, h[k]);
    double line[3][3], norm[3];
    for (int k = 0; k < 3; ++k) {
      const double* a = h[k];
      const double* b = h[(k + 1) % 3];
      line[k][0] = a[1] * b[2] - a[2] * b[1];
      line[k][1] = a[2] * b[0] - a[0] * b[2];
      line[k][2] = a[0] * b[1] - a[1] * b[0];
      norm[k] = std::hypot(line[k][0], line[k][1]);
    }
    const double g = st_.grid_scale, tol = 2.0 / g;
    for (int i = 0; i < 3; ++i) {
      e[i] = kClip;
      double best = tol;
      for (int k = 0; k < 3; ++k) {
        if (!(norm[k] > 0)) continue;
        double worst = 0;
        for (int j = 0; j < 2; ++j) {
          const int c = (i + j) % 3;
          const double x = st_.xy[6 * size_t(s) + 2 * c] / g,
                       y = st_.xy[6 * size_t(s) + 2 * c + 1] / g;
          worst = std::max(worst, std::abs(line[k][0] * x + line[k][1] * y + line[k][2]) / norm[k]);
        }
        if (worst < best) best = worst, e[i] = int8_t(k);
      }
    }
    return e;
  }

  // The edge k of source (m, t) the segment a-b lies on (through any of its screen triangles),
  // or -1; *s: the screen triangle it was found in (the first one, when none).
  // *mask (if given): a bit for each source edge it lies on (a needle's edges may all be one
  // line on the screen).
  int source_edge(uint32_t m, uint32_t t, const double* a, const double* b, uint32_t* s_out,
                  int* mask = nullptr) {
    const uint32_t* first = by_source_.find(pair_key(m, t));
    if (!first)
      bad("a fragment of mesh " + std::to_string(m) + " triangle " + std::to_string(t) +
          " has no screen triangle");
    *s_out = *first;
    int found = -1;
    if (mask) *mask = 0;
    const double g = st_.grid_scale;
    for (uint32_t s = *first; s != kNone; s = next_[s]) {
      const int32_t* v = &st_.xy[6 * size_t(s)];
      for (int i = 0; i < 3; ++i) {
        const double px = v[2 * i] / g, py = v[2 * i + 1] / g;
        const double dx = v[2 * ((i + 1) % 3)] / g - px, dy = v[2 * ((i + 1) % 3) + 1] / g - py;
        const double len = std::hypot(dx, dy);
        if (!(len > 0)) continue;
        auto on = [&](const double* p) {
          const double ux = p[0] - px, uy = p[1] - py;
          if (std::abs(dx * uy - dy * ux) > kOnLine * len) return false;
          const double along = (dx * ux + dy * uy) / len;
          return along >= -kOnLine && along <= len + kOnLine;
        };
        if (!on(a) || !on(b)) continue;
        const int k = edges_of(s)[i];
        if (found == -1) {
          if (k < 0 && !mask) return -1;
          *s_out = s;
          found = k < 0 ? -2 : k;
        }
        if (!mask) return found;
        if (k >= 0) *mask |= 1 << k;
      }
    }
    return found < 0 ? -1 : found;
  }

  // A diced implicit (Mesh::normals given) is the boundary of a solid whose back faces the
  // dicer left out where they cannot be seen (core/surfaces/implicit3d.cpp): its open edges had
  // a neighbour, facing away.
  bool has_neighbour(uint32_t m, uint32_t t, int k) {
    return !scene_.meshes[m].normals.empty() || topo(m).edge_uses(scene_.meshes[m], t, k) >= 2;
  }

  bool shared_edge(uint32_t m, uint32_t t1, int k1, uint32_t t2, int k2) {
    const Topology& T = topo(m);
    const Mesh& mesh = scene_.meshes[m];
    return T.undirected(mesh, t1, k1) == T.undirected(mesh, t2, k2);
  }

  Vec position(const Mesh& m, uint32_t t, int k) const {
    const float* p = &m.positions[3 * size_t(m.indices[3 * size_t(t) + k])];
    return {p[0], p[1], p[2]};
  }
  Vec normal(const Mesh& m, uint32_t t) const {
    const Vec p0 = position(m, t, 0);
    return cross(sub(position(m, t, 1), p0), sub(position(m, t, 2), p0));
  }
  // Positive when triangle t of m shows the side its normal points to.
  double facing(const Mesh& m, uint32_t t) const {
    const Vec n = normal(m, t);
    if (cam_.projection == Camera::Projection::Orthographic)
      return -dot(n, sub({cam_.target[0], cam_.target[1], cam_.target[2]},
                         {cam_.eye[0], cam_.eye[1], cam_.eye[2]}));
    return dot(n, sub({cam_.eye[0], cam_.eye[1], cam_.eye[2]}, position(m, t, 0)));
  }

  Vec edge_dir(const Side& x) const {
    const Mesh& mesh = scene_.meshes[x.mesh];
    return sub(position(mesh, x.tri, (x.edge + 1) % 3), position(mesh, x.tri, x.edge));
  }
  // x and y (one mesh) meet along their edges x.edge and y.edge: shared, or collinear in 3D (a
  // seam between pieces of one surface). With y's orientation made consistent with x's across
  // the edge (a soup need not be: consistent when the two run it opposite ways), does one face
  // the eye and the other away? *cosang: the cosine of the angle between their normals.
  bool facing_differs(const Side& x, const Side& y, double* cosang) const {
    const Mesh& mesh = scene_.meshes[x.mesh];
    const double flip = dot(edge_dir(x), edge_dir(y)) > 0 ? -1 : 1;
    const Vec n1 = normal(mesh, x.tri), n2 = normal(mesh, y.tri);
    const double l = std::sqrt(dot(n1, n1) * dot(n2, n2));
    *cosang = l > 0 ? flip * dot(n1, n2) / l : 1.0;
    const double f1 = facing(mesh, x.tri), f2 = flip * facing(mesh, y.tri);
    return (f1 > 0) != (f2 > 0);
  }
  // Rule 4's kinds for an edge x and y meet along: contour at a fold, crease past the crease
  // angle, else false (no line).
  // With LineOptions::crease_smooth, a crease also needs the smoothed normals of the two faces
  // to differ by more than half the crease angle.
  bool edge_kind(const Side& x, const Side& y, LineKind& kind) {
    double cosang;
    if (facing_differs(x, y, &cosang))
      kind = LineKind::Contour;
    else if (cosang < cos_crease_ && (!crease_smooth_ || smoothed_cos(x, y) < cos_half_crease_))
      kind = LineKind::Crease;
    else
      return false;
    return true;
  }
  // The cosine of the angle between x's and y's smoothed normals (orientations made consistent
  // across their edge as facing_differs does): each the sum of its corners' vertex normals, a
  // vertex normal the sum of the area-weighted normals of the triangles around it.
  double smoothed_cos(const Side& x, const Side& y) {
    const Mesh& mesh = scene_.meshes[x.mesh];
    const Topology& T = topo(x.mesh);
    std::vector<Vec>& vn = vertex_normals_[x.mesh];
    if (vn.empty()) {
      vn.assign(mesh.vertex_count(), Vec{0, 0, 0});
      for (size_t t = 0; t < mesh.triangle_count(); ++t) {
        const Vec n = normal(mesh, uint32_t(t));
        for (int k = 0; k < 3; ++k) {
          Vec& v = vn[T.vertex(mesh, t, k)];
          v = {v.x + n.x, v.y + n.y, v.z + n.z};
        }
      }
    }
    auto smooth = [&](uint32_t t) {
      Vec s{0, 0, 0};
      for (int k = 0; k < 3; ++k) {
        const Vec& v = vn[T.vertex(mesh, t, k)];
        s = {s.x + v.x, s.y + v.y, s.z + v.z};
      }
      return s;
    };
    const double flip = dot(edge_dir(x), edge_dir(y)) > 0 ? -1 : 1;
    const Vec a = smooth(x.tri), b = smooth(y.tri);
    const double l = std::sqrt(dot(a, a) * dot(b, b));
    return l > 0 ? flip * dot(a, b) / l : 1.0;
  }

  // --- Contacts: where one surface's edge lies on another surface in 3D. ---

  // The point of x's edge (in the world) that projects to p (pixels): the edge's parameter
  // solved in homogeneous coordinates, where it is affine.
  Vec on_edge(const Side& x, const double* p) const {
    const Mesh& mesh = scene_.meshes[x.mesh];
    double h0[3], h1[3];
    homog(mesh, x.tri, x.edge, h0);
    homog(mesh, x.tri, (x.edge + 1) % 3, h1);
    // p.x (w0 + u dw) = x0 + u dx, the same in y: the better conditioned of the two.
    const double dnx = (h1[0] - h0[0]) - p[0] * (h1[2] - h0[2]);
    const double dny = (h1[1] - h0[1]) - p[1] * (h1[2] - h0[2]);
    double u = std::abs(dnx) >= std::abs(dny) ? (p[0] * h0[2] - h0[0]) / dnx
                                              : (p[1] * h0[2] - h0[1]) / dny;
    if (!std::isfinite(u)) u = 0.5;
    u = std::clamp(u, 0.0, 1.0);
    const Vec p0 = position(mesh, x.tri, x.edge), d = edge_dir(x);
    return {p0.x + u * d.x, p0.y + u * d.y, p0.z + u * d.z};
  }
  // Does x's edge, along the map edge a-b, lie on y's surface (its plane, within the scene's
  // tolerance)? Within one mesh, not where y is within two rings of the edge (a vertex of y at
  // or next to one of the edge's): there the surface folds, it does not meet itself.
  // (A seam, where y's edge holds x's edge in 3D, is a contact however near.)
  bool touches(const Side& x, const Side& y, const double* a, const double* b) {
    if (x.mesh == y.mesh && near_on_mesh(x, y.tri)) return y.edge >= 0 && on_edge_line(x, y, a, b);
    return on_plane(x, y, a, b);
  }
  // Do the points of x's edge at a quarter and three quarters of the map edge a-b lie on y's
  // edge (the segment, in 3D)?
  // (A degenerate y, its corners in a line, holds every edge along it and is no partner.) The
  // two edges must run along one line, not merely pass near each other where they meet.
  bool on_edge_line(const Side& x, const Side& y, const double* a, const double* b) const {
    const Vec p0 = position(scene_.meshes[y.mesh], y.tri, y.edge), d = edge_dir(y);
    const double l2 = dot(d, d);
    if (!(l2 > 0) || degenerate(y)) return false;
    // Parallel within 1e-5 radians (float corners: ~1e-7).
    const Vec dx = edge_dir(x), c = cross(dx, d);
    if (dot(c, c) > 1e-10 * dot(dx, dx) * l2) return false;
    for (double u : {0.25, 0.75}) {
      const double p[2] = {a[0] + u * (b[0] - a[0]), a[1] + u * (b[1] - a[1])};
      const Vec q = sub(on_edge(x, p), p0);
      const double t = std::clamp(dot(q, d) / l2, 0.0, 1.0);
      const Vec r = sub(q, {t * d.x, t * d.y, t * d.z});
      if (dot(r, r) > eps_ * eps_) return false;
    }
    return true;
  }
  // Do the points of x's edge at a quarter and three quarters of the map edge a-b lie on y's
  // plane?
  bool on_plane(const Side& x, const Side& y, const double* a, const double* b) const {
    for (double u : {0.25, 0.75}) {
      const double p[2] = {a[0] + u * (b[0] - a[0]), a[1] + u * (b[1] - a[1])};
      if (!on_plane_of(y, on_edge(x, p))) return false;
    }
    return true;
  }
  // Is the point p within eps_ of y's plane (never, for a triangle with no area)?
  bool on_plane_of(const Side& y, const Vec& p) const {
    const Mesh& mesh = scene_.meshes[y.mesh];
    const Vec n = normal(mesh, y.tri);
    const double ln = std::sqrt(dot(n, n));
    return ln > 0 && std::abs(dot(n, sub(p, position(mesh, y.tri, 0)))) <= eps_ * ln;
  }
  // The square of x's triangle's longest edge.
  double longest_edge2(const Side& x) const {
    double l2 = 0;
    for (int k = 0; k < 3; ++k) {
      const Vec d = edge_dir({x.mesh, x.tri, k});
      l2 = std::max(l2, dot(d, d));
    }
    return l2;
  }
  // Does the surface end at x's edge in 3D: no neighbour there, more than one, or one facing
  // the other way (a contour edge)?
  bool ends_at(const Side& x) {
    const Mesh& mesh = scene_.meshes[x.mesh];
    const Topology& T = topo(x.mesh);
    const uint64_t key = T.undirected(mesh, x.tri, x.edge);
    const uint32_t id = *T.edge.find(key);
    if (T.uses[id] != 2) return true;
    const uint32_t o =
        T.tris[2 * size_t(id)] == x.tri ? T.tris[2 * size_t(id) + 1] : T.tris[2 * size_t(id)];
    int k = 0;
    while (k < 2 && T.undirected(mesh, o, k) != key) ++k;
    double cosang;
    return facing_differs(x, {x.mesh, o, k}, &cosang);
  }
  // Does y (x's mesh, within two rings of x's edge) touch x's edge along the map edge a-b?
  bool continues_into(const Side& x, const Side& y, const double* a, const double* b) {
    return x.mesh == y.mesh && near_on_mesh(x, y.tri) && on_plane(x, y, a, b);
  }
  // Is x's triangle (nearly) a segment: its area under 1e-9 of its longest edge squared?
  bool degenerate(const Side& x) const {
    const Vec n = normal(scene_.meshes[x.mesh], x.tri);
    return std::sqrt(dot(n, n)) <= 1e-9 * longest_edge2(x);
  }
  // Do x's and y's triangles lie in one plane (y's corners on x's plane)?
  bool coplanar(const Side& x, const Side& y) const {
    const Mesh& my = scene_.meshes[y.mesh];
    for (int k = 0; k < 3; ++k)
      if (!on_plane_of(x, position(my, y.tri, k))) return false;
    return true;
  }
  // Does x's whole edge lie on y's plane (same tolerance and rings as touches())?
  bool edge_on(const Side& x, const Side& y) {
    if (x.mesh == y.mesh && near_on_mesh(x, y.tri)) return false;
    const Mesh& mx = scene_.meshes[x.mesh];
    return on_plane_of(y, position(mx, x.tri, x.edge)) &&
           on_plane_of(y, position(mx, x.tri, (x.edge + 1) % 3));
  }
  // On a diced implicit, is what shows beyond x's edge (y, along the view ray through the map
  // edge's midpoint) nearer to the edge in 3D than x's longest edge? The dicer's cells are about
  // that size and its surface is within sqrt(3) cells of f = 0 (core/surfaces/implicit3d.cpp):
  // such a fold is the grid's, not the surface's (a sheet where f touches 0 without changing
  // sign: the architecture model's slabs meeting at x = 0 leave a groove one cell deep).
  bool grid_fold(const Side& x, const Side& y, const double* a, const double* b) {
    if (scene_.meshes[x.mesh].normals.empty()) return false;
    const double m[2] = {(a[0] + b[0]) / 2, (a[1] + b[1]) / 2};
    const Vec p = on_edge(x, m);
    const Mesh& my = scene_.meshes[y.mesh];
    const Vec n = normal(my, y.tri), p0 = position(my, y.tri, 0);
    const Vec eye{cam_.eye[0], cam_.eye[1], cam_.eye[2]};
    const Vec dir = cam_.projection == Camera::Projection::Orthographic
                        ? sub({cam_.target[0], cam_.target[1], cam_.target[2]}, eye)
                        : sub(p, eye);
    const double nd = dot(n, dir);
    if (!(std::abs(nd) > 0)) return false;
    const double s = dot(n, sub(p0, p)) / nd;  // p + s dir lies on y's plane
    const double gap = std::abs(s) * std::sqrt(dot(dir, dir));
    return gap < std::sqrt(longest_edge2(x));
  }
  bool near_on_mesh(const Side& x, uint32_t t) {
    const Mesh& mesh = scene_.meshes[x.mesh];
    const Topology& T = topo(x.mesh);
    const uint32_t u = T.vertex(mesh, x.tri, x.edge), v = T.vertex(mesh, x.tri, (x.edge + 1) % 3);
    for (int k = 0; k < 3; ++k)
      if (T.adjacent(T.vertex(mesh, t, k), u) || T.adjacent(T.vertex(mesh, t, k), v)) return true;
    return false;
  }
  // Does x's edge (shared with y) lie on a third surface that the map edge a-b passes over on
  // the screen? (A box's bottom face ties with the floor under it: the floor is not on either
  // side of the box's bottom edge there, but the edge stands on it all the same.)
  bool touches_third(const Side& x, const Side& y, const double* a, const double* b) {
    const double mx = (a[0] + b[0]) / 2, my = (a[1] + b[1]) / 2;
    bool hit = false;
    for_each_covering(mx, my, [&](uint32_t s) {
      const uint32_t m = st_.mesh[s], t = st_.triangle[s];
      if (hit || (m == x.mesh && (t == x.tri || t == y.tri))) return;
      hit = touches(x, {m, t, -1}, a, b);
    });
    return hit;
  }
  // A triangle y of x's mesh (within kSeamPx on the screen) with an edge that holds x's edge
  // along the map edge a-b in 3D: the other side of a T-junction (pieces of one surface not
  // welded, whose snapped corners leave a crack a rounding wide between them).
  bool seam_partner(const Side& x, const double* a, const double* b, Side& y) {
    bool found = false;
    for_each_covering((a[0] + b[0]) / 2, (a[1] + b[1]) / 2,
                      [&](uint32_t s) {
                        if (found || st_.mesh[s] != x.mesh || st_.triangle[s] == x.tri) return;
                        for (int k = 0; k < 3 && !found; ++k) {
                          const Side c{x.mesh, st_.triangle[s], k};
                          if (on_edge_line(x, c, a, b)) y = c, found = true;
                        }
                      },
                      kSeamPx);
    return found;
  }
  // The kind of an edge with no neighbour in its mesh (by position): a boundary, unless it is
  // a seam (seam_partner), then as if the two shared it (false: no line).
  bool open_edge_kind(const Side& x, const double* a, const double* b, LineKind& kind) {
    Side y;
    if (!seam_partner(x, a, b, y)) {
      kind = LineKind::Boundary;
      return true;
    }
    return edge_kind(x, y, kind);
  }
  // The kind of a contact: x's edge lies on y's surface. Two meshes meet: border. Pieces of one
  // mesh: along y's edge too (a seam, the pieces not welded), as if they shared the edge (a
  // fold, a crease or nothing); inside y's face, nothing where they are coplanar (within the
  // crease angle), else border.
  bool contact_kind(const Side& x, const Side& y, LineKind& kind) {
    if (x.mesh != y.mesh) {
      kind = LineKind::Border;
      return true;
    }
    if (y.edge >= 0) return edge_kind(x, y, kind);
    const Mesh& mesh = scene_.meshes[x.mesh];
    const Vec n1 = normal(mesh, x.tri), n2 = normal(mesh, y.tri);
    const double l = std::sqrt(dot(n1, n1) * dot(n2, n2));
    if (l > 0 && std::abs(dot(n1, n2)) / l >= cos_crease_) return false;
    kind = LineKind::Border;
    return true;
  }
  // Calls f(s) for each screen triangle whose closure holds (x, y) pixels (within tol px, at
  // most a cell).
  template <class F>
  void for_each_covering(double x, double y, F&& f, double tol = kOnLine) {
    if (cell_start_.empty()) build_cells();
    const int cx = std::clamp(int(x / kCell), 0, cells_x_ - 1);
    const int cy = std::clamp(int(y / kCell), 0, cells_y_ - 1);
    const size_t c = size_t(cy) * cells_x_ + cx;
    const double g = st_.grid_scale;
    for (uint32_t i = cell_start_[c]; i < cell_start_[c + 1]; ++i) {
      const uint32_t s = cell_tris_[i];
      const int32_t* v = &st_.xy[6 * size_t(s)];
      const double area = double(v[2] - v[0]) * (v[5] - v[1]) - double(v[4] - v[0]) * (v[3] - v[1]);
      if (area == 0) continue;
      bool in = true;
      for (int k = 0; k < 3 && in; ++k) {
        const double px = v[2 * k] / g, py = v[2 * k + 1] / g;
        const double dx = v[2 * ((k + 1) % 3)] / g - px, dy = v[2 * ((k + 1) % 3) + 1] / g - py;
        const double side = (dx * (y - py) - dy * (x - px)) * (area > 0 ? 1 : -1);
        in = side >= -tol * std::hypot(dx, dy);
      }
      if (in) f(s);
    }
  }
  void build_cells() {
    cells_x_ = std::max(1, int(std::ceil(map_.width / kCell)));
    cells_y_ = std::max(1, int(std::ceil(map_.height / kCell)));
    const double g = st_.grid_scale;
    auto range = [&](uint32_t s, int& x0, int& y0, int& x1, int& y1) {
      const int32_t* v = &st_.xy[6 * size_t(s)];
      const double lx = std::min({v[0], v[2], v[4]}) / g, hx = std::max({v[0], v[2], v[4]}) / g;
      const double ly = std::min({v[1], v[3], v[5]}) / g, hy = std::max({v[1], v[3], v[5]}) / g;
      const double m = kSeamPx;
      x0 = std::clamp(int(std::floor((lx - m) / kCell)), 0, cells_x_ - 1);
      x1 = std::clamp(int(std::floor((hx + m) / kCell)), 0, cells_x_ - 1);
      y0 = std::clamp(int(std::floor((ly - m) / kCell)), 0, cells_y_ - 1);
      y1 = std::clamp(int(std::floor((hy + m) / kCell)), 0, cells_y_ - 1);
    };
    cell_start_.assign(size_t(cells_x_) * cells_y_ + 1, 0);
    for (int pass = 0; pass < 2; ++pass) {
      std::vector<uint32_t> fill;
      if (pass) {
        for (size_t c = 1; c < cell_start_.size(); ++c) cell_start_[c] += cell_start_[c - 1];
        fill.assign(cell_start_.begin(), cell_start_.end() - 1);
        cell_tris_.resize(cell_start_.back());
      }
      for (uint32_t s = 0; s < st_.size(); ++s) {
        int x0, y0, x1, y1;
        range(s, x0, y0, x1, y1);
        for (int y = y0; y <= y1; ++y)
          for (int x = x0; x <= x1; ++x) {
            const size_t c = size_t(y) * cells_x_ + x;
            if (pass)
              cell_tris_[fill[c]++] = s;
            else
              ++cell_start_[c + 1];
          }
      }
    }
  }

  // --- Crossings: the lines the pipeline clipped penetrating pairs with. ---

  void index_crossings() {
    const auto& X = st_.crossings;
    crossing_next_.assign(X.size(), kNone);
    for (uint32_t i = 0; i < X.size(); ++i) {
      const uint32_t* s0 = by_source_.find(pair_key(X[i].mesh[0], X[i].triangle[0]));
      const uint32_t* s1 = by_source_.find(pair_key(X[i].mesh[1], X[i].triangle[1]));
      if (!s0 || !s1) bad("a crossing names a triangle with no screen triangle");
      auto [first, fresh] = crossing_.emplace(pair_key(std::min(*s0, *s1), std::max(*s0, *s1)), i);
      if (!fresh) {
        crossing_next_[i] = crossing_next_[first];
        crossing_next_[first] = i;
      }
    }
  }
  // Does the map edge a-b lie on a crossing line of the sources of screen triangles s1, s2?
  // (A source pair split into several screen triangles, by the view volume's planes, has a
  // line for each piece, snapped alike but not exactly one: where two pieces meet, a map edge
  // a rounding long may join the two lines, an end on each.)
  bool on_crossing(uint32_t s1, uint32_t s2, const double* a, const double* b) const {
    const uint32_t f1 = *by_source_.find(pair_key(st_.mesh[s1], st_.triangle[s1]));
    const uint32_t f2 = *by_source_.find(pair_key(st_.mesh[s2], st_.triangle[s2]));
    const uint32_t* first = crossing_.find(pair_key(std::min(f1, f2), std::max(f1, f2)));
    const double g = st_.grid_scale, tol = kOnCrossing * g;
    bool on_a = false, on_b = false;
    for (uint32_t i = first ? *first : kNone; i != kNone; i = crossing_next_[i]) {
      const ScreenTriangles::Crossing& c = st_.crossings[i];
      const long double A = c.a, B = c.b, C = c.c, n = std::hypot(double(c.a), double(c.b));
      auto on = [&](const double* p) {
        return n > 0 &&
               double(std::abs(A * (long double)(p[0] * g) + B * (long double)(p[1] * g) + C)) <=
                   tol * n;
      };
      on_a |= on(a);
      on_b |= on(b);
    }
    return on_a && on_b;
  }

  // The nearness at (x, y) pixels on screen triangle s's depth plane.
  double nearness(uint32_t s, double x, double y) const {
    const double g = st_.grid_scale;
    const int32_t* v = &st_.xy[6 * size_t(s)];
    const double* q = &st_.depth[3 * size_t(s)];
    const double x0 = v[0] / g, y0 = v[1] / g, x1 = v[2] / g, y1 = v[3] / g, x2 = v[4] / g,
                 y2 = v[5] / g;
    const double d = (x1 - x0) * (y2 - y0) - (x2 - x0) * (y1 - y0);
    if (!(d != 0)) return q[0];
    const double l1 = ((x - x0) * (y2 - y0) - (x2 - x0) * (y - y0)) / d;
    const double l2 = ((x1 - x0) * (y - y0) - (x - x0) * (y1 - y0)) / d;
    return q[0] + l1 * (q[1] - q[0]) + l2 * (q[2] - q[0]);
  }

  const PlanarMap& map_;
  const ScreenTriangles& st_;
  const Scene& scene_;
  const Camera& cam_;
  std::vector<Topology> topo_;
  FlatMap by_source_;
  std::vector<uint32_t> next_;
  std::vector<std::array<int8_t, 3>> edge_of_;
  Mat4 vp_{};
  double cos_crease_ = 0;
  bool self_folds_ = false;
  bool crease_smooth_ = false;
  double cos_half_crease_ = 1;
  std::vector<std::vector<Vec>> vertex_normals_;  // per mesh, by canonical vertex (smoothed_cos)
  double eps_ = 0;       // a point within this of a plane is on it (world units)
  FlatMap crossing_{0};  // (first screen triangle of each source, lower first) -> a crossing
  std::vector<uint32_t> crossing_next_;
  static constexpr double kCell = 4;  // pixels per cell of the covering index
  int cells_x_ = 0, cells_y_ = 0;
  std::vector<uint32_t> cell_start_, cell_tris_;
};

// Douglas-Peucker on pts[i0..i1] (indices into xy), keeping both ends; appends kept interior
// points in order to `keep`.
void simplify(const std::vector<double>& xy, const std::vector<uint32_t>& pts, size_t i0, size_t i1,
              double tol, std::vector<uint32_t>& keep) {
  if (i1 <= i0 + 1) return;
  const double ax = xy[2 * pts[i0]], ay = xy[2 * pts[i0] + 1];
  const double dx = xy[2 * pts[i1]] - ax, dy = xy[2 * pts[i1] + 1] - ay;
  const double len = std::hypot(dx, dy);
  double worst = -1;
  size_t at = i0;
  for (size_t i = i0 + 1; i < i1; ++i) {
    const double ux = xy[2 * pts[i]] - ax, uy = xy[2 * pts[i] + 1] - ay;
    const double d = len > 0 ? std::abs(dx * uy - dy * ux) / len : std::hypot(ux, uy);
    if (d > worst) worst = d, at = i;
  }
  if (worst <= tol) return;
  simplify(xy, pts, i0, at, tol, keep);
  keep.push_back(pts[at]);
  simplify(xy, pts, at, i1, tol, keep);
}

struct Seg {
  uint32_t a, b;
};

// Chains: maximal paths of segs (over points xy) through points where exactly two of them
// meet, appended to out as chains of this kind.
void chain(const std::vector<double>& xy, const std::vector<Seg>& S, LineKind kind, bool hidden,
           double simplify_px, double min_length_px, LineSet& out) {
  if (S.empty()) return;
  const size_t nv = xy.size() / 2;
  std::vector<uint32_t> start(nv + 1, 0), inc(2 * S.size()), pts, keep;
  for (const Seg& s : S) ++start[s.a + 1], ++start[s.b + 1];
  for (size_t v = 0; v < nv; ++v) start[v + 1] += start[v];
  {
    std::vector<uint32_t> fill(start.begin(), start.end() - 1);
    for (uint32_t i = 0; i < S.size(); ++i) inc[fill[S[i].a]++] = i, inc[fill[S[i].b]++] = i;
  }
  std::vector<uint8_t> used(S.size(), 0);
  auto degree = [&](uint32_t v) { return start[v + 1] - start[v]; };
  // Where more than two meet, a chain goes on through the straightest pair (turning by less
  // than 30 degrees), pairs taken straightest first: a T-junction's through line stays one
  // chain and its stem ends there. partner[r]: the segment incidence r continues into.
  std::vector<uint32_t> partner(inc.size(), ~0u);
  {
    std::vector<std::tuple<double, uint32_t, uint32_t>> pairs;
    std::vector<std::array<double, 2>> dir;
    for (uint32_t v = 0; v < nv; ++v) {
      const uint32_t d = degree(v);
      if (d == 2) {
        partner[start[v]] = inc[start[v] + 1];
        partner[start[v] + 1] = inc[start[v]];
      }
      if (d < 3) continue;
      dir.clear();
      for (uint32_t r = start[v]; r < start[v + 1]; ++r) {
        const Seg& g = S[inc[r]];
        const uint32_t w = g.a == v ? g.b : g.a;
        const double dx = xy[2 * w] - xy[2 * v], dy = xy[2 * w + 1] - xy[2 * v + 1];
        const double l = std::hypot(dx, dy);
        dir.push_back({l > 0 ? dx / l : 0, l > 0 ? dy / l : 0});
      }
      pairs.clear();
      for (uint32_t i = 0; i < d; ++i)
        for (uint32_t j = i + 1; j < d; ++j) {
          const double c = dir[i][0] * dir[j][0] + dir[i][1] * dir[j][1];
          if (c < -0.866) pairs.emplace_back(c, i, j);
        }
      std::sort(pairs.begin(), pairs.end());
      for (const auto& [c, i, j] : pairs) {
        if (partner[start[v] + i] != ~0u || partner[start[v] + j] != ~0u) continue;
        partner[start[v] + i] = inc[start[v] + j];
        partner[start[v] + j] = inc[start[v] + i];
      }
    }
  }
  auto emit = [&](bool closed) {
    if (min_length_px > 0) {  // selection: shorter chains are dropped, counted
      double len = 0;
      for (size_t i = 0; i + 1 < pts.size() + closed; ++i) {
        const uint32_t u = pts[i], v = pts[(i + 1) % pts.size()];
        len += std::hypot(xy[2 * v] - xy[2 * u], xy[2 * v + 1] - xy[2 * u + 1]);
      }
      if (len < min_length_px) {
        ++out.short_chains[size_t(kind)];
        return;
      }
    }
    if (simplify_px > 0 && pts.size() > 2) {
      keep.clear();
      keep.push_back(pts.front());
      if (closed) {  // split at the point farthest from the first: two open halves
        size_t split = 1;
        double far = -1;
        for (size_t i = 1; i < pts.size(); ++i) {
          const double d =
              std::hypot(xy[2 * pts[i]] - xy[2 * pts[0]], xy[2 * pts[i] + 1] - xy[2 * pts[0] + 1]);
          if (d > far) far = d, split = i;
        }
        pts.push_back(pts.front());
        simplify(xy, pts, 0, split, simplify_px, keep);
        keep.push_back(pts[split]);
        simplify(xy, pts, split, pts.size() - 1, simplify_px, keep);
      } else {
        simplify(xy, pts, 0, pts.size() - 1, simplify_px, keep);
        keep.push_back(pts.back());
      }
      pts.swap(keep);
    }
    for (uint32_t v : pts) out.xy.push_back(xy[2 * v]), out.xy.push_back(xy[2 * v + 1]);
    out.off.push_back(uint32_t(out.xy.size() / 2));
    out.kind.push_back(kind);
    out.closed.push_back(closed);
    out.hidden.push_back(hidden);
  };
  // Walks from v along segment i until a chain end (or back to the start: closed).
  auto walk = [&](uint32_t v, uint32_t i) {
    pts.clear();
    pts.push_back(v);
    const uint32_t first = v;
    for (;;) {
      used[i] = 1;
      v = S[i].a == v ? S[i].b : S[i].a;
      if (v == first) return true;  // closed
      pts.push_back(v);
      uint32_t r = start[v];
      while (inc[r] != i) ++r;
      const uint32_t j = partner[r];
      if (j == ~0u || used[j]) return false;
      i = j;
    }
  };
  for (uint32_t v = 0; v < nv; ++v)  // chains with an end first, from their ends
    for (uint32_t r = start[v]; r < start[v + 1]; ++r)
      if (partner[r] == ~0u && !used[inc[r]]) emit(walk(v, inc[r]));
  for (uint32_t i = 0; i < S.size(); ++i)
    if (!used[i]) emit(walk(S[i].a, i));
}

}  // namespace

LineSet extract_lines(const PlanarMap& map, const ScreenTriangles& screen, const Scene& scene,
                      const Camera& camera, const LineOptions& opts) {
  // Long on purpose (~130 lines): the edge table built first is what the classification, the
  // hidden parts and the chaining below all walk.
  if (map.mesh.size() != map.fragment_count() || map.triangle.size() != map.fragment_count())
    bad("fragment arrays of different lengths");
  for (size_t f = 0; f < map.fragment_count(); ++f)
    if (map.mesh[f] >= scene.meshes.size() ||
        map.triangle[f] >= scene.meshes[map.mesh[f]].triangle_count())
      bad("fragment " + std::to_string(f) + " names no triangle of the scene");
  ConformedPolygons P = conform_polygons(map, 1);
  weld_vertices(P, kOnLine);
  Classifier cls(map, screen, scene, camera, opts);

  // Every polygon edge, by its directed vertex pair; an edge is looked at once, from the side
  // whose polygon comes first (or its only side).
  FlatMap edges(P.v.size());
  for (uint32_t p = 0; p < P.size(); ++p)
    for (uint32_t i = P.off[p], n = P.off[p + 1]; i < n; ++i)
      edges.emplace(pair_key(P.v[i], P.v[i + 1 < n ? i + 1 : P.off[p]]), p);
  std::array<std::vector<Seg>, kLineKinds> segs;
  // The visible parts of mesh edge lines, for --hidden: (mesh, edge key) -> map edges on it.
  struct OnEdge {
    uint32_t mesh;
    uint64_t edge;
    uint32_t a, b;
  };
  std::vector<OnEdge> on_edge;
  // Map edges shorter than kOnLine (two exact points a rounding apart, e.g. where a crossing
  // line meets two triangles' edges at one point in theory) are no line of any kind: their
  // ends are merged for chaining.
  std::vector<uint32_t> root(P.xy.size() / 2);
  for (uint32_t v = 0; v < root.size(); ++v) root[v] = v;
  auto find = [&](uint32_t v) {
    while (root[v] != v) v = root[v] = root[root[v]];
    return v;
  };
  for (uint32_t p = 0; p < P.size(); ++p)
    for (uint32_t i = P.off[p], n = P.off[p + 1]; i < n; ++i) {
      const uint32_t a = P.v[i], b = P.v[i + 1 < n ? i + 1 : P.off[p]];
      const uint32_t* twin = edges.find(pair_key(b, a));
      if (twin && *twin < p) continue;
      if (std::hypot(P.xy[2 * a] - P.xy[2 * b], P.xy[2 * a + 1] - P.xy[2 * b + 1]) < kOnLine) {
        const uint32_t ra = find(a), rb = find(b);
        if (ra != rb) root[std::max(ra, rb)] = std::min(ra, rb);
        continue;
      }
      LineKind kind;
      Classifier::Owner owner;
      const bool line = cls.classify(&P.xy[2 * a], &P.xy[2 * b], P.fragment[p],
                                     twin ? P.fragment[*twin] : Classifier::kNone, kind, owner);
      if (line) segs[size_t(kind)].push_back({a, b});
      if (opts.hidden && owner.edge != Classifier::kNoEdge)
        on_edge.push_back({owner.mesh, owner.edge, a, b});
    }

  LineSet out;
  out.unplaced = cls.unplaced;
  for (size_t k = 0; k < kLineKinds; ++k) {
    for (Seg& g : segs[k]) g.a = find(g.a), g.b = find(g.b);
    out.edges[k] = segs[k].size();
    chain(P.xy, segs[k], LineKind(k), false, opts.simplify_px, opts.min_length_px[k], out);
  }
  if (!opts.hidden) return out;

  // Hidden parts: each mesh edge line (from the mesh) less the map edges that lie on it.
  std::sort(on_edge.begin(), on_edge.end(), [](const OnEdge& x, const OnEdge& y) {
    return x.mesh != y.mesh ? x.mesh < y.mesh : x.edge < y.edge;
  });
  std::vector<double> hxy;  // hidden segments' points, merged by exact position below
  std::array<std::vector<Seg>, kLineKinds> hsegs;
  std::vector<std::array<double, 4>> pieces;  // (t0, t1) with their points: x0 y0 | x1 y1
  struct Cut {
    double t;
    uint32_t v;  // a map vertex (into P.xy)
  };
  std::vector<std::pair<Cut, Cut>> visible;
  std::array<std::vector<std::array<double, 4>>, kLineKinds> raw;
  for (uint32_t m = 0; m < scene.meshes.size(); ++m) {
    auto lo = std::lower_bound(on_edge.begin(), on_edge.end(), m,
                               [](const OnEdge& x, uint32_t mm) { return x.mesh < mm; });
    cls.for_each_edge_line(m, [&](LineKind kind, uint64_t key, const double* a, const double* b) {
      const double dx = b[0] - a[0], dy = b[1] - a[1], l2 = dx * dx + dy * dy;
      if (!(l2 > 0)) return;
      visible.clear();
      auto it = std::lower_bound(lo, on_edge.end(), key, [m](const OnEdge& x, uint64_t kk) {
        return x.mesh < m || (x.mesh == m && x.edge < kk);
      });
      for (; it != on_edge.end() && it->mesh == m && it->edge == key; ++it) {
        auto param = [&](uint32_t v) {
          return ((P.xy[2 * v] - a[0]) * dx + (P.xy[2 * v + 1] - a[1]) * dy) / l2;
        };
        Cut c0{param(it->a), it->a}, c1{param(it->b), it->b};
        if (c1.t < c0.t) std::swap(c0, c1);
        visible.push_back({c0, c1});
      }
      std::sort(visible.begin(), visible.end(),
                [](const auto& x, const auto& y) { return x.first.t < y.first.t; });
      // Walk [0, 1], emitting what no visible part covers; a piece starts or ends at a visible
      // part's end point (a map vertex, exactly) or at the edge's own end.
      double t = 0, px = a[0], py = a[1];
      const double tiny = 1e-9 / std::sqrt(l2);  // a nanopixel
      auto piece = [&](double t1, double x1, double y1) {
        if (t1 - t > tiny) raw[size_t(kind)].push_back({px, py, x1, y1});
      };
      for (const auto& [c0, c1] : visible) {
        if (c0.t > t) piece(c0.t, P.xy[2 * c0.v], P.xy[2 * c0.v + 1]);
        if (c1.t > t) {
          t = c1.t;
          px = P.xy[2 * c1.v];
          py = P.xy[2 * c1.v + 1];
        }
      }
      if (t < 1) piece(1, b[0], b[1]);
    });
  }
  for (size_t k = 0; k < kLineKinds; ++k) {
    // Points merged by exact position (the ends two edges share are snapped alike).
    hxy.clear();
    hsegs[k].clear();
    Weld<double, 2> at(2 * raw[k].size());
    auto id = [&](double x, double y) {
      const double p[2] = {x, y};
      auto [v, fresh] = at.add(p, uint32_t(hxy.size() / 2));
      if (fresh) hxy.push_back(x), hxy.push_back(y);
      return v;
    };
    for (const auto& r : raw[k]) {
      const uint32_t a = id(r[0], r[1]), b = id(r[2], r[3]);
      if (a != b) hsegs[k].push_back({a, b});
    }
    out.hidden_edges[k] = hsegs[k].size();
    chain(hxy, hsegs[k], LineKind(k), true, opts.simplify_px, opts.min_length_px[k], out);
  }
  return out;
}

}  // namespace vismap
