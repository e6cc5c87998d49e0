// Camera matrices against hand-computed gluLookAt / gluPerspective / glOrtho values, the
// screen mapping (y down), validation errors and scene framing.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "core/camera.h"
#include "core/error.h"
#include "core/scene.h"

using vismap::Camera;
using vismap::Mat4;
using vismap::Vec3;

namespace {

double el(const Mat4& m, int row, int col) {
  return m[col * 4 + row];
}

void expect_matrix(const Mat4& m, const std::array<double, 16>& rows_major) {
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c)
      EXPECT_NEAR(el(m, r, c), rows_major[r * 4 + c], 1e-12) << "row " << r << " col " << c;
}

// Clip coordinates of a world point.
std::array<double, 4> clip(const Camera& c, const Vec3& p) {
  const Mat4 m = c.view_projection();
  std::array<double, 4> out{};
  for (int r = 0; r < 4; ++r)
    out[r] = el(m, r, 0) * p[0] + el(m, r, 1) * p[1] + el(m, r, 2) * p[2] + el(m, r, 3);
  return out;
}

// Pixel position and NDC depth, with the project's screen mapping (y down).
std::array<double, 3> to_pixel(const Camera& c, const Vec3& p) {
  const auto q = clip(c, p);
  const double x = q[0] / q[3], y = q[1] / q[3], z = q[2] / q[3];
  return {(x + 1) / 2 * c.width, (1 - y) / 2 * c.height, z};
}

Camera good_camera() {
  Camera c;
  c.eye = {0, 0, 5};
  c.target = {0, 0, 0};
  c.up = {0, 1, 0};
  c.fov_y_deg = 90;
  c.near_plane = 1;
  c.far_plane = 10;
  c.width = 100;
  c.height = 100;
  return c;
}

vismap::Scene box_scene(const Vec3& lo, const Vec3& hi) {
  vismap::Mesh m;
  m.name = "box";
  for (int i = 0; i < 8; ++i) {
    m.positions.push_back(float((i & 1) ? hi[0] : lo[0]));
    m.positions.push_back(float((i & 2) ? hi[1] : lo[1]));
    m.positions.push_back(float((i & 4) ? hi[2] : lo[2]));
  }
  // Four triangles that between them use all eight corners.
  m.indices = {0, 1, 2, 3, 4, 5, 6, 7, 0, 7, 3, 4};
  m.face_ids = {0, 1, 2, 3};
  m.source_triangles = 4;
  vismap::Scene s;
  s.meshes.push_back(m);
  return s;
}

void expect_box_in_view(const Camera& c, const vismap::Scene& s) {
  const auto& p = s.meshes[0].positions;
  for (size_t i = 0; i < p.size(); i += 3) {
    const auto px = to_pixel(c, {p[i], p[i + 1], p[i + 2]});
    EXPECT_GT(px[0], 0) << "corner " << i / 3;
    EXPECT_LT(px[0], c.width) << "corner " << i / 3;
    EXPECT_GT(px[1], 0) << "corner " << i / 3;
    EXPECT_LT(px[1], c.height) << "corner " << i / 3;
    EXPECT_GT(px[2], -1) << "corner " << i / 3 << " in front of near";
    EXPECT_LT(px[2], 1) << "corner " << i / 3 << " before far";
  }
}

void expect_bad_camera(const Camera& c, const char* what) {
  try {
    c.validate();
    ADD_FAILURE() << "validate() accepted: " << what;
  } catch (const vismap::InputError& e) {
    EXPECT_EQ(e.kind(), vismap::InputErrorKind::BadCamera) << what;
  }
}

}  // namespace

TEST(Camera, LookAtMatchesGluLookAt) {
  Camera c = good_camera();
  // Looking down -Z from z=5: identity rotation, translation -5 along z.
  expect_matrix(c.view(), {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, -5, 0, 0, 0, 1});
  // From +X towards the origin: f = (-1,0,0), s = f x up = (0,0,-1), u = s x f = (0,1,0).
  c.eye = {3, 0, 0};
  expect_matrix(c.view(), {0, 0, -1, 0, 0, 1, 0, 0, 1, 0, 0, -3, 0, 0, 0, 1});
}

TEST(Camera, PerspectiveMatchesGluPerspective) {
  Camera c = good_camera();
  c.width = 200;  // aspect 2
  c.near_plane = 1;
  c.far_plane = 3;
  // fovy 90: cot(45) = 1; (f+n)/(n-f) = -2; 2fn/(n-f) = -3.
  expect_matrix(c.projection_matrix(), {0.5, 0, 0, 0, 0, 1, 0, 0, 0, 0, -2, -3, 0, 0, -1, 0});
}

TEST(Camera, OrthoMatchesGlOrtho) {
  Camera c = good_camera();
  c.projection = Camera::Projection::Orthographic;
  c.ortho_height = 4;
  c.width = 200;  // aspect 2: glOrtho(-4, 4, -2, 2, 1, 5)
  c.near_plane = 1;
  c.far_plane = 5;
  expect_matrix(c.projection_matrix(), {0.25, 0, 0, 0, 0, 0.5, 0, 0, 0, 0, -0.5, -1.5, 0, 0, 0, 1});
}

TEST(Camera, WorldPointToPixelYDown) {
  Camera c = good_camera();
  // (1,1,0) is 5 in front of the eye: NDC (0.2, 0.2) -> pixel (60, 40), above the centre.
  auto p = to_pixel(c, {1, 1, 0});
  EXPECT_NEAR(p[0], 60, 1e-9);
  EXPECT_NEAR(p[1], 40, 1e-9);
  // The target is the viewport centre; near plane maps to NDC z -1, far to +1.
  p = to_pixel(c, {0, 0, 0});
  EXPECT_NEAR(p[0], 50, 1e-9);
  EXPECT_NEAR(p[1], 50, 1e-9);
  EXPECT_NEAR(to_pixel(c, {0, 0, 4})[2], -1, 1e-12);
  EXPECT_NEAR(to_pixel(c, {0, 0, -5})[2], 1, 1e-12);
  // Orthographic: height 4 over 100 px, (1,1,0) -> (75, 25).
  c.projection = Camera::Projection::Orthographic;
  c.ortho_height = 4;
  p = to_pixel(c, {1, 1, 0});
  EXPECT_NEAR(p[0], 75, 1e-9);
  EXPECT_NEAR(p[1], 25, 1e-9);
}

TEST(Camera, ValidateRejectsBadCameras) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  EXPECT_NO_THROW(good_camera().validate());
  Camera c = good_camera();
  c.target = c.eye;
  expect_bad_camera(c, "eye == target");
  c = good_camera();
  c.up = {0, 0, 2};
  expect_bad_camera(c, "up parallel to view");
  c.up = {0, 0, 0};
  expect_bad_camera(c, "zero up");
  for (double fov : {0.0, -10.0, 180.0, 200.0, nan}) {
    c = good_camera();
    c.fov_y_deg = fov;
    expect_bad_camera(c, "fov");
  }
  for (auto nf : {std::pair{0.0, 1.0}, {-1.0, 1.0}, {2.0, 2.0}, {3.0, 2.0}, {1.0, inf}}) {
    c = good_camera();
    c.near_plane = nf.first;
    c.far_plane = nf.second;
    expect_bad_camera(c, "near/far");
  }
  for (auto wh : {std::pair{0u, 10u}, {10u, 0u}, {16385u, 10u}, {10u, 100000u}}) {
    c = good_camera();
    c.width = wh.first;
    c.height = wh.second;
    expect_bad_camera(c, "viewport");
  }
  c = good_camera();
  c.width = c.height = 16384;
  EXPECT_NO_THROW(c.validate());
  c = good_camera();
  c.eye[1] = nan;
  expect_bad_camera(c, "NaN eye");
  c = good_camera();
  c.target[0] = inf;
  expect_bad_camera(c, "Inf target");
  c = good_camera();
  c.projection = Camera::Projection::Orthographic;
  c.fov_y_deg = 0;  // ignored for orthographic
  EXPECT_NO_THROW(c.validate());
  c.ortho_height = 0;
  expect_bad_camera(c, "ortho height 0");
}

TEST(Camera, FrameSceneKeepsBoundsInView) {
  struct Case {
    Vec3 lo, hi;
    uint32_t w, h;
  };
  for (const Case& k :
       {Case{{10, -2, 5}, {14, 1, 6}, 640, 480}, Case{{-1, -1, -1}, {1, 1, 1}, 300, 900},
        Case{{-1, -1, -1}, {1, 1, 1}, 2000, 100},
        Case{{1e6, 1e6, 1e6}, {1e6 + 3, 1e6 + 1, 1e6 + 2}, 512, 512},
        Case{{0, 0, 0}, {1e-6, 2e-6, 1e-6}, 512, 256}}) {
    SCOPED_TRACE(testing::Message() << "box " << k.lo[0] << " " << k.w << "x" << k.h);
    const auto s = box_scene(k.lo, k.hi);
    const Camera c = frame_scene(s, k.w, k.h);
    EXPECT_NO_THROW(c.validate());
    EXPECT_EQ(c.width, k.w);
    EXPECT_EQ(c.height, k.h);
    expect_box_in_view(c, s);
    // It looks along -normalize(0.6, 0.35, 1): the eye is on the +Z side.
    EXPECT_GT(c.eye[2], c.target[2]);
  }
}

TEST(Camera, FrameSceneOfEmptyOrPointSceneIsValid) {
  vismap::Scene empty;
  EXPECT_NO_THROW(frame_scene(empty, 64, 64).validate());
  auto point = box_scene({5, 5, 5}, {5, 5, 5});
  EXPECT_NO_THROW(frame_scene(point, 64, 64).validate());
}

TEST(Camera, FitNearFarFromBounds) {
  const auto s = box_scene({-1, -1, -1}, {1, 1, 1});
  Camera c = good_camera();
  c.eye = {0, 0, 10};
  c.near_plane = 0;
  c.far_plane = 0;
  fit_near_far(c, s);
  EXPECT_NO_THROW(c.validate());
  expect_box_in_view(c, s);
  EXPECT_LE(c.near_plane, 9.0);  // the box's front face is at depth 9
  EXPECT_GE(c.far_plane, 11.0);  // its back face at depth 11
  // Camera inside the bounds: near stays positive.
  c = good_camera();
  c.eye = {0, 0, 0.5};
  c.near_plane = c.far_plane = 0;
  fit_near_far(c, s);
  EXPECT_NO_THROW(c.validate());
  EXPECT_GT(c.near_plane, 0);
  // Scene behind the camera: still a valid camera.
  c = good_camera();
  c.eye = {0, 0, 10};
  c.target = {0, 0, 20};
  c.near_plane = c.far_plane = 0;
  fit_near_far(c, s);
  EXPECT_NO_THROW(c.validate());
  // Given planes are kept.
  c = good_camera();
  c.eye = {0, 0, 10};
  c.near_plane = 0.5;
  c.far_plane = 0;
  fit_near_far(c, s);
  EXPECT_EQ(c.near_plane, 0.5);
  EXPECT_GE(c.far_plane, 11.0);
}
