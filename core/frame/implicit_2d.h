// The 2D implicit frame (MPR's 2D mode, docs/IMPLICIT.md): an expression in x and y drawn as
// filled SVG regions, under the same limits as a frame of a scene (frame.h): one time limit
// counted from `started` (the default: now) and one memory budget for the region queue.
#pragma once

#include <cstdint>
#include <string>

#include "core/implicit/implicit.h"
#include "core/pipeline.h"
#include "core/surfaces/implicit2d.h"
#include "core/util/clock.h"

namespace vismap::frame {

struct Frame2D {
  implicit::Regions2D regions;
  std::string svg;
  double svg_ms = 0;  // writing the SVG
};

Frame2D run_frame_2d(Renderer& renderer, const implicit::Tape& tape, const implicit::View2D& view,
                     double tolerance_px, double time_limit_s = 0, uint64_t memory_budget = 0,
                     Clock::time_point started = {});

}  // namespace vismap::frame
