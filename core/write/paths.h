// The filled paths and the line chains as the vector writers draw them (core/write/svg.cpp,
// core/write/cairo.cpp): one path per source triangle, every vertex rounded once to 1/100 px,
// the seam strokes' edge flags, the fill colours. Shared so that SVG, PDF, EPS and PNG draw the
// same geometry in the same colours; not part of the public API.
#pragma once

#include <cmath>
#include <cstdint>
#include <vector>

#include "core/camera.h"
#include "core/lines/lines.h"
#include "core/planar_map.h"
#include "core/scene.h"
#include "core/write/output.h"

namespace vismap::detail {

constexpr int64_t kUnit = 100;  // units per pixel: every vertex is rounded once to 1/kUnit px

struct Q {
  int64_t x, y;
  bool operator==(const Q& o) const { return x == o.x && y == o.y; }
};

inline int64_t quantize(double v) {
  return std::llround(v * double(kUnit));
}

// The map's vertices in units, consecutive duplicates removed; a fragment that collapses
// below 3 distinct points is empty (it covers nothing at this precision).
struct QuantizedMap {
  std::vector<Q> v;
  std::vector<uint32_t> off{0};  // per fragment
  std::vector<uint8_t> shared;   // per edge (same index as its first vertex): stroke it
};

// Where the writers send a path: move, line, close (the closing edge is stroked; an open
// subpath's implicit closing edge is filled, not stroked).
class PathSink {
 public:
  virtual void move(Q q) = 0;
  virtual void line(Q q) = 0;
  virtual void close() = 0;

 protected:
  ~PathSink() = default;
};

// Writes fragment f of the quantized map. Without edge flags (Fill::Id) it is a closed polygon;
// with them, unshared edges are never stroked (core/write/paths.cpp's header).
void write_fragment(PathSink& d, const QuantizedMap& q, size_t f, bool use_flags);

// One path per source triangle that has something to draw, in drawing order.
struct TrianglePath {
  uint32_t mesh, tri;
  uint32_t color;      // #RRGGBB: the shade (sRGB) or the global id + 1
  size_t first, last;  // range in FillPlan::order
};
struct FillPlan {
  QuantizedMap q;
  std::vector<uint32_t> order;  // fragments ordered by (mesh, triangle)
  std::vector<TrianglePath> paths;
  bool stroke_seams = false;  // Fill::Shade: q.shared is set; stroke each path in its colour
};
// Quantizes the map, conforms its T-junctions (Fill::Id) or flags its shared edges
// (Fill::Shade), computes the colours (shade paths sorted by mesh, then colour). Throws
// InputError (`writer` named) when an id does not fit 24 bits.
FillPlan plan_fills(const PlanarMap& map, const Scene& scene, const Camera& camera, Fill fill,
                    const char* writer);

// Chain c's points in units, points that round onto the previous dropped (at least one).
void chain_points(const LineSet& lines, size_t c, std::vector<Q>& out);

// Lambert shade times the mesh colour, as sRGB #RRGGBB.
uint32_t shade_color(const Scene& scene, const Camera& cam, uint32_t mesh, uint32_t tri);
// Fragment f's fill: the shade colour of its source, or (shade false) its global id + 1;
// InputError TooLarge (naming `writer`) when the id does not fit 24 bits.
uint32_t fill_color(const PlanarMap& map, const Scene& scene, const Camera& camera, bool shade,
                    const std::vector<uint64_t>& base, size_t f, const char* writer);

}  // namespace vismap::detail
