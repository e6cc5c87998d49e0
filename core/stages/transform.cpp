#include "core/stages/transform.h"

#include <algorithm>
#include <cmath>

namespace vismap::stages {

// Back faces are culled only where that cannot change the picture: a closed, consistently
// oriented mesh lying wholly in front of the near plane (so the eye is outside it and no cut
// opens it). Everything else is two-sided.
std::vector<uint32_t> cull_modes(const Scene& scene, const std::vector<int8_t>& closed,
                                 const Camera& cam) {
  Mat4 vp = cam.view_projection();
  std::vector<uint32_t> modes(scene.meshes.size(), VM_CULL_NONE);
  for (size_t m = 0; m < scene.meshes.size(); ++m) {
    if (closed[m] == 0) continue;
    const std::vector<float>& P = scene.meshes[m].positions;
    bool in_front = true;
    for (size_t v = 0; v + 2 < P.size() && in_front; v += 3) {
      double x = P[v], y = P[v + 1], z = P[v + 2];
      double cz = vp[2] * x + vp[6] * y + vp[10] * z + vp[14];
      double cw = vp[3] * x + vp[7] * y + vp[11] * z + vp[15];
      in_front = cz + cw > 0 && cw > 0;
    }
    if (!in_front) continue;
    // Outward faces are counter-clockwise in NDC when they face the eye, i.e. negative grid
    // orientation with y down; their back faces have positive grid orientation.
    modes[m] = closed[m] > 0 ? VM_CULL_POSITIVE : VM_CULL_NEGATIVE;
  }
  return modes;
}

Frame begin_frame(ClRuntime& rt, const SceneBuffers& sb, const Scene& scene, const Camera& cam,
                  Stage stage) {
  Frame f;
  f.W = cam.width;
  f.H = cam.height;
  Mat4 vp = cam.view_projection();
  f.mat = rt.upload(std::vector<double>(vp.begin(), vp.end()), "view-projection");
  f.mesh_cull = rt.upload(cull_modes(scene, sb.closed, cam), "cull modes");
  f.clip = rt.alloc(size_t(sb.nv) * sizeof(cl_double4), "clip-space vertices");
  // The depth exponents and the frame's counts (VM_FRAME_*), zeroed by transform_vertices.
  f.depth_ex = rt.alloc(VM_FRAME_WORDS * sizeof(cl_int), "frame words");
  f.totals = rt.alloc(VM_TOTAL_SLOTS * 4, "totals");              // zeroed by clip_fill
  rt.launch(stage, "transform_vertices", std::max<uint32_t>(sb.nv, 1), sb.pos, sb.nv, f.mat,
            f.clip, f.depth_ex);
  f.offsets = rt.alloc(size_t(sb.ntri) * 4, "clip offsets");
  f.screen_groups = rt.group_sums(sb.ntri, "clip group totals");
  f.ortho = cam.projection == Camera::Projection::Orthographic ? 1 : 0;
  f.full = {{0, 0, cl_int(cam.width * VM_GRID_SCALE), cl_int(cam.height * VM_GRID_SCALE)}};
  f.boxes = rt.alloc(16, "triangle boxes");  // plan_buckets fills it for buckets
  return f;
}

uint32_t count_screen(ClRuntime& rt, const SceneBuffers& sb, Frame& fr, const cl_int4& region,
                      Stage stage) {
  rt.launch_grouped(stage, "clip_count", sb.ntri, VM_SCAN_WG, sb.idx, sb.ntri, fr.clip,
                    sb.tri_mesh, sb.tri_local, fr.mesh_cull, fr.W, fr.H, fr.ortho, region, fr.boxes,
                    fr.use_boxes, fr.offsets, fr.screen_groups.sums, fr.depth_ex);
  // The back faces so far, without a read of its own: complete with the group totals' below.
  rt.read_async(stage, fr.depth_ex, VM_FRAME_BACK_FACES * 4, 4, &fr.back_faces);
  return rt.group_total(stage, fr.screen_groups);
}

ScreenSet fill_screen(ClRuntime& rt, const SceneBuffers& sb, Frame& fr, const cl_int4& region,
                      uint32_t S, bool bary, Stage stage) {
  ScreenSet s;
  s.count = S;
  s.tris = rt.alloc(std::max<size_t>(S, 1) * sizeof(VmScreenTri), "screen triangles");
  s.bary = rt.alloc(bary ? std::max<size_t>(S, 1) * 9 * sizeof(float) : 16, "screen barycentrics");
  const cl_int want = bary ? 1 : 0;
  const ClRuntime::GroupSums& g = fr.screen_groups;
  rt.launch_grouped(stage, "clip_fill", sb.ntri, VM_SCAN_WG, sb.idx, sb.ntri, fr.clip,
                    sb.tri_mesh, sb.tri_local, fr.mesh_cull, fr.W, fr.H, fr.ortho, region, fr.boxes,
                    fr.use_boxes, fr.offsets, g.bases, g.groups, s.tris, s.bary, want,
                    fr.depth_ex, cl_int(fr.depth_ex_done ? 0 : 1), fr.totals);
  fr.depth_ex_done = true;  // (zeroed by begin_frame; noted by clip_cells under buckets)
  return s;
}

ApartView apart_view(const SceneBuffers& sb, const Camera& cam, double min_fraction) {
  ApartView v;
  if (!sb.facts) return v;
  const double need = facts::crossing_skip_distance(*sb.facts, cam, &v.qmax);
  if (!std::isfinite(need) || (min_fraction > 0 && facts::apart_fraction(*sb.facts, need) < min_fraction))
    return v;
  v.need = static_cast<float>(need);
  if (static_cast<double>(v.need) < need) v.need = std::nextafter(v.need, INFINITY);
  v.on = std::isfinite(v.need) && std::isfinite(v.qmax);
  return v;
}

void snap_depths(ClRuntime& rt, Frame& fr, ScreenSet& s, Stage stage, const SceneBuffers* sb,
                 const ApartView& apart) {
  s.bb = rt.alloc(std::max<size_t>(s.count, 1) * sizeof(cl_int4), "triangle boxes");
  s.qr = rt.alloc(std::max<size_t>(s.count, 1) * sizeof(cl_double2), "triangle depth ranges");
  const bool on = apart.on && sb != nullptr;
  // Allocated whether the facts are on or not, so that a region's bytes (and so its memory
  // budget's halving, core/stages/budget.h) are the same with and without them.
  s.apart = rt.alloc(std::max<size_t>(s.count, 4), "apart triangles");
  rt.launch(stage, "snap_depth_planes", s.count, s.tris, s.count, fr.depth_ex, s.bb, s.qr,
            cl_int(on ? 1 : 0), on ? sb->clearance : s.apart, apart.need, apart.qmax, s.apart);
}

}  // namespace vismap::stages
