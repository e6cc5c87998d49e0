// Stage transform (kernels/transform.cl): the scene's vertices to clip space once per frame, then
// per region (the whole screen, or one bucket) every input triangle near-clipped, culled and
// snapped to the grid as screen triangles (count, scan, fill); after the silhouette hash, each
// screen triangle's depth plane snapped to integers over the frame's 2^k.
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "core/camera.h"
#include "core/device/cl_runtime.h"
#include "core/stages/scene_facts.h"
#include "core/scene.h"

namespace vismap::stages {

// The uploaded scene (Renderer's upload order: meshes in scene order).
struct SceneBuffers {
  cl::Buffer pos, idx, tri_mesh, tri_local;
  uint32_t nv = 0, ntri = 0;
  uint64_t bytes = 0;          // device bytes they hold
  std::vector<int8_t> closed;  // per mesh: closed_orientation()
  // The scene's view-independent facts (scene_facts.h), once found or given: the host's copy
  // (for each view's need) and the clearances and adjacency on the device.
  bool facts_tried = false;  // the renderer tried to find them for this upload
  bool facts_given = false;  // they are RenderOptions::scene_facts (not the renderer's own)
  std::shared_ptr<const SceneFacts> facts;
  cl::Buffer clearance, adj_offset, adj;
};

// Per frame, with scene facts: the clearance a triangle needs in this view to be apart
// (crossing_skip_distance, rounded up to a float) and the largest nearness for the steepness
// test. `on` false: no facts, or none apply to this view.
struct ApartView {
  bool on = false;
  float need = 0;
  double qmax = 0;
};
// Off where fewer than min_fraction of the triangles are apart (SceneFacts' bins, from below).
ApartView apart_view(const SceneBuffers& sb, const Camera& cam, double min_fraction);

// Per frame, before any region: the camera's matrix and cull modes, the clip-space vertices, the
// per-input-triangle offsets (within their work-group) and the groups' totals, the whole screen
// as a region, and (buckets only) each input triangle's box in pixels.
struct Frame {
  uint32_t W = 0, H = 0;
  cl::Buffer mat, mesh_cull, clip, offsets, boxes;
  ClRuntime::GroupSums screen_groups;  // clip_count -> clip_fill (a fused scan)
  cl_int ortho = 0, use_boxes = 0;
  // The depth-plane exponent reductions (note_depth_exponents): over the whole frame once
  // clip_cells has noted every screen triangle (buckets), else by the first clip_fill.
  cl::Buffer depth_ex;  // and the frame's counts after them (VM_FRAME_*)
  bool depth_ex_done = false;
  // Back faces of closed meshes left out so far (read back by count_screen with its count).
  uint32_t back_faces = 0;
  // The region's VM_TOTAL_* words (counts and status flags the kernels raise), zeroed by
  // fill_screen for each region.
  cl::Buffer totals;
  cl_int4 full{};
};

// The S screen triangles of one region; bary (9 floats each) only when asked for; their boxes
// (int4, grid units) and nearness ranges (double2), written by snap_depths.
struct ScreenSet {
  cl::Buffer tris, bary, bb, qr;
  cl::Buffer apart;  // per triangle, a byte: apart in this view (only with an ApartView on)
  uint32_t count = 0;
};

// Back faces are culled only where that cannot change the picture (per mesh, VM_CULL_*).
std::vector<uint32_t> cull_modes(const Scene& scene, const std::vector<int8_t>& closed,
                                 const Camera& cam);

Frame begin_frame(ClRuntime& rt, const SceneBuffers& sb, const Scene& scene, const Camera& cam,
                  Stage stage);
// Sizes the region's screen triangles (the frame's offsets and group totals); returns S.
uint32_t count_screen(ClRuntime& rt, const SceneBuffers& sb, Frame& fr, const cl_int4& region,
                      Stage stage);
// Writes the S triangles counted by count_screen, with barycentrics when `bary`, and zeroes
// fr.totals.
ScreenSet fill_screen(ClRuntime& rt, const SceneBuffers& sb, Frame& fr, const cl_int4& region,
                      uint32_t S, bool bary, Stage stage);
// The depth planes snapped to integers over one 2^k (snap_depth_planes): crossing lines between
// them are then exact. After the silhouette hash, whose keys are the transformed depths shared by
// mesh neighbours. Also writes s.bb and s.qr (the binning's boxes and nearness ranges), and
// with `apart` on, s.apart.
void snap_depths(ClRuntime& rt, Frame& fr, ScreenSet& s, Stage stage,
                 const SceneBuffers* sb = nullptr, const ApartView& apart = {});

}  // namespace vismap::stages
