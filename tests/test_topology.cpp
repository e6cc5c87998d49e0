#include <gtest/gtest.h>

#include "core/util/mesh_topology.h"

namespace {

using vismap::Mesh;

Mesh tetra(bool flip, bool drop_face = false, bool soup = false) {
  Mesh m;
  float p[4][3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  uint32_t f[4][3] = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};  // outward
  for (int t = 0; t < (drop_face ? 3 : 4); ++t)
    for (int k = 0; k < 3; ++k) {
      uint32_t v = f[t][flip ? 2 - k : k];
      if (soup) {
        m.positions.insert(m.positions.end(), p[v], p[v] + 3);
        m.indices.push_back(uint32_t(m.indices.size()));
      } else {
        m.indices.push_back(v);
      }
    }
  if (!soup)
    for (auto& q : p) m.positions.insert(m.positions.end(), q, q + 3);
  return m;
}

TEST(Topology, ClosedOrientation) {
  EXPECT_EQ(vismap::closed_orientation(tetra(false)), 1);
  EXPECT_EQ(vismap::closed_orientation(tetra(true)), -1);
  EXPECT_EQ(vismap::closed_orientation(tetra(false, true)), 0);         // open
  EXPECT_EQ(vismap::closed_orientation(tetra(false, false, true)), 1);  // soup welds by position
  Mesh twice = tetra(false);
  twice.indices.insert(twice.indices.end(), twice.indices.begin(), twice.indices.begin() + 3);
  EXPECT_EQ(vismap::closed_orientation(twice), 0);  // a duplicated face: non-manifold
  Mesh mixed = tetra(false);
  std::swap(mixed.indices[0], mixed.indices[1]);  // one face flipped: inconsistent
  EXPECT_EQ(vismap::closed_orientation(mixed), 0);
}

}  // namespace
