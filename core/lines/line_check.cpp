// check_lines (core/lines/line_check.h): the drawing against a supersampled id raster.
#include "core/lines/line_check.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "core/error.h"
#include "core/lines/topology.h"

namespace vismap {

namespace {

using lines_detail::Topology;

[[noreturn]] void bad(const std::string& what) {
  throw InputError(InputErrorKind::ParseError, "lines check", "", "raster", -1, what);
}

// Which surfaces two raster ids belong to: global input triangle index -> (mesh, triangle).
class Surfaces {
 public:
  explicit Surfaces(const Scene& scene) : scene_(scene), first_(scene.meshes.size() + 1, 0) {
    for (size_t m = 0; m < scene.meshes.size(); ++m)
      first_[m + 1] = first_[m] + scene.meshes[m].triangle_count();
    topo_.resize(scene.meshes.size());
  }
  // Do the triangles a and b (~0u: background) belong to different surfaces?
  bool apart(uint32_t a, uint32_t b) {
    if (a == b) return false;
    if (a == ~0u || b == ~0u) return true;
    uint32_t ma, ta, mb, tb;
    locate(a, ma, ta);
    locate(b, mb, tb);
    if (ma != mb) return true;
    return !topo_[ma].within_two_rings(scene_.meshes[ma], ta, tb);
  }

 private:
  void locate(uint32_t id, uint32_t& m, uint32_t& t) {
    if (id >= first_.back())
      bad("the id raster names triangle " + std::to_string(id) + ", past the scene's");
    m = uint32_t(std::upper_bound(first_.begin(), first_.end(), uint64_t(id)) - first_.begin() - 1);
    t = uint32_t(id - first_[m]);
    if (!topo_[m].built) topo_[m].build(scene_.meshes[m]);
  }
  const Scene& scene_;
  std::vector<uint64_t> first_;
  std::vector<Topology> topo_;
};

double seg_dist(double px, double py, double ax, double ay, double bx, double by) {
  const double dx = bx - ax, dy = by - ay, l2 = dx * dx + dy * dy;
  const double t = l2 > 0 ? std::clamp(((px - ax) * dx + (py - ay) * dy) / l2, 0.0, 1.0) : 0;
  return std::hypot(px - ax - t * dx, py - ay - t * dy);
}

// Calls f(ax, ay, bx, by) for each segment of the chains that the check looks at.
template <class F>
void for_each_checked_segment(const LineSet& L, F&& f) {
  for (size_t c = 0; c < L.chain_count(); ++c) {
    if (L.kind[c] == LineKind::Crease || (!L.hidden.empty() && L.hidden[c])) continue;
    const uint32_t n = L.off[c + 1] - L.off[c];
    const uint32_t segs = L.closed[c] ? n : n - 1;
    for (uint32_t s = 0; s < segs; ++s) {
      const uint32_t i = L.off[c] + s, j = L.off[c] + (s + 1) % n;
      f(L.xy[2 * i], L.xy[2 * i + 1], L.xy[2 * j], L.xy[2 * j + 1]);
    }
  }
}

}  // namespace

LineCheck check_lines(const LineSet& lines, const std::vector<uint32_t>& ids, uint32_t width,
                      uint32_t height, uint32_t factor, const Scene& scene, double radius,
                      std::vector<uint8_t>* image) {
  if (factor == 0) bad("a supersampling factor of 0");
  const size_t F = factor, W = size_t(width) * F, H = size_t(height) * F;
  if (ids.size() != W * H) bad("an id raster of the wrong size");
  LineCheck r;
  r.factor = factor;
  r.radius = radius;
  Surfaces surfaces(scene);
  // Reference points, on the sample grid's half steps: point (2x + 1, 2y) lies between samples
  // (x, y) and (x + 1, y), point (2x, 2y + 1) between (x, y) and (x, y + 1). Kept per sample
  // (bit 0: to the right, bit 1: below), and per sample whether a line is within the radius.
  std::vector<uint8_t> ref(W * H, 0);
  for (size_t y = 0; y < H; ++y)
    for (size_t x = 0; x < W; ++x) {
      const uint32_t a = ids[y * W + x];
      if (x + 1 < W && surfaces.apart(a, ids[y * W + x + 1])) ref[y * W + x] |= 1;
      if (y + 1 < H && surfaces.apart(a, ids[(y + 1) * W + x])) ref[y * W + x] |= 2;
    }
  // A point in pixels of each reference point: sample (x, y) is at ((x + 0.5) / F, ...).
  auto point = [F](size_t x, size_t y, int dir, double& px, double& py) {
    px = (double(x) + (dir == 1 ? 1.0 : 0.5)) / F;
    py = (double(y) + (dir == 2 ? 1.0 : 0.5)) / F;
  };
  // Which reference points have a line within the radius: marked per sample and direction.
  std::vector<uint8_t> covered(W * H, 0);
  const double reach = radius + 1.0 / F;
  for_each_checked_segment(lines, [&](double ax, double ay, double bx, double by) {
    const long x0 = std::max(0L, long(std::floor((std::min(ax, bx) - reach) * F)));
    const long x1 = std::min(long(W) - 1, long(std::floor((std::max(ax, bx) + reach) * F)));
    const long y0 = std::max(0L, long(std::floor((std::min(ay, by) - reach) * F)));
    const long y1 = std::min(long(H) - 1, long(std::floor((std::max(ay, by) + reach) * F)));
    for (long y = y0; y <= y1; ++y)
      for (long x = x0; x <= x1; ++x) {
        const uint8_t rf = ref[size_t(y) * W + x];
        for (int dir = 1; dir <= 2; ++dir) {
          if (!(rf & dir) || (covered[size_t(y) * W + x] & dir)) continue;
          double px, py;
          point(size_t(x), size_t(y), dir, px, py);
          if (seg_dist(px, py, ax, ay, bx, by) <= radius)
            covered[size_t(y) * W + x] |= uint8_t(dir);
        }
      }
  });
  if (image) image->assign(size_t(width) * height, 0);
  for (size_t y = 0; y < H; ++y)
    for (size_t x = 0; x < W; ++x)
      for (int dir = 1; dir <= 2; ++dir) {
        if (!(ref[y * W + x] & dir)) continue;
        ++r.reference_points;
        const bool hit = covered[y * W + x] & dir;
        r.reference_near_line += hit;
        if (image) {
          double px, py;
          point(x, y, dir, px, py);
          const size_t pix = size_t(std::min<double>(py, height - 1)) * width +
                             size_t(std::min<double>(px, width - 1));
          (*image)[pix] |= kRefPoint | (hit ? 0 : kRefMissed);
        }
      }
  // Precision: the drawn length, sampled every 1/4 px, each sample standing for its share.
  const long rs = long(std::ceil(radius * F)) + 1;
  for_each_checked_segment(lines, [&](double ax, double ay, double bx, double by) {
    const double len = std::hypot(bx - ax, by - ay);
    const int k = std::max(1, int(std::ceil(len * 4)));
    for (int q = 0; q < k; ++q) {
      const double t = (q + 0.5) / k, sx = ax + t * (bx - ax), sy = ay + t * (by - ay);
      const long cx = long(std::floor(sx * F)), cy = long(std::floor(sy * F));
      bool ok = false;
      for (long y = std::max(0L, cy - rs); y <= std::min(long(H) - 1, cy + rs) && !ok; ++y)
        for (long x = std::max(0L, cx - rs); x <= std::min(long(W) - 1, cx + rs) && !ok; ++x)
          for (int dir = 1; dir <= 2 && !ok; ++dir) {
            if (!(ref[size_t(y) * W + x] & dir)) continue;
            double px, py;
            point(size_t(x), size_t(y), dir, px, py);
            ok = std::hypot(px - sx, py - sy) <= radius;
          }
      r.line_px += len / k;
      if (ok) r.line_near_reference += len / k;
      if (image && sx >= 0 && sy >= 0 && sx < width && sy < height)
        (*image)[size_t(sy) * width + size_t(sx)] |= kDrawn | (ok ? 0 : kDrawnUnsupported);
    }
  });
  return r;
}

}  // namespace vismap
