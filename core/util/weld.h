// Welding by exact position: finite points whose coordinates are equal as numbers (-0 is +0)
// become one.
// One table for every caller: the loaders' duplicate check, the meshes' topology (closedness,
// lines' edges), the dicers' output vertices, and the 2D welds of the conformed map and of the
// hidden lines. Exact: the table keeps the coordinates, so a hash collision never merges two
// places (nor keeps one place apart).
#pragma once

#include <array>
#include <bit>
#include <cstdint>
#include <type_traits>
#include <utility>
#include <vector>

namespace vismap {

// T is float or double, N the dimension. Ids are the caller's: add() returns the id the first
// point at a place was added with.
template <typename T, int N>
class Weld {
  using Bits = std::conditional_t<sizeof(T) == 4, uint32_t, uint64_t>;

 public:
  // Sized once for at most `expected` distinct places.
  explicit Weld(size_t expected) {
    size_t cap = 16;
    while (cap < 2 * expected + 1) cap <<= 1;
    slots_.resize(cap);
    mask_ = cap - 1;
  }
  // The id of the place p: {an earlier point's id, false} when one was added there, else
  // {fresh, true} (p is added under `fresh`).
  std::pair<uint32_t, bool> add(const T* p, uint32_t fresh) {
    std::array<Bits, N> key;
    uint64_t h = 0;
    for (int k = 0; k < N; ++k) {
      key[k] = std::bit_cast<Bits>(T(p[k] + T(0)));  // -0 + 0 is +0
      h = (h ^ uint64_t(key[k])) * 0x9E3779B97F4A7C15ull;
      h ^= h >> 29;
    }
    for (size_t i = size_t(h ^ (h >> 32)) & mask_;; i = (i + 1) & mask_) {
      Slot& s = slots_[i];
      if (s.id == kEmpty) {
        s.key = key;
        s.id = fresh;
        return {fresh, true};
      }
      if (s.key == key) return {s.id, false};
    }
  }

 private:
  static constexpr uint32_t kEmpty = ~0u;
  struct Slot {
    std::array<Bits, N> key{};
    uint32_t id = kEmpty;
  };
  std::vector<Slot> slots_;
  size_t mask_ = 0;
};

// Per vertex of an xyz array (n points): the first vertex at its position.
inline std::vector<uint32_t> weld_first(const float* xyz, size_t n) {
  std::vector<uint32_t> canon(n);
  Weld<float, 3> w(n);
  for (size_t v = 0; v < n; ++v) canon[v] = w.add(xyz + 3 * v, uint32_t(v)).first;
  return canon;
}

}  // namespace vismap
