#include "core/stages/buckets.h"

#include <algorithm>

#include "core/error.h"
#include "core/stages/budget.h"
#include "core/stages/grid.h"

namespace vismap::stages {

// One pass counts, per cell of a coarse grid, the screen triangles whose box touches it (an
// upper bound for any rectangle of cells), then rectangles are halved at their count median,
// longer side first, until each fits or is one cell. Also fills `boxes` (each input triangle's
// box in pixels) so that buckets skip the triangles that cannot reach them without clipping
// them again.
std::vector<cl_int4> plan_buckets(ClRuntime& rt, const SceneBuffers& sb, Frame& fr, uint64_t budget,
                                  RenderStats& st) {
  const uint32_t W = fr.W, H = fr.H;
  const uint32_t cell_px = std::max<uint32_t>(16, next_pow2((std::max(W, H) + 63) / 64));
  const VmGrid cells = make_grid(cell_px, W, H);
  const uint32_t cx = uint32_t(cells.tiles_x), cy = uint32_t(cells.tiles_y);

  fr.boxes = rt.alloc(size_t(sb.ntri) * sizeof(cl_ushort4), "triangle boxes");
  fr.use_boxes = 1;
  std::vector<uint32_t> hist(size_t(cx) * cy);
  {
    cl::Buffer h = rt.alloc(hist.size() * 4, "bucket cell counts");
    rt.fill_u32(h, 0, hist.size(), Stage::Transform);
    rt.launch(Stage::Transform, "clip_cells", sb.ntri, sb.idx, sb.ntri, fr.clip, sb.tri_mesh,
              sb.tri_local, fr.mesh_cull, W, H, fr.ortho, fr.full, cells, h, fr.boxes, fr.depth_ex);
    fr.depth_ex_done = true;
    rt.read(Stage::Transform, h, 0, hist.size() * 4, hist.data());
  }
  // What every bucket holds besides its own work: the scene, the clip-space vertices, the
  // per-input-triangle counts, offsets and boxes (all allocated by now).
  // Counted from the sizes, not from what the runtime reports held: releases of an earlier
  // render's buffers may still be on their way, and the plan must not depend on timing.
  // An eighth of the budget is left for what the allocator holds beyond the live buffers
  // (rounding to huge pages, freed blocks kept for reuse).
  // The scene's facts are not counted (issue 45, item 9: with --scene-facts their bytes made 3
  // buckets where there were 2, and so other bytes for the same picture): the plan, and every
  // decision that follows from it, must be the same with and without them. They are held only
  // where they fit in half of that eighth (Renderer::Impl::take_facts); nothing else a frame
  // allocates depends on them (the same crossing pairs are found either way, and the apart
  // flags are allocated either way: snap_depths).
  const uint64_t facts = sb.facts ? sb.facts->bytes() : 0;
  const uint64_t held = sb.bytes - facts + rt.allocated_bytes(), fixed = held + budget / 8;
  if (budget <= fixed + (held >> 3))
    throw InputError(InputErrorKind::TooLarge, "", "", "", -1,
                     "memory budget of " + mib(budget) + " is too small: the scene alone holds " +
                         mib(held) + " of device memory");
  const uint64_t work = budget - fixed;
  st.bucket_work_bytes = work;

  // Summed-area table over the cells.
  std::vector<uint64_t> sat((cx + 1) * size_t(cy + 1), 0);
  for (uint32_t y = 0; y < cy; ++y)
    for (uint32_t x = 0; x < cx; ++x)
      sat[(y + 1) * size_t(cx + 1) + x + 1] =
          hist[y * size_t(cx) + x] + sat[y * size_t(cx + 1) + x + 1] +
          sat[(y + 1) * size_t(cx + 1) + x] - sat[y * size_t(cx + 1) + x];
  auto sum = [&](uint32_t x0, uint32_t y0, uint32_t x1, uint32_t y1) {
    return sat[y1 * size_t(cx + 1) + x1] - sat[y0 * size_t(cx + 1) + x1] -
           sat[y1 * size_t(cx + 1) + x0] + sat[y0 * size_t(cx + 1) + x0];
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

bool halve_bucket(const cl_int4& r, cl_int4& a, cl_int4& b, uint32_t unit_px) {
  const int unit = int(unit_px) * VM_GRID_SCALE, w = r.s[2] - r.s[0], h = r.s[3] - r.s[1];
  const bool cut_x = w >= 2 * unit && (w >= h || h < 2 * unit);
  if (!cut_x && h < 2 * unit) return false;
  a = b = r;
  const int at = cut_x ? r.s[0] + (w / 2 / unit) * unit : r.s[1] + (h / 2 / unit) * unit;
  a.s[cut_x ? 2 : 3] = at;
  b.s[cut_x ? 0 : 1] = at;
  return true;
}

}  // namespace vismap::stages
