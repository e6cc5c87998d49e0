// Exact checks of a planar map against the screen triangles it was made from (DESIGN §4):
// overlap, coverage, source containment, a pixel comparison with a z-buffer, and the exact
// reference visibility. Used by the tests and by `vismap check`. What each figure means, how
// exactly it is computed and what it costs: docs/CHECKS.md.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/planar_map.h"

namespace vismap::check {

struct CheckOptions {
  bool use_exact = true;  // use hx/hy/hw when the map has them (else the rounded doubles)
  bool overlap = true;    // overlap_area / overlap_pairs
  bool coverage = true;   // union_area / coverage_error (CGAL union: the slowest part)
  bool outside = true;    // outside_source / outside_area
};

// Areas are in square pixels.
struct CheckReport {
  bool exact = false;  // vertices taken from hx/hy/hw (else from the doubles)
  size_t fragments = 0, screen_triangles = 0;

  size_t degenerate = 0;  // fragments with exact area <= 0 (left out of the rest)
  size_t nonconvex = 0;   // positive area but not convex (reflex vertex or winds >1)

  double output_area = 0;     // sum of fragment areas
  double union_area = 0;      // area of the union of the screen triangles
  double coverage_error = 0;  // |output_area - union_area| / union_area

  size_t candidate_pairs = 0;  // fragment pairs whose bounding boxes overlap
  size_t overlap_pairs = 0;    // pairs whose interiors intersect (must be 0)
  double overlap_area = 0;     // sum of the areas of those intersections (must be 0)

  size_t outside_source = 0;  // fragments not inside their source's screen triangles
  size_t unknown_source = 0;  // ... of which the source is not among the screen triangles
  double outside_area = 0;    // total fragment area outside the source

  double ms_total = 0, ms_overlap = 0, ms_union = 0, ms_outside = 0;

  bool ok(double coverage_tolerance = 1e-12) const;  // every must-be-zero figure is zero
  std::string summary() const;                       // multi-line, human readable
};

CheckReport check_planar_map(const PlanarMap& map, const ScreenTriangles& screen,
                             const CheckOptions& options = {});

// Z-buffer id raster of the screen triangles against the map's source ids, at n x n sample
// centres over the map's viewport. "Interior" samples are farther than 1.5 sample spacings from
// every edge of every screen triangle and every fragment.
struct PixelReport {
  uint32_t n = 0;
  uint64_t samples = 0;         // interior samples
  uint64_t mismatched = 0;      // interior samples whose ids differ
  double fraction = 0;          // mismatched / samples
  uint64_t all_samples = 0;     // n * n
  uint64_t all_mismatched = 0;  // mismatches, edge samples included
  double all_fraction = 0;
  double ms = 0;
};

PixelReport pixel_compare(const PlanarMap& map, const ScreenTriangles& screen, uint32_t n);

// Exact visible region of every screen triangle (DESIGN §4), held as CGAL polygon sets.
struct ReferenceResult {
  struct Impl;
  std::shared_ptr<const Impl> impl;
  std::vector<double> visible_area;  // per screen triangle, square pixels (rounded from exact)
  double total_visible_area = 0;     // square pixels
  // Widest snap band of a crossing pair, pixels: how far (in the axis across the line) the
  // pipeline's rounded crossing line may lie from the exact one (reference.cpp snap_band()).
  double snap_band = 0;
  // Crossing pairs (depth planes that cross inside their overlap), and those of them whose line
  // the pipeline rounds (a depth plane not snapped to integers, ScreenTriangles::plane_k): only
  // these have a snap band; the others' lines are exact.
  size_t crossing_pairs = 0, rounded_crossing_pairs = 0;
  // Square pixels covered by the triangles but visible in none: where the tie rule's pairwise
  // order is cyclic and the definition has no answer (reference.cpp, docs/NUMERICS.md §3).
  double tie_cycle_area = 0;
  double ms = 0;
};

ReferenceResult exact_visibility(const ScreenTriangles& screen);

struct ReferenceReport {
  double area_error = 0;  // sum over sources of area(output xor visible) / total visible
  double xor_area = 0;    // the numerator, square pixels
  double total_visible_area = 0;
  size_t fragments = 0;
  size_t wrong_source = 0;    // fragments with more than half their area outside visible(src)
  size_t partly_outside = 0;  // fragments with any area outside visible(src) beyond
                              // 1e-9 of their own area (exact maps: any area at all)
  // What the snapped crossing lines cannot explain: the above outside every snap band (the
  // part of each crossing pair's overlap within its rounding bound of the exact line). Both
  // are 0 for a right map, with or without crossing lines.
  double area_error_outside_band = 0;  // area(output xor visible, minus the bands) / visible
  size_t wrong_outside_band = 0;       // fragments with any area outside visible(src) and bands
  double snap_band = 0;                // ReferenceResult::snap_band, pixels
  bool exact = false;
  double ms = 0;
};

ReferenceReport compare_with_reference(const PlanarMap& map, const ScreenTriangles& screen,
                                       const ReferenceResult& reference);

}  // namespace vismap::check
