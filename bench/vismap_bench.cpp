// vismap_bench: renders one scene N times in one process and prints one JSON object per line
// with medians of the warm runs, so that first-run costs (OpenCL context, program build or cache
// load, PoCL's per-kernel JIT on first launch, scene upload) are reported apart from the steady
// state. Used by bench/run.sh; not a test (benchmarks measure, tests do not time things).
//
//   vismap_bench SCENE [--width W] [--height H] [--runs N] [--tile-pixels 0,16,32,...]
//                [--camera auto|bench|frame] [--device NAME] [--writes N] [--budget-s S]
//                [--no-cull] [--no-facts]
//
// The scene's facts (core/facts/scene_facts.h: the crossing search skips pairs far apart in 3D)
// are found before the first render, their time reported as facts_ms; --no-facts renders without.
// --budget-s: stop a setting's warm runs once they have taken S seconds (at least one run), and
// skip the extra render for the binary writer's size when one render takes more than S/4: slow
// scenes stay affordable on a shared machine.
// --camera auto: the scene file's camera if it has one, else the benchmark camera.
// The benchmark camera (issue 5): perspective, 35 degree vertical fov, up +Y, looking at the
// bounding-box centre from centre + 25 * (diag / 14.6) * normalize(0.6, 0.35, 1), near/far fitted
// to the bounds. --camera frame: core/camera.h's frame_scene (slightly farther: 1.746 vs 1.712
// diagonals). The line's "cli_camera" gives the same camera as `vismap render` flags.
#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "core/camera.h"
#include "core/error.h"
#include "core/facts/scene_facts.h"
#include "core/pipeline.h"
#include "core/scene.h"
#include "core/write/output.h"

namespace {

using namespace vismap;
using Clock = std::chrono::steady_clock;

double ms_between(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double, std::milli>(b - a).count();
}

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

double peak_rss_mb() {
  rusage ru{};
  getrusage(RUSAGE_SELF, &ru);
  return ru.ru_maxrss / 1024.0;  // kilobytes on Linux
}

std::string fmt(double v) {
  char b[64];
  std::snprintf(b, sizeof b, "%.17g", v);
  return b;
}

std::string vec_flag(const Vec3& v) {
  return fmt(v[0]) + "," + fmt(v[1]) + "," + fmt(v[2]);
}

std::string json_string(const std::string& s) {
  std::string o = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') o += '\\';
    if (static_cast<unsigned char>(c) < 0x20) continue;
    o += c;
  }
  return o + "\"";
}

Camera bench_camera(const Scene& scene, uint32_t w, uint32_t h) {
  Bounds b = scene_bounds(scene);
  Vec3 c{0.5 * (b.lo[0] + b.hi[0]), 0.5 * (b.lo[1] + b.hi[1]), 0.5 * (b.lo[2] + b.hi[2])};
  double dx = b.hi[0] - b.lo[0], dy = b.hi[1] - b.lo[1], dz = b.hi[2] - b.lo[2];
  double diag = std::sqrt(dx * dx + dy * dy + dz * dz);
  double n = std::sqrt(0.6 * 0.6 + 0.35 * 0.35 + 1.0);
  double d = 25.0 * (diag / 14.6);
  Camera cam;
  cam.projection = Camera::Projection::Perspective;
  cam.fov_y_deg = 35.0;
  cam.target = c;
  cam.eye = {c[0] + d * 0.6 / n, c[1] + d * 0.35 / n, c[2] + d * 1.0 / n};
  cam.up = {0, 1, 0};
  cam.width = w;
  cam.height = h;
  cam.near_plane = cam.far_plane = 0;  // as `vismap render` does after --eye/--target
  fit_near_far(cam, scene);
  return cam;
}

std::vector<uint32_t> parse_list(const std::string& s) {
  std::vector<uint32_t> v;
  std::stringstream ss(s);
  std::string item;
  while (std::getline(ss, item, ',')) v.push_back(static_cast<uint32_t>(std::stoul(item)));
  return v;
}

struct Args {
  std::string scene, camera = "auto", device;
  uint32_t width = 1024, height = 1024, runs = 5, writes = 3;
  double budget_s = 1e9;
  bool width_set = false;
  bool cull = true;  // --no-cull: RenderOptions::cull off (the frame before issue 32's culling)
  bool facts = true;  // --no-facts: no scene facts for the crossings (RenderOptions::scene_facts)
  std::vector<uint32_t> tiles{0};
};

int usage() {
  std::fputs(
      "usage: vismap_bench SCENE [--width W] [--height H] [--runs N] [--tile-pixels 0,16,...]\n"
      "                    [--camera auto|bench|frame] [--device NAME] [--writes N] [--budget-s "
      "S]\n",
      stderr);
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  vismap::keep_freed_memory_for_reuse();
  Args a;
  for (int i = 1; i < argc; ++i) {
    std::string f = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) {
        std::fprintf(stderr, "vismap_bench: %s needs a value\n", f.c_str());
        std::exit(2);
      }
      return argv[++i];
    };
    try {
      if (f == "--width")
        a.width = std::stoul(value()), a.width_set = true;
      else if (f == "--height")
        a.height = std::stoul(value());
      else if (f == "--runs")
        a.runs = std::max<uint32_t>(1, std::stoul(value()));
      else if (f == "--writes")
        a.writes = std::stoul(value());
      else if (f == "--budget-s")
        a.budget_s = std::stod(value());
      else if (f == "--tile-pixels")
        a.tiles = parse_list(value());
      else if (f == "--camera")
        a.camera = value();
      else if (f == "--device")
        a.device = value();
      else if (f == "--no-cull")
        a.cull = false;
      else if (f == "--no-facts")
        a.facts = false;
      else if (!f.empty() && f[0] == '-')
        return usage();
      else
        a.scene = f;
    } catch (const std::exception&) {
      return usage();
    }
  }
  if (a.scene.empty() || a.tiles.empty()) return usage();
  if (a.camera != "auto" && a.camera != "bench" && a.camera != "frame") return usage();

  try {
    auto t0 = Clock::now();
    Scene scene = load_scene(a.scene);
    auto t1 = Clock::now();
    Renderer renderer(a.device);  // context + program (built, or loaded from the disk cache)
    auto t2 = Clock::now();

    Camera cam;
    std::string cli_camera;
    if (a.camera == "auto" && scene.camera) {
      cam = *scene.camera;
      if (a.width_set) cam.width = a.width, cam.height = a.height;
      fit_near_far(cam, scene);
      cli_camera = "";
    } else if (a.camera == "frame") {
      cam = frame_scene(scene, a.width, a.height);
    } else {
      cam = bench_camera(scene, a.width, a.height);
      cli_camera = "--eye " + vec_flag(cam.eye) + " --target " + vec_flag(cam.target) +
                   " --up 0,1,0 --fov-y 35";
    }
    cam.validate();

    // First render: pays the upload and PoCL's kernel JIT.
    RenderOptions first_opts;
    first_opts.tile_pixels = a.tiles[0];
    first_opts.cull = a.cull;
    // The scene's facts (found once per scene, as a server finds them for a session's scene)
    // before the first render, so that the warm runs are the steady state; their time is
    // facts_ms.
    double facts_ms = 0;
    if (a.facts && facts::scene_facts_fit(scene.triangle_count(), 0)) {
      const auto tf = Clock::now();
      first_opts.scene_facts =
          std::make_shared<const facts::SceneFacts>(facts::find_scene_facts(scene));
      facts_ms = ms_between(tf, Clock::now());
    }
    RenderStats first;
    auto t3 = Clock::now();
    (void)renderer.render(scene, cam, first_opts, &first);
    first.facts_ms = facts_ms;
    auto t4 = Clock::now();
    const double first_ms = ms_between(t3, t4);
    const double upload_ms = first.upload_ms;

    for (uint32_t tile : a.tiles) {
      RenderOptions opts;
      opts.tile_pixels = tile;
      opts.cull = a.cull;
      opts.scene_facts = first_opts.scene_facts;
      std::vector<double> pipe, kernels, host;
      std::map<std::string, std::vector<double>> stage_ms, kernel_ms;
      std::vector<std::string> stage_order;
      RenderStats st;
      PlanarMap map;
      const auto warm0 = Clock::now();
      for (uint32_t r = 0; r < a.runs; ++r) {
        if (r > 0 && ms_between(warm0, Clock::now()) > a.budget_s * 1000) break;
        map = renderer.render(scene, cam, opts, &st);
        double sum = 0;
        for (const StageStat& s : st.stages) {
          if (r == 0) stage_order.push_back(s.name);
          stage_ms[s.name].push_back(s.ms);
          sum += s.ms;
        }
        for (const StageStat& k : st.kernels) kernel_ms[k.name].push_back(k.ms);
        pipe.push_back(st.pipeline_ms);
        kernels.push_back(sum);
        host.push_back(st.pipeline_ms - sum);
      }
      // Writers: median of a few, on the last map (the output is the same every run).
      std::vector<double> svg_ms, bin_ms;
      size_t svg_bytes = 0, bin_bytes = 0;
      const bool slow = median(pipe) > a.budget_s * 250;
      for (uint32_t w = 0; w < (slow ? 1 : a.writes); ++w) {
        auto s0 = Clock::now();
        std::string svg = write_svg(map, scene, cam, Fill::Shade);
        auto s1 = Clock::now();
        svg_ms.push_back(ms_between(s0, s1));
        svg_bytes = svg.size();
      }
      if (!slow) {
        // The binary writer wants barycentrics (as `vismap render --format bin`): one more render.
        RenderOptions bopts = opts;
        bopts.attributes = true;
        RenderStats bst;
        PlanarMap bmap = renderer.render(scene, cam, bopts, &bst);
        for (uint32_t w = 0; w < std::max<uint32_t>(a.writes, 1); ++w) {
          auto s0 = Clock::now();
          std::string bin = write_bin(bmap, scene);
          auto s1 = Clock::now();
          bin_ms.push_back(ms_between(s0, s1));
          bin_bytes = bin.size();
        }
      }
      // The floor (issue 5): a plain z-buffer id raster of the same scene on the same device, as
      // many runs as the pipeline had (its first run pays the raster kernels' JIT: not counted).
      std::vector<double> zb_ms, zb_kernels;
      renderer.raster_ids(scene, cam);
      for (size_t r = 0; r < pipe.size(); ++r) {
        RasterStats rs = renderer.raster_ids(scene, cam);
        zb_ms.push_back(rs.ms);
        zb_kernels.push_back(rs.kernels_ms);
      }
      uint64_t out_tris = 0;
      for (size_t f = 0; f < map.fragment_count(); ++f)
        out_tris += map.offsets[f + 1] - map.offsets[f] - 2;
      const uint32_t eff_tile =
          std::max<uint32_t>(st.tile_pixels, 1);  // the pipeline's choice when tile is 0
      const uint64_t bins = uint64_t((cam.width + eff_tile - 1) / eff_tile) *
                            ((cam.height + eff_tile - 1) / eff_tile);

      std::string o = "{";
      auto kv = [&](const std::string& k, const std::string& v) {
        if (o.size() > 1) o += ",";
        o += json_string(k) + ":" + v;
      };
      auto num = [&](const std::string& k, double v) { kv(k, fmt(v)); };
      kv("scene", json_string(a.scene));
      kv("device", json_string(renderer.device().platform + " / " + renderer.device().name));
      num("meshes", double(scene.meshes.size()));
      num("triangles", double(st.input_triangles));
      num("width", cam.width);
      num("height", cam.height);
      num("tile_pixels", tile);
      num("tile_pixels_effective", eff_tile);
      num("bins", double(bins));
      num("runs", double(pipe.size()));
      num("load_ms", ms_between(t0, t1));
      num("init_ms", ms_between(t1, t2));
      num("first_render_ms", first_ms);
      num("upload_ms", upload_ms);
      num("pipeline_ms", median(pipe));
      num("pipeline_min_ms", *std::min_element(pipe.begin(), pipe.end()));
      num("pipeline_max_ms", *std::max_element(pipe.begin(), pipe.end()));
      num("kernels_ms", median(kernels));
      num("host_ms", median(host));
      std::string stages = "{";
      for (const std::string& n : stage_order) {
        if (stages.size() > 1) stages += ",";
        stages += json_string(n) + ":" + fmt(median(stage_ms[n]));
      }
      kv("stages", stages + "}");
      std::string ks = "{";  // per kernel, medians (a kernel missing from a run counts 0 there)
      for (auto& [n, v] : kernel_ms) {
        v.resize(pipe.size(), 0.0);
        if (ks.size() > 1) ks += ",";
        ks += json_string(n) + ":" + fmt(median(v));
      }
      kv("kernels", ks + "}");
      num("triangles_per_s", st.input_triangles / (median(pipe) / 1000.0));
      num("screen_triangles", double(st.screen_triangles));
      num("silhouette_edges", double(st.silhouette_edges));
      num("crossing_lines", double(st.crossing_lines));
      num("fragments", double(st.fragments));
      num("visible_fragments", double(st.visible_fragments));
      num("sliver_fragments", double(st.sliver_fragments));
      num("culled_triangles", double(st.culled_triangles));
      num("dropped_fragments", double(st.dropped_fragments));
      num("cull", a.cull ? 1 : 0);
      num("facts", st.apart_need > 0 ? 1 : 0);  // the crossing search used scene facts
      num("facts_ms", first.facts_ms);
      num("facts_isolated", double(first.facts_isolated));
      num("apart_need", st.apart_need);
      num("clip_rounds", st.clip_rounds);
      num("host_syncs", st.host_syncs);
      num("launches", st.launches);
      num("device_bytes", double(st.device_bytes));
      num("transfer_bytes", double(st.transfer_bytes));
      num("gpu_floor_ms", modelled_gpu_floor_ms(st));
      {
        std::string c = "{";  // per stage: [launches, blocking reads, bytes moved]
        for (const StageStat& ss : st.stages) {
          if (c.size() > 1) c += ",";
          c += json_string(ss.name) + ":[" + fmt(ss.launches) + "," + fmt(ss.host_syncs) + "," +
               fmt(double(ss.device_bytes + ss.transfer_bytes)) + "]";
        }
        kv("stage_counts", c + "}");
      }
      num("output_fragments", double(map.fragment_count()));
      num("output_triangles", double(out_tris));
      num("peak_device_bytes", double(st.peak_device_bytes));
      num("zbuffer_ms", median(zb_ms));
      num("zbuffer_kernels_ms", median(zb_kernels));
      num("zbuffer_ratio", median(pipe) / std::max(median(zb_ms), 1e-9));
      num("svg_bytes", double(svg_bytes));
      num("svg_ms", median(svg_ms));
      if (!bin_ms.empty()) {
        num("bin_bytes", double(bin_bytes));
        num("bin_ms", median(bin_ms));
      }
      num("peak_rss_mb", peak_rss_mb());
      kv("cli_camera", json_string(cli_camera));
      o += "}";
      std::printf("%s\n", o.c_str());
      std::fflush(stdout);
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "vismap_bench: %s\n", e.what());
    return 1;
  }
  return 0;
}
