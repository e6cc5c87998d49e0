// Stage occlusion (kernels/occlusion.cl, SVGPU §3.3): every finished fragment is now wholly
// visible or wholly hidden, decided at one interior point by the triangles of the fine leaves
// that cover it (ordered by their depth planes, ties by the fixed rule); a fragment thinner than
// the fine sample grid is decided at an exact rational point by occlude_thin, and a tournament
// of more triangles than the private arrays hold (VM_TOUR_MAX) by occlude_deep, with room sized
// from a count.
#pragma once

#include <cstdint>

#include "core/device/cl_runtime.h"
#include "core/stages/bin.h"
#include "core/stages/clip.h"
#include "core/stages/crossings.h"
#include "core/stages/cull.h"
#include "core/stages/silhouettes.h"
#include "core/stages/transform.h"

namespace vismap::stages {

struct Visibility {
  cl::Buffer visible, offset;  // per fragment: 1 when visible, and its place among the visible
  ClRuntime::GroupSums groups;  // offset is within these work-groups (groups 0: global)
  uint32_t count = 0;          // V
  uint32_t thin = 0;           // fragments thinner than the fine grid (decided at exact points)
  uint32_t deep = 0;           // tournaments of more than VM_TOUR_MAX triangles (occlude_deep)
};

// A fragment whose interior point lies below the bound of its leaf (`cull`) is hidden at once.
Visibility decide_visibility(ClRuntime& rt, const Fragments& fr, const ScreenSet& s,
                             const TriangleBins& tb, const ClipEdges& ce, const Crossings& cx,
                             const CullBounds& cull, cl::Buffer& totals);

}  // namespace vismap::stages
