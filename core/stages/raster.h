// The z-buffer id raster (kernels/raster.cl): the same transform as a frame, then one sample per
// pixel centre, two passes (nearest depth, then its id). The floor a frame is measured against
// (vismap_bench) and the pixel comparison of `vismap check`; not exact.
#pragma once

#include <cstdint>
#include <vector>

#include "core/camera.h"
#include "core/device/cl_runtime.h"
#include "core/render_stats.h"
#include "core/stages/transform.h"

namespace vismap::stages {

// ids (when given): W x H row-major, y down, the global input triangle index or 0xffffffff.
RasterStats raster_ids(ClRuntime& rt, const SceneBuffers& sb, const Scene& scene, const Camera& cam,
                       std::vector<uint32_t>* ids);

}  // namespace vismap::stages
