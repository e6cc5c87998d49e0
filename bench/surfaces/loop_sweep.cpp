// Killeroo Loop subdivision at 1024x1024: level, triangles and warm tessellate time per tolerance.
// Build: g++ -O2 -std=c++20 -I. bench/surfaces/loop_sweep.cpp build/libvismap_core.a ... (see
// docs/SURFACES.md); run from the repository root.
#include <cstdio>

#include "core/error.h"
#include "core/pipeline.h"

int main(int argc, char** argv) {
  using namespace vismap;
  Scene s = load_scene(argc > 1 ? argv[1] : "../shared/data/killeroo/killeroo.pbrt");
  Camera cam = frame_scene(s, 1024, 1024);
  Renderer r;
  for (float tol : {2.0f, 1.0f, 0.5f, 0.2f}) {
    TessellateOptions o;
    o.tolerance_px = tol;
    TessellateStats st;
    try {
      r.tessellate(s, cam, o, &st);
    } catch (const InputError& e) {
      std::printf("tolerance %.2f px: %s\n", tol, e.what());
      continue;
    }  // builds the plan's levels (host, once)
    double cold = st.ms;
    double best = 1e30;
    for (int i = 0; i < 5; ++i) {
      r.tessellate(s, cam, o, &st);
      best = std::min(best, st.ms);
    }
    std::printf("tolerance %.2f px: level %u, %llu triangles, first %.1f ms, warm %.1f ms\n", tol,
                st.subdivision_level, (unsigned long long)st.triangles, cold, best);
  }
}
