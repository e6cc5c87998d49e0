// Stage tessellate: curved surfaces diced for the camera before a frame
// (core/surfaces/tessellate.h). Bezier patches (core/surfaces/patches.cpp, kernels/patches.cl):
// bound, split in rounds of the scan-and-compact queue, dice with edge rates taken from each edge's
// own data so that neighbours agree bit for bit. Loop subdivision (core/surfaces/loop.cpp,
// kernels/loop.cl): stencil tables built once per control mesh on the host, applied on the device
// per frame.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <vector>

#include "core/camera.h"
#include "core/device/cl_runtime.h"
#include "core/scene.h"
#include "core/surfaces/tessellate.h"

namespace vismap::surfaces {

// The view a dicer measures with: the camera, near and far fitted to the control points (x, y, z
// each) when not given; the view-projection as float rows for the kernels' culling; pixels per
// world unit at w = 1 (perspective) or per unit (orthographic).
struct DiceView {
  Camera cam;
  cl_float16 m;
  bool persp = false;
  float f_px = 0;
};

inline DiceView dice_view(const Camera& cam_in, const std::vector<float>& points) {
  DiceView v;
  Camera& cam = v.cam;
  cam = cam_in;
  if (cam.near_plane <= 0 || cam.far_plane <= 0) {
    Bounds b;
    for (size_t i = 0; i < points.size(); i += 3)
      for (int k = 0; k < 3; ++k) {
        double x = points[i + k];
        b.lo[k] = b.empty ? x : std::min(b.lo[k], x);
        b.hi[k] = b.empty ? x : std::max(b.hi[k], x);
        if (k == 2) b.empty = false;
      }
    fit_near_far(cam, b);
  }
  Mat4 vp = cam.view_projection();
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) v.m.s[4 * r + c] = float(vp[4 * c + r]);
  v.persp = cam.projection == Camera::Projection::Perspective;
  v.f_px = v.persp ? float(cam.height / (2 * std::tan(cam.fov_y_deg * M_PI / 360)))
                   : float(cam.height / cam.ortho_height);
  return v;
}

// Output cap of one diced surface mesh: 2^27 triangles (~5 GB of host arrays downstream); past
// it the frame is TooLarge naming the mesh, never truncated.
constexpr uint64_t kMaxDicedTriangles = uint64_t(1) << 27;

// One patch mesh diced: positions, indices (vertices shared, across patches too), uv (per corner), face_ids (the patch of each
// triangle), source_triangles = patch count; name, color and flags copied.
// check_time: throws past TessellateOptions::time_limit_s (Renderer::tessellate's deadline).
using TimeCheck = std::function<void()>;

Mesh dice_patches(ClRuntime& rt, const Mesh& mesh, const Camera& cam, const TessellateOptions& o,
                  TessellateStats& st, const TimeCheck& check_time);

// One implicit object (Mesh::implicit) diced: positions, indices, normals (per vertex, from the
// gradient), face_ids 0..n-1 (each triangle its own source), source_triangles = n; name, color.
Mesh dice_implicit(ClRuntime& rt, const Mesh& mesh, const Camera& cam, const TessellateOptions& o,
                   TessellateStats& st, const TimeCheck& check_time);

// One Loop subdivision surface diced: face_ids the control triangle, uv its barycentrics. The
// mesh's plan is kept in `plans`; the meshes not being diced keep theirs up to
// TessellateOptions::loop_plan_cache_bytes in all, least recently used evicted first.
Mesh dice_subdivision(ClRuntime& rt, const Mesh& mesh, const Camera& cam,
                      const TessellateOptions& o, LoopPlans& plans, TessellateStats& st,
                      const TimeCheck& check_time);

}  // namespace vismap::surfaces
