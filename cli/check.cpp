// `vismap check`: runs the pipeline and the checks (core/check/scene_check.h) on one scene and
// prints one JSON object on stdout. Exit status 0 when every figure is within its tolerance
// (docs/NUMERICS.md), 4 when one is over (the JSON then lists them under "over_tolerance").
#include "cli/check.h"

#include <cstdio>
#include <memory>
#include <string>

#include "cli/args.h"
#include "core/check/line_figures.h"
#include "core/check/scene_check.h"
#include "core/frame/frame.h"

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

// The scene diced for the view through the front door (core/frame), then every check.
int run_check(const CheckArgs& a) {
  auto loaded = std::make_shared<const Scene>(load_scene(a.scene));
  print_load_warnings(*loaded);
  frame::FrameSpec spec;
  spec.camera = make_camera(*loaded, a.view);
  spec.scene = std::make_shared<frame::SceneState>(loaded);
  spec.tolerance_px = a.view.tolerance_px;
  spec.implicit_tolerance_px = a.view.implicit_tolerance_px;
  spec.memory_budget = a.opts.memory_budget;
  const Camera& cam = spec.camera;
  Renderer renderer(a.view.device);
  Scene scene = *frame::dice_for_view(renderer, spec);
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
    check::LineFigureOptions lo;
    lo.lines = a.line_opts;
    lo.from_svg = a.lines_from;
    lo.memory_budget = a.opts.memory_budget;
    lo.image = !a.lines_image.empty();
    const check::LineFigures lf = check::check_line_drawing(renderer, scene, cam, lo);
    if (lo.image) write_atomically(a.lines_image, lf.ppm);
    j["lines"] = lf.json;
  }
  j["over_tolerance"] = bad;
  std::printf("%s\n", j.dump().c_str());
  return bad.empty() ? 0 : 4;
}
}  // namespace

int cmd_check(int argc, char** argv) {
  const CheckArgs a = parse_check(argc, argv);
  return naming_scene(a.scene, [&] { return run_check(a); });
}

}  // namespace vismap::cli
