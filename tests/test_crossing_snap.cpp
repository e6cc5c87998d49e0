// Regression model: crossing lines of simple slope (docs/NUMERICS.md §2). The crossing line of a
// penetrating pair used to be snapped to a line through two grid points. Searching the columns next
// to the overlap for the one where the line passes closest to a grid point gives ~1/512 grid unit
// for a generic slope, but a horizontal, vertical or diagonal line (slope near p/q with small q)
// rounds alike in every column: up to 1/2 grid unit off over the whole overlap. That was the
// area_error of nearly_touching (9.5e-6, a horizontal line 0.41 grid units off) and of
// far_coordinates_1e6 / tiny_scene_1e-6 (4.5e-6, a vertical one), 20-50x below snap_area_bound and
// untouched by the column search. Crossing lines are now integer (a, b, c), which can be exactly
// axis-parallel at any offset to 2^-24 grid units. Here: a pair of large triangles crossing along
// lines of such slopes, at offsets off the grid, against the exact reference.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

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

// World units = pixels (orthographic 256x256 looking down -z). Triangle a is flat at z = 10;
// b's plane rises across the line through (px, py) with normal (nx, ny), so the pair crosses
// along that line over ~150 px.
Scene crossing_pair(double nx, double ny, double px, double py, Camera& cam) {
  Scene s;
  add_triangle(s, "a", {{20, 20, 10}, {236, 20, 10}, {128, 240, 10}});
  auto z = [&](double x, double y) { return 10 + 0.05 * (nx * (x - px) + ny * (y - py)); };
  add_triangle(s, "b", {{20, 236, z(20, 236)}, {236, 236, z(236, 236)}, {128, 16, z(128, 16)}});
  cam = test_support::ortho_view_256(s);
  return s;
}

TEST(CrossingSnap, SimpleSlopesSnapWellBelowHalfAGridUnit) {
  check::SceneCheckOptions opts;
  opts.pixels = 0;
  // Line normals: horizontal and vertical lines, diagonals, slopes 1/2 and 1/3, and a generic one.
  const double normals[][2] = {{0, 1}, {1, 0}, {1, 1}, {1, -1}, {1, 2}, {3, -1}, {0.2955, 0.9553}};
  double worst = 0;
  for (const auto& n : normals)
    for (double off :
         {0.0, 0.37, 0.49, 0.73}) {  // pixels: off the 1/256-pixel grid by up to 1/2 unit
      const double len = std::hypot(n[0], n[1]);
      const double px = 128 + off / 3, py = 128 + off;
      Camera cam;
      Scene scene = crossing_pair(n[0] / len, n[1] / len, px, py, cam);
      check::ReversedScene rev = check::reverse_order(scene);
      for (const Scene* s : {&scene, &rev.scene}) {
        check::SceneFigures f = check::check_scene(renderer(), *s, cam, opts);
        const std::string what = "normal (" + std::to_string(n[0]) + ", " + std::to_string(n[1]) +
                                 ") offset " + std::to_string(off) +
                                 (s == &scene ? "" : " reversed") + ": " + check::to_json(f).dump();
        ASSERT_GT(f.crossing_lines, 0u) << what;
        EXPECT_EQ(*f.overlap_area, 0.0) << what;
        EXPECT_LE(*f.coverage_error, 1e-20) << what;
        EXPECT_EQ(check::over_tolerance(f), std::vector<std::string>{}) << what;
        // A line 1/2 grid unit off over ~150 px is ~5e-6 of the visible area (both members count
        // the sliver). Integer lines: a slope within 2^-24 of a simple fraction (these planes'
        // float vertices tilt the vertical line by ~1e-8) is off by up to h * 2^-24; worst
        // measured 2.9e-8 (vertical), 3.0e-7 with the two-point lines snapped by direction.
        EXPECT_LE(*f.area_error, 1e-7) << what;
        worst = std::max(worst, *f.area_error);
      }
    }
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3g", worst);
  RecordProperty("worst_area_error", buf);
}

}  // namespace
