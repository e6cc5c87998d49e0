// Buckets (--memory-budget): the screen split into rectangles of whole pixels rendered one after
// another, each small enough for the budget. Host planning over the per-cell counts that
// transform.cl's clip_cells makes (stage transform); no kernel file of its own.
#pragma once

#include <cstdint>
#include <vector>

#include "core/render_stats.h"
#include "core/stages/transform.h"

namespace vismap::stages {

// Device bytes a bucket needs per screen triangle in it, all stages together (measured peak
// over screen triangles on the bench scenes, with margin; PERFORMANCE_LOG.md, "Memory budget").
constexpr uint64_t kBucketBytesPerTriangle = 1400;

// Splits the screen into rectangles whose estimated working memory fits in what the budget
// leaves after the scene and the per-frame buffers. Fills fr.boxes (each input triangle's box)
// and notes the depth exponents over the whole frame. Sets st.bucket_work_bytes.
std::vector<cl_int4> plan_buckets(ClRuntime& rt, const SceneBuffers& sb, Frame& fr, uint64_t budget,
                                  RenderStats& st);

// Halves a bucket along its longer side at a multiple of unit_px pixels from its low corner;
// false when neither side is two units long. The plan's estimate halves down to its 16-px cells;
// a bucket that a stage found over budget halves down to single pixels.
bool halve_bucket(const cl_int4& r, cl_int4& a, cl_int4& b, uint32_t unit_px);

}  // namespace vismap::stages
