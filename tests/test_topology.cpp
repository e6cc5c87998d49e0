#include <gtest/gtest.h>

#include <filesystem>

#include "core/check/map_diff.h"
#include "core/pipeline.h"
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

// Closed components facing opposite ways in one mesh (issue 45): a large outward tetrahedron
// and a small inward one. The whole mesh's signed volume is positive; culling by it dropped the
// inward one's near faces. Such a mesh is two-sided.
TEST(Topology, ComponentsFacingOppositeWaysAreTwoSided) {
  Mesh both = tetra(false), small = tetra(true);
  for (size_t i = 0; i < small.positions.size(); ++i)
    both.positions.push_back(small.positions[i] * 0.5f + (i % 3 == 0 ? 3.0f : 0.0f));
  for (uint32_t i : small.indices) both.indices.push_back(i + 4);
  EXPECT_EQ(vismap::closed_orientation(both), 0);
  Mesh outward = tetra(false), twice = tetra(false);  // two outward components: still culled
  for (size_t i = 0; i < outward.positions.size(); ++i)
    twice.positions.push_back(outward.positions[i] + (i % 3 == 0 ? 3.0f : 0.0f));
  for (uint32_t i : outward.indices) twice.indices.push_back(i + 4);
  EXPECT_EQ(vismap::closed_orientation(twice), 1);
}

// data/stiff/opposite_shells: one mesh, an outward cube and a smaller inward one (its triangles
// 12..23). Every source must show the same region as with the inward cube wound outward (which
// the whole-mesh cull handles): before, the inward cube's near faces were culled and its far
// faces' insides drawn in their place.
TEST(Topology, OppositeShellsRenderTheirNearFaces) {
  namespace fs = std::filesystem;
  vismap::Scene scene = vismap::load_scene(
      (fs::path(VISMAP_SOURCE_DIR) / "data/stiff/opposite_shells.json").string());
  ASSERT_TRUE(scene.camera);
  vismap::Camera cam = *scene.camera;
  vismap::Scene fixed = scene;
  std::vector<uint32_t>& idx = fixed.meshes.at(0).indices;
  ASSERT_EQ(idx.size(), 72u);
  for (size_t t = 12; t < 24; ++t) std::swap(idx[3 * t + 1], idx[3 * t + 2]);
  ASSERT_EQ(vismap::closed_orientation(fixed.meshes[0]), 1);
  vismap::Renderer r;
  vismap::RenderOptions opts;
  opts.exact = true;
  vismap::RenderStats st, fixed_st;
  const vismap::PlanarMap a = r.render(scene, cam, opts, &st);
  const vismap::PlanarMap b = r.render(fixed, cam, opts, &fixed_st);
  EXPECT_GT(fixed_st.back_faces, 0u);  // the comparison map does cull
  const vismap::check::MapDiff d = vismap::check::compare_maps(a, b);
  EXPECT_TRUE(d.same()) << d.summary();
  EXPECT_GT(d.visible_area, 1000.0);
}

}  // namespace
