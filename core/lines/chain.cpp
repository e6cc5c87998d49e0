// Chaining and simplifying classified map edges into polylines (chain.h).
#include "core/lines/chain.h"

#include <algorithm>
#include <cmath>

namespace vismap::lines_detail {

namespace {

// Douglas-Peucker on pts[i0..i1] (indices into xy), keeping both ends; appends kept interior
// points in order to `keep`.
void simplify(const std::vector<double>& xy, const std::vector<uint32_t>& pts, size_t i0, size_t i1,
              double tol, std::vector<uint32_t>& keep) {
  if (i1 <= i0 + 1) return;
  const double ax = xy[2 * pts[i0]], ay = xy[2 * pts[i0] + 1];
  const double dx = xy[2 * pts[i1]] - ax, dy = xy[2 * pts[i1] + 1] - ay;
  const double len = std::hypot(dx, dy);
  double worst = -1;
  size_t at = i0;
  for (size_t i = i0 + 1; i < i1; ++i) {
    const double ux = xy[2 * pts[i]] - ax, uy = xy[2 * pts[i] + 1] - ay;
    const double d = len > 0 ? std::abs(dx * uy - dy * ux) / len : std::hypot(ux, uy);
    if (d > worst) worst = d, at = i;
  }
  if (worst <= tol) return;
  simplify(xy, pts, i0, at, tol, keep);
  keep.push_back(pts[at]);
  simplify(xy, pts, at, i1, tol, keep);
}

}  // namespace

void chain(const std::vector<double>& xy, const std::vector<Seg>& S, LineKind kind, bool hidden,
           double simplify_px, double min_length_px, LineSet& out) {
  if (S.empty()) return;
  const size_t nv = xy.size() / 2;
  std::vector<uint32_t> start(nv + 1, 0), inc(2 * S.size()), pts, keep;
  for (const Seg& s : S) ++start[s.a + 1], ++start[s.b + 1];
  for (size_t v = 0; v < nv; ++v) start[v + 1] += start[v];
  {
    std::vector<uint32_t> fill(start.begin(), start.end() - 1);
    for (uint32_t i = 0; i < S.size(); ++i) inc[fill[S[i].a]++] = i, inc[fill[S[i].b]++] = i;
  }
  std::vector<uint8_t> used(S.size(), 0);
  auto degree = [&](uint32_t v) { return start[v + 1] - start[v]; };
  // Where more than two meet, a chain goes on through the straightest pair (turning by less
  // than 30 degrees), pairs taken straightest first: a T-junction's through line stays one
  // chain and its stem ends there. partner[r]: the segment incidence r continues into.
  std::vector<uint32_t> partner(inc.size(), ~0u);
  {
    std::vector<std::tuple<double, uint32_t, uint32_t>> pairs;
    std::vector<std::array<double, 2>> dir;
    for (uint32_t v = 0; v < nv; ++v) {
      const uint32_t d = degree(v);
      if (d == 2) {
        partner[start[v]] = inc[start[v] + 1];
        partner[start[v] + 1] = inc[start[v]];
      }
      if (d < 3) continue;
      dir.clear();
      for (uint32_t r = start[v]; r < start[v + 1]; ++r) {
        const Seg& g = S[inc[r]];
        const uint32_t w = g.a == v ? g.b : g.a;
        const double dx = xy[2 * w] - xy[2 * v], dy = xy[2 * w + 1] - xy[2 * v + 1];
        const double l = std::hypot(dx, dy);
        dir.push_back({l > 0 ? dx / l : 0, l > 0 ? dy / l : 0});
      }
      pairs.clear();
      for (uint32_t i = 0; i < d; ++i)
        for (uint32_t j = i + 1; j < d; ++j) {
          const double c = dir[i][0] * dir[j][0] + dir[i][1] * dir[j][1];
          if (c < -0.866) pairs.emplace_back(c, i, j);
        }
      std::sort(pairs.begin(), pairs.end());
      for (const auto& [c, i, j] : pairs) {
        if (partner[start[v] + i] != ~0u || partner[start[v] + j] != ~0u) continue;
        partner[start[v] + i] = inc[start[v] + j];
        partner[start[v] + j] = inc[start[v] + i];
      }
    }
  }
  auto emit = [&](bool closed) {
    if (min_length_px > 0) {  // selection: shorter chains are dropped, counted
      double len = 0;
      for (size_t i = 0; i + 1 < pts.size() + closed; ++i) {
        const uint32_t u = pts[i], v = pts[(i + 1) % pts.size()];
        len += std::hypot(xy[2 * v] - xy[2 * u], xy[2 * v + 1] - xy[2 * u + 1]);
      }
      if (len < min_length_px) {
        ++out.short_chains[size_t(kind)];
        return;
      }
    }
    if (simplify_px > 0 && pts.size() > 2) {
      keep.clear();
      keep.push_back(pts.front());
      if (closed) {  // split at the point farthest from the first: two open halves
        size_t split = 1;
        double far = -1;
        for (size_t i = 1; i < pts.size(); ++i) {
          const double d =
              std::hypot(xy[2 * pts[i]] - xy[2 * pts[0]], xy[2 * pts[i] + 1] - xy[2 * pts[0] + 1]);
          if (d > far) far = d, split = i;
        }
        pts.push_back(pts.front());
        simplify(xy, pts, 0, split, simplify_px, keep);
        keep.push_back(pts[split]);
        simplify(xy, pts, split, pts.size() - 1, simplify_px, keep);
      } else {
        simplify(xy, pts, 0, pts.size() - 1, simplify_px, keep);
        keep.push_back(pts.back());
      }
      pts.swap(keep);
    }
    for (uint32_t v : pts) out.xy.push_back(xy[2 * v]), out.xy.push_back(xy[2 * v + 1]);
    out.off.push_back(uint32_t(out.xy.size() / 2));
    out.kind.push_back(kind);
    out.closed.push_back(closed);
    out.hidden.push_back(hidden);
  };
  // Walks from v along segment i until a chain end (or back to the start: closed).
  auto walk = [&](uint32_t v, uint32_t i) {
    pts.clear();
    pts.push_back(v);
    const uint32_t first = v;
    for (;;) {
      used[i] = 1;
      v = S[i].a == v ? S[i].b : S[i].a;
      if (v == first) return true;  // closed
      pts.push_back(v);
      uint32_t r = start[v];
      while (inc[r] != i) ++r;
      const uint32_t j = partner[r];
      if (j == ~0u || used[j]) return false;
      i = j;
    }
  };
  for (uint32_t v = 0; v < nv; ++v)  // chains with an end first, from their ends
    for (uint32_t r = start[v]; r < start[v + 1]; ++r)
      if (partner[r] == ~0u && !used[inc[r]]) emit(walk(v, inc[r]));
  for (uint32_t i = 0; i < S.size(); ++i)
    if (!used[i]) emit(walk(S[i].a, i));
}

}  // namespace vismap::lines_detail
