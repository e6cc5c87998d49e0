/* Stage: binning into uniform tiles (MPR-style: a tile keeps only what can touch it).
 * Items are given by grid bounding boxes (int4: x0, y0, x1, y1, inclusive); count per tile,
 * scan (host), fill per tile, and sort each tile's list by item id so that everything downstream
 * is deterministic whatever order the atomics ran in. */

/* Also each triangle's nearness range, so pair tests can reject by depth before loading it. */
__kernel void tri_bbox(__global const VmScreenTri* tris, uint n, __global int4* bb,
                       __global double2* qr) {
  uint i = get_global_id(0);
  if (i >= n) return;
  VmScreenTri t = tris[i];
  bb[i] = (int4)(min(min(t.x[0], t.x[1]), t.x[2]), min(min(t.y[0], t.y[1]), t.y[2]),
                 max(max(t.x[0], t.x[1]), t.x[2]), max(max(t.y[0], t.y[1]), t.y[2]));
  qr[i] = (double2)(fmin(fmin(t.q[0], t.q[1]), t.q[2]), fmax(fmax(t.q[0], t.q[1]), t.q[2]));
}

__kernel void edge_bbox(__global const VmEdge* edges, uint n, __global int4* bb) {
  uint i = get_global_id(0);
  if (i >= n) return;
  VmEdge e = edges[i];
  bb[i] = (int4)(min(e.x0, e.x1), min(e.y0, e.y1), max(e.x0, e.x1), max(e.y0, e.y1));
}

/* Tiles are powers of two wide: a shift, not a division, in the hottest loops. */
inline int tile_coord(int v, int shift, int count) { return clamp(v >> shift, 0, count - 1); }

/* The tiles (x0, y0, x1, y1, inclusive) that a grid box touches. */
inline int4 tile_range(int4 b, VmGrid g) {
  return (int4)(tile_coord(b.x, g.tile_shift, g.tiles_x), tile_coord(b.y, g.tile_shift, g.tiles_y),
                tile_coord(b.z, g.tile_shift, g.tiles_x), tile_coord(b.w, g.tile_shift, g.tiles_y));
}

/* Should the pair of boxes a, b be looked at in tile (tx, ty)? Only in the tile holding the low
 * corner of their overlap, so a pair that shares several tiles is visited once. `open`: boxes
 * that only touch (zero-width overlap) are skipped too. */
inline bool pair_here(int4 a, int4 b, VmGrid g, int tx, int ty, bool open) {
  int ix0 = max(a.x, b.x), iy0 = max(a.y, b.y);
  int ix1 = min(a.z, b.z), iy1 = min(a.w, b.w);
  if (open ? (ix0 >= ix1 || iy0 >= iy1) : (ix0 > ix1 || iy0 > iy1)) return false;
  return tile_coord(ix0, g.tile_shift, g.tiles_x) == tx && tile_coord(iy0, g.tile_shift, g.tiles_y) == ty;
}

/* Insertion sort of a short list of ids (per-tile and per-triangle lists). */
inline void sort_ids(__global uint* a, int n) {
  for (int i = 1; i < n; ++i) {
    uint v = a[i];
    int j = i - 1;
    while (j >= 0 && a[j] > v) {
      a[j + 1] = a[j];
      --j;
    }
    a[j + 1] = v;
  }
}

__kernel void bin_count(__global const int4* bb, uint n, VmGrid g, __global uint* tile_count) {
  uint i = get_global_id(0);
  if (i >= n) return;
  int4 b = bb[i];
  int4 tr = tile_range(b, g);
  int tx0 = tr.x, ty0 = tr.y, tx1 = tr.z, ty1 = tr.w;
  for (int ty = ty0; ty <= ty1; ++ty)
    for (int tx = tx0; tx <= tx1; ++tx) atomic_inc(&tile_count[ty * g.tiles_x + tx]);
}

__kernel void bin_fill(__global const int4* bb, uint n, VmGrid g, __global const uint* tile_offset,
                       __global uint* tile_cursor, __global uint* list) {
  uint i = get_global_id(0);
  if (i >= n) return;
  int4 b = bb[i];
  int4 tr = tile_range(b, g);
  int tx0 = tr.x, ty0 = tr.y, tx1 = tr.z, ty1 = tr.w;
  for (int ty = ty0; ty <= ty1; ++ty)
    for (int tx = tx0; tx <= tx1; ++tx) {
      uint t = ty * g.tiles_x + tx;
      list[tile_offset[t] + atomic_inc(&tile_cursor[t])] = i;
    }
}

/* Sorts n ids (or keys) ascending: insertion sort for short lists, heap sort for long ones. */
inline void sort_list(__global uint* a, int n) {
  if (n <= 32) {
    sort_ids(a, n);
    return;
  }
  /* heap sort */
  for (int start = n / 2 - 1; start >= 0; --start) {
    int root = start;
    while (2 * root + 1 < n) {
      int child = 2 * root + 1;
      if (child + 1 < n && a[child] < a[child + 1]) ++child;
      if (a[root] >= a[child]) break;
      uint tmp = a[root]; a[root] = a[child]; a[child] = tmp;
      root = child;
    }
  }
  for (int end = n - 1; end > 0; --end) {
    uint tmp = a[0]; a[0] = a[end]; a[end] = tmp;
    int root = 0;
    while (2 * root + 1 < end) {
      int child = 2 * root + 1;
      if (child + 1 < end && a[child] < a[child + 1]) ++child;
      if (a[root] >= a[child]) break;
      uint t2 = a[root]; a[root] = a[child]; a[child] = t2;
      root = child;
    }
  }
}

/* One work-item per tile. */
__kernel void bin_sort(__global const uint* tile_offset, __global const uint* tile_count,
                       uint ntiles, __global uint* list) {
  uint t = get_global_id(0);
  if (t >= ntiles) return;
  sort_list(list + tile_offset[t], (int)tile_count[t]);
}

/* Where an item's box starts relative to a tile it is listed in: class 0 starts in the tile in
 * both x and y (the item's home tile), 1 in x only, 2 in y only, 3 in neither. The pair of boxes
 * a, b is owned by the tile holding the low corner of their overlap (pair_here), which is tile
 * (tx, ty) exactly when a or b starts there in x and a or b starts there in y (tile coordinates
 * are monotone and both boxes reach the tile). So an item of class c in a tile only needs the
 * entries of some classes (partner_classes): all for class 0; classes 0 and 2 for class 1;
 * 0 and 1 for class 2; 0 for class 3. */
inline uint box_class(int4 b, VmGrid g, int tx, int ty) {
  return (tile_coord(b.x, g.tile_shift, g.tiles_x) == tx ? 0u : 1u) |
         (tile_coord(b.y, g.tile_shift, g.tiles_y) == ty ? 0u : 2u);
}

/* Like bin_sort, ordering each tile's list by (class, id) and writing where classes 1, 2 and 3
 * begin (x, y, z; w = the count). Ids are below 2^30 (the host checks), so the class fits in the
 * top two bits of the sort key. */
__kernel void bin_sort_classes(__global const uint* tile_offset, __global const uint* tile_count,
                               uint ntiles, __global const int4* bb, VmGrid g, __global uint* list,
                               __global uint4* class_start) {
  uint t = get_global_id(0);
  if (t >= ntiles) return;
  int tx = (int)(t % (uint)g.tiles_x), ty = (int)(t / (uint)g.tiles_x);
  __global uint* a = list + tile_offset[t];
  int n = (int)tile_count[t];
  for (int k = 0; k < n; ++k) a[k] |= box_class(bb[a[k]], g, tx, ty) << 30;
  sort_list(a, n);
  uint4 cs = (uint4)(n, n, n, n);
  for (int k = n - 1; k >= 0; --k) {
    uint c = a[k] >> 30;
    if (c >= 1) cs.x = k;
    if (c >= 2) cs.y = k;
    if (c == 3) cs.z = k;
    a[k] &= 0x3fffffffu;
  }
  /* cs.x: first entry of class >= 1, cs.y: of class >= 2, cs.z: of class 3 */
  class_start[t] = cs;
}

/* The classes (bit mask) whose entries an item of class c must pair with in a tile. */
inline uint partner_classes(uint c) { return c == 0 ? 15u : c == 1 ? 5u : c == 2 ? 3u : 1u; }

/* Where class c begins in a tile's list, from its class starts (class 4: the end). */
inline uint class_begin(uint4 cs, uint c) {
  return c == 0 ? 0u : c == 1 ? cs.x : c == 2 ? cs.y : c == 3 ? cs.z : cs.w;
}

/* First index in the ascending ids a[lo, hi) holding an id above t. */
inline uint first_above(__global const uint* a, uint lo, uint hi, uint t) {
  while (lo < hi) {
    uint mid = (lo + hi) >> 1;
    if (a[mid] <= t) lo = mid + 1; else hi = mid;
  }
  return lo;
}
