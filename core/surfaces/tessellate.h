// Curved surfaces diced for a camera (issue 18, docs/SURFACES.md): Renderer::tessellate turns
// every Bezier patch mesh and Loop subdivision surface of a scene into an ordinary triangle mesh
// in the same slot, on the renderer's device, within a screen-space tolerance of the surface and
// without cracks; the result goes through render() like any scene.
#pragma once

#include <array>
#include <atomic>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <map>
#include <memory>

namespace vismap {

struct Mesh;

namespace surfaces {
struct LoopPlan;  // core/surfaces/loop.cpp
}

// What a Loop control mesh needs every frame (topology, stencils, and their device copies),
// built once per mesh and kept for the next frame. A Renderer keeps one set for its callers; a
// caller that must charge the plans to someone keeps its own (TessellateOptions::loop_plans:
// vismapd, one per session's scene, which go with the scene and count against the session's
// max_session_bytes). Used by one tessellate() at a time; the device copies are remade when
// another Renderer dices the mesh.
struct LoopPlans {
  std::map<const Mesh*, std::shared_ptr<surfaces::LoopPlan>> by_mesh;
  uint64_t clock = 0;  // uses so far: each plan's last one orders the eviction
};

struct TessellateOptions {
  // The largest screen distance (pixels) between a diced triangle and its surface, bounded per
  // piece from the control points (docs/SURFACES.md "Error bound").
  float tolerance_px = 0.2f;
  // Implicit surfaces (docs/IMPLICIT.md "3D"): the largest screen distance (pixels) between a
  // triangle and the surface f = 0, for the object's nearest depth in view (cells of side h with
  // sqrt(3) h at most this many pixels there).
  float implicit_tolerance_px = 4.0f;
  // Keep an implicit surface's back faces. By default they are left out where they cannot be
  // seen: the eye outside the solid and the near plane cutting no leaf cell.
  bool implicit_back_faces = false;
  // Leave out an implicit object's regions hidden behind its own full boxes nearer the eye
  // (docs/IMPLICIT.md "Hidden regions"): they change nothing seen. Off: for the tests' comparison.
  bool implicit_occlusion = true;
  // The frame's limits, as RenderOptions' (the CLI and the server pass the same ones); 0: none.
  // memory_budget: a dicer that has counted what it would hold refuses (TooLarge) past it,
  // before it allocates (Bezier patches; issue 35, case 4). time_limit_s: checked before each
  // mesh and between a dicer's launches (TimeLimit, naming stage tessellate).
  uint64_t memory_budget = 0;
  double time_limit_s = 0;
  std::chrono::steady_clock::time_point started{};  // as RenderOptions::started and ::cancel
  const std::atomic<bool>* cancel = nullptr;
  // Loop subdivision plans (host topology and stencils, and their device copies) kept for the
  // next frame, in bytes of host plan: past it, the least recently used plans of other meshes
  // are dropped (issue 35, case 6: six sessions' plans held 6 GB in the server for good).
  uint64_t loop_plan_cache_bytes = uint64_t(1) << 30;
  // One plan past this many bytes is TooLarge naming its level (vismapd: what the session has
  // left of max_session_bytes besides its scene).
  uint64_t loop_plan_max_bytes = uint64_t(2) << 30;
  // The plans to use and keep; null: the Renderer's own.
  LoopPlans* loop_plans = nullptr;
};

struct TessellateStats {
  double ms = 0;                // host wall time of tessellate()
  uint32_t split_rounds = 0;    // rounds of the bound/split queue, summed over meshes
  uint64_t pieces = 0;          // pieces diced (after splits and culling)
  uint64_t culled = 0;          // pieces culled outside the view
  uint64_t triangles = 0;       // diced triangles written
  uint64_t over_rate = 0;       // Bezier patches diced at the largest rate (128) without reaching
                                // the tolerance there (near the eye, across the near plane)
  uint32_t subdivision_level = 0;  // the deepest Loop level used
  uint64_t loop_plan_bytes = 0;    // the Loop plans the renderer keeps after this call
  uint64_t loop_plans_evicted = 0;  // plans dropped by this call to keep within the cache bound
  // Implicit surfaces: the most cells per axis of an object's grid, leaf cells, and the clauses
  // of the full tape (clipped to its box) against those of the leaves' shortened tapes.
  uint64_t implicit_cells = 0;
  uint64_t implicit_leaves = 0, implicit_clauses_full = 0, implicit_leaf_clauses = 0;
  uint64_t implicit_back_faces = 0;  // triangles left out as back faces
  // Leaf cells by the length of their shortened tape: [1, 2), [2, 4), ... [2^15, inf).
  std::array<uint64_t, 16> implicit_clause_hist{};
  // Host wall time of the region queue, the corners' evaluation and the meshing (with normals).
  double implicit_queue_ms = 0, implicit_points_ms = 0, implicit_mesh_ms = 0;
  // Implicit leaves by level (level l: 2^l cells per axis of the object's cube; issue 32: each
  // leaf sized for its own depth), and the least and greatest leaf side (in the object's space).
  std::array<uint64_t, 17> implicit_leaf_levels{};
  double implicit_leaf_side_min = 0, implicit_leaf_side_max = 0;
  uint64_t implicit_occluded = 0;  // regions left out as hidden behind full boxes
  uint32_t launches = 0, host_syncs = 0;
};

// The surface point S(u, v) of patch `p` of a patch mesh (Mesh::patches), in double precision:
// the reference that the diced triangles are measured against (tests, bench/surfaces).
std::array<double, 3> patch_point(const Mesh& mesh, size_t p, double u, double v);

}  // namespace vismap
