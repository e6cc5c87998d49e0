// Real meshes checked through check_scene (core/check/scene_check.h): small ones against the
// exact reference, large ones by pixels, within `vismap check`'s tolerances.
#include <gtest/gtest.h>

#include <filesystem>

#include "core/check/scene_check.h"
#include "core/pipeline.h"

namespace {

using namespace vismap;

struct RealCase {
  std::string name, path;
  bool reference;
};
void PrintTo(const RealCase& c, std::ostream* os) {
  *os << c.name;
}

std::string shared(const std::string& rel) {
  return std::string(VISMAP_SHARED_DATA_DIR) + "/" + rel;
}

class RealMeshes : public ::testing::TestWithParam<RealCase> {};

TEST_P(RealMeshes, WithinTolerance) {
  const RealCase& c = GetParam();
  if (!std::filesystem::exists(c.path)) GTEST_SKIP() << c.path << " not present";
  static Renderer renderer;
  Scene scene = load_scene(c.path);
  Camera cam = scene.camera ? *scene.camera : frame_scene(scene, 512, 512);
  cam.width = cam.height = 512;
  fit_near_far(cam, scene);
  check::SceneCheckOptions o;
  o.reference = c.reference;
  o.invariants = c.reference;  // the CGAL union is the slow part on big scenes
  o.pixels = 512;
  check::SceneFigures f = check::check_scene(renderer, scene, cam, o);
  EXPECT_EQ(check::over_tolerance(f), std::vector<std::string>{}) << check::to_json(f).dump();
  // No wrong-source fragment, also where surfaces penetrate (the teapot: 153 crossing pairs,
  // all exact lines between integer depth planes; 5 band cells before them).
  if (c.reference) {
    EXPECT_EQ(*f.wrong_source, 0u) << check::to_json(f).dump();
  }
}

INSTANTIATE_TEST_SUITE_P(
    Meshes, RealMeshes,
    ::testing::Values(
        RealCase{"bunny_res4_reference", shared("stanford/bun_zipper_res4.ply"), true},
        RealCase{"teapot_reference", shared("teapot/teapot_c3d.obj"), true},
        RealCase{"bunny_res2_pixels", shared("stanford/bun_zipper_res2.ply"), false},
        RealCase{"happy_vrip_res3_pixels", shared("stanford/happy_vrip_res3.ply"), false},
        RealCase{"cornell_armadillo_pixels",
                 std::string(VISMAP_SOURCE_DIR) + "/data/scenes/cornell_armadillo.json", false}),
    [](const ::testing::TestParamInfo<RealCase>& i) { return i.param.name; });

}  // namespace
