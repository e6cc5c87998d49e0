// The exact checker on hand-made inputs whose answers are worked out by hand (docs/CHECKS.md).
#include <gtest/gtest.h>
#include <pthread.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <utility>
#include <vector>

#include "core/check/planar_check.h"

using namespace vismap;
using namespace vismap::check;

namespace {

using Pts = std::vector<std::pair<double, double>>;  // pixels

Int128Parts parts(__int128 v) {
  return Int128Parts{static_cast<int64_t>(v >> 64), static_cast<uint64_t>(v)};
}

// Adds a fragment; exact vertices (x·gs·hw, y·gs·hw, hw) with a large hw, so the checker's
// homogeneous arithmetic is exercised (coordinates must be multiples of 1/gs).
void add_fragment(PlanarMap& m, uint32_t mesh, uint32_t tri, const Pts& pts) {
  const __int128 hw = (static_cast<__int128>(1) << 40) + 7;
  for (auto [x, y] : pts) {
    m.xy.push_back(x);
    m.xy.push_back(y);
    m.hx.push_back(parts(static_cast<__int128>(std::llround(x * m.grid_scale)) * hw));
    m.hy.push_back(parts(static_cast<__int128>(std::llround(y * m.grid_scale)) * hw));
    m.hw.push_back(parts(hw));
  }
  m.offsets.push_back(static_cast<uint32_t>(m.xy.size() / 2));
  m.mesh.push_back(mesh);
  m.triangle.push_back(tri);
}

PlanarMap empty_map(uint32_t w, uint32_t h, uint32_t gs) {
  PlanarMap m;
  m.width = w, m.height = h, m.grid_scale = gs;
  return m;
}

PlanarMap rounded(PlanarMap m) {  // the same map without exact vertices
  m.hx.clear(), m.hy.clear(), m.hw.clear();
  return m;
}

// Triangle in pixels (multiples of 1/gs) with per-vertex nearness.
void add_triangle(ScreenTriangles& s, uint32_t mesh, uint32_t tri, const Pts& pts,
                  std::vector<double> depth) {
  for (auto [x, y] : pts) {
    s.xy.push_back(static_cast<int32_t>(std::llround(x * s.grid_scale)));
    s.xy.push_back(static_cast<int32_t>(std::llround(y * s.grid_scale)));
  }
  for (double d : depth) s.depth.push_back(d);
  s.mesh.push_back(mesh);
  s.triangle.push_back(tri);
}

ScreenTriangles screen_with_gs(uint32_t gs) {
  ScreenTriangles s;
  s.grid_scale = gs;
  return s;
}

// Square [0,8]^2 as two triangles at nearness 0 (mesh 0) and square [4,12]x[0,8] at nearness 1
// (mesh 1): the front square hides x in [4,8] of the back one.
ScreenTriangles two_squares() {
  ScreenTriangles s = screen_with_gs(4);
  add_triangle(s, 0, 0, {{0, 0}, {8, 0}, {8, 8}}, {0, 0, 0});
  add_triangle(s, 0, 1, {{0, 0}, {8, 8}, {0, 8}}, {0, 0, 0});
  add_triangle(s, 1, 0, {{4, 0}, {12, 0}, {12, 8}}, {1, 1, 1});
  add_triangle(s, 1, 1, {{4, 0}, {12, 8}, {4, 8}}, {1, 1, 1});
  return s;
}
PlanarMap two_squares_map() {
  PlanarMap m = empty_map(12, 8, 4);
  add_fragment(m, 0, 0, {{0, 0}, {4, 0}, {4, 4}});
  add_fragment(m, 0, 1, {{0, 0}, {4, 4}, {4, 8}, {0, 8}});
  add_fragment(m, 1, 0, {{4, 0}, {12, 0}, {12, 8}});
  add_fragment(m, 1, 1, {{4, 0}, {12, 8}, {4, 8}});
  return m;
}

// Penetrating pair: A = (0,0),(10,0),(0,10) with nearness x; B = (0,0),(10,0),(10,10) with
// nearness 6 - x. They cross along x = 3: A is in front for x > 3.
// visible(A) = 50 - area(A∩B∩{x<3}) = 50 - 4.5; visible(B) = 50 - (25 - 4.5).
ScreenTriangles penetrating() {
  ScreenTriangles s = screen_with_gs(2);
  add_triangle(s, 0, 0, {{0, 0}, {10, 0}, {0, 10}}, {0, 10, 0});
  add_triangle(s, 0, 1, {{0, 0}, {10, 0}, {10, 10}}, {6, -4, -4});
  return s;
}
PlanarMap penetrating_map(double cut = 3) {
  PlanarMap m = empty_map(10, 10, 2);
  add_fragment(m, 0, 0, {{cut, 0}, {10, 0}, {5, 5}, {cut, cut}});
  add_fragment(m, 0, 0, {{0, 0}, {cut, cut}, {5, 5}, {0, 10}});
  add_fragment(m, 0, 1, {{0, 0}, {cut, 0}, {cut, cut}});
  add_fragment(m, 0, 1, {{5, 5}, {10, 0}, {10, 10}});
  return m;
}

}  // namespace

TEST(Check, OverlappingSquaresGiveExactOverlapArea) {
  // [0,4]^2 and [2,6]x[1,5]: the intersection is [2,4]x[1,4], area 6. Both argument orders.
  for (int order = 0; order < 2; ++order) {
    PlanarMap m = empty_map(8, 8, 256);
    Pts a{{0, 0}, {4, 0}, {4, 4}, {0, 4}}, b{{2, 1}, {6, 1}, {6, 5}, {2, 5}};
    add_fragment(m, 0, 0, order ? b : a);
    add_fragment(m, 0, 1, order ? a : b);
    ScreenTriangles s = screen_with_gs(256);
    CheckOptions o;
    o.coverage = false, o.outside = false;
    CheckReport r = check_planar_map(m, s, o);
    EXPECT_TRUE(r.exact);
    EXPECT_EQ(r.overlap_pairs, 1u);
    EXPECT_EQ(r.overlap_area, 6.0);
    EXPECT_EQ(r.output_area, 32.0);
    EXPECT_EQ(r.degenerate, 0u);
    EXPECT_FALSE(r.ok());
    CheckReport rr = check_planar_map(rounded(m), s, o);
    EXPECT_FALSE(rr.exact);
    EXPECT_EQ(rr.overlap_area, 6.0);
  }
}

TEST(Check, TouchingFragmentsDoNotOverlap) {
  // Shared edge, shared vertex only, and a T-junction (a vertex in the middle of an edge).
  PlanarMap m = empty_map(8, 8, 256);
  add_fragment(m, 0, 0, {{0, 0}, {4, 0}, {4, 4}, {0, 4}});
  add_fragment(m, 0, 1, {{4, 0}, {8, 0}, {8, 2}, {4, 2}});
  add_fragment(m, 0, 2, {{4, 2}, {8, 2}, {8, 4}, {4, 4}});
  add_fragment(m, 0, 3, {{4, 4}, {8, 4}, {8, 8}});
  ScreenTriangles s = screen_with_gs(256);
  CheckOptions o;
  o.coverage = false, o.outside = false;
  CheckReport r = check_planar_map(m, s, o);
  EXPECT_GE(r.candidate_pairs, 3u);
  EXPECT_EQ(r.overlap_pairs, 0u);
  EXPECT_EQ(r.overlap_area, 0.0);
}

TEST(Check, CorrectMapHasNoErrors) {
  ScreenTriangles s = two_squares();
  PlanarMap m = two_squares_map();
  CheckReport r = check_planar_map(m, s);
  EXPECT_TRUE(r.exact);
  EXPECT_EQ(r.degenerate, 0u);
  EXPECT_EQ(r.nonconvex, 0u);
  EXPECT_EQ(r.overlap_pairs, 0u);
  EXPECT_EQ(r.outside_source, 0u);
  EXPECT_EQ(r.output_area, 96.0);
  EXPECT_EQ(r.union_area, 96.0);
  EXPECT_EQ(r.coverage_error, 0.0);
  EXPECT_TRUE(r.ok()) << r.summary();
}

TEST(Check, MissingPieceGivesCoverageError) {
  ScreenTriangles s = two_squares();
  PlanarMap m = empty_map(12, 8, 4);
  add_fragment(m, 0, 0, {{0, 0}, {4, 0}, {4, 4}});
  add_fragment(m, 1, 0, {{4, 0}, {12, 0}, {12, 8}});
  add_fragment(m, 1, 1, {{4, 0}, {12, 8}, {4, 8}});  // (0,1)'s quad, area 24 of 96, missing
  CheckReport r = check_planar_map(m, s);
  EXPECT_EQ(r.output_area, 72.0);
  EXPECT_EQ(r.union_area, 96.0);
  EXPECT_DOUBLE_EQ(r.coverage_error, 0.25);
  EXPECT_FALSE(r.ok());
}

TEST(Check, WrongSourceIsOutside) {
  ScreenTriangles s = two_squares();
  PlanarMap m = two_squares_map();
  std::swap(m.triangle[2], m.triangle[3]);  // front square's halves swapped: each is outside
  m.mesh[0] = 7;                            // no such source at all
  CheckReport r = check_planar_map(m, s);
  EXPECT_EQ(r.outside_source, 3u);
  EXPECT_EQ(r.unknown_source, 1u);
  // Fragment 0 (area 8) entirely; fragments 2 and 3 (area 32 each) are each in the other half:
  // their common part with the swapped source is the diagonal, area 0.
  EXPECT_EQ(r.outside_area, 8.0 + 32 + 32);
  EXPECT_EQ(r.coverage_error, 0.0);  // areas alone cannot see it
  EXPECT_FALSE(r.ok());
}

TEST(Check, DegenerateAndNonConvexAreCounted) {
  PlanarMap m = empty_map(8, 8, 4);
  add_fragment(m, 0, 0, {{0, 0}, {2, 2}, {4, 4}});                  // collinear
  add_fragment(m, 0, 1, {{0, 0}, {0, 4}, {4, 4}});                  // negative orientation
  add_fragment(m, 0, 2, {{0, 0}, {4, 0}, {1, 1}, {0, 4}});          // reflex vertex
  add_fragment(m, 0, 3, {{0, 0}, {4, 0}, {4, 0}, {4, 4}, {0, 4}});  // duplicate vertex: fine
  ScreenTriangles s = screen_with_gs(4);
  CheckOptions o;
  o.coverage = false, o.outside = false;
  CheckReport r = check_planar_map(m, s, o);
  EXPECT_EQ(r.degenerate, 2u);
  EXPECT_EQ(r.nonconvex, 1u);
  EXPECT_EQ(r.output_area, 16.0 + 4.0);  // square + the reflex quad (4·1/2 + 1·4/2)
}

TEST(Check, PixelCompareFindsWrongIds) {
  ScreenTriangles s = two_squares();
  PixelReport good = pixel_compare(two_squares_map(), s, 96);
  EXPECT_EQ(good.all_samples, 96u * 96u);
  EXPECT_GT(good.samples, good.all_samples / 2);
  EXPECT_EQ(good.mismatched, 0u);

  // The back square drawn whole: its right half claims the front square's samples.
  PlanarMap bad = empty_map(12, 8, 4);
  add_fragment(bad, 0, 0, {{0, 0}, {8, 0}, {8, 8}});
  add_fragment(bad, 0, 1, {{0, 0}, {8, 8}, {0, 8}});
  add_fragment(bad, 1, 0, {{8, 0}, {12, 0}, {12, 8}, {8, 8}});
  PixelReport r = pixel_compare(bad, s, 96);
  EXPECT_GT(r.mismatched, r.samples / 5);  // x in [4,8] is a third of the viewport
  EXPECT_GT(r.all_mismatched, r.mismatched);
}

TEST(Reference, BackTriangleLosesWhatTheFrontOneCovers) {
  ScreenTriangles s = two_squares();
  ReferenceResult ref = exact_visibility(s);
  ASSERT_EQ(ref.visible_area.size(), 4u);
  EXPECT_EQ(ref.visible_area[0], 8.0);   // (0,0),(4,0),(4,4)
  EXPECT_EQ(ref.visible_area[1], 24.0);  // (0,0),(4,4),(4,8),(0,8)
  EXPECT_EQ(ref.visible_area[2], 32.0);
  EXPECT_EQ(ref.visible_area[3], 32.0);
  EXPECT_EQ(ref.total_visible_area, 96.0);

  // The same scene listed front first, with the depths negated and swapped back.
  ScreenTriangles f = screen_with_gs(4);
  add_triangle(f, 1, 1, {{4, 0}, {12, 8}, {4, 8}}, {5, 5, 5});
  add_triangle(f, 0, 1, {{0, 0}, {8, 8}, {0, 8}}, {-3, -3, -3});
  ReferenceResult rf = exact_visibility(f);
  EXPECT_EQ(rf.visible_area[0], 32.0);
  EXPECT_EQ(rf.visible_area[1], 24.0);

  ReferenceReport c = compare_with_reference(two_squares_map(), s, ref);
  EXPECT_EQ(c.area_error, 0.0);
  EXPECT_EQ(c.wrong_source, 0u);
  EXPECT_EQ(c.partly_outside, 0u);
}

TEST(Reference, PenetratingPairSplitsAlongIntersectionLine) {
  ScreenTriangles s = penetrating();
  ReferenceResult ref = exact_visibility(s);
  EXPECT_EQ(ref.visible_area[0], 45.5);
  EXPECT_EQ(ref.visible_area[1], 29.5);

  ReferenceReport good = compare_with_reference(penetrating_map(), s, ref);
  EXPECT_EQ(good.area_error, 0.0);
  EXPECT_EQ(good.partly_outside, 0u);
  CheckReport gc = check_planar_map(penetrating_map(), s);
  EXPECT_TRUE(gc.ok()) << gc.summary();
  EXPECT_EQ(pixel_compare(penetrating_map(), s, 64).mismatched, 0u);

  // Cut at x = 4 instead of 3: A claims the strip 3<x<4 where B is in front.
  ReferenceReport bad = compare_with_reference(penetrating_map(4), s, ref);
  // A's part of the strip: 3<x<4 below y=x: area 3.5, both in A's output and missing from B's.
  EXPECT_DOUBLE_EQ(bad.xor_area, 2 * 3.5);
  EXPECT_DOUBLE_EQ(bad.area_error, 7.0 / 75.0);
  EXPECT_EQ(bad.partly_outside, 1u);  // B's (0,0),(4,0),(4,4): 3.5 of its 8 outside
  EXPECT_GT(pixel_compare(penetrating_map(4), s, 64).mismatched, 0u);
  EXPECT_EQ(bad.wrong_source, 0u);
  // A whole grid unit off is far outside the pair's snap band: none of it is explained.
  EXPECT_NEAR(bad.area_error_outside_band, 7.0 / 75.0, 1e-6);
  EXPECT_EQ(bad.wrong_outside_band, 1u);
  EXPECT_EQ(good.area_error_outside_band, 0.0);
  EXPECT_EQ(good.wrong_outside_band, 0u);
}

TEST(Reference, SnapBandExplainsOnlyWhatRoundingCanMove) {
  // The line x = 3 px (6 grid units) over an overlap 10 grid units high: the pipeline's rounded
  // line is within (1 + h) / (2 (2^23 - 255)) grid units of it, h = 5 + 1.5, i.e. 4.47e-7 grid
  // units = 2.24e-7 px, plus a floating-point allowance far below that here. The maps below
  // carry their vertices as doubles (rounded()), so that the cut can be off the grid.
  ScreenTriangles s = penetrating();
  ReferenceResult ref = exact_visibility(s);
  EXPECT_GT(ref.snap_band, 2.23e-7);
  EXPECT_LT(ref.snap_band, 2.25e-7);

  ReferenceReport inside = compare_with_reference(rounded(penetrating_map(3 + 1e-7)), s, ref);
  EXPECT_GT(inside.area_error, 0.0);
  EXPECT_EQ(inside.area_error_outside_band, 0.0);
  EXPECT_EQ(inside.wrong_outside_band, 0u);
  EXPECT_EQ(inside.snap_band, ref.snap_band);

  ReferenceReport outside = compare_with_reference(rounded(penetrating_map(3 + 1e-6)), s, ref);
  EXPECT_GT(outside.area_error_outside_band, 0.0);
  EXPECT_LT(outside.area_error_outside_band, outside.area_error);
  EXPECT_EQ(outside.wrong_outside_band, 1u);
}

TEST(Reference, CoplanarOverlapLowerIdInFront) {
  // Same plane; (0,2) is lower than (0,5), so it is in front. Both listing orders.
  for (int order = 0; order < 2; ++order) {
    ScreenTriangles s = screen_with_gs(4);
    Pts lo{{0, 0}, {8, 0}, {0, 8}}, hi{{2, 0}, {10, 0}, {2, 8}};
    if (order == 0) {
      add_triangle(s, 0, 5, hi, {1, 2, 3});
      add_triangle(s, 0, 2, lo, {0.75, 1.75, 2.75});  // the plane 0.75 + x/8 + y/4
    } else {
      add_triangle(s, 0, 2, lo, {0.75, 1.75, 2.75});  // the plane 0.75 + x/8 + y/4
      add_triangle(s, 0, 5, hi, {1, 2, 3});
    }
    ReferenceResult ref = exact_visibility(s);
    size_t ilo = order == 0 ? 1 : 0, ihi = 1 - ilo;
    EXPECT_EQ(ref.visible_area[ilo], 32.0);
    // hi minus lo: the overlap is (2,0),(8,0),(2,6), area 18.
    EXPECT_EQ(ref.visible_area[ihi], 32.0 - 18.0);
  }
}

// Issue 35 (smaller): `vismap check data/bunny.ply` died of SIGSEGV after 110 s: the reference's
// sums over ~40,000 visible sources built chains of lazy exact additions that their exact
// evaluation walked by recursion, two stack frames a term, past the 8 MiB stack. Scaled down: 3,000
// disjoint triangles with exact (homogeneous) fragments, whose xor area is an exact zero that
// only exact evaluation decides, compared on a thread with a 256 KiB stack (~2,500 frames) in a
// child process, so that an overflow fails the test instead of ending the run.
TEST(Check, LongReferenceSumsStayShallow) {
  const int n = 3000;
  const uint32_t gs = 4;
  ScreenTriangles s = screen_with_gs(gs);
  PlanarMap m = empty_map(200, 200, gs);
  for (int i = 0; i < n; ++i) {
    const double x = 3.0 * (i % 60), y = 3.0 * (i / 60);
    const Pts t{{x, y}, {x + 2, y}, {x, y + 2}};
    add_triangle(s, 0, uint32_t(i), t, {1, 1, 1});
    add_fragment(m, 0, uint32_t(i), t);
  }
  struct Job {
    const PlanarMap* m;
    const ScreenTriangles* s;
    double area_error = -1, visible = 0;
  } job{&m, &s};
  const pid_t pid = ::fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    pthread_attr_t attr;
    pthread_attr_init(&attr);
    pthread_attr_setstacksize(&attr, 256 << 10);
    pthread_t th;
    auto run = [](void* p) -> void* {
      Job& j = *static_cast<Job*>(p);
      const ReferenceResult ref = exact_visibility(*j.s);
      const ReferenceReport r = compare_with_reference(*j.m, *j.s, ref);
      j.area_error = r.area_error;
      j.visible = r.total_visible_area;
      return nullptr;
    };
    if (pthread_create(&th, &attr, run, &job) != 0) ::_exit(3);
    pthread_join(th, nullptr);
    ::_exit(job.area_error == 0 && job.visible == 2.0 * n ? 0 : 1);
  }
  int status = 0;
  ::waitpid(pid, &status, 0);
  EXPECT_TRUE(WIFEXITED(status)) << "signal " << (WIFSIGNALED(status) ? WTERMSIG(status) : 0);
  EXPECT_EQ(WIFEXITED(status) ? WEXITSTATUS(status) : -1, 0);
}
