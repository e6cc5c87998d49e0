#include "core/surfaces/implicit2d.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <unordered_map>
#include <unordered_set>

#include "core/device/cl_runtime.h"
#include "core/error.h"
#include "core/surfaces/implicit.h"
#include "core/util/clock.h"

namespace vismap::implicit {

namespace {

using P2 = std::array<double, 2>;

struct Key {
  int64_t i, j;
  int dir;  // 0: the edge (i, j)-(i+1, j); 1: (i, j)-(i, j+1); 2: a corner
  bool operator==(const Key& o) const { return i == o.i && j == o.j && dir == o.dir; }
};
struct KeyHash {
  size_t operator()(const Key& k) const {
    return size_t((uint64_t(k.i) * 0x9E3779B97F4A7C15ull) ^ (uint64_t(k.j) * 0xC2B2AE3D27D4EB4Full) ^
                  uint64_t(k.dir));
  }
};

double signed_area(const std::vector<P2>& l) {
  double a = 0;
  for (size_t i = 0, n = l.size(); i < n; ++i) {
    const P2 &p = l[i], &q = l[(i + 1) % n];
    a += p[0] * q[1] - q[0] * p[1];
  }
  return a / 2;
}

bool inside(const std::vector<P2>& l, const P2& p) {  // even-odd crossing test
  bool in = false;
  for (size_t i = 0, n = l.size(), j = n - 1; i < n; j = i++) {
    const P2 &a = l[i], &b = l[j];
    if ((a[1] > p[1]) != (b[1] > p[1]) &&
        p[0] < (b[0] - a[0]) * (p[1] - a[1]) / (b[1] - a[1]) + a[0])
      in = !in;
  }
  return in;
}

}  // namespace

bool uses_z(const Tape& t) {
  for (const Clause& c : t.clauses)
    if (c.op == Op::Z) return true;
  return false;
}

Regions2D contour_2d(ClRuntime& rt, const Tape& tape, const View2D& v, double tolerance_px,
                     const std::function<void()>& check_time, uint64_t max_bytes) {
  // Long on purpose (~150 lines): MPR's 2D mode as the steps the comments below name (cell size,
  // the queue, corners, crossings, segments, loops, components), each a loop over the arrays the
  // step before it made.
  if (uses_z(tape))
    throw InputError(InputErrorKind::BadScene, "", "", "", -1,
                     "the expression uses z: the 2D mode draws expressions in x and y alone");
  if (!(v.x1 > v.x0) || !(v.y1 > v.y0) || !std::isfinite(v.x1 - v.x0) || !std::isfinite(v.y1 - v.y0))
    throw InputError(InputErrorKind::BadCamera, "", "", "", -1, "the 2D window is empty or not finite");
  if (!(tolerance_px > 0)) throw InputError(InputErrorKind::BadCamera, "", "", "", -1, "tolerance must be > 0");
  Regions2D out;
  const auto t0 = Clock::now();
  const double sx = v.width / (v.x1 - v.x0), sy = v.height / (v.y1 - v.y0);
  // Cell side h (expression units) with a diagonal of at most the tolerance in pixels: every
  // point drawn lies in a cell that f = 0 crosses, so within one diagonal of the curve.
  const double h_max = tolerance_px / std::sqrt(sx * sx + sy * sy);
  const double size = std::max(v.x1 - v.x0, v.y1 - v.y0);
  std::vector<uint32_t> splits;
  double h = size;
  while (h > h_max) {
    const uint32_t s = h / 4 >= h_max ? 4 : (h / 2 >= h_max ? 2 : (h / 4 > h_max / 2 ? 4 : 2));
    splits.push_back(s);
    h /= s;
    if (splits.size() > 40)
      throw InputError(InputErrorKind::TooLarge, "", "", "", -1, "the tolerance needs more than 40 levels");
  }
  out.cell_px = h * std::max(sx, sy);
  // The window inset by half a cell: its edges then run through cells, not along them.
  const double wlo[3] = {v.x0 + h / 2, v.y0 + h / 2, 0}, whi[3] = {v.x1 - h / 2, v.y1 - h / 2, 0};
  const Tape clipped = clipped_to_box(tape, wlo, whi, 2);
  const SlotTape st = allocate_slots(clipped);
  const float lo[3] = {float(v.x0), float(v.y0), 0.f};
  const surfaces::ImplicitQueue q =
      surfaces::run_implicit_queue(rt, st, lo, float(size), 2, splits, max_bytes, {}, check_time);
  for (const auto& r : q.rounds) {
    out.clauses_per_round.push_back(r.clauses);
    out.full_cells += r.full;
  }
  out.leaves = q.leaves.size();
  // Corners on the grid of side h from (x0, y0): the same integer corner gives the same float
  // point, so cells that share it evaluate it alike.
  std::vector<int64_t> cell(2 * q.leaves.size());
  std::vector<float> xyz;
  xyz.reserve(q.leaves.size() * 12);
  for (size_t k = 0; k < q.leaves.size(); ++k) {
    const VmIRegion& L = q.leaves[k];
    cell[2 * k] = std::llround((L.lo[0] - v.x0) / h);
    cell[2 * k + 1] = std::llround((L.lo[1] - v.y0) / h);
    for (int c = 0; c < 4; ++c) {
      const int64_t i = cell[2 * k] + (c == 1 || c == 2), j = cell[2 * k + 1] + (c >= 2);
      xyz.insert(xyz.end(), {float(v.x0 + double(i) * h), float(v.y0 + double(j) * h), 0.f});
    }
  }
  const std::vector<float> val = surfaces::eval_leaf_points(rt, st, q, xyz, 4, nullptr, check_time);
  out.queue_ms = ms_since(t0);
  const auto t1 = Clock::now();
  // Corner values by grid index (every copy of a corner holds the same value: the shortened
  // tapes compute the full tape's operations on the same float point).
  std::unordered_map<Key, float, KeyHash> corner;
  corner.reserve(q.leaves.size() * 2);
  for (size_t k = 0; k < q.leaves.size(); ++k)
    for (int c = 0; c < 4; ++c)
      corner.emplace(Key{cell[2 * k] + (c == 1 || c == 2), cell[2 * k + 1] + (c >= 2), 2}, val[4 * k + c]);
  auto point_of = [&](int64_t i, int64_t j) {
    return P2{double(float(v.x0 + double(i) * h)), double(float(v.y0 + double(j) * h))};
  };
  // The crossing on an edge, from its lower corner A and upper corner B alone.
  auto crossing = [&](const Key& e) {
    const int64_t bi = e.i + (e.dir == 0), bj = e.j + (e.dir == 1);
    const double fa = corner.at(Key{e.i, e.j, 2}), fb = corner.at(Key{bi, bj, 2});
    const P2 a = point_of(e.i, e.j), b = point_of(bi, bj);
    const double t = fa / (fa - fb);
    const double x = a[0] + t * (b[0] - a[0]), y = a[1] + t * (b[1] - a[1]);
    return P2{(x - v.x0) * sx, (v.y1 - y) * sy};
  };
  std::unordered_map<Key, Key, KeyHash> next;  // segment start edge -> end edge
  next.reserve(q.leaves.size() * 2);
  for (size_t k = 0; k < q.leaves.size(); ++k) {
    const int64_t i = cell[2 * k], j = cell[2 * k + 1];
    const float f[4] = {val[4 * k], val[4 * k + 1], val[4 * k + 2], val[4 * k + 3]};  // CCW
    const bool in[4] = {f[0] < 0, f[1] < 0, f[2] < 0, f[3] < 0};
    const Key edge[4] = {{i, j, 0}, {i + 1, j, 1}, {i, j + 1, 0}, {i, j, 1}};
    int exits[2], entries[2], ne = 0, nn = 0;
    for (int e = 0; e < 4; ++e) {
      if (in[e] && !in[(e + 1) % 4]) exits[ne++] = e;
      if (!in[e] && in[(e + 1) % 4]) entries[nn++] = e;
    }
    if (ne == 0) continue;
    const bool center_in = (double(f[0]) + f[1] + f[2] + f[3]) < 0;
    for (int x = 0; x < ne; ++x) {
      int partner = entries[0];
      if (ne == 2) {  // a saddle: solid through the centre joins each exit to the next entry
        const int want = center_in ? (exits[x] + 1) % 4 : (exits[x] + 3) % 4;
        partner = entries[0] == want ? entries[0] : entries[1];
      }
      next[edge[exits[x]]] = edge[partner];
    }
  }
  if (check_time) check_time();
  // Loops: follow the segments; each crossing starts one segment and ends one.
  std::unordered_set<Key, KeyHash> seen;
  for (const auto& [start, unused] : next) {
    if (seen.count(start)) continue;
    std::vector<P2> loop;
    Key e = start;
    for (;;) {
      seen.insert(e);
      const P2 p = crossing(e);
      if (loop.empty() || p != loop.back()) loop.push_back(p);
      auto it = next.find(e);
      if (it == next.end())
        throw std::logic_error("implicit 2D: a contour does not close (a crossing without a segment)");
      e = it->second;
      if (e == start) break;
    }
    while (loop.size() > 1 && loop.front() == loop.back()) loop.pop_back();
    if (loop.size() >= 3) out.loops.push_back(std::move(loop));
  }
  // Components: an outer loop (solid on its left in the plane: clockwise on the y-down screen,
  // negative area there) and the holes whose smallest enclosing outer loop it is.
  std::vector<double> area(out.loops.size());
  std::vector<std::array<double, 4>> box(out.loops.size());
  std::vector<uint32_t> outers;
  for (size_t l = 0; l < out.loops.size(); ++l) {
    area[l] = signed_area(out.loops[l]);
    std::array<double, 4> b{1e300, 1e300, -1e300, -1e300};
    for (const P2& p : out.loops[l])
      b = {std::min(b[0], p[0]), std::min(b[1], p[1]), std::max(b[2], p[0]), std::max(b[3], p[1])};
    box[l] = b;
    if (area[l] < 0) outers.push_back(uint32_t(l));
  }
  std::sort(outers.begin(), outers.end(), [&](uint32_t a, uint32_t b) { return area[a] > area[b]; });
  std::vector<int64_t> region_of(out.loops.size(), -1);
  for (uint32_t o : outers) {
    region_of[o] = int64_t(out.regions.size());
    out.regions.push_back({o});
  }
  for (size_t l = 0; l < out.loops.size(); ++l) {
    if (area[l] < 0) continue;
    const P2 p = out.loops[l][0];
    int64_t best = -1;
    for (uint32_t o : outers) {  // smallest first (sorted by area, negative: largest |area| last)
      const auto& b = box[o];
      if (p[0] < b[0] || p[0] > b[2] || p[1] < b[1] || p[1] > b[3]) continue;
      if (inside(out.loops[o], p)) {
        best = o;
        break;
      }
    }
    if (best >= 0) out.regions[size_t(region_of[size_t(best)])].push_back(uint32_t(l));
  }
  out.contour_ms = ms_since(t1);
  return out;
}

std::string write_svg_2d(const Regions2D& r, const View2D& v, const std::string& color) {
  std::string s = "<svg xmlns=\"http://www.w3.org/2000/svg\" viewBox=\"0 0 " + std::to_string(v.width) +
                  " " + std::to_string(v.height) + "\" width=\"" + std::to_string(v.width) +
                  "\" height=\"" + std::to_string(v.height) + "\">\n<g fill=\"" + color +
                  "\" fill-rule=\"nonzero\">\n";
  char buf[64];
  for (const auto& region : r.regions) {
    s += "<path d=\"";
    for (uint32_t l : region) {
      // On the 1/100 px grid of the output: repeated points go, and so does every point that lies
      // exactly on the line of its kept neighbours (straight runs become one segment).
      std::vector<std::array<long, 2>> q;
      for (const P2& p : r.loops[l]) {
        const std::array<long, 2> g{std::lround(p[0] * 100), std::lround(p[1] * 100)};
        if (q.empty() || g != q.back()) q.push_back(g);
      }
      while (q.size() > 1 && q.front() == q.back()) q.pop_back();
      std::vector<std::array<long, 2>> k;
      for (size_t i = 0; i < q.size(); ++i) {
        const auto& b = q[i];
        const auto& c = q[(i + 1) % q.size()];
        if (!k.empty()) {
          const auto& a = k.back();
          const long cross = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
          const long dot = (b[0] - a[0]) * (c[0] - b[0]) + (b[1] - a[1]) * (c[1] - b[1]);
          if (cross == 0 && dot >= 0) continue;  // b on the segment a..c
        }
        k.push_back(b);
      }
      if (k.size() < 3) continue;
      for (size_t i = 0; i < k.size(); ++i) {
        std::snprintf(buf, sizeof buf, "%s%.2f %.2f", i ? "L" : "M", k[i][0] / 100.0, k[i][1] / 100.0);
        s += buf;
      }
      s += "Z";
    }
    s += "\"/>\n";
  }
  s += "</g>\n</svg>\n";
  return s;
}

}  // namespace vismap::implicit
