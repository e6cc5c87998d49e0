// `vismap render`: the flags into a FrameSpec (core/frame/frame.h), one run_frame, the bytes
// written atomically; --stats prints what the frame measured (render_stats.cpp).
#include "cli/render.h"

#include <unistd.h>

#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>

#include "core/frame/frame.h"
#include "core/frame/implicit_2d.h"
#include "core/implicit/implicit.h"

namespace vismap::cli {

namespace {

// "X0,Y0,X1,Y1" for --bounds.
std::array<double, 4> parse_bounds(const std::string& flag, const std::string& s) {
  std::array<double, 4> b{};
  const char* p = s.c_str();
  for (int k = 0; k < 4; ++k) {
    char* end = nullptr;
    b[k] = std::strtod(p, &end);
    if (end == p || !std::isfinite(b[k]) || (k < 3 && *end != ','))
      throw UsageError(flag + ": expected X0,Y0,X1,Y1, got '" + s + "'");
    p = end + (k < 3);
  }
  if (*p) throw UsageError(flag + ": expected X0,Y0,X1,Y1, got '" + s + "'");
  if (!(b[2] > b[0] && b[3] > b[1])) throw UsageError(flag + ": expected X0 < X1 and Y0 < Y1");
  return b;
}

bool is_sexp(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  for (char& c : ext) c = char(std::tolower(static_cast<unsigned char>(c)));
  return ext == ".sexp";
}

// The format OUT's extension names (case aside): formats.h's table.
frame::OutputFormat format_of(const std::string& out) {
  if (const auto f = frame::format_of_path(out)) return *f;
  const std::string ext = std::filesystem::path(out).extension().string();
  throw UsageError("-o " + out + ": " +
                   (ext.empty() ? std::string("no extension") : "unknown extension '" + ext + "'") +
                   " (" + frame::file_format_extensions() + ", or give --format)");
}

// "KIND=#RRGGBB" for --line-color.
void parse_line_color(const std::string& v, SvgStyle& svg) {
  const size_t eq = v.find('=');
  const std::string kind = v.substr(0, eq);
  for (size_t k = 0; k < kLineKinds; ++k) {
    if (kind != line_kind_name(LineKind(k))) continue;
    const std::string c = eq == std::string::npos ? "" : v.substr(eq + 1);
    if (c.size() == 7 && c[0] == '#' &&
        c.find_first_not_of("0123456789abcdefABCDEF", 1) == std::string::npos) {
      svg.line_color[k] = uint32_t(std::stoul(c.substr(1), nullptr, 16));
      return;
    }
    throw UsageError("--line-color: expected " + kind + "=#RRGGBB, got '" + v + "'");
  }
  throw UsageError("--line-color: expected contour, boundary, crease, intersection or border "
                   "=#RRGGBB, got '" + v + "'");
}

double parse_time_limit(const std::string& v) {
  char* end = nullptr;
  const double s = std::strtod(v.c_str(), &end);
  if (v.empty() || *end || !(s > 0) || !std::isfinite(s))
    throw UsageError("--time-limit: expected a positive number of seconds, got '" + v + "'");
  return s;
}

// The output flags: format, fill, compact's coding, style and lines. True when `f` was one.
bool parse_output_flag(const std::string& f, const std::function<std::string()>& value,
                       RenderArgs& a) {
  frame::OutputSpec& o = a.output;
  if (f == "--format") {
    const std::string v = value();
    const auto fmt = frame::format_named(v);
    if (!fmt || !frame::format_row(*fmt).extension)
      throw UsageError("--format: expected " + frame::file_format_names());
    o.format = *fmt;
    a.format_given = true;
  } else if (f == "--fill") {
    const std::string v = value();
    if (v != "shade" && v != "id") throw UsageError("--fill: expected shade or id");
    o.fill = v == "id" ? Fill::Id : Fill::Shade;
  } else if (f == "--quantum") {
    // One range and one message for every value (parse_pixels said 1..16384 past 16384).
    const std::string v = value();
    char* end = nullptr;
    const double q = std::strtod(v.c_str(), &end);
    if (v.empty() || *end || !(q >= kMinQuantum && q <= kMaxQuantum) || q != std::floor(q))
      throw UsageError("--quantum: expected an integer in " + quantum_range_text() + ", got '" +
                       v + "'");
    o.quantum = static_cast<uint32_t>(q);
  } else if (f == "--compression") {
    const std::string v = value();
    if (v != "zstd" && v != "deflate") throw UsageError("--compression: expected zstd or deflate");
    o.compression = v == "deflate" ? Compression::Deflate : Compression::Zstd;
  } else if (f == "--style") {
    const auto s = frame::style_named(value());
    if (!s) throw UsageError("--style: expected fill, lines or fill+lines");
    o.style = *s;
  } else if (parse_line_flag(f, value, o.lines)) {
  } else if (f == "--line-width") {
    o.svg.line_width = parse_number(f, value());
    if (!(o.svg.line_width > 0 && o.svg.line_width <= 1000))
      throw UsageError("--line-width: expected a positive number of pixels (at most 1000)");
  } else if (f == "--simplify") {
    o.lines.simplify_px = parse_number(f, value());
    if (!(o.lines.simplify_px >= 0 && o.lines.simplify_px <= 1000))
      throw UsageError("--simplify: expected 0 ... 1000 pixels");
  } else if (f == "--merge") {
    o.svg.merge = true;
  } else if (f == "--hidden") {
    o.lines.hidden = true;
  } else if (f == "--line-color") {
    parse_line_color(value(), o.svg);
  } else {
    return false;
  }
  return true;
}

// What the flags together must satisfy.
void validate_render(RenderArgs& a) {
  if (a.scene.empty()) throw UsageError("render: missing SCENE");
  if (a.out.empty()) throw UsageError("render: missing -o OUT");
  frame::OutputSpec& o = a.output;
  if (!a.format_given) o.format = format_of(a.out);
  const char* style = frame::style_name(o.style);
  if (o.draws_lines() && !frame::format_row(o.format).lines)
    throw UsageError(std::string("--style ") + style +
                     ": lines are written to svg, pdf, eps, png and bin, not compact");
  o.svg.fill = o.draws_fills();
  if (o.svg.merge && (o.format != frame::OutputFormat::Svg || !o.draws_fills()))
    throw UsageError(
        "--merge: joins the fills of an svg (--format svg, --style fill or fill+lines)");
  if (o.lines.hidden && !o.draws_lines())
    throw UsageError(
        "--hidden: draws the occluded parts of lines; give --style lines or fill+lines");
  o.attributes = frame::format_row(o.format).carries_attributes;  // (bin: always)
  validate_view(a.view);
}

// An implicit expression in x and y (MPR's 2D mode): filled regions straight to SVG.
// t0: when the command began (the tape was read and parsed since).
int render_implicit_2d(const RenderArgs& a, const implicit::Tape& tape, Clock::time_point t0) {
  const Clock::time_point t_load = Clock::now();
  if (a.output.format != frame::OutputFormat::Svg)
    throw UsageError("an implicit expression renders to svg only");
  implicit::View2D v;
  if (a.bounds)
    v.x0 = (*a.bounds)[0], v.y0 = (*a.bounds)[1], v.x1 = (*a.bounds)[2], v.y1 = (*a.bounds)[3];
  v.width = a.view.width.value_or(a.view.height.value_or(1024));
  v.height = a.view.height.value_or(v.width);
  Renderer renderer(a.view.device);
  const Clock::time_point t_dev = Clock::now();
  const frame::Frame2D f = frame::run_frame_2d(renderer, tape, v, a.view.tolerance_px,
                                               a.time_limit_s, a.memory_budget, t0);
  write_atomically(a.out, f.svg);
  if (a.stats)
    print_implicit_2d_stats(renderer.device(), tape, f, ms_since(t0) - ms_since(t_load),
                            ms_since(t_load) - ms_since(t_dev));
  return 0;
}

// The FrameSpec of these flags for this scene (loaded since t0).
frame::FrameSpec frame_spec(const RenderArgs& a, std::shared_ptr<const Scene> scene,
                            Clock::time_point t0) {
  frame::FrameSpec spec;
  spec.camera = make_camera(*scene, a.view);
  spec.scene = std::make_shared<frame::SceneState>(std::move(scene));
  spec.output = a.output;
  spec.tolerance_px = a.view.tolerance_px;
  spec.implicit_tolerance_px = a.view.implicit_tolerance_px;
  spec.time_limit_s = a.time_limit_s;
  spec.started = t0;  // (one limit for the whole command: the load counts)
  spec.memory_budget = a.memory_budget;
  spec.cull = a.cull;
  if (a.facts) spec.facts = frame::FactsPolicy::Now;
  if (::isatty(2))
    spec.progress = [t0](double f) {
      if (ms_since(t0) < 1000) return;
      std::fprintf(stderr, "\rvismap: rendering %3.0f%%", f * 100);
    };
  return spec;
}

int run_render(const RenderArgs& a, Clock::time_point t0) {
  // An expression in x and y alone is MPR's 2D mode; one that uses z is a 3D object.
  if (is_sexp(a.scene)) {
    const implicit::Tape tape = implicit::load(a.scene);
    if (!implicit::uses_z(tape)) return render_implicit_2d(a, tape, t0);
  }
  if (a.bounds) throw UsageError("--bounds: the window of a 2D implicit expression (.sexp)");
  LoadOptions lo;
  lo.time_limit_s = a.time_limit_s;  // an implicit object's bounds search, too
  auto scene = std::make_shared<const Scene>(load_scene(a.scene, lo));
  print_load_warnings(*scene);
  const double load_ms = ms_since(t0);
  const frame::FrameSpec spec = frame_spec(a, scene, t0);
  Renderer renderer(a.view.device);
  const frame::Frame f = frame::run_frame(renderer, spec);
  if (a.memory_budget && f.rendered.stats.peak_device_bytes > a.memory_budget)
    std::fprintf(
        stderr,
        "vismap: warning: device memory peaked at %.1f MB, over the budget of %.1f MB "
        "(a part of the screen holds more than the budget allows; see --memory-budget in "
        "README.md)\n",
        f.rendered.stats.peak_device_bytes / 1e6, a.memory_budget / 1e6);
  write_atomically(a.out, f.encoded.bytes);
  if (spec.progress && ms_since(t0) >= 1000) std::fprintf(stderr, "\r%30s\r", "");
  if (a.stats) print_render_stats({a, renderer.device(), f, scene->dropped_degenerate, load_ms,
                                   ms_since(t0)});
  return 0;
}

}  // namespace

RenderArgs parse_render(int argc, char** argv) {
  RenderArgs a;
  for (int i = 2; i < argc; ++i) {
    std::string f = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) throw UsageError(f + " needs a value");
      return argv[++i];
    };
    if (f == "-o" || f == "--output")
      a.out = value();
    else if (parse_view_flag(f, value, a.view) || parse_output_flag(f, value, a))
      continue;
    else if (f == "--bounds")
      a.bounds = parse_bounds(f, value());
    else if (f == "--stats")
      a.stats = true;
    else if (f == "--no-cull")
      a.cull = false;
    else if (f == "--scene-facts")
      a.facts = true;
    else if (f == "--memory-budget")
      a.memory_budget = parse_bytes(f, value());
    else if (f == "--time-limit")
      a.time_limit_s = parse_time_limit(value());
    else if (!f.empty() && f[0] == '-')
      throw UsageError("unknown option " + f);
    else if (a.scene.empty())
      a.scene = f;
    else
      throw UsageError("unexpected argument " + f);
  }
  validate_render(a);
  return a;
}

int cmd_render(int argc, char** argv) {
  const Clock::time_point t0 = Clock::now();
  const RenderArgs a = parse_render(argc, argv);
  return naming_scene(a.scene, [&] { return run_render(a, t0); });
}

}  // namespace vismap::cli
