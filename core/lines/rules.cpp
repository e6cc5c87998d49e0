// The rules that give a map edge its kind from the source triangles on its two sides
// (docs/LINES.md "How an edge of the map is classified"), and the mesh facts they use.
#include <algorithm>
#include <cmath>

#include "core/lines/classifier.h"

namespace vismap::lines_detail {

// The kind of the map edge a-b (pixels) between fragments f and g (g = kNone: background);
// false when it is no line (docs/LINES.md "How an edge of the map is classified").
bool Classifier::classify(const double* a, const double* b, uint32_t f, uint32_t g, LineKind& kind,
                          Owner& owner) {
  owner = Owner{};
  const uint32_t m1 = map_.mesh[f], t1 = map_.triangle[f];
  auto own = [&](uint32_t m, uint32_t t, int e) {
    owner.mesh = m;
    owner.edge = topo(m).undirected(scene_.meshes[m], t, e);
  };
  if (g == kNone) {
    if (on_viewport_border(a, b)) return false;
    uint32_t s;
    const int e = source_edge(m1, t1, a, b, &s);
    if (e < 0) return false;  // the near plane's cut
    own(m1, t1, e);
    if (has_neighbour(m1, t1, e)) {
      kind = LineKind::Contour;
      return true;
    }
    return open_edge_kind({m1, t1, e}, a, b, kind);
  }
  const uint32_t m2 = map_.mesh[g], t2 = map_.triangle[g];
  if (m1 == m2 && t1 == t2) return false;
  uint32_t s1 = kNone, s2 = kNone;
  int mask1 = 0, mask2 = 0;
  const int e1 = source_edge(m1, t1, a, b, &s1, &mask1);
  const int e2 = source_edge(m2, t2, a, b, &s2, &mask2);
  const Side side[2] = {{m1, t1, e1}, {m2, t2, e2}};
  // A mesh edge both sides share: a fold, a crease or nothing; a contact where the edge
  // lies on a third surface (a box's bottom edge on the floor its bottom face ties with).
  for (int k1 = 0; k1 < 3 && m1 == m2; ++k1)
    for (int k2 = 0; k2 < 3; ++k2) {
      if (!(mask1 >> k1 & 1) || !(mask2 >> k2 & 1) || !shared_edge(m1, t1, k1, t2, k2)) continue;
      const Side x{m1, t1, k1}, y{m2, t2, k2};
      own(m1, t1, k1);
      if (!edge_kind(x, y, kind)) return false;
      if (touches_third(x, y, a, b)) kind = LineKind::Border;
      return true;
    }
  // A contact: one side's edge lies on the other surface (in 3D, so from every view alike).
  for (int i = 0; i < 2; ++i) {
    if (side[i].edge < 0 || !touches(side[i], side[1 - i], a, b)) continue;
    own(side[i].mesh, side[i].tri, side[i].edge);
    return contact_kind(side[i], side[1 - i], kind);
  }
  // On a crossing line the pipeline clipped with: the surfaces cross.
  // On a crossing line the pipeline clipped with: the surfaces cross, unless an edge of one
  // lies on the other in 3D (a box's bottom edge on the floor: the snapped depth planes cross
  // a rounding away from it), where they are in contact as above.
  if (on_crossing(s1, s2, a, b)) {
    for (int i = 0; i < 2; ++i)
      for (int k = 0; k < 3; ++k) {
        const Side x{side[i].mesh, side[i].tri, k};
        if (!edge_on(x, side[1 - i])) continue;
        own(x.mesh, x.tri, k);
        return contact_kind(x, side[1 - i], kind);
      }
    kind = LineKind::Intersection;
    return true;
  }
  if (e1 < 0 && e2 < 0) {
    // Coplanar surfaces (one plane in 3D) that the tie rule orders cyclically, cut by a
    // third pair's line: one surface, no line.
    if (coplanar(side[0], side[1])) return false;
    ++unplaced;
    return false;
  }
  // One surface ends here in front of the other. The owner: the nearer side when both lie on
  // an edge of theirs, else the one that does.
  const double mx = (a[0] + b[0]) / 2, my = (a[1] + b[1]) / 2;
  const bool first = e1 >= 0 && (e2 < 0 || nearness(s1, mx, my) > nearness(s2, mx, my));
  const Side& n = side[first ? 0 : 1];
  // Unless the surface goes on across n's edge (no fold there) and what shows beyond is the
  // same surface within two rings, less than a pixel from the edge: a neighbour too thin to
  // show (a sliver snapped to nothing) lies between them, and there is no line.
  if (!ends_at(n) && continues_into(n, side[first ? 1 : 0], a, b)) return false;
  own(n.mesh, n.tri, n.edge);
  if (has_neighbour(n.mesh, n.tri, n.edge)) {
    // Selection (LineOptions::self_folds): a contour where what shows beyond is its own
    // surface within two rings separates nothing but the two sides of a fold smaller than
    // its triangles.
    const Side& o = side[first ? 1 : 0];
    if (!self_folds_ && o.mesh == n.mesh && (near_on_mesh(n, o.tri) || grid_fold(n, o, a, b)))
      return false;
    kind = LineKind::Contour;
    return true;
  }
  return open_edge_kind(n, a, b, kind);
}

const Topology& Classifier::topo(uint32_t m) {
  if (!topo_[m].built) topo_[m].build(scene_.meshes[m]);
  return topo_[m];
}

// A diced implicit (Mesh::normals given) is the boundary of a solid whose back faces the
// dicer left out where they cannot be seen (core/surfaces/implicit3d.cpp): its open edges had
// a neighbour, facing away.
bool Classifier::has_neighbour(uint32_t m, uint32_t t, int k) {
  return !scene_.meshes[m].normals.empty() || topo(m).edge_uses(scene_.meshes[m], t, k) >= 2;
}

bool Classifier::shared_edge(uint32_t m, uint32_t t1, int k1, uint32_t t2, int k2) {
  const Topology& T = topo(m);
  const Mesh& mesh = scene_.meshes[m];
  return T.undirected(mesh, t1, k1) == T.undirected(mesh, t2, k2);
}

Vec Classifier::position(const Mesh& m, uint32_t t, int k) const {
  const float* p = &m.positions[3 * size_t(m.indices[3 * size_t(t) + k])];
  return {p[0], p[1], p[2]};
}

Vec Classifier::normal(const Mesh& m, uint32_t t) const {
  const Vec p0 = position(m, t, 0);
  return cross(sub(position(m, t, 1), p0), sub(position(m, t, 2), p0));
}

// Positive when triangle t of m shows the side its normal points to.
double Classifier::facing(const Mesh& m, uint32_t t) const {
  const Vec n = normal(m, t);
  if (cam_.projection == Camera::Projection::Orthographic)
    return -dot(n, sub({cam_.target[0], cam_.target[1], cam_.target[2]},
                       {cam_.eye[0], cam_.eye[1], cam_.eye[2]}));
  return dot(n, sub({cam_.eye[0], cam_.eye[1], cam_.eye[2]}, position(m, t, 0)));
}

Vec Classifier::edge_dir(const Side& x) const {
  const Mesh& mesh = scene_.meshes[x.mesh];
  return sub(position(mesh, x.tri, (x.edge + 1) % 3), position(mesh, x.tri, x.edge));
}

// x and y (one mesh) meet along their edges x.edge and y.edge: shared, or collinear in 3D (a
// seam between pieces of one surface). With y's orientation made consistent with x's across
// the edge (a soup need not be: consistent when the two run it opposite ways), does one face
// the eye and the other away? *cosang: the cosine of the angle between their normals.
bool Classifier::facing_differs(const Side& x, const Side& y, double* cosang) const {
  const Mesh& mesh = scene_.meshes[x.mesh];
  const double flip = dot(edge_dir(x), edge_dir(y)) > 0 ? -1 : 1;
  const Vec n1 = normal(mesh, x.tri), n2 = normal(mesh, y.tri);
  const double l = std::sqrt(dot(n1, n1) * dot(n2, n2));
  *cosang = l > 0 ? flip * dot(n1, n2) / l : 1.0;
  const double f1 = facing(mesh, x.tri), f2 = flip * facing(mesh, y.tri);
  return (f1 > 0) != (f2 > 0);
}

// Rule 4's kinds for an edge x and y meet along: contour at a fold, crease past the crease
// angle, else false (no line).
// With LineOptions::crease_smooth, a crease also needs the smoothed normals of the two faces
// to differ by more than half the crease angle.
bool Classifier::edge_kind(const Side& x, const Side& y, LineKind& kind) {
  double cosang;
  if (facing_differs(x, y, &cosang))
    kind = LineKind::Contour;
  else if (cosang < cos_crease_ && (!crease_smooth_ || smoothed_cos(x, y) < cos_half_crease_))
    kind = LineKind::Crease;
  else
    return false;
  return true;
}

// The cosine of the angle between x's and y's smoothed normals (orientations made consistent
// across their edge as facing_differs does): each the sum of its corners' vertex normals, a
// vertex normal the sum of the area-weighted normals of the triangles around it.
double Classifier::smoothed_cos(const Side& x, const Side& y) {
  const Mesh& mesh = scene_.meshes[x.mesh];
  const Topology& T = topo(x.mesh);
  std::vector<Vec>& vn = vertex_normals_[x.mesh];
  if (vn.empty()) {
    vn.assign(mesh.vertex_count(), Vec{0, 0, 0});
    for (size_t t = 0; t < mesh.triangle_count(); ++t) {
      const Vec n = normal(mesh, uint32_t(t));
      for (int k = 0; k < 3; ++k) {
        Vec& v = vn[T.vertex(mesh, t, k)];
        v = {v.x + n.x, v.y + n.y, v.z + n.z};
      }
    }
  }
  auto smooth = [&](uint32_t t) {
    Vec s{0, 0, 0};
    for (int k = 0; k < 3; ++k) {
      const Vec& v = vn[T.vertex(mesh, t, k)];
      s = {s.x + v.x, s.y + v.y, s.z + v.z};
    }
    return s;
  };
  const double flip = dot(edge_dir(x), edge_dir(y)) > 0 ? -1 : 1;
  const Vec a = smooth(x.tri), b = smooth(y.tri);
  const double l = std::sqrt(dot(a, a) * dot(b, b));
  return l > 0 ? flip * dot(a, b) / l : 1.0;
}

// The kind of an edge with no neighbour in its mesh (by position): a boundary, unless it is
// a seam (seam_partner), then as if the two shared it (false: no line).
bool Classifier::open_edge_kind(const Side& x, const double* a, const double* b, LineKind& kind) {
  Side y;
  if (!seam_partner(x, a, b, y)) {
    kind = LineKind::Boundary;
    return true;
  }
  return edge_kind(x, y, kind);
}

// The kind of a contact: x's edge lies on y's surface. Two meshes meet: border. Pieces of one
// mesh: along y's edge too (a seam, the pieces not welded), as if they shared the edge (a
// fold, a crease or nothing); inside y's face, nothing where they are coplanar (within the
// crease angle), else border.
bool Classifier::contact_kind(const Side& x, const Side& y, LineKind& kind) {
  if (x.mesh != y.mesh) {
    kind = LineKind::Border;
    return true;
  }
  if (y.edge >= 0) return edge_kind(x, y, kind);
  const Mesh& mesh = scene_.meshes[x.mesh];
  const Vec n1 = normal(mesh, x.tri), n2 = normal(mesh, y.tri);
  const double l = std::sqrt(dot(n1, n1) * dot(n2, n2));
  if (l > 0 && std::abs(dot(n1, n2)) / l >= cos_crease_) return false;
  kind = LineKind::Border;
  return true;
}

}  // namespace vismap::lines_detail
