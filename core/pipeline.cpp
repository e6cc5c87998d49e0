// Host side of the pipeline: the Renderer, the scene upload, and a frame as a loop of stage
// calls over its regions (the whole screen, or the buckets of --memory-budget). Each stage's
// host code is in core/stages/ and its kernels in kernels/ (docs/ARCHITECTURE.md); this file only
// orders them and adds up their figures.
#include "core/pipeline.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <exception>
#include <cstring>
#include <string>
#include <utility>
#include <vector>
#if defined(__GLIBC__)
#include <malloc.h>
#endif

#include "core/device/cl_runtime.h"
#include "core/error.h"
#include "core/stages/bin.h"
#include "core/stages/buckets.h"
#include "core/stages/budget.h"
#include "core/stages/candidates.h"
#include "core/stages/clip.h"
#include "core/stages/crossings.h"
#include "core/stages/cull.h"
#include "core/stages/deadline.h"
#include "core/stages/emit.h"
#include "core/stages/map_build.h"
#include "core/stages/occlusion.h"
#include "core/stages/raster.h"
#include "core/stages/silhouettes.h"
#include "core/stages/transform.h"
#include "core/surfaces/implicit.h"
#include "core/surfaces/implicit2d.h"
#include "core/surfaces/internal.h"
#include "core/util/clock.h"
#include "core/util/mesh_topology.h"

namespace vismap {

static_assert(ScreenTriangles::kFreePlane == VM_PLANE_FREE, "one sentinel for a free depth plane");

namespace {

// A frame's per-stage figures, summed over its regions.
struct Tally {
  ClRuntime::StageTimes time{};
  std::array<std::pair<uint64_t, uint64_t>, kStageCount> io{};  // items in, items out
  void items(Stage s, uint64_t in, uint64_t out) {
    io[size_t(s)].first += in;
    io[size_t(s)].second += out;
  }
  void add(const ClRuntime::StageTimes& t) {
    for (size_t i = 0; i < kStageCount; ++i) {
      time[i].ms += t[i].ms;
      time[i].launches += t[i].launches;
      time[i].syncs += t[i].syncs;
      time[i].bytes += t[i].bytes;
      time[i].transfer_bytes += t[i].transfer_bytes;
    }
  }
};

// In buckets a triangle is seen by every bucket its box meets; it is kept once, by the bucket
// holding its box's low corner (buckets tile the screen, half-open).
void keep_screen_triangles(const std::vector<VmScreenTri>& tris, const cl_int4& region,
                           bool in_buckets, ScreenTriangles& out) {
  for (const VmScreenTri& t : tris) {
    if (in_buckets) {
      int x0 = std::min({t.x[0], t.x[1], t.x[2]}), y0 = std::min({t.y[0], t.y[1], t.y[2]});
      if (x0 < region.s[0] || x0 >= region.s[2] || y0 < region.s[1] || y0 >= region.s[3]) continue;
    }
    for (int k = 0; k < 3; ++k) {
      out.xy.push_back(t.x[k]);
      out.xy.push_back(t.y[k]);
      out.depth.push_back(t.q[k]);
    }
    out.mesh.push_back(t.mesh);
    out.triangle.push_back(t.tri);
    out.plane_k.push_back(t.plane_k);
  }
}

}  // namespace

struct Renderer::Impl {
  explicit Impl(const std::string& device) : rt(device) { rt.build(8); }

  ClRuntime rt;

  // What the uploaded scene's buffers were made of, byte for byte: every mesh's positions and
  // indices, concatenated, and each mesh's counts. A scene is uploaded again unless it matches
  // all of it (same_as_uploaded). A hash was the key before (issue 45, item 4): a 64-bit
  // non-cryptographic one, so a scene crafted to collide with another session's got that
  // session's frame, and showed it the crafted geometry. Held on the host: 12 B a vertex and
  // 12 B a triangle of the last scene uploaded (the bunny's 1.2 MB, the dragon's 16 MB).
  std::vector<float> held_positions;
  std::vector<uint32_t> held_indices;
  std::vector<std::pair<size_t, size_t>> held_counts;  // per mesh: positions, indices
  bool uploaded = false;
  bool same_as_uploaded(const Scene& scene) const;
  stages::SceneBuffers sb;
  LoopPlans loop_plans;  // per Loop control mesh, built on first use

  void upload(const Scene& scene, RenderStats& st);
  // The facts given for the uploaded scene (RenderOptions::scene_facts) uploaded, or the ones
  // held released where none (or none usable) are given.
  void take_facts(const RenderOptions& opts);
  void drop_facts();  // the facts held released (device buffers and bytes)
  PlanarMap run(const Scene& scene, const Camera& cam, const RenderOptions& opts, RenderStats& st,
                ScreenTriangles* screen);
  // One region's S screen triangles through every stage into `map`. False when a stage found
  // that the region would pass its budget (budget.needed() says by how much): nothing of it is
  // in the map or the figures then.
  bool render_region(stages::Frame& fr, const cl_int4& region, uint32_t S,
                     const RenderOptions& opts, const stages::ApartView& apart,
                     const stages::Deadline& deadline, stages::RegionBudget& budget,
                     RenderStats& st, Tally& tally, PlanarMap& map, ScreenTriangles* screen);
};

// Compares the bytes, not a digest: exact, and at memory speed (both copies read once). Measured
// on the shared 2-core machine at load 9: 0.09 ms for the bunny, 2.8 ms for the dragon, where
// the 64-bit hash it replaces took 0.21 and 3.7 and a SHA-256 (OpenSSL, ~1 GB/s there) would
// take ~1.3 and ~16. Floats compare bitwise, as they are uploaded (0.0 and -0.0 differ: the
// scene is uploaded again).
bool Renderer::Impl::same_as_uploaded(const Scene& scene) const {
  if (!uploaded || scene.meshes.size() != held_counts.size()) return false;
  size_t pos = 0, idx = 0;
  for (size_t m = 0; m < scene.meshes.size(); ++m) {
    const Mesh& mesh = scene.meshes[m];
    if (mesh.positions.size() != held_counts[m].first ||
        mesh.indices.size() != held_counts[m].second)
      return false;
    if (!mesh.positions.empty() && std::memcmp(mesh.positions.data(), held_positions.data() + pos,
                                               mesh.positions.size() * sizeof(float)) != 0)
      return false;
    if (!mesh.indices.empty() && std::memcmp(mesh.indices.data(), held_indices.data() + idx,
                                             mesh.indices.size() * sizeof(uint32_t)) != 0)
      return false;
    pos += mesh.positions.size();
    idx += mesh.indices.size();
  }
  return true;
}

void Renderer::Impl::upload(const Scene& scene, RenderStats& st) {
  if (scene.has_surfaces())
    throw InputError(InputErrorKind::BadScene, scene.source, "", "", -1,
                     "curved surfaces must be diced first (Renderer::tessellate)");
  // By content, not by address: a scene freed and another loaded in its place (a server's
  // sessions, a loop over scenes) may reuse its addresses and its triangle count. A diced scene
  // is new every frame: always uploaded.
  bool diced = false;
  for (const Mesh& m : scene.meshes) diced = diced || !m.uv.empty();
  if (!diced && same_as_uploaded(scene)) return;
  auto t0 = Clock::now();
  std::vector<float> p;
  std::vector<uint32_t> ix, tm, tl;
  uint64_t vbase = 0;
  for (size_t m = 0; m < scene.meshes.size(); ++m) {
    const Mesh& mesh = scene.meshes[m];
    p.insert(p.end(), mesh.positions.begin(), mesh.positions.end());
    for (uint32_t i : mesh.indices) ix.push_back(static_cast<uint32_t>(vbase + i));
    for (size_t t = 0; t < mesh.triangle_count(); ++t) {
      tm.push_back(static_cast<uint32_t>(m));
      tl.push_back(static_cast<uint32_t>(t));
    }
    vbase += mesh.vertex_count();
  }
  if (vbase >= (1ull << 32) || tm.size() >= (1ull << 30))
    throw InputError(InputErrorKind::TooLarge, scene.source, "", "", -1,
                     "scene too large for 32-bit indices");
  sb.nv = static_cast<uint32_t>(vbase);
  sb.ntri = static_cast<uint32_t>(tm.size());
  sb.pos = rt.upload(p, "positions");
  sb.idx = rt.upload(ix, "indices");
  sb.tri_mesh = rt.upload(tm, "triangle mesh ids");
  sb.tri_local = rt.upload(tl, "triangle ids");
  sb.bytes = p.size() * sizeof(float) + (ix.size() + tm.size() + tl.size()) * sizeof(uint32_t);
  sb.closed.clear();
  for (const Mesh& mesh : scene.meshes) sb.closed.push_back(closed_orientation(mesh));
  sb.facts.reset();  // (the new scene's come with its frames)
  sb.clearance = sb.adj_offset = sb.adj = cl::Buffer();
  uploaded = !diced;
  held_counts.clear();
  held_indices.clear();
  held_positions.clear();
  if (uploaded) {
    held_positions = std::move(p);  // (the positions as uploaded: concatenated, unchanged)
    held_indices.reserve(ix.size());
    for (const Mesh& mesh : scene.meshes) {
      held_indices.insert(held_indices.end(), mesh.indices.begin(), mesh.indices.end());
      held_counts.emplace_back(mesh.positions.size(), mesh.indices.size());
    }
  } else {
    held_positions.shrink_to_fit();
    held_indices.shrink_to_fit();
  }
  st.upload_ms = ms_since(t0);
}

void Renderer::Impl::drop_facts() {
  if (sb.facts) sb.bytes -= sb.facts->bytes();
  sb.facts.reset();
  sb.clearance = sb.adj_offset = sb.adj = cl::Buffer();
}

void Renderer::Impl::take_facts(const RenderOptions& opts) {
  const std::shared_ptr<const facts::SceneFacts>& f = opts.scene_facts;
  if (!opts.cull || !f || f->clearance.size() != sb.ntri || !(f->cap > 0) ||
      (opts.memory_budget && f->bytes() > opts.memory_budget / 16)) {
    // (None given, not this scene's, none found, or too large: under a budget the buckets' plan
    // leaves them out, so that it is the same with and without them (plan_buckets), and they come
    // out of the eighth it keeps for the allocator: at most half of it, else the frame goes
    // without.)
    if (sb.facts) drop_facts();
    return;
  }
  if (f == sb.facts) return;  // (uploaded already)
  if (sb.facts) sb.bytes -= sb.facts->bytes();
  sb.facts = f;
  sb.clearance = rt.upload(f->clearance, "scene clearances");
  sb.adj_offset = rt.upload(f->adj_offset, "scene adjacency");
  sb.adj = rt.upload(f->adj, "scene adjacency");
  sb.bytes += f->bytes();
}

PlanarMap Renderer::Impl::run(const Scene& scene, const Camera& cam, const RenderOptions& opts,
                              RenderStats& st, ScreenTriangles* screen) {
  cam.validate();
  PlanarMap map;
  map.width = cam.width;
  map.height = cam.height;
  map.grid_scale = VM_GRID_SCALE;
  upload(scene, st);
  const stages::Deadline deadline(opts.time_limit_s, scene.source, opts.started, opts.cancel);
  take_facts(opts);
  st.input_triangles = sb.ntri;
  rt.reset_profile();
  rt.reset_allocated();
  rt.reset_peak();
  if (sb.ntri == 0) return map;
  if (screen) {
    *screen = ScreenTriangles{};
    screen->grid_scale = VM_GRID_SCALE;
  }
  Tally tally;

  stages::Frame fr = stages::begin_frame(rt, sb, scene, cam, Stage::Transform);
  // A throw drains the queue before fr goes (count_screen reads its back faces without blocking).
  struct DrainOnThrow {
    ClRuntime& rt;
    int in_flight = std::uncaught_exceptions();
    ~DrainOnThrow() {
      if (std::uncaught_exceptions() > in_flight) rt.drain();
    }
  } drain_on_throw{rt};
  const stages::ApartView apart = stages::apart_view(sb, cam, opts.min_apart_fraction);
  st.has_facts = sb.facts != nullptr;
  st.facts_isolated = sb.facts ? sb.facts->isolated : 0;
  st.apart_need = apart.on ? apart.need : 0;
  std::vector<cl_int4> todo{fr.full};
  if (opts.memory_budget) todo = stages::plan_buckets(rt, sb, fr, opts.memory_budget, st);
  std::reverse(todo.begin(), todo.end());
  st.buckets = 0;
  // The plan is an estimate: a bucket whose screen triangles, at the bytes per triangle seen so
  // far, would not fit is halved again before anything of it is allocated.
  uint64_t bytes_per_tri = stages::kBucketBytesPerTriangle;
  while (!todo.empty()) {
    const cl_int4 region = todo.back();
    todo.pop_back();
    deadline.check(Stage::Transform);
    const uint64_t base = rt.allocated_bytes();
    const uint32_t S = stages::count_screen(rt, sb, fr, region, Stage::Transform);
    tally.items(Stage::Transform, sb.ntri, 0);
    cl_int4 half_a, half_b;
    if (fr.use_boxes && uint64_t(S) * bytes_per_tri > st.bucket_work_bytes &&
        stages::halve_bucket(region, half_a, half_b, 16)) {
      todo.push_back(half_b);
      todo.push_back(half_a);
      continue;
    }
    if (S > 0) {
      stages::RegionBudget budget =
          fr.use_boxes ? stages::RegionBudget(rt, st.bucket_work_bytes) : stages::RegionBudget();
      if (!render_region(fr, region, S, opts, apart, deadline, budget, st, tally, map, screen)) {
        // Its pairs, candidates or fragments would pass the budget: halve it, down to single
        // pixels, and plan the halves with what it would have needed per triangle. A pixel that
        // cannot fit is an error, not a bucket that goes over.
        if (!stages::halve_bucket(region, half_a, half_b, 1))
          throw InputError(InputErrorKind::TooLarge, scene.source, "", "", -1,
                           "memory budget of " + mib(opts.memory_budget) +
                               " is too small: one pixel of the screen needs " +
                               mib(budget.needed() + (opts.memory_budget - budget.limit())) +
                               " of device memory");
        bytes_per_tri = std::max(bytes_per_tri, budget.needed() / S + 1);
        todo.push_back(half_b);
        todo.push_back(half_a);
        continue;
      }
    }
    ++st.buckets;
    st.screen_triangles += S;
    tally.items(Stage::Transform, 0, S);
    if (S == 0) continue;
    // What this bucket allocated per screen triangle: a deterministic upper bound of what it held
    // at once (the peak itself depends on when the runtime frees), so that the same scene and
    // budget always give the same buckets.
    if (fr.use_boxes) bytes_per_tri = std::max(bytes_per_tri, (rt.allocated_bytes() - base) / S);
  }
  st.back_faces = fr.back_faces;  // (read with the last region's count)
  st.host_syncs = rt.host_syncs();
  st.transfer_bytes = rt.write_bytes();
  tally.items(Stage::Emit, st.visible_fragments, map.vertex_count());
  for (Stage s : kFrameStages) {
    StageStat ss;
    ss.name = stage_name(s);
    ss.ms = tally.time[size_t(s)].ms;
    ss.launches = tally.time[size_t(s)].launches;
    ss.host_syncs = tally.time[size_t(s)].syncs;
    ss.device_bytes = tally.time[size_t(s)].bytes;
    ss.transfer_bytes = tally.time[size_t(s)].transfer_bytes;
    st.launches += ss.launches;
    st.device_bytes += ss.device_bytes;
    st.transfer_bytes += ss.transfer_bytes;
    ss.items_in = tally.io[size_t(s)].first;
    ss.items_out = tally.io[size_t(s)].second;
    st.stages.push_back(ss);
  }
  for (const auto& [name, t] : rt.kernel_profile())
    st.kernels.push_back({name, t.first, 0, 0, t.second});
  st.peak_device_bytes = rt.peak_bytes();
  st.allocated_device_bytes = rt.allocated_bytes();
#if defined(__GLIBC__)
  if (opts.memory_budget) malloc_trim(0);  // a budgeted render hands back what it freed
#endif
  return map;
}

double modelled_gpu_floor_ms(const RenderStats& st) {
  constexpr double kLaunchUs = 5.5, kSyncUs = 17.0, kBytesPerUs = 2.3e6;  // 2.3 TB/s
  return (st.launches * kLaunchUs + st.host_syncs * kSyncUs +
          double(st.device_bytes + st.transfer_bytes) / kBytesPerUs) /
         1000.0;
}

bool Renderer::Impl::render_region(stages::Frame& fr, const cl_int4& region, uint32_t S,
                                   const RenderOptions& opts, const stages::ApartView& apart,
                                   const stages::Deadline& deadline, stages::RegionBudget& budget,
                                   RenderStats& st, Tally& tally, PlanarMap& map,
                                   ScreenTriangles* screen) {
  using namespace stages;
  ScreenSet s = fill_screen(rt, sb, fr, region, S, opts.attributes, Stage::Transform);
  cl::Buffer& totals = fr.totals;

  Silhouettes sil;
  find_silhouettes(rt, s, totals, sil);
  snap_depths(rt, fr, s, Stage::Transform, &sb, apart);
  const Grids grids = choose_grids(opts.tile_pixels, fr.W, fr.H, S);
  st.tile_pixels = grids.tile_px;
  // The leaves' places are the cull's (a rectangle a leaf, a leaf an entry): under a budget only
  // where they fit (the whole screen's leaves, before any split, and about four entries a triangle).
  const uint64_t places_bytes = uint64_t(grids.fine.tiles_x) * grids.fine.tiles_y * 16 + S * 16ull;
  const bool places = opts.cull && budget.fits_more(rt, places_bytes);
  const TriangleBins tb = bin_triangles(rt, s, grids.fine, places);
  // From here on the provably hidden triangles are out of the frame (their boxes emptied).
  CullBounds cull;
  deadline.check(Stage::Cull);
  if (!places || !cull_hidden(rt, s, tb, fr.W, fr.H, sil, totals, budget, cull))
    cull = no_cull_bounds(rt);  // (off, or no room for it under the budget: every triangle kept)
  deadline.check(Stage::Crossings);
  Crossings cx;
  if (!find_crossings(rt, s, tb, totals, budget, sb, fr, apart.on, cx)) return false;
  ClipEdges ce = emit_silhouettes(rt, s, sil, cx.entries);
  emit_crossings(rt, s, cx, ce);
  const EdgeBins eb = bin_edges(rt, ce, grids.edge);
  Candidates cand;
  if (!find_candidates(rt, s, tb, ce, eb, cx, cull, totals, budget, cand)) return false;
  deadline.check(Stage::Clip);

  auto progress = [&](uint32_t rounds) {
    if (opts.progress) opts.progress(0.2 + 0.6 * (1.0 - 1.0 / (1.0 + rounds * 0.1)));
  };
  Fragments frags;
  const uint64_t before_clip = budget.used(rt);
  for (;;) {
    const ClipStatus cs = clip_fragments(rt, s, region, fr.use_boxes, cand, ce, cull, totals,
                                         deadline, budget, progress, frags);
    if (cs == ClipStatus::Done) break;
    if (cs == ClipStatus::OverBudget) return false;
    // A fragment needs more supporting lines than the program was built for: rebuild with twice
    // as many and run the clipping again. Nothing is dropped.
    if (rt.maxl() >= 256) throw DeviceError("a fragment needs more than 256 supporting lines");
    rt.build(rt.maxl() * 2);
    rt.fill_u32(totals, 0, VM_TOTAL_PRUNED, Stage::Clip);  // (not the earlier stages' counts)
    budget.forget_since(rt, before_clip);                  // the first try's fragments are gone
  }
  deadline.check(Stage::Occlusion);
  const Visibility vis = decide_visibility(rt, frags, s, tb, ce, cx, cull, totals);

  Emitted em;
  read_visible(rt, frags, vis, s, screen != nullptr, opts.attributes, totals, em);
  tally.add(rt.collect_profile());  // waits for the queue: every read above is complete
  auto t_emit = Clock::now();
  build_planar_map(em.fragments, opts.exact, fr.ortho != 0, opts.attributes ? &em.tris : nullptr,
                   opts.attributes ? &em.bary : nullptr, map);
  tally.time[size_t(Stage::Emit)].ms += ms_since(t_emit);

  st.silhouette_edges += sil.count;
  st.entangled_pairs += cx.pairs;
  st.crossing_lines += cx.entries;
  st.clip_rounds += frags.rounds;
  st.fragments += frags.count;
  st.visible_fragments += vis.count;
  st.thin_fragments += vis.thin;
  st.deep_tournaments += vis.deep;
  st.sliver_fragments += em.totals[VM_TOTAL_SLIVERS];
  const uint32_t kept = S - em.totals[VM_TOTAL_CULLED];
  st.culled_triangles += em.totals[VM_TOTAL_CULLED];
  st.dropped_fragments += em.totals[VM_TOTAL_DROPPED];
  st.pruned_candidates += em.totals[VM_TOTAL_PRUNED];
  tally.items(Stage::Silhouettes, uint64_t(3) * S, sil.count);
  tally.items(Stage::Bin, uint64_t(S) + sil.count, uint64_t(tb.leaves.entries) + eb.leaves.entries);
  tally.items(Stage::Cull, S, kept);
  tally.items(Stage::Crossings, kept, cx.pairs);
  tally.items(Stage::Candidates, kept, cand.total);
  tally.items(Stage::Clip, kept, frags.count);
  tally.items(Stage::Occlusion, frags.count, vis.count);
  if (screen) {
    keep_screen_triangles(em.tris, region, fr.use_boxes != 0, *screen);
    stages::keep_crossing_lines(rt, cx, em.tris, screen->crossings);
  }
  return true;
}

void keep_freed_memory_for_reuse() {
#if defined(__GLIBC__)
  mallopt(M_MMAP_THRESHOLD, 32 << 20);  // fixed: glibc's dynamic threshold would creep up
  mallopt(M_TRIM_THRESHOLD, 512 << 20);
#endif
}

void release_freed_memory() {
  release_host_blocks();
#if defined(__GLIBC__)
  malloc_trim(0);
#endif
}

namespace {

// The OpenCL C++ wrapper's exceptions, from any call the Renderer makes, as DeviceError naming the
// failed call, its code and the device.
template <typename F>
auto device_errors(const ClRuntime& rt, F&& f) -> decltype(f()) {
  try {
    return f();
  } catch (const cl::Error& e) {
    throw DeviceError(std::string("OpenCL error in ") + e.what() + " (" + std::to_string(e.err()) +
                      ") on " + rt.info().name);
  }
}

}  // namespace

Renderer::Renderer(const std::string& device) : impl_(std::make_unique<Impl>(device)) {}
Renderer::~Renderer() = default;

const DeviceInfo& Renderer::device() const {
  return impl_->rt.info();
}

RasterStats Renderer::raster_ids(const Scene& scene, const Camera& camera,
                                 std::vector<uint32_t>* ids) {
  return device_errors(impl_->rt, [&] {
    camera.validate();
    RenderStats ust;
    impl_->upload(scene, ust);
    return stages::raster_ids(impl_->rt, impl_->sb, scene, camera, ids);
  });
}

Scene Renderer::tessellate(const Scene& scene, const Camera& camera, const TessellateOptions& opts,
                           TessellateStats* stats) {
  TessellateStats local;
  TessellateStats& st = stats ? *stats : local;
  st = TessellateStats{};
  auto t0 = Clock::now();
  return device_errors(impl_->rt, [&] {
    camera.validate();
    if (!(opts.tolerance_px > 0) || !std::isfinite(opts.tolerance_px))
      throw InputError(InputErrorKind::BadScene, scene.source, "", "", -1,
                       "tessellation tolerance must be a positive number of pixels");
    Scene out;
    out.camera = scene.camera;
    out.dropped_degenerate = scene.dropped_degenerate;
    out.source = scene.source;
    out.meshes.reserve(scene.meshes.size());
    const stages::Deadline deadline(opts.time_limit_s, scene.source, opts.started, opts.cancel);
    const surfaces::TimeCheck check_time = [&] { deadline.check(Stage::Tessellate); };
    for (const Mesh& m : scene.meshes) {
      check_time();
      if (m.implicit)
        out.meshes.push_back(surfaces::dice_implicit(impl_->rt, m, camera, opts, st, check_time));
      else if (!m.patches.empty())
        out.meshes.push_back(surfaces::dice_patches(impl_->rt, m, camera, opts, st, check_time));
      else if (m.subdivision)
        out.meshes.push_back(surfaces::dice_subdivision(
            impl_->rt, m, camera, opts, opts.loop_plans ? *opts.loop_plans : impl_->loop_plans, st,
            check_time));
      else
        out.meshes.push_back(m);
    }
    st.ms = ms_since(t0);
    return out;
  });
}

implicit::Regions2D Renderer::implicit_2d(const implicit::Tape& tape, const implicit::View2D& view,
                                          double tolerance_px, double time_limit_s,
                                          uint64_t memory_budget, Clock::time_point started) {
  const stages::Deadline deadline(time_limit_s, "", started);
  return device_errors(impl_->rt, [&] {
    return implicit::contour_2d(
        impl_->rt, tape, view, tolerance_px, [&] { deadline.check(Stage::Implicit); },
        surfaces::implicit_queue_cap(memory_budget));
  });
}

PlanarMap Renderer::render(const Scene& scene, const Camera& camera, const RenderOptions& opts,
                           RenderStats* stats, ScreenTriangles* screen) {
  RenderStats local;
  RenderStats& st = stats ? *stats : local;
  st = RenderStats{};
  auto t0 = Clock::now();
  return device_errors(impl_->rt, [&] {
    PlanarMap map = impl_->run(scene, camera, opts, st, screen);
    st.pipeline_ms = ms_since(t0);
    return map;
  });
}

}  // namespace vismap
