// Planar-map invariants on real meshes (DESIGN §4), checked exactly with CGAL: no two output
// fragments overlap, the output covers exactly the union of the projected scene, every fragment
// lies in its source triangle; and a z-buffer id raster agrees away from edges.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>

#include "core/camera.h"
#include "core/check/planar_check.h"
#include "core/pipeline.h"
#include "core/scene.h"

namespace {

using namespace vismap;

std::string shared(const std::string& rel) {
  return std::string(VISMAP_SHARED_DATA_DIR) + "/" + rel;
}

Renderer& renderer() {
  static Renderer r;
  return r;
}

struct Case {
  std::string name, path;
  uint32_t size;
  bool ortho;
};

void PrintTo(const Case& c, std::ostream* os) {
  *os << c.name;
}

class PlanarMapInvariants : public ::testing::TestWithParam<Case> {};

TEST_P(PlanarMapInvariants, ExactAndComplete) {
  const Case& c = GetParam();
  if (!std::filesystem::exists(c.path)) GTEST_SKIP() << c.path << " not present";
  Scene scene = load_scene(c.path);
  Camera cam = scene.camera ? *scene.camera : frame_scene(scene, c.size, c.size);
  cam.width = cam.height = c.size;
  if (c.ortho) {
    Bounds b = scene_bounds(scene);
    double dx = b.hi[0] - b.lo[0], dy = b.hi[1] - b.lo[1], dz = b.hi[2] - b.lo[2];
    cam.projection = Camera::Projection::Orthographic;
    cam.ortho_height = 1.1 * std::sqrt(dx * dx + dy * dy + dz * dz);
  }
  RenderOptions opts;
  opts.exact = true;
  RenderStats stats;
  ScreenTriangles screen;
  PlanarMap map = renderer().render(scene, cam, opts, &stats, &screen);
  ASSERT_GT(map.fragment_count(), 0u);
  EXPECT_EQ(stats.sliver_fragments, 0u);

  check::CheckReport rep = check::check_planar_map(map, screen);
  EXPECT_TRUE(rep.exact);
  EXPECT_EQ(rep.degenerate, 0u);
  EXPECT_EQ(rep.nonconvex, 0u);
  EXPECT_EQ(rep.overlap_pairs, 0u) << rep.summary();
  EXPECT_EQ(rep.overlap_area, 0.0) << rep.summary();
  EXPECT_EQ(rep.outside_source, 0u) << rep.summary();
  EXPECT_LT(rep.coverage_error, 1e-12)
      << rep.summary();  // area sums are fixed point (docs/CHECKS.md)

  check::PixelReport px = check::pixel_compare(map, screen, 1024);
  EXPECT_LT(px.fraction, 1e-3) << px.mismatched << " of " << px.samples;
}

INSTANTIATE_TEST_SUITE_P(
    RealMeshes, PlanarMapInvariants,
    ::testing::Values(
        Case{"bunny_res4", shared("stanford/bun_zipper_res4.ply"), 512, false},
        Case{"bunny_res3_ortho", shared("stanford/bun_zipper_res3.ply"), 768, true},
        Case{"bunny", std::string(VISMAP_SOURCE_DIR) + "/data/bunny.ply", 1024, false},
        Case{"teapot", shared("teapot/teapot_c3d.obj"), 1024, false},
        Case{"cow", shared("cgal/cow.off"), 800, false},
        Case{"elephant_with_holes", shared("cgal/elephant-with-holes.off"), 800, false},
        Case{"fandisk", shared("cgal/fandisk.off"), 800, false},
        Case{"mech_holes_shark", shared("cgal/mech-holes-shark.off"), 800, false},
        Case{"cornell_box", shared("cornell_box/CornellBox-Original.obj"), 800, false}),
    [](const ::testing::TestParamInfo<Case>& i) { return i.param.name; });

}  // namespace

namespace {

using namespace vismap;

// The planar map against the exact reference visibility (DESIGN §4) on scenes small enough for
// CGAL's Boolean operations: every fragment is visible where it claims to be.
TEST(PlanarMapReference, SmallScenesMatchExactVisibility) {
  for (const std::string& path :
       {shared("stanford/bun_zipper_res4.ply"),
        std::string(VISMAP_SOURCE_DIR) + "/data/cornell_box/CornellBox-Original.obj",
        shared("cgal/tetra_intersected_by_triangle.off")}) {
    if (!std::filesystem::exists(path)) continue;
    Scene scene = load_scene(path);
    Camera cam = frame_scene(scene, 400, 300);
    RenderOptions opts;
    opts.exact = true;
    ScreenTriangles screen;
    RenderStats stats;
    PlanarMap map = renderer().render(scene, cam, opts, &stats, &screen);
    check::ReferenceResult ref = check::exact_visibility(screen);
    check::ReferenceReport rep = check::compare_with_reference(map, screen, ref);
    // A fragment could be attributed wrongly only as a cell beside a rounded crossing line;
    // between integer depth planes every crossing line is exact (docs/NUMERICS.md §2).
    EXPECT_EQ(ref.rounded_crossing_pairs, 0u) << path;
    EXPECT_EQ(rep.wrong_source, 0u) << path;
    // Exact but for the fixed-point area sums and any tie cycle (NUMERICS §3).
    EXPECT_LE(rep.area_error, 1e-12 + ref.tie_cycle_area / std::max(ref.total_visible_area, 1e-300))
        << path << " xor area " << rep.xor_area;
  }
}

// The same scene rendered twice, by two renderers, gives the same planar map bit for bit: no
// decision depends on the order in which work-items or atomics ran.
TEST(PlanarMapReference, Deterministic) {
  std::string path = shared("teapot/teapot_c3d.obj");
  if (!std::filesystem::exists(path)) GTEST_SKIP();
  Scene scene = load_scene(path);
  Camera cam = frame_scene(scene, 640, 480);
  PlanarMap a = renderer().render(scene, cam);
  Renderer other;
  PlanarMap b = other.render(scene, cam);
  EXPECT_EQ(a.offsets, b.offsets);
  EXPECT_EQ(a.xy, b.xy);
  EXPECT_EQ(a.mesh, b.mesh);
  EXPECT_EQ(a.triangle, b.triangle);
}

}  // namespace
