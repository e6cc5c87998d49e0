#include <cmath>
#include <string>

#include "core/error.h"
#include "core/write/shared.h"

namespace vismap::detail {

namespace {
[[noreturn]] void bad(const char* writer, InputErrorKind kind, const std::string& element,
                      int64_t index, const std::string& msg) {
  throw InputError(kind, writer, "", element, index, msg);
}
}  // namespace

void check_map(const PlanarMap& map, const Scene& scene, const char* writer) {
  using K = InputErrorKind;
  if (map.offsets.empty() || map.offsets.front() != 0)
    bad(writer, K::BadScene, "planar map", -1, "offsets must start with 0");
  if (map.xy.size() % 2 != 0) bad(writer, K::BadScene, "planar map", -1, "odd xy size");
  const size_t nf = map.fragment_count(), nv = map.vertex_count();
  if (map.offsets.back() != nv)
    bad(writer, K::BadScene, "planar map", -1,
        "offsets end at " + std::to_string(map.offsets.back()) + " but there are " +
            std::to_string(nv) + " vertices");
  if (map.mesh.size() != nf || map.triangle.size() != nf)
    bad(writer, K::BadScene, "planar map", -1, "mesh/triangle arrays do not match fragments");
  const bool attrs = !map.bary.empty() || !map.inv_w.empty();
  if (attrs && (map.bary.size() != 3 * nv || map.inv_w.size() != nv))
    bad(writer, K::BadScene, "planar map", -1, "bary/inv_w must have 3 and 1 values per vertex");
  for (size_t f = 0; f < nf; ++f) {
    if (map.offsets[f + 1] < map.offsets[f])
      bad(writer, K::BadScene, "fragment", int64_t(f), "offsets decrease");
    if (map.mesh[f] >= scene.meshes.size())
      bad(writer, K::IndexOutOfRange, "fragment", int64_t(f),
          "mesh " + std::to_string(map.mesh[f]) + " out of range (" +
              std::to_string(scene.meshes.size()) + " meshes)");
    const Mesh& m = scene.meshes[map.mesh[f]];
    if (map.triangle[f] >= m.triangle_count() || map.triangle[f] >= m.face_ids.size())
      bad(writer, K::IndexOutOfRange, "fragment", int64_t(f),
          "triangle " + std::to_string(map.triangle[f]) + " out of range in mesh '" + m.name +
              "' (" + std::to_string(m.triangle_count()) + " triangles)");
  }
  for (size_t i = 0; i < map.bary.size(); ++i)
    if (!std::isfinite(map.bary[i]))
      bad(writer, K::NonFiniteVertex, "vertex", int64_t(i / 3), "non-finite barycentric");
  for (size_t i = 0; i < map.inv_w.size(); ++i)
    if (!(map.inv_w[i] > 0) || !std::isfinite(map.inv_w[i]))
      bad(writer, K::NonFiniteVertex, "vertex", int64_t(i), "1/w must be positive and finite");
  for (size_t i = 0; i < map.xy.size(); ++i)
    if (!std::isfinite(map.xy[i]) || std::abs(map.xy[i]) > 1e9)
      bad(writer, K::NonFiniteVertex, "vertex", int64_t(i / 2),
          "coordinate " + std::to_string(map.xy[i]) + " is not finite or beyond 1e9 pixels");
}

}  // namespace vismap::detail
