// libFuzzer target for the delta frame reader (proto/DELTA.md): any bytes, applied after the
// keyframe proto/vectors/delta_cornell_0.vmd (version 1), and after the held torus's frames 0-2
// (delta2_torus_*: version 2, facing flips and source-edge references), either decode to a frame
// whose triangles keep the format's promises or are refused with InputError. Seeds: the vectors'
// delta frames (delta2_torus_3 is a compact frame in the stream).
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
std::string vector(const char* name) {
  std::ifstream in(std::string(VISMAP_SOURCE_DIR "/proto/vectors/") + name, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

const vismap::DeltaDecoder& after_keyframe() {
  static vismap::DeltaDecoder d = [] {
    vismap::DeltaDecoder dec;
    dec.decode(vector("delta_cornell_0.vmd"));
    return dec;
  }();
  return d;
}

const vismap::DeltaDecoder& held_torus() {
  static vismap::DeltaDecoder d = [] {
    vismap::DeltaDecoder dec;
    dec.hold_scene(vector("delta2_torus_sources.vmd"));
    for (const char* f : {"delta2_torus_0.vmd", "delta2_torus_1.vmd", "delta2_torus_2.vmd"})
      dec.decode(vector(f));
    return dec;
  }();
  return d;
}

void check(vismap::DeltaDecoder dec, const std::string& bytes) {
  using namespace vismap;
  try {
    const DeltaFrame f = dec.decode(bytes);
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
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string bytes(reinterpret_cast<const char*>(data), size);
  check(after_keyframe(), bytes);
  check(held_torus(), bytes);
  return 0;
}
