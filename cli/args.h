// Command-line parsing shared by the CLI's commands: numbers, vectors, and the camera flags that
// `render` and `check` both take.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <stdexcept>
#include <string>

#include "core/camera.h"
#include "core/error.h"
#include "core/frame/frame.h"
#include "core/scene.h"

namespace vismap::cli {

struct UsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// Runs f; an InputError it throws that names no file (the camera's, a dicer's, the frame's)
// names `scene` instead of "<input>" (issue 35).
template <class F>
auto naming_scene(const std::string& scene, F&& f) -> decltype(f()) {
  try {
    return f();
  } catch (const InputError& e) {
    if (!e.file().empty()) throw;
    throw InputError(e.kind(), scene, e.mesh(), e.element(), e.index(), e.detail());
  }
}

// Prints the load's warnings (Scene::warnings) on stderr, one "vismap: warning: " line each.
void print_load_warnings(const Scene& scene);

Vec3 parse_vec3(const std::string& flag, const std::string& s);
double parse_number(const std::string& flag, const std::string& s);
uint32_t parse_pixels(const std::string& flag, const std::string& s);
// A byte count: an integer with an optional K, M or G suffix (powers of 1024), e.g. 512M, 1G.
uint64_t parse_bytes(const std::string& flag, const std::string& s);

// --width --height --eye --target --up --fov-y --ortho --near --far --device --tolerance
// --implicit-tolerance
struct ViewArgs {
  std::optional<uint32_t> width, height;
  std::optional<Vec3> eye, target, up;
  std::optional<double> fov_y, ortho, near_plane, far_plane;
  std::string device;
  double tolerance_px = 0.2;           // curved surfaces: TessellateOptions::tolerance_px
  double implicit_tolerance_px = 4.0;  // TessellateOptions::implicit_tolerance_px
};

// If `flag` is one of the view flags, consumes its value through `value` and returns true.
bool parse_view_flag(const std::string& flag, const std::function<std::string()>& value,
                     ViewArgs& v);
void validate_view(const ViewArgs& v);  // throws UsageError

// If `flag` is one of the line drawing flags that render and check share (--crease-angle
// --min-length --self-folds --crease-smooth on|off), consumes its value through `value` and
// returns true.
bool parse_line_flag(const std::string& flag, const std::function<std::string()>& value,
                     LineOptions& o);

// The camera: the scene's own (or a framing one), then the flags on top.
Camera make_camera(const Scene& scene, const ViewArgs& a);

// Writes through a temporary file in the same folder and renames it: no half-written output.
void write_atomically(const std::string& path, const std::string& bytes);

}  // namespace vismap::cli
