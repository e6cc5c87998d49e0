/* Stage: cull (issue 32). Before any crossing, candidate or clip work, the screen triangles that
 * are provably hidden are left out, and later (candidates.cl, clip.cl, occlusion.cl) the same
 * proof prunes candidate edges, stops fragments and decides them. The proof is per leaf C, a
 * closed grid rectangle (cull_leaves), about the triangles meeting its open cell:
 *
 * - Each one's nearness over the cell lies in [lo, hi] (its plane at the cell's corners and its
 *   vertices' range). The occlusion stage's "hides" relation can order two triangles against
 *   their exact depths at a point by at most d, the step: the tie band (VM_TIE_EPS of the largest
 *   |q|), or where a plane is not snapped the rounding of its crossing lines; a crossing pair
 *   with integer planes decides by the exact sign of their difference. A triangle t that beats
 *   u at a point is nearer there than u minus d.
 * - Connected components of the union of the intervals [lo, hi + d]: between two of them is a
 *   gap wider than d that no triangle's depth crosses, so no chain of "beats" at any point of
 *   the cell climbs from a lower component to a higher one.
 * - A sheet: where no silhouette edge (boundary, fold or non-manifold, silhouettes.cl) of a
 *   component's members meets the open cell, they form surfaces that continue across every edge
 *   inside it, so each projects onto the whole cell (SVGPU's premise: coverage changes only at
 *   silhouettes), and one sheet's intervals have a connected union: the component holds whole
 *   sheets covering the cell, nearer than its lower end `top` everywhere.
 *
 * A triangle x in a lower component is then hidden at every point of the cell, and it can be no
 * part of the top of the tournament at any point (occlusion.cl): a sheet member s beats it there,
 * whatever beats a top member is one, and x would need a chain of "beats" climbing back to s
 * across the gap. Whatever x hides the sheet hides too, so removing x changes no visible point.
 * A triangle that contains the closed cell is a sheet by itself; as no gap is known below it, it
 * proves a bound (meeting triangles + 2) steps below its least depth over the cell (no chain is
 * longer than the triangles covering a point). A triangle is culled when the test
 * hi + d < top holds in every leaf whose open cell it meets (docs/ARCHITECTURE.md "Cull"). */

/* Relative tie band per step of a chain (VM_TIE_EPS, with room for rounding and for pieces of one
 * source, whose planes differ by their snaps: 2^-24 at most). */
#define VM_CULL_STEP (1.25 * VM_TIE_EPS)
/* Passes of the top-component search before a leaf gives up (and proves nothing). */
#ifndef VM_CULL_MUTATION
#define VM_CULL_MUTATION 0
#endif
#define VM_CULL_PASSES 32
/* Components of the intervals' union a leaf looks at, from the top, for one free of silhouettes. */
#define VM_CULL_GROUPS 4

/* The closed rectangle (x0, y0, x1, y1) of a leaf, in grid units. */
inline long4 leaf_rect(VmGrid g, int tx, int ty, uint d, int lx, int ly) {
  const long ls = (long)1 << (g.tile_shift - (int)d);
  const long x0 = ((long)tx << g.tile_shift) + lx * ls, y0 = ((long)ty << g.tile_shift) + ly * ls;
  return (long4)(x0, y0, x0 + ls, y0 + ls);
}

/* The edge function of a -> b, orient(a, b, p) = ex (py - ay) - ey (px - ax), at the corner of
 * the closed rectangle r where it is greatest (hi = 1) or least (hi = 0): an affine function is
 * extreme at a corner, chosen by the signs of its coefficients (-ey for x, ex for y). Exact:
 * grid coordinates are below 2^22, so each product is below 2^46. */
inline long edge_fn_extreme(long ax, long ay, long bx, long by, long4 r, int hi) {
  const long ex = bx - ax, ey = by - ay;
  const long px = (-ey > 0) == (hi != 0) ? r.z : r.x, py = (ex > 0) == (hi != 0) ? r.w : r.y;
  return ex * (py - ay) - ey * (px - ax);
}

/* Exact: does the closed triangle t (box b) meet the open rectangle r with positive area?
 * Separating axes: the rectangle's sides, then t's edges (t is counter-clockwise on the grid,
 * orient > 0: r is outside an edge when the edge's function is <= 0 at every corner). */
inline bool tri_meets_open_rect(const VmScreenTri* t, int4 b, long4 r) {
  if (b.z <= r.x || b.x >= r.z || b.w <= r.y || b.y >= r.w) return false;
  if (b.x >= r.x && b.z <= r.z && b.y >= r.y && b.w <= r.w) return true; /* inside the cell */
  for (int i = 0; i < 3; ++i) {
    const int j = i == 2 ? 0 : i + 1;
    if (edge_fn_extreme(t->x[i], t->y[i], t->x[j], t->y[j], r, 1) <= 0) return false;
  }
  return true;
}

/* Exact: does the closed triangle t (box b) contain the closed rectangle r (all four corners)? */
inline bool tri_contains_rect(const VmScreenTri* t, int4 b, long4 r) {
  if (b.x > r.x || b.z < r.z || b.y > r.y || b.w < r.w) return false;
  for (int i = 0; i < 3; ++i) {
    const int j = i == 2 ? 0 : i + 1;
    if (edge_fn_extreme(t->x[i], t->y[i], t->x[j], t->y[j], r, 0) < 0) return false;
  }
  return true;
}

/* Exact: does the closed segment (a, b) meet the open rectangle r? */
inline bool segment_meets_open_rect(long ax, long ay, long bx, long by, long4 r) {
  if (max(ax, bx) <= r.x || min(ax, bx) >= r.z || max(ay, by) <= r.y || min(ay, by) >= r.w)
    return false;
  return edge_fn_extreme(ax, ay, bx, by, r, 1) > 0 && edge_fn_extreme(ax, ay, bx, by, r, 0) < 0;
}

/* The nearness plane p (depth_plane, computed once a triangle by the callers) over the closed box r
 * (doubles, grid units): its least and greatest value there, at the corners its slopes' signs
 * pick. */
inline double2 plane_range(DepthPlane p, double4 r) {
  const double xl = p.gx > 0 ? r.x : r.z, yl = p.gy > 0 ? r.y : r.w;
  const double xh = p.gx > 0 ? r.z : r.x, yh = p.gy > 0 ? r.w : r.y;
  return (double2)(plane_at(p, xl, yl), plane_at(p, xh, yh));
}

/* A triangle's nearness over its part in the closed box r lies in [lo, hi]: its plane's range
 * over the box, cut to the range of its vertices qr (which bound it over the triangle). */
inline double2 depth_interval(DepthPlane p, double2 qr, double4 r) {
  const double2 pr = plane_range(p, r);
  return (double2)(fmax(pr.x, qr.x), fmin(pr.y, qr.y));
}

inline double4 rect_d(long4 r) {
  return (double4)((double)r.x, (double)r.y, (double)r.z, (double)r.w);
}

/* What a triangle meeting a leaf's open cell adds to the leaf's proof (cull_bin), in the leaf's
 * slots from its list's offset on, in the order the atomics ran (the proof does not depend on
 * it): iv its depth interval over the cell; cover its least depth over the cell where it contains
 * the closed cell, else -inf; both as floats rounded outward (lo and cover down, hi up: the
 * interval only grows, the bound only drops, 2^-24 relative against the step's 10^-6); flags
 * VM_CULL_SIL (a silhouette edge of it meets the open cell), VM_CULL_FREE (its depth plane is not
 * snapped); slot_tri its index, for the leaves that need its slope (unsnapped planes). */
#define VM_CULL_SIL 1u
#define VM_CULL_FREE 2u
/* Is edge e a silhouette to the cull? From edge_classify's key_sil; for a key three or more
 * triangles share, only when its triangles do not lie on both sides of it (duplicated faces, a
 * fin: the surfaces still cover both sides near it). */
inline bool cull_edge_sil(uint e, __global const uchar* key_sil, __global const uint* partners,
                          __global const uint* slot_sides) {
  const uint k = key_sil[e];
  if (k != VM_KEY_SIL_MANY) return k != 0;
  return (slot_sides[partners[e]] & (VM_SIDE_LEFT | VM_SIDE_RIGHT)) !=
         (VM_SIDE_LEFT | VM_SIDE_RIGHT);
}

/* One work-item a triangle: the leaves its box touches (the walk every binning shares), each one
 * whose open cell it meets given a slot (an atomic cursor, leaf_sort_classes zeroed) with what it
 * adds. The triangle is read once, not once a leaf. */
__kernel void cull_bin(__global const VmScreenTri* tris, uint ntris, __global const int4* tri_bb,
                       __global const double2* tri_qr, __global const uchar* key_sil,
                       __global const uint* partners, __global const uint* slot_sides, VmGrid g,
                       __global const uint* tile_leaf, __global const uint* leaf_offset,
                       __global uint* cursors, __global float2* iv, __global float* cover,
                       __global uint* slot_tri, __global uchar* flags) {
  const uint t = get_global_id(0);
  if (t >= ntris) return;
  const VmScreenTri T = tris[t];
  const int4 b = tri_bb[t];
  const double2 qr = tri_qr[t];
  uint sil_edges = 0; /* which of its edges the cull takes for silhouettes */
  for (int e = 0; e < 3; ++e)
    if (cull_edge_sil(3 * t + e, key_sil, partners, slot_sides)) sil_edges |= 1u << e;
  const uint base = T.plane_k == VM_PLANE_FREE ? VM_CULL_FREE : 0u;
  const DepthPlane p = depth_plane(&T);
  VM_FOR_EACH_LEAF(w, b, g, tile_leaf) {
    const long4 r = leaf_rect(g, w.tx, w.ty, leaf_depth(w.tl), w.lx, w.ly);
    if (!tri_meets_open_rect(&T, b, r)) continue;
    const uint leaf = leaf_walk_leaf(&w);
    const uint j = leaf_offset[leaf] + atomic_inc(&cursors[leaf]);
    const double4 rd = rect_d(r);
    const bool inside = b.x >= r.x && b.z <= r.z && b.y >= r.y && b.w <= r.w;
    const double2 d = inside ? qr : depth_interval(p, qr, rd); /* (inside: its vertices' range) */
    iv[j] = (float2)(convert_float_rtn(d.x), convert_float_rtp(d.y));
    cover[j] = tri_contains_rect(&T, b, r) ? convert_float_rtn(plane_range(p, rd).x) : -INFINITY;
    uint f = base;
    for (int e = 0; e < 3; ++e) {
      if (!((sil_edges >> e) & 1u)) continue;
      const int k = e == 2 ? 0 : e + 1;
      if (segment_meets_open_rect(T.x[e], T.y[e], T.x[k], T.y[k], r)) f |= VM_CULL_SIL;
    }
    flags[j] = (uchar)f;
    slot_tri[j] = t;
  }
}

/* Per leaf: (top, d) as proven above from its slots (cull_bin), or top = -inf where
 * nothing is proven: a triangle whose nearness over the cell stays below top - d is hidden. */
/* Also zeroes the `groups` words of `zero` (edge_reclassify's group counts): one launch less. */
__kernel void cull_leaves(uint nleaves, __global const uint* leaf_offset,
                          __global const uint* cursors, __global const uint* slot_tri,
                          __global const VmScreenTri* tris, __global const int4* tri_bb,
                          __global const float2* iv, __global const float* cover,
                          __global const uchar* flags, __global double2* leaf_cull,
                          __global uint* zero, uint groups) {
  const uint leaf = get_global_id(0);
  if (leaf < groups) zero[leaf] = 0;
  if (leaf >= nleaves) return;
  const uint n = cursors[leaf], off = leaf_offset[leaf]; /* (the triangles meeting the cell) */
  const uint meet = n;
  uint any = 0;
  double qabs = 0, single = -INFINITY;
  for (uint k = off; k < off + n; ++k) {
    any |= flags[k];
    const float2 v = iv[k];
    qabs = fmax(qabs, (double)fmax(fabs(v.x), fabs(v.y)));
    single = fmax(single, (double)cover[k]);
  }
  double gmax = 0, free_span = 0;
  if (any & VM_CULL_FREE) /* (rare: a plane too steep to snap) */
    for (uint k = off; k < off + n; ++k) {
      const VmScreenTri T = tris[slot_tri[k]];
      const DepthPlane p = depth_plane(&T);
      gmax = fmax(gmax, (fabs(p.gx) + fabs(p.gy)) * (1 + 0x1p-40));
      if (flags[k] & VM_CULL_FREE) {
        const int4 b = tri_bb[slot_tri[k]];
        free_span = fmax(free_span, (double)max(b.z - b.x, b.w - b.y));
      }
    }
  /* Per step: the tie band (|q| at any point of the cell that a triangle covers is within its
   * interval there); and where a plane is not snapped, a rounded crossing line: within
   * (1 + h) / (2 (2^23 - 255)) grid units of the true one over the pair's overlap (h its
   * half-span plus 1.5, at most the free triangle's span: docs/NUMERICS.md §2), where the depth
   * difference changes by at most the sum of the two slopes a grid unit. */
  const double round = any & VM_CULL_FREE ? 2.0 * gmax * (free_span + 8.0) * 0x1p-23 : 0.0;
  const double M = VM_CULL_STEP * qabs + round; /* the step d */
  double top = -INFINITY;
  /* The connected components of the union of [lo, hi + d], from the top down: each from the
   * highest reach below the one above, taking in every interval that reaches it, until none is
   * added. The first whose members have no silhouette edge in the cell (their sheets cover it)
   * proves the bound; one above it with silhouettes (a contour in front) does not matter. */
  double ceiling = INFINITY; /* the groups left lie wholly below it */
  for (int grp = 0; grp < VM_CULL_GROUPS && top == -INFINITY && meet > 0; ++grp) {
    double v = -INFINITY;
    for (uint k = off; k < off + n; ++k)
      if ((double)iv[k].y + M < ceiling) v = fmax(v, (double)iv[k].y + M);
    if (v == -INFINITY) break;
    bool settled = false;
    for (int pass = 0; pass < VM_CULL_PASSES && !settled; ++pass) {
      double nv = v;
      for (uint k = off; k < off + n; ++k)
        if ((double)iv[k].y + M >= v && (double)iv[k].y + M < ceiling)
          nv = fmin(nv, (double)iv[k].x);
      settled = nv == v;
      v = nv;
    }
    if (!settled) break;
    bool clean = true;
#if VM_CULL_MUTATION != 1 /* (tests/test_cull.cpp: a cull without this must be caught) */
    for (uint k = off; k < off + n && clean; ++k)
      if ((flags[k] & VM_CULL_SIL) && (double)iv[k].y + M >= v && (double)iv[k].y + M < ceiling)
        clean = false;
#endif
    if (clean) top = v;
    ceiling = v;
  }
  /* A single cover: no gap known below it, so (meet + 2) steps below it, less the test's one. */
  top = fmax(top, single - (double)(meet + 1) * M);
  leaf_cull[leaf] = (double2)(top, M);
}

/* Is T (box tb, depth range qr) hidden in every leaf that the box `walk` touches and whose open
 * cell T meets? (tri_hidden walks T's own box; hidden_along a silhouette edge's.) */
inline bool hidden_in_leaves(const VmScreenTri* T, int4 walk, int4 tb, double2 qr, VmGrid g,
                             __global const uint* tile_leaf, __global const double2* leaf_cull) {
  const DepthPlane p = depth_plane(T);
  VM_FOR_EACH_LEAF(w, walk, g, tile_leaf) {
    const long4 r = leaf_rect(g, w.tx, w.ty, leaf_depth(w.tl), w.lx, w.ly);
    if (!tri_meets_open_rect(T, tb, r)) continue;
    const double2 c = leaf_cull[leaf_walk_leaf(&w)];
    if (!(qr.y + c.y < c.x) && !(depth_interval(p, qr, rect_d(r)).y + c.y < c.x)) return false;
  }
  return true;
}

/* Is t (whose box is b) hidden in every leaf whose open cell it meets? */
inline bool tri_hidden(const VmScreenTri* T, int4 b, double2 qr, VmGrid g,
                       __global const uint* tile_leaf, __global const double2* leaf_cull) {
  return hidden_in_leaves(T, b, b, qr, g, tile_leaf, leaf_cull);
}

/* An empty box: what a culled triangle's box becomes (cull_tris), so that every traversal that
 * tests boxes (crossing pairs, candidates, occluders, the root fragments) passes it by, as if it
 * were not in the scene. */
#define VM_EMPTY_BOX ((int4)(0x7fffffff, 0x7fffffff, -0x7fffffff - 1, -0x7fffffff - 1))

/* keep[t] = 0 for a triangle proven hidden, whose box is then emptied (tri_bb[t] = VM_EMPTY_BOX:
 * each item reads only its own box here); 1 otherwise. The culled are counted into
 * totals[VM_TOTAL_CULLED]. */
__kernel __attribute__((reqd_work_group_size(VM_SCAN_WG, 1, 1))) void cull_tris(
    __global const VmScreenTri* tris, uint ntris, __global int4* tri_bb,
    __global const double2* tri_qr, VmGrid g, __global const uint* tile_leaf,
    __global const double2* leaf_cull, __global uint* keep, __global uint* totals) {
  __local uint culled;
  const uint t = get_global_id(0);
  if (get_local_id(0) == 0) culled = 0;
  barrier(CLK_LOCAL_MEM_FENCE);
  if (t < ntris) {
    const VmScreenTri T = tris[t];
    const bool hidden = tri_hidden(&T, tri_bb[t], tri_qr[t], g, tile_leaf, leaf_cull);
    keep[t] = hidden ? 0u : 1u;
    if (hidden) {
      tri_bb[t] = VM_EMPTY_BOX;
      atomic_inc(&culled);
    }
  }
  barrier(CLK_LOCAL_MEM_FENCE);
  if (get_local_id(0) == 0 && culled) atomic_add(&totals[VM_TOTAL_CULLED], culled);
}

/* Is the fragment (lines L) of screen triangle T with box fb (grid units, closed: widened past its
 * vertices) hidden in every leaf whose open cell it meets? clip.cl drops it then. */
inline bool fragment_hidden(const VmScreenTri* T, const VmLine* L, uint nl, int4 fb, VmGrid g,
                            __global const uint* tile_leaf, __global const double2* leaf_cull) {
  const double4 fd = (double4)((double)fb.x, (double)fb.y, (double)fb.z, (double)fb.w);
  const double vmax = fmax(fmax(T->q[0], T->q[1]), T->q[2]);
  const DepthPlane p = depth_plane(T);
  VM_FOR_EACH_LEAF(w, fb, g, tile_leaf) {
    const long4 r = leaf_rect(g, w.tx, w.ty, leaf_depth(w.tl), w.lx, w.ly);
    if (fb.z <= r.x || fb.x >= r.z || fb.w <= r.y || fb.y >= r.w) continue;
    /* A cell the fragment (the positive side of its lines) does not meet holds none of it: a
     * line with the whole cell on its closed outer side (at the corner it is greatest). */
    bool apart = false;
    for (uint i = 0; i < nl && !apart; ++i)
      apart = line_eval_point(line_of_vm(L[i]), L[i].a > 0 ? r.z : r.x, L[i].b > 0 ? r.w : r.y) <= 0;
    if (apart) continue;
    const double2 c = leaf_cull[leaf_walk_leaf(&w)];
    /* The fragment's nearness over this cell: the plane over the box cut to the cell. */
    const double4 b = (double4)(fmax(fd.x, (double)r.x), fmax(fd.y, (double)r.y),
                                fmin(fd.z, (double)r.z), fmin(fd.w, (double)r.w));
    const double hi = fmin(plane_at(p, p.gx > 0 ? b.z : b.x, p.gy > 0 ? b.w : b.y), vmax);
    if (!(hi + c.y < c.x)) return false;
  }
  return true;
}

/* Is triangle T (depth range qr) hidden, as the leaves prove, on every closed cell that the box eb
 * (a silhouette edge's, inclusive) touches? Then T is hidden on a neighbourhood of every point
 * of the edge, so its visibility cannot change across the edge, and the edge need not cut its
 * fragments (candidates.cl): every point where T's visibility changes is still on a candidate
 * kept. (The box is widened down by one grid unit so that a cell it only touches from below or
 * the left is walked too; a cell T does not meet holds nothing of T.) */
inline bool hidden_along(const VmScreenTri* T, double2 qr, int4 eb, VmGrid g,
                         __global const uint* tile_leaf, __global const double2* leaf_cull) {
  const int4 b = (int4)(eb.x - 1, eb.y - 1, eb.z, eb.w);
  const int4 tb = (int4)(min(min(T->x[0], T->x[1]), T->x[2]), min(min(T->y[0], T->y[1]), T->y[2]),
                         max(max(T->x[0], T->x[1]), T->x[2]), max(max(T->y[0], T->y[1]), T->y[2]));
  return hidden_in_leaves(T, b, tb, qr, g, tile_leaf, leaf_cull);
}
