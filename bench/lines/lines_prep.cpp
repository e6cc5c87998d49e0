// For the peer bench (bench/lines/run.sh): prints the camera vismap uses for a scene at W x H as
// explicit flags (--eye --target --up --fov-y --width --height), so every tool gets the same
// view, and with --obj writes the scene's triangles in world space as one OBJ (an object per
// mesh) for Blender, which reads neither OFF, .ply.gz nor our scene files.
//
//   vismap_lines_prep SCENE --width W --height H [--obj OUT.obj]
#include <cstdio>
#include <fstream>
#include <stdexcept>
#include <string>

#include "core/scene.h"

int main(int argc, char** argv) {
  try {
    std::string scene_path, obj;
    uint32_t w = 1024, h = 1024;
    for (int i = 1; i < argc; ++i) {
      const std::string f = argv[i];
      auto value = [&]() -> std::string {
        if (i + 1 >= argc) throw std::runtime_error(f + " needs a value");
        return argv[++i];
      };
      if (f == "--width") w = uint32_t(std::stoul(value()));
      else if (f == "--height") h = uint32_t(std::stoul(value()));
      else if (f == "--obj") obj = value();
      else if (scene_path.empty() && f[0] != '-') scene_path = f;
      else throw std::runtime_error("unknown argument " + f);
    }
    if (scene_path.empty()) throw std::runtime_error("usage: vismap_lines_prep SCENE --width W --height H [--obj OUT.obj]");
    const vismap::Scene s = vismap::load_scene(scene_path);
    // As cli/args.cpp make_camera: the scene's camera, else the framed one.
    vismap::Camera c = s.camera ? *s.camera : vismap::frame_scene(s, w, h);
    if (c.projection != vismap::Camera::Projection::Perspective)
      throw std::runtime_error("the bench needs a perspective camera");
    std::printf("--eye %.17g,%.17g,%.17g --target %.17g,%.17g,%.17g --up %.17g,%.17g,%.17g "
                "--fov-y %.17g --width %u --height %u\n",
                c.eye[0], c.eye[1], c.eye[2], c.target[0], c.target[1], c.target[2], c.up[0],
                c.up[1], c.up[2], c.fov_y_deg, w, h);
    if (!obj.empty()) {
      std::ofstream out(obj, std::ios::binary);
      size_t base = 1;
      char buf[128];
      for (const vismap::Mesh& m : s.meshes) {
        out << "o " << (m.name.empty() ? "mesh" : m.name) << "\n";
        for (size_t v = 0; v < m.vertex_count(); ++v) {
          std::snprintf(buf, sizeof buf, "v %.9g %.9g %.9g\n", m.positions[3 * v],
                        m.positions[3 * v + 1], m.positions[3 * v + 2]);
          out << buf;
        }
        for (size_t t = 0; t < m.triangle_count(); ++t)
          out << "f " << base + m.indices[3 * t] << ' ' << base + m.indices[3 * t + 1] << ' '
              << base + m.indices[3 * t + 2] << "\n";
        base += m.vertex_count();
      }
      if (!out) throw std::runtime_error("cannot write " + obj);
    }
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "lines_prep: %s\n", e.what());
    return 1;
  }
}
