// The frame's memory budget and time limit hold on every scene (issue 15): dense penetrating soup
// (a 245 KB upload of 5,000 triangles took 26 s and 2.3 GB in one bucket under a 256 MiB budget)
// needs far more memory for its crossing pairs, candidates and fragments than its triangle count
// suggests. Those stages now check the region's budget before allocating and the region is split
// when it would pass; one 16-px cell that cannot fit fails with TooLarge; a time limit stops a
// frame with TimeLimit. The renderer goes on working after either.
#include <gtest/gtest.h>

#include "core/device/cl_runtime.h"
#include "core/error.h"
#include "core/pipeline.h"
#include "core/scene.h"
#include "tests/support/soup.h"
#include "tests/support/triangle_scene.h"

namespace {

using namespace vismap;

Renderer& renderer() {
  static Renderer r;
  return r;
}

// Regression: soup under a budget a third of what it needs in one piece. The frame splits into
// buckets until every part fits, the device memory stays under the budget, and the picture (the
// covered area, and every source's area) is the one rendered without a budget.
TEST(Budget, DensePenetratingSoupSplitsUntilItFits) {
  Scene soup = test_support::penetrating_soup(1500, 0.2, 7);
  Camera cam = frame_scene(soup, 512, 512);
  RenderStats whole, split;
  PlanarMap a = renderer().render(soup, cam, {}, &whole);
  ASSERT_GT(whole.crossing_lines, 5000u) << "the soup must be dense";
  RenderOptions o;
  o.memory_budget = whole.peak_device_bytes / 3;
  PlanarMap b = renderer().render(soup, cam, o, &split);
  EXPECT_GT(split.buckets, 2u);
  // The peak is measured from release callbacks, which a loaded machine delivers late (buffers
  // already dropped still count): a quarter over the budget is allowed for that; in one bucket
  // the soup peaks at three times the budget.
  EXPECT_LE(split.peak_device_bytes, o.memory_budget + o.memory_budget / 4)
      << "whole " << whole.peak_device_bytes << ", buckets " << split.buckets;
  EXPECT_NEAR(test_support::map_area(b), test_support::map_area(a),
              1e-9 * test_support::map_area(a));
  std::vector<double> per_a(1500, 0.0), per_b(1500, 0.0);
  for (size_t f = 0; f < a.fragment_count(); ++f) per_a[a.triangle[f]] += a.fragment_area(f);
  for (size_t f = 0; f < b.fragment_count(); ++f) per_b[b.triangle[f]] += b.fragment_area(f);
  for (size_t t = 0; t < per_a.size(); ++t)
    ASSERT_NEAR(per_a[t], per_b[t], 1e-6) << "triangle " << t;
}

// One pixel (a 1x1 viewport) holding more than the budget allows: TooLarge, nothing returned. The
// renderer still renders afterwards.
TEST(Budget, OneCellThatCannotFitIsTooLarge) {
  Scene soup = test_support::penetrating_soup(1500, 0.2, 7);
  Camera cam = frame_scene(soup, 1, 1);
  RenderStats whole;
  renderer().render(soup, cam, {}, &whole);
  RenderOptions o;
  o.memory_budget = whole.peak_device_bytes / 4;
  try {
    renderer().render(soup, cam, o);
    FAIL() << "a cell that cannot fit must fail the frame";
  } catch (const InputError& e) {
    EXPECT_EQ(e.kind(), InputErrorKind::TooLarge) << e.what();
    EXPECT_NE(std::string(e.what()).find("one pixel of the screen"), std::string::npos) << e.what();
  }
  RenderStats again;
  PlanarMap m = renderer().render(soup, cam, {}, &again);
  EXPECT_EQ(again.fragments, whole.fragments);
  EXPECT_GT(m.fragment_count(), 0u);
}

// A frame past its time limit stops with TimeLimit, naming the stage; the next frame renders.
TEST(Budget, TimeLimitStopsTheFrame) {
  Scene soup = test_support::penetrating_soup(1500, 0.2, 7);
  Camera cam = frame_scene(soup, 512, 512);
  RenderOptions o;
  o.time_limit_s = 1e-4;
  try {
    renderer().render(soup, cam, o);
    FAIL() << "the frame takes far more than 0.1 ms";
  } catch (const InputError& e) {
    EXPECT_EQ(e.kind(), InputErrorKind::TimeLimit) << e.what();
    EXPECT_NE(std::string(e.what()).find("time limit"), std::string::npos) << e.what();
  }
  o.time_limit_s = 600;
  RenderStats st;
  renderer().render(soup, cam, o, &st);
  EXPECT_GT(st.fragments, 0u);
}

}  // namespace

// Issue 35 (smaller): a budget under 1 MiB was reported as "0 MiB" (bytes shifted down to whole
// MiB); the message now gives the budget and what the scene holds to the hundredth.
TEST(Budget, TooSmallBudgetSaysItsSize) {
  Scene bunny = load_scene(std::string(VISMAP_SOURCE_DIR) + "/data/bunny.ply");
  Camera cam = frame_scene(bunny, 256, 256);
  RenderOptions o;
  o.memory_budget = 1000000;  // the bunny alone holds more on the device
  try {
    renderer().render(bunny, cam, o);
    FAIL() << "1 MB cannot hold the scene";
  } catch (const InputError& e) {
    EXPECT_EQ(e.kind(), InputErrorKind::TooLarge) << e.what();
    EXPECT_NE(std::string(e.what()).find("memory budget of 0.95 MiB is too small: the scene "
                                         "alone holds "),
              std::string::npos)
        << e.what();
  }
}

// Issue 35, case 2: a device buffer larger than the device allows is too large for the frame (an
// InputError the caller reports), not a device fault: a dense implicit asked for 10 GB of
// fragment lines and got 'device error: clCreateBuffer (-61)', exit 3.
TEST(Budget, BufferPastTheDeviceLimitIsTooLarge) {
  ClRuntime rt("");
  const auto devices = rt.context().getInfo<CL_CONTEXT_DEVICES>();
  ASSERT_FALSE(devices.empty());
  const uint64_t max = devices[0].getInfo<CL_DEVICE_MAX_MEM_ALLOC_SIZE>();
  try {
    rt.alloc(size_t(max) + (size_t(64) << 20), "fragment lines");
    FAIL() << "allocated past CL_DEVICE_MAX_MEM_ALLOC_SIZE " << max;
  } catch (const InputError& e) {
    EXPECT_EQ(e.kind(), InputErrorKind::TooLarge) << e.what();
    EXPECT_NE(std::string(e.what()).find("fragment lines"), std::string::npos) << e.what();
  }
  EXPECT_NO_THROW(rt.alloc(size_t(64) << 20, "fragment lines"));  // the runtime goes on
}
