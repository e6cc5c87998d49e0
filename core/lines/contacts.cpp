// Contacts in 3D: where one surface's edge lies on another surface (a box on a floor, pieces
// of one surface not welded), within the scene's tolerance.
#include <algorithm>
#include <cmath>

#include "core/lines/classifier.h"

namespace vismap::lines_detail {

// --- Contacts: where one surface's edge lies on another surface in 3D. ---
// The point of x's edge (in the world) that projects to p (pixels): the edge's parameter
// solved in homogeneous coordinates, where it is affine.
Vec Classifier::on_edge(const Side& x, const double* p) const {
  const Mesh& mesh = scene_.meshes[x.mesh];
  double h0[3], h1[3];
  homog(mesh, x.tri, x.edge, h0);
  homog(mesh, x.tri, (x.edge + 1) % 3, h1);
  // p.x (w0 + u dw) = x0 + u dx, the same in y: the better conditioned of the two.
  const double dnx = (h1[0] - h0[0]) - p[0] * (h1[2] - h0[2]);
  const double dny = (h1[1] - h0[1]) - p[1] * (h1[2] - h0[2]);
  double u =
      std::abs(dnx) >= std::abs(dny) ? (p[0] * h0[2] - h0[0]) / dnx : (p[1] * h0[2] - h0[1]) / dny;
  if (!std::isfinite(u)) u = 0.5;
  u = std::clamp(u, 0.0, 1.0);
  const Vec p0 = position(mesh, x.tri, x.edge), d = edge_dir(x);
  return {p0.x + u * d.x, p0.y + u * d.y, p0.z + u * d.z};
}

// Does x's edge, along the map edge a-b, lie on y's surface (its plane, within the scene's
// tolerance)? Within one mesh, not where y is within two rings of the edge (a vertex of y at
// or next to one of the edge's): there the surface folds, it does not meet itself.
// (A seam, where y's edge holds x's edge in 3D, is a contact however near.)
bool Classifier::touches(const Side& x, const Side& y, const double* a, const double* b) {
  if (x.mesh == y.mesh && near_on_mesh(x, y.tri)) return y.edge >= 0 && on_edge_line(x, y, a, b);
  return on_plane(x, y, a, b);
}

// Do the points of x's edge at a quarter and three quarters of the map edge a-b lie on y's
// edge (the segment, in 3D)?
// (A degenerate y, its corners in a line, holds every edge along it and is no partner.) The
// two edges must run along one line, not merely pass near each other where they meet.
bool Classifier::on_edge_line(const Side& x, const Side& y, const double* a,
                              const double* b) const {
  const Vec p0 = position(scene_.meshes[y.mesh], y.tri, y.edge), d = edge_dir(y);
  const double l2 = dot(d, d);
  if (!(l2 > 0) || degenerate(y)) return false;
  // Parallel within 1e-5 radians (float corners: ~1e-7).
  const Vec dx = edge_dir(x), c = cross(dx, d);
  if (dot(c, c) > 1e-10 * dot(dx, dx) * l2) return false;
  for (double u : {0.25, 0.75}) {
    const double p[2] = {a[0] + u * (b[0] - a[0]), a[1] + u * (b[1] - a[1])};
    const Vec q = sub(on_edge(x, p), p0);
    const double t = std::clamp(dot(q, d) / l2, 0.0, 1.0);
    const Vec r = sub(q, {t * d.x, t * d.y, t * d.z});
    if (dot(r, r) > eps_ * eps_) return false;
  }
  return true;
}

// Do the points of x's edge at a quarter and three quarters of the map edge a-b lie on y's
// plane?
bool Classifier::on_plane(const Side& x, const Side& y, const double* a, const double* b) const {
  for (double u : {0.25, 0.75}) {
    const double p[2] = {a[0] + u * (b[0] - a[0]), a[1] + u * (b[1] - a[1])};
    if (!on_plane_of(y, on_edge(x, p))) return false;
  }
  return true;
}

// Is the point p within eps_ of y's plane (never, for a triangle with no area)?
bool Classifier::on_plane_of(const Side& y, const Vec& p) const {
  const Mesh& mesh = scene_.meshes[y.mesh];
  const Vec n = normal(mesh, y.tri);
  const double ln = std::sqrt(dot(n, n));
  return ln > 0 && std::abs(dot(n, sub(p, position(mesh, y.tri, 0)))) <= eps_ * ln;
}

// The square of x's triangle's longest edge.
double Classifier::longest_edge2(const Side& x) const {
  double l2 = 0;
  for (int k = 0; k < 3; ++k) {
    const Vec d = edge_dir({x.mesh, x.tri, k});
    l2 = std::max(l2, dot(d, d));
  }
  return l2;
}

// Does the surface end at x's edge in 3D: no neighbour there, more than one, or one facing
// the other way (a contour edge)?
bool Classifier::ends_at(const Side& x) {
  const Mesh& mesh = scene_.meshes[x.mesh];
  const Topology& T = topo(x.mesh);
  const uint64_t key = T.undirected(mesh, x.tri, x.edge);
  const uint32_t id = *T.edge.find(key);
  if (T.uses[id] != 2) return true;
  const uint32_t o =
      T.tris[2 * size_t(id)] == x.tri ? T.tris[2 * size_t(id) + 1] : T.tris[2 * size_t(id)];
  int k = 0;
  while (k < 2 && T.undirected(mesh, o, k) != key) ++k;
  double cosang;
  return facing_differs(x, {x.mesh, o, k}, &cosang);
}

// Does y (x's mesh, within two rings of x's edge) touch x's edge along the map edge a-b?
bool Classifier::continues_into(const Side& x, const Side& y, const double* a, const double* b) {
  return x.mesh == y.mesh && near_on_mesh(x, y.tri) && on_plane(x, y, a, b);
}

// Is x's triangle (nearly) a segment: its area under 1e-9 of its longest edge squared?
bool Classifier::degenerate(const Side& x) const {
  const Vec n = normal(scene_.meshes[x.mesh], x.tri);
  return std::sqrt(dot(n, n)) <= 1e-9 * longest_edge2(x);
}

// Do x's and y's triangles lie in one plane (y's corners on x's plane)?
bool Classifier::coplanar(const Side& x, const Side& y) const {
  const Mesh& my = scene_.meshes[y.mesh];
  for (int k = 0; k < 3; ++k)
    if (!on_plane_of(x, position(my, y.tri, k))) return false;
  return true;
}

// Does x's whole edge lie on y's plane (same tolerance and rings as touches())?
bool Classifier::edge_on(const Side& x, const Side& y) {
  if (x.mesh == y.mesh && near_on_mesh(x, y.tri)) return false;
  const Mesh& mx = scene_.meshes[x.mesh];
  return on_plane_of(y, position(mx, x.tri, x.edge)) &&
         on_plane_of(y, position(mx, x.tri, (x.edge + 1) % 3));
}

// On a diced implicit, is what shows beyond x's edge (y, along the view ray through the map
// edge's midpoint) nearer to the edge in 3D than x's longest edge? The dicer's cells are about
// that size and its surface is within sqrt(3) cells of f = 0 (core/surfaces/implicit3d.cpp):
// such a fold is the grid's, not the surface's (a sheet where f touches 0 without changing
// sign: the architecture model's slabs meeting at x = 0 leave a groove one cell deep).
bool Classifier::grid_fold(const Side& x, const Side& y, const double* a, const double* b) {
  if (scene_.meshes[x.mesh].normals.empty()) return false;
  const double m[2] = {(a[0] + b[0]) / 2, (a[1] + b[1]) / 2};
  const Vec p = on_edge(x, m);
  const Mesh& my = scene_.meshes[y.mesh];
  const Vec n = normal(my, y.tri), p0 = position(my, y.tri, 0);
  const Vec eye{cam_.eye[0], cam_.eye[1], cam_.eye[2]};
  const Vec dir = cam_.projection == Camera::Projection::Orthographic
                      ? sub({cam_.target[0], cam_.target[1], cam_.target[2]}, eye)
                      : sub(p, eye);
  const double nd = dot(n, dir);
  if (!(std::abs(nd) > 0)) return false;
  const double s = dot(n, sub(p0, p)) / nd;  // p + s dir lies on y's plane
  const double gap = std::abs(s) * std::sqrt(dot(dir, dir));
  return gap < std::sqrt(longest_edge2(x));
}

bool Classifier::near_on_mesh(const Side& x, uint32_t t) {
  const Mesh& mesh = scene_.meshes[x.mesh];
  const Topology& T = topo(x.mesh);
  const uint32_t u = T.vertex(mesh, x.tri, x.edge), v = T.vertex(mesh, x.tri, (x.edge + 1) % 3);
  for (int k = 0; k < 3; ++k)
    if (T.adjacent(T.vertex(mesh, t, k), u) || T.adjacent(T.vertex(mesh, t, k), v)) return true;
  return false;
}

// Does x's edge (shared with y) lie on a third surface that the map edge a-b passes over on
// the screen? (A box's bottom face ties with the floor under it: the floor is not on either
// side of the box's bottom edge there, but the edge stands on it all the same.)
bool Classifier::touches_third(const Side& x, const Side& y, const double* a, const double* b) {
  const double mx = (a[0] + b[0]) / 2, my = (a[1] + b[1]) / 2;
  bool hit = false;
  for_each_covering(mx, my, [&](uint32_t s) {
    const uint32_t m = st_.mesh[s], t = st_.triangle[s];
    if (hit || (m == x.mesh && (t == x.tri || t == y.tri))) return;
    hit = touches(x, {m, t, -1}, a, b);
  });
  return hit;
}

// A triangle y of x's mesh (within kSeamPx on the screen) with an edge that holds x's edge
// along the map edge a-b in 3D: the other side of a T-junction (pieces of one surface not
// welded, whose snapped corners leave a crack a rounding wide between them).
bool Classifier::seam_partner(const Side& x, const double* a, const double* b, Side& y) {
  bool found = false;
  for_each_covering((a[0] + b[0]) / 2, (a[1] + b[1]) / 2,
                    [&](uint32_t s) {
                      if (found || st_.mesh[s] != x.mesh || st_.triangle[s] == x.tri) return;
                      for (int k = 0; k < 3 && !found; ++k) {
                        const Side c{x.mesh, st_.triangle[s], k};
                        if (on_edge_line(x, c, a, b)) y = c, found = true;
                      }
                    },
                    kSeamPx);
  return found;
}

}  // namespace vismap::lines_detail
