// Camera conventions follow OpenGL: gluLookAt (right-handed world, camera looks down -Z of its
// view space) and gluPerspective (vertical field of view, aspect = width/height) or glOrtho.
// In screen space pixel (0,0) is the top-left corner and y grows downward.
#pragma once

#include <array>
#include <cstdint>
#include <optional>

namespace vismap {

// The widest and tallest viewport a camera may have, in pixels: what validate() accepts, and
// what every reader of a camera (scene files, pbrt, the CLI) checks against.
inline constexpr uint32_t kMaxViewport = 16384;

using Vec3 = std::array<double, 3>;
using Mat4 = std::array<double, 16>;  // column-major, as OpenGL

// a * b (column-major): the one 4x4 product of the camera and the loaders' node transforms.
Mat4 multiply(const Mat4& a, const Mat4& b);

struct Camera {
  enum class Projection { Perspective, Orthographic };
  Projection projection = Projection::Perspective;
  Vec3 eye{0, 0, 1};
  Vec3 target{0, 0, 0};
  Vec3 up{0, 1, 0};
  double fov_y_deg = 35.0;    // perspective: vertical field of view in degrees
  double ortho_height = 2.0;  // orthographic: height of the view volume in world units
  double near_plane = 0.0;    // <= 0: chosen from the scene bounds
  double far_plane = 0.0;     // <= 0: chosen from the scene bounds
  uint32_t width = 1024;      // viewport in pixels
  uint32_t height = 1024;

  Mat4 view() const;               // gluLookAt(eye, target, up)
  Mat4 projection_matrix() const;  // gluPerspective / glOrtho with aspect width/height
  Mat4 view_projection() const;    // projection * view
  // Throws InputError(BadCamera) when eye == target, up is parallel to the view direction,
  // fov is outside (0,180), near/far are not 0 < near < far, or the viewport is empty/too big.
  void validate() const;
};

struct Bounds {
  Vec3 lo{0, 0, 0}, hi{0, 0, 0};
  bool empty = true;
};

// A camera that frames the bounds: looks at their centre from the +Z side along
// normalize(0.6, 0.35, 1) (the benchmark's view direction), distance chosen so the bounding
// sphere fits the vertical and horizontal field of view; near/far from the sphere. For a scene,
// frame_scene (core/scene.h).
Camera frame_bounds(const Bounds& b, uint32_t width, uint32_t height);

// Fills near/far when they are <= 0, from the bounds as seen from the camera.
void fit_near_far(Camera& c, const Bounds& b);

}  // namespace vismap
