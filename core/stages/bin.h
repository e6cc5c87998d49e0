// Stage bin (kernels/bin.cl, MPR's tiles): boxes binned into a uniform tile grid, a crowded tile
// split into 2^d x 2^d leaves where that saves work, and every leaf's list ordered by (class,
// id) with where each class starts, so that pair traversals skip what a leaf does not own and
// every walk is in a fixed order. Run twice per region: screen triangles on the fine grid
// (crossing pairs, occlusion), clipping edges on the edge grid (candidates).
#pragma once

#include <cstdint>

#include "core/device/cl_runtime.h"
#include "core/stages/silhouettes.h"
#include "core/stages/transform.h"

namespace vismap::stages {

struct Leaves {
  cl::Buffer tile_leaf, offset, class_start, list;
  cl::Buffer cursors;  // with `places`: per leaf a cursor at 0 (the cull's, cull.cl cull_bin)
  uint32_t leaves = 0, entries = 0;
};

// Adaptive leaves over n boxes (int4, grid units) on grid g; `places` also gives each leaf a
// cursor at 0 for the cull to place its entries with (core/stages/cull.h).
Leaves bin_leaves(ClRuntime& rt, cl::Buffer& boxes, uint32_t n, const VmGrid& g,
                  bool places = false);

// The two grids of a region: edge tiles of tile_px pixels, fine tiles of half that (>= 4 px).
struct Grids {
  uint32_t tile_px = 0;
  VmGrid edge{}, fine{};
};
// tile_pixels 0: chosen from the screen triangles' density.
Grids choose_grids(uint32_t tile_pixels, uint32_t W, uint32_t H, uint32_t S);

// Screen triangles on the fine grid: their boxes, depth ranges and leaves.
struct TriangleBins {
  cl::Buffer bb, qr;
  Leaves leaves;
  VmGrid grid{};
};
TriangleBins bin_triangles(ClRuntime& rt, const ScreenSet& s, const VmGrid& fine,
                           bool places = false);

// The silhouette edges (the first ce.silhouettes of ce.edges) on the edge grid.
struct EdgeBins {
  cl::Buffer bb;
  Leaves leaves;
  VmGrid grid{};
};
EdgeBins bin_edges(ClRuntime& rt, const ClipEdges& ce, const VmGrid& edge);

}  // namespace vismap::stages
