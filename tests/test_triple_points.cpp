// Triple points of mutually penetrating triangles (docs/NUMERICS.md §2): seeded clusters of
// triangles whose planes meet near one point (nearly or exactly concurrent planes, random planes
// near one depth, small crowded triangles, and folds of one surface through them). Independently
// snapped crossing lines meet in snap-sized cells that order three or more triangles cyclically;
// the map must stay hole-free and overlap-free there, in both input orders. Only the planar map
// invariants are checked (exact, no reference): they are what a cycle breaks.
// Before the tournament rule 42 of these 48 runs had holes (coverage_error 1e-10 and more).
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "core/check/scene_check.h"
#include "core/pipeline.h"
#include "core/scene.h"
#include "tests/support/triangle_scene.h"

namespace {

using namespace vismap;

Renderer& renderer() {
  static Renderer r;
  return r;
}

using test_support::add_triangle;

// World units = pixels (orthographic 256x256 looking down -z), as in data/stiff/.
Scene cluster_scene(uint64_t seed, Camera& cam) {
  std::mt19937_64 rng(seed);
  auto uni = [&](double a, double b) { return a + (b - a) * double(rng() >> 11) * 0x1.0p-53; };
  Scene s;
  add_triangle(s, "bg0", {{8, 8, 0}, {248, 8, 0}, {248, 248, 0}});
  add_triangle(s, "bg1", {{8, 8, 0}, {248, 248, 0}, {8, 248, 0}});
  const int kind = int(seed % 4);
  const int n = 4 + int(rng() % 9);
  const double cx = 128 + uni(-20, 20), cy = 128 + uni(-20, 20), cz = 20;
  for (int t = 0; t < n; ++t) {
    double gx, gy, z0;
    if (kind == 0) {  // planes through nearly one point
      gx = uni(-0.4, 0.4), gy = uni(-0.4, 0.4), z0 = cz + uni(-0.02, 0.02);
    } else if (kind == 1) {  // random planes near one depth
      gx = uni(-0.3, 0.3), gy = uni(-0.3, 0.3), z0 = cz + uni(-5, 5);
    } else if (kind == 2) {  // exactly concurrent planes
      gx = uni(-0.4, 0.4), gy = uni(-0.4, 0.4), z0 = cz;
    } else {  // small crowded triangles
      gx = uni(-1, 1), gy = uni(-1, 1), z0 = cz + uni(-3, 3);
    }
    const double size = kind == 3 ? uni(2, 10) : uni(20, 120);
    const double b = uni(0, 2 * M_PI), ox = uni(-size / 2, size / 2), oy = uni(-size / 2, size / 2);
    double p[3][3];
    for (int j = 0; j < 3; ++j) {
      const double a = b + 2 * M_PI * j / 3 + uni(-0.5, 0.5);
      const double x = cx + ox + size * std::cos(a), y = cy + oy + size * std::sin(a);
      p[j][0] = x, p[j][1] = y, p[j][2] = z0 + gx * (x - cx) + gy * (y - cy);
    }
    add_triangle(s, "t" + std::to_string(t), p);
  }
  if (seed % 3 == 0) {  // a fold: two triangles on one edge, on the same side of it on screen
    const double a[3] = {cx - 30, cy - 5, cz + 1}, e[3] = {cx + 30, cy + 5, cz - 1};
    const double c1[3] = {cx + uni(-10, 10), cy + 40, cz + uni(-8, 8)};
    const double c2[3] = {cx + uni(-10, 10), cy + 25, cz + uni(-8, 8)};
    add_triangle(s, "fold0", {{a[0], a[1], a[2]}, {e[0], e[1], e[2]}, {c1[0], c1[1], c1[2]}});
    add_triangle(s, "fold1", {{a[0], a[1], a[2]}, {e[0], e[1], e[2]}, {c2[0], c2[1], c2[2]}});
  }
  cam = test_support::ortho_view_256(s);
  if (seed % 5 == 0) {  // perspective instead
    cam.projection = Camera::Projection::Perspective;
    cam.eye = {128 + uni(-40, 40), 128 + uni(-40, 40), 150};
    cam.target = {128, 128, 20};
    cam.fov_y_deg = 90;
    fit_near_far(cam, s);
  }
  return s;
}

TEST(TriplePoints, PenetratingClustersAreHoleFreeAndOverlapFree) {
  check::SceneCheckOptions opts;
  opts.reference = false;
  opts.pixels = 0;
  size_t crossing = 0;
  for (uint64_t seed = 0; seed < 24; ++seed) {
    Camera cam;
    Scene scene = cluster_scene(seed, cam);
    check::ReversedScene rev = check::reverse_order(scene);
    for (const Scene* s : {&scene, &rev.scene}) {
      check::SceneFigures f = check::check_scene(renderer(), *s, cam, opts);
      const std::string what = "seed " + std::to_string(seed) + (s == &scene ? "" : " reversed") +
                               ": " + check::to_json(f).dump();
      crossing += f.crossing_lines;
      EXPECT_EQ(*f.overlap_area, 0.0) << what;
      EXPECT_LE(*f.coverage_error, 1e-20) << what;
      EXPECT_EQ(*f.outside_source, 0u) << what;
      EXPECT_EQ(check::over_tolerance(f), std::vector<std::string>{}) << what;
    }
  }
  EXPECT_GT(crossing, 0u);  // the scenes do penetrate
}

}  // namespace
