// `vismap check`: runs the pipeline and the checks (core/check/scene_check.h) on one scene and
// prints one JSON object on stdout. Exit status 0 when every figure is within its tolerance
// (docs/NUMERICS.md), 4 when one is over (the JSON then lists them under "over_tolerance").
#include "cli/check.h"

#include <cstdio>
#include <string>

#include "cli/args.h"
#include "core/check/scene_check.h"
#include "core/lines/line_check.h"
#include "core/lines/lines.h"
#include "core/lines/svg_lines.h"

namespace vismap::cli {

namespace {
struct CheckArgs {
  std::string scene;
  ViewArgs view;
  check::SceneCheckOptions opts;
  bool reverse = false;
  check::Tolerances tol;
  bool lines = false;
  std::string lines_image;  // a PPM of where the drawing and the raster agree (--lines-image)
  std::string lines_from;   // score this SVG drawing instead of ours (--lines-from; another tool's)
  LineOptions line_opts;
};

CheckArgs parse_check(int argc, char** argv) {
  CheckArgs a;
  bool pixels_given = false, force_reference = false;
  for (int i = 2; i < argc; ++i) {
    std::string f = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) throw UsageError(f + " needs a value");
      return argv[++i];
    };
    if (parse_view_flag(f, value, a.view)) continue;
    if (f == "--pixels") {
      a.opts.pixels = parse_pixels(f, value());
      pixels_given = true;
    } else if (f == "--tile-pixels")
      a.opts.tile_pixels = parse_pixels(f, value());
    else if (f == "--memory-budget")
      a.opts.memory_budget = parse_bytes(f, value());
    else if (f == "--lines")
      a.lines = true;
    else if (f == "--lines-image")
      a.lines_image = value();
    else if (f == "--lines-from") {
      a.lines_from = value();
      a.lines = true;
    } else if (parse_line_flag(f, value, a.line_opts))
      continue;
    else if (f == "--reverse")
      a.reverse = true;
    else if (f == "--strict")
      a.tol.strict = true;
    else if (f == "--no-reference")
      a.opts.reference = false;
    else if (f == "--reference")
      force_reference = true;
    else if (!f.empty() && f[0] == '-')
      throw UsageError("unknown option " + f);
    else if (a.scene.empty())
      a.scene = f;
    else
      throw UsageError("unexpected argument " + f);
  }
  if (a.scene.empty()) throw UsageError("check: missing SCENE");
  validate_view(a.view);
  // --pixels N is for scenes too big for the exact reference: it skips it unless --reference.
  if (pixels_given && !force_reference) a.opts.reference = false;
  return a;
}
}  // namespace

namespace {
int run_check(const CheckArgs& a);

// --lines-image: where the drawing and the reference agree, one colour per pixel. Red: a
// reference point with no line near (missed); magenta: a drawn line with no reference point
// near (unsupported); black: a drawn line with one; light green: reference points, all near a
// line; white: nothing.
void write_line_check_image(const std::string& path, const std::vector<uint8_t>& img,
                            uint32_t width, uint32_t height) {
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
  write_atomically(path, ppm);
}
}  // namespace

int cmd_check(int argc, char** argv) {
  const CheckArgs a = parse_check(argc, argv);
  return naming_scene(a.scene, [&] { return run_check(a); });
}

namespace {

int run_check(const CheckArgs& a) {
  Scene scene = load_scene(a.scene);
  print_load_warnings(scene);
  Camera cam = make_camera(scene, a.view);
  Renderer renderer(a.view.device);
  scene = dice_for_view(renderer, std::move(scene), cam, a.view, nullptr, a.opts.memory_budget);
  check::ReversedScene rev;
  if (a.reverse) {
    rev = check::reverse_order(scene);
    scene = rev.scene;
  }
  check::SceneFigures f = check::check_scene(renderer, scene, cam, a.opts);
  nlohmann::ordered_json j = check::to_json(f);
  j["scene"] = a.scene;
  j["device"] = renderer.device().name;
  j["width"] = cam.width;
  j["height"] = cam.height;
  j["reversed"] = a.reverse;
  std::vector<std::string> bad = check::over_tolerance(f, a.tol);
  if (a.lines) {
    // The drawing `vismap render --style lines` makes, against the id raster of the same view.
    // With --lines-from, another tool's drawing read from SVG (core/lines/svg_lines.h) instead.
    LineSet lines;
    if (!a.lines_from.empty()) {
      lines = read_svg_lines_file(a.lines_from, cam.width, cam.height);
    } else {
      RenderOptions ro;
      ro.keep_screen_triangles = true;
      ro.memory_budget = a.opts.memory_budget;
      ScreenTriangles screen;
      const PlanarMap map = renderer.render(scene, cam, ro, nullptr, &screen);
      lines = extract_lines(map, screen, scene, cam, a.line_opts);
    }
    // The reference: the id raster at 4 x 4 samples per pixel (the same view, finer).
    constexpr uint32_t kFactor = 4;
    Camera fine = cam;
    fine.width *= kFactor;
    fine.height *= kFactor;
    std::vector<uint32_t> ids;
    renderer.raster_ids(scene, fine, &ids);
    std::vector<uint8_t> img;
    const LineCheck lc = check_lines(lines, ids, cam.width, cam.height, kFactor, scene, 1.5,
                                     a.lines_image.empty() ? nullptr : &img);
    if (!a.lines_image.empty()) write_line_check_image(a.lines_image, img, cam.width, cam.height);
    nlohmann::ordered_json l;
    if (!a.lines_from.empty()) l["from"] = a.lines_from;
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
    j["lines"] = l;
  }
  j["over_tolerance"] = bad;
  std::printf("%s\n", j.dump().c_str());
  return bad.empty() ? 0 : 4;
}

}  // namespace

}  // namespace vismap::cli
