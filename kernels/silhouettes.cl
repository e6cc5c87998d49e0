/* Stage: silhouette edges from a spatial hash (SVGPU §3.1). Every screen-triangle edge is keyed
 * by its two endpoints' snapped position and nearness (so shared edges of indexed meshes and of
 * soup with duplicated vertices meet, and so do the pieces of an edge split by the near plane).
 * An edge is NOT a silhouette only when exactly two triangles share it and they lie on opposite
 * sides of it on the screen (the surface continues across it). Boundary edges (one triangle),
 * non-manifold edges (three or more) and folds (both on the same side) are silhouettes. Treating
 * an edge as a silhouette when in doubt is always safe: it only adds clipping lines. */

typedef struct {
  int x0, y0, x1, y1;
  ulong q0, q1;
} EdgeKey;

inline bool vtx_before(int xa, int ya, ulong qa, int xb, int yb, ulong qb) {
  if (xa != xb) return xa < xb;
  if (ya != yb) return ya < yb;
  return qa < qb;
}

inline EdgeKey edge_key(__global const VmScreenTri* tris, uint e) {
  uint t = e / 3, k = e % 3, k1 = k == 2 ? 0 : k + 1;
  __global const VmScreenTri* s = &tris[t];
  int xa = s->x[k], ya = s->y[k], xb = s->x[k1], yb = s->y[k1];
  ulong qa = as_ulong(s->q[k]), qb = as_ulong(s->q[k1]);
  EdgeKey key;
  if (vtx_before(xb, yb, qb, xa, ya, qa)) {
    key.x0 = xb;
    key.y0 = yb;
    key.q0 = qb;
    key.x1 = xa;
    key.y1 = ya;
    key.q1 = qa;
  } else {
    key.x0 = xa;
    key.y0 = ya;
    key.q0 = qa;
    key.x1 = xb;
    key.y1 = yb;
    key.q1 = qb;
  }
  return key;
}

inline bool key_equal(EdgeKey a, EdgeKey b) {
  return a.x0 == b.x0 && a.y0 == b.y0 && a.x1 == b.x1 && a.y1 == b.y1 && a.q0 == b.q0 &&
         a.q1 == b.q1;
}

inline uint key_hash(EdgeKey k) {
  ulong h = 1469598103934665603UL;
  h = (h ^ (uint)k.x0) * 1099511628211UL;
  h = (h ^ (uint)k.y0) * 1099511628211UL;
  h = (h ^ (uint)k.x1) * 1099511628211UL;
  h = (h ^ (uint)k.y1) * 1099511628211UL;
  h = (h ^ k.q0) * 1099511628211UL;
  h = (h ^ k.q1) * 1099511628211UL;
  return (uint)(h ^ (h >> 29));
}

/* table: 0 = empty, else the id + 1 of the edge that claimed the slot; second: the same for the
 * second edge with that key; many: 1 once a third comes, and then slot_min the lowest id of all
 * (every edge from the third on folds in itself and the first two). Usual edges (two triangles)
 * cost one or two compare-and-swaps, not one per counter. All start at 0 but slot_min
 * (0xffffffff). */
/* The table's four arrays as edge_insert expects them, in one launch (issue 17: not four fills). */
/* Also zeroes edge_classify's groups counts (groups <= size). */
__kernel void edge_table_clear(uint size, __global uint* table, __global uint* second,
                               __global uint* many, __global uint* slot_min,
                               __global uint* group_sums, uint groups) {
  uint i = get_global_id(0);
  if (i >= size) return;
  if (i < groups) group_sums[i] = 0;
  table[i] = 0;
  second[i] = 0;
  many[i] = 0;
  slot_min[i] = 0xffffffffu;
}

__kernel void edge_insert(__global const VmScreenTri* tris, uint nedges, __global uint* table,
                          uint mask, __global uint* slot_of_edge, __global uint* second,
                          __global uint* many, __global uint* slot_min, __global uint* status) {
  uint e = get_global_id(0);
  if (e >= nedges) return;
  EdgeKey key = edge_key(tris, e);
  uint h = key_hash(key) & mask;
  for (uint probe = 0; probe <= mask; ++probe) {
    uint old = atomic_cmpxchg(&table[h], 0u, e + 1);
    if (old == 0 || key_equal(edge_key(tris, old - 1), key)) {
      slot_of_edge[e] = h;
      if (old != 0) {
        uint b = atomic_cmpxchg(&second[h], 0u, e + 1);
        if (b != 0) {
          many[h] = 1;
          atomic_min(&slot_min[h], min(e, min(old, b) - 1));
        }
      }
      return;
    }
    h = (h + 1) & mask;
  }
  atomic_or(status, VM_STATUS_HASH_FULL);
}

/* The vertex of triangle t opposite its edge k. */
inline void opposite_vertex(__global const VmScreenTri* tris, uint e, long* x, long* y) {
  uint t = e / 3, k2 = (e % 3 + 2) % 3;
  *x = tris[t].x[k2];
  *y = tris[t].y[k2];
}

/* How edge e's key is shared: by one triangle (VM_EDGE_ONE), by three or more (VM_EDGE_MANY), or
 * by exactly two, the other being the edge returned (layout.h). */
/* A third edge is told by slot_min, which edge_insert lowers exactly when it sets many[s], not by
 * many[s]: edge_classify's items of such a slot atomic_or their sides into many[s] meanwhile, and
 * a plain read racing an atomic is undefined in OpenCL 1.2, which has no atomic load (issue 51,
 * oclgrind --data-races; benign by design, every order reading nonzero, but an atomic read there
 * took the bunny's silhouettes from 75 to 128 ms on PoCL). */
inline uint edge_partner(uint e, uint s, __global const uint* table, __global const uint* second,
                         __global const uint* slot_min) {
  if (slot_min[s] != 0xffffffffu) return VM_EDGE_MANY;
  const uint a = table[s] - 1, b = second[s];
  if (b == 0) return VM_EDGE_ONE;
  return a == e ? b - 1 : a;
}

/* The side of edge e's key (in its canonical direction) that e's triangle lies on: > 0 left. */
inline long key_side(__global const VmScreenTri* tris, uint e) {
  EdgeKey key = edge_key(tris, e);
  long x, y;
  opposite_vertex(tris, e, &x, &y);
  return orient_points(key.x0, key.y0, key.x1, key.y1, x, y);
}

/* Whether the key of edge e (shared with `partner`) is a silhouette: a boundary, non-manifold
 * edge or a fold (both triangles on one side of it). */
inline uint key_is_silhouette(__global const VmScreenTri* tris, uint e, uint partner) {
  if (partner == VM_EDGE_ONE || partner == VM_EDGE_MANY) return 1;
  const long sa = key_side(tris, e), sb = key_side(tris, partner);
  return (sa > 0 && sb < 0) || (sa < 0 && sb > 0) ? 0 : 1;
}

/* flags[e] = 1 when edge e is the representative (lowest id) of a silhouette edge, and each block
 * of VM_SCAN_WG edges' count of them (edge_emit's work-groups) into group_sums by atomics:
 * silhouettes are a small share of the edges, and the sums are the same in any order. No
 * barrier: on PoCL this kernel ran ~20 % slower as a fused scan (a work-group loop around its
 * hash lookups). For the cull (cull.cl) and the classification after it (edge_reclassify), also
 * every edge's partner and whether its key is a silhouette (key_sil). */
__kernel void edge_classify(__global const VmScreenTri* tris, uint nedges,
                            __global const uint* slot_of_edge, __global const uint* table,
                            __global const uint* second, __global uint* many,
                            __global const uint* slot_min, __global uint* flags,
                            __global uint* group_sums, __global uint* partners,
                            __global uchar* key_sil) {
  const uint e = get_global_id(0);
  if (e >= nedges) return;
  const uint s = slot_of_edge[e];
  const uint p = edge_partner(e, s, table, second, slot_min);
  if (p == VM_EDGE_MANY) { /* (rare) the cull asks the slot which sides its triangles cover */
    atomic_or(&many[s], key_side(tris, e) > 0 ? VM_SIDE_LEFT : VM_SIDE_RIGHT);
    partners[e] = s;
    key_sil[e] = VM_KEY_SIL_MANY;
  } else {
    partners[e] = p;
  }
  /* A key two edges share is judged once, by the lower, which writes both edges' key_sil. */
  uint f;
  if (p == VM_EDGE_MANY) {
    f = slot_min[s] == e;
  } else if (p == VM_EDGE_ONE) {
    f = 1;
    key_sil[e] = 1;
  } else if (e < p) {
    f = key_is_silhouette(tris, e, p);
    key_sil[e] = key_sil[p] = (uchar)f;
  } else {
    f = 0;
  }
  flags[e] = f;
  if (f) atomic_inc(&group_sums[e / VM_SCAN_WG]);
}

/* The silhouettes of the triangles the cull kept (keep[t]), from edge_classify's partners: an
 * edge of two kept triangles as before; of a kept and a culled one, a boundary now, written by
 * the kept one's edge; of one kept triangle, a boundary; three or more, a silhouette as before
 * (written once, whatever was culled: an extra silhouette only adds a clipping line). Edges of
 * culled triangles only are left out. */
__kernel void edge_reclassify(uint nedges, __global const uint* keep, __global const uint* partners,
                              __global const uchar* key_sil, __global const uint* flags_all,
                              __global uint* flags, __global uint* group_sums) {
  const uint e = get_global_id(0);
  if (e >= nedges) return;
  const uint p = partners[e], kept = keep[e / 3];
  uint f;
  if (key_sil[e] == VM_KEY_SIL_MANY)
    f = flags_all[e];
  else if (p == VM_EDGE_ONE)
    f = kept;
  else
    f = kept && keep[p / 3] ? flags_all[e] : kept;
  flags[e] = f;
  if (f) atomic_inc(&group_sums[e / VM_SCAN_WG]);
}

/* Writes each silhouette edge at its group's base (the counts before it) plus its place among
 * its group's silhouettes, counted by the edge itself (silhouettes are few: cheaper than a
 * work-group scan of every edge's flag, ~8x on PoCL). */
__kernel __attribute__((reqd_work_group_size(VM_SCAN_WG, 1, 1))) void edge_emit(
    __global const VmScreenTri* tris, uint nedges, __global const uint* flags,
    __global const uint* group_bases, uint groups,
    __global VmEdge* edges, __global int4* bb) {
  const uint e = get_global_id(0);
  const uint base = vm_group_base(group_bases, groups);
  if (e >= nedges || !flags[e]) return;
  uint o = base;
  for (uint j = e - get_local_id(0); j < e; ++j) o += flags[j];
  EdgeKey key = edge_key(tris, e);
  VmEdge out;
  out.x0 = key.x0;
  out.y0 = key.y0;
  out.x1 = key.x1;
  out.y1 = key.y1;
  out.q0 = as_double(key.q0);
  out.q1 = as_double(key.q1);
  edges[o] = out;
  /* its box, for binning on the edge grid (bin.cpp bin_edges) */
  bb[o] = (int4)(min(out.x0, out.x1), min(out.y0, out.y1), max(out.x0, out.x1),
                                 max(out.y0, out.y1));
}
