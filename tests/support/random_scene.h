// Seeded random scenes for the randomised checks (tests/test_random.cpp): overlapping,
// interpenetrating, coplanar and clustered triangles under random cameras. The same seed gives
// the same scene on every machine (std::mt19937_64 and integer arithmetic only in the choices;
// coordinates are rounded to floats as the loaders would).
#pragma once

#include <cmath>
#include <cstdint>
#include <fstream>
#include <nlohmann/json.hpp>
#include <random>
#include <string>

#include "core/camera.h"
#include "core/scene.h"

namespace vismap::randomized {

enum class RandomKind { Overlapping, Interpenetrating, Coplanar, Clustered, kCount };

inline const char* kind_name(RandomKind k) {
  static const char* names[] = {"overlapping", "interpenetrating", "coplanar", "clustered"};
  return names[int(k)];
}

struct RandomScene {
  Scene scene;
  Camera camera;
  RandomKind kind;
};

inline RandomScene random_scene(uint64_t seed) {
  std::mt19937_64 rng(seed);
  auto uni = [&](double a, double b) { return a + (b - a) * double(rng() >> 11) * 0x1.0p-53; };
  auto pick = [&](uint64_t n) { return rng() % n; };
  RandomScene r;
  r.kind = RandomKind(pick(uint64_t(RandomKind::kCount)));
  const int meshes = 1 + int(pick(4));
  for (int m = 0; m < meshes; ++m) {
    Mesh mesh;
    mesh.name = "m" + std::to_string(m);
    const int tris = 2 + int(pick(12));
    const double plane_z = uni(-0.5, 0.5);
    // Coplanar scenes put all meshes in one of two planes, so ties happen across meshes.
    const double coplanar_z = (pick(2) ? 0.25 : -0.25);
    double cx = uni(-0.5, 0.5), cy = uni(-0.5, 0.5), cz = uni(-0.5, 0.5);
    for (int t = 0; t < tris; ++t) {
      float p[9];
      for (;;) {
        for (int k = 0; k < 3; ++k) {
          double x, y, z;
          switch (r.kind) {
            case RandomKind::Overlapping:  // near-parallel layers, separate in depth
              x = uni(-1, 1), y = uni(-1, 1), z = plane_z + uni(-0.02, 0.02);
              break;
            case RandomKind::Interpenetrating:
              x = uni(-1, 1), y = uni(-1, 1), z = uni(-1, 1);
              break;
            case RandomKind::Coplanar:  // vertices on a coarse lattice, in a shared plane
              x = double(int(pick(9)) - 4) / 4, y = double(int(pick(9)) - 4) / 4, z = coplanar_z;
              break;
            default:  // clustered: many small triangles around one point
              x = cx + uni(-0.05, 0.05), y = cy + uni(-0.05, 0.05), z = cz + uni(-0.05, 0.05);
              break;
          }
          p[3 * k] = float(x), p[3 * k + 1] = float(y), p[3 * k + 2] = float(z);
        }
        double ux = p[3] - p[0], uy = p[4] - p[1], uz = p[5] - p[2];
        double vx = p[6] - p[0], vy = p[7] - p[1], vz = p[8] - p[2];
        double nx = uy * vz - uz * vy, ny = uz * vx - ux * vz, nz = ux * vy - uy * vx;
        if (nx != 0 || ny != 0 || nz != 0) break;  // the loaders drop zero-area triangles
      }
      for (int k = 0; k < 9; ++k) mesh.positions.push_back(p[k]);
      for (int k = 0; k < 3; ++k) mesh.indices.push_back(uint32_t(3 * t + k));
      mesh.face_ids.push_back(uint32_t(t));
    }
    mesh.source_triangles = uint32_t(tris);
    // As the loaders set it: soup when two vertices share a position (match edges by position).
    for (size_t a = 0; a < mesh.vertex_count() && !mesh.soup; ++a)
      for (size_t b = a + 1; b < mesh.vertex_count() && !mesh.soup; ++b)
        mesh.soup = mesh.positions[3 * a] == mesh.positions[3 * b] &&
                    mesh.positions[3 * a + 1] == mesh.positions[3 * b + 1] &&
                    mesh.positions[3 * a + 2] == mesh.positions[3 * b + 2];
    r.scene.meshes.push_back(std::move(mesh));
  }
  Camera& c = r.camera;
  c.width = c.height = 256;
  const double th = uni(0, 2 * M_PI), ph = uni(0.1, 1.4), dist = uni(2.5, 6);
  c.eye = {dist * std::cos(ph) * std::cos(th), dist * std::cos(ph) * std::sin(th),
           dist * std::sin(ph)};
  if (r.kind == RandomKind::Coplanar || pick(3) == 0)
    c.eye = {uni(-0.3, 0.3), uni(-0.3, 0.3), dist};
  c.target = {uni(-0.2, 0.2), uni(-0.2, 0.2), uni(-0.2, 0.2)};
  c.up = {0, 1, 0};
  if (pick(3) == 0) {
    c.projection = Camera::Projection::Orthographic;
    c.ortho_height = uni(1.5, 3.5);
  } else {
    c.fov_y_deg = uni(25, 70);
  }
  fit_near_far(c, r.scene);
  return r;
}

// Writes the scene as PATH.obj (one object per mesh) and PATH.json (the scene file with the camera
// and explicit near/far), so `vismap check PATH.json` reproduces the run.
inline void write_scene(const RandomScene& r, const std::string& path) {
  std::ofstream obj(path + ".obj");
  obj.precision(9);
  uint32_t base = 1;
  for (const Mesh& m : r.scene.meshes) {
    obj << "o " << m.name << "\n";
    for (size_t v = 0; v < m.vertex_count(); ++v)
      obj << "v " << m.positions[3 * v] << " " << m.positions[3 * v + 1] << " "
          << m.positions[3 * v + 2] << "\n";
    for (size_t t = 0; t < m.triangle_count(); ++t)
      obj << "f " << base + m.indices[3 * t] << " " << base + m.indices[3 * t + 1] << " "
          << base + m.indices[3 * t + 2] << "\n";
    base += uint32_t(m.vertex_count());
  }
  const Camera& c = r.camera;
  nlohmann::json cam = {
      {"type", c.projection == Camera::Projection::Orthographic ? "orthographic" : "perspective"},
      {"eye", c.eye},
      {"target", c.target},
      {"up", c.up},
      {"near", c.near_plane},
      {"far", c.far_plane},
      {"width", c.width},
      {"height", c.height}};
  if (c.projection == Camera::Projection::Orthographic)
    cam["ortho_height"] = c.ortho_height;
  else
    cam["fov_y_deg"] = c.fov_y_deg;
  std::string stem = path.substr(path.find_last_of('/') + 1);
  nlohmann::json j = {{"comment", std::string("random scene, kind ") + kind_name(r.kind)},
                      {"meshes", {{{"file", stem + ".obj"}}}},
                      {"camera", cam}};
  std::ofstream(path + ".json") << j.dump(1) << "\n";
}

}  // namespace vismap::randomized
