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

/* Does screen triangle o hide screen triangle t at the fine point (px, py), which both cover?
 * Crossing pairs: by the side of their snapped intersection line (t's copy is directed so that
 * t is in front on its positive side). Other pairs: by the depth difference where it is clear
 * of the tie band, else by the relation of the pair over its whole overlap, so that all points
 * of the overlap get the same answer. */
inline bool hides(uint t, uint o, const VmScreenTri* T, const VmScreenTri* O, long px, long py,
                  __global const VmEdge* edges, uint nsil, __global const uint* cross_offset,
                  __global const uint* cross_count, __global const uint* partner) {
  uint co = cross_offset[t], cn = cross_count[t];
  for (uint k = 0; k < cn; ++k)
    if (partner[co + k] == o) {
      VmEdge e = edges[nsil + co + k];
      if (isinf(e.q0)) return line_side_fine(line_of(e.x0, e.y0, e.x1, e.y1), px, py) < 0;
    }
  const double inv = 1.0 / (double)((long)1 << VM_POINT_BITS);
  double fx = (double)px * inv, fy = (double)py * inv;
  double qt = tri_depth_at(T, fx, fy), qo = tri_depth_at(O, fx, fy);
  double band = VM_TIE_EPS * fmax(fabs(qt), fabs(qo));
  if (qo - qt > band) return true;
  if (qt - qo > band) return false;
  VmLine unused;
  int rel = t < o ? pair_relation(T, O, &unused) : pair_relation(O, T, &unused);
  bool t_is_a = t < o;
  if ((rel & 3) == VM_REL_A_FRONT) return !t_is_a;
  if ((rel & 3) == VM_REL_B_FRONT) return t_is_a;
  /* No overlap of positive area found (or a crossing too short to snap): the tie rule. */
  return in_front(qo, qt, O->mesh, O->tri, T->mesh, T->tri);
}

/* visible[i] = 1 when no screen triangle covers fragment i's interior point in front of it;
 * 0 when one does; 0 (and counted in status[1]) when the fragment has no interior point. */
__kernel void occlude(__global const VmFragMeta* meta, __global const VmLine* lines, uint n,
                      __global const VmScreenTri* tris, __global const int4* tri_bb, VmGrid g,
                      __global const uint* tile_offset,
                      __global const uint* tile_count, __global const uint* tile_list,
                      __global const VmEdge* edges, uint nsil, __global const uint* cross_offset,
                      __global const uint* cross_count, __global const uint* partner,
                      __global uint* visible, __global uint* status) {
  uint i = get_global_id(0);
  if (i >= n) return;
  VmFragMeta m = meta[i];
  long px, py;
  if (!interior_point(lines + (size_t)i * VM_MAXL, m.nlines, &px, &py)) {
    visible[i] = 0;
    atomic_inc(&status[1]);
    return;
  }
  VmScreenTri t = tris[m.tri];
  int gx = (int)(px >> VM_POINT_BITS), gy = (int)(py >> VM_POINT_BITS);
  uint tile = tile_coord(gy, g.tile_shift, g.tiles_y) * g.tiles_x + tile_coord(gx, g.tile_shift, g.tiles_x);
  uint off = tile_offset[tile], cnt = tile_count[tile];
  for (uint k = 0; k < cnt; ++k) {
    uint o = tile_list[off + k];
    if (o == m.tri) continue;
    int4 ob = tri_bb[o];
    if (gx < ob.x || gx > ob.z || gy < ob.y || gy > ob.w) continue;
    if (!covers(&tris[o], px, py)) continue;
    VmScreenTri ot = tris[o];
    if (ot.mesh == t.mesh && ot.tri == t.tri) continue; /* pieces of one source never overlap */
    if (hides(m.tri, o, &t, &ot, px, py, edges, nsil, cross_offset, cross_count, partner)) {
      visible[i] = 0;
      return;
    }
  }
  visible[i] = 1;
}
