// Filled paths for the vector writers (core/write/paths.h): quantizing, T-junctions, seams.
//
// A vertex that two fragments share is the same double, hence the same integer count of units
// (1/100 px), so every writer reconstructs it to the same value: no cracks from rounding. A
// vertex that lies on a neighbour's edge without being one of its vertices (a T-junction: an
// occluder's edge against the fragments it hides) would round off that edge and open a gap up
// to 1/200 px wide, which aliased rendering (Fill::Id: SVG crispEdges, the PNG writer without
// antialiasing) shows as background specks; there it is inserted into the neighbour's edge
// (conform_t_junctions), and Fill::Shade strokes such edges instead (below).
//
// Seams (Fill::Shade): anti-aliasing rasterizers composite each path on its own, so two paths
// that abut exactly leave a faint line where background shows through ("conflation": coverage
// a and 1-a compose to 1-a(1-a), 75% at a half-covered pixel). We hide it by stroking each
// fragment edge that another fragment shares, in the fill colour, 1 device pixel wide
// (vector-effect: non-scaling-stroke where supported). Silhouette edges (shared with nobody)
// are not stroked, so outlines are not fattened: a fragment's unshared edge is made the
// implicit closing segment of an open subpath (filled, not stroked); with several unshared
// edges the fragment is written as centre-fan pieces whose stroked sides are interior. Edges
// that meet another fragment along a T-junction (an occluder's edge against the fragments it
// hides) count as shared when fragments of the opposite direction cover half of their length.
// Measured with rsvg-convert on a mid-grey square of 288 triangles: without stroke seams lift
// interior pixels from 128 to 171; with a 1 px stroke on every edge to 131 but outlines gain
// half a pixel; with shared-edge strokes only, interior 131 and outline pixels equal to a
// single-polygon reference (tests/test_write_svg_bin.cpp checks the structure).
//
// Fill::Id: no stroke (aliased rendering has no conflation seams).
#include "core/write/paths.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <unordered_map>
#include <unordered_set>

#include "core/error.h"
#include "core/write/shared.h"

namespace vismap::detail {

namespace {

constexpr double kAmbient = 0.12;  // fraction of the mesh colour that faces away still get
// T-junction collinearity tolerance in units: each end point is off its exact position by at
// most half a unit per axis (0.71 units), and so is the line through the long edge's rounded
// end points; 2 units covers both.
constexpr int64_t kTJunctionTol = 2;

struct EdgeKey {
  Q a, b;
  bool operator==(const EdgeKey& o) const { return a == o.a && b == o.b; }
};
struct EdgeHash {
  size_t operator()(const EdgeKey& k) const {
    uint64_t h = 0x9E3779B97F4A7C15ull;
    for (int64_t v : {k.a.x, k.a.y, k.b.x, k.b.y}) {
      h ^= uint64_t(v) + 0x9E3779B97F4A7C15ull + (h << 6) + (h >> 2);
      h *= 0xBF58476D1CE4E5B9ull;
    }
    return size_t(h ^ (h >> 31));
  }
};

QuantizedMap quantize_map(const PlanarMap& map) {
  QuantizedMap q;
  q.v.reserve(map.vertex_count());
  for (size_t f = 0; f < map.fragment_count(); ++f) {
    const size_t begin = q.v.size();
    for (uint32_t i = map.offsets[f]; i < map.offsets[f + 1]; ++i) {
      const Q p{quantize(map.xy[2 * size_t(i)]), quantize(map.xy[2 * size_t(i) + 1])};
      if (q.v.size() == begin || !(q.v.back() == p)) q.v.push_back(p);
    }
    while (q.v.size() > begin + 1 && q.v.back() == q.v[begin]) q.v.pop_back();
    if (q.v.size() - begin < 3) q.v.resize(begin);
    q.off.push_back(uint32_t(q.v.size()));
  }
  return q;
}

// The edges of a quantized map that no other edge matches exactly in reverse (an occluder's
// edge against the fragments it hides: a T-junction), bucketed in a grid of 16-pixel cells
// for partner queries; edges whose box spans more than 64 cells go to a list every query scans.
class OpenEdges {
 public:
  std::vector<EdgeKey> edge;
  std::vector<uint32_t> id, frag;  // first vertex (index into q.v) and fragment of each

  // `matched` (optional): per edge of q, set to 1 when the reverse edge exists.
  OpenEdges(const QuantizedMap& q, size_t fragments, std::vector<uint8_t>* matched) {
    auto at = [&](size_t f, uint32_t i) {
      const uint32_t b = q.off[f], n = q.off[f + 1] - b;
      return EdgeKey{q.v[b + i], q.v[b + (i + 1) % n]};
    };
    std::unordered_set<EdgeKey, EdgeHash> all;
    all.reserve(q.v.size() * 2);
    for (size_t f = 0; f < fragments; ++f)
      for (uint32_t i = 0; i < q.off[f + 1] - q.off[f]; ++i) all.insert(at(f, i));
    for (size_t f = 0; f < fragments; ++f)
      for (uint32_t i = 0; i < q.off[f + 1] - q.off[f]; ++i) {
        const EdgeKey e = at(f, i);
        if (all.count(EdgeKey{e.b, e.a})) {
          if (matched) (*matched)[q.off[f] + i] = 1;
        } else {
          edge.push_back(e);
          id.push_back(q.off[f] + i);
          frag.push_back(uint32_t(f));
        }
      }
    for (uint32_t k = 0; k < edge.size(); ++k) {
      const EdgeKey& e = edge[k];
      const int64_t x0 = cell(std::min(e.a.x, e.b.x) - kTJunctionTol),
                    x1 = cell(std::max(e.a.x, e.b.x) + kTJunctionTol),
                    y0 = cell(std::min(e.a.y, e.b.y) - kTJunctionTol),
                    y1 = cell(std::max(e.a.y, e.b.y) + kTJunctionTol);
      if ((x1 - x0 + 1) * (y1 - y0 + 1) > 64) {
        big_.push_back(k);
        continue;
      }
      for (int64_t cx = x0; cx <= x1; ++cx)
        for (int64_t cy = y0; cy <= y1; ++cy) grid_[cell_key(cx, cy)].push_back(k);
    }
  }

  // The open edges other than k that run the opposite way along the same line: both end points
  // of the shorter one within kTJunctionTol of the longer one's line.
  void partners(uint32_t k, std::vector<uint32_t>& out) {
    const EdgeKey& e = edge[k];
    cand_.assign(big_.begin(), big_.end());
    const int64_t x0 = cell(std::min(e.a.x, e.b.x)), x1 = cell(std::max(e.a.x, e.b.x)),
                  y0 = cell(std::min(e.a.y, e.b.y)), y1 = cell(std::max(e.a.y, e.b.y));
    if ((x1 - x0 + 1) * (y1 - y0 + 1) > 64) {
      cand_.resize(edge.size());
      for (uint32_t j = 0; j < edge.size(); ++j) cand_[j] = j;
    } else {
      for (int64_t cx = x0; cx <= x1; ++cx)
        for (int64_t cy = y0; cy <= y1; ++cy) {
          auto it = grid_.find(cell_key(cx, cy));
          if (it != grid_.end()) cand_.insert(cand_.end(), it->second.begin(), it->second.end());
        }
      std::sort(cand_.begin(), cand_.end());
      cand_.erase(std::unique(cand_.begin(), cand_.end()), cand_.end());
    }
    out.clear();
    const double dx = double(e.b.x - e.a.x), dy = double(e.b.y - e.a.y);
    const double len = std::hypot(dx, dy);
    for (uint32_t j : cand_) {
      if (j == k) continue;
      const EdgeKey& o = edge[j];
      const double ox = double(o.b.x - o.a.x), oy = double(o.b.y - o.a.y);
      if (dx * ox + dy * oy >= 0) continue;  // must run the opposite way
      const double olen = std::hypot(ox, oy);
      const EdgeKey& lng = len >= olen ? e : o;
      const EdgeKey& sht = len >= olen ? o : e;
      const double lx = double(lng.b.x - lng.a.x), ly = double(lng.b.y - lng.a.y);
      const double llen = std::max(len, olen);
      auto dist = [&](Q p) {
        return std::abs(lx * double(p.y - lng.a.y) - ly * double(p.x - lng.a.x)) / llen;
      };
      if (dist(sht.a) <= kTJunctionTol && dist(sht.b) <= kTJunctionTol) out.push_back(j);
    }
  }

 private:
  static constexpr int64_t kCell = 16 * kUnit;
  static int64_t cell(int64_t v) { return v >= 0 ? v / kCell : -((-v + kCell - 1) / kCell); }
  static uint64_t cell_key(int64_t cx, int64_t cy) {
    return uint64_t(cx) * 0x100000001B3ull ^ uint64_t(cy);
  }
  std::unordered_map<uint64_t, std::vector<uint32_t>> grid_;
  std::vector<uint32_t> big_, cand_;
};

// Where a fragment's edge runs along several edges of its neighbours (a T-junction), the
// neighbours' vertices lie on it in the exact map but not after rounding: each moved by up to
// half a unit, so thin gaps (and overlaps) open along the edge, which an aliased rasterizer
// (Fill::Id, crispEdges) shows as background specks where a pixel centre falls in one. So the
// neighbours' vertices strictly inside the edge are inserted into it, in order: both sides then
// pass through the same rounded points (the edge bends by at most kTJunctionTol units). Not
// inserted: a vertex the fragment already has (a sliver thinner than the tolerance would fold
// onto itself) and one within the tolerance of the edge's end points (it would spike a corner
// whose two edges both pass that close).
void conform_t_junctions(QuantizedMap& q, size_t fragments) {
  OpenEdges open(q, fragments, nullptr);
  if (open.edge.empty()) return;
  std::unordered_map<uint32_t, std::vector<std::pair<double, Q>>> insert;  // by edge id
  auto near = [](Q p, Q v) {
    return std::max(std::abs(p.x - v.x), std::abs(p.y - v.y)) <= kTJunctionTol;
  };
  std::vector<uint32_t> partners;
  for (uint32_t k = 0; k < open.edge.size(); ++k) {
    open.partners(k, partners);
    const EdgeKey& e = open.edge[k];
    const double dx = double(e.b.x - e.a.x), dy = double(e.b.y - e.a.y);
    const double len2 = dx * dx + dy * dy;
    const uint32_t f = open.frag[k];
    for (uint32_t j : partners) {
      if (open.frag[j] == f) continue;
      for (Q p : {open.edge[j].a, open.edge[j].b}) {
        if (near(p, e.a) || near(p, e.b)) continue;
        if (std::find(q.v.begin() + q.off[f], q.v.begin() + q.off[f + 1], p) !=
            q.v.begin() + q.off[f + 1])
          continue;
        const double t = (double(p.x - e.a.x) * dx + double(p.y - e.a.y) * dy) / len2;
        if (t > 0 && t < 1) insert[open.id[k]].push_back({t, p});
      }
    }
  }
  if (insert.empty()) return;
  QuantizedMap r;
  r.v.reserve(q.v.size() + insert.size() * 2);
  for (size_t f = 0; f < fragments; ++f) {
    for (uint32_t i = q.off[f]; i < q.off[f + 1]; ++i) {
      r.v.push_back(q.v[i]);
      auto it = insert.find(i);
      if (it == insert.end()) continue;
      auto& pts = it->second;
      std::sort(pts.begin(), pts.end(),
                [](const auto& a, const auto& b) { return a.first < b.first; });
      for (size_t m = 0; m < pts.size(); ++m)
        if (!(pts[m].second == r.v.back())) r.v.push_back(pts[m].second);
    }
    r.off.push_back(uint32_t(r.v.size()));
  }
  q = std::move(r);
}

// Marks the edges that another fragment shares: exactly (the reverse edge exists), or along a
// T-junction (reverse-direction collinear edges cover at least half of it).
void find_shared_edges(QuantizedMap& q, size_t fragments) {
  q.shared.assign(q.v.size(), 0);
  OpenEdges open(q, fragments, &q.shared);
  std::vector<uint32_t> partners;
  for (uint32_t k = 0; k < open.edge.size(); ++k) {
    open.partners(k, partners);
    const EdgeKey& e = open.edge[k];
    const double dx = double(e.b.x - e.a.x), dy = double(e.b.y - e.a.y);
    const double len = std::hypot(dx, dy);
    double covered = 0;
    for (uint32_t j : partners) {
      const EdgeKey& o = open.edge[j];
      // Overlap of o with e, measured along e.
      const double t0 = (double(o.a.x - e.a.x) * dx + double(o.a.y - e.a.y) * dy) / len;
      const double t1 = (double(o.b.x - e.a.x) * dx + double(o.b.y - e.a.y) * dy) / len;
      covered += std::max(0.0, std::min(len, std::max(t0, t1)) - std::max(0.0, std::min(t0, t1)));
    }
    if (covered >= 0.5 * len) q.shared[open.id[k]] = 1;
  }
}

uint8_t to_srgb8(double linear) {
  const double c = std::clamp(linear, 0.0, 1.0);
  const double s = c <= 0.0031308 ? 12.92 * c : 1.055 * std::pow(c, 1.0 / 2.4) - 0.055;
  return static_cast<uint8_t>(std::lround(s * 255.0));
}

}  // namespace

void write_fragment(PathSink& d, const QuantizedMap& q, size_t f, bool use_flags) {
  const uint32_t b = q.off[f], n = q.off[f + 1] - b;
  auto at = [&](uint32_t i) { return q.v[b + i % n]; };
  uint32_t unshared = 0, longest = 0;
  double longest_len = -1, unshared_len = 0, perimeter = 0;
  if (use_flags) {
    for (uint32_t i = 0; i < n; ++i) {
      const Q u = at(i), w = at(i + 1);
      const double l = std::hypot(double(w.x - u.x), double(w.y - u.y));
      perimeter += l;
      if (q.shared[b + i]) continue;
      ++unshared;
      unshared_len += l;
      if (l > longest_len) longest_len = l, longest = i;
    }
  }
  // With several unshared edges one of them can be the implicit closing segment; the others
  // are stroked (spilling half a stroke width over the outline along their length) unless the
  // fragment is cut into centre-fan pieces, whose interior diagonals spill only near their
  // ends -- but far along them when the fragment is a sliver and a diagonal runs almost
  // parallel to an outline edge. Short other unshared edges (a sliver's tip): stroke them.
  if (unshared >= 2 && unshared_len - longest_len <= 0.1 * perimeter) unshared = 1;
  if (unshared == 0) {  // closed polygon, every edge stroked
    d.move(at(0));
    for (uint32_t i = 1; i < n; ++i) d.line(at(i));
    d.close();
    return;
  }
  if (unshared ==
      1) {  // open polygon whose implicit closing segment is the (longest) unshared edge
    for (uint32_t i = 0; i < n; ++i) {
      const Q p = at(longest + 1 + i);
      if (i == 0)
        d.move(p);
      else
        d.line(p);
    }
    return;
  }
  // Several unshared edges: runs of shared edges as fans from the centre C ("M C v_s .. v_e",
  // closing back to C), and each unshared edge (a, b) as the triangle "M b C a" closing a -> b.
  // All pieces keep the fragment's orientation, so the nonzero fill is the fragment.
  int64_t sx = 0, sy = 0;
  for (uint32_t i = 0; i < n; ++i) sx += at(i).x, sy += at(i).y;
  const Q c{sx / int64_t(n), sy / int64_t(n)};
  uint32_t start = 0;  // an edge that follows an unshared one starts a run
  while (q.shared[b + start] == 0 || q.shared[b + (start + n - 1) % n] != 0) {
    if (++start == n) break;
  }
  for (uint32_t k = 0; k < n; ++k) {
    const uint32_t i = (start + k) % n;
    if (!q.shared[b + i]) {
      d.move(at(i + 1));
      d.line(c);
      d.line(at(i));
    } else if (k == 0 || !q.shared[b + (i + n - 1) % n]) {
      d.move(c);
      d.line(at(i));
      uint32_t j = i;
      while (q.shared[b + j % n] && j - i < n) d.line(at(++j));
    }
  }
}

double lambert_shade(const Scene& scene, const Camera& cam, uint32_t mesh, uint32_t tri) {
  const Mesh& m = scene.meshes[mesh];
  Vec3 p[3];
  for (int k = 0; k < 3; ++k) {
    const uint32_t vi = m.indices[3 * size_t(tri) + k];
    if (vi >= m.vertex_count())
      throw InputError(InputErrorKind::IndexOutOfRange, "svg", m.name, "triangle", tri,
                       "vertex index " + std::to_string(vi) + " out of range");
    for (int c = 0; c < 3; ++c) p[k][c] = m.positions[3 * size_t(vi) + c];
  }
  const Vec3 e1{p[1][0] - p[0][0], p[1][1] - p[0][1], p[1][2] - p[0][2]};
  const Vec3 e2{p[2][0] - p[0][0], p[2][1] - p[0][1], p[2][2] - p[0][2]};
  Vec3 n{e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
         e1[0] * e2[1] - e1[1] * e2[0]};
  // A diced implicit surface carries the gradient's normal per vertex: their mean shades the
  // triangle, so cells do not show as facets.
  if (m.normals.size() == m.positions.size()) {
    n = {0, 0, 0};
    for (int k = 0; k < 3; ++k)
      for (int c = 0; c < 3; ++c) n[c] += m.normals[3 * size_t(m.indices[3 * size_t(tri) + k]) + c];
  }
  // A headlight along the view direction, for both projections: a plane gets one shade
  // whatever its triangulation (a light at the eye shaded each triangle of a wall by its own
  // centroid, issue 20).
  const Vec3 l{cam.eye[0] - cam.target[0], cam.eye[1] - cam.target[1], cam.eye[2] - cam.target[2]};
  const double nn = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
  const double ll = std::sqrt(l[0] * l[0] + l[1] * l[1] + l[2] * l[2]);
  double ndl = std::abs(n[0] * l[0] + n[1] * l[1] + n[2] * l[2]) / (nn * ll);
  if (!std::isfinite(ndl)) ndl = 1.0;  // degenerate triangle
  return kAmbient + (1.0 - kAmbient) * std::min(ndl, 1.0);
}

uint32_t fill_color(const PlanarMap& map, const Scene& scene, const Camera& camera, bool shade,
                    const std::vector<uint64_t>& base, size_t f, const char* writer) {
  const uint32_t mesh = map.mesh[f], tri = map.triangle[f];
  if (shade) return shade_color(scene, camera, mesh, tri);
  const uint64_t id = global_triangle_id(map, scene, base, f) + 1;
  if (id > 0xFFFFFF)
    throw InputError(InputErrorKind::TooLarge, writer, scene.meshes[mesh].name, "triangle",
                     int64_t(tri),
                     "global triangle id " + std::to_string(id - 1) +
                         " does not fit a 24-bit --fill id colour");
  return uint32_t(id);
}

uint32_t shade_color(const Scene& scene, const Camera& cam, uint32_t mesh, uint32_t tri) {
  const double k = lambert_shade(scene, cam, mesh, tri);
  uint32_t rgb = 0;
  for (int c = 0; c < 3; ++c) rgb = rgb << 8 | to_srgb8(scene.meshes[mesh].color[c] * k);
  return rgb;
}

FillPlan plan_fills(const PlanarMap& map, const Scene& scene, const Camera& camera, Fill fill,
                    const char* writer) {
  FillPlan plan;
  const size_t nf = map.fragment_count();
  const std::vector<uint64_t> base = scene.triangle_id_base();

  // Fragments ordered by (mesh, triangle), stable: one path per source triangle.
  plan.order.resize(nf);
  for (uint32_t f = 0; f < nf; ++f) plan.order[f] = f;
  std::stable_sort(plan.order.begin(), plan.order.end(), [&](uint32_t a, uint32_t b) {
    return map.mesh[a] != map.mesh[b] ? map.mesh[a] < map.mesh[b]
                                      : map.triangle[a] < map.triangle[b];
  });

  QuantizedMap& q = plan.q;
  q = quantize_map(map);
  const bool shade = fill == Fill::Shade;
  plan.stroke_seams = shade;
  // Shade strokes the T-junction edges (find_shared_edges), which covers their gaps; Id has no
  // stroke, so its T-junctions are made conforming (which costs ~25 ms on the bunny's 30k
  // fragments and, for millions of fragments, a second copy of the vertices).
  if (shade)
    find_shared_edges(q, nf);
  else
    conform_t_junctions(q, nf);

  const std::vector<uint32_t>& order = plan.order;
  for (size_t i = 0; i < nf;) {
    const uint32_t mesh = map.mesh[order[i]], tri = map.triangle[order[i]];
    size_t j = i;
    bool any = false;
    for (; j < nf && map.mesh[order[j]] == mesh && map.triangle[order[j]] == tri; ++j)
      any = any || q.off[order[j] + 1] > q.off[order[j]];
    if (any) {
      const uint32_t color = fill_color(map, scene, camera, shade, base, order[i], writer);
      plan.paths.push_back({mesh, tri, color, i, j});
    }
    i = j;
  }
  // Shade: paths of one colour together (a mesh has at most a few hundred 8-bit shades), so
  // that writers set each colour once. Drawing order does not matter in a map of depth
  // complexity one.
  if (shade)
    std::stable_sort(plan.paths.begin(), plan.paths.end(),
                     [](const TrianglePath& a, const TrianglePath& b) {
                       return a.mesh != b.mesh ? a.mesh < b.mesh : a.color < b.color;
                     });
  return plan;
}

void chain_points(const LineSet& lines, size_t c, std::vector<Q>& out) {
  out.clear();
  for (uint32_t i = lines.off[c]; i < lines.off[c + 1]; ++i) {
    const Q q{quantize(lines.xy[2 * size_t(i)]), quantize(lines.xy[2 * size_t(i) + 1])};
    if (out.empty() || !(out.back() == q)) out.push_back(q);
  }
}

}  // namespace vismap::detail
