// One scene, one camera: run the pipeline and every check on its output, and gather the figures
// (`vismap check`, the stiff/random/real-mesh tests and bench/error_vs_time all use this).
// What each figure means: docs/CHECKS.md; the tolerances and why: docs/NUMERICS.md.
#pragma once

#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "core/camera.h"
#include "core/pipeline.h"
#include "core/planar_map.h"
#include "core/scene.h"

namespace vismap::check {

struct SceneCheckOptions {
  bool reference = true;       // exact reference (CGAL); off for scenes too big for it
  bool invariants = true;      // check_planar_map (overlap, coverage, outside source)
  uint32_t pixels = 1024;      // pixel_compare raster size; 0: no pixel comparison
  uint32_t tile_pixels = 0;    // RenderOptions::tile_pixels
  uint64_t memory_budget = 0;  // RenderOptions::memory_budget
  // Render again with RenderOptions::cull off and compare the maps exactly (map_diff.h): what the
  // cull left out must change no source's visible region.
  bool cull_compare = true;
};

// Figures of one run. std::nullopt: not computed (skipped by the options).
struct SceneFigures {
  size_t input_triangles = 0, screen_triangles = 0, fragments = 0, thin_fragments = 0,
         sliver_fragments = 0;
  size_t deep_tournaments = 0;  // fragments decided by occlude_deep (> VM_TOUR_MAX competitors)
  size_t crossing_lines = 0;    // clipping lines from penetrating pairs (snapped)
  double pipeline_ms = 0;       // Renderer::render wall time
  std::optional<double> area_error, xor_area, visible_area;  // vs the exact reference
  std::optional<size_t> wrong_source, partly_outside;
  // The same outside the crossing pairs' snap bands (ReferenceReport): exact with or without
  // crossing lines. snap_band: the widest band, pixels.
  std::optional<double> area_error_outside_band, snap_band;
  std::optional<size_t> wrong_outside_band;
  // Crossing pairs in the reference, and those with a rounded line (a depth plane that could not
  // be snapped to integers): only these can leave snap-band cells. free_planes: screen triangles
  // whose depth plane was not snapped (ScreenTriangles::plane_k).
  std::optional<size_t> crossing_pairs, rounded_crossing_pairs;
  // Covered but visible in no triangle in the reference (a cyclic tie-rule order), relative to
  // the visible area: left out of wrong_source and the outside-band figures.
  std::optional<double> tie_cycle_area;
  size_t free_planes = 0;
  // The cull (issue 32): screen triangles it left out, fragments the clip rounds dropped, and
  // against the frame without it (cull_compare) the sources whose visible region differs (must
  // be 0) and their xor area relative to the visible area.
  size_t culled_triangles = 0, dropped_fragments = 0;
  std::optional<size_t> cull_differing;
  std::optional<double> cull_xor_area;
  std::optional<double> reference_ms;  // exact_visibility + compare_with_reference
  std::optional<double> overlap_area, coverage_error, outside_area;
  std::optional<size_t> overlap_pairs, outside_source, degenerate, nonconvex;
  std::optional<double> invariants_ms;
  std::optional<double> pixel_error, pixel_error_all;  // interior samples; all samples
  std::optional<double> pixel_ms;
  uint32_t pixels = 0;
  // Bound on the area moved by snapping, relative to the visible area: sum over screen triangles
  // of perimeter * sqrt(2)/2 grid units (each vertex moves at most half a grid unit per axis).
  double snap_area_bound = 0;
};

// Tolerances of `vismap check` (docs/NUMERICS.md derives them). Against the snapped screen
// triangles the map is exact unless penetrating pairs were clipped along snapped crossing lines:
// then area_error may reach the snap level (snap_area_bound) and wrong_source counts snap-sized
// fragments on the wrong side of a crossing line (their area is in area_error), but outside the
// crossing pairs' snap bands the map is still exact (area_error_outside_band, wrong_outside_band).
struct Tolerances {
  double exact = 1e-12;      // coverage_error always, area_error without crossing lines
                             // (rounding of the final quotient and the 2^-96 fixed-point sums)
  double snap_factor = 1.0;  // with crossing lines: <= snap_factor * snap_area_bound
  double overlap_area = 0;
  size_t wrong_source = 0;    // without crossing lines; wrong_outside_band always
  double pixel_error = 1e-3;  // interior samples
  size_t outside_source = 0;
  bool strict = false;  // `--strict`: no snap-level allowance for crossing lines either
};

// The figures over tolerance, as "name value > tolerance" strings; empty when all pass.
std::vector<std::string> over_tolerance(const SceneFigures& f, const Tolerances& t = {});

nlohmann::ordered_json to_json(const SceneFigures& f);

SceneFigures check_scene(Renderer& renderer, const Scene& scene, const Camera& camera,
                         const SceneCheckOptions& options = {}, PlanarMap* map_out = nullptr,
                         ScreenTriangles* screen_out = nullptr);

// The same scene with the mesh order and the triangle order within every mesh reversed, and the
// map from the reversed ids back to the original ones.
struct ReversedScene {
  Scene scene;
  // original (mesh, triangle) of reversed (mesh, triangle)
  std::pair<uint32_t, uint32_t> original(uint32_t mesh, uint32_t tri) const;
  std::vector<uint32_t> mesh_of, tri_count;
};
ReversedScene reverse_order(const Scene& scene);

// A map as a sorted list of fragments in canonical form (source ids, then the rounded vertices
// starting at the smallest), to compare maps up to fragment order. `rename` maps source ids.
using CanonicalFragment = std::vector<double>;
std::vector<CanonicalFragment> canonical_fragments(const PlanarMap& map,
                                                   const ReversedScene* rename = nullptr);

}  // namespace vismap::check
