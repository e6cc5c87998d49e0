// Camera matrices (gluLookAt, gluPerspective, glOrtho), validation, and scene framing.
#include "core/camera.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "core/error.h"
#include "core/util/vec3.h"
#include "kernels/layout.h"

namespace vismap {

static_assert(kMaxViewport == VM_MAX_VIEWPORT, "core/camera.h and kernels/layout.h agree");

namespace {

constexpr double kPi = 3.14159265358979323846;

using vec3::add;
using vec3::cross;
using vec3::dot;
using vec3::length;
using vec3::scale;
using vec3::sub;
Vec3 normalize(const Vec3& a) {
  return scale(a, 1.0 / length(a));
}
bool finite(const Vec3& a) {
  return std::isfinite(a[0]) && std::isfinite(a[1]) && std::isfinite(a[2]);
}

// Element (row r, column c) of a column-major matrix.
double& at(Mat4& m, int r, int c) {
  return m[c * 4 + r];
}

Mat4 identity() {
  Mat4 m{};
  m[0] = m[5] = m[10] = m[15] = 1.0;
  return m;
}


[[noreturn]] void bad_camera(const std::string& msg) {
  throw InputError(InputErrorKind::BadCamera, "", "", "camera", -1, msg);
}

double aspect(const Camera& c) {
  return static_cast<double>(c.width) / static_cast<double>(c.height);
}

// Bounding sphere of the bounds; radius 0 for an empty or single-point scene.
void bounding_sphere(const Bounds& b, Vec3& centre, double& radius) {
  if (b.empty) {
    centre = {0, 0, 0};
    radius = 0;
    return;
  }
  centre = scale(add(b.lo, b.hi), 0.5);
  radius = 0.5 * length(sub(b.hi, b.lo));
}

}  // namespace

Mat4 Camera::view() const {
  // gluLookAt: f = normalize(target - eye), s = normalize(f x up), u = s x f;
  // rows (s, -s.eye), (u, -u.eye), (-f, f.eye), (0, 0, 0, 1).
  const Vec3 f = normalize(sub(target, eye));
  const Vec3 s = normalize(cross(f, up));
  const Vec3 u = cross(s, f);
  Mat4 m = identity();
  for (int i = 0; i < 3; ++i) {
    at(m, 0, i) = s[i];
    at(m, 1, i) = u[i];
    at(m, 2, i) = -f[i];
  }
  at(m, 0, 3) = -dot(s, eye);
  at(m, 1, 3) = -dot(u, eye);
  at(m, 2, 3) = dot(f, eye);
  return m;
}

Mat4 Camera::projection_matrix() const {
  const double a = aspect(*this);
  const double n = near_plane, f = far_plane;
  Mat4 m{};
  if (projection == Projection::Perspective) {
    // gluPerspective: cot(fovy/2) / aspect, cot(fovy/2), (f+n)/(n-f), 2fn/(n-f), w = -z.
    const double cot = 1.0 / std::tan(fov_y_deg * kPi / 360.0);
    at(m, 0, 0) = cot / a;
    at(m, 1, 1) = cot;
    at(m, 2, 2) = (f + n) / (n - f);
    at(m, 2, 3) = 2.0 * f * n / (n - f);
    at(m, 3, 2) = -1.0;
  } else {
    // glOrtho(-h/2*aspect, h/2*aspect, -h/2, h/2, n, f): symmetric, so no x/y translation.
    const double half_h = ortho_height * 0.5;
    const double half_w = half_h * a;
    at(m, 0, 0) = 1.0 / half_w;
    at(m, 1, 1) = 1.0 / half_h;
    at(m, 2, 2) = -2.0 / (f - n);
    at(m, 2, 3) = -(f + n) / (f - n);
    at(m, 3, 3) = 1.0;
  }
  return m;
}

Mat4 Camera::view_projection() const {
  return multiply(projection_matrix(), view());
}

void Camera::validate() const {
  if (!finite(eye) || !finite(target) || !finite(up))
    bad_camera("eye, target and up must be finite");
  if (width == 0 || height == 0 || width > kMaxViewport || height > kMaxViewport)
    bad_camera("viewport " + std::to_string(width) + "x" + std::to_string(height) +
               " must be between 1x1 and " + std::to_string(kMaxViewport) + "x" +
               std::to_string(kMaxViewport));
  const Vec3 d = sub(target, eye);
  const double dl = length(d);
  if (!(dl > 0) || !std::isfinite(dl)) bad_camera("eye and target coincide");
  const double ul = length(up);
  if (!(ul > 0) || !std::isfinite(ul)) bad_camera("up vector is zero");
  // sin of the angle between up and the view direction; below ~1e-9 rad the basis is
  // numerically meaningless (s = f x up loses all its digits).
  if (!(length(cross(scale(d, 1.0 / dl), scale(up, 1.0 / ul))) > 1e-9))
    bad_camera("up vector is parallel to the view direction");
  if (projection == Projection::Perspective) {
    if (!(fov_y_deg > 0.0 && fov_y_deg < 180.0))
      bad_camera("fov_y " + std::to_string(fov_y_deg) + " must be in (0, 180) degrees");
  } else {
    if (!(ortho_height > 0.0) || !std::isfinite(ortho_height))
      bad_camera("ortho_height must be positive and finite");
  }
  if (!std::isfinite(near_plane) || !std::isfinite(far_plane) || !(near_plane > 0.0) ||
      !(near_plane < far_plane))
    bad_camera("near/far must satisfy 0 < near < far (near " + std::to_string(near_plane) +
               ", far " + std::to_string(far_plane) + ")");
}

Camera frame_bounds(const Bounds& b, uint32_t width, uint32_t height) {
  Camera c;
  c.projection = Camera::Projection::Perspective;
  c.width = width;
  c.height = height;
  c.up = {0, 1, 0};
  Vec3 centre;
  double r;
  bounding_sphere(b, centre, r);
  // A point (or empty) scene still needs a non-degenerate camera: any radius works, pick one
  // proportional to the coordinates so that far-from-origin points keep their precision.
  if (!(r > 0) || !std::isfinite(r)) r = std::max(1e-6 * length(centre), 1.0);
  // The sphere fits a cone of half-angle a when d = r / sin(a); take the narrower of the
  // vertical and horizontal half-angles and a 5% margin.
  const double half_v = c.fov_y_deg * kPi / 360.0;
  const double asp = (width > 0 && height > 0) ? double(width) / double(height) : 1.0;
  const double half_h = std::atan(std::tan(half_v) * asp);
  const double half = std::min(half_v, half_h);
  const double margin = 1.05;
  const double d = r * margin / std::sin(half);
  const Vec3 dir = normalize(Vec3{0.6, 0.35, 1.0});
  c.target = centre;
  c.eye = add(centre, scale(dir, d));
  c.far_plane = d + r * margin;
  c.near_plane = std::max(d - r * margin, d * 1e-3);
  return c;
}

void fit_near_far(Camera& c, const Bounds& b) {
  if (c.near_plane > 0 && c.far_plane > 0) return;
  Vec3 centre;
  double r;
  bounding_sphere(b, centre, r);
  const Vec3 view = sub(c.target, c.eye);
  const double vl = length(view);
  // Depth of the sphere's centre along the view direction; the planes are perpendicular to it.
  const double z = vl > 0 ? dot(sub(centre, c.eye), scale(view, 1.0 / vl)) : 0.0;
  const double rr = r * 1.01 + 1e-12 * (std::abs(z) + length(centre));  // margin for rounding
  double far = z + rr;
  if (!(far > 0) || !std::isfinite(far)) {
    // Nothing is in front of the camera: any valid pair renders an empty frame.
    far = std::max({vl, r, 1.0});
  }
  // Keep near positive and the depth range within ~1e4:1 so depth keeps its precision.
  double near = std::max(z - rr, far * 1e-4);
  if (c.far_plane > 0) {
    far = c.far_plane;
    if (!(c.near_plane > 0) && near >= far) near = far * 1e-4;
  }
  if (c.near_plane > 0) {
    near = c.near_plane;
    if (!(c.far_plane > 0) && far <= near) far = near * 2.0;
  }
  c.near_plane = near;
  c.far_plane = far;
}

Mat4 multiply(const Mat4& a, const Mat4& b) {
  Mat4 r{};
  for (int c = 0; c < 4; ++c)
    for (int row = 0; row < 4; ++row) {
      double s = 0;
      for (int k = 0; k < 4; ++k) s += a[k * 4 + row] * b[c * 4 + k];
      r[c * 4 + row] = s;
    }
  return r;
}

}  // namespace vismap
