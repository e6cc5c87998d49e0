// Fewer, larger polygons for the delta frame: merge_source_polygons (core/stream/simplify.h).
#include "core/stream/simplify.h"

#include <algorithm>
#include <cmath>

#include "core/util/flat_map.h"

namespace vismap {

namespace {

constexpr double kFlat = 1e-6;  // px: as core/util/conform.cpp's on-edge distance
constexpr double kSliver = 8;   // px of straight-cornered edge a fan's start may have beside it

using Ring = std::vector<uint32_t>;

// Where corner b turns from a to c: > 0 convex, 0 straight, < 0 reflex (positive orientation, as
// the map's polygons), against the tolerance of kFlat px off the chord a-c.
int turn(const std::vector<double>& xy, uint32_t a, uint32_t b, uint32_t c) {
  const double* p = &xy[2 * size_t(a)];
  const double* q = &xy[2 * size_t(b)];
  const double* r = &xy[2 * size_t(c)];
  const double o = (q[0] - p[0]) * (r[1] - p[1]) - (q[1] - p[1]) * (r[0] - p[0]);
  const double tol = kFlat * std::hypot(r[0] - p[0], r[1] - p[1]);
  return o > tol ? 1 : o < -tol ? -1 : 0;
}

size_t index_of(const Ring& r, uint32_t v) {
  return size_t(std::find(r.begin(), r.end(), v) - r.begin());
}

// A and B (of one source) share the edge u -> v of A (v -> u in B). The union along the whole
// path they share, when it is one convex polygon without a repeated point: into A. (Checked at
// every corner, not only where the two meet: with the zero-length edges a map can have, a
// union convex at those two corners was not convex; tests/test_stream_delta.cpp,
// MergedPolygonsTileTheSameArea, the Cornell box.)
bool try_merge(Ring& A, const Ring& B, uint32_t u, uint32_t v, const std::vector<double>& xy) {
  const size_t na = A.size(), nb = B.size();
  size_t sa = index_of(A, u), sb = index_of(B, u);  // a_0 = u
  size_t ea = (sa + 1) % na, eb = index_of(B, v);   // a_m = v
  if (sa == na || sb == nb || eb == nb || A[ea] != v || (eb + 1) % nb != sb) return false;
  size_t m = 1;
  while (m + 1 < std::min(na, nb) && A[(ea + 1) % na] == B[(eb + nb - 1) % nb])
    ea = (ea + 1) % na, eb = (eb + nb - 1) % nb, ++m;
  while (m + 1 < std::min(na, nb) && A[(sa + na - 1) % na] == B[(sb + 1) % nb])
    sa = (sa + na - 1) % na, sb = (sb + 1) % nb, ++m;
  if (m + 1 >= std::min(na, nb)) return false;
  Ring merged;
  for (size_t k = ea;; k = (k + 1) % na) {  // a_m ... a_0 along A
    merged.push_back(A[k]);
    if (k == sa) break;
  }
  for (size_t k = (sb + 1) % nb; k != eb; k = (k + 1) % nb) merged.push_back(B[k]);
  // No point twice (by position: the map has distinct vertices at one place, the ends of
  // zero-length edges, and polygons of no area around them), and convex at every corner.
  std::vector<std::pair<double, double>> at;
  for (uint32_t w : merged) at.emplace_back(xy[2 * size_t(w)], xy[2 * size_t(w) + 1]);
  std::sort(at.begin(), at.end());
  if (std::adjacent_find(at.begin(), at.end()) != at.end()) return false;
  const size_t n = merged.size();
  std::vector<uint8_t> straight(n);
  for (size_t k = 0; k < n; ++k) {
    const int t = turn(xy, merged[(k + n - 1) % n], merged[k], merged[(k + 1) % n]);
    if (t < 0) return false;
    straight[k] = t == 0;
  }
  // The decoder fans a polygon from one corner (DELTA.md): the fan's triangles along the start
  // corner's two edges are slivers where straight corners lie on them, which rounding folds into
  // hairline cracks as long as those edges (a merged wall of the Cornell box fanned across its
  // T-junctions: 47 dB against the exact raster). So some corner must have at most kSliver px
  // of straight-cornered edge beside it. Measured: 4 px kept the Cornell box's cracks away
  // (61.7 dB) and cost the bunny 2.3 KB a frame of the merge's savings; 8 px the same on the
  // box and most of those bytes back (bunny frames 0-5 at 59.2 dB, compact 59.5); 16 px little
  // more.
  auto len = [&](size_t a, size_t b) {
    return std::hypot(xy[2 * size_t(merged[b])] - xy[2 * size_t(merged[a])],
                      xy[2 * size_t(merged[b]) + 1] - xy[2 * size_t(merged[a]) + 1]);
  };
  bool fan = false;
  for (size_t k = 0; k < n && !fan; ++k) {
    if (straight[k]) continue;
    double sliver = 0;
    for (size_t j = k; straight[(j + 1) % n] && (j + 1) % n != k; j = (j + 1) % n)
      sliver += len(j % n, (j + 1) % n) + len((j + 1) % n, (j + 2) % n);
    for (size_t j = k; straight[(j + n - 1) % n] && (j + n - 1) % n != k; j = (j + n - 1) % n)
      sliver += len(j % n, (j + n - 1) % n) + len((j + n - 1) % n, (j + 2 * n - 2) % n);
    fan = sliver <= kSliver;
  }
  if (!fan) return false;
  A = std::move(merged);
  return true;
}

// Rounds of merges: each round finds the shared edges from a fresh edge map and merges every
// polygon at most once (a merged polygon waits for the next round).
uint64_t merge_rounds(std::vector<Ring>& rings, std::vector<uint8_t>& alive,
                      const std::vector<uint64_t>& source, const std::vector<double>& xy) {
  uint64_t merged = 0;
  for (bool any = true; any;) {
    any = false;
    size_t edges = 0;
    for (size_t p = 0; p < rings.size(); ++p) edges += alive[p] ? rings[p].size() : 0;
    FlatMap edge_of(edges);
    for (size_t p = 0; p < rings.size(); ++p)
      for (size_t k = 0; alive[p] && k < rings[p].size(); ++k)
        edge_of.emplace(uint64_t(rings[p][k]) << 32 | rings[p][(k + 1) % rings[p].size()],
                        uint32_t(p));
    std::vector<uint8_t> touched(rings.size(), 0);
    for (size_t p = 0; p < rings.size(); ++p) {
      for (size_t k = 0; alive[p] && !touched[p] && k < rings[p].size(); ++k) {
        const uint32_t u = rings[p][k], v = rings[p][(k + 1) % rings[p].size()];
        const uint32_t* q = edge_of.find(uint64_t(v) << 32 | u);
        if (!q || *q == p || !alive[*q] || touched[*q] || source[*q] != source[p]) continue;
        if (!try_merge(rings[p], rings[*q], u, v, xy)) continue;
        alive[*q] = 0;
        touched[p] = touched[*q] = 1;
        any = true;
        ++merged;
      }
    }
  }
  return merged;
}

// w lies within kFlat px of the segment from p to q, strictly between its ends.
bool on_segment(const std::vector<double>& xy, uint32_t p, uint32_t q, uint32_t w) {
  const double* a = &xy[2 * size_t(p)];
  const double* b = &xy[2 * size_t(q)];
  const double* c = &xy[2 * size_t(w)];
  const double ex = b[0] - a[0], ey = b[1] - a[1], len = std::hypot(ex, ey);
  if (!(len > 0)) return false;
  const double o = ex * (c[1] - a[1]) - ey * (c[0] - a[0]);
  const double t = ex * (c[0] - a[0]) + ey * (c[1] - a[1]);
  return std::abs(o) <= kFlat * len && t > 0 && t < len * len;
}

// Drops the vertices that at most two polygons have and that lie, in each of them, on the
// segment between the nearest corners kept on either side. Decided for a vertex in every polygon
// that has it (so both sides of an edge drop the same ones), by rounds: a run of candidates
// that does not lie on its ends' segment is kept, which changes the runs around it. (Judged by
// each vertex's own neighbours instead, a cluster of points a thousandth of a pixel apart at a
// corner looked flat point by point, and dropping them all cut the corner off: the Cornell box.)
uint64_t drop_flat_vertices(std::vector<Ring>& rings, const std::vector<uint8_t>& alive,
                            size_t vertex_count, const std::vector<double>& xy,
                            std::vector<uint8_t>& changed) {
  std::vector<uint8_t> uses(vertex_count, 0), drop(vertex_count, 0);
  for (size_t p = 0; p < rings.size(); ++p)
    for (uint32_t w : alive[p] ? rings[p] : Ring{}) uses[w] = uint8_t(std::min(3, uses[w] + 1));
  for (size_t w = 0; w < vertex_count; ++w) drop[w] = uses[w] >= 1 && uses[w] <= 2;
  for (bool again = true; again;) {
    again = false;
    for (size_t p = 0; p < rings.size(); ++p) {
      const Ring& r = rings[p];
      const size_t n = r.size();
      size_t kept = 0, first = n;
      for (size_t k = 0; k < n; ++k)
        if (!drop[r[k]]) ++kept, first = first == n ? k : first;
      if (!alive[p] || kept == n) continue;
      if (kept < 3) {  // it would collapse: it keeps its vertices
        for (uint32_t w : r) again |= drop[w], drop[w] = 0;
        continue;
      }
      for (size_t k = 1, from = first; k <= n; ++k) {  // r[from], r[i]: kept, candidates between
        const size_t i = (first + k) % n;
        if (drop[r[i]]) continue;
        bool on = true;
        for (size_t j = (from + 1) % n; j != i; j = (j + 1) % n)
          on = on && on_segment(xy, r[from], r[i], r[j]);
        for (size_t j = (from + 1) % n; !on && j != i; j = (j + 1) % n)
          drop[r[j]] = 0, again = true;
        from = i;
      }
    }
  }
  uint64_t dropped = 0;
  for (size_t p = 0; p < rings.size(); ++p) {
    Ring kept;
    for (uint32_t w : alive[p] ? rings[p] : Ring{})
      if (!drop[w]) kept.push_back(w);
    if (!alive[p] || kept.size() == rings[p].size()) continue;
    dropped += rings[p].size() - kept.size();
    rings[p] = std::move(kept);
    changed[p] = 1;
  }
  return dropped;
}

}  // namespace

SimplifyStats merge_source_polygons(ConformedPolygons& P, const std::vector<uint64_t>& source) {
  std::vector<Ring> rings(P.size());
  for (size_t p = 0; p < P.size(); ++p)
    rings[p].assign(P.v.begin() + P.off[p], P.v.begin() + P.off[p + 1]);
  std::vector<uint8_t> alive(P.size(), 1);
  SimplifyStats st;
  std::vector<Ring> before = rings;
  st.merged = merge_rounds(rings, alive, source, P.xy);
  std::vector<uint8_t> changed(P.size(), 0);
  for (size_t p = 0; p < P.size(); ++p) changed[p] = alive[p] && rings[p] != before[p];
  st.dropped = drop_flat_vertices(rings, alive, P.xy.size() / 2, P.xy, changed);
  if (!st.merged && !st.dropped) return st;

  ConformedPolygons out;
  out.xy = std::move(P.xy);
  out.t_junctions = P.t_junctions;
  for (size_t p = 0; p < P.size(); ++p) {
    if (!alive[p]) continue;
    out.v.insert(out.v.end(), rings[p].begin(), rings[p].end());
    out.off.push_back(uint32_t(out.v.size()));
    out.fragment.push_back(P.fragment[p]);
    out.original.push_back(changed[p] ? uint32_t(rings[p].size()) : P.original[p]);
  }
  P = std::move(out);
  return st;
}

}  // namespace vismap
