// libFuzzer target for the scene loaders (core/load_scene_from_memory). The first input byte picks
// the format (by the name's extension), the rest is the file. The contract under test: any bytes
// either load or throw InputError; nothing else (no crash, no other exception, no leak, no UB).
// Build and run: fuzz/README.md.
#include <cstddef>
#include <cstdint>
#include <string>

#include "core/error.h"
#include "core/scene.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  // New formats go at the end, so that the seeds' format bytes keep their meaning.
  static const char* names[] = {"f.ply", "f.ply.gz", "f.obj",  "f.off", "f.stl",     "f.gltf",
                                "f.glb", "f.json",   "f.pbrt", "f.bpt", "f.patches", "f.sexp"};
  constexpr size_t kNames = sizeof(names) / sizeof(names[0]);
  if (size < 1) return 0;
  const std::string name = names[data[0] % kNames];
  const std::string bytes(reinterpret_cast<const char*>(data + 1), size - 1);
  vismap::LoadOptions opts;
  opts.max_triangles = 1u << 20;  // keeps the fuzzer's memory bounded; TooLarge is an InputError
  opts.max_bytes = 16u << 20;     // and a gzip bomb (the seed gzip_bomb) stops at 16 MiB inflated
  opts.time_limit_s = 5;          // an implicit's bounds search ends within libFuzzer's -timeout
  try {
    vismap::Scene s = vismap::load_scene_from_memory(name, bytes, opts);
    (void)s;
  } catch (const vismap::InputError&) {
  }
  return 0;
}
