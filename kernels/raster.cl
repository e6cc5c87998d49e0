/* The floor (issue 5): a plain z-buffer id raster of the same screen triangles on the same
 * device, the cheapest picture of "who is visible" to compare the pipeline's time against. One
 * sample per pixel centre, nearness from the triangle's depth plane. Two passes with 32-bit
 * atomics only (OpenCL 1.2 core): the nearest depth per pixel, then the lowest screen-triangle
 * index among the triangles at that depth. Not exact (float depth, one sample): a floor, not a
 * reference (core/check does the exact checks). */

/* Order-preserving key of a nearness: larger q, larger key. */
inline uint zb_key(double q) {
  uint b = as_uint((float)q);
  return (b & 0x80000000u) ? ~b : (b | 0x80000000u);
}

/* Runs BODY for every pixel centre (px + 1/2, py + 1/2) inside or on the edge of triangle T,
 * with pix (the pixel's index) and key (T's depth key there) set. Depth starts at 0 and ids at
 * 0xffffffff (the host fills them). */
#define ZB_FOR_PIXELS(T, W, H, BODY)                                                  \
  {                                                                                   \
    int x0 = min(T.x[0], min(T.x[1], T.x[2])), x1 = max(T.x[0], max(T.x[1], T.x[2])); \
    int y0 = min(T.y[0], min(T.y[1], T.y[2])), y1 = max(T.y[0], max(T.y[1], T.y[2])); \
    const int hp = VM_GRID_SCALE / 2;                                                 \
    int px0 = max(0, (x0 - hp + VM_GRID_SCALE - 1) / VM_GRID_SCALE);                  \
    int px1 = min((int)(W)-1, (x1 - hp) / VM_GRID_SCALE);                             \
    int py0 = max(0, (y0 - hp + VM_GRID_SCALE - 1) / VM_GRID_SCALE);                  \
    int py1 = min((int)(H)-1, (y1 - hp) / VM_GRID_SCALE);                             \
    DepthPlane P = depth_plane(&T);                                                   \
    for (int py = py0; py <= py1; ++py)                                               \
      for (int px = px0; px <= px1; ++px) {                                           \
        long gx = (long)px * VM_GRID_SCALE + hp, gy = (long)py * VM_GRID_SCALE + hp;  \
        if (orient_points(T.x[0], T.y[0], T.x[1], T.y[1], gx, gy) < 0 ||              \
            orient_points(T.x[1], T.y[1], T.x[2], T.y[2], gx, gy) < 0 ||              \
            orient_points(T.x[2], T.y[2], T.x[0], T.y[0], gx, gy) < 0)                \
          continue;                                                                   \
        uint pix = (uint)py * (W) + (uint)px;                                         \
        uint key = zb_key(plane_at(P, (double)gx, (double)gy));                       \
        BODY                                                                          \
      }                                                                               \
  }

__kernel void zb_depth(__global const VmScreenTri* tris, uint ntris, uint W, uint H,
                       __global uint* depth) {
  uint t = get_global_id(0);
  if (t >= ntris) return;
  VmScreenTri T = tris[t];
  ZB_FOR_PIXELS(T, W, H, { atomic_max(&depth[pix], key); })
}

__kernel void zb_ids(__global const VmScreenTri* tris, uint ntris, uint W, uint H,
                     __global const uint* depth, __global uint* ids) {
  uint t = get_global_id(0);
  if (t >= ntris) return;
  VmScreenTri T = tris[t];
  ZB_FOR_PIXELS(T, W, H, {
    if (key == depth[pix]) atomic_min(&ids[pix], t);
  })
}
