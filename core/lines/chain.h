// The classified map edges of one kind chained into polylines (lines.cpp's last step): maximal
// paths through points where exactly two segments meet, a T-junction's straightest pair going
// on; simplified (Douglas-Peucker) and selected by length. Internal to core/lines/.
#pragma once

#include <cstdint>
#include <vector>

#include "core/lines/lines.h"

namespace vismap::lines_detail {

struct Seg {
  uint32_t a, b;  // point indices into xy
};

// Chains: maximal paths of segs (over points xy) through points where exactly two of them
// meet, appended to out as chains of this kind.
void chain(const std::vector<double>& xy, const std::vector<Seg>& S, LineKind kind, bool hidden,
           double simplify_px, double min_length_px, LineSet& out);

}  // namespace vismap::lines_detail
