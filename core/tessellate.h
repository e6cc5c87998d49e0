// Curved surfaces diced for a camera (issue 18, docs/SURFACES.md): Renderer::tessellate turns
// every Bezier patch mesh and Loop subdivision surface of a scene into an ordinary triangle mesh
// in the same slot, on the renderer's device, within a screen-space tolerance of the surface and
// without cracks; the result goes through render() like any scene.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>

namespace vismap {

struct Mesh;

struct TessellateOptions {
  // The largest screen distance (pixels) between a diced triangle and its surface, bounded per
  // piece from the control points (docs/SURFACES.md "Error bound").
  float tolerance_px = 0.2f;
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
  uint32_t launches = 0, host_syncs = 0;
};

// The surface point S(u, v) of patch `p` of a patch mesh (Mesh::patches), in double precision:
// the reference that the diced triangles are measured against (tests, bench/surfaces).
std::array<double, 3> patch_point(const Mesh& mesh, size_t p, double u, double v);

}  // namespace vismap
