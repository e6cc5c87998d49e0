// Little-endian 32-bit words, the one byte order every binary format here uses (proto/FORMAT.md,
// COMPACT.md, DELTA.md): written into a buffer or appended to a string, and read back.
#pragma once

#include <bit>
#include <cstdint>
#include <string>

namespace vismap::le {

inline void put_u32(char* p, uint32_t v) {
  for (int i = 0; i < 4; ++i) p[i] = char((v >> (8 * i)) & 0xFF);
}
inline void put_u32(std::string& s, uint32_t v) {
  char b[4];
  put_u32(b, v);
  s.append(b, 4);
}
inline void put_f32(char* p, float v) {
  put_u32(p, std::bit_cast<uint32_t>(v));
}
inline uint32_t get_u32(const char* p) {
  uint32_t v = 0;
  for (int i = 0; i < 4; ++i) v |= uint32_t(static_cast<unsigned char>(p[i])) << (8 * i);
  return v;
}
inline float get_f32(const char* p) {
  return std::bit_cast<float>(get_u32(p));
}

}  // namespace vismap::le
