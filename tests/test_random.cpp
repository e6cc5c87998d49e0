// Randomised scenes (tests/support/random_scene.h) checked against the exact reference. Seeds are
// fixed, so CI is deterministic; each shard is one ctest test. A failing seed is printed and its
// scene written to random_failures/seed_N.{json,obj} in the test's working directory, so that
// `vismap check random_failures/seed_N.json` reproduces it.
// VISMAP_RANDOM_COUNT=n runs n seeds per shard (default 40); VISMAP_RANDOM_SEED=s runs only seed s.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>

#include "core/check/scene_check.h"
#include "core/pipeline.h"
#include "tests/support/random_scene.h"

namespace {

using namespace vismap;
namespace fs = std::filesystem;

Renderer& renderer() {
  static Renderer r;
  return r;
}

constexpr int kShards = 8;

// Coplanar scenes run in their own test: they exercise the tie rule, which the pipeline, the
// exact reference and the z-buffer all apply pair by pair over the pair's overlap
// (docs/NUMERICS.md; data/stiff/coplanar_near_tie.json is the case that showed the need).
void check_seed(uint64_t seed, bool coplanar = false) {
  randomized::RandomScene rs = randomized::random_scene(seed);
  if ((rs.kind == randomized::RandomKind::Coplanar) != coplanar) return;
  check::SceneCheckOptions opts;
  opts.pixels = 256;
  check::SceneFigures f = check::check_scene(renderer(), rs.scene, rs.camera, opts);
  std::vector<std::string> bad = check::over_tolerance(f);
  // Hole-free also with crossing lines (triple points, docs/NUMERICS.md §2): coverage_error is
  // only the 2^-96 fixed-point area sums (~1e-37), as without them.
  if (f.coverage_error && *f.coverage_error > 1e-20)
    bad.push_back("coverage_error " + std::to_string(*f.coverage_error) + " > 1e-20 (a hole)");
  if (!bad.empty()) {
    fs::create_directories("random_failures");
    std::string path = "random_failures/seed_" + std::to_string(seed);
    randomized::write_scene(rs, path);
    ADD_FAILURE() << "seed " << seed << " (" << randomized::kind_name(rs.kind)
                  << "): " << bad.front() << "\n  reproduce: vismap check "
                  << fs::absolute(path + ".json").string() << "\n  " << check::to_json(f).dump();
  }
}

class RandomScenes : public ::testing::TestWithParam<int> {};

TEST_P(RandomScenes, MatchReference) {
  if (const char* s = std::getenv("VISMAP_RANDOM_SEED")) {
    if (GetParam() != 0) GTEST_SKIP() << "VISMAP_RANDOM_SEED runs in shard 0 only";
    uint64_t seed = std::strtoull(s, nullptr, 10);
    check_seed(seed, randomized::random_scene(seed).kind == randomized::RandomKind::Coplanar);
    return;
  }
  int count = 40;
  if (const char* s = std::getenv("VISMAP_RANDOM_COUNT")) count = std::atoi(s);
  for (int i = 0; i < count; ++i) check_seed(uint64_t(GetParam()) * 100000 + uint64_t(i));
}

// Seeds beyond CI's range that once failed, kept: 200167 (clustered) had a fragment 1e-5 grid
// units off its exact crossing line, because i128_to_double lost up to 2^12 on small negative
// values and a depth plane's recovery (geometry.cl int_plane) fell back to a rounded line that
// the reference took for exact (wrong_outside_band 1).
TEST(RandomScenesRegressions, MatchReference) {
  for (uint64_t seed : {200167}) {
    check_seed(seed, false);
    check_seed(seed, true);
  }
}

TEST(RandomScenesCoplanar, CoplanarMatchReference) {
  for (uint64_t seed = 0; seed < 40; ++seed) check_seed(seed, true);
}

INSTANTIATE_TEST_SUITE_P(Seeds, RandomScenes, ::testing::Range(0, kShards));

}  // namespace
