// Stage cull (kernels/cull.cl, issue 32): the screen triangles that are provably hidden are left
// out before the crossings, candidates and clip rounds, and the bounds that proved it go on to
// the clip rounds, which drop a fragment as soon as it is provably hidden. Per leaf of the fine
// triangle bins: the least nearness of a surface known to cover the whole leaf (a sheet with no
// silhouette inside the leaf, or one triangle containing it) and the margin by which the
// occlusion stage's decisions can depart from exact depths there; a triangle whose nearness stays
// below that bound minus the margin in every leaf it meets cannot be seen, and nothing it hides is
// seen either. Its box is emptied, so that every later traversal passes it by as if it were not
// in the scene, and the silhouettes become those of the kept triangles; the visible region of
// every source stays the same (docs/ARCHITECTURE.md "Cull").
#pragma once

#include <cstdint>

#include "core/device/cl_runtime.h"
#include "core/stages/bin.h"
#include "core/stages/budget.h"
#include "core/stages/silhouettes.h"
#include "core/stages/transform.h"

namespace vismap::stages {

// What the cull proved, for the clip rounds: the fine grid's tile map and per leaf (top, margin)
// as double2. on = false: nothing proven (the clip rounds then drop nothing).
struct CullBounds {
  cl::Buffer tile_leaf, leaf_cull;
  VmGrid grid{};
  bool on = false;
};

// Proves what it can over the region's screen set `s` (binned in `fine` with places, its
// silhouettes classified in `sil`): empties the boxes of the hidden triangles (s.bb, which tb
// shares), counts them into totals[VM_TOTAL_CULLED] and makes sil's flags those of the kept
// triangles' silhouettes (edge_reclassify). No blocking read. False, with nothing done, when its
// buffers would pass the region's budget: the region is then rendered without the cull.
// `fine`: the frame's fine triangle bins (with places); for large triangles the cull bins them
// again on smaller leaves of its own (a W x H screen).
bool cull_hidden(ClRuntime& rt, const ScreenSet& s, const TriangleBins& fine, uint32_t W,
                 uint32_t H, Silhouettes& sil, cl::Buffer& totals, const RegionBudget& budget,
                 CullBounds& out);

// A CullBounds that proves nothing (small placeholder buffers for the kernels' arguments).
CullBounds no_cull_bounds(ClRuntime& rt);

}  // namespace vismap::stages
