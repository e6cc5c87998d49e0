// The stages of a frame, in the order of DESIGN §2. Every launch, fill and profile entry is
// recorded under one, and every device error names it. A frame stage's host code is
// core/stages/<name>.cpp beside kernels/<name>.cl; the dicers that run before a frame are in
// core/surfaces/ (patches.cpp with patches.cl, loop.cpp with loop.cl, implicit.cpp with
// implicit.cl; docs/ARCHITECTURE.md).
#pragma once

#include <cstddef>
#include <cstdint>

namespace vismap {

enum class Stage : uint8_t {
  Transform,    // transform + near clip + cull + snap; depth planes; bucket cells
  Silhouettes,  // edge hash: silhouette, boundary and non-manifold edges
  Bin,          // adaptive tiles (leaves) of triangles and of clipping edges
  Cull,         // provably hidden triangles left out; the bounds that prove it (issue 32)
  Crossings,    // penetrating, tying and touching pairs and their clipping entries
  Candidates,   // per triangle, the clipping edges that may cut it
  Clip,         // clipping rounds (the work queue)
  Occlusion,    // each finished fragment visible or hidden
  Emit,         // visible fragments to the host, the planar map
  Raster,       // the z-buffer id raster (the floor to beat; not part of a frame)
  Test,         // launches made by tests of single kernels
  Tessellate,   // curved surfaces diced for the camera (before a frame; TessellateStats)
  Implicit,     // implicit surfaces: the interval region queue with tape shortening
};
constexpr size_t kStageCount = size_t(Stage::Implicit) + 1;  // (Implicit is the last)
// The stages a frame reports in RenderStats, in order.
constexpr Stage kFrameStages[] = {Stage::Transform, Stage::Silhouettes, Stage::Bin,
                                  Stage::Cull,      Stage::Crossings, Stage::Candidates,  Stage::Clip,
                                  Stage::Occlusion, Stage::Emit};

constexpr const char* stage_name(Stage s) {
  constexpr const char* names[] = {"transform",  "silhouettes", "bin",       "cull",  "crossings",
                                              "candidates", "clip",        "occlusion", "emit",
                                              "raster",     "test",        "tessellate",
                                              "implicit"};
  static_assert(sizeof(names) / sizeof(names[0]) == kStageCount, "a name for every Stage");
  return names[static_cast<size_t>(s)];
}

}  // namespace vismap
