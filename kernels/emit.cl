/* Stage: planar map. The visible fragments are compacted into one contiguous list (scan of the
 * visibility flags) for the host to read back; the host turns line pairs into exact vertices
 * (core/planar_map_build.cpp) so that shared vertices round identically. */

__kernel __attribute__((reqd_work_group_size(VM_SCAN_WG, 1, 1))) void emit_visible(
    __global const VmFragMeta* meta, __global const VmLine* lines, uint n,
    __global const uint* visible, __global const uint* offsets, __global const uint* group_bases, uint groups, __global const VmScreenTri* tris,
    __global VmFragMeta* out_meta, __global VmLine* out_lines, __global uint2* out_src) {
  const uint i = get_global_id(0);
  const uint base = vm_group_base(group_bases, groups); /* (occlude's scan) */
  if (i >= n || !visible[i]) return;
  uint o = base + offsets[i];
  VmFragMeta m = meta[i];
  out_meta[o] = m;
  out_src[o] = (uint2)(tris[m.tri].mesh, tris[m.tri].tri);
  for (uint j = 0; j < m.nlines; ++j)
    out_lines[(size_t)o * VM_MAXL + j] = lines[(size_t)i * VM_MAXL + j];
}
