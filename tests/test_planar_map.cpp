// Planar-map invariants on real meshes (DESIGN §4), checked exactly with CGAL: no two output
// fragments overlap, the output covers exactly the union of the projected scene, every fragment
// lies in its source triangle; and a z-buffer id raster agrees away from edges.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

#include "core/camera.h"
#include "core/pipeline.h"
#include "core/scene.h"
#include "tests/support/planar_check.h"

namespace {

using namespace vismap;

std::string shared(const std::string& rel) { return std::string(VISMAP_SHARED_DATA_DIR) + "/" + rel; }

Renderer& renderer() {
  static Renderer r;
  return r;
}

struct Case {
  std::string name, path;
  uint32_t size;
  bool ortho;
};

void PrintTo(const Case& c, std::ostream* os) { *os << c.name; }

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
  EXPECT_LT(rep.coverage_error, 1e-12) << rep.summary();  // area sums are fixed point (docs/CHECKS.md)

  check::PixelReport px = check::pixel_compare(map, screen, 1024);
  EXPECT_LT(px.fraction, 1e-3) << px.mismatched << " of " << px.samples;
}

INSTANTIATE_TEST_SUITE_P(
    RealMeshes, PlanarMapInvariants,
    ::testing::Values(Case{"bunny_res4", shared("stanford/bun_zipper_res4.ply"), 512, false},
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
