// vismap: the command-line front end: usage, and the commands `vismap render` (cli/render.cpp),
// `vismap check` (cli/check.cpp), `vismap decode` (cli/decode.cpp), `vismap devices`.
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
#include "cli/render.h"
#include "core/error.h"
#include "core/pipeline.h"

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
