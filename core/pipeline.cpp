// Host side of the pipeline: orders the stages, owns the buffers, sizes every buffer from a
// count (count, scan, allocate, fill), and turns the result into a PlanarMap. The per-element
// work is in kernels/ (see docs/ARCHITECTURE.md for the stage-by-stage map).
#include "core/pipeline.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#if defined(__GLIBC__)
#include <malloc.h>
#endif

#include "core/cl_runtime.h"
#include "core/clock.h"
#include "core/error.h"
#include "core/map_build.h"
#include "core/mesh_topology.h"

namespace vismap {

static_assert(ScreenTriangles::kFreePlane == VM_PLANE_FREE, "one sentinel for a free depth plane");

namespace {

uint32_t next_pow2(uint64_t v) {
  uint64_t p = 1;
  while (p < v) p <<= 1;
  return static_cast<uint32_t>(p);
}

// A uniform grid of square tiles of tile_px pixels over a W x H screen (bins, bucket cells).
VmGrid make_grid(uint32_t tile_px, uint32_t W, uint32_t H) {
  VmGrid g;
  g.tile_size = static_cast<int32_t>(tile_px * VM_GRID_SCALE);
  g.tiles_x = static_cast<int32_t>((W + tile_px - 1) / tile_px);
  g.tiles_y = static_cast<int32_t>((H + tile_px - 1) / tile_px);
  g.tile_shift = 0;
  while ((1 << g.tile_shift) < g.tile_size) ++g.tile_shift;
  return g;
}

// Totals buffer slots: one small read per clip round brings back all of them.
enum Slot : uint32_t { kStatus = 0, kSlivers = 1, kNextTotal = 2, kDoneTotal = 3, kThin = 4, kSlots = 5 };

struct LinesOverflow {};

}  // namespace

struct Renderer::Impl {
  explicit Impl(const std::string& device) : rt(device) { rt.build(8); }

  ClRuntime rt;

  // The uploaded scene; re-uploaded when a different scene comes in.
  const Scene* scene_key = nullptr;
  size_t key_tris = 0;
  const float* key_pos = nullptr;
  cl::Buffer pos, idx, tri_mesh, tri_local;
  uint32_t nv = 0, ntri = 0;
  uint64_t scene_bytes = 0;  // device bytes of the uploaded scene
  std::vector<int8_t> closed;  // per mesh: closed_orientation()

  void upload(const Scene& scene, RenderStats& st);
  std::vector<uint32_t> cull_modes(const Scene& scene, const Camera& cam) const;
  PlanarMap run(const Scene& scene, const Camera& cam, const RenderOptions& opts, RenderStats& st,
                ScreenTriangles* screen);
  RasterStats raster(const Scene& scene, const Camera& cam, std::vector<uint32_t>* ids);

  // Per frame, before clipping: the camera's matrix and cull modes, the clip-space vertices, the
  // per-input-triangle count and offset buffers, the whole screen as a region, and (buckets
  // only) each input triangle's box in pixels.
  struct Frame {
    uint32_t W = 0, H = 0;
    cl::Buffer mat, mesh_cull, clip, counts, offsets, boxes;
    cl_int ortho = 0, use_boxes = 0;
    // The depth-plane exponent reductions (transform.cl depth_exponents): over the whole frame
    // once clip_cells has noted every screen triangle (buckets), else per screen set.
    cl::Buffer depth_ex;
    bool depth_ex_done = false;
    cl_int4 full{};
  };
  Frame begin_frame(const Scene& scene, const Camera& cam, const char* stage);
  // The S screen triangles of a region: count_screen sizes them (the frame's counts and
  // offsets, S returned), then fill_screen writes them, with barycentrics when bary is given.
  uint32_t count_screen(Frame& fr, const cl_int4& region, const char* stage);
  void fill_screen(Frame& fr, const cl_int4& region, const char* stage, uint32_t S, cl::Buffer& tris,
                   cl::Buffer* bary);
  // The S screen triangles' depth planes snapped to integers over one 2^k (transform.cl
  // snap_depth_planes): crossing lines between them are then exact. After the silhouette hash,
  // whose keys are the transformed depths shared by mesh neighbours.
  void snap_depths(Frame& fr, cl::Buffer& tris, uint32_t S, const char* stage);
  std::vector<cl_int4> plan_buckets(uint64_t budget, Frame& fr, RenderStats& st);
};

// Device bytes a bucket needs per screen triangle in it, all stages together (measured peak
// over screen triangles on the bench scenes, with margin; docs/PERFORMANCE.md).
constexpr uint64_t kBucketBytesPerTriangle = 1400;

// Splits the screen into rectangles whose estimated working memory fits in what the budget
// leaves after the scene and the per-frame buffers: one pass counts, per cell of a coarse grid,
// the screen triangles whose box touches it (an upper bound for any rectangle of cells), then
// rectangles are halved at their count median, longer side first, until each fits or is one
// cell. Also fills `boxes` (each input triangle's box in pixels) so that buckets skip the
// triangles that cannot reach them without clipping them again.
std::vector<cl_int4> Renderer::Impl::plan_buckets(uint64_t budget, Frame& fr, RenderStats& st) {
  const uint32_t W = fr.W, H = fr.H;
  const uint32_t cell_px = std::max<uint32_t>(16, next_pow2((std::max(W, H) + 63) / 64));
  const VmGrid cells = make_grid(cell_px, W, H);
  const uint32_t cx = uint32_t(cells.tiles_x), cy = uint32_t(cells.tiles_y);

  fr.boxes = rt.alloc(size_t(ntri) * sizeof(cl_ushort4), "triangle boxes");
  fr.use_boxes = 1;
  std::vector<uint32_t> hist(size_t(cx) * cy);
  {
    cl::Buffer h = rt.alloc(hist.size() * 4, "bucket cell counts");
    rt.fill_u32(h, 0, hist.size(), "transform");
    rt.launch("transform", "clip_cells", ntri, idx, ntri, fr.clip, tri_mesh, tri_local, fr.mesh_cull,
              W, H, fr.ortho, fr.full, cells, h, fr.boxes, fr.depth_ex);
    fr.depth_ex_done = true;
    rt.read(h, 0, hist.size() * 4, hist.data());
  }
  // What every bucket holds besides its own work: the scene, the clip-space vertices, the
  // per-input-triangle counts, offsets and boxes (all allocated by now).
  // Counted from the sizes, not from what the runtime reports held: releases of an earlier
  // render's buffers may still be on their way, and the plan must not depend on timing.
  // An eighth of the budget is left for what the allocator holds beyond the live buffers
  // (rounding to huge pages, freed blocks kept for reuse).
  const uint64_t held = scene_bytes + rt.allocated_bytes(), fixed = held + budget / 8;
  if (budget <= fixed + (held >> 3))
    throw InputError(InputErrorKind::TooLarge, "", "", "", -1,
                     "memory budget of " + std::to_string(budget >> 20) + " MiB is too small: the scene alone holds " +
                         std::to_string(held >> 20) + " MiB of device memory");
  const uint64_t work = budget - fixed;
  st.bucket_work_bytes = work;

  // Summed-area table over the cells.
  std::vector<uint64_t> sat((cx + 1) * size_t(cy + 1), 0);
  for (uint32_t y = 0; y < cy; ++y)
    for (uint32_t x = 0; x < cx; ++x)
      sat[(y + 1) * size_t(cx + 1) + x + 1] = hist[y * size_t(cx) + x] + sat[y * size_t(cx + 1) + x + 1] +
                                              sat[(y + 1) * size_t(cx + 1) + x] - sat[y * size_t(cx + 1) + x];
  auto sum = [&](uint32_t x0, uint32_t y0, uint32_t x1, uint32_t y1) {
    return sat[y1 * size_t(cx + 1) + x1] - sat[y0 * size_t(cx + 1) + x1] - sat[y1 * size_t(cx + 1) + x0] +
           sat[y0 * size_t(cx + 1) + x0];
  };
  std::vector<cl_int4> out;
  auto split = [&](auto&& self, uint32_t x0, uint32_t y0, uint32_t x1, uint32_t y1) -> void {
    const uint64_t n = sum(x0, y0, x1, y1);
    if (n == 0) return;  // nothing reaches it: nothing to draw there
    const bool wide = (x1 - x0) >= (y1 - y0);
    if (n * kBucketBytesPerTriangle <= work || (x1 - x0 == 1 && y1 - y0 == 1)) {
      out.push_back({{cl_int(x0 * cell_px * VM_GRID_SCALE), cl_int(y0 * cell_px * VM_GRID_SCALE),
                      cl_int(std::min(x1 * cell_px, W) * VM_GRID_SCALE),
                      cl_int(std::min(y1 * cell_px, H) * VM_GRID_SCALE)}});
      return;
    }
    // Cut at the median of the counts along the longer side (a side of one cell is not cut).
    const bool cut_x = (x1 - x0 > 1) && (wide || y1 - y0 == 1);
    const uint32_t lo = cut_x ? x0 : y0, hi = cut_x ? x1 : y1;
    uint32_t m = lo + 1;
    for (; m + 1 < hi; ++m) {
      uint64_t part = cut_x ? sum(x0, y0, m, y1) : sum(x0, y0, x1, m);
      if (2 * part >= n) break;
    }
    if (cut_x) {
      self(self, x0, y0, m, y1);
      self(self, m, y0, x1, y1);
    } else {
      self(self, x0, y0, x1, m);
      self(self, x0, m, x1, y1);
    }
  };
  split(split, 0, 0, cx, cy);
  if (out.empty()) out.push_back(fr.full);  // nothing on screen: one (empty) bucket
  return out;
}

void Renderer::Impl::upload(const Scene& scene, RenderStats& st) {
  const float* first = scene.meshes.empty() ? nullptr : scene.meshes[0].positions.data();
  if (scene_key == &scene && key_tris == scene.triangle_count() && key_pos == first) return;
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
  nv = static_cast<uint32_t>(vbase);
  ntri = static_cast<uint32_t>(tm.size());
  pos = rt.upload(p, "positions");
  idx = rt.upload(ix, "indices");
  tri_mesh = rt.upload(tm, "triangle mesh ids");
  tri_local = rt.upload(tl, "triangle ids");
  scene_bytes = p.size() * sizeof(float) + (ix.size() + tm.size() + tl.size()) * sizeof(uint32_t);
  closed.clear();
  for (const Mesh& mesh : scene.meshes) closed.push_back(closed_orientation(mesh));
  scene_key = &scene;
  key_tris = scene.triangle_count();
  key_pos = first;
  st.upload_ms = ms_since(t0);
}

// Back faces are culled only where that cannot change the picture: a closed, consistently
// oriented mesh lying wholly in front of the near plane (so the eye is outside it and no cut
// opens it). Everything else is two-sided.
std::vector<uint32_t> Renderer::Impl::cull_modes(const Scene& scene, const Camera& cam) const {
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

PlanarMap Renderer::Impl::run(const Scene& scene, const Camera& cam, const RenderOptions& opts,
                              RenderStats& st, ScreenTriangles* screen) {
  cam.validate();
  const uint32_t W = cam.width, H = cam.height;
  const bool ortho = cam.projection == Camera::Projection::Orthographic;
  PlanarMap map;
  map.width = W;
  map.height = H;
  map.grid_scale = VM_GRID_SCALE;
  upload(scene, st);
  st.input_triangles = ntri;
  rt.reset_profile();
  rt.reset_allocated();
  rt.reset_peak();
  if (ntri == 0) return map;
  auto& q = rt.queue();
  const bool want_bary = opts.attributes;

  // ---- transform (once per frame) ----------------------------------------------------------
  Frame fr = begin_frame(scene, cam, "transform");

  // ---- buckets (--memory-budget): parts of the screen rendered one after another ------------
  std::vector<cl_int4> regions{fr.full};
  if (opts.memory_budget) regions = plan_buckets(opts.memory_budget, fr, st);
  const cl_int use_boxes = fr.use_boxes;  // in buckets, root fragments are clipped to theirs
  st.buckets = 0;
  // The plan is an estimate: a bucket whose screen triangles, at the bytes per triangle seen so
  // far, would not fit is halved again before anything of it is allocated.
  std::vector<cl_int4> todo(regions.rbegin(), regions.rend());
  uint64_t bytes_per_tri = kBucketBytesPerTriangle;
  auto halve = [](const cl_int4& r, cl_int4& a, cl_int4& b) {
    const int unit = 16 * VM_GRID_SCALE, w = r.s[2] - r.s[0], h = r.s[3] - r.s[1];
    const bool cut_x = w >= 2 * unit && (w >= h || h < 2 * unit);
    if (!cut_x && h < 2 * unit) return false;
    a = b = r;
    const int at = cut_x ? r.s[0] + (w / 2 / unit) * unit : r.s[1] + (h / 2 / unit) * unit;
    a.s[cut_x ? 2 : 3] = at;
    b.s[cut_x ? 0 : 1] = at;
    return true;
  };

  std::map<std::string, std::pair<double, uint32_t>> profile;
  std::map<std::string, std::pair<uint64_t, uint64_t>> io;
  auto add_io = [&](const char* stage, uint64_t in, uint64_t out) {
    io[stage].first += in;
    io[stage].second += out;
  };
  if (screen) {
    screen->grid_scale = VM_GRID_SCALE;
    screen->xy.clear();
    screen->depth.clear();
    screen->mesh.clear();
    screen->triangle.clear();
    screen->plane_k.clear();
  }

  while (!todo.empty()) {
    const cl_int4 region = todo.back();
    todo.pop_back();
    const uint64_t base = rt.allocated_bytes();
    // ---- clip + cull + snap, keeping the triangles that reach the region ----------------------
    const uint32_t S = count_screen(fr, region, "transform");
    add_io("transform", ntri, 0);
    cl_int4 half_a, half_b;
    if (use_boxes && uint64_t(S) * bytes_per_tri > st.bucket_work_bytes && halve(region, half_a, half_b)) {
      todo.push_back(half_b);
      todo.push_back(half_a);
      continue;
    }
    ++st.buckets;
    st.screen_triangles += S;
    add_io("transform", 0, S);
    if (S == 0) continue;
    cl::Buffer tris, tri_bary;
    fill_screen(fr, region, "transform", S, tris, want_bary ? &tri_bary : nullptr);

    cl::Buffer totals = rt.alloc(kSlots * 4, "totals");
    rt.fill_u32(totals, 0, kSlots, "transform");

    // ---- silhouette edges (hash) --------------------------------------------------------------
    const uint32_t nedges = 3 * S;
    cl::Buffer eflags = rt.alloc(size_t(nedges) * 4, "edge flags");
    cl::Buffer eoffs = rt.alloc(size_t(nedges) * 4, "edge offsets");
    uint32_t E = 0;
    {  // the hash table only lives to classify (memory freed early is memory reused later)
      const uint32_t table_size = next_pow2(uint64_t(nedges) * 2);
      cl::Buffer table = rt.alloc(size_t(table_size) * 4, "edge hash table");
      cl::Buffer second = rt.alloc(size_t(table_size) * 4, "edge hash second ids");
      cl::Buffer many = rt.alloc(size_t(table_size) * 4, "edge hash shared flags");
      cl::Buffer slot_min = rt.alloc(size_t(table_size) * 4, "edge slot min");
      cl::Buffer slot_of_edge = rt.alloc(size_t(nedges) * 4, "edge slots");
      rt.fill_u32(table, 0, table_size, "silhouettes");
      rt.fill_u32(second, 0, table_size, "silhouettes");
      rt.fill_u32(many, 0, table_size, "silhouettes");
      rt.fill_u32(slot_min, 0xffffffffu, table_size, "silhouettes");
      rt.launch("silhouettes", "edge_insert", nedges, tris, nedges, table, table_size - 1, slot_of_edge,
                second, many, slot_min, totals);
      rt.launch("silhouettes", "edge_classify", nedges, tris, nedges, slot_of_edge, table, second, many,
                slot_min, eflags);
      E = rt.scan("silhouettes", eflags, eoffs, nedges);
    }
    snap_depths(fr, tris, S, "transform");

    // ---- bins ---------------------------------------------------------------------------------
    uint32_t tile_px = opts.tile_pixels;
    if (tile_px == 0) {
      double side = 2.0 * std::sqrt(double(W) * H / std::max<uint32_t>(S, 1));
      tile_px = std::clamp<uint32_t>(next_pow2(static_cast<uint64_t>(std::ceil(side))), 8, 512);
    }
    st.tile_pixels = tile_px;
    const VmGrid eg = make_grid(tile_px, W, H);
    const VmGrid og = make_grid(std::max<uint32_t>(tile_px / 2, 4), W, H);


    // Adaptive leaves (kernels/bin.cl): a crowded tile of g is split into leaves where that
    // saves work, and every leaf's list is ordered by (class, id) with where each class starts,
    // so that pair traversals skip what a leaf does not own and every walk is in a fixed order.
    struct Leaves {
      cl::Buffer tile_leaf, offset, class_start, list;
      uint32_t leaves = 0, entries = 0;
    };
    auto bin_leaves = [&](const char* stage, cl::Buffer& bb, uint32_t n, const VmGrid& g) {
      const uint32_t ntiles = uint32_t(g.tiles_x) * uint32_t(g.tiles_y);
      Leaves lv;
      cl::Buffer count;
      // Count, scan and fill the lists of the leaves given by lv.tile_leaf (lv.leaves of them).
      auto fill_leaves = [&] {
        count = rt.alloc(size_t(lv.leaves) * 4, "leaf counts");
        lv.offset = rt.alloc(size_t(lv.leaves) * 4, "leaf offsets");
        rt.fill_u32(count, 0, lv.leaves, stage);
        rt.launch(stage, "leaf_bin", n, bb, n, g, lv.tile_leaf, count, count, count, count, cl_int(0));
        lv.entries = rt.scan(stage, count, lv.offset, lv.leaves);
        lv.list = rt.alloc(std::max<size_t>(lv.entries, 1) * 4, "leaf lists");
        cl::Buffer cursor = rt.alloc(size_t(lv.leaves) * 4, "leaf cursors");
        rt.fill_u32(cursor, 0, lv.leaves, stage);
        rt.launch(stage, "leaf_bin", n, bb, n, g, lv.tile_leaf, count, lv.offset, cursor, lv.list, cl_int(1));
      };
      // The coarse pass: every tile one leaf.
      lv.tile_leaf = rt.alloc(size_t(ntiles) * 4, "tile leaves");
      lv.leaves = ntiles;
      rt.launch(stage, "leaf_identity", ntiles, ntiles, lv.tile_leaf);
      fill_leaves();
      // Each tile's depth from its coarse list; the map is rewritten only after the last use of
      // the coarse one (the queue is in order).
      cl::Buffer per_tile = rt.alloc(size_t(ntiles) * 4, "leaves per tile");
      cl::Buffer first = rt.alloc(size_t(ntiles) * 4, "first leaf per tile");
      rt.launch(stage, "bin_depth", ntiles, lv.offset, count, ntiles, bb, g, lv.list, lv.tile_leaf, per_tile);
      const uint32_t leaves = rt.scan(stage, per_tile, first, ntiles);
      rt.launch(stage, "bin_pack", ntiles, ntiles, first, lv.tile_leaf);
      if (leaves != ntiles) {  // some tile split: bin again into the leaves (else the map is the same)
        lv.leaves = leaves;
        fill_leaves();
      }
      lv.class_start = rt.alloc(size_t(lv.leaves) * sizeof(cl_uint4), "leaf class starts");
      rt.launch(stage, "leaf_sort_classes", ntiles, ntiles, lv.tile_leaf, lv.offset, count, lv.list,
                lv.class_start);
      return lv;
    };
    // Triangles on the fine grid (crossing pairs, occlusion), sorted so that every list a kernel
    // walks is in a fixed order.
    cl::Buffer tri_bb = rt.alloc(size_t(S) * sizeof(cl_int4), "triangle boxes");
    cl::Buffer tri_qr = rt.alloc(size_t(S) * sizeof(cl_double2), "triangle depth ranges");
    rt.launch("bin", "tri_bbox", S, tris, S, tri_bb, tri_qr);
    Leaves tbins = bin_leaves("bin", tri_bb, S, og);
    cl::Buffer pair_t, pair_o, pair_rel, pair_line;

    // ---- penetrating and tying pairs ----------------------------------------------------------
    // One traversal finds each pair once (by its lower triangle) into small inline slots; only if
    // a triangle has more pairs than the slots hold is the traversal repeated into exact space.
    constexpr uint32_t kInline = 4;  // VM_PAIRS_INLINE in kernels/crossing.cl
    cl::Buffer pcount = rt.alloc(size_t(S) * 4, "pair counts");
    cl::Buffer poffset = rt.alloc(size_t(S) * 4, "pair offsets");
    uint32_t P = 0;
    {
      cl::Buffer scr_o = rt.alloc(size_t(S) * kInline * 4, "pair scratch");
      cl::Buffer scr_rel = rt.alloc(size_t(S) * kInline * 4, "pair scratch");
      cl::Buffer scr_line = rt.alloc(size_t(S) * kInline * sizeof(VmLine), "pair scratch");
      rt.launch("crossings", "cross_pairs", S, tris, S, tri_bb, tri_qr, og, tbins.tile_leaf, tbins.offset,
                tbins.class_start, tbins.list, pcount, scr_o, scr_rel, scr_line, totals);
      P = rt.scan("crossings", pcount, poffset, S);
      uint32_t status = 0;
      rt.read(totals, 0, sizeof status, &status);
      pair_t = rt.alloc(std::max<size_t>(P, 1) * 4, "pairs");
      pair_o = rt.alloc(std::max<size_t>(P, 1) * 4, "pairs");
      pair_rel = rt.alloc(std::max<size_t>(P, 1) * 4, "pairs");
      pair_line = rt.alloc(std::max<size_t>(P, 1) * sizeof(VmLine), "pairs");
      // Triangles whose pairs fit their slots are copied; after an overflow the others traverse
      // again, straight into the compact arrays.
      rt.launch("crossings", "cross_compact", S, S, pcount, poffset, scr_o, scr_rel, scr_line,
                pair_t, pair_o, pair_rel, pair_line);
      if (status & VM_STATUS_PAIRS_OVERFLOW)
        rt.launch("crossings", "cross_pairs_fill", S, tris, S, tri_bb, tri_qr, og, tbins.tile_leaf,
                  tbins.offset, tbins.class_start, tbins.list, pcount, poffset, pair_t, pair_o, pair_rel,
                  pair_line);
    }
    rt.launch("crossings", "cross_refine", P, P, tris, pair_t, pair_o, pair_rel, pair_line);
    cl::Buffer in_count = rt.alloc(size_t(S) * 4, "incoming pair counts");
    cl::Buffer in_offset = rt.alloc(size_t(S) * 4, "incoming pair offsets");
    cl::Buffer in_cursor = rt.alloc(size_t(S) * 4, "incoming pair cursors");
    rt.fill_u32(in_count, 0, S, "crossings");
    rt.fill_u32(in_cursor, 0, S, "crossings");
    rt.launch("crossings", "cross_in_count", P, P, pair_o, in_count);
    rt.scan("crossings", in_count, in_offset, S);
    cl::Buffer in_list = rt.alloc(std::max<size_t>(P, 1) * 4, "incoming pairs");
    rt.launch("crossings", "cross_in_fill", P, P, pair_o, in_offset, in_cursor, in_list);
    cl::Buffer cross_count = rt.alloc(size_t(S) * 4, "crossing entry counts");
    cl::Buffer cross_offset = rt.alloc(size_t(S) * 4, "crossing entry offsets");
    rt.launch("crossings", "cross_in_sort", S, S, in_count, in_offset, in_list);
    rt.launch("crossings", "cross_entry_count", S, S, tris, pcount, poffset, in_count, in_offset,
              in_list, pair_t, pair_o, pair_rel, pair_line, cross_count);
    const uint32_t X = rt.scan("crossings", cross_count, cross_offset, S);
    cl::Buffer edges = rt.alloc((size_t(E) + X) * sizeof(VmEdge), "clipping edges");
    cl::Buffer partner = rt.alloc(std::max<size_t>(X, 1) * 4, "crossing partners");
    rt.launch("silhouettes", "edge_emit", nedges, tris, nedges, eflags, eoffs, edges);
    rt.launch("crossings", "cross_entry_fill", S, S, tris, pcount, poffset, in_count, in_offset,
              in_list, pair_t, pair_o, pair_rel, pair_line, cross_offset, E, edges, partner);

    cl::Buffer edge_bb = rt.alloc(std::max<size_t>(E, 1) * sizeof(cl_int4), "edge boxes");
    rt.launch("bin", "edge_bbox", E, edges, E, edge_bb);
    Leaves ebins = bin_leaves("bin", edge_bb, E, eg);

    // ---- candidate edges per triangle ---------------------------------------------------------
    cl::Buffer cand_count = rt.alloc(size_t(S) * 4, "candidate counts");
    cl::Buffer cand_offset = rt.alloc(size_t(S) * 4, "candidate offsets");
    rt.launch("candidates", "cand_count", S, tris, S, tri_bb, edges, edge_bb, eg, ebins.tile_leaf,
              ebins.offset, ebins.class_start, ebins.list, cross_count, cand_count);
    const uint32_t C = rt.scan("candidates", cand_count, cand_offset, S);
    cl::Buffer cand = rt.alloc(std::max<size_t>(C, 1) * 4, "candidates");
    rt.launch("candidates", "cand_fill", S, tris, S, tri_bb, edges, edge_bb, eg, ebins.tile_leaf,
              ebins.offset, ebins.class_start, ebins.list, cross_offset, cross_count, E, cand_offset, cand);

    // ---- clipping rounds (work queue) ---------------------------------------------------------
    cl::Buffer done_meta, done_lines;
    uint32_t nd = 0, rounds = 0;
    for (;;) {
      const uint32_t L = rt.maxl();
      try {
        cl::Buffer qmeta = rt.alloc(size_t(S) * sizeof(VmFragMeta), "fragment queue");
        cl::Buffer qlines = rt.alloc(size_t(S) * L * sizeof(VmLine), "fragment lines");
        rt.launch("clip", "frag_init", S, tris, S, region, use_boxes, qmeta, qlines);
        // Finished fragments are ~1.2 per screen triangle on the bench scenes (bunny 1.17,
        // dragon 1.23): room for 1.25 avoids growing (a copy, and old and new held at once).
        uint32_t nq = S, done_cap = std::max<uint32_t>(S + S / 4, 1024);
        done_meta = rt.alloc(size_t(done_cap) * sizeof(VmFragMeta), "finished fragments");
        done_lines = rt.alloc(size_t(done_cap) * L * sizeof(VmLine), "finished fragment lines");
        nd = 0;
        rounds = 0;
        while (nq > 0) {
          ++rounds;
          cl::Buffer split_at = rt.alloc(size_t(nq) * 4, "split edges");
          cl::Buffer ncount = rt.alloc(size_t(nq) * 4, "queue counts");
          cl::Buffer dcount = rt.alloc(size_t(nq) * 4, "done counts");
          cl::Buffer noff = rt.alloc(size_t(nq) * 4, "queue offsets");
          cl::Buffer doff = rt.alloc(size_t(nq) * 4, "done offsets");
          rt.launch("clip", "clip_find", nq, qmeta, qlines, nq, cand_offset, cand_count, cand, edges,
                    split_at, ncount, dcount, totals);
          rt.scan_to("clip", ncount, noff, nq, totals, kNextTotal);
          rt.scan_to("clip", dcount, doff, nq, totals, kDoneTotal);
          uint32_t tot[kSlots];
          rt.read(totals, 0, sizeof tot, tot);
          if (tot[kStatus] & VM_STATUS_LINES_OVERFLOW) throw LinesOverflow{};
          if (tot[kStatus] & VM_STATUS_HASH_FULL) throw DeviceError("edge hash table full");
          const uint32_t nn = tot[kNextTotal], dn = tot[kDoneTotal];
          if (uint64_t(nd) + dn > done_cap) {  // grow the finished list, keeping what it holds
            uint32_t cap = std::max<uint32_t>(done_cap + done_cap / 2, nd + dn);
            cl::Buffer m2 = rt.alloc(size_t(cap) * sizeof(VmFragMeta), "finished fragments");
            cl::Buffer l2 = rt.alloc(size_t(cap) * L * sizeof(VmLine), "finished fragment lines");
            if (nd) {
              q.enqueueCopyBuffer(done_meta, m2, 0, 0, size_t(nd) * sizeof(VmFragMeta));
              q.enqueueCopyBuffer(done_lines, l2, 0, 0, size_t(nd) * L * sizeof(VmLine));
            }
            done_meta = m2;
            done_lines = l2;
            done_cap = cap;
          }
          cl::Buffer nmeta = rt.alloc(std::max<size_t>(nn, 1) * sizeof(VmFragMeta), "fragment queue");
          cl::Buffer nlines = rt.alloc(std::max<size_t>(nn, 1) * L * sizeof(VmLine), "fragment lines");
          rt.launch("clip", "clip_apply", nq, qmeta, qlines, nq, cand_offset, cand, edges, split_at,
                    noff, doff, nd, nmeta, nlines, done_meta, done_lines);
          nd += dn;
          nq = nn;
          qmeta = nmeta;
          qlines = nlines;
          if (opts.progress) opts.progress(0.2 + 0.6 * (1.0 - 1.0 / (1.0 + rounds * 0.1)));
        }
        break;
      } catch (const LinesOverflow&) {
        // A fragment needs more supporting lines than the program was built for: rebuild with
        // twice as many and run the clipping again. Nothing is dropped.
        if (L >= 256) throw DeviceError("a fragment needs more than 256 supporting lines");
        rt.build(L * 2);
        rt.fill_u32(totals, 0, kSlots, "clip");
      }
    }
    const uint32_t L = rt.maxl();

    // ---- occlusion ----------------------------------------------------------------------------
    cl::Buffer visible = rt.alloc(std::max<size_t>(nd, 1) * 4, "visibility");
    cl::Buffer voff = rt.alloc(std::max<size_t>(nd, 1) * 4, "visible offsets");
    rt.launch("occlusion", "occlude", nd, done_meta, done_lines, nd, tris, tri_bb, og, tbins.tile_leaf,
              tbins.offset, tbins.class_start, tbins.list, edges, E, cross_offset, cross_count, partner,
              visible, totals);
    uint32_t thin = 0;
    rt.read(totals, kThin * 4, 4, &thin);
    if (thin > 0)  // cells thinner than the fine sample grid: decided at exact rational points
      rt.launch("occlusion", "occlude_thin", nd, done_meta, done_lines, nd, tris, tri_bb, og,
                tbins.tile_leaf, tbins.offset, tbins.class_start, tbins.list, edges, E, cross_offset,
                cross_count, partner, visible, totals);
    const uint32_t V = rt.scan("occlusion", visible, voff, nd);

    // ---- planar map ---------------------------------------------------------------------------
    VisibleFragments vf;
    vf.maxl = L;
    vf.meta.resize(V);
    vf.lines.resize(size_t(V) * L);
    std::vector<cl_uint2> src(V);
    if (V > 0) {
      cl::Buffer om = rt.alloc(size_t(V) * sizeof(VmFragMeta), "visible fragments");
      cl::Buffer ol = rt.alloc(size_t(V) * L * sizeof(VmLine), "visible lines");
      cl::Buffer os = rt.alloc(size_t(V) * sizeof(cl_uint2), "visible sources");
      rt.launch("emit", "emit_visible", nd, done_meta, done_lines, nd, visible, voff, tris, om, ol, os);
      q.enqueueReadBuffer(om, CL_FALSE, 0, size_t(V) * sizeof(VmFragMeta), vf.meta.data());
      q.enqueueReadBuffer(ol, CL_FALSE, 0, size_t(V) * L * sizeof(VmLine), vf.lines.data());
      q.enqueueReadBuffer(os, CL_FALSE, 0, size_t(V) * sizeof(cl_uint2), src.data());
    }
    uint32_t tot[kSlots];
    rt.read(totals, 0, sizeof tot, tot);  // in order: the reads above are done too
    vf.mesh.resize(V);
    vf.triangle.resize(V);
    for (uint32_t i = 0; i < V; ++i) {
      vf.mesh[i] = src[i].s[0];
      vf.triangle[i] = src[i].s[1];
    }

    std::vector<VmScreenTri> host_tris;
    std::vector<float> host_bary;
    if (want_bary || screen) {
      host_tris.resize(S);
      q.enqueueReadBuffer(tris, CL_FALSE, 0, size_t(S) * sizeof(VmScreenTri), host_tris.data());
    }
    if (want_bary) {
      host_bary.resize(size_t(S) * 9);
      q.enqueueReadBuffer(tri_bary, CL_FALSE, 0, host_bary.size() * sizeof(float), host_bary.data());
    }
    // collect_profile() waits for the queue: the reads above are complete after it.
    for (const auto& [stage, t] : rt.collect_profile()) {
      profile[stage].first += t.first;
      profile[stage].second += t.second;
    }
    auto t_emit = Clock::now();
    build_planar_map(vf, opts.exact, ortho, want_bary ? &host_tris : nullptr,
                     want_bary ? &host_bary : nullptr, map);
    profile["emit"].first += ms_since(t_emit);

    st.silhouette_edges += E;
    st.entangled_pairs += P;
    st.crossing_lines += X;
    st.clip_rounds += rounds;
    st.fragments += nd;
    st.visible_fragments += V;
    st.thin_fragments += thin;
    st.sliver_fragments += tot[kSlivers];
    add_io("silhouettes", uint64_t(3) * S, E);
    add_io("bin", uint64_t(S) + E, uint64_t(tbins.entries) + ebins.entries);
    add_io("crossings", S, P);
    add_io("candidates", S, C);
    add_io("clip", S, nd);
    add_io("occlusion", nd, V);

    if (screen) {
      // In buckets a triangle is seen by every bucket its box meets; it is kept once, by the
      // bucket holding its box's low corner (buckets tile the screen, half-open).
      for (const VmScreenTri& t : host_tris) {
        if (use_boxes) {
          int x0 = std::min({t.x[0], t.x[1], t.x[2]}), y0 = std::min({t.y[0], t.y[1], t.y[2]});
          if (x0 < region.s[0] || x0 >= region.s[2] || y0 < region.s[1] || y0 >= region.s[3]) continue;
        }
        for (int k = 0; k < 3; ++k) {
          screen->xy.push_back(t.x[k]);
          screen->xy.push_back(t.y[k]);
          screen->depth.push_back(t.q[k]);
        }
        screen->mesh.push_back(t.mesh);
        screen->triangle.push_back(t.tri);
        screen->plane_k.push_back(t.plane_k);
      }
    }
    if (use_boxes) {
      // What this bucket allocated per screen triangle: a deterministic upper bound of what it
      // held at once (the peak itself depends on when the runtime frees), so that the same
      // scene and budget always give the same buckets.
      bytes_per_tri = std::max(bytes_per_tri, (rt.allocated_bytes() - base) / S);
    }
  }  // buckets
  st.host_syncs = rt.host_syncs();
  add_io("emit", st.visible_fragments, map.vertex_count());

  for (const char* name : {"transform", "silhouettes", "bin", "crossings", "candidates", "clip",
                           "occlusion", "emit"}) {
    StageStat s;
    s.name = name;
    s.ms = profile[name].first;
    s.launches = profile[name].second;
    s.items_in = io[name].first;
    s.items_out = io[name].second;
    st.stages.push_back(s);
  }
  for (const auto& [name, t] : rt.kernel_profile()) {
    StageStat k;
    k.name = name;
    k.ms = t.first;
    k.launches = t.second;
    st.kernels.push_back(k);
  }
  st.peak_device_bytes = rt.peak_bytes();
  st.allocated_device_bytes = rt.allocated_bytes();
#if defined(__GLIBC__)
  if (opts.memory_budget) malloc_trim(0);  // a budgeted render hands back what it freed
#endif
  return map;
}

Renderer::Impl::Frame Renderer::Impl::begin_frame(const Scene& scene, const Camera& cam,
                                                  const char* stage) {
  Frame f;
  f.W = cam.width;
  f.H = cam.height;
  Mat4 vp = cam.view_projection();
  f.mat = rt.upload(std::vector<double>(vp.begin(), vp.end()), "view-projection");
  f.mesh_cull = rt.upload(cull_modes(scene, cam), "cull modes");
  f.clip = rt.alloc(size_t(nv) * sizeof(cl_double4), "clip-space vertices");
  rt.launch(stage, "transform_vertices", nv, pos, nv, f.mat, f.clip);
  f.counts = rt.alloc(size_t(ntri) * 4, "clip counts");
  f.offsets = rt.alloc(size_t(ntri) * 4, "clip offsets");
  f.ortho = cam.projection == Camera::Projection::Orthographic ? 1 : 0;
  f.full = {{0, 0, cl_int(cam.width * VM_GRID_SCALE), cl_int(cam.height * VM_GRID_SCALE)}};
  f.boxes = rt.alloc(16, "triangle boxes");  // plan_buckets fills it for buckets
  f.depth_ex = rt.alloc(4 * sizeof(cl_int), "depth exponents");
  rt.fill_u32(f.depth_ex, 0, 4, stage);
  return f;
}

uint32_t Renderer::Impl::count_screen(Frame& fr, const cl_int4& region, const char* stage) {
  rt.launch(stage, "clip_count", ntri, idx, ntri, fr.clip, tri_mesh, tri_local, fr.mesh_cull, fr.W, fr.H,
            fr.ortho, region, fr.boxes, fr.use_boxes, fr.counts);
  return rt.scan(stage, fr.counts, fr.offsets, ntri);
}

void Renderer::Impl::fill_screen(Frame& fr, const cl_int4& region, const char* stage, uint32_t S,
                                 cl::Buffer& tris, cl::Buffer* bary) {
  tris = rt.alloc(std::max<size_t>(S, 1) * sizeof(VmScreenTri), "screen triangles");
  cl::Buffer none;
  cl::Buffer& b = bary ? *bary : none;
  b = rt.alloc(bary ? std::max<size_t>(S, 1) * 9 * sizeof(float) : 16, "screen barycentrics");
  const cl_int want = bary ? 1 : 0;
  rt.launch(stage, "clip_fill", ntri, idx, ntri, fr.clip, tri_mesh, tri_local, fr.mesh_cull, fr.W, fr.H,
            fr.ortho, region, fr.boxes, fr.use_boxes, fr.offsets, tris, b, want);
}

void Renderer::Impl::snap_depths(Frame& fr, cl::Buffer& tris, uint32_t S, const char* stage) {
  if (!fr.depth_ex_done) {  // zeroed by begin_frame
    rt.launch(stage, "depth_exponents", S, tris, S, fr.ortho, fr.depth_ex);
    fr.depth_ex_done = true;
  }
  rt.launch(stage, "snap_depth_planes", S, tris, S, fr.depth_ex);
}

RasterStats Renderer::Impl::raster(const Scene& scene, const Camera& cam, std::vector<uint32_t>* ids) {
  cam.validate();
  RenderStats ust;
  upload(scene, ust);
  RasterStats rs;
  const uint32_t W = cam.width, H = cam.height;
  if (ids) ids->assign(size_t(W) * H, 0xffffffffu);
  if (ntri == 0) return rs;
  auto t0 = Clock::now();
  rt.reset_profile();
  // The same transform, clipping, culling and snapping as run(), over the whole screen.
  Frame fr = begin_frame(scene, cam, "raster");
  const uint32_t S = count_screen(fr, fr.full, "raster");
  rs.screen_triangles = S;
  cl::Buffer tris;
  fill_screen(fr, fr.full, "raster", S, tris, nullptr);
  if (S) snap_depths(fr, tris, S, "raster");
  const uint32_t npix = W * H;
  cl::Buffer depth = rt.alloc(size_t(npix) * 4, "z-buffer depth");
  cl::Buffer pix = rt.alloc(size_t(npix) * 4, "z-buffer ids");
  rt.fill_u32(depth, 0, npix, "raster");
  rt.fill_u32(pix, 0xffffffffu, npix, "raster");
  rt.launch("raster", "zb_depth", S, tris, S, W, H, depth);
  rt.launch("raster", "zb_ids", S, tris, S, W, H, depth, pix);
  std::vector<uint32_t> local;
  std::vector<uint32_t>& out = ids ? *ids : local;
  out.resize(npix);
  rt.queue().enqueueReadBuffer(pix, CL_TRUE, 0, size_t(npix) * 4, out.data());
  rs.ms = ms_since(t0);
  for (const auto& [stage, t] : rt.collect_profile()) rs.kernels_ms += t.first;
  if (ids && S) {  // screen-triangle index -> input triangle index
    std::vector<VmScreenTri> host(S);
    rt.queue().enqueueReadBuffer(tris, CL_TRUE, 0, size_t(S) * sizeof(VmScreenTri), host.data());
    for (uint32_t& v : out)
      if (v != 0xffffffffu) v = host[v].src;
  }
  return rs;
}

void keep_freed_memory_for_reuse() {
#if defined(__GLIBC__)
  mallopt(M_MMAP_MAX, 0);
  mallopt(M_TRIM_THRESHOLD, 512 << 20);
#endif
}

Renderer::Renderer(const std::string& device) : impl_(std::make_unique<Impl>(device)) {}
Renderer::~Renderer() = default;

const DeviceInfo& Renderer::device() const { return impl_->rt.info(); }

RasterStats Renderer::raster_ids(const Scene& scene, const Camera& camera, std::vector<uint32_t>* ids) {
  try {
    return impl_->raster(scene, camera, ids);
  } catch (const cl::Error& e) {
    throw DeviceError(std::string("OpenCL error in ") + e.what() + " (" + std::to_string(e.err()) +
                      ") on " + impl_->rt.info().name);
  }
}

PlanarMap Renderer::render(const Scene& scene, const Camera& camera, const RenderOptions& opts,
                           RenderStats* stats, ScreenTriangles* screen) {
  RenderStats local;
  RenderStats& st = stats ? *stats : local;
  st = RenderStats{};
  auto t0 = Clock::now();
  try {
    PlanarMap map = impl_->run(scene, camera, opts, st, screen);
    st.pipeline_ms = ms_since(t0);
    return map;
  } catch (const cl::Error& e) {
    throw DeviceError(std::string("OpenCL error in ") + e.what() + " (" + std::to_string(e.err()) +
                      ") on " + impl_->rt.info().name);
  }
}

}  // namespace vismap
