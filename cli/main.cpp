// vismap: the command-line front end. `vismap render`, `vismap devices`.
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <optional>
#include <string>
#include <vector>

#include "core/camera.h"
#include "core/error.h"
#include "core/output.h"
#include "core/pipeline.h"
#include "core/scene.h"

namespace {

using namespace vismap;

const char* kUsage =
    "usage:\n"
    "  vismap render SCENE -o OUT [--format svg|bin] [--fill shade|id] [--width W --height H]\n"
    "                [--eye X,Y,Z --target X,Y,Z --up X,Y,Z] [--fov-y DEG | --ortho HEIGHT]\n"
    "                [--near N --far F] [--device NAME] [--stats]\n"
    "  vismap devices\n"
    "SCENE: .ply .ply.gz .obj .off .stl .gltf .glb or a .json scene file.\n"
    "--device (or $VISMAP_DEVICE): 'P:D' from `vismap devices`, or part of a device/platform name.\n";

struct UsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

Vec3 parse_vec3(const std::string& flag, const std::string& s) {
  Vec3 v;
  char* end = nullptr;
  const char* p = s.c_str();
  for (int k = 0; k < 3; ++k) {
    v[k] = std::strtod(p, &end);
    if (end == p || !std::isfinite(v[k])) throw UsageError(flag + ": expected X,Y,Z, got '" + s + "'");
    p = end;
    if (k < 2) {
      if (*p != ',') throw UsageError(flag + ": expected X,Y,Z, got '" + s + "'");
      ++p;
    }
  }
  if (*p) throw UsageError(flag + ": expected X,Y,Z, got '" + s + "'");
  return v;
}

double parse_number(const std::string& flag, const std::string& s) {
  char* end = nullptr;
  double v = std::strtod(s.c_str(), &end);
  if (s.empty() || *end || !std::isfinite(v)) throw UsageError(flag + ": expected a number, got '" + s + "'");
  return v;
}

uint32_t parse_pixels(const std::string& flag, const std::string& s) {
  double v = parse_number(flag, s);
  if (v < 1 || v > 16384 || v != std::floor(v))
    throw UsageError(flag + ": expected an integer in 1..16384, got '" + s + "'");
  return static_cast<uint32_t>(v);
}

struct RenderArgs {
  std::string scene, out, format = "svg", fill = "shade", device;
  std::optional<uint32_t> width, height;
  std::optional<Vec3> eye, target, up;
  std::optional<double> fov_y, ortho, near_plane, far_plane;
  bool stats = false;
};

RenderArgs parse_render(int argc, char** argv) {
  RenderArgs a;
  for (int i = 2; i < argc; ++i) {
    std::string f = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) throw UsageError(f + " needs a value");
      return argv[++i];
    };
    if (f == "-o" || f == "--output") a.out = value();
    else if (f == "--format") a.format = value();
    else if (f == "--fill") a.fill = value();
    else if (f == "--width") a.width = parse_pixels(f, value());
    else if (f == "--height") a.height = parse_pixels(f, value());
    else if (f == "--eye") a.eye = parse_vec3(f, value());
    else if (f == "--target") a.target = parse_vec3(f, value());
    else if (f == "--up") a.up = parse_vec3(f, value());
    else if (f == "--fov-y") a.fov_y = parse_number(f, value());
    else if (f == "--ortho") a.ortho = parse_number(f, value());
    else if (f == "--near") a.near_plane = parse_number(f, value());
    else if (f == "--far") a.far_plane = parse_number(f, value());
    else if (f == "--device") a.device = value();
    else if (f == "--stats") a.stats = true;
    else if (!f.empty() && f[0] == '-') throw UsageError("unknown option " + f);
    else if (a.scene.empty()) a.scene = f;
    else throw UsageError("unexpected argument " + f);
  }
  if (a.scene.empty()) throw UsageError("render: missing SCENE");
  if (a.out.empty()) throw UsageError("render: missing -o OUT");
  if (a.format != "svg" && a.format != "bin") throw UsageError("--format: expected svg or bin");
  if (a.fill != "shade" && a.fill != "id") throw UsageError("--fill: expected shade or id");
  if (a.fov_y && a.ortho) throw UsageError("--fov-y and --ortho exclude each other");
  return a;
}

Camera make_camera(const Scene& scene, const RenderArgs& a) {
  uint32_t w = a.width.value_or(scene.camera ? scene.camera->width : 1024);
  uint32_t h = a.height.value_or(scene.camera ? scene.camera->height : 1024);
  if (a.width && !a.height && !scene.camera) h = w;
  if (a.height && !a.width && !scene.camera) w = h;
  Camera c = scene.camera ? *scene.camera : frame_scene(scene, w, h);
  c.width = w;
  c.height = h;
  bool moved = a.eye || a.target || a.up || a.ortho || a.fov_y;
  if (a.eye) c.eye = *a.eye;
  if (a.target) c.target = *a.target;
  if (a.up) c.up = *a.up;
  if (a.fov_y) {
    c.projection = Camera::Projection::Perspective;
    c.fov_y_deg = *a.fov_y;
  }
  if (a.ortho) {
    c.projection = Camera::Projection::Orthographic;
    c.ortho_height = *a.ortho;
  }
  if (moved && !scene.camera) {  // the framed near/far belonged to the framed view
    c.near_plane = 0;
    c.far_plane = 0;
  }
  if (a.near_plane) c.near_plane = *a.near_plane;
  if (a.far_plane) c.far_plane = *a.far_plane;
  fit_near_far(c, scene);
  c.validate();
  return c;
}

// Writes through a temporary file in the same folder and renames it: no half-written output.
void write_atomically(const std::string& path, const std::string& bytes) {
  std::filesystem::path p(path);
  std::filesystem::path tmp = p;
  tmp += ".tmp." + std::to_string(::getpid());
  {
    std::ofstream out(tmp, std::ios::binary);
    if (!out) throw std::runtime_error(path + ": cannot open for writing");
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    out.flush();
    if (!out) {
      out.close();
      std::filesystem::remove(tmp);
      throw std::runtime_error(path + ": write failed");
    }
  }
  std::error_code ec;
  std::filesystem::rename(tmp, p, ec);
  if (ec) {
    std::filesystem::remove(tmp);
    throw std::runtime_error(path + ": " + ec.message());
  }
}

int cmd_render(int argc, char** argv) {
  using Clock = std::chrono::steady_clock;
  auto t0 = Clock::now();
  RenderArgs a = parse_render(argc, argv);
  Scene scene = load_scene(a.scene);
  auto t_load = Clock::now();
  Camera cam = make_camera(scene, a);
  Renderer renderer(a.device);
  RenderOptions opts;
  opts.attributes = a.format == "bin";
  bool tty = ::isatty(2);
  if (tty) {
    opts.progress = [t0, shown = false](double f) mutable {
      if (std::chrono::duration<double>(Clock::now() - t0).count() < 1.0) return;
      std::fprintf(stderr, "\rvismap: rendering %3.0f%%", f * 100);
      shown = true;
    };
  }
  RenderStats st;
  PlanarMap map = renderer.render(scene, cam, opts, &st);
  auto t_render = Clock::now();
  std::string bytes = a.format == "bin" ? write_bin(map, scene)
                                        : write_svg(map, scene, cam, a.fill == "id" ? Fill::Id : Fill::Shade);
  write_atomically(a.out, bytes);
  auto t_end = Clock::now();
  if (tty && std::chrono::duration<double>(t_render - t0).count() >= 1.0) std::fprintf(stderr, "\r%30s\r", "");
  if (a.stats) {
    auto ms = [](auto d) { return std::chrono::duration<double, std::milli>(d).count(); };
    uint64_t out_tris = 0;
    for (size_t f = 0; f < map.fragment_count(); ++f) out_tris += map.offsets[f + 1] - map.offsets[f] - 2;
    std::fprintf(stderr, "device: %s / %s\n", renderer.device().platform.c_str(), renderer.device().name.c_str());
    std::fprintf(stderr, "%-12s %10s %9s %12s %12s\n", "stage", "ms", "launches", "in", "out");
    double sum = 0;
    for (const StageStat& s : st.stages) {
      std::fprintf(stderr, "%-12s %10.2f %9u %12llu %12llu\n", s.name.c_str(), s.ms, s.launches,
                   static_cast<unsigned long long>(s.items_in), static_cast<unsigned long long>(s.items_out));
      sum += s.ms;
    }
    std::fprintf(stderr, "%-12s %10.2f   (sum of stage times; pipeline wall %.2f ms, upload %.2f ms)\n",
                 "kernels", sum, st.pipeline_ms, st.upload_ms);
    std::fprintf(stderr, "input triangles %llu (dropped degenerate %llu), screen triangles %llu, silhouette edges %llu\n",
                 static_cast<unsigned long long>(st.input_triangles),
                 static_cast<unsigned long long>(scene.dropped_degenerate),
                 static_cast<unsigned long long>(st.screen_triangles),
                 static_cast<unsigned long long>(st.silhouette_edges));
    std::fprintf(stderr, "fragments %llu, visible %llu, clip rounds %u, device memory %.1f MB\n",
                 static_cast<unsigned long long>(st.fragments),
                 static_cast<unsigned long long>(st.visible_fragments), st.clip_rounds,
                 st.peak_device_bytes / 1e6);
    std::fprintf(stderr, "output: %llu triangles in %zu fragments, %zu bytes (%s)\n",
                 static_cast<unsigned long long>(out_tris), map.fragment_count(), bytes.size(), a.format.c_str());
    std::fprintf(stderr, "time: load %.1f ms, render %.1f ms, write %.1f ms, total %.1f ms\n",
                 ms(t_load - t0), ms(t_render - t_load), ms(t_end - t_render), ms(t_end - t0));
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
    std::printf("%s  %-4s %s / %s (%s)\n", d.id.c_str(), d.is_gpu ? "gpu" : "cpu", d.platform.c_str(),
                d.name.c_str(), d.version.c_str());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2 || !std::strcmp(argv[1], "-h") || !std::strcmp(argv[1], "--help")) {
    std::fputs(kUsage, argc < 2 ? stderr : stdout);
    return argc < 2 ? 2 : 0;
  }
  std::string cmd = argv[1];
  try {
    if (cmd == "render") return cmd_render(argc, argv);
    if (cmd == "devices") return cmd_devices();
    throw UsageError("unknown command '" + cmd + "'");
  } catch (const UsageError& e) {
    std::fprintf(stderr, "vismap: %s\n%s", e.what(), kUsage);
    return 2;
  } catch (const InputError& e) {
    std::fprintf(stderr, "vismap: %s\n", e.what());
    return 1;
  } catch (const DeviceError& e) {
    std::fprintf(stderr, "vismap: device error: %s\n", e.what());
    return 3;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "vismap: %s\n", e.what());
    return 1;
  }
}
