/* Stage 1: transform, near/frustum clipping, culling, snapping (DESIGN §2). One pass per
 * triangle, run twice: clip_count sizes the output, clip_fill writes it at the scanned offsets.
 * Both run the same deterministic code, so the counts match by construction. */

__kernel void transform_vertices(__global const float* pos, uint nv, __constant double* m,
                                 __global double4* clip) {
  uint i = get_global_id(0);
  if (i >= nv) return;
  double x = pos[3 * i], y = pos[3 * i + 1], z = pos[3 * i + 2];
  /* column-major 4x4, as OpenGL */
  clip[i] = (double4)(m[0] * x + m[4] * y + m[8] * z + m[12], m[1] * x + m[5] * y + m[9] * z + m[13],
                      m[2] * x + m[6] * y + m[10] * z + m[14], m[3] * x + m[7] * y + m[11] * z + m[15]);
}

/* Signed distance to clip plane k (inside >= 0): near, far, left, right, bottom, top. */
inline double plane_dist(double4 p, int k) {
  switch (k) {
    case 0: return p.z + p.w;
    case 1: return p.w - p.z;
    case 2: return p.x + p.w;
    case 3: return p.w - p.x;
    case 4: return p.y + p.w;
    default: return p.w - p.y;
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
    double4 t4 = a; a = b; b = t4;
    float3 t3 = ba; ba = bb; bb = t3;
  }
  double da = plane_dist(a, k), db = plane_dist(b, k);
  double t = da / (da - db);
  double4 r = a + (b - a) * t;
  switch (k) {
    case 0: r.z = -r.w; break;
    case 1: r.z = r.w; break;
    case 2: r.x = -r.w; break;
    case 3: r.x = r.w; break;
    case 4: r.y = -r.w; break;
    default: r.y = r.w; break;
  }
  *p = r;
  *bp = ba + (bb - ba) * (float)t;
}

#define VM_CLIP_MAXV 9

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
                          __global ushort4* box_out) {
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

  uint cull = mesh_cull[tri_mesh[t]];
  uint count = 0;
  int4 box = (int4)(INT_MAX, INT_MAX, INT_MIN, INT_MIN);
  for (int i = 1; i + 1 < n; ++i) {
    int a = 0, c1 = i, c2 = i + 1;
    long o = orient_points(X[a], Y[a], X[c1], Y[c1], X[c2], Y[c2]);
    if (o == 0) continue;
    if (cull == VM_CULL_POSITIVE && o > 0) continue;
    if (cull == VM_CULL_NEGATIVE && o < 0) continue;
    int bx0 = min(X[a], min(X[c1], X[c2])), bx1 = max(X[a], max(X[c1], X[c2]));
    int by0 = min(Y[a], min(Y[c1], Y[c2])), by1 = max(Y[a], max(Y[c1], Y[c2]));
    if (bx1 <= region.x || bx0 >= region.z || by1 <= region.y || by0 >= region.w) continue;
    if (hist) {
      int4 r = tile_range((int4)(bx0, by0, bx1, by1), cells);
      for (int cy = r.y; cy <= r.w; ++cy)
        for (int cx = r.x; cx <= r.z; ++cx) atomic_inc(&hist[cy * cells.tiles_x + cx]);
      box = (int4)(min(box.x, bx0), min(box.y, by0), max(box.z, bx1), max(box.w, by1));
    }
    if (write) {
      if (o < 0) {
        int tmp = c1; c1 = c2; c2 = tmp;
      }
      VmScreenTri s;
      s.x[0] = X[a]; s.y[0] = Y[a]; s.q[0] = Q[a];
      s.x[1] = X[c1]; s.y[1] = Y[c1]; s.q[1] = Q[c1];
      s.x[2] = X[c2]; s.y[2] = Y[c2]; s.q[2] = Q[c2];
      s.mesh = tri_mesh[t];
      s.tri = tri_local[t];
      s.src = t;
      s.pad = 0;
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

__kernel void clip_count(__global const uint* idx, uint ntri, __global const double4* clip,
                         __global const uint* tri_mesh, __global const uint* tri_local,
                         __global const uint* mesh_cull, uint width, uint height, int ortho,
                         int4 region, __global const ushort4* boxes, int use_boxes,
                         __global uint* counts) {
  uint t = get_global_id(0);
  if (t >= ntri) return;
  VmGrid none = {0, 0, 0, 0};
  counts[t] = box_meets(boxes, use_boxes, t, region)
                  ? clip_triangle(t, idx, clip, tri_mesh, tri_local, mesh_cull, width, height, ortho,
                                  region, 0, 0, 0, 0, none, 0, 0)
                  : 0;
}

__kernel void clip_fill(__global const uint* idx, uint ntri, __global const double4* clip,
                        __global const uint* tri_mesh, __global const uint* tri_local,
                        __global const uint* mesh_cull, uint width, uint height, int ortho,
                        int4 region, __global const ushort4* boxes, int use_boxes,
                        __global const uint* offsets, __global VmScreenTri* out,
                        __global float* bary_out, int want_bary) {
  uint t = get_global_id(0);
  if (t >= ntri) return;
  if (!box_meets(boxes, use_boxes, t, region)) return;
  VmGrid none = {0, 0, 0, 0};
  clip_triangle(t, idx, clip, tri_mesh, tri_local, mesh_cull, width, height, ortho, region, 1,
                offsets[t], out, want_bary ? bary_out : 0, none, 0, 0);
}

/* For planning buckets: per-cell counts of the screen triangles whose box touches each cell
 * (a triangle over several cells counts in each, so sums over cells bound a region's count from
 * above), and each input triangle's box in pixels. */
__kernel void clip_cells(__global const uint* idx, uint ntri, __global const double4* clip,
                         __global const uint* tri_mesh, __global const uint* tri_local,
                         __global const uint* mesh_cull, uint width, uint height, int ortho,
                         int4 region, VmGrid cells, __global uint* hist, __global ushort4* boxes) {
  uint t = get_global_id(0);
  if (t >= ntri) return;
  clip_triangle(t, idx, clip, tri_mesh, tri_local, mesh_cull, width, height, ortho, region, 0, 0, 0,
                0, cells, hist, boxes);
}
