#include "core/check/scene_check.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>

#include "core/check/map_diff.h"
#include "core/check/planar_check.h"
#include "core/facts/scene_facts.h"
#include "core/util/clock.h"

namespace vismap::check {

SceneFigures check_scene(Renderer& renderer, const Scene& scene, const Camera& camera,
                         const SceneCheckOptions& o, PlanarMap* map_out,
                         ScreenTriangles* screen_out) {
  SceneFigures f;
  RenderOptions ro;
  ro.exact = true;
  ro.keep_screen_triangles = true;
  ro.tile_pixels = o.tile_pixels;
  ro.memory_budget = o.memory_budget;
  // The scene's facts at once (a single frame would not find them): the culled frame below is
  // then also the one whose crossing search skips pairs far apart in 3D, and cull_differing
  // compares it with the frame that does neither.
  if (facts::scene_facts_fit(scene.triangle_count(), o.memory_budget))
    ro.scene_facts = std::make_shared<const facts::SceneFacts>(facts::find_scene_facts(scene));
  ro.min_apart_fraction = 0;  // (wherever they apply, not only where they pay)
  RenderStats st;
  ScreenTriangles screen;
  PlanarMap map = renderer.render(scene, camera, ro, &st, &screen);
  f.pipeline_ms = st.pipeline_ms;
  f.input_triangles = st.input_triangles;
  f.screen_triangles = screen.size();
  f.fragments = map.fragment_count();
  f.thin_fragments = st.thin_fragments;
  f.sliver_fragments = st.sliver_fragments;
  f.deep_tournaments = st.deep_tournaments;
  f.crossing_lines = st.crossing_lines;
  f.free_planes =
      size_t(std::count(screen.plane_k.begin(), screen.plane_k.end(), ScreenTriangles::kFreePlane));
  f.culled_triangles = st.culled_triangles;
  f.dropped_fragments = st.dropped_fragments;
  if (o.cull_compare) {
    RenderOptions off = ro;
    off.cull = false;
    off.keep_screen_triangles = false;
    const MapDiff d = compare_maps(map, renderer.render(scene, camera, off));
    f.cull_differing = d.differing;
    f.cull_xor_area = d.visible_area > 0 ? d.xor_area / d.visible_area : d.xor_area;
  }

  double perimeter = 0;  // grid units
  for (size_t t = 0; t < screen.size(); ++t)
    for (int k = 0; k < 3; ++k) {
      const int32_t* a = &screen.xy[6 * t + 2 * k];
      const int32_t* b = &screen.xy[6 * t + 2 * ((k + 1) % 3)];
      perimeter += std::hypot(double(b[0] - a[0]), double(b[1] - a[1]));
    }

  if (o.invariants) {
    CheckReport r = check_planar_map(map, screen);
    f.overlap_area = r.overlap_area;
    f.overlap_pairs = r.overlap_pairs;
    f.coverage_error = screen.size() ? r.coverage_error : 0.0;
    f.outside_source = r.outside_source;
    f.outside_area = r.outside_area;
    f.degenerate = r.degenerate;
    f.nonconvex = r.nonconvex;
    f.invariants_ms = r.ms_total;
  }
  if (o.reference) {
    auto t0 = Clock::now();
    ReferenceResult ref = exact_visibility(screen);
    ReferenceReport cmp = compare_with_reference(map, screen, ref);
    f.reference_ms = ms_since(t0);
    f.area_error = ref.total_visible_area > 0 ? cmp.area_error : 0.0;
    f.xor_area = cmp.xor_area;
    f.visible_area = ref.total_visible_area;
    f.wrong_source = cmp.wrong_source;
    f.partly_outside = cmp.partly_outside;
    f.area_error_outside_band = cmp.area_error_outside_band;
    f.wrong_outside_band = cmp.wrong_outside_band;
    f.snap_band = cmp.snap_band;
    f.crossing_pairs = ref.crossing_pairs;
    f.rounded_crossing_pairs = ref.rounded_crossing_pairs;
    f.tie_cycle_area =
        ref.total_visible_area > 0 ? ref.tie_cycle_area / ref.total_visible_area : 0.0;
  }
  if (o.pixels) {
    PixelReport px = pixel_compare(map, screen, o.pixels);
    f.pixels = o.pixels;
    f.pixel_error = px.fraction;
    f.pixel_error_all = px.all_fraction;
    f.pixel_ms = px.ms;
  }
  const double gs = screen.grid_scale ? screen.grid_scale : 1;
  double visible = f.visible_area.value_or(0);
  if (visible <= 0) {  // no reference: the union of the triangles bounds the visible area
    for (size_t f2 = 0; f2 < map.fragment_count(); ++f2) visible += map.fragment_area(f2);
  }
  f.snap_area_bound = visible > 0 ? perimeter * (std::sqrt(2.0) / 2) / (gs * gs) / visible : 0;
  if (map_out) *map_out = std::move(map);
  if (screen_out) *screen_out = std::move(screen);
  return f;
}

static std::string fmt(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%.3g", v);
  return b;
}

std::vector<std::string> over_tolerance(const SceneFigures& f, const Tolerances& t) {
  std::vector<std::string> bad;
  auto chk = [&](const char* name, auto value, auto tol) {
    if (value && *value > tol)
      bad.push_back(std::string(name) + " " + fmt(double(*value)) + " > " + fmt(double(tol)));
  };
  // Only rounded crossing lines (a depth plane not snapped to integers) leave snap-level error;
  // without the reference, every crossing line is assumed to be one.
  const bool crossing =
      (f.rounded_crossing_pairs ? *f.rounded_crossing_pairs > 0 : f.crossing_lines > 0) &&
      !t.strict;
  // Tie cycles (covered, no answer in the reference) count in area_error; they are allowed
  // for, unless --strict.
  const double cycles = t.strict ? 0.0 : f.tie_cycle_area.value_or(0.0);
  const double area_tol =
      crossing ? std::max(t.exact, t.snap_factor * f.snap_area_bound) : t.exact + cycles;
  chk("area_error", f.area_error, area_tol);
  chk("overlap_area", f.overlap_area, t.overlap_area);
  if (!crossing) chk("wrong_source", f.wrong_source, t.wrong_source);
  // Outside the snap bands nothing is left to snapping: exact in every mode.
  chk("area_error_outside_band", f.area_error_outside_band, t.exact);
  chk("wrong_outside_band", f.wrong_outside_band, t.wrong_source);
  chk("pixel_error", f.pixel_error, t.pixel_error);
  // Snapping crossing lines moves area between triangles, never out of the union: holes are
  // held to the exact tolerance with or without crossing lines (docs/NUMERICS.md §2).
  chk("coverage_error", f.coverage_error, t.exact);
  chk("outside_source", f.outside_source, t.outside_source);
  // What the cull leaves out changes no visible point: exactly the same regions (issue 32).
  chk("cull_differing", f.cull_differing, size_t(0));
  return bad;
}

nlohmann::ordered_json to_json(const SceneFigures& f) {
  nlohmann::ordered_json j;
  auto put = [&](const char* k, const auto& v) {
    if (v)
      j[k] = *v;
    else
      j[k] = nullptr;
  };
  put("area_error", f.area_error);
  put("overlap_area", f.overlap_area);
  put("wrong_source", f.wrong_source);
  put("pixel_error", f.pixel_error);
  j["pipeline_ms"] = f.pipeline_ms;
  put("reference_ms", f.reference_ms);
  put("coverage_error", f.coverage_error);
  put("outside_source", f.outside_source);
  put("outside_area", f.outside_area);
  put("overlap_pairs", f.overlap_pairs);
  put("degenerate", f.degenerate);
  put("nonconvex", f.nonconvex);
  put("partly_outside", f.partly_outside);
  put("area_error_outside_band", f.area_error_outside_band);
  put("wrong_outside_band", f.wrong_outside_band);
  put("snap_band", f.snap_band);
  put("xor_area", f.xor_area);
  put("visible_area", f.visible_area);
  put("pixel_error_all", f.pixel_error_all);
  j["pixels"] = f.pixels;
  put("invariants_ms", f.invariants_ms);
  put("pixel_ms", f.pixel_ms);
  j["snap_area_bound"] = f.snap_area_bound;
  j["input_triangles"] = f.input_triangles;
  j["screen_triangles"] = f.screen_triangles;
  j["fragments"] = f.fragments;
  j["thin_fragments"] = f.thin_fragments;
  j["sliver_fragments"] = f.sliver_fragments;
  j["deep_tournaments"] = f.deep_tournaments;
  j["crossing_lines"] = f.crossing_lines;
  put("crossing_pairs", f.crossing_pairs);
  put("rounded_crossing_pairs", f.rounded_crossing_pairs);
  put("tie_cycle_area", f.tie_cycle_area);
  j["free_planes"] = f.free_planes;
  j["culled_triangles"] = f.culled_triangles;
  j["dropped_fragments"] = f.dropped_fragments;
  put("cull_differing", f.cull_differing);
  put("cull_xor_area", f.cull_xor_area);
  return j;
}

ReversedScene reverse_order(const Scene& scene) {
  ReversedScene r;
  r.scene = scene;
  std::reverse(r.scene.meshes.begin(), r.scene.meshes.end());
  const uint32_t nm = uint32_t(scene.meshes.size());
  for (uint32_t m = 0; m < nm; ++m) {
    Mesh& mesh = r.scene.meshes[m];
    const size_t nt = mesh.triangle_count();
    std::vector<uint32_t> idx(mesh.indices.size());
    for (size_t t = 0; t < nt; ++t)
      for (int k = 0; k < 3; ++k) idx[3 * (nt - 1 - t) + k] = mesh.indices[3 * t + k];
    mesh.indices = std::move(idx);
    std::reverse(mesh.face_ids.begin(), mesh.face_ids.end());
    r.mesh_of.push_back(nm - 1 - m);
    r.tri_count.push_back(uint32_t(nt));
  }
  return r;
}

std::pair<uint32_t, uint32_t> ReversedScene::original(uint32_t mesh, uint32_t tri) const {
  return {mesh_of[mesh], tri_count[mesh] - 1 - tri};
}

std::vector<CanonicalFragment> canonical_fragments(const PlanarMap& map,
                                                   const ReversedScene* rename) {
  std::vector<CanonicalFragment> out;
  out.reserve(map.fragment_count());
  for (size_t f = 0; f < map.fragment_count(); ++f) {
    uint32_t m = map.mesh[f], t = map.triangle[f];
    if (rename) std::tie(m, t) = rename->original(m, t);
    const uint32_t b = map.offsets[f], n = map.offsets[f + 1] - b;
    uint32_t start = 0;
    for (uint32_t v = 1; v < n; ++v) {
      const double* p = &map.xy[2 * (b + v)];
      const double* q = &map.xy[2 * (b + start)];
      if (p[0] < q[0] || (p[0] == q[0] && p[1] < q[1])) start = v;
    }
    CanonicalFragment c{double(m), double(t)};
    for (uint32_t v = 0; v < n; ++v) {
      const double* p = &map.xy[2 * (b + (start + v) % n)];
      c.push_back(p[0]);
      c.push_back(p[1]);
    }
    out.push_back(std::move(c));
  }
  std::sort(out.begin(), out.end());
  return out;
}

}  // namespace vismap::check
