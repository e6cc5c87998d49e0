#include "core/stages/bin.h"

#include <algorithm>
#include <cmath>

#include "core/stages/grid.h"

namespace vismap::stages {

namespace {

constexpr Stage kStage = Stage::Bin;

// Counts, scans and fills the lists of the leaves given by lv.tile_leaf (lv.leaves of them);
// identity: the coarse pass, whose map leaf_init writes (every tile one leaf).
void fill_leaves(ClRuntime& rt, cl::Buffer& bb, uint32_t n, const VmGrid& g, Leaves& lv,
                 cl::Buffer& count, cl_uint identity) {
  count = rt.alloc(size_t(lv.leaves) * 4, "leaf counts");
  lv.offset = rt.alloc(size_t(lv.leaves) * 4, "leaf offsets");
  cl::Buffer cursor = rt.alloc(size_t(lv.leaves) * 4, "leaf cursors");
  rt.launch(kStage, "leaf_init", lv.leaves, lv.leaves, identity, lv.tile_leaf, count, cursor);
  rt.launch(kStage, "leaf_bin", n, bb, n, g, lv.tile_leaf, count, count, count, count, cl_int(0));
  lv.entries = rt.scan(kStage, count, lv.offset, lv.leaves);
  lv.list = rt.alloc(std::max<size_t>(lv.entries, 1) * 4, "leaf lists");
  rt.launch(kStage, "leaf_bin", n, bb, n, g, lv.tile_leaf, count, lv.offset, cursor, lv.list,
            cl_int(1));
}

}  // namespace

// A coarse pass with every tile one leaf, each tile's depth from its coarse list, and a second
// pass into the leaves when some tile split.
Leaves bin_leaves(ClRuntime& rt, cl::Buffer& bb, uint32_t n, const VmGrid& g, bool places) {
  const uint32_t ntiles = uint32_t(g.tiles_x) * uint32_t(g.tiles_y);
  Leaves lv;
  cl::Buffer count;
  lv.tile_leaf = rt.alloc(size_t(ntiles) * 4, "tile leaves");
  lv.leaves = ntiles;
  fill_leaves(rt, bb, n, g, lv, count, 1);
  // The map is rewritten only after the last use of the coarse one (the queue is in order).
  cl::Buffer first = rt.alloc(size_t(ntiles) * 4, "first leaf per tile");
  ClRuntime::GroupSums groups = rt.group_sums(ntiles, "leaf group totals");
  rt.launch_grouped(kStage, "bin_depth", ntiles, VM_SCAN_WG, lv.offset, count, ntiles, bb, g,
                    lv.list, lv.tile_leaf, first, groups.sums);
  const uint32_t leaves = rt.group_total(kStage, groups);
  if (leaves != ntiles) {  // some tile split: bin again into the leaves (else the map is the same)
    rt.launch_grouped(kStage, "bin_pack", ntiles, VM_SCAN_WG, ntiles, first, groups.bases,
                      groups.groups, lv.tile_leaf);
    lv.leaves = leaves;
    fill_leaves(rt, bb, n, g, lv, count, 0);
  }
  lv.class_start = rt.alloc(size_t(lv.leaves) * sizeof(cl_uint4), "leaf class starts");
  lv.cursors = rt.alloc(places ? size_t(lv.leaves) * 4 : 16, "leaf cursors (cull)");
  rt.launch(kStage, "leaf_sort_classes", ntiles, ntiles, lv.tile_leaf, lv.offset, count, lv.list,
            lv.class_start, cl_int(places ? 1 : 0), lv.cursors);
  return lv;
}

Grids choose_grids(uint32_t tile_pixels, uint32_t W, uint32_t H, uint32_t S) {
  Grids g;
  g.tile_px = tile_pixels;
  if (g.tile_px == 0) {
    double side = 2.0 * std::sqrt(double(W) * H / std::max<uint32_t>(S, 1));
    g.tile_px = std::clamp<uint32_t>(next_pow2(static_cast<uint64_t>(std::ceil(side))), 8, 512);
  }
  g.edge = make_grid(g.tile_px, W, H);
  g.fine = make_grid(std::max<uint32_t>(g.tile_px / 2, 4), W, H);
  return g;
}

TriangleBins bin_triangles(ClRuntime& rt, const ScreenSet& s, const VmGrid& fine, bool places) {
  TriangleBins tb;
  tb.grid = fine;
  tb.bb = s.bb;  // written by snap_depth_planes
  tb.qr = s.qr;
  tb.leaves = bin_leaves(rt, tb.bb, s.count, fine, places);
  return tb;
}

EdgeBins bin_edges(ClRuntime& rt, const ClipEdges& ce, const VmGrid& edge) {
  EdgeBins eb;
  eb.grid = edge;
  eb.bb = ce.bb;  // written by edge_emit
  eb.leaves = bin_leaves(rt, eb.bb, ce.silhouettes, edge);
  return eb;
}

}  // namespace vismap::stages
