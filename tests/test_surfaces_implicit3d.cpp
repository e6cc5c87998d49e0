// Implicit surfaces in 3D (issue 19, core/surfaces/implicit3d.cpp, core/load/sexp.cpp):
// shapes with known answers diced for a camera within the error bound (|f| / |grad f| at every
// vertex, f being a distance or 1-Lipschitz here), closed where wholly in view (every edge of
// two triangles), normals outward and from the gradient; the bounds search; scene-file objects
// with transforms and bad input; a mixed scene through the exact pipeline; the gradient against
// finite differences.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <set>

#include "core/error.h"
#include "core/implicit/implicit.h"
#include "core/pipeline.h"

namespace {

using namespace vismap;
namespace fs = std::filesystem;

Renderer& renderer() {
  static Renderer r;
  return r;
}

const char* kSphere = "(- (sqrt (+ (square x) (square y) (square z))) 1)";
const char* kBox = "(max (- (abs x) 0.8) (- (abs y) 0.5) (- (abs z) 0.6))";
const char* kTorus = "(- (sqrt (+ (square (- (sqrt (+ (square x) (square y))) 1)) (square z))) 0.35)";
const char* kUnion =
    "(min (- (sqrt (+ (square (- x 0.5)) (square y) (square z))) 0.7)"
    "     (- (sqrt (+ (square (+ x 0.5)) (square y) (square z))) 0.7))";
const char* kDifference =
    "(max (max (- (abs x) 0.8) (- (abs y) 0.8) (- (abs z) 0.8))"
    "     (- 0.5 (sqrt (+ (square x) (square y) (square z)))))";
const char* kIntersection =
    "(max (- (sqrt (+ (square (- x 0.4)) (square y) (square z))) 0.8)"
    "     (- (sqrt (+ (square (+ x 0.4)) (square y) (square z))) 0.8))";

Scene scene_of(const std::string& expr) { return load_scene_from_memory("shape.sexp", expr); }

struct Diced {
  Mesh mesh;
  TessellateStats st;
  double h = 0;  // the largest leaf cell's side
  int levels = 0;  // leaf sides used
};

Diced dice(const Scene& s, const Camera& cam, float tol, bool back_faces = true) {
  TessellateOptions o;
  o.implicit_tolerance_px = tol;
  o.implicit_back_faces = back_faces;
  o.implicit_occlusion = false;  // the whole surface (tests/test_implicit_occlusion.cpp: the cull)
  Diced d;
  Scene out = renderer().tessellate(s, cam, o, &d.st);
  d.mesh = out.meshes.at(0);
  d.h = d.st.implicit_leaf_side_max;
  for (uint64_t n : d.st.implicit_leaf_levels) d.levels += n > 0;
  return d;
}

// The projection's largest pixel scale per unit at depth 1 (perspective), as the dicer bounds it.
double pixels_per_unit_at_depth_1(const Camera& cam) {
  const double f = cam.height / (2 * std::tan(cam.fov_y_deg * M_PI / 360));
  const double r = 0.5 * std::hypot(double(cam.width), double(cam.height));
  return f * std::sqrt(1 + (r / f) * (r / f));
}

// Edges by use: (a, b) with a < b -> triangles using it.
std::map<std::pair<uint32_t, uint32_t>, int> edge_uses(const Mesh& m) {
  std::map<std::pair<uint32_t, uint32_t>, int> e;
  for (size_t t = 0; t < m.triangle_count(); ++t)
    for (int k = 0; k < 3; ++k) {
      uint32_t a = m.indices[3 * t + k], b = m.indices[3 * t + (k + 1) % 3];
      ++e[{std::min(a, b), std::max(a, b)}];
    }
  return e;
}

// Checks a closed shape wholly in view: the bound at every vertex (in the object's space: within
// sqrt(3) h of f = 0, h the largest leaf's side; on the screen: within the tolerance at the
// vertex's depth, as f is a distance or 1-Lipschitz), every edge of exactly two triangles, each
// triangle's normal pointing out (along the gradient), vertex normals unit. Returns the leaf
// sides used.
int check_closed_shape(const char* expr, const char* what, bool lipschitz = true,
                       const Camera* view = nullptr, float tol = 2.0f) {
  SCOPED_TRACE(what);
  const Scene s = scene_of(expr);
  EXPECT_EQ(s.meshes.size(), 1u);
  EXPECT_TRUE(s.meshes[0].implicit);
  if (s.meshes.size() != 1 || !s.meshes[0].implicit) return 0;
  const Camera cam = view ? *view : frame_scene(s, 320, 240);
  const Diced d = dice(s, cam, tol);
  const Mesh& m = d.mesh;
  EXPECT_GT(m.triangle_count(), 200u);
  EXPECT_EQ(m.source_triangles, m.triangle_count());
  EXPECT_EQ(m.normals.size(), m.positions.size());
  if (m.normals.size() != m.positions.size()) return 0;
  const implicit::Tape& t = *s.meshes[0].implicit;
  const double bound = std::sqrt(3.0) * d.h * 1.001 + 1e-6;
  const Mat4 vm = cam.view();
  const double k_px = pixels_per_unit_at_depth_1(cam);
  double worst = 0, worst_px = 0;
  for (size_t v = 0; v < m.vertex_count(); ++v) {
    const double x = m.positions[3 * v], y = m.positions[3 * v + 1], z = m.positions[3 * v + 2];
    const double f = std::abs(implicit::eval(t, x, y, z));
    const double depth = -(vm[2] * x + vm[6] * y + vm[10] * z + vm[14]);
    worst = std::max(worst, f);
    worst_px = std::max(worst_px, f * k_px / depth);
    const double nl = std::hypot(m.normals[3 * v], m.normals[3 * v + 1], m.normals[3 * v + 2]);
    EXPECT_NEAR(nl, 1.0, 1e-5);
  }
  if (lipschitz) {
    EXPECT_LE(worst, bound) << "h " << d.h;
    EXPECT_LE(worst_px, tol * 1.001) << "pixels at the vertex's depth";
  }
  size_t open = 0;
  for (const auto& [e, uses] : edge_uses(m)) open += uses != 2;
  EXPECT_EQ(open, 0u) << "edges not of two triangles";
  // Outward: the triangle's normal against the gradient's at its centroid, by central
  // differences of f.
  size_t outward = 0;
  for (size_t tr = 0; tr < m.triangle_count(); ++tr) {
    double p[3][3], c[3] = {0, 0, 0};
    for (int k = 0; k < 3; ++k)
      for (int a = 0; a < 3; ++a) {
        p[k][a] = m.positions[3 * m.indices[3 * tr + k] + a];
        c[a] += p[k][a] / 3;
      }
    const double u[3] = {p[1][0] - p[0][0], p[1][1] - p[0][1], p[1][2] - p[0][2]};
    const double w[3] = {p[2][0] - p[0][0], p[2][1] - p[0][1], p[2][2] - p[0][2]};
    const double n[3] = {u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2],
                         u[0] * w[1] - u[1] * w[0]};
    const double e = 1e-4;
    const double g[3] = {implicit::eval(t, c[0] + e, c[1], c[2]) - implicit::eval(t, c[0] - e, c[1], c[2]),
                         implicit::eval(t, c[0], c[1] + e, c[2]) - implicit::eval(t, c[0], c[1] - e, c[2]),
                         implicit::eval(t, c[0], c[1], c[2] + e) - implicit::eval(t, c[0], c[1], c[2] - e)};
    outward += n[0] * g[0] + n[1] * g[1] + n[2] * g[2] > 0;
  }
  // Where the gradient turns sharply (CSG edges) a chamfer's triangle may lean past it; nearly
  // all face out.
  EXPECT_GE(outward, m.triangle_count() * 99 / 100) << outward << " of " << m.triangle_count();
  return d.levels;
}

}  // namespace

TEST(Implicit3D, ShapesWithKnownAnswersAreClosedAndWithinTheBound) {
  check_closed_shape(kSphere, "sphere");
  check_closed_shape(kBox, "box");
  check_closed_shape(kTorus, "torus");
  check_closed_shape(kUnion, "union");
  check_closed_shape(kDifference, "difference");
  check_closed_shape(kIntersection, "intersection");
  // A thin wall (0.05 thick, cells of side ~0.02 at this tolerance) stays closed.
  check_closed_shape("(max (- (abs x) 0.025) (- (abs y) 1) (- (abs z) 1))", "thin wall");
  // (The sphere, union and torus take sqrt at 0: boxes holding the origin or the axis.)
  // The unit sphere as a quotient, not a distance: only closedness and orientation checked.
  check_closed_shape("(/ (- (+ (square x) (square y) (square z)) 1) (+ 1 (square x)))",
                     "quotient", false);
  // A division by an interval holding 0: (y - 2) / (x + 0.1) jumps from -inf to inf across
  // x = -0.1 (boxes there are (-inf, inf) and split to the last level): the half ball x > -0.1,
  // closed, its cut face where f changes sign.
  check_closed_shape("(max (- (sqrt (+ (square x) (square y) (square z))) 1) "
                     "(/ (- y 2) (+ x 0.1)))",
                     "division through 0", false);
}

// Issue 32: leaves sized by their own depth. Long shapes seen end-on from close by (depths from
// 1 to 9) get leaves of two to four sides; where a smaller leaf meets a larger one the mesh is
// still closed, and every vertex within the tolerance at its own depth.
TEST(Implicit3D, LeavesOfSeveralSidesJoinWithoutCracks) {
  Camera cam;
  cam.eye = {0.3, 0.2, 1.8};
  cam.target = {0, 0, -2};
  cam.up = {0, 1, 0};
  cam.fov_y_deg = 60;
  cam.width = 320, cam.height = 240;
  cam.near_plane = 0.2, cam.far_plane = 20;
  // A capsule along z from -6 to 0.5 (the distance to a segment), a torus standing across the
  // view (its ring in the y-z plane), a box with a ball cut out.
  const char* capsule =
      "(- (sqrt (+ (square x) (square y) (square (+ (max (- z 0.5) 0) (min (+ z 6) 0))))) 0.4)";
  EXPECT_GE(check_closed_shape(capsule, "capsule", true, &cam, 2.0f), 3);
  const char* standing =
      "(- (sqrt (+ (square (- (sqrt (+ (square y) (square (+ z 2)))) 1.2)) (square x))) 0.3)";
  EXPECT_GE(check_closed_shape(standing, "standing torus", true, &cam, 2.0f), 2);
  const char* hollow =
      "(max (- (abs x) 0.5) (- (abs y) 0.4) (- (abs (+ z 2.5)) 3) "
      "     (- 0.3 (sqrt (+ (square x) (square (- y 0.4)) (square (+ z 1))))))";
  EXPECT_GE(check_closed_shape(hollow, "box with a bite", true, &cam, 2.0f), 3);
}

TEST(Implicit3D, BackFacesLeftOutOnlyWhereHidden) {
  // The torus from outside: back faces go, the visible map keeps its area and its raster.
  const Scene s = scene_of(kTorus);
  const Camera cam = frame_scene(s, 240, 240);
  const Diced all = dice(s, cam, 2.0f), front = dice(s, cam, 2.0f, false);
  EXPECT_GT(front.st.implicit_back_faces, all.mesh.triangle_count() / 3);
  EXPECT_EQ(front.mesh.triangle_count() + front.st.implicit_back_faces, all.mesh.triangle_count());
  // Every kept triangle is one of the full mesh's, with its corners and normals (the kept
  // vertices are renumbered).
  const auto corners = [](const Mesh& m, size_t t) {
    std::array<std::array<float, 6>, 3> c;
    for (int k = 0; k < 3; ++k)
      for (int a = 0; a < 3; ++a) {
        c[k][a] = m.positions[3 * m.indices[3 * t + k] + a];
        c[k][3 + a] = m.normals[3 * m.indices[3 * t + k] + a];
      }
    std::rotate(c.begin(), std::min_element(c.begin(), c.end()), c.end());
    return c;
  };
  std::set<std::array<std::array<float, 6>, 3>> full;
  for (size_t t = 0; t < all.mesh.triangle_count(); ++t) full.insert(corners(all.mesh, t));
  for (size_t t = 0; t < front.mesh.triangle_count(); ++t)
    ASSERT_TRUE(full.count(corners(front.mesh, t))) << "triangle " << t;
  ASSERT_EQ(front.mesh.normals.size(), front.mesh.positions.size());
  Scene a = s, f = s;
  a.meshes[0] = all.mesh;
  f.meshes[0] = front.mesh;
  const PlanarMap ma = renderer().render(a, cam), mf = renderer().render(f, cam);
  double area_a = 0, area_f = 0;
  for (size_t i = 0; i < ma.fragment_count(); ++i) area_a += ma.fragment_area(i);
  for (size_t i = 0; i < mf.fragment_count(); ++i) area_f += mf.fragment_area(i);
  EXPECT_NEAR(area_f, area_a, 1e-5 * area_a);  // areas over the map's rounded vertices
  std::vector<uint32_t> ra, rf;
  renderer().raster_ids(a, cam, &ra);
  renderer().raster_ids(f, cam, &rf);
  // raster_ids samples pixel centres in float, not exactly: a centre within a ten-thousandth of
  // a pixel of the silhouette, on a sliver where front and back faces meet, can fall either way
  // (one such pixel here). Away from the silhouette no pixel may differ, and on it only a few.
  size_t differ = 0, off_edge = 0, covered = 0;
  const uint32_t W = cam.width, H = cam.height;
  for (size_t i = 0; i < ra.size(); ++i) {
    covered += ra[i] != ~0u;
    if ((ra[i] == ~0u) == (rf[i] == ~0u)) continue;
    ++differ;
    const int x = int(i % W), y = int(i / W);
    bool edge = false;
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx) {
        const int u = x + dx, w = y + dy;
        if (u >= 0 && w >= 0 && u < int(W) && w < int(H))
          edge |= (ra[size_t(w) * W + u] == ~0u) != (ra[i] == ~0u);
      }
    off_edge += !edge;
  }
  EXPECT_GT(covered, 5000u);
  EXPECT_EQ(off_edge, 0u);
  EXPECT_LE(differ, 2u);
  // From inside the torus's tube the eye sees back faces: none are left out.
  Camera in = cam;
  in.eye = {1, 0, 0.1};
  in.target = {1, 1, 0.1};
  in.up = {0, 0, 1};
  in.near_plane = 0.2, in.far_plane = 10;
  in.width = in.height = 64;
  const Diced inside = dice(s, in, 16.0f, false);
  EXPECT_EQ(inside.st.implicit_back_faces, 0u);
}

// The near plane inside the solid across the whole view (issue 45): every ray starts inside and
// meets the far surface's inner side, so ray casting covers every pixel. No leaf in view is cut
// by the near plane and the eye is outside, yet back faces must stay: the whole view is covered,
// also with the dicer's occlusion on (as the CLI dices). Before, 0 triangles and an empty frame.
TEST(Implicit3D, NearPlaneInsideTheSolidKeepsTheInnerSurface) {
  for (const char* shape : {kSphere, kBox}) {
    const Scene s = scene_of(shape);
    Camera cam;
    cam.eye = {0, 0, 1.3};
    cam.target = {0, 0, 0};
    cam.up = {0, 1, 0};
    cam.fov_y_deg = 40;
    cam.near_plane = 0.8, cam.far_plane = 10;
    cam.width = cam.height = 48;
    for (bool occlusion : {false, true}) {
      TessellateOptions o;
      o.implicit_tolerance_px = 1.0f;
      o.implicit_back_faces = false;  // left out where hidden
      o.implicit_occlusion = occlusion;
      TessellateStats st;
      const Scene diced = renderer().tessellate(s, cam, o, &st);
      ASSERT_GT(diced.meshes.at(0).triangle_count(), 0u) << shape;
      EXPECT_EQ(st.implicit_back_faces, 0u) << shape;
      std::vector<uint32_t> ids;
      renderer().raster_ids(diced, cam, &ids);
      const size_t covered = size_t(std::count_if(ids.begin(), ids.end(),
                                                  [](uint32_t i) { return i != ~0u; }));
      EXPECT_EQ(covered, ids.size()) << shape << (occlusion ? " (occlusion)" : "");
    }
  }
}

TEST(Implicit3D, SphereNormalsAreTheGradient) {
  const Scene s = scene_of(kSphere);
  const Diced d = dice(s, frame_scene(s, 256, 256), 1.0f);
  for (size_t v = 0; v < d.mesh.vertex_count(); ++v) {
    const double* p = nullptr;
    (void)p;
    double x = d.mesh.positions[3 * v], y = d.mesh.positions[3 * v + 1],
           z = d.mesh.positions[3 * v + 2], r = std::sqrt(x * x + y * y + z * z);
    EXPECT_NEAR(d.mesh.normals[3 * v] * r, x, 1e-4);
    EXPECT_NEAR(d.mesh.normals[3 * v + 1] * r, y, 1e-4);
    EXPECT_NEAR(d.mesh.normals[3 * v + 2] * r, z, 1e-4);
  }
  // Tape shortening: the leaves' tapes are shorter than the full (box-clipped) tape.
  EXPECT_LT(d.st.implicit_leaf_clauses, d.st.implicit_leaves * d.st.implicit_clauses_full);
}

TEST(Implicit3D, FinerToleranceMeansSmallerCells) {
  const Scene s = scene_of(kTorus);
  const Camera cam = frame_scene(s, 256, 256);
  const Diced a = dice(s, cam, 4.0f), b = dice(s, cam, 1.0f);
  EXPECT_GE(b.st.implicit_cells, 3 * a.st.implicit_cells);
  EXPECT_LE(b.st.implicit_cells, 6 * a.st.implicit_cells);
  EXPECT_GT(b.mesh.triangle_count(), 8 * a.mesh.triangle_count());
}

TEST(Implicit3D, OnlyWhatTheViewNeedsAndNoGapInside) {
  // A large sphere seen from close by: most of it is outside the view and culled; edges of one
  // triangle (the cut) lie outside the viewport.
  const Scene s = scene_of("(- (sqrt (+ (square x) (square y) (square z))) 5)");
  Camera cam = frame_scene(s, 200, 150);
  cam.eye = {0, 0, 9};
  cam.target = {0, 0, 0};
  cam.fov_y_deg = 20;
  cam.near_plane = 0.1, cam.far_plane = 100;
  const Diced d = dice(s, cam, 4.0f);
  EXPECT_GT(d.st.culled, 0u);
  const Mat4 vp = cam.view_projection();
  size_t open = 0;
  for (const auto& [e, uses] : edge_uses(d.mesh)) {
    ASSERT_LE(uses, 2);
    if (uses == 2) continue;
    ++open;
    for (uint32_t v : {e.first, e.second}) {
      double q[4];
      for (int r = 0; r < 4; ++r)
        q[r] = vp[r] * d.mesh.positions[3 * v] + vp[4 + r] * d.mesh.positions[3 * v + 1] +
               vp[8 + r] * d.mesh.positions[3 * v + 2] + vp[12 + r];
      const double x = q[0] / q[3], y = q[1] / q[3];
      EXPECT_TRUE(std::abs(x) > 1 || std::abs(y) > 1) << "open edge in view at " << x << ", " << y;
    }
  }
  EXPECT_GT(open, 0u);
}

TEST(Implicit3D, BoundsSearch) {
  const implicit::Tape t = implicit::parse("(- (sqrt (+ (square (- x 3)) (square y) (square z))) 2)", "s");
  const auto b = implicit::find_bounds(t, "s");
  const double want[6] = {1, -2, -2, 5, 2, 2};
  for (int k = 0; k < 3; ++k) {
    EXPECT_LE(b[k], want[k]);
    EXPECT_GE(b[k], want[k] - 1);
    EXPECT_GE(b[k + 3], want[k + 3]);
    EXPECT_LE(b[k + 3], want[k + 3] + 1);
  }
  // Away from the origin: the small cubes are empty there, a larger one holds it.
  const auto far = implicit::find_bounds(
      implicit::parse("(- (sqrt (+ (square (- x 100)) (square y) (square z))) 2)", "far"), "far");
  EXPECT_LE(far[0], 98);
  EXPECT_GE(far[0], 97);
  EXPECT_GE(far[3], 102);
  EXPECT_LE(far[3], 103);
  try {
    implicit::find_bounds(implicit::parse("(+ x z)", "half"), "half.sexp");
    ADD_FAILURE() << "a half-space has no bounds";
  } catch (const InputError& e) {
    EXPECT_EQ(e.kind(), InputErrorKind::BadScene);
    EXPECT_NE(std::string(e.what()).find("half.sexp"), std::string::npos) << e.what();
  }
  try {
    implicit::find_bounds(implicit::parse("(+ (square x) 1)", "none"), "none.sexp");
    ADD_FAILURE() << "f > 0 everywhere";
  } catch (const InputError& e) {
    EXPECT_EQ(e.kind(), InputErrorKind::EmptyMesh);
  }
}

TEST(Implicit3D, GradientMatchesFiniteDifferences) {
  const std::string path = std::string(VISMAP_SHARED_DATA_DIR) + "/implicit/mpr_architecture.sexp";
  if (!std::filesystem::exists(path)) GTEST_SKIP() << "no ../shared/data";
  const implicit::Tape t = implicit::load(path);
  const implicit::SlotTape s = implicit::allocate_slots(t);
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> ux(-18, 18), uy(-5, 12), uz(-0.5, 10);
  int checked = 0;
  for (int i = 0; i < 400; ++i) {
    const double x = ux(rng), y = uy(rng), z = uz(rng);
    double g[3];
    const double f = implicit::eval_code_grad(s.code.data(), s.size(), s.slots, s.root_slot, x,
                                              y, z, g);
    EXPECT_NEAR(f, implicit::eval_slots(s, x, y, z), 1e-9);
    const double e = 1e-6;
    const double fd[3] = {
        (implicit::eval_slots(s, x + e, y, z) - implicit::eval_slots(s, x - e, y, z)) / (2 * e),
        (implicit::eval_slots(s, x, y + e, z) - implicit::eval_slots(s, x, y - e, z)) / (2 * e),
        (implicit::eval_slots(s, x, y, z + e) - implicit::eval_slots(s, x, y, z - e)) / (2 * e)};
    // Away from kinks (min/max switching within e) the derivatives agree.
    const double fd2x =
        (implicit::eval_slots(s, x + 2 * e, y, z) - implicit::eval_slots(s, x - 2 * e, y, z)) /
        (4 * e);
    if (std::abs(fd2x - fd[0]) > 1e-5) continue;
    ++checked;
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(g[k], fd[k], 1e-4) << x << " " << y << " " << z;
  }
  EXPECT_GT(checked, 300);
}

namespace {
struct TempDir {
  fs::path dir;
  TempDir() : dir(fs::temp_directory_path() / ("vismap_implicit3d_" + std::to_string(::getpid()))) {
    fs::create_directories(dir);
  }
  ~TempDir() { fs::remove_all(dir); }
  std::string write(const std::string& name, const std::string& text) const {
    std::ofstream(dir / name) << text;
    return (dir / name).string();
  }
};

std::string error_of(const std::string& path) {
  try {
    load_scene(path);
  } catch (const InputError& e) {
    return e.what();
  }
  return "no error";
}
}  // namespace

TEST(Implicit3D, SceneFileObjectsTransformsAndBadInput) {
  TempDir t;
  t.write("ball.sexp", kSphere);
  const std::string ok = t.write(
      "s.json",
      R"J({"meshes": [{"file": "ball.sexp", "scale": 2, "translate": [5, 0, 0], "color": [1, 0, 0]},
                      {"expression": "(max (- (abs x) 1) (- (abs y) 1) (- (abs z) 1))",
                       "bounds": [-1.5, -1.5, -1.5, 1.5, 1.5, 1.5], "scale": [-1, 1, 1],
                       "name": "cube"}]})J");
  const Scene s = load_scene(ok);
  ASSERT_EQ(s.meshes.size(), 2u);
  EXPECT_EQ(s.meshes[0].name, "ball");
  EXPECT_EQ(s.meshes[1].name, "cube");
  EXPECT_EQ(s.meshes[1].implicit_box[0], -1.5);
  EXPECT_EQ(s.meshes[0].color[0], 1.0f);
  const Camera cam = frame_scene(s, 320, 200);
  TessellateOptions o;
  o.implicit_tolerance_px = 2;
  o.implicit_back_faces = true;  // closed, for the volume
  o.implicit_occlusion = false;
  const Scene d = renderer().tessellate(s, cam, o);
  // The ball: radius 2 about (5, 0, 0).
  for (size_t v = 0; v < d.meshes[0].vertex_count(); v += 7) {
    const float* p = &d.meshes[0].positions[3 * v];
    EXPECT_NEAR(std::hypot(p[0] - 5, p[1], p[2]), 2, 0.1);
  }
  // The mirrored cube keeps its triangles facing out: the signed volume is positive.
  const Mesh& c = d.meshes[1];
  double vol = 0;
  for (size_t tr = 0; tr < c.triangle_count(); ++tr) {
    const float* a = &c.positions[3 * c.indices[3 * tr]];
    const float* b = &c.positions[3 * c.indices[3 * tr + 1]];
    const float* e = &c.positions[3 * c.indices[3 * tr + 2]];
    vol += (a[0] * (b[1] * e[2] - b[2] * e[1]) - a[1] * (b[0] * e[2] - b[2] * e[0]) +
            a[2] * (b[0] * e[1] - b[1] * e[0])) / 6;
  }
  EXPECT_NEAR(vol, 8, 0.5);

  const auto expect_error = [&](const std::string& json, const std::string& want) {
    const std::string p = t.write("bad.json", json);
    const std::string err = error_of(p);
    EXPECT_NE(err.find(want), std::string::npos) << json << "\n -> " << err;
  };
  expect_error(R"J({"meshes": [{"expression": "(- x", "bounds": [0,0,0,1,1,1]}]})J",
               "meshes[0].expression: line 1 column");
  expect_error(R"J({"meshes": [{"expression": "(+ x z)", "bounds": [0,0,0,1,1]}]})J",
               "meshes[0].bounds: expected an array of 6 numbers");
  expect_error(R"J({"meshes": [{"expression": "(+ x z)", "bounds": [0,0,0,1,0,1]}]})J",
               "each lo < hi");
  expect_error(R"J({"meshes": [{"expression": "(+ x z)", "file": "ball.sexp"}]})J",
               "give either 'file' or 'expression'");
  expect_error(R"J({"meshes": [{"expression": 3}]})J", "expected an expression string");
  expect_error(R"J({"meshes": [{"expression": "(+ x z)"}]})J",
               "bad.json meshes[0].expression: the solid f < 0");
  expect_error(R"J({"meshes": [{"file": "ball.sexp", "subdivision": true}]})J",
               "an implicit object has no control mesh");
  expect_error(R"J({"meshes": [{"file": "ball.sexp", "scale": [1, 1, 1], "matrix": [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1]}]})J",
               "cannot be combined");
  expect_error(R"J({"meshes": [{"file": "ball.sexp", "matrix": [1,0,0,0, 0,1,0,0, 0,0,0,0, 0,0,0,1]}]})J",
               "affine and invertible");
  expect_error(R"J({"meshes": [{"file": "ball.sexp", "bounds": [1, 1, 1, 2, 2, 2]}]})J", "no error");
}

TEST(Implicit3D, MixedSceneThroughTheExactPipeline) {
  // The bunny standing on an implicit slab with a sphere cut out of it, penetrating it: both
  // objects are in the map, and the slab hides the bunny's feet.
  TempDir t;
  const std::string bunny = std::string(VISMAP_SOURCE_DIR) + "/data/bunny.ply";
  const std::string p = t.write(
      "mixed.json",
      R"J({"meshes": [{"file": ")J" + bunny + R"J(", "name": "bunny"},
                      {"expression": "(max (- (abs x) 0.12) (- (abs (- y 0.045)) 0.01) (- (abs z) 0.12) (- 0.03 (sqrt (+ (square (- x 0.06)) (square (- y 0.045)) (square z)))))",
                       "name": "slab", "color": [0.3, 0.5, 0.8]}]})J");
  const Scene s = load_scene(p);
  ASSERT_EQ(s.meshes.size(), 2u);
  const Camera cam = frame_scene(s, 256, 256);
  TessellateOptions o;
  o.implicit_tolerance_px = 2;
  const Scene d = renderer().tessellate(s, cam, o);
  EXPECT_EQ(d.meshes[0].triangle_count(), s.meshes[0].triangle_count());  // the bunny as is
  EXPECT_GT(d.meshes[1].triangle_count(), 100u);
  const PlanarMap map = renderer().render(d, cam);
  double area[2] = {0, 0};
  for (size_t f = 0; f < map.fragment_count(); ++f) area[map.mesh[f]] += map.fragment_area(f);
  EXPECT_GT(area[0], 1000);
  EXPECT_GT(area[1], 1000);
}

// Issue 35, case 3: the time limit holds inside implicit tessellation (checked after each round
// of the region queue and each batch of leaf points), not only between meshes: the architecture
// model at implicit tolerance 0.5 px dices for many seconds; with a 1 s limit it stops with
// TimeLimit naming stage tessellate. (Checked between meshes only, the limit was met at the start
// and the dice ran on to its end or to the queue's own cap.)
TEST(Implicit3D, TimeLimitHoldsInsideTheDice) {
  const std::string path = std::string(VISMAP_SOURCE_DIR) + "/bench/implicit/architecture.json";
  if (!std::filesystem::exists(std::string(VISMAP_SHARED_DATA_DIR) +
                               "/implicit/mpr_architecture.sexp"))
    GTEST_SKIP() << "no ../shared/data";
  const Scene s = load_scene(path);
  ASSERT_TRUE(s.camera.has_value());
  Camera cam = *s.camera;
  fit_near_far(cam, s);
  TessellateOptions o;
  o.implicit_tolerance_px = 0.5f;
  o.time_limit_s = 1.0;
  try {
    renderer().tessellate(s, cam, o);
    FAIL() << "the dice should pass a 1 s limit";
  } catch (const InputError& e) {
    EXPECT_EQ(e.kind(), InputErrorKind::TimeLimit) << e.what();
    EXPECT_NE(std::string(e.what()).find("in stage tessellate"), std::string::npos) << e.what();
  }
}
