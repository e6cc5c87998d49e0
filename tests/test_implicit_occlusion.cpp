// Issue 32, item 4: an implicit object's regions hidden behind its own full boxes nearer the eye
// leave the region queue (docs/IMPLICIT.md "Hidden regions"), and that must change nothing seen.
// Each scene is diced twice, with the cull and without: every triangle kept is a triangle of the
// full dice (the same three vertices), and the exact planar maps of the two, the kept triangles
// numbered as in the full dice, show every source's visible region the same
// (check::compare_maps): what was left out was hidden. Scenes: random solids (boxes and balls
// joined, balls cut out) seen from random eyes, a wall before a torus, the architecture model. A
// deliberately unsound cull (VM_IOCCLUDE_MUTATION: full boxes drawn at their least depth, not
// their entry depth at each texel) must be caught, so the comparison can fail.
#include <gtest/gtest.h>

#include <array>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <random>
#include <string>

#include "core/check/map_diff.h"
#include "core/pipeline.h"

namespace {

using namespace vismap;

Renderer& renderer() {
  static Renderer r;
  return r;
}

using TriangleKey = std::array<float, 9>;

// A triangle by its corners, rotated to start at the least (the winding kept).
TriangleKey triangle_key(const Mesh& m, size_t t) {
  std::array<std::array<float, 3>, 3> c;
  for (int k = 0; k < 3; ++k)
    for (int a = 0; a < 3; ++a) c[k][a] = m.positions[3 * size_t(m.indices[3 * t + k]) + a];
  std::rotate(c.begin(), std::min_element(c.begin(), c.end()), c.end());
  TriangleKey key;
  for (int k = 0; k < 3; ++k)
    for (int a = 0; a < 3; ++a) key[3 * k + a] = c[k][a];
  return key;
}

struct Outcome {
  check::MapDiff diff;
  size_t foreign = 0;  // kept triangles that the full dice does not have
  uint64_t occluded = 0;
  size_t triangles_on = 0, triangles_off = 0;
};

// Dices the scene's implicit object (its first mesh) with the cull and without, renders both
// exactly (the object's triangles of the culled dice numbered as the full dice's) and compares.
Outcome dice_and_compare(Renderer& r, const Scene& s, const Camera& cam, float tol) {
  TessellateOptions o;
  o.implicit_tolerance_px = tol;
  TessellateStats st_on, st_off;
  const Scene on = r.tessellate(s, cam, o, &st_on);
  o.implicit_occlusion = false;
  const Scene off = r.tessellate(s, cam, o, &st_off);
  EXPECT_EQ(st_off.implicit_occluded, 0u);
  Outcome out;
  out.occluded = st_on.implicit_occluded;
  const Mesh &m_on = on.meshes[0], &m_off = off.meshes[0];
  out.triangles_on = m_on.triangle_count();
  out.triangles_off = m_off.triangle_count();
  std::map<TriangleKey, uint32_t> full;
  for (size_t t = 0; t < m_off.triangle_count(); ++t) full[triangle_key(m_off, t)] = uint32_t(t);
  std::vector<uint32_t> as_full(m_on.triangle_count(), 0);
  for (size_t t = 0; t < m_on.triangle_count(); ++t) {
    const auto it = full.find(triangle_key(m_on, t));
    if (it == full.end()) {
      ++out.foreign;
      continue;
    }
    as_full[t] = it->second;
  }
  RenderOptions ro;
  ro.exact = true;
  PlanarMap a = r.render(on, cam, ro);
  const PlanarMap b = r.render(off, cam, ro);
  for (size_t f = 0; f < a.fragment_count(); ++f)
    if (a.mesh[f] == 0) a.triangle[f] = as_full[a.triangle[f]];
  out.diff = check::compare_maps(a, b);
  return out;
}

// A solid of 2 to 5 boxes and balls in [-1, 1]^3, with up to 3 balls cut out of it.
std::string random_solid(std::mt19937& rng) {
  std::uniform_real_distribution<double> c(-0.8, 0.8), e(0.15, 0.6);
  const auto num = [](double v) { return std::to_string(v); };
  const auto ball = [&](double r) {
    return "(- (sqrt (+ (square (- x " + num(c(rng)) + ")) (square (- y " + num(c(rng)) +
           ")) (square (- z " + num(c(rng)) + ")))) " + num(r) + ")";
  };
  std::string u = "(min";
  const int parts = 2 + int(rng() % 4);
  for (int i = 0; i < parts; ++i)
    if (rng() % 3)
      u += " (max (- (abs (- x " + num(c(rng)) + ")) " + num(e(rng)) + ") (- (abs (- y " +
           num(c(rng)) + ")) " + num(e(rng)) + ") (- (abs (- z " + num(c(rng)) + ")) " +
           num(e(rng)) + "))";
    else
      u += " " + ball(e(rng));
  u += ")";
  const int cuts = int(rng() % 4);
  if (cuts == 0) return u;
  std::string s = "(max " + u;
  for (int i = 0; i < cuts; ++i) s += " (- " + ball(e(rng) * 0.6) + ")";
  return s + ")";
}

// An eye 3.5 to 6 units from the origin in a random direction, looking near it; near and far
// fitted to the scene (as the CLI and the server fit them before dicing).
Camera random_camera(std::mt19937& rng, const Scene& s) {
  std::normal_distribution<double> n(0, 1);
  std::uniform_real_distribution<double> d(3.5, 6), j(-0.3, 0.3);
  double v[3] = {n(rng), n(rng), n(rng)};
  const double l = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
  const double dist = d(rng);
  Camera cam;
  cam.eye = {v[0] / l * dist, v[1] / l * dist, v[2] / l * dist};
  cam.target = {j(rng), j(rng), j(rng)};
  cam.up = std::abs(v[1] / l) > 0.9 ? Vec3{1, 0, 0} : Vec3{0, 1, 0};
  cam.fov_y_deg = 45;
  cam.width = cam.height = 160;
  fit_near_far(cam, s);
  return cam;
}

// Over `count` random solids: the outcomes summed; every map the same.
Outcome random_solids(Renderer& r, uint64_t first, uint64_t count, bool expect_same) {
  Outcome sum;
  for (uint64_t seed = first; seed < first + count; ++seed) {
    std::mt19937 rng(uint32_t(seed) * 7919u + 17u);
    const std::string expr = random_solid(rng);
    const Scene s = load_scene_from_memory("solid.sexp", expr);
    const Camera cam = random_camera(rng, s);
    const Outcome o = dice_and_compare(r, s, cam, 2.0f);
    if (expect_same) {
      EXPECT_TRUE(o.diff.same()) << "seed " << seed << " " << expr << ": " << o.diff.summary();
      EXPECT_EQ(o.foreign, 0u) << "seed " << seed;
    }
    sum.diff.differing += o.diff.differing;
    sum.foreign += o.foreign;
    sum.occluded += o.occluded;
    sum.triangles_on += o.triangles_on;
    sum.triangles_off += o.triangles_off;
  }
  return sum;
}

TEST(ImplicitOcclusion, RandomSolidsKeepEverySourcesVisibleRegion) {
  const Outcome sum = random_solids(renderer(), 0, 16, true);
  // The cull leaves things out: regions, and with them triangles.
  EXPECT_GT(sum.occluded, 1000u);
  EXPECT_LT(sum.triangles_on, sum.triangles_off);
  std::printf("occluded %llu regions; triangles %zu with the cull, %zu without\n",
              (unsigned long long)sum.occluded, sum.triangles_on, sum.triangles_off);
}

// A thick wall between the eye and a torus: most of the torus is hidden, its top shows above the
// wall.
Outcome wall_and_torus(Renderer& r) {
  const Scene s = load_scene_from_memory(
      "wall.sexp",
      "(min (max (- (abs x) 1.4) (- (abs (- y 0.5)) 0.9) (- (abs (- z 0.4)) 0.25))"
      "     (- (sqrt (+ (square (- (sqrt (+ (square x) (square (+ z 1)))) 0.9)) (square y))) "
      "0.3))");
  Camera cam;
  cam.eye = {0.6, 0.9, 5};
  cam.target = {0, 0.2, -0.5};
  cam.up = {0, 1, 0};
  cam.fov_y_deg = 40;
  cam.width = cam.height = 200;
  fit_near_far(cam, s);
  return dice_and_compare(r, s, cam, 1.5f);
}

TEST(ImplicitOcclusion, AWallHidesATorus) {
  const Outcome o = wall_and_torus(renderer());
  EXPECT_TRUE(o.diff.same()) << o.diff.summary();
  EXPECT_EQ(o.foreign, 0u);
  EXPECT_GT(o.occluded, 500u);
  EXPECT_LT(o.triangles_on, o.triangles_off * 3 / 4);
}

TEST(ImplicitOcclusion, ArchitectureModelKeepsEverySourcesVisibleRegion) {
  const std::string path = std::string(VISMAP_SOURCE_DIR) + "/bench/implicit/architecture.json";
  if (!std::filesystem::exists(std::string(VISMAP_SHARED_DATA_DIR) +
                               "/implicit/mpr_architecture.sexp"))
    GTEST_SKIP() << "no ../shared/data";
  const Scene s = load_scene(path);
  ASSERT_TRUE(s.camera.has_value());
  Camera cam = *s.camera;
  cam.width = cam.height = 256;
  fit_near_far(cam, s);
  const Outcome o = dice_and_compare(renderer(), s, cam, 3.0f);
  EXPECT_TRUE(o.diff.same()) << o.diff.summary();
  EXPECT_EQ(o.foreign, 0u);
  EXPECT_GT(o.occluded, 1000u);
  std::printf(
      "architecture at 256 px, 3 px: occluded %llu regions; triangles %zu with the "
      "cull, %zu without\n",
      (unsigned long long)o.occluded, o.triangles_on, o.triangles_off);
}

// The mutation: each full box is drawn at its least depth over the whole box, not its entry depth
// at each texel; a ray meets an oblique box deeper than its nearest corner, so surfaces between
// the two depths are left out though they show. The comparison must catch it (it does on 12 of
// the first 16 solids).
TEST(ImplicitOcclusion, AnUnsoundCullIsCaught) {
  setenv("VISMAP_CL_OPTIONS", "-DVM_IOCCLUDE_MUTATION=1", 1);
  Renderer mutated;
  unsetenv("VISMAP_CL_OPTIONS");
  size_t differing = 0, solids = 0;
  for (uint64_t seed = 0; seed < 16 && differing == 0; ++seed, ++solids)
    differing += random_solids(mutated, seed, 1, false).diff.differing;
  EXPECT_GT(differing, 0u) << "the mutated cull was not caught";
  std::printf("caught after %zu solids: %zu sources differ\n", solids, differing);
}

}  // namespace
