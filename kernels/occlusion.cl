/* Stage: occlusion (SVGPU §3.3). After clipping, no silhouette in front of a fragment crosses
 * it, so the fragment is all visible or all hidden: one interior point decides. The point is
 * on a fine grid (VM_POINT_BITS below the snap grid) and is checked EXACTLY to lie strictly
 * inside the fragment; the occluders are the screen triangles binned on a finer grid, each
 * tested exactly for covering the point and then for being in front of the fragment's own
 * triangle there (nearness, with the fixed tie rule). */

/* Finds a fine-grid point strictly inside the fragment. Returns false for a fragment thinner
 * than the fine grid (area below ~2^-40 pixels^2), which is then dropped and counted. */
inline bool interior_point(__global const VmLine* L, uint n, long* px, long* py) {
  double2 v[VM_MAXL];
  Line3 first = line_of_vm(L[0]), cur = first;
  double2 c = (double2)(0, 0);
  for (uint i = 0; i < n; ++i) {
    Line3 nxt = i + 1 == n ? first : line_of_vm(L[i + 1]);
    v[i] = vertex_approx(cur, nxt);
    c += v[i];
    cur = nxt;
  }
  const double scale = (double)((long)1 << VM_POINT_BITS);
  /* Candidates: the vertex centroid, then the centroid of each fan triangle. */
  for (uint attempt = 0; attempt < n - 1; ++attempt) {
    double2 p;
    if (attempt == 0)
      p = c / (double)n;
    else
      p = (v[0] + v[attempt] + v[attempt + 1]) / 3.0;
    long x = (long)rint(p.x * scale), y = (long)rint(p.y * scale);
    bool inside = true;
    for (uint i = 0; i < n && inside; ++i) inside = line_side_fine(line_of_vm(L[i]), x, y) > 0;
    if (inside) {
      *px = x;
      *py = y;
      return true;
    }
  }
  return false;
}

/* The vertex Li ^ Lj exactly, as (X / W, Y / W) with W > 0: |X|, |Y| < 2^85, W < 2^61 (§1 of
 * NUMERICS). False when the lines are parallel. */
inline bool vertex_exact(Line3 Li, Line3 Lj, i128* X, i128* Y, long* W) {
  long w = Li.a * Lj.b - Lj.a * Li.b;
  if (w == 0) return false;
  i128 x = i128_sub(i128_mul64(Li.b, Lj.c), i128_mul64(Lj.b, Li.c));
  i128 y = i128_sub(i128_mul64(Li.c, Lj.a), i128_mul64(Lj.c, Li.a));
  *X = w < 0 ? i128_neg(x) : x;
  *Y = w < 0 ? i128_neg(y) : y;
  *W = w < 0 ? -w : w;
  return true;
}

/* floor(X / W) for W > 0, exactly: the rounded quotient corrected by exact comparisons. */
inline int floor_div_exact(i256 X, i256 W) {
  long g = (long)floor(i256_to_double(X) / i256_to_double(W));
  while (i256_sign(i256_sub(X, i256_mul64(W, g))) < 0) --g;
  while (i256_sign(i256_sub(X, i256_mul64(W, g + 1))) >= 0) ++g;
  return (int)g;
}

/* For a cell that interior_point() found no fine-grid point in (thinner than 2^-VM_POINT_BITS
 * grid units: three lines that nearly meet, e.g. at a triple point): an exact rational point
 * strictly inside, the centroid of a fan triangle of its exact vertices,
 *   (X0 Wa Wb + Xa W0 Wb + Xb W0 Wa) / (3 W0 Wa Wb),
 * numerators below 2^209 and denominator below 2^185. Every candidate is checked exactly
 * against every line, so a cell of positive area always gets one (some fan triangle of a
 * convex polygon has positive area, and its centroid is strictly inside); false means the
 * cell has no interior. */
inline bool exact_interior_point(__global const VmLine* L, uint n, VmSample* s) {
  i128 X0, Y0;
  long W0;
  if (!vertex_exact(line_of_vm(L[0]), line_of_vm(L[1 % n]), &X0, &Y0, &W0)) return false;
  for (uint a = 1; a + 1 < n; ++a) {
    i128 Xa, Ya, Xb, Yb;
    long Wa, Wb;
    Line3 La = line_of_vm(L[a]), Lb = line_of_vm(L[a + 1]), Lc = line_of_vm(L[(a + 2) % n]);
    if (!vertex_exact(La, Lb, &Xa, &Ya, &Wa) || !vertex_exact(Lb, Lc, &Xb, &Yb, &Wb)) continue;
    i256 X = i256_mul64(i256_mul64(i256_from_i128(X0), Wa), Wb);
    X = i256_add(X, i256_mul64(i256_mul64(i256_from_i128(Xa), W0), Wb));
    X = i256_add(X, i256_mul64(i256_mul64(i256_from_i128(Xb), W0), Wa));
    i256 Y = i256_mul64(i256_mul64(i256_from_i128(Y0), Wa), Wb);
    Y = i256_add(Y, i256_mul64(i256_mul64(i256_from_i128(Ya), W0), Wb));
    Y = i256_add(Y, i256_mul64(i256_mul64(i256_from_i128(Yb), W0), Wa));
    i256 W = i256_mul64(i256_mul64(i256_from_long(3 * W0), Wa), Wb);
    bool inside = true;
    for (uint i = 0; i < n && inside; ++i) inside = line_side_exact(line_of_vm(L[i]), X, Y, W) > 0;
    if (!inside) continue;
    s->exact = 1;
    s->X = X;
    s->Y = Y;
    s->W = W;
    s->px = s->py = 0;
    s->gx = floor_div_exact(X, W);
    s->gy = floor_div_exact(Y, W);
    double w = i256_to_double(W);
    s->fx = i256_to_double(X) / w;
    s->fy = i256_to_double(Y) / w;
    return true;
  }
  return false;
}

/* Exact: is the fine point inside or on the boundary of screen triangle o (orient > 0)? */
inline bool covers(__global const VmScreenTri* o, long px, long py) {
  for (int i = 0; i < 3; ++i) {
    int j = i == 2 ? 0 : i + 1;
    long ax = (long)o->x[i] << VM_POINT_BITS, ay = (long)o->y[i] << VM_POINT_BITS;
    long ex = o->x[j] - o->x[i], ey = o->y[j] - o->y[i];
    i128 s = i128_sub(i128_mul64(ex, py - ay), i128_mul64(ey, px - ax));
    if (i128_sign(s) < 0) return false;
  }
  return true;
}

/* Exact: is the rational point (X / W, Y / W) inside or on the boundary of o? Each term below
 * 2^23 * 2^210. */
inline bool covers_exact(__global const VmScreenTri* o, i256 X, i256 Y, i256 W) {
  for (int i = 0; i < 3; ++i) {
    int j = i == 2 ? 0 : i + 1;
    long ex = o->x[j] - o->x[i], ey = o->y[j] - o->y[i];
    i256 dy = i256_sub(Y, i256_mul64(W, o->y[i])), dx = i256_sub(X, i256_mul64(W, o->x[i]));
    if (i256_sign(i256_sub(i256_mul64(dy, ex), i256_mul64(dx, ey))) < 0) return false;
  }
  return true;
}

inline bool sample_covers(__global const VmScreenTri* o, const VmSample* s) {
  return s->exact ? covers_exact(o, s->X, s->Y, s->W) : covers(o, s->px, s->py);
}

/* A mutation for tests/test_coplanar.cpp: 1 takes the band at the sample point (the rule before
 * issue 45), so that the point decides pairs the relation orders otherwise; it must be caught. */
#ifndef VM_BAND_MUTATION
#define VM_BAND_MUTATION 0
#endif

/* Does screen triangle o hide screen triangle t at the sample point, which both cover?
 * Crossing pairs: by the side of their snapped intersection line (t's copy is directed so that
 * t is in front on its positive side). Other pairs: by the relation of the pair over its whole
 * overlap (its band is VM_TIE_EPS of the largest |q| over the overlap), so that all points of
 * the overlap get the same answer. The depths at the point stand in for it only where their
 * difference passes twice VM_TIE_EPS of the largest |q| at the six corners: beyond the pair's
 * band with room for the rounding of its overlap, where the relation is that side (or a
 * crossing). A band taken at the point (narrower) would let the point decide
 * (docs/NUMERICS.md §3). Antisymmetric at every point: exactly one of hides(t, o) and
 * hides(o, t) holds, so the covering triangles form a tournament there. */
inline bool hides(uint t, uint o, const VmScreenTri* T, const VmScreenTri* O, const VmSample* smp,
                  __global const VmEdge* edges, uint nsil, __global const uint* cross_offset,
                  __global const uint* cross_count, __global const uint* partner) {
  uint co = cross_offset[t], cn = cross_count[t];
  for (uint k = 0; k < cn; ++k)
    if (partner[co + k] == o) {
      VmEdge e = edges[nsil + co + k];
      if (isinf(e.q0)) {
        /* The point lies on the line only when neither t's nor o's fragment is clipped by it
         * (a tournament among other triangles): the lower index is in front there. */
        int s = sample_side(edge_line(e), smp);
        return s < 0 || (s == 0 && o < t);
      }
      break; /* a tying pair: its entries are the partner's edges */
    }
  double qt = tri_depth_at(T, smp->fx, smp->fy), qo = tri_depth_at(O, smp->fx, smp->fy);
#if VM_BAND_MUTATION == 1
  double band = VM_TIE_EPS * fmax(fabs(qt), fabs(qo));
#else
  double qmax = 0;
  for (int k = 0; k < 3; ++k) qmax = fmax(qmax, fmax(fabs(T->q[k]), fabs(O->q[k])));
  double band = 2.0 * VM_TIE_EPS * qmax;
#endif
  if (qo - qt > band) return true;
  if (qt - qo > band) return false;
  VmLine unused;
  int rel = t < o ? pair_relation(T, O, &unused, 1) : pair_relation(O, T, &unused, 1);
  bool t_is_a = t < o;
  if ((rel & 3) == VM_REL_A_FRONT) return !t_is_a;
  if ((rel & 3) == VM_REL_B_FRONT) return t_is_a;
  /* No overlap of positive area found (or a crossing too short to snap): the tie rule. */
  return in_front(qo, qt, O->mesh, O->tri, T->mesh, T->tri);
}

/* Is screen triangle o one of those competing at the sample point: does it cover the point,
 * and is it no piece of the source of triangle t (pieces of one source never overlap)? */
inline bool competes(__global const VmScreenTri* tris, __global const int4* tri_bb, uint o,
                     const VmScreenTri* t, const VmSample* s) {
  int4 ob = tri_bb[o];
  if (s->gx < ob.x || s->gx > ob.z || s->gy < ob.y || s->gy > ob.w) return false;
  if (!sample_covers(&tris[o], s)) return false;
  VmScreenTri ot = tris[o];
  return !(ot.mesh == t->mesh && ot.tri == t->tri);
}

/* The crossing line of the pair (a, b) from a's entries (directed so that a is in front on its
 * positive side); false when the pair does not cross. */
inline bool pair_line_of(uint a, uint b, __global const VmEdge* edges, uint nsil,
                         __global const uint* cross_offset, __global const uint* cross_count,
                         __global const uint* partner, Line3* L) {
  uint co = cross_offset[a], cn = cross_count[a];
  for (uint k = 0; k < cn; ++k)
    if (partner[co + k] == b) {
      VmEdge e = edges[nsil + co + k];
      if (!isinf(e.q0)) return false;
      Line3 l = edge_line(e);
      /* canonical direction: as the lower member stores it, so both members get one line */
      *L = a < b ? l : line_reversed(l);
      return true;
    }
  return false;
}

/* Triangles a tournament at one point can hold (bit masks of a ulong). */
#ifndef VM_TOUR_MAX
#define VM_TOUR_MAX 64
#endif

/* The visible member of a cycle whose members mem[0..k) are sorted by screen-triangle index.
 * The cycle lies near the triple points of its members: c = the mean of the intersections of
 * any two crossing lines of its pairs that share a member. The visible one is the member in
 * front at c (true depth planes), ties to the lower index: a function of the cycle only, so the
 * same over the whole cell and for every member. Defined for a private member list (wins_cycle)
 * and a global one (occlude_deep): OpenCL C 1.2 has no generic address space. */
#define VM_DEFINE_CYCLE_WINNER(NAME, SPACE)                                                   \
  inline uint NAME(SPACE const uint* mem, uint k, __global const VmScreenTri* tris,           \
                   __global const VmEdge* edges, uint nsil, __global const uint* cross_offset, \
                   __global const uint* cross_count, __global const uint* partner) {           \
    double2 c = (double2)(0, 0);                                                              \
    uint nc = 0;                                                                              \
    for (uint a = 0; a < k; ++a)                                                              \
      for (uint b = 0; b < k; ++b) {                                                          \
        if (b == a) continue;                                                                 \
        Line3 L1;                                                                             \
        if (!pair_line_of(mem[a], mem[b], edges, nsil, cross_offset, cross_count, partner,    \
                          &L1))                                                               \
          continue;                                                                           \
        for (uint d = b + 1; d < k; ++d) {                                                    \
          if (d == a) continue;                                                               \
          Line3 L2;                                                                           \
          if (!pair_line_of(mem[a], mem[d], edges, nsil, cross_offset, cross_count, partner,  \
                            &L2))                                                             \
            continue;                                                                         \
          if (L1.a * L2.b - L2.a * L1.b == 0) continue;                                       \
          c += vertex_approx(L1, L2);                                                         \
          ++nc;                                                                               \
        }                                                                                     \
      }                                                                                       \
    uint best = mem[0];                                                                       \
    if (nc > 0) {                                                                             \
      c /= (double)nc;                                                                        \
      VmScreenTri B = tris[best];                                                             \
      double qb = tri_depth_at(&B, c.x, c.y);                                                 \
      for (uint a = 1; a < k; ++a) {                                                          \
        VmScreenTri A = tris[mem[a]];                                                         \
        double qa = tri_depth_at(&A, c.x, c.y);                                               \
        if (qa > qb) {                                                                        \
          best = mem[a];                                                                      \
          qb = qa;                                                                            \
        }                                                                                     \
      }                                                                                       \
    }                                                                                         \
    return best;                                                                              \
  }
VM_DEFINE_CYCLE_WINNER(cycle_winner, )
VM_DEFINE_CYCLE_WINNER(cycle_winner_global, __global)

/* Triangle t = ids[0] (which has crossing entries) is hidden at the point; ids[0..n) are the
 * triangles covering the point (competes()), in tile order after t. Near a triple point the
 * independently snapped crossing lines can order the covering triangles cyclically (a over b
 * over c over a), so that none is unhidden: a hole. Visibility is then decided by the whole
 * tournament of the covering triangles at the point: its top strongly connected component (the
 * triangles that reach every other one through "hides") is a single triangle where one is
 * unhidden, else a cycle, of which the member in front at the cycle's centre (below) is
 * visible. Every triangle at the point computes the same tournament, so exactly one is visible
 * there; the triple-point entries (crossings.cl) make the answer the same over each fragment.
 * Returns whether t is the visible one. */
inline bool wins_cycle(const uint* ids, uint n, __global const VmScreenTri* tris,
                       const VmSample* smp, __global const VmEdge* edges, uint nsil,
                       __global const uint* cross_offset, __global const uint* cross_count,
                       __global const uint* partner) {
  uint t = ids[0];
  ulong beats[VM_TOUR_MAX];
  for (uint i = 0; i < n; ++i) beats[i] = 0;
  for (uint i = 0; i < n; ++i) {
    VmScreenTri A = tris[ids[i]];
    for (uint j = i + 1; j < n; ++j) {
      VmScreenTri B = tris[ids[j]];
      if (A.mesh == B.mesh && A.tri == B.tri) {
        /* pieces of one source: they only meet on a shared edge; the lower index is in front */
        if (ids[i] < ids[j])
          beats[i] |= (ulong)1 << j;
        else
          beats[j] |= (ulong)1 << i;
        continue;
      }
      if (hides(ids[i], ids[j], &A, &B, smp, edges, nsil, cross_offset, cross_count, partner))
        beats[j] |= (ulong)1 << i;
      else
        beats[i] |= (ulong)1 << j;
    }
  }
  ulong all = n == 64 ? ~(ulong)0 : (((ulong)1 << n) - 1);
  /* The top component: the triangles that reach every other one. t (slot 0) must be in it. */
  ulong top = 0;
  for (uint v = 0; v < n; ++v) {
    ulong r = beats[v] | ((ulong)1 << v), prev = 0;
    while (r != prev) {
      prev = r;
      ulong add = 0;
      for (uint u = 0; u < n; ++u)
        if (r & ((ulong)1 << u)) add |= beats[u];
      r |= add;
    }
    if (r == all) top |= (ulong)1 << v;
  }
  if (!(top & 1)) return false;
  if (top == 1) return true; /* t is hidden by nobody (not reached here, but exact) */
  /* A cycle. Its members, by screen-triangle index, so that every member sees the same list. */
  uint mem[VM_TOUR_MAX];
  uint k = 0;
  for (uint v = 0; v < n; ++v)
    if (top & ((ulong)1 << v)) {
      uint j = k++;
      while (j > 0 && mem[j - 1] > ids[v]) {
        mem[j] = mem[j - 1];
        --j;
      }
      mem[j] = ids[v];
    }
  return cycle_winner(mem, k, tris, edges, nsil, cross_offset, cross_count, partner) == t;
}

/* occlude() leaves this in visible[] for a fragment it found no fine-grid point in. */
#define VM_VISIBLE_THIN 2u
/* A tournament of more than VM_TOUR_MAX triangles, left for occlude_deep (no cap): at the
 * fine-grid point (DEEP) or at the exact point of a thin fragment (DEEP_EXACT). */
#define VM_VISIBLE_DEEP 3u
#define VM_VISIBLE_DEEP_EXACT 4u

/* Is t visible at the sample point, deciding by the whole tournament of the triangles covering
 * it: hidden by nobody, or the visible member of a cycle (wins_cycle). One pass over the
 * point's leaf collects them: 1 visible, 0 hidden, or `deep` when t is hidden and more than
 * VM_TOUR_MAX triangles compete, for occlude_deep to decide with room sized from the count. */
inline uint visible_by_tournament(uint tri, const VmScreenTri* t, const VmSample* s,
                                  __global const VmScreenTri* tris, __global const int4* tri_bb,
                                  __global const uint* list, uint cnt, __global const VmEdge* edges,
                                  uint nsil, __global const uint* cross_offset,
                                  __global const uint* cross_count, __global const uint* partner,
                                  uint deep) {
  uint ids[VM_TOUR_MAX];
  uint nc = 0;
  ids[nc++] = tri;
  bool hidden = false, over = false;
  for (uint k = 0; k < cnt; ++k) {
    uint o = list[k];
    if (o == tri || !competes(tris, tri_bb, o, t, s)) continue;
    if (nc < VM_TOUR_MAX)
      ids[nc++] = o;
    else
      over = true;
    if (!hidden) {
      VmScreenTri ot = tris[o];
      hidden = hides(tri, o, t, &ot, s, edges, nsil, cross_offset, cross_count, partner);
    }
  }
  if (!hidden) return 1;
  if (over) return deep;
  return wins_cycle(ids, nc, tris, s, edges, nsil, cross_offset, cross_count, partner) ? 1 : 0;
}

/* 1 when no screen triangle covers fragment i's interior point in front of it; 0 when one
 * does; VM_VISIBLE_THIN (counted in status[VM_TOTAL_THIN]) when the fragment is thinner than the
 * fine grid, for occlude_thin() to decide. */
inline uint occlude_one(uint i, __global const VmFragMeta* meta, __global const VmLine* lines,
                        __global const VmScreenTri* tris, __global const int4* tri_bb, VmGrid g,
                        __global const uint* tile_leaf, __global const uint* leaf_offset,
                        __global const uint4* class_start, __global const uint* tile_list,
                        __global const VmEdge* edges, uint nsil,
                        __global const uint* cross_offset, __global const uint* cross_count,
                        __global const uint* partner, __global uint* status, VmGrid cull_grid,
                        __global const uint* cull_tile_leaf, __global const double2* leaf_cull,
                        int cull_on) {
  VmFragMeta m = meta[i];
  long px, py;
  if (!interior_point(lines + (size_t)i * VM_MAXL, m.nlines, &px, &py)) {
    atomic_inc(&status[VM_TOTAL_THIN]);
    return VM_VISIBLE_THIN;
  }
  const VmSample s = sample_fine(px, py);
  VmScreenTri t = tris[m.tri];
  int gx = s.gx, gy = s.gy;
  if (cull_on) { /* proven hidden where the point is (cull.cl): no occluder need be looked at */
    const double2 c = leaf_cull[leaf_of_point(gx, gy, cull_grid, cull_tile_leaf)];
    if (tri_depth_at(&t, s.fx, s.fy) + c.y < c.x) return 0;
  }
  uint leaf = leaf_of_point(gx, gy, g, tile_leaf);
  uint off = leaf_offset[leaf], cnt = class_start[leaf].w;
  /* A cycle through t needs one of its entangled partners at the point (a crossing line
   * misplaced by snapping, or a tie): without one, hidden is final. */
  bool partnered = false;
  {
    uint co = cross_offset[m.tri], cn = cross_count[m.tri], last = VM_NONE;
    for (uint k = 0; k < cn && !partnered; ++k) {
      uint o = partner[co + k];
      if (o == last || o == VM_NONE) continue;
      last = o;
      partnered = competes(tris, tri_bb, o, &t, &s);
    }
  }
  if (partnered) {
    /* An entangled partner of t covers the point: hidden may still mean visible when the
     * covering triangles form a cycle. */
    uint v = visible_by_tournament(m.tri, &t, &s, tris, tri_bb, tile_list + off, cnt, edges, nsil,
                                   cross_offset, cross_count, partner, VM_VISIBLE_DEEP);
    if (v == VM_VISIBLE_DEEP) atomic_inc(&status[VM_TOTAL_DEEP]);
    return v;
  }
  /* (Written out rather than through competes(): PoCL compiles this hot loop 3x slower that
   * way.) */
  for (uint k = 0; k < cnt; ++k) {
    uint o = tile_list[off + k];
    if (o == m.tri) continue;
    int4 ob = tri_bb[o];
    if (gx < ob.x || gx > ob.z || gy < ob.y || gy > ob.w) continue;
    if (!covers(&tris[o], px, py)) continue;
    VmScreenTri ot = tris[o];
    if (ot.mesh == t.mesh && ot.tri == t.tri) continue; /* pieces of one source never overlap */
    if (hides(m.tri, o, &t, &ot, &s, edges, nsil, cross_offset, cross_count, partner)) return 0;
  }
  return 1;
}

/* visible[i] as occlude_one, and the visible fragments' offsets within the work-group with
 * the group's total (scan.cl's fused scan, emit_visible adding the bases): right when no
 * fragment was thin or deep; else the host scans again after their passes. */
__kernel __attribute__((reqd_work_group_size(VM_SCAN_WG, 1, 1))) void occlude(
    __global const VmFragMeta* meta, __global const VmLine* lines, uint n,
    __global const VmScreenTri* tris, __global const int4* tri_bb, VmGrid g,
    __global const uint* tile_leaf, __global const uint* leaf_offset,
    __global const uint4* class_start, __global const uint* tile_list,
    __global const VmEdge* edges, uint nsil, __global const uint* cross_offset,
    __global const uint* cross_count, __global const uint* partner, __global uint* visible,
    __global uint* offsets, __global uint* group_sums, __global uint* status, VmGrid cull_grid,
    __global const uint* cull_tile_leaf, __global const double2* leaf_cull, int cull_on) {
  __local uint tmp[VM_SCAN_WG];
  const uint i = get_global_id(0);
  const uint v = i < n ? occlude_one(i, meta, lines, tris, tri_bb, g, tile_leaf, leaf_offset,
                                     class_start, tile_list, edges, nsil, cross_offset,
                                     cross_count, partner, status, cull_grid, cull_tile_leaf,
                                     leaf_cull, cull_on)
                       : 0;
  const uint o = vm_group_offset(v, tmp, group_sums);
  if (i < n) {
    visible[i] = v;
    offsets[i] = o;
  }
}

/* The fragments occlude() left VM_VISIBLE_THIN: decided the same way at an exact rational
 * point inside (exact_interior_point), by the whole tournament (a cell this thin is where
 * nearly concurrent lines meet, so a cycle is likely). A fragment with no interior at all
 * (zero area) is dropped and counted in status[VM_TOTAL_SLIVERS]. Launched only when
 * status[VM_TOTAL_THIN] > 0. */
__kernel void occlude_thin(__global const VmFragMeta* meta, __global const VmLine* lines, uint n,
                           __global const VmScreenTri* tris, __global const int4* tri_bb, VmGrid g,
                           __global const uint* tile_leaf, __global const uint* leaf_offset,
                           __global const uint4* class_start, __global const uint* tile_list,
                           __global const VmEdge* edges, uint nsil,
                           __global const uint* cross_offset, __global const uint* cross_count,
                           __global const uint* partner, __global uint* visible,
                           __global uint* status) {
  uint i = get_global_id(0);
  if (i >= n || visible[i] != VM_VISIBLE_THIN) return;
  VmFragMeta m = meta[i];
  VmSample s;
  if (!exact_interior_point(lines + (size_t)i * VM_MAXL, m.nlines, &s)) {
    visible[i] = 0;
    atomic_inc(&status[VM_TOTAL_SLIVERS]);
    return;
  }
  VmScreenTri t = tris[m.tri];
  uint leaf = leaf_of_point(s.gx, s.gy, g, tile_leaf);
  uint v = visible_by_tournament(m.tri, &t, &s, tris, tri_bb, tile_list + leaf_offset[leaf],
                                 class_start[leaf].w, edges, nsil, cross_offset, cross_count,
                                 partner, VM_VISIBLE_DEEP_EXACT);
  if (v == VM_VISIBLE_DEEP_EXACT) atomic_inc(&status[VM_TOTAL_DEEP]);
  visible[i] = v;
}

/* The sample point occlude() or occlude_thin() decided fragment i at, again, and its leaf. */
inline bool deep_sample(__global const VmFragMeta* meta, __global const VmLine* lines, uint i,
                        uint how, VmGrid g, __global const uint* tile_leaf, VmSample* s,
                        uint* leaf) {
  VmFragMeta m = meta[i];
  if (how == VM_VISIBLE_DEEP_EXACT) {
    if (!exact_interior_point(lines + (size_t)i * VM_MAXL, m.nlines, s)) return false;
  } else {
    long px, py;
    if (!interior_point(lines + (size_t)i * VM_MAXL, m.nlines, &px, &py)) return false;
    *s = sample_fine(px, py);
  }
  *leaf = leaf_of_point(s->gx, s->gy, g, tile_leaf);
  return true;
}

/* Room for a deep fragment's tournament: its own triangle and its leaf's list (an upper bound
 * of the triangles covering the point); 0 for every other fragment. */
__kernel void deep_count(__global const VmFragMeta* meta, __global const VmLine* lines, uint n,
                         VmGrid g, __global const uint* tile_leaf,
                         __global const uint4* class_start, __global const uint* visible,
                         __global uint* need) {
  uint i = get_global_id(0);
  if (i >= n) return;
  uint how = visible[i], leaf = 0;
  VmSample s;
  need[i] = 0;
  if (how != VM_VISIBLE_DEEP && how != VM_VISIBLE_DEEP_EXACT) return;
  if (deep_sample(meta, lines, i, how, g, tile_leaf, &s, &leaf)) need[i] = 1 + class_start[leaf].w;
}

/* The whole tournament at the point of a deep fragment, with no cap: the covering triangles in
 * ids, each one's score (how many of the others it hides) in score, and Landau's criterion for
 * the top strongly connected component (the triangles that reach every other one): sorted by
 * score descending, it is the shortest prefix of size k whose scores sum to
 * k (k - 1) / 2 + k (n - k), i.e. that beats everything outside it, so t is in it iff its
 * score is at least n - k. The same relation and the same cycle rule as wins_cycle(), which
 * does this with bit masks for up to VM_TOUR_MAX triangles. */
__kernel void occlude_deep(__global const VmFragMeta* meta, __global const VmLine* lines, uint n,
                           __global const VmScreenTri* tris, __global const int4* tri_bb, VmGrid g,
                           __global const uint* tile_leaf, __global const uint* leaf_offset,
                           __global const uint4* class_start, __global const uint* tile_list,
                           __global const VmEdge* edges, uint nsil,
                           __global const uint* cross_offset, __global const uint* cross_count,
                           __global const uint* partner, __global const uint* room,
                           __global uint* scratch, uint total, __global uint* visible) {
  uint i = get_global_id(0);
  if (i >= n) return;
  uint how = visible[i], leaf = 0;
  if (how != VM_VISIBLE_DEEP && how != VM_VISIBLE_DEEP_EXACT) return;
  VmSample smp;
  if (!deep_sample(meta, lines, i, how, g, tile_leaf, &smp, &leaf)) {
    visible[i] = 0; /* cannot happen: occlude found the same point */
    return;
  }
  __global uint* ids = scratch + room[i];
  __global uint* score = scratch + total + room[i];
  __global uint* order = scratch + 2 * (size_t)total + room[i];
  const uint tri = meta[i].tri;
  VmScreenTri t = tris[tri];
  __global const uint* list = tile_list + leaf_offset[leaf];
  uint cnt = class_start[leaf].w, nc = 0;
  ids[nc++] = tri;
  for (uint k = 0; k < cnt; ++k) {
    uint o = list[k];
    if (o != tri && competes(tris, tri_bb, o, &t, &smp)) ids[nc++] = o;
  }
  for (uint a = 0; a < nc; ++a) score[a] = 0;
  for (uint a = 0; a < nc; ++a) {
    VmScreenTri A = tris[ids[a]];
    for (uint b = a + 1; b < nc; ++b) {
      VmScreenTri B = tris[ids[b]];
      bool b_wins;
      if (A.mesh == B.mesh && A.tri == B.tri)
        b_wins = ids[b] < ids[a]; /* pieces of one source: the lower index is in front */
      else
        b_wins = hides(ids[a], ids[b], &A, &B, &smp, edges, nsil, cross_offset, cross_count,
                       partner);
      ++score[b_wins ? b : a];
    }
  }
  /* Scores sorted descending (insertion sort: n is a leaf's list at most). */
  for (uint a = 0; a < nc; ++a) {
    uint v = score[a], j = a;
    while (j > 0 && order[j - 1] < v) {
      order[j] = order[j - 1];
      --j;
    }
    order[j] = v;
  }
  ulong sum = 0;
  uint k = nc;
  for (uint m = 1; m <= nc; ++m) {
    sum += order[m - 1];
    if (sum == (ulong)m * (m - 1) / 2 + (ulong)m * (nc - m)) {
      k = m;
      break;
    }
  }
  if (score[0] < nc - k) {
    visible[i] = 0;
    return;
  }
  if (k == 1) {
    visible[i] = 1;
    return;
  }
  /* A cycle: its members by screen-triangle index (in order[], no longer needed for scores),
   * and the one of them in front at the cycle's centre (cycle_winner). */
  uint nm = 0;
  for (uint v = 0; v < nc; ++v)
    if (score[v] >= nc - k) {
      uint j = nm++;
      while (j > 0 && order[j - 1] > ids[v]) {
        order[j] = order[j - 1];
        --j;
      }
      order[j] = ids[v];
    }
  const uint best =
      cycle_winner_global(order, nm, tris, edges, nsil, cross_offset, cross_count, partner);
  visible[i] = best == tri ? 1 : 0;
}
