#include "core/stages/silhouettes.h"

#include <algorithm>

#include "core/stages/grid.h"

namespace vismap::stages {

void find_silhouettes(ClRuntime& rt, const ScreenSet& s, cl::Buffer& totals, Silhouettes& sil) {
  constexpr Stage kStage = Stage::Silhouettes;
  const uint32_t nedges = 3 * s.count;
  sil.edges_in = nedges;
  sil.flags = rt.alloc(size_t(nedges) * 4, "edge flags");
  sil.partners = rt.alloc(size_t(nedges) * 4, "edge partners");
  sil.key_sil = rt.alloc(std::max<size_t>(nedges, 4), "edge keys on silhouettes");
  // The hash table only lives to classify (memory freed early is memory reused later).
  const uint32_t table_size = next_pow2(uint64_t(nedges) * 2);
  cl::Buffer table = rt.alloc(size_t(table_size) * 4, "edge hash table");
  cl::Buffer second = rt.alloc(size_t(table_size) * 4, "edge hash second ids");
  cl::Buffer many = rt.alloc(size_t(table_size) * 4, "edge hash shared flags");
  sil.slot_sides = many;  // (kept for the cull, cull.cl cull_edge_sil)
  cl::Buffer slot_min = rt.alloc(size_t(table_size) * 4, "edge slot min");
  cl::Buffer slot_of_edge = rt.alloc(size_t(nedges) * 4, "edge slots");
  sil.groups = rt.group_sums(nedges, "edge group totals");
  rt.launch(kStage, "edge_table_clear", table_size, table_size, table, second, many, slot_min,
            sil.groups.sums, sil.groups.groups);
  rt.launch(kStage, "edge_insert", nedges, s.tris, nedges, table, table_size - 1, slot_of_edge,
            second, many, slot_min, totals);
  rt.launch(kStage, "edge_classify", nedges, s.tris, nedges, slot_of_edge, table, second, many,
            slot_min, sil.flags, sil.groups.sums, sil.partners, sil.key_sil);
  std::vector<uint32_t>& sums = rt.host_words(sil.groups.groups);
  rt.read_async(kStage, sil.groups.sums, 0, sums.size() * 4, sums.data());
}

ClipEdges emit_silhouettes(ClRuntime& rt, const ScreenSet& s, Silhouettes& sil,
                           uint32_t crossing_entries) {
  rt.complete_reads(Stage::Silhouettes);  // the count (a blocking read since has done it)
  sil.count = rt.set_bases(sil.groups, rt.host_words(sil.groups.groups));  // (for edge_emit)
  ClipEdges ce;
  ce.silhouettes = sil.count;
  ce.crossings = crossing_entries;
  ce.edges = rt.alloc((size_t(sil.count) + crossing_entries) * sizeof(VmEdge), "clipping edges");
  ce.partner = rt.alloc(std::max<size_t>(crossing_entries, 1) * 4, "crossing partners");
  ce.bb = rt.alloc(std::max<size_t>(sil.count, 1) * sizeof(cl_int4), "edge boxes");
  const ClRuntime::GroupSums& g = sil.groups;
  rt.launch_grouped(Stage::Silhouettes, "edge_emit", sil.edges_in, VM_SCAN_WG, s.tris,
                    sil.edges_in, sil.flags, g.bases, g.groups, ce.edges,
                    ce.bb);
  return ce;
}

}  // namespace vismap::stages
