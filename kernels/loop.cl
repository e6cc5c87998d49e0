/* Stage tessellate, Loop subdivision (core/surfaces/loop.cpp, docs/SURFACES.md): the host builds
 * each level's stencils once per control mesh (CSR rows: new vertex = sum of weights times the
 * previous level's vertices); every frame applies them level by level, then the limit stencil,
 * and measures the screen-space flatness of the level to choose it. */

/* out[i] = sum over row i of w[k] * in[col[k]], xyz packed. */
__kernel void loop_stencil(__global const uint* start, __global const uint* col,
                           __global const float* w, uint n, __global const float* in,
                           __global float* out) {
  uint i = get_global_id(0);
  if (i >= n) return;
  float x = 0, y = 0, z = 0;
  for (uint k = start[i]; k < start[i + 1]; ++k) {
    uint c = col[k];
    float wk = w[k];
    x += wk * in[3 * c];
    y += wk * in[3 * c + 1];
    z += wk * in[3 * c + 2];
  }
  out[3 * i] = x;
  out[3 * i + 1] = y;
  out[3 * i + 2] = z;
}

/* d_L: for each level-L edge (a, b), the distance between the midpoint of its limit points and the
 * limit point of the level-(L+1) vertex on it (index nv + e), in pixels at the nearest w of the
 * three (clamped to the near plane); edges whose three points lie outside one clip plane are not
 * seen and skipped. Each item takes `per` edges and folds its maximum into *dmax (positive floats
 * order as their bits). m: view-projection, row-major rows; f_px: pixels per world unit at w = 1. */
__kernel void loop_edge_error(__global const uint* edge_v, uint ne, uint nv,
                              __global const float* lim, float16 m, float f_px, float w_floor,
                              uint per, __global uint* dmax) {
  uint g = get_global_id(0);
  uint e0 = g * per;
  if (e0 >= ne) return;
  uint e1 = min(ne, e0 + per);
  float best = 0;
  for (uint e = e0; e < e1; ++e) {
    uint ids[3] = {edge_v[2 * e], edge_v[2 * e + 1], nv + e};
    float3 p[3];
    float4 c[3];
    for (int k = 0; k < 3; ++k) {
      uint v = ids[k];
      p[k] = (float3)(lim[3 * v], lim[3 * v + 1], lim[3 * v + 2]);
      float4 q = (float4)(p[k], 1.0f);
      c[k] = (float4)(dot(m.s0123, q), dot(m.s4567, q), dot(m.s89ab, q), dot(m.scdef, q));
    }
    int out = 0;
#define VM_ALL_OUT(expr) ((expr(c[0])) && (expr(c[1])) && (expr(c[2])))
#define VM_L(q) ((q).x < -(q).w)
#define VM_R(q) ((q).x > (q).w)
#define VM_B(q) ((q).y < -(q).w)
#define VM_T(q) ((q).y > (q).w)
#define VM_N(q) ((q).z < -(q).w)
#define VM_F(q) ((q).z > (q).w)
    out = VM_ALL_OUT(VM_L) || VM_ALL_OUT(VM_R) || VM_ALL_OUT(VM_B) || VM_ALL_OUT(VM_T) ||
          VM_ALL_OUT(VM_N) || VM_ALL_OUT(VM_F);
#undef VM_ALL_OUT
#undef VM_L
#undef VM_R
#undef VM_B
#undef VM_T
#undef VM_N
#undef VM_F
    if (out) continue;
    float w = fmax(fmin(c[0].w, fmin(c[1].w, c[2].w)), w_floor);
    float d = length(0.5f * (p[0] + p[1]) - p[2]) * f_px / w;
    best = fmax(best, d);
  }
  if (best > 0) atomic_max(dmax, as_uint(best));
}
