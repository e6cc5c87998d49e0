// `vismap check --lines`: a line drawing measured against a supersampled id raster of the same
// view (docs/LINES.md "Checks").
//
// The reference: Renderer::raster_ids at `factor` times the resolution (factor x factor samples
// per pixel). Between two neighbouring samples (right or below) whose triangles belong to
// different surfaces, a line is expected at the point halfway: "different" means background on
// one side, another mesh, or triangles of one mesh more than two rings apart (no vertex of one
// at or next to a vertex of the other; vertices matched by position). Creases lie between
// neighbouring triangles, so neither fraction looks at them, nor at hidden parts.
//   - recall: of those reference points, the fraction with a drawn contour, boundary,
//     intersection or border line within `radius` pixels;
//   - precision: of the drawn length of those kinds, the fraction within `radius` of a
//     reference point.
#pragma once

#include <cstdint>
#include <vector>

#include "core/lines/lines.h"
#include "core/scene.h"

namespace vismap {

struct LineCheck {
  uint32_t factor = 4;  // samples per pixel along each axis
  double radius = 1.5;  // pixels
  uint64_t reference_points = 0;
  uint64_t reference_near_line = 0;  // of those, with a drawn line within `radius`
  double line_px = 0;                // drawn length of the kinds looked at
  double line_near_reference = 0;    // of it, within `radius` of a reference point
  double recall() const {
    return reference_points ? double(reference_near_line) / reference_points : 1;
  }
  double precision() const { return line_px > 0 ? line_near_reference / line_px : 1; }
};

// Per pixel of the drawing (row-major, width x height), what check_lines saw: bit 0 a reference
// point in the pixel, bit 1 one of them with no line near (missed), bit 2 a drawn line through
// the pixel, bit 3 a drawn line there with no reference point near (unsupported).
enum LineCheckPixel : uint8_t {
  kRefPoint = 1,
  kRefMissed = 2,
  kDrawn = 4,
  kDrawnUnsupported = 8,
};

// ids: the id raster at factor x the drawing's width and height (Renderer::raster_ids of the
// camera with width and height multiplied by factor: the same view). Throws InputError when the
// raster's size does not match or it names a triangle past the scene's.
LineCheck check_lines(const LineSet& lines, const std::vector<uint32_t>& ids, uint32_t width,
                      uint32_t height, uint32_t factor, const Scene& scene, double radius = 1.5,
                      std::vector<uint8_t>* image = nullptr);

}  // namespace vismap
