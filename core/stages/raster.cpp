#include "core/stages/raster.h"

#include "core/util/clock.h"

namespace vismap::stages {

RasterStats raster_ids(ClRuntime& rt, const SceneBuffers& sb, const Scene& scene, const Camera& cam,
                       std::vector<uint32_t>* ids) {
  constexpr Stage kStage = Stage::Raster;
  RasterStats rs;
  const uint32_t W = cam.width, H = cam.height;
  if (ids) ids->assign(size_t(W) * H, 0xffffffffu);
  if (sb.ntri == 0) return rs;
  auto t0 = Clock::now();
  rt.reset_profile();
  // The same transform, clipping, culling and snapping as a frame, over the whole screen.
  Frame fr = begin_frame(rt, sb, scene, cam, kStage);
  const uint32_t S = count_screen(rt, sb, fr, fr.full, kStage);
  rs.screen_triangles = S;
  ScreenSet s = fill_screen(rt, sb, fr, fr.full, S, false, kStage);
  if (S) snap_depths(rt, fr, s, kStage);
  const uint32_t npix = W * H;
  cl::Buffer depth = rt.alloc(size_t(npix) * 4, "z-buffer depth");
  cl::Buffer pix = rt.alloc(size_t(npix) * 4, "z-buffer ids");
  rt.fill_u32(depth, 0, npix, kStage);
  rt.fill_u32(pix, 0xffffffffu, npix, kStage);
  rt.launch(kStage, "zb_depth", S, s.tris, S, W, H, depth);
  rt.launch(kStage, "zb_ids", S, s.tris, S, W, H, depth, pix);
  std::vector<uint32_t> local;
  std::vector<uint32_t>& out = ids ? *ids : local;
  out.resize(npix);
  rt.queue().enqueueReadBuffer(pix, CL_TRUE, 0, size_t(npix) * 4, out.data());
  rs.ms = ms_since(t0);
  for (const ClRuntime::StageTime& t : rt.collect_profile()) rs.kernels_ms += t.ms;
  if (ids && S) {  // screen-triangle index -> input triangle index
    std::vector<VmScreenTri> host(S);
    rt.queue().enqueueReadBuffer(s.tris, CL_TRUE, 0, size_t(S) * sizeof(VmScreenTri), host.data());
    for (uint32_t& v : out)
      if (v != 0xffffffffu) v = host[v].src;
  }
  return rs;
}

}  // namespace vismap::stages
