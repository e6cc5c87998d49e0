/* Stage tessellate, bicubic Bezier patches (core/surfaces/patches.cpp, docs/SURFACES.md
 * "Bezier patches"). Two passes per frame, one work-item per patch:
 *   patch_rates  culls the patch against the view (its 16 control points outside one clip plane)
 *                and bounds it: the interior grid's rates, and each side's demand (segments);
 *                the host gives each side the largest demand of the patches sharing it (by its
 *                four control points, bit for bit) and sums the counts.
 *   patch_dice   writes the patch's vertices (each side's n + 1 points on its curve, evaluated
 *                from its control points in a canonical direction, so that both patches on a
 *                side write the same bits; the interior grid on the surface) and triangles: the
 *                grid's cells and, along each side, a strip zipped between the side's points and
 *                the grid's first row.
 * Error bound (pixels): a world displacement d at depth w moves its image by at most
 * |d| f_px / w (f_px: pixels per unit at w = 1, times sqrt(1 + (r / f)^2) for the image's half
 * diagonal r: the projection's largest singular value there; the host folds it in), with w
 * clamped to the near plane (first order in d / w); orthographic: |d| f_px. Linear
 * interpolation over a triangle spanning h_u, h_v of a patch's parameters misses the surface by
 * at most (h_u^2 Muu + 2 h_u h_v Muv + h_v^2 Mvv) / 8, with Muu = 6 max |P(i,j) - 2 P(i,j+1) +
 * P(i,j+2)|, Mvv likewise along v, Muv = 9 max of the mixed differences; a curve of n segments
 * misses by at most 0.75 max |second difference| / n^2. */

#define VM_MAX_PATCH_RATE 128u

typedef struct {
  float4 m0, m1, m2, m3; /* view-projection rows */
  float f_px, r_px, w_floor, tol;
  uint persp;
} VmPatchView;

static float3 vm_cp(__global const float* ctrl, uint p, int i, int j) {
  __global const float* q = ctrl + 48 * p + 3 * (4 * i + j);
  return (float3)(q[0], q[1], q[2]);
}

static float4 vm_clip(const VmPatchView* v, float3 p) {
  float4 q = (float4)(p, 1.0f);
  return (float4)(dot(v->m0, q), dot(v->m1, q), dot(v->m2, q), dot(v->m3, q));
}

/* Pixels per world unit for points whose smallest depth is w_min. */
static float vm_scale(const VmPatchView* v, float w_min) {
  if (!v->persp) return v->f_px;
  return v->f_px / fmax(w_min, v->w_floor);
}

/* Lexicographic order of two points (x, then y, then z). */
static int vm_less(float3 a, float3 b) {
  if (a.x != b.x) return a.x < b.x;
  if (a.y != b.y) return a.y < b.y;
  return a.z < b.z;
}

/* Edge e of patch p: 0 v = 0 (row i = 0, along u), 1 v = 1 (row 3), 2 u = 0 (column 0, along v),
 * 3 u = 1 (column 3). k = 0..3 in the patch's direction. */
static float3 vm_edge_cp(__global const float* ctrl, uint p, int e, int k) {
  if (e == 0) return vm_cp(ctrl, p, 0, k);
  if (e == 1) return vm_cp(ctrl, p, 3, k);
  if (e == 2) return vm_cp(ctrl, p, k, 0);
  return vm_cp(ctrl, p, k, 3);
}

/* Whether edge e runs against its canonical direction (the one from the lexicographically smaller
 * end; for equal ends, the smaller inner point). Both patches on an edge decide alike. */
static int vm_edge_reversed(__global const float* ctrl, uint p, int e) {
  float3 a = vm_edge_cp(ctrl, p, e, 0), d = vm_edge_cp(ctrl, p, e, 3);
  if (vm_less(d, a)) return 1;
  if (vm_less(a, d)) return 0;
  return vm_less(vm_edge_cp(ctrl, p, e, 2), vm_edge_cp(ctrl, p, e, 1));
}

/* The edge's four control points in canonical order. */
static void vm_edge_canonical(__global const float* ctrl, uint p, int e, float3 c[4]) {
  int r = vm_edge_reversed(ctrl, p, e);
  for (int k = 0; k < 4; ++k) c[k] = vm_edge_cp(ctrl, p, e, r ? 3 - k : k);
}

static float3 vm_bezier3(float3 a, float3 b, float3 c, float3 d, float t) {
  float s = 1.0f - t;
  float3 ab = s * a + t * b, bc = s * b + t * c, cd = s * c + t * d;
  float3 abc = s * ab + t * bc, bcd = s * bc + t * cd;
  return s * abc + t * bcd;
}

static uint vm_rate(float err_at_one, float tol) {
  /* the smallest n >= 1 with err_at_one / n^2 <= tol, capped */
  float n = ceil(sqrt(fmax(err_at_one, 0.0f) / tol));
  if (!(n < (float)VM_MAX_PATCH_RATE)) return VM_MAX_PATCH_RATE;
  return max(1u, (uint)n);
}

/* The edge's rate, from its canonical control points alone. */
static uint vm_edge_rate(const VmPatchView* v, const float3 c[4]) {
  float w_min = INFINITY;
  for (int k = 0; k < 4; ++k) w_min = fmin(w_min, vm_clip(v, c[k]).w);
  float d2 = fmax(length(c[0] - 2.0f * c[1] + c[2]), length(c[1] - 2.0f * c[2] + c[3]));
  return vm_rate(0.75f * d2 * vm_scale(v, w_min), v->tol);
}

/* A patch's 16 control points, q[4 i + j]. */
static void vm_load(__global const float* ctrl, uint p, float3 q[16]) {
  for (int k = 0; k < 16; ++k) q[k] = vm_cp(ctrl, p, k / 4, k % 4);
}

/* Second differences along u (duu), along v (dvv) and mixed (duv), the largest norms; the
 * smallest clip w. */
static void vm_diffs(const VmPatchView* v, const float3 q[16], float* duu, float* dvv, float* duv,
                     float* w_min) {
  float a = 0, b = 0, c = 0, w = INFINITY;
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 2; ++j) {
      a = fmax(a, length(q[4 * i + j] - 2.0f * q[4 * i + j + 1] + q[4 * i + j + 2]));
      b = fmax(b, length(q[4 * j + i] - 2.0f * q[4 * (j + 1) + i] + q[4 * (j + 2) + i]));
    }
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      c = fmax(c, length(q[4 * (i + 1) + j + 1] - q[4 * (i + 1) + j] - q[4 * i + j + 1] + q[4 * i + j]));
  for (int k = 0; k < 16; ++k) w = fmin(w, vm_clip(v, q[k]).w);
  *duu = a;
  *dvv = b;
  *duv = c;
  *w_min = w;
}

/* The part of the patch within parameter distance d of side e (0 v = 0, 1 v = 1, 2 u = 0,
 * 3 u = 1), as a patch of its own (de Casteljau along the side's normal direction). */
static void vm_side_piece(const float3 q[16], int e, float d, float3 out[16]) {
  for (int l = 0; l < 4; ++l) {
    /* line l across the side: the four points from the side inward */
    float3 c[4];
    for (int k = 0; k < 4; ++k) {
      int i = e == 0 ? k : e == 1 ? 3 - k : l, j = e == 2 ? k : e == 3 ? 3 - k : l;
      c[k] = q[4 * i + j];
    }
    float s = 1.0f - d;
    float3 ab = s * c[0] + d * c[1], bc = s * c[1] + d * c[2], cd = s * c[2] + d * c[3];
    float3 abc = s * ab + d * bc, bcd = s * bc + d * cd;
    float3 r[4] = {c[0], ab, abc, s * abc + d * bcd};
    for (int k = 0; k < 4; ++k) {
      int i = e == 0 ? k : e == 1 ? 3 - k : l, j = e == 2 ? k : e == 3 ? 3 - k : l;
      out[4 * i + j] = r[k];
    }
  }
}

/* Pass 1, one work-item per patch. rates[12 p ...]: the demand of sides 0..3 (segments), the
 * interior rates nu, nv, culled, over (a rate hit its cap or a strip could not meet the
 * tolerance), 0 0 0 0. m: view-projection, row-major rows; prm: pixels per unit at w = 1 (the
 * largest singular value over the image), the image's half diagonal, w_floor (the near plane; 1
 * orthographic), tolerance in pixels.
 *
 * Interior: a uniform grid over [d_u, 1 - d_u] x [d_v, 1 - d_v], d = 1 / (n + 2), of cells no
 * larger than 1 / nu by 1 / nv, where (6 Duu hu^2 + 18 Duv hu hv + 6 Dvv hv^2) / 8 <= tol for the
 * whole patch's second differences. Side s: a strip of width d between the side and the grid,
 * zipped so that each of its triangles spans at most 1 / n_s along the side (vm_strip); its demand
 * is the smallest n_s for which the same bound over the strip, as a patch of its own, with
 * hu = 1 / n_s along and the whole width across, is within the tolerance. The host gives each
 * side the largest demand of the patches that share it, so both sides place the same points. */
__kernel void patch_rates(__global const float* ctrl, uint n, float16 m, float4 prm, uint persp,
                          __global uint* rates) {
  uint p = get_global_id(0);
  if (p >= n) return;
  VmPatchView v;
  v.m0 = m.s0123;
  v.m1 = m.s4567;
  v.m2 = m.s89ab;
  v.m3 = m.scdef;
  v.f_px = prm.x;
  v.r_px = prm.y;
  v.w_floor = prm.z;
  v.tol = prm.w;
  v.persp = persp;
  float3 q[16];
  vm_load(ctrl, p, q);
  int out_l = 1, out_r = 1, out_b = 1, out_t = 1, out_n = 1, out_f = 1;
  for (int k = 0; k < 16; ++k) {
    float4 c = vm_clip(&v, q[k]);
    out_l &= c.x < -c.w;
    out_r &= c.x > c.w;
    out_b &= c.y < -c.w;
    out_t &= c.y > c.w;
    out_n &= c.z < -c.w;
    out_f &= c.z > c.w;
  }
  __global uint* r = rates + 12 * p;
  for (int k = 0; k < 12; ++k) r[k] = 0;
  if (out_l || out_r || out_b || out_t || out_n || out_f) {
    r[6] = 1;
    return;
  }
  uint over = 0;
  float duu, dvv, duv, w_min;
  vm_diffs(&v, q, &duu, &dvv, &duv, &w_min);
  float s = vm_scale(&v, w_min);
  /* A / nu^2 + B / (nu nv) + C / nv^2 with B / (nu nv) <= (B / 2) (1 / nu^2 + 1 / nv^2): half of
   * tol to each direction. */
  float a = 0.75f * duu * s, b = 2.25f * duv * s, c = 0.75f * dvv * s;
  uint nu = vm_rate(2.0f * (a + 0.5f * b), v.tol), nv = vm_rate(2.0f * (c + 0.5f * b), v.tol);
  over |= nu >= VM_MAX_PATCH_RATE || nv >= VM_MAX_PATCH_RATE;
  for (int e = 0; e < 4; ++e) {
    float3 ce[4];
    vm_edge_canonical(ctrl, p, e, ce);
    uint demand = vm_edge_rate(&v, ce);  /* the side's own curve */
    float3 piece[16];
    vm_side_piece(q, e, 1.0f / (float)((e < 2 ? nv : nu) + 2), piece);
    float pu, pv, puv, pw;
    vm_diffs(&v, piece, &pu, &pv, &puv, &pw);
    float k = vm_scale(&v, pw);
    float A = 0.75f * (e < 2 ? pu : pv) * k, B = 2.25f * puv * k, C = 0.75f * (e < 2 ? pv : pu) * k;
    float room = v.tol - C;  /* what the across term leaves */
    uint strip = VM_MAX_PATCH_RATE;
    if (room > 0) {
      /* the largest h with A h^2 + B h <= room */
      float h = A > 0 ? (-B + sqrt(B * B + 4.0f * A * room)) / (2.0f * A) : B > 0 ? room / B : 1.0f;
      float ns = ceil(1.0f / h);
      strip = ns < (float)VM_MAX_PATCH_RATE ? max(1u, (uint)ns) : VM_MAX_PATCH_RATE;
    }
    demand = max(demand, strip);
    over |= demand >= VM_MAX_PATCH_RATE;
    r[e] = demand;
  }
  r[4] = nu;
  r[5] = nv;
  r[7] = over;
}

static float3 vm_surface(__global const float* ctrl, uint p, float u, float w) {
  float3 row[4];
  for (int i = 0; i < 4; ++i)
    row[i] = vm_bezier3(vm_cp(ctrl, p, i, 0), vm_cp(ctrl, p, i, 1), vm_cp(ctrl, p, i, 2),
                        vm_cp(ctrl, p, i, 3), u);
  return vm_bezier3(row[0], row[1], row[2], row[3], w);
}

static void vm_put(__global float* xyz, __global float* uv, uint at, float3 p, float u, float w) {
  xyz[3 * at] = p.x;
  xyz[3 * at + 1] = p.y;
  xyz[3 * at + 2] = p.z;
  uv[2 * at] = u;
  uv[2 * at + 1] = w;
}

/* A strip between an outer polyline of n segments (vertex o(k) = obase + (orev ? n - k : k),
 * parameter k / n) and an inner one of m segments (vertex ibase + k istride, parameter
 * lo + (hi - lo) k / m), both by increasing parameter; flip reverses the triangles' orientation.
 * The inner side advances while its next point is within the current outer segment, so that with
 * inner steps no longer than 1 / n every triangle spans at most 1 / n along the strip. */
static uint vm_strip(__global uint* tri, uint t, uint obase, uint n, int orev, uint ibase,
                     int istride, uint m, float lo, float hi, int flip) {
  uint a = 0, b = 0;
  while (a < n || b < m) {
    float next_inner = b == m ? INFINITY : lo + (hi - lo) * (float)(b + 1) / (float)m;
    int outer = a < n && !(next_inner <= (float)(a + 1) / (float)n);
    uint oa = obase + (orev ? n - a : a);
    uint ib = (uint)((int)ibase + (int)b * istride);
    uint x, y;
    if (outer) {
      x = obase + (orev ? n - (a + 1) : a + 1);
      y = ib;
      ++a;
    } else {
      x = (uint)((int)ibase + (int)(b + 1) * istride);
      y = ib;
      ++b;
    }
    tri[3 * t] = oa;
    tri[3 * t + 1] = flip ? y : x;
    tri[3 * t + 2] = flip ? x : y;
    ++t;
  }
  return t;
}

/* Pass 2. plan[12 p ...] (the host's): segments of sides 0..3, Nu, Nv (grid columns and rows
 * counting the sides), culled, 0, the strip widths of sides 0..3 (float bits). voff, toff: the
 * patch's first vertex and triangle (exclusive prefix sums of its counts). Triangles
 * are counter-clockwise in (u, v): for a patch whose normal dPdu x dPdv points outward, they face
 * out. face[t]: the patch. */
__kernel void patch_dice(__global const float* ctrl, uint n, __global const uint* plan,
                         __global const uint* voff, __global const uint* toff,
                         __global float* xyz, __global float* uv, __global uint* tri,
                         __global uint* face) {
  uint p = get_global_id(0);
  if (p >= n) return;
  __global const uint* r = plan + 12 * p;
  if (r[6]) return;
  uint nu = r[4], nv = r[5];
  /* the interior grid's extent: [u_lo, u_hi] x [v_lo, v_hi], inside the four strips */
  float v_lo = as_float(r[8]), v_hi = 1.0f - as_float(r[9]);
  float u_lo = as_float(r[10]), u_hi = 1.0f - as_float(r[11]);
  uint v0 = voff[p], t0 = toff[p];
  /* edges: n_e + 1 points each, canonical order */
  uint ebase[4];
  int erev[4];
  uint at = v0;
  for (int e = 0; e < 4; ++e) {
    uint ne = r[e];
    float3 c[4];
    vm_edge_canonical(ctrl, p, e, c);
    erev[e] = vm_edge_reversed(ctrl, p, e);
    ebase[e] = at;
    /* a side collapsed to a point is that point exactly (de Casteljau of equal points rounds) */
    int point = all(c[0] == c[1]) && all(c[0] == c[2]) && all(c[0] == c[3]);
    for (uint k = 0; k <= ne; ++k) {
      float t = k == ne ? 1.0f : (float)k / (float)ne;
      float3 q = k == 0 || point ? c[0] : k == ne ? c[3] : vm_bezier3(c[0], c[1], c[2], c[3], t);
      float s = erev[e] ? 1.0f - t : t;  /* the parameter along the patch's own direction */
      float u = e == 0 || e == 1 ? s : e == 2 ? 0.0f : 1.0f;
      float w = e == 2 || e == 3 ? s : e == 0 ? 0.0f : 1.0f;
      vm_put(xyz, uv, at++, q, u, w);
    }
  }
  /* interior (i, j) for i = 1..nu-1 along u, j = 1..nv-1 along v */
  uint ibase = at;
  for (uint j = 1; j < nv; ++j)
    for (uint i = 1; i < nu; ++i) {
      float u = i == nu - 1 ? u_hi : u_lo + (u_hi - u_lo) * (float)(i - 1) / (float)(nu - 2);
      float w = j == nv - 1 ? v_hi : v_lo + (v_hi - v_lo) * (float)(j - 1) / (float)(nv - 2);
      vm_put(xyz, uv, at++, vm_surface(ctrl, p, u, w), u, w);
    }
#define VM_IN(i, j) (ibase + ((j) - 1) * (nu - 1) + ((i) - 1))
  uint t = t0;
  for (uint j = 1; j + 1 < nv; ++j)
    for (uint i = 1; i + 1 < nu; ++i) {
      tri[3 * t] = VM_IN(i, j);
      tri[3 * t + 1] = VM_IN(i + 1, j);
      tri[3 * t + 2] = VM_IN(i + 1, j + 1);
      tri[3 * t + 3] = VM_IN(i, j);
      tri[3 * t + 4] = VM_IN(i + 1, j + 1);
      tri[3 * t + 5] = VM_IN(i, j + 1);
      t += 2;
    }
  /* strips: v = 0 (inner row j = 1), v = 1 (j = nv - 1), u = 0 (column i = 1), u = 1 (i = nu - 1);
   * outer index k in the patch's direction is canonical k or n - k */
  t = vm_strip(tri, t, ebase[0], r[0], erev[0], VM_IN(1, 1), 1, nu - 2, u_lo, u_hi, 0);
  t = vm_strip(tri, t, ebase[1], r[1], erev[1], VM_IN(1, nv - 1), 1, nu - 2, u_lo, u_hi, 1);
  t = vm_strip(tri, t, ebase[2], r[2], erev[2], VM_IN(1, 1), (int)(nu - 1), nv - 2, v_lo, v_hi, 1);
  t = vm_strip(tri, t, ebase[3], r[3], erev[3], VM_IN(nu - 1, 1), (int)(nu - 1), nv - 2, v_lo, v_hi, 0);
#undef VM_IN
  for (uint k = t0; k < t; ++k) face[k] = p;
}
