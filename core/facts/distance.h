// The distances find_scene_facts measures (scene_facts.h): between points, segments and
// triangles in doubles, with the rounding the facts' margins cover (docs/NUMERICS.md §2 "Pairs far
// apart in 3D"). Inline: the search calls them for every candidate pair.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "core/util/vec3.h"

namespace vismap::facts::geom {

using vec3::V;
using Tri = std::array<V, 3>;
using vec3::cross;
using vec3::dot;
using vec3::sub;
using vec3::length;
inline V along(const V& a, const V& d, double s) { return {a[0] + d[0] * s, a[1] + d[1] * s, a[2] + d[2] * s}; }

// Distance from p to segment [a, b].
inline double point_segment(const V& p, const V& a, const V& b) {
  const V d = sub(b, a);
  const double dd = dot(d, d);
  const double s = dd > 0 ? std::clamp(dot(sub(p, a), d) / dd, 0.0, 1.0) : 0.0;
  return length(sub(p, along(a, d, s)));
}

// Distance between segments [p1, q1] and [p2, q2] (the closest points of Ericson's Real-Time
// Collision Detection 5.1.9), never more than the four endpoint-to-segment distances. Where
// the segments are nearly parallel the interior solution is ill-conditioned; the caller's
// margin covers it (scene_facts.h, NUMERICS §2).
inline double segment_segment(const V& p1, const V& q1, const V& p2, const V& q2) {
  double best = std::min({point_segment(p1, p2, q2), point_segment(q1, p2, q2),
                          point_segment(p2, p1, q1), point_segment(q2, p1, q1)});
  const V d1 = sub(q1, p1), d2 = sub(q2, p2), r = sub(p1, p2);
  const double a = dot(d1, d1), e = dot(d2, d2);
  if (!(a > 0) || !(e > 0)) return best;
  const double b = dot(d1, d2), c = dot(d1, r), f = dot(d2, r), denom = a * e - b * b;
  if (!(denom > 0)) return best;
  const double s = std::clamp((b * f - c * e) / denom, 0.0, 1.0);
  const double t = (b * s + f) / e;
  if (t < 0 || t > 1) return best;  // then an endpoint solution is the closest: in `best`
  return std::min(best, length(sub(along(p1, d1, s), along(p2, d2, t))));
}

struct Prepared {
  Tri v;
  V n;          // (v1 - v0) x (v2 - v0)
  double nl;    // |n|
  bool flat;    // degenerate (its edges stand for it)
  double perimeter;
};

inline Prepared prepare(const Tri& t) {
  Prepared p;
  p.v = t;
  const V e1 = sub(t[1], t[0]), e2 = sub(t[2], t[0]), e3 = sub(t[2], t[1]);
  p.n = cross(e1, e2);
  p.nl = length(p.n);
  // sin^2 of the angle at v0 below 2^-40: too thin for its plane to be trusted.
  p.flat = !(dot(p.n, p.n) > std::ldexp(dot(e1, e1) * dot(e2, e2), -40));
  p.perimeter = length(e1) + length(e2) + length(e3);
  return p;
}

// Is x (in the plane of t, or near it) inside t's closure, with a tolerance that only ever says
// "inside" more often (the plane distance used then is a lower bound of the true one)?
inline bool inside(const Prepared& t, const V& x) {
  for (int i = 0; i < 3; ++i) {
    const V& a = t.v[i];
    const V& b = t.v[i == 2 ? 0 : i + 1];
    const V e = sub(b, a), w = sub(x, a);
    const double s = dot(cross(e, w), t.n);
    const double tol = std::ldexp(length(e) * (length(w) + length(e)) * t.nl, -30);
    if (s < -tol) return false;
  }
  return true;
}

inline double point_triangle(const V& p, const Prepared& t) {
  double best = std::min({point_segment(p, t.v[0], t.v[1]), point_segment(p, t.v[1], t.v[2]),
                          point_segment(p, t.v[2], t.v[0])});
  if (t.flat) return best;
  const double h = dot(sub(p, t.v[0]), t.n) / t.nl;
  const V foot = along(p, t.n, -h / t.nl);
  if (inside(t, foot)) best = std::min(best, std::fabs(h));
  return best;
}

// Does segment [p, q] meet t (closure, with the tolerance of `inside`)?
inline bool segment_meets(const V& p, const V& q, const Prepared& t) {
  if (t.flat) return false;  // (its edges are compared as segments)
  const double sp = dot(sub(p, t.v[0]), t.n), sq = dot(sub(q, t.v[0]), t.n);
  if ((sp > 0 && sq > 0) || (sp < 0 && sq < 0)) return false;
  if (sp == sq) return false;  // in the plane: the edge and point distances see it
  return inside(t, along(p, sub(q, p), sp / (sp - sq)));
}

inline double distance(const Prepared& a, const Prepared& b) {
  for (int i = 0; i < 3; ++i) {
    const int j = i == 2 ? 0 : i + 1;
    if (segment_meets(a.v[i], a.v[j], b) || segment_meets(b.v[i], b.v[j], a)) return 0;
  }
  double best = std::numeric_limits<double>::infinity();
  for (int i = 0; i < 3; ++i) {
    best = std::min({best, point_triangle(a.v[i], b), point_triangle(b.v[i], a)});
    const int j = i == 2 ? 0 : i + 1;
    for (int k = 0; k < 3; ++k) {
      const int l = k == 2 ? 0 : k + 1;
      best = std::min(best, segment_segment(a.v[i], a.v[j], b.v[k], b.v[l]));
    }
  }
  return best;
}

// Are a and b more than `gap` apart along one of eight axes (each normal, each edge's normal
// within its triangle's plane)? Projections onto a unit axis do not lengthen distances, so then
// their distance is more than gap: a cheap test before `distance` (most pairs near each other
// in a mesh are two rings apart and separated by a whole triangle's width).
inline bool separated(const Prepared& a, const Prepared& b, double gap) {
  auto apart_along = [&](const V& axis) {
    const double l = length(axis);
    if (!(l > 0)) return false;
    double amin = INFINITY, amax = -INFINITY, bmin = INFINITY, bmax = -INFINITY;
    for (int i = 0; i < 3; ++i) {
      const double pa = dot(a.v[i], axis), pb = dot(b.v[i], axis);
      amin = std::min(amin, pa);
      amax = std::max(amax, pa);
      bmin = std::min(bmin, pb);
      bmax = std::max(bmax, pb);
    }
    return bmin - amax > gap * l || amin - bmax > gap * l;
  };
  for (const Prepared* p : {&a, &b}) {
    if (p->flat) continue;
    if (apart_along(p->n)) return true;
    for (int i = 0; i < 3; ++i)
      if (apart_along(cross(p->n, sub(p->v[i == 2 ? 0 : i + 1], p->v[i])))) return true;
  }
  return false;
}

// A float not above x (x >= 0).
inline float float_below(double x) {
  float f = static_cast<float>(x);
  if (static_cast<double>(f) > x) f = std::nextafter(f, 0.0f);
  return std::max(f, 0.0f);
}

struct Box {
  V lo, hi;
};

inline double box_distance(const Box& a, const Box& b) {
  double s = 0;
  for (int k = 0; k < 3; ++k) {
    const double g = std::max({0.0, a.lo[k] - b.hi[k], b.lo[k] - a.hi[k]});
    s += g * g;
  }
  return std::sqrt(s);
}

}  // namespace vismap::facts::geom
