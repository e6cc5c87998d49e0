// Fewer, larger polygons for the delta frame (proto/DELTA.md, "Encoding"). The planar map's
// fragments of one source triangle are cut along every silhouette line the clipping met, also
// where what cast it lies behind the triangle (hidden): the bunny cut by two planes
// (data/scenes/bunny_cut.json) has each plane in thousands of pieces, most of them where nothing
// hides the plane. Sending those pieces costs what sending the plane whole would not.
#pragma once

#include <cstdint>
#include <vector>

#include "core/util/conform.h"

namespace vismap {

struct SimplifyStats {
  uint64_t merged = 0;   // polygons merged into a neighbour of the same source
  uint64_t dropped = 0;  // flat vertices dropped from the polygons that had them
};

// Merges neighbouring polygons of one source (source[p]: any key, equal for polygons of the same
// source triangle) whose union is convex, and drops the vertices that at most two polygons have
// and that lie, in each, within 1e-6 px of the segment between the nearest corners kept on
// either side. The polygons still conform (both sides of every edge have the same
// vertices, no T-junction) and stay convex (corners at most 1e-6 px reflex); off, v, fragment and
// original are rewritten (original: the corner count of a polygon that changed).
SimplifyStats merge_source_polygons(ConformedPolygons& polygons,
                                    const std::vector<uint64_t>& source);

}  // namespace vismap
