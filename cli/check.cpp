// `vismap check`: runs the pipeline and the checks (core/reference/scene_check.h) on one scene and
// prints one JSON object on stdout. Exit status 0 when every figure is within its tolerance
// (docs/NUMERICS.md), 4 when one is over (the JSON then lists them under "over_tolerance").
#include "cli/check.h"

#include <cstdio>
#include <string>

#include "cli/args.h"
#include "core/reference/scene_check.h"

namespace vismap::cli {

namespace {
struct CheckArgs {
  std::string scene;
  ViewArgs view;
  check::SceneCheckOptions opts;
  bool reverse = false;
  check::Tolerances tol;
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

int cmd_check(int argc, char** argv) {
  CheckArgs a = parse_check(argc, argv);
  Scene scene = load_scene(a.scene);
  Camera cam = make_camera(scene, a.view);
  Renderer renderer(a.view.device);
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
  j["over_tolerance"] = bad;
  std::printf("%s\n", j.dump().c_str());
  return bad.empty() ? 0 : 4;
}

}  // namespace vismap::cli
