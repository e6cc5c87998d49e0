// PDF, EPS and PNG through cairo: the same map as write_svg (the same paths, vertices rounded
// to 1/100 px, seam strokes and colours; core/write/paths.h) and the same lines, drawn in the
// same order. Like the other writers they return the file's bytes (cairo's stream surfaces),
// so the CLI writes them atomically.
#pragma once

#include <string>

#include "core/camera.h"
#include "core/planar_map.h"
#include "core/scene.h"
#include "core/write/output.h"

namespace vismap {

enum class CairoFormat { Pdf, Eps, Png };

// PDF and EPS: one page of map.width x map.height points (1 px = 1 pt), y down as in the SVG.
// PNG: map.width x map.height pixels, ARGB (transparent background, as the SVG's), antialiased;
// Fill::Id without antialiasing and without seam strokes, so each pixel is exactly the id
// colour of the fragment over its centre. Throws InputError (TooLarge) for a PNG wider or taller
// than cairo's 32767 pixels or an id over 24 bits, and BadScene for a non-positive line width.
std::string write_cairo(const PlanarMap& map, const Scene& scene, const Camera& camera, Fill fill,
                        const SvgStyle& style, CairoFormat format);

}  // namespace vismap
