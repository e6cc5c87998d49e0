#include "core/util/mesh_topology.h"

#include <algorithm>
#include <utility>
#include <vector>

#include "core/util/weld.h"

namespace vismap {

int8_t closed_orientation(const Mesh& m) {
  const size_t nt = m.triangle_count();
  if (nt < 4) return 0;
  std::vector<uint32_t> weld = weld_first(m.positions.data(), m.vertex_count());
  // Closed and consistently oriented: every undirected edge is used exactly twice, once in each
  // direction. Sort the edges by (min, max) with the direction in the low bit.
  std::vector<uint64_t> edges;
  edges.reserve(nt * 3);
  for (size_t t = 0; t < nt; ++t)
    for (int k = 0; k < 3; ++k) {
      uint64_t a = weld[m.indices[3 * t + k]], b = weld[m.indices[3 * t + (k + 1) % 3]];
      if (a == b) return 0;
      edges.push_back(a < b ? (a << 33) | (b << 1) : (b << 33) | (a << 1) | 1);
    }
  std::sort(edges.begin(), edges.end());
  for (size_t i = 0; i < edges.size(); i += 2) {
    if (i + 1 >= edges.size()) return 0;
    // A pair must be the same edge in both directions (low bits 0 then 1) ...
    if ((edges[i] | 1) != edges[i + 1] || (edges[i] & 1)) return 0;
    // ... and no third use of it.
    if (i + 2 < edges.size() && (edges[i + 2] >> 1) == (edges[i] >> 1)) return 0;
  }
  // The closed components (triangles joined through shared edges: two shells that touch at a
  // vertex stay apart), each with its own signed volume. One orientation for the mesh only when
  // every component has it: a mesh holding an outward and an inward shell (one OBJ group with
  // a flipped sphere, a solid with a cavity) is two-sided, since culling by the whole mesh's
  // sign would drop the near half of the shell that faces the other way (issue 45).
  std::vector<uint32_t> root(nt);
  for (size_t t = 0; t < nt; ++t) root[t] = uint32_t(t);
  auto find = [&](uint32_t t) {
    while (root[t] != t) t = root[t] = root[root[t]];
    return t;
  };
  std::vector<std::pair<uint64_t, uint32_t>> tri_edges;  // (undirected edge, triangle)
  tri_edges.reserve(nt * 3);
  for (size_t t = 0; t < nt; ++t)
    for (int k = 0; k < 3; ++k) {
      uint64_t a = weld[m.indices[3 * t + k]], b = weld[m.indices[3 * t + (k + 1) % 3]];
      tri_edges.push_back({std::min(a, b) << 32 | std::max(a, b), uint32_t(t)});
    }
  std::sort(tri_edges.begin(), tri_edges.end());
  for (size_t i = 0; i + 1 < tri_edges.size(); i += 2)  // (each edge exactly twice, above)
    root[find(tri_edges[i].second)] = find(tri_edges[i + 1].second);
  std::vector<double> volume(nt, 0.0);
  for (size_t t = 0; t < nt; ++t) {
    const float* a = &m.positions[3 * m.indices[3 * t]];
    const float* b = &m.positions[3 * m.indices[3 * t + 1]];
    const float* c = &m.positions[3 * m.indices[3 * t + 2]];
    volume[find(uint32_t(t))] += a[0] * (double(b[1]) * c[2] - double(b[2]) * c[1]) -
                                 a[1] * (double(b[0]) * c[2] - double(b[2]) * c[0]) +
                                 a[2] * (double(b[0]) * c[1] - double(b[1]) * c[0]);
  }
  bool outward = false, inward = false;
  for (size_t t = 0; t < nt; ++t) {
    if (find(uint32_t(t)) != t) continue;
    if (!(volume[t] > 0) && !(volume[t] < 0)) return 0;  // a flat (or NaN) component
    (volume[t] > 0 ? outward : inward) = true;
  }
  return outward == inward ? 0 : outward ? 1 : -1;
}

}  // namespace vismap
