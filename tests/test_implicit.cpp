// Implicit surfaces, host side (core/implicit.h): the s-expression parser, the tape, the plain
// and interval evaluators, and tape shortening.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>

#include "core/error.h"
#include "core/implicit.h"

using namespace vismap;
using namespace vismap::implicit;

namespace {

std::string data_path(const std::string& rel) { return std::string(VISMAP_SOURCE_DIR) + "/../shared/data/" + rel; }

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
  const Tape t = load(data_path("implicit/mpr_architecture.sexp"));
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
  const Tape t = load(data_path("implicit/mpr_architecture.sexp"));
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
