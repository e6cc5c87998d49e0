// `vismap check --lines`: a line drawing (ours, or another tool's read from SVG) scored against
// the z-buffer id raster of the same view at 4 x 4 samples a pixel (core/lines/line_check.h):
// recall and precision, and optionally a picture of where they agree.
#pragma once

#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "core/camera.h"
#include "core/lines/lines.h"
#include "core/pipeline.h"
#include "core/scene.h"

namespace vismap::check {

struct LineFigureOptions {
  LineOptions lines;          // the drawing's rules (ours)
  std::string from_svg;       // score this SVG drawing instead of ours (--lines-from)
  uint64_t memory_budget = 0;  // our render's
  bool image = false;         // make the PPM picture (--lines-image)
};

struct LineFigures {
  nlohmann::ordered_json json;
  // A PPM of where the drawing and the raster agree, one colour per pixel. Red: a reference
  // point with no line near (missed); magenta: a drawn line with no reference point near
  // (unsupported); black: a drawn line with one; light green: reference points, all near a
  // line; white: nothing.
  std::string ppm;
};

LineFigures check_line_drawing(Renderer& renderer, const Scene& scene, const Camera& cam,
                               const LineFigureOptions& o);

}  // namespace vismap::check
