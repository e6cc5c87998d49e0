// check_planar_map and pixel_compare (docs/CHECKS.md). Exact predicates from exact_geom.h; the
// union of the screen triangles comes from reference.cpp (the CGAL translation unit).
#include "core/check/planar_check.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <unordered_map>

#include "core/check/exact_geom.h"
#include "core/util/clock.h"
#include "kernels/layout.h"

namespace vismap::check {
namespace detail {

std::vector<QPoint> clip_left(const std::vector<QPoint>& poly, const QPoint& a, const QPoint& b) {
  std::vector<QPoint> out;
  size_t n = poly.size();
  if (n == 0) return out;
  std::vector<mpq_class> s(n);
  for (size_t i = 0; i < n; ++i) s[i] = cross(a, b, poly[i]);
  for (size_t i = 0; i < n; ++i) {
    size_t j = (i + 1) % n;
    if (sgn(s[i]) >= 0) out.push_back(poly[i]);
    if ((sgn(s[i]) > 0 && sgn(s[j]) < 0) || (sgn(s[i]) < 0 && sgn(s[j]) > 0)) {
      mpq_class t = s[i] / (s[i] - s[j]);
      out.push_back(
          QPoint{poly[i].x + t * (poly[j].x - poly[i].x), poly[i].y + t * (poly[j].y - poly[i].y)});
    }
  }
  return out;
}

mpq_class convex_intersection_area2(const std::vector<QPoint>& p, const std::vector<QPoint>& q) {
  std::vector<QPoint> r = p;
  for (size_t i = 0, n = q.size(); i < n && r.size() >= 3; ++i)
    r = clip_left(r, q[i], q[(i + 1) % n]);
  if (r.size() < 3) return 0;
  return area2(r);
}

void AreaSum::add(const mpq_class& v) {
  mpz_class num = v.get_num();
  num <<= kFrac;
  mpz_class q;
  mpz_tdiv_q(q.get_mpz_t(), num.get_mpz_t(), v.get_den_mpz_t());
  sum_ += q;
}

double AreaSum::value() const {
  long exp = 0;
  double m = mpz_get_d_2exp(&exp, sum_.get_mpz_t());
  return std::ldexp(m, static_cast<int>(exp) - kFrac);
}

}  // namespace detail

using namespace detail;

namespace {

uint64_t source_key(uint32_t mesh, uint32_t tri) {
  return (uint64_t(mesh) << 32) | tri;
}

// The map's fragments as exact homogeneous polygons in grid units, consecutive duplicate
// vertices removed.
struct Fragments {
  bool exact = false;
  uint32_t gs = 1;
  std::vector<HPoint> pts;
  std::vector<uint32_t> begin;  // fragment f: pts[begin[f], begin[f+1])
  std::vector<uint8_t> bad;     // a vertex was unusable (hw <= 0, non-finite, too large)
  size_t size() const { return begin.size() - 1; }
  const HPoint* poly(size_t f) const { return pts.data() + begin[f]; }
  size_t count(size_t f) const { return begin[f + 1] - begin[f]; }
};

Fragments load_fragments(const PlanarMap& map, uint32_t screen_gs, bool use_exact) {
  Fragments fr;
  fr.gs = map.grid_scale ? map.grid_scale : (screen_gs ? screen_gs : 1);
  size_t nv = map.vertex_count();
  fr.exact =
      use_exact && map.hx.size() == nv && map.hy.size() == nv && map.hw.size() == nv && nv > 0;
  size_t nf = map.fragment_count();
  fr.begin.assign(1, 0);
  fr.bad.assign(nf, 0);
  fr.pts.reserve(nv);
  for (size_t f = 0; f < nf; ++f) {
    size_t first = fr.pts.size();
    for (uint32_t v = map.offsets[f]; v < map.offsets[f + 1]; ++v) {
      HPoint p;
      if (fr.exact) {
        i128 W = to_i128(map.hw[v]);
        if (W <= 0) {
          fr.bad[f] = 1;
          continue;
        }
        p = make_point(to_i128(map.hx[v]), to_i128(map.hy[v]), W);
      } else {
        // A double d is exactly trunc(d·2^64)/2^64 when |d| >= 2^-12 (its ulp is >= 2^-64);
        // smaller non-zero coordinates lose bits below 2^-64 pixels.
        double x = map.xy[2 * v], y = map.xy[2 * v + 1];
        double lim = std::ldexp(1.0, 62) / fr.gs;
        if (!std::isfinite(x) || !std::isfinite(y) || std::fabs(x) >= lim || std::fabs(y) >= lim) {
          fr.bad[f] = 1;
          continue;
        }
        p = make_point(static_cast<i128>(std::ldexp(x, 64)) * fr.gs,
                       static_cast<i128>(std::ldexp(y, 64)) * fr.gs, static_cast<i128>(1) << 64);
      }
      if (fr.pts.size() > first && same_point(fr.pts.back(), p)) continue;
      fr.pts.push_back(p);
    }
    while (fr.pts.size() > first + 1 && same_point(fr.pts.back(), fr.pts[first])) fr.pts.pop_back();
    fr.begin.push_back(static_cast<uint32_t>(fr.pts.size()));
  }
  return fr;
}

// Sign of b.x - a.x (exact).
int cmp_x(const HPoint& a, const HPoint& b) {
  double d = b.x - a.x, m = std::fmax(std::fabs(a.x), std::fabs(b.x));
  if (d > 8 * 0x1p-53 * m) return 1;  // each rounded coordinate errs by <= 3u·m
  if (d < -8 * 0x1p-53 * m) return -1;
  Big v = big(b.X) * big(a.W) - big(a.X) * big(b.W);
  return v > 0 ? 1 : (v < 0 ? -1 : 0);
}
int cmp_y(const HPoint& a, const HPoint& b) {
  HPoint a2 = a, b2 = b;
  std::swap(a2.X, a2.Y);
  std::swap(a2.x, a2.y);
  std::swap(b2.X, b2.Y);
  std::swap(b2.x, b2.y);
  return cmp_x(a2, b2);
}

std::vector<QPoint> to_q(const HPoint* p, size_t n) {
  std::vector<QPoint> q;
  q.reserve(n);
  for (size_t i = 0; i < n; ++i) q.push_back(detail::to_q(p[i]));
  return q;
}

enum class Shape { Degenerate, Convex, NonConvex };

// Exact classification; `area` gets twice the area of non-degenerate fragments, in fixed point.
Shape classify(const HPoint* p, size_t n, AreaSum* area) {
  if (n < 3) return Shape::Degenerate;
  bool any_pos = false, any_neg = false;
  for (size_t i = 0; i < n; ++i) {
    int o = orient(p[(i + n - 1) % n], p[i], p[(i + 1) % n]);
    any_pos |= o > 0;
    any_neg |= o < 0;
  }
  if (!any_pos && !any_neg) return Shape::Degenerate;  // all collinear
  bool convex = !any_neg;
  if (convex) {  // all left turns: convex unless it winds more than once
    int changes_x = 0, changes_y = 0, last_x = 0, last_y = 0;
    for (size_t i = 0; i <= n; ++i) {
      int sx = cmp_x(p[i % n], p[(i + 1) % n]), sy = cmp_y(p[i % n], p[(i + 1) % n]);
      if (sx) {
        changes_x += last_x && sx != last_x;
        last_x = sx;
      }
      if (sy) {
        changes_y += last_y && sy != last_y;
        last_y = sy;
      }
    }
    convex = changes_x <= 2 && changes_y <= 2;
  }
  mpz_class sum = 0;  // shoelace terms in fixed point
  for (size_t i = 0; i < n; ++i) {
    const HPoint& a = p[i];
    const HPoint& b = p[(i + 1) % n];
    mpz_class num = mpz(a.X) * mpz(b.Y) - mpz(b.X) * mpz(a.Y);
    num <<= AreaSum::kFrac;
    mpz_class den = mpz(a.W) * mpz(b.W), q;
    mpz_tdiv_q(q.get_mpz_t(), num.get_mpz_t(), den.get_mpz_t());
    sum += q;
  }
  if (!convex) {
    mpq_class a2 = area2(to_q(p, n));  // the sign must be exact
    if (sgn(a2) <= 0) return Shape::Degenerate;
  }
  area->add_fixed(sum);
  return convex ? Shape::Convex : Shape::NonConvex;
}

struct Box {
  double x0, y0, x1, y1;
};

Box bbox(const HPoint* p, size_t n) {
  Box b{std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity(),
        -std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity()};
  for (size_t i = 0; i < n; ++i) {
    b.x0 = std::min(b.x0, p[i].x);
    b.y0 = std::min(b.y0, p[i].y);
    b.x1 = std::max(b.x1, p[i].x);
    b.y1 = std::max(b.y1, p[i].y);
  }
  // Rounded coordinates err by <= 3u|x|: widen so the box contains the exact polygon.
  double m = std::max({std::fabs(b.x0), std::fabs(b.y0), std::fabs(b.x1), std::fabs(b.y1)});
  double e = 4 * 0x1p-53 * m + 1e-300;
  return Box{b.x0 - e, b.y0 - e, b.x1 + e, b.y1 + e};
}

// Convex P and Q have disjoint interiors iff an edge line of one of them has the other entirely
// on its closed outer side (the separating-axis theorem for polygons).
bool separated_by_edges(const HPoint* p, size_t np, const HPoint* q, size_t nq) {
  for (size_t i = 0; i < np; ++i) {
    const HPoint& a = p[i];
    const HPoint& b = p[(i + 1) % np];
    bool all_out = true;
    for (size_t j = 0; j < nq && all_out; ++j) all_out = orient(a, b, q[j]) <= 0;
    if (all_out) return true;
  }
  return false;
}

// Candidate pairs (bounding boxes overlap) through a uniform grid in CSR form; calls fn(i, j)
// once per pair.
template <class Fn>
void for_each_box_pair(const std::vector<Box>& boxes, const std::vector<uint32_t>& ids, Fn fn) {
  if (ids.size() < 2) return;
  Box all = boxes[ids[0]];
  double mean = 0;
  for (uint32_t i : ids) {
    const Box& b = boxes[i];
    all.x0 = std::min(all.x0, b.x0), all.y0 = std::min(all.y0, b.y0);
    all.x1 = std::max(all.x1, b.x1), all.y1 = std::max(all.y1, b.y1);
    mean += std::max(b.x1 - b.x0, b.y1 - b.y0);
  }
  mean /= ids.size();
  double w = all.x1 - all.x0, h = all.y1 - all.y0;
  double cell = std::max(mean * 2, std::sqrt(w * h / (4.0 * ids.size())));
  if (!(cell > 0)) cell = 1;
  uint32_t gx = static_cast<uint32_t>(std::min(4096.0, std::floor(w / cell) + 1));
  uint32_t gy = static_cast<uint32_t>(std::min(4096.0, std::floor(h / cell) + 1));
  double sx = gx / (w > 0 ? w : 1), sy = gy / (h > 0 ? h : 1);
  auto cx = [&](double x) {
    return std::min<uint32_t>(gx - 1, static_cast<uint32_t>(std::max(0.0, (x - all.x0) * sx)));
  };
  auto cy = [&](double y) {
    return std::min<uint32_t>(gy - 1, static_cast<uint32_t>(std::max(0.0, (y - all.y0) * sy)));
  };
  std::vector<uint32_t> start(size_t(gx) * gy + 1, 0), items;
  for (int pass = 0; pass < 2; ++pass) {  // count, scan, fill
    std::vector<uint32_t> fill;
    if (pass == 1) {
      for (size_t c = 1; c < start.size(); ++c) start[c] += start[c - 1];
      fill.assign(start.begin(), start.end() - 1);
    }
    if (pass == 1) items.assign(start.back(), 0);
    for (uint32_t i : ids) {
      const Box& b = boxes[i];
      for (uint32_t y = cy(b.y0); y <= cy(b.y1); ++y)
        for (uint32_t x = cx(b.x0); x <= cx(b.x1); ++x) {
          size_t c = size_t(y) * gx + x;
          if (pass == 0)
            ++start[c + 1];
          else
            items[fill[c]++] = i;
        }
    }
    if (pass == 1) {
      for (size_t c = 0; c + 1 < start.size(); ++c)
        for (uint32_t s = start[c]; s < start[c + 1]; ++s)
          for (uint32_t t = s + 1; t < start[c + 1]; ++t) {
            const Box& a = boxes[items[s]];
            const Box& b = boxes[items[t]];
            if (!(a.x0 < b.x1 && b.x0 < a.x1 && a.y0 < b.y1 && b.y0 < a.y1)) continue;
            // Report the pair only in the cell that holds the corner of the boxes' overlap.
            if (size_t(cy(std::max(a.y0, b.y0))) * gx + cx(std::max(a.x0, b.x0)) != c) continue;
            fn(items[s], items[t]);
          }
    }
  }
}

struct SourceTriangles {
  std::vector<HPoint> tri;  // 3 per screen triangle, positively oriented
  std::unordered_map<uint64_t, std::vector<uint32_t>> by_source;
};

SourceTriangles load_triangles(const ScreenTriangles& s) {
  SourceTriangles st;
  st.tri.resize(s.size() * 3);
  for (size_t t = 0; t < s.size(); ++t) {
    HPoint p[3];
    for (int k = 0; k < 3; ++k) p[k] = make_point(s.xy[6 * t + 2 * k], s.xy[6 * t + 2 * k + 1], 1);
    if (orient(p[0], p[1], p[2]) < 0) std::swap(p[1], p[2]);
    for (int k = 0; k < 3; ++k) st.tri[3 * t + k] = p[k];
    st.by_source[source_key(s.mesh[t], s.triangle[t])].push_back(static_cast<uint32_t>(t));
  }
  return st;
}

bool in_triangle(const HPoint* t, const HPoint& p) {
  return orient(t[0], t[1], p) >= 0 && orient(t[1], t[2], p) >= 0 && orient(t[2], t[0], p) >= 0;
}

double to_pixels2(const AreaSum& twice, uint32_t gs) {
  return twice.value() / 2 / (double(gs) * gs);
}

}  // namespace

bool CheckReport::ok(double coverage_tolerance) const {
  return degenerate == 0 && nonconvex == 0 && overlap_pairs == 0 && outside_source == 0 &&
         coverage_error <= coverage_tolerance;
}

std::string CheckReport::summary() const {
  std::ostringstream o;
  o << "planar map check (" << (exact ? "exact vertices" : "rounded vertices") << "): " << fragments
    << " fragments, " << screen_triangles << " screen triangles\n"
    << "  degenerate " << degenerate << ", non-convex " << nonconvex << "\n"
    << "  output area " << output_area << " px^2, union area " << union_area
    << " px^2, coverage error " << coverage_error << "\n"
    << "  overlap: " << overlap_pairs << " pairs (of " << candidate_pairs << " candidates), area "
    << overlap_area << " px^2\n"
    << "  outside source: " << outside_source << " fragments (" << unknown_source
    << " unknown source), area " << outside_area << " px^2\n"
    << "  time: " << ms_total << " ms (overlap " << ms_overlap << ", union " << ms_union
    << ", outside " << ms_outside << ")\n";
  return o.str();
}

CheckReport check_planar_map(const PlanarMap& map, const ScreenTriangles& screen,
                             const CheckOptions& options) {
  auto t0 = Clock::now();
  CheckReport r;
  if (map.grid_scale && screen.grid_scale && map.grid_scale != screen.grid_scale)
    throw std::invalid_argument("check_planar_map: map and screen triangles differ in grid_scale");
  Fragments fr = load_fragments(map, screen.grid_scale, options.use_exact);
  r.exact = fr.exact;
  r.fragments = fr.size();
  r.screen_triangles = screen.size();
  uint32_t gs = fr.gs;

  // Shape and area of every fragment.
  std::vector<Shape> shape(fr.size());
  std::vector<AreaSum> area(fr.size());
  AreaSum output;
  for (size_t f = 0; f < fr.size(); ++f) {
    shape[f] = fr.bad[f] ? Shape::Degenerate : classify(fr.poly(f), fr.count(f), &area[f]);
    r.degenerate += shape[f] == Shape::Degenerate;
    r.nonconvex += shape[f] == Shape::NonConvex;
    output.add(area[f]);
  }
  r.output_area = to_pixels2(output, gs);

  if (options.overlap) {
    auto t1 = Clock::now();
    std::vector<Box> boxes(fr.size());
    std::vector<uint32_t> ids;
    for (size_t f = 0; f < fr.size(); ++f)
      if (shape[f] == Shape::Convex) {
        boxes[f] = bbox(fr.poly(f), fr.count(f));
        ids.push_back(static_cast<uint32_t>(f));
      }
    AreaSum overlap;
    for_each_box_pair(boxes, ids, [&](uint32_t a, uint32_t b) {
      ++r.candidate_pairs;
      if (separated_by_edges(fr.poly(a), fr.count(a), fr.poly(b), fr.count(b)) ||
          separated_by_edges(fr.poly(b), fr.count(b), fr.poly(a), fr.count(a)))
        return;
      mpq_class a2 =
          convex_intersection_area2(to_q(fr.poly(a), fr.count(a)), to_q(fr.poly(b), fr.count(b)));
      if (sgn(a2) > 0) {
        ++r.overlap_pairs;
        overlap.add(a2);
      }
    });
    r.overlap_area = to_pixels2(overlap, gs);
    r.ms_overlap = ms_since(t1);
  }

  if (options.outside) {
    auto t1 = Clock::now();
    SourceTriangles st = load_triangles(screen);
    AreaSum outside;
    for (size_t f = 0; f < fr.size(); ++f) {
      if (shape[f] == Shape::Degenerate) continue;
      auto it = st.by_source.find(source_key(map.mesh[f], map.triangle[f]));
      if (it == st.by_source.end()) {
        ++r.outside_source;
        ++r.unknown_source;
        outside.add(area[f]);
        continue;
      }
      // The screen triangles of one source partition a convex polygon (the source triangle
      // clipped by the near plane), so the fragment is inside iff all its vertices are.
      const HPoint* p = fr.poly(f);
      bool inside = true;
      for (size_t i = 0; i < fr.count(f) && inside; ++i) {
        bool in_any = false;
        for (uint32_t t : it->second) in_any = in_any || in_triangle(&st.tri[3 * t], p[i]);
        inside = in_any;
      }
      if (inside) continue;
      ++r.outside_source;
      std::vector<QPoint> q = to_q(p, fr.count(f));
      mpq_class in = 0;
      for (uint32_t t : it->second) in += convex_intersection_area2(q, to_q(&st.tri[3 * t], 3));
      outside.add(area2(q) - in);
    }
    r.outside_area = to_pixels2(outside, gs);
    r.ms_outside = ms_since(t1);
  }

  if (options.coverage) {
    auto t1 = Clock::now();
    AreaSum uni;
    uni.add(union_area2(screen));
    r.union_area = to_pixels2(uni, gs);
    mpz_class diff = abs(output.fixed() - uni.fixed());
    if (uni.is_zero()) {
      r.coverage_error = diff == 0 ? 0 : std::numeric_limits<double>::infinity();
    } else {
      mpq_class e(diff, uni.fixed());
      e.canonicalize();
      r.coverage_error = e.get_d();
    }
    r.ms_union = ms_since(t1);
  }
  r.ms_total = ms_since(t0);
  return r;
}

namespace {

// The tie rule pair by pair, as the pipeline applies it (kernels/crossings.cl pair_relation) and
// the reference does (reference.cpp): over the overlap of the two footprints the depth
// difference d = depth_a - depth_b; +1: a in front over all of it, -1: b in front, 0: the
// planes cross beyond the band (decide point by point).
int pair_order(const ScreenTriangles& s, size_t a, size_t b) {
  auto plane = [&](size_t t, double& gx, double& gy, double& q0, double& x0, double& y0) {
    const int32_t* v = &s.xy[6 * t];
    const double* d = &s.depth[3 * t];
    double ux = v[2] - v[0], uy = v[3] - v[1], wx = v[4] - v[0], wy = v[5] - v[1];
    double det = ux * wy - uy * wx;
    gx = ((d[1] - d[0]) * wy - (d[2] - d[0]) * uy) / det;
    gy = ((d[2] - d[0]) * ux - (d[1] - d[0]) * wx) / det;
    q0 = d[0];
    x0 = v[0];
    y0 = v[1];
  };
  std::vector<std::pair<double, double>> poly;
  for (int k = 0; k < 3; ++k)
    poly.push_back({double(s.xy[6 * a + 2 * k]), double(s.xy[6 * a + 2 * k + 1])});
  const int32_t* w = &s.xy[6 * b];
  double orient = double(w[2] - w[0]) * (w[5] - w[1]) - double(w[3] - w[1]) * (w[4] - w[0]);
  for (int e = 0; e < 3 && !poly.empty(); ++e) {
    int f = (e + 1) % 3;
    double ex = w[2 * f] - w[2 * e], ey = w[2 * f + 1] - w[2 * e + 1];
    if (orient < 0) ex = -ex, ey = -ey;
    std::vector<std::pair<double, double>> out;
    for (size_t i = 0; i < poly.size(); ++i) {
      auto u = poly[i], v = poly[(i + 1) % poly.size()];
      double su = ex * (u.second - w[2 * e + 1]) - ey * (u.first - w[2 * e]);
      double sv = ex * (v.second - w[2 * e + 1]) - ey * (v.first - w[2 * e]);
      if (su >= 0) out.push_back(u);
      if ((su >= 0) != (sv >= 0)) {
        double t = su / (su - sv);
        out.push_back({u.first + t * (v.first - u.first), u.second + t * (v.second - u.second)});
      }
    }
    poly = out;
  }
  double ga, ha, qa, xa, ya, gb, hb, qb, xb, yb;
  plane(a, ga, ha, qa, xa, ya);
  plane(b, gb, hb, qb, xb, yb);
  double dmin = INFINITY, dmax = -INFINITY, band = 0;
  for (auto& p : poly) {
    double da = qa + ga * (p.first - xa) + ha * (p.second - ya);
    double db = qb + gb * (p.first - xb) + hb * (p.second - yb);
    dmin = std::min(dmin, da - db);
    dmax = std::max(dmax, da - db);
    band = std::max(band, VM_TIE_EPS * std::max(std::fabs(da), std::fabs(db)));
  }
  if (dmax > band && dmin < -band) return 0;
  if (dmax > band) return 1;
  if (dmin < -band) return -1;
  uint64_t ka = source_key(s.mesh[a], s.triangle[a]), kb = source_key(s.mesh[b], s.triangle[b]);
  return ka < kb ? 1 : -1;
}

}  // namespace

namespace {

// Marks samples within 1.5 sample spacings of the segment a-b (grid units).
void mark_edge(std::vector<uint8_t>& near, uint32_t n, double sx, double sy, double ax, double ay,
               double bx, double by) {
  // In sample units: sample (i, j) sits at (i + 0.5, j + 0.5).
  ax /= sx, ay /= sy, bx /= sx, by /= sy;
  const double r = 1.5;
  int i0 = std::max(0, static_cast<int>(std::floor(std::min(ax, bx) - r - 0.5)));
  int i1 = std::min(int(n) - 1, static_cast<int>(std::ceil(std::max(ax, bx) + r - 0.5)));
  int j0 = std::max(0, static_cast<int>(std::floor(std::min(ay, by) - r - 0.5)));
  int j1 = std::min(int(n) - 1, static_cast<int>(std::ceil(std::max(ay, by) + r - 0.5)));
  double dx = bx - ax, dy = by - ay, len2 = dx * dx + dy * dy;
  for (int j = j0; j <= j1; ++j)
    for (int i = i0; i <= i1; ++i) {
      double px = i + 0.5 - ax, py = j + 0.5 - ay;
      double t = len2 > 0 ? std::clamp((px * dx + py * dy) / len2, 0.0, 1.0) : 0.0;
      double ex = px - t * dx, ey = py - t * dy;
      if (ex * ex + ey * ey <= r * r) near[size_t(j) * n + i] = 1;
    }
}

}  // namespace

PixelReport pixel_compare(const PlanarMap& map, const ScreenTriangles& screen, uint32_t n) {
  auto t0 = Clock::now();
  PixelReport r;
  r.n = n;
  if (n == 0) return r;
  uint32_t gs = screen.grid_scale ? screen.grid_scale : (map.grid_scale ? map.grid_scale : 1);
  if (map.grid_scale && map.grid_scale != gs)
    throw std::invalid_argument("pixel_compare: map and screen triangles differ in grid_scale");
  // Sample (i, j) is at ((2i+1)·width·gs, (2j+1)·height·gs) / (2n) grid units: exact as HPoint.
  const double sx = double(map.width) * gs / n, sy = double(map.height) * gs / n;
  auto sample = [&](uint32_t i, uint32_t j) {
    return make_point(i128(2 * i + 1) * map.width * gs, i128(2 * j + 1) * map.height * gs,
                      i128(2) * n);
  };
  auto range = [&](double lo, double hi, double s, uint32_t& a, uint32_t& b) {
    double fa = std::ceil(lo / s - 0.5 - 1e-9), fb = std::floor(hi / s - 0.5 + 1e-9);
    if (fb < 0 || fa > n - 1.0 || fa > fb) return false;
    a = static_cast<uint32_t>(std::max(0.0, fa));
    b = static_cast<uint32_t>(std::min(n - 1.0, fb));
    return true;
  };
  const uint64_t kEmpty = ~uint64_t(0), kConflict = ~uint64_t(0) - 1;
  std::vector<uint64_t> zid(size_t(n) * n, kEmpty), mid(size_t(n) * n, kEmpty);
  std::vector<double> zdepth(size_t(n) * n, -std::numeric_limits<double>::infinity());
  std::vector<uint8_t> near(size_t(n) * n, 0);
  std::vector<uint32_t> ztri(size_t(n) * n, 0);
  std::unordered_map<uint64_t, int> order_cache;
  // A mutation for tests/test_coplanar.cpp: VISMAP_BAND_MUTATION set takes the tie band at the
  // sample (the rule before issue 45), which the random coplanar scenes must catch.
  const bool point_band = std::getenv("VISMAP_BAND_MUTATION") != nullptr;

  // Z-buffer of the screen triangles: closed point-in-triangle exactly; depth interpolated in
  // double; within the tie band the pair's order over its overlap decides (pair_order).
  SourceTriangles st = load_triangles(screen);
  for (size_t t = 0; t < screen.size(); ++t) {
    const HPoint* p = &st.tri[3 * t];
    double x0 = std::min({p[0].x, p[1].x, p[2].x}), x1 = std::max({p[0].x, p[1].x, p[2].x});
    double y0 = std::min({p[0].y, p[1].y, p[2].y}), y1 = std::max({p[0].y, p[1].y, p[2].y});
    for (int k = 0; k < 3; ++k)
      mark_edge(near, n, sx, sy, p[k].x, p[k].y, p[(k + 1) % 3].x, p[(k + 1) % 3].y);
    uint32_t i0, i1, j0, j1;
    if (!range(x0, x1, sx, i0, i1) || !range(y0, y1, sy, j0, j1)) continue;
    // Depth plane from the original vertex order.
    const int32_t* v = &screen.xy[6 * t];
    const double* d = &screen.depth[3 * t];
    double ux = v[2] - v[0], uy = v[3] - v[1], wx = v[4] - v[0], wy = v[5] - v[1];
    double det = ux * wy - uy * wx;
    uint64_t key = source_key(screen.mesh[t], screen.triangle[t]);
    for (uint32_t j = j0; j <= j1; ++j)
      for (uint32_t i = i0; i <= i1; ++i) {
        HPoint s = sample(i, j);
        if (!in_triangle(p, s)) continue;
        double px = s.x - v[0], py = s.y - v[1];
        double b1 = (px * wy - py * wx) / det, b2 = (ux * py - uy * px) / det;
        double depth = d[0] + b1 * (d[1] - d[0]) + b2 * (d[2] - d[0]);
        size_t k = size_t(j) * n + i;
        bool closer;
        // The pair's band is VM_TIE_EPS of the largest |depth| over its overlap, at most
        // `bound` (the largest over both triangles' corners); beyond twice that (room for the
        // rounding of the doubles' overlap) the depths' sign is the pair's order, whatever the
        // sample. Within it, only the pair's order over its overlap decides: the band at the
        // sample alone would let the sample point decide (docs/NUMERICS.md §3).
        double bound = 0;
        if (zid[k] != kEmpty)
          for (int c = 0; c < 3; ++c)
            bound = std::max({bound, std::fabs(d[c]), std::fabs(screen.depth[3 * ztri[k] + c])});
        double band = 2 * VM_TIE_EPS * bound;
        if (point_band)  // (the mutation: the band at the sample, narrower)
          band = VM_TIE_EPS * std::max(std::fabs(depth), std::fabs(zdepth[k]));
        if (zid[k] == kEmpty || std::fabs(depth - zdepth[k]) > band) {
          closer = depth > zdepth[k];
        } else {  // near the tie band: the pair's order over its whole overlap
          uint64_t pk = (uint64_t(t) << 32) | ztri[k];
          auto it = order_cache.find(pk);
          int order = it != order_cache.end() ? it->second
                                              : (order_cache[pk] = pair_order(screen, t, ztri[k]));
          closer = order == 0 ? depth > zdepth[k] : order > 0;
        }
        if (closer) {
          zdepth[k] = depth;
          zid[k] = key;
          ztri[k] = uint32_t(t);
        }
      }
  }

  // The map's ids: closed point-in-convex-polygon, exact. Two sources on one sample: conflict.
  Fragments fr = load_fragments(map, gs, true);
  for (size_t f = 0; f < fr.size(); ++f) {
    const HPoint* p = fr.poly(f);
    size_t m = fr.count(f);
    if (m < 3) continue;
    Box b = bbox(p, m);
    for (size_t k = 0; k < m; ++k)
      mark_edge(near, n, sx, sy, p[k].x, p[k].y, p[(k + 1) % m].x, p[(k + 1) % m].y);
    uint32_t i0, i1, j0, j1;
    if (!range(b.x0, b.x1, sx, i0, i1) || !range(b.y0, b.y1, sy, j0, j1)) continue;
    uint64_t key = source_key(map.mesh[f], map.triangle[f]);
    for (uint32_t j = j0; j <= j1; ++j)
      for (uint32_t i = i0; i <= i1; ++i) {
        HPoint s = sample(i, j);
        bool in = true;
        for (size_t k = 0; k < m && in; ++k) in = orient(p[k], p[(k + 1) % m], s) >= 0;
        if (!in) continue;
        uint64_t& id = mid[size_t(j) * n + i];
        id = (id == kEmpty || id == key) ? key : kConflict;
      }
  }

  for (size_t k = 0; k < zid.size(); ++k) {
    bool diff = zid[k] != mid[k];
    ++r.all_samples;
    r.all_mismatched += diff;
    if (near[k]) continue;
    ++r.samples;
    r.mismatched += diff;
  }
  r.fraction = r.samples ? double(r.mismatched) / r.samples : 0;
  r.all_fraction = r.all_samples ? double(r.all_mismatched) / r.all_samples : 0;
  r.ms = ms_since(t0);
  return r;
}

}  // namespace vismap::check
