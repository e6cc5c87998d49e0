/* Exact 2D predicates on the grid (DESIGN §3, docs/NUMERICS.md §1).
 * Grid coordinates are below 2^22, so a line through two grid points has |a|,|b| <= 2^23 and
 * |c| <= 2^46; an exact crossing line has |a|, |b| <= 2^30 and |c| <= 2^54. Products of two
 * coefficients fit in 64 bits, and the 3x3 determinants that decide the side of an
 * intersection vertex fit in 128 bits. No epsilon anywhere. */

typedef struct {
  long a, b, c;
} Line3;

/* a*x + b*y + c = orient(p0, p1, (x, y)) */
inline Line3 line_of(int x0, int y0, int x1, int y1) {
  Line3 L;
  L.a = -(long)(y1 - y0);
  L.b = (long)(x1 - x0);
  L.c = -(L.a * (long)x0 + L.b * (long)y0);
  return L;
}

inline Line3 line_of_vm(VmLine l) {
  Line3 L;
  L.a = l.a;
  L.b = l.b;
  L.c = l.c;
  return L;
}

inline VmLine vm_line(Line3 L) {
  VmLine l;
  l.a = (int)L.a;
  l.b = (int)L.b;
  l.c = L.c;
  return l;
}

inline VmLine vm_line_of(int x0, int y0, int x1, int y1) {
  return vm_line(line_of(x0, y0, x1, y1));
}

/* The line of an edge record: a segment's through its two points; an infinite crossing line
 * (q0 = +inf) keeps its coefficients in the point fields: a, b in (x0, y0), c in (x1, y1) as
 * low and high 32 bits. */
inline Line3 edge_line(VmEdge e) {
  if (!isinf(e.q0)) return line_of(e.x0, e.y0, e.x1, e.y1);
  Line3 L;
  L.a = e.x0;
  L.b = e.y0;
  L.c = (long)(((ulong)(uint)e.y1 << 32) | (ulong)(uint)e.x1);
  return L;
}

/* A partner's edge as an entry: a segment always in front (q0 = q1 = DBL_MAX). */
inline VmEdge segment_edge(int x0, int y0, int x1, int y1) {
  VmEdge e;
  e.x0 = x0;
  e.y0 = y0;
  e.x1 = x1;
  e.y1 = y1;
  e.q0 = DBL_MAX;
  e.q1 = DBL_MAX;
  return e;
}

inline VmEdge crossing_edge(Line3 L) {
  VmEdge e;
  e.x0 = (int)L.a;
  e.y0 = (int)L.b;
  e.x1 = (int)(uint)((ulong)L.c & 0xffffffffUL);
  e.y1 = (int)(L.c >> 32);
  e.q0 = INFINITY;
  e.q1 = INFINITY;
  return e;
}

inline Line3 line_reversed(Line3 L) {
  Line3 R;
  R.a = -L.a;
  R.b = -L.b;
  R.c = -L.c;
  return R;
}

/* Exact side of a grid point: |a*x|, |b*y| <= 2^52, |c| <= 2^54. */
inline long line_eval_point(Line3 L, long x, long y) {
  return L.a * x + L.b * y + L.c;
}

inline long orient_points(long x0, long y0, long x1, long y1, long x2, long y2) {
  return (x1 - x0) * (y2 - y0) - (y1 - y0) * (x2 - x0);
}

/* Side of the vertex Li ^ Lj with respect to Lm: sign(det[Li; Lj; Lm]) * sign(w) where the
 * vertex is (X, Y, w) = Li x Lj and w = ai*bj - aj*bi. Each 2x2 minor is below 2^61, each
 * product with a c below 2^115, the sum below 2^117. Li and Lj must not be parallel. */
inline int vertex_side(Line3 Li, Line3 Lj, Line3 Lm) {
  long m_jm = Lj.a * Lm.b - Lm.a * Lj.b;
  long m_im = Li.a * Lm.b - Lm.a * Li.b;
  long m_ij = Li.a * Lj.b - Lj.a * Li.b;
  i128 d = i128_mul64(Li.c, m_jm);
  d = i128_sub(d, i128_mul64(Lj.c, m_im));
  d = i128_add(d, i128_mul64(Lm.c, m_ij));
  int s = i128_sign(d);
  return m_ij > 0 ? s : -s;
}

/* A vertex as doubles (grid units), for choosing sample points only: never for decisions. */
inline double2 vertex_approx(Line3 Li, Line3 Lj) {
  i128 X = i128_sub(i128_mul64(Li.b, Lj.c), i128_mul64(Lj.b, Li.c));
  i128 Y = i128_sub(i128_mul64(Li.c, Lj.a), i128_mul64(Lj.c, Li.a));
  double w = (double)(Li.a * Lj.b - Lj.a * Li.b);
  return (double2)(i128_to_double(X) / w, i128_to_double(Y) / w);
}

/* Exact side of a fine sample point (px, py) / 2^VM_POINT_BITS. */
inline int line_side_fine(Line3 L, long px, long py) {
  i128 s = i128_add(i128_mul64(L.a, px), i128_mul64(L.b, py));
  s = i128_add(s, i128_mul64(L.c, (long)1 << VM_POINT_BITS));
  return i128_sign(s);
}

/* A point where occlusion decides: a fine-grid point (px, py) / 2^VM_POINT_BITS, or, for a
 * cell thinner than the fine grid, an exact rational point (X / W, Y / W) with W > 0
 * (occlusion.cl exact_interior_point; coordinates below 2^209 over 2^185, §1 of NUMERICS). */
typedef struct {
  long px, py;
  int exact;
  int gx, gy;    /* the grid cell holding the point: floor of its coordinates */
  double fx, fy; /* the point in grid units, rounded: for depths only, never for sides */
  i256 X, Y, W;
} VmSample;

inline VmSample sample_fine(long px, long py) {
  VmSample s;
  s.px = px;
  s.py = py;
  s.exact = 0;
  s.gx = (int)(px >> VM_POINT_BITS);
  s.gy = (int)(py >> VM_POINT_BITS);
  const double inv = 1.0 / (double)((long)1 << VM_POINT_BITS);
  s.fx = (double)px * inv;
  s.fy = (double)py * inv;
  return s;
}

/* Exact side of a rational point: a*X + b*Y + c*W, each term below 2^239 (NUMERICS §1). */
inline int line_side_exact(Line3 L, i256 X, i256 Y, i256 W) {
  i256 s = i256_add(i256_mul64(X, L.a), i256_mul64(Y, L.b));
  return i256_sign(i256_add(s, i256_mul64(W, L.c)));
}

inline int sample_side(Line3 L, const VmSample* s) {
  return s->exact ? line_side_exact(L, s->X, s->Y, s->W) : line_side_fine(L, s->px, s->py);
}

/* A screen triangle's depth plane: nearness q(x, y) = q0 + gx*(x - x0) + gy*(y - y0) in grid
 * units, the affine interpolation of its three vertices' nearness. */
typedef struct {
  double x0, y0, q0, gx, gy;
} DepthPlane;

inline DepthPlane depth_plane(const VmScreenTri* t) {
  double dx1 = (double)(t->x[1] - t->x[0]), dy1 = (double)(t->y[1] - t->y[0]);
  double dx2 = (double)(t->x[2] - t->x[0]), dy2 = (double)(t->y[2] - t->y[0]);
  double dq1 = t->q[1] - t->q[0], dq2 = t->q[2] - t->q[0];
  double det = dx1 * dy2 - dx2 * dy1;
  DepthPlane p;
  p.x0 = (double)t->x[0];
  p.y0 = (double)t->y[0];
  p.q0 = t->q[0];
  p.gx = (dq1 * dy2 - dq2 * dy1) / det;
  p.gy = (dq2 * dx1 - dq1 * dx2) / det;
  return p;
}

inline double plane_at(DepthPlane p, double x, double y) {
  return p.q0 + p.gx * (x - p.x0) + p.gy * (y - p.y0);
}

inline double tri_depth_at(const VmScreenTri* t, double x, double y) {
  return plane_at(depth_plane(t), x, y);
}

/* Does triangle `o` win over triangle `t` where their nearness is qo and qt? Ties within the
 * relative band VM_TIE_EPS go to the lower (mesh, triangle): a fixed rule, never chance. */
inline bool in_front(double qo, double qt, uint mesh_o, uint tri_o, uint mesh_t, uint tri_t) {
  double scale = fmax(fabs(qo), fabs(qt));
  double d = qo - qt;
  if (d > VM_TIE_EPS * scale) return true;
  if (d < -VM_TIE_EPS * scale) return false;
  return mesh_o < mesh_t || (mesh_o == mesh_t && tri_o < tri_t);
}

/* The integer depth plane of a snapped triangle (transform.cl snap_depth_planes, which
 * keeps a plane only when this recovers it): 2^k q(x, y) =
 * A x + B y + C at grid point (x, y). The vertices' values N_i = 2^k q_i are integers; A det =
 * (N1 - N0) dy2 - (N2 - N0) dy1 is formed exactly (i128) and divided in double, which lands
 * within 2^-22 of the integer A (|A| <= 2^29, two roundings of 2^-53), and the result is
 * verified against the vertices exactly. |C| <= 2^52 + 2 * 2^29 * 2^22 = 2^53. */
inline bool int_plane(const VmScreenTri* t, long* A, long* B, long* C) {
  if (t->plane_k == VM_PLANE_FREE) return false;
  long n0 = (long)ldexp(t->q[0], t->plane_k), n1 = (long)ldexp(t->q[1], t->plane_k) - n0,
       n2 = (long)ldexp(t->q[2], t->plane_k) - n0;
  long dx1 = t->x[1] - t->x[0], dy1 = t->y[1] - t->y[0], dx2 = t->x[2] - t->x[0],
       dy2 = t->y[2] - t->y[0];
  double det = (double)(dx1 * dy2 - dx2 * dy1);
  long a = (long)rint(i128_to_double(i128_sub(i128_mul64(n1, dy2), i128_mul64(n2, dy1))) / det);
  long b = (long)rint(i128_to_double(i128_sub(i128_mul64(n2, dx1), i128_mul64(n1, dx2))) / det);
  if (n1 != a * dx1 + b * dy1 || n2 != a * dx2 + b * dy2) return false;
  *A = a;
  *B = b;
  *C = n0 - a * t->x[0] - b * t->y[0];
  return true;
}
