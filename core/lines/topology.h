// Mesh topology for the line drawings (core/lines/lines.cpp) and their check
// (core/lines/line_check.cpp): vertices matched by position, undirected edges and the triangles
// that use them.
#pragma once

#include <cstdint>
#include <vector>

#include "core/scene.h"
#include "core/util/flat_map.h"
#include "core/util/weld.h"

namespace vismap::lines_detail {

inline uint64_t pair_key(uint32_t a, uint32_t b) {
  return uint64_t(a) << 32 | b;
}

// Per mesh: vertices matched by position (so soup and split-vertex meshes have edges), and
// how many triangles use each undirected edge.
struct Topology {
  bool built = false;
  std::vector<uint32_t> canon;  // per vertex: the first vertex at its position
  std::vector<uint32_t> uses;   // per edge id: triangles using it
  std::vector<uint32_t> tris;   // per edge id: the first two triangles using it (~0u: none)
  std::vector<uint8_t> side;    // per edge id: the first triangle's corner k where the edge starts
  FlatMap edge{0};              // (lo, hi) canonical vertex pair -> edge id

  void build(const Mesh& m) {
    built = true;
    const size_t nv = m.vertex_count(), nt = m.triangle_count();
    canon = weld_first(m.positions.data(), nv);
    edge = FlatMap(3 * nt);
    uses.clear();
    for (size_t t = 0; t < nt; ++t)
      for (int k = 0; k < 3; ++k) {
        const uint64_t key = undirected(m, t, k);
        auto [id, fresh] = edge.emplace(key, uint32_t(uses.size()));
        if (fresh) {
          uses.push_back(1);
          tris.push_back(uint32_t(t));
          tris.push_back(~0u);
          side.push_back(uint8_t(k));
        } else if (++uses[id] == 2) {
          tris[2 * size_t(id) + 1] = uint32_t(t);
        }
      }
  }
  uint32_t vertex(const Mesh& m, size_t t, int k) const { return canon[m.indices[3 * t + k]]; }
  uint64_t undirected(const Mesh& m, size_t t, int k) const {
    const uint32_t a = vertex(m, t, k), b = vertex(m, t, (k + 1) % 3);
    return a < b ? pair_key(a, b) : pair_key(b, a);
  }
  uint32_t edge_uses(const Mesh& m, size_t t, int k) const {
    const uint32_t* id = edge.find(undirected(m, t, k));
    return id ? uses[*id] : 0;
  }
  // Are vertices u and v one, or joined by a mesh edge?
  bool adjacent(uint32_t u, uint32_t v) const {
    return u == v || edge.find(u < v ? pair_key(u, v) : pair_key(v, u)) != nullptr;
  }
  // Is triangle b within two rings of triangle a (a vertex of b at or next to one of a's: some
  // triangle shares a vertex with each)?
  bool within_two_rings(const Mesh& m, size_t a, size_t b) const {
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j)
        if (adjacent(vertex(m, a, i), vertex(m, b, j))) return true;
    return false;
  }
};

}  // namespace vismap::lines_detail
