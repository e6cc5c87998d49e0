#include "core/mesh_topology.h"

#include <cstring>
#include <unordered_map>
#include <vector>

namespace vismap {

namespace {

struct PosKey {
  uint32_t x, y, z;
  bool operator==(const PosKey& o) const { return x == o.x && y == o.y && z == o.z; }
};
struct PosHash {
  size_t operator()(const PosKey& k) const {
    uint64_t h = k.x * 0x9E3779B97F4A7C15ull;
    h ^= (h >> 29) + k.y * 0xBF58476D1CE4E5B9ull;
    h ^= (h >> 31) + k.z * 0x94D049BB133111EBull;
    return static_cast<size_t>(h ^ (h >> 32));
  }
};

}  // namespace

int8_t closed_orientation(const Mesh& m) {
  const size_t nv = m.vertex_count(), nt = m.triangle_count();
  if (nt < 4) return 0;
  // Weld vertices by exact position.
  std::vector<uint32_t> weld(nv);
  std::unordered_map<PosKey, uint32_t, PosHash> ids;
  ids.reserve(nv * 2);
  for (size_t v = 0; v < nv; ++v) {
    PosKey k;
    std::memcpy(&k.x, &m.positions[3 * v], 4);
    std::memcpy(&k.y, &m.positions[3 * v + 1], 4);
    std::memcpy(&k.z, &m.positions[3 * v + 2], 4);
    weld[v] = ids.emplace(k, static_cast<uint32_t>(ids.size())).first->second;
  }
  // Every directed edge must occur exactly once, and so must its reverse.
  std::unordered_map<uint64_t, uint32_t> directed;
  directed.reserve(nt * 6);
  for (size_t t = 0; t < nt; ++t) {
    for (int k = 0; k < 3; ++k) {
      uint64_t a = weld[m.indices[3 * t + k]], b = weld[m.indices[3 * t + (k + 1) % 3]];
      if (a == b) return 0;
      if (++directed[(a << 32) | b] > 1) return 0;
    }
  }
  for (const auto& [key, count] : directed) {
    uint64_t rev = (key << 32) | (key >> 32);
    if (directed.find(rev) == directed.end()) return 0;
  }
  double volume = 0;
  for (size_t t = 0; t < nt; ++t) {
    const float* a = &m.positions[3 * m.indices[3 * t]];
    const float* b = &m.positions[3 * m.indices[3 * t + 1]];
    const float* c = &m.positions[3 * m.indices[3 * t + 2]];
    volume += a[0] * (double(b[1]) * c[2] - double(b[2]) * c[1]) -
              a[1] * (double(b[0]) * c[2] - double(b[2]) * c[0]) +
              a[2] * (double(b[0]) * c[1] - double(b[1]) * c[0]);
  }
  if (volume > 0) return 1;
  if (volume < 0) return -1;
  return 0;
}

}  // namespace vismap
