#include "core/scene.h"

#include <algorithm>
#include <cmath>

namespace vismap {

size_t Scene::triangle_count() const {
  size_t n = 0;
  for (const Mesh& m : meshes) n += m.triangle_count();
  return n;
}

bool Scene::has_surfaces() const {
  for (const Mesh& m : meshes)
    if (m.is_surface()) return true;
  return false;
}

std::vector<uint64_t> Scene::triangle_id_base() const {
  std::vector<uint64_t> base(meshes.size());
  uint64_t b = 0;
  for (size_t i = 0; i < meshes.size(); ++i) {
    base[i] = b;
    b += meshes[i].source_triangles;
  }
  return base;
}

std::array<std::array<double, 3>, 8> Mesh::implicit_corners() const {
  const auto& b = implicit_box;
  const auto& x = implicit_xform;
  std::array<std::array<double, 3>, 8> w;
  for (int c = 0; c < 8; ++c) {
    const double p[3] = {b[c & 1 ? 3 : 0], b[c & 2 ? 4 : 1], b[c & 4 ? 5 : 2]};
    for (int r = 0; r < 3; ++r) w[c][r] = x[r] * p[0] + x[4 + r] * p[1] + x[8 + r] * p[2] + x[12 + r];
  }
  return w;
}

Bounds scene_bounds(const Scene& s) {
  // Only vertices that triangles use: stray unused vertices must not move the framing.
  // A Bezier patch lies in the hull of its control points, and so does a Loop surface in its
  // control mesh's: their boxes bound the diced surfaces for every tolerance.
  Bounds b;
  auto add = [&b](const float* p) {
    if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2])) return;
    for (int k = 0; k < 3; ++k) {
      if (b.empty) {
        b.lo[k] = b.hi[k] = p[k];
      } else {
        b.lo[k] = std::min(b.lo[k], double(p[k]));
        b.hi[k] = std::max(b.hi[k], double(p[k]));
      }
    }
    b.empty = false;
  };
  for (const Mesh& m : s.meshes) {
    for (size_t i = 0; i + 3 <= m.patches.size(); i += 3) add(&m.patches[i]);
    if (m.implicit && m.positions.empty())  // an undiced implicit: its box's corners, placed
      for (const auto& p : m.implicit_corners()) {
        const float w[3] = {float(p[0]), float(p[1]), float(p[2])};
        add(w);
      }
    const size_t nv = m.vertex_count();
    for (uint32_t i : m.indices) {
      if (i >= nv) continue;  // the loader reports bad indices; bounds just skip them
      add(&m.positions[3 * size_t(i)]);
    }
  }
  return b;
}

Camera frame_scene(const Scene& s, uint32_t width, uint32_t height) {
  return frame_bounds(scene_bounds(s), width, height);
}

void fit_near_far(Camera& c, const Scene& s) {
  fit_near_far(c, scene_bounds(s));
}

}  // namespace vismap
