// The compact frame encoding (proto/COMPACT.md): watertight on the grid, faithful to the map,
// and every malformed frame refused with an InputError.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <map>
#include <random>
#include <set>
#include <sstream>

#include "core/error.h"
#include "core/pipeline.h"
#include "core/scene.h"
#include "core/stream/compact.h"
#include "core/util/conform.h"
#include "tests/support/grid_raster.h"

namespace vismap {
namespace {

using test_support::Coverage;

Renderer& renderer() {
  static Renderer r;
  return r;
}

struct Frame {
  Scene scene;
  Camera camera;
  PlanarMap map;
};

// A scene file rendered at w x h from its framing camera, turned by `azimuth_deg` about +Y.
const Frame& frame_of(const std::string& path, uint32_t w, uint32_t h, double azimuth_deg = 0) {
  static std::map<std::string, Frame> cache;
  const std::string key =
      path + "@" + std::to_string(w) + "x" + std::to_string(h) + "/" + std::to_string(azimuth_deg);
  auto it = cache.find(key);
  if (it != cache.end()) return it->second;
  Frame f;
  f.scene = load_scene(path);
  f.camera = frame_scene(f.scene, w, h);
  const double a = azimuth_deg * M_PI / 180;
  const Vec3 d{f.camera.eye[0] - f.camera.target[0], f.camera.eye[1] - f.camera.target[1],
               f.camera.eye[2] - f.camera.target[2]};
  f.camera.eye = {f.camera.target[0] + std::cos(a) * d[0] + std::sin(a) * d[2],
                  f.camera.target[1] + d[1],
                  f.camera.target[2] - std::sin(a) * d[0] + std::cos(a) * d[2]};
  fit_near_far(f.camera, f.scene);
  f.map = renderer().render(f.scene, f.camera, {});
  return cache.emplace(key, std::move(f)).first->second;
}

std::string src(const std::string& rel) {
  return std::string(VISMAP_SOURCE_DIR) + "/" + rel;
}

// Coverage of the decoded frame, tagged by source triangle id.
Coverage decoded_coverage(const CompactFrame& c) {
  return test_support::raster_grid(c.width, c.height, c.quantum, c.xy, c.indices, c.source);
}

struct Holes {
  size_t interior = 0, holes = 0, doubles = 0, wrong_id = 0;
};

// Compares a decoded frame's coverage with the exact map's: pixels inside the object that the
// frame leaves uncovered (holes), covers twice, or gives another source than the map.
Holes compare(const Frame& f, const CompactFrame& c) {
  const Coverage ref = test_support::raster_map(f.map);
  const Coverage got = decoded_coverage(c);
  const std::vector<uint8_t> in = test_support::interior(ref);
  const std::vector<uint64_t> base = f.scene.triangle_id_base();
  Holes h;
  for (size_t p = 0; p < in.size(); ++p) {
    if (got.count[p] > 1) ++h.doubles;
    if (!in[p]) continue;
    ++h.interior;
    if (got.count[p] == 0) {
      ++h.holes;
      continue;
    }
    const uint32_t fr = ref.id[p];
    const uint64_t id =
        base[f.map.mesh[fr]] + f.scene.meshes[f.map.mesh[fr]].face_ids[f.map.triangle[fr]];
    if (got.id[p] != id) ++h.wrong_id;
  }
  return h;
}

TEST(Compact, BunnyIsWatertightAndFaithful) {
  const Frame& f = frame_of(src("data/bunny.ply"), 1920, 1080);
  CompactStats st;
  const std::string bytes = write_compact(f.map, f.scene, f.camera, {}, &st);
  const CompactFrame c = read_compact(bytes);
  EXPECT_EQ(c.triangle_count(), st.triangles);
  EXPECT_GT(st.t_junctions, 1000u);  // the bunny's frame has thousands
  const Holes h = compare(f, c);
  EXPECT_GT(h.interior, 200000u);
  EXPECT_EQ(h.holes, 0u);
  // Where rounding inverts a sliver its neighbours overlap (a fold, under a grid step wide):
  // a pixel centre there is covered twice. Rare; never a hole.
  EXPECT_LT(double(h.doubles) / h.interior, 1e-3) << h.doubles;
  // A pixel centre within a grid step of an edge may change sides (1.1% here).
  EXPECT_LT(double(h.wrong_id) / h.interior, 0.03) << h.wrong_id << " of " << h.interior;
}

// The check above can fail: without the T-junctions inserted, rounding opens cracks.
TEST(Compact, WithoutTJunctionsRoundingOpensCracks) {
  const Frame& f = frame_of(src("data/bunny.ply"), 1920, 1080);
  const GridMesh g = conform_to_grid(f.map, 16, /*insert_t_junctions=*/false);
  CompactFrame c;
  c.width = f.map.width, c.height = f.map.height, c.quantum = 16;
  c.xy = g.xy;
  c.indices = g.tri;
  const Coverage got = test_support::raster_grid(c.width, c.height, 16, g.xy, g.tri, g.fragment);
  const std::vector<uint8_t> in = test_support::interior(test_support::raster_map(f.map));
  size_t holes = 0;
  for (size_t p = 0; p < in.size(); ++p) holes += in[p] && got.count[p] == 0;
  EXPECT_GT(holes, 0u);
}

TEST(Compact, CoarseAndFineGrids) {
  const Frame& f = frame_of(src("data/scenes/cornell_armadillo.json"), 640, 480, 30);
  double last_wrong = 1;
  for (uint32_t q : {1u, 4u, 16u, 256u}) {
    CompactOptions o;
    o.quantum = q;
    CompactStats st;
    const CompactFrame c = read_compact(write_compact(f.map, f.scene, f.camera, o, &st));
    EXPECT_EQ(c.quantum, q);
    const Holes h = compare(f, c);
    EXPECT_EQ(h.holes, 0u) << "quantum " << q;  // at any grid, however coarse
    const double wrong = double(h.wrong_id) / h.interior;
    EXPECT_LT(wrong, last_wrong) << "quantum " << q;  // finer grids are more faithful
    last_wrong = wrong;
    if (q >= 16) {
      EXPECT_LT(double(h.doubles) / h.interior, 1e-3) << "quantum " << q;
      EXPECT_LT(wrong, q == 256 ? 0.003 : 0.03) << "quantum " << q;
    }
  }
  CompactOptions bad;
  bad.quantum = 0;
  EXPECT_THROW(write_compact(f.map, f.scene, f.camera, bad), InputError);
}

TEST(Compact, ShadesAndMeshesRoundTrip) {
  const Frame& f = frame_of(src("data/scenes/cornell_armadillo.json"), 640, 480);
  CompactOptions o;
  o.shade = true;
  const CompactFrame c = read_compact(write_compact(f.map, f.scene, f.camera, o));
  ASSERT_EQ(c.flags & kCompactShade, kCompactShade);
  ASSERT_EQ(c.shade.size(), c.triangle_count());
  ASSERT_EQ(c.mesh_base.size(), f.scene.meshes.size());
  for (size_t m = 0; m < f.scene.meshes.size(); ++m)
    for (int k = 0; k < 3; ++k) EXPECT_EQ(c.mesh_color[m][k], f.scene.meshes[m].color[k]);
  // The decoded frame as a planar map of the scene: every triangle's source is in it.
  const PlanarMap back = to_planar_map(c, f.scene);
  EXPECT_EQ(back.fragment_count(), c.triangle_count());
  std::set<uint32_t> meshes(c.mesh.begin(), c.mesh.end());
  EXPECT_GT(meshes.size(), 3u);
}

TEST(Compact, EmptyFrame) {
  const Frame& f = frame_of(src("data/bunny.ply"), 320, 200);
  Camera away = f.camera;
  for (int k = 0; k < 3; ++k) away.target[k] = 2 * away.eye[k] - f.camera.target[k];
  fit_near_far(away, f.scene);
  const PlanarMap empty = renderer().render(f.scene, away, {});
  const CompactFrame c = read_compact(write_compact(empty, f.scene, away, {}));
  EXPECT_EQ(c.triangle_count(), 0u);
  EXPECT_EQ(c.vertex_count(), 0u);
}

// Every prefix and many corruptions of a real frame: an InputError or a valid frame, never a
// crash (the fuzzer, tests/fuzz/fuzz_compact.cpp, goes further).
TEST(Compact, MalformedFramesAreRefused) {
  const Frame& f = frame_of(src("data/scenes/two_quads.json"), 64, 48);
  const std::string good = write_compact(f.map, f.scene, f.camera, {});
  for (size_t n = 0; n < good.size(); ++n)
    EXPECT_THROW(read_compact(good.substr(0, n)), InputError) << "prefix " << n;
  EXPECT_THROW(read_compact(good + std::string(1, '\0')), InputError);
  std::string v2 = good;
  v2[4] = 2;
  EXPECT_THROW(read_compact(v2), InputError);
  std::mt19937 rng(7);
  for (int trial = 0; trial < 500; ++trial) {
    std::string b = good;
    const int flips = 1 + trial % 4;
    for (int k = 0; k < flips; ++k) b[rng() % b.size()] ^= char(1 + rng() % 255);
    try {
      const CompactFrame c = read_compact(b);
      for (uint32_t i : c.indices) ASSERT_LT(i, c.vertex_count());
    } catch (const InputError&) {
    }
  }
}

// Issue 35, case 8: a frame whose header claims far more triangles or vertices than its sections
// hold is refused from the counts, before anything is sized from them (a 2 KB frame claiming
// 2^28 triangles had allocated 3 GB first, then been refused by the index codec).
TEST(Compact, CountsAreCheckedAgainstTheBytesBeforeAllocating) {
  const Frame& f = frame_of(src("data/scenes/two_quads.json"), 64, 48);
  const std::string good = write_compact(f.map, f.scene, f.camera, {});
  ASSERT_LT(good.size(), 2048u);
  auto with_word = [&](size_t offset, uint32_t v) {
    std::string b = good;
    for (int k = 0; k < 4; ++k) b[offset + k] = char(v >> (8 * k));
    return b;
  };
  auto refusal = [](const std::string& b) -> std::string {
    try {
      read_compact(b);
    } catch (const InputError& e) {
      return e.element() + ": " + e.detail();
    }
    return "accepted";
  };
  const std::string many_triangles = refusal(with_word(28, 1u << 28));  // nt, the header's cap
  EXPECT_EQ(many_triangles.rfind("indices: fewer bytes than the header's 268435456 triangles", 0),
            0u)
      << many_triangles;
  const std::string many_meshes = refusal(with_word(32, 1u << 24));
  EXPECT_EQ(many_meshes.rfind("mesh table: 16777216 meshes need", 0), 0u) << many_meshes;
}

// proto/vectors/compact_cornell.vmc (and its deflate twin) decodes to what
// proto/vectors/compact_cornell.json says: every client's decoder is tested against these files.
TEST(Compact, TestVector) {
  std::ifstream in(src("proto/vectors/compact_cornell.vmc"), std::ios::binary);
  ASSERT_TRUE(in) << "missing test vector";
  std::stringstream ss;
  ss << in.rdbuf();
  const CompactFrame c = read_compact(ss.str());
  EXPECT_EQ(c.compression, Compression::Zstd);
  // The same frame coded with raw deflate (what browsers inflate) decodes to the same arrays.
  std::ifstream din(src("proto/vectors/compact_cornell_deflate.vmc"), std::ios::binary);
  std::stringstream dss;
  dss << din.rdbuf();
  const CompactFrame d = read_compact(dss.str());
  EXPECT_EQ(d.compression, Compression::Deflate);
  EXPECT_EQ(d.xy, c.xy);
  EXPECT_EQ(d.indices, c.indices);
  EXPECT_EQ(d.source, c.source);
  EXPECT_EQ(d.shade, c.shade);
  std::ifstream js(src("proto/vectors/compact_cornell.json"));
  std::stringstream jss;
  jss << js.rdbuf();
  const std::string want = jss.str();
  // The expected values as the JSON file writes them (one array per line).
  auto line = [&](const std::string& key) {
    const size_t at = want.find("\"" + key + "\"");
    EXPECT_NE(at, std::string::npos) << key;
    return want.substr(at, want.find('\n', at) - at);
  };
  auto join = [](const auto& v) {
    std::string s;
    for (size_t i = 0; i < v.size(); ++i) s += (i ? ", " : "") + std::to_string(v[i]);
    return s;
  };
  EXPECT_NE(line("xy").find("[" + join(c.xy) + "]"), std::string::npos) << join(c.xy);
  EXPECT_NE(line("indices").find("[" + join(c.indices) + "]"), std::string::npos);
  EXPECT_NE(line("source").find("[" + join(c.source) + "]"), std::string::npos);
  EXPECT_NE(line("mesh").find("[" + join(c.mesh) + "]"), std::string::npos);
  EXPECT_NE(line("shade").find("[" + join(c.shade) + "]"), std::string::npos);
  EXPECT_GT(c.triangle_count(), 100u);
}

}  // namespace
}  // namespace vismap
