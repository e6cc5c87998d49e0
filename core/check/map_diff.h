// Are two planar maps of one view the same picture? For each source triangle, the region its
// fragments cover in one map against the other, exactly (the maps' exact vertices, rational
// arithmetic): the culled frame against the frame that clips every triangle (issue 32's proof that
// leaving out what is provably hidden changes no visible point), or any two maps that must show
// the same thing while their fragments may be cut differently.
#pragma once

#include <cstddef>
#include <string>

#include "core/planar_map.h"

namespace vismap::check {

struct MapDiff {
  size_t sources = 0;    // sources visible in either map
  size_t differing = 0;  // sources whose regions differ (xor of positive area)
  size_t fragments_a = 0, fragments_b = 0;
  double xor_area = 0;      // square pixels, summed over sources
  double visible_area = 0;  // square pixels, map a
  bool exact = false;       // both maps had exact vertices (else the rounded doubles, and a
                            // difference below output rounding is not counted)
  bool same() const { return differing == 0; }
  std::string summary() const;
};

// Both maps need RenderOptions::exact for an exact answer; without it the rounded vertices are
// compared and a source differs only past what rounding to the 2^-28 px lattice can explain.
MapDiff compare_maps(const PlanarMap& a, const PlanarMap& b);

}  // namespace vismap::check
