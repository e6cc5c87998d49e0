// compare_maps: per source, area(A) + area(B) - 2 area(A ∩ B) over its fragments in the two maps
// (fragments of one source in one map are disjoint, so the sums are the areas of the regions),
// in rationals from the exact vertices; a box filter skips fragment pairs that cannot meet. A
// map whose fragments of one source overlap (a wrong map, which check_planar_map reports as
// overlap_area) has that source's fragments cut into disjoint pieces first: without that a map
// compared with itself differed by twice its self-overlap (issue 45: `cull_differing 1` for
// byte-identical maps).
#include "core/check/map_diff.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <sstream>
#include <utility>
#include <vector>

#include "core/check/exact_geom.h"

namespace vismap::check {

namespace {

using detail::QPoint;

struct Piece {
  std::vector<QPoint> poly;
  double x0, y0, x1, y1;  // box, pixels (rounded vertices)
  double perimeter;       // pixels
};

// Fragments of each source, as rational polygons in grid units.
std::map<std::pair<uint32_t, uint32_t>, std::vector<Piece>> pieces_of(const PlanarMap& m,
                                                                      bool exact) {
  std::map<std::pair<uint32_t, uint32_t>, std::vector<Piece>> out;
  const double g = m.grid_scale ? m.grid_scale : 1.0;
  for (size_t f = 0; f < m.fragment_count(); ++f) {
    Piece p;
    p.x0 = p.y0 = INFINITY;
    p.x1 = p.y1 = -INFINITY;
    p.perimeter = 0;
    for (uint32_t v = m.offsets[f]; v < m.offsets[f + 1]; ++v) {
      const double x = m.xy[2 * v], y = m.xy[2 * v + 1];
      p.x0 = std::min(p.x0, x), p.y0 = std::min(p.y0, y);
      p.x1 = std::max(p.x1, x), p.y1 = std::max(p.y1, y);
      const uint32_t w = v + 1 < m.offsets[f + 1] ? v + 1 : m.offsets[f];
      p.perimeter += std::hypot(m.xy[2 * w] - x, m.xy[2 * w + 1] - y);
      if (exact) {
        p.poly.push_back(detail::to_q(detail::make_point(
            detail::to_i128(m.hx[v]), detail::to_i128(m.hy[v]), detail::to_i128(m.hw[v]))));
      } else {
        QPoint q{mpq_class(x * g), mpq_class(y * g)};  // doubles are exact rationals
        p.poly.push_back(q);
      }
    }
    out[{m.mesh[f], m.triangle[f]}].push_back(std::move(p));
  }
  return out;
}

bool boxes_apart(const Piece& p, const Piece& q) {
  return p.x1 < q.x0 || q.x1 < p.x0 || p.y1 < q.y0 || q.y1 < p.y0;
}

// P less the convex, positively oriented Q, as disjoint convex parts appended to out: the part
// of P outside Q's first edge, then of the rest the part outside its second edge, and so on.
void subtract(const std::vector<QPoint>& P, const std::vector<QPoint>& Q,
              std::vector<std::vector<QPoint>>& out) {
  std::vector<QPoint> rest = P;
  for (size_t i = 0, n = Q.size(); i < n; ++i) {
    const QPoint& a = Q[i];
    const QPoint& b = Q[(i + 1) % n];
    std::vector<QPoint> outside = detail::clip_left(rest, b, a);
    if (outside.size() >= 3 && detail::area2(outside) != 0) out.push_back(std::move(outside));
    rest = detail::clip_left(rest, a, b);
    if (rest.size() < 3 || detail::area2(rest) == 0) return;
  }
}

// One source's fragments as disjoint pieces covering the same region: unchanged unless two
// overlap; then each less the pieces kept before it.
void make_disjoint(std::vector<Piece>& pieces) {
  bool overlap = false;
  for (size_t i = 0; i < pieces.size() && !overlap; ++i)
    for (size_t j = i + 1; j < pieces.size() && !overlap; ++j)
      overlap = !boxes_apart(pieces[i], pieces[j]) &&
                detail::convex_intersection_area2(pieces[i].poly, pieces[j].poly) != 0;
  if (!overlap) return;
  std::vector<Piece> out;
  for (const Piece& p : pieces) {
    std::vector<std::vector<QPoint>> parts{p.poly};
    for (size_t k = 0, before = out.size(); k < before && !parts.empty(); ++k) {
      if (boxes_apart(p, out[k])) continue;
      std::vector<std::vector<QPoint>> next;
      for (const auto& part : parts) subtract(part, out[k].poly, next);
      parts = std::move(next);
    }
    for (auto& part : parts) out.push_back({std::move(part), p.x0, p.y0, p.x1, p.y1, p.perimeter});
  }
  pieces = std::move(out);
}

}  // namespace

std::string MapDiff::summary() const {
  std::ostringstream s;
  s << sources << " sources, " << differing << " differing, xor area " << xor_area << " px^2 of "
    << visible_area << " (" << fragments_a << " against " << fragments_b << " fragments"
    << (exact ? ", exact" : ", rounded vertices") << ")";
  return s.str();
}

MapDiff compare_maps(const PlanarMap& a, const PlanarMap& b) {
  MapDiff d;
  d.exact = !a.hx.empty() && !b.hx.empty() && a.grid_scale == b.grid_scale;
  d.fragments_a = a.fragment_count();
  d.fragments_b = b.fragment_count();
  auto pa = pieces_of(a, d.exact), pb = pieces_of(b, d.exact);
  if (d.exact)  // (rounded vertices overlap within the slack below anyway)
    for (auto* m : {&pa, &pb})
      for (auto& [k, v] : *m) make_disjoint(v);
  const double g = a.grid_scale ? a.grid_scale : 1.0;
  std::map<std::pair<uint32_t, uint32_t>, int> keys;
  for (const auto& [k, v] : pa) keys[k] |= 1;
  for (const auto& [k, v] : pb) keys[k] |= 2;
  static const std::vector<Piece> none;
  for (const auto& [k, which] : keys) {
    ++d.sources;
    const std::vector<Piece>& A = which & 1 ? pa.at(k) : none;
    const std::vector<Piece>& B = which & 2 ? pb.at(k) : none;
    mpq_class x = 0;   // twice the xor area, grid units squared
    double slack = 0;  // pixels squared: what rounding the vertices can move (inexact maps)
    for (const Piece& p : A) x += detail::area2(p.poly), slack += p.perimeter * 0x1p-27;
    for (const Piece& p : B) x += detail::area2(p.poly), slack += p.perimeter * 0x1p-27;
    for (const Piece& p : A)
      for (const Piece& q : B) {
        if (boxes_apart(p, q)) continue;
        x -= 2 * detail::convex_intersection_area2(p.poly, q.poly);
      }
    const double xor_px = std::fabs(x.get_d()) / 2 / (g * g);
    for (const Piece& p : A) d.visible_area += detail::area2(p.poly).get_d() / 2 / (g * g);
    d.xor_area += xor_px;
    if (d.exact ? x != 0 : xor_px > slack) ++d.differing;
  }
  return d;
}

}  // namespace vismap::check
