// Small helpers shared by the tests that build scenes triangle by triangle.
#pragma once

#include <cstdint>
#include <string>
#include <utility>

#include "core/camera.h"
#include "core/planar_map.h"
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

// The 12 triangles of a box whose 8 corners are m.positions in bit order (bit 0: high x, bit 1:
// high y, bit 2: high z), counter-clockwise seen from outside, with face ids and the source
// triangle count.
inline void add_box_triangles(Mesh& m) {
  const uint32_t q[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4},
                            {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (const auto& f : q) m.indices.insert(m.indices.end(), {f[0], f[1], f[2], f[0], f[2], f[3]});
  for (uint32_t t = 0; t < 12; ++t) m.face_ids.push_back(t);
  m.source_triangles = 12;
}

// Indices of a regular grid of (n + 1) x (n + 1) vertices, row by row: two triangles per cell,
// with face ids and the source triangle count.
inline void add_grid_triangles(Mesh& m, int n) {
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      uint32_t a = j * (n + 1) + i, b = a + 1, c = a + n + 1, d = c + 1;
      m.indices.insert(m.indices.end(), {a, b, d, a, d, c});
      m.face_ids.push_back(2 * (j * n + i));
      m.face_ids.push_back(2 * (j * n + i) + 1);
    }
  m.source_triangles = 2 * n * n;
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

// Covered area of a planar map in pixels^2 (the sum of its fragments' areas).
inline double map_area(const PlanarMap& m) {
  double a = 0;
  for (size_t f = 0; f < m.fragment_count(); ++f) a += m.fragment_area(f);
  return a;
}

}  // namespace vismap::test_support
