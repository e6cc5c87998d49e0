// Stage candidates (kernels/candidates.cl): per screen triangle, the clipping edges that may cut
// it: its crossing entries, then the silhouette edges through the edge leaves that pass the exact
// side tests and a conservative depth test (count, fill: the scan fused into both, scan.cl).
#pragma once

#include <cstdint>

#include "core/device/cl_runtime.h"
#include "core/stages/bin.h"
#include "core/stages/budget.h"
#include "core/stages/crossings.h"
#include "core/stages/cull.h"
#include "core/stages/silhouettes.h"
#include "core/stages/transform.h"

namespace vismap::stages {

struct Candidates {
  cl::Buffer count, offset, list;  // per triangle; list holds indices into the clipping edges
  uint32_t total = 0;              // C
};

// False when the list would pass the region's budget (counted, not filled).
// A silhouette edge along which the triangle is proven hidden (`cull`, cull.cl hidden_along)
// cannot change its visibility and is left out of its list (counted in totals[VM_TOTAL_PRUNED]).
bool find_candidates(ClRuntime& rt, const ScreenSet& s, const TriangleBins& tb, const ClipEdges& ce,
                     const EdgeBins& eb, const Crossings& cx, const CullBounds& cull,
                     cl::Buffer& totals, const RegionBudget& budget, Candidates& c);

}  // namespace vismap::stages
