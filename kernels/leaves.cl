/* Shared helper: how tiles and their leaves are addressed and walked. The bin stage (bin.cl)
 * builds them; candidates (candidates.cl), crossing pairs (crossings.cl) and occlusion's point
 * lookups (occlusion.cl) read them. A coarse tile at depth d is split into 2^d x 2^d leaves of
 * side tile_size >> d; tile_leaf packs (index of the tile's first leaf << 4) | d. Items are
 * listed per leaf, and a point or a box finds its leaves through its coarse tile. Tiles that are
 * not crowded are their own single leaf. */

/* Tiles are powers of two wide: a shift, not a division, in the hottest loops. */
inline int tile_coord(int v, int shift, int count) {
  return clamp(v >> shift, 0, count - 1);
}

/* The tiles (x0, y0, x1, y1, inclusive) that a grid box touches. */
inline int4 tile_range(int4 b, VmGrid g) {
  return (int4)(tile_coord(b.x, g.tile_shift, g.tiles_x), tile_coord(b.y, g.tile_shift, g.tiles_y),
                tile_coord(b.z, g.tile_shift, g.tiles_x), tile_coord(b.w, g.tile_shift, g.tiles_y));
}

inline uint leaf_depth(uint tl) {
  return tl & 15u;
}
inline uint leaf_first(uint tl) {
  return tl >> 4;
}

/* Leaf coordinate of grid coordinate v inside the tile starting at origin (clamped to it). */
inline int leaf_coord(int v, int origin, int leaf_shift, int n) {
  return clamp((v - origin) >> leaf_shift, 0, n - 1);
}

/* The leaf holding grid point (x, y). */
inline uint leaf_of_point(int x, int y, VmGrid g, __global const uint* tile_leaf) {
  int tx = tile_coord(x, g.tile_shift, g.tiles_x), ty = tile_coord(y, g.tile_shift, g.tiles_y);
  uint tl = tile_leaf[ty * g.tiles_x + tx], d = leaf_depth(tl);
  int n = 1 << d, ls = g.tile_shift - (int)d;
  int lx = leaf_coord(x, tx << g.tile_shift, ls, n), ly = leaf_coord(y, ty << g.tile_shift, ls, n);
  return leaf_first(tl) + (uint)(ly * n + lx);
}

/* The leaves (x0, y0, x1, y1, inclusive, in leaf coordinates of tile (tx, ty) at depth d) that a
 * box touches. */
inline int4 leaf_range(int4 b, VmGrid g, int tx, int ty, uint d) {
  int n = 1 << d, ls = g.tile_shift - (int)d, ox = tx << g.tile_shift, oy = ty << g.tile_shift;
  return (int4)(leaf_coord(b.x, ox, ls, n), leaf_coord(b.y, oy, ls, n), leaf_coord(b.z, ox, ls, n),
                leaf_coord(b.w, oy, ls, n));
}

/* Where an item's box starts relative to a leaf it is listed in: class 0 starts in the leaf in
 * both x and y, 1 in y only, 2 in x only, 3 in neither. The pair of boxes a, b (overlapping with
 * positive area) is owned by the leaf holding the low corner of their overlap, which is leaf L
 * exactly when a or b starts in L in x and a or b starts in L in y (both boxes reach L, so the
 * larger of their low x lies in L's x range exactly when one of them starts there; leaves at the
 * screen's edge reach out to infinity, as the clamps say). So an item of class c in a leaf only
 * needs the entries of some classes (partner_classes): all for class 0; classes 0 and 2 for
 * class 1; 0 and 1 for class 2; 0 for class 3. With tr the box's tile range and lr its leaf
 * range in tile (tx, ty), the box starts in leaf (lx, ly) of that tile in x exactly when tx and
 * lx are the first of their ranges. */
inline uint box_class(int4 tr, int4 lr, int tx, int ty, int lx, int ly) {
  return (tx == tr.x && lx == lr.x ? 0u : 1u) | (ty == tr.y && ly == lr.y ? 0u : 2u);
}

/* The classes (bit mask) whose entries an item of class c must pair with in a leaf. */
inline uint partner_classes(uint c) {
  return c == 0 ? 15u : c == 1 ? 5u : c == 2 ? 3u : 1u;
}

/* Where class c begins in a leaf's list, from its class starts (class 4: the end). */
inline uint class_begin(uint4 cs, uint c) {
  return c == 0 ? 0u : c == 1 ? cs.x : c == 2 ? cs.y : c == 3 ? cs.z : cs.w;
}

/* ---- The leaf walk ---------------------------------------------------------------------------
 * The leaves a grid box b touches, tile by tile (rows of tiles, then tiles in a row) and, in each
 * tile, leaf by leaf (rows, then leaves in a row): the one traversal that binning (leaf_bin),
 * the candidates (candidates_of) and the crossing pairs (pairs_of) share, so an item is binned
 * into exactly the leaves a partner's walk visits. A for-each over four nested loops (a macro:
 * OpenCL C has no closures, and an iterator function's state machine cost the binning ~10%):
 *   VM_FOR_EACH_LEAF(w, b, g, tile_leaf) { uint leaf = leaf_walk_leaf(&w); ... }
 * `continue` in the body steps to the next leaf; `break` would leave only the innermost loop. */
typedef struct {
  int4 tr, lr; /* the box's tile range; its leaf range in the current tile */
  int tx, ty;  /* the current tile */
  int lx, ly;  /* the current leaf, in its tile's leaf coordinates */
  uint tl;     /* the current tile's tile_leaf */
} LeafWalk;

inline LeafWalk leaf_walk(int4 b, VmGrid g) {
  LeafWalk w;
  w.tr = tile_range(b, g);
  w.ty = w.tr.y;
  return w;
}

/* Enters tile (w->tx, w->ty): its tile_leaf and the box's leaf range there. */
inline void leaf_walk_tile(LeafWalk* w, int4 b, VmGrid g, __global const uint* tile_leaf) {
  w->tl = tile_leaf[w->ty * g.tiles_x + w->tx];
  w->lr = leaf_range(b, g, w->tx, w->ty, leaf_depth(w->tl));
}

#define VM_FOR_EACH_LEAF(w, b, g, tile_leaf)                                           \
  for (LeafWalk w = leaf_walk(b, g); w.ty <= w.tr.w; ++w.ty)                           \
    for (w.tx = w.tr.x; w.tx <= w.tr.z; ++w.tx)                                        \
      for (leaf_walk_tile(&w, b, g, tile_leaf), w.ly = w.lr.y; w.ly <= w.lr.w; ++w.ly) \
        for (w.lx = w.lr.x; w.lx <= w.lr.z; ++w.lx)

/* The current leaf's index. */
inline uint leaf_walk_leaf(const LeafWalk* w) {
  return leaf_first(w->tl) + (uint)((w->ly << leaf_depth(w->tl)) + w->lx);
}

/* The box's class in the current leaf (box_class). */
inline uint leaf_walk_class(const LeafWalk* w) {
  return box_class(w->tr, w->lr, w->tx, w->ty, w->lx, w->ly);
}

/* The current leaf as a partner search reads it (candidates_of, pairs_of): its list of entries,
 * grouped by class (class_start), and the classes whose entries an item of the walking box's
 * class pairs with there (partner_classes). False, and nothing read, when the leaf is empty. */
typedef struct {
  __global const uint* list;
  uint4 cs;   /* the leaf's class starts (class_begin) */
  uint want;  /* bit c: class c's entries pair with the box */
} LeafPartners;

inline bool leaf_partners(const LeafWalk* w, __global const uint* leaf_offset,
                          __global const uint4* class_start, __global const uint* leaf_list,
                          LeafPartners* p) {
  uint leaf = leaf_walk_leaf(w);
  p->cs = class_start[leaf];
  if (p->cs.w == 0) return false;
  p->list = leaf_list + leaf_offset[leaf];
  p->want = partner_classes(leaf_walk_class(w));
  return true;
}

/* The classes c of a leaf_partners result whose entries pair with the box, in order. */
#define VM_FOR_EACH_PARTNER_CLASS(p, c) \
  for (uint c = 0; c < 4; ++c)          \
    if (((p).want >> c) & 1u)
