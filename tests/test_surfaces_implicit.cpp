// Implicit surfaces, host side (core/implicit/implicit.h): the s-expression parser, the tape, the
// plain and interval evaluators, and tape shortening.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <random>
#include <string>

#include "core/error.h"
#include "core/implicit/implicit.h"

using namespace vismap;
using namespace vismap::implicit;

namespace {

std::string data_path(const std::string& rel) { return std::string(VISMAP_SOURCE_DIR) + "/../shared/data/" + rel; }

// The architecture model is in ../shared/data, not in the repository: without it the tests that
// use it skip, as the loaders' do.
#define LOAD_ARCHITECTURE(t)                                                     \
  if (!std::filesystem::exists(data_path("implicit/mpr_architecture.sexp")))     \
    GTEST_SKIP() << "no ../shared/data";                                         \
  const Tape t = load(data_path("implicit/mpr_architecture.sexp"))

std::string parse_error_of(const std::string& text) {
  try {
    parse(text, "t.sexp");
  } catch (const InputError& e) {
    EXPECT_EQ(e.kind(), InputErrorKind::ParseError);
    return e.what();
  }
  return "no error";
}

}  // namespace

TEST(Implicit, ParsesAndEvaluatesShapesWithKnownAnswers) {
  const Tape sphere = parse("(- (sqrt (+ (square x) (square y) (square z))) 1)", "s");
  EXPECT_DOUBLE_EQ(eval(sphere, 0, 0, 0), -1);
  EXPECT_DOUBLE_EQ(eval(sphere, 3, 4, 0), 4);
  const Tape box = parse("(max (- (abs x) 1) (- (abs y) 2) (- (abs z) 3))", "b");
  EXPECT_DOUBLE_EQ(eval(box, 0.5, 1.5, 2.5), -0.5);
  EXPECT_DOUBLE_EQ(eval(box, 2, 0, 0), 1);
  // A torus (major 2, minor 0.5) in the xy plane.
  const Tape torus = parse("(- (sqrt (+ (square (- (sqrt (+ (square x) (square y))) 2)) (square z))) 0.5)", "t");
  EXPECT_NEAR(eval(torus, 2, 0, 0), -0.5, 1e-15);
  EXPECT_NEAR(eval(torus, 0, 0, 0), 1.5, 1e-15);
  // Union, intersection, difference of two spheres.
  const std::string a = "(- (sqrt (+ (square x) (square y) (square z))) 1)";
  const std::string b = "(- (sqrt (+ (square (- x 1)) (square y) (square z))) 1)";
  const Tape u = parse("(min " + a + " " + b + ")", "u"), in = parse("(max " + a + " " + b + ")", "i"),
             d = parse("(max " + a + " (- " + b + "))", "d");
  EXPECT_LT(eval(u, -0.9, 0, 0), 0);
  EXPECT_GT(eval(in, -0.9, 0, 0), 0);
  EXPECT_LT(eval(in, 0.5, 0, 0), 0);
  EXPECT_LT(eval(d, -0.5, 0, 0), 0);
  EXPECT_GT(eval(d, 0.5, 0, 0), 0);
  // n-ary - and /, unary minus, pow, the rest of the unary operations.
  EXPECT_DOUBLE_EQ(eval(parse("(- 10 x 3)", "n"), 2, 0, 0), 5);
  EXPECT_DOUBLE_EQ(eval(parse("(/ 12 x 3)", "n"), 2, 0, 0), 2);
  EXPECT_DOUBLE_EQ(eval(parse("(- x)", "n"), 2, 0, 0), -2);
  EXPECT_DOUBLE_EQ(eval(parse("(pow x 3)", "n"), -2, 0, 0), -8);
  EXPECT_DOUBLE_EQ(eval(parse("(pow x 0.5)", "n"), 9, 0, 0), 3);
  EXPECT_NEAR(eval(parse("(+ (exp 0) (log 1) (sin 0) (cos 0) (tan 0) (asin 1) (acos 1) (atan 1))", "n"), 0, 0, 0),
              2 + M_PI / 2 + M_PI / 4, 1e-15);
  // sqrt at 0 and of a rounding-negative argument: 0, never NaN.
  EXPECT_EQ(eval(parse("(sqrt (- (square x) 1))", "n"), 1, 0, 0), 0);
  EXPECT_EQ(eval(parse("(sqrt x)", "n"), -1e-300, 0, 0), 0);
}

TEST(Implicit, MergesSharedSubexpressionsAndFoldsConstants) {
  // (square x) appears three times, (+ 1 2) folds.
  const Tape t = parse("(+ (square x) (* (square x) (square x)) (+ 1 2))", "m");
  size_t squares = 0, consts = 0;
  for (const Clause& c : t.clauses) {
    squares += c.op == Op::Square;
    consts += c.op == Op::Const;
  }
  EXPECT_EQ(squares, 1u);
  EXPECT_EQ(consts, 1u);
  EXPECT_DOUBLE_EQ(eval(t, 2, 0, 0), 4 + 16 + 3);
  // Commutative operands are ordered: (min x y) and (min y x) are one clause.
  const Tape c = parse("(+ (min x y) (min y x))", "c");
  EXPECT_EQ(c.size(), 4u);  // x y min +
  // Operands are always earlier clauses.
  for (size_t i = 0; i < t.size(); ++i) {
    if (t.clauses[i].op >= Op::Add) {
      EXPECT_LT(t.clauses[i].a, i);
    }
  }
}

TEST(Implicit, ArchitectureModelLoadsAndIsBounded) {
  LOAD_ARCHITECTURE(t);
  // Its README counts 1,599 operations in the tree: one per parenthesized operation.
  EXPECT_EQ(t.tree_ops, 1599u);
  std::printf("architecture: %zu clauses, %zu min/max, %u source operations\n", t.size(),
              t.choice_count(), t.tree_ops);
  EXPECT_GT(t.size(), 500u);
  EXPECT_GT(t.choice_count(), 300u);
  // Inside the building's footprint near the ground something is solid; far away nothing is.
  EXPECT_GT(eval(t, 100, 100, 100), 0);
  // Sampled: the model is bounded by the README's box (f > 0 outside it).
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int i = 0; i < 2000; ++i) {
    const double x = 30 * u(rng), y = 30 * u(rng), z = 30 * u(rng);
    const bool outside = x < -18.5 || x > 18.5 || y < -5.7 || y > 12.9 || z < -1 || z > 10.6;
    if (outside) {
      EXPECT_GT(eval(t, x, y, z), 0) << x << " " << y << " " << z;
    }
  }
}

TEST(Implicit, IntervalsContainEverySampleAndShortenedTapesAgree) {
  LOAD_ARCHITECTURE(t);
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(0, 1);
  size_t decided = 0, regions = 0;
  for (int r = 0; r < 200; ++r) {
    const double s = r < 100 ? 0.25 : 3.0;  // small and large regions
    const double x0 = -18 + 36 * u(rng), y0 = -5 + 17 * u(rng), z0 = 10 * u(rng);
    const Interval X{x0, x0 + s}, Y{y0, y0 + s}, Z{z0, z0 + s};
    std::vector<uint8_t> ch;
    const Interval f = eval_interval(t, X, Y, Z, &ch);
    std::vector<uint32_t> kept;
    const Tape sh = shorten(t, ch, &kept);
    ++regions;
    decided += t.size() - sh.size();
    EXPECT_LE(sh.size(), t.size());
    // The shortened tape's interval is inside the full one's (it drops losing branches).
    const Interval fs = eval_interval(sh, X, Y, Z);
    EXPECT_GE(fs.lo, f.lo);
    EXPECT_LE(fs.hi, f.hi);
    for (int k = 0; k < 40; ++k) {
      const double x = x0 + s * u(rng), y = y0 + s * u(rng), z = z0 + s * u(rng);
      const double v = eval(t, x, y, z);
      EXPECT_LE(f.lo, v);
      EXPECT_GE(f.hi, v);
      EXPECT_EQ(eval(sh, x, y, z), v) << "region " << r << " sample " << k;  // bit for bit
    }
  }
  std::printf("shortening: %.1f of %zu clauses dropped per region on average\n",
              double(decided) / regions, t.size());
  EXPECT_GT(decided, 0u);
}

TEST(Implicit, IntervalEdgeCases) {
  // Division by an interval holding 0 is unbounded, not a NaN or a wrong bound.
  const Tape d = parse("(/ 1 x)", "d");
  Interval r = eval_interval(d, {-1, 1}, {0, 0}, {0, 0});
  EXPECT_TRUE(std::isinf(r.lo) && std::isinf(r.hi));
  r = eval_interval(d, {2, 4}, {0, 0}, {0, 0});
  EXPECT_LE(r.lo, 0.25);
  EXPECT_GE(r.hi, 0.5);
  EXPECT_LT(r.hi, 0.5000001);
  // sqrt over an interval through 0 starts at 0; square of a straddling interval too.
  r = eval_interval(parse("(sqrt x)", "s"), {-1, 4}, {0, 0}, {0, 0});
  EXPECT_EQ(r.lo, 0);
  EXPECT_GE(r.hi, 2);
  r = eval_interval(parse("(square x)", "s"), {-3, 2}, {0, 0}, {0, 0});
  EXPECT_EQ(r.lo, 0);
  EXPECT_GE(r.hi, 9);
  // sin and cos reach their peaks inside an interval; tan over a pole is unbounded.
  r = eval_interval(parse("(sin x)", "s"), {1, 2}, {0, 0}, {0, 0});
  EXPECT_EQ(r.hi, 1);
  EXPECT_LE(r.lo, std::sin(1.0));
  r = eval_interval(parse("(cos x)", "s"), {3, 3.5}, {0, 0}, {0, 0});
  EXPECT_EQ(r.lo, -1);
  r = eval_interval(parse("(tan x)", "s"), {1.5, 1.6}, {0, 0}, {0, 0});
  EXPECT_TRUE(std::isinf(r.lo) && std::isinf(r.hi));
  // Random unary and binary expressions: every sample inside the interval.
  const char* exprs[] = {"(sin (* 3 x))", "(cos (+ x y))", "(exp (- x))", "(log (+ 2 x))",
                         "(atan (/ x (+ 3 y)))", "(asin (* 0.5 x))", "(acos (* 0.5 y))",
                         "(pow (+ 2 x) y)", "(pow x 4)", "(pow x -3)", "(tan (* 0.3 x))",
                         "(min (abs x) (max y (- z)))"};
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-2, 2), w(0, 1);
  for (const char* e : exprs) {
    const Tape t = parse(e, "r");
    for (int k = 0; k < 300; ++k) {
      const double x0 = u(rng), y0 = u(rng), z0 = u(rng), s = 0.5 * w(rng);
      const Interval f = eval_interval(t, {x0, x0 + s}, {y0, y0 + s}, {z0, z0 + s});
      for (int j = 0; j < 8; ++j) {
        const double v = eval(t, x0 + s * w(rng), y0 + s * w(rng), z0 + s * w(rng));
        if (std::isnan(v)) continue;
        EXPECT_LE(f.lo, v) << e;
        EXPECT_GE(f.hi, v) << e;
      }
    }
  }
}

TEST(Implicit, DeepTreesParseWithoutRecursion) {
  // 200,000 nested (+ 1 ...): the parser's stack is explicit.
  std::string s;
  const int depth = 200000;
  for (int i = 0; i < depth; ++i) s += "(+ x ";
  s += "0";
  s += std::string(depth, ')');
  const Tape t = parse(s, "deep");
  EXPECT_DOUBLE_EQ(eval(t, 1, 0, 0), depth);
}

TEST(Implicit, BadInputNamesLineAndColumn) {
  EXPECT_NE(parse_error_of("(+ x\n  (foo y))").find("t.sexp: line 2 column 4: unknown operation 'foo'"), std::string::npos)
      << parse_error_of("(+ x\n  (foo y))");
  EXPECT_NE(parse_error_of("(+ x y").find("not closed"), std::string::npos);
  EXPECT_NE(parse_error_of("(+ x y))").find("')' without"), std::string::npos);
  EXPECT_NE(parse_error_of("(sqrt x y)").find("takes one argument, got 2"), std::string::npos);
  EXPECT_NE(parse_error_of("(pow x)").find("takes two arguments"), std::string::npos);
  EXPECT_NE(parse_error_of("(/ x)").find("two or more"), std::string::npos);
  EXPECT_NE(parse_error_of("(+ x 1.2.3)").find("expected a number"), std::string::npos);
  EXPECT_NE(parse_error_of("(+ x 1e999)").find("not finite"), std::string::npos);
  // Issue 35, case 5: constants the float device cannot hold, written or folded.
  EXPECT_NE(parse_error_of("(+ x 1e308)").find("line 1 column 6: the number '1e308' is beyond "
                                               "float range"),
            std::string::npos)
      << parse_error_of("(+ x 1e308)");
  EXPECT_NE(parse_error_of("(+ x\n (- (/ 1 0) (/ 1 0)))")
                .find("line 2 column 5: '(/' folds to a constant that is not a finite float"),
            std::string::npos)
      << parse_error_of("(+ x\n (- (/ 1 0) (/ 1 0)))");
  EXPECT_NE(parse_error_of("(+ x (* 1e30 1e30))").find("folds to a constant"), std::string::npos);
  EXPECT_NE(parse_error_of("(+ x (exp 100))").find("folds to a constant"), std::string::npos);
  EXPECT_NO_THROW(parse("(+ x (* 1e18 1e18) 1e-50)", "t.sexp"));  // 1e36: a float still
  EXPECT_NE(parse_error_of("x y").find("a second expression"), std::string::npos);
  EXPECT_NE(parse_error_of("").find("no expression"), std::string::npos);
  EXPECT_NE(parse_error_of("()").find("expected an operation"), std::string::npos);
  try {
    load("/nonexistent/model.sexp");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.kind(), InputErrorKind::FileNotFound);
  }
}

// ---- The device's region queue (core/surfaces/implicit.h, kernels/implicit.cl) ----

#include "core/device/cl_runtime.h"
#include "core/surfaces/implicit.h"

namespace {

ClRuntime& implicit_runtime() {
  static ClRuntime rt("");
  static bool built = (rt.build(8), true);
  (void)built;
  return rt;
}

// The leaf with its tape as a SlotTape (for the host's evaluation of the device's tape).
implicit::SlotTape leaf_tape(const implicit::SlotTape& full, const surfaces::ImplicitQueue& q, size_t i) {
  implicit::SlotTape t;
  t.slots = full.slots;
  t.root_slot = full.root_slot;
  const VmIRegion& L = q.leaves[i];
  t.code.assign(q.pool.begin() + 4 * size_t(L.tape_off),
                q.pool.begin() + 4 * size_t(L.tape_off + L.tape_len));
  return t;
}

}  // namespace

TEST(Implicit, SlotTapeEvaluatesAsTheTape) {
  LOAD_ARCHITECTURE(t);
  const SlotTape s = allocate_slots(t);
  std::printf("architecture: %zu clauses on %u slots\n", s.size(), s.slots);
  EXPECT_LT(s.slots, t.size() / 4);  // slots are reused
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-20, 20);
  for (int i = 0; i < 500; ++i) {
    // Constants become floats on the device: the difference stays at float rounding.
    const double x = u(rng), y = u(rng) * 0.5 + 4, z = u(rng) * 0.3 + 5;
    EXPECT_NEAR(eval_slots(s, x, y, z), eval(t, x, y, z), 1e-4);
  }
}

TEST(Implicit, DeviceQueueClassifiesAndShortensLikeTheHost) {
  ClRuntime& rt = implicit_runtime();
  LOAD_ARCHITECTURE(t);
  const SlotTape s = allocate_slots(t);
  const float lo[3] = {-19.f, -19.f, -19.f};
  const float size = 38.f;
  const surfaces::ImplicitQueue q = surfaces::run_implicit_queue(rt, s, lo, size, 3, {4, 4, 4});
  ASSERT_EQ(q.rounds.size(), 4u);
  for (const auto& r : q.rounds) {
    std::printf("round: %llu regions, %llu full, %llu empty, %llu ambiguous, %llu clauses\n",
                (unsigned long long)r.regions, (unsigned long long)r.full,
                (unsigned long long)r.empty, (unsigned long long)r.ambiguous,
                (unsigned long long)r.clauses);
    EXPECT_EQ(r.full + r.empty + r.ambiguous, r.regions);
  }
  ASSERT_GT(q.leaves.size(), 1000u);
  EXPECT_EQ(q.leaves.size(), q.rounds.back().ambiguous);
  // Every leaf: the box is a 1/64 cube of the root; its shortened tape gives, on the host in
  // doubles, exactly the full slot tape's value at points inside it (the dropped branches could
  // not win there), and the value's sign never contradicts a classification.
  std::mt19937 rng(9);
  std::uniform_real_distribution<float> u(0.f, 1.f);
  size_t sum_len = 0, checked = 0;
  for (size_t i = 0; i < q.leaves.size(); i += 7) {
    const VmIRegion& L = q.leaves[i];
    EXPECT_FLOAT_EQ(L.size, size / 64.f);
    const SlotTape lt = leaf_tape(s, q, i);
    sum_len += lt.size();
    for (int k = 0; k < 4; ++k) {
      const double x = L.lo[0] + L.size * u(rng), y = L.lo[1] + L.size * u(rng),
                   z = L.lo[2] + L.size * u(rng);
      EXPECT_EQ(eval_slots(lt, x, y, z), eval_slots(s, x, y, z)) << "leaf " << i;
      ++checked;
    }
  }
  std::printf("leaves: %zu, mean tape %.1f of %zu clauses (%zu points checked)\n", q.leaves.size(),
              double(sum_len) / ((q.leaves.size() + 6) / 7), s.size(), checked);
  // The leaves' tapes on the device at their centres agree with the host's float evaluation of
  // the full tape to float rounding.
  std::vector<float> xyz;
  for (const VmIRegion& L : q.leaves)
    for (int k = 0; k < 3; ++k) xyz.push_back(L.lo[k] + 0.5f * L.size);
  const std::vector<float> v = surfaces::eval_leaf_points(rt, s, q, xyz, 1);
  for (size_t i = 0; i < q.leaves.size(); i += 13) {
    const double want = eval_slots(s, xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]);
    EXPECT_NEAR(v[i], want, 1e-3 * std::max(1.0, std::abs(want))) << "leaf " << i;
  }
}

TEST(Implicit, DeviceQueueOnKnownShapes) {
  ClRuntime& rt = implicit_runtime();
  // A unit sphere in a box of side 4 split 8 ways per axis twice: leaves only where the sphere
  // passes, and full regions only inside it.
  const SlotTape s = allocate_slots(parse("(- (sqrt (+ (square x) (square y) (square z))) 1)", "sphere"));
  const float lo[3] = {-2.f, -2.f, -2.f};
  const surfaces::ImplicitQueue q = surfaces::run_implicit_queue(rt, s, lo, 4.f, 3, {8, 8});
  ASSERT_EQ(q.rounds.size(), 3u);
  EXPECT_EQ(q.rounds[0].ambiguous, 1u);
  for (const VmIRegion& L : q.leaves) {
    const double cx = L.lo[0] + L.size / 2, cy = L.lo[1] + L.size / 2, cz = L.lo[2] + L.size / 2;
    const double r = std::sqrt(cx * cx + cy * cy + cz * cz);
    EXPECT_LT(std::abs(r - 1), L.size);  // the surface passes within the leaf's diagonal
  }
  // Leaves: a shell of cells of side 1/16 around the unit sphere (area 4 pi): on the order of
  // 4 pi * 16^2 = 3,217 cells, more with the shell's thickness.
  EXPECT_GT(q.leaves.size(), 2000u);
  EXPECT_LT(q.leaves.size(), 20000u);
  // 2D: a disc, split 4 ways twice in x and y only.
  const SlotTape d = allocate_slots(parse("(- (+ (square x) (square y)) 1)", "disc"));
  const surfaces::ImplicitQueue q2 = surfaces::run_implicit_queue(rt, d, lo, 4.f, 2, {4, 4});
  EXPECT_EQ(q2.rounds[1].regions, 16u);
  for (const VmIRegion& L : q2.leaves) EXPECT_EQ(L.lo[2], -2.f);
  // Division by an interval holding 0 and sqrt at 0: ambiguous, not NaN, never dropped.
  const SlotTape w = allocate_slots(parse("(- (/ 1 (sqrt (+ (square x) (square y) (square z)))) 2)", "pole"));
  const surfaces::ImplicitQueue q3 = surfaces::run_implicit_queue(rt, w, lo, 4.f, 3, {2, 2});
  EXPECT_GT(q3.leaves.size(), 0u);
  bool has_origin = false;
  for (const VmIRegion& L : q3.leaves)
    has_origin |= L.lo[0] <= 0 && L.lo[0] + L.size >= 0 && L.lo[1] <= 0 && L.lo[1] + L.size >= 0 &&
                  L.lo[2] <= 0 && L.lo[2] + L.size >= 0;
  EXPECT_TRUE(has_origin);
  // A memory cap that a round passes is an error naming the round, not a silent drop.
  try {
    surfaces::run_implicit_queue(rt, s, lo, 4.f, 3, {8, 8, 8}, 1 << 20);
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(e.kind(), InputErrorKind::TooLarge);
  }
}

// ---- MPR's 2D mode (core/surfaces/implicit2d.h) ----

#include "core/surfaces/implicit2d.h"

TEST(Implicit, TwoDimensionalRegionsWithKnownAnswers) {
  ClRuntime& rt = implicit_runtime();
  View2D v;  // [-1, 1]^2 on 512 x 512: 256 px per unit
  v.width = v.height = 512;
  const double tol = 0.3;
  // A disc of radius 0.5: one region, one loop, every vertex within the tolerance of the circle.
  Regions2D r = contour_2d(rt, parse("(- (sqrt (+ (square x) (square y))) 0.5)", "disc"), v, tol);
  ASSERT_EQ(r.regions.size(), 1u);
  ASSERT_EQ(r.loops.size(), 1u);
  EXPECT_LE(r.cell_px * std::sqrt(2.0), tol + 1e-9);
  for (const auto& p : r.loops[0]) {
    const double x = p[0] / 256 - 1, y = 1 - p[1] / 256;
    EXPECT_LE(std::abs(std::hypot(x, y) - 0.5) * 256, tol) << x << " " << y;
  }
  // An annulus: one region of two loops (the hole turns the other way).
  r = contour_2d(rt, parse("(max (- (sqrt (+ (square x) (square y))) 0.6) (- 0.3 (sqrt (+ (square x) (square y)))))", "ring"), v, tol);
  ASSERT_EQ(r.regions.size(), 1u);
  EXPECT_EQ(r.regions[0].size(), 2u);
  // Two discs apart, and a disc inside the hole of a ring: three regions in all.
  r = contour_2d(rt, parse("(min (- (sqrt (+ (square (- x 0.5)) (square y))) 0.3) (- (sqrt (+ (square (+ x 0.5)) (square y))) 0.3))", "two"), v, tol);
  EXPECT_EQ(r.regions.size(), 2u);
  r = contour_2d(rt, parse("(min (max (- (sqrt (+ (square x) (square y))) 0.9) (- 0.6 (sqrt (+ (square x) (square y))))) (- (sqrt (+ (square x) (square y))) 0.3))", "nest"), v, tol);
  EXPECT_EQ(r.regions.size(), 2u);
  EXPECT_EQ(r.loops.size(), 3u);
  // A solid that runs past the window closes along the window's edges: the half plane x < 0
  // is one region, a rectangle of the window's left half.
  r = contour_2d(rt, parse("x", "half"), v, tol);
  ASSERT_EQ(r.regions.size(), 1u);
  double minx = 1e9, maxx = -1e9;
  for (const auto& p : r.loops[0]) minx = std::min(minx, p[0]), maxx = std::max(maxx, p[0]);
  EXPECT_NEAR(maxx, 256, tol);
  EXPECT_NEAR(minx, 0, tol);
  // The SVG has one path per region.
  const std::string svg = write_svg_2d(r, v);
  EXPECT_EQ(svg.find("<path"), svg.rfind("<path"));
  // z is refused.
  EXPECT_THROW(contour_2d(rt, parse("(+ x z)", "z"), v, tol), InputError);
}

// Issue 35, case 5: the 2D mode keeps a time limit. A 200 x 200-cycle checkerboard at 1024^2
// contours for tens of seconds; contour_2d's check_time runs after each queue round and corner
// batch, so a check that throws once called past its first calls stops it within a round (the
// CLI passes --time-limit through Renderer::implicit_2d; 'vismap render checker.sexp
// --time-limit 5' stopped after 7.4 s here, against 36 s before).
TEST(Implicit2D, TimeCheckStopsTheContouring) {
  ClRuntime& rt = implicit_runtime();
  View2D v;
  int calls = 0;
  struct Stop {};
  try {
    contour_2d(rt, parse("(* (sin (* 200 x)) (sin (* 200 y)))", "checker"), v, 0.3, [&] {
      if (++calls == 2) throw Stop{};
    });
    FAIL() << "the check was not called twice";
  } catch (const Stop&) {
  }
  EXPECT_EQ(calls, 2);
}

// Issue 35, case 1: a long tape that no box shortens (a sphere under 10,000 nested (+ ... 0))
// made the bounds search hold a copy of it per ambiguous box: 5.9 GB and 38 s here before the
// region queue refused the object (10^5 of them, a 4.3 MB upload, grew past 14 GB). The search
// now counts the tapes a level holds and refuses past 256 MiB, asking for bounds.
TEST(Implicit, BoundsSearchOfALongTapeIsBounded) {
  std::string s;
  const int n = 10000;
  for (int i = 0; i < n; ++i) s += "(+ ";
  s += "(- (+ (square x) (square y) (square z)) 1)";
  for (int i = 0; i < n; ++i) s += " 0)";
  const Tape t = parse(s, "nested.sexp");
  ASSERT_GT(t.size(), size_t(n));  // nothing folded away: (+ f 0) is kept
  try {
    find_bounds(t, "nested.sexp");
    FAIL() << "the search should refuse";
  } catch (const InputError& e) {
    EXPECT_EQ(e.kind(), InputErrorKind::TooLarge) << e.what();
    EXPECT_NE(std::string(e.what()).find("the bounds search would hold more than 256.00 MiB"),
              std::string::npos)
        << e.what();
  }
  // The sphere alone is found as before.
  const std::array<double, 6> b =
      find_bounds(parse("(- (+ (square x) (square y) (square z)) 1)", "ball.sexp"), "ball.sexp");
  EXPECT_LT(b[0], -1);
  EXPECT_GT(b[3], 1);
}
