// The leaves of a 3D implicit queue (core/surfaces/implicit.h) as the leaves of an octree on a
// dyadic grid, and their dual contouring (docs/IMPLICIT.md "3D"): leaves of several sides (each
// sized for its own depth) meshed without cracks between them.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/surfaces/implicit.h"

namespace vismap::surfaces {

// The object's cube [lo, lo + size]^3 and its finest grid: 2^levels cells per axis of side unit.
// A leaf of level l has side size / 2^l and its corners are points lo + i unit of the finest grid
// (computed in double, then rounded to float), so a corner shared by leaves of any sides is one
// float point, and neighbours evaluate it to the same value.
struct OctreeGrid {
  float lo[3] = {0, 0, 0};
  float size = 0;
  uint32_t levels = 0;
  double unit = 0;
  double at(int k, uint64_t i) const { return lo[k] + double(i) * unit; }
};

// Per leaf: its level, its lowest corner in units of the finest grid (3 each) and its 8 corners
// (24 floats each; corner c is at +side along axis k where bit k of c is set).
struct OctreeLeaves {
  std::vector<uint8_t> level;
  std::vector<uint32_t> gi;
  std::vector<float> xyz;
  uint32_t finest = 0;  // the deepest level of a leaf
};

OctreeLeaves octree_leaves(const ImplicitQueue& q, const OctreeGrid& g);

// Dual contouring on the octree (Ju et al. 2002), with surface nets' vertices (Gibson 1998):
// - A vertex per leaf that a polygon uses: the mean of the crossings on its own 12 edges (each
//   from the edge's two corner values alone), or its centre when none of its own edges changes
//   sign (a leaf beside smaller ones, crossed only on their edges on its faces). A function of the
//   leaf's own corner values: whatever is left out around it, its vertex is the same.
// - A polygon per minimal edge whose corner values differ in sign (an edge of a leaf that no
//   smaller leaf subdivides), joining the leaves in the four quadrants around it (three distinct
//   when a larger leaf holds the edge in its face: a triangle; four: a quad split along its
//   shorter diagonal), oriented from the edge's inside corner to its outside one. Each minimal
//   edge is found once, from the first of its smallest leaves in quadrant order.
// A quadrant whose leaf is missing (a region culled: outside the view, or hidden) gives no
// polygon. Every edge of the mesh away from missing leaves is shared by two triangles.
// Throws InputError NonFiniteVertex naming `name` where f is NaN at a corner.
struct DualMesh {
  std::vector<double> opos;     // vertex positions in the object's space
  std::vector<uint32_t> vleaf;  // per vertex: its leaf
  std::vector<uint32_t> indices;
};

DualMesh dual_contour(const OctreeLeaves& c, const std::vector<float>& val, const OctreeGrid& g,
                      const std::string& name);

}  // namespace vismap::surfaces
