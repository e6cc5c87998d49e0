#include "core/scene.h"

namespace vismap {

size_t Scene::triangle_count() const {
  size_t n = 0;
  for (const Mesh& m : meshes) n += m.triangle_count();
  return n;
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

}  // namespace vismap
