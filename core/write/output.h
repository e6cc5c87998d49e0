// Writers: SVG and the binary triangle list (proto/FORMAT.md). Both write to a string; the CLI
// writes it to a temporary file and renames it, so a failed render leaves nothing half-written.
#pragma once

#include <string>

#include "core/camera.h"
#include "core/lines/lines.h"
#include "core/planar_map.h"
#include "core/scene.h"

namespace vismap {

enum class Fill { Shade, Id };

// SVG: viewBox in pixels; the fragments of one source triangle in one <path>. Shade fills with a
// Lambert shade of the source triangle's normal (headlight along the view) times the mesh color; Id fills
// with #RRGGBB = global source triangle id + 1 (Scene::triangle_id_base + face id) and
// shape-rendering="crispEdges".
std::string write_svg(const PlanarMap& map, const Scene& scene, const Camera& camera, Fill fill);

// What write_svg draws besides (or instead of) the filled fragments: lines from extract_lines
// (core/lines/lines.h), over the fills, one <g class="KIND"> per line kind ("contour", "boundary",
// "crease", "intersection", "border") inside <g class="lines">, one <path> per chain. Widths
// in device pixels (vector-effect: non-scaling-stroke).
struct SvgStyle {
  bool fill = true;                // the fragments, as write_svg(map, scene, camera, fill)
  // The fragments of one mesh with the same fill joined into one path per region (holes kept),
  // exactly (docs/LINES.md "Flat regions").
  bool merge = false;
  const LineSet* lines = nullptr;  // nullptr: no lines
  double line_width = 1.0;
  // #RRGGBB per LineKind: contour, boundary, crease, intersection, border.
  std::array<uint32_t, kLineKinds> line_color{0x000000, 0x000000, 0x404040, 0xb00000, 0x000000};
};
std::string write_svg(const PlanarMap& map, const Scene& scene, const Camera& camera, Fill fill,
                      const SvgStyle& style);

// How write_svg prints a coordinate: rounded to 1/100 pixel, trailing zeros and a leading "0"
// dropped ("12.5", ".25", "-.05", "3"). Equal doubles print equal text.
std::string svg_number(double v);

// Binary triangle list, little-endian, versioned (proto/FORMAT.md). Fragments are fanned into
// triangles; barycentrics and 1/w are included when the map has them.
std::string write_bin(const PlanarMap& map, const Scene& scene);
// The same with a line section (flags bit 1, proto/FORMAT.md "Lines") when lines is given;
// triangles = false leaves the triangles out (T = 0: a line drawing only).
std::string write_bin(const PlanarMap& map, const Scene& scene, const LineSet* lines,
                      bool triangles);

// Reader for the binary format (tests, clients). Throws InputError on malformed bytes.
struct BinFrame {
  uint32_t version = 0, width = 0, height = 0, flags = 0;
  std::vector<float> xy;                    // 6 per triangle
  std::vector<uint32_t> mesh, triangle_id;  // per triangle: mesh index, global source triangle id
  std::vector<float> bary;                  // 9 per triangle when flags & 1
  std::vector<float> inv_w;                 // 3 per triangle when flags & 1
  bool has_lines = false;                   // flags & 2: the line section
  LineSet lines;                            // its chains (points as float32 read back)
  size_t triangle_count() const { return mesh.size(); }
};
BinFrame read_bin(const std::string& bytes);

}  // namespace vismap
