/* Stage: penetrating geometry (which SVGPU forbids). Where two screen triangles overlap on the
 * screen and their depth planes cross inside the overlap, the front surface switches along the
 * projected intersection line. That line becomes a clipping line for both triangles, snapped to
 * two grid points on it; and inside the overlap the two triangles are ordered by the side of
 * that one snapped line, not by a depth comparison, so both make the same decision at every
 * point: no overlap and no hole, with the error bounded by the snap (docs/NUMERICS.md).
 *
 * Pairs that do not cross are ordered once for their whole overlap: by the sign of the depth
 * difference where it leaves the tie band, else by the tie rule. */

#define VM_REL_NONE 0     /* footprints do not overlap with positive area */
#define VM_REL_A_FRONT 1  /* a is in front of b over the whole overlap */
#define VM_REL_B_FRONT 2
#define VM_REL_CROSS 3
#define VM_REL_TIE 4      /* or'ed in: decided by the tie rule (the planes agree within the band) */

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
inline int pair_relation(const VmScreenTri* a, const VmScreenTri* b, VmLine* line) {
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
    if (dmax > band) return VM_REL_A_FRONT;
    if (dmin < -band) return VM_REL_B_FRONT;
    return VM_REL_TIE | ((a->mesh < b->mesh || (a->mesh == b->mesh && a->tri < b->tri))
                             ? VM_REL_A_FRONT
                             : VM_REL_B_FRONT);
  }
  /* d(x, y) = A x + B y + C, zero on the intersection line. Two grid points on it, one grid
   * unit beyond the overlap's box on either side. */
  double A = pa.gx - pb.gx, B = pa.gy - pb.gy;
  double C = (pa.q0 - pa.gx * pa.x0 - pa.gy * pa.y0) - (pb.q0 - pb.gx * pb.x0 - pb.gy * pb.y0);
  long x0, y0, x1, y1;
  if (fabs(B) >= fabs(A)) {
    x0 = (long)floor(lo.x) - 1;
    x1 = (long)ceil(hi.x) + 1;
    y0 = (long)rint(-(A * (double)x0 + C) / B);
    y1 = (long)rint(-(A * (double)x1 + C) / B);
  } else {
    y0 = (long)floor(lo.y) - 1;
    y1 = (long)ceil(hi.y) + 1;
    x0 = (long)rint(-(B * (double)y0 + C) / A);
    x1 = (long)rint(-(B * (double)y1 + C) / A);
  }
  /* Keep the points inside the grid's range: slide along the line if needed is not worth it;
   * the overlap lies inside the viewport, so clamping moves them only for near-vertical lines
   * that already leave it. */
  long lim = (long)1 << 23;
  x0 = clamp(x0, -lim, lim); y0 = clamp(y0, -lim, lim);
  x1 = clamp(x1, -lim, lim); y1 = clamp(y1, -lim, lim);
  if (x0 == x1 && y0 == y1) return dmax > -dmin ? VM_REL_A_FRONT : VM_REL_B_FRONT;
  /* Positive side of (p0 -> p1) is along (-(y1-y0), x1-x0); a is in front where d > 0. */
  if (A * (double)(-(y1 - y0)) + B * (double)(x1 - x0) < 0) {
    long t = x0; x0 = x1; x1 = t;
    t = y0; y0 = y1; y1 = t;
  }
  line->x0 = (int)x0; line->y0 = (int)y0; line->x1 = (int)x1; line->y1 = (int)y1;
  return VM_REL_CROSS;
}

/* Entangled pairs: crossing pairs and pairs that tie (coplanar within the band). Each pair is
 * found once, by its lower triangle t, through the triangle bins (each pair looked at in one tile
 * only), in one traversal: up to VM_PAIRS_INLINE pairs per triangle go to a scratch slot and the
 * rest only raise a status bit, after which cross_pairs_fill traverses again into exact space. */
#define VM_PAIRS_INLINE 4

inline uint pairs_of(uint t, __global const VmScreenTri* tris, __global const int4* tri_bb,
                     __global const double2* tri_qr, VmGrid g,
                     __global const uint* tile_offset, __global const uint* tile_count,
                     __global const uint* tile_list, uint cap, __global uint* out_o,
                     __global uint* out_rel, __global VmLine* out_line) {
  int4 tb = tri_bb[t];
  VmScreenTri me = tris[t];
  double qmin = fmin(fmin(me.q[0], me.q[1]), me.q[2]), qmax = fmax(fmax(me.q[0], me.q[1]), me.q[2]);
  int4 tr = tile_range(tb, g);
  int tx0 = tr.x, ty0 = tr.y, tx1 = tr.z, ty1 = tr.w;
  uint count = 0;
  for (int ty = ty0; ty <= ty1; ++ty)
    for (int tx = tx0; tx <= tx1; ++tx) {
      uint tile = ty * g.tiles_x + tx;
      uint off = tile_offset[tile], n = tile_count[tile];
      for (uint k = 0; k < n; ++k) {
        uint o = tile_list[off + k];
        if (o <= t) continue;
        if (!pair_here(tb, tri_bb[o], g, tx, ty, true)) continue;
        /* Depth ranges apart beyond the tie band: neither crossing nor tying. */
        double2 oq = tri_qr[o];
        double band = VM_TIE_EPS * fmax(fmax(fabs(qmax), fabs(oq.y)), fmax(fabs(qmin), fabs(oq.x)));
        if (oq.x > qmax + band || qmin > oq.y + band) continue;
        VmScreenTri other = tris[o];
        if (other.mesh == me.mesh && other.tri == me.tri) continue;
        VmLine line;
        int rel = pair_relation(&me, &other, &line);
        if (rel != VM_REL_CROSS && !(rel & VM_REL_TIE)) continue;
        if (count < cap) {
          out_o[count] = o;
          out_rel[count] = (uint)rel;
          out_line[count] = line;
        }
        ++count;
      }
    }
  return count;
}

__kernel void cross_pairs(__global const VmScreenTri* tris, uint ntris, __global const int4* tri_bb,
                          __global const double2* tri_qr, VmGrid g, __global const uint* tile_offset, __global const uint* tile_count,
                          __global const uint* tile_list, __global uint* counts,
                          __global uint* scr_o, __global uint* scr_rel, __global VmLine* scr_line,
                          __global uint* status) {
  uint t = get_global_id(0);
  if (t >= ntris) return;
  size_t s = (size_t)t * VM_PAIRS_INLINE;
  uint c = pairs_of(t, tris, tri_bb, tri_qr, g, tile_offset, tile_count, tile_list, VM_PAIRS_INLINE,
                    scr_o + s, scr_rel + s, scr_line + s);
  counts[t] = c;
  if (c > VM_PAIRS_INLINE) atomic_or(status, VM_STATUS_PAIRS_OVERFLOW);
}

/* Only after an overflow: the same traversal, straight into the compact pair arrays. */
__kernel void cross_pairs_fill(__global const VmScreenTri* tris, uint ntris,
                               __global const int4* tri_bb, __global const double2* tri_qr, VmGrid g,
                               __global const uint* tile_offset, __global const uint* tile_count,
                               __global const uint* tile_list, __global const uint* offsets,
                               __global uint* pair_t, __global uint* pair_o, __global uint* pair_rel,
                               __global VmLine* pair_line) {
  uint t = get_global_id(0);
  if (t >= ntris) return;
  uint o = offsets[t];
  uint c = pairs_of(t, tris, tri_bb, tri_qr, g, tile_offset, tile_count, tile_list, 0xffffffffu,
                    pair_o + o, pair_rel + o, pair_line + o);
  for (uint k = 0; k < c; ++k) pair_t[o + k] = t;
}

__kernel void cross_compact(uint ntris, __global const uint* counts, __global const uint* offsets,
                            __global const uint* scr_o, __global const uint* scr_rel,
                            __global const VmLine* scr_line, __global uint* pair_t,
                            __global uint* pair_o, __global uint* pair_rel,
                            __global VmLine* pair_line) {
  uint t = get_global_id(0);
  if (t >= ntris) return;
  uint c = counts[t], o = offsets[t];
  size_t s = (size_t)t * VM_PAIRS_INLINE;
  for (uint k = 0; k < c; ++k) {
    pair_t[o + k] = t;
    pair_o[o + k] = scr_o[s + k];
    pair_rel[o + k] = scr_rel[s + k];
    pair_line[o + k] = scr_line[s + k];
  }
}

/* The pairs where a triangle is the higher member ("incoming"), as per-triangle lists. */
__kernel void cross_in_count(uint npairs, __global const uint* pair_o, __global uint* in_count) {
  uint p = get_global_id(0);
  if (p >= npairs) return;
  atomic_inc(&in_count[pair_o[p]]);
}

__kernel void cross_in_fill(uint npairs, __global const uint* pair_o, __global const uint* in_offset,
                            __global uint* in_cursor, __global uint* in_list) {
  uint p = get_global_id(0);
  if (p >= npairs) return;
  uint x = pair_o[p];
  in_list[in_offset[x] + atomic_inc(&in_cursor[x])] = p;
}

inline uint pair_entries(uint rel) { return rel == VM_REL_CROSS ? 4 : 3; }

/* Per triangle: sorts its incoming list (pair order, so the result is deterministic) and
 * counts its clipping entries. */
__kernel void cross_entry_count(uint ntris, __global const uint* out_count,
                                __global const uint* out_offset, __global const uint* in_count,
                                __global const uint* in_offset, __global uint* in_list,
                                __global const uint* pair_rel, __global uint* ent_count) {
  uint x = get_global_id(0);
  if (x >= ntris) return;
  __global uint* a = in_list + in_offset[x];
  int n = (int)in_count[x];
  sort_ids(a, n);
  uint c = 0;
  for (uint k = 0; k < out_count[x]; ++k) c += pair_entries(pair_rel[out_offset[x] + k]);
  for (int k = 0; k < n; ++k) c += pair_entries(pair_rel[a[k]]);
  ent_count[x] = c;
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
  VmEdge e;
  if (rel == VM_REL_CROSS) {
    VmLine l = pair_line[p];
    if (lower) {
      e.x0 = l.x0; e.y0 = l.y0; e.x1 = l.x1; e.y1 = l.y1;
    } else {
      e.x0 = l.x1; e.y0 = l.y1; e.x1 = l.x0; e.y1 = l.y0;
    }
    e.q0 = INFINITY;
    e.q1 = INFINITY;
    out[m] = e;
    partner[m] = o;
    ++m;
  }
  VmScreenTri other = tris[o];
  for (int i = 0; i < 3; ++i) {
    int j = i == 2 ? 0 : i + 1;
    e.x0 = other.x[i]; e.y0 = other.y[i]; e.x1 = other.x[j]; e.y1 = other.y[j];
    e.q0 = DBL_MAX;
    e.q1 = DBL_MAX;
    out[m] = e;
    partner[m] = o;
    ++m;
  }
  return m;
}

__kernel void cross_entry_fill(uint ntris, __global const VmScreenTri* tris,
                               __global const uint* out_count, __global const uint* out_offset,
                               __global const uint* in_count, __global const uint* in_offset,
                               __global const uint* in_list, __global const uint* pair_t,
                               __global const uint* pair_o, __global const uint* pair_rel,
                               __global const VmLine* pair_line, __global const uint* ent_offset,
                               uint nsil, __global VmEdge* edges, __global uint* partner) {
  uint x = get_global_id(0);
  if (x >= ntris) return;
  uint w = ent_offset[x];
  for (uint k = 0; k < out_count[x]; ++k)
    w += write_entries(x, out_offset[x] + k, true, tris, pair_t, pair_o, pair_rel, pair_line,
                       edges + nsil + w, partner + w);
  for (uint k = 0; k < in_count[x]; ++k)
    w += write_entries(x, in_list[in_offset[x] + k], false, tris, pair_t, pair_o, pair_rel,
                       pair_line, edges + nsil + w, partner + w);
}
