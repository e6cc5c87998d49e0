#include "core/stages/occlusion.h"

#include <algorithm>

namespace vismap::stages {

Visibility decide_visibility(ClRuntime& rt, const Fragments& fr, const ScreenSet& s,
                             const TriangleBins& tb, const ClipEdges& ce, const Crossings& cx,
                             const CullBounds& cull, cl::Buffer& totals) {
  constexpr Stage kStage = Stage::Occlusion;
  const uint32_t nd = fr.count;
  const Leaves& lv = tb.leaves;
  Visibility v;
  v.visible = rt.alloc(std::max<size_t>(nd, 1) * 4, "visibility");
  v.offset = rt.alloc(std::max<size_t>(nd, 1) * 4, "visible offsets");
  v.groups = rt.group_sums(nd, "visible group totals");
  rt.launch_grouped(kStage, "occlude", nd, VM_SCAN_WG, fr.meta, fr.lines, nd, s.tris, tb.bb,
                    tb.grid, lv.tile_leaf, lv.offset, lv.class_start, lv.list, ce.edges,
                    ce.silhouettes, cx.entry_offset, cx.entry_count, ce.partner, v.visible,
                    v.offset, v.groups.sums, totals, cull.grid, cull.tile_leaf, cull.leaf_cull,
                    cl_int(cull.on ? 1 : 0));
  // Thin fragments and deep tournaments, counted by occlude, and the visible count in one read:
  // occlude's fused scan is right unless a fragment was thin or deep (their passes change the
  // visibility, and it is scanned again after them).
  uint32_t counts[2];
  rt.read_async(kStage, totals, VM_TOTAL_THIN * 4, sizeof counts, counts);
  const uint32_t fused_count = rt.group_total(kStage, v.groups);
  v.thin = counts[0];
  if (v.thin > 0) {  // cells thinner than the fine sample grid: decided at exact rational points
    rt.launch(kStage, "occlude_thin", nd, fr.meta, fr.lines, nd, s.tris, tb.bb, tb.grid,
              lv.tile_leaf, lv.offset, lv.class_start, lv.list, ce.edges, ce.silhouettes,
              cx.entry_offset, cx.entry_count, ce.partner, v.visible, totals);
    rt.read(kStage, totals, VM_TOTAL_DEEP * 4, 4, &counts[1]);
  }
  v.deep = counts[1];
  if (v.deep > 0) {
    // Tournaments of more than VM_TOUR_MAX triangles: room for each from its leaf's count.
    cl::Buffer need = rt.alloc(size_t(nd) * 4, "deep tournament counts");
    cl::Buffer room = rt.alloc(size_t(nd) * 4, "deep tournament offsets");
    rt.launch(kStage, "deep_count", nd, fr.meta, fr.lines, nd, tb.grid, lv.tile_leaf,
              lv.class_start, v.visible, need);
    const uint32_t total = rt.scan(kStage, need, room, nd);
    cl::Buffer scratch = rt.alloc(size_t(total) * 3 * 4, "deep tournaments");
    rt.launch(kStage, "occlude_deep", nd, fr.meta, fr.lines, nd, s.tris, tb.bb, tb.grid,
              lv.tile_leaf, lv.offset, lv.class_start, lv.list, ce.edges, ce.silhouettes,
              cx.entry_offset, cx.entry_count, ce.partner, room, scratch, total, v.visible);
  }
  if (v.thin || v.deep) {
    v.count = rt.scan(kStage, v.visible, v.offset, nd);
    v.groups.groups = 0;  // the offsets are global
  } else {
    v.count = fused_count;
  }
  return v;
}

}  // namespace vismap::stages
