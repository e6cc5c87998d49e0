/* Stage 1: transform, near/frustum clipping, culling, snapping (DESIGN §2). One pass per
 * triangle, run twice: clip_count sizes the output, clip_fill writes it at the scanned offsets.
 * Both run the same deterministic code, so the counts match by construction. */

/* Item 0 also zeroes the frame's words (its four depth exponents, clip_fill and clip_cells, and
 * its counts, VM_FRAME_*): one launch, not a fill besides. */
__kernel void transform_vertices(__global const float* pos, uint nv, __constant double* m,
                                 __global double4* clip, __global int* depth_ex) {
  uint i = get_global_id(0);
  if (i == 0)
    for (int k = 0; k < VM_FRAME_WORDS; ++k) depth_ex[k] = 0;
  if (i >= nv) return;
  double x = pos[3 * i], y = pos[3 * i + 1], z = pos[3 * i + 2];
  /* column-major 4x4, as OpenGL. (Oclgrind's --uninitialized flags this store when optimised:
   * LLVM 14 writes it as a store of an undef double4 and then its four lanes, as the same line
   * alone in a minimal kernel shows; unoptimised, as ClRuntime::build builds for Oclgrind, it is
   * clean. All four lanes are written.) */
  clip[i] =
      (double4)(m[0] * x + m[4] * y + m[8] * z + m[12], m[1] * x + m[5] * y + m[9] * z + m[13],
                m[2] * x + m[6] * y + m[10] * z + m[14], m[3] * x + m[7] * y + m[11] * z + m[15]);
}

/* Signed distance to clip plane k (inside >= 0): near, far, left, right, bottom, top. */
inline double plane_dist(double4 p, int k) {
  switch (k) {
    case 0:
      return p.z + p.w;
    case 1:
      return p.w - p.z;
    case 2:
      return p.x + p.w;
    case 3:
      return p.w - p.x;
    case 4:
      return p.y + p.w;
    default:
      return p.w - p.y;
  }
}

inline bool clip_before(double4 a, double4 b) {
  if (a.x != b.x) return a.x < b.x;
  if (a.y != b.y) return a.y < b.y;
  if (a.z != b.z) return a.z < b.z;
  return a.w < b.w;
}

/* The crossing of edge (a, b) with plane k, computed from the endpoints in a canonical order so
 * that two triangles sharing the edge get bit-identical points, then put exactly on the plane. */
inline void clip_edge(double4 a, float3 ba, double4 b, float3 bb, int k, double4* p, float3* bp) {
  if (clip_before(b, a)) {
    double4 t4 = a;
    a = b;
    b = t4;
    float3 t3 = ba;
    ba = bb;
    bb = t3;
  }
  double da = plane_dist(a, k), db = plane_dist(b, k);
  double t = da / (da - db);
  double4 r = a + (b - a) * t;
  switch (k) {
    case 0:
      r.z = -r.w;
      break;
    case 1:
      r.z = r.w;
      break;
    case 2:
      r.x = -r.w;
      break;
    case 3:
      r.x = r.w;
      break;
    case 4:
      r.y = -r.w;
      break;
    default:
      r.y = r.w;
      break;
  }
  *p = r;
  *bp = ba + (bb - ba) * (float)t;
}

/* Depth planes snapped to integers (docs/NUMERICS.md §2 "Depth planes"). Every screen
 * triangle's nearness plane becomes q = N(x, y) / 2^k with N(x, y) = N_0 + A (x - x_0) +
 * B (y - y_0), integers |A|, |B| <= 2^VM_PLANE_SLOPE_BITS, |N_i| <= 2^VM_PLANE_VALUE_BITS at
 * the vertices, one k for the frame (shared by all buckets under --memory-budget). Then the line
 * where two planes cross is an integer line, exactly: no rounding, no snap band, and three
 * crossing lines of three planes meet in one point. A vertex's depth moves by at most
 * (1 + |x - x_0| + |y - y_0|) / 2^(k+1), the rounding of A, B and N_0.
 *
 * k comes from three reductions, each a max of a biased value (the buffer starts at 0):
 *   ex[0] = VM_PLANE_BIAS - min over T of the largest k at which T's slopes fit,
 *   ex[1] = VM_PLANE_BIAS + max over T of the smallest k that keeps T's depth error within
 *           2^-VM_PLANE_FIDELITY_BITS of its largest |q| (of 1 for orthographic views),
 *   ex[2] = VM_PLANE_BIAS - min over T of the largest k at which T's values fit.
 * k = min(values, max(slopes, fidelity)): every slope fits unless that would cost some triangle
 * its fidelity; then the steepest triangles keep their transformed depths (VM_PLANE_FREE) and
 * their crossing lines are rounded as before. */
#define VM_PLANE_BIAS 4096

/* Always the atomic: a plain read first (it sparing the atomic once the maxima settle) raced
 * with the other items' atomic_max, which OpenCL 1.2 leaves undefined (no atomic loads; issue
 * 51, oclgrind --data-races); an atomic read (atomic_or(p, 0)) would cost as much as the max. */
inline void raise_to(__global int* p, int v) {
  atomic_max(p, v);
}

inline void note_depth_exponents(const VmScreenTri* t, int ortho, __global int* ex) {
  DepthPlane p = depth_plane(t);
  double g = fmax(fabs(p.gx), fabs(p.gy));
  double m = fmax(fmax(fabs(t->q[0]), fabs(t->q[1])), fabs(t->q[2]));
  if (!isfinite(g) || !isfinite(m)) return;
  /* |A| = |2^k g| < 2^(k + ilogb(g) + 1) <= 2^VM_PLANE_SLOPE_BITS */
  if (g > 0) raise_to(&ex[0], VM_PLANE_BIAS - (VM_PLANE_SLOPE_BITS - 1 - ilogb(g)));
  if (m > 0) {
    /* Orthographic nearness is -z_ndc in [-1, 1], and a surface may sit at 0: its scale is 1. */
    double scale = ortho ? 1.0 : m;
    long w = 0;
    for (int j = 1; j < 3; ++j)
      w = max(w, (long)abs(t->x[j] - t->x[0]) + (long)abs(t->y[j] - t->y[0]));
    /* (1 + w) / 2^(k+1) <= 2^-F scale  <=>  2^k >= (1 + w) 2^(F-1) / scale */
    double need = ldexp((double)(1 + w) / scale, VM_PLANE_FIDELITY_BITS - 1);
    raise_to(&ex[1], VM_PLANE_BIAS + ilogb(need) + 1);
    /* |N_i| <= 2^k m + (1 + w) / 2 < 2^(k + ilogb(m) + 1) + 2^23 <= 2^VM_PLANE_VALUE_BITS */
    raise_to(&ex[2], VM_PLANE_BIAS - (VM_PLANE_VALUE_BITS - 2 - ilogb(m)));
  }
}

/* (Noted by clip_fill as it writes the screen triangles; under --memory-budget clip_cells notes
 * every screen triangle of the frame instead, so that all buckets share one k.) */

inline int depth_exponent(__global const int* ex) {
  int slopes = VM_PLANE_BIAS - ex[0], fidelity = ex[1] - VM_PLANE_BIAS,
      values = VM_PLANE_BIAS - ex[2];
  return clamp(min(values, max(slopes, fidelity)), -1000, 1000);
}

/* t's depth plane snapped to integers over 2^k; false (t as it was) when it cannot be. */
inline bool snap_plane(VmScreenTri* tp, int k) {
  VmScreenTri t = *tp;
  DepthPlane p = depth_plane(&t);
  double A = rint(ldexp(p.gx, k)), B = rint(ldexp(p.gy, k)), N0 = rint(ldexp(t.q[0], k));
  const double slope_lim = (double)(1L << VM_PLANE_SLOPE_BITS);
  const long value_lim = 1L << VM_PLANE_VALUE_BITS;
  if (!(fabs(A) <= slope_lim && fabs(B) <= slope_lim && fabs(N0) <= (double)value_lim))
    return false;
  long a = (long)A, b = (long)B, N[3];
  N[0] = (long)N0;
  for (int j = 1; j < 3; ++j) {
    N[j] = N[0] + a * (long)(t.x[j] - t.x[0]) + b * (long)(t.y[j] - t.y[0]);
    if (N[j] > value_lim || N[j] < -value_lim) return false;
  }
  for (int j = 0; j < 3; ++j) t.q[j] = ldexp((double)N[j], -k); /* exact: |N| <= 2^52 */
  t.plane_k = k;
  /* What crossings.cl will read back must be this plane, or the triangle stays free (the
   * reference takes plane_k as the promise of an exact line). */
  long ra, rb, rc;
  if (!int_plane(&t, &ra, &rb, &rc) || ra != a || rb != b) return false;
  *tp = t;
  return true;
}

#ifndef VM_APART_MUTATION
#define VM_APART_MUTATION 0
#endif

/* Each screen triangle's plane snapped (snap_plane), then its box and nearness range for the
 * binning (bin.cl), so pair tests can reject by depth before loading it. With scene facts
 * (use_apart), also whether the triangle is apart in this view (crossings.cl): its source's
 * clearance passes `need` (core/facts/scene_facts.h) and its plane is not steeper than 16 qmax
 * per grid unit (the rounding of an overlap's corners moves its depth by less than the margin
 * the need has for it: docs/NUMERICS.md §2 "Pairs far apart in 3D"). */
__kernel void snap_depth_planes(__global VmScreenTri* tris, uint n, __global const int* ex,
                                __global int4* bb, __global double2* qr, int use_apart,
                                __global const float* clearance, float need, double qmax,
                                __global uchar* apart) {
  uint i = get_global_id(0);
  if (i >= n) return;
  VmScreenTri t = tris[i];
  if (snap_plane(&t, depth_exponent(ex))) tris[i] = t;
  bb[i] = (int4)(min(min(t.x[0], t.x[1]), t.x[2]), min(min(t.y[0], t.y[1]), t.y[2]),
                 max(max(t.x[0], t.x[1]), t.x[2]), max(max(t.y[0], t.y[1]), t.y[2]));
  qr[i] = (double2)(fmin(fmin(t.q[0], t.q[1]), t.q[2]), fmax(fmax(t.q[0], t.q[1]), t.q[2]));
  if (use_apart) {
    DepthPlane p = depth_plane(&t);
#if VM_APART_MUTATION == 1 /* (tests/test_cull.cpp: apart without the clearance must be caught) */
    apart[i] = fabs(p.gx) + fabs(p.gy) <= 16.0 * qmax ? 1 : 0;
#else
    apart[i] = clearance[t.src] > need && fabs(p.gx) + fabs(p.gy) <= 16.0 * qmax ? 1 : 0;
#endif
  }
}

#define VM_CLIP_MAXV 9

/* Does the snapped polygon (X, Y) turn one way only, once around? Then it is convex and its fan
 * from vertex 0 tiles it. Repeated vertices are passed over; a vertex where the polygon turns
 * back (a spike) or turns the other way, or a polygon that winds more than once, is not convex.
 * A polygon with fewer than 3 distinct vertices in a row counts as convex (its fan is empty). */
inline bool snapped_convex(const int* X, const int* Y, int n) {
  int v[VM_CLIP_MAXV], m = 0;
  for (int i = 0; i < n; ++i) {
    int j = i + 1 == n ? 0 : i + 1;
    if (X[i] != X[j] || Y[i] != Y[j]) v[m++] = i;
  }
  if (m < 3) return true;
  long sign = 0;
  int wind = 0;
  for (int i = 0; i < m; ++i) {
    int a = v[i == 0 ? m - 1 : i - 1], b = v[i], c = v[i + 1 == m ? 0 : i + 1];
    long ex = X[b] - X[a], ey = Y[b] - Y[a], fx = X[c] - X[b], fy = Y[c] - Y[b];
    long o = ex * fy - ey * fx;
    if (o == 0) {
      if (ex * fx + ey * fy <= 0) return false; /* turns back */
      continue;
    }
    if (sign == 0) sign = o > 0 ? 1 : -1;
    if ((o > 0 ? 1 : -1) != sign) return false;
    /* The edge direction passes angle 0 (turning positively) or leaves it (negatively): once
     * per turn around. Steps are below a half turn, so each pass is seen once. */
    if (sign > 0 ? (ey < 0 && fy >= 0) : (ey >= 0 && fy < 0)) ++wind;
  }
  return sign == 0 || wind == 1;
}

/* The convex hull of the n snapped points (X, Y), as indices into them in positive turning order
 * (orient_points > 0), collinear points left out (Andrew's monotone chain, n <= VM_CLIP_MAXV).
 * Returns its size (< 3: no area). */
inline int snapped_hull(const int* X, const int* Y, int n, int* hull) {
  int s[VM_CLIP_MAXV];
  for (int i = 0; i < n; ++i) { /* sorted by (x, y), insertion */
    int j = i;
    for (; j > 0 && (X[s[j - 1]] > X[i] || (X[s[j - 1]] == X[i] && Y[s[j - 1]] > Y[i])); --j)
      s[j] = s[j - 1];
    s[j] = i;
  }
  int h[2 * VM_CLIP_MAXV], k = 0;
  for (int pass = 0; pass < 2; ++pass) {
    const int start = k;
    for (int q = 0; q < n; ++q) {
      int i = pass ? s[n - 1 - q] : s[q];
      while (k >= start + 2 && orient_points(X[h[k - 2]], Y[h[k - 2]], X[h[k - 1]], Y[h[k - 1]],
                                             X[i], Y[i]) <= 0)
        --k;
      h[k++] = i;
    }
    --k; /* the last point of each chain is the first of the other */
  }
  for (int i = 0; i < k; ++i) hull[i] = h[i];
  return k;
}

/* Clips input triangle t and emits its snapped, non-degenerate, non-culled fan triangles.
 * Returns how many; writes them at out[base...] when write is set. The region (grid units,
 * x0 y0 x1 y1) is the part of the screen being rendered: fan triangles whose box misses its
 * interior are left out (buckets, --memory-budget). When hist is given, each kept fan triangle
 * adds one to every cell of the grid `cells` its box touches, and box_out (pixels) receives the
 * union of their boxes. */
inline uint clip_triangle(uint t, __global const uint* idx, __global const double4* clip,
                          __global const uint* tri_mesh, __global const uint* tri_local,
                          __global const uint* mesh_cull, uint width, uint height, int ortho,
                          int4 region, int write, uint base, __global VmScreenTri* out,
                          __global float* bary_out, VmGrid cells, __global uint* hist,
                          __global ushort4* box_out, __global int* depth_ex, uint* backs) {
  double4 p[VM_CLIP_MAXV], np[VM_CLIP_MAXV];
  float3 b[VM_CLIP_MAXV], nb[VM_CLIP_MAXV];
  int n = 3;
  p[0] = clip[idx[3 * t]];
  p[1] = clip[idx[3 * t + 1]];
  p[2] = clip[idx[3 * t + 2]];
  b[0] = (float3)(1, 0, 0);
  b[1] = (float3)(0, 1, 0);
  b[2] = (float3)(0, 0, 1);
  /* Most triangles lie wholly inside the view volume: then clipping would copy them unchanged. */
  bool inside = true;
  for (int k = 0; k < 6 && inside; ++k)
    inside = plane_dist(p[0], k) >= 0 && plane_dist(p[1], k) >= 0 && plane_dist(p[2], k) >= 0;
  for (int k = 0; k < 6 && n > 0 && !inside; ++k) {
    int m = 0;
    for (int i = 0; i < n; ++i) {
      int j = i + 1 == n ? 0 : i + 1;
      double di = plane_dist(p[i], k), dj = plane_dist(p[j], k);
      bool in_i = di >= 0, in_j = dj >= 0;
      if (in_i) {
        np[m] = p[i];
        nb[m] = b[i];
        ++m;
      }
      if (in_i != in_j) {
        clip_edge(p[i], b[i], p[j], b[j], k, &np[m], &nb[m]);
        ++m;
      }
    }
    n = m;
    for (int i = 0; i < n; ++i) {
      p[i] = np[i];
      b[i] = nb[i];
    }
  }
  if (n < 3) return 0;

  /* Snap to the grid (y down) and compute the nearness. */
  int X[VM_CLIP_MAXV], Y[VM_CLIP_MAXV];
  double Q[VM_CLIP_MAXV];
  double sx = (double)width * VM_GRID_SCALE * 0.5, sy = (double)height * VM_GRID_SCALE * 0.5;
  double xmax = (double)width * VM_GRID_SCALE, ymax = (double)height * VM_GRID_SCALE;
  for (int i = 0; i < n; ++i) {
    double iw = 1.0 / p[i].w;
    double fx = rint((p[i].x * iw + 1.0) * sx);
    double fy = rint((1.0 - p[i].y * iw) * sy);
    X[i] = (int)clamp(fx, 0.0, xmax);
    Y[i] = (int)clamp(fy, 0.0, ymax);
    Q[i] = ortho ? -p[i].z : iw;
  }
  /* A clipped polygon is convex, but snapping a sliver's (several vertices within a grid unit
   * of one line) can fold it, and its fan triangles would overlap: pieces of one source on top
   * of each other (issue 45). Then its vertices' convex hull is cut instead, wound the way the
   * polygon was before snapping (so that the back-face cull sees its orientation). */
  if (n > 3 && !snapped_convex(X, Y, n)) {
    double area = 0;
    for (int i = 0; i < n; ++i) {
      int j = i + 1 == n ? 0 : i + 1;
      double ax = p[i].x / p[i].w, ay = -p[i].y / p[i].w, bx = p[j].x / p[j].w,
             by = -p[j].y / p[j].w;
      area += ax * by - bx * ay;
    }
    int hull[2 * VM_CLIP_MAXV];
    int h = snapped_hull(X, Y, n, hull);
    int HX[VM_CLIP_MAXV], HY[VM_CLIP_MAXV];
    double HQ[VM_CLIP_MAXV];
    float3 HB[VM_CLIP_MAXV];
    for (int i = 0; i < h; ++i) {
      int s = area < 0 ? hull[h - 1 - i] : hull[i]; /* (y down on the grid, up in NDC) */
      HX[i] = X[s];
      HY[i] = Y[s];
      HQ[i] = Q[s];
      HB[i] = b[s];
    }
    n = h < 3 ? 0 : h;
    for (int i = 0; i < n; ++i) {
      X[i] = HX[i];
      Y[i] = HY[i];
      Q[i] = HQ[i];
      b[i] = HB[i];
    }
  }

  uint cull = mesh_cull[tri_mesh[t]];
  uint count = 0;
  int4 box = (int4)(INT_MAX, INT_MAX, INT_MIN, INT_MIN);
  for (int i = 1; i + 1 < n; ++i) {
    int a = 0, c1 = i, c2 = i + 1;
    long o = orient_points(X[a], Y[a], X[c1], Y[c1], X[c2], Y[c2]);
    if (o == 0) continue;
    if ((cull == VM_CULL_POSITIVE && o > 0) || (cull == VM_CULL_NEGATIVE && o < 0)) {
      ++*backs; /* a back face of a closed mesh seen from outside (counted by clip_count) */
      continue;
    }
    int bx0 = min(X[a], min(X[c1], X[c2])), bx1 = max(X[a], max(X[c1], X[c2]));
    int by0 = min(Y[a], min(Y[c1], Y[c2])), by1 = max(Y[a], max(Y[c1], Y[c2]));
    if (bx1 <= region.x || bx0 >= region.z || by1 <= region.y || by0 >= region.w) continue;
    if (hist) {
      int4 r = tile_range((int4)(bx0, by0, bx1, by1), cells);
      for (int cy = r.y; cy <= r.w; ++cy)
        for (int cx = r.x; cx <= r.z; ++cx) atomic_inc(&hist[cy * cells.tiles_x + cx]);
      box = (int4)(min(box.x, bx0), min(box.y, by0), max(box.z, bx1), max(box.w, by1));
    }
    if (o < 0) {
      int tmp = c1;
      c1 = c2;
      c2 = tmp;
    }
    VmScreenTri s;
    s.x[0] = X[a];
    s.y[0] = Y[a];
    s.q[0] = Q[a];
    s.x[1] = X[c1];
    s.y[1] = Y[c1];
    s.q[1] = Q[c1];
    s.x[2] = X[c2];
    s.y[2] = Y[c2];
    s.q[2] = Q[c2];
    if (depth_ex) note_depth_exponents(&s, ortho, depth_ex);
    if (write) {
      s.mesh = tri_mesh[t];
      s.tri = tri_local[t];
      s.src = t;
      s.plane_k = VM_PLANE_FREE;
      out[base + count] = s;
      if (bary_out) {
        __global float* bo = bary_out + 9 * (base + count);
        vstore3(b[a], 0, bo);
        vstore3(b[c1], 1, bo);
        vstore3(b[c2], 2, bo);
      }
    }
    ++count;
  }
  if (box_out)
    box_out[t] = count ? (ushort4)((ushort)(box.x / VM_GRID_SCALE), (ushort)(box.y / VM_GRID_SCALE),
                                   (ushort)((box.z + VM_GRID_SCALE - 1) / VM_GRID_SCALE),
                                   (ushort)((box.w + VM_GRID_SCALE - 1) / VM_GRID_SCALE))
                       : (ushort4)(0xffff, 0xffff, 0, 0);
  return count;
}

/* Cheap test before clipping again for a region: can triangle t's fan triangles touch the
 * region's interior at all (boxes from clip_cells, in pixels)? */
inline bool box_meets(__global const ushort4* boxes, int use_boxes, uint t, int4 region) {
  if (!use_boxes) return true;
  ushort4 b = boxes[t];
  return (int)b.z * VM_GRID_SCALE > region.x && (int)b.x * VM_GRID_SCALE < region.z &&
         (int)b.w * VM_GRID_SCALE > region.y && (int)b.y * VM_GRID_SCALE < region.w;
}

/* Counts each triangle's screen triangles and scans them within the work-group (scan.cl's fused
 * scan): offsets[t] within the group, the group's total to group_sums. */
__kernel __attribute__((reqd_work_group_size(VM_SCAN_WG, 1, 1))) void clip_count(
    __global const uint* idx, uint ntri, __global const double4* clip,
    __global const uint* tri_mesh, __global const uint* tri_local,
    __global const uint* mesh_cull, uint width, uint height, int ortho, int4 region,
    __global const ushort4* boxes, int use_boxes, __global uint* offsets,
    __global uint* group_sums, __global uint* frame_words) {
  __local uint tmp[VM_SCAN_WG];
  __local uint backs_wg;
  const uint t = get_global_id(0);
  if (get_local_id(0) == 0) backs_wg = 0;
  barrier(CLK_LOCAL_MEM_FENCE);
  VmGrid none = {0, 0, 0, 0};
  uint backs = 0;
  const uint count = t < ntri && box_meets(boxes, use_boxes, t, region)
                         ? clip_triangle(t, idx, clip, tri_mesh, tri_local, mesh_cull, width,
                                         height, ortho, region, 0, 0, 0, 0, none, 0, 0, 0, &backs)
                         : 0;
  if (backs) atomic_add(&backs_wg, backs);
  const uint offset = vm_group_offset(count, tmp, group_sums); /* (its barriers order backs_wg) */
  if (t < ntri) offsets[t] = offset;
  if (get_local_id(0) == 0 && backs_wg)
    atomic_add(&frame_words[VM_FRAME_BACK_FACES], backs_wg); /* (summed over buckets) */
}

/* Writes them at the group's base (scan.cl vm_group_base) plus clip_count's offsets, noting
 * their depth exponents into depth_ex when note_ex is set (a frame without buckets, whose one
 * region is the screen: the exponents of all its screen triangles). */
__kernel __attribute__((reqd_work_group_size(VM_SCAN_WG, 1, 1))) void clip_fill(
    __global const uint* idx, uint ntri, __global const double4* clip,
    __global const uint* tri_mesh, __global const uint* tri_local,
    __global const uint* mesh_cull, uint width, uint height, int ortho, int4 region,
    __global const ushort4* boxes, int use_boxes, __global const uint* offsets,
    __global const uint* group_bases, uint groups,
    __global VmScreenTri* out, __global float* bary_out, int want_bary,
    __global int* depth_ex, int note_ex, __global uint* totals) {
  const uint t = get_global_id(0);
  const uint base = vm_group_base(group_bases, groups);
  if (t == 0) /* the region's totals (layout.h VM_TOTAL_*), zeroed here: one launch less */
    for (int k = 0; k < VM_TOTAL_SLOTS; ++k) totals[k] = 0;
  if (t >= ntri) return;
  if (!box_meets(boxes, use_boxes, t, region)) return;
  VmGrid none = {0, 0, 0, 0};
  uint backs = 0;
  clip_triangle(t, idx, clip, tri_mesh, tri_local, mesh_cull, width, height, ortho, region, 1,
                base + offsets[t], out, want_bary ? bary_out : 0, none, 0, 0,
                note_ex ? depth_ex : 0, &backs);
}

/* For planning buckets: per-cell counts of the screen triangles whose box touches each cell
 * (a triangle over several cells counts in each, so sums over cells bound a region's count from
 * above), and each input triangle's box in pixels. */
__kernel void clip_cells(__global const uint* idx, uint ntri, __global const double4* clip,
                         __global const uint* tri_mesh, __global const uint* tri_local,
                         __global const uint* mesh_cull, uint width, uint height, int ortho,
                         int4 region, VmGrid cells, __global uint* hist, __global ushort4* boxes,
                         __global int* depth_ex) {
  uint t = get_global_id(0);
  if (t >= ntri) return;
  uint backs = 0;
  clip_triangle(t, idx, clip, tri_mesh, tri_local, mesh_cull, width, height, ortho, region, 0, 0, 0,
                0, cells, hist, boxes, depth_ex, &backs);
}
