// An open-addressing hash map from 64-bit keys to 32-bit values, sized once for a known number
// of keys: the encoders' vertex and edge lookups (core/util/conform.cpp, core/stream/compact.cpp),
// where std::unordered_map's node per entry cost more than the work itself.
#pragma once

#include <cstdint>
#include <vector>

namespace vismap {

class FlatMap {
 public:
  explicit FlatMap(size_t expected) {
    size_t cap = 16;
    while (cap < 2 * expected + 1) cap <<= 1;
    keys_.assign(cap, kEmpty);
    vals_.resize(cap);
    mask_ = cap - 1;
  }
  // The value stored under `key`, or nullptr.
  const uint32_t* find(uint64_t key) const {
    for (size_t i = slot(key);; i = (i + 1) & mask_) {
      if (keys_[i] == key) return &vals_[i];
      if (keys_[i] == kEmpty) return nullptr;
    }
  }
  // Inserts (key, value) unless the key is there; returns the stored value and whether it is
  // the new one. Keys must differ from ~0 and the map must not hold more than `expected` keys.
  std::pair<uint32_t, bool> emplace(uint64_t key, uint32_t value) {
    for (size_t i = slot(key);; i = (i + 1) & mask_) {
      if (keys_[i] == key) return {vals_[i], false};
      if (keys_[i] == kEmpty) {
        keys_[i] = key;
        vals_[i] = value;
        return {value, true};
      }
    }
  }

 private:
  static constexpr uint64_t kEmpty = ~uint64_t(0);
  size_t slot(uint64_t key) const {
    key ^= key >> 33;
    key *= 0xFF51AFD7ED558CCDull;
    key ^= key >> 33;
    return size_t(key) & mask_;
  }
  std::vector<uint64_t> keys_;
  std::vector<uint32_t> vals_;
  size_t mask_ = 0;
};

}  // namespace vismap
