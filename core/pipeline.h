// The OpenCL pipeline (DESIGN §2): transform + clip + cull, snap, bin, silhouettes, clipping
// rounds, occlusion, planar map. Host code owns memory and orders the stages; kernels/ does the
// per-element work.
#pragma once

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "core/camera.h"
#include "core/device/device.h"
#include "core/planar_map.h"
#include "core/scene.h"
#include "core/surfaces/implicit2d.h"
#include "core/surfaces/tessellate.h"

namespace vismap {

struct RenderOptions {
  bool attributes = false;  // barycentrics + 1/w per vertex (binary output, clients)
  bool exact = false;       // exact homogeneous vertices (checks)
  bool keep_screen_triangles = false;
  uint32_t tile_pixels = 0;  // 0: chosen from the input
  // Device memory (bytes) the render may hold at once; 0: no limit. Over the limit the screen
  // is rendered in buckets (rectangles of whole pixels, each clipped exactly), one at a time.
  uint64_t memory_budget = 0;
  std::function<void(double)> progress;  // called with a fraction in [0,1], if set
  // Seconds of host wall time the render may take; 0: no limit. Checked between launches: past
  // it the render stops with InputError TimeLimit and nothing is returned.
  double time_limit_s = 0;
};

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
  uint64_t peak_device_bytes = 0;  // most device memory held at once (scene upload included)
  uint64_t allocated_device_bytes = 0;  // sum of every allocation during the render
  uint32_t clip_rounds = 0;             // summed over buckets
  uint32_t host_syncs = 0;         // blocking reads (host waits for the device), upload excluded
  uint32_t launches = 0;           // kernels, fills and copies of the frame's stages
  // Bytes moved, a model (docs/PERFORMANCE.md "Issue 17"): device_bytes sums, over launches,
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

// Tells the C allocator to keep freed memory for reuse instead of handing it back to the kernel
// (large blocks from the heap, not fresh mmaps; the heap's top trimmed only beyond 512 MiB).
// Every render allocates and frees its buffers, and with PoCL device buffers are host memory:
// each fresh page costs a page fault on first touch, ~11 us per 4 KiB on the CI machine (a
// Firecracker VM), which was a third of the bunny's pipeline time. Process-wide, so the
// executables call it first thing in main(); a library user can do the same or set
// GLIBC_TUNABLES=glibc.malloc.mmap_max=0. No effect where the C library is not glibc.
void keep_freed_memory_for_reuse();

class Renderer {
 public:
  // device: "" picks $VISMAP_DEVICE, else a GPU if there is one, else the first CPU device
  // (PoCL). Otherwise "P:D" or a case-insensitive substring of the platform or device name.
  explicit Renderer(const std::string& device = "");
  ~Renderer();
  Renderer(const Renderer&) = delete;
  Renderer& operator=(const Renderer&) = delete;

  const DeviceInfo& device() const;
  // Every curved surface of `scene` (Bezier patches, Loop subdivision) diced for `camera` on
  // this device into an ordinary mesh in the same slot (Mesh::uv, face_ids: the source patch or
  // control triangle); other meshes copied. render() takes the result; it refuses a scene with
  // undiced surfaces (InputError BadScene).
  Scene tessellate(const Scene& scene, const Camera& camera, const TessellateOptions& opts = {},
                   TessellateStats* stats = nullptr);
  // An expression in x and y drawn as filled regions on this device (core/surfaces/implicit2d.h).
  implicit::Regions2D implicit_2d(const implicit::Tape& tape, const implicit::View2D& view,
                                  double tolerance_px);
  PlanarMap render(const Scene& scene, const Camera& camera, const RenderOptions& opts = {},
                   RenderStats* stats = nullptr, ScreenTriangles* screen = nullptr);
  // One sample per pixel centre (row-major, y down): the global input triangle index
  // (Renderer's upload order: meshes in scene order) of the nearest triangle, or 0xffffffff.
  // Not exact: it is the time to beat, not a reference.
  RasterStats raster_ids(const Scene& scene, const Camera& camera,
                         std::vector<uint32_t>* ids = nullptr);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace vismap
