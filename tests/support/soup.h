// Dense penetrating triangle soup (issue 15's hard scene): n triangles of about `size` across,
// each around a uniformly random centre in the unit cube, vertices at random offsets in a cube
// of side `size` around it, so that most triangles cross many others. Seeded: the same scene on
// every machine (std::mt19937_64, integer-derived doubles, rounded to floats as loaders would).
// Used by tests/test_budget.cpp and bench/soup_bench.cpp.
#pragma once

#include <cmath>
#include <cstdint>
#include <random>

#include "core/camera.h"
#include "core/scene.h"

namespace vismap::test_support {

inline Scene penetrating_soup(uint32_t n, double size, uint64_t seed) {
  std::mt19937_64 rng(seed);
  auto uni = [&](double a, double b) { return a + (b - a) * double(rng() >> 11) * 0x1.0p-53; };
  Scene s;
  Mesh m;
  m.name = "soup";
  m.soup = true;
  for (uint32_t t = 0; t < n; ++t) {
    const double c[3] = {uni(0, 1), uni(0, 1), uni(0, 1)};
    for (int k = 0; k < 3; ++k)
      for (int a = 0; a < 3; ++a) m.positions.push_back(float(c[a] + size * uni(-0.5, 0.5)));
    m.indices.insert(m.indices.end(), {3 * t, 3 * t + 1, 3 * t + 2});
    m.face_ids.push_back(t);
  }
  m.source_triangles = n;
  m.color = {0.7f, 0.6f, 0.5f};
  s.meshes.push_back(std::move(m));
  s.source = "soup";
  return s;
}

}  // namespace vismap::test_support
