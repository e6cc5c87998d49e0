// Bicubic Bezier patches diced for the camera (issue 18, core/surfaces/patches.cpp,
// kernels/patches.cl): the screen-space tolerance holds against the surface evaluated in double
// precision; crack-free (a diced edge used by one triangle only lies on a patch side that no
// other patch shares, and no edge is used more than twice); the tea set's degenerate patches;
// patches across the near plane, behind the camera and outside the view; seeded random patch
// grids with strong perspective, so neighbours choose different rates.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <map>
#include <random>
#include <set>

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

// Pixel position of a world point (perspective divide), and its clip w.
struct Projector {
  Mat4 m;
  double w_px, h_px;
  explicit Projector(const Camera& c) : m(c.view_projection()), w_px(c.width), h_px(c.height) {}
  std::array<double, 3> operator()(const std::array<double, 3>& p) const {
    double q[4];
    for (int r = 0; r < 4; ++r)
      q[r] = m[r] * p[0] + m[4 + r] * p[1] + m[8 + r] * p[2] + m[12 + r];
    return {(q[0] / q[3] + 1) * 0.5 * w_px, (1 - q[1] / q[3]) * 0.5 * h_px, q[3]};
  }
};

// The largest screen distance between the diced triangles and the surface, sampled at corner,
// edge and interior points of every triangle whose corners are all in front of the near plane
// (a point on triangle t at barycentrics b against the patch at the same b of the corners'
// (u, v)). Also counts the samples.
double max_screen_error(const Mesh& patches, const Mesh& diced, const Camera& cam,
                        uint64_t* samples = nullptr) {
  Projector proj(cam);
  double worst = 0;
  uint64_t count = 0;
  const int k = 6;
  for (size_t t = 0; t < diced.triangle_count(); ++t) {
    std::array<double, 3> p[3];
    double uv[3][2];
    bool front = true;
    for (int c = 0; c < 3; ++c) {
      uint32_t v = diced.indices[3 * t + c];
      for (int d = 0; d < 3; ++d) p[c][d] = diced.positions[3 * v + d];
      uv[c][0] = diced.uv[6 * t + 2 * c];
      uv[c][1] = diced.uv[6 * t + 2 * c + 1];
      front &= proj(p[c])[2] > cam.near_plane;
    }
    if (!front) continue;
    for (int i = 0; i <= k; ++i)
      for (int j = 0; i + j <= k; ++j) {
        double b[3] = {double(i) / k, double(j) / k, double(k - i - j) / k};
        std::array<double, 3> q{0, 0, 0};
        double u = 0, w = 0;
        for (int c = 0; c < 3; ++c) {
          for (int d = 0; d < 3; ++d) q[d] += b[c] * p[c][d];
          u += b[c] * uv[c][0];
          w += b[c] * uv[c][1];
        }
        auto s = proj(patch_point(patches, diced.face_ids[t], u, w));
        auto a = proj(q);
        // Only what lies in the image counts (the bound is for the visible image).
        if (a[0] < 0 || a[0] > cam.width || a[1] < 0 || a[1] > cam.height) continue;
        double e = std::hypot(s[0] - a[0], s[1] - a[1]);
        if (e > worst && getenv("VM_DEBUG"))
          std::printf("worst %.3f patch %u t %zu uv (%g %g) (%g %g) (%g %g) at b %g %g\n", e,
                      diced.face_ids[t], t, uv[0][0], uv[0][1], uv[1][0], uv[1][1], uv[2][0],
                      uv[2][1], b[0], b[1]);
        worst = std::max(worst, e);
        ++count;
      }
  }
  if (samples) *samples = count;
  return worst;
}

// Patch sides (patch, side 0..3: v = 0, v = 1, u = 0, u = 1) that another patch in `present`
// (those diced: not culled) also has, by their four control points (bit for bit, in either
// direction).
std::set<std::pair<uint32_t, int>> shared_sides(const Mesh& m, const std::set<uint32_t>& present) {
  using Key = std::array<float, 12>;
  std::map<Key, std::vector<std::pair<uint32_t, int>>> by;
  for (uint32_t p = 0; p < m.patch_count(); ++p)
    for (int s = 0; s < 4; ++s) {
      if (!present.count(p)) break;
      Key a, b;
      for (int k = 0; k < 4; ++k) {
        int i = s == 0 ? 0 : s == 1 ? 3 : k, j = s == 2 ? 0 : s == 3 ? 3 : k;
        for (int d = 0; d < 3; ++d) {
          a[3 * k + d] = m.patches[48 * p + 3 * (4 * i + j) + d];
          b[3 * (3 - k) + d] = a[3 * k + d];
        }
      }
      by[std::min(a, b)].push_back({p, s});
    }
  std::set<std::pair<uint32_t, int>> out;
  for (auto& [key, v] : by)
    if (v.size() > 1) out.insert(v.begin(), v.end());
  return out;
}

struct EdgeCheck {
  uint64_t edges = 0, boundary = 0, on_shared_side = 0, not_on_a_side = 0, over_two = 0;
};

// Every edge of the diced mesh by its use count; a boundary edge (one use) must lie on a patch
// side (both corners' u, or v, equal to 0 or 1) that no other patch shares.
EdgeCheck check_edges(const Mesh& patches, const Mesh& diced) {
  std::map<std::pair<uint32_t, uint32_t>, std::vector<size_t>> uses;  // edge -> triangle corners
  for (size_t t = 0; t < diced.triangle_count(); ++t)
    for (int c = 0; c < 3; ++c) {
      uint32_t a = diced.indices[3 * t + c], b = diced.indices[3 * t + (c + 1) % 3];
      uses[{std::min(a, b), std::max(a, b)}].push_back(3 * t + c);
    }
  auto shared = shared_sides(patches, std::set<uint32_t>(diced.face_ids.begin(), diced.face_ids.end()));
  EdgeCheck r;
  for (auto& [e, corners] : uses) {
    ++r.edges;
    if (corners.size() > 2) {
      ++r.over_two;
      if (getenv("VM_DEBUG")) {
        std::printf("edge used %zu times:", corners.size());
        for (size_t k : corners) {
          size_t t = k / 3, c = k % 3;
          std::printf(" [patch %u uv (%g %g)-(%g %g)]", diced.face_ids[t], diced.uv[6 * t + 2 * c],
                      diced.uv[6 * t + 2 * c + 1], diced.uv[6 * t + 2 * ((c + 1) % 3)],
                      diced.uv[6 * t + 2 * ((c + 1) % 3) + 1]);
        }
        std::printf(" p (%.9g %.9g %.9g)\n", diced.positions[3 * e.first], diced.positions[3 * e.first + 1], diced.positions[3 * e.first + 2]);
      }
    }
    if (corners.size() != 1) continue;
    ++r.boundary;
    size_t t = corners[0] / 3, c = corners[0] % 3, c2 = (c + 1) % 3;
    const float* uv = &diced.uv[6 * t];
    float u0 = uv[2 * c], v0 = uv[2 * c + 1], u1 = uv[2 * c2], v1 = uv[2 * c2 + 1];
    int side = v0 == 0 && v1 == 0 ? 0 : v0 == 1 && v1 == 1 ? 1 : u0 == 0 && u1 == 0 ? 2
             : u0 == 1 && u1 == 1 ? 3 : -1;
    if (side < 0) ++r.not_on_a_side;
    else if (shared.count({diced.face_ids[t], side})) {
      ++r.on_shared_side;
      if (getenv("VM_DEBUG") && r.on_shared_side < 4) {
        uint32_t a = diced.indices[3 * t + c], b = diced.indices[3 * t + c2];
        std::printf("crack: patch %u side %d uv (%g %g)-(%g %g) p (%.9g %.9g %.9g)-(%.9g %.9g %.9g)\n",
                    diced.face_ids[t], side, u0, v0, u1, v1, diced.positions[3 * a],
                    diced.positions[3 * a + 1], diced.positions[3 * a + 2], diced.positions[3 * b],
                    diced.positions[3 * b + 1], diced.positions[3 * b + 2]);
      }
    }
  }
  return r;
}

Camera teapot_camera(const Scene& s, uint32_t size = 1024) {
  Camera c = frame_scene(s, size, size);
  return c;
}

TEST(Patches, TeapotWithinToleranceAndCrackFree) {
  std::string p = shared("teapot/teapot.bpt");
  if (!std::filesystem::exists(p)) GTEST_SKIP() << p;
  Scene s = load_scene(p);
  Camera cam = teapot_camera(s);
  for (float tol : {2.0f, 0.5f, 0.2f}) {
    TessellateStats st;
    Scene d = renderer().tessellate(s, cam, TessellateOptions{tol}, &st);
    const Mesh& m = d.meshes[0];
    ASSERT_GT(m.triangle_count(), 0u);
    EXPECT_EQ(m.uv.size(), 6 * m.triangle_count());
    EXPECT_EQ(m.face_ids.size(), m.triangle_count());
    uint64_t samples = 0;
    double err = max_screen_error(s.meshes[0], m, cam, &samples);
    EXPECT_LE(err, tol) << "tolerance " << tol;
    EXPECT_GT(samples, 1000u);
    EdgeCheck e = check_edges(s.meshes[0], m);
    EXPECT_EQ(e.over_two, 0u);
    EXPECT_EQ(e.not_on_a_side, 0u);
    EXPECT_EQ(e.on_shared_side, 0u) << "a crack: a boundary edge on a side two patches share";
    EXPECT_GT(e.boundary, 0u);  // the rim, the spout's and handle's open ends
    EXPECT_EQ(st.over_rate, 0u);
    for (float x : m.positions) ASSERT_TRUE(std::isfinite(x));
    std::printf("teapot at %.1f px: %zu triangles, %zu vertices, largest error %.3f px over %llu "
                "samples, %llu boundary edges\n",
                tol, m.triangle_count(), m.vertex_count(), err,
                static_cast<unsigned long long>(samples),
                static_cast<unsigned long long>(e.boundary));
  }
}

TEST(Patches, NewellTeaSetRendersCrackFree) {
  for (const char* f : {"teapot/newell_teapot.patches", "teapot/newell_teacup.patches",
                        "teapot/newell_teaspoon.patches"}) {
    std::string p = shared(f);
    if (!std::filesystem::exists(p)) GTEST_SKIP() << p;
    Scene s = load_scene(p);
    Camera cam = teapot_camera(s, 512);
    Scene d = renderer().tessellate(s, cam, TessellateOptions{0.5f});
    const Mesh& m = d.meshes[0];
    EdgeCheck e = check_edges(s.meshes[0], m);
    EXPECT_EQ(e.over_two, 0u) << f;
    EXPECT_EQ(e.on_shared_side, 0u) << f;
    EXPECT_EQ(e.not_on_a_side, 0u) << f;
    EXPECT_LE(max_screen_error(s.meshes[0], m, cam), 0.5) << f;
    // Degenerate patches (repeated control points at the poles) leave no collapsed triangle.
    for (size_t t = 0; t < m.triangle_count(); ++t) {
      uint32_t a = m.indices[3 * t], b = m.indices[3 * t + 1], c = m.indices[3 * t + 2];
      ASSERT_TRUE(a != b && b != c && c != a) << f << " triangle " << t;
    }
    PlanarMap map = renderer().render(d, cam);
    EXPECT_GT(map.fragment_count(), 100u) << f;
  }
}

// A heightfield of n x n patches sharing control points (C0 across sides, random heights),
// seen from low and close so that the rates differ from patch to patch.
Scene random_grid(uint32_t seed, int n) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> h(-0.6f, 0.6f);
  const int g = 3 * n + 1;
  std::vector<float> z(size_t(g) * g);
  for (float& x : z) x = h(rng);
  Mesh m;
  m.name = "grid";
  for (int pi = 0; pi < n; ++pi)
    for (int pj = 0; pj < n; ++pj)
      for (int i = 0; i < 4; ++i)
        for (int j = 0; j < 4; ++j) {
          int gi = 3 * pi + i, gj = 3 * pj + j;
          m.patches.insert(m.patches.end(),
                           {float(gj) / 3, z[size_t(gi) * g + gj], float(gi) / 3});
        }
  m.source_triangles = uint32_t(n * n);
  Scene s;
  s.meshes.push_back(std::move(m));
  return s;
}

TEST(Patches, RandomGridsWatertightUnderPerspective) {
  for (uint32_t seed : {1u, 2u, 3u}) {
    const int n = 8;
    Scene s = random_grid(seed, n);
    Camera cam;
    cam.width = cam.height = 512;
    cam.eye = {-1.0, 2.0, -1.0};
    cam.target = {n * 0.5, 0.0, n * 0.5};
    cam.fov_y_deg = 60;
    fit_near_far(cam, s);
    TessellateStats st;
    Scene d = renderer().tessellate(s, cam, TessellateOptions{0.5f}, &st);
    const Mesh& m = d.meshes[0];
    EdgeCheck e = check_edges(s.meshes[0], m);
    EXPECT_EQ(e.over_two, 0u) << seed;
    EXPECT_EQ(e.on_shared_side, 0u) << seed;
    EXPECT_EQ(e.not_on_a_side, 0u) << seed;
    EXPECT_LE(max_screen_error(s.meshes[0], m, cam), 0.5) << seed;
    EXPECT_GT(m.triangle_count(), 2000u);
    PlanarMap map = renderer().render(d, cam);
    EXPECT_GT(map.fragment_count(), 500u);
  }
}

TEST(Patches, NearPlaneBehindAndOutsideTheView) {
  Scene s = random_grid(7, 6);
  // The eye inside the grid's box, just above the surface: patches cross the near plane, some
  // lie behind the eye.
  Camera cam;
  cam.width = cam.height = 256;
  cam.eye = {3.0, 0.05, 3.0};
  cam.target = {6.0, 0.0, 3.0};
  cam.near_plane = 0.01;
  cam.far_plane = 100;
  TessellateStats st;
  Scene d = renderer().tessellate(s, cam, TessellateOptions{0.5f}, &st);
  EXPECT_GT(st.culled, 0u);  // behind the eye
  EXPECT_GT(st.pieces, 0u);
  EXPECT_EQ(st.pieces + st.culled, 36u);
  for (float x : d.meshes[0].positions) ASSERT_TRUE(std::isfinite(x));
  PlanarMap map = renderer().render(d, cam);
  EXPECT_GT(map.fragment_count(), 0u);
  // Looking away: everything culled, an empty mesh, an empty map.
  cam.target = {3.0, 0.05, -10.0};
  cam.eye = {3.0, 0.05, -5.0};
  Scene none = renderer().tessellate(s, cam, TessellateOptions{0.5f}, &st);
  EXPECT_EQ(st.culled, 36u);
  EXPECT_EQ(none.meshes[0].triangle_count(), 0u);
}

TEST(Patches, MirroredPatchesStayCrackFree) {
  std::string p = shared("teapot/newell_teapot.patches");
  if (!std::filesystem::exists(p)) GTEST_SKIP() << p;
  Scene s = load_scene(p);
  for (size_t i = 0; i < s.meshes[0].patches.size(); i += 3) s.meshes[0].patches[i] *= -1;
  Camera cam = teapot_camera(s, 512);
  Scene d = renderer().tessellate(s, cam, TessellateOptions{0.5f});
  EdgeCheck e = check_edges(s.meshes[0], d.meshes[0]);
  EXPECT_EQ(e.on_shared_side, 0u);
  EXPECT_EQ(e.over_two, 0u);
}

}  // namespace

// Issue 35, case 4: dicing is counted before it is done and refused from the count. Crumpled
// patches (random control points) near the eye dice finely; under a memory budget smaller than
// what the count says the dice would hold, tessellate refuses (TooLarge, naming the mesh and the
// budget) before it allocates, and with room it dices the same patches.
TEST(Patches, DicingPastTheMemoryBudgetIsRefusedFromTheCount) {
  std::mt19937 rng(35);
  std::uniform_real_distribution<float> u(-1, 1);
  Mesh m;
  m.name = "crumpled";
  const int n = 400;
  for (int p = 0; p < n; ++p)
    for (int k = 0; k < 48; ++k) m.patches.push_back(u(rng));
  m.source_triangles = n;
  Scene s;
  s.meshes.push_back(std::move(m));
  Camera cam;
  cam.width = cam.height = 1024;
  cam.eye = {0.0, 0.0, 3.0};
  cam.target = {0.0, 0.0, 0.0};
  fit_near_far(cam, s);
  TessellateStats st;
  const Scene d = renderer().tessellate(s, cam, TessellateOptions{0.2f}, &st);
  const uint64_t tris = d.meshes[0].triangle_count();
  ASSERT_GT(tris, 50000u);  // fine enough that the count matters
  TessellateOptions tight{0.2f};
  tight.memory_budget = 72 * tris / 2;  // half of what the triangles alone are counted at
  try {
    renderer().tessellate(s, cam, tight, &st);
    FAIL() << "past the budget";
  } catch (const InputError& e) {
    EXPECT_EQ(e.kind(), InputErrorKind::TooLarge) << e.what();
    EXPECT_EQ(e.mesh(), "crumpled");
    EXPECT_NE(std::string(e.what()).find("over the memory budget of"), std::string::npos)
        << e.what();
  }
  TessellateOptions roomy{0.2f};
  roomy.memory_budget = 200 * tris + (1 << 20);
  EXPECT_EQ(renderer().tessellate(s, cam, roomy, &st).meshes[0].triangle_count(), tris);
  // The time limit holds in tessellate too: one already past stops it, naming the stage.
  TessellateOptions hurried{0.2f};
  hurried.time_limit_s = 1e-9;
  try {
    renderer().tessellate(s, cam, hurried, &st);
    FAIL() << "past the time limit";
  } catch (const InputError& e) {
    EXPECT_EQ(e.kind(), InputErrorKind::TimeLimit) << e.what();
    EXPECT_NE(std::string(e.what()).find("tessellate"), std::string::npos) << e.what();
  }
}
