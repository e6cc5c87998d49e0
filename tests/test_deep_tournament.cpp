// Occlusion tournaments with no cap (kernels/occlusion.cl occlude_deep). A fragment whose
// triangle is hidden at its sample point by an entangled partner is decided by the whole
// tournament of the triangles covering the point; up to VM_TOUR_MAX (64) of them fit private
// bit masks, and beyond that the fragment was left hidden ("a hidden t stays hidden"), a hole in
// a deep cyclic overlap, with no count and no status. Now such fragments are counted and decided
// by occlude_deep with room sized from the count, by the same relation and cycle rule.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <string>

#include "core/check/scene_check.h"
#include "core/pipeline.h"
#include "core/scene.h"
#include "tests/support/triangle_scene.h"

namespace {

using namespace vismap;
namespace fs = std::filesystem;

Scene stiff(const std::string& name) {
  return load_scene((fs::path(VISMAP_SOURCE_DIR) / "data/stiff" / (name + ".json")).string());
}

bool same_map(const PlanarMap& a, const PlanarMap& b) {
  return a.offsets == b.offsets && a.xy == b.xy && a.mesh == b.mesh && a.triangle == b.triangle;
}

// A Renderer whose program keeps at most `tour_max` triangles in the private tournament, so
// every larger tournament takes the deep path.
Renderer& small_tournaments() {
  static Renderer* r = [] {
    const char* old = std::getenv("VISMAP_CL_OPTIONS");
    const std::string keep = old ? old : "";
    setenv("VISMAP_CL_OPTIONS", (keep + " -DVM_TOUR_MAX=2").c_str(), 1);
    auto* made = new Renderer();
    if (old)
      setenv("VISMAP_CL_OPTIONS", keep.c_str(), 1);
    else
      unsetenv("VISMAP_CL_OPTIONS");
    return made;
  }();
  return *r;
}

Renderer& normal() {
  static Renderer r;
  return r;
}

// The deep path decides exactly as the private one: the same map, fragment for fragment, on the
// stiff cases with entangled partners, while most of their tournaments go deep.
TEST(DeepTournament, DecidesAsThePrivateTournament) {
  uint64_t deep = 0;
  for (const char* name : {"tie_cycle", "triple_points", "concurrent_planes", "cyclic_overlap",
                           "penetrating_triangles", "one_tile_crowded", "coplanar_overlap"}) {
    Scene scene = stiff(name);
    Camera cam = *scene.camera;
    fit_near_far(cam, scene);
    RenderStats a, b;
    PlanarMap ma = normal().render(scene, cam, {}, &a);
    PlanarMap mb = small_tournaments().render(scene, cam, {}, &b);
    EXPECT_TRUE(same_map(ma, mb)) << name;
    EXPECT_EQ(a.deep_tournaments, 0u) << name;
    deep += b.deep_tournaments;
  }
  EXPECT_GT(deep, 20u) << "the deep path must have been taken";
}

// The regression: a tie cycle (ten coplanar triangles whose tie and crossing orders are cyclic)
// in front of 70 layers covering it. Every tournament in the cycle's cells holds more than 64
// triangles; with the cap the cells were visible in no triangle (a hole of ~2.5e-11 of the
// area), now the map covers exactly the union of the triangles.
TEST(DeepTournament, TieCycleInFrontOfSeventyLayersLeavesNoHole) {
  Scene scene = stiff("tie_cycle");
  Camera cam = *scene.camera;
  for (int i = 0; i < 70; ++i) {
    const double z = -2.0 - 0.01 * i;
    test_support::add_triangle(scene, "layer" + std::to_string(i),
                               {{-20, -20, z}, {20, -20, z}, {0, 20, z}});
  }
  cam.near_plane = cam.far_plane = 0;
  fit_near_far(cam, scene);
  check::SceneCheckOptions opts;
  opts.pixels = 0;
  check::SceneFigures f = check::check_scene(normal(), scene, cam, opts);
  EXPECT_GT(f.deep_tournaments, 0u) << check::to_json(f).dump();
  EXPECT_LE(*f.coverage_error, 1e-20) << check::to_json(f).dump();
  EXPECT_EQ(*f.wrong_source, 0u) << check::to_json(f).dump();
}

}  // namespace
