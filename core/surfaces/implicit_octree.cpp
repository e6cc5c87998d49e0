#include "core/surfaces/implicit_octree.h"

#include <cmath>

#include "core/error.h"

namespace vismap::surfaces {

namespace {

// Open addressing from 64-bit keys (never ~0; here octree nodes) to 32-bit values.
class KeyTable {
 public:
  explicit KeyTable(size_t expect) {
    size_t cap = 16;
    while (cap < 2 * expect) cap <<= 1;
    keys_.assign(cap, ~uint64_t(0));
    vals_.resize(cap);
  }
  void insert(uint64_t key, uint32_t value) {
    size_t i = hash(key) & (keys_.size() - 1);
    while (keys_[i] != ~uint64_t(0) && keys_[i] != key) i = (i + 1) & (keys_.size() - 1);
    keys_[i] = key;
    vals_[i] = value;
  }
  // The value of `key`, or ~0u.
  uint32_t find(uint64_t key) const {
    size_t i = hash(key) & (keys_.size() - 1);
    while (keys_[i] != ~uint64_t(0)) {
      if (keys_[i] == key) return vals_[i];
      i = (i + 1) & (keys_.size() - 1);
    }
    return ~0u;
  }

 private:
  static size_t hash(uint64_t k) {
    k ^= k >> 31;
    k *= 0x9E3779B97F4A7C15ull;
    return size_t(k ^ (k >> 29));
  }
  std::vector<uint64_t> keys_;
  std::vector<uint32_t> vals_;
};

// A node: its level and its index along each axis at that level (< 2^16 each).
uint64_t node_key(uint32_t level, uint64_t i, uint64_t j, uint64_t k) {
  return (((uint64_t(level) << 17 | i) << 17 | j) << 17) | k;
}

constexpr int kEdges[12][2] = {{0, 1}, {2, 3}, {4, 5}, {6, 7}, {0, 2}, {1, 3},
                               {4, 6}, {5, 7}, {0, 4}, {1, 5}, {2, 6}, {3, 7}};
// The quadrants around an edge along axis ax, counter-clockwise about it: the signs along
// a = ax + 1 and b = ax + 2 (mod 3).
constexpr int kQuadrants[4][2] = {{-1, -1}, {1, -1}, {1, 1}, {-1, 1}};

class Contour {
 public:
  Contour(const OctreeLeaves& c, const std::vector<float>& val, const OctreeGrid& g)
      : c_(c), val_(val), g_(g), nodes_(c.level.size()), vertex_(c.level.size(), ~0u) {
    for (size_t l = 0; l < c.level.size(); ++l) {
      const uint32_t sh = g.levels - c.level[l];
      nodes_.insert(
          node_key(c.level[l], c.gi[3 * l] >> sh, c.gi[3 * l + 1] >> sh, c.gi[3 * l + 2] >> sh),
          uint32_t(l));
    }
  }

  // The polygons of leaf l's minimal edges that it is the first smallest leaf of.
  void leaf_polygons(uint32_t l, DualMesh& m) {
    const float* f = &val_[8 * size_t(l)];
    const uint32_t lv = c_.level[l];
    const uint64_t step = uint64_t(1) << (g_.levels - lv);
    for (const auto& e : kEdges) {
      const int u = e[0], v = e[1];
      if ((f[u] < 0) == (f[v] < 0)) continue;
      const int ax = v - u == 1 ? 0 : v - u == 2 ? 1 : 2;
      const int a = (ax + 1) % 3, b = (ax + 2) % 3;
      int64_t P[3];  // the edge's low end, in halves of the finest unit
      for (int k = 0; k < 3; ++k) P[k] = 2 * int64_t(c_.gi[3 * l + k] + ((u >> k) & 1) * step);
      const int own_a = (u >> a) & 1 ? -1 : 1, own_b = (u >> b) & 1 ? -1 : 1;
      uint32_t owner[4], owner_level[4];
      bool ok = true, first = true;
      for (int q = 0; q < 4 && ok; ++q) {
        if (kQuadrants[q][0] == own_a && kQuadrants[q][1] == own_b) {
          owner[q] = l, owner_level[q] = lv;
          continue;
        }
        int64_t X[3] = {P[0], P[1], P[2]};
        X[ax] += int64_t(step);  // the edge's midpoint, moved half a finest unit into quadrant q
        X[a] += kQuadrants[q][0];
        X[b] += kQuadrants[q][1];
        ok = find(X, lv, owner[q], owner_level[q]);
        // Another smallest leaf before this one in quadrant order finds the edge.
        if (ok && owner_level[q] == lv && q < quadrant_of(own_a, own_b)) first = false;
      }
      if (!ok || !first) continue;
      if (!(f[u] < 0)) std::swap(owner[1], owner[3]);  // the normal out of the solid
      emit(owner, l, m);
    }
  }

 private:
  static int quadrant_of(int sa, int sb) {
    for (int q = 0; q < 4; ++q)
      if (kQuadrants[q][0] == sa && kQuadrants[q][1] == sb) return q;
    return -1;
  }

  // The leaf holding the point X (in halves of the finest unit) at level lv or coarser: the
  // quadrant's terminal node, when it is a leaf no smaller than the edge's. Else (a smaller leaf
  // subdivides the edge, or the node there is full, empty or culled) false.
  bool find(const int64_t X[3], uint32_t lv, uint32_t& leaf, uint32_t& level) const {
    const int64_t end = int64_t(2) << g_.levels;
    for (int k = 0; k < 3; ++k)
      if (X[k] < 0 || X[k] >= end) return false;  // outside the cube: f >= 0 there (clipped)
    for (int64_t l = lv; l >= 0; --l) {
      const uint32_t sh = g_.levels - uint32_t(l) + 1;
      leaf = nodes_.find(
          node_key(uint32_t(l), uint64_t(X[0]) >> sh, uint64_t(X[1]) >> sh, uint64_t(X[2]) >> sh));
      if (leaf != ~0u) {
        level = uint32_t(l);
        return true;
      }
    }
    return false;
  }

  // The polygon of the leaves owner[0..3] around an edge whose smallest leaf is l.
  void emit(const uint32_t owner[4], uint32_t l, DualMesh& m) {
    uint32_t p[4];
    int n = 0, at_l = 0;
    bool one_level = true;
    for (int q = 0; q < 4; ++q) {
      one_level = one_level && c_.level[owner[q]] == c_.level[l];
      if (owner[q] == owner[(q + 3) % 4]) continue;
      if (owner[q] == l) at_l = n;
      p[n++] = vertex(owner[q], m);
    }
    if (n == 3) {
      m.indices.insert(m.indices.end(), p, p + 3);
      return;
    }
    if (n != 4) return;  // cannot happen: a box around an edge holds it in a face or an edge
    // Leaves of one side: along the shorter diagonal. Of several: along the diagonal through the
    // smallest, so that no triangle is made of larger leaves alone: the halves of a larger leaf's
    // edge that smaller leaves subdivide have polygons around the same three larger leaves (the
    // surface crosses the edge twice), and two such triangles would be one triangle twice, once
    // each way round (a fold whose edges four triangles share).
    const auto d2 = [&](uint32_t x, uint32_t y) {
      double s2 = 0;
      for (int k = 0; k < 3; ++k)
        s2 += (m.opos[3 * x + k] - m.opos[3 * y + k]) * (m.opos[3 * x + k] - m.opos[3 * y + k]);
      return s2;
    };
    const bool diag02 = one_level ? d2(p[0], p[2]) <= d2(p[1], p[3]) : at_l % 2 == 0;
    if (diag02) {
      const uint32_t t[6] = {p[0], p[1], p[2], p[0], p[2], p[3]};
      m.indices.insert(m.indices.end(), t, t + 6);
    } else {
      const uint32_t t[6] = {p[0], p[1], p[3], p[1], p[2], p[3]};
      m.indices.insert(m.indices.end(), t, t + 6);
    }
  }

  // Leaf l's vertex, made on first use: the mean of its own edges' crossings, else its centre.
  uint32_t vertex(uint32_t l, DualMesh& m) {
    if (vertex_[l] != ~0u) return vertex_[l];
    const float* f = &val_[8 * size_t(l)];
    const uint64_t step = uint64_t(1) << (g_.levels - c_.level[l]);
    double acc[3] = {0, 0, 0};
    int nc = 0;
    for (const auto& e : kEdges) {
      const int u = e[0], v = e[1];
      if ((f[u] < 0) == (f[v] < 0)) continue;
      const double fa = f[u], fb = f[v], t = fa / (fa - fb);
      for (int k = 0; k < 3; ++k) {
        const double x0 = g_.at(k, c_.gi[3 * l + k] + ((u >> k) & 1) * step);
        const double x1 = g_.at(k, c_.gi[3 * l + k] + ((v >> k) & 1) * step);
        acc[k] += x0 + t * (x1 - x0);
      }
      ++nc;
    }
    vertex_[l] = uint32_t(m.vleaf.size());
    for (int k = 0; k < 3; ++k)
      m.opos.push_back(nc ? acc[k] / nc : g_.at(k, c_.gi[3 * l + k]) + 0.5 * step * g_.unit);
    m.vleaf.push_back(l);
    return vertex_[l];
  }

  const OctreeLeaves& c_;
  const std::vector<float>& val_;
  const OctreeGrid& g_;
  KeyTable nodes_;
  std::vector<uint32_t> vertex_;
};

}  // namespace

OctreeLeaves octree_leaves(const ImplicitQueue& q, const OctreeGrid& g) {
  const size_t nl = q.leaves.size();
  OctreeLeaves c;
  c.level.resize(nl);
  c.gi.resize(3 * nl);
  c.xyz.resize(24 * nl);
  for (size_t l = 0; l < nl; ++l) {
    const VmIRegion& L = q.leaves[l];
    const uint32_t lv = uint32_t(std::lround(std::log2(double(g.size) / double(L.size))));
    c.level[l] = uint8_t(lv);
    c.finest = std::max(c.finest, lv);
    const uint64_t step = uint64_t(1) << (g.levels - lv);
    for (int k = 0; k < 3; ++k)
      c.gi[3 * l + k] = uint32_t(std::llround((double(L.lo[k]) - g.lo[k]) / g.unit));
    for (int v = 0; v < 8; ++v)
      for (int k = 0; k < 3; ++k)
        c.xyz[24 * l + 3 * v + k] = float(g.at(k, c.gi[3 * l + k] + ((v >> k) & 1) * step));
  }
  return c;
}

DualMesh dual_contour(const OctreeLeaves& c, const std::vector<float>& val, const OctreeGrid& g,
                      const std::string& name) {
  const size_t nl = c.level.size();
  for (size_t l = 0; l < nl; ++l)
    for (int v = 0; v < 8; ++v)
      if (std::isnan(val[8 * l + v])) {
        const float* P = &c.xyz[24 * l + 3 * v];
        throw InputError(InputErrorKind::NonFiniteVertex, "", name, "expression", -1,
                         "f is not a number at (" + std::to_string(P[0]) + ", " +
                             std::to_string(P[1]) + ", " + std::to_string(P[2]) + ")");
      }
  DualMesh m;
  Contour contour(c, val, g);
  for (size_t l = 0; l < nl; ++l) contour.leaf_polygons(uint32_t(l), m);
  return m;
}

}  // namespace vismap::surfaces
