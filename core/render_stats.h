// What a frame reports (--stats, the server's metrics, bench/): per stage and in total, times,
// counts, launches, reads and bytes moved, and the modelled GPU floor. Its own header so that the
// stages that fill it (buckets, raster) need not include the Renderer (core/pipeline.h).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace vismap {

struct StageStat {
  std::string name;
  double ms = 0;  // summed OpenCL event time of the stage's kernels
  uint64_t items_in = 0, items_out = 0;
  uint32_t launches = 0;  // kernels, fills and copies enqueued
  uint32_t host_syncs = 0;
  uint64_t device_bytes = 0;    // modelled device memory traffic (RenderStats::device_bytes)
  uint64_t transfer_bytes = 0;  // device -> host
};

struct RenderStats {
  std::vector<StageStat> stages;
  std::vector<StageStat> kernels;  // the same times per "stage/kernel" ("stage/fill": fills)
  double pipeline_ms = 0;          // host wall time of render(), upload included
  double upload_ms = 0;
  // Counts are summed over buckets: a triangle over several buckets counts in each.
  uint64_t input_triangles = 0, screen_triangles = 0, silhouette_edges = 0;
  uint64_t entangled_pairs = 0;  // screen-triangle pairs that cross or tie (coplanar)
  uint64_t crossing_lines = 0;   // clipping entries those pairs add (lines and partner edges)
  uint64_t fragments = 0, visible_fragments = 0;
  uint64_t thin_fragments = 0;     // thinner than the fine sample grid: decided at exact points
  uint64_t deep_tournaments = 0;   // fragments decided by a tournament of > VM_TOUR_MAX triangles
  uint64_t sliver_fragments = 0;   // fragments without interior (zero area; dropped)
  // Left out because provably hidden (the cull stage, core/stages/cull.h): screen triangles
  // before the crossings, and fragments the clip rounds stopped (neither split nor finished).
  uint64_t culled_triangles = 0, dropped_fragments = 0;
  uint64_t back_faces = 0;        // back faces of closed meshes seen from outside (transform)
  uint64_t pruned_candidates = 0;  // silhouette edges along which a triangle is proven hidden
  // The scene's view-independent facts (core/facts/scene_facts.h): found in this frame in
  // facts_ms (0: earlier, or not at all); scene triangles whose clearance reached its cap
  // (facts_isolated); the clearance this view needs for a triangle to skip the crossing search
  // with all but its neighbours (apart_need, world units; 0: the skip was off this frame).
  bool has_facts = false;
  double facts_ms = 0;
  uint64_t facts_isolated = 0;
  double apart_need = 0;
  uint64_t peak_device_bytes = 0;  // most device memory held at once (scene upload included)
  uint64_t allocated_device_bytes = 0;  // sum of every allocation during the render
  uint32_t clip_rounds = 0;             // summed over buckets
  uint32_t host_syncs = 0;  // blocking reads (host waits for the device), upload excluded
  uint32_t launches = 0;    // kernels, fills and copies of the frame's stages
  // Bytes moved, a model (docs/PERFORMANCE_LOG.md "Issue 17"): device_bytes sums, over launches,
  // the sizes of the buffers each kernel is passed (once per launch; fills and copies what they
  // write, or read and write); transfer_bytes are the frame's host <-> device copies (reads
  // back, the camera's and cull modes' upload; the scene's upload excluded).
  uint64_t device_bytes = 0, transfer_bytes = 0;
  uint32_t buckets = 1;            // screen rectangles rendered one after another
  uint32_t tile_pixels = 0;        // bin tile side used (the last bucket's when there are several)
  uint64_t bucket_work_bytes = 0;  // the estimate each bucket was planned to stay under
};

// The modelled GPU floor of a frame (issue 17): launches x 5.5 us + blocking reads x 17 us +
// (device + transfer bytes) / 2.3 TB/s, the costs measured on an H100 through NVIDIA's OpenCL
// (a launch ~5-6 us, a launch plus a blocking 4-byte read ~16-19 us, streaming ~2.3 TB/s).
double modelled_gpu_floor_ms(const RenderStats& st);

// The floor of issue 5: a plain z-buffer id raster of the same scene on the same device.
struct RasterStats {
  double ms = 0;          // host wall time (scene upload excluded)
  double kernels_ms = 0;  // OpenCL event time: transform, clip, snap, clear, 2 passes
  uint64_t screen_triangles = 0;
};

}  // namespace vismap
