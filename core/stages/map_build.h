// Host side of the planar-map stage: turns the visible fragments (convex polygons stored by
// their supporting lines, read back from the device) into vertices. Each vertex is the exact
// intersection of two lines (128-bit homogeneous integers), rounded once, correctly, to a
// 2^-20 grid-unit lattice: any two fragments that share a vertex print the same coordinates.
#pragma once

#include <cstdint>
#include <vector>

#include "core/planar_map.h"
#include "kernels/layout.h"

namespace vismap {

struct HomPoint {
  __int128 x, y, w;  // the point is (x/w, y/w) in grid units, w > 0
};

// Intersection of the directed lines (through grid points) a and b; they must not be parallel.
HomPoint intersect(const VmLine& a, const VmLine& b);

// Correctly rounded x/w in pixels (grid units / grid_scale), on a 2^-20 grid-unit lattice.
double to_pixels(__int128 num, __int128 w, uint32_t grid_scale);

struct VisibleFragments {
  uint32_t maxl = 0;
  std::vector<VmFragMeta> meta;          // per fragment (meta.tri = screen triangle)
  std::vector<VmLine> lines;             // maxl per fragment
  std::vector<uint32_t> mesh, triangle;  // per fragment: source
};

// Appends the fragments to `map` (vertices, ids; exact vertices when `exact`). When `tris` and
// `tri_bary` are given, also per-vertex barycentrics in the source triangle and 1/w.
void build_planar_map(const VisibleFragments& frags, bool exact, bool orthographic,
                      const std::vector<VmScreenTri>* tris, const std::vector<float>* tri_bary,
                      PlanarMap& map);

}  // namespace vismap
