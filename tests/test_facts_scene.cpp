// The scene's view-independent facts (core/facts/scene_facts.h): the triangle distance they are
// built on against dense sampling, the adjacency against a brute-force scan, every clearance a
// lower bound of the true distance to every triangle not sharing a vertex, and the per-view
// need. (That a frame using them keeps every map the same: tests/test_cull.cpp.)
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <random>
#include <set>

#include "core/facts/scene_facts.h"

namespace {

using namespace vismap;
using Tri = std::array<std::array<double, 3>, 3>;

std::array<double, 3> point_at(const Tri& t, double u, double v) {
  std::array<double, 3> p;
  for (int d = 0; d < 3; ++d) p[d] = t[0][d] + u * (t[1][d] - t[0][d]) + v * (t[2][d] - t[0][d]);
  return p;
}

// Min over a dense sample of both triangles: an upper bound of their distance, within
// `slack` of it (the sample's spacing times the triangles' size).
double sampled_distance(const Tri& a, const Tri& b, int n) {
  std::vector<std::array<double, 3>> pa, pb;
  for (int i = 0; i <= n; ++i)
    for (int j = 0; i + j <= n; ++j) {
      pa.push_back(point_at(a, double(i) / n, double(j) / n));
      pb.push_back(point_at(b, double(i) / n, double(j) / n));
    }
  double best = INFINITY;
  for (const auto& p : pa)
    for (const auto& q : pb)
      best = std::min(best, std::hypot(p[0] - q[0], p[1] - q[1], p[2] - q[2]));
  return best;
}

Tri random_tri(std::mt19937_64& rng, double spread) {
  std::uniform_real_distribution<double> c(-spread, spread), s(-0.5, 0.5);
  std::array<double, 3> o{c(rng), c(rng), c(rng)};
  Tri t;
  for (auto& v : t)
    for (int d = 0; d < 3; ++d) v[d] = o[d] + s(rng);
  return t;
}

TEST(SceneFacts, TriangleDistanceAgreesWithSampling) {
  std::mt19937_64 rng(7);
  int meeting = 0;
  for (int k = 0; k < 150; ++k) {
    const Tri a = random_tri(rng, 0.4), b = random_tri(rng, 0.4);
    const double d = facts::triangle_distance(a, b), s = sampled_distance(a, b, 40);
    // Never above a true distance (the sample's is one), and near it (spacing 1/40 of edges
    // about 1 long).
    EXPECT_LE(d, s + 1e-12) << k;
    EXPECT_GE(d, s - 0.06) << k;
    meeting += d == 0;
  }
  EXPECT_GT(meeting, 15);  // the sample has penetrating pairs, found as distance 0
}

TEST(SceneFacts, TriangleDistanceEdgeCases) {
  const Tri base{{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}};
  // Parallel above: the height.
  Tri above = base;
  for (auto& v : above) v[2] = 0.25;
  EXPECT_NEAR(facts::triangle_distance(base, above), 0.25, 1e-12);
  // Through the interior without any edge near another: 0.
  const Tri pierce{{{0.2, 0.2, -1}, {0.3, 0.2, 1}, {0.2, 0.3, 1}}};
  EXPECT_EQ(facts::triangle_distance(base, pierce), 0.0);
  // Coplanar, apart along x.
  const Tri beside{{{1.5, 0, 0}, {2.5, 0, 0}, {1.5, 1, 0}}};
  EXPECT_NEAR(facts::triangle_distance(base, beside), 0.5, 1e-12);
  // A degenerate (collinear) partner: its segment's distance.
  const Tri needle{{{0.5, 0.5, 1}, {0.5, 0.5, 2}, {0.5, 0.5, 1.5}}};
  EXPECT_NEAR(facts::triangle_distance(base, needle), 1.0, 1e-12);
  // Crossing edges, nearly parallel planes.
  const Tri tilted{{{-1, 0.5, 1e-9}, {2, 0.5, -1e-9}, {0.5, 3, 0}}};
  EXPECT_EQ(facts::triangle_distance(base, tilted), 0.0);
}

// A small scene: a grid mesh folded over itself (two sheets close together), a separate
// triangle touching it at a vertex position (another mesh), and a far one.
Scene folded_scene(double gap) {
  Scene s;
  Mesh m;
  const int n = 8;
  for (int sheet = 0; sheet < 2; ++sheet)
    for (int j = 0; j <= n; ++j)
      for (int i = 0; i <= n; ++i) {
        m.positions.push_back(float(i) / n);
        m.positions.push_back(float(j) / n);
        m.positions.push_back(sheet ? float(gap) : 0.0f);
      }
  for (int sheet = 0; sheet < 2; ++sheet)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        const uint32_t o = sheet * (n + 1) * (n + 1), a = o + j * (n + 1) + i;
        for (uint32_t v : {a, a + 1, a + n + 2, a, a + n + 2, a + n + 1}) m.indices.push_back(v);
      }
  s.meshes.push_back(m);
  Mesh t;  // shares the position (1, 1, 0) with the grid's corner, not an index
  t.positions = {1, 1, 0, 2, 1, 0, 1, 2, 0.5f};
  t.indices = {0, 1, 2};
  s.meshes.push_back(t);
  Mesh far;
  far.positions = {10, 10, 10, 11, 10, 10, 10, 11, 10};
  far.indices = {0, 1, 2};
  s.meshes.push_back(far);
  return s;
}

std::vector<Tri> triangles_of(const Scene& s) {
  std::vector<Tri> out;
  for (const Mesh& m : s.meshes)
    for (size_t t = 0; t < m.triangle_count(); ++t) {
      Tri x;
      for (int k = 0; k < 3; ++k)
        for (int d = 0; d < 3; ++d) x[k][d] = m.positions[3 * m.indices[3 * t + k] + d];
      out.push_back(x);
    }
  return out;
}

double perimeter(const Tri& t) {
  double p = 0;
  for (int i = 0; i < 3; ++i) {
    const auto &a = t[i], &b = t[(i + 1) % 3];
    p += std::hypot(a[0] - b[0], a[1] - b[1], a[2] - b[2]);
  }
  return p;
}

bool share_position(const Tri& a, const Tri& b) {
  for (const auto& p : a)
    for (const auto& q : b)
      if (p == q) return true;
  return false;
}

TEST(SceneFacts, AdjacencyAndClearancesAgreeWithBruteForce) {
  for (double gap : {1e-5, 1e-3, 0.05}) {
    const Scene s = folded_scene(gap);
    const facts::SceneFacts f = facts::find_scene_facts(s);
    const std::vector<Tri> tri = triangles_of(s);
    ASSERT_EQ(f.clearance.size(), tri.size());
    ASSERT_GT(f.cap, 0);
    for (uint32_t t = 0; t < tri.size(); ++t) {
      std::set<uint32_t> want, got(f.adj.begin() + f.adj_offset[t],
                                   f.adj.begin() + f.adj_offset[t + 1]);
      double nearest = INFINITY, margined = INFINITY;
      for (uint32_t u = 0; u < tri.size(); ++u) {
        if (u == t) continue;
        if (share_position(tri[t], tri[u])) {
          if (u > t) want.insert(u);
        } else {
          const double d = facts::triangle_distance(tri[t], tri[u]);
          nearest = std::min(nearest, d);
          margined = std::min(margined, d - std::ldexp(perimeter(tri[t]) + perimeter(tri[u]), -19));
        }
      }
      EXPECT_EQ(got, want) << "gap " << gap << " triangle " << t;
      // A lower bound, capped; and below the truth where the truth is under the cap by no more
      // than its rounding margin (2^-19 of the two perimeters).
      EXPECT_LE(f.clearance[t], std::min(nearest, f.cap)) << "gap " << gap << " triangle " << t;
      if (nearest < f.cap) EXPECT_GE(f.clearance[t], margined * (1 - 1e-6) - 1e-9) << t;
    }
    // The corner triangle of the other mesh is the grid corner's neighbour (by position).
    const uint32_t corner_tri = uint32_t(tri.size() - 2);
    bool found = false;
    for (uint32_t t = 0; t < corner_tri; ++t)
      for (uint32_t k = f.adj_offset[t]; k < f.adj_offset[t + 1]; ++k) found |= f.adj[k] == corner_tri;
    EXPECT_TRUE(found) << gap;
    // The far triangle is at the cap; the sheets' triangles are within the gap of each other.
    EXPECT_EQ(f.clearance.back(), float(f.cap));
    EXPECT_LE(f.clearance[0], gap);
  }
}

// The bins count from below: the fraction they give never passes the true one.
TEST(SceneFacts, ApartFractionIsALowerBound) {
  for (double gap : {1e-5, 1e-3, 0.05}) {
    const facts::SceneFacts f = facts::find_scene_facts(folded_scene(gap));
    for (double need : {0.0, 1e-9, 1e-6, 1e-5, 1e-4, f.cap / 3, f.cap}) {
      size_t n = 0;
      for (float c : f.clearance) n += c > need;
      const double truth = double(n) / f.clearance.size(), bound = facts::apart_fraction(f, need);
      EXPECT_LE(bound, truth) << gap << " " << need;
      if (need == 0) EXPECT_EQ(bound, truth) << gap;  // (every clearance here is above cap 2^-63)
    }
    EXPECT_EQ(facts::apart_fraction(f, f.cap), 0.0);
  }
}

TEST(SceneFacts, NeedFollowsTheViewAndIsOffWhereNotDerived) {
  const Scene s = folded_scene(0.05);
  const facts::SceneFacts f = facts::find_scene_facts(s);
  Camera cam = frame_scene(s, 1024, 1024);
  double qmax = 0;
  const double near_need = facts::crossing_skip_distance(f, cam, &qmax);
  ASSERT_TRUE(std::isfinite(near_need));
  EXPECT_GT(near_need, 0);
  EXPECT_GT(qmax, 0);
  // A smaller viewport blurs more (a grid unit is larger in the world).
  Camera small = cam;
  small.width = small.height = 128;
  EXPECT_GT(facts::crossing_skip_distance(f, small), near_need);
  // Orthographic: not derived.
  Camera ortho = cam;
  ortho.projection = Camera::Projection::Orthographic;
  EXPECT_TRUE(std::isinf(facts::crossing_skip_distance(f, ortho)));
  // Far away, the need passes the cap: off.
  Camera far = cam;
  for (int d = 0; d < 3; ++d) far.eye[d] = cam.target[d] + (cam.eye[d] - cam.target[d]) * 1e4;
  fit_near_far(far, s);
  EXPECT_TRUE(std::isinf(facts::crossing_skip_distance(f, far)));
}

}  // namespace
