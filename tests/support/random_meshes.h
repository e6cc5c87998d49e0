// Random scenes of connected meshes for the cull's tests (issue 32): grid patches (sheets whose
// triangles share edges, so that the cull's sheet proof is used), stacked in layers, crossing,
// with holes, folded over themselves, coplanar, touching along a line, cut by the near plane,
// and closed boxes (back faces culled). Deterministic per seed.
#pragma once

#include <array>
#include <cmath>
#include <cstdint>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include "core/camera.h"
#include "core/scene.h"
#include "tests/support/triangle_scene.h"

namespace vismap::randomized {

enum class MeshKind {
  Layers,
  Crossing,
  Holes,
  Folded,
  Coplanar,
  Touching,
  NearPlane,
  Boxes,
  kCount
};

inline const char* mesh_kind_name(MeshKind k) {
  static const char* names[] = {"layers",   "crossing", "holes",      "folded",
                                "coplanar", "touching", "near_plane", "boxes"};
  return names[int(k)];
}

struct RandomMeshScene {
  Scene scene;
  Camera camera;
  MeshKind kind;
};

namespace detail_meshes {

using Rng = std::mt19937_64;

inline double uni(Rng& rng, double a, double b) {
  return a + (b - a) * double(rng() >> 11) * 0x1.0p-53;
}

// A rotation by angles (a, b, c) about x, then y, then z.
inline std::array<double, 9> rotation(double a, double b, double c) {
  const double ca = std::cos(a), sa = std::sin(a), cb = std::cos(b), sb = std::sin(b),
               cc = std::cos(c), sc = std::sin(c);
  // Rz * Ry * Rx
  return {cc * cb,
          cc * sb * sa - sc * ca,
          cc * sb * ca + sc * sa,
          sc * cb,
          sc * sb * sa + cc * ca,
          sc * sb * ca - cc * sa,
          -sb,
          cb * sa,
          cb * ca};
}

// A grid patch of nu x nv vertices over [-s, s]^2, z = height(u, v), placed by rotation r and
// offset o; every cell two triangles (counter-clockwise seen from +z), a cell left out with
// probability `holes`.
template <class Height>
Mesh grid_patch(Rng& rng, int nu, int nv, double s, Height height, const std::array<double, 9>& r,
                const std::array<double, 3>& o, double holes, const std::string& name) {
  Mesh m;
  m.name = name;
  for (int j = 0; j < nv; ++j)
    for (int i = 0; i < nu; ++i) {
      const double u = -s + 2 * s * i / (nu - 1), v = -s + 2 * s * j / (nv - 1);
      const double w = height(u, v);
      const double x = r[0] * u + r[1] * v + r[2] * w + o[0];
      const double y = r[3] * u + r[4] * v + r[5] * w + o[1];
      const double z = r[6] * u + r[7] * v + r[8] * w + o[2];
      m.positions.insert(m.positions.end(), {float(x), float(y), float(z)});
    }
  uint32_t t = 0;
  for (int j = 0; j + 1 < nv; ++j)
    for (int i = 0; i + 1 < nu; ++i) {
      const uint32_t a = uint32_t(j * nu + i), b = a + 1, c = a + uint32_t(nu), d = c + 1;
      if (holes > 0 && uni(rng, 0, 1) < holes) {
        t += 2;
        continue;
      }
      m.indices.insert(m.indices.end(), {a, b, d, a, d, c});
      m.face_ids.insert(m.face_ids.end(), {t, t + 1});
      t += 2;
    }
  m.source_triangles = t;
  return m;
}

// A closed box (outward faces counter-clockwise), centre c, half sizes h, rotated by r.
inline Mesh box(const std::array<double, 3>& c, const std::array<double, 3>& h,
                const std::array<double, 9>& r, const std::string& name) {
  Mesh m;
  m.name = name;
  for (int k = 0; k < 8; ++k) {
    const double u = (k & 1 ? 1 : -1) * h[0], v = (k & 2 ? 1 : -1) * h[1],
                 w = (k & 4 ? 1 : -1) * h[2];
    m.positions.insert(m.positions.end(), {float(r[0] * u + r[1] * v + r[2] * w + c[0]),
                                           float(r[3] * u + r[4] * v + r[5] * w + c[1]),
                                           float(r[6] * u + r[7] * v + r[8] * w + c[2])});
  }
  test_support::add_box_triangles(m);
  return m;
}

}  // namespace detail_meshes

inline RandomMeshScene random_mesh_scene(uint64_t seed) {
  using namespace detail_meshes;
  Rng rng(seed * 0x9e3779b97f4a7c15ull + 17);
  RandomMeshScene r;
  r.kind = MeshKind(rng() % uint64_t(MeshKind::kCount));
  const int patches = 2 + int(rng() % 4);
  auto bumps = [&](double amp) {
    const double fa = uni(rng, 1, 5), fb = uni(rng, 1, 5), ph = uni(rng, 0, 6.3);
    return [=](double u, double v) { return amp * std::sin(fa * u + ph) * std::cos(fb * v); };
  };
  for (int p = 0; p < patches; ++p) {
    const int nu = 3 + int(rng() % 12), nv = 3 + int(rng() % 12);
    const std::string name = "p" + std::to_string(p);
    const double s = uni(rng, 0.3, 0.9);
    std::array<double, 9> rot =
        rotation(uni(rng, -0.3, 0.3), uni(rng, -0.3, 0.3), uni(rng, 0, 6.3));
    std::array<double, 3> o = {uni(rng, -0.3, 0.3), uni(rng, -0.3, 0.3), -0.6 + 0.4 * p};
    double holes = 0;
    switch (r.kind) {
      case MeshKind::Crossing:
        rot = rotation(uni(rng, -1.2, 1.2), uni(rng, -1.2, 1.2), uni(rng, 0, 6.3));
        o[2] = uni(rng, -0.2, 0.2);
        break;
      case MeshKind::Holes:
        holes = uni(rng, 0.05, 0.4);
        break;
      case MeshKind::Coplanar:  // two patches in one plane, one behind
        rot = rotation(0, 0, uni(rng, 0, 6.3));
        o[2] = p < 2 ? 0.1 : -0.5;
        break;
      default:
        break;
    }
    if (r.kind == MeshKind::Folded && p == 0) {
      // x(u) = sin(2.2 u / s) s folds back over itself twice on the way; z rises with u.
      Mesh m = grid_patch(
          rng, 4 * nu, nv, s, [](double, double) { return 0.0; }, rot, o, 0, name);
      for (size_t v = 0; v < m.vertex_count(); ++v) {
        const double u = m.positions[3 * v] - o[0];
        m.positions[3 * v] = float(o[0] + s * std::sin(2.2 * u / s));
        m.positions[3 * v + 2] = float(o[2] + 0.5 * u);
      }
      r.scene.meshes.push_back(std::move(m));
      continue;
    }
    if (r.kind == MeshKind::Touching && p == 1) {
      // A flat patch, then one standing on it: its bottom row lies exactly on the first patch's
      // plane z = o0 (vertical, x from -s to s at y = 0), so the two touch along a line.
      Mesh base = r.scene.meshes[0];
      const double z0 = base.positions[2];
      Mesh m = grid_patch(
          rng, nu, nv, s, [](double, double) { return 0.0; }, rotation(M_PI / 2, 0, 0), {0, 0, 0},
          0, name);
      for (size_t v = 0; v < m.vertex_count(); ++v) m.positions[3 * v + 2] += float(z0 + s);
      r.scene.meshes.push_back(std::move(m));
      continue;
    }
    const double amp = r.kind == MeshKind::Layers ? uni(rng, 0, 0.08) : uni(rng, 0, 0.3);
    if (r.kind == MeshKind::Touching && p == 0) rot = rotation(0, 0, 0), o = {0, 0, o[2]};
    r.scene.meshes.push_back(
        grid_patch(rng, nu, nv, s,
                   r.kind == MeshKind::Touching && p == 0
                       ? std::function<double(double, double)>([](double, double) { return 0.0; })
                       : std::function<double(double, double)>(bumps(amp)),
                   rot, o, holes, name));
  }
  if (r.kind == MeshKind::Boxes || r.kind == MeshKind::Layers)
    for (int b = 0; b < 2; ++b)
      r.scene.meshes.push_back(box({uni(rng, -0.4, 0.4), uni(rng, -0.4, 0.4), uni(rng, -0.6, 0.6)},
                                   {uni(rng, 0.1, 0.4), uni(rng, 0.1, 0.4), uni(rng, 0.1, 0.4)},
                                   rotation(uni(rng, 0, 3), uni(rng, 0, 3), uni(rng, 0, 3)),
                                   "box" + std::to_string(b)));
  Camera& c = r.camera;
  c.width = 200 + uint32_t(rng() % 120);
  c.height = 160 + uint32_t(rng() % 120);
  const double th = uni(rng, -0.6, 0.6), ph = uni(rng, -0.5, 0.5), dist = uni(rng, 2.2, 4);
  c.eye = {dist * std::sin(th) * std::cos(ph), dist * std::sin(ph),
           dist * std::cos(th) * std::cos(ph)};
  c.target = {uni(rng, -0.1, 0.1), uni(rng, -0.1, 0.1), uni(rng, -0.1, 0.1)};
  c.up = {0, 1, 0};
  if (rng() % 4 == 0) {
    c.projection = Camera::Projection::Orthographic;
    c.ortho_height = uni(rng, 1.5, 3);
  } else {
    c.fov_y_deg = uni(rng, 30, 60);
  }
  fit_near_far(c, r.scene);
  if (r.kind == MeshKind::NearPlane) {  // the near plane through the middle of the layers
    const double d = std::sqrt(c.eye[0] * c.eye[0] + c.eye[1] * c.eye[1] + c.eye[2] * c.eye[2]);
    c.near_plane = d - uni(rng, -0.2, 0.3);
    c.far_plane = d + 3;
  }
  return r;
}

}  // namespace vismap::randomized
