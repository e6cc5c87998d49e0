// Depth planes snapped to integers (docs/NUMERICS.md §2 "Depth planes"): every screen triangle's
// nearness is N / 2^k with N integers on an integer plane (|A|, |B| <= 2^29), one k per frame
// (also across buckets), so that the crossing line of two penetrating triangles is exact: no
// snap band, and the three lines of three mutually penetrating planes meet in one point.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <random>
#include <set>

#include "core/check/scene_check.h"
#include "core/pipeline.h"
#include "core/scene.h"
#include "kernels/layout.h"
#include "tests/support/triangle_scene.h"

namespace {

using namespace vismap;

// n large triangles on random planes near one depth, mutually penetrating (many triple points).
Scene penetrating_cluster(unsigned seed, int n, double centre = 128, double size = 1) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0, 1);
  Scene s;
  for (int i = 0; i < n; ++i) {
    double cx = centre + 30 * size * (u(rng) - 0.5), cy = centre + 30 * size * (u(rng) - 0.5);
    double gx = 0.6 * (u(rng) - 0.5), gy = 0.6 * (u(rng) - 0.5), z0 = 10 + 4 * (u(rng) - 0.5);
    double p[3][3];
    for (int k = 0; k < 3; ++k) {
      double a = 2 * M_PI * (k + u(rng) * 0.5) / 3, r = size * (60 + 50 * u(rng));
      p[k][0] = cx + r * std::cos(a);
      p[k][1] = cy + r * std::sin(a);
      p[k][2] = z0 + gx * (p[k][0] - centre) + gy * (p[k][1] - centre);
    }
    test_support::add_triangle(s, "t" + std::to_string(i), p);
  }
  return s;
}

// Each snapped triangle's depths are integers over 2^k on an integer plane within the budget.
void expect_integer_planes(const ScreenTriangles& st, std::set<int32_t>* ks) {
  ASSERT_EQ(st.plane_k.size(), st.size());
  for (size_t t = 0; t < st.size(); ++t) {
    const int32_t k = st.plane_k[t];
    if (k == ScreenTriangles::kFreePlane) continue;
    ks->insert(k);
    int64_t N[3], x[3], y[3];
    for (int i = 0; i < 3; ++i) {
      const double v = std::ldexp(st.depth[3 * t + i], k);
      ASSERT_EQ(v, std::floor(v)) << "triangle " << t << " vertex " << i;
      ASSERT_LE(std::fabs(v), std::ldexp(1.0, VM_PLANE_VALUE_BITS));
      N[i] = int64_t(v);
      x[i] = st.xy[6 * t + 2 * i];
      y[i] = st.xy[6 * t + 2 * i + 1];
    }
    // A det = (N1 - N0) dy2 - (N2 - N0) dy1 exactly, A an integer within 2^29 (same for B).
    const __int128 det =
        __int128(x[1] - x[0]) * (y[2] - y[0]) - __int128(x[2] - x[0]) * (y[1] - y[0]);
    const __int128 an =
        __int128(N[1] - N[0]) * (y[2] - y[0]) - __int128(N[2] - N[0]) * (y[1] - y[0]);
    const __int128 bn =
        __int128(N[2] - N[0]) * (x[1] - x[0]) - __int128(N[1] - N[0]) * (x[2] - x[0]);
    ASSERT_NE(det, 0);
    EXPECT_EQ(an % det, 0) << "triangle " << t;
    EXPECT_EQ(bn % det, 0) << "triangle " << t;
    const __int128 lim = __int128(1) << VM_PLANE_SLOPE_BITS;
    EXPECT_LE(an / det, lim);
    EXPECT_GE(an / det, -lim);
    EXPECT_LE(bn / det, lim);
    EXPECT_GE(bn / det, -lim);
  }
}

TEST(DepthPlanes, CrossingLinesAreExact) {
  Renderer r;
  for (unsigned seed = 1; seed <= 6; ++seed) {
    Scene s = penetrating_cluster(seed, 7);
    Camera cam = test_support::ortho_view_256(s);
    for (bool reversed : {false, true}) {
      Scene scene = reversed ? check::reverse_order(s).scene : s;
      check::SceneCheckOptions opts;
      opts.pixels = 256;
      ScreenTriangles st;
      check::SceneFigures f = check::check_scene(r, scene, cam, opts, nullptr, &st);
      std::set<int32_t> ks;
      expect_integer_planes(st, &ks);
      EXPECT_EQ(ks.size(), 1u) << "one k per frame";
      EXPECT_EQ(f.free_planes, 0u);
      ASSERT_GT(*f.crossing_pairs, 0u) << "seed " << seed;
      // Every crossing line exact: no snap band, and the map equals the reference. Before the
      // integer planes these clusters had wrong-source cells inside the bands of their rounded
      // lines and needed the thin-cell path at their triple points.
      EXPECT_EQ(*f.rounded_crossing_pairs, 0u);
      EXPECT_EQ(*f.snap_band, 0.0);
      EXPECT_EQ(*f.wrong_source, 0u) << check::to_json(f).dump();
      EXPECT_LE(*f.area_error, 1e-12) << check::to_json(f).dump();
      EXPECT_EQ(*f.overlap_area, 0.0);
      EXPECT_LE(*f.coverage_error, 1e-20);
      EXPECT_EQ(check::over_tolerance(f, {.strict = true}), std::vector<std::string>{})
          << "seed " << seed << " " << check::to_json(f).dump();
    }
  }
}

// Under --memory-budget the frame is rendered in buckets; a triangle reaching two of them must
// get the same plane in both, so k comes from the whole frame (clip_cells), not from a bucket.
TEST(DepthPlanes, OneExponentAcrossBuckets) {
  Renderer r;
  Scene s = penetrating_cluster(3, 7, 40, 0.25);  // in one corner: the buckets differ
  // A floor of many small triangles under the cluster, so that a small budget needs buckets.
  Mesh floor_mesh;
  floor_mesh.name = "floor";
  const int n = 120;
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i)
      for (double c : {256.0 * i / n, 256.0 * j / n, 0.05 * i})
        floor_mesh.positions.push_back(float(c));
  test_support::add_grid_triangles(floor_mesh, n);
  s.meshes.push_back(std::move(floor_mesh));
  Camera cam = test_support::ortho_view_256(s);
  cam.width = cam.height = 2048;
  check::SceneCheckOptions opts;
  opts.pixels = 0;
  opts.reference = false;
  ScreenTriangles whole, parts;
  check::check_scene(r, s, cam, opts, nullptr, &whole);
  opts.memory_budget = 40ull << 20;
  RenderStats st;
  RenderOptions ro;
  ro.memory_budget = opts.memory_budget;
  r.render(s, cam, ro, &st, &parts);
  ASSERT_GT(st.buckets, 1u);
  std::set<int32_t> kw, kp;
  expect_integer_planes(whole, &kw);
  expect_integer_planes(parts, &kp);
  EXPECT_EQ(kw.size(), 1u);
  EXPECT_EQ(kw, kp);
  ASSERT_EQ(whole.size(), parts.size());
}

}  // namespace
