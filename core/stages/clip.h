// Stage clip (kernels/clip.cl, SVGPU §3.2 as a GPU Reyes work queue): every screen triangle's root
// fragment (clipped to its bucket), then rounds in which each fragment finds the first candidate
// edge that really cuts it and splits in two or finishes; a scan of the per-item counts places
// the children. The queue length stays on the device, so after the first round four rounds run
// per small read-back of the queue state and the status (docs/ARCHITECTURE.md "Clip").
#pragma once

#include <cstdint>
#include <functional>

#include "core/device/cl_runtime.h"
#include "core/stages/budget.h"
#include "core/stages/candidates.h"
#include "core/stages/cull.h"
#include "core/stages/deadline.h"
#include "core/stages/silhouettes.h"
#include "core/stages/transform.h"

namespace vismap::stages {

// Finished fragments: VmFragMeta and rt.maxl() lines each.
struct Fragments {
  cl::Buffer meta, lines;
  uint32_t count = 0;  // nd
  uint32_t rounds = 0;
};

enum class ClipStatus {
  Done,
  LinesOverflow,  // a fragment needs more than rt.maxl() lines: rebuild with more and run again
  OverBudget,     // the fragments would pass the region's budget: split the region
};

// after_round(rounds) is called after each round (progress). What the rounds hold at once is
// estimated from the queue lengths (the queues are allocated anew each round, so the sum of the
// allocations would count each round's again) and checked against the budget before each
// round's allocations.
// A fragment that `cull` proves hidden is dropped (neither split further nor finished).
ClipStatus clip_fragments(ClRuntime& rt, const ScreenSet& s, const cl_int4& region,
                          cl_int clip_region, const Candidates& cand, const ClipEdges& ce,
                          const CullBounds& cull, cl::Buffer& totals, const Deadline& deadline, const RegionBudget& budget,
                          const std::function<void(uint32_t)>& after_round, Fragments& out);

}  // namespace vismap::stages
