#include "core/stages/candidates.h"

#include <algorithm>

namespace vismap::stages {

bool find_candidates(ClRuntime& rt, const ScreenSet& s, const TriangleBins& tb, const ClipEdges& ce,
                     const EdgeBins& eb, const Crossings& cx, const CullBounds& cull,
                     cl::Buffer& totals, const RegionBudget& budget, Candidates& c) {
  const cl_int on = cull.on ? 1 : 0;
  constexpr Stage kStage = Stage::Candidates;
  const uint32_t S = s.count;
  const Leaves& lv = eb.leaves;
  c.count = rt.alloc(size_t(S) * 4, "candidate counts");
  c.offset = rt.alloc(size_t(S) * 4, "candidate offsets");
  ClRuntime::GroupSums g = rt.group_sums(S, "candidate group totals");
  rt.launch_grouped(kStage, "cand_count", S, VM_SCAN_WG, s.tris, S, tb.bb, ce.edges, eb.bb,
                    eb.grid, lv.tile_leaf, lv.offset, lv.class_start, lv.list, cx.entry_count,
                    c.count, c.offset, g.sums, tb.qr, cull.grid, cull.tile_leaf, cull.leaf_cull,
                    on, totals);
  c.total = rt.group_total(kStage, g);
  if (!budget.allows_more(rt, size_t(c.total) * 4)) return false;
  c.list = rt.alloc(std::max<size_t>(c.total, 1) * 4, "candidates");
  rt.launch_grouped(kStage, "cand_fill", S, VM_SCAN_WG, s.tris, S, tb.bb, ce.edges, eb.bb,
                    eb.grid, lv.tile_leaf, lv.offset, lv.class_start, lv.list, cx.entry_offset,
                    cx.entry_count, ce.silhouettes, c.offset, g.bases, g.groups, c.list, tb.qr,
                    cull.grid, cull.tile_leaf, cull.leaf_cull, on);
  return true;
}

}  // namespace vismap::stages
