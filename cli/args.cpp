#include "cli/args.h"

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>

namespace vismap::cli {

void print_load_warnings(const Scene& scene) {
  for (const std::string& w : scene.warnings)
    std::fprintf(stderr, "vismap: warning: %s\n", w.c_str());
}

Vec3 parse_vec3(const std::string& flag, const std::string& s) {
  Vec3 v;
  char* end = nullptr;
  const char* p = s.c_str();
  for (int k = 0; k < 3; ++k) {
    v[k] = std::strtod(p, &end);
    if (end == p || !std::isfinite(v[k]))
      throw UsageError(flag + ": expected X,Y,Z, got '" + s + "'");
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
  if (s.empty() || *end || !std::isfinite(v))
    throw UsageError(flag + ": expected a number, got '" + s + "'");
  return v;
}

uint32_t parse_pixels(const std::string& flag, const std::string& s) {
  double v = parse_number(flag, s);
  if (v < 1 || v > kMaxViewport || v != std::floor(v))
    throw UsageError(flag + ": expected an integer in 1.." + std::to_string(kMaxViewport) +
                     ", got '" + s + "'");
  return static_cast<uint32_t>(v);
}

uint64_t parse_bytes(const std::string& flag, const std::string& s) {
  char* end = nullptr;
  double v = std::strtod(s.c_str(), &end);
  double unit = 1;
  std::string suffix = end ? end : "";
  if (suffix == "K" || suffix == "k")
    unit = 1024.0;
  else if (suffix == "M" || suffix == "m")
    unit = 1024.0 * 1024;
  else if (suffix == "G" || suffix == "g")
    unit = 1024.0 * 1024 * 1024;
  else if (!suffix.empty())
    unit = 0;
  v *= unit;
  if (s.empty() || end == s.c_str() || unit == 0 || !std::isfinite(v) || v < 1 || v > 1e18)
    throw UsageError(flag + ": expected a byte count such as 800M or 2G, got '" + s + "'");
  return static_cast<uint64_t>(v);
}

bool parse_line_flag(const std::string& f, const std::function<std::string()>& value,
                     LineOptions& o) {
  if (f == "--crease-angle") {
    o.crease_angle_deg = parse_number(f, value());
    if (!(o.crease_angle_deg >= 0 && o.crease_angle_deg <= 180))
      throw UsageError("--crease-angle: expected 0 ... 180 degrees");
  } else if (f == "--min-length") {
    // PX for every kind, or KIND=PX for one (repeatable).
    const std::string v = value();
    const size_t eq = v.find('=');
    const std::string kind = eq == std::string::npos ? "" : v.substr(0, eq);
    const double px = parse_number(f, eq == std::string::npos ? v : v.substr(eq + 1));
    if (!(px >= 0 && px <= 100000))
      throw UsageError("--min-length: expected 0 ... 100000 pixels, got '" + v + "'");
    bool known = kind.empty();
    for (size_t k = 0; k < kLineKinds; ++k)
      if (kind.empty() || kind == line_kind_name(LineKind(k))) {
        o.min_length_px[k] = px;
        known = true;
      }
    if (!known)
      throw UsageError(
          "--min-length: expected PX or KIND=PX (contour, boundary, crease, "
          "intersection, border), got '" +
          v + "'");
  } else if (f == "--self-folds") {
    o.self_folds = true;
  } else if (f == "--crease-smooth") {
    const std::string v = value();
    if (v != "on" && v != "off") throw UsageError("--crease-smooth: expected on or off");
    o.crease_smooth = v == "on";
  } else {
    return false;
  }
  return true;
}

bool parse_view_flag(const std::string& f, const std::function<std::string()>& value, ViewArgs& a) {
  if (f == "--width")
    a.width = parse_pixels(f, value());
  else if (f == "--height")
    a.height = parse_pixels(f, value());
  else if (f == "--eye")
    a.eye = parse_vec3(f, value());
  else if (f == "--target")
    a.target = parse_vec3(f, value());
  else if (f == "--up")
    a.up = parse_vec3(f, value());
  else if (f == "--fov-y")
    a.fov_y = parse_number(f, value());
  else if (f == "--ortho")
    a.ortho = parse_number(f, value());
  else if (f == "--near")
    a.near_plane = parse_number(f, value());
  else if (f == "--far")
    a.far_plane = parse_number(f, value());
  else if (f == "--device")
    a.device = value();
  else if (f == "--tolerance") {
    a.tolerance_px = parse_number(f, value());
    if (!(a.tolerance_px >= 1e-3 && a.tolerance_px <= 1000))
      throw UsageError("--tolerance: expected 0.001 ... 1000 pixels");
  } else if (f == "--implicit-tolerance") {
    a.implicit_tolerance_px = parse_number(f, value());
    if (!(a.implicit_tolerance_px >= 1e-2 && a.implicit_tolerance_px <= 1000))
      throw UsageError("--implicit-tolerance: expected 0.01 ... 1000 pixels");
  } else
    return false;
  return true;
}

void validate_view(const ViewArgs& a) {
  if (a.fov_y && a.ortho) throw UsageError("--fov-y and --ortho exclude each other");
}

Camera make_camera(const Scene& scene, const ViewArgs& a) {
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

}  // namespace vismap::cli
