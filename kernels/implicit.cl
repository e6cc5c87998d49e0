/* Implicit surfaces (issue 19; host: core/surfaces/implicit.cpp, docs/IMPLICIT.md): MPR's region
 * queue. Each round evaluates every region's tape in interval arithmetic over its box, classifies
 * it (full, empty, or ambiguous), shortens the tape of an ambiguous region to the clauses that can
 * still choose its value (decided min/max become copies of their winner), and splits it into
 * children that inherit the shortened tape. Slots live in a scratch buffer sized from the region
 * count and the tape's slot count: no fixed limit. The per-region kernels take regions
 * first .. first + global size (the host runs a large round in chunks, reusing the scratch).
 *
 * Rounding: float, with every bound of an inexact operation moved outward by VM_IULPS ulps, which
 * covers OpenCL 1.2's full-profile error bounds (+ - * exact-rounded, / 2.5 ulp, sqrt 3 ulp, exp
 * log 3 ulp, sin cos tan 4 ulp, asin acos atan 4 ulp, pow 16 ulp: pow gets 20). */

#define VM_IULPS 5.0f
#define VM_IINF INFINITY

/* Outward by k ulps: |v| * k * 2^-23 is at least k ulps of v, and the subtraction's rounding
 * gives back at most half of one; the absolute 1e-30f keeps zero bounds moving too. */
inline float vm_down(float v, float k) { return v - (fabs(v) * (k * 1.1920929e-7f) + 1e-30f); }
inline float vm_up(float v, float k) { return v + (fabs(v) * (k * 1.1920929e-7f) + 1e-30f); }

inline float2 vm_widen(float lo, float hi, float k) {
  if (isnan(lo) || isnan(hi)) return (float2)(-VM_IINF, VM_IINF);
  return (float2)(vm_down(lo, k), vm_up(hi, k));
}
inline float2 vm_hull4(float a, float b, float c, float d, float k) {
  if (isnan(a) || isnan(b) || isnan(c) || isnan(d)) return (float2)(-VM_IINF, VM_IINF);
  return vm_widen(fmin(fmin(a, b), fmin(c, d)), fmax(fmax(a, b), fmax(c, d)), k);
}

/* sin over [lo, hi] (+ shift for cos): the endpoints, and +-1 where a peak or trough is inside. */
inline float2 vm_isin(float lo, float hi, float shift) {
  const float two_pi = 6.2831853f;
  if (!(hi - lo < 6.0f)) return (float2)(-1.0f, 1.0f);
  lo += shift;
  hi += shift;
  float a = sin(lo), b = sin(hi);
  float2 r = vm_widen(fmin(a, b), fmax(a, b), VM_IULPS);
  const float m = 1e-5f * fmax(1.0f, fmax(fabs(lo), fabs(hi)));
  if (ceil((lo - m - 1.5707964f) / two_pi) <= floor((hi + m - 1.5707964f) / two_pi)) r.y = 1.0f;
  if (ceil((lo - m + 1.5707964f) / two_pi) <= floor((hi + m + 1.5707964f) / two_pi)) r.x = -1.0f;
  r.x = fmax(r.x, -1.0f);
  r.y = fmin(r.y, 1.0f);
  return r;
}

inline float vm_ipow_int(float a, float n) { return pown(a, (int)n); }

/* One clause in intervals; *choice: 1 only a can win a min/max, 2 only b, 0 both (or n/a). */
inline float2 vm_iop(uint op, float2 a, float2 b, uchar* choice) {
  const float k = VM_IULPS;
  switch (op) {
    case VM_IOP_ADD: return vm_widen(a.x + b.x, a.y + b.y, k);
    case VM_IOP_SUB: return vm_widen(a.x - b.y, a.y - b.x, k);
    case VM_IOP_MUL: return vm_hull4(a.x * b.x, a.x * b.y, a.y * b.x, a.y * b.y, k);
    case VM_IOP_DIV:
      if (b.x <= 0.0f && b.y >= 0.0f) return (float2)(-VM_IINF, VM_IINF);
      return vm_hull4(a.x / b.x, a.x / b.y, a.y / b.x, a.y / b.y, k);
    case VM_IOP_MIN:
      if (a.y <= b.x) *choice = 1;
      else if (b.y <= a.x) *choice = 2;
      return (float2)(fmin(a.x, b.x), fmin(a.y, b.y));
    case VM_IOP_MAX:
      if (a.x >= b.y) *choice = 1;
      else if (b.x >= a.y) *choice = 2;
      return (float2)(fmax(a.x, b.x), fmax(a.y, b.y));
    case VM_IOP_POW: {
      if (b.x == b.y && b.x == floor(b.x) && fabs(b.x) < 1e6f) {
        const float n = b.x;
        if (n == 0.0f) return (float2)(1.0f, 1.0f);
        const float p = vm_ipow_int(a.x, n), q = vm_ipow_int(a.y, n);
        if (a.x <= 0.0f && a.y >= 0.0f && n < 0.0f) return (float2)(-VM_IINF, VM_IINF);
        if (fmod(n, 2.0f) == 0.0f && a.x < 0.0f && a.y > 0.0f)
          return (float2)(0.0f, vm_up(fmax(p, q), 20.0f));
        return vm_hull4(p, q, p, q, 20.0f);
      }
      const float alo = fmax(a.x, 0.0f), ahi = fmax(a.y, 0.0f);
      float2 r = vm_hull4(pow(alo, b.x), pow(alo, b.y), pow(ahi, b.x), pow(ahi, b.y), 20.0f);
      if ((alo <= 1.0f && ahi >= 1.0f) || (b.x <= 0.0f && b.y >= 0.0f))
        r = (float2)(fmin(r.x, 1.0f), fmax(r.y, 1.0f));
      return r;
    }
    case VM_IOP_NEG: return (float2)(-a.y, -a.x);
    case VM_IOP_SQUARE:
      if (a.x >= 0.0f) return (float2)(fmax(0.0f, vm_down(a.x * a.x, k)), vm_up(a.y * a.y, k));
      if (a.y <= 0.0f) return (float2)(fmax(0.0f, vm_down(a.y * a.y, k)), vm_up(a.x * a.x, k));
      return (float2)(0.0f, vm_up(fmax(a.x * a.x, a.y * a.y), k));
    case VM_IOP_SQRT: {
      float2 r = vm_widen(sqrt(fmax(a.x, 0.0f)), sqrt(fmax(a.y, 0.0f)), k);
      r.x = fmax(r.x, 0.0f);
      return r;
    }
    case VM_IOP_ABS:
      if (a.x >= 0.0f) return a;
      if (a.y <= 0.0f) return (float2)(-a.y, -a.x);
      return (float2)(0.0f, fmax(-a.x, a.y));
    case VM_IOP_EXP: {
      float2 r = vm_widen(exp(a.x), exp(a.y), k);
      r.x = fmax(r.x, 0.0f);
      return r;
    }
    case VM_IOP_LOG: return vm_widen(log(fmax(a.x, 0.0f)), log(fmax(a.y, 0.0f)), k);
    case VM_IOP_SIN: return vm_isin(a.x, a.y, 0.0f);
    case VM_IOP_COS: return vm_isin(a.x, a.y, 1.5707964f);
    case VM_IOP_TAN: {
      if (!(a.y - a.x < 3.0f)) return (float2)(-VM_IINF, VM_IINF);
      const float m = 1e-5f * fmax(1.0f, fmax(fabs(a.x), fabs(a.y)));
      if (ceil((a.x - m - 1.5707964f) / 3.1415927f) <= floor((a.y + m - 1.5707964f) / 3.1415927f))
        return (float2)(-VM_IINF, VM_IINF);
      return vm_widen(tan(a.x), tan(a.y), k);
    }
    case VM_IOP_ASIN:
      return vm_widen(asin(clamp(a.x, -1.0f, 1.0f)), asin(clamp(a.y, -1.0f, 1.0f)), k);
    case VM_IOP_ACOS:
      return vm_widen(acos(clamp(a.y, -1.0f, 1.0f)), acos(clamp(a.x, -1.0f, 1.0f)), k);
    case VM_IOP_ATAN: return vm_widen(atan(a.x), atan(a.y), k);
    case VM_IOP_COPY: return a;
    default: return (float2)(-VM_IINF, VM_IINF);
  }
}

inline bool vm_iop_binary(uint op) { return op >= VM_IOP_ADD && op <= VM_IOP_POW; }
inline bool vm_iop_leaf(uint op) { return op <= VM_IOP_Z; }

/* Region r's slice of the round's choice bytes: the regions are the children of the last
 * round's ambiguous regions, `per` a parent (1 in the first round), child c of a parent at
 * r = per * (parent's rank) + c, sharing the parent's tape at tape_off; so the slices
 * per * tape_off + c * tape_len tile per * (the pool's length) bytes. */
inline size_t vm_choice_off(VmIRegion R, uint r, uint per) {
  return (size_t)per * R.tape_off + (size_t)(r % per) * R.tape_len;
}

/* The view depth's least and greatest values over R's box grown by g on every side (depth is
 * affine: its extremes are at corners). */
inline float2 vm_depth_range(VmIView v, VmIRegion R, float g) {
  float a = v.depth[3], b = v.depth[3];
  for (int k = 0; k < 3; ++k) {
    const float p = v.depth[k] * (R.lo[k] - g), q = v.depth[k] * (R.lo[k] + R.size + g);
    a += fmin(p, q);
    b += fmax(p, q);
  }
  return (float2)(a, b);
}

/* The largest leaf side at depth d. */
inline float vm_leaf_side(VmIView v, float d) { return v.c0 + v.c1 * fmax(d, v.near_d); }

/* Occlusion (docs/IMPLICIT.md "Hidden regions"). VM_IOCCLUDE_MUTATION 1 (tests only, through
 * VISMAP_CL_OPTIONS) draws a full box at its least depth over the whole box instead of its entry
 * depth at each texel (a ray meets an oblique box deeper than its nearest corner): an unsound
 * cull that tests/test_implicit_occlusion.cpp must catch. */
#ifndef VM_IOCCLUDE_MUTATION
#define VM_IOCCLUDE_MUTATION 0
#endif

/* Texel coordinates of the object-space point p (x, y) and its view depth (z). */
inline float3 vm_texel(VmIOcclusion o, float3 p) {
  const float x = o.proj[0] * p.x + o.proj[1] * p.y + o.proj[2] * p.z + o.proj[3];
  const float y = o.proj[4] * p.x + o.proj[5] * p.y + o.proj[6] * p.z + o.proj[7];
  const float w = o.proj[8] * p.x + o.proj[9] * p.y + o.proj[10] * p.z + o.proj[11];
  return (float3)(x / w, y / w, w);
}

/* The depth image's texels that R's box grown by g can touch: (x0, y0, x1, y1), inclusive, one
 * texel wider on every side than the corners' projections (their rounding); x0 > x1 when none. */
inline int4 vm_footprint(VmIOcclusion o, VmIRegion R, float g) {
  float x0 = INFINITY, y0 = INFINITY, x1 = -INFINITY, y1 = -INFINITY;
  for (int c = 0; c < 8; ++c) {
    const float3 p = (float3)(R.lo[0] - g + ((c & 1) ? R.size + 2.0f * g : 0.0f),
                              R.lo[1] - g + ((c & 2) ? R.size + 2.0f * g : 0.0f),
                              R.lo[2] - g + ((c & 4) ? R.size + 2.0f * g : 0.0f));
    const float3 t = vm_texel(o, p);
    x0 = fmin(x0, t.x), x1 = fmax(x1, t.x), y0 = fmin(y0, t.y), y1 = fmax(y1, t.y);
  }
  const float W = (float)o.width, H = (float)o.height;
  if (!(x0 < W + 1.0f && y0 < H + 1.0f && x1 > -1.0f && y1 > -1.0f)) return (int4)(1, 1, 0, 0);
  return (int4)((int)floor(fmax(x0, -1.0f)) - 1, (int)floor(fmax(y0, -1.0f)) - 1,
                (int)floor(fmin(x1, W + 1.0f)) + 1, (int)floor(fmin(y1, H + 1.0f)) + 1);
}

/* The depth image is a pyramid: level 0 the texels, level k + 1 the greatest of each 2 x 2 of
 * level k (those inside it), so a texel of level k bounds the 2^k x 2^k texels under it. Level
 * k's width, and its offset in the buffer. */
inline uint vm_mip_w(uint w, int k) { return (w + (1u << k) - 1) >> k; }
inline size_t vm_mip_off(VmIOcclusion o, int k) {
  size_t off = 0;
  for (int j = 0; j < k; ++j) off += (size_t)vm_mip_w(o.width, j) * vm_mip_w(o.height, j);
  return off;
}

/* Is every ray through a point of R's box grown by g, inside the viewport, through a full box at
 * a depth below the grown box's least depth? The footprint's texels (those outside the viewport
 * show nothing) all hold a depth below it, read at the pyramid level where the footprint spans at
 * most 8 x 8 (a level's texel may lag behind level 0 within a round: it is then larger, never
 * smaller, than the texels under it). */
inline bool vm_hidden(VmIOcclusion o, global const uint* image, VmIView v, VmIRegion R, float g) {
  const float2 dr = vm_depth_range(v, R, g);
  if (!(dr.x > v.near_d)) return false;
  const float d = dr.x;
  const float below = d - 1e-5f * d; /* the float rounding of the depth range */
  const int4 f = vm_footprint(o, R, g);
  int x0 = max(f.x, 0), y0 = max(f.y, 0);
  int x1 = min(f.z, (int)o.width - 1), y1 = min(f.w, (int)o.height - 1);
  if (x0 > x1 || y0 > y1) return false;
  int k = 0;
  while ((x1 >> k) - (x0 >> k) > 7 || (y1 >> k) - (y0 >> k) > 7) ++k;
  x0 >>= k, x1 >>= k, y0 >>= k, y1 >>= k;
  global const uint* level = image + vm_mip_off(o, k);
  const uint w = vm_mip_w(o.width, k);
  for (int y = y0; y <= y1; ++y)
    for (int x = x0; x <= x1; ++x)
      if (!(as_float(level[(size_t)y * w + x]) < below)) return false;
  return true;
}

/* Level k + 1 of the depth image's pyramid from level k (one work-item per texel of k + 1). */
__kernel void implicit_depth_mip(global uint* image, VmIOcclusion o, int k) {
  const uint w = vm_mip_w(o.width, k + 1), h = vm_mip_w(o.height, k + 1);
  const uint i = get_global_id(0);
  if (i >= w * h) return;
  const uint x = i % w, y = i / w, sw = vm_mip_w(o.width, k), sh = vm_mip_w(o.height, k);
  global const uint* src = image + vm_mip_off(o, k);
  uint m = 0; /* positive floats' bits order as the floats */
  for (uint dy = 0; dy < 2; ++dy)
    for (uint dx = 0; dx < 2; ++dx)
      if (2 * x + dx < sw && 2 * y + dy < sh) m = max(m, src[(size_t)(2 * y + dy) * sw + 2 * x + dx]);
  image[vm_mip_off(o, k + 1) + (size_t)y * w + x] = m;
}

/* The view depth where the ray eye + t d enters the box [lo, hi] (slabs), or -1 if it misses. */
inline float vm_ray_entry(float3 O, float3 d, float3 lo, float3 hi) {
  float tin = 0.0f, tout = INFINITY;
  const float Oa[3] = {O.x, O.y, O.z}, da[3] = {d.x, d.y, d.z};
  const float la[3] = {lo.x, lo.y, lo.z}, ha[3] = {hi.x, hi.y, hi.z};
  for (int k = 0; k < 3; ++k) {
    if (fabs(da[k]) < 1e-30f) {
      if (Oa[k] < la[k] || Oa[k] > ha[k]) return -1.0f;
      continue;
    }
    const float t1 = (la[k] - Oa[k]) / da[k], t2 = (ha[k] - Oa[k]) / da[k];
    tin = fmax(tin, fmin(t1, t2));
    tout = fmin(tout, fmax(t1, t2));
  }
  return tin <= tout ? tin : -1.0f;
}

inline float vm_texel_entry(VmIOcclusion o, float3 O, float3 lo, float3 hi, float tx, float ty) {
  const float3 d = (float3)(o.dir[0] + tx * o.dir[4] + ty * o.dir[8],
                            o.dir[1] + tx * o.dir[5] + ty * o.dir[9],
                            o.dir[2] + tx * o.dir[6] + ty * o.dir[10]);
  return vm_ray_entry(O, d, lo, hi);
}

/* Per full region of the round beyond the near plane: into the depth image, at each texel its
 * box covers wholly (the rays through the texel's 4 corners all meet it, so every ray through the
 * texel does: the projection is convex), the greatest of the corners' entry depths. The entry
 * depth's reciprocal is the least of the entered faces' (each affine over the screen), so over
 * the texel its greatest is at a corner. The box is shrunk by more than the rays' float error,
 * and the depth moved up by more than its own: a covered texel is truly covered, and every ray
 * through it truly meets the box no deeper than the value written. The box drawn is the region
 * grown over its full siblings (the children of one parent, `per` of them: x first, then whole
 * rows in y, then whole layers in z), one solid box: a texel on the seam between two full
 * siblings is covered by their union though by neither alone. */
__kernel void implicit_occluders(global const VmIRegion* reg, uint n, uint first, uint m,
                                 uint per, global const float2* result, VmIOcclusion o,
                                 VmIView v, global uint* image) {
  const uint r = first + get_global_id(0);
  if (r >= n || r >= first + m || !(result[r].y < 0.0f)) return;
  const VmIRegion R = reg[r];
  const float2 dr = vm_depth_range(v, R, 0.0f);
  /* Beyond the near plane, and not itself behind what is drawn (it could lower no texel). */
  if (!(dr.x > v.near_d) || vm_hidden(o, image, v, R, 0.0f)) return;
  /* Its siblings (in this chunk: their results are known), i = ix + s (iy + s iz). */
  const uint s = per == 64 ? 4 : per == 8 ? 2 : 1, i = r % per;
  const uint ix = i % s, iy = (i / s) % s, iz = i / (s * s), base = r - i;
  uint e[3] = {1, 1, 1};
#define VM_SIB(a, b, c) (base + (a) + s * ((b) + s * (c)))
#define VM_FULL(a, b, c) \
  (VM_SIB(a, b, c) >= first && VM_SIB(a, b, c) < first + m && result[VM_SIB(a, b, c)].y < 0.0f)
  while (ix + e[0] < s && VM_FULL(ix + e[0], iy, iz)) ++e[0];
  for (bool grow = true; grow && iy + e[1] < s;) {
    for (uint x = ix; x < ix + e[0] && grow; ++x) grow = VM_FULL(x, iy + e[1], iz);
    if (grow) ++e[1];
  }
  for (bool grow = true; grow && iz + e[2] < s;) {
    for (uint y = iy; y < iy + e[1] && grow; ++y)
      for (uint x = ix; x < ix + e[0] && grow; ++x) grow = VM_FULL(x, y, iz + e[2]);
    if (grow) ++e[2];
  }
#undef VM_FULL
#undef VM_SIB
  const float3 O = (float3)(o.eye[0], o.eye[1], o.eye[2]);
  const float far = vm_depth_range(v, R, R.size * (float)(max(e[0], max(e[1], e[2])) - 1)).y;
  const float eps = 1e-3f * R.size +
                    2e-5f * (fmax(fabs(O.x), fmax(fabs(O.y), fabs(O.z))) + far * o.dmax +
                             fmax(fabs(R.lo[0]), fmax(fabs(R.lo[1]), fabs(R.lo[2]))) +
                             R.size * (float)(e[0] + e[1] + e[2]));
  if (!(2.0f * eps < R.size)) return;
  const float3 lo = (float3)(R.lo[0] + eps, R.lo[1] + eps, R.lo[2] + eps);
  const float3 hi = (float3)(R.lo[0] + R.size * (float)e[0] - eps,
                             R.lo[1] + R.size * (float)e[1] - eps,
                             R.lo[2] + R.size * (float)e[2] - eps);
  float fx0 = INFINITY, fy0 = INFINITY, fx1 = -INFINITY, fy1 = -INFINITY;
  for (int c = 0; c < 8; ++c) {
    const float3 p = (float3)((c & 1) ? hi.x : lo.x, (c & 2) ? hi.y : lo.y, (c & 4) ? hi.z : lo.z);
    const float3 t = vm_texel(o, p);
    fx0 = fmin(fx0, t.x), fx1 = fmax(fx1, t.x), fy0 = fmin(fy0, t.y), fy1 = fmax(fy1, t.y);
  }
  const float W = (float)o.width, H = (float)o.height;
  const int x0 = max((int)floor(fmax(fx0, -1.0f)), 0), y0 = max((int)floor(fmax(fy0, -1.0f)), 0);
  const int x1 = min((int)floor(fmin(fx1, W + 1.0f)), (int)o.width - 1);
  const int y1 = min((int)floor(fmin(fy1, H + 1.0f)), (int)o.height - 1);
  for (int y = y0; y <= y1; ++y) {
    float a = vm_texel_entry(o, O, lo, hi, (float)x0, (float)y);
    float b = vm_texel_entry(o, O, lo, hi, (float)x0, (float)(y + 1));
    for (int x = x0; x <= x1; ++x) {
      const float c = vm_texel_entry(o, O, lo, hi, (float)(x + 1), (float)y);
      const float d = vm_texel_entry(o, O, lo, hi, (float)(x + 1), (float)(y + 1));
      if (a >= 0.0f && b >= 0.0f && c >= 0.0f && d >= 0.0f) {
#if VM_IOCCLUDE_MUTATION == 1
        const float t = dr.x;
#else
        const float t = fmax(fmax(a, b), fmax(c, d));
#endif
        atomic_min(&image[(size_t)y * o.width + x], as_uint(t + 1e-5f * t));
      }
      a = c;
      b = d;
    }
  }
}

/* Per region: its tape over its box in intervals (the choices of its min/max clauses in its
 * slice of choices) and the result; counts full and empty regions in totals. */
#define VM_IZERO (-1e-30f) /* see vm_ambiguous */
__kernel void implicit_intervals(global const VmIRegion* reg, uint n, uint first,
                               global const VmIClause* pool,
                               global float2* scratch, uint slots, uint root_slot,
                               global uchar* choices, uint per, global float2* result,
                               global uint* totals, global const float4* planes, uint nplanes,
                               VmIView view, VmIOcclusion occ, global const uint* image,
                               uint occlude) {
  const uint r = first + get_global_id(0);
  if (r >= n) return;
  const VmIRegion R = reg[r];
  /* Culling (3D frames): a box wholly on the outer side of one of the view's planes (n.p + w <
   * 0 over the box, with a margin of a thousandth of the box) by more than twice the largest
   * leaf side at its farthest depth, H (and view.margin), cannot be seen: a triangle of a leaf
   * inside it lies within H of it on every axis (docs/IMPLICIT.md "3D"). It leaves the queue as
   * if empty and is counted apart. */
  const float H = nplanes ? view.margin + 2.0f * vm_leaf_side(view, vm_depth_range(view, R, 0.0f).y)
                          : 0.0f;
  for (uint k = 0; k < nplanes; ++k) {
    const float4 P = planes[k];
    const float hi = P.x * (R.lo[0] + (P.x > 0.0f ? R.size : 0.0f)) +
                     P.y * (R.lo[1] + (P.y > 0.0f ? R.size : 0.0f)) +
                     P.z * (R.lo[2] + (P.z > 0.0f ? R.size : 0.0f)) + P.w;
    const float margin = (1e-3f * R.size + H) * (fabs(P.x) + fabs(P.y) + fabs(P.z)) +
                         1e-6f * (fabs(P.x * R.lo[0]) + fabs(P.y * R.lo[1]) + fabs(P.z * R.lo[2]) + fabs(P.w));
    if (hi < -margin) {
      result[r] = (float2)(VM_IINF, VM_IINF);
      atomic_inc(&totals[VM_ITOTAL_CULLED]);
      return;
    }
  }
  /* Hidden (3D frames whose rays start outside the solid): the box grown by the leaf side at
   * its farthest depth, where every triangle of a leaf inside it lies, is behind full boxes
   * nearer the eye wherever it projects. Every ray through the grown box has entered the solid
   * before it, so has crossed the surface nearer than any of those triangles: leaving them out
   * changes nothing seen. */
  if (occlude &&
      vm_hidden(occ, image, view, R,
                1.001f * vm_leaf_side(view, vm_depth_range(view, R, 0.0f).y) + 1e-3f * R.size)) {
    result[r] = (float2)(VM_IINF, VM_IINF);
    atomic_inc(&totals[VM_ITOTAL_OCCLUDED]);
    return;
  }
  global float2* s = scratch + (size_t)(r - first) * slots;
  global uchar* ch = choices + vm_choice_off(R, r, per);
  /* The box grown by 1/1000 of its side each way: points computed elsewhere for its corners
   * (in doubles, or by other roundings of lo) still lie inside the box the tape was shortened
   * over. */
  const float g = R.size * 1e-3f;
  const float2 X = (float2)(vm_down(R.lo[0] - g, 1.0f), vm_up(R.lo[0] + R.size + g, 1.0f));
  const float2 Y = (float2)(vm_down(R.lo[1] - g, 1.0f), vm_up(R.lo[1] + R.size + g, 1.0f));
  const float2 Z = (float2)(vm_down(R.lo[2] - g, 1.0f), vm_up(R.lo[2] + R.size + g, 1.0f));
  for (uint k = 0; k < R.tape_len; ++k) {
    const VmIClause c = pool[R.tape_off + k];
    uchar choice = 0;
    float2 v;
    if (c.op == VM_IOP_CONST) v = (float2)(as_float(c.a), as_float(c.a));
    else if (c.op == VM_IOP_X) v = X;
    else if (c.op == VM_IOP_Y) v = Y;
    else if (c.op == VM_IOP_Z) v = Z;
    else v = vm_iop(c.op, s[c.a], vm_iop_binary(c.op) ? s[c.b] : (float2)(0.0f, 0.0f), &choice);
    if (isnan(v.x) || isnan(v.y)) v = (float2)(-VM_IINF, VM_IINF);
    ch[k] = choice;
    s[c.out] = v;
  }
  const float2 f = s[root_slot];
  result[r] = f;
  if (f.y < 0.0f) atomic_inc(&totals[VM_ITOTAL_FULL]);
  else if (f.x >= VM_IZERO) atomic_inc(&totals[VM_ITOTAL_EMPTY]);
}

/* The backward walk of tape shortening (MPR): a clause is kept when its slot is live below it; a
 * decided min/max becomes a copy of its winner (dropped when winner and out share a slot). With
 * out == 0 it only counts. */
inline uint vm_shorten(global const VmIClause* pool, VmIRegion R, global const uchar* ch,
                       global uchar* live, uint slots, uint root_slot, global VmIClause* out,
                       uint count) {
  for (uint i = 0; i < slots; ++i) live[i] = 0;
  live[root_slot] = 1;
  uint kept = 0;
  for (uint k = R.tape_len; k-- > 0;) {
    VmIClause c = pool[R.tape_off + k];
    if (!live[c.out]) continue;
    live[c.out] = 0;
    const uchar choice = ch[k];
    if ((c.op == VM_IOP_MIN || c.op == VM_IOP_MAX) && choice) {
      const uint src = choice == 1 ? c.a : c.b;
      live[src] = 1;
      if (src == c.out) continue;
      c.op = VM_IOP_COPY;
      c.a = src;
      c.b = 0;
    } else if (!vm_iop_leaf(c.op)) {
      live[c.a] = 1;
      if (vm_iop_binary(c.op)) live[c.b] = 1;
    }
    if (out) out[count - 1 - kept] = c;
    ++kept;
  }
  return kept;
}

/* Empty: f >= 0 over the box, so no point of the solid f < 0. An exact 0 rounded outward is a
 * denormal below 0: VM_IZERO (-1e-30) still counts as 0, so a sheet where f touches 0 (the
 * architecture model's floor) leaves the queue instead of splitting to the last level. */
inline bool vm_ambiguous(float2 f) { return !(f.y < 0.0f) && !(f.x >= VM_IZERO); }

/* An ambiguous region either splits (its children go to the next round) or becomes a leaf:
 * in the last round, or once its side is at most the leaf side at its least depth, taken over
 * the region grown by its side (a triangle of the leaf lies within that, docs/IMPLICIT.md "3D").
 * Per region: counts[r] and amb[r] (the shortened tape's length and 1) when it splits, leaf_counts[r]
 * and leaf[r] when it is a leaf, else 0. A last-round leaf larger than its side is counted in
 * totals (the host refuses the dice). */
__kernel void implicit_shorten_count(global const VmIRegion* reg, uint n, uint first,
                                   global const VmIClause* pool,
                                   global const uchar* choices, uint per_in,
                                   global const float2* result, global uchar* live, uint slots,
                                   uint root_slot, global uint* counts, global uint* amb,
                                   global uint* leaf_counts, global uint* leaf, VmIView view,
                                   uint last, global uint* totals) {
  const uint r = first + get_global_id(0);
  if (r >= n) return;
  counts[r] = amb[r] = leaf_counts[r] = leaf[r] = 0;
  if (!vm_ambiguous(result[r])) return;
  const VmIRegion R = reg[r];
  const uint len = vm_shorten(pool, R, choices + vm_choice_off(R, r, per_in),
                              live + (size_t)(r - first) * slots, slots, root_slot, 0, 0);
  const bool sized = view.c0 + view.c1 > 0.0f;
  /* The float rounding of the depth is some ulps of depths of tens of units: 1e-5 covers it. */
  const bool fine =
      sized && R.size <= vm_leaf_side(view, vm_depth_range(view, R, R.size).x) * (1.0f - 1e-5f);
  if (last || fine) {
    leaf_counts[r] = len;
    leaf[r] = 1;
    if (sized && !fine) atomic_inc(&totals[VM_ITOTAL_COARSE]);
  } else {
    counts[r] = len;
    amb[r] = 1;
  }
}

/* Writes the shortened tapes at their offsets: a splitting region's in the next pool with its
 * split^dims children (all pointing at it), a leaf's in the leaf pool with the region itself. */
__kernel void implicit_shorten_fill(global const VmIRegion* reg, uint n, uint first,
                                  global const VmIClause* pool,
                                  global const uchar* choices, uint per_in,
                                  global const float2* result, global uchar* live, uint slots,
                                  uint root_slot, global const uint* counts,
                                  global const uint* offsets, global const uint* amb_off,
                                  global VmIClause* next_pool, global VmIRegion* next, uint split,
                                  uint dims, global const uint* leaf_counts,
                                  global const uint* leaf_offsets, global const uint* leaf_idx,
                                  global VmIClause* leaf_pool, global VmIRegion* leaves) {
  const uint r = first + get_global_id(0);
  if (r >= n) return;
  const uint len = counts[r], leaf_len = leaf_counts[r];
  if (len == 0 && leaf_len == 0) return;
  VmIRegion R = reg[r];
  global const uchar* ch = choices + vm_choice_off(R, r, per_in);
  global uchar* lv = live + (size_t)(r - first) * slots;
  if (leaf_len) {
    vm_shorten(pool, R, ch, lv, slots, root_slot, leaf_pool + leaf_offsets[r], leaf_len);
    R.tape_off = leaf_offsets[r];
    R.tape_len = leaf_len;
    leaves[leaf_idx[r]] = R;
    return;
  }
  vm_shorten(pool, R, ch, lv, slots, root_slot, next_pool + offsets[r], len);
  VmIRegion C = R;
  C.tape_off = offsets[r];
  C.tape_len = len;
  const uint per = dims == 3 ? split * split * split : split * split;
  const uint base = amb_off[r] * per;
  C.size = R.size / (float)split;
  for (uint i = 0; i < per; ++i) {
    const uint ix = i % split, iy = (i / split) % split, iz = i / (split * split);
    C.lo[0] = R.lo[0] + C.size * (float)ix;
    C.lo[1] = R.lo[1] + C.size * (float)iy;
    C.lo[2] = dims == 3 ? R.lo[2] + C.size * (float)iz : R.lo[2];
    next[base + i] = C;
  }
}

/* Plain evaluation of region r's tape at m points (xyz in pts[r * m + j]), into val. */
__kernel void implicit_points(global const VmIRegion* reg, uint n, global const VmIClause* pool,
                            global float* scratch, uint slots, uint root_slot,
                            global const float4* pts, uint m, global float* val) {
  const uint g = get_global_id(0);
  if (g >= n * m) return;
  const uint r = g / m;
  const VmIRegion R = reg[r];
  const float4 p = pts[g];
  global float* s = scratch + (size_t)g * slots;
  for (uint k = 0; k < R.tape_len; ++k) {
    const VmIClause c = pool[R.tape_off + k];
    const float a = vm_iop_leaf(c.op) ? 0.0f : s[c.a];
    const float b = vm_iop_binary(c.op) ? s[c.b] : 0.0f;
    float v;
    switch (c.op) {
      case VM_IOP_CONST: v = as_float(c.a); break;
      case VM_IOP_X: v = p.x; break;
      case VM_IOP_Y: v = p.y; break;
      case VM_IOP_Z: v = p.z; break;
      case VM_IOP_ADD: v = a + b; break;
      case VM_IOP_SUB: v = a - b; break;
      case VM_IOP_MUL: v = a * b; break;
      case VM_IOP_DIV: v = a / b; break;
      case VM_IOP_MIN: v = fmin(a, b); break;
      case VM_IOP_MAX: v = fmax(a, b); break;
      case VM_IOP_POW:
        v = b == floor(b) && fabs(b) < 1e6f ? vm_ipow_int(a, b) : pow(fmax(a, 0.0f), b);
        break;
      case VM_IOP_NEG: v = -a; break;
      case VM_IOP_SQUARE: v = a * a; break;
      case VM_IOP_SQRT: v = sqrt(fmax(a, 0.0f)); break;
      case VM_IOP_ABS: v = fabs(a); break;
      case VM_IOP_EXP: v = exp(a); break;
      case VM_IOP_LOG: v = log(fmax(a, 0.0f)); break;
      case VM_IOP_SIN: v = sin(a); break;
      case VM_IOP_COS: v = cos(a); break;
      case VM_IOP_TAN: v = tan(a); break;
      case VM_IOP_ASIN: v = asin(clamp(a, -1.0f, 1.0f)); break;
      case VM_IOP_ACOS: v = acos(clamp(a, -1.0f, 1.0f)); break;
      case VM_IOP_ATAN: v = atan(a); break;
      default: v = a; break; /* COPY */
    }
    s[c.out] = v;
  }
  val[g] = s[root_slot];
}
