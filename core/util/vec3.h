// Vectors of three doubles (camera.h's Vec3): the few operations the camera and the scene facts
// share.
#pragma once

#include <array>
#include <cmath>

namespace vismap::vec3 {

using V = std::array<double, 3>;

inline V sub(const V& a, const V& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
inline V add(const V& a, const V& b) { return {a[0] + b[0], a[1] + b[1], a[2] + b[2]}; }
inline V scale(const V& a, double s) { return {a[0] * s, a[1] * s, a[2] * s}; }
inline double dot(const V& a, const V& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
inline V cross(const V& a, const V& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
inline double length(const V& a) { return std::sqrt(dot(a, a)); }

}  // namespace vismap::vec3
