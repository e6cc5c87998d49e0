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
#include "core/stages/scene_facts.h"
#include "core/render_stats.h"
#include "core/scene.h"
#include "core/surfaces/tessellate.h"

namespace vismap {

namespace implicit {  // core/surfaces/implicit2d.h, for Renderer::implicit_2d's callers
struct Tape;
struct View2D;
struct Regions2D;
}  // namespace implicit

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
  // Leave out what is provably hidden (core/stages/cull.h): triangles before the crossings,
  // candidates and clip rounds, fragments during them. The visible region of every source is the
  // same either way; off, the frame clips every triangle in view (for comparisons and tests).
  bool cull = true;
  // With cull, the crossing search skips pairs of triangles that are far apart in 3D and share
  // no vertex (core/stages/scene_facts.h), from view-independent facts found once per uploaded
  // scene: when the scene is rendered a second time (Repeat: a single frame, as the CLI renders,
  // does not pay for them; an orbit does), at once (Now), or never (Off); or given (below).
  // The map is the same either way, byte for byte, under a memory budget too (the buckets are
  // planned without the facts' bytes; facts over a sixteenth of the budget are not used). Under
  // a memory budget Repeat finds none (a renderer there holds only what it was asked for): ask
  // for them (Now, or scene_facts) and every frame has them.
  enum class Facts { Repeat, Now, Off };
  Facts facts = Facts::Repeat;
  // Facts the caller found for this scene (stages::find_scene_facts), used instead of the
  // renderer's own (unless facts is Off): a server finds them once per session's scene, whichever
  // renderer draws its frames.
  std::shared_ptr<const stages::SceneFacts> scene_facts;
  // The facts serve a view only where at least this fraction of the triangles is apart in it
  // (below, the bins' walk of those not apart plus the adjacency cost about what they save: the
  // teapot stadium's view has 3 %). 0: whenever they apply (tests).
  double min_apart_fraction = 0.5;
};

// Tells the C allocator to keep freed blocks under 32 MiB for reuse instead of handing them back
// to the kernel (from the heap, not fresh mmaps; the heap's top trimmed only beyond 512 MiB);
// blocks of 32 MiB and more come from mmap and go back when freed. Every render allocates and
// frees its buffers, and with PoCL device buffers are host memory: each fresh page costs a page
// fault on first touch, ~11 us per 4 KiB on the CI machine (a Firecracker VM), which was a
// third of the bunny's pipeline time when glibc's default (mmap from 128 KiB up) applied. The
// big device buffers' host blocks are kept for reuse by the device runtime itself
// (core/device/cl_runtime.cpp, release_freed_memory); what is left at 32 MiB and more is a few
// host arrays (the bunny's frame has none; the dragon's at 1080p ~55 MB of pages a frame), and
// they are what a heavy request would otherwise leave in the heap (issue 35: a server held
// 52-60 MiB in thread arenas after one dense implicit frame, malloc_trim or not). Process-wide,
// so the executables call it first thing in main(); a library user can do the same or set
// GLIBC_TUNABLES=glibc.malloc.mmap_threshold=33554432. No effect where the C library is not
// glibc.
void keep_freed_memory_for_reuse();
// Hands memory kept for reuse back to the kernel: the freed host blocks of CPU devices' buffers
// (32 MiB and more, core/device/cl_runtime.cpp) and the C heap's free pages (malloc_trim). For a
// process that must give back what one heavy request took once it ends (vismapd); safe from any
// thread, while others render too.
void release_freed_memory();

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
  // An expression in x and y drawn as filled regions on this device (core/surfaces/implicit2d.h),
  // within the time limit and memory budget given (0: none), as a frame's.
  implicit::Regions2D implicit_2d(const implicit::Tape& tape, const implicit::View2D& view,
                                  double tolerance_px, double time_limit_s = 0,
                                  uint64_t memory_budget = 0);
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
