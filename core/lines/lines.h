// Line drawings from the planar map (docs/LINES.md): the visible parts of occluding contours,
// mesh boundaries, creases, borders between meshes and the intersection lines of penetrating
// surfaces, each an edge of the map between two fragments (or a fragment and the background),
// chained into polylines.
//
// Every line is a chain of planar map edges, so it starts and ends at the map's own vertices:
// a contour that passes behind a surface stops exactly where the occluder's edge crosses it.
// Which kind an edge is follows from the two source triangles on its sides (ScreenTriangles,
// the pipeline's snapped input), the scene's meshes and the pipeline's crossing lines
// (docs/LINES.md "How an edge of the map is classified"):
//   - background on one side: the source's edge; boundary when no other triangle of the mesh
//     shares it (nor holds it at a T-junction), contour otherwise;
//   - both sides of one source triangle: no line;
//   - on an edge both sources share in their mesh (matched by position): contour when one faces
//     the eye and the other away, crease past the crease angle, else no line; border where the
//     edge stands on a third surface (in 3D);
//   - one side's edge lies on the other surface in 3D (a contact, the same from every view):
//     border between meshes; within one mesh a seam (as if the edge were shared) or, inside the
//     other's face, nothing where coplanar, else border;
//   - on a crossing line of the two the pipeline clipped with: intersection (a contact if an
//     edge of one lies on the other);
//   - otherwise one surface ends in front of the other: the nearer side's edge is a contour or
//     a boundary, unless the surface goes on across it into what shows beyond (no line);
//   - on no edge and no crossing: counted (LineSet::unplaced), not drawn.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "core/camera.h"
#include "core/planar_map.h"
#include "core/scene.h"

namespace vismap {

enum class LineKind : uint8_t { Contour, Boundary, Crease, Intersection, Border };
constexpr size_t kLineKinds = 5;
// "contour", "boundary", "crease", "intersection", "border": the SVG classes.
const char* line_kind_name(LineKind k);

struct LineOptions {
  // An edge between two triangles of a mesh is a crease when their normals differ by more than
  // this many degrees (the dihedral angle's supplement; Blender Freestyle's default crease angle
  // of 134.43 degrees between faces is 45.57 here).
  double crease_angle_deg = 45.0;
  // Douglas-Peucker tolerance in pixels for each chain (0: the map's edges as they are; the
  // chain's ends are always kept).
  double simplify_px = 0.0;
  // Selection (docs/LINES.md "Selection"), as Blender Freestyle's: chains of each kind shorter
  // than this many pixels are not drawn (visible and hidden chains, each by its own length).
  std::array<double, kLineKinds> min_length_px{};
  // Also the contours where what shows beyond is the contour's own surface within two rings (a
  // fold smaller than its triangles: on a scanned mesh, the tails of interior contours and
  // specks; docs/LINES.md "Selection").
  bool self_folds = false;
  // Selection: a crease also needs the two faces' smoothed normals (each the sum of its corners'
  // area-weighted vertex normals) to differ by more than half the crease angle: the zig-zags of
  // a noisy scan go, a CAD model's edges stay.
  bool crease_smooth = true;
  // Also the occluded parts of the mesh edge lines (contours, boundaries, creases: every mesh
  // edge of those kinds in the view volume, less its visible parts). Intersection lines have no
  // hidden part here (the pipeline finds crossings only where they can be seen).
  bool hidden = false;
};

// Polylines in pixels (y down). Chain c is the points [off[c], off[c+1]); a closed chain does
// not repeat its first point.
struct LineSet {
  std::vector<double> xy;
  std::vector<uint32_t> off{0};
  std::vector<LineKind> kind;
  std::vector<uint8_t> closed;
  std::vector<uint8_t> hidden;                      // 1: an occluded part (LineOptions::hidden)
  std::array<uint64_t, kLineKinds> edges{};         // map edges of each kind (before simplifying)
  std::array<uint64_t, kLineKinds> hidden_edges{};  // hidden segments of each kind
  // Map edges between two surfaces that no rule of docs/LINES.md places (on no edge of either
  // side and on no crossing line of theirs): drawn as nothing, counted to be found.
  uint64_t unplaced = 0;
  std::array<uint64_t, kLineKinds> short_chains{};  // chains dropped by min_length_px
  size_t chain_count() const { return kind.size(); }
};

// screen: the triangles the pipeline rendered `map` from (RenderOptions::keep_screen_triangles).
// Throws InputError when the map or the screen triangles do not refer to the scene's meshes.
LineSet extract_lines(const PlanarMap& map, const ScreenTriangles& screen, const Scene& scene,
                      const Camera& camera, const LineOptions& opts = {});

}  // namespace vismap
