// What a view may take of a scene's facts (scene_facts.h): the clearance it needs for the crossing
// search to skip a pair, and how many triangles pass it.
#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include "core/facts/scene_facts.h"
#include "kernels/layout.h"

namespace vismap::facts {

double apart_fraction(const SceneFacts& facts, double need) {
  if (facts.clearance.empty()) return 0;
  uint64_t n = 0;
  for (int k = 0; k < 63; ++k)
    if (std::ldexp(facts.cap, -(k + 1)) >= need) n += facts.clearance_bins[k];
  return double(n) / double(facts.clearance.size());
}

double crossing_skip_distance(const SceneFacts& facts, const Camera& cam, double* qmax) {
  constexpr double kOff = std::numeric_limits<double>::infinity();
  if (qmax) *qmax = kOff;
  if (!(facts.cap > 0) || cam.projection != Camera::Projection::Perspective) return kOff;
  const double n = cam.near_plane, far = cam.far_plane;
  if (!(n > 0) || !(far > n)) return kOff;
  // The nearest and farthest depth w (clip w: distance along the view axis) of any point of a
  // screen triangle: the scene's box (w is affine; its extremes are at corners) within the
  // near and far planes.
  const Mat4 vp = cam.view_projection();
  double wlo = kOff, whi = -kOff;
  for (int c = 0; c < 8; ++c) {
    const double x = (c & 1) ? facts.bounds.hi[0] : facts.bounds.lo[0];
    const double y = (c & 2) ? facts.bounds.hi[1] : facts.bounds.lo[1];
    const double z = (c & 4) ? facts.bounds.hi[2] : facts.bounds.lo[2];
    const double w = vp[3] * x + vp[7] * y + vp[11] * z + vp[15];
    wlo = std::min(wlo, w);
    whi = std::max(whi, w);
  }
  const double wmin = std::max(wlo, n), wmax = std::min(whi, far);
  if (!(wmax >= wmin)) return kOff;  // nothing of the scene in depth range
  const double cot = 1.0 / std::tan(cam.fov_y_deg * std::numbers::pi / 360.0);
  const double aspect = double(cam.width) / double(cam.height);
  // Grid units per unit of tangent (square pixels), and the longest ray per unit of depth
  // within the frustum (the screen triangles are clipped to it).
  const double K = cot * cam.height * VM_GRID_SCALE / 2;
  const double L = std::sqrt(1 + (aspect / cot) * (aspect / cot) + 1 / (cot * cot));
  // NUMERICS §2 "Pairs far apart in 3D": a point of a snapped triangle is within E of the
  // unsnapped triangle (a vertex snap of <= 0.75 grid units, at most wmax deep; depth-plane
  // snapping of 2^-24 of the largest nearness, in depth, along a ray); two triangles farther
  // apart than 2E + L dw are at least dw apart in depth along every ray through both, and
  // dw >= (1e-6 + 2^-18) wmax^2 / wmin keeps their nearness difference past the tie band
  // (1e-6 of the largest nearness) and the overlap's rounding (the kernels leave out
  // triangles steeper than 16 qmax per grid unit).
  const double E = 0.75 * wmax / K + std::ldexp(wmax * wmax / wmin, -23) * L;
  const double dw = (1e-6 + std::ldexp(1.0, -18)) * wmax * wmax / wmin;
  const double need = (2 * E + L * dw) * (1 + std::ldexp(1.0, -20)) +
                      std::ldexp(facts.coordinate_max + std::fabs(cam.eye[0]) +
                                     std::fabs(cam.eye[1]) + std::fabs(cam.eye[2]),
                                 -36);
  if (qmax) *qmax = 1.0 / wmin;
  if (!(need < facts.cap)) return kOff;  // no clearance can pass it
  return need;
}

}  // namespace vismap::facts
