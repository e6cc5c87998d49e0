// The planar map as one conforming triangle mesh on a fixed-point grid: the step the compact
// and delta encodings share (proto/COMPACT.md, "From the planar map to the mesh").
//
// The planar map's fragments meet with T-junctions: a fragment's vertex may lie inside a
// neighbour's edge (an occluder's silhouette edge is one edge on its side and many on the
// occluded side). Exact coordinates keep such a vertex on the edge; rounded to a grid it leaves
// it, and a hairline crack opens. So the vertex is first inserted into the neighbour's edge,
// then every vertex is rounded to the grid once (vertices that round to the same grid point
// become one), then each fragment is triangulated through all its boundary vertices. The mesh
// is then conforming on the grid: every interior edge is shared by exactly two triangles, so
// no rasterization rule that is consistent along shared edges leaves a gap. Triangles the
// rounding made degenerate or inverted are dropped: for a conforming mesh whose outline is the
// rounded outline, every point inside is still covered (the covering's degree is one).
#pragma once

#include <cstdint>
#include <vector>

#include "core/planar_map.h"

namespace vismap {

// A vertex lies on an edge when it is within this distance (pixels) of the edge's line, strictly
// between its ends. The planar map's vertices are exact points rounded once to a 2^-20 grid-unit
// lattice (core/stages/map_build.h), so a vertex that is exactly on an edge is within ~1e-9 px of
// it. (The compact and delta coders decide on-edge alike.)
inline constexpr double kOnEdge = 1e-6;

struct GridMesh {
  uint32_t quantum = 0;            // grid steps per pixel
  std::vector<int32_t> xy;         // 2 per vertex, grid steps, y down
  std::vector<uint32_t> tri;       // 3 per triangle, positive orientation (clockwise on screen)
  std::vector<uint32_t> fragment;  // per triangle: the planar map fragment it came from
  uint64_t t_junctions = 0;        // vertices inserted into a neighbour's edge
  uint64_t dropped = 0;            // triangles dropped: degenerate or inverted on the grid
  size_t triangle_count() const { return fragment.size(); }
  size_t vertex_count() const { return xy.size() / 2; }
};

// The fragments as polygons over shared vertices, before rounding: exactly equal vertices merged,
// T-junctions inserted into the edges they lie on. Orientation as the map's (positive).
struct ConformedPolygons {
  std::vector<double> xy;           // 2 per vertex, pixels
  std::vector<uint32_t> off{0}, v;  // polygon p is v[off[p] .. off[p+1])
  std::vector<uint32_t> fragment;   // per polygon: its planar map fragment
  std::vector<uint32_t> original;   // per polygon: its corners before T-junctions were inserted
  uint64_t t_junctions = 0;
  size_t size() const { return fragment.size(); }
};

// quantum: 1 ... 256 grid steps per pixel; the map's coordinates must be finite and within the
// grid's 2^23 steps (checked here). insert_t_junctions = false only for the test that shows the
// cracks it prevents.
ConformedPolygons conform_polygons(const PlanarMap& map, uint32_t quantum,
                                   bool insert_t_junctions = true);
// Merges the polygons' vertices that lie within eps pixels of each other (and drops what
// collapses). Two exact points of the map can be that close without being equal: a crossing
// line of one mesh's two neighbouring triangles with another surface meets their shared edge at
// two points ~1e-7 px apart, each triangle's depth plane snapped on its own; their edges would
// otherwise find no twin (core/lines/lines.cpp, the SVG writer's --merge).
void weld_vertices(ConformedPolygons& polygons, double eps);
// Rounds the polygons' vertices to the grid and triangulates them through every vertex.
GridMesh triangulate_on_grid(const ConformedPolygons& polygons, uint32_t quantum);
// Both steps.
GridMesh conform_to_grid(const PlanarMap& map, uint32_t quantum, bool insert_t_junctions = true);

// Twice the signed area of (a, b, c) on the grid, exact.
inline int64_t orient2(const int32_t* a, const int32_t* b, const int32_t* c) {
  return (int64_t(b[0]) - a[0]) * (int64_t(c[1]) - a[1]) -
         (int64_t(b[1]) - a[1]) * (int64_t(c[0]) - a[0]);
}

}  // namespace vismap
