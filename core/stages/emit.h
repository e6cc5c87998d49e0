// Stage emit (kernels/emit.cl, then core/stages/map_build.cpp on the host): the visible fragments
// compacted on the device and read back with their sources, then turned into the planar map's
// vertices (each the exact intersection of two lines, rounded once).
#pragma once

#include <cstdint>
#include <vector>

#include "core/device/cl_runtime.h"
#include "core/stages/clip.h"
#include "core/stages/map_build.h"
#include "core/stages/occlusion.h"
#include "core/stages/transform.h"

namespace vismap::stages {

struct Emitted {
  VisibleFragments fragments;
  uint32_t totals[VM_TOTAL_SLOTS] = {};
  std::vector<VmScreenTri> tris;  // the region's screen triangles, when asked for
  std::vector<float> bary;        // their barycentrics (9 floats each), when asked for
};

// Reads the visible fragments and the totals back (one blocking read). The screen triangles and
// barycentrics are read without blocking: complete once the queue has finished
// (ClRuntime::collect_profile waits for it). `out` must stay in place until then.
void read_visible(ClRuntime& rt, const Fragments& fr, const Visibility& vis, const ScreenSet& s,
                  bool want_tris, bool want_bary, cl::Buffer& totals, Emitted& out);

}  // namespace vismap::stages
