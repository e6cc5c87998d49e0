// Loop subdivision surfaces (issue 18): the pbrt loader and the dicing (core/surfaces/loop.cpp).
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <map>

#include "core/error.h"
#include "core/pipeline.h"

namespace {

using namespace vismap;

std::string shared(const std::string& rel) {
  return std::string(VISMAP_SHARED_DATA_DIR) + "/" + rel;
}

Renderer& renderer() {
  static Renderer r;
  return r;
}

std::string error_of(const std::string& text) {
  try {
    load_scene_from_memory("bad.pbrt", text);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(Loop, LoadsKilleroo) {
  std::string p = shared("killeroo/killeroo.pbrt");
  if (!std::filesystem::exists(p)) GTEST_SKIP() << p;
  Scene s = load_scene(p);
  ASSERT_EQ(s.meshes.size(), 1u);
  EXPECT_TRUE(s.meshes[0].subdivision);
  EXPECT_EQ(s.meshes[0].vertex_count(), 4290u);
  EXPECT_EQ(s.meshes[0].triangle_count(), 8316u);
}

TEST(Loop, LoadsKillerooScene) {
  std::string p = shared("killeroo/killeroo-simple.pbrt");
  if (!std::filesystem::exists(p)) GTEST_SKIP() << p;
  Scene s = load_scene(p);
  ASSERT_EQ(s.meshes.size(), 4u);  // floor, wall, two Killeroos (the light sphere left out)
  EXPECT_FALSE(s.meshes[0].subdivision);
  EXPECT_TRUE(s.meshes[2].subdivision && s.meshes[3].subdivision);
  ASSERT_TRUE(s.camera);
  EXPECT_EQ(s.camera->width, 700u);
  EXPECT_NEAR(s.camera->fov_y_deg, 39, 1e-9);
  // LookAt 400 20 30 ..., then Rotate -5 0 0 1 (world to camera): the eye turns by +5 degrees.
  double a = 5 * M_PI / 180;
  EXPECT_NEAR(s.camera->eye[0], 400 * std::cos(a) - 20 * std::sin(a), 1e-9);
  EXPECT_NEAR(s.camera->eye[2], 30, 1e-9);
  EXPECT_NEAR(s.meshes[0].positions[2], -140, 1e-4);  // Translate 0 0 -140
  EXPECT_NEAR(s.meshes[2].color[0], 0.4f, 1e-6);
}

TEST(Loop, BadInputNamesLineAndColumn) {
  std::string e = error_of("Shape \"trianglemesh\" \"point P\" [0 0 0 1 0 0 0 1 0\n");
  EXPECT_NE(e.find("line 1: column 32: bracket not closed"), std::string::npos) << e;
  EXPECT_NE(error_of("Translate 1 2\nWorldBegin").find("line 2: column 1: expected a number"),
            std::string::npos);
  e = error_of(
      "Shape \"trianglemesh\" \"point P\" [0 0 0 1 0 0 0 1 0]\n \"integer indices\" [0 1 3]");
  EXPECT_NE(e.find("line 2: column 25: index 3 is not a point"), std::string::npos) << e;
  e = error_of("Shape \"loopsubdiv\"\n \"point P\" [0 0 nan 1 0 0 0 1 0] \"integer indices\" [0 1 2]");
  EXPECT_NE(e.find("line 2: column 17:"), std::string::npos) << e;
  EXPECT_NE(error_of("Shape \"sphere\" \"float radius\" 1").find("not supported"), std::string::npos);
  EXPECT_NE(error_of("Frobnicate 1").find("unknown directive"), std::string::npos);
}

// The octahedron: closed, every vertex of valence 4.
Mesh octahedron() {
  Mesh m;
  m.name = "octahedron";
  m.positions = {1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1};
  m.indices = {0, 2, 4, 2, 1, 4, 1, 3, 4, 3, 0, 4, 2, 0, 5, 1, 2, 5, 3, 1, 5, 0, 3, 5};
  m.source_triangles = 8;
  m.subdivision = true;
  return m;
}

std::map<std::pair<uint32_t, uint32_t>, int> edge_uses(const Mesh& m) {
  std::map<std::pair<uint32_t, uint32_t>, int> uses;
  for (size_t t = 0; t < m.indices.size(); t += 3)
    for (int k = 0; k < 3; ++k) {
      uint32_t a = m.indices[t + k], b = m.indices[t + (k + 1) % 3];
      ++uses[{std::min(a, b), std::max(a, b)}];
    }
  return uses;
}

Camera view(uint32_t px, double dist) {
  Camera c;
  c.eye = {dist * 0.6, dist * 0.35, dist};
  c.target = {0, 0, 0};
  c.width = c.height = px;
  c.near_plane = 0.1;
  c.far_plane = 100;
  return c;
}

TEST(Loop, ClosedStaysClosedAndNearTheSphere) {
  Scene s;
  s.meshes.push_back(octahedron());
  for (float tol : {4.0f, 1.0f, 0.2f}) {
    TessellateStats st;
    TessellateOptions o;
    o.tolerance_px = tol;
    Scene d = renderer().tessellate(s, view(512, 4), o, &st);
    const Mesh& m = d.meshes[0];
    EXPECT_EQ(m.triangle_count(), size_t(8) << (2 * st.subdivision_level));
    for (auto& [e, n] : edge_uses(m)) ASSERT_EQ(n, 2) << "level " << st.subdivision_level;
    EXPECT_EQ(m.uv.size(), 6 * m.triangle_count());
    EXPECT_EQ(m.face_ids.size(), m.triangle_count());
    for (uint32_t f : m.face_ids) ASSERT_LT(f, 8u);
    // Symmetry of the octahedron's limit surface: the limit of vertex 0 lies on the x axis.
    EXPECT_NEAR(m.positions[1], 0, 1e-5);
    EXPECT_NEAR(m.positions[2], 0, 1e-5);
    // Regular valence-4 limit mask: 1 - 4 chi with chi = 1/(4 + 3/(8 beta_4)), beta_4 = 31/256.
    double beta = (0.625 - 0.375 * 0.375) / 4, chi = 1 / (4 + 3 / (8 * beta));
    if (st.subdivision_level == 0) {
      EXPECT_NEAR(m.positions[0], 1 - 4 * chi, 1e-5);
    }
  }
}

TEST(Loop, FlatControlMeshStaysOnItsPlane) {
  Mesh m;
  m.name = "grid";
  const int n = 5;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      float x = float(i) / (n - 1) - 0.5f, y = float(j) / (n - 1) - 0.5f;
      m.positions.insert(m.positions.end(), {x, y, 0.3f * x + 0.2f * y});
    }
  for (int j = 0; j + 1 < n; ++j)
    for (int i = 0; i + 1 < n; ++i) {
      uint32_t a = j * n + i, b = a + 1, c = a + n, d = c + 1;
      m.indices.insert(m.indices.end(), {a, b, d, a, d, c});
    }
  m.source_triangles = uint32_t(m.indices.size() / 3);
  m.subdivision = true;
  Scene s;
  s.meshes.push_back(m);
  TessellateStats st;
  Scene d = renderer().tessellate(s, view(1024, 2), {}, &st);
  EXPECT_GE(st.subdivision_level, 1u);
  const Mesh& o = d.meshes[0];
  for (size_t v = 0; v < o.positions.size(); v += 3)
    ASSERT_NEAR(o.positions[v + 2], 0.3f * o.positions[v] + 0.2f * o.positions[v + 1], 1e-5);
  // Boundary edges double per level: 16 on the control mesh.
  int boundary = 0;
  for (auto& [e, k] : edge_uses(o)) boundary += k == 1;
  EXPECT_EQ(boundary, 16 << st.subdivision_level);
}

TEST(Loop, KillerooDicesCrackFreeAndRenders) {
  std::string p = shared("killeroo/killeroo.pbrt");
  if (!std::filesystem::exists(p)) GTEST_SKIP() << p;
  Scene s = load_scene(p);
  Camera cam = frame_scene(s, 256, 256);
  TessellateStats st;
  Scene d = renderer().tessellate(s, cam, {}, &st);
  const Mesh& m = d.meshes[0];
  EXPECT_FALSE(m.subdivision);
  EXPECT_EQ(m.triangle_count(), size_t(8316) << (2 * st.subdivision_level));
  int boundary = 0, nonmanifold = 0;
  for (auto& [e, k] : edge_uses(m)) boundary += k == 1, nonmanifold += k > 2;
  EXPECT_EQ(boundary, 270 << st.subdivision_level);  // the control mesh's 270, split
  EXPECT_EQ(nonmanifold, 0);
  fit_near_far(cam, d);
  PlanarMap map = renderer().render(d, cam);
  EXPECT_GT(map.fragment_count(), 1000u);
  for (uint32_t t : map.triangle) ASSERT_LT(t, m.triangle_count());
}

}  // namespace

// Issue 35, case 6: the Loop plans a renderer keeps are bounded (TessellateOptions::
// loop_plan_cache_bytes); past the bound the least recently used plans of other meshes go, and a
// mesh whose plan went is diced the same way again (its plan rebuilt). Six sessions' plans had
// taken the server from 2.6 to 8.6 GB, kept after they closed.
TEST(Loop, PlanCacheIsBoundedLeastRecentlyUsedFirst) {
  Renderer r;
  Scene a, b;
  a.meshes.push_back(octahedron());
  Mesh big = octahedron();
  big.name = "octahedron x2";
  for (float& x : big.positions) x *= 2;
  b.meshes.push_back(big);
  TessellateOptions o;
  o.tolerance_px = 0.5f;
  TessellateStats sa, sb, sb2, sa2;
  const Scene da = r.tessellate(a, view(512, 4), o, &sa);
  ASSERT_GT(sa.loop_plan_bytes, 0u);
  EXPECT_EQ(sa.loop_plans_evicted, 0u);
  r.tessellate(b, view(512, 8), o, &sb);  // both kept under the default bound
  EXPECT_EQ(sb.loop_plans_evicted, 0u);
  EXPECT_GT(sb.loop_plan_bytes, sa.loop_plan_bytes);
  TessellateOptions tight = o;
  tight.loop_plan_cache_bytes = 1;  // only the plan being diced stays
  r.tessellate(b, view(512, 8), tight, &sb2);
  EXPECT_EQ(sb2.loop_plans_evicted, 1u);  // a's, the least recently used
  EXPECT_EQ(sb2.loop_plan_bytes, sb.loop_plan_bytes - sa.loop_plan_bytes);
  const Scene da2 = r.tessellate(a, view(512, 4), tight, &sa2);  // rebuilt; b's goes now
  EXPECT_EQ(sa2.loop_plans_evicted, 1u);
  EXPECT_EQ(sa2.loop_plan_bytes, sa.loop_plan_bytes);
  EXPECT_EQ(da2.meshes[0].positions, da.meshes[0].positions);
  EXPECT_EQ(da2.meshes[0].indices, da.meshes[0].indices);
}

// Issue 35, case 6 (the rest): a caller's own plans (TessellateOptions::loop_plans: vismapd's, one
// set per session's scene, charged to it) are used and kept there, not in the renderer's; one
// plan past loop_plan_max_bytes, or a dice past the memory budget, is refused from the level's
// counts before the level is built; plans made on one Renderer dice the same on another (their
// device copies remade); and the time limit is checked between levels.
TEST(Loop, CallersPlansAreBoundedAndCountedBeforeEachLevel) {
  Scene s;
  s.meshes.push_back(octahedron());
  const Camera cam = view(512, 4);
  TessellateOptions o;
  o.tolerance_px = 0.2f;
  LoopPlans own;
  o.loop_plans = &own;
  TessellateStats st;
  const Scene d = renderer().tessellate(s, cam, o, &st);
  ASSERT_EQ(own.by_mesh.size(), 1u);
  EXPECT_GT(st.loop_plan_bytes, 0u);
  const uint32_t level = st.subdivision_level;
  ASSERT_GE(level, 3u);
  Renderer other;
  TessellateStats st2;
  const Scene d2 = other.tessellate(s, cam, o, &st2);  // the plan is reused, its copies remade
  EXPECT_EQ(d2.meshes[0].positions, d.meshes[0].positions);
  EXPECT_EQ(d2.meshes[0].indices, d.meshes[0].indices);
  EXPECT_EQ(st2.loop_plan_bytes, st.loop_plan_bytes);
  // "" when tessellate refuses (TooLarge or TimeLimit) with `part` in the message.
  auto refused = [&](const TessellateOptions& opts, const std::string& part) -> std::string {
    LoopPlans fresh;
    TessellateOptions x = opts;
    x.loop_plans = &fresh;
    try {
      renderer().tessellate(s, cam, x, &st2);
      return "diced";
    } catch (const InputError& e) {
      const bool kind =
          e.kind() == InputErrorKind::TooLarge || e.kind() == InputErrorKind::TimeLimit;
      return kind && std::string(e.what()).find(part) != std::string::npos ? "" : e.what();
    }
  };
  TessellateOptions small = o;
  small.loop_plan_max_bytes = st.loop_plan_bytes / 2;  // the last level does not fit
  EXPECT_EQ(refused(small, "faces would take the plan past"), "");
  TessellateOptions tight = o;
  tight.memory_budget = st.loop_plan_bytes;  // the plan alone, less what the dice holds besides
  EXPECT_EQ(refused(tight, "over the memory budget of"), "");
  TessellateOptions hurried = o;
  hurried.time_limit_s = 1e-9;
  EXPECT_EQ(refused(hurried, "time limit"), "");
}
