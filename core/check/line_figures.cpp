#include "core/check/line_figures.h"

#include "core/lines/line_check.h"
#include "core/lines/svg_lines.h"

namespace vismap::check {

namespace {

std::string line_check_ppm(const std::vector<uint8_t>& img, uint32_t width, uint32_t height) {
  std::string ppm = "P6\n" + std::to_string(width) + " " + std::to_string(height) + "\n255\n";
  for (uint8_t v : img) {
    uint8_t c[3] = {255, 255, 255};
    if (v & kRefMissed)
      c[0] = 230, c[1] = 0, c[2] = 0;
    else if (v & kDrawnUnsupported)
      c[0] = 220, c[1] = 0, c[2] = 220;
    else if (v & kDrawn)
      c[0] = c[1] = c[2] = 0;
    else if (v & kRefPoint)
      c[0] = 150, c[1] = 220, c[2] = 150;
    ppm.append(reinterpret_cast<const char*>(c), 3);
  }
  return ppm;
}

// The drawing `vismap render --style lines` makes, or the one read from o.from_svg.
LineSet drawing(Renderer& renderer, const Scene& scene, const Camera& cam,
                const LineFigureOptions& o) {
  if (!o.from_svg.empty()) return read_svg_lines_file(o.from_svg, cam.width, cam.height);
  RenderOptions ro;
  ro.keep_screen_triangles = true;
  ro.memory_budget = o.memory_budget;
  ScreenTriangles screen;
  const PlanarMap map = renderer.render(scene, cam, ro, nullptr, &screen);
  return extract_lines(map, screen, scene, cam, o.lines);
}

}  // namespace

LineFigures check_line_drawing(Renderer& renderer, const Scene& scene, const Camera& cam,
                               const LineFigureOptions& o) {
  const LineSet lines = drawing(renderer, scene, cam, o);
  // The reference: the id raster at 4 x 4 samples per pixel (the same view, finer).
  constexpr uint32_t kFactor = 4;
  Camera fine = cam;
  fine.width *= kFactor;
  fine.height *= kFactor;
  std::vector<uint32_t> ids;
  renderer.raster_ids(scene, fine, &ids);
  std::vector<uint8_t> img;
  const LineCheck lc =
      check_lines(lines, ids, cam.width, cam.height, kFactor, scene, 1.5, o.image ? &img : nullptr);
  LineFigures out;
  nlohmann::ordered_json& l = out.json;
  if (!o.from_svg.empty()) l["from"] = o.from_svg;
  l["chains"] = lines.chain_count();
  for (size_t k = 0; k < kLineKinds; ++k)
    l[std::string(line_kind_name(LineKind(k))) + "_edges"] = lines.edges[k];
  l["unplaced_edges"] = lines.unplaced;
  l["samples_per_pixel"] = kFactor * kFactor;
  l["radius_px"] = lc.radius;
  l["reference_points"] = lc.reference_points;
  l["recall"] = lc.recall();
  l["line_px"] = lc.line_px;
  l["precision"] = lc.precision();
  if (o.image) out.ppm = line_check_ppm(img, cam.width, cam.height);
  return out;
}

}  // namespace vismap::check
