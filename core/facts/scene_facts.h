// View-independent facts of a static scene, found once per scene instead of once per frame
// (issue 32 item 3): which triangles share a vertex (by position, across meshes), and how far
// each triangle is from every triangle it shares no vertex with (its clearance). A frame's
// crossing search (crossings.cl) then visits, for a triangle whose clearance passes what the
// view can blur (crossing_skip_distance: vertex snapping, depth-plane snapping, the tie band),
// only the triangles it shares a vertex with: two triangles that far apart in 3D can neither
// cross, tie nor touch on the screen (docs/NUMERICS.md §2 "Pairs far apart in 3D").
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "core/camera.h"
#include "core/scene.h"

namespace vismap::facts {

struct SceneFacts {
  // Per global triangle (Renderer's upload order): a lower bound on its distance to every
  // triangle that shares no vertex position with it, capped at `cap`; 0 where unknown (a
  // degenerate triangle, one at a vertex of more than kMaxValence triangles, one too large for
  // the grid, one near a crowded cell). Rounded down to float.
  std::vector<float> clearance;
  // Per global triangle t, the triangles u > t sharing a vertex position with it, ascending:
  // adj[adj_offset[t] .. adj_offset[t + 1]).
  std::vector<uint32_t> adj_offset, adj;
  double cap = 0;  // world units; 0: no facts (an empty or flat-to-a-point scene)
  Bounds bounds;   // of the triangles' vertices
  double coordinate_max = 0;  // largest |coordinate| of a vertex (for rounding margins)
  uint64_t isolated = 0;      // triangles whose clearance reached the cap
  // Triangles by clearance: bin k holds those in (cap 2^-(k+1), cap 2^-k] (the last also 0), so
  // that a view can count, from below, the triangles apart in it (apart_fraction).
  std::array<uint32_t, 64> clearance_bins{};
  double ms = 0;              // time taken
  bool timed_out = false;     // gave up past max_seconds (then cap is 0: no facts)
  uint64_t bytes() const {
    return (clearance.size() + adj_offset.size() + adj.size()) * uint64_t(4);
  }
};

// Above this many triangles at one vertex position, pairs through that vertex are left to the
// frame's search (their triangles get clearance 0) instead of listing valence^2 neighbours.
inline constexpr uint32_t kMaxValence = 64;

// Scenes with more triangles get none (cap 0): their search would hold ~4 GiB.
inline constexpr uint64_t kMaxFactsTriangles = uint64_t(1) << 23;

// The facts of `scene`'s triangle meshes (every mesh; surfaces must be diced). Uses up to
// hardware_concurrency threads (at most 8). Past max_seconds (> 0) it gives up: cap 0, no facts;
// likewise past kMaxFactsTriangles.
SceneFacts find_scene_facts(const Scene& scene, double max_seconds = 0);

// What find_scene_facts holds on the host while it works, about, for T triangles (its corners,
// boxes, grid entries and per-thread minima; measured ~300-400 bytes a triangle).
inline uint64_t scene_facts_work_bytes(uint64_t triangles) { return triangles * 512; }
// Whether finding the facts of a scene of this many triangles is worth trying: at most
// kMaxFactsTriangles, and within half of a memory budget (0: none).
inline bool scene_facts_fit(uint64_t triangles, uint64_t memory_budget) {
  return triangles <= kMaxFactsTriangles &&
         (memory_budget == 0 || scene_facts_work_bytes(triangles) <= memory_budget / 2);
}

// The clearance (world units) a triangle needs in this view for the crossing search to skip its
// pairs with triangles it shares no vertex with; +infinity where the bound is not derived
// (orthographic views, no near plane) or the scene has no facts. qmax: the largest nearness
// (1/w) a screen triangle of this view can have (for the kernels' steepness test).
double crossing_skip_distance(const SceneFacts& facts, const Camera& cam, double* qmax = nullptr);

// A lower bound on the fraction of triangles whose clearance passes `need` (from the bins).
double apart_fraction(const SceneFacts& facts, double need);

// The distance between two triangles (corners a[0..2], b[0..2]), to double rounding: 0 where they
// meet. Degenerate triangles are handled as their edges. (For tests.)
double triangle_distance(const std::array<std::array<double, 3>, 3>& a,
                         const std::array<std::array<double, 3>, 3>& b);

}  // namespace vismap::facts
