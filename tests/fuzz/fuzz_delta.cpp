// libFuzzer target for the delta frame reader (proto/DELTA.md): any bytes, applied after the
// keyframe proto/vectors/delta_cornell_0.vmd, either decode to a frame whose triangles keep the
// format's promises or are refused with InputError. Seeds: the vectors' delta frames.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>

#include "core/error.h"
#include "core/stream/delta.h"
#include "core/util/conform.h"

namespace {
const vismap::DeltaDecoder& after_keyframe() {
  static vismap::DeltaDecoder d = [] {
    std::ifstream in(VISMAP_SOURCE_DIR "/proto/vectors/delta_cornell_0.vmd", std::ios::binary);
    std::stringstream ss;
    ss << in.rdbuf();
    vismap::DeltaDecoder dec;
    dec.decode(ss.str());
    return dec;
  }();
  return d;
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace vismap;
  DeltaDecoder dec = after_keyframe();
  try {
    const DeltaFrame f = dec.decode(std::string(reinterpret_cast<const char*>(data), size));
    for (size_t t = 0; t < f.triangle_count(); ++t) {
      const uint32_t* i = &f.indices[3 * t];
      for (int k = 0; k < 3; ++k)
        if (i[k] >= f.xy.size() / 2) std::abort();
      if (orient2(&f.xy[2 * i[0]], &f.xy[2 * i[1]], &f.xy[2 * i[2]]) <= 0) std::abort();
      if (f.mesh[t] >= f.mesh_color.size()) std::abort();
    }
    if (f.shade.size() != f.triangle_count()) std::abort();
  } catch (const InputError&) {
  }
  return 0;
}
