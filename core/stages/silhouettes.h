// Stage silhouettes (kernels/silhouettes.cl, SVGPU §3.1): every screen-triangle edge hashed by
// its endpoints, so that each mesh edge is seen from both sides; an edge between a front and a
// back face, a boundary edge or a non-manifold one is a silhouette edge. They are written first
// into the frame's clipping-edge list, before the crossing entries.
#pragma once

#include <cstdint>

#include "core/device/cl_runtime.h"
#include "core/stages/transform.h"

namespace vismap::stages {

struct Silhouettes {
  cl::Buffer flags;             // per screen-triangle edge (3 S): silhouette or not
  cl::Buffer partners;          // per edge: the other edge of its key, or VM_EDGE_ONE / _MANY
  cl::Buffer key_sil;           // per edge (a byte): its key is a silhouette (the cull's test)
  cl::Buffer slot_sides;        // the hash's "many" words: the sides a shared key is covered on
  ClRuntime::GroupSums groups;  // silhouettes per VM_SCAN_WG edges (edge_classify's atomics)
  uint32_t edges_in = 0;      // 3 S
  uint32_t count = 0;         // E: read without blocking, set by emit_silhouettes
};

// The clipping edges of a region: E silhouette edges, then X crossing entries (crossings.cpp);
// partner[x] is the screen triangle a crossing entry comes from; bb: the E silhouette edges'
// boxes (int4, grid units), written with them.
struct ClipEdges {
  cl::Buffer edges, partner, bb;
  uint32_t silhouettes = 0, crossings = 0;
};

// Classifies the edges (a full hash table raises VM_STATUS_HASH_FULL in totals). Their work-groups'
// counts are read into rt.host_words() without a blocking read of their own (nothing needs the
// count before the clipping edges are allocated).
void find_silhouettes(ClRuntime& rt, const ScreenSet& s, cl::Buffer& totals, Silhouettes& sil);
// Sets sil.count (after the count's read has completed), allocates the E + X clipping edges and
// writes the E silhouette edges.
ClipEdges emit_silhouettes(ClRuntime& rt, const ScreenSet& s, Silhouettes& sil,
                           uint32_t crossing_entries);

}  // namespace vismap::stages
