/* Stage: penetrating geometry (which SVGPU forbids). Where two screen triangles overlap on the
 * screen and their depth planes cross inside the overlap, the front surface switches along the
 * projected intersection line. That line becomes a clipping line for both triangles: exact, the
 * difference of their integer depth planes (transform.cl snap_depth_planes), or, where a plane
 * could not be snapped, rounded to integers; and inside the overlap the two triangles are
 * ordered by the side of that one line, not by a depth comparison, so both make the same
 * decision at every point: no overlap and no hole (docs/NUMERICS.md §2).
 *
 * Pairs that do not cross are ordered once for their whole overlap: by the sign of the depth
 * difference where it leaves the tie band, else by the tie rule. */

/* VM_REL_NONE ... VM_REL_TIE: kernels/layout.h (the host reads the relations too). */
/* or'ed into A_FRONT / B_FRONT: the planes come within the band somewhere in the overlap (the
 * surfaces touch there), and the two share no vertex. Such a pair is entangled like a tying one:
 * each is clipped by the other's edges. Where a surface passes from in front of a triangle x to
 * behind it across one of its own mesh edges (within the band), no crossing line and no
 * silhouette marks that edge for x, yet x's visibility changes there; both triangles at the
 * edge touch x, so this brings the edge into x's clipping lines. Mesh neighbours of x touch
 * it at their shared vertex by construction; for them the fold's silhouette or the triangle on
 * the other side of the edge brings it (docs/NUMERICS.md §2, "Touching pairs"). */
#define VM_REL_TOUCH 8

/* Values of n tried when rounding a crossing line to integer coefficients (pair_relation). */
#ifndef VM_SNAP_SEARCH
#define VM_SNAP_SEARCH 256
#endif
/* Largest coefficient of a crossing line (a, b, c): |a|, |b| <= 2^23, within the bit budget. */
#define VM_SNAP_N (1L << 23)

/* The overlap of two screen triangles' footprints, in doubles (grid units): a clipped by b's
 * three edge lines. Returns the vertex count (0 when empty). */
inline int tri_overlap(const VmScreenTri* a, const VmScreenTri* b, double2* out) {
  double2 p[9], q[9];
  int n = 3;
  for (int i = 0; i < 3; ++i) p[i] = (double2)((double)a->x[i], (double)a->y[i]);
  for (int e = 0; e < 3 && n > 0; ++e) {
    int f = e == 2 ? 0 : e + 1;
    double ex = (double)(b->x[f] - b->x[e]), ey = (double)(b->y[f] - b->y[e]);
    double bx = (double)b->x[e], by = (double)b->y[e];
    int m = 0;
    for (int i = 0; i < n; ++i) {
      double2 u = p[i], v = p[i + 1 == n ? 0 : i + 1];
      double su = ex * (u.y - by) - ey * (u.x - bx), sv = ex * (v.y - by) - ey * (v.x - bx);
      if (su >= 0) q[m++] = u;
      if ((su >= 0) != (sv >= 0)) q[m++] = u + (v - u) * (su / (su - sv));
    }
    n = m;
    for (int i = 0; i < n; ++i) p[i] = q[i];
  }
  for (int i = 0; i < n; ++i) out[i] = p[i];
  return n;
}

/* How a (lower index) and b relate over their overlap; for crossing pairs also the snapped
 * line, directed so that a is in front on its positive side. Pure function of the two
 * triangles: both members of a pair compute the same answer. */
/* Do a and b have a vertex in common (mesh neighbours, after snapping)? */
inline bool share_vertex(const VmScreenTri* a, const VmScreenTri* b) {
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      if (a->x[i] == b->x[j] && a->y[i] == b->y[j]) return true;
  return false;
}

inline int pair_relation(const VmScreenTri* a, const VmScreenTri* b, VmLine* line, int search) {
  /* Exact separating axes on the grid first: most pairs that get here are mesh neighbours whose
   * footprints only touch (an edge or a corner in common). */
  for (int side = 0; side < 2; ++side) {
    const VmScreenTri* p = side ? b : a;
    const VmScreenTri* o = side ? a : b;
    for (int i = 0; i < 3; ++i) {
      int j = i == 2 ? 0 : i + 1;
      bool separates = true;
      for (int k = 0; k < 3 && separates; ++k)
        separates = orient_points(p->x[i], p->y[i], p->x[j], p->y[j], o->x[k], o->y[k]) <= 0;
      if (separates) return VM_REL_NONE;
    }
  }
  double2 r[9];
  int n = tri_overlap(a, b, r);
  if (n < 3) return VM_REL_NONE;
  double area = 0;
  for (int i = 0; i < n; ++i) {
    double2 u = r[i], v = r[i + 1 == n ? 0 : i + 1];
    area += u.x * v.y - v.x * u.y;
  }
  if (!(fabs(area) > 1e-9)) return VM_REL_NONE;
  DepthPlane pa = depth_plane(a), pb = depth_plane(b);
  double dmin = INFINITY, dmax = -INFINITY, band = 0;
  double2 lo = r[0], hi = r[0];
  for (int i = 0; i < n; ++i) {
    double qa = plane_at(pa, r[i].x, r[i].y), qb = plane_at(pb, r[i].x, r[i].y);
    double d = qa - qb;
    dmin = fmin(dmin, d);
    dmax = fmax(dmax, d);
    band = fmax(band, VM_TIE_EPS * fmax(fabs(qa), fabs(qb)));
    lo = fmin(lo, r[i]);
    hi = fmax(hi, r[i]);
  }
  if (!(dmax > band && dmin < -band)) {
    if (dmax > band)
      return VM_REL_A_FRONT | (dmin <= band && !share_vertex(a, b) ? VM_REL_TOUCH : 0);
    if (dmin < -band)
      return VM_REL_B_FRONT | (dmax >= -band && !share_vertex(a, b) ? VM_REL_TOUCH : 0);
    return VM_REL_TIE |
           ((a->mesh < b->mesh || (a->mesh == b->mesh && a->tri < b->tri)) ? VM_REL_A_FRONT
                                                                           : VM_REL_B_FRONT);
  }
  /* Both depth planes snapped with the same k: their difference is the exact crossing line,
   * 2^k d(x, y) = (Aa - Ab) x + (Ba - Bb) y + (Ca - Cb), |a|, |b| <= 2^30, |c| <= 2^54 (the
   * budget of NUMERICS §1), positive where a is in front. */
  long Aa, Ba, Ca, Ab, Bb, Cb;
  if (a->plane_k == b->plane_k && int_plane(a, &Aa, &Ba, &Ca) && int_plane(b, &Ab, &Bb, &Cb)) {
    line->a = (int)(Aa - Ab);
    line->b = (int)(Ba - Bb);
    line->c = Ca - Cb;
    return VM_REL_CROSS;
  }
  /* Otherwise d(x, y) = A x + B y + C, zero on the intersection line, is rounded to an integer line
   * (a, b, c): along the axis u on which its slope m is <= 1 (v the other coordinate), the line
   * n v + p u + c = 0 with n within `search` of VM_SNAP_N = 2^23, p = round(m n), and c putting
   * it on the true line at the overlap's centre column uc to within 1/(2n). Its error over the
   * overlap is at most |c - c_exact| / n + |p/n - m| h for the half-span h; the best of the
   * `search` values of n is kept (docs/NUMERICS.md §2). An axis-parallel line is exact in
   * direction and within 2^-24 grid units in offset. |c| <= 2^23 (|v| + |u|) < 2^47: the budget
   * of §1. The pair traversal, which needs only the relation, takes n = 2^23 (search = 1);
   * refine_pair redoes every crossing pair with VM_SNAP_SEARCH as the pairs are compacted,
   * before anything uses it. */
  double A = pa.gx - pb.gx, B = pa.gy - pb.gy;
  double C = (pa.q0 - pa.gx * pa.x0 - pa.gy * pa.y0) - (pb.q0 - pb.gx * pb.x0 - pb.gy * pb.y0);
  bool along_x = fabs(B) >= fabs(A);
  double P = along_x ? A : B, Q = along_x ? B : A; /* P u + Q v + C = 0 */
  double m = P / Q, ulo = along_x ? lo.x : lo.y, uhi = along_x ? hi.x : hi.y;
  double uc = rint(0.5 * (ulo + uhi));
  double vc = -(P * uc + C) / Q, h = fmax(uhi - uc, uc - ulo) + 1.0;
  long bn = 0, bp = 0, bc = 0;
  double err = INFINITY;
  for (int k = 0; k < search; ++k) {
    long n = VM_SNAP_N - k, p = (long)rint(m * (double)n);
    double cex = -((double)n * vc + (double)p * uc);
    double c = rint(cex);
    double e = fabs(c - cex) / (double)n + fabs((double)p / (double)n - m) * h;
    if (e < err) {
      err = e;
      bn = n;
      bp = p;
      bc = (long)c;
    }
  }
  long lim = (long)1 << 47;
  bc = clamp(bc, -lim, lim);
  /* (p, n, c) in (u, v) is a positive multiple of (P, Q, C) when Q > 0: a is in front where
   * d > 0, so that is the positive side. */
  long s = Q > 0 ? 1 : -1;
  line->a = (int)(s * (along_x ? bp : bn));
  line->b = (int)(s * (along_x ? bn : bp));
  line->c = s * bc;
  return VM_REL_CROSS;
}

/* Entangled pairs: crossing pairs and pairs that tie (coplanar within the band). Each pair is
 * found once, by its lower triangle t, through the triangle bins (each pair looked at in one tile
 * only), in one traversal: up to VM_PAIRS_INLINE pairs per triangle go to a scratch slot and the
 * rest only raise a status bit, after which cross_pairs_fill traverses again into exact space,
 * for those triangles only.
 *
 * With scene facts (core/facts/scene_facts.h), a triangle "apart" in this view (snap_depth_planes)
 * can be entangled only with triangles it shares a vertex with in 3D: a pair with an apart member
 * is looked for through the scene's adjacency lists (its source's neighbours above it, each
 * neighbour's screen triangles from clip_count's offsets), and the bins' walk, which only
 * triangles that are not apart make, skips apart partners. Each pair is still found once, by its
 * lower member, with the same relation; sort_pairs makes the order the same. */

/* The screen triangles of source triangle u: [first, end) (clip_count's offsets within their
 * work-group plus the group's base; the sources' screen triangles are in source order). */
typedef struct {
  int on; /* scene facts in use: the rest is read only then */
  __global const uchar* apart;
  __global const uint* adj_offset;
  __global const uint* adj;
  __global const uint* src_offset;
  __global const uint* src_base;
  uint src_groups, nsrc;
} VmApart;

inline uint source_first(const VmApart* a, uint u) {
  return (a->src_groups ? a->src_base[u / VM_SCAN_WG] : 0u) + a->src_offset[u];
}

/* Does t (me, its box tb and nearness range) pair with o? Their relation and line if so. */
inline bool entangled(const VmScreenTri* me, int4 tb, double qmin, double qmax, uint o,
                      __global const VmScreenTri* tris, __global const int4* tri_bb,
                      __global const double2* tri_qr, int* rel, VmLine* line) {
  int4 ob = tri_bb[o];
  if (max(tb.x, ob.x) >= min(tb.z, ob.z) || max(tb.y, ob.y) >= min(tb.w, ob.w)) return false;
  /* Depth ranges apart beyond the tie band: neither crossing nor tying. */
  double2 oq = tri_qr[o];
  double band = VM_TIE_EPS * fmax(fmax(fabs(qmax), fabs(oq.y)), fmax(fabs(qmin), fabs(oq.x)));
  if (oq.x > qmax + band || qmin > oq.y + band) return false;
  VmScreenTri other = tris[o];
  if (other.mesh == me->mesh && other.tri == me->tri) return false;
  *rel = pair_relation(me, &other, line, 1);
  return *rel == VM_REL_CROSS || (*rel & (VM_REL_TIE | VM_REL_TOUCH));
}

/* The count-th pair into the slots where they hold it (cap); counted either way. */
inline void keep_pair(uint* count, uint cap, __global uint* out_o, __global uint* out_rel,
                      __global VmLine* out_line, uint o, int rel, VmLine line) {
  if (*count < cap) {
    out_o[*count] = o;
    out_rel[*count] = (uint)rel;
    out_line[*count] = line;
  }
  ++*count;
}

inline uint pairs_of(uint t, __global const VmScreenTri* tris, uint ntris,
                     __global const int4* tri_bb, __global const double2* tri_qr, VmGrid g,
                     __global const uint* tile_leaf, __global const uint* leaf_offset,
                     __global const uint4* class_start, __global const uint* leaf_list,
                     const VmApart* ap, uint cap, __global uint* out_o, __global uint* out_rel,
                     __global VmLine* out_line) {
  int4 tb = tri_bb[t];
  VmScreenTri me = tris[t];
  double qmin = fmin(fmin(me.q[0], me.q[1]), me.q[2]), qmax = fmax(fmax(me.q[0], me.q[1]), me.q[2]);
  const bool use_apart = ap->on != 0;
  const bool t_apart = use_apart && ap->apart[t];
  uint count = 0;
  if (!t_apart) {
    VM_FOR_EACH_LEAF(w, tb, g, tile_leaf) {
      /* Only the classes of entries whose pairs with t this leaf owns, each (sorted by id) walked
       * down from its top to its first id not above t: each pair is found once, by its lower
       * member, and no entry below t is touched but the one that stops the walk. */
      LeafPartners L;
      if (!leaf_partners(&w, leaf_offset, class_start, leaf_list, &L)) continue;
      VM_FOR_EACH_PARTNER_CLASS(L, c) {
        uint lo = class_begin(L.cs, c);
        for (uint k = class_begin(L.cs, c + 1); k-- > lo;) {
          uint o = L.list[k];
          if (o <= t) break;
          if (use_apart && ap->apart[o]) continue; /* (through the adjacency below, or none) */
          VmLine line;
          int rel;
          if (entangled(&me, tb, qmin, qmax, o, tris, tri_bb, tri_qr, &rel, &line))
            keep_pair(&count, cap, out_o, out_rel, out_line, o, rel, line);
        }
      }
    }
  }
  if (use_apart && tb.x < tb.z) { /* (a culled triangle's box is empty: no pairs) */
    for (uint k = ap->adj_offset[me.src]; k < ap->adj_offset[me.src + 1]; ++k) {
      uint u = ap->adj[k];
      uint end = u + 1 < ap->nsrc ? source_first(ap, u + 1) : ntris;
      for (uint o = source_first(ap, u); o < end; ++o) {
        if (!t_apart && !ap->apart[o]) continue; /* both walk the bins: found there */
        VmLine line;
        int rel;
        if (entangled(&me, tb, qmin, qmax, o, tris, tri_bb, tri_qr, &rel, &line))
          keep_pair(&count, cap, out_o, out_rel, out_line, o, rel, line);
      }
    }
  }
  return count;
}

/* A triangle's c pairs in order of their partner (insertion sort: a handful each, rarely more).
 * The order is then the same however the pairs were found (the leaf walk's order depends on the
 * bins), and the entries, fragments and output that follow from it with it. */
inline void sort_pairs(uint c, __global uint* o, __global uint* rel, __global VmLine* line) {
  for (uint i = 1; i < c; ++i) {
    uint ko = o[i], kr = rel[i];
    VmLine kl = line[i];
    uint j = i;
    for (; j > 0 && o[j - 1] > ko; --j) {
      o[j] = o[j - 1];
      rel[j] = rel[j - 1];
      line[j] = line[j - 1];
    }
    o[j] = ko;
    rel[j] = kr;
    line[j] = kl;
  }
}

/* Each triangle's pairs into its inline slots, their count, and its offset within the
 * work-group with the group's total (scan.cl's fused scan; cross_compact makes the offsets
 * global). */
#define VM_APART_PARAMS                                                                    \
  int use_apart, __global const uchar *apart, __global const uint *adj_offset,             \
      __global const uint *adj, __global const uint *src_offset, __global const uint *src_base, \
      uint src_groups, uint nsrc
#define VM_APART_INIT(ap) \
  VmApart ap = {use_apart, apart, adj_offset, adj, src_offset, src_base, src_groups, nsrc}

__kernel __attribute__((reqd_work_group_size(VM_SCAN_WG, 1, 1))) void cross_pairs(
    __global const VmScreenTri* tris, uint ntris, __global const int4* tri_bb,
    __global const double2* tri_qr, VmGrid g, __global const uint* tile_leaf,
    __global const uint* leaf_offset, __global const uint4* class_start,
    __global const uint* leaf_list, VM_APART_PARAMS, __global uint* counts,
    __global uint* offsets, __global uint* group_sums, __global uint* scr_o,
    __global uint* scr_rel, __global VmLine* scr_line, __global uint* status) {
  __local uint tmp[VM_SCAN_WG];
  const uint t = get_global_id(0);
  VM_APART_INIT(ap);
  uint c = 0;
  if (t < ntris) {
    size_t s = (size_t)t * VM_PAIRS_INLINE;
    c = pairs_of(t, tris, ntris, tri_bb, tri_qr, g, tile_leaf, leaf_offset, class_start,
                 leaf_list, &ap, VM_PAIRS_INLINE, scr_o + s, scr_rel + s, scr_line + s);
    if (c > VM_PAIRS_INLINE) atomic_or(status, VM_STATUS_PAIRS_OVERFLOW);
  }
  const uint o = vm_group_offset(c, tmp, group_sums);
  if (t < ntris) {
    counts[t] = c;
    offsets[t] = o;
  }
}

/* Pair p's crossing line rounded with the best of VM_SNAP_SEARCH values of n (kept out of the
 * pair traversal, whose hot loop it would slow down; done as the pairs are compacted). */
inline void refine_pair(uint p, __global const VmScreenTri* tris, __global const uint* pair_t,
                        __global const uint* pair_o, __global const uint* pair_rel,
                        __global VmLine* pair_line) {
  if (pair_rel[p] != VM_REL_CROSS) return;
  VmScreenTri a = tris[pair_t[p]], b = tris[pair_o[p]];
  VmLine line;
  if (pair_relation(&a, &b, &line, VM_SNAP_SEARCH) == VM_REL_CROSS) pair_line[p] = line;
}

/* Only after an overflow, and only for the triangles whose pairs did not fit their slots (the
 * others are copied by cross_compact): the same traversal, straight into the compact arrays. */
__kernel void cross_pairs_fill(__global const VmScreenTri* tris, uint ntris,
                               __global const int4* tri_bb, __global const double2* tri_qr,
                               VmGrid g, __global const uint* tile_leaf,
                               __global const uint* leaf_offset, __global const uint4* class_start,
                               __global const uint* leaf_list, VM_APART_PARAMS,
                               __global const uint* counts, __global const uint* offsets,
                               __global uint* pair_t, __global uint* pair_o,
                               __global uint* pair_rel, __global VmLine* pair_line) {
  uint t = get_global_id(0);
  if (t >= ntris || counts[t] <= VM_PAIRS_INLINE) return;
  VM_APART_INIT(ap);
  uint o = offsets[t];
  uint c = pairs_of(t, tris, ntris, tri_bb, tri_qr, g, tile_leaf, leaf_offset, class_start,
                    leaf_list, &ap, 0xffffffffu, pair_o + o, pair_rel + o, pair_line + o);
  sort_pairs(c, pair_o + o, pair_rel + o, pair_line + o);
  for (uint k = 0; k < c; ++k) pair_t[o + k] = t;
  for (uint k = 0; k < c; ++k) refine_pair(o + k, tris, pair_t, pair_o, pair_rel, pair_line);
}

/* Makes cross_pairs' offsets global (adding the group's base), and copies the pairs that fit
 * their slots there, refining their lines (refine_pair). */
__kernel __attribute__((reqd_work_group_size(VM_SCAN_WG, 1, 1))) void cross_compact(
    uint ntris, __global const VmScreenTri* tris, __global const uint* counts,
    __global uint* offsets, __global const uint* group_bases,
    uint groups, __global const uint* scr_o, __global const uint* scr_rel, __global const VmLine* scr_line,
    __global uint* pair_t, __global uint* pair_o, __global uint* pair_rel,
    __global VmLine* pair_line) {
  const uint t = get_global_id(0);
  const uint base = vm_group_base(group_bases, groups);
  if (t >= ntris) return;
  const uint c = counts[t], o = base + offsets[t];
  offsets[t] = o;
  if (c > VM_PAIRS_INLINE) return; /* cross_pairs_fill writes these */
  size_t s = (size_t)t * VM_PAIRS_INLINE;
  for (uint k = 0; k < c; ++k) {
    pair_t[o + k] = t;
    pair_o[o + k] = scr_o[s + k];
    pair_rel[o + k] = scr_rel[s + k];
    pair_line[o + k] = scr_line[s + k];
  }
  sort_pairs(c, pair_o + o, pair_rel + o, pair_line + o);
  for (uint k = 0; k < c; ++k) refine_pair(o + k, tris, pair_t, pair_o, pair_rel, pair_line);
}


/* The pairs where a triangle is the higher member ("incoming"), as per-triangle lists. */
__kernel void cross_in_count(uint npairs, __global const uint* pair_o, __global uint* in_count) {
  uint p = get_global_id(0);
  if (p >= npairs) return;
  atomic_inc(&in_count[pair_o[p]]);
}

__kernel void cross_in_fill(uint npairs, __global const uint* pair_o,
                            __global const uint* in_offset, __global uint* in_cursor,
                            __global uint* in_list) {
  uint p = get_global_id(0);
  if (p >= npairs) return;
  uint x = pair_o[p];
  in_list[in_offset[x] + atomic_inc(&in_cursor[x])] = p;
}

inline uint pair_entries(uint rel) {
  return rel == VM_REL_CROSS ? 4 : 3;
}

/* ---- Triple points ---------------------------------------------------------------------------
 * Three mutually entangled triangles x, b, c get three independently snapped lines that need not
 * meet in one point. Where they do not, the small cell between them can order the three
 * cyclically (x over b over c over x): occlusion then picks one winner there (occlusion.cl,
 * `visible_at`), and for that choice to be the same over a whole fragment every member must be
 * clipped by all three lines, not only its own two. So x also gets the line of the pair (b, c)
 * when b and c are both entangled with x, (b, c) crosses, and a cyclic order of the three is
 * possible somewhere in their common footprint (tested below in doubles, with a margin, so the
 * test only ever adds lines: an extra line splits a fragment and changes no visibility). */

/* The pair (lo, hi) with lo < hi, or VM_NONE_PAIR. Pairs are listed under their lower member. */
#define VM_NONE_PAIR 0xffffffffu
inline uint find_pair(uint lo, uint hi, __global const uint* out_count,
                      __global const uint* out_offset, __global const uint* pair_o) {
  uint o = out_offset[lo], n = out_count[lo];
  for (uint k = 0; k < n; ++k)
    if (pair_o[o + k] == hi) return o + k;
  return VM_NONE_PAIR;
}

/* Keeps the part of convex polygon p (n vertices) where a*x + b*y + c >= -slack; returns the
 * new count (at most n + 1). */
inline int clip_half(double2* p, int n, double a, double b, double c, double slack) {
  double2 q[20];
  int m = 0;
  for (int i = 0; i < n && m < 19; ++i) {
    double2 u = p[i], v = p[i + 1 == n ? 0 : i + 1];
    double su = a * u.x + b * u.y + c + slack, sv = a * v.x + b * v.y + c + slack;
    if (su >= 0) q[m++] = u;
    if ((su >= 0) != (sv >= 0)) q[m++] = u + (v - u) * (su / (su - sv));
  }
  for (int i = 0; i < m; ++i) p[i] = q[i];
  return m;
}

/* Margin of the cycle test, in grid units of distance: far above the rounding of the doubles
 * (coordinates < 2^24, 53-bit mantissas), so a cycle cell that exists is never missed. */
#define VM_TRIPLE_SLACK 0.5

/* Restricts p to where u is in front of v, for the relation (rel, line) of u and v as
 * pair_relation gives it (u_lo: u is the lower member). Returns the new count, 0 when nowhere. */
inline int clip_front(double2* p, int n, uint rel, VmLine l, bool u_lo) {
  if (rel == VM_REL_CROSS) {
    Line3 L = line_of_vm(l); /* the lower member is in front on the positive side */
    double a = (double)L.a, b = (double)L.b, c = (double)L.c;
    if (!u_lo) {
      a = -a;
      b = -b;
      c = -c;
    }
    return clip_half(p, n, a, b, c, VM_TRIPLE_SLACK * sqrt(a * a + b * b));
  }
  bool lo_front = (rel & 3) == VM_REL_A_FRONT;
  return lo_front == u_lo ? n : 0;
}

/* Can x, b, c be ordered cyclically at some point of their common footprint, given the
 * relations of their three pairs (rel, line as from pair_relation, lower member first)? */
inline bool cycle_possible(uint x, uint b, uint c, __global const VmScreenTri* tris, uint r_xb,
                           VmLine l_xb, uint r_xc, VmLine l_xc, uint r_bc, VmLine l_bc) {
  uint id[3] = {x, b, c};
  double2 box[20];
  int n0 = 4;
  {
    VmScreenTri t = tris[x];
    double lx = (double)min(min(t.x[0], t.x[1]), t.x[2]) - 2,
           hx = (double)max(max(t.x[0], t.x[1]), t.x[2]) + 2;
    double ly = (double)min(min(t.y[0], t.y[1]), t.y[2]) - 2,
           hy = (double)max(max(t.y[0], t.y[1]), t.y[2]) + 2;
    box[0] = (double2)(lx, ly);
    box[1] = (double2)(hx, ly);
    box[2] = (double2)(hx, hy);
    box[3] = (double2)(lx, hy);
  }
  for (int m = 0; m < 3 && n0 > 0; ++m) {
    VmScreenTri t = tris[id[m]];
    for (int i = 0; i < 3 && n0 > 0; ++i) {
      int j = i == 2 ? 0 : i + 1;
      Line3 L = line_of(t.x[i], t.y[i], t.x[j], t.y[j]);
      double a = (double)L.a, bb = (double)L.b;
      n0 = clip_half(box, n0, a, bb, (double)L.c, VM_TRIPLE_SLACK * sqrt(a * a + bb * bb));
    }
  }
  if (n0 == 0) return false;
  /* The two cyclic orders: x > b > c > x and x > c > b > x (">" = in front). */
  for (int dir = 0; dir < 2; ++dir) {
    double2 p[20];
    for (int i = 0; i < n0; ++i) p[i] = box[i];
    int n = n0;
    uint u0 = dir ? c : b, u1 = dir ? b : c;
    /* x in front of u0, u0 in front of u1, u1 in front of x */
    n = clip_front(p, n, dir ? r_xc : r_xb, dir ? l_xc : l_xb, x < u0);
    if (n > 0) n = clip_front(p, n, r_bc, l_bc, u0 < u1);
    if (n > 0) n = clip_front(p, n, dir ? r_xb : r_xc, dir ? l_xb : l_xc, u1 < x);
    if (n > 0) return true;
  }
  return false;
}

/* The partner of x in the k-th of its pairs (its own pairs first, then the incoming ones) and
 * that pair's record. */
inline uint partner_at(uint x, uint k, __global const uint* out_count,
                       __global const uint* out_offset, __global const uint* in_offset,
                       __global const uint* in_list, __global const uint* pair_t,
                       __global const uint* pair_o, uint* pr) {
  uint no = out_count[x];
  if (k < no) {
    *pr = out_offset[x] + k;
    return pair_o[*pr];
  }
  *pr = in_list[in_offset[x] + (k - no)];
  return pair_t[*pr];
}

/* An entry without a partner (a triple-point entry): a crossing line or a segment. */
inline void put_entry(__global VmEdge* out, __global uint* partner, uint m, VmEdge e) {
  out[m] = e;
  partner[m] = VM_NONE_PAIR;
}

/* x's triple-point entries: counts them, and writes them when out is not null. Partner
 * VM_NONE_PAIR, so that occlusion never takes one for an entry of x's own pairs.
 * 1. b, c both entangled with x, (b, c) crossing: the line of (b, c).
 * 2. b entangled with x, (b, c) crossing, c not entangled with x but overlapping it (a fold of
 *    one surface in front of or behind x, ordered with x by depth over their whole overlap):
 *    the line of (b, c) and c's three edges, since x is not clipped by c's edges otherwise. */
inline uint triple_lines(uint x, __global const VmScreenTri* tris, __global const uint* out_count,
                         __global const uint* out_offset, __global const uint* in_count,
                         __global const uint* in_offset, __global const uint* in_list,
                         __global const uint* pair_t, __global const uint* pair_o,
                         __global const uint* pair_rel, __global const VmLine* pair_line,
                         __global VmEdge* out, __global uint* partner) {
  uint np = out_count[x] + in_count[x];
  uint m = 0;
  for (uint i = 0; i < np; ++i) {
    uint pi;
    uint b = partner_at(x, i, out_count, out_offset, in_offset, in_list, pair_t, pair_o, &pi);
    for (uint j = i + 1; j < np; ++j) {
      uint pj;
      uint c = partner_at(x, j, out_count, out_offset, in_offset, in_list, pair_t, pair_o, &pj);
      uint pbc = b < c ? find_pair(b, c, out_count, out_offset, pair_o)
                       : find_pair(c, b, out_count, out_offset, pair_o);
      if (pbc == VM_NONE_PAIR || pair_rel[pbc] != VM_REL_CROSS) continue;
      if (!cycle_possible(x, b, c, tris, pair_rel[pi], pair_line[pi], pair_rel[pj], pair_line[pj],
                          VM_REL_CROSS, pair_line[pbc]))
        continue;
      if (out) put_entry(out, partner, m, crossing_edge(line_of_vm(pair_line[pbc])));
      ++m;
    }
    uint nb = out_count[b] + in_count[b];
    for (uint j = 0; j < nb; ++j) {
      uint pbc;
      uint c = partner_at(b, j, out_count, out_offset, in_offset, in_list, pair_t, pair_o, &pbc);
      if (c == x || pair_rel[pbc] != VM_REL_CROSS) continue;
      if ((x < c ? find_pair(x, c, out_count, out_offset, pair_o)
                 : find_pair(c, x, out_count, out_offset, pair_o)) != VM_NONE_PAIR)
        continue; /* entangled with x: case 1 */
      VmScreenTri tx = tris[x], tc = tris[c];
      if (tx.mesh == tc.mesh && tx.tri == tc.tri) continue;
      VmLine l_xc;
      uint r_xc =
          (uint)(x < c ? pair_relation(&tx, &tc, &l_xc, 1) : pair_relation(&tc, &tx, &l_xc, 1));
      if (r_xc == VM_REL_NONE || r_xc == VM_REL_CROSS) continue;
      if (!cycle_possible(x, b, c, tris, pair_rel[pi], pair_line[pi], r_xc, l_xc, VM_REL_CROSS,
                          pair_line[pbc]))
        continue;
      if (out) {
        put_entry(out, partner, m, crossing_edge(line_of_vm(pair_line[pbc])));
        for (int k = 0; k < 3; ++k) {
          int k1 = k == 2 ? 0 : k + 1;
          put_entry(out, partner, m + 1 + k, segment_edge(tc.x[k], tc.y[k], tc.x[k1], tc.y[k1]));
        }
      }
      m += 4;
    }
  }
  return m;
}

/* Sorts each triangle's incoming list (pair order), so that every later traversal of it, its
 * own or a neighbour's, sees the same order. */
__kernel void cross_in_sort(uint ntris, __global const uint* in_count,
                            __global const uint* in_offset, __global uint* in_list) {
  uint x = get_global_id(0);
  if (x >= ntris) return;
  sort_ids(in_list + in_offset[x], (int)in_count[x]);
}

/* Per triangle: counts its clipping entries (its pairs' and its triple-point entries). */
inline uint entries_of(uint x, __global const VmScreenTri* tris,
                       __global const uint* out_count, __global const uint* out_offset,
                       __global const uint* in_count, __global const uint* in_offset,
                       __global const uint* in_list, __global const uint* pair_t,
                       __global const uint* pair_o, __global const uint* pair_rel,
                       __global const VmLine* pair_line) {
  __global const uint* a = in_list + in_offset[x];
  int n = (int)in_count[x];
  uint c = 0;
  for (uint k = 0; k < out_count[x]; ++k) c += pair_entries(pair_rel[out_offset[x] + k]);
  for (int k = 0; k < n; ++k) c += pair_entries(pair_rel[a[k]]);
  c += triple_lines(x, tris, out_count, out_offset, in_count, in_offset, in_list, pair_t, pair_o,
                    pair_rel, pair_line, 0, 0);
  return c;
}

/* Each triangle's entries counted, and its offset within the work-group with the group's total
 * (scan.cl's fused scan; cross_entry_fill makes the offsets global). */
__kernel __attribute__((reqd_work_group_size(VM_SCAN_WG, 1, 1))) void cross_entry_count(
    uint ntris, __global const VmScreenTri* tris, __global const uint* out_count,
    __global const uint* out_offset, __global const uint* in_count,
    __global const uint* in_offset, __global const uint* in_list, __global const uint* pair_t,
    __global const uint* pair_o, __global const uint* pair_rel, __global const VmLine* pair_line,
    __global uint* ent_count, __global uint* ent_offset, __global uint* group_sums) {
  __local uint tmp[VM_SCAN_WG];
  const uint x = get_global_id(0);
  const uint c = x < ntris ? entries_of(x, tris, out_count, out_offset, in_count, in_offset,
                                        in_list, pair_t, pair_o, pair_rel, pair_line)
                           : 0;
  const uint o = vm_group_offset(c, tmp, group_sums);
  if (x < ntris) {
    ent_count[x] = c;
    ent_offset[x] = o;
  }
}

/* Writes triangle x's entries: for a crossing pair, the snapped intersection line directed so
 * that x is in front on its positive side (an infinite line: q0 = q1 = +inf); for both kinds,
 * the partner's three edges as segments (q0 = q1 = DBL_MAX: always in front). The partner's
 * edges matter because next to it the surface may continue through an edge that is no
 * silhouette but on whose other side the order with x is decided differently. */
inline uint write_entries(uint x, uint p, bool lower, __global const VmScreenTri* tris,
                          __global const uint* pair_t, __global const uint* pair_o,
                          __global const uint* pair_rel, __global const VmLine* pair_line,
                          __global VmEdge* out, __global uint* partner) {
  uint o = lower ? pair_o[p] : pair_t[p];
  uint rel = pair_rel[p];
  uint m = 0;
  if (rel == VM_REL_CROSS) {
    Line3 l = line_of_vm(pair_line[p]);
    out[m] = crossing_edge(lower ? l : line_reversed(l));
    partner[m] = o;
    ++m;
  }
  VmScreenTri other = tris[o];
  for (int i = 0; i < 3; ++i) {
    int j = i == 2 ? 0 : i + 1;
    out[m] = segment_edge(other.x[i], other.y[i], other.x[j], other.y[j]);
    partner[m] = o;
    ++m;
  }
  return m;
}

/* Writes each triangle's entries at its group's base plus cross_entry_count's offset, and makes
 * the offsets global (candidates and occlusion read them by triangle). */
__kernel __attribute__((reqd_work_group_size(VM_SCAN_WG, 1, 1))) void cross_entry_fill(
    uint ntris, __global const VmScreenTri* tris, __global const uint* out_count,
    __global const uint* out_offset, __global const uint* in_count,
    __global const uint* in_offset, __global const uint* in_list, __global const uint* pair_t,
    __global const uint* pair_o, __global const uint* pair_rel, __global const VmLine* pair_line,
    __global uint* ent_offset, __global const uint* group_bases,
    uint groups, uint nsil, __global VmEdge* edges, __global uint* partner) {
  const uint x = get_global_id(0);
  const uint base = vm_group_base(group_bases, groups);
  if (x >= ntris) return;
  uint w = base + ent_offset[x];
  ent_offset[x] = w;
  for (uint k = 0; k < out_count[x]; ++k)
    w += write_entries(x, out_offset[x] + k, true, tris, pair_t, pair_o, pair_rel, pair_line,
                       edges + nsil + w, partner + w);
  for (uint k = 0; k < in_count[x]; ++k)
    w += write_entries(x, in_list[in_offset[x] + k], false, tris, pair_t, pair_o, pair_rel,
                       pair_line, edges + nsil + w, partner + w);
  triple_lines(x, tris, out_count, out_offset, in_count, in_offset, in_list, pair_t, pair_o,
               pair_rel, pair_line, edges + nsil + w, partner + w);
}
