// The stiff-case corpus (data/stiff/, DESIGN §5): every scene checked against the exact reference
// and its invariants, in the file's order and with the mesh and triangle order reversed; where no
// two triangles tie in depth the two maps must be the same set of fragments.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <map>

#include "core/check/scene_check.h"
#include "core/lines/line_check.h"
#include "core/lines/lines.h"
#include "core/pipeline.h"
#include "core/scene.h"

namespace {

using namespace vismap;
namespace fs = std::filesystem;

Renderer& renderer() {
  static Renderer r;
  return r;
}

std::vector<std::string> corpus() {
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(fs::path(VISMAP_SOURCE_DIR) / "data/stiff"))
    if (e.path().extension() == ".json") names.push_back(e.path().stem().string());
  std::sort(names.begin(), names.end());
  return names;
}

// Cases where the tie rule (lower mesh, then triangle, in front) decides part of the picture, so
// reversing the order legitimately changes which source shows there.
bool has_ties(const std::string& name) {
  return name == "coplanar_overlap" || name == "soup_duplicated_vertices" ||
         name == "coplanar_near_tie" || name == "tie_cycle" || name == "coplanar_triple" ||
         name == "plates_1e-6" || name == "jittered_plates";
}

std::string describe(const check::SceneFigures& f) {
  return check::to_json(f).dump();
}

// coverage_error of a hole-free map: only the 2^-96 fixed-point area sums, ~1e-37 (far below
// the 1e-12 "exact" tolerance of check::Tolerances, which a 1e-13 hole would pass). Holes at
// triple points were 4e-11 to 6e-10 before the tournament rule (docs/NUMERICS.md §2).
constexpr double kHoleFree = 1e-20;

class Stiff : public ::testing::TestWithParam<std::string> {};

TEST_P(Stiff, MatchesReferenceInBothOrders) {
  const std::string name = GetParam();
  Scene scene =
      load_scene((fs::path(VISMAP_SOURCE_DIR) / "data/stiff" / (name + ".json")).string());
  ASSERT_TRUE(scene.camera);
  Camera cam = *scene.camera;
  fit_near_far(cam, scene);

  check::SceneCheckOptions opts;
  opts.pixels = 512;
  PlanarMap fwd, bwd;
  check::SceneFigures f = check::check_scene(renderer(), scene, cam, opts, &fwd);
  EXPECT_GT(f.fragments, 0u);
  EXPECT_EQ(check::over_tolerance(f), std::vector<std::string>{}) << describe(f);
  // Zero wrong-source fragments in every case, also where crossing lines are rounded
  // (one_tile_crowded: planes too steep for the frame's integer depth planes).
  EXPECT_EQ(*f.wrong_source, 0u) << describe(f);
  EXPECT_EQ(*f.degenerate, 0u);
  EXPECT_EQ(*f.nonconvex, 0u);
  // No holes, also where crossing lines are snapped: the map covers exactly the union of the
  // triangles (up to the 2^-96 fixed-point area sums), including at triple points of mutually
  // penetrating triangles (triple_points, concurrent_planes, one_tile_crowded).
  EXPECT_LE(*f.coverage_error, kHoleFree) << describe(f);

  check::ReversedScene rev = check::reverse_order(scene);
  check::SceneFigures r = check::check_scene(renderer(), rev.scene, cam, opts, &bwd);
  EXPECT_EQ(check::over_tolerance(r), std::vector<std::string>{}) << "reversed: " << describe(r);
  EXPECT_LE(*r.coverage_error, kHoleFree) << "reversed: " << describe(r);
  // Without ties the visible area of every source is the same in both orders (exactly so
  // against the reference, checked above; here directly between the two maps).
  if (!has_ties(name)) {
    auto per_source = [](const std::vector<check::CanonicalFragment>& frags) {
      std::map<std::pair<int, int>, double> area;
      for (const auto& c : frags) {
        double a = 0;
        const size_t n = (c.size() - 2) / 2;
        for (size_t v = 0; v < n; ++v) {
          size_t w = (v + 1) % n;
          a += c[2 + 2 * v] * c[3 + 2 * w] - c[2 + 2 * w] * c[3 + 2 * v];
        }
        area[{int(c[0]), int(c[1])}] += a / 2;
      }
      return area;
    };
    auto af = per_source(check::canonical_fragments(fwd));
    auto ab = per_source(check::canonical_fragments(bwd, &rev));
    ASSERT_EQ(af.size(), ab.size());
    for (const auto& [src, a] : af) {
      ASSERT_TRUE(ab.count(src)) << src.first << ":" << src.second;
      EXPECT_NEAR(a, ab[src], 1e-6 * (1 + a) + (f.crossing_lines ? 1e-3 : 0))
          << "visible area of source " << src.first << ":" << src.second << " depends on the order";
    }
  }
}

// Finding (not a visibility error): the *fragmentation* depends on the input order -- the same
// visible region per source is cut into different fragments when the mesh and triangle order is
// reversed (8 of the 15 tie-free cases: collinear_edges, grazing_view, non_manifold_edge,
// one_tile_crowded, penetrating_triangles, t_junctions, tile_border_vertices, vertex_on_edge).
// Enable when the pipeline makes fragments canonical.
TEST_P(Stiff, DISABLED_SameFragmentsInBothOrders) {
  const std::string name = GetParam();
  if (has_ties(name)) GTEST_SKIP();
  Scene scene =
      load_scene((fs::path(VISMAP_SOURCE_DIR) / "data/stiff" / (name + ".json")).string());
  Camera cam = *scene.camera;
  fit_near_far(cam, scene);
  check::SceneCheckOptions opts;
  opts.reference = opts.invariants = false;
  opts.pixels = 0;
  PlanarMap fwd, bwd;
  check::check_scene(renderer(), scene, cam, opts, &fwd);
  check::ReversedScene rev = check::reverse_order(scene);
  check::check_scene(renderer(), rev.scene, cam, opts, &bwd);
  EXPECT_EQ(check::canonical_fragments(fwd), check::canonical_fragments(bwd, &rev));
}

INSTANTIATE_TEST_SUITE_P(Corpus, Stiff, ::testing::ValuesIn(corpus()),
                         [](const ::testing::TestParamInfo<std::string>& i) {
                           std::string s = i.param;
                           std::replace_if(
                               s.begin(), s.end(), [](char c) { return !isalnum(c); }, '_');
                           return s;
                         });

// Line drawings of the corpus (core/lines/lines.h), in both orders: every drawn line on an id
// change of the raster and every change between surfaces apart on a line, and the same drawing
// (each kind's length) whichever order the scene comes in, except where ties decide the picture.
class StiffLines : public ::testing::TestWithParam<std::string> {};

TEST_P(StiffLines, DrawingMatchesTheRasterInBothOrders) {
  const std::string name = GetParam();
  Scene scene = load_scene((fs::path(VISMAP_SOURCE_DIR) / "data/stiff" / (name + ".json")).string());
  check::ReversedScene rev = check::reverse_order(scene);
  ASSERT_TRUE(scene.camera);
  Camera cam = *scene.camera;
  fit_near_far(cam, scene);
  std::array<double, kLineKinds> length[2]{};
  for (int order = 0; order < 2; ++order) {
    const Scene& s = order ? rev.scene : scene;
    RenderOptions ro;
    ro.keep_screen_triangles = true;
    ScreenTriangles screen;
    const PlanarMap map = renderer().render(s, cam, ro, nullptr, &screen);
    const LineSet lines = extract_lines(map, screen, s, cam);
    for (size_t c = 0; c < lines.chain_count(); ++c) {
      const uint32_t n = lines.off[c + 1] - lines.off[c];
      for (uint32_t i = 0; i + 1 < n + lines.closed[c]; ++i) {
        const double* a = &lines.xy[2 * (lines.off[c] + i)];
        const double* b = &lines.xy[2 * (lines.off[c] + (i + 1) % n)];
        length[order][size_t(lines.kind[c])] += std::hypot(b[0] - a[0], b[1] - a[1]);
      }
    }
    Camera fine = cam;
    fine.width *= 4;
    fine.height *= 4;
    std::vector<uint32_t> ids;
    renderer().raster_ids(s, fine, &ids);
    const LineCheck lc = check_lines(lines, ids, cam.width, cam.height, 4, s);
    // Against the 4 x 4 supersampled raster (core/lines/line_check.h), but where: sampling
    // decides near-ties its own way (coplanar_near_tie, tie_cycle); coplanar pieces of one mesh,
    // overlapping or meeting at T-junctions, are one surface and meet with no line, where the
    // raster sees triangles more than two rings apart (coplanar_overlap, t_junctions); needles
    // thinner than a sample leave no change for their outlines (sliver_needles); the fans'
    // steps, and the fold of an open surface along an edge three triangles share, lie between
    // triangles within two rings, which the check counts as one surface (tile_border_vertices,
    // non_manifold_edge); the grazing view's far strips are thinner than a sample. Coplanar
    // triangles of one mesh (coplanar_triple) meet with no line where the raster's samples split
    // them by the tie rule, and plates 1e-6 apart and jittered (jittered_plates) tie where the
    // raster's per-sample depths do not, as do plates_1e-6 (issue 45's stiff cases; measured
    // recall 0.67, 0.43 and 0.49, precision 0.52 and 0.52); sliver_viewport_edge's sliver is
    // thinner than a sample, so the raster has no support for its outline (precision 0).
    const std::map<std::string, std::pair<double, double>> limits = {
        {"coplanar_near_tie", {0.25, 0.995}}, {"tie_cycle", {0.65, 0.9}},
        {"coplanar_triple", {0.6, 0.995}},    {"jittered_plates", {0.35, 0.45}},
        {"plates_1e-6", {0.4, 0.45}},         {"sliver_viewport_edge", {0.995, 0.0}},
        {"coplanar_overlap", {0.85, 0.995}},  {"t_junctions", {0.9, 0.995}},
        {"sliver_needles", {0.995, 0.2}},     {"tile_border_vertices", {0.995, 0.65}},
        {"non_manifold_edge", {0.995, 0.8}},  {"grazing_view", {0.995, 0.99}}};
    const auto it = limits.find(name);
    const auto [recall, precision] = it != limits.end() ? it->second : std::pair{0.995, 0.995};
    EXPECT_GE(lc.recall(), recall) << name << " order " << order;
    EXPECT_GE(lc.precision(), precision) << name << " order " << order;
  }
  if (has_ties(name)) return;
  for (size_t k = 0; k < kLineKinds; ++k)
    EXPECT_NEAR(length[0][k], length[1][k], 1e-6 * (1 + length[0][k]))
        << name << " " << line_kind_name(LineKind(k));
}

INSTANTIATE_TEST_SUITE_P(Corpus, StiffLines, ::testing::ValuesIn(corpus()),
                         [](const ::testing::TestParamInfo<std::string>& i) {
                           std::string s = i.param;
                           std::replace_if(
                               s.begin(), s.end(), [](char c) { return !isalnum(c); }, '_');
                           return s;
                         });

}  // namespace
