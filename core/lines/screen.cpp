// Source edges on the screen: projected and clipped to the view volume as transform.cl does,
// matched to the screen triangles' edges, and depth on a screen triangle's plane.
#include <algorithm>
#include <cmath>

#include "core/lines/classifier.h"

namespace vismap::lines_detail {

// Edge k of triangle t clipped to the view volume (clip space, as transform.cl clips) and
// projected; false when nothing of it is in view.
bool Classifier::project_edge(const Mesh& mesh, uint32_t t, int k, double* a, double* b) const {
  double c[2][4];
  for (int e = 0; e < 2; ++e) {
    const float* p = &mesh.positions[3 * size_t(mesh.indices[3 * size_t(t) + (k + e) % 3])];
    for (int r = 0; r < 4; ++r)
      c[e][r] = vp_[r] * p[0] + vp_[4 + r] * p[1] + vp_[8 + r] * p[2] + vp_[12 + r];
  }
  double t0 = 0, t1 = 1;
  for (int pl = 0; pl < 6; ++pl) {
    auto dist = [pl](const double* q) {
      const double s = pl & 1 ? -1 : 1;
      return q[3] + s * q[pl / 2 == 0 ? 2 : pl / 2 == 1 ? 0 : 1];
    };
    const double d0 = dist(c[0]), d1 = dist(c[1]);
    if (d0 < 0 && d1 < 0) return false;
    if (d0 < 0) t0 = std::max(t0, d0 / (d0 - d1));
    if (d1 < 0) t1 = std::min(t1, d0 / (d0 - d1));
  }
  if (!(t0 < t1)) return false;
  const double G = st_.grid_scale ? st_.grid_scale : kGrid;
  auto put = [&](double u, double* out) {
    double q[4];
    for (int r = 0; r < 4; ++r) q[r] = c[0][r] + u * (c[1][r] - c[0][r]);
    const double sx = map_.width * G * 0.5, sy = map_.height * G * 0.5;
    out[0] = std::clamp(std::rint((q[0] / q[3] + 1.0) * sx), 0.0, map_.width * G) / G;
    out[1] = std::clamp(std::rint((1.0 - q[1] / q[3]) * sy), 0.0, map_.height * G) / G;
  };
  put(t0, a);
  put(t1, b);
  return true;
}

bool Classifier::on_viewport_border(const double* a, const double* b) const {
  const double W = map_.width, H = map_.height, e = 1e-9;
  auto at = [e](double u, double v) { return std::abs(u - v) <= e; };
  return (at(a[0], 0) && at(b[0], 0)) || (at(a[0], W) && at(b[0], W)) ||
         (at(a[1], 0) && at(b[1], 0)) || (at(a[1], H) && at(b[1], H));
}

// Corner k of triangle t as homogeneous pixel coordinates (x, y, w): x = (cx/cw + 1) W/2
// etc. times cw.
void Classifier::homog(const Mesh& mesh, uint32_t t, int k, double* h) const {
  const float* p = &mesh.positions[3 * size_t(mesh.indices[3 * size_t(t) + k])];
  double c[4];
  for (int r = 0; r < 4; ++r)
    c[r] = vp_[r] * p[0] + vp_[4 + r] * p[1] + vp_[8 + r] * p[2] + vp_[12 + r];
  h[0] = (c[0] + c[3]) * 0.5 * map_.width;
  h[1] = (c[3] - c[1]) * 0.5 * map_.height;
  h[2] = c[3];
}

// Which source edge (k: vertices k, k+1) each edge of screen triangle s lies on; kClip where
// it lies on none (a cut of the view volume's planes). Tested against the source edge's line
// in homogeneous screen coordinates, which stays right when a corner is behind the eye: the
// screen edge's ends are grid points (snapped corners or clip points), within 1/(2G) px per
// axis of that line when they are on it.
const std::array<int8_t, 3>& Classifier::edges_of(uint32_t s) {
  std::array<int8_t, 3>& e = edge_of_[s];
  if (e[0] != kUnmapped) return e;
  const Mesh& mesh = scene_.meshes[st_.mesh[s]];
  double h[3][3];
  for (int k = 0; k < 3; ++k) homog(mesh, st_.triangle[s], k, h[k]);
  double line[3][3], norm[3];
  for (int k = 0; k < 3; ++k) {
    const double* a = h[k];
    const double* b = h[(k + 1) % 3];
    line[k][0] = a[1] * b[2] - a[2] * b[1];
    line[k][1] = a[2] * b[0] - a[0] * b[2];
    line[k][2] = a[0] * b[1] - a[1] * b[0];
    norm[k] = std::hypot(line[k][0], line[k][1]);
  }
  const double g = st_.grid_scale, tol = 2.0 / g;
  for (int i = 0; i < 3; ++i) {
    e[i] = kClip;
    double best = tol;
    for (int k = 0; k < 3; ++k) {
      if (!(norm[k] > 0)) continue;
      double worst = 0;
      for (int j = 0; j < 2; ++j) {
        const int c = (i + j) % 3;
        const double x = st_.xy[6 * size_t(s) + 2 * c] / g,
                     y = st_.xy[6 * size_t(s) + 2 * c + 1] / g;
        worst = std::max(worst, std::abs(line[k][0] * x + line[k][1] * y + line[k][2]) / norm[k]);
      }
      if (worst < best) best = worst, e[i] = int8_t(k);
    }
  }
  return e;
}

// The edge k of source (m, t) the segment a-b lies on (through any of its screen triangles),
// or -1; *s: the screen triangle it was found in (the first one, when none).
// *mask (if given): a bit for each source edge it lies on (a needle's edges may all be one
// line on the screen).
int Classifier::source_edge(uint32_t m, uint32_t t, const double* a, const double* b,
                            uint32_t* s_out, int* mask) {
  const uint32_t* first = by_source_.find(pair_key(m, t));
  if (!first)
    bad("a fragment of mesh " + std::to_string(m) + " triangle " + std::to_string(t) +
        " has no screen triangle");
  *s_out = *first;
  int found = -1;
  if (mask) *mask = 0;
  const double g = st_.grid_scale;
  for (uint32_t s = *first; s != kNone; s = next_[s]) {
    const int32_t* v = &st_.xy[6 * size_t(s)];
    for (int i = 0; i < 3; ++i) {
      const double px = v[2 * i] / g, py = v[2 * i + 1] / g;
      const double dx = v[2 * ((i + 1) % 3)] / g - px, dy = v[2 * ((i + 1) % 3) + 1] / g - py;
      const double len = std::hypot(dx, dy);
      if (!(len > 0)) continue;
      auto on = [&](const double* p) {
        const double ux = p[0] - px, uy = p[1] - py;
        if (std::abs(dx * uy - dy * ux) > kOnLine * len) return false;
        const double along = (dx * ux + dy * uy) / len;
        return along >= -kOnLine && along <= len + kOnLine;
      };
      if (!on(a) || !on(b)) continue;
      const int k = edges_of(s)[i];
      if (found == -1) {
        if (k < 0 && !mask) return -1;
        *s_out = s;
        found = k < 0 ? -2 : k;
      }
      if (!mask) return found;
      if (k >= 0) *mask |= 1 << k;
    }
  }
  return found < 0 ? -1 : found;
}

// The nearness at (x, y) pixels on screen triangle s's depth plane.
double Classifier::nearness(uint32_t s, double x, double y) const {
  const double g = st_.grid_scale;
  const int32_t* v = &st_.xy[6 * size_t(s)];
  const double* q = &st_.depth[3 * size_t(s)];
  const double x0 = v[0] / g, y0 = v[1] / g, x1 = v[2] / g, y1 = v[3] / g, x2 = v[4] / g,
               y2 = v[5] / g;
  const double d = (x1 - x0) * (y2 - y0) - (x2 - x0) * (y1 - y0);
  if (!(d != 0)) return q[0];
  const double l1 = ((x - x0) * (y2 - y0) - (x2 - x0) * (y - y0)) / d;
  const double l2 = ((x1 - x0) * (y - y0) - (x - x0) * (y1 - y0)) / d;
  return q[0] + l1 * (q[1] - q[0]) + l2 * (q[2] - q[0]);
}

}  // namespace vismap::lines_detail
