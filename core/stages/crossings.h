// Stage crossings (kernels/crossings.cl): the entangled pairs of screen triangles (penetrating,
// tying within the band, or touching it at a mesh edge), found once each through the triangle
// leaves, and for each triangle the clipping entries they add: crossing lines (exact between
// snapped depth planes) and the partner's edges. The entries follow the silhouette edges in the
// clipping-edge list.
#pragma once

#include <cstdint>
#include <vector>

#include "core/device/cl_runtime.h"
#include "core/planar_map.h"
#include "core/stages/bin.h"
#include "core/stages/budget.h"
#include "core/stages/silhouettes.h"
#include "core/stages/transform.h"

namespace vismap::stages {

struct Crossings {
  cl::Buffer pcount, poffset;                      // per triangle: pairs it lists (as lower member)
  cl::Buffer pair_t, pair_o, pair_rel, pair_line;  // per pair
  cl::Buffer in_count, in_offset, in_list;         // per triangle: pairs it is the upper member of
  cl::Buffer entry_count, entry_offset;            // per triangle: its clipping entries
  ClRuntime::GroupSums entry_groups;  // entry_offset within these groups until emit_crossings
  uint32_t pairs = 0;                              // P
  uint32_t entries = 0;                            // X
};

// Finds the pairs and sizes each triangle's entries (one status read for the inline slots).
// False when the pairs or the entries would pass the region's budget (nothing more allocated).
// With `apart` (the frame's ApartView was on: s.apart written), pairs with an apart member are
// looked for through sb's adjacency (fr: the region's clip_count offsets) instead of the bins.
bool find_crossings(ClRuntime& rt, const ScreenSet& s, const TriangleBins& tb, cl::Buffer& totals,
                    const RegionBudget& budget, const SceneBuffers& sb, const Frame& fr,
                    bool apart, Crossings& cx);
// Writes the X entries after the silhouette edges of ce (and their partners).
void emit_crossings(ClRuntime& rt, const ScreenSet& s, const Crossings& cx, ClipEdges& ce);
// The pairs whose planes cross (VM_REL_CROSS) with their lines, by source triangle, appended
// to `out` (tris: the region's screen triangles as read back; for extract_lines).
void keep_crossing_lines(ClRuntime& rt, const Crossings& cx, const std::vector<VmScreenTri>& tris,
                         std::vector<ScreenTriangles::Crossing>& out);

}  // namespace vismap::stages
