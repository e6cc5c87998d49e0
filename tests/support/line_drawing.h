// Helpers shared by the line drawing tests: a frame rendered with its screen triangles kept and
// its lines extracted, and a walk over a drawing's segments.
#pragma once

#include "core/lines/lines.h"
#include "core/pipeline.h"
#include "core/scene.h"

namespace vismap::test_support {

inline Renderer& line_renderer() {
  static Renderer r;
  return r;
}

struct Drawn {
  PlanarMap map;
  ScreenTriangles screen;
  LineSet lines;
};

inline Drawn draw_lines(const Scene& s, const Camera& cam, const LineOptions& o = {}) {
  Drawn d;
  RenderOptions ro;
  ro.keep_screen_triangles = true;
  d.map = line_renderer().render(s, cam, ro, nullptr, &d.screen);
  d.lines = extract_lines(d.map, d.screen, s, cam, o);
  return d;
}

// Calls f(c, a, b) for each segment of every chain c of `l` (a, b: its ends, x and y each).
template <class F>
void for_each_segment(const LineSet& l, F&& f) {
  for (size_t c = 0; c < l.chain_count(); ++c) {
    const uint32_t n = l.off[c + 1] - l.off[c];
    for (uint32_t i = 0; i + 1 < n + l.closed[c]; ++i)
      f(c, &l.xy[2 * (l.off[c] + i)], &l.xy[2 * (l.off[c] + (i + 1) % n)]);
  }
}

}  // namespace vismap::test_support
