#include "core/stages/emit.h"

namespace vismap::stages {

void read_visible(ClRuntime& rt, const Fragments& fr, const Visibility& vis, const ScreenSet& s,
                  bool want_tris, bool want_bary, cl::Buffer& totals, Emitted& out) {
  const uint32_t V = vis.count, L = rt.maxl(), S = s.count;
  VisibleFragments& vf = out.fragments;
  vf.maxl = L;
  vf.meta.resize(V);
  vf.lines.resize(size_t(V) * L);
  std::vector<cl_uint2> src(V);
  if (V > 0) {
    cl::Buffer om = rt.alloc(size_t(V) * sizeof(VmFragMeta), "visible fragments");
    cl::Buffer ol = rt.alloc(size_t(V) * L * sizeof(VmLine), "visible lines");
    cl::Buffer os = rt.alloc(size_t(V) * sizeof(cl_uint2), "visible sources");
    const ClRuntime::GroupSums& g = vis.groups;
    rt.launch_grouped(Stage::Emit, "emit_visible", fr.count, VM_SCAN_WG, fr.meta, fr.lines,
                      fr.count, vis.visible, vis.offset, g.bases, g.groups, s.tris, om, ol,
                      os);
    rt.read_async(Stage::Emit, om, 0, size_t(V) * sizeof(VmFragMeta), vf.meta.data());
    rt.read_async(Stage::Emit, ol, 0, size_t(V) * L * sizeof(VmLine), vf.lines.data());
    rt.read_async(Stage::Emit, os, 0, size_t(V) * sizeof(cl_uint2), src.data());
  }
  rt.read(Stage::Emit, totals, 0, sizeof out.totals, out.totals);  // in order: the reads above are done too
  vf.mesh.resize(V);
  vf.triangle.resize(V);
  for (uint32_t i = 0; i < V; ++i) {
    vf.mesh[i] = src[i].s[0];
    vf.triangle[i] = src[i].s[1];
  }
  if (want_tris || want_bary) {
    out.tris.resize(S);
    rt.read_async(Stage::Emit, s.tris, 0, size_t(S) * sizeof(VmScreenTri), out.tris.data());
  }
  if (want_bary) {
    out.bary.resize(size_t(S) * 9);
    rt.read_async(Stage::Emit, s.bary, 0, out.bary.size() * sizeof(float), out.bary.data());
  }
}

}  // namespace vismap::stages
