// SVG writer: one <path> per source triangle (one subpath per fragment), grouped by mesh.
//
// Numbers: every vertex is rounded once to 1/100 pixel (an integer count of "units"); the first
// point of a path is written absolute, the rest as exact differences of those integers (relative
// "m"/"l"), printed with at most 2 decimals, trailing zeros and leading "0" dropped, and no
// separator where the grammar allows it ("1.5-2", "1.5.5"). A vertex that two fragments share is
// the same double, hence the same integer, so every path reconstructs it to the same decimal
// value: no cracks from formatting. A vertex that lies on a neighbour's edge without being one
// of its vertices (a T-junction: an occluder's edge against the fragments it hides) would round
// off that edge and open a gap up to 1/200 px wide, which crispEdges (Fill::Id) shows as
// background specks; there it is inserted into the neighbour's edge (conform_t_junctions), and
// Fill::Shade strokes such edges instead (below). See svg_number(). Why 2 decimals, not 3: 1/100 px
// is far below what anyone sees even zoomed 10x (the binary format keeps full float precision for
// programs), and it saves a byte per number: ~6 bytes per triangle, which is what keeps a
// 60k-fragment bunny under 3 MB.
//
// Seams (Fill::Shade): anti-aliasing rasterizers composite each path on its own, so two paths
// that abut exactly leave a faint line where background shows through ("conflation": coverage
// a and 1-a compose to 1-a(1-a), 75% at a half-covered pixel). We hide it by stroking each
// fragment edge that another fragment shares, in the fill colour, 1 device pixel wide
// (vector-effect: non-scaling-stroke where supported). Silhouette edges (shared with nobody)
// are not stroked, so outlines are not fattened: a fragment's unshared edge is made the
// implicit closing segment of an open subpath (filled, not stroked); with several unshared
// edges the fragment is written as centre-fan pieces whose stroked sides are interior. Edges
// that meet another fragment along a T-junction (an occluder's edge against the fragments it
// hides) count as shared when fragments of the opposite direction cover half of their length.
// Measured with rsvg-convert on a mid-grey square of 288 triangles: without stroke seams lift
// interior pixels from 128 to 171; with a 1 px stroke on every edge to 131 but outlines gain
// half a pixel; with shared-edge strokes only, interior 131 and outline pixels equal to a
// single-polygon reference (tests/test_output.cpp checks the structure).
//
// Fill::Id: fill = global source triangle id + 1 as #RRGGBB, shape-rendering="crispEdges",
// no stroke (aliased rendering has no conflation seams).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <unordered_map>
#include <unordered_set>
#include <vector>

#include "core/conform.h"
#include "core/error.h"
#include "core/output.h"
#include "core/output_internal.h"

namespace vismap {

namespace {

constexpr int kDecimals = 2;
constexpr int64_t kUnit = kDecimals == 2 ? 100 : 1000;  // units per pixel
static_assert(kDecimals == 2 || kDecimals == 3);
constexpr double kScale = double(kUnit);
constexpr double kAmbient = 0.12;  // fraction of the mesh colour that faces away still get
// T-junction collinearity tolerance in units: each end point is off its exact position by at
// most half a unit per axis (0.71 units), and so is the line through the long edge's rounded
// end points; 2 units covers both.
constexpr int64_t kTJunctionTol = 2;

struct Q {
  int64_t x, y;
  bool operator==(const Q& o) const { return x == o.x && y == o.y; }
};

int64_t quantize(double v) {
  return std::llround(v * kScale);
}

// Prints q/kUnit: "-1.25", ".5", "-.05", "3", "0".
size_t format_units(int64_t q, char* buf) {
  char* p = buf;
  uint64_t a = q < 0 ? 0 - uint64_t(q) : uint64_t(q);
  if (q < 0) *p++ = '-';
  const uint64_t ip = a / uint64_t(kUnit);
  unsigned fp = unsigned(a % uint64_t(kUnit));
  if (ip != 0 || fp == 0) p += std::snprintf(p, 24, "%llu", static_cast<unsigned long long>(ip));
  if (fp != 0) {
    *p++ = '.';
    char d[kDecimals];
    for (int i = kDecimals - 1; i >= 0; --i, fp /= 10) d[i] = char('0' + fp % 10);
    int n = kDecimals;
    while (d[n - 1] == '0') --n;
    for (int i = 0; i < n; ++i) *p++ = d[i];
  }
  return size_t(p - buf);
}

// Path data writer with the separator rules above and relative coordinates.
class PathData {
 public:
  // `stroked`: closed subpaths end with z (the stroke needs the closing edge); fill-only paths
  // leave it out, since filling closes every subpath anyway.
  PathData(std::string& out, bool stroked) : out_(out), stroked_(stroked) {}
  void move(Q q) {
    if (first_) {
      out_ += 'M';
      number(q.x, false);
      number(q.y, true);
      need_l_ = true;  // after an absolute M, implicit pairs would be absolute
      first_ = false;
    } else {
      out_ += 'm';
      number(q.x - cur_.x, false);
      number(q.y - cur_.y, true);
      need_l_ = false;  // after a relative m, implicit pairs are relative l
    }
    cur_ = start_ = q;
  }
  void line(Q q) {
    const bool cmd = need_l_;
    if (cmd) out_ += 'l';
    need_l_ = false;
    number(q.x - cur_.x, !cmd);
    number(q.y - cur_.y, true);
    cur_ = q;
  }
  void close() {
    if (!stroked_) return;  // the current point stays at the last vertex
    out_ += 'z';
    cur_ = start_;
  }

 private:
  void number(int64_t v, bool after_number) {
    char buf[32];
    const size_t n = format_units(v, buf);
    if (after_number && buf[0] != '-' && !(buf[0] == '.' && prev_dot_)) out_ += ' ';
    out_.append(buf, n);
    prev_dot_ = std::find(buf, buf + n, '.') != buf + n;
  }
  std::string& out_;
  Q cur_{0, 0}, start_{0, 0};
  bool stroked_, first_ = true, need_l_ = false, prev_dot_ = false;
};

// XML-escapes text, replacing characters XML 1.0 forbids and invalid UTF-8 with '?'.
std::string xml_escape(const std::string& s) {
  std::string r;
  for (size_t i = 0; i < s.size();) {
    const unsigned char c = static_cast<unsigned char>(s[i]);
    if (c < 0x80) {
      switch (c) {
        case '<':
          r += "&lt;";
          break;
        case '>':
          r += "&gt;";
          break;
        case '&':
          r += "&amp;";
          break;
        case '"':
          r += "&quot;";
          break;
        case '\'':
          r += "&apos;";
          break;
        default:
          r += (c < 0x20 && c != '\t' && c != '\n' && c != '\r') ? '?' : char(c);
      }
      ++i;
      continue;
    }
    const int len = c >= 0xF0 && c < 0xF5 ? 4 : c >= 0xE0 ? 3 : c >= 0xC2 && c < 0xE0 ? 2 : 0;
    bool ok = len > 0 && i + len <= s.size();
    for (int k = 1; ok && k < len; ++k) ok = (static_cast<unsigned char>(s[i + k]) & 0xC0) == 0x80;
    if (ok && len == 3) {  // no overlongs or surrogates
      const unsigned c1 = static_cast<unsigned char>(s[i + 1]);
      ok = !(c == 0xE0 && c1 < 0xA0) && !(c == 0xED && c1 >= 0xA0);
    }
    if (ok && len == 4) {
      const unsigned c1 = static_cast<unsigned char>(s[i + 1]);
      ok = !(c == 0xF0 && c1 < 0x90) && !(c == 0xF4 && c1 >= 0x90);
    }
    if (ok) {
      r.append(s, i, len);
      i += len;
    } else {
      r += '?';
      ++i;
    }
  }
  return r;
}

std::string hex_color(uint32_t rgb) {
  char buf[8];
  std::snprintf(buf, sizeof buf, "#%06x", rgb & 0xFFFFFFu);
  return buf;
}

uint8_t to_srgb8(double linear) {
  const double c = std::clamp(linear, 0.0, 1.0);
  const double s = c <= 0.0031308 ? 12.92 * c : 1.055 * std::pow(c, 1.0 / 2.4) - 0.055;
  return static_cast<uint8_t>(std::lround(s * 255.0));
}

// Lambert shade of a source triangle times the mesh colour plus ambient, as sRGB.
uint32_t shade_color(const Scene& scene, const Camera& cam, uint32_t mesh, uint32_t tri) {
  const double k = detail::lambert_shade(scene, cam, mesh, tri);
  uint32_t rgb = 0;
  for (int c = 0; c < 3; ++c) rgb = rgb << 8 | to_srgb8(scene.meshes[mesh].color[c] * k);
  return rgb;
}

struct EdgeKey {
  Q a, b;
  bool operator==(const EdgeKey& o) const { return a == o.a && b == o.b; }
};
struct EdgeHash {
  size_t operator()(const EdgeKey& k) const {
    uint64_t h = 0x9E3779B97F4A7C15ull;
    for (int64_t v : {k.a.x, k.a.y, k.b.x, k.b.y}) {
      h ^= uint64_t(v) + 0x9E3779B97F4A7C15ull + (h << 6) + (h >> 2);
      h *= 0xBF58476D1CE4E5B9ull;
    }
    return size_t(h ^ (h >> 31));
  }
};

// The map's vertices in units, consecutive duplicates removed; a fragment that collapses
// below 3 distinct points is empty (it covers nothing at this precision).
struct QuantizedMap {
  std::vector<Q> v;
  std::vector<uint32_t> off{0};  // per fragment
  std::vector<uint8_t> shared;   // per edge (same index as its first vertex): stroke it
};

QuantizedMap quantize_map(const PlanarMap& map) {
  QuantizedMap q;
  q.v.reserve(map.vertex_count());
  for (size_t f = 0; f < map.fragment_count(); ++f) {
    const size_t begin = q.v.size();
    for (uint32_t i = map.offsets[f]; i < map.offsets[f + 1]; ++i) {
      const Q p{quantize(map.xy[2 * size_t(i)]), quantize(map.xy[2 * size_t(i) + 1])};
      if (q.v.size() == begin || !(q.v.back() == p)) q.v.push_back(p);
    }
    while (q.v.size() > begin + 1 && q.v.back() == q.v[begin]) q.v.pop_back();
    if (q.v.size() - begin < 3) q.v.resize(begin);
    q.off.push_back(uint32_t(q.v.size()));
  }
  return q;
}

// The edges of a quantized map that no other edge matches exactly in reverse (an occluder's
// edge against the fragments it hides: a T-junction), bucketed in a grid of 16-pixel cells
// for partner queries; edges whose box spans more than 64 cells go to a list every query scans.
class OpenEdges {
 public:
  std::vector<EdgeKey> edge;
  std::vector<uint32_t> id, frag;  // first vertex (index into q.v) and fragment of each

  // `matched` (optional): per edge of q, set to 1 when the reverse edge exists.
  OpenEdges(const QuantizedMap& q, size_t fragments, std::vector<uint8_t>* matched) {
    auto at = [&](size_t f, uint32_t i) {
      const uint32_t b = q.off[f], n = q.off[f + 1] - b;
      return EdgeKey{q.v[b + i], q.v[b + (i + 1) % n]};
    };
    std::unordered_set<EdgeKey, EdgeHash> all;
    all.reserve(q.v.size() * 2);
    for (size_t f = 0; f < fragments; ++f)
      for (uint32_t i = 0; i < q.off[f + 1] - q.off[f]; ++i) all.insert(at(f, i));
    for (size_t f = 0; f < fragments; ++f)
      for (uint32_t i = 0; i < q.off[f + 1] - q.off[f]; ++i) {
        const EdgeKey e = at(f, i);
        if (all.count(EdgeKey{e.b, e.a})) {
          if (matched) (*matched)[q.off[f] + i] = 1;
        } else {
          edge.push_back(e);
          id.push_back(q.off[f] + i);
          frag.push_back(uint32_t(f));
        }
      }
    for (uint32_t k = 0; k < edge.size(); ++k) {
      const EdgeKey& e = edge[k];
      const int64_t x0 = cell(std::min(e.a.x, e.b.x) - kTJunctionTol),
                    x1 = cell(std::max(e.a.x, e.b.x) + kTJunctionTol),
                    y0 = cell(std::min(e.a.y, e.b.y) - kTJunctionTol),
                    y1 = cell(std::max(e.a.y, e.b.y) + kTJunctionTol);
      if ((x1 - x0 + 1) * (y1 - y0 + 1) > 64) {
        big_.push_back(k);
        continue;
      }
      for (int64_t cx = x0; cx <= x1; ++cx)
        for (int64_t cy = y0; cy <= y1; ++cy) grid_[cell_key(cx, cy)].push_back(k);
    }
  }

  // The open edges other than k that run the opposite way along the same line: both end points
  // of the shorter one within kTJunctionTol of the longer one's line.
  void partners(uint32_t k, std::vector<uint32_t>& out) {
    const EdgeKey& e = edge[k];
    cand_.assign(big_.begin(), big_.end());
    const int64_t x0 = cell(std::min(e.a.x, e.b.x)), x1 = cell(std::max(e.a.x, e.b.x)),
                  y0 = cell(std::min(e.a.y, e.b.y)), y1 = cell(std::max(e.a.y, e.b.y));
    if ((x1 - x0 + 1) * (y1 - y0 + 1) > 64) {
      cand_.resize(edge.size());
      for (uint32_t j = 0; j < edge.size(); ++j) cand_[j] = j;
    } else {
      for (int64_t cx = x0; cx <= x1; ++cx)
        for (int64_t cy = y0; cy <= y1; ++cy) {
          auto it = grid_.find(cell_key(cx, cy));
          if (it != grid_.end()) cand_.insert(cand_.end(), it->second.begin(), it->second.end());
        }
      std::sort(cand_.begin(), cand_.end());
      cand_.erase(std::unique(cand_.begin(), cand_.end()), cand_.end());
    }
    out.clear();
    const double dx = double(e.b.x - e.a.x), dy = double(e.b.y - e.a.y);
    const double len = std::hypot(dx, dy);
    for (uint32_t j : cand_) {
      if (j == k) continue;
      const EdgeKey& o = edge[j];
      const double ox = double(o.b.x - o.a.x), oy = double(o.b.y - o.a.y);
      if (dx * ox + dy * oy >= 0) continue;  // must run the opposite way
      const double olen = std::hypot(ox, oy);
      const EdgeKey& lng = len >= olen ? e : o;
      const EdgeKey& sht = len >= olen ? o : e;
      const double lx = double(lng.b.x - lng.a.x), ly = double(lng.b.y - lng.a.y);
      const double llen = std::max(len, olen);
      auto dist = [&](Q p) {
        return std::abs(lx * double(p.y - lng.a.y) - ly * double(p.x - lng.a.x)) / llen;
      };
      if (dist(sht.a) <= kTJunctionTol && dist(sht.b) <= kTJunctionTol) out.push_back(j);
    }
  }

 private:
  static constexpr int64_t kCell = 16 * kUnit;
  static int64_t cell(int64_t v) { return v >= 0 ? v / kCell : -((-v + kCell - 1) / kCell); }
  static uint64_t cell_key(int64_t cx, int64_t cy) {
    return uint64_t(cx) * 0x100000001B3ull ^ uint64_t(cy);
  }
  std::unordered_map<uint64_t, std::vector<uint32_t>> grid_;
  std::vector<uint32_t> big_, cand_;
};

// Where a fragment's edge runs along several edges of its neighbours (a T-junction), the
// neighbours' vertices lie on it in the exact map but not after rounding: each moved by up to
// half a unit, so thin gaps (and overlaps) open along the edge, which an aliased rasterizer
// (Fill::Id, crispEdges) shows as background specks where a pixel centre falls in one. So the
// neighbours' vertices strictly inside the edge are inserted into it, in order: both sides then
// pass through the same rounded points (the edge bends by at most kTJunctionTol units). Not
// inserted: a vertex the fragment already has (a sliver thinner than the tolerance would fold
// onto itself) and one within the tolerance of the edge's end points (it would spike a corner
// whose two edges both pass that close).
void conform_t_junctions(QuantizedMap& q, size_t fragments) {
  OpenEdges open(q, fragments, nullptr);
  if (open.edge.empty()) return;
  std::unordered_map<uint32_t, std::vector<std::pair<double, Q>>> insert;  // by edge id
  auto near = [](Q p, Q v) {
    return std::max(std::abs(p.x - v.x), std::abs(p.y - v.y)) <= kTJunctionTol;
  };
  std::vector<uint32_t> partners;
  for (uint32_t k = 0; k < open.edge.size(); ++k) {
    open.partners(k, partners);
    const EdgeKey& e = open.edge[k];
    const double dx = double(e.b.x - e.a.x), dy = double(e.b.y - e.a.y);
    const double len2 = dx * dx + dy * dy;
    const uint32_t f = open.frag[k];
    for (uint32_t j : partners) {
      if (open.frag[j] == f) continue;
      for (Q p : {open.edge[j].a, open.edge[j].b}) {
        if (near(p, e.a) || near(p, e.b)) continue;
        if (std::find(q.v.begin() + q.off[f], q.v.begin() + q.off[f + 1], p) !=
            q.v.begin() + q.off[f + 1])
          continue;
        const double t = (double(p.x - e.a.x) * dx + double(p.y - e.a.y) * dy) / len2;
        if (t > 0 && t < 1) insert[open.id[k]].push_back({t, p});
      }
    }
  }
  if (insert.empty()) return;
  QuantizedMap r;
  r.v.reserve(q.v.size() + insert.size() * 2);
  for (size_t f = 0; f < fragments; ++f) {
    for (uint32_t i = q.off[f]; i < q.off[f + 1]; ++i) {
      r.v.push_back(q.v[i]);
      auto it = insert.find(i);
      if (it == insert.end()) continue;
      auto& pts = it->second;
      std::sort(pts.begin(), pts.end(),
                [](const auto& a, const auto& b) { return a.first < b.first; });
      for (size_t m = 0; m < pts.size(); ++m)
        if (!(pts[m].second == r.v.back())) r.v.push_back(pts[m].second);
    }
    r.off.push_back(uint32_t(r.v.size()));
  }
  q = std::move(r);
}

// Marks the edges that another fragment shares: exactly (the reverse edge exists), or along a
// T-junction (reverse-direction collinear edges cover at least half of it).
void find_shared_edges(QuantizedMap& q, size_t fragments) {
  q.shared.assign(q.v.size(), 0);
  OpenEdges open(q, fragments, &q.shared);
  std::vector<uint32_t> partners;
  for (uint32_t k = 0; k < open.edge.size(); ++k) {
    open.partners(k, partners);
    const EdgeKey& e = open.edge[k];
    const double dx = double(e.b.x - e.a.x), dy = double(e.b.y - e.a.y);
    const double len = std::hypot(dx, dy);
    double covered = 0;
    for (uint32_t j : partners) {
      const EdgeKey& o = open.edge[j];
      // Overlap of o with e, measured along e.
      const double t0 = (double(o.a.x - e.a.x) * dx + double(o.a.y - e.a.y) * dy) / len;
      const double t1 = (double(o.b.x - e.a.x) * dx + double(o.b.y - e.a.y) * dy) / len;
      covered += std::max(0.0, std::min(len, std::max(t0, t1)) - std::max(0.0, std::min(t0, t1)));
    }
    if (covered >= 0.5 * len) q.shared[open.id[k]] = 1;
  }
}

// Writes fragment f of the quantized map. Without edge flags (Fill::Id) it is a closed polygon;
// with them, unshared edges are never stroked (see the comment at the top).
void write_fragment(PathData& d, const QuantizedMap& q, size_t f, bool use_flags) {
  const uint32_t b = q.off[f], n = q.off[f + 1] - b;
  auto at = [&](uint32_t i) { return q.v[b + i % n]; };
  uint32_t unshared = 0, longest = 0;
  double longest_len = -1, unshared_len = 0, perimeter = 0;
  if (use_flags) {
    for (uint32_t i = 0; i < n; ++i) {
      const Q u = at(i), w = at(i + 1);
      const double l = std::hypot(double(w.x - u.x), double(w.y - u.y));
      perimeter += l;
      if (q.shared[b + i]) continue;
      ++unshared;
      unshared_len += l;
      if (l > longest_len) longest_len = l, longest = i;
    }
  }
  // With several unshared edges one of them can be the implicit closing segment; the others
  // are stroked (spilling half a stroke width over the outline along their length) unless the
  // fragment is cut into centre-fan pieces, whose interior diagonals spill only near their
  // ends -- but far along them when the fragment is a sliver and a diagonal runs almost
  // parallel to an outline edge. Short other unshared edges (a sliver's tip): stroke them.
  if (unshared >= 2 && unshared_len - longest_len <= 0.1 * perimeter) unshared = 1;
  if (unshared == 0) {  // closed polygon, every edge stroked
    d.move(at(0));
    for (uint32_t i = 1; i < n; ++i) d.line(at(i));
    d.close();
    return;
  }
  if (unshared ==
      1) {  // open polygon whose implicit closing segment is the (longest) unshared edge
    for (uint32_t i = 0; i < n; ++i) {
      const Q p = at(longest + 1 + i);
      if (i == 0)
        d.move(p);
      else
        d.line(p);
    }
    return;
  }
  // Several unshared edges: runs of shared edges as fans from the centre C ("M C v_s .. v_e",
  // closing back to C), and each unshared edge (a, b) as the triangle "M b C a" closing a -> b.
  // All pieces keep the fragment's orientation, so the nonzero fill is the fragment.
  int64_t sx = 0, sy = 0;
  for (uint32_t i = 0; i < n; ++i) sx += at(i).x, sy += at(i).y;
  const Q c{sx / int64_t(n), sy / int64_t(n)};
  uint32_t start = 0;  // an edge that follows an unshared one starts a run
  while (q.shared[b + start] == 0 || q.shared[b + (start + n - 1) % n] != 0) {
    if (++start == n) break;
  }
  for (uint32_t k = 0; k < n; ++k) {
    const uint32_t i = (start + k) % n;
    if (!q.shared[b + i]) {
      d.move(at(i + 1));
      d.line(c);
      d.line(at(i));
    } else if (k == 0 || !q.shared[b + (i + n - 1) % n]) {
      d.move(c);
      d.line(at(i));
      uint32_t j = i;
      while (q.shared[b + j % n] && j - i < n) d.line(at(++j));
    }
  }
}

}  // namespace

double detail::lambert_shade(const Scene& scene, const Camera& cam, uint32_t mesh, uint32_t tri) {
  const Mesh& m = scene.meshes[mesh];
  Vec3 p[3];
  for (int k = 0; k < 3; ++k) {
    const uint32_t vi = m.indices[3 * size_t(tri) + k];
    if (vi >= m.vertex_count())
      throw InputError(InputErrorKind::IndexOutOfRange, "svg", m.name, "triangle", tri,
                       "vertex index " + std::to_string(vi) + " out of range");
    for (int c = 0; c < 3; ++c) p[k][c] = m.positions[3 * size_t(vi) + c];
  }
  const Vec3 e1{p[1][0] - p[0][0], p[1][1] - p[0][1], p[1][2] - p[0][2]};
  const Vec3 e2{p[2][0] - p[0][0], p[2][1] - p[0][1], p[2][2] - p[0][2]};
  const Vec3 n{e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
               e1[0] * e2[1] - e1[1] * e2[0]};
  Vec3 l;
  if (cam.projection == Camera::Projection::Orthographic) {
    l = {cam.eye[0] - cam.target[0], cam.eye[1] - cam.target[1], cam.eye[2] - cam.target[2]};
  } else {
    for (int c = 0; c < 3; ++c) l[c] = cam.eye[c] - (p[0][c] + p[1][c] + p[2][c]) / 3.0;
  }
  const double nn = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
  const double ll = std::sqrt(l[0] * l[0] + l[1] * l[1] + l[2] * l[2]);
  double ndl = std::abs(n[0] * l[0] + n[1] * l[1] + n[2] * l[2]) / (nn * ll);
  if (!std::isfinite(ndl)) ndl = 1.0;  // degenerate triangle or light at its centroid
  return kAmbient + (1.0 - kAmbient) * std::min(ndl, 1.0);
}

namespace {

// The lines over the fills: <g class="lines"> holding one <g class="KIND"> per kind that has
// chains, one <path> per chain. Points rounded to units as the fills' (a chain's point that is
// a fragment's vertex prints as that vertex); points that round onto the previous are skipped.
void write_lines(std::string& out, const LineSet& lines, const SvgStyle& style) {
  if (!(style.line_width > 0) || !std::isfinite(style.line_width))
    throw InputError(InputErrorKind::BadScene, "svg", "", "line width", -1,
                     "must be a positive number of pixels");
  char width[32];
  std::snprintf(width, sizeof width, "%g", style.line_width);
  out += "<g class=\"lines\" fill=\"none\" stroke-width=\"";
  out += width;
  out += "\" stroke-linecap=\"round\" stroke-linejoin=\"round\">\n";
  // The hidden parts first (under the visible ones), dashed, in a group of their own.
  for (int hidden = 1; hidden >= 0; --hidden) {
    bool any = false;
    for (size_t k = 0; k < kLineKinds; ++k) {
      bool open = false;
      for (size_t c = 0; c < lines.chain_count(); ++c) {
        if (size_t(lines.kind[c]) != k || lines.hidden[c] != hidden) continue;
        if (!any && hidden) {
          char dash[64];
          std::snprintf(dash, sizeof dash, "%g %g", 4 * style.line_width, 3 * style.line_width);
          out += std::string("<g class=\"hidden\" stroke-dasharray=\"") + dash + "\">\n";
        }
        any = true;
        if (!open) {
          out += std::string("<g class=\"") + line_kind_name(LineKind(k)) + "\" stroke=\"" +
                 hex_color(style.line_color[k]) + "\">\n";
          open = true;
        }
        out += "<path d=\"";
        PathData d(out, true);
        Q prev{0, 0};
        size_t n = 0;
        for (uint32_t i = lines.off[c]; i < lines.off[c + 1]; ++i) {
          const Q q{quantize(lines.xy[2 * i]), quantize(lines.xy[2 * i + 1])};
          if (n > 0 && q == prev) continue;
          if (n == 0)
            d.move(q);
          else
            d.line(q);
          prev = q;
          ++n;
        }
        if (n == 1) d.line(prev);  // a chain shorter than a unit: a dot (round caps draw it)
        if (lines.closed[c] && n > 2) d.close();
        out += "\"/>\n";
      }
      if (open) out += "</g>\n";
    }
    if (any && hidden) out += "</g>\n";
  }
  out += "</g>\n";
}

}  // namespace

namespace {

// --merge: the visible fragments of one mesh with the same fill joined into regions (across the
// edges they share; T-junctions inserted and near-equal vertices welded first, core/conform.h),
// each region one <path> of its boundary loops (holes are loops of the other orientation, so
// the default nonzero rule fills them right). Points that lie exactly on the straight line of
// their neighbours in units are dropped (T-junction vertices, collinear chains): a neighbour
// that keeps such a point keeps it on that line, so nothing opens. Shade: the boundary edges a
// region shares with another region are stroked in its colour (the seam cover of the
// unmerged writer) in a second path; its outline is not.
void write_merged(std::string& out, const PlanarMap& map, const Scene& scene, const Camera& camera,
                  bool shade) {
  ConformedPolygons P = conform_polygons(map, 1);
  weld_vertices(P, 1e-6);
  const size_t np = P.size();
  const std::vector<uint64_t> base = scene.triangle_id_base();
  std::vector<uint32_t> color(np);
  {
    std::unordered_map<uint64_t, uint32_t> by_source;
    for (size_t p = 0; p < np; ++p) {
      const uint32_t f = P.fragment[p], m = map.mesh[f], t = map.triangle[f];
      const uint64_t key = uint64_t(m) << 32 | t;
      auto it = by_source.find(key);
      if (it == by_source.end()) {
        uint32_t c;
        if (shade) {
          c = shade_color(scene, camera, m, t);
        } else {
          const uint64_t id = detail::global_triangle_id(map, scene, base, f) + 1;
          if (id > 0xFFFFFF)
            throw InputError(InputErrorKind::TooLarge, "svg", scene.meshes[m].name, "triangle",
                             int64_t(t), "global triangle id does not fit a 24-bit --fill id colour");
          c = uint32_t(id);
        }
        it = by_source.emplace(key, c).first;
      }
      color[p] = it->second;
    }
  }
  auto mesh_of = [&](size_t p) { return map.mesh[P.fragment[p]]; };
  auto ekey = [](uint32_t a, uint32_t b) { return uint64_t(a) << 32 | b; };
  std::unordered_map<uint64_t, uint32_t> edge;  // directed edge -> polygon
  edge.reserve(P.v.size() * 2);
  for (uint32_t p = 0; p < np; ++p)
    for (uint32_t i = P.off[p], n = P.off[p + 1]; i < n; ++i)
      edge.emplace(ekey(P.v[i], P.v[i + 1 < n ? i + 1 : P.off[p]]), p);
  std::vector<uint32_t> root(np);
  for (uint32_t p = 0; p < np; ++p) root[p] = p;
  auto find = [&](uint32_t p) {
    while (root[p] != p) p = root[p] = root[root[p]];
    return p;
  };
  for (uint32_t p = 0; p < np; ++p)
    for (uint32_t i = P.off[p], n = P.off[p + 1]; i < n; ++i) {
      auto it = edge.find(ekey(P.v[i + 1 < n ? i + 1 : P.off[p]], P.v[i]));
      if (it == edge.end()) continue;
      const uint32_t q = it->second;
      if (mesh_of(q) != mesh_of(p) || color[q] != color[p]) continue;
      const uint32_t a = find(p), b = find(q);
      if (a != b) root[std::max(a, b)] = std::min(a, b);
    }
  // Boundary edges of each region: (region, from, to, shared with another region).
  struct B {
    uint32_t region, a, b;
    bool shared;
  };
  std::vector<B> bd;
  for (uint32_t p = 0; p < np; ++p)
    for (uint32_t i = P.off[p], n = P.off[p + 1]; i < n; ++i) {
      const uint32_t a = P.v[i], b = P.v[i + 1 < n ? i + 1 : P.off[p]];
      auto it = edge.find(ekey(b, a));
      if (it != edge.end() && find(it->second) == find(p)) continue;
      bd.push_back({find(p), a, b, it != edge.end()});
    }
  // Regions in the writer's order: mesh, then colour.
  std::sort(bd.begin(), bd.end(), [&](const B& x, const B& y) {
    const uint32_t mx = mesh_of(x.region), my = mesh_of(y.region);
    if (mx != my) return mx < my;
    if (color[x.region] != color[y.region]) return color[x.region] < color[y.region];
    if (x.region != y.region) return x.region < y.region;
    return x.a < y.a;
  });
  std::vector<uint8_t> used(bd.size(), 0);
  std::vector<uint32_t> loop_v;
  std::vector<uint8_t> loop_shared;
  std::vector<Q> pts;
  std::vector<uint8_t> pshared;
  std::string fills, strokes;
  for (size_t i = 0; i < bd.size();) {
    const uint32_t mesh = mesh_of(bd[i].region);
    out += "<g><title>" + xml_escape(scene.meshes[mesh].name) + "</title>\n";
    while (i < bd.size() && mesh_of(bd[i].region) == mesh) {
      const uint32_t c = color[bd[i].region];
      if (shade) out += "<g color=\"" + hex_color(c) + "\">\n";
      while (i < bd.size() && mesh_of(bd[i].region) == mesh && color[bd[i].region] == c) {
        const uint32_t r = bd[i].region;
        size_t j = i;
        while (j < bd.size() && bd[j].region == r) ++j;
        // Boundary edges of region r are bd[i, j), sorted by their start vertex.
        auto next_from = [&](uint32_t v) -> size_t {
          size_t lo = std::lower_bound(bd.begin() + i, bd.begin() + j, v,
                                       [](const B& e, uint32_t x) { return e.a < x; }) - bd.begin();
          for (; lo < j && bd[lo].a == v; ++lo)
            if (!used[lo]) return lo;
          return j;
        };
        fills.clear();
        strokes.clear();
        bool every_edge_shared = shade;  // then one path, filled and stroked, does both
        for (size_t e = i; e < j; ++e) every_edge_shared = every_edge_shared && bd[e].shared;
        PathData fd(fills, every_edge_shared), sd(strokes, true);
        for (size_t e = i; e < j; ++e) {
          if (used[e]) continue;
          loop_v.clear();
          loop_shared.clear();
          for (size_t k = e; k < j && !used[k]; k = next_from(bd[k].b)) {
            used[k] = 1;
            loop_v.push_back(bd[k].a);
            loop_shared.push_back(bd[k].shared);
          }
          // In units; drop repeats and points on their neighbours' line (edge k runs from
          // point k to point k+1; a dropped point's two edges become one, shared if either was).
          pts.clear();
          pshared.clear();
          for (size_t k = 0; k < loop_v.size(); ++k) {
            const Q q{quantize(P.xy[2 * loop_v[k]]), quantize(P.xy[2 * loop_v[k] + 1])};
            if (!pts.empty() && pts.back() == q) {
              pshared.back() = pshared.back() | loop_shared[k];
              continue;
            }
            pts.push_back(q);
            pshared.push_back(loop_shared[k]);
          }
          while (pts.size() > 1 && pts.back() == pts.front()) {
            pshared[pshared.size() - 2] = pshared[pshared.size() - 2] | pshared.back();
            pts.pop_back();
            pshared.pop_back();
          }
          for (bool changed = true; changed && pts.size() >= 3;) {
            changed = false;
            for (size_t k = 0; k < pts.size() && pts.size() >= 3; ++k) {
              const size_t a = (k + pts.size() - 1) % pts.size(), b = (k + 1) % pts.size();
              const __int128 o = __int128(pts[k].x - pts[a].x) * (pts[b].y - pts[a].y) -
                                 __int128(pts[k].y - pts[a].y) * (pts[b].x - pts[a].x);
              const bool on = o == 0 && (pts[k].x - pts[a].x) * (pts[b].x - pts[k].x) >= 0 &&
                              (pts[k].y - pts[a].y) * (pts[b].y - pts[k].y) >= 0;
              if (!on || pshared[a] != pshared[k]) continue;  // keep where stroking changes
              pts.erase(pts.begin() + k);
              pshared.erase(pshared.begin() + k);
              changed = true;
              --k;
            }
          }
          if (pts.size() < 3) continue;
          fd.move(pts[0]);
          for (size_t k = 1; k < pts.size(); ++k) fd.line(pts[k]);
          fd.close();
          if (!shade || every_edge_shared) continue;
          // Shared runs, as open subpaths.
          const size_t n = pts.size();
          bool all = true;
          for (uint8_t v : pshared) all = all && v;
          if (all) {
            sd.move(pts[0]);
            for (size_t k = 1; k < n; ++k) sd.line(pts[k]);
            sd.close();
            continue;
          }
          size_t s0 = 0;  // an edge whose predecessor is not shared: runs start at or after it
          while (pshared[(s0 + n - 1) % n]) ++s0;
          for (size_t k = 0; k < n; ++k) {
            const size_t a = (s0 + k) % n;
            if (!pshared[a]) continue;
            if (!pshared[(a + n - 1) % n]) sd.move(pts[a]);
            sd.line(pts[(a + 1) % n]);
          }
        }
        if (!fills.empty()) {
          if (every_edge_shared)
            out += "<path d=\"" + fills + "\"/>\n";
          else if (shade)
            out += "<path stroke=\"none\" d=\"" + fills + "\"/>\n";
          else
            out += "<path fill=\"" + hex_color(c) + "\" d=\"" + fills + "\"/>\n";
          if (!strokes.empty()) out += "<path fill=\"none\" d=\"" + strokes + "\"/>\n";
        }
        i = j;
      }
      if (shade) out += "</g>\n";
    }
    out += "</g>\n";
  }
}

}  // namespace

std::string svg_number(double v) {
  char buf[32];
  return std::string(buf, format_units(quantize(v), buf));
}

std::string write_svg(const PlanarMap& map, const Scene& scene, const Camera& camera, Fill fill) {
  return write_svg(map, scene, camera, fill, SvgStyle{});
}

std::string write_svg(const PlanarMap& map, const Scene& scene, const Camera& camera, Fill fill,
                      const SvgStyle& style) {
  detail::check_map(map, scene, "svg");
  if (!style.fill) {
    std::string out;
    const std::string w = std::to_string(map.width), h = std::to_string(map.height);
    out += "<svg xmlns=\"http://www.w3.org/2000/svg\" viewBox=\"0 0 " + w + " " + h +
           "\" width=\"" + w + "\" height=\"" + h +
           "\">\n<style>path{vector-effect:non-scaling-stroke}</style>\n";
    if (style.lines) write_lines(out, *style.lines, style);
    return out + "</svg>\n";
  }
  const size_t nf = map.fragment_count();
  const std::vector<uint64_t> base = scene.triangle_id_base();

  // Fragments ordered by (mesh, triangle), stable: one path per source triangle.
  std::vector<uint32_t> order(nf);
  for (uint32_t f = 0; f < nf; ++f) order[f] = f;
  std::stable_sort(order.begin(), order.end(), [&](uint32_t a, uint32_t b) {
    return map.mesh[a] != map.mesh[b] ? map.mesh[a] < map.mesh[b]
                                      : map.triangle[a] < map.triangle[b];
  });

  QuantizedMap q = quantize_map(map);
  const bool shade = fill == Fill::Shade;
  // Shade strokes the T-junction edges (find_shared_edges), which covers their gaps; Id has no
  // stroke, so its T-junctions are made conforming (which costs ~25 ms on the bunny's 30k
  // fragments and, for millions of fragments, a second copy of the vertices).
  if (shade)
    find_shared_edges(q, nf);
  else
    conform_t_junctions(q, nf);

  std::string out;
  out.reserve(64 + q.v.size() * 12 + nf * 16);
  const std::string w = std::to_string(map.width), h = std::to_string(map.height);
  out += "<svg xmlns=\"http://www.w3.org/2000/svg\" viewBox=\"0 0 " + w + " " + h + "\" width=\"" +
         w + "\" height=\"" + h + "\"";
  if (shade) {
    out +=
        ">\n<style>path{vector-effect:non-scaling-stroke}</style>\n"
        "<g fill=\"currentColor\" stroke=\"currentColor\" stroke-width=\"1\" "
        "stroke-linejoin=\"bevel\">\n";
  } else {
    out += " shape-rendering=\"crispEdges\">\n";
  }

  if (style.merge) {
    write_merged(out, map, scene, camera, shade);
  } else {
    // One record per source triangle that has something to draw.
    struct PathRec {
      uint32_t mesh, tri, color;
      size_t first, last;  // range in `order`
    };
    std::vector<PathRec> paths;
    for (size_t i = 0; i < nf;) {
      const uint32_t mesh = map.mesh[order[i]], tri = map.triangle[order[i]];
      size_t j = i;
      bool any = false;
      for (; j < nf && map.mesh[order[j]] == mesh && map.triangle[order[j]] == tri; ++j)
        any = any || q.off[order[j] + 1] > q.off[order[j]];
      if (any) {
        uint32_t color;
        if (shade) {
          color = shade_color(scene, camera, mesh, tri);
        } else {
          const uint64_t id = detail::global_triangle_id(map, scene, base, order[i]) + 1;
          if (id > 0xFFFFFF)
            throw InputError(InputErrorKind::TooLarge, "svg", scene.meshes[mesh].name, "triangle",
                             int64_t(tri),
                             "global triangle id " + std::to_string(id - 1) +
                                 " does not fit a 24-bit --fill id colour");
          color = uint32_t(id);
        }
        paths.push_back({mesh, tri, color, i, j});
      }
      i = j;
    }
    // Shade: paths of one colour share a <g color=...> (a mesh has at most a few hundred 8-bit
    // shades), which keeps the per-path overhead to `<path d=""/>`. Drawing order does not
    // matter in a map of depth complexity one.
    if (shade)
      std::stable_sort(paths.begin(), paths.end(), [](const PathRec& a, const PathRec& b) {
        return a.mesh != b.mesh ? a.mesh < b.mesh : a.color < b.color;
      });

    for (size_t i = 0; i < paths.size();) {
      const uint32_t mesh = paths[i].mesh;
      out += "<g><title>" + xml_escape(scene.meshes[mesh].name) + "</title>\n";
      for (; i < paths.size() && paths[i].mesh == mesh;) {
        const uint32_t color = paths[i].color;
        if (shade) out += "<g color=\"" + hex_color(color) + "\">\n";
        for (; i < paths.size() && paths[i].mesh == mesh && (!shade || paths[i].color == color);
             ++i) {
          out += shade ? "<path d=\"" : "<path fill=\"" + hex_color(paths[i].color) + "\" d=\"";
          PathData d(out, shade);
          for (size_t k = paths[i].first; k < paths[i].last; ++k)
            if (q.off[order[k] + 1] > q.off[order[k]]) write_fragment(d, q, order[k], shade);
          out += "\"/>\n";
        }
        if (shade) out += "</g>\n";
      }
      out += "</g>\n";
    }
  }
  if (shade) out += "</g>\n";
  if (style.lines) {
    if (!shade) out += "<style>path{vector-effect:non-scaling-stroke}</style>\n";
    write_lines(out, *style.lines, style);
  }
  out += "</svg>\n";
  return out;
}

}  // namespace vismap
