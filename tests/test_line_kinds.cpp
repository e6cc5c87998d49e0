// The classification of line drawings against facts of the scene (issue 33): intersection lines
// only on the surfaces' crossings, computed here in 3D and independently of the pipeline, and
// every visible part of a crossing drawn; contacts of the same kind from every view; pieces of
// one surface meeting flush drawn as nothing.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include "core/lines/line_check.h"
#include "core/lines/lines.h"
#include "core/pipeline.h"
#include "core/scene.h"
#include "core/surfaces/tessellate.h"
#include "support/line_drawing.h"

namespace vismap {
namespace {

namespace fs = std::filesystem;

using test_support::Drawn;
using test_support::for_each_segment;
Renderer& renderer() {
  return test_support::line_renderer();
}
Drawn draw(const Scene& s, const Camera& cam, const LineOptions& o = {}) {
  return test_support::draw_lines(s, cam, o);
}

using P3 = std::array<double, 3>;
using P2 = std::array<double, 2>;
P3 sub(P3 a, P3 b) {
  return {a[0] - b[0], a[1] - b[1], a[2] - b[2]};
}
P3 cross(P3 a, P3 b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
double dot(P3 a, P3 b) {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

P3 vertex(const Mesh& m, size_t t, int k) {
  const float* p = &m.positions[3 * size_t(m.indices[3 * t + k])];
  return {p[0], p[1], p[2]};
}

// Where triangle a's edges cross the plane of b: the segment of a on it (false: none).
bool on_plane_of(const std::array<P3, 3>& a, const std::array<P3, 3>& b, P3& p, P3& q) {
  const P3 n = cross(sub(b[1], b[0]), sub(b[2], b[0]));
  double d[3];
  for (int k = 0; k < 3; ++k) d[k] = dot(n, sub(a[k], b[0]));
  std::vector<P3> pts;
  for (int k = 0; k < 3; ++k) {
    const double u = d[k], v = d[(k + 1) % 3];
    if ((u < 0 && v > 0) || (u > 0 && v < 0)) {
      const double t = u / (u - v);
      const P3 x = a[k], y = a[(k + 1) % 3];
      pts.push_back({x[0] + t * (y[0] - x[0]), x[1] + t * (y[1] - x[1]), x[2] + t * (y[2] - x[2])});
    }
  }
  if (pts.size() != 2) return false;  // touching at a vertex, or coplanar: no crossing
  p = pts[0];
  q = pts[1];
  return true;
}

// The crossing segment of two triangles in 3D (false: they do not cross).
bool crossing(const std::array<P3, 3>& a, const std::array<P3, 3>& b, P3& p, P3& q) {
  P3 a0, a1, b0, b1;
  if (!on_plane_of(a, b, a0, a1) || !on_plane_of(b, a, b0, b1)) return false;
  const P3 dir = sub(a1, a0);
  const double l2 = dot(dir, dir);
  if (!(l2 > 0)) return false;
  auto t = [&](P3 x) { return dot(sub(x, a0), dir) / l2; };
  double lo = std::max(0.0, std::min(t(b0), t(b1))), hi = std::min(1.0, std::max(t(b0), t(b1)));
  if (!(hi > lo)) return false;
  p = {a0[0] + lo * dir[0], a0[1] + lo * dir[1], a0[2] + lo * dir[2]};
  q = {a0[0] + hi * dir[0], a0[1] + hi * dir[1], a0[2] + hi * dir[2]};
  return true;
}

P2 project(const Camera& cam, P3 p) {
  const Mat4 m = cam.view_projection();
  double c[4];
  for (int r = 0; r < 4; ++r) c[r] = m[r] * p[0] + m[4 + r] * p[1] + m[8 + r] * p[2] + m[12 + r];
  return {(c[0] / c[3] + 1) * 0.5 * cam.width, (1 - c[1] / c[3]) * 0.5 * cam.height};
}

double seg_dist(P2 p, P2 a, P2 b) {
  const double dx = b[0] - a[0], dy = b[1] - a[1], l2 = dx * dx + dy * dy;
  const double t =
      l2 > 0 ? std::clamp(((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / l2, 0.0, 1.0) : 0;
  return std::hypot(p[0] - a[0] - t * dx, p[1] - a[1] - t * dy);
}

// A crossing of two scene triangles, projected.
struct Crossing {
  uint32_t mesh[2], tri[2];
  P2 a, b;
};

// Every pair of triangles that cross: of two meshes, or of one mesh sharing no vertex (by
// position), brute force over pairs of meshes with at most `cap` pairs.
std::vector<Crossing> scene_crossings(const Scene& s, const Camera& cam, size_t cap = 50'000'000) {
  std::vector<Crossing> out;
  auto tri = [&](uint32_t m, size_t t) {
    return std::array<P3, 3>{vertex(s.meshes[m], t, 0), vertex(s.meshes[m], t, 1),
                             vertex(s.meshes[m], t, 2)};
  };
  for (uint32_t ma = 0; ma < s.meshes.size(); ++ma)
    for (uint32_t mb = ma; mb < s.meshes.size(); ++mb) {
      const size_t na = s.meshes[ma].triangle_count(), nb = s.meshes[mb].triangle_count();
      if (na * nb > cap) continue;
      for (size_t i = 0; i < na; ++i)
        for (size_t j = ma == mb ? i + 1 : 0; j < nb; ++j) {
          const auto A = tri(ma, i), B = tri(mb, j);
          if (ma == mb) {
            bool share = false;
            for (const P3& x : A)
              for (const P3& y : B) share |= x == y;
            if (share) continue;
          }
          P3 p, q;
          if (!crossing(A, B, p, q)) continue;
          out.push_back({{ma, mb}, {uint32_t(i), uint32_t(j)}, project(cam, p), project(cam, q)});
        }
    }
  return out;
}

// Is the point p (pixels) in the closure of a fragment of (mesh, tri)?
bool shows(const PlanarMap& map, uint32_t mesh, uint32_t tri, P2 p, double tol) {
  for (size_t f = 0; f < map.fragment_count(); ++f) {
    if (map.mesh[f] != mesh || map.triangle[f] != tri) continue;
    const double area = map.fragment_area(f);
    bool in = true;
    for (uint32_t v = map.offsets[f], n = map.offsets[f + 1]; v < n && in; ++v) {
      const uint32_t w = v + 1 < n ? v + 1 : map.offsets[f];
      const double ax = map.xy[2 * v], ay = map.xy[2 * v + 1];
      const double dx = map.xy[2 * w] - ax, dy = map.xy[2 * w + 1] - ay;
      const double side = (dx * (p[1] - ay) - dy * (p[0] - ax)) * (area > 0 ? 1 : -1);
      in = side >= -tol * std::hypot(dx, dy);
    }
    if (in) return true;
  }
  return false;
}

// Every drawn intersection segment lies on a crossing of the scene (both ends within `tol` px
// of one projected crossing segment); every point of a crossing where both triangles show on
// the map (within `tol`; sampled each quarter pixel) has an intersection line within 2 `tol`,
// but for one sample or 1 % at most (where three triangles meet within `tol`, a sample may show
// two and lie on the third's line). Returns the number of visible samples.
size_t expect_crossings_drawn(const Scene& s, const Camera& cam, const Drawn& d, double tol) {
  const std::vector<Crossing> X = scene_crossings(s, cam);
  const LineSet& L = d.lines;
  std::vector<std::array<P2, 2>> drawn;
  for_each_segment(L, [&](size_t c, const double* a, const double* b) {
    if (L.kind[c] == LineKind::Intersection) drawn.push_back({P2{a[0], a[1]}, P2{b[0], b[1]}});
  });
  for (const auto& [a, b] : drawn) {
    bool on = false;
    for (const Crossing& x : X) on |= seg_dist(a, x.a, x.b) <= tol && seg_dist(b, x.a, x.b) <= tol;
    EXPECT_TRUE(on) << "intersection line (" << a[0] << "," << a[1] << ")-(" << b[0] << "," << b[1]
                    << ") lies on no crossing of the scene";
  }
  size_t visible = 0, missed = 0;
  for (const Crossing& x : X) {
    const double len = std::hypot(x.b[0] - x.a[0], x.b[1] - x.a[1]);
    const int k = std::max(1, int(len * 4));
    for (int i = 0; i < k; ++i) {
      const double t = (i + 0.5) / k;
      const P2 p{x.a[0] + t * (x.b[0] - x.a[0]), x.a[1] + t * (x.b[1] - x.a[1])};
      if (p[0] < 0 || p[1] < 0 || p[0] > cam.width || p[1] > cam.height) continue;
      // (The pipeline's crossing is the snapped planes', a hundredth of a pixel or so off.)
      if (!shows(d.map, x.mesh[0], x.tri[0], p, tol) || !shows(d.map, x.mesh[1], x.tri[1], p, tol))
        continue;
      ++visible;
      bool near = false;
      for (const auto& [a, b] : drawn) near |= seg_dist(p, a, b) <= 2 * tol;
      if (!near) ++missed;
    }
  }
  EXPECT_LE(missed, std::max<size_t>(1, visible / 100))
      << missed << " of " << visible << " visible samples missed";
  return visible;
}

constexpr double kSeamFrom = -5, kSeamTo = 7;  // the floor's seam, world y (architecture)

Scene stiff(const std::string& name) {
  return load_scene((fs::path(VISMAP_SOURCE_DIR) / "data/stiff" / (name + ".json")).string());
}

Camera scene_camera(const Scene& s) {
  Camera cam = *s.camera;
  fit_near_far(cam, s);
  return cam;
}

TEST(LineKinds, TheBunnyDrawsNoIntersection) {
  const Scene s = load_scene((fs::path(VISMAP_SOURCE_DIR) / "data/bunny.ply").string());
  const Drawn d = draw(s, frame_scene(s, 1024, 1024));
  EXPECT_EQ(d.lines.edges[size_t(LineKind::Intersection)], 0u);
  EXPECT_EQ(d.lines.unplaced, 0u);
  EXPECT_GT(d.lines.edges[size_t(LineKind::Contour)], 1000u);
}

class PenetratingLines : public ::testing::TestWithParam<std::string> {};

TEST_P(PenetratingLines, IntersectionLinesAreTheVisibleCrossings) {
  const Scene s = stiff(GetParam());
  const Camera cam = scene_camera(s);
  const Drawn d = draw(s, cam);
  EXPECT_EQ(d.lines.unplaced, 0u);
  EXPECT_GT(d.lines.edges[size_t(LineKind::Intersection)], 0u);
  EXPECT_GT(expect_crossings_drawn(s, cam, d, 0.02), 10u);
}

INSTANTIATE_TEST_SUITE_P(Stiff, PenetratingLines,
                         ::testing::Values("penetrating_triangles", "cyclic_overlap",
                                           "triple_points", "concurrent_planes", "one_tile_crowded",
                                           "nearly_touching", "far_coordinates_1e6",
                                           "tiny_scene_1e-6"));

// A square through the bunny's middle, and a tilted one through its ears and body.
TEST(LineKinds, TheBunnyThroughTwoPlanesDrawsTheirCrossingsOnly) {
  Scene s = load_scene((fs::path(VISMAP_SOURCE_DIR) / "data/bunny.ply").string());
  float lo[3] = {1e9f, 1e9f, 1e9f}, hi[3] = {-1e9f, -1e9f, -1e9f};
  for (size_t i = 0; i < s.meshes[0].positions.size(); ++i) {
    lo[i % 3] = std::min(lo[i % 3], s.meshes[0].positions[i]);
    hi[i % 3] = std::max(hi[i % 3], s.meshes[0].positions[i]);
  }
  auto plane = [&](const std::string& name, const std::array<P3, 4>& c) {
    Mesh m;
    m.name = name;
    for (const P3& p : c)
      for (double v : p) m.positions.push_back(float(v));
    m.indices = {0, 1, 2, 0, 2, 3};
    m.face_ids = {0, 1};
    m.source_triangles = 2;
    s.meshes.push_back(m);
  };
  const double mx = (lo[0] + hi[0]) / 2, my = (lo[1] + hi[1]) / 2, mz = (lo[2] + hi[2]) / 2;
  const double r = 0.8 * std::max({hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]});
  plane("level", {P3{mx - r, my, mz - r}, P3{mx + r, my, mz - r}, P3{mx + r, my, mz + r},
                  P3{mx - r, my, mz + r}});
  const double ty = 0.3 * (hi[1] - lo[1]);  // tilted about z: from low at -x to high at +x
  plane("tilted", {P3{mx - r, my - ty, mz - r}, P3{mx - r, my - ty, mz + r},
                   P3{mx + r, my + ty, mz + r}, P3{mx + r, my + ty, mz - r}});
  Camera cam;
  cam.width = cam.height = 1024;
  cam.target = {mx, my, mz};
  cam.eye = {mx + 0.6 * r, my + 1.2 * r, mz + 2.5 * r};
  fit_near_far(cam, s);
  const Drawn d = draw(s, cam);
  EXPECT_EQ(d.lines.unplaced, 0u);
  EXPECT_GT(expect_crossings_drawn(s, cam, d, 0.02), 1000u);
}

// The Cornell box's boxes stand on its floor (y = 0 in the file, both): their bottom edges are
// a border from every camera that sees them, twelve in a ring inside the box under its ceiling.
TEST(LineKinds, TheCornellBoxBottomsAreBordersFromEveryView) {
  const Scene s = load_scene(
      (fs::path(VISMAP_SOURCE_DIR) / "data/cornell_box/CornellBox-Original.obj").string());
  std::vector<std::array<P3, 2>> bottoms;
  for (const Mesh& m : s.meshes) {
    if (m.name.find("Box") == std::string::npos) continue;
    for (size_t t = 0; t < m.triangle_count(); ++t)
      for (int k = 0; k < 3; ++k) {
        const P3 a = vertex(m, t, k), b = vertex(m, t, (k + 1) % 3);
        if (a[1] == 0 && b[1] == 0) bottoms.push_back({a, b});
      }
  }
  ASSERT_GE(bottoms.size(), 8u);  // short box and tall box, four edges each
  int views_seeing = 0;
  for (int v = 0; v < 12; ++v) {
    Camera cam;
    cam.width = cam.height = 512;
    const double a = v * M_PI / 6;
    cam.target = {0, 0.3, 0};
    cam.eye = {0.9 * std::cos(a), 1.7, 0.9 * std::sin(a)};
    fit_near_far(cam, s);
    const Drawn d = draw(s, cam);
    std::vector<std::array<P2, 2>> edges;
    for (const auto& e : bottoms) edges.push_back({project(cam, e[0]), project(cam, e[1])});
    double seen = 0;
    const LineSet& L = d.lines;
    for_each_segment(L, [&](size_t c, const double* pa, const double* pb) {
      const P2 a2{pa[0], pa[1]}, b2{pb[0], pb[1]};
      // (Pieces shorter than 0.1 px at a corner may lie on the edge's end and another's.)
      if (std::hypot(b2[0] - a2[0], b2[1] - a2[1]) < 0.1) return;
      for (const auto& e : edges) {
        if (seg_dist(a2, e[0], e[1]) > 0.01 || seg_dist(b2, e[0], e[1]) > 0.01) continue;
        EXPECT_EQ(L.kind[c], LineKind::Border)
            << "view " << v << ": a box's bottom edge drawn as " << line_kind_name(L.kind[c])
            << " at (" << a2[0] << "," << a2[1] << ")-(" << b2[0] << "," << b2[1] << ")";
        seen += std::hypot(b2[0] - a2[0], b2[1] - a2[1]);
        break;
      }
    });
    views_seeing += seen > 20;
  }
  EXPECT_GE(views_seeing, 6);
}

// Two quads of one mesh meeting flush along x = 0, tessellated differently (the left one's
// edge there is one edge, the right one's two: a T-junction): no line between them, from above
// and at a slant; a box on the same floor still meets it at a border.
TEST(LineKinds, FlushPiecesOfOneSurfaceMeetWithoutALine) {
  Scene s;
  Mesh m;
  m.name = "floor";
  m.positions = {-2, 0, -1, 0, 0, -1, 0, 0, 1, -2, 0, 1,                // left quad
                 0,  0, -1, 2, 0, -1, 2, 0, 1, 0,  0, 1, 0, 0, 0.25f};  // right quad, T at 8
  m.indices = {0, 2, 1, 0, 3, 2, 4, 8, 5, 5, 8, 6, 8, 7, 6};
  m.face_ids = {0, 1, 2, 3, 4};
  m.source_triangles = 5;
  s.meshes.push_back(m);
  for (const P3 eye : {P3{0.3, 6, 0.2}, P3{3, 2.5, 4}, P3{-4, 1.5, -3}}) {
    Camera cam;
    cam.width = cam.height = 256;
    cam.eye = {eye[0], eye[1], eye[2]};
    cam.target = {0, 0, 0};
    fit_near_far(cam, s);
    const Drawn d = draw(s, cam);
    const P2 a = project(cam, {0, 0, -1}), b = project(cam, {0, 0, 1});
    const LineSet& L = d.lines;
    for (size_t c = 0; c < L.chain_count(); ++c)
      for (uint32_t i = L.off[c]; i < L.off[c + 1]; ++i) {
        const P2 p{L.xy[2 * i], L.xy[2 * i + 1]};
        // Only the outline's corners at the seam's ends may touch it.
        const bool end = std::hypot(p[0] - a[0], p[1] - a[1]) < 0.01 ||
                         std::hypot(p[0] - b[0], p[1] - b[1]) < 0.01;
        EXPECT_TRUE(end || seg_dist(p, a, b) > 0.01)
            << line_kind_name(L.kind[c]) << " at (" << p[0] << "," << p[1] << ") on the seam ("
            << a[0] << "," << a[1] << ")-(" << b[0] << "," << b[1] << ")";
      }
    EXPECT_EQ(d.lines.edges[size_t(LineKind::Boundary)] > 0, true);  // the floor's rim
  }
}

// The architecture model's slabs meet at x = 0 (an f = 0 sheet inside the solid); the diced
// surface has a groove one cell deep there, which drew a line across the floor. Along the
// floor's seam (x = 0, z = 0; the groove's rim is a pixel or two beside it) no line is drawn
// now but where other lines cross it.
TEST(LineKinds, TheArchitectureSeamDrawsNoLine) {
  const fs::path path = fs::path(VISMAP_SOURCE_DIR) / "bench/implicit/architecture.json";
  if (!fs::exists(fs::path(VISMAP_SHARED_DATA_DIR) / "implicit/mpr_architecture.sexp"))
    GTEST_SKIP() << "no ../shared/data";
  Scene s = load_scene(path.string());
  Camera cam = *s.camera;
  fit_near_far(cam, s);
  s = renderer().tessellate(s, cam);  // as vismap render dices it
  const Drawn d = draw(s, cam);
  const P2 a = project(cam, {0, kSeamFrom, 0}), b = project(cam, {0, kSeamTo, 0});
  double on = 0;
  for_each_segment(d.lines, [&](size_t, const double* pa, const double* pb) {
    const double len = std::hypot(pb[0] - pa[0], pb[1] - pa[1]);
    const int k = std::max(1, int(len * 4));
    for (int q = 0; q < k; ++q) {
      const double t = (q + 0.5) / k;
      const P2 x{pa[0] + t * (pb[0] - pa[0]), pa[1] + t * (pb[1] - pa[1])};
      if (seg_dist(x, a, b) <= 2.5) on += len / k;
    }
  });
  const double seam = std::hypot(b[0] - a[0], b[1] - a[1]);
  EXPECT_GT(seam, 200);
  // (Lines that cross the seam put some 18 px of 232 within 2.5 px of it; the seam's line put
  // all 232 there.)
  EXPECT_LT(on, 0.15 * seam) << "a line along the seam";
}

// --- Selection (docs/LINES.md "Selection"). ---

LineCheck measure(const Scene& s, const Camera& cam, const LineSet& lines) {
  Camera fine = cam;
  fine.width *= 4;
  fine.height *= 4;
  std::vector<uint32_t> ids;
  renderer().raster_ids(s, fine, &ids);
  return check_lines(lines, ids, cam.width, cam.height, 4, s);
}

TEST(LineSelection, ShortChainsOfAKindAreDropped) {
  Scene s;
  Mesh cube;
  cube.name = "cube";
  for (int i = 0; i < 8; ++i)
    for (int c = 0; c < 3; ++c) cube.positions.push_back(i >> c & 1 ? 1.f : -1.f);
  const uint32_t q[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4},
                            {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (const auto& f : q)
    cube.indices.insert(cube.indices.end(), {f[0], f[1], f[2], f[0], f[2], f[3]});
  s.meshes.push_back(cube);
  Camera cam;
  cam.width = cam.height = 256;
  cam.eye = {4, 3, 5};
  cam.target = {0, 0, 0};
  fit_near_far(cam, s);
  const Drawn all = draw(s, cam);
  ASSERT_EQ(all.lines.edges[size_t(LineKind::Crease)], 3u);
  LineOptions o;
  o.min_length_px[size_t(LineKind::Crease)] = 1000;  // longer than any crease here
  const Drawn some = draw(s, cam, o);
  EXPECT_EQ(some.lines.short_chains[size_t(LineKind::Crease)], 3u);
  EXPECT_EQ(some.lines.short_chains[size_t(LineKind::Contour)], 0u);
  EXPECT_EQ(some.lines.chain_count(), all.lines.chain_count() - 3);
  for (LineKind k : some.lines.kind) EXPECT_NE(k, LineKind::Crease);
}

// The scanned bunny at 1024 px: by default its drawing has no contour where the surface hides
// only itself within two rings (folds smaller than its triangles) and no crease that smoothed
// normals do not confirm; the drawing then meets the checker (recall and precision at least
// 0.995), where drawing the folds costs precision.
TEST(LineSelection, TheBunnyReadsCleanlyByDefault) {
  const Scene s = load_scene((fs::path(VISMAP_SOURCE_DIR) / "data/bunny.ply").string());
  const Camera cam = frame_scene(s, 1024, 1024);
  const Drawn d = draw(s, cam);
  const LineCheck c = measure(s, cam, d.lines);
  EXPECT_GE(c.recall(), 0.995);
  EXPECT_GE(c.precision(), 0.995);
  LineOptions folds;
  folds.self_folds = true;
  const Drawn f = draw(s, cam, folds);
  EXPECT_GT(f.lines.chain_count(), 2 * d.lines.chain_count());
  EXPECT_LT(measure(s, cam, f.lines).precision(), 0.99);
  LineOptions sharp;
  sharp.crease_smooth = false;
  const Drawn z = draw(s, cam, sharp);
  EXPECT_LT(d.lines.edges[size_t(LineKind::Crease)],
            z.lines.edges[size_t(LineKind::Crease)] * 2 / 3);
}

// A CAD model keeps every crease under the smoothed-normal test, and its drawing meets the
// checker.
TEST(LineSelection, FandiskKeepsItsCreases) {
  const fs::path path = fs::path(VISMAP_SHARED_DATA_DIR) / "cgal/fandisk.off";
  if (!fs::exists(path)) GTEST_SKIP() << "no " << path;
  const Scene s = load_scene(path.string());
  const Camera cam = frame_scene(s, 1024, 1024);
  const Drawn d = draw(s, cam);
  LineOptions sharp;
  sharp.crease_smooth = false;
  EXPECT_EQ(d.lines.edges[size_t(LineKind::Crease)],
            draw(s, cam, sharp).lines.edges[size_t(LineKind::Crease)]);
  EXPECT_GT(d.lines.edges[size_t(LineKind::Crease)], 100u);
  const LineCheck c = measure(s, cam, d.lines);
  EXPECT_GE(c.recall(), 0.995);
  EXPECT_GE(c.precision(), 0.995);
}

}  // namespace
}  // namespace vismap
