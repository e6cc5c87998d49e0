// extract_lines' classifier (lines.h): one class spread over the files of its ideas, as manifold
// spreads one class over files. The rules that give a map edge its kind (rules.cpp), the screen
// projection of source edges (screen.cpp), contacts of surfaces in 3D (contacts.cpp), the screen
// indices of covering triangles and crossing lines (screen_index.cpp); the chaining of the
// classified edges is chain.h's. Internal to core/lines/.
#pragma once

#include <array>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "core/camera.h"
#include "core/error.h"
#include "core/lines/lines.h"
#include "core/lines/topology.h"
#include "core/planar_map.h"
#include "core/scene.h"
#include "core/util/flat_map.h"
#include "kernels/layout.h"

namespace vismap::lines_detail {

// A map vertex that is exactly on a screen triangle's edge is within ~1e-9 px of it (the map's
// vertices are exact points rounded once to a 2^-20 grid-unit lattice, core/stages/map_build.h; the
// screen triangles' corners are grid points); other vertices are farther than this by far, but
// for edges that meet at a vertex at a vanishing angle.
inline constexpr double kOnLine = 1e-6;

// A point lies on a plane when it is within this fraction of the scene's extent (its bounding
// box's diagonal) of it: float coordinates hold ~6e-8 of their magnitude, so points that meet
// in the scene's file (a box's bottom at y = 0 on a floor at y = 0) do, and a fold of a dense
// scan two rings away (~1e-5 of the extent on the dragon) does not.
inline constexpr double kTouch = 1e-6;
// A map edge lies on a crossing line when both its ends are within this many pixels of it (the
// map's vertices are the exact points rounded to 2^-20 grid units, then welded within kOnLine).
inline constexpr double kOnCrossing = 4 * kOnLine;
// Two pieces of one surface meeting at a T-junction are snapped apart by up to a grid unit's
// half at each corner: their edges are looked for within this many pixels of each other.
inline constexpr double kSeamPx = 1.0 / 64;

inline double scene_extent(const Scene& scene) {
  double lo[3] = {HUGE_VAL, HUGE_VAL, HUGE_VAL}, hi[3] = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
  for (const Mesh& m : scene.meshes)
    for (size_t i = 0; i < m.positions.size(); ++i) {
      lo[i % 3] = std::min(lo[i % 3], double(m.positions[i]));
      hi[i % 3] = std::max(hi[i % 3], double(m.positions[i]));
    }
  if (!(hi[0] >= lo[0])) return 0;
  return std::hypot(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]);
}

[[noreturn]] inline void bad(const std::string& what) {
  throw InputError(InputErrorKind::ParseError, "lines", "", "map", -1, what);
}

struct Vec {
  double x, y, z;
};
inline Vec sub(Vec a, Vec b) {
  return {a.x - b.x, a.y - b.y, a.z - b.z};
}
inline Vec cross(Vec a, Vec b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
inline double dot(Vec a, Vec b) {
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
             const Camera& camera, const LineOptions& opts);

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
                Owner& owner);

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
  static constexpr double kGrid = VM_GRID_SCALE;

  // Edge k of triangle t clipped to the view volume (clip space, as transform.cl clips) and
  // projected; false when nothing of it is in view.
  bool project_edge(const Mesh& mesh, uint32_t t, int k, double* a, double* b) const;

  bool on_viewport_border(const double* a, const double* b) const;

  const Topology& topo(uint32_t m);

  // Corner k of triangle t as homogeneous pixel coordinates (x, y, w): x = (cx/cw + 1) W/2
  // etc. times cw.
  void homog(const Mesh& mesh, uint32_t t, int k, double* h) const;

  // Which source edge (k: vertices k, k+1) each edge of screen triangle s lies on; kClip where
  // it lies on none (a cut of the view volume's planes). Tested against the source edge's line
  // in homogeneous screen coordinates, which stays right when a corner is behind the eye: the
  // screen edge's ends are grid points (snapped corners or clip points), within 1/(2G) px per
  // axis of that line when they are on it.
  const std::array<int8_t, 3>& edges_of(uint32_t s);

  // The edge k of source (m, t) the segment a-b lies on (through any of its screen triangles),
  // or -1; *s: the screen triangle it was found in (the first one, when none).
  // *mask (if given): a bit for each source edge it lies on (a needle's edges may all be one
  // line on the screen).
  int source_edge(uint32_t m, uint32_t t, const double* a, const double* b, uint32_t* s_out,
                  int* mask = nullptr);

  // A diced implicit (Mesh::normals given) is the boundary of a solid whose back faces the
  // dicer left out where they cannot be seen (core/surfaces/implicit3d.cpp): its open edges had
  // a neighbour, facing away.
  bool has_neighbour(uint32_t m, uint32_t t, int k);

  bool shared_edge(uint32_t m, uint32_t t1, int k1, uint32_t t2, int k2);

  Vec position(const Mesh& m, uint32_t t, int k) const;
  Vec normal(const Mesh& m, uint32_t t) const;
  // Positive when triangle t of m shows the side its normal points to.
  double facing(const Mesh& m, uint32_t t) const;

  Vec edge_dir(const Side& x) const;
  // x and y (one mesh) meet along their edges x.edge and y.edge: shared, or collinear in 3D (a
  // seam between pieces of one surface). With y's orientation made consistent with x's across
  // the edge (a soup need not be: consistent when the two run it opposite ways), does one face
  // the eye and the other away? *cosang: the cosine of the angle between their normals.
  bool facing_differs(const Side& x, const Side& y, double* cosang) const;
  // Rule 4's kinds for an edge x and y meet along: contour at a fold, crease past the crease
  // angle, else false (no line).
  // With LineOptions::crease_smooth, a crease also needs the smoothed normals of the two faces
  // to differ by more than half the crease angle.
  bool edge_kind(const Side& x, const Side& y, LineKind& kind);
  // The cosine of the angle between x's and y's smoothed normals (orientations made consistent
  // across their edge as facing_differs does): each the sum of its corners' vertex normals, a
  // vertex normal the sum of the area-weighted normals of the triangles around it.
  double smoothed_cos(const Side& x, const Side& y);

  // --- Contacts: where one surface's edge lies on another surface in 3D. ---

  // The point of x's edge (in the world) that projects to p (pixels): the edge's parameter
  // solved in homogeneous coordinates, where it is affine.
  Vec on_edge(const Side& x, const double* p) const;
  // Does x's edge, along the map edge a-b, lie on y's surface (its plane, within the scene's
  // tolerance)? Within one mesh, not where y is within two rings of the edge (a vertex of y at
  // or next to one of the edge's): there the surface folds, it does not meet itself.
  // (A seam, where y's edge holds x's edge in 3D, is a contact however near.)
  bool touches(const Side& x, const Side& y, const double* a, const double* b);
  // Do the points of x's edge at a quarter and three quarters of the map edge a-b lie on y's
  // edge (the segment, in 3D)?
  // (A degenerate y, its corners in a line, holds every edge along it and is no partner.) The
  // two edges must run along one line, not merely pass near each other where they meet.
  bool on_edge_line(const Side& x, const Side& y, const double* a, const double* b) const;
  // Do the points of x's edge at a quarter and three quarters of the map edge a-b lie on y's
  // plane?
  bool on_plane(const Side& x, const Side& y, const double* a, const double* b) const;
  // Is the point p within eps_ of y's plane (never, for a triangle with no area)?
  bool on_plane_of(const Side& y, const Vec& p) const;
  // The square of x's triangle's longest edge.
  double longest_edge2(const Side& x) const;
  // Does the surface end at x's edge in 3D: no neighbour there, more than one, or one facing
  // the other way (a contour edge)?
  bool ends_at(const Side& x);
  // Does y (x's mesh, within two rings of x's edge) touch x's edge along the map edge a-b?
  bool continues_into(const Side& x, const Side& y, const double* a, const double* b);
  // Is x's triangle (nearly) a segment: its area under 1e-9 of its longest edge squared?
  bool degenerate(const Side& x) const;
  // Do x's and y's triangles lie in one plane (y's corners on x's plane)?
  bool coplanar(const Side& x, const Side& y) const;
  // Does x's whole edge lie on y's plane (same tolerance and rings as touches())?
  bool edge_on(const Side& x, const Side& y);
  // On a diced implicit, is what shows beyond x's edge (y, along the view ray through the map
  // edge's midpoint) nearer to the edge in 3D than x's longest edge? The dicer's cells are about
  // that size and its surface is within sqrt(3) cells of f = 0 (core/surfaces/implicit3d.cpp):
  // such a fold is the grid's, not the surface's (a sheet where f touches 0 without changing
  // sign: the architecture model's slabs meeting at x = 0 leave a groove one cell deep).
  bool grid_fold(const Side& x, const Side& y, const double* a, const double* b);
  bool near_on_mesh(const Side& x, uint32_t t);
  // Does x's edge (shared with y) lie on a third surface that the map edge a-b passes over on
  // the screen? (A box's bottom face ties with the floor under it: the floor is not on either
  // side of the box's bottom edge there, but the edge stands on it all the same.)
  bool touches_third(const Side& x, const Side& y, const double* a, const double* b);
  // A triangle y of x's mesh (within kSeamPx on the screen) with an edge that holds x's edge
  // along the map edge a-b in 3D: the other side of a T-junction (pieces of one surface not
  // welded, whose snapped corners leave a crack a rounding wide between them).
  bool seam_partner(const Side& x, const double* a, const double* b, Side& y);
  // The kind of an edge with no neighbour in its mesh (by position): a boundary, unless it is
  // a seam (seam_partner), then as if the two shared it (false: no line).
  bool open_edge_kind(const Side& x, const double* a, const double* b, LineKind& kind);
  // The kind of a contact: x's edge lies on y's surface. Two meshes meet: border. Pieces of one
  // mesh: along y's edge too (a seam, the pieces not welded), as if they shared the edge (a
  // fold, a crease or nothing); inside y's face, nothing where they are coplanar (within the
  // crease angle), else border.
  bool contact_kind(const Side& x, const Side& y, LineKind& kind);
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
  void build_cells();

  // --- Crossings: the lines the pipeline clipped penetrating pairs with. ---

  void index_crossings();
  // Does the map edge a-b lie on a crossing line of the sources of screen triangles s1, s2?
  // (A source pair split into several screen triangles, by the view volume's planes, has a
  // line for each piece, snapped alike but not exactly one: where two pieces meet, a map edge
  // a rounding long may join the two lines, an end on each.)
  bool on_crossing(uint32_t s1, uint32_t s2, const double* a, const double* b) const;

  // The nearness at (x, y) pixels on screen triangle s's depth plane.
  double nearness(uint32_t s, double x, double y) const;

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

}  // namespace vismap::lines_detail
