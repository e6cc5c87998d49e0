// extract_lines (core/lines/lines.h): the planar map's edges classified by the source triangles on
// their two sides (classifier.h), chained into polylines (chain.h).
#include "core/lines/lines.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <tuple>

#include "core/error.h"
#include "core/lines/chain.h"
#include "core/lines/classifier.h"
#include "core/lines/topology.h"
#include "core/util/conform.h"
#include "core/util/flat_map.h"
#include "core/util/weld.h"

namespace vismap {

const char* line_kind_name(LineKind k) {
  switch (k) {
    case LineKind::Contour:
      return "contour";
    case LineKind::Boundary:
      return "boundary";
    case LineKind::Crease:
      return "crease";
    case LineKind::Intersection:
      return "intersection";
    case LineKind::Border:
      return "border";
  }
  return "?";
}

namespace lines_detail {

Classifier::Classifier(const PlanarMap& map, const ScreenTriangles& screen, const Scene& scene,
           const Camera& camera, const LineOptions& opts)
    : map_(map),
      st_(screen),
      scene_(scene),
      cam_(camera),
      topo_(scene.meshes.size()),
      by_source_(screen.size()),
      next_(screen.size(), kNone),
      edge_of_(screen.size()) {
  if (screen.grid_scale == 0 && screen.size() != 0) bad("screen triangles without a grid scale");
  if (screen.xy.size() != 6 * screen.size() || screen.depth.size() != 3 * screen.size() ||
      screen.triangle.size() != screen.size())
    bad("screen triangle arrays of different lengths");
  cos_crease_ = std::cos(opts.crease_angle_deg * M_PI / 180.0);
  cos_half_crease_ = std::cos(opts.crease_angle_deg * M_PI / 360.0);
  crease_smooth_ = opts.crease_smooth;
  vertex_normals_.resize(scene.meshes.size());
  self_folds_ = opts.self_folds;
  vp_ = camera.view_projection();
  for (uint32_t s = 0; s < screen.size(); ++s) {
    const uint32_t m = screen.mesh[s], t = screen.triangle[s];
    if (m >= scene.meshes.size() || t >= scene.meshes[m].triangle_count())
      bad("screen triangle " + std::to_string(s) + " names no triangle of the scene");
    auto [first, fresh] = by_source_.emplace(pair_key(m, t), s);
    if (!fresh) {
      next_[s] = next_[first];
      next_[first] = s;
    }
    edge_of_[s] = {kUnmapped, kUnmapped, kUnmapped};
  }
  crossing_ = FlatMap(screen.crossings.size());
  index_crossings();
  eps_ = kTouch * scene_extent(scene);
}

}  // namespace lines_detail

using lines_detail::bad;
using lines_detail::Classifier;
using lines_detail::kOnLine;
using lines_detail::Seg;
using lines_detail::chain;
using lines_detail::pair_key;

LineSet extract_lines(const PlanarMap& map, const ScreenTriangles& screen, const Scene& scene,
                      const Camera& camera, const LineOptions& opts) {
  // Long on purpose (~130 lines): the edge table built first is what the classification, the
  // hidden parts and the chaining below all walk.
  if (map.mesh.size() != map.fragment_count() || map.triangle.size() != map.fragment_count())
    bad("fragment arrays of different lengths");
  for (size_t f = 0; f < map.fragment_count(); ++f)
    if (map.mesh[f] >= scene.meshes.size() ||
        map.triangle[f] >= scene.meshes[map.mesh[f]].triangle_count())
      bad("fragment " + std::to_string(f) + " names no triangle of the scene");
  ConformedPolygons P = conform_polygons(map, 1);
  weld_vertices(P, kOnLine);
  Classifier cls(map, screen, scene, camera, opts);

  // Every polygon edge, by its directed vertex pair; an edge is looked at once, from the side
  // whose polygon comes first (or its only side).
  FlatMap edges(P.v.size());
  for (uint32_t p = 0; p < P.size(); ++p)
    for (uint32_t i = P.off[p], n = P.off[p + 1]; i < n; ++i)
      edges.emplace(pair_key(P.v[i], P.v[i + 1 < n ? i + 1 : P.off[p]]), p);
  std::array<std::vector<Seg>, kLineKinds> segs;
  // The visible parts of mesh edge lines, for --hidden: (mesh, edge key) -> map edges on it.
  struct OnEdge {
    uint32_t mesh;
    uint64_t edge;
    uint32_t a, b;
  };
  std::vector<OnEdge> on_edge;
  // Map edges shorter than kOnLine (two exact points a rounding apart, e.g. where a crossing
  // line meets two triangles' edges at one point in theory) are no line of any kind: their
  // ends are merged for chaining.
  std::vector<uint32_t> root(P.xy.size() / 2);
  for (uint32_t v = 0; v < root.size(); ++v) root[v] = v;
  auto find = [&](uint32_t v) {
    while (root[v] != v) v = root[v] = root[root[v]];
    return v;
  };
  for (uint32_t p = 0; p < P.size(); ++p)
    for (uint32_t i = P.off[p], n = P.off[p + 1]; i < n; ++i) {
      const uint32_t a = P.v[i], b = P.v[i + 1 < n ? i + 1 : P.off[p]];
      const uint32_t* twin = edges.find(pair_key(b, a));
      if (twin && *twin < p) continue;
      if (std::hypot(P.xy[2 * a] - P.xy[2 * b], P.xy[2 * a + 1] - P.xy[2 * b + 1]) < kOnLine) {
        const uint32_t ra = find(a), rb = find(b);
        if (ra != rb) root[std::max(ra, rb)] = std::min(ra, rb);
        continue;
      }
      LineKind kind;
      Classifier::Owner owner;
      const bool line = cls.classify(&P.xy[2 * a], &P.xy[2 * b], P.fragment[p],
                                     twin ? P.fragment[*twin] : Classifier::kNone, kind, owner);
      if (line) segs[size_t(kind)].push_back({a, b});
      if (opts.hidden && owner.edge != Classifier::kNoEdge)
        on_edge.push_back({owner.mesh, owner.edge, a, b});
    }

  LineSet out;
  out.unplaced = cls.unplaced;
  for (size_t k = 0; k < kLineKinds; ++k) {
    for (Seg& g : segs[k]) g.a = find(g.a), g.b = find(g.b);
    out.edges[k] = segs[k].size();
    chain(P.xy, segs[k], LineKind(k), false, opts.simplify_px, opts.min_length_px[k], out);
  }
  if (!opts.hidden) return out;

  // Hidden parts: each mesh edge line (from the mesh) less the map edges that lie on it.
  std::sort(on_edge.begin(), on_edge.end(), [](const OnEdge& x, const OnEdge& y) {
    return x.mesh != y.mesh ? x.mesh < y.mesh : x.edge < y.edge;
  });
  std::vector<double> hxy;  // hidden segments' points, merged by exact position below
  std::array<std::vector<Seg>, kLineKinds> hsegs;
  std::vector<std::array<double, 4>> pieces;  // (t0, t1) with their points: x0 y0 | x1 y1
  struct Cut {
    double t;
    uint32_t v;  // a map vertex (into P.xy)
  };
  std::vector<std::pair<Cut, Cut>> visible;
  std::array<std::vector<std::array<double, 4>>, kLineKinds> raw;
  for (uint32_t m = 0; m < scene.meshes.size(); ++m) {
    auto lo = std::lower_bound(on_edge.begin(), on_edge.end(), m,
                               [](const OnEdge& x, uint32_t mm) { return x.mesh < mm; });
    cls.for_each_edge_line(m, [&](LineKind kind, uint64_t key, const double* a, const double* b) {
      const double dx = b[0] - a[0], dy = b[1] - a[1], l2 = dx * dx + dy * dy;
      if (!(l2 > 0)) return;
      visible.clear();
      auto it = std::lower_bound(lo, on_edge.end(), key, [m](const OnEdge& x, uint64_t kk) {
        return x.mesh < m || (x.mesh == m && x.edge < kk);
      });
      for (; it != on_edge.end() && it->mesh == m && it->edge == key; ++it) {
        auto param = [&](uint32_t v) {
          return ((P.xy[2 * v] - a[0]) * dx + (P.xy[2 * v + 1] - a[1]) * dy) / l2;
        };
        Cut c0{param(it->a), it->a}, c1{param(it->b), it->b};
        if (c1.t < c0.t) std::swap(c0, c1);
        visible.push_back({c0, c1});
      }
      std::sort(visible.begin(), visible.end(),
                [](const auto& x, const auto& y) { return x.first.t < y.first.t; });
      // Walk [0, 1], emitting what no visible part covers; a piece starts or ends at a visible
      // part's end point (a map vertex, exactly) or at the edge's own end.
      double t = 0, px = a[0], py = a[1];
      const double tiny = 1e-9 / std::sqrt(l2);  // a nanopixel
      auto piece = [&](double t1, double x1, double y1) {
        if (t1 - t > tiny) raw[size_t(kind)].push_back({px, py, x1, y1});
      };
      for (const auto& [c0, c1] : visible) {
        if (c0.t > t) piece(c0.t, P.xy[2 * c0.v], P.xy[2 * c0.v + 1]);
        if (c1.t > t) {
          t = c1.t;
          px = P.xy[2 * c1.v];
          py = P.xy[2 * c1.v + 1];
        }
      }
      if (t < 1) piece(1, b[0], b[1]);
    });
  }
  for (size_t k = 0; k < kLineKinds; ++k) {
    // Points merged by exact position (the ends two edges share are snapped alike).
    hxy.clear();
    hsegs[k].clear();
    Weld<double, 2> at(2 * raw[k].size());
    auto id = [&](double x, double y) {
      const double p[2] = {x, y};
      auto [v, fresh] = at.add(p, uint32_t(hxy.size() / 2));
      if (fresh) hxy.push_back(x), hxy.push_back(y);
      return v;
    };
    for (const auto& r : raw[k]) {
      const uint32_t a = id(r[0], r[1]), b = id(r[2], r[3]);
      if (a != b) hsegs[k].push_back({a, b});
    }
    out.hidden_edges[k] = hsegs[k].size();
    chain(hxy, hsegs[k], LineKind(k), true, opts.simplify_px, opts.min_length_px[k], out);
  }
  return out;
}

}  // namespace vismap
