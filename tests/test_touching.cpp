// A surface that passes from in front of a triangle to behind it exactly across one of its own
// mesh edges (docs/NUMERICS.md §2, "Touching pairs"). Neither triangle at that edge crosses the
// other surface beyond the tie band, so no crossing line marks the edge, and it is no silhouette
// (the surface goes on); yet the visibility of the triangle behind changes there. Found in the
// teapot in a stadium (two Loop-subdivided teapot sheets meeting at a mesh edge): 6 overlapping
// pairs, 3.6e-5 px^2.
//
// The scene, orthographic, world units = pixels: B, a large triangle at z = 0; S, two triangles
// A and N of one mesh sharing the edge E on x = 150, on the plane z = (x - 150) / 2, so that A
// (x > 150) is in front of B and N (x < 150) behind it, and they meet B's depth exactly on E.
// A's other two edges are the mesh's boundary (silhouettes); B's centroid is outside S.
#include <gtest/gtest.h>

#include "core/check/scene_check.h"
#include "core/pipeline.h"
#include "core/scene.h"
#include "tests/support/triangle_scene.h"

namespace {

using namespace vismap;

Scene touching_scene(double tilt) {
  Scene s;
  test_support::add_triangle(s, "B", {{20, 20, 0}, {230, 40, 0}, {60, 230, 0}});
  Mesh m;
  m.name = "S";
  const double v[4][2] = {{150, 60}, {150, 120}, {190, 90}, {110, 90}};
  for (const auto& p : v)
    for (double c : {p[0], p[1], tilt * (p[0] - 150)}) m.positions.push_back(float(c));
  m.indices = {1, 0, 2, 0, 1, 3};  // A = (v1, v0, v2), N = (v0, v1, v3): E runs both ways
  m.face_ids = {0, 1};
  m.source_triangles = 2;
  s.meshes.push_back(std::move(m));
  return s;
}

TEST(Touching, SurfacePassingBehindAcrossAMeshEdge) {
  Renderer r;
  for (double tilt : {0.5, 0.01, 2.0}) {
    const Scene s = touching_scene(tilt);
    for (bool reversed : {false, true}) {
      check::ReversedScene rev = check::reverse_order(s);
      const Scene& scene = reversed ? rev.scene : s;
      check::SceneCheckOptions o;
      o.pixels = 256;
      check::SceneFigures f = check::check_scene(r, scene, test_support::ortho_view_256(scene), o);
      const std::string what = "tilt " + std::to_string(tilt) + (reversed ? " reversed" : "") +
                               ": " + check::to_json(f).dump();
      EXPECT_EQ(f.crossing_lines > 0, true) << what;  // the touching pair's edges
      EXPECT_EQ(*f.overlap_area, 0.0) << what;
      EXPECT_EQ(*f.area_error, 0.0) << what;
      EXPECT_EQ(*f.wrong_source, 0u) << what;
      EXPECT_LE(*f.coverage_error, 1e-20) << what;
      EXPECT_EQ(check::over_tolerance(f), std::vector<std::string>{}) << what;
    }
  }
}

}  // namespace
