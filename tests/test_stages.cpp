// Kernel stages against small host re-implementations on tiny inputs: the scan, the binning,
// transform + clip + snap, and the silhouette hash (through the pipeline's screen triangles).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <numeric>
#include <random>
#include <set>

#include "core/cl_runtime.h"
#include "core/pipeline.h"
#include "kernels/layout.h"

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

TEST(Stages, ScanMatchesHost) {
  ClRuntime& rt = runtime();
  std::mt19937 rng(7);
  for (uint32_t n : {1u, 2u, 255u, 2048u, 2049u, 70000u, 5000000u}) {
    std::vector<uint32_t> c(n);
    for (auto& x : c) x = rng() % 5;
    cl::Buffer in = rt.upload(c, "counts"), out = rt.alloc(n * 4, "offsets");
    uint32_t total = rt.scan("test", in, out, n);
    std::vector<uint32_t> expect(n);
    std::exclusive_scan(c.begin(), c.end(), expect.begin(), 0u);
    EXPECT_EQ(total, expect.back() + c.back()) << n;
    EXPECT_EQ(read<uint32_t>(rt, out, n), expect) << n;
  }
}

TEST(Stages, BinningMatchesHostAndIsSorted) {
  ClRuntime& rt = runtime();
  std::mt19937 rng(11);
  const uint32_t n = 3000;
  VmGrid g{64, 9, 7, 6};
  std::vector<cl_int4> boxes(n);
  for (auto& b : boxes) {
    int x0 = rng() % 600, y0 = rng() % 460;
    b = {{x0, y0, x0 + int(rng() % 120), y0 + int(rng() % 90)}};
  }
  cl::Buffer bb = rt.upload(boxes, "boxes");
  const uint32_t ntiles = 9 * 7;
  cl::Buffer count = rt.alloc(ntiles * 4, "c"), offset = rt.alloc(ntiles * 4, "o"),
             cursor = rt.alloc(ntiles * 4, "k");
  rt.fill_u32(count, 0, ntiles, "test");
  rt.fill_u32(cursor, 0, ntiles, "test");
  rt.launch("test", "bin_count", n, bb, n, g, count);
  uint32_t pairs = rt.scan("test", count, offset, ntiles);
  cl::Buffer list = rt.alloc(pairs * 4, "list");
  rt.launch("test", "bin_fill", n, bb, n, g, offset, cursor, list);
  rt.launch("test", "bin_sort", ntiles, offset, count, ntiles, list);
  auto off = read<uint32_t>(rt, offset, ntiles), cnt = read<uint32_t>(rt, count, ntiles);
  auto got = read<uint32_t>(rt, list, pairs);
  std::vector<std::vector<uint32_t>> expect(ntiles);
  for (uint32_t i = 0; i < n; ++i) {
    auto tc = [](int v, int count) { return std::clamp(v / 64, 0, count - 1); };
    for (int ty = tc(boxes[i].s[1], 7); ty <= tc(boxes[i].s[3], 7); ++ty)
      for (int tx = tc(boxes[i].s[0], 9); tx <= tc(boxes[i].s[2], 9); ++tx) expect[ty * 9 + tx].push_back(i);
  }
  for (uint32_t t = 0; t < ntiles; ++t) {
    std::vector<uint32_t> tile(got.begin() + off[t], got.begin() + off[t] + cnt[t]);
    EXPECT_EQ(tile, expect[t]) << "tile " << t;
  }
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
        for (int r = 0; r < 4; ++r) c[r] = m[r] * p[0] + m[4 + r] * p[1] + m[8 + r] * p[2] + m[12 + r];
        poly.push_back(c);
      }
      auto dist = [](const std::array<double, 4>& p, int k) {
        switch (k) {
          case 0: return p[2] + p[3];
          case 1: return p[3] - p[2];
          case 2: return p[0] + p[3];
          case 3: return p[3] - p[0];
          case 4: return p[1] + p[3];
          default: return p[3] - p[1];
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
        g.push_back({int(std::rint((p[0] / p[3] + 1) * sx)), int(std::rint((1 - p[1] / p[3]) * sy))});
      for (size_t i = 1; i + 1 < g.size(); ++i) {
        HostTri h{{g[0][0], g[i][0], g[i + 1][0]}, {g[0][1], g[i][1], g[i + 1][1]}};
        long o = long(h.x[1] - h.x[0]) * (h.y[2] - h.y[0]) - long(h.y[1] - h.y[0]) * (h.x[2] - h.x[0]);
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
      Key a{st.xy[6 * t + 2 * k], st.xy[6 * t + 2 * k + 1], st.xy[6 * t + 2 * k1], st.xy[6 * t + 2 * k1 + 1],
            st.depth[3 * t + k], st.depth[3 * t + k1]};
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
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      uint32_t a = j * (n + 1) + i, b = a + 1, c = a + n + 1, d = c + 1;
      m.indices.insert(m.indices.end(), {a, b, d, a, d, c});
      m.face_ids.push_back(2 * (j * n + i));
      m.face_ids.push_back(2 * (j * n + i) + 1);
    }
  m.source_triangles = 2 * n * n;
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
  for (double fold : {1.0, 4.0, 9.0}) {
    Scene s = grid_surface(12, fold);
    ScreenTriangles st;
    RenderStats stats;
    r.render(s, cam, {}, &stats, &st);
    ASSERT_GT(st.size(), 0u);
    EXPECT_EQ(stats.silhouette_edges, host_silhouettes(st)) << "fold " << fold;
  }
  Scene soup = random_soup(3, 40, 1.0);  // heavily interpenetrating: keep it small
  ScreenTriangles st;
  RenderStats stats;
  r.render(soup, cam, {}, &stats, &st);
  EXPECT_EQ(stats.silhouette_edges, host_silhouettes(st));
}

}  // namespace
