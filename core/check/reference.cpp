// The CGAL translation unit of the checkers (slow to compile; keep CGAL code here): the union
// of the screen triangles, the exact reference visibility (DESIGN §4) and the comparison of a
// planar map with it. Exact kernel with Boolean set operations throughout.
#include <CGAL/Boolean_set_operations_2.h>
#include <CGAL/Exact_predicates_exact_constructions_kernel.h>
#include <CGAL/Polygon_set_2.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <map>
#include <sstream>
#include <stdexcept>

#include "core/check/exact_geom.h"
#include "core/check/planar_check.h"
#include "core/util/clock.h"
#include "kernels/layout.h"

namespace vismap::check {

namespace {

using K = CGAL::Exact_predicates_exact_constructions_kernel;
using FT = K::FT;
using Point = K::Point_2;
using Poly = CGAL::Polygon_2<K>;
using PolyH = CGAL::Polygon_with_holes_2<K>;
using PSet = CGAL::Polygon_set_2<K>;
uint64_t source_key(uint32_t mesh, uint32_t tri) {
  return (uint64_t(mesh) << 32) | tri;
}

mpq_class to_mpq(const FT& v) {
  std::ostringstream os;
  os << CGAL::exact(v);
  mpq_class q(os.str());
  q.canonicalize();
  return q;
}

// Exactly, from 32-bit pieces (each an exact double).
FT to_ft(detail::i128 v) {
  bool neg = v < 0;
  unsigned __int128 m =
      neg ? -static_cast<unsigned __int128>(v) : static_cast<unsigned __int128>(v);
  FT r = 0;
  for (int k = 3; k >= 0; --k) r = r * FT(4294967296.0) + FT(double(uint32_t(m >> (32 * k))));
  return neg ? -r : r;
}

// A sum of many lazy exact numbers. `s += x` over K::FT builds a chain of lazy additions that
// the first exact evaluation walks by recursion, two stack frames a term: the sums over the
// bunny's ~40,000 visible sources overflowed the 8 MiB stack (`vismap check data/bunny.ply`,
// SIGSEGV after 110 s; issue 35). Asking for the exact value every 256 terms prunes the chain
// (CGAL's update_exact drops a node's operands once its exact value is known).
class ExactSum {
 public:
  ExactSum& operator+=(const FT& x) {
    s_ += x;
    if (++n_ % 256 == 0) CGAL::exact(s_);
    return *this;
  }
  const FT& value() const { return s_; }

 private:
  FT s_ = 0;
  uint32_t n_ = 0;
};

// Polygon_2::area, as one ExactSum over the edges (a union's boundary has thousands).
FT polygon_area(const Poly& p) {
  ExactSum s;
  for (size_t i = 0, n = p.size(); i < n; ++i) {
    const Point &a = p[i], &b = p[(i + 1) % n];
    s += a.x() * b.y() - b.x() * a.y();
  }
  return s.value() / 2;
}

FT area(const std::vector<PolyH>& parts) {
  ExactSum a;
  for (const PolyH& p : parts) {
    a += polygon_area(p.outer_boundary());
    for (auto h = p.holes_begin(); h != p.holes_end(); ++h)
      a += polygon_area(*h);  // holes are clockwise
  }
  return a.value();
}

FT area(const PSet& s) {
  std::vector<PolyH> parts;
  s.polygons_with_holes(std::back_inserter(parts));
  return area(parts);
}

Poly screen_triangle(const ScreenTriangles& s, size_t t) {
  Poly p;
  for (int k = 0; k < 3; ++k) p.push_back(Point(s.xy[6 * t + 2 * k], s.xy[6 * t + 2 * k + 1]));
  if (p.orientation() == CGAL::CLOCKWISE) p.reverse_orientation();
  return p;
}

// Depth as an affine function a·x + b·y + c of grid coordinates, exactly from the doubles.
struct Plane {
  FT a, b, c;
};
Plane depth_plane(const ScreenTriangles& s, size_t t) {
  const int32_t* v = &s.xy[6 * t];
  const double* d = &s.depth[3 * t];
  FT ux = v[2] - v[0], uy = v[3] - v[1], wx = v[4] - v[0], wy = v[5] - v[1];
  FT d1 = FT(d[1]) - FT(d[0]), d2 = FT(d[2]) - FT(d[0]);
  FT det = ux * wy - uy * wx;  // non-zero: zero-area triangles are not in the input
  Plane p;
  p.a = (d1 * wy - d2 * uy) / det;
  p.b = (ux * d2 - wx * d1) / det;
  p.c = FT(d[0]) - p.a * v[0] - p.b * v[1];
  return p;
}

// The part of triangle `tri` where a·x + b·y + c > 0 (as a closed polygon; (a, b) != 0).
Poly clip_halfplane(const Poly& tri, const FT& a, const FT& b, const FT& c) {
  Poly out;
  size_t n = tri.size();
  std::vector<FT> s(n);
  for (size_t i = 0; i < n; ++i) s[i] = a * tri[i].x() + b * tri[i].y() + c;
  for (size_t i = 0; i < n; ++i) {
    size_t j = (i + 1) % n;
    CGAL::Sign si = CGAL::sign(s[i]), sj = CGAL::sign(s[j]);
    if (si != CGAL::NEGATIVE) out.push_back(tri[i]);
    if ((si == CGAL::POSITIVE && sj == CGAL::NEGATIVE) ||
        (si == CGAL::NEGATIVE && sj == CGAL::POSITIVE)) {
      FT t = s[i] / (s[i] - s[j]);
      out.push_back(Point(tri[i].x() + t * (tri[j].x() - tri[i].x()),
                          tri[i].y() + t * (tri[j].y() - tri[i].y())));
    }
  }
  return out;
}

uint32_t morton(uint32_t x, uint32_t y) {
  auto spread = [](uint32_t v) {
    v &= 0xffff;
    v = (v | (v << 8)) & 0x00ff00ff;
    v = (v | (v << 4)) & 0x0f0f0f0f;
    v = (v | (v << 2)) & 0x33333333;
    return (v | (v << 1)) & 0x55555555;
  };
  return spread(x) | (spread(y) << 1);
}

}  // namespace

namespace detail {

mpq_class union_area2(const ScreenTriangles& screen) {
  size_t n = screen.size();
  if (n == 0) return 0;
  // Join in Morton order of the centroids so partial unions stay compact.
  int64_t x0 = INT64_MAX, y0 = INT64_MAX, x1 = INT64_MIN, y1 = INT64_MIN;
  for (size_t i = 0; i < screen.xy.size(); i += 2) {
    x0 = std::min<int64_t>(x0, screen.xy[i]), x1 = std::max<int64_t>(x1, screen.xy[i]);
    y0 = std::min<int64_t>(y0, screen.xy[i + 1]), y1 = std::max<int64_t>(y1, screen.xy[i + 1]);
  }
  double scale = 65535.0 / std::max<int64_t>(1, std::max(x1 - x0, y1 - y0));
  std::vector<std::pair<uint32_t, uint32_t>> order(n);
  for (size_t t = 0; t < n; ++t) {
    const int32_t* v = &screen.xy[6 * t];
    double cx = (double(v[0]) + v[2] + v[4]) / 3 - x0, cy = (double(v[1]) + v[3] + v[5]) / 3 - y0;
    order[t] = {morton(uint32_t(cx * scale), uint32_t(cy * scale)), uint32_t(t)};
  }
  std::sort(order.begin(), order.end());
  std::vector<Poly> tris;
  tris.reserve(n);
  for (auto& o : order) tris.push_back(screen_triangle(screen, o.second));
  std::vector<PolyH> parts;
  CGAL::join(tris.begin(), tris.end(), std::back_inserter(parts));
  return to_mpq(area(parts)) * 2;
}

}  // namespace detail

struct ReferenceResult::Impl {
  uint32_t gs = 1;
  std::vector<PSet> visible;  // per screen triangle, grid units
  PSet bands;                 // the snap bands of the crossing pairs, grid units
  PSet tie_cycles;            // covered, but visible in no triangle (exact_visibility)
};

namespace {

// The pipeline rounds a crossing line to integers (crossings.cl pair_relation): along the axis u
// on which the true line's slope m is <= 1, the line n v + p u + c = 0 with n >= 2^23 - 255,
// p = round(m n), and c = round(the exact c at the overlap's rounded centre column uc). So at
// every u of the overlap its v is within |c - c_exact| / n + |p / n - m| |u - uc|
// <= (1 + h) / (2 n) of the true line's, h = the overlap's half-span in u plus 1.5 (uc is
// rounded, and the kernel adds 1). The kernel forms the true line in doubles from the double
// depth planes; `fp` bounds that: a few roundings of 2^-53 on each term of
// d = A x + B y + C, i.e. 2^-44 ((|A| + |B|) (|x| + |y|) + |C|) summed over both planes, with
// |x| + |y| the largest over both triangles' vertices, divided by |Q| (v's coefficient) to give
// v units. The band is the part of the overlap within that
// many v units of the exact line: outside every band the map must be exactly right
// (docs/NUMERICS.md §2), inside one a cell may lie wholly on the wrong side of the true line.
Poly snap_band(const Poly& overlap, const Poly& to, const Poly& tt, const Plane& po,
               const Plane& pt, double* half_width) {
  FT a = po.a - pt.a, b = po.b - pt.b, c = po.c - pt.c;
  bool along_x = CGAL::abs(b) >= CGAL::abs(a);
  FT q = CGAL::abs(along_x ? b : a);
  double umin = INFINITY, umax = -INFINITY, xy = 0;
  for (size_t i = 0; i < overlap.size(); ++i) {
    double u = CGAL::to_double(along_x ? overlap[i].x() : overlap[i].y());
    umin = std::min(umin, u), umax = std::max(umax, u);
  }
  for (const Poly* p : {&to, &tt})
    for (size_t i = 0; i < p->size(); ++i)
      xy = std::max(
          xy, std::abs(CGAL::to_double((*p)[i].x())) + std::abs(CGAL::to_double((*p)[i].y())));
  const double n_min = double((1 << 23) - 255);
  double h = (umax - umin) / 2 + 1.5;
  double scale = 0;
  for (const Plane* p : {&po, &pt})
    scale += (std::abs(CGAL::to_double(p->a)) + std::abs(CGAL::to_double(p->b))) * xy +
             std::abs(CGAL::to_double(p->c));
  double fp = std::ldexp(scale, -44) / CGAL::to_double(q);
  double e = (1 + h) / (2 * n_min) + fp;
  *half_width = e;
  FT w = FT(e) * q;
  Poly band = clip_halfplane(overlap, a, b, c + w);
  if (band.size() >= 3) band = clip_halfplane(band, -a, -b, w - c);
  return band;
}

// Is the pipeline's crossing line of t and o exact? When both depth planes were snapped to
// integers over the same 2^k (transform.cl snap_depth_planes), crossings.cl pair_relation takes
// their difference as the line: no snap band.
bool exact_line(const ScreenTriangles& screen, size_t t, size_t o) {
  if (screen.plane_k.size() != screen.size()) return false;
  return screen.plane_k[t] != ScreenTriangles::kFreePlane && screen.plane_k[t] == screen.plane_k[o];
}

}  // namespace

ReferenceResult exact_visibility(const ScreenTriangles& screen) {
  auto t0 = Clock::now();
  auto impl = std::make_shared<ReferenceResult::Impl>();
  impl->gs = screen.grid_scale ? screen.grid_scale : 1;
  size_t n = screen.size();
  std::vector<Poly> tri(n);
  std::vector<Plane> plane(n);
  std::vector<std::array<int32_t, 4>> box(n);
  for (size_t t = 0; t < n; ++t) {
    tri[t] = screen_triangle(screen, t);
    plane[t] = depth_plane(screen, t);
    const int32_t* v = &screen.xy[6 * t];
    box[t] = {std::min({v[0], v[2], v[4]}), std::min({v[1], v[3], v[5]}),
              std::max({v[0], v[2], v[4]}), std::max({v[1], v[3], v[5]})};
  }
  // Bounding-box filter: sweep over x.
  std::vector<uint32_t> by_x(n);
  for (size_t t = 0; t < n; ++t) by_x[t] = uint32_t(t);
  std::sort(by_x.begin(), by_x.end(),
            [&](uint32_t a, uint32_t b) { return box[a][0] < box[b][0]; });

  ReferenceResult r;
  std::vector<Poly> bands;
  r.visible_area.resize(n);
  impl->visible.resize(n);
  ExactSum total;
  for (size_t t = 0; t < n; ++t) {
    uint64_t kt = source_key(screen.mesh[t], screen.triangle[t]);
    std::vector<Poly> occluders;
    for (uint32_t o : by_x) {
      if (box[o][0] >= box[t][2]) break;
      if (o == t || box[o][2] <= box[t][0] || box[o][1] >= box[t][3] || box[o][3] <= box[t][1])
        continue;
      FT a = plane[o].a - plane[t].a, b = plane[o].b - plane[t].b, c = plane[o].c - plane[t].c;
      uint64_t ko = source_key(screen.mesh[o], screen.triangle[o]);
      // The tie rule (DESIGN §3), pair by pair as the pipeline applies it: over the overlap R of
      // the two footprints, d = depth_o - depth_t. If d leaves the relative band
      // VM_TIE_EPS * |depth| on both sides, the planes cross and the order switches along d = 0;
      // if only on one side, that side's order holds over all of R; if nowhere, the lower
      // (mesh, triangle) is in front over all of R.
      Poly overlap = tri[o];
      for (size_t e = 0; e < 3 && overlap.size() >= 3; ++e) {
        const Point& p0 = tri[t][e];
        const Point& p1 = tri[t][(e + 1) % 3];
        FT ea = -(p1.y() - p0.y()), eb = p1.x() - p0.x();
        overlap = clip_halfplane(overlap, ea, eb, -(ea * p0.x() + eb * p0.y()));
      }
      if (overlap.size() < 3 || CGAL::is_zero(overlap.area())) continue;
      FT dmin = 0, dmax = 0, band = 0;
      for (size_t i = 0; i < overlap.size(); ++i) {
        const Point& v = overlap[i];
        FT qo = plane[o].a * v.x() + plane[o].b * v.y() + plane[o].c;
        FT qt = plane[t].a * v.x() + plane[t].b * v.y() + plane[t].c;
        FT d = qo - qt;
        if (i == 0 || d < dmin) dmin = d;
        if (i == 0 || d > dmax) dmax = d;
        band = std::max(band, FT(VM_TIE_EPS) * std::max(CGAL::abs(qo), CGAL::abs(qt)));
      }
      bool crossing = dmax > band && dmin < -band;
      if (!crossing) {
        bool o_front = dmax > band ? true : dmin < -band ? false : ko < kt;
        if (o_front) occluders.push_back(tri[o]);
        continue;
      }
      Poly part = clip_halfplane(tri[o], a, b, c);
      if (part.size() >= 3 && part.is_simple() && !CGAL::is_zero(part.area()))
        occluders.push_back(part);
      if (t < o) ++r.crossing_pairs;
      if (t < o && !exact_line(screen, t, o)) {
        ++r.rounded_crossing_pairs;
        double e = 0;
        Poly band = snap_band(overlap, tri[o], tri[t], plane[o], plane[t], &e);
        r.snap_band = std::max(r.snap_band, e / impl->gs);
        if (band.size() >= 3 && band.is_simple() && !CGAL::is_zero(band.area())) {
          if (band.orientation() == CGAL::CLOCKWISE) band.reverse_orientation();
          bands.push_back(std::move(band));
        }
      }
    }
    PSet vis(tri[t]);
    if (!occluders.empty()) {
      PSet occ;
      occ.join(occluders.begin(), occluders.end());
      vis.difference(occ);
    }
    FT a = area(vis);
    total += a;
    r.visible_area[t] = CGAL::to_double(a) / (double(impl->gs) * impl->gs);
    impl->visible[t] = std::move(vis);
  }
  r.total_visible_area = CGAL::to_double(total.value()) / (double(impl->gs) * impl->gs);
  if (!bands.empty()) impl->bands.join(bands.begin(), bands.end());
  // Tie cycles. The pairwise definition above can leave a covered point visible in no triangle:
  // only through the tie rule, when a pair ordered by one side of the band over its whole
  // overlap (exactly in front of each other by less than the band somewhere) and crossings
  // with a third surface at that place make the order at a point cyclic. There the definition
  // has no answer (the pipeline's tournament picks one, occlusion.cl wins_cycle); such regions
  // are reported and left out of what must be exact (docs/NUMERICS.md §3).
  if (n > 0) {
    PSet covered;
    covered.join(tri.begin(), tri.end());
    std::vector<PolyH> parts;
    for (const PSet& v : impl->visible) v.polygons_with_holes(std::back_inserter(parts));
    PSet seen;
    seen.join(parts.begin(), parts.end());
    covered.difference(seen);
    r.tie_cycle_area = CGAL::to_double(area(covered)) / (double(impl->gs) * impl->gs);
    impl->tie_cycles = std::move(covered);
  }
  r.impl = impl;
  r.ms = ms_since(t0);
  return r;
}

ReferenceReport compare_with_reference(const PlanarMap& map, const ScreenTriangles& screen,
                                       const ReferenceResult& reference) {
  auto t0 = Clock::now();
  if (!reference.impl) throw std::invalid_argument("compare_with_reference: empty reference");
  const ReferenceResult::Impl& ref = *reference.impl;
  ReferenceReport r;
  size_t nv = map.vertex_count();
  r.exact = map.hx.size() == nv && map.hy.size() == nv && map.hw.size() == nv && nv > 0;
  uint32_t gs = ref.gs;
  if (map.grid_scale && map.grid_scale != gs)
    throw std::invalid_argument(
        "compare_with_reference: map and screen triangles differ in grid_scale");

  // visible(source): union of its screen triangles' visible regions.
  std::map<uint64_t, PSet> visible;
  for (size_t t = 0; t < screen.size(); ++t)
    visible[source_key(screen.mesh[t], screen.triangle[t])].join(ref.visible[t]);

  std::map<uint64_t, PSet> output;
  ExactSum total_visible_sum, xor_area_sum, xor_outside_sum;
  // The area of a region that no snap band (and no tie cycle) explains.
  auto outside_bands = [&](PSet x) {
    if (!ref.bands.is_empty()) x.difference(ref.bands);
    if (!ref.tie_cycles.is_empty()) x.difference(ref.tie_cycles);
    return area(x);
  };
  r.fragments = map.fragment_count();
  for (size_t f = 0; f < map.fragment_count(); ++f) {
    Poly p;
    for (uint32_t v = map.offsets[f]; v < map.offsets[f + 1]; ++v) {
      Point q;
      if (r.exact) {
        FT w = to_ft(detail::to_i128(map.hw[v]));
        q = Point(to_ft(detail::to_i128(map.hx[v])) / w, to_ft(detail::to_i128(map.hy[v])) / w);
      } else {
        q = Point(FT(map.xy[2 * v]) * FT(int(gs)), FT(map.xy[2 * v + 1]) * FT(int(gs)));
      }
      if (p.size() > 0 && (p.vertices_end() - 1)->x() == q.x() &&
          (p.vertices_end() - 1)->y() == q.y())
        continue;
      p.push_back(q);
    }
    while (p.size() > 1 && p[0] == p[p.size() - 1]) p.erase(p.vertices_end() - 1);
    if (p.size() < 3 || !p.is_simple() || CGAL::is_zero(p.area()))
      continue;  // check_planar_map counts these
    if (p.orientation() == CGAL::CLOCKWISE) p.reverse_orientation();
    uint64_t key = source_key(map.mesh[f], map.triangle[f]);
    output[key].join(p);
    FT a = p.area(), inside = 0;
    auto it = visible.find(key);
    if (it != visible.end()) {
      PSet part(p);
      part.intersection(it->second);
      inside = area(part);
    }
    // What lies outside visible(src), less the tie cycles where the definition has no answer.
    FT out = a - inside;
    PSet wrong;
    if (CGAL::is_positive(out)) {
      wrong = PSet(p);
      if (it != visible.end()) wrong.difference(it->second);
      if (!ref.tie_cycles.is_empty()) {
        wrong.difference(ref.tie_cycles);
        out = area(wrong);
      }
    }
    if (out > a / 2) ++r.wrong_source;
    if (r.exact ? CGAL::is_positive(out) : out > a * 1e-9) ++r.partly_outside;
    // Is what is left all inside snap bands?
    if (CGAL::is_positive(out) && CGAL::is_positive(outside_bands(std::move(wrong))))
      ++r.wrong_outside_band;
  }
  for (auto& [key, vis] : visible) {
    total_visible_sum += area(vis);
    auto it = output.find(key);
    if (it == output.end()) {
      xor_area_sum += area(vis);
      xor_outside_sum += outside_bands(vis);
      continue;
    }
    PSet x = it->second;
    x.symmetric_difference(vis);
    FT xa = area(x);
    xor_area_sum += xa;
    if (CGAL::is_positive(xa)) xor_outside_sum += outside_bands(std::move(x));
  }
  for (auto& [key, out] : output)
    if (!visible.count(key)) {
      xor_area_sum += area(out);
      xor_outside_sum += outside_bands(out);
    }

  const FT total_visible = total_visible_sum.value(), xor_area = xor_area_sum.value(),
           xor_outside = xor_outside_sum.value();
  double g2 = double(gs) * gs;
  r.total_visible_area = CGAL::to_double(total_visible) / g2;
  r.xor_area = CGAL::to_double(xor_area) / g2;
  r.area_error = CGAL::is_zero(total_visible) ? (CGAL::is_zero(xor_area) ? 0 : INFINITY)
                                              : CGAL::to_double(xor_area / total_visible);
  r.area_error_outside_band = CGAL::is_zero(total_visible)
                                  ? (CGAL::is_zero(xor_outside) ? 0 : INFINITY)
                                  : CGAL::to_double(xor_outside / total_visible);
  r.snap_band = reference.snap_band;
  r.ms = ms_since(t0);
  return r;
}

}  // namespace vismap::check
