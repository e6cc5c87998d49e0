// conform_to_grid (core/util/conform.h): T-junctions inserted, vertices rounded to the grid once,
// fragments triangulated through every boundary vertex.
#include "core/util/conform.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "core/error.h"
#include "core/util/flat_map.h"
#include "core/util/weld.h"

namespace vismap {

namespace {

constexpr double kCell = 4.0;  // pixels per cell of the candidate grid

[[noreturn]] void bad(const char* what, size_t f) {
  throw InputError(InputErrorKind::ParseError, "compact writer", "", "fragment", int64_t(f), what);
}

ConformedPolygons merge_equal(const PlanarMap& map, uint32_t quantum) {
  ConformedPolygons P;
  Weld<double, 2> at(map.vertex_count());
  const double lim = double(1 << 23) / quantum;
  for (size_t f = 0; f < map.fragment_count(); ++f) {
    const size_t start = P.v.size();
    for (uint32_t k = map.offsets[f]; k < map.offsets[f + 1]; ++k) {
      const double x = map.xy[2 * k], y = map.xy[2 * k + 1];
      if (!(std::abs(x) < lim && std::abs(y) < lim)) bad("vertex outside the grid's range", f);
      auto [id, fresh] = at.add(&map.xy[2 * k], uint32_t(P.xy.size() / 2));
      if (fresh) {
        P.xy.push_back(x);
        P.xy.push_back(y);
      }
      if (P.v.size() == start || P.v.back() != id) P.v.push_back(id);
    }
    while (P.v.size() > start + 1 && P.v.back() == P.v[start]) P.v.pop_back();
    if (P.v.size() - start < 3) {
      P.v.resize(start);
      continue;
    }
    P.off.push_back(uint32_t(P.v.size()));
    P.fragment.push_back(uint32_t(f));
  }
  return P;
}

// Inserts every vertex that lies inside an edge into that edge. Only edges without a twin
// (the reverse edge in a neighbour) can hold one, and only the ends of such edges can be one.
uint64_t insert_into_edges(ConformedPolygons& P, double width, double height) {
  const size_t np = P.fragment.size();
  auto key = [](uint32_t a, uint32_t b) { return uint64_t(a) << 32 | b; };
  FlatMap edges(P.v.size());
  for (size_t p = 0; p < np; ++p)
    for (uint32_t i = P.off[p], n = P.off[p + 1]; i < n; ++i)
      edges.emplace(key(P.v[i], P.v[i + 1 < n ? i + 1 : P.off[p]]), 0);
  std::vector<uint8_t> open(P.v.size(), 0);  // per polygon edge (by its first corner)
  std::vector<uint32_t> ends;
  for (size_t p = 0; p < np; ++p)
    for (uint32_t i = P.off[p], n = P.off[p + 1]; i < n; ++i) {
      const uint32_t a = P.v[i], b = P.v[i + 1 < n ? i + 1 : P.off[p]];
      if (edges.find(key(b, a))) continue;
      open[i] = 1;
      ends.push_back(a);
      ends.push_back(b);
    }
  if (ends.empty()) return 0;
  std::sort(ends.begin(), ends.end());
  ends.erase(std::unique(ends.begin(), ends.end()), ends.end());

  // The open edges' ends in a grid of kCell-pixel cells (CSR).
  const int gw = std::max(1, int(std::ceil(width / kCell)) + 1);
  const int gh = std::max(1, int(std::ceil(height / kCell)) + 1);
  auto cell_of = [&](double x, double y) {
    const int cx = std::clamp(int(std::floor(x / kCell)), 0, gw - 1);
    const int cy = std::clamp(int(std::floor(y / kCell)), 0, gh - 1);
    return cy * gw + cx;
  };
  std::vector<uint32_t> start(size_t(gw) * gh + 1, 0), in(ends.size());
  for (uint32_t v : ends) ++start[cell_of(P.xy[2 * v], P.xy[2 * v + 1]) + 1];
  for (size_t c = 1; c < start.size(); ++c) start[c] += start[c - 1];
  {
    std::vector<uint32_t> fill(start.begin(), start.end() - 1);
    for (uint32_t v : ends) in[fill[cell_of(P.xy[2 * v], P.xy[2 * v + 1])]++] = v;
  }

  uint64_t inserted = 0;
  std::vector<uint32_t> off{0}, out;
  out.reserve(P.v.size() + P.v.size() / 4);
  std::vector<int> cells;
  std::vector<std::pair<double, uint32_t>> on;
  for (size_t p = 0; p < np; ++p) {
    for (uint32_t i = P.off[p], n = P.off[p + 1]; i < n; ++i) {
      const uint32_t a = P.v[i], b = P.v[i + 1 < n ? i + 1 : P.off[p]];
      out.push_back(a);
      if (!open[i]) continue;
      const double ax = P.xy[2 * a], ay = P.xy[2 * a + 1];
      const double dx = P.xy[2 * b] - ax, dy = P.xy[2 * b + 1] - ay;
      const double len = std::hypot(dx, dy);
      if (!(len > 0)) continue;
      // The cells the edge passes, row by row of cells: in each row, the x range the segment
      // (widened by kOnEdge) spans there.
      cells.clear();
      const double bx = P.xy[2 * b], by = P.xy[2 * b + 1];
      const double ylo = std::min(ay, by) - kOnEdge, yhi = std::max(ay, by) + kOnEdge;
      const int r0 = std::clamp(int(std::floor(ylo / kCell)), 0, gh - 1);
      const int r1 = std::clamp(int(std::floor(yhi / kCell)), 0, gh - 1);
      for (int r = r0; r <= r1; ++r) {
        const double y0 = std::max(ylo, r * kCell), y1 = std::min(yhi, (r + 1) * kCell);
        double x0 = std::min(ax, bx), x1 = std::max(ax, bx);
        if (std::abs(dy) > kOnEdge) {
          const double xa = ax + (y0 - ay) * dx / dy, xb = ax + (y1 - ay) * dx / dy;
          x0 = std::max(x0, std::min(xa, xb)), x1 = std::min(x1, std::max(xa, xb));
        }
        const int c0 = std::clamp(int(std::floor((x0 - kOnEdge) / kCell)), 0, gw - 1);
        const int c1 = std::clamp(int(std::floor((x1 + kOnEdge) / kCell)), 0, gw - 1);
        for (int c = c0; c <= c1; ++c) cells.push_back(r * gw + c);
      }
      on.clear();
      const double len2 = len * len;
      for (int c : cells)
        for (uint32_t k = start[c]; k < start[c + 1]; ++k) {
          const uint32_t v = in[k];
          if (v == a || v == b) continue;
          const double px = P.xy[2 * v] - ax, py = P.xy[2 * v + 1] - ay;
          if (std::abs(dx * py - dy * px) > kOnEdge * len) continue;
          const double t = (dx * px + dy * py) / len2;
          if (t * len > kOnEdge && (1 - t) * len > kOnEdge) on.emplace_back(t, v);
        }
      std::sort(on.begin(), on.end());
      for (auto& [t, v] : on) out.push_back(v);
      inserted += on.size();
    }
    off.push_back(uint32_t(out.size()));
  }
  P.off = std::move(off);
  P.v = std::move(out);
  return inserted;
}

double orient_d(const double* a, const double* b, const double* c) {
  return (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
}

}  // namespace

ConformedPolygons conform_polygons(const PlanarMap& map, uint32_t quantum,
                                   bool insert_t_junctions) {
  if (quantum < 1 || quantum > 256)
    throw InputError(InputErrorKind::BadCamera, "compact writer", "", "quantum", -1,
                     "grid steps per pixel must be 1 ... 256, got " + std::to_string(quantum));
  ConformedPolygons P = merge_equal(map, quantum);
  P.original.resize(P.fragment.size());
  for (size_t p = 0; p < P.fragment.size(); ++p) P.original[p] = P.off[p + 1] - P.off[p];
  if (insert_t_junctions) P.t_junctions = insert_into_edges(P, map.width, map.height);
  return P;
}

GridMesh conform_to_grid(const PlanarMap& map, uint32_t quantum, bool insert_t_junctions) {
  return triangulate_on_grid(conform_polygons(map, quantum, insert_t_junctions), quantum);
}

GridMesh triangulate_on_grid(const ConformedPolygons& P, uint32_t quantum) {
  GridMesh g;
  g.quantum = quantum;
  g.t_junctions = P.t_junctions;

  // Round each vertex once; vertices on the same grid point become one.
  const size_t nv = P.xy.size() / 2;
  std::vector<uint32_t> grid_id(nv);
  FlatMap at(nv);
  for (size_t v = 0; v < nv; ++v) {
    const int32_t qx = int32_t(std::llround(P.xy[2 * v] * quantum));
    const int32_t qy = int32_t(std::llround(P.xy[2 * v + 1] * quantum));
    auto [id, fresh] =
        at.emplace(uint64_t(uint32_t(qx)) << 32 | uint32_t(qy), uint32_t(g.xy.size() / 2));
    if (fresh) {
      g.xy.push_back(qx);
      g.xy.push_back(qy);
    }
    grid_id[v] = id;
  }

  // Ear clipping in the unrounded coordinates, where the polygon is convex with the inserted
  // vertices on its edges (collinear, up to rounding): every cut is a chord between boundary
  // vertices, so every boundary vertex stays a corner of some triangle. The ear is the sharpest
  // corner whose cut leaves a polygon with a corner (cutting the corner opposite a chain of
  // collinear vertices first would leave the chain, no area in these coordinates but some on
  // the grid: a crack). Corners: vertices farther than kOnEdge from the chord of their
  // neighbours.
  std::vector<uint32_t> ring;
  std::vector<double> o;
  std::vector<uint8_t> corner;
  auto turn = [&](uint32_t a, uint32_t b, uint32_t c, double& out) {
    out = orient_d(&P.xy[2 * a], &P.xy[2 * b], &P.xy[2 * c]);
    const double chord = std::hypot(P.xy[2 * c] - P.xy[2 * a], P.xy[2 * c + 1] - P.xy[2 * a + 1]);
    return out > kOnEdge * chord;
  };
  // A triangle of polygon p, kept when it is positive on the grid.
  auto emit = [&](uint32_t a, uint32_t b, uint32_t c, size_t p) {
    const uint32_t t[3] = {grid_id[a], grid_id[b], grid_id[c]};
    if (orient2(&g.xy[2 * t[0]], &g.xy[2 * t[1]], &g.xy[2 * t[2]]) > 0) {
      g.tri.insert(g.tri.end(), t, t + 3);
      g.fragment.push_back(P.fragment[p]);
    } else {
      ++g.dropped;
    }
  };
  for (size_t p = 0; p + 1 < P.off.size(); ++p) {
    ring.clear();
    for (uint32_t i = P.off[p]; i < P.off[p + 1]; ++i) {
      const uint32_t v = P.v[i];
      if (!ring.empty() && grid_id[ring.back()] == grid_id[v]) continue;
      ring.push_back(v);
    }
    while (ring.size() > 1 && grid_id[ring.front()] == grid_id[ring.back()]) ring.pop_back();
    while (ring.size() >= 3) {
      const size_t m = ring.size();
      o.resize(m);
      corner.resize(m);
      size_t corners = 0;
      for (size_t i = 0; i < m; ++i)
        corners += corner[i] = turn(ring[(i + m - 1) % m], ring[i], ring[(i + 1) % m], o[i]);
      if (corners == 0) {
        // No area left in these coordinates, but maybe some on the grid: fan it (any
        // triangulation conforms), keeping what is positive there.
        for (size_t i = 1; i + 1 < m; ++i) emit(ring[0], ring[i], ring[i + 1], p);
        break;
      }
      size_t best = m;
      for (size_t i = 0; i < m; ++i) {
        if (!corner[i] || (best < m && o[i] <= o[best])) continue;
        if (m > 3) {  // does a corner remain once i is cut off?
          const size_t a = (i + m - 1) % m, b = (i + 1) % m;
          double unused;
          const size_t others = corners - 1 - corner[a] - (b != a ? corner[b] : 0);
          if (others == 0 && !turn(ring[(a + m - 1) % m], ring[a], ring[b], unused) &&
              !turn(ring[a], ring[b], ring[(b + 1) % m], unused))
            continue;
        }
        best = i;
      }
      if (best == m)  // every cut leaves a chain: take the sharpest all the same
        best = size_t(std::max_element(o.begin(), o.end()) - o.begin());
      emit(ring[(best + m - 1) % m], ring[best], ring[(best + 1) % m], p);
      ring.erase(ring.begin() + best);
    }
  }
  return g;
}

void weld_vertices(ConformedPolygons& P, double eps) {
  const size_t nv = P.xy.size() / 2;
  std::vector<uint32_t> root(nv);
  for (uint32_t v = 0; v < nv; ++v) root[v] = v;
  auto find = [&](uint32_t v) {
    while (root[v] != v) v = root[v] = root[root[v]];
    return v;
  };
  // Cells of eps: a vertex looks at its own cell and the eight around it.
  auto cell = [eps](double x, double y) {
    return std::pair<int64_t, int64_t>{int64_t(std::floor(x / eps)),
                                       int64_t(std::floor(y / eps))};
  };
  auto key = [](int64_t cx, int64_t cy) {
    return (uint64_t(cx) * 0x9E3779B97F4A7C15ull ^ uint64_t(cy)) * 0xC2B2AE3D27D4EB4Full >> 1;
  };
  FlatMap first(nv);
  std::vector<uint32_t> next(nv, ~0u);
  bool any = false;
  for (uint32_t v = 0; v < nv; ++v) {
    const double x = P.xy[2 * v], y = P.xy[2 * v + 1];
    const auto [cx, cy] = cell(x, y);
    for (int64_t dy = -1; dy <= 1; ++dy)
      for (int64_t dx = -1; dx <= 1; ++dx) {
        const uint32_t* f = first.find(key(cx + dx, cy + dy));
        for (uint32_t w = f ? *f : ~0u; w != ~0u; w = next[w]) {
          if (std::hypot(P.xy[2 * w] - x, P.xy[2 * w + 1] - y) > eps) continue;
          const uint32_t a = find(v), b = find(w);
          if (a != b) root[std::max(a, b)] = std::min(a, b), any = true;
        }
      }
    auto [f, fresh] = first.emplace(key(cx, cy), v);
    if (!fresh) {  // prepend v to the cell's list (FlatMap keeps the first; chain through next)
      next[v] = next[f];
      next[f] = v;
    }
  }
  if (!any) return;
  std::vector<uint32_t> off{0}, out;
  std::vector<uint32_t> frag, orig;
  for (size_t p = 0; p + 1 < P.off.size(); ++p) {
    const size_t begin = out.size();
    for (uint32_t i = P.off[p]; i < P.off[p + 1]; ++i) {
      const uint32_t v = find(P.v[i]);
      if (out.size() == begin || out.back() != v) out.push_back(v);
    }
    while (out.size() > begin + 1 && out.back() == out[begin]) out.pop_back();
    if (out.size() - begin < 3) {
      out.resize(begin);
      continue;
    }
    off.push_back(uint32_t(out.size()));
    frag.push_back(P.fragment[p]);
    orig.push_back(P.original[p]);
  }
  P.off = std::move(off);
  P.v = std::move(out);
  P.fragment = std::move(frag);
  P.original = std::move(orig);
}


}  // namespace vismap
