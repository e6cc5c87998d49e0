// The planar map: the visible parts of the scene's triangles in screen space, depth complexity
// one. Each fragment is a convex polygon, tagged with its source triangle. Written by the
// pipeline (core/pipeline.cpp), read by the writers (core/output_*.cpp) and the checkers.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace vismap {

// A 128-bit signed integer as two 64-bit halves (value = hi * 2^64 + lo), for exact vertices.
struct Int128Parts {
  int64_t hi = 0;
  uint64_t lo = 0;
};

struct PlanarMap {
  uint32_t width = 0, height = 0;  // viewport in pixels

  // Fragments: fragment f has vertices [offsets[f], offsets[f+1]), ordered so that the shoelace
  // sum (x_i*y_{i+1} - x_{i+1}*y_i)/2 in pixel coordinates (y down) is positive.
  std::vector<uint32_t> offsets{0};
  std::vector<double> xy;          // 2 per vertex, pixels, (0,0) top-left, y down
  std::vector<uint32_t> mesh;      // per fragment: index into Scene::meshes
  std::vector<uint32_t> triangle;  // per fragment: index of the source triangle within its mesh
                                   // (into Mesh::indices/3, not face_ids)

  // Filled when RenderOptions::attributes is set: per vertex, the barycentric coordinates of the
  // vertex in its source triangle (3 floats, perspective-correct: they are 3D barycentrics) and
  // the vertex's 1/w (clip w), so a client interpolates attributes perspective-correctly inside a
  // fragment: interpolate b/w and 1/w linearly on screen, divide.
  std::vector<float> bary;   // 3 per vertex
  std::vector<float> inv_w;  // 1 per vertex (1 for orthographic)

  // Filled when RenderOptions::exact is set: vertex v is (hx/hw, hy/hw) in grid units
  // (grid_scale grid units per pixel), exactly; hw > 0.
  std::vector<Int128Parts> hx, hy, hw;
  uint32_t grid_scale = 0;

  size_t fragment_count() const { return offsets.size() - 1; }
  // Area of fragment f in pixels^2 (shoelace over the rounded vertices).
  double fragment_area(size_t f) const {
    double a = 0;
    for (uint32_t v = offsets[f], n = offsets[f + 1]; v < n; ++v) {
      const uint32_t w = v + 1 < n ? v + 1 : offsets[f];
      a += xy[2 * v] * xy[2 * w + 1] - xy[2 * w] * xy[2 * v + 1];
    }
    return a / 2;
  }
  size_t vertex_count() const { return xy.size() / 2; }
};

// The scene as the pipeline saw it after transform, clipping, culling and snapping: the input
// of every 2D decision. Filled when RenderOptions::keep_screen_triangles is set (for checks).
struct ScreenTriangles {
  uint32_t grid_scale = 0;    // grid units per pixel
  std::vector<int32_t> xy;    // 6 per triangle: grid coordinates, y down
  std::vector<double> depth;  // 3 per triangle: nearness (larger is closer), affine on screen
  std::vector<uint32_t> mesh, triangle;
  // Per triangle: k when its depth plane was snapped to integers over 2^k (depth * 2^k is an
  // integer at each vertex, and crossing lines between two such triangles are exact), else
  // kFreePlane (docs/NUMERICS.md §2 "Depth planes").
  static constexpr int32_t kFreePlane = -0x7fffffff;  // VM_PLANE_FREE (kernels/layout.h)
  std::vector<int32_t> plane_k;
  // The crossing lines the pipeline clipped with (pairs whose depth planes cross inside their
  // overlap, kernels/crossings.cl VM_REL_CROSS): a*x + b*y + c = 0 in grid units, by the two
  // source triangles. extract_lines draws intersection lines only on these.
  struct Crossing {
    uint32_t mesh[2], triangle[2];
    int64_t a, b, c;
  };
  std::vector<Crossing> crossings;
  size_t size() const { return mesh.size(); }
};

}  // namespace vismap
