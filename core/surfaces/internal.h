// Stage tessellate: curved surfaces diced for the camera before a frame
// (core/surfaces/tessellate.h). Bezier patches (core/surfaces/patches.cpp, kernels/patches.cl):
// bound, split in rounds of the scan-and-compact queue, dice with edge rates taken from each edge's
// own data so that neighbours agree bit for bit. Loop subdivision (core/surfaces/loop.cpp,
// kernels/loop.cl): stencil tables built once per control mesh on the host, applied on the device
// per frame.
#pragma once

#include <cstdint>
#include <map>
#include <memory>

#include "core/camera.h"
#include "core/device/cl_runtime.h"
#include "core/scene.h"
#include "core/surfaces/tessellate.h"

namespace vismap::stages {

// Output cap of one diced surface mesh: 2^27 triangles (~5 GB of host arrays downstream); past
// it the frame is TooLarge naming the mesh, never truncated.
constexpr uint64_t kMaxDicedTriangles = uint64_t(1) << 27;

// One patch mesh diced: positions, indices (vertices shared, across patches too), uv (per corner), face_ids (the patch of each
// triangle), source_triangles = patch count; name, color and flags copied.
Mesh dice_patches(ClRuntime& rt, const Mesh& mesh, const Camera& cam, const TessellateOptions& o,
                  TessellateStats& st);

// One implicit object (Mesh::implicit) diced: positions, indices, normals (per vertex, from the
// gradient), face_ids 0..n-1 (each triangle its own source), source_triangles = n; name, color.
Mesh dice_implicit(ClRuntime& rt, const Mesh& mesh, const Camera& cam, const TessellateOptions& o,
                   TessellateStats& st);

// What a Loop control mesh needs every frame (topology, stencils), built once per mesh.
struct LoopPlan;
using LoopPlans = std::map<const Mesh*, std::shared_ptr<LoopPlan>>;
// One Loop subdivision surface diced: face_ids the control triangle, uv its barycentrics.
Mesh dice_subdivision(ClRuntime& rt, const Mesh& mesh, const Camera& cam,
                      const TessellateOptions& o, LoopPlans& plans, TessellateStats& st);

}  // namespace vismap::stages
