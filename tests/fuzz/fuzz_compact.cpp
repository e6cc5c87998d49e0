// libFuzzer target for the compact frame reader (proto/COMPACT.md): any bytes either decode to a
// frame that keeps every promise of the format or are refused with InputError. Seeds:
// proto/vectors/*.vmc. Registered as fuzz_compact_short in fuzz/CMakeLists.txt.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>

#include "core/error.h"
#include "core/stream/compact.h"
#include "core/util/conform.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace vismap;
  try {
    const CompactFrame f = read_compact(std::string(reinterpret_cast<const char*>(data), size));
    const int64_t xmax = int64_t(f.width) * f.quantum, ymax = int64_t(f.height) * f.quantum;
    for (size_t v = 0; v < f.vertex_count(); ++v)
      if (f.xy[2 * v] < 0 || f.xy[2 * v] > xmax || f.xy[2 * v + 1] < 0 || f.xy[2 * v + 1] > ymax)
        std::abort();
    for (size_t t = 0; t < f.triangle_count(); ++t) {
      const uint32_t* i = &f.indices[3 * t];
      if (i[0] >= f.vertex_count() || i[1] >= f.vertex_count() || i[2] >= f.vertex_count())
        std::abort();
      if (orient2(&f.xy[2 * i[0]], &f.xy[2 * i[1]], &f.xy[2 * i[2]]) <= 0) std::abort();
      if (f.mesh[t] >= f.mesh_base.size() || f.source[t] < f.mesh_base[f.mesh[t]]) std::abort();
    }
    if (!f.shade.empty() && f.shade.size() != f.triangle_count()) std::abort();
  } catch (const InputError&) {
  }
  return 0;
}
