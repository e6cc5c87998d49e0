#include "core/stages/cull.h"

#include <algorithm>
#include <cmath>

#include "core/stages/grid.h"

namespace vismap::stages {

namespace {
constexpr Stage kStage = Stage::Cull;
}

CullBounds no_cull_bounds(ClRuntime& rt) {
  CullBounds b;
  b.tile_leaf = rt.alloc(16, "cull tile map (none)");
  b.leaf_cull = rt.alloc(16, "cull bounds (none)");
  b.grid = VmGrid{1, 1, 1, 0};
  return b;
}

namespace {

// The leaves the cull proves over: about a quarter of the triangles' mean extent a, at least 4 px
// (the fine bins' leaves when those are as small: the bunny's triangles are about 4 px, and
// sheets of such triangles cover 4 px leaves). Larger triangles (the penetrating soup: about 45 px
// against 64 px leaves) cover a leaf alone only where it is well inside them, so they get leaves
// of their own, binned anew. a comes from the counts the fine binning has read: a triangle's box
// meets about (1 + a/c)^2 leaves of side c.
TriangleBins cull_bins(ClRuntime& rt, const ScreenSet& s, const TriangleBins& tb, uint32_t W,
                       uint32_t H, const RegionBudget& budget) {
  const double per = double(tb.leaves.entries) / std::max<uint32_t>(s.count, 1);
  const uint32_t fine_px = uint32_t(tb.grid.tile_size / VM_GRID_SCALE);
  const double extent_px = (std::sqrt(std::max(per, 1.0)) - 1.0) * fine_px;  // a
  uint32_t px = fine_px;
  while (px > 4 && px > extent_px / 4) px /= 2;
  if (px == fine_px) return tb;
  TriangleBins cb;
  cb.grid = make_grid(px, W, H);
  // Its tiles and leaves (about 56 bytes a tile with places) and lists (12 bytes an entry, as
  // estimated from the extent): where they would pass the region's budget, the fine leaves serve.
  const double per_new = (1 + extent_px / px) * (1 + extent_px / px);
  const uint64_t tiles = uint64_t(cb.grid.tiles_x) * uint64_t(cb.grid.tiles_y);
  if (!budget.fits_more(rt, tiles * 56 + uint64_t(per_new * s.count * 12))) return tb;
  cb.bb = s.bb;
  cb.qr = s.qr;
  cb.leaves = bin_leaves(rt, cb.bb, s.count, cb.grid, true);
  return cb;
}

}  // namespace

bool cull_hidden(ClRuntime& rt, const ScreenSet& s, const TriangleBins& fine, uint32_t W,
                 uint32_t H, Silhouettes& sil, cl::Buffer& totals, const RegionBudget& budget,
                 CullBounds& out) {
  const uint32_t S = s.count;
  const TriangleBins tb = cull_bins(rt, s, fine, W, H, budget);
  const Leaves& lv = tb.leaves;
  const size_t E = std::max<size_t>(lv.entries, 1);
  // Per leaf its bound (kept for the clip rounds); per list entry an interval, a cover and a flag
  // byte; per triangle its keep flag; per edge the kept triangles' silhouette flags.
  // The cull only saves work: where its buffers would pass the region's budget, the region is
  // rendered without it (every triangle clipped), not split or refused.
  if (!budget.fits_more(
          rt, uint64_t(lv.leaves) * 16 + E * 17 + uint64_t(S) * 4 + uint64_t(sil.edges_in) * 4))
    return false;
  out.tile_leaf = lv.tile_leaf;
  out.grid = tb.grid;
  out.leaf_cull = rt.alloc(std::max<size_t>(lv.leaves, 1) * sizeof(cl_double2), "cull bounds");
  // The kept triangles' silhouette counts per group, zeroed by cull_leaves.
  ClRuntime::GroupSums eg = rt.group_sums(sil.edges_in, "edge group totals (kept)");
  {
    cl::Buffer iv = rt.alloc(E * sizeof(cl_float2), "cull intervals");
    cl::Buffer cover = rt.alloc(E * sizeof(cl_float), "cull covers");
    cl::Buffer slot_tri = rt.alloc(E * sizeof(cl_uint), "cull slot triangles");
    cl::Buffer flags = rt.alloc(std::max<size_t>(E, 4), "cull entry flags");
    rt.launch(kStage, "cull_bin", S, s.tris, S, tb.bb, tb.qr, sil.key_sil, sil.partners,
              sil.slot_sides, tb.grid, lv.tile_leaf, lv.offset, lv.cursors, iv, cover, slot_tri,
              flags);
    rt.launch(kStage, "cull_leaves", std::max(lv.leaves, eg.groups), lv.leaves, lv.offset,
              lv.cursors, slot_tri, s.tris, tb.bb, iv, cover, flags, out.leaf_cull, eg.sums,
              eg.groups);
  }
  cl::Buffer keep = rt.alloc(std::max<size_t>(S, 1) * 4, "cull keep");
  rt.launch_grouped(kStage, "cull_tris", S, VM_SCAN_WG, s.tris, S, tb.bb, tb.qr, tb.grid,
                    lv.tile_leaf, out.leaf_cull, keep, totals);
  out.on = true;
  // The kept triangles' silhouettes: edges they share with culled ones are boundaries now.
  cl::Buffer flags = rt.alloc(size_t(sil.edges_in) * 4, "edge flags (kept)");
  rt.launch(kStage, "edge_reclassify", sil.edges_in, sil.edges_in, keep, sil.partners,
            sil.key_sil, sil.flags, flags, eg.sums);
  sil.flags = flags;
  sil.groups = eg;
  std::vector<uint32_t>& sums = rt.host_words(eg.groups);
  rt.read_async(kStage, eg.sums, 0, sums.size() * 4, sums.data());
  return true;
}

}  // namespace vismap::stages
