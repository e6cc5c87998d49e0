/* Stage: binning (MPR-style: a tile keeps only what can touch it). Items are given by grid
 * bounding boxes (int4: x0, y0, x1, y1, inclusive). A uniform grid of tiles first, each tile
 * one leaf (count per leaf, scan on the host, fill); then each tile chooses a depth from its
 * list, and a crowded tile splits into 2^d x 2^d leaves, the items binned again into leaves.
 * Every leaf's list is sorted, so everything downstream is deterministic whatever order the
 * atomics ran in. */

/* (The boxes binned here are written where their items are: the screen triangles' and their
 * depth ranges by snap_depth_planes, transform.cl; the silhouette edges' by edge_emit.) */

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

/* List entries are keys while binning: the id, and in the top two bits the item's class in that
 * leaf (box_class below; ids are below 2^30, the host checks). */
#define VM_KEY_ID 0x3fffffffu

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
      uint tmp = a[root];
      a[root] = a[child];
      a[child] = tmp;
      root = child;
    }
  }
  for (int end = n - 1; end > 0; --end) {
    uint tmp = a[0];
    a[0] = a[end];
    a[end] = tmp;
    int root = 0;
    while (2 * root + 1 < end) {
      int child = 2 * root + 1;
      if (child + 1 < end && a[child] < a[child + 1]) ++child;
      if (a[root] >= a[child]) break;
      uint t2 = a[root];
      a[root] = a[child];
      a[child] = t2;
      root = child;
    }
  }
}

/* ---- Adaptive leaves (MPR-style: a crowded tile splits until its pieces hold little) --------
 * How a tile's leaves are addressed and walked: leaves.cl. */
#define VM_LEAF_MAX_DEPTH 7 /* leaves down to 8 grid units (1/32 pixel) on 4-pixel tiles */
#ifndef VM_LEAF_CROWDED
#define VM_LEAF_CROWDED 256 /* a tile with more entries than this may split */
#endif

/* Per coarse tile, from its coarse list: the depth minimising an estimate of the work, with
 * e(d) the entries the tile's items would have at depth d (an item is listed in every leaf its
 * box touches): per-leaf overhead + entries + pair visits, the last as if the entries spread
 * evenly, e(d)^2 / 4^d. An uncrowded tile stays one leaf; a tile under a few big triangles does
 * not split (their entries grow with the leaves). Reads the coarse lists by tile (leaf = tile
 * there), not tile_leaf, which it rewrites. */
inline uint best_depth(uint t, __global const uint* tile_offset, __global const uint* tile_count,
                       __global const int4* bb, VmGrid g, __global const uint* list) {
  int tx = (int)(t % (uint)g.tiles_x), ty = (int)(t / (uint)g.tiles_x);
  uint n = tile_count[t], off = tile_offset[t];
  uint best = 0;
  double best_cost = 4.0 + (double)n + (double)n * (double)n;
  /* Splitting costs a second binning pass over all items: only for a crowded tile, and only for
   * a clear gain. */
  if (n > VM_LEAF_CROWDED) {
    best_cost *= 0.5;
    int dmax = min(VM_LEAF_MAX_DEPTH, g.tile_shift - 3);
    for (int d = 1; d <= dmax; ++d) {
      double e = 0;
      for (uint k = 0; k < n; ++k) {
        int4 r = leaf_range(bb[list[off + k] & VM_KEY_ID], g, tx, ty, (uint)d);
        e += (double)((r.z - r.x + 1) * (r.w - r.y + 1));
      }
      double nl = (double)(1u << (2 * d));
      double cost = 4.0 * nl + e + e * e / nl;
      if (cost < best_cost) {
        best_cost = cost;
        best = (uint)d;
      }
    }
  }
  return best;
}

/* Each tile's depth, its 4^d leaves scanned within the work-group (scan.cl's fused scan: the
 * tile's first leaf within the group to first_leaf, the group's total to group_sums; bin_pack
 * adds the bases). */
__kernel __attribute__((reqd_work_group_size(VM_SCAN_WG, 1, 1))) void bin_depth(
    __global const uint* tile_offset, __global const uint* tile_count, uint ntiles,
    __global const int4* bb, VmGrid g, __global const uint* list, __global uint* tile_leaf,
    __global uint* first_leaf, __global uint* group_sums) {
  __local uint tmp[VM_SCAN_WG];
  const uint t = get_global_id(0);
  const uint best = t < ntiles ? best_depth(t, tile_offset, tile_count, bb, g, list) : 0;
  const uint first = vm_group_offset(t < ntiles ? 1u << (2 * best) : 0, tmp, group_sums);
  if (t < ntiles) {
    tile_leaf[t] = t << 4 | best; /* the first leaf as if no tile split (bin_pack) */
    first_leaf[t] = first;
  }
}

/* Zeroes the n leaves' counts and fill cursors and, for the coarse pass (identity set), makes
 * every tile its own single leaf (depth 0, leaf index = tile index): one launch, not three. */
__kernel void leaf_init(uint n, uint identity, __global uint* tile_leaf, __global uint* count,
                        __global uint* cursor) {
  uint t = get_global_id(0);
  if (t >= n) return;
  if (identity) tile_leaf[t] = t << 4;
  count[t] = 0;
  cursor[t] = 0;
}

/* Packs each tile's first leaf (bin_depth's offset plus its group's base) with its depth. Only
 * when some tile split: else every tile's first leaf is its own index, as bin_depth wrote it. */
__kernel __attribute__((reqd_work_group_size(VM_SCAN_WG, 1, 1))) void bin_pack(
    uint ntiles, __global const uint* first_leaf, __global const uint* group_bases, uint groups, __global uint* tile_leaf) {
  const uint t = get_global_id(0);
  const uint base = vm_group_base(group_bases, groups);
  if (t >= ntiles) return;
  tile_leaf[t] = leaf_depth(tile_leaf[t]) | (base + first_leaf[t]) << 4;
}

/* Per item: counts (fill = 0) or fills (fill = 1, with keys) the lists of the leaves its box
 * touches. */
__kernel void leaf_bin(__global const int4* bb, uint n, VmGrid g, __global const uint* tile_leaf,
                       __global uint* leaf_count, __global const uint* leaf_offset,
                       __global uint* leaf_cursor, __global uint* list, int fill) {
  uint i = get_global_id(0);
  if (i >= n) return;
  int4 b = bb[i];
  VM_FOR_EACH_LEAF(w, b, g, tile_leaf) {
    uint leaf = leaf_walk_leaf(&w);
    if (fill)
      list[leaf_offset[leaf] + atomic_inc(&leaf_cursor[leaf])] = i | leaf_walk_class(&w) << 30;
    else
      atomic_inc(&leaf_count[leaf]);
  }
}

/* Per coarse tile, for each of its leaves: sorts the leaf's keys, so its list is ordered by
 * (class, id), writes where classes 1, 2 and 3 begin (x, y, z) and the count (w), and leaves
 * plain ids. Lists in a fixed order keep every kernel that walks them deterministic, whatever
 * order the atomics ran in. */
/* With `cursors` (the cull's, cull.cl cull_bin): each leaf's cursor zeroed, one launch less. */
__kernel void leaf_sort_classes(uint ntiles, __global const uint* tile_leaf,
                                __global const uint* leaf_offset, __global const uint* leaf_count,
                                __global uint* list, __global uint4* class_start, int zero_cursors,
                                __global uint* cursors) {
  uint t = get_global_id(0);
  if (t >= ntiles) return;
  uint tl = tile_leaf[t], first = leaf_first(tl), d = leaf_depth(tl), nleaves = 1u << (2 * d);
  for (uint leaf = first; leaf < first + nleaves; ++leaf) {
    if (zero_cursors) cursors[leaf] = 0;
    __global uint* a = list + leaf_offset[leaf];
    int n = (int)leaf_count[leaf];
    sort_list(a, n);
    uint4 cs = (uint4)(n, n, n, n);
    for (int k = n - 1; k >= 0; --k) {
      uint c = a[k] >> 30;
      if (c >= 1) cs.x = k;
      if (c >= 2) cs.y = k;
      if (c == 3) cs.z = k;
      a[k] &= VM_KEY_ID;
    }
    class_start[leaf] = cs;
  }
}

