// Kernel stages against small host re-implementations on tiny inputs: the scan, the binning into
// adaptive leaves, transform + clip + snap, and the silhouette hash (through the pipeline's
// screen triangles).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <map>
#include <numeric>
#include <optional>
#include <random>
#include <set>

#include "core/device/cl_runtime.h"
#include "core/error.h"
#include "core/pipeline.h"
#include "core/stages/bin.h"
#include "kernels/layout.h"
#include "tests/support/triangle_scene.h"

namespace {

using namespace vismap;

ClRuntime& runtime() {
  static ClRuntime rt("");
  static bool built = (rt.build(16), true);
  (void)built;
  return rt;
}

template <class T>
std::vector<T> read(ClRuntime& rt, cl::Buffer& b, size_t n) {
  std::vector<T> v(n);
  if (n) rt.queue().enqueueReadBuffer(b, CL_TRUE, 0, n * sizeof(T), v.data());
  return v;
}

// Each path of the scan (scan.cl): one block is one launch, up to VM_SCAN_FINISH_MAX blocks two
// (scan_blocks, scan_finish), beyond that the block sums are scanned recursively.
TEST(Stages, ScanMatchesHost) {
  ClRuntime& rt = runtime();
  std::mt19937 rng(7);
  const uint32_t two_max = VM_SCAN_FINISH_MAX * VM_SCAN_BLOCK;
  for (uint32_t n : {1u, 2u, 255u, 2048u, 2049u, 5000u, uint32_t(VM_SCAN_SMALL_MAX),
                     uint32_t(VM_SCAN_SMALL_MAX) + 1, 70000u, 5000000u, two_max, two_max + 1}) {
    std::vector<uint32_t> c(n);
    for (auto& x : c) x = rng() % 5;
    cl::Buffer in = rt.upload(c, "counts"), out = rt.alloc(size_t(n) * 4, "offsets");
    rt.reset_profile();
    uint32_t total = rt.scan(Stage::Test, in, out, n);
    const uint32_t launches = rt.collect_profile()[size_t(Stage::Test)].launches;
    // (above two_max: scan_blocks, the 4,097 block sums by scan_small, scan_add)
    EXPECT_EQ(launches, n <= VM_SCAN_SMALL_MAX ? 1u : n <= two_max ? 2u : 3u) << n;
    std::vector<uint32_t> expect(n);
    std::exclusive_scan(c.begin(), c.end(), expect.begin(), 0u);
    EXPECT_EQ(total, expect.back() + c.back()) << n;
    EXPECT_EQ(read<uint32_t>(rt, out, n), expect) << n;
  }
}

// The fused scan (ClRuntime::GroupSums, scan.cl vm_group_offset / vm_group_base) through a real
// producer and consumer, bin_depth and bin_pack: with no tile crowded every tile is one leaf, so
// tile t's first leaf, its group's base (written by the host from the groups' totals) plus its
// offset within the group, must be t; up to and past 4,096 groups (a million items).
TEST(Stages, FusedScanPlacesEveryItem) {
  ClRuntime& rt = runtime();
  for (uint32_t n : {1u, 1000u, uint32_t(VM_SCAN_FINISH_MAX) * VM_SCAN_WG,
                     uint32_t(VM_SCAN_FINISH_MAX) * VM_SCAN_WG + 1000}) {
    std::vector<uint32_t> zeros(n, 0);
    cl::Buffer offset = rt.upload(zeros, "tile offsets"), count = rt.upload(zeros, "tile counts");
    cl::Buffer bb = rt.alloc(16, "boxes"), list = rt.alloc(16, "lists");
    cl::Buffer tile_leaf = rt.alloc(size_t(n) * 4, "tile leaves");
    cl::Buffer first = rt.alloc(size_t(n) * 4, "first leaves");
    VmGrid g{8, 1024, cl_int((n + 1023) / 1024), 3};
    ClRuntime::GroupSums groups = rt.group_sums(n, "groups");
    rt.reset_profile();
    rt.launch_grouped(Stage::Test, "bin_depth", n, VM_SCAN_WG, offset, count, n, bb, g, list,
                      tile_leaf, first, groups.sums);
    EXPECT_EQ(rt.group_total(Stage::Test, groups), n);
    rt.launch_grouped(Stage::Test, "bin_pack", n, VM_SCAN_WG, n, first, groups.bases, groups.groups, tile_leaf);
    const ClRuntime::StageTime t = rt.collect_profile()[size_t(Stage::Test)];
    EXPECT_EQ(t.launches, 2u) << n;  // producer and consumer, nothing between
    EXPECT_EQ(t.syncs, 1u) << n;
    const std::vector<uint32_t> leaf = read<uint32_t>(rt, tile_leaf, n);
    uint32_t wrong = 0;
    for (uint32_t i = 0; i < n; ++i) wrong += leaf[i] != i << 4;
    EXPECT_EQ(wrong, 0u) << n;
  }
}

// Adaptive leaves (kernels/bin.cl): random boxes plus a crowd in one tile. Every leaf must list
// exactly the boxes that touch it, ordered by (class, id) with the right class starts, the crowded
// tile must split, and the class rule must hand every overlapping pair of boxes to exactly one
// leaf, as the pair traversals (cross_pairs, candidates) rely on.
TEST(Stages, AdaptiveLeavesListEveryBoxAndOwnEveryPairOnce) {
  ClRuntime& rt = runtime();
  std::mt19937 rng(11);
  const int tiles_x = 9, tiles_y = 7, shift = 6, size = 1 << shift;
  VmGrid g{size, tiles_x, tiles_y, shift};
  std::vector<cl_int4> boxes;
  for (int i = 0; i < 1500; ++i) {  // spread, some reaching past the screen's edges
    int x0 = int(rng() % 640) - 20, y0 = int(rng() % 500) - 20;
    boxes.push_back({{x0, y0, x0 + int(rng() % 120), y0 + int(rng() % 90)}});
  }
  for (int i = 0; i < 1500; ++i) {  // a crowd of small boxes inside tile (4, 3)
    int x0 = 4 * size + int(rng() % 60), y0 = 3 * size + int(rng() % 60);
    boxes.push_back({{x0, y0, x0 + int(rng() % 4), y0 + int(rng() % 4)}});
  }
  const uint32_t n = uint32_t(boxes.size()), ntiles = tiles_x * tiles_y;
  cl::Buffer bb = rt.upload(boxes, "boxes");
  // The bin stage's own host code (core/stages/bin.cpp): coarse pass, depths, leaves.
  stages::Leaves lv = stages::bin_leaves(rt, bb, n, g);
  const uint32_t nleaves = lv.leaves, lentries = lv.entries;
  ASSERT_GT(nleaves, ntiles) << "the crowded tile should split";
  auto tl = read<uint32_t>(rt, lv.tile_leaf, ntiles), loff = read<uint32_t>(rt, lv.offset, nleaves);
  auto got = read<uint32_t>(rt, lv.list, lentries);
  auto cs = read<cl_uint4>(rt, lv.class_start, nleaves);

  // Host model: leaf coordinates per tile, an item's leaves, its class in a leaf.
  auto tc = [](int v, int count) { return std::clamp(v >> 6, 0, count - 1); };
  auto lc = [&](int v, int origin, int d) {
    return std::clamp((v - origin) >> (shift - d), 0, (1 << d) - 1);
  };
  struct Leaf {
    int tx, ty, d, lx, ly;
    uint32_t id;
  };
  auto leaves_of = [&](const cl_int4& b) {
    std::vector<Leaf> out;
    for (int ty = tc(b.s[1], tiles_y); ty <= tc(b.s[3], tiles_y); ++ty)
      for (int tx = tc(b.s[0], tiles_x); tx <= tc(b.s[2], tiles_x); ++tx) {
        uint32_t t = tl[ty * tiles_x + tx], d = t & 15, f = t >> 4;
        for (int ly = lc(b.s[1], ty * size, d); ly <= lc(b.s[3], ty * size, d); ++ly)
          for (int lx = lc(b.s[0], tx * size, d); lx <= lc(b.s[2], tx * size, d); ++lx)
            out.push_back({tx, ty, int(d), lx, ly, f + uint32_t(ly * (1 << d) + lx)});
      }
    return out;
  };
  auto klass = [&](const cl_int4& b, const Leaf& l) {
    bool sx = tc(b.s[0], tiles_x) == l.tx && lc(b.s[0], l.tx * size, l.d) == l.lx;
    bool sy = tc(b.s[1], tiles_y) == l.ty && lc(b.s[1], l.ty * size, l.d) == l.ly;
    return uint32_t(sx ? 0 : 1) | uint32_t(sy ? 0 : 2);
  };
  std::vector<std::vector<uint64_t>> expect(nleaves);  // (class << 32 | id), sorted
  std::vector<std::vector<Leaf>> item_leaves(n);
  for (uint32_t i = 0; i < n; ++i) {
    item_leaves[i] = leaves_of(boxes[i]);
    for (const Leaf& l : item_leaves[i])
      expect[l.id].push_back(uint64_t(klass(boxes[i], l)) << 32 | i);
  }
  for (uint32_t l = 0; l < nleaves; ++l) {
    std::sort(expect[l].begin(), expect[l].end());
    ASSERT_EQ(cs[l].s[3], expect[l].size()) << "leaf " << l;
    uint32_t starts[4] = {0, cs[l].s[0], cs[l].s[1], cs[l].s[2]};
    for (size_t k = 0; k < expect[l].size(); ++k) {
      ASSERT_EQ(got[loff[l] + k], uint32_t(expect[l][k])) << "leaf " << l << " entry " << k;
      uint32_t c = uint32_t(expect[l][k] >> 32);
      EXPECT_TRUE(k >= starts[c] && (c == 3 ? k < cs[l].s[3] : k < starts[c + 1])) << "leaf " << l;
    }
  }
  // Every pair of boxes whose overlap has positive area, found from its lower member through the
  // partner classes, exactly once.
  const uint32_t partners[4] = {15, 5, 3, 1};
  std::map<std::pair<uint32_t, uint32_t>, int> found;
  for (uint32_t i = 0; i < n; ++i)
    for (const Leaf& l : item_leaves[i]) {
      uint32_t want = partners[klass(boxes[i], l)];
      for (size_t k = 0; k < cs[l.id].s[3]; ++k) {
        uint32_t j = got[loff[l.id] + k];
        uint32_t cj = k < cs[l.id].s[0] ? 0 : k < cs[l.id].s[1] ? 1 : k < cs[l.id].s[2] ? 2 : 3;
        if (j <= i || !((want >> cj) & 1)) continue;
        const cl_int4 &a = boxes[i], &b = boxes[j];
        if (std::max(a.s[0], b.s[0]) >= std::min(a.s[2], b.s[2]) ||
            std::max(a.s[1], b.s[1]) >= std::min(a.s[3], b.s[3]))
          continue;
        ++found[{i, j}];
      }
    }
  size_t overlapping = 0;
  for (uint32_t i = 0; i < n; ++i)
    for (uint32_t j = i + 1; j < n; ++j) {
      const cl_int4 &a = boxes[i], &b = boxes[j];
      if (std::max(a.s[0], b.s[0]) >= std::min(a.s[2], b.s[2]) ||
          std::max(a.s[1], b.s[1]) >= std::min(a.s[3], b.s[3]))
        continue;
      ++overlapping;
      auto it = found.find({i, j});
      ASSERT_TRUE(it != found.end() && it->second == 1) << "pair " << i << "," << j;
    }
  EXPECT_EQ(found.size(), overlapping);
}

// --- transform + clip + snap, against a host version in double ---------------------------------

struct HostTri {
  int x[3], y[3];
};

std::vector<HostTri> host_clip(const Scene& s, const Camera& cam) {
  Mat4 m = cam.view_projection();
  std::vector<HostTri> out;
  const double sx = cam.width * VM_GRID_SCALE * 0.5, sy = cam.height * VM_GRID_SCALE * 0.5;
  for (const Mesh& mesh : s.meshes)
    for (size_t t = 0; t < mesh.triangle_count(); ++t) {
      std::vector<std::array<double, 4>> poly;
      for (int k = 0; k < 3; ++k) {
        const float* p = &mesh.positions[3 * mesh.indices[3 * t + k]];
        std::array<double, 4> c{};
        for (int r = 0; r < 4; ++r)
          c[r] = m[r] * p[0] + m[4 + r] * p[1] + m[8 + r] * p[2] + m[12 + r];
        poly.push_back(c);
      }
      auto dist = [](const std::array<double, 4>& p, int k) {
        switch (k) {
          case 0:
            return p[2] + p[3];
          case 1:
            return p[3] - p[2];
          case 2:
            return p[0] + p[3];
          case 3:
            return p[3] - p[0];
          case 4:
            return p[1] + p[3];
          default:
            return p[3] - p[1];
        }
      };
      for (int k = 0; k < 6 && !poly.empty(); ++k) {
        std::vector<std::array<double, 4>> np;
        for (size_t i = 0; i < poly.size(); ++i) {
          auto a = poly[i], b = poly[(i + 1) % poly.size()];
          double da = dist(a, k), db = dist(b, k);
          if (da >= 0) np.push_back(a);
          if ((da >= 0) != (db >= 0)) {
            double tt = da / (da - db);
            std::array<double, 4> r;
            for (int c = 0; c < 4; ++c) r[c] = a[c] + (b[c] - a[c]) * tt;
            np.push_back(r);
          }
        }
        poly = np;
      }
      if (poly.size() < 3) continue;
      std::vector<std::array<int, 2>> g;
      for (auto& p : poly)
        g.push_back(
            {int(std::rint((p[0] / p[3] + 1) * sx)), int(std::rint((1 - p[1] / p[3]) * sy))});
      for (size_t i = 1; i + 1 < g.size(); ++i) {
        HostTri h{{g[0][0], g[i][0], g[i + 1][0]}, {g[0][1], g[i][1], g[i + 1][1]}};
        long o =
            long(h.x[1] - h.x[0]) * (h.y[2] - h.y[0]) - long(h.y[1] - h.y[0]) * (h.x[2] - h.x[0]);
        if (o != 0) out.push_back(h);
      }
    }
  return out;
}

Scene random_soup(uint32_t seed, int n, double spread) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-spread, spread);
  Scene s;
  Mesh m;
  m.name = "soup";
  m.soup = true;
  for (int t = 0; t < n; ++t) {
    for (int k = 0; k < 3; ++k) {
      m.positions.push_back(float(u(rng)));
      m.positions.push_back(float(u(rng)));
      m.positions.push_back(float(u(rng)));
      m.indices.push_back(3 * t + k);
    }
    m.face_ids.push_back(t);
  }
  m.source_triangles = n;
  s.meshes.push_back(m);
  return s;
}

TEST(Stages, TransformClipSnapMatchesHost) {
  for (uint32_t seed = 1; seed <= 4; ++seed) {
    // Triangles around the camera: many cross the near plane, some lie behind the eye.
    Scene s = random_soup(seed, 60, 3.0);
    Camera cam;
    cam.eye = {0, 0, 0.5};
    cam.target = {0, 0, -1};
    cam.near_plane = 0.1;
    cam.far_plane = 10;
    cam.width = 320;
    cam.height = 200;
    Renderer r;
    ScreenTriangles st;
    r.render(s, cam, {}, nullptr, &st);
    std::vector<HostTri> h = host_clip(s, cam);
    ASSERT_EQ(st.size(), h.size()) << "seed " << seed;
    // Vertices may differ by one grid unit where the device contracted a multiply-add.
    for (size_t i = 0; i < h.size(); ++i) {
      std::multiset<std::pair<int, int>> a, b;
      for (int k = 0; k < 3; ++k) {
        a.insert({st.xy[6 * i + 2 * k], st.xy[6 * i + 2 * k + 1]});
        b.insert({h[i].x[k], h[i].y[k]});
      }
      auto ia = a.begin(), ib = b.begin();
      for (; ia != a.end(); ++ia, ++ib) {
        EXPECT_LE(std::abs(ia->first - ib->first), 1) << "seed " << seed << " tri " << i;
        EXPECT_LE(std::abs(ia->second - ib->second), 1) << "seed " << seed << " tri " << i;
      }
    }
  }
}

// --- silhouette hash: brute-force pairing of screen-triangle edges on the host ------------------

// Keyed by the screen positions only: the hash keys on the transformed depths too (to keep apart
// distinct surfaces whose edges meet on the screen; none do here), but ScreenTriangles holds the
// depths after snap_depth_planes, where mesh neighbours no longer share them exactly.
uint64_t host_silhouettes(const ScreenTriangles& st) {
  struct Key {
    int x0, y0, x1, y1;
    double q0, q1;
    bool operator<(const Key& o) const {
      return std::tie(x0, y0, q0, x1, y1, q1) < std::tie(o.x0, o.y0, o.q0, o.x1, o.y1, o.q1);
    }
  };
  std::map<Key, std::vector<std::pair<size_t, int>>> groups;
  for (size_t t = 0; t < st.size(); ++t)
    for (int k = 0; k < 3; ++k) {
      int k1 = (k + 1) % 3;
      Key a{st.xy[6 * t + 2 * k],
            st.xy[6 * t + 2 * k + 1],
            st.xy[6 * t + 2 * k1],
            st.xy[6 * t + 2 * k1 + 1],
            0,
            0};
      if (std::tie(a.x1, a.y1, a.q1) < std::tie(a.x0, a.y0, a.q0)) {
        std::swap(a.x0, a.x1);
        std::swap(a.y0, a.y1);
        std::swap(a.q0, a.q1);
      }
      groups[a].push_back({t, (k + 2) % 3});
    }
  uint64_t sil = 0;
  for (auto& [k, v] : groups) {
    if (v.size() != 2) {
      ++sil;
      continue;
    }
    auto side = [&](std::pair<size_t, int> e) {
      long x = st.xy[6 * e.first + 2 * e.second], y = st.xy[6 * e.first + 2 * e.second + 1];
      long o = long(k.x1 - k.x0) * (y - k.y0) - long(k.y1 - k.y0) * (x - k.x0);
      return (o > 0) - (o < 0);
    };
    if (side(v[0]) * side(v[1]) >= 0) ++sil;
  }
  return sil;
}

Scene grid_surface(int n, double fold) {
  // A height field folded over itself: indexed, with shared vertices and real folds.
  Scene s;
  Mesh m;
  m.name = "fold";
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) {
      double u = double(i) / n, v = double(j) / n;
      m.positions.push_back(float(std::sin(u * fold) * 0.8));
      m.positions.push_back(float(v - 0.5));
      m.positions.push_back(float(std::cos(u * fold) * 0.4 - 0.2 * v));
    }
  test_support::add_grid_triangles(m, n);
  s.meshes.push_back(m);
  return s;
}

TEST(Stages, SilhouetteHashMatchesBruteForce) {
  Camera cam;
  cam.eye = {0.3, 0.4, 3};
  cam.target = {0, 0, 0};
  cam.near_plane = 0.5;
  cam.far_plane = 10;
  cam.width = cam.height = 256;
  Renderer r;
  // The hash's silhouettes of every screen triangle: without the cull, which would leave out
  // hidden triangles and count the kept ones' silhouettes (tests/test_cull.cpp).
  RenderOptions no_cull;
  no_cull.cull = false;
  for (double fold : {1.0, 4.0, 9.0}) {
    Scene s = grid_surface(12, fold);
    ScreenTriangles st;
    RenderStats stats;
    r.render(s, cam, no_cull, &stats, &st);
    ASSERT_GT(st.size(), 0u);
    EXPECT_EQ(stats.silhouette_edges, host_silhouettes(st)) << "fold " << fold;
  }
  Scene soup = random_soup(3, 40, 1.0);  // heavily interpenetrating: keep it small
  ScreenTriangles st;
  RenderStats stats;
  r.render(soup, cam, no_cull, &stats, &st);
  EXPECT_EQ(stats.silhouette_edges, host_silhouettes(st));
}

TEST(Stages, HostSyncsAreOnePerSixClipRoundsPlusAFewPerStage) {
  // Each blocking read is a round trip the host waits for (~17 us on an H100, against a 0.5 ms
  // target for the bunny): counted, and held to one per six clip rounds plus the stages' fixed ones
  // (scan totals, statuses, the thin count, the read-back), so that a new one shows here.
  Camera cam;
  cam.eye = {0, 0, 5};
  cam.near_plane = 0.5;
  cam.far_plane = 10;
  cam.width = cam.height = 256;
  Renderer r;
  for (double fold : {1.0, 9.0}) {
    RenderStats stats;
    r.render(grid_surface(12, fold), cam, {}, &stats);
    ASSERT_GT(stats.clip_rounds, 0u);
    // The clip rounds: an exact first pass of up to three, then one read per two passes of
    // three (issue 17), and one more exact pass for each stop (none expected here).
    uint32_t clip_syncs = 0;
    for (const StageStat& s : stats.stages)
      if (s.name == "clip") clip_syncs = s.host_syncs;
    // The folded surface (fold 9) needs more lines per fragment on a fresh program: its first
    // clipping stops and runs again after a rebuild, and the first try's reads count too.
    EXPECT_GE(clip_syncs, 1u) << "fold " << fold;
    if (fold == 1.0) {
      const uint32_t batches = (stats.clip_rounds - 1 + 5) / 6;  // after a first of >= 1 round
      EXPECT_LE(clip_syncs, 1 + batches);
      // Launches (issue 17): a clip pass is two (clip_find scans its groups' counts, clip_apply
      // sums them) and runs three rounds, the other stages' fixed ones fused (scans of one or
      // two launches, no fills beside kernels): a new launch shows here.
      uint32_t clip_launches = 0;
      for (const StageStat& s : stats.stages)
        if (s.name == "clip") clip_launches = s.launches;
      EXPECT_LE(clip_launches, 1 + 2 * (1 + 2 * batches)) << stats.clip_rounds;
      // 36 on this surface, and the cull's 5 (issue 32: entries, leaves, triangles, the kept
      // silhouettes' fill and classification; no blocking read)
      EXPECT_LE(stats.launches, clip_launches + 36 + 5);
    }
    EXPECT_LE(clip_syncs, stats.clip_rounds + 2) << "fold " << fold;
    EXPECT_LE(stats.host_syncs, clip_syncs + 14) << "fold " << fold;
    EXPECT_GT(stats.host_syncs, clip_syncs) << "fold " << fold;
  }
}

// Launch errors name the kernel and the stage: a wrong argument count is caught before anything
// is set (CL_KERNEL_NUM_ARGS), and an argument the runtime refuses names its index.
TEST(Stages, LaunchErrorsNameKernelAndStage) {
  ClRuntime& rt = runtime();
  cl::Buffer b = rt.alloc(64, "b");
  try {
    rt.launch(Stage::Bin, "zero_words2", 4, cl_uint(4));  // takes (n, a, b)
    FAIL() << "a launch with too few arguments must throw";
  } catch (const DeviceError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("zero_words2"), std::string::npos) << m;
    EXPECT_NE(m.find("stage bin"), std::string::npos) << m;
    EXPECT_NE(m.find("1 arguments; the kernel takes 3"), std::string::npos) << m;
  }
  try {
    rt.launch(Stage::Clip, "zero_words2", 4, b, b, b);  // a buffer where a uint goes
    FAIL() << "an argument of the wrong size must throw";
  } catch (const DeviceError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("zero_words2"), std::string::npos) << m;
    EXPECT_NE(m.find("stage clip"), std::string::npos) << m;
    EXPECT_NE(m.find("argument 0"), std::string::npos) << m;
  }
  rt.launch(Stage::Test, "zero_words2", 4, cl_uint(4), b, b);  // the right call still works
  rt.queue().finish();
}

}  // namespace

namespace {

// The upload is kept by content, not by address: the same Scene object changed in place (the
// same vectors, the same triangle count, as a scene freed and another loaded in its place can
// be) is uploaded again, and its frame is the new scene's.
TEST(Stages, ASceneChangedInPlaceIsUploadedAgain) {
  using namespace vismap;
  Scene s;
  test_support::add_triangle(s, "t", {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}});
  const Camera cam = frame_scene(s, 64, 64);
  Renderer r;
  const PlanarMap a = r.render(s, cam);
  s.meshes[0].positions[3] = 0.5f;  // the second corner moves in place
  const PlanarMap b = r.render(s, cam);
  Renderer fresh;
  const PlanarMap c = fresh.render(s, cam);
  EXPECT_NE(a.xy, b.xy);
  EXPECT_EQ(b.xy, c.xy);
}

// The 64-bit fingerprint the Renderer keyed its upload by at a3eef30 (Scene::geometry_fingerprint,
// since removed), for crafting a collision with it: four multiply-xor lanes over 32-byte
// blocks, each lane's step invertible, so one block can bring the lanes back to any state.
namespace old_fingerprint {
constexpr uint64_t kMul = 0x9E3779B97F4A7C15ull;
struct Lanes {
  uint64_t l[4];
};
Lanes start(uint64_t seed) {
  return {{seed, seed ^ 0x243F6A8885A308D3ull, seed ^ 0x13198A2E03707344ull,
           seed ^ 0xA4093822299F31D0ull}};
}
void block(Lanes& s, const unsigned char* p) {
  for (int k = 0; k < 4; ++k) {
    uint64_t w;
    std::memcpy(&w, p + 8 * k, 8);
    s.l[k] = (s.l[k] ^ w) * kMul;
    s.l[k] ^= s.l[k] >> 29;
  }
}
uint64_t words(const void* data, size_t bytes, uint64_t seed) {
  Lanes s = start(seed);
  const unsigned char* p = static_cast<const unsigned char*>(data);
  size_t i = 0;
  for (; i + 32 <= bytes; i += 32) block(s, p + i);
  uint64_t tail[4] = {0, 0, 0, 0};
  std::memcpy(tail, p + i, bytes - i);
  uint64_t h = bytes * kMul;
  for (int k = 0; k < 4; ++k) {
    s.l[k] = (s.l[k] ^ tail[k]) * kMul;
    h = (h ^ (s.l[k] ^ (s.l[k] >> 31))) * kMul;
    h ^= h >> 32;
  }
  return h;
}
uint64_t of(const Scene& sc) {
  uint64_t h = sc.meshes.size();
  for (const Mesh& m : sc.meshes) {
    h = words(m.positions.data(), m.positions.size() * sizeof(float), h);
    h = words(m.indices.data(), m.indices.size() * sizeof(uint32_t), h);
  }
  return h;
}
}  // namespace old_fingerprint

// Issue 45, item 4: the Renderer skipped an upload when the 64-bit fingerprint matched, and
// that hash is not collision resistant: one 32-byte block of positions cancels any change
// before it. Here scene b moves a vertex of scene a (a different picture) and then sets the
// next 32-byte block (the positions of vertices no triangle uses) so that both fingerprints
// are equal. A renderer that drew a must draw b as a fresh renderer does; at a3eef30 it kept
// a's upload and drew a's frame again.
TEST(Stages, ACraftedFingerprintCollisionIsUploadedAgain) {
  // 8 used vertices (a 4 x 2 strip, 6 triangles) and 3 that no triangle uses: 33 floats, the
  // fourth 32-byte block (floats 24 ... 31) in the unused ones, float 32 in the tail.
  auto make = [](float moved_x, float moved_y, const float(&stray)[9]) {
    Mesh m;
    m.name = "strip";
    for (int j = 0; j < 2; ++j)
      for (int i = 0; i < 4; ++i) m.positions.insert(m.positions.end(), {float(i), float(j), 0.f});
    m.positions[3 * 5] = moved_x;  // vertex 5, (1, 1, 0) in scene a
    m.positions[3 * 5 + 1] = moved_y;
    m.positions.insert(m.positions.end(), std::begin(stray), std::end(stray));
    for (uint32_t i = 0; i < 3; ++i) {
      const uint32_t a = i, b = i + 1, c = i + 4, d = i + 5;
      m.indices.insert(m.indices.end(), {a, b, d, a, d, c});
      m.face_ids.insert(m.face_ids.end(), {2 * i, 2 * i + 1});
    }
    m.source_triangles = 6;
    Scene s;
    s.meshes.push_back(std::move(m));
    return s;
  };
  const float stray_a[9] = {0.25f, 0.5f, 0.75f, 1.25f, 1.5f, 1.75f, 2.25f, 2.5f, 2.75f};
  const Scene a = make(1.f, 1.f, stray_a);
  // The lanes after the first three blocks (floats 0 ... 23) of a mesh's positions.
  auto lanes_after_3 = [](const Scene& s) {
    old_fingerprint::Lanes l = old_fingerprint::start(1);  // seed: the mesh count
    for (int b = 0; b < 3; ++b)
      old_fingerprint::block(
          l, reinterpret_cast<const unsigned char*>(s.meshes[0].positions.data()) + 32 * b);
    return l;
  };
  const old_fingerprint::Lanes la = lanes_after_3(a);
  std::optional<Scene> b;
  for (int t = 0; t < 100000 && !b; ++t) {
    float stray_b[9];
    std::copy(std::begin(stray_a), std::end(stray_a), stray_b);
    Scene trial = make(1.3f + 1e-4f * float(t), 1.4f + 1e-4f * float(t), stray_a);
    const old_fingerprint::Lanes lb = lanes_after_3(trial);
    // Block 3 of b: a's words xor the lanes' difference, so that both lanes agree after it.
    unsigned char blk[32];
    std::memcpy(blk, a.meshes[0].positions.data() + 24, 32);
    for (int k = 0; k < 4; ++k) {
      uint64_t w;
      std::memcpy(&w, blk + 8 * k, 8);
      w ^= la.l[k] ^ lb.l[k];
      std::memcpy(blk + 8 * k, &w, 8);
    }
    std::memcpy(stray_b, blk, 32);  // floats 24 ... 31 are stray_b[0 ... 7]
    // Tame values only (finite, |x| <= 1e4), so that nothing but the moved vertex can matter.
    bool tame = true;
    for (int k = 0; k < 8; ++k)
      tame = tame && std::isfinite(stray_b[k]) && std::fabs(stray_b[k]) <= 1e4f;
    if (tame) b = make(1.3f + 1e-4f * float(t), 1.4f + 1e-4f * float(t), stray_b);
  }
  ASSERT_TRUE(b) << "no tame collision block found";
  ASSERT_EQ(old_fingerprint::of(a), old_fingerprint::of(*b)) << "the crafted collision";
  ASSERT_NE(a.meshes[0].positions, b->meshes[0].positions);

  const Camera cam = frame_scene(a, 96, 64);
  Renderer r;
  const PlanarMap pa = r.render(a, cam);
  const PlanarMap pb = r.render(*b, cam);
  Renderer fresh;
  const PlanarMap want = fresh.render(*b, cam);
  EXPECT_NE(pa.xy, want.xy) << "the two scenes must draw differently";
  EXPECT_EQ(pb.xy, want.xy) << "scene b drew scene a's upload";
  // And back: a again after b is a's picture, not b's.
  EXPECT_EQ(r.render(a, cam).xy, pa.xy);
}

}  // namespace
