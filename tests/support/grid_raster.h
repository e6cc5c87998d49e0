// Point-sampling rasterizers for the streaming tests: which triangle covers each pixel centre.
// The grid one is exact (integer edge functions with a tie rule that is a consistent symbolic
// perturbation of the sample point, so a conforming mesh covers every sample exactly once); the
// planar-map one samples the exact map's fragments in doubles.
#pragma once

#include <algorithm>
#include <cstdint>
#include <vector>

#include "core/planar_map.h"

namespace vismap::test_support {

constexpr uint32_t kNoCover = 0xFFFFFFFFu;

struct Coverage {
  uint32_t width = 0, height = 0;
  std::vector<uint32_t> id;    // per pixel: the last covering triangle's tag, or kNoCover
  std::vector<uint8_t> count;  // per pixel: how many triangles cover its centre (saturating)
};

// Triangles on a grid of `quantum` steps per pixel (xy in grid steps, tri 3 per triangle with
// positive orientation), tagged by tag[t].
inline Coverage raster_grid(uint32_t width, uint32_t height, uint32_t quantum,
                            const std::vector<int32_t>& xy, const std::vector<uint32_t>& tri,
                            const std::vector<uint32_t>& tag) {
  Coverage c{width, height, std::vector<uint32_t>(size_t(width) * height, kNoCover),
             std::vector<uint8_t>(size_t(width) * height, 0)};
  // Doubled coordinates, so the pixel centre (i + 1/2) * quantum is an integer for any quantum.
  auto X = [&](uint32_t v) { return 2 * int64_t(xy[2 * v]); };
  auto Y = [&](uint32_t v) { return 2 * int64_t(xy[2 * v + 1]); };
  for (size_t t = 0; t < tag.size(); ++t) {
    const uint32_t v[3] = {tri[3 * t], tri[3 * t + 1], tri[3 * t + 2]};
    int64_t lo_x = X(v[0]), hi_x = lo_x, lo_y = Y(v[0]), hi_y = lo_y;
    for (uint32_t k : v) {
      lo_x = std::min(lo_x, X(k)), hi_x = std::max(hi_x, X(k));
      lo_y = std::min(lo_y, Y(k)), hi_y = std::max(hi_y, Y(k));
    }
    const int64_t q2 = 2 * int64_t(quantum);
    const int64_t i0 = std::max<int64_t>(0, (lo_x - quantum) / q2 - 1);
    const int64_t i1 = std::min<int64_t>(width - 1, (hi_x - quantum) / q2 + 1);
    const int64_t j0 = std::max<int64_t>(0, (lo_y - quantum) / q2 - 1);
    const int64_t j1 = std::min<int64_t>(height - 1, (hi_y - quantum) / q2 + 1);
    for (int64_t j = j0; j <= j1; ++j)
      for (int64_t i = i0; i <= i1; ++i) {
        const int64_t px = i * q2 + quantum, py = j * q2 + quantum;
        bool in = true;
        for (int e = 0; e < 3 && in; ++e) {
          const uint32_t a = v[e], b = v[(e + 1) % 3];
          const int64_t dx = X(b) - X(a), dy = Y(b) - Y(a);
          const int64_t E = dx * (py - Y(a)) - dy * (px - X(a));
          // Ties: the sign E takes when the sample moves by (eps, eps^2).
          in = E > 0 || (E == 0 && (dy < 0 || (dy == 0 && dx > 0)));
        }
        if (!in) continue;
        const size_t p = size_t(j) * width + size_t(i);
        c.id[p] = tag[t];
        if (c.count[p] < 255) ++c.count[p];
      }
  }
  return c;
}

// The planar map's fragments (convex, positive orientation), tagged by fragment index.
inline Coverage raster_map(const PlanarMap& m) {
  Coverage c{m.width, m.height, std::vector<uint32_t>(size_t(m.width) * m.height, kNoCover),
             std::vector<uint8_t>(size_t(m.width) * m.height, 0)};
  for (size_t f = 0; f < m.fragment_count(); ++f) {
    const uint32_t b = m.offsets[f], n = m.offsets[f + 1] - b;
    if (n < 3) continue;
    double lo_x = 1e300, hi_x = -1e300, lo_y = 1e300, hi_y = -1e300;
    for (uint32_t k = 0; k < n; ++k) {
      lo_x = std::min(lo_x, m.xy[2 * (b + k)]), hi_x = std::max(hi_x, m.xy[2 * (b + k)]);
      lo_y = std::min(lo_y, m.xy[2 * (b + k) + 1]), hi_y = std::max(hi_y, m.xy[2 * (b + k) + 1]);
    }
    const int64_t i0 = std::max<int64_t>(0, int64_t(lo_x) - 1);
    const int64_t i1 = std::min<int64_t>(m.width - 1, int64_t(hi_x) + 1);
    const int64_t j0 = std::max<int64_t>(0, int64_t(lo_y) - 1);
    const int64_t j1 = std::min<int64_t>(m.height - 1, int64_t(hi_y) + 1);
    for (int64_t j = j0; j <= j1; ++j)
      for (int64_t i = i0; i <= i1; ++i) {
        const double px = i + 0.5, py = j + 0.5;
        bool in = true;
        for (uint32_t k = 0; k < n && in; ++k) {
          const uint32_t a = b + k, e = b + (k + 1) % n;
          const double dx = m.xy[2 * e] - m.xy[2 * a], dy = m.xy[2 * e + 1] - m.xy[2 * a + 1];
          const double E = dx * (py - m.xy[2 * a + 1]) - dy * (px - m.xy[2 * a]);
          in = E > 0 || (E == 0 && (dy < 0 || (dy == 0 && dx > 0)));
        }
        if (!in) continue;
        const size_t p = size_t(j) * m.width + size_t(i);
        c.id[p] = uint32_t(f);
        if (c.count[p] < 255) ++c.count[p];
      }
  }
  return c;
}

// Pixels covered in `ref` whose 8 neighbours are covered too: inside the object, away from its
// outline, where a decoded frame must cover the centre.
inline std::vector<uint8_t> interior(const Coverage& ref) {
  std::vector<uint8_t> in(ref.id.size(), 0);
  for (uint32_t j = 1; j + 1 < ref.height; ++j)
    for (uint32_t i = 1; i + 1 < ref.width; ++i) {
      bool all = true;
      for (int dj = -1; dj <= 1 && all; ++dj)
        for (int di = -1; di <= 1 && all; ++di)
          all = ref.count[size_t(j + dj) * ref.width + (i + di)] > 0;
      in[size_t(j) * ref.width + i] = all;
    }
  return in;
}

}  // namespace vismap::test_support
