#include "core/stages/scene_facts.h"

#include <algorithm>
#include <atomic>
#include <array>
#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>
#include <numbers>
#include <thread>
#include <unordered_map>

#include "core/util/vec3.h"
#include "core/util/weld.h"
#include "kernels/layout.h"

namespace vismap::stages {

namespace {

using vec3::V;
using Tri = std::array<V, 3>;
using vec3::cross;
using vec3::dot;
using vec3::sub;
using vec3::length;
V along(const V& a, const V& d, double s) { return {a[0] + d[0] * s, a[1] + d[1] * s, a[2] + d[2] * s}; }

// Distance from p to segment [a, b].
double point_segment(const V& p, const V& a, const V& b) {
  const V d = sub(b, a);
  const double dd = dot(d, d);
  const double s = dd > 0 ? std::clamp(dot(sub(p, a), d) / dd, 0.0, 1.0) : 0.0;
  return length(sub(p, along(a, d, s)));
}

// Distance between segments [p1, q1] and [p2, q2] (the closest points of Ericson's Real-Time
// Collision Detection 5.1.9), never more than the four endpoint-to-segment distances. Where
// the segments are nearly parallel the interior solution is ill-conditioned; the caller's
// margin covers it (scene_facts.h, NUMERICS §2).
double segment_segment(const V& p1, const V& q1, const V& p2, const V& q2) {
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

Prepared prepare(const Tri& t) {
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
bool inside(const Prepared& t, const V& x) {
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

double point_triangle(const V& p, const Prepared& t) {
  double best = std::min({point_segment(p, t.v[0], t.v[1]), point_segment(p, t.v[1], t.v[2]),
                          point_segment(p, t.v[2], t.v[0])});
  if (t.flat) return best;
  const double h = dot(sub(p, t.v[0]), t.n) / t.nl;
  const V foot = along(p, t.n, -h / t.nl);
  if (inside(t, foot)) best = std::min(best, std::fabs(h));
  return best;
}

// Does segment [p, q] meet t (closure, with the tolerance of `inside`)?
bool segment_meets(const V& p, const V& q, const Prepared& t) {
  if (t.flat) return false;  // (its edges are compared as segments)
  const double sp = dot(sub(p, t.v[0]), t.n), sq = dot(sub(q, t.v[0]), t.n);
  if ((sp > 0 && sq > 0) || (sp < 0 && sq < 0)) return false;
  if (sp == sq) return false;  // in the plane: the edge and point distances see it
  return inside(t, along(p, sub(q, p), sp / (sp - sq)));
}

double distance(const Prepared& a, const Prepared& b) {
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
bool separated(const Prepared& a, const Prepared& b, double gap) {
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
float float_below(double x) {
  float f = static_cast<float>(x);
  if (static_cast<double>(f) > x) f = std::nextafter(f, 0.0f);
  return std::max(f, 0.0f);
}

struct Box {
  V lo, hi;
};

double box_distance(const Box& a, const Box& b) {
  double s = 0;
  for (int k = 0; k < 3; ++k) {
    const double g = std::max({0.0, a.lo[k] - b.hi[k], b.lo[k] - a.hi[k]});
    s += g * g;
  }
  return std::sqrt(s);
}

}  // namespace

double triangle_distance(const Tri& a, const Tri& b) { return distance(prepare(a), prepare(b)); }

SceneFacts find_scene_facts(const Scene& scene, double max_seconds) {
  const auto t0 = std::chrono::steady_clock::now();
  std::atomic<bool> gave_up{false};
  auto over_time = [&] {
    if (gave_up.load(std::memory_order_relaxed)) return true;
    if (!(max_seconds > 0)) return false;
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (s > max_seconds) gave_up = true;
    return gave_up.load();
  };
  SceneFacts f;
  if (scene.triangle_count() > kMaxFactsTriangles) {
    f.ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    return f;  // (cap 0: none)
  }
  // Every triangle's corners, and canonical vertex ids by exact position (util/weld.h, across
  // meshes): a vertex's id is the first vertex at its place.
  std::vector<Tri> tri;
  std::vector<std::array<uint32_t, 3>> corner;
  std::vector<uint32_t> vbase;
  uint32_t nv = 0;
  for (const Mesh& m : scene.meshes) {
    vbase.push_back(nv);
    nv += static_cast<uint32_t>(m.vertex_count());
  }
  std::vector<uint32_t> canon(nv);
  {
    Weld<float, 3> weld(nv);
    for (size_t mi = 0; mi < scene.meshes.size(); ++mi) {
      const Mesh& m = scene.meshes[mi];
      for (size_t v = 0; v < m.vertex_count(); ++v) {
        const uint32_t id = vbase[mi] + static_cast<uint32_t>(v);
        canon[id] = weld.add(&m.positions[3 * v], id).first;
      }
    }
  }
  const uint32_t nc = nv;  // (ids are vertex ids: some unused)
  bool any = false;
  for (size_t mi = 0; mi < scene.meshes.size(); ++mi) {
    const Mesh& m = scene.meshes[mi];
    for (size_t t = 0; t < m.triangle_count(); ++t) {
      Tri x;
      std::array<uint32_t, 3> c;
      for (int k = 0; k < 3; ++k) {
        const uint32_t v = m.indices[3 * t + k];
        c[k] = canon[vbase[mi] + v];
        for (int d = 0; d < 3; ++d) {
          x[k][d] = m.positions[3 * v + d];
          f.bounds.lo[d] = any ? std::min(f.bounds.lo[d], x[k][d]) : x[k][d];
          f.bounds.hi[d] = any ? std::max(f.bounds.hi[d], x[k][d]) : x[k][d];
          f.coordinate_max = std::max(f.coordinate_max, std::fabs(x[k][d]));
        }
        any = true;
      }
      tri.push_back(x);
      corner.push_back(c);
    }
  }
  const uint32_t T = static_cast<uint32_t>(tri.size());
  f.clearance.assign(T, 0.0f);
  f.adj_offset.assign(size_t(T) + 1, 0);
  const double diag = length(sub(f.bounds.hi, f.bounds.lo));
  if (T == 0 || !(diag > 0) || !std::isfinite(diag)) return f;  // cap 0: no facts
  f.cap = float_below(std::ldexp(diag, -13));  // (a float: clearances are floats not above it)

  // Triangles at each canonical vertex (once each), and the crowded vertices.
  std::vector<uint32_t> vcount(size_t(nc) + 1, 0);
  std::vector<char> bad(T, 0);  // clearance 0 whatever the distances say
  for (uint32_t t = 0; t < T; ++t) {
    const auto& c = corner[t];
    if (c[0] == c[1] || c[1] == c[2] || c[0] == c[2]) bad[t] = 1;
    for (int k = 0; k < 3; ++k)
      if (k == 0 || (c[k] != c[0] && (k == 1 || c[k] != c[1]))) ++vcount[c[k] + 1];
  }
  for (uint32_t v = 0; v < nc; ++v) vcount[v + 1] += vcount[v];
  std::vector<uint32_t> vtri(vcount[nc]), cursor(vcount.begin(), vcount.end() - 1);
  for (uint32_t t = 0; t < T; ++t) {
    const auto& c = corner[t];
    for (int k = 0; k < 3; ++k)
      if (k == 0 || (c[k] != c[0] && (k == 1 || c[k] != c[1]))) vtri[cursor[c[k]]++] = t;
  }
  auto crowded_vertex = [&](uint32_t v) { return vcount[v + 1] - vcount[v] > kMaxValence; };
  // Neighbours u > t through vertices that are not crowded (through a crowded one both are bad:
  // the frame's own search finds such pairs).
  std::vector<uint32_t> nb;
  for (uint32_t t = 0; t < T; ++t) {
    nb.clear();
    for (int k = 0; k < 3; ++k) {
      const uint32_t v = corner[t][k];
      if (crowded_vertex(v)) {
        bad[t] = 1;
        continue;
      }
      for (uint32_t i = vcount[v]; i < vcount[v + 1]; ++i)
        if (vtri[i] > t) nb.push_back(vtri[i]);
    }
    std::sort(nb.begin(), nb.end());
    nb.erase(std::unique(nb.begin(), nb.end()), nb.end());
    f.adj.insert(f.adj.end(), nb.begin(), nb.end());
    f.adj_offset[t + 1] = static_cast<uint32_t>(f.adj.size());
  }
  auto shares_vertex = [&](uint32_t a, uint32_t b) {
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j)
        if (corner[a][i] == corner[b][j]) return true;
    return false;
  };

  // The grids: level k has cells of h 4^k (h about a triangle's size, at least 2 caps), and
  // each triangle sits in the finest level where its grown box spans at most kMaxCells cells. A
  // pair within the cap is found once: in one level by the cell that owns it, across levels by
  // the finer member looking through the coarser levels' cells.
  std::vector<Box> box(T);
  std::vector<double> extent(T);
  for (uint32_t t = 0; t < T; ++t) {
    for (int d = 0; d < 3; ++d) {
      box[t].lo[d] = std::min({tri[t][0][d], tri[t][1][d], tri[t][2][d]});
      box[t].hi[d] = std::max({tri[t][0][d], tri[t][1][d], tri[t][2][d]});
    }
    extent[t] = std::max({box[t].hi[0] - box[t].lo[0], box[t].hi[1] - box[t].lo[1],
                          box[t].hi[2] - box[t].lo[2]});
  }
  std::vector<double> sorted_extent = extent;
  std::nth_element(sorted_extent.begin(), sorted_extent.begin() + T / 2, sorted_extent.end());
  const double h0 = std::max(2 * f.cap, sorted_extent[T / 2]);
  constexpr uint64_t kMaxCells = 64, kCrowdedCell = 256;
  constexpr int kLevels = 15;
  const V& lo = f.bounds.lo;
  auto cell_range = [&](const Box& b, double grow, int level, std::array<int64_t, 6>& r) {
    const double h = std::ldexp(h0, 2 * level);
    uint64_t n = 1;
    for (int d = 0; d < 3; ++d) {
      r[d] = static_cast<int64_t>(std::floor((b.lo[d] - grow - lo[d]) / h));
      r[d + 3] = static_cast<int64_t>(std::floor((b.hi[d] + grow - lo[d]) / h));
      n *= uint64_t(r[d + 3] - r[d] + 1);
    }
    return n;
  };
  // Cell coordinates stay within +-2^19 (level 0 has at most diag / 2 caps = 2^12 cells a side).
  auto key_of = [](int level, int64_t x, int64_t y, int64_t z) {
    return (uint64_t(level) << 60) | (uint64_t(x + (1 << 19)) << 40) |
           (uint64_t(y + (1 << 19)) << 20) | uint64_t(z + (1 << 19));
  };
  // Each triangle is in every cell of its level that its box grown by half the cap meets: two
  // triangles within the cap of each other meet in a cell, and one cell owns their pair (the
  // one holding the low corner of their grown boxes' overlap: the larger of their start cells).
  const double half = f.cap / 2;
  std::vector<std::pair<uint64_t, uint32_t>> entries;
  std::vector<uint8_t> level(T, 0);
  std::vector<std::array<int64_t, 3>> start(T);
  int top = 0;
  for (uint32_t t = 0; t < T; ++t) {
    std::array<int64_t, 6> r;
    int k = 0;
    while (k + 1 < kLevels && cell_range(box[t], half, k, r) > kMaxCells) ++k;
    cell_range(box[t], half, k, r);
    level[t] = static_cast<uint8_t>(k);
    start[t] = {r[0], r[1], r[2]};
    top = std::max(top, k);
    for (int64_t x = r[0]; x <= r[3]; ++x)
      for (int64_t y = r[1]; y <= r[4]; ++y)
        for (int64_t z = r[2]; z <= r[5]; ++z) entries.push_back({key_of(k, x, y, z), t});
  }
  std::sort(entries.begin(), entries.end());
  // key -> index into cell_first, for the cells above level 0 (the only ones looked up: across
  // levels, a finer triangle looks through the coarser levels' cells).
  std::unordered_map<uint64_t, uint32_t> cell_of;
  std::vector<uint32_t> cell_first;
  for (size_t i = 0; i < entries.size(); ++i)
    if (i == 0 || entries[i].first != entries[i - 1].first) {
      if (entries[i].first >> 60) cell_of.emplace(entries[i].first, uint32_t(cell_first.size()));
      cell_first.push_back(static_cast<uint32_t>(i));
    }
  cell_first.push_back(static_cast<uint32_t>(entries.size()));
  std::vector<char> level_used(kLevels, 0);
  for (uint32_t t = 0; t < T; ++t) level_used[level[t]] = 1;
  for (size_t c = 0; c + 1 < cell_first.size(); ++c)
    if (cell_first[c + 1] - cell_first[c] > kCrowdedCell)
      for (uint32_t i = cell_first[c]; i < cell_first[c + 1]; ++i) bad[entries[i].second] = 1;

  std::vector<Prepared> prep(T);
  for (uint32_t t = 0; t < T; ++t) {
    prep[t] = prepare(tri[t]);
    if (prep[t].flat) bad[t] = 1;
  }
  // A lower bound: the computed distance less its rounding (nearly parallel edges, thin
  // triangles: 2^-19 of the perimeters; coordinates: 2^-40 of the largest).
  const double coord_margin = std::ldexp(f.coordinate_max, -40);
  auto lower_bound = [&](uint32_t a, uint32_t b) {
    const double d = distance(prep[a], prep[b]);
    return std::max(0.0, d - std::ldexp(prep[a].perimeter + prep[b].perimeter, -19) - coord_margin);
  };

  // In parallel over cells, then over t; each thread keeps its own minima, merged after.
  const unsigned threads = std::max(1u, std::min(8u, std::thread::hardware_concurrency()));
  std::vector<std::vector<float>> part(threads, std::vector<float>(T, static_cast<float>(f.cap)));
  auto consider = [&](std::vector<float>& c, uint32_t t, uint32_t u) {
    const double bd = box_distance(box[t], box[u]);
    if (bd > f.cap || (bd >= c[t] && bd >= c[u]) || shares_vertex(t, u) ||
        separated(prep[t], prep[u], std::max(c[t], c[u]) + coord_margin))
      return;
    const float d = float_below(lower_bound(t, u));
    c[t] = std::min(c[t], d);
    c[u] = std::min(c[u], d);
  };
  const size_t cells = cell_first.size() - 1;
  auto work = [&](unsigned id) {
    std::vector<float>& c = part[id];
    // Pairs of one level: each cell's, where the cell owns them.
    for (size_t ci = id; ci < cells; ci += threads) {
      if ((ci & 1023) == id && over_time()) return;
      const uint32_t b = cell_first[ci], e = cell_first[ci + 1];
      if (e - b > kCrowdedCell) continue;  // (its triangles are bad)
      const uint64_t key = entries[b].first;
      const int64_t cell[3] = {int64_t((key >> 40) & 0xFFFFF) - (1 << 19),
                               int64_t((key >> 20) & 0xFFFFF) - (1 << 19),
                               int64_t(key & 0xFFFFF) - (1 << 19)};
      for (uint32_t i = b; i < e; ++i)
        for (uint32_t j = i + 1; j < e; ++j) {
          const uint32_t t = entries[i].second, u = entries[j].second;
          bool owner = true;
          for (int d = 0; d < 3 && owner; ++d) owner = std::max(start[t][d], start[u][d]) == cell[d];
          if (owner) consider(c, t, u);
        }
    }
    // Pairs across levels: each triangle looks through the coarser levels' cells.
    std::vector<uint32_t> stamp(T, 0xffffffffu);
    for (uint32_t t = id; t < T; t += threads) {
      if ((t & 1023) == 0 && over_time()) return;
      for (int k = level[t] + 1; k <= top; ++k) {
        if (!level_used[k]) continue;
        std::array<int64_t, 6> r;
        cell_range(box[t], half, k, r);
        for (int64_t x = r[0]; x <= r[3]; ++x)
          for (int64_t y = r[1]; y <= r[4]; ++y)
            for (int64_t z = r[2]; z <= r[5]; ++z) {
              const auto it = cell_of.find(key_of(k, x, y, z));
              if (it == cell_of.end()) continue;
              const size_t ci = it->second;
              if (cell_first[ci + 1] - cell_first[ci] > kCrowdedCell) {
                c[t] = 0;  // (its triangles are bad; so is t, which comes this near them)
                continue;
              }
              for (uint32_t i = cell_first[ci]; i < cell_first[ci + 1]; ++i) {
                const uint32_t u = entries[i].second;
                if (stamp[u] == t) continue;
                stamp[u] = t;
                consider(c, t, u);
              }
            }
      }
    }
  };
  {
    std::vector<std::thread> pool;
    for (unsigned id = 1; id < threads; ++id) pool.emplace_back(work, id);
    work(0);
    for (std::thread& th : pool) th.join();
  }
  if (gave_up) {  // past max_seconds: no facts (the frames search as without them)
    f.cap = 0;
    f.clearance.assign(T, 0.0f);
    f.timed_out = true;
    f.ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    return f;
  }
  for (uint32_t t = 0; t < T; ++t) {
    float m = static_cast<float>(f.cap);
    for (unsigned id = 0; id < threads; ++id) m = std::min(m, part[id][t]);
    f.clearance[t] = bad[t] ? 0.0f : m;
    if (!bad[t] && m >= static_cast<float>(f.cap)) ++f.isolated;
    int k = 63;
    if (f.clearance[t] > 0) k = std::clamp(int(std::floor(std::log2(f.cap / f.clearance[t]))), 0, 63);
    ++f.clearance_bins[k];
  }
  f.ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  return f;
}

double apart_fraction(const SceneFacts& facts, double need) {
  if (facts.clearance.empty()) return 0;
  uint64_t n = 0;
  for (int k = 0; k < 63; ++k)
    if (std::ldexp(facts.cap, -(k + 1)) >= need) n += facts.clearance_bins[k];
  return double(n) / double(facts.clearance.size());
}

double crossing_skip_distance(const SceneFacts& facts, const Camera& cam, double* qmax) {
  constexpr double kOff = std::numeric_limits<double>::infinity();
  if (qmax) *qmax = kOff;
  if (!(facts.cap > 0) || cam.projection != Camera::Projection::Perspective) return kOff;
  const double n = cam.near_plane, far = cam.far_plane;
  if (!(n > 0) || !(far > n)) return kOff;
  // The nearest and farthest depth w (clip w: distance along the view axis) of any point of a
  // screen triangle: the scene's box (w is affine; its extremes are at corners) within the
  // near and far planes.
  const Mat4 vp = cam.view_projection();
  double wlo = kOff, whi = -kOff;
  for (int c = 0; c < 8; ++c) {
    const double x = (c & 1) ? facts.bounds.hi[0] : facts.bounds.lo[0];
    const double y = (c & 2) ? facts.bounds.hi[1] : facts.bounds.lo[1];
    const double z = (c & 4) ? facts.bounds.hi[2] : facts.bounds.lo[2];
    const double w = vp[3] * x + vp[7] * y + vp[11] * z + vp[15];
    wlo = std::min(wlo, w);
    whi = std::max(whi, w);
  }
  const double wmin = std::max(wlo, n), wmax = std::min(whi, far);
  if (!(wmax >= wmin)) return kOff;  // nothing of the scene in depth range
  const double cot = 1.0 / std::tan(cam.fov_y_deg * std::numbers::pi / 360.0);
  const double aspect = double(cam.width) / double(cam.height);
  // Grid units per unit of tangent (square pixels), and the longest ray per unit of depth
  // within the frustum (the screen triangles are clipped to it).
  const double K = cot * cam.height * VM_GRID_SCALE / 2;
  const double L = std::sqrt(1 + (aspect / cot) * (aspect / cot) + 1 / (cot * cot));
  // NUMERICS §2 "Pairs far apart in 3D": a point of a snapped triangle is within E of the
  // unsnapped triangle (a vertex snap of <= 0.75 grid units, at most wmax deep; depth-plane
  // snapping of 2^-24 of the largest nearness, in depth, along a ray); two triangles farther
  // apart than 2E + L dw are at least dw apart in depth along every ray through both, and
  // dw >= (1e-6 + 2^-18) wmax^2 / wmin keeps their nearness difference past the tie band
  // (1e-6 of the largest nearness) and the overlap's rounding (the kernels leave out
  // triangles steeper than 16 qmax per grid unit).
  const double E = 0.75 * wmax / K + std::ldexp(wmax * wmax / wmin, -23) * L;
  const double dw = (1e-6 + std::ldexp(1.0, -18)) * wmax * wmax / wmin;
  const double need = (2 * E + L * dw) * (1 + std::ldexp(1.0, -20)) +
                      std::ldexp(facts.coordinate_max + std::fabs(cam.eye[0]) +
                                     std::fabs(cam.eye[1]) + std::fabs(cam.eye[2]),
                                 -36);
  if (qmax) *qmax = 1.0 / wmin;
  if (!(need < facts.cap)) return kOff;  // no clearance can pass it
  return need;
}

}  // namespace vismap::stages
