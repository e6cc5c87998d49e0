#include "core/util/polygon.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

namespace vismap {

namespace {

// Knuth's TwoSum: x + y = a + b exactly, x the rounded sum (no overflow in our range).
inline void two_sum(double a, double b, double& x, double& y) {
  x = a + b;
  const double bv = x - a, av = x - bv;
  y = (a - av) + (b - bv);
}

}  // namespace

int orient2d_exact(const float a[2], const float b[2], const float c[2]) {
  // Shewchuk's filter first (orient2d's stage A, ccwerrboundA): the rounded determinant's sign
  // is right wherever it is past this bound (no underflow: float coordinates' differences and
  // their products stay far inside double's range).
  constexpr double kEps = 0x1p-53;
  constexpr double kBound = (3.0 + 16.0 * kEps) * kEps;
  const double detleft = (double(a[0]) - c[0]) * (double(b[1]) - c[1]);
  const double detright = (double(a[1]) - c[1]) * (double(b[0]) - c[0]);
  const double det = detleft - detright;
  const double bound = kBound * (std::fabs(detleft) + std::fabs(detright));
  if (det > bound) return 1;
  if (-det > bound) return -1;
  // Near zero, exactly: (bx - ax)(cy - ay) - (by - ay)(cx - ax) expanded into six products of
  // floats, each exact in double (24 x 24 bits < 53; float range squared is within double's,
  // denormals included), and their sum's sign found exactly.
  const double ax = a[0], ay = a[1], bx = b[0], by = b[1], cx = c[0], cy = c[1];
  const double terms[6] = {bx * cy, -(bx * ay), -(ax * cy), -(by * cx), ax * by, ay * cx};
  // Shewchuk's GROW-EXPANSION: e stays a non-overlapping expansion of the terms so far, in
  // increasing magnitude; its sign is its largest non-zero component's.
  double e[7];
  int n = 0;
  for (double t : terms) {
    double q = t;
    for (int i = 0; i < n; ++i) {
      double x, y;
      two_sum(q, e[i], x, y);
      e[i] = y;
      q = x;
    }
    e[n++] = q;
  }
  for (int i = n - 1; i >= 0; --i)
    if (e[i] != 0) return e[i] > 0 ? 1 : -1;
  return 0;
}

namespace {

using P2 = std::array<float, 2>;

int orient(const P2& a, const P2& b, const P2& c) {
  return orient2d_exact(a.data(), b.data(), c.data());
}

// Whether all non-zero turns have one sign and the boundary goes round once: the u coordinate
// changes direction exactly twice round the polygon (a star pentagon turns one way throughout
// but goes round twice, changing direction four times).
bool is_convex(const P2* p, size_t k) {
  int sign = 0;
  for (size_t i = 0, h = k - 1, j = 1; i < k; h = i, ++i, j = j + 1 == k ? 0 : j + 1) {
    const int t = orient(p[h], p[i], p[j]);
    if (t == 0) continue;
    if (sign == 0) sign = t;
    if (t != sign) return false;
  }
  if (sign == 0) return true;  // every corner on a line: nothing to choose (zero-area triangles)
  // The sign of each edge's step in u, zero steps left out: changes round the polygon.
  int first = 0, last = 0, changes = 0;
  for (size_t i = 0; i < k; ++i) {
    const float a = p[i][0], b = p[i + 1 == k ? 0 : i + 1][0];
    if (a == b) continue;
    const int d = b > a ? 1 : -1;
    if (first == 0) first = d;
    if (last != 0 && d != last) ++changes;
    last = d;
  }
  if (last != first) ++changes;  // round the end
  return changes <= 2;
}

// Whether two edges that share no corner cross at a point inside both (a proper crossing). Edges
// that only touch, or overlap along a line (a bridge walked both ways), do not.
bool edges_cross(const P2& a, const P2& b, const P2& c, const P2& d) {
  const int o1 = orient(a, b, c), o2 = orient(a, b, d);
  if (o1 == 0 || o2 == 0 || o1 == o2) return false;
  const int o3 = orient(c, d, a), o4 = orient(c, d, b);
  return o3 != 0 && o4 != 0 && o3 != o4;
}

bool has_crossing(const P2* p, size_t k) {
  std::vector<std::array<float, 4>> box(k);  // each edge's u, v extent
  for (size_t i = 0; i < k; ++i) {
    const P2& a = p[i];
    const P2& b = p[(i + 1) % k];
    box[i] = {std::min(a[0], b[0]), std::max(a[0], b[0]), std::min(a[1], b[1]),
              std::max(a[1], b[1])};
  }
  for (size_t i = 0; i < k; ++i)
    for (size_t j = i + 2; j < k; ++j) {
      if (i == 0 && j == k - 1) continue;  // adjacent across the end
      if (box[i][1] < box[j][0] || box[j][1] < box[i][0] || box[i][3] < box[j][2] ||
          box[j][3] < box[i][2])
        continue;
      if (edges_cross(p[i], p[(i + 1) % k], p[j], p[(j + 1) % k])) return true;
    }
  return false;
}

}  // namespace

PolygonShape triangulate_polygon(const float* positions, const uint32_t* corners, size_t k,
                                 uint32_t* out) {
  auto fan = [&] {
    for (size_t i = 2; i < k; ++i) {
      uint32_t* t = out + 3 * (i - 2);
      t[0] = corners[0], t[1] = corners[i - 1], t[2] = corners[i];
    }
  };
  if (k <= 3) {
    fan();
    return PolygonShape::Convex;
  }
  // The dominant plane: the largest component of the Newell normal (double sums of floats).
  double n[3] = {0, 0, 0};
  for (size_t i = 0; i < k; ++i) {
    const float* a = positions + 3 * size_t(corners[i]);
    const float* b = positions + 3 * size_t(corners[i + 1 == k ? 0 : i + 1]);
    n[0] += (double(a[1]) - b[1]) * (double(a[2]) + b[2]);
    n[1] += (double(a[2]) - b[2]) * (double(a[0]) + b[0]);
    n[2] += (double(a[0]) - b[0]) * (double(a[1]) + b[1]);
  }
  int axis = 0;
  for (int c = 1; c < 3; ++c)
    if (std::fabs(n[c]) > std::fabs(n[axis])) axis = c;
  if (!(std::fabs(n[axis]) > 0)) {  // a zero (or NaN: finish_mesh refuses it) area: nothing to do
    fan();
    return PolygonShape::Convex;
  }
  // Projected with the normal's own handedness kept: (y, z) for x, (z, x) for y, (x, y) for z,
  // so that the polygon turns left (counter-clockwise) where n[axis] > 0.
  const int u = (axis + 1) % 3, v = (axis + 2) % 3;
  // On the stack for the usual small faces (a quad mesh calls this per face).
  P2 small[16];
  std::vector<P2> large(k > 16 ? k : 0);
  P2* p = k > 16 ? large.data() : small;
  for (size_t i = 0; i < k; ++i) {
    const float* q = positions + 3 * size_t(corners[i]);
    p[i] = {q[u], q[v]};
  }
  if (is_convex(p, k)) {
    fan();
    return PolygonShape::Convex;
  }
  if (k > kMaxEarClipCorners) {
    fan();
    return PolygonShape::TooLarge;
  }
  // Edges that cross: there is no right triangulation to give (which parts are inside depends on
  // a fill rule the file does not state), so the fan stays, as before, and the caller warns.
  if (has_crossing(p, k)) {
    fan();
    return PolygonShape::NotSimple;
  }

  // Ear clipping (as mapbox's earcut, without its dropping of repeated and collinear corners,
  // which would change the triangle count): a corner is an ear when it turns left and no corner
  // that does not (a reflex or flat one) lies in or on its triangle, corners at the triangle's
  // own points excepted (a polygon that touches itself repeats them).
  const int s = n[axis] > 0 ? 1 : -1;
  auto turn = [&](size_t a, size_t b, size_t c) { return s * orient(p[a], p[b], p[c]); };
  std::vector<uint32_t> prev(k), next(k);
  std::vector<int8_t> turns(k);
  for (size_t i = 0; i < k; ++i) {
    prev[i] = uint32_t((i + k - 1) % k);
    next[i] = uint32_t((i + 1) % k);
  }
  for (size_t i = 0; i < k; ++i) turns[i] = int8_t(turn(prev[i], i, next[i]));
  auto same = [&](size_t a, size_t b) { return p[a] == p[b]; };
  // Work bound: the corners looked at by ear tests, at most 8 k^2 (a simple polygon needs far
  // fewer). Past it (a degenerate polygon the tests above let through), the rest is fanned.
  uint64_t work = 0;
  const uint64_t max_work = 8 * uint64_t(k) * k;
  auto is_ear = [&](size_t b) {
    const size_t a = prev[b], c = next[b];
    if (turns[b] <= 0) return false;
    for (size_t q = next[c]; q != a; q = next[q]) {
      ++work;
      if (turns[q] > 0 || same(q, a) || same(q, b) || same(q, c)) continue;
      if (turn(a, b, q) >= 0 && turn(b, c, q) >= 0 && turn(c, a, q) >= 0) return false;
    }
    return true;
  };
  size_t emitted = 0;
  auto clip = [&](size_t b) {
    const size_t a = prev[b], c = next[b];
    uint32_t* t = out + 3 * emitted++;
    t[0] = corners[a], t[1] = corners[b], t[2] = corners[c];
    next[a] = uint32_t(c);
    prev[c] = uint32_t(a);
    turns[a] = int8_t(turn(prev[a], a, c));
    turns[c] = int8_t(turn(a, c, next[c]));
  };
  bool stuck = false;
  size_t left = k, cur = 0, stop = 0;
  while (left > 3) {
    if (work > max_work) {  // fan what is left from cur: still one triangle per corner cut
      stuck = true;
      for (size_t b = next[cur]; left > 3; --left) {
        const size_t c = next[b];
        uint32_t* t = out + 3 * emitted++;
        t[0] = corners[cur], t[1] = corners[b], t[2] = corners[c];
        next[cur] = uint32_t(c);
        prev[c] = uint32_t(cur);
        b = c;
      }
      cur = next[cur];
      break;
    }
    if (is_ear(cur)) {
      const size_t after = next[cur];
      clip(cur);
      --left;
      cur = stop = after;
      continue;
    }
    cur = next[cur];
    if (cur == stop) {
      // A whole round without an ear: the polygon touches itself in a way no ear survives (or is
      // degenerate past what the tests above see). Cut a corner that turns left, else this one.
      stuck = true;
      size_t pick = cur;
      if (turns[cur] <= 0)
        for (size_t q = next[cur]; q != cur; q = next[q])
          if (turns[q] > 0) {
            pick = q;
            break;
          }
      const size_t after = next[pick];
      clip(pick);
      --left;
      cur = stop = after;
    }
  }
  uint32_t* t = out + 3 * emitted;
  t[0] = corners[prev[cur]], t[1] = corners[cur], t[2] = corners[next[cur]];
  return stuck ? PolygonShape::NotSimple : PolygonShape::Concave;
}

}  // namespace vismap
