// Writes a delta stream (proto/DELTA.md) of an orbit, one file per frame, for the clients' delta
// decoders to check against `vismap decode FRAME... --json` (clients/python/tests/test_delta.py,
// clients/js/test_delta.mjs). Frame i: the framing camera turned by `step` degrees about +Y, as
// tests/test_stream_delta.cpp's orbit.
//   vismap_delta_orbit SCENE OUTDIR [--frames N] [--width W] [--height H] [--quantum Q]
//                      [--compression zstd|deflate] [--step DEG] [--keyframe-every K]
//                      [--version 1|2] [--held 0|1]
// writes OUTDIR/delta_000.vmd ... (version 2 with --held 1: OUTDIR/sources.vmd first, the held
// scene's message) and prints one line per frame (bytes, how coded, polygons, corners). Version
// 1 unless asked: the clients' version 1 tests use it.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <string>

#include "core/error.h"
#include "core/pipeline.h"
#include "core/scene.h"
#include "core/stream/delta.h"

using namespace vismap;

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr,
                 "usage: vismap_delta_orbit SCENE OUTDIR [--frames N] [--width W] [--height H] "
                 "[--quantum Q] [--compression zstd|deflate] [--step DEG] [--keyframe-every K] "
                 "[--version 1|2] [--held 0|1] [--level L]\n");
    return 2;
  }
  int frames = 4;
  uint32_t width = 1920, height = 1080;
  double step = 6;
  DeltaOptions opt;
  opt.version = 1;
  for (int i = 3; i + 1 < argc; i += 2) {
    const std::string a = argv[i], v = argv[i + 1];
    if (a == "--frames")
      frames = std::atoi(v.c_str());
    else if (a == "--width")
      width = uint32_t(std::atoi(v.c_str()));
    else if (a == "--height")
      height = uint32_t(std::atoi(v.c_str()));
    else if (a == "--quantum")
      opt.quantum = uint32_t(std::atoi(v.c_str()));
    else if (a == "--held")
      opt.client_holds_scene = v == "1";
    else if (a == "--version")
      opt.version = uint32_t(std::atoi(v.c_str()));
    else if (a == "--step")
      step = std::atof(v.c_str());
    else if (a == "--level")  // the entropy coder's level (0: its default)
      opt.level = std::atoi(v.c_str());
    else if (a == "--keyframe-every")
      opt.keyframe_every = uint32_t(std::atoi(v.c_str()));
    else if (a == "--compression" && (v == "zstd" || v == "deflate"))
      opt.compression = v == "zstd" ? Compression::Zstd : Compression::Deflate;
    else {
      std::fprintf(stderr, "vismap_delta_orbit: unknown option %s %s\n", a.c_str(), v.c_str());
      return 2;
    }
  }
  try {
    const Scene s = load_scene(argv[1]);
    Renderer renderer;
    DeltaEncoder enc(s, opt);
    if (opt.client_holds_scene && opt.version >= 2)
      std::ofstream(std::string(argv[2]) + "/sources.vmd", std::ios::binary)
          << encode_delta_sources(s, opt.compression);
    for (int i = 0; i < frames; ++i) {
      Camera c = frame_scene(s, width, height);
      const double a = i * step * M_PI / 180;
      const Vec3 d{c.eye[0] - c.target[0], c.eye[1] - c.target[1], c.eye[2] - c.target[2]};
      c.eye = {c.target[0] + std::cos(a) * d[0] + std::sin(a) * d[2], c.target[1] + d[1],
               c.target[2] - std::sin(a) * d[0] + std::cos(a) * d[2]};
      c.near_plane = c.far_plane = 0;
      fit_near_far(c, s);
      RenderOptions o;
      o.keep_screen_triangles = true;
      ScreenTriangles screen;
      const PlanarMap map = renderer.render(s, c, o, nullptr, &screen);
      DeltaStats st;
      const std::string bytes = enc.encode(map, screen, c, &st);
      char name[32];
      std::snprintf(name, sizeof name, "/delta_%03d.vmd", i);
      std::ofstream(std::string(argv[2]) + name, std::ios::binary) << bytes;
      std::printf(
          "%s: %zu bytes (%s; delta %llu, compact %llu), flips %llu, edge refs %llu, whole %llu, "
          "polygons %llu, corners %llu, points %llu\n",
          name + 1, bytes.size(),
          st.coding == DeltaCoding::Compact ? "compact"
          : st.keyframe                     ? "keyframe"
                                            : "delta",
          (unsigned long long)st.delta_bytes, (unsigned long long)st.compact_bytes,
          (unsigned long long)st.flips, (unsigned long long)st.edge_refs,
          (unsigned long long)st.whole, (unsigned long long)st.partial,
          (unsigned long long)st.partial_corners, (unsigned long long)st.points);
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "vismap_delta_orbit: %s\n", e.what());
    return 1;
  }
  return 0;
}
