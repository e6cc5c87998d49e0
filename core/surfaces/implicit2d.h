// MPR's 2D mode (issue 19 item 4, docs/IMPLICIT.md "2D"): an expression in x and y alone drawn
// as filled regions. The region queue (core/surfaces/implicit.h) finds the cells the boundary
// passes through at a cell size from the tolerance; marching squares on them, with every
// crossing computed from its edge's two corner values alone, gives closed loops; each
// connected component (an outer loop and its holes) becomes one region.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "core/implicit/implicit.h"

namespace vismap {
class ClRuntime;
}

namespace vismap::implicit {

// The window [x0, x1] x [y0, y1] of the expression's plane drawn on W x H pixels (y up in the
// expression, down on the screen; the window's aspect need not match, each axis scales alone).
struct View2D {
  double x0 = -1, y0 = -1, x1 = 1, y1 = 1;
  uint32_t width = 1024, height = 1024;
};

struct Regions2D {
  // Loops in pixels (y down), closed (last point != first); solid on the left walking in the
  // expression's plane, so outer loops and holes turn opposite ways.
  std::vector<std::vector<std::array<double, 2>>> loops;
  std::vector<std::vector<uint32_t>> regions;  // per connected component: outer loop, then holes
  double cell_px = 0;                          // the leaf cell's side in pixels
  uint64_t leaves = 0, full_cells = 0;
  std::vector<uint64_t> clauses_per_round;
  double queue_ms = 0, contour_ms = 0;
};

// Throws InputError BadScene when the expression uses z. The boundary drawn lies within
// tolerance_px of f = 0 (cell diagonal; docs/IMPLICIT.md "2D"). check_time (when given) runs
// after each round of the queue, each batch of corners and the host's contouring: it throws
// past the caller's time limit (issue 35, case 5). max_bytes caps the queue's buffers (0: none).
Regions2D contour_2d(ClRuntime& rt, const Tape& t, const View2D& view, double tolerance_px,
                     const std::function<void()>& check_time = {}, uint64_t max_bytes = 0);

// Filled SVG: one <path> per region (fill-rule nonzero), the window as its viewBox in pixels.
std::string write_svg_2d(const Regions2D& r, const View2D& view, const std::string& color = "#333");

bool uses_z(const Tape& t);

}  // namespace vismap::implicit
