// Small helpers shared by the tests that build scenes triangle by triangle.
#pragma once

#include <string>
#include <utility>

#include "core/camera.h"
#include "core/scene.h"

namespace vismap::test_support {

// Appends one triangle (three points, world units) to the scene as a mesh of its own.
inline void add_triangle(Scene& s, const std::string& name, const double (&p)[3][3]) {
  Mesh m;
  m.name = name;
  for (int k = 0; k < 3; ++k)
    for (int c = 0; c < 3; ++c) m.positions.push_back(float(p[k][c]));
  m.indices = {0, 1, 2};
  m.face_ids = {0};
  m.source_triangles = 1;
  s.meshes.push_back(std::move(m));
}

// World units = pixels: a 256x256 orthographic view down -z onto [0, 256]^2, near and far
// fitted to the scene.
inline Camera ortho_view_256(const Scene& s) {
  Camera cam;
  cam.width = cam.height = 256;
  cam.up = {0, 1, 0};
  cam.projection = Camera::Projection::Orthographic;
  cam.eye = {128, 128, 100};
  cam.target = {128, 128, 0};
  cam.ortho_height = 256;
  fit_near_far(cam, s);
  return cam;
}

}  // namespace vismap::test_support
