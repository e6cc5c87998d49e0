#include "core/stages/map_build.h"

#include <algorithm>
#include <cmath>

namespace vismap {

namespace {

struct L3 {
  int64_t a, b, c;
};

L3 coeffs(const VmLine& l) {
  return {l.a, l.b, l.c};
}

__int128 round_div(__int128 num, __int128 den) {  // round(num / den), den > 0, ties up
  __int128 n2 = 2 * num + den, d2 = 2 * den;
  __int128 q = n2 / d2;
  if ((n2 % d2 != 0) && (n2 < 0)) --q;  // floor for negatives
  return q;
}

Int128Parts parts(__int128 v) {
  Int128Parts p;
  p.lo = static_cast<uint64_t>(v);
  p.hi = static_cast<int64_t>(v >> 64);
  return p;
}

}  // namespace

HomPoint intersect(const VmLine& la, const VmLine& lb) {
  L3 a = coeffs(la), b = coeffs(lb);
  HomPoint p;
  p.x = __int128(a.b) * b.c - __int128(b.b) * a.c;
  p.y = __int128(a.c) * b.a - __int128(b.c) * a.a;
  p.w = __int128(a.a) * b.b - __int128(b.a) * a.b;
  if (p.w < 0) {
    p.x = -p.x;
    p.y = -p.y;
    p.w = -p.w;
  }
  return p;
}

double to_pixels(__int128 num, __int128 w, uint32_t grid_scale) {
  constexpr int kBits = 20;
  // q = round(num * 2^20 / w), ties up, without a 128-bit division in the common case: estimate
  // in double, then confirm exactly that (2q-1)w <= 2 num 2^20 < (2q+1)w (|q| < 2^43, w < 2^61:
  // every product fits in 128 bits) and step by one if the estimate was off.
  const __int128 n2 = num * (__int128(1) << (kBits + 1));
  __int128 q = static_cast<__int128>(
      std::floor(static_cast<double>(num) * double(1 << kBits) / static_cast<double>(w) + 0.5));
  for (int guard = 0; guard < 4; ++guard) {
    if ((2 * q - 1) * w > n2)
      --q;
    else if (n2 >= (2 * q + 1) * w)
      ++q;
    else
      return static_cast<double>(static_cast<int64_t>(q)) /
             (double(grid_scale) * double(1 << kBits));
  }
  q = round_div(num * (__int128(1) << kBits), w);  // the estimate was far off: divide
  return static_cast<double>(static_cast<int64_t>(q)) / (double(grid_scale) * double(1 << kBits));
}

void build_planar_map(const VisibleFragments& frags, bool exact, bool orthographic,
                      const std::vector<VmScreenTri>* tris, const std::vector<float>* tri_bary,
                      PlanarMap& map) {
  const uint32_t S = VM_GRID_SCALE;
  const bool attributes = tris && tri_bary;
  map.grid_scale = S;
  size_t nverts = 0;
  for (const VmFragMeta& m : frags.meta) nverts += m.nlines;
  // Called once per bucket: grow geometrically, not to the exact size each time.
  auto grow = [](auto& v, size_t more) {
    if (v.size() + more > v.capacity())
      v.reserve(std::max(v.size() + more, v.capacity() + v.capacity() / 2));
  };
  grow(map.xy, 2 * nverts);
  grow(map.offsets, frags.meta.size());
  grow(map.mesh, frags.meta.size());
  grow(map.triangle, frags.meta.size());
  if (exact) {
    grow(map.hx, nverts);
    grow(map.hy, nverts);
    grow(map.hw, nverts);
  }
  if (attributes) {
    grow(map.bary, 3 * nverts);
    grow(map.inv_w, nverts);
  }
  for (size_t f = 0; f < frags.meta.size(); ++f) {
    const VmFragMeta& m = frags.meta[f];
    const VmLine* L = &frags.lines[f * frags.maxl];
    const uint32_t n = m.nlines;
    for (uint32_t i = 0; i < n; ++i) {
      HomPoint p = intersect(L[i], L[(i + 1) % n]);
      double x = to_pixels(p.x, p.w, S), y = to_pixels(p.y, p.w, S);
      map.xy.push_back(x);
      map.xy.push_back(y);
      if (exact) {
        map.hx.push_back(parts(p.x));
        map.hy.push_back(parts(p.y));
        map.hw.push_back(parts(p.w));
      }
      if (attributes) {
        const VmScreenTri& t = (*tris)[m.tri];
        const float* sb = &(*tri_bary)[9 * size_t(m.tri)];
        // 2D barycentrics of the vertex in the snapped screen triangle (grid units).
        double gx = x * S, gy = y * S;
        double x0 = t.x[0], y0 = t.y[0], x1 = t.x[1], y1 = t.y[1], x2 = t.x[2], y2 = t.y[2];
        double det = (x1 - x0) * (y2 - y0) - (y1 - y0) * (x2 - x0);
        double b1 = ((gx - x0) * (y2 - y0) - (gy - y0) * (x2 - x0)) / det;
        double b2 = ((x1 - x0) * (gy - y0) - (y1 - y0) * (gx - x0)) / det;
        double b0 = 1.0 - b1 - b2;
        double w0 = b0, w1 = b1, w2 = b2, inv_w = 1.0;
        if (!orthographic) {  // perspective-correct: weights by 1/w (= nearness q)
          w0 *= t.q[0];
          w1 *= t.q[1];
          w2 *= t.q[2];
          inv_w = w0 + w1 + w2;
          w0 /= inv_w;
          w1 /= inv_w;
          w2 /= inv_w;
        }
        for (int k = 0; k < 3; ++k)
          map.bary.push_back(static_cast<float>(w0 * sb[k] + w1 * sb[3 + k] + w2 * sb[6 + k]));
        map.inv_w.push_back(static_cast<float>(inv_w));
      }
    }
    map.offsets.push_back(static_cast<uint32_t>(map.xy.size() / 2));
    map.mesh.push_back(frags.mesh[f]);
    map.triangle.push_back(frags.triangle[f]);
  }
}

}  // namespace vismap
