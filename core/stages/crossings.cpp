#include "core/stages/crossings.h"

#include <algorithm>

namespace vismap::stages {

namespace {
constexpr Stage kStage = Stage::Crossings;
}  // namespace

bool find_crossings(ClRuntime& rt, const ScreenSet& s, const TriangleBins& tb, cl::Buffer& totals,
                    const RegionBudget& budget, const SceneBuffers& sb, const Frame& fr,
                    bool apart, Crossings& cx) {
  const uint32_t S = s.count;
  const Leaves& lv = tb.leaves;
  // pairs_of's VmApart (crossings.cl); without facts its buffers are s.apart's placeholder.
  const cl_int on = apart ? 1 : 0;
  const cl::Buffer& adj_offset = apart ? sb.adj_offset : s.apart;
  const cl::Buffer& adj = apart ? sb.adj : s.apart;
  const cl::Buffer& src_base = apart ? fr.screen_groups.bases : s.apart;
  const cl::Buffer& src_offset = apart ? fr.offsets : s.apart;
  const cl_uint src_groups = fr.screen_groups.groups, nsrc = sb.ntri;
  // One traversal finds each pair once (by its lower triangle) into small inline slots; only if
  // a triangle has more pairs than the slots hold is the traversal repeated into exact space.
  cx.pcount = rt.alloc(size_t(S) * 4, "pair counts");
  cx.poffset = rt.alloc(size_t(S) * 4, "pair offsets");
  {
    cl::Buffer scr_o = rt.alloc(size_t(S) * VM_PAIRS_INLINE * 4, "pair scratch");
    cl::Buffer scr_rel = rt.alloc(size_t(S) * VM_PAIRS_INLINE * 4, "pair scratch");
    cl::Buffer scr_line = rt.alloc(size_t(S) * VM_PAIRS_INLINE * sizeof(VmLine), "pair scratch");
    ClRuntime::GroupSums g = rt.group_sums(S, "pair group totals");
    rt.launch_grouped(kStage, "cross_pairs", S, VM_SCAN_WG, s.tris, S, tb.bb, tb.qr, tb.grid,
                      lv.tile_leaf, lv.offset, lv.class_start, lv.list, on, s.apart, adj_offset,
                      adj, src_offset, src_base, src_groups, nsrc, cx.pcount, cx.poffset, g.sums,
                      scr_o, scr_rel, scr_line, totals);
    // The pair count (its work-groups' totals) and the overflow flag in one read.
    uint32_t status = 0;
    rt.read_async(kStage, totals, VM_TOTAL_STATUS * 4, 4, &status);
    cx.pairs = rt.group_total(kStage, g);
    const size_t P1 = std::max<size_t>(cx.pairs, 1);
    // The pair arrays, then per triangle 3 incoming-pair words and 2 entry words, and the list.
    if (!budget.allows_more(rt, P1 * (12 + sizeof(VmLine)) + size_t(S) * 20 + P1 * 4)) return false;
    cx.pair_t = rt.alloc(P1 * 4, "pairs");
    cx.pair_o = rt.alloc(P1 * 4, "pairs");
    cx.pair_rel = rt.alloc(P1 * 4, "pairs");
    cx.pair_line = rt.alloc(P1 * sizeof(VmLine), "pairs");
    // Triangles whose pairs fit their slots are copied (and the offsets made global); after an
    // overflow the others traverse again, straight into the compact arrays.
    if (cx.pairs > 0)  // (with none, nothing to copy, no overflow, and no offset is read)
      rt.launch_grouped(kStage, "cross_compact", S, VM_SCAN_WG, S, s.tris, cx.pcount, cx.poffset,
                        g.bases, g.groups, scr_o, scr_rel, scr_line, cx.pair_t, cx.pair_o,
                        cx.pair_rel, cx.pair_line);
    if (status & VM_STATUS_PAIRS_OVERFLOW)
      rt.launch(kStage, "cross_pairs_fill", S, s.tris, S, tb.bb, tb.qr, tb.grid, lv.tile_leaf,
                lv.offset, lv.class_start, lv.list, on, s.apart, adj_offset, adj, src_offset,
                src_base, src_groups, nsrc, cx.pcount, cx.poffset, cx.pair_t, cx.pair_o,
                cx.pair_rel, cx.pair_line);
  }
  const uint32_t P = cx.pairs;
  cx.in_count = rt.alloc(size_t(S) * 4, "incoming pair counts");
  cx.in_offset = rt.alloc(size_t(S) * 4, "incoming pair offsets");
  cl::Buffer in_cursor = rt.alloc(size_t(S) * 4, "incoming pair cursors");
  cx.in_list = rt.alloc(std::max<size_t>(P, 1) * 4, "incoming pairs");
  cx.entry_count = rt.alloc(size_t(S) * 4, "crossing entry counts");
  cx.entry_offset = rt.alloc(size_t(S) * 4, "crossing entry offsets");
  if (P == 0) {
    // Every entry comes from a pair (its own lines and partner edges, incoming pairs, the lines
    // of two partners): with none, every count and offset is 0, known without the scans and
    // their two reads (the bunny: 10 launches and 2 reads of its frame); both zeroed in one.
    rt.launch(kStage, "zero_words2", S, S, cx.entry_count, cx.entry_offset);
    cx.entries = 0;
    return budget.allows_more(rt, 0);
  }
  rt.launch(kStage, "zero_words2", S, S, cx.in_count, in_cursor);
  rt.launch(kStage, "cross_in_count", P, P, cx.pair_o, cx.in_count);
  rt.scan_offsets(kStage, cx.in_count, cx.in_offset, S);  // (their total is P)
  rt.launch(kStage, "cross_in_fill", P, P, cx.pair_o, cx.in_offset, in_cursor, cx.in_list);
  rt.launch(kStage, "cross_in_sort", S, S, cx.in_count, cx.in_offset, cx.in_list);
  cx.entry_groups = rt.group_sums(S, "crossing entry group totals");
  rt.launch_grouped(kStage, "cross_entry_count", S, VM_SCAN_WG, S, s.tris, cx.pcount, cx.poffset,
                    cx.in_count, cx.in_offset, cx.in_list, cx.pair_t, cx.pair_o, cx.pair_rel,
                    cx.pair_line, cx.entry_count, cx.entry_offset, cx.entry_groups.sums);
  cx.entries = rt.group_total(kStage, cx.entry_groups);
  // The entries join the clipping edges (VmEdge and a partner each).
  return budget.allows_more(rt, size_t(cx.entries) * (sizeof(VmEdge) + 4));
}

void emit_crossings(ClRuntime& rt, const ScreenSet& s, const Crossings& cx, ClipEdges& ce) {
  const uint32_t S = s.count;
  if (cx.entries == 0) return;  // nothing to write
  const ClRuntime::GroupSums& g = cx.entry_groups;
  rt.launch_grouped(kStage, "cross_entry_fill", S, VM_SCAN_WG, S, s.tris, cx.pcount, cx.poffset,
                    cx.in_count, cx.in_offset, cx.in_list, cx.pair_t, cx.pair_o, cx.pair_rel,
                    cx.pair_line, cx.entry_offset, g.bases, g.groups, ce.silhouettes,
                    ce.edges, ce.partner);
}

void keep_crossing_lines(ClRuntime& rt, const Crossings& cx, const std::vector<VmScreenTri>& tris,
                         std::vector<ScreenTriangles::Crossing>& out) {
  const uint32_t P = cx.pairs;
  if (P == 0) return;
  std::vector<uint32_t> t(P), o(P), rel(P);
  std::vector<VmLine> line(P);
  rt.read_async(kStage, cx.pair_t, 0, size_t(P) * 4, t.data());
  rt.read_async(kStage, cx.pair_o, 0, size_t(P) * 4, o.data());
  rt.read_async(kStage, cx.pair_line, 0, size_t(P) * sizeof(VmLine), line.data());
  rt.read(kStage, cx.pair_rel, 0, size_t(P) * 4, rel.data());  // in order: all four are read
  for (uint32_t p = 0; p < P; ++p) {
    if (rel[p] != VM_REL_CROSS) continue;
    const VmScreenTri &x = tris[t[p]], &y = tris[o[p]];
    out.push_back({{x.mesh, y.mesh}, {x.tri, y.tri}, line[p].a, line[p].b, line[p].c});
  }
}

}  // namespace vismap::stages
