// What every output of a planar map needs, the writers (core/write/) and the stream encoders
// (core/stream/) alike: the map's check, its sources' global ids, their shade. Within core/ only.
#pragma once

#include "core/camera.h"
#include "core/planar_map.h"
#include "core/scene.h"

namespace vismap::detail {

// Checks that the planar map is self-consistent and refers to existing meshes and triangles:
// offsets non-decreasing and ending at vertex_count(), per-fragment arrays sized to
// fragment_count(), mesh and triangle in range, coordinates finite and within 1e9 pixels,
// (fragments with fewer than 3 vertices are allowed: writers skip them), attributes either absent
// or sized per vertex. Throws InputError naming the fragment.
void check_map(const PlanarMap& map, const Scene& scene, const char* writer);

// Global source triangle id of fragment f (Scene::triangle_id_base + Mesh::face_ids).
inline uint64_t global_triangle_id(const PlanarMap& map, const Scene& scene,
                                   const std::vector<uint64_t>& base, size_t f) {
  const uint32_t m = map.mesh[f];
  return base[m] + scene.meshes[m].face_ids[map.triangle[f]];
}

// Lambert shade of a source triangle, two-sided, a headlight along the view direction
// (eye - target, both projections: coplanar faces get one shade), plus ambient: the factor on the
// mesh colour, in [0.12, 1]. Throws InputError when a vertex index is out of range.
double lambert_shade(const Scene& scene, const Camera& cam, uint32_t mesh, uint32_t tri);

}  // namespace vismap::detail
