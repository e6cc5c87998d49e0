// find_scene_facts (scene_facts.h) as its phases, in order: the triangles' corners welded by
// position, the triangles at each vertex, the neighbour lists, the grids of boxes, the search of
// pairs near each other (threads over cells, then over triangles), and the clearances with their
// bins. Each phase is a function of what the ones before it made.
#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <thread>
#include <unordered_map>

#include "core/facts/distance.h"
#include "core/facts/scene_facts.h"
#include "core/util/clock.h"
#include "core/util/weld.h"

namespace vismap::facts {

namespace {

using geom::Box;
using geom::Prepared;
using geom::Tri;
using vec3::V;

// Every triangle's corners, and each corner's canonical vertex id by exact position
// (util/weld.h, across meshes): a vertex's id is the first vertex at its place.
struct Corners {
  std::vector<Tri> tri;
  std::vector<std::array<uint32_t, 3>> id;
  uint32_t vertex_ids = 0;  // ids are vertex ids: some unused
  uint32_t size() const { return static_cast<uint32_t>(tri.size()); }
  bool shares_vertex(uint32_t a, uint32_t b) const {
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j)
        if (id[a][i] == id[b][j]) return true;
    return false;
  }
};

// The corners of every mesh's triangles; f's bounds and coordinate_max from them.
Corners gather_corners(const Scene& scene, SceneFacts& f) {
  Corners c;
  std::vector<uint32_t> vbase;
  for (const Mesh& m : scene.meshes) {
    vbase.push_back(c.vertex_ids);
    c.vertex_ids += static_cast<uint32_t>(m.vertex_count());
  }
  std::vector<uint32_t> canon(c.vertex_ids);
  {
    Weld<float, 3> weld(c.vertex_ids);
    for (size_t mi = 0; mi < scene.meshes.size(); ++mi) {
      const Mesh& m = scene.meshes[mi];
      for (size_t v = 0; v < m.vertex_count(); ++v) {
        const uint32_t id = vbase[mi] + static_cast<uint32_t>(v);
        canon[id] = weld.add(&m.positions[3 * v], id).first;
      }
    }
  }
  bool any = false;
  for (size_t mi = 0; mi < scene.meshes.size(); ++mi) {
    const Mesh& m = scene.meshes[mi];
    for (size_t t = 0; t < m.triangle_count(); ++t) {
      Tri x;
      std::array<uint32_t, 3> ids;
      for (int k = 0; k < 3; ++k) {
        const uint32_t v = m.indices[3 * t + k];
        ids[k] = canon[vbase[mi] + v];
        for (int d = 0; d < 3; ++d) {
          x[k][d] = m.positions[3 * v + d];
          f.bounds.lo[d] = any ? std::min(f.bounds.lo[d], x[k][d]) : x[k][d];
          f.bounds.hi[d] = any ? std::max(f.bounds.hi[d], x[k][d]) : x[k][d];
          f.coordinate_max = std::max(f.coordinate_max, std::fabs(x[k][d]));
        }
        any = true;
      }
      c.tri.push_back(x);
      c.id.push_back(ids);
    }
  }
  return c;
}

// The triangles at each canonical vertex, once each: vtri[first[v] .. first[v + 1]).
struct VertexStar {
  std::vector<uint32_t> first, vtri;
  bool crowded(uint32_t v) const { return first[v + 1] - first[v] > kMaxValence; }
};

// Marks bad the triangles with two corners at one place.
VertexStar vertex_triangles(const Corners& c, std::vector<char>& bad) {
  const uint32_t T = c.size(), nc = c.vertex_ids;
  auto distinct = [&](const std::array<uint32_t, 3>& id, int k) {
    return k == 0 || (id[k] != id[0] && (k == 1 || id[k] != id[1]));
  };
  VertexStar s;
  s.first.assign(size_t(nc) + 1, 0);
  for (uint32_t t = 0; t < T; ++t) {
    const auto& id = c.id[t];
    if (id[0] == id[1] || id[1] == id[2] || id[0] == id[2]) bad[t] = 1;
    for (int k = 0; k < 3; ++k)
      if (distinct(id, k)) ++s.first[id[k] + 1];
  }
  for (uint32_t v = 0; v < nc; ++v) s.first[v + 1] += s.first[v];
  s.vtri.resize(s.first[nc]);
  std::vector<uint32_t> cursor(s.first.begin(), s.first.end() - 1);
  for (uint32_t t = 0; t < T; ++t) {
    const auto& id = c.id[t];
    for (int k = 0; k < 3; ++k)
      if (distinct(id, k)) s.vtri[cursor[id[k]]++] = t;
  }
  return s;
}

// f's neighbour lists: per triangle t those u > t through vertices that are not crowded
// (through a crowded one both are bad: the frame's own search finds such pairs).
void list_neighbours(const Corners& c, const VertexStar& s, std::vector<char>& bad,
                     SceneFacts& f) {
  std::vector<uint32_t> nb;
  for (uint32_t t = 0; t < c.size(); ++t) {
    nb.clear();
    for (int k = 0; k < 3; ++k) {
      const uint32_t v = c.id[t][k];
      if (s.crowded(v)) {
        bad[t] = 1;
        continue;
      }
      for (uint32_t i = s.first[v]; i < s.first[v + 1]; ++i)
        if (s.vtri[i] > t) nb.push_back(s.vtri[i]);
    }
    std::sort(nb.begin(), nb.end());
    nb.erase(std::unique(nb.begin(), nb.end()), nb.end());
    f.adj.insert(f.adj.end(), nb.begin(), nb.end());
    f.adj_offset[t + 1] = static_cast<uint32_t>(f.adj.size());
  }
}

constexpr uint64_t kMaxCells = 64, kCrowdedCell = 256;
constexpr int kLevels = 15;

// The grids: level k has cells of h 4^k (h about a triangle's size, at least 2 caps), and each
// triangle sits in the finest level where its grown box spans at most kMaxCells cells. A pair
// within the cap is found once: in one level by the cell that owns it, across levels by the
// finer member looking through the coarser levels' cells. Each triangle is in every cell of its
// level that its box grown by half the cap meets: two triangles within the cap of each other
// meet in a cell, and one cell owns their pair (the one holding the low corner of their grown
// boxes' overlap: the larger of their start cells).
struct Grid {
  V lo;
  double h0 = 0, half = 0;
  std::vector<Box> box;
  std::vector<uint8_t> level;
  std::vector<std::array<int64_t, 3>> start;
  int top = 0;
  std::vector<char> level_used;
  std::vector<std::pair<uint64_t, uint32_t>> entries;  // (cell key, triangle), sorted
  std::vector<uint32_t> cell_first;                    // per cell, its first entry; then the end
  // key -> index into cell_first, for the cells above level 0 (the only ones looked up).
  std::unordered_map<uint64_t, uint32_t> cell_of;

  uint64_t cell_range(const Box& b, int k, std::array<int64_t, 6>& r) const {
    const double h = std::ldexp(h0, 2 * k);
    uint64_t n = 1;
    for (int d = 0; d < 3; ++d) {
      r[d] = static_cast<int64_t>(std::floor((b.lo[d] - half - lo[d]) / h));
      r[d + 3] = static_cast<int64_t>(std::floor((b.hi[d] + half - lo[d]) / h));
      n *= uint64_t(r[d + 3] - r[d] + 1);
    }
    return n;
  }
  // Cell coordinates stay within +-2^19 (level 0 has at most diag / 2 caps = 2^12 cells a side).
  static uint64_t key_of(int k, int64_t x, int64_t y, int64_t z) {
    return (uint64_t(k) << 60) | (uint64_t(x + (1 << 19)) << 40) |
           (uint64_t(y + (1 << 19)) << 20) | uint64_t(z + (1 << 19));
  }
  size_t cells() const { return cell_first.size() - 1; }
  uint32_t cell_size(size_t ci) const { return cell_first[ci + 1] - cell_first[ci]; }
};

// Marks bad the triangles of crowded cells.
Grid build_grid(const Corners& c, const SceneFacts& f, std::vector<char>& bad) {
  const uint32_t T = c.size();
  Grid g;
  g.lo = f.bounds.lo;
  g.half = f.cap / 2;
  g.box.resize(T);
  std::vector<double> extent(T);
  for (uint32_t t = 0; t < T; ++t) {
    for (int d = 0; d < 3; ++d) {
      g.box[t].lo[d] = std::min({c.tri[t][0][d], c.tri[t][1][d], c.tri[t][2][d]});
      g.box[t].hi[d] = std::max({c.tri[t][0][d], c.tri[t][1][d], c.tri[t][2][d]});
    }
    extent[t] = std::max({g.box[t].hi[0] - g.box[t].lo[0], g.box[t].hi[1] - g.box[t].lo[1],
                          g.box[t].hi[2] - g.box[t].lo[2]});
  }
  std::nth_element(extent.begin(), extent.begin() + T / 2, extent.end());
  g.h0 = std::max(2 * f.cap, extent[T / 2]);
  g.level.assign(T, 0);
  g.start.resize(T);
  for (uint32_t t = 0; t < T; ++t) {
    std::array<int64_t, 6> r;
    int k = 0;
    while (k + 1 < kLevels && g.cell_range(g.box[t], k, r) > kMaxCells) ++k;
    g.cell_range(g.box[t], k, r);
    g.level[t] = static_cast<uint8_t>(k);
    g.start[t] = {r[0], r[1], r[2]};
    g.top = std::max(g.top, k);
    for (int64_t x = r[0]; x <= r[3]; ++x)
      for (int64_t y = r[1]; y <= r[4]; ++y)
        for (int64_t z = r[2]; z <= r[5]; ++z) g.entries.push_back({Grid::key_of(k, x, y, z), t});
  }
  std::sort(g.entries.begin(), g.entries.end());
  for (size_t i = 0; i < g.entries.size(); ++i)
    if (i == 0 || g.entries[i].first != g.entries[i - 1].first) {
      if (g.entries[i].first >> 60)
        g.cell_of.emplace(g.entries[i].first, uint32_t(g.cell_first.size()));
      g.cell_first.push_back(static_cast<uint32_t>(i));
    }
  g.cell_first.push_back(static_cast<uint32_t>(g.entries.size()));
  g.level_used.assign(kLevels, 0);
  for (uint32_t t = 0; t < T; ++t) g.level_used[g.level[t]] = 1;
  for (size_t ci = 0; ci < g.cells(); ++ci)
    if (g.cell_size(ci) > kCrowdedCell)
      for (uint32_t i = g.cell_first[ci]; i < g.cell_first[ci + 1]; ++i) bad[g.entries[i].second] = 1;
  return g;
}

// The search of pairs within the cap: per thread, each triangle's least lower bound on its
// distance to a triangle it shares no vertex with (the cap where none is nearer).
class ClearanceSearch {
 public:
  ClearanceSearch(const Corners& c, const Grid& g, const SceneFacts& f, std::vector<char>& bad,
                  Clock::time_point t0, double max_seconds)
      : c_(c), g_(g), cap_(f.cap), t0_(t0), max_seconds_(max_seconds), prep_(c.size()) {
    for (uint32_t t = 0; t < c.size(); ++t) {
      prep_[t] = geom::prepare(c.tri[t]);
      if (prep_[t].flat) bad[t] = 1;
    }
    coord_margin_ = std::ldexp(f.coordinate_max, -40);
  }

  // In parallel over cells, then over triangles (up to hardware_concurrency threads, at most 8);
  // the threads' minima. Empty where it gave up past max_seconds.
  std::vector<std::vector<float>> run() {
    const unsigned threads = std::max(1u, std::min(8u, std::thread::hardware_concurrency()));
    threads_ = threads;
    std::vector<std::vector<float>> part(threads,
                                         std::vector<float>(c_.size(), static_cast<float>(cap_)));
    {
      std::vector<std::thread> pool;
      for (unsigned id = 1; id < threads; ++id)
        pool.emplace_back([&, id] { work(id, part[id]); });
      work(0, part[0]);
      for (std::thread& th : pool) th.join();
    }
    if (gave_up_) part.clear();
    return part;
  }

 private:
  bool over_time() {
    if (gave_up_.load(std::memory_order_relaxed)) return true;
    if (!(max_seconds_ > 0)) return false;
    if (ms_since(t0_) / 1000 > max_seconds_) gave_up_ = true;
    return gave_up_.load();
  }

  // A lower bound: the computed distance less its rounding (nearly parallel edges, thin
  // triangles: 2^-19 of the perimeters; coordinates: 2^-40 of the largest).
  double lower_bound(uint32_t a, uint32_t b) const {
    const double d = geom::distance(prep_[a], prep_[b]);
    return std::max(0.0,
                    d - std::ldexp(prep_[a].perimeter + prep_[b].perimeter, -19) - coord_margin_);
  }

  void consider(std::vector<float>& m, uint32_t t, uint32_t u) const {
    const double bd = geom::box_distance(g_.box[t], g_.box[u]);
    if (bd > cap_ || (bd >= m[t] && bd >= m[u]) || c_.shares_vertex(t, u) ||
        geom::separated(prep_[t], prep_[u], std::max(m[t], m[u]) + coord_margin_))
      return;
    const float d = geom::float_below(lower_bound(t, u));
    m[t] = std::min(m[t], d);
    m[u] = std::min(m[u], d);
  }

  void work(unsigned id, std::vector<float>& m) {
    if (same_level_pairs(id, m)) cross_level_pairs(id, m);
  }

  // Pairs of one level: each cell's, where the cell owns them. False where it gave up.
  bool same_level_pairs(unsigned id, std::vector<float>& m) {
    for (size_t ci = id; ci < g_.cells(); ci += threads_) {
      if ((ci & 1023) == id && over_time()) return false;
      const uint32_t b = g_.cell_first[ci], e = g_.cell_first[ci + 1];
      if (e - b > kCrowdedCell) continue;  // (its triangles are bad)
      const uint64_t key = g_.entries[b].first;
      const int64_t cell[3] = {int64_t((key >> 40) & 0xFFFFF) - (1 << 19),
                               int64_t((key >> 20) & 0xFFFFF) - (1 << 19),
                               int64_t(key & 0xFFFFF) - (1 << 19)};
      for (uint32_t i = b; i < e; ++i)
        for (uint32_t j = i + 1; j < e; ++j) {
          const uint32_t t = g_.entries[i].second, u = g_.entries[j].second;
          bool owner = true;
          for (int d = 0; d < 3 && owner; ++d)
            owner = std::max(g_.start[t][d], g_.start[u][d]) == cell[d];
          if (owner) consider(m, t, u);
        }
    }
    return true;
  }

  // Pairs across levels: each triangle looks through the coarser levels' cells.
  void cross_level_pairs(unsigned id, std::vector<float>& m) {
    std::vector<uint32_t> stamp(c_.size(), 0xffffffffu);
    for (uint32_t t = id; t < c_.size(); t += threads_) {
      if ((t & 1023) == 0 && over_time()) return;
      for (int k = g_.level[t] + 1; k <= g_.top; ++k) {
        if (!g_.level_used[k]) continue;
        std::array<int64_t, 6> r;
        g_.cell_range(g_.box[t], k, r);
        for (int64_t x = r[0]; x <= r[3]; ++x)
          for (int64_t y = r[1]; y <= r[4]; ++y)
            for (int64_t z = r[2]; z <= r[5]; ++z) {
              const auto it = g_.cell_of.find(Grid::key_of(k, x, y, z));
              if (it == g_.cell_of.end()) continue;
              const size_t ci = it->second;
              if (g_.cell_size(ci) > kCrowdedCell) {
                m[t] = 0;  // (its triangles are bad; so is t, which comes this near them)
                continue;
              }
              for (uint32_t i = g_.cell_first[ci]; i < g_.cell_first[ci + 1]; ++i) {
                const uint32_t u = g_.entries[i].second;
                if (stamp[u] == t) continue;
                stamp[u] = t;
                consider(m, t, u);
              }
            }
      }
    }
  }

  const Corners& c_;
  const Grid& g_;
  const double cap_;
  const Clock::time_point t0_;
  const double max_seconds_;
  std::vector<Prepared> prep_;
  double coord_margin_ = 0;
  unsigned threads_ = 1;
  std::atomic<bool> gave_up_{false};
};

// f's clearances from the threads' minima (0 for the bad), the isolated count and the bins.
void set_clearances(const std::vector<std::vector<float>>& part, const std::vector<char>& bad,
                    SceneFacts& f) {
  for (size_t t = 0; t < f.clearance.size(); ++t) {
    float m = static_cast<float>(f.cap);
    for (const std::vector<float>& p : part) m = std::min(m, p[t]);
    f.clearance[t] = bad[t] ? 0.0f : m;
    if (!bad[t] && m >= static_cast<float>(f.cap)) ++f.isolated;
    int k = 63;
    if (f.clearance[t] > 0)
      k = std::clamp(int(std::floor(std::log2(f.cap / f.clearance[t]))), 0, 63);
    ++f.clearance_bins[k];
  }
}

}  // namespace

double triangle_distance(const geom::Tri& a, const geom::Tri& b) {
  return geom::distance(geom::prepare(a), geom::prepare(b));
}

SceneFacts find_scene_facts(const Scene& scene, double max_seconds) {
  const Clock::time_point t0 = Clock::now();
  SceneFacts f;
  if (scene.triangle_count() > kMaxFactsTriangles) {
    f.ms = ms_since(t0);
    return f;  // (cap 0: none)
  }
  const Corners corners = gather_corners(scene, f);
  const uint32_t T = corners.size();
  f.clearance.assign(T, 0.0f);
  f.adj_offset.assign(size_t(T) + 1, 0);
  const double diag = vec3::length(vec3::sub(f.bounds.hi, f.bounds.lo));
  if (T == 0 || !(diag > 0) || !std::isfinite(diag)) return f;  // cap 0: no facts
  f.cap = geom::float_below(std::ldexp(diag, -13));  // (a float: clearances are floats below it)

  std::vector<char> bad(T, 0);  // clearance 0 whatever the distances say
  list_neighbours(corners, vertex_triangles(corners, bad), bad, f);
  const Grid grid = build_grid(corners, f, bad);
  const std::vector<std::vector<float>> part =
      ClearanceSearch(corners, grid, f, bad, t0, max_seconds).run();
  if (part.empty()) {  // past max_seconds: no facts (the frames search as without them)
    f.cap = 0;
    f.clearance.assign(T, 0.0f);
    f.timed_out = true;
    f.ms = ms_since(t0);
    return f;
  }
  set_clearances(part, bad, f);
  f.ms = ms_since(t0);
  return f;
}

}  // namespace vismap::facts
