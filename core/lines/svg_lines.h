// Reading a line drawing back from SVG (`vismap check --lines --lines-from DRAWING.svg`), so that
// other tools' drawings (Blender Freestyle's SVG exporter, OpenCASCADE's HLR through
// bench/lines/occt_hlr.cpp) are scored by the same check_lines as ours (docs/LINES.md, "Against
// other tools").
//
// What is read: <path> with the commands M m L l H h V v Z z (any other command is an error),
// <polyline>, <polygon>, <line>; `transform` on <svg>, <g> and the shapes (matrix, translate,
// scale, rotate; skewX/skewY are refused). Ignored: <title>, <desc>, <metadata>, <style>,
// <defs> and their content, comments, processing instructions, namespaced elements
// (sodipodi:, inkscape:). Any other element (rect, circle, text, use, ...) is an error naming
// the file, the element and its index in the file.
//
// Kinds: the nearest enclosing element whose class or id is a kind's name ("contour",
// "crease", ...; core/lines/lines.h), or ends in "_" and one (Freestyle names a lineset's group
// LAYER_LINESET), sets it, else Contour. Whatever is inside class="hidden" (our own
// --hidden output) is left out: the check scores the visible drawing.
#pragma once

#include <cstdint>
#include <string>

#include "core/lines/lines.h"

namespace vismap {

// Parses `text` (named `file` in errors). The root <svg>'s viewBox (or, without one, its
// width/height) must be 0 0 width height: otherwise InputError(BadScene) saying both sizes.
// Points come out in pixels of that frame (y down). Throws InputError(ParseError) on what it
// does not read.
LineSet read_svg_lines(const std::string& text, const std::string& file, uint32_t width,
                       uint32_t height);
// The same from a file (InputError FileNotFound when it cannot be read).
LineSet read_svg_lines_file(const std::string& path, uint32_t width, uint32_t height);

}  // namespace vismap
