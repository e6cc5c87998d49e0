// vismap: the command-line front end. `vismap render`, `vismap check` (cli/check.cpp),
// `vismap devices`.
#include <unistd.h>

#include <cctype>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <new>
#include <optional>
#include <string>
#include <vector>

#include "cli/args.h"
#include "cli/check.h"
#include "cli/decode.h"
#include "core/camera.h"
#include "core/error.h"
#include "core/implicit/implicit.h"
#include "core/lines/lines.h"
#include "core/pipeline.h"
#include "core/scene.h"
#include "core/stream/compact.h"
#include "core/surfaces/implicit2d.h"
#include "core/write/cairo.h"
#include "core/write/output.h"

namespace {

using namespace vismap;
using namespace vismap::cli;

const char* kRenderUsage =
    "  vismap render SCENE -o OUT [--format svg|pdf|eps|png|bin|compact] [--fill shade|id]\n"
    "                [--quantum Q] [--compression zstd|deflate] [--width W --height H]\n"
    "                [--eye X,Y,Z --target X,Y,Z --up X,Y,Z] [--fov-y DEG | --ortho HEIGHT]\n"
    "                [--near N --far F] [--device NAME] [--memory-budget BYTES]\n"
    "                [--time-limit SECONDS] [--stats] [--tolerance PX] [--implicit-tolerance PX]\n"
    "                [--no-cull] [--scene-facts]\n"
    "                [--style fill|lines|fill+lines] [--crease-angle DEG] [--line-width PX]\n"
    "                [--line-color KIND=#RRGGBB] [--simplify PX] [--hidden] [--merge]\n"
    "                [--min-length PX | KIND=PX]... [--self-folds] [--crease-smooth on|off]\n"
    "                [--bounds X0,Y0,X1,Y1]   (a 2D implicit .sexp: the window drawn)\n"
    "                format: --format, else OUT's extension (.svg .pdf .eps .png .bin .vmc)\n";
const char* kCheckUsage =
    "  vismap check SCENE [camera flags as render] [--pixels N] [--tile-pixels T] [--device NAME]\n"
    "                [--memory-budget BYTES]\n"
    "                [--lines [--crease-angle DEG] [--min-length [KIND=]PX] [--self-folds]\n"
    "                 [--crease-smooth on|off]\n"
    "                 [--lines-image OUT.ppm]\n"
    "                 [--lines-from DRAWING.svg]]   (another tool's SVG drawing, scored alike)\n"
    "                [--reverse] [--no-reference] [--strict]   one JSON object on stdout; exit 4 "
    "if over tolerance\n";
const char* kDecodeUsage =
    "  vismap decode FRAME... [-o OUT.svg] [--json] [--sources SOURCES]   a bin or compact "
    "frame,\n"
    "                or a delta sequence (--sources: the held scene's message): a summary line on "
    "stdout\n";
const char* kDevicesUsage = "  vismap devices\n";
const char* kNotes =
    "SCENE: .ply .ply.gz .obj .off .stl .gltf .glb, pbrt .pbrt (trianglemesh, loopsubdiv),\n"
    "       Bezier patches .bpt .patches,\n"
    "       a .json scene file, or an implicit expression (.sexp): in x and y alone, filled\n"
    "       regions (2D); with z, a surface f = 0 rendered as any mesh.\n"
    "--tolerance PX: curved surfaces are diced within PX pixels of the surface (default 0.2).\n"
    "--implicit-tolerance PX: implicit surfaces, within PX pixels at their nearest depth\n"
    "       (default 4; a bound: the surface is usually far closer).\n"
    "--device (or $VISMAP_DEVICE): 'P:D' from `vismap devices`, or part of a device/platform "
    "name.\n";

// The usage of one command ("" or unknown: all of them), with the notes and the general flags.
std::string usage(const std::string& cmd) {
  std::string u = "usage:\n";
  if (cmd == "render")
    u += kRenderUsage;
  else if (cmd == "check")
    u += kCheckUsage;
  else if (cmd == "decode")
    u += kDecodeUsage;
  else if (cmd == "devices")
    u += kDevicesUsage;
  else
    u += std::string(kRenderUsage) + kCheckUsage + kDecodeUsage + kDevicesUsage +
         "  vismap help [COMMAND] | --help | -h | --version\n";
  return u + kNotes;
}

// True when an argument after the command asks for its usage. A scan before parsing, so that
// `vismap render --help` prints usage even without the SCENE and -o that render requires.
bool asks_help(int argc, char** argv) {
  for (int i = 2; i < argc; ++i)
    if (!std::strcmp(argv[i], "-h") || !std::strcmp(argv[i], "--help")) return true;
  return false;
}

struct RenderArgs {
  std::string scene, out, format, fill = "shade";  // format: "" until resolved
  ViewArgs view;
  bool stats = false;
  bool cull = true;  // --no-cull: clip every triangle in view (RenderOptions::cull)
  bool facts = false;  // --scene-facts: RenderOptions::facts Now (else Repeat: none in one frame)
  uint64_t memory_budget = 0;
  double time_limit_s = 0;
  uint32_t quantum = 16;  // compact: grid steps per pixel
  std::string compression = "zstd";
  std::string style = "fill";
  LineOptions lines;
  SvgStyle svg;
  std::optional<std::array<double, 4>> bounds;  // 2D implicit: the window X0,Y0,X1,Y1
};

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

// An implicit expression in x and y (MPR's 2D mode): filled regions straight to SVG.
// t0: when the command began (the tape was read and parsed since).
int render_implicit_2d(const RenderArgs& a, const implicit::Tape& tape,
                       std::chrono::steady_clock::time_point t0) {
  using Clock = std::chrono::steady_clock;
  const auto t_load = Clock::now();
  if (a.format != "svg") throw UsageError("an implicit expression renders to svg only");
  implicit::View2D v;
  if (a.bounds)
    v.x0 = (*a.bounds)[0], v.y0 = (*a.bounds)[1], v.x1 = (*a.bounds)[2], v.y1 = (*a.bounds)[3];
  v.width = a.view.width.value_or(a.view.height.value_or(1024));
  v.height = a.view.height.value_or(v.width);
  Renderer renderer(a.view.device);
  const auto t_dev = Clock::now();
  const implicit::Regions2D r =
      renderer.implicit_2d(tape, v, a.view.tolerance_px, a.time_limit_s, a.memory_budget);
  const auto t_map = Clock::now();
  const std::string svg = implicit::write_svg_2d(r, v);
  write_atomically(a.out, svg);
  if (a.stats) {
    auto ms = [](auto d) { return std::chrono::duration<double, std::milli>(d).count(); };
    size_t points = 0;
    for (const auto& l : r.loops) points += l.size();
    std::fprintf(stderr, "device: %s / %s\n", renderer.device().platform.c_str(),
                 renderer.device().name.c_str());
    std::fprintf(stderr,
                 "implicit 2D: %zu clauses, cell %.3f px, %llu leaves, %llu full cells, %zu "
                 "loops (%zu points), %zu regions\n",
                 tape.size(), r.cell_px, static_cast<unsigned long long>(r.leaves),
                 static_cast<unsigned long long>(r.full_cells), r.loops.size(), points,
                 r.regions.size());
    std::fprintf(stderr, "clauses evaluated per round:");
    for (uint64_t c : r.clauses_per_round)
      std::fprintf(stderr, " %llu", static_cast<unsigned long long>(c));
    std::fprintf(stderr,
                 "\nms: load+parse %.2f, device start %.2f, queue %.2f, contour %.2f, svg+write "
                 "%.2f (a first run also builds the kernels, inside queue)\n",
                 ms(t_load - t0), ms(t_dev - t_load), r.queue_ms, r.contour_ms,
                 ms(Clock::now() - t_map));
  }
  return 0;
}

// The format OUT's extension names (case aside): .svg .pdf .eps .png .bin, .vmc for compact.
std::string format_of(const std::string& out) {
  std::string ext = std::filesystem::path(out).extension().string();
  for (char& c : ext) c = char(std::tolower(static_cast<unsigned char>(c)));
  for (const char* f : {"svg", "pdf", "eps", "png", "bin"})
    if (ext == std::string(".") + f) return f;
  if (ext == ".vmc") return "compact";
  throw UsageError("-o " + out + ": " +
                   (ext.empty() ? std::string("no extension") : "unknown extension '" + ext + "'") +
                   " (.svg .pdf .eps .png .bin .vmc, or give --format)");
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
    else if (f == "--format")
      a.format = value();
    else if (f == "--fill")
      a.fill = value();
    else if (f == "--quantum") {
      // One range and one message for every value (parse_pixels said 1..16384 past 16384).
      const std::string v = value();
      char* end = nullptr;
      const double q = std::strtod(v.c_str(), &end);
      if (v.empty() || *end || !(q >= kMinQuantum && q <= kMaxQuantum) || q != std::floor(q))
        throw UsageError("--quantum: expected an integer in " + quantum_range_text() + ", got '" +
                         v + "'");
      a.quantum = static_cast<uint32_t>(q);
    } else if (f == "--compression") {
      a.compression = value();
      if (a.compression != "zstd" && a.compression != "deflate")
        throw UsageError("--compression: expected zstd or deflate");
    } else if (parse_view_flag(f, value, a.view))
      continue;
    else if (f == "--style")
      a.style = value();
    else if (parse_line_flag(f, value, a.lines))
      continue;
    else if (f == "--line-width") {
      a.svg.line_width = parse_number(f, value());
      if (!(a.svg.line_width > 0 && a.svg.line_width <= 1000))
        throw UsageError("--line-width: expected a positive number of pixels (at most 1000)");
    } else if (f == "--simplify") {
      a.lines.simplify_px = parse_number(f, value());
      if (!(a.lines.simplify_px >= 0 && a.lines.simplify_px <= 1000))
        throw UsageError("--simplify: expected 0 ... 1000 pixels");
    } else if (f == "--merge")
      a.svg.merge = true;
    else if (f == "--bounds")
      a.bounds = parse_bounds(f, value());
    else if (f == "--hidden")
      a.lines.hidden = true;
    else if (f == "--line-color")
      parse_line_color(value(), a.svg);
    else if (f == "--stats")
      a.stats = true;
    else if (f == "--no-cull")
      a.cull = false;
    else if (f == "--scene-facts")
      a.facts = true;
    else if (f == "--memory-budget")
      a.memory_budget = parse_bytes(f, value());
    else if (f == "--time-limit") {
      const std::string v = value();
      char* end = nullptr;
      a.time_limit_s = std::strtod(v.c_str(), &end);
      if (v.empty() || *end || !(a.time_limit_s > 0) || !std::isfinite(a.time_limit_s))
        throw UsageError("--time-limit: expected a positive number of seconds, got '" + v + "'");
    } else if (!f.empty() && f[0] == '-')
      throw UsageError("unknown option " + f);
    else if (a.scene.empty())
      a.scene = f;
    else
      throw UsageError("unexpected argument " + f);
  }
  if (a.scene.empty()) throw UsageError("render: missing SCENE");
  if (a.out.empty()) throw UsageError("render: missing -o OUT");
  if (a.format.empty())
    a.format = format_of(a.out);
  else if (a.format != "svg" && a.format != "pdf" && a.format != "eps" && a.format != "png" &&
           a.format != "bin" && a.format != "compact")
    throw UsageError("--format: expected svg, pdf, eps, png, bin or compact");
  if (a.fill != "shade" && a.fill != "id") throw UsageError("--fill: expected shade or id");
  if (a.style != "fill" && a.style != "lines" && a.style != "fill+lines")
    throw UsageError("--style: expected fill, lines or fill+lines");
  if (a.style != "fill" && a.format == "compact")
    throw UsageError("--style " + a.style +
                     ": lines are written to svg, pdf, eps, png and bin, not compact");
  a.svg.fill = a.style != "lines";
  if (a.svg.merge && (a.format != "svg" || a.style == "lines"))
    throw UsageError(
        "--merge: joins the fills of an svg (--format svg, --style fill or fill+lines)");
  if (a.lines.hidden && a.style == "fill")
    throw UsageError(
        "--hidden: draws the occluded parts of lines; give --style lines or fill+lines");
  validate_view(a.view);
  return a;
}

// What `render --stats` prints: everything a frame measured, gathered once the output is written.
struct RenderReport {
  const RenderArgs& args;
  const DeviceInfo& device;
  const RenderStats& st;
  const TessellateStats& ts;
  const PlanarMap& map;
  const CompactStats& cs;
  const LineSet* line_set;  // null without lines
  uint64_t dropped_degenerate = 0;
  size_t bytes = 0;
  double load_ms = 0, render_ms = 0, lines_ms = 0, write_ms = 0, total_ms = 0;
};

// The device and the per-stage table.
void print_stage_table(const RenderReport& r) {
  std::fprintf(stderr, "device: %s / %s\n", r.device.platform.c_str(), r.device.name.c_str());
  std::fprintf(stderr, "%-12s %10s %9s %6s %10s %12s %12s\n", "stage", "ms", "launches", "reads",
               "MB moved", "in", "out");
  double sum = 0;
  for (const StageStat& s : r.st.stages) {
    std::fprintf(stderr, "%-12s %10.2f %9u %6u %10.2f %12llu %12llu\n", s.name.c_str(), s.ms,
                 s.launches, s.host_syncs, (s.device_bytes + s.transfer_bytes) / 1e6,
                 static_cast<unsigned long long>(s.items_in),
                 static_cast<unsigned long long>(s.items_out));
    sum += s.ms;
  }
  std::fprintf(stderr,
               "%-12s %10.2f   (sum of stage times; pipeline wall %.2f ms, upload %.2f ms)\n",
               "kernels", sum, r.st.pipeline_ms, r.st.upload_ms);
}

// Dicing before the frame: patches, Loop surfaces, implicit objects.
void print_surface_stats(const RenderReport& r) {
  if (r.ts.triangles)
    std::fprintf(stderr,
                 "tessellate: %.2f ms, %u launches, %u reads, %u split rounds, %llu pieces "
                 "(%llu culled, %llu short of the tolerance at the largest rate), %llu "
                 "triangles, Loop level %u\n",
                 r.ts.ms, r.ts.launches, r.ts.host_syncs, r.ts.split_rounds,
                 static_cast<unsigned long long>(r.ts.pieces),
                 static_cast<unsigned long long>(r.ts.culled),
                 static_cast<unsigned long long>(r.ts.over_rate),
                 static_cast<unsigned long long>(r.ts.triangles), r.ts.subdivision_level);
  if (r.ts.implicit_leaves)
    std::fprintf(stderr,
                 "implicit: %llu cells per axis, %llu leaf cells, clauses per "
                 "leaf %.1f of %llu (tape shortening), %llu regions hidden behind full boxes "
                 "and %llu back faces left out; ms: queue %.1f, corners %.1f, mesh %.1f\n",
                 static_cast<unsigned long long>(r.ts.implicit_cells),
                 static_cast<unsigned long long>(r.ts.implicit_leaves),
                 double(r.ts.implicit_leaf_clauses) / double(r.ts.implicit_leaves),
                 static_cast<unsigned long long>(r.ts.implicit_clauses_full),
                 static_cast<unsigned long long>(r.ts.implicit_occluded),
                 static_cast<unsigned long long>(r.ts.implicit_back_faces), r.ts.implicit_queue_ms,
                 r.ts.implicit_points_ms, r.ts.implicit_mesh_ms);
}

// The frame's counts, syncs, memory and buckets.
void print_frame_stats(const RenderReport& r) {
  std::fprintf(stderr,
               "input triangles %llu (dropped degenerate %llu), screen triangles %llu, "
               "silhouette edges %llu\n",
               static_cast<unsigned long long>(r.st.input_triangles),
               static_cast<unsigned long long>(r.dropped_degenerate),
               static_cast<unsigned long long>(r.st.screen_triangles),
               static_cast<unsigned long long>(r.st.silhouette_edges));
  std::fprintf(stderr,
               "fragments %llu, visible %llu, clip rounds %u, host syncs %u, device memory peak "
               "%.1f MB (%.1f MB allocated in all)\n",
               static_cast<unsigned long long>(r.st.fragments),
               static_cast<unsigned long long>(r.st.visible_fragments), r.st.clip_rounds,
               r.st.host_syncs, r.st.peak_device_bytes / 1e6, r.st.allocated_device_bytes / 1e6);
  std::fprintf(stderr,
               "per frame: launches %u, blocking reads %u, bytes moved %.2f MB (device model "
               "%.2f MB, host<->device %.3f MB); modelled GPU floor %.3f ms (pipeline wall "
               "here %.2f ms)\n",
               r.st.launches, r.st.host_syncs, (r.st.device_bytes + r.st.transfer_bytes) / 1e6,
               r.st.device_bytes / 1e6, r.st.transfer_bytes / 1e6, modelled_gpu_floor_ms(r.st),
               r.st.pipeline_ms);
  std::fprintf(
      stderr,
      "entangled pairs %llu, crossing entries %llu, thin fragments %llu, deep tournaments %llu\n",
      static_cast<unsigned long long>(r.st.entangled_pairs),
      static_cast<unsigned long long>(r.st.crossing_lines),
      static_cast<unsigned long long>(r.st.thin_fragments),
      static_cast<unsigned long long>(r.st.deep_tournaments));
  std::fprintf(stderr,
               "left out: %llu back faces (closed meshes seen from outside); as provably hidden, "
               "%llu screen triangles (cull), %llu candidate edges (the triangle hidden along "
               "them), %llu fragments (stopped in the clip rounds)%s\n",
               static_cast<unsigned long long>(r.st.back_faces),
               static_cast<unsigned long long>(r.st.culled_triangles),
               static_cast<unsigned long long>(r.st.pruned_candidates),
               static_cast<unsigned long long>(r.st.dropped_fragments),
               r.args.cull ? "" : "; culling off (--no-cull)");
  if (r.st.entangled_pairs == 0)
    std::fprintf(stderr,
                 "skipped: the crossing lines' sorting and entries (no entangled pair)\n");
  if (r.st.apart_need > 0)
    std::fprintf(stderr,
                 "skipped: the crossing search between triangles farther apart in 3D than %.3g "
                 "that share no vertex (scene facts: %llu of %llu triangles at their cap, found "
                 "in %.1f ms)\n",
                 r.st.apart_need, static_cast<unsigned long long>(r.st.facts_isolated),
                 static_cast<unsigned long long>(r.st.input_triangles), r.st.facts_ms);
  else if (r.st.has_facts)
    std::fprintf(stderr, "scene facts found (%.1f ms) but not used: in this view fewer than "
                 "half the triangles are apart (it blurs more than their clearances), or it is "
                 "orthographic\n", r.st.facts_ms);
  if (r.args.memory_budget)
    std::fprintf(stderr,
                 "memory budget %.1f MB: %u bucket(s), each planned under %.1f MB of work\n",
                 r.args.memory_budget / 1e6, r.st.buckets, r.st.bucket_work_bytes / 1e6);
}

// The output file, and what the compact encoder and the line extraction made.
void print_output_stats(const RenderReport& r) {
  // Each fragment (a convex polygon of n vertices) is n - 2 triangles.
  const size_t triangles = r.map.vertex_count() - 2 * r.map.fragment_count();
  std::fprintf(stderr, "output: %zu triangles in %zu fragments, %zu bytes (%s)\n", triangles,
               r.map.fragment_count(), r.bytes, r.args.format.c_str());
  if (r.args.format == "compact")
    std::fprintf(stderr,
                 "compact: %llu vertices, %llu triangles (%llu T-junctions inserted, %llu "
                 "dropped on the grid), before zstd: vertices %llu, indices %llu, ids %llu, "
                 "shades %llu bytes\n",
                 static_cast<unsigned long long>(r.cs.vertices),
                 static_cast<unsigned long long>(r.cs.triangles),
                 static_cast<unsigned long long>(r.cs.t_junctions),
                 static_cast<unsigned long long>(r.cs.dropped),
                 static_cast<unsigned long long>(r.cs.vertex_bytes),
                 static_cast<unsigned long long>(r.cs.index_bytes),
                 static_cast<unsigned long long>(r.cs.id_bytes),
                 static_cast<unsigned long long>(r.cs.shade_bytes));
  if (r.line_set) {
    std::fprintf(stderr, "lines: %zu chains;", r.line_set->chain_count());
    for (size_t k = 0; k < kLineKinds; ++k)
      std::fprintf(stderr, " %s %llu", line_kind_name(LineKind(k)),
                   static_cast<unsigned long long>(r.line_set->edges[k]));
    std::fprintf(stderr, " map edges;");
    if (r.args.lines.hidden)
      for (size_t k = 0; k < kLineKinds; ++k)
        std::fprintf(stderr, " hidden %s %llu", line_kind_name(LineKind(k)),
                     static_cast<unsigned long long>(r.line_set->hidden_edges[k]));
    std::fprintf(stderr, " %.1f ms\n", r.lines_ms);
  }
}

void print_render_stats(const RenderReport& r) {
  print_stage_table(r);
  print_surface_stats(r);
  print_frame_stats(r);
  print_output_stats(r);
  std::fprintf(stderr, "time: load %.1f ms, render %.1f ms, write %.1f ms, total %.1f ms\n",
               r.load_ms, r.render_ms, r.write_ms, r.total_ms);
}

int run_render(RenderArgs& a, std::chrono::steady_clock::time_point t0);

int cmd_render(int argc, char** argv) {
  const auto t0 = std::chrono::steady_clock::now();
  RenderArgs a = parse_render(argc, argv);
  return naming_scene(a.scene, [&] { return run_render(a, t0); });
}

int run_render(RenderArgs& a, std::chrono::steady_clock::time_point t0) {
  using Clock = std::chrono::steady_clock;
  // An expression in x and y alone is MPR's 2D mode; one that uses z is a 3D object.
  if (is_sexp(a.scene)) {
    const implicit::Tape tape = implicit::load(a.scene);
    if (!implicit::uses_z(tape)) return render_implicit_2d(a, tape, t0);
  }
  if (a.bounds) throw UsageError("--bounds: the window of a 2D implicit expression (.sexp)");
  LoadOptions lo;
  lo.time_limit_s = a.time_limit_s;  // an implicit object's bounds search, too
  Scene scene = load_scene(a.scene, lo);
  print_load_warnings(scene);
  auto t_load = Clock::now();
  Camera cam = make_camera(scene, a.view);
  Renderer renderer(a.view.device);
  TessellateStats ts;
  scene = dice_for_view(renderer, std::move(scene), cam, a.view, &ts, a.memory_budget,
                        a.time_limit_s);
  RenderOptions opts;
  opts.attributes = a.format == "bin";
  opts.memory_budget = a.memory_budget;
  opts.time_limit_s = a.time_limit_s;
  opts.cull = a.cull;
  if (a.facts) opts.facts = RenderOptions::Facts::Now;
  bool tty = ::isatty(2);
  if (tty) {
    opts.progress = [t0, shown = false](double f) mutable {
      if (std::chrono::duration<double>(Clock::now() - t0).count() < 1.0) return;
      std::fprintf(stderr, "\rvismap: rendering %3.0f%%", f * 100);
      shown = true;
    };
  }
  const bool lines = a.style != "fill";
  opts.keep_screen_triangles = lines;
  RenderStats st;
  ScreenTriangles screen;
  PlanarMap map = renderer.render(scene, cam, opts, &st, lines ? &screen : nullptr);
  auto t_render = Clock::now();
  LineSet line_set;
  if (lines) {
    line_set = extract_lines(map, screen, scene, cam, a.lines);
    a.svg.lines = &line_set;
  }
  auto t_lines = Clock::now();
  if (a.memory_budget && st.peak_device_bytes > a.memory_budget)
    std::fprintf(
        stderr,
        "vismap: warning: device memory peaked at %.1f MB, over the budget of %.1f MB "
        "(a part of the screen holds more than the budget allows; see --memory-budget in "
        "README.md)\n",
        st.peak_device_bytes / 1e6, a.memory_budget / 1e6);
  CompactStats cs;
  std::string bytes;
  if (a.format == "bin") {
    bytes = lines ? write_bin(map, scene, &line_set, a.style != "lines") : write_bin(map, scene);
  } else if (a.format == "compact") {
    CompactOptions co;
    co.quantum = a.quantum;
    co.shade = a.fill == "shade";
    co.compression = a.compression == "deflate" ? Compression::Deflate : Compression::Zstd;
    bytes = write_compact(map, scene, cam, co, &cs);
  } else {
    const Fill fill = a.fill == "id" ? Fill::Id : Fill::Shade;
    if (a.format == "svg")
      bytes = write_svg(map, scene, cam, fill, a.svg);
    else
      bytes = write_cairo(map, scene, cam, fill, a.svg,
                          a.format == "pdf"   ? CairoFormat::Pdf
                          : a.format == "eps" ? CairoFormat::Eps
                                              : CairoFormat::Png);
  }
  write_atomically(a.out, bytes);
  auto t_end = Clock::now();
  if (tty && std::chrono::duration<double>(t_render - t0).count() >= 1.0)
    std::fprintf(stderr, "\r%30s\r", "");
  if (a.stats) {
    auto ms = [](auto d) { return std::chrono::duration<double, std::milli>(d).count(); };
    RenderReport r{a, renderer.device(), st, ts, map, cs, lines ? &line_set : nullptr};
    r.dropped_degenerate = scene.dropped_degenerate;
    r.bytes = bytes.size();
    r.load_ms = ms(t_load - t0);
    r.render_ms = ms(t_render - t_load);
    r.lines_ms = ms(t_lines - t_render);
    r.write_ms = ms(t_end - t_render);
    r.total_ms = ms(t_end - t0);
    print_render_stats(r);
  }
  return 0;
}

int cmd_devices() {
  std::vector<DeviceInfo> devs = list_devices();
  if (devs.empty()) {
    std::fprintf(stderr, "vismap: no OpenCL devices found (is pocl-opencl-icd installed?)\n");
    return 1;
  }
  for (const DeviceInfo& d : devs)
    std::printf("%s  %-4s %s / %s (%s)\n", d.id.c_str(), d.is_gpu ? "gpu" : "cpu",
                d.platform.c_str(), d.name.c_str(), d.version.c_str());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  keep_freed_memory_for_reuse();
  if (argc < 2) {
    std::fputs(usage("").c_str(), stderr);
    return 2;
  }
  std::string cmd = argv[1];
  if (cmd == "-h" || cmd == "--help" || cmd == "help") {
    std::fputs(usage(argc > 2 && cmd == "help" ? argv[2] : "").c_str(), stdout);
    return 0;
  }
  if (cmd == "--version") {
    std::printf("vismap %s\n", VISMAP_VERSION);  // CMake's project(VERSION)
    return 0;
  }
  bool known = cmd == "render" || cmd == "check" || cmd == "decode" || cmd == "devices";
  if (known && asks_help(argc, argv)) {
    std::fputs(usage(cmd).c_str(), stdout);
    return 0;
  }
  try {
    if (cmd == "render") return cmd_render(argc, argv);
    if (cmd == "check") return cmd_check(argc, argv);
    if (cmd == "decode") return cmd_decode(argc, argv);
    if (cmd == "devices") return cmd_devices();
    throw UsageError("unknown command '" + cmd + "'");
  } catch (const UsageError& e) {  // one line; the usage is one --help away
    std::fprintf(stderr, "vismap: %s (see 'vismap %s--help')\n", e.what(),
                 known ? (cmd + " ").c_str() : "");
    return 2;
  } catch (const InputError& e) {
    std::fprintf(stderr, "vismap: %s\n", e.what());
    return 1;
  } catch (const DeviceError& e) {
    std::fprintf(stderr, "vismap: device error: %s\n", e.what());
    return 3;
  } catch (const std::bad_alloc&) {  // what no count foresaw (an address-space cap): too large
    std::fprintf(stderr,
                 "vismap: out of memory: too large for the memory this process may use "
                 "(see --memory-budget)\n");
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "vismap: %s\n", e.what());
    return 1;
  }
}
