// Exact 2D primitives shared by the checkers (internal to tests/support).
// Points are homogeneous integers (X/W, Y/W) in grid units with W > 0 and |X|,|Y|,W < 2^127;
// predicates are a double filter with a derived error bound, then int512 arithmetic.
#pragma once

#include <gmpxx.h>

#include <boost/multiprecision/cpp_int.hpp>
#include <cmath>
#include <cstdint>
#include <vector>

#include "core/planar_map.h"

namespace vismap::check::detail {

using i128 = __int128;
using Big = boost::multiprecision::int512_t;  // 3x3 determinants of 128-bit entries: < 2^387

inline i128 to_i128(const Int128Parts& p) {
  return static_cast<i128>((static_cast<unsigned __int128>(static_cast<uint64_t>(p.hi)) << 64) |
                           p.lo);
}
inline Big big(i128 v) {
  bool neg = v < 0;
  unsigned __int128 m =
      neg ? -static_cast<unsigned __int128>(v) : static_cast<unsigned __int128>(v);
  Big r = Big(static_cast<uint64_t>(m >> 64));
  r <<= 64;
  r += static_cast<uint64_t>(m);
  return neg ? Big(-r) : r;
}
inline mpz_class mpz(i128 v) {
  bool neg = v < 0;
  unsigned __int128 m =
      neg ? -static_cast<unsigned __int128>(v) : static_cast<unsigned __int128>(v);
  mpz_class r = static_cast<unsigned long>(static_cast<uint64_t>(m >> 64));
  r <<= 64;
  r += static_cast<unsigned long>(static_cast<uint64_t>(m));
  return neg ? mpz_class(-r) : r;
}

struct HPoint {
  i128 X = 0, Y = 0, W = 1;
  double x = 0, y = 0;  // X/W, Y/W rounded: |x - X/W| <= 3u|X/W| (three roundings)
};

inline HPoint make_point(i128 X, i128 Y, i128 W) {
  HPoint p{X, Y, W, 0, 0};
  double w = static_cast<double>(W);
  p.x = static_cast<double>(X) / w;
  p.y = static_cast<double>(Y) / w;
  return p;
}

inline bool same_point(const HPoint& a, const HPoint& b) {
  if (a.X == b.X && a.Y == b.Y && a.W == b.W) return true;
  return big(a.X) * big(b.W) == big(b.X) * big(a.W) && big(a.Y) * big(b.W) == big(b.Y) * big(a.W);
}

// Sign of the cross product (b-a) x (c-a): > 0 when c is left of a->b in (x, y) with the usual
// determinant, i.e. the turn of a polygon with positive shoelace area.
//
// Filter: each rounded coordinate is off by at most 3u·M (u = 2^-53, M = max |coordinate| of the
// three points). A difference then carries at most 6u·M + u·2M(1+6u) <= 8.1u·M of error and is at
// most 2M in size; a product of two differences errs by <= 2·2M·8.1u·M + (8.1u·M)^2 + u·4.1M^2
// <= 36.6u·M^2; the two products and the final subtraction (u·8.2M^2) give <= 81.4u·M^2. We use
// 128u·M^2, computed with a margin that covers the rounding of the bound itself.
inline int orient(const HPoint& a, const HPoint& b, const HPoint& c) {
  double m = std::fmax(std::fmax(std::fmax(std::fabs(a.x), std::fabs(a.y)),
                                 std::fmax(std::fabs(b.x), std::fabs(b.y))),
                       std::fmax(std::fabs(c.x), std::fabs(c.y)));
  double det = (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
  double bound = 128.0 * 0x1p-53 * m * m;
  if (m > 1e-100 && m < 1e100) {
    if (det > bound) return 1;
    if (det < -bound) return -1;
  }
  // det3 [[aX aY aW] [bX bY bW] [cX cY cW]] has the sign of the orientation (W > 0).
  Big aX = big(a.X), aY = big(a.Y), aW = big(a.W), bX = big(b.X), bY = big(b.Y), bW = big(b.W),
      cX = big(c.X), cY = big(c.Y), cW = big(c.W);
  Big d = aX * (bY * cW - cY * bW) - aY * (bX * cW - cX * bW) + aW * (bX * cY - cX * bY);
  return d > 0 ? 1 : (d < 0 ? -1 : 0);
}

// Rational points for constructions (clipping).
struct QPoint {
  mpq_class x, y;
};
inline QPoint to_q(const HPoint& p) {
  mpz_class w = mpz(p.W);
  QPoint q{mpq_class(mpz(p.X), w), mpq_class(mpz(p.Y), w)};
  q.x.canonicalize();
  q.y.canonicalize();
  return q;
}
inline mpq_class cross(const QPoint& a, const QPoint& b, const QPoint& c) {
  return (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
}
inline mpq_class area2(const std::vector<QPoint>& poly) {  // twice the shoelace area
  mpq_class s = 0;
  for (size_t i = 0, n = poly.size(); i < n; ++i) {
    const QPoint& a = poly[i];
    const QPoint& b = poly[(i + 1) % n];
    s += a.x * b.y - b.x * a.y;
  }
  return s;
}
// Keeps the part of `poly` where cross(a, b, p) >= 0 (left of a->b, closed).
std::vector<QPoint> clip_left(const std::vector<QPoint>& poly, const QPoint& a, const QPoint& b);
// Area (twice) of the intersection of two convex, positively oriented polygons.
mpq_class convex_intersection_area2(const std::vector<QPoint>& p, const std::vector<QPoint>& q);

// Fixed-point accumulator of areas: units of 2^-kFrac grid units squared. A rational added is
// truncated to that resolution, so a sum of n terms is exact to within n·2^-kFrac.
class AreaSum {
 public:
  static constexpr int kFrac = 96;
  void add(const mpq_class& v);
  void add_fixed(const mpz_class& v) { sum_ += v; }
  void add(const AreaSum& o) { sum_ += o.sum_; }
  const mpz_class& fixed() const { return sum_; }
  double value() const;  // in grid units squared
  bool is_zero() const { return sum_ == 0; }

 private:
  mpz_class sum_ = 0;
};

// Exact area (twice) of the union of the screen triangles, grid units squared (reference.cpp).
mpq_class union_area2(const ScreenTriangles& screen);

}  // namespace vismap::check::detail
