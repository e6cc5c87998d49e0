// Polygon triangulation for the readers that meet faces of more than three corners (OBJ, OFF,
// PLY): k - 2 triangles per k-gon, in the face's place, so that the global triangle id rule (a
// k-gon counts as k - 2 triangles, in face order) holds whatever the shape.
//
// A convex polygon is fanned from its first corner, as the readers always did, so every output
// of a convex input stays byte-identical. Any other polygon (concave, or touching itself: a ring
// given as one face with a bridge edge walked both ways) is cut by ear clipping in its dominant
// plane (the largest component of its Newell normal), with exact orientation tests on the float
// coordinates. A polygon whose edges cross is not simple: no triangulation is right for it (what
// is inside depends on a fill rule the file does not state), so it keeps the fan, and the caller
// warns.
#pragma once

#include <cstddef>
#include <cstdint>

namespace vismap {

enum class PolygonShape : uint8_t {
  Convex,     // fanned (also a degenerate one: all corners on a line, or a zero normal)
  Concave,    // ear-clipped; simple, or only touching itself
  NotSimple,  // its edges cross: fanned; or no ear was left to cut: triangulated, some overlap
  TooLarge,   // more than kMaxEarClipCorners corners and not convex: fanned
};

// Past this many corners a polygon that is not convex is fanned (and the caller warns): ear
// clipping takes time quadratic in the corners, and a file must not buy minutes with one face.
inline constexpr size_t kMaxEarClipCorners = 4096;

// Writes polygon `corners`' k - 2 triangles (k >= 3) to out[0 ... 3(k - 2)), each as three
// indices into `positions` (xyz floats; every corner < vertex_count, checked by the caller).
PolygonShape triangulate_polygon(const float* positions, const uint32_t* corners, size_t k,
                                 uint32_t* out);

// Whether the three 2D points turn left (+1), right (-1) or lie on a line (0), exactly: each
// product of two float coordinates is exact in double, and their sum's sign is found exactly
// (an expansion of the six products). Exposed for the tests.
int orient2d_exact(const float a[2], const float b[2], const float c[2]);

}  // namespace vismap
