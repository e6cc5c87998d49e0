/* Stage: candidates. For every screen triangle, the clipping edges that may cut it (SVGPU §3.2's
 * "edges in front"): first its own crossing entries (crossings.cl), then the silhouette edges
 * found through the edge leaves (bin.cl) that pass the exact side tests and a conservative depth
 * test. Count, scan, fill: the list is the clipping rounds' (clip.cl) input. */

/* Candidate edges of a screen triangle: silhouette edges whose segment meets the triangle's
 * interior, whose line strictly separates its corners, and which may be in front of it
 * somewhere (nearness is affine along the edge and over the triangle's plane, so checking the
 * two endpoints against the plane, with a band, is conservative). */
inline bool edge_is_candidate(__global const VmScreenTri* T, VmEdge E) {
  Line3 LE = line_of(E.x0, E.y0, E.x1, E.y1);
  int pos = 0, neg = 0;
  for (int i = 0; i < 3; ++i) {
    long s = line_eval_point(LE, T->x[i], T->y[i]);
    pos |= s > 0;
    neg |= s < 0;
  }
  if (!(pos && neg)) return false;
  for (int i = 0; i < 3; ++i) {
    int j = i == 2 ? 0 : i + 1;
    Line3 L = line_of(T->x[i], T->y[i], T->x[j], T->y[j]);
    if (line_eval_point(L, E.x0, E.y0) <= 0 && line_eval_point(L, E.x1, E.y1) <= 0) return false;
  }
  VmScreenTri t = *T;
  DepthPlane P = depth_plane(&t);
  double qa = plane_at(P, (double)E.x0, (double)E.y0);
  double qb = plane_at(P, (double)E.x1, (double)E.y1);
  double scale = fmax(fmax(fabs(qa), fabs(qb)), fmax(fabs(E.q0), fabs(E.q1)));
  /* Snapping moved every vertex by up to half a grid unit, so a point on the edge and the plane
   * of T can disagree by the plane's change over about one grid unit: the band covers that,
   * twice the tie band, and nothing that could be in front is left out. */
  double band = 2.0 * VM_TIE_EPS * scale + 2.0 * (fabs(P.gx) + fabs(P.gy));
  return E.q0 - qa > -band || E.q1 - qb > -band;
}

/* What the cull proved (cull.cl), for candidates_of: the fine bins' leaves with their bounds, and
 * the screen triangles' depth ranges. on = 0: nothing. */
typedef struct {
  __global const double2* tri_qr;
  __global const uint* tile_leaf;
  __global const double2* leaf_cull;
  VmGrid g;
  int on;
} CullProof;

/* Silhouette edges that pass edge_is_candidate, but not those along which t is proven hidden
 * (cull.cl hidden_along): they cannot change its visibility. */
inline uint candidates_of(uint t, __global const VmScreenTri* tris, __global const int4* tri_bb,
                          __global const VmEdge* edges, __global const int4* edge_bb, VmGrid g,
                          __global const uint* tile_leaf, __global const uint* leaf_offset,
                          __global const uint4* class_start, __global const uint* leaf_list,
                          const CullProof* cp, uint* pruned, __global uint* out) {
  int4 tb = tri_bb[t];
  uint count = 0;
  VM_FOR_EACH_LEAF(w, tb, g, tile_leaf) {
    /* Only the classes of edges whose (closed) box overlap with t's this leaf owns. */
    LeafPartners L;
    if (!leaf_partners(&w, leaf_offset, class_start, leaf_list, &L)) continue;
    VM_FOR_EACH_PARTNER_CLASS(L, c) {
      uint hi = class_begin(L.cs, c + 1);
      for (uint k = class_begin(L.cs, c); k < hi; ++k) {
        uint e = L.list[k];
        int4 eb = edge_bb[e];
        if (max(tb.x, eb.x) > min(tb.z, eb.z) || max(tb.y, eb.y) > min(tb.w, eb.w)) continue;
        if (!edge_is_candidate(&tris[t], edges[e])) continue;
        if (cp->on) {
          const VmScreenTri T = tris[t];
          if (hidden_along(&T, cp->tri_qr[t], eb, cp->g, cp->tile_leaf, cp->leaf_cull)) {
            if (pruned) ++*pruned;
            continue;
          }
        }
        if (out) out[count] = e;
        ++count;
      }
    }
  }
  return count;
}

/* A triangle's candidates: first its crossing lines (edges[nsil + cross_offset[t] ...]), then
 * the silhouette edges in front of it. */
/* Each triangle's count, and its offset within the work-group (scan.cl's fused scan; the
 * group's total to group_sums). */
__kernel __attribute__((reqd_work_group_size(VM_SCAN_WG, 1, 1))) void cand_count(
    __global const VmScreenTri* tris, uint ntris, __global const int4* tri_bb,
    __global const VmEdge* edges, __global const int4* edge_bb, VmGrid g,
    __global const uint* tile_leaf, __global const uint* leaf_offset,
    __global const uint4* class_start, __global const uint* leaf_list,
    __global const uint* cross_count, __global uint* counts, __global uint* offsets,
    __global uint* group_sums, __global const double2* tri_qr, VmGrid cull_grid,
    __global const uint* cull_tile_leaf, __global const double2* leaf_cull, int cull_on,
    __global uint* totals) {
  __local uint tmp[VM_SCAN_WG];
  __local uint pruned_wg;
  const uint t = get_global_id(0);
  if (get_local_id(0) == 0) pruned_wg = 0;
  barrier(CLK_LOCAL_MEM_FENCE);
  const CullProof cp = {tri_qr, cull_tile_leaf, leaf_cull, cull_grid, cull_on};
  uint pruned = 0;
  const uint count = t < ntris ? cross_count[t] + candidates_of(t, tris, tri_bb, edges, edge_bb, g,
                                                                tile_leaf, leaf_offset,
                                                                class_start, leaf_list, &cp,
                                                                &pruned, 0)
                               : 0;
  if (pruned) atomic_add(&pruned_wg, pruned);
  const uint offset = vm_group_offset(count, tmp, group_sums); /* (its barriers order pruned_wg) */
  if (get_local_id(0) == 0 && pruned_wg) atomic_add(&totals[VM_TOTAL_PRUNED], pruned_wg);
  if (t < ntris) {
    counts[t] = count;
    offsets[t] = offset;
  }
}

/* Fills each list at the group's base plus cand_count's offset, and makes the offsets global
 * (the clip rounds read them by triangle). */
__kernel __attribute__((reqd_work_group_size(VM_SCAN_WG, 1, 1))) void cand_fill(
    __global const VmScreenTri* tris, uint ntris, __global const int4* tri_bb,
    __global const VmEdge* edges, __global const int4* edge_bb, VmGrid g,
    __global const uint* tile_leaf, __global const uint* leaf_offset,
    __global const uint4* class_start, __global const uint* leaf_list,
    __global const uint* cross_offset, __global const uint* cross_count, uint nsil,
    __global uint* offsets, __global const uint* group_bases,
    uint groups, __global uint* cand, __global const double2* tri_qr, VmGrid cull_grid,
    __global const uint* cull_tile_leaf, __global const double2* leaf_cull, int cull_on) {
  const uint t = get_global_id(0);
  const CullProof cp = {tri_qr, cull_tile_leaf, leaf_cull, cull_grid, cull_on};
  const uint base = vm_group_base(group_bases, groups);
  if (t >= ntris) return;
  const uint o = base + offsets[t];
  offsets[t] = o;
  uint nc = cross_count[t];
  for (uint k = 0; k < nc; ++k) cand[o + k] = nsil + cross_offset[t] + k;
  candidates_of(t, tris, tri_bb, edges, edge_bb, g, tile_leaf, leaf_offset, class_start, leaf_list,
                &cp, 0, cand + o + nc);
}
