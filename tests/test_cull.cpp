// The cull (issue 32, core/stages/cull.h) leaves out what is provably hidden: the visible region
// of every source must be exactly the same with it and without it. Random scenes of connected
// meshes (tests/support/random_meshes.h: layers, crossing, holes, folds, coplanar and touching
// pieces, the near plane through meshes, closed boxes) and of random triangles
// (tests/support/random_scene.h), with and without buckets, are rendered with the cull on and off
// and compared exactly (check::compare_maps). A deliberately unsound cull (VM_CULL_MUTATION, built
// into the kernels only on request) must be caught, so the comparison can fail.
#include <gtest/gtest.h>

#include <array>
#include <cstdlib>
#include <initializer_list>
#include <string>

#include "core/check/map_diff.h"
#include "core/facts/scene_facts.h"
#include "core/pipeline.h"
#include "tests/support/random_meshes.h"
#include "tests/support/random_scene.h"
#include "tests/support/soup.h"

namespace {

using namespace vismap;

Renderer& renderer() {
  static Renderer r;
  return r;
}

struct Pair {
  check::MapDiff diff;
  RenderStats on, off;
};

Pair render_both(Renderer& r, const Scene& scene, const Camera& cam, uint64_t budget = 0) {
  RenderOptions opts;
  opts.exact = true;
  opts.memory_budget = budget;
  Pair p;
  opts.cull = true;
  // With the scene's facts: the culled frame's crossing search also skips pairs far apart in 3D
  // (core/facts/scene_facts.h), so every comparison below covers that too.
  if (facts::scene_facts_fit(scene.triangle_count(), budget))
    opts.scene_facts = std::make_shared<const facts::SceneFacts>(facts::find_scene_facts(scene));
  opts.min_apart_fraction = 0;  // (whenever they apply, not only where they pay)
  const PlanarMap a = r.render(scene, cam, opts, &p.on);
  opts.cull = false;
  const PlanarMap b = r.render(scene, cam, opts, &p.off);
  p.diff = check::compare_maps(a, b);
  return p;
}

// Over `seeds` mesh scenes: every map the same; returns how much was culled and dropped.
void check_mesh_seeds(uint64_t first, uint64_t count, uint64_t* culled, uint64_t* dropped,
                      uint64_t budget = 0) {
  for (uint64_t seed = first; seed < first + count; ++seed) {
    randomized::RandomMeshScene rs = randomized::random_mesh_scene(seed);
    Pair p = render_both(renderer(), rs.scene, rs.camera, budget);
    EXPECT_TRUE(p.diff.same()) << "seed " << seed << " (" << randomized::mesh_kind_name(rs.kind)
                               << "): " << p.diff.summary();
    EXPECT_EQ(p.off.culled_triangles, 0u);
    *culled += p.on.culled_triangles;
    *dropped += p.on.dropped_fragments;
  }
}

TEST(Cull, MeshScenesKeepEverySourcesVisibleRegion) {
  uint64_t culled = 0, dropped = 0;
  check_mesh_seeds(0, 96, &culled, &dropped);
  // The scenes exercise the cull: it leaves out triangles and stops fragments.
  EXPECT_GT(culled, 500u);
  EXPECT_GT(dropped, 10u);
  std::printf("culled %llu triangles, dropped %llu fragments\n", (unsigned long long)culled,
              (unsigned long long)dropped);
}

TEST(Cull, MeshScenesInBucketsKeepEverySourcesVisibleRegion) {
  uint64_t culled = 0, dropped = 0;
  check_mesh_seeds(1000, 24, &culled, &dropped, 3u << 20);
  EXPECT_GT(culled, 100u);
}

// (Their few large triangles seldom cover a whole leaf: what is culled is seldom much.)
TEST(Cull, RandomTriangleScenesKeepEverySourcesVisibleRegion) {
  uint32_t with_facts = 0;
  for (uint64_t seed = 0; seed < 120; ++seed) {
    randomized::RandomScene rs = randomized::random_scene(seed);
    Pair p = render_both(renderer(), rs.scene, rs.camera);
    EXPECT_TRUE(p.diff.same()) << "seed " << seed << " (" << randomized::kind_name(rs.kind)
                               << "): " << p.diff.summary();
    with_facts += p.on.apart_need > 0;
    // The facts' skip finds the same pairs as the culled frame without it.
    RenderOptions no_facts;
    RenderStats st;
    (void)renderer().render(rs.scene, rs.camera, no_facts, &st);
    EXPECT_EQ(p.on.entangled_pairs, st.entangled_pairs) << "seed " << seed;
  }
  // The facts' skip was on in most of them (off: orthographic views, or views that blur more
  // than the clearances' cap).
  EXPECT_GT(with_facts, 60u);
}

// Dense penetrating soup (bench/soup.sh's, smaller): large triangles, so the cull bins them on
// leaves of its own (cull.cpp cull_bins), and most of what it saves is fragments dropped.
TEST(Cull, PenetratingSoupKeepsEverySourcesVisibleRegion) {
  uint64_t dropped = 0;
  for (uint64_t seed = 1; seed <= 3; ++seed) {
    const Scene soup = test_support::penetrating_soup(400, 0.2, seed);
    const Camera cam = frame_scene(soup, 256, 256);
    Pair p = render_both(renderer(), soup, cam);
    EXPECT_TRUE(p.diff.same()) << "seed " << seed << ": " << p.diff.summary();
    EXPECT_LT(p.on.fragments, p.off.fragments);
    dropped += p.on.dropped_fragments;
  }
  EXPECT_GT(dropped, 100u);
}

// The cull is no stand-in: with it the bunny clips far fewer fragments for the same picture.
TEST(Cull, BunnyLeavesOutMostHiddenTriangles) {
  Scene scene = load_scene(std::string(VISMAP_SOURCE_DIR) + "/data/bunny.ply");
  Camera cam = frame_scene(scene, 512, 512);
  Pair p = render_both(renderer(), scene, cam);
  EXPECT_TRUE(p.diff.same()) << p.diff.summary();
  EXPECT_GT(p.on.culled_triangles, p.on.screen_triangles / 3);
  EXPECT_LT(p.on.fragments, p.off.fragments * 3 / 4);
  EXPECT_EQ(p.on.visible_fragments > 0, true);
}

// With the kernels built with `define` (a mutation), the sources that differ between the culled
// and the unculled map on the first of `seeds` scenes (make(seed)) where any do; 0 if none.
template <class MakeScene>
size_t differing_under(const char* define, uint64_t seeds, MakeScene make) {
  setenv("VISMAP_CL_OPTIONS", define, 1);
  Renderer mutated;
  unsetenv("VISMAP_CL_OPTIONS");
  size_t differing = 0;
  for (uint64_t seed = 0; seed < seeds && differing == 0; ++seed) {
    const auto rs = make(seed);
    differing += render_both(mutated, rs.scene, rs.camera).diff.differing;
  }
  return differing;
}

// A mutation: the cull trusts sheets even where a silhouette (a hole's border, a fold) crosses the
// cell. Such a sheet need not cover the cell, so triangles seen through its holes are culled, and
// the comparison must say so on some seed.
TEST(Cull, AnUnsoundCullIsCaught) {
  EXPECT_GT(differing_under("-DVM_CULL_MUTATION=1", 160, randomized::random_mesh_scene), 0u)
      << "the mutated cull was not caught";
}

// A mutation of the facts' premise: every triangle apart, whatever its clearance. Pairs of
// triangles that penetrate without sharing a vertex are then never looked for, their crossing
// lines are missing, and the comparison must say so on some seed.
TEST(Cull, ApartTrianglesWithoutTheirClearanceAreCaught) {
  EXPECT_GT(differing_under("-DVM_APART_MUTATION=1", 120, randomized::random_scene), 0u)
      << "the mutated facts were not caught";
}

// compare_maps on a map whose fragments of one source overlap (issue 45 item 6: a sliver at the
// viewport's edge snapped into overlapping pieces, and `vismap check` reported cull_differing 1
// for byte-identical maps): the source's region is the union of its fragments.
PlanarMap squares(std::initializer_list<std::array<int, 4>> boxes) {
  PlanarMap m;
  m.width = m.height = 8;
  m.grid_scale = 1;
  for (const auto& b : boxes) {
    const int x[4] = {b[0], b[2], b[2], b[0]}, y[4] = {b[1], b[1], b[3], b[3]};
    for (int k = 0; k < 4; ++k) {
      m.xy.push_back(x[k]);
      m.xy.push_back(y[k]);
      m.hx.push_back({x[k] < 0 ? -1 : 0, uint64_t(int64_t(x[k]))});
      m.hy.push_back({y[k] < 0 ? -1 : 0, uint64_t(int64_t(y[k]))});
      m.hw.push_back({0, 1});
    }
    m.offsets.push_back(uint32_t(m.xy.size() / 2));
    m.mesh.push_back(0);
    m.triangle.push_back(0);
  }
  return m;
}

TEST(MapDiff, SelfOverlappingFragmentsAreTheirUnion) {
  const PlanarMap overlapping = squares({{0, 0, 4, 4}, {2, 0, 6, 4}, {1, 1, 3, 5}});
  const PlanarMap disjoint = squares({{0, 0, 6, 4}, {1, 4, 3, 5}});
  const check::MapDiff self = check::compare_maps(overlapping, overlapping);
  EXPECT_TRUE(self.exact);
  EXPECT_TRUE(self.same()) << self.summary();
  EXPECT_DOUBLE_EQ(self.visible_area, 26.0);
  const check::MapDiff same = check::compare_maps(overlapping, disjoint);
  EXPECT_TRUE(same.same()) << same.summary();
  const check::MapDiff other = check::compare_maps(overlapping, squares({{0, 0, 6, 4}}));
  EXPECT_EQ(other.differing, 1u) << other.summary();
  EXPECT_DOUBLE_EQ(other.xor_area, 2.0);
}

}  // namespace
