#include "core/frame/implicit_2d.h"

namespace vismap::frame {

Frame2D run_frame_2d(Renderer& renderer, const implicit::Tape& tape, const implicit::View2D& view,
                     double tolerance_px, double time_limit_s, uint64_t memory_budget,
                     Clock::time_point started) {
  Frame2D f;
  f.regions = renderer.implicit_2d(tape, view, tolerance_px, time_limit_s, memory_budget, started);
  const Clock::time_point t0 = Clock::now();
  f.svg = implicit::write_svg_2d(f.regions, view);
  f.svg_ms = ms_since(t0);
  return f;
}

}  // namespace vismap::frame
