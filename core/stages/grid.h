// Uniform grids of square tiles over the screen (bin tiles, bucket cells).
#pragma once

#include <cstdint>

#include "kernels/layout.h"

namespace vismap::stages {

inline uint32_t next_pow2(uint64_t v) {
  uint64_t p = 1;
  while (p < v) p <<= 1;
  return static_cast<uint32_t>(p);
}

// A uniform grid of square tiles of tile_px pixels over a W x H screen.
inline VmGrid make_grid(uint32_t tile_px, uint32_t W, uint32_t H) {
  VmGrid g;
  g.tile_size = static_cast<int32_t>(tile_px * VM_GRID_SCALE);
  g.tiles_x = static_cast<int32_t>((W + tile_px - 1) / tile_px);
  g.tiles_y = static_cast<int32_t>((H + tile_px - 1) / tile_px);
  g.tile_shift = 0;
  while ((1 << g.tile_shift) < g.tile_size) ++g.tile_shift;
  return g;
}

}  // namespace vismap::stages
