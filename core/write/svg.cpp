// SVG writer: one <path> per source triangle (one subpath per fragment), grouped by mesh. The
// paths, their seam strokes and colours come from core/write/paths.h (shared with the cairo
// writers); this file prints them.
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
// Fill::Shade strokes such edges instead (core/write/paths.cpp). See svg_number(). Why 2
// decimals, not 3: 1/100 px is far below what anyone sees even zoomed 10x (the binary format
// keeps full float precision for programs), and it saves a byte per number: ~6 bytes per
// triangle, which is what keeps a 60k-fragment bunny under 3 MB.
//
// Fill::Shade: each path is also stroked in its fill colour along the edges it shares, 1 device
// pixel wide (vector-effect: non-scaling-stroke), which hides the conflation seams
// (core/write/paths.cpp measures them). Fill::Id: shape-rendering="crispEdges", no stroke.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <unordered_map>
#include <vector>

#include "core/error.h"
#include "core/util/conform.h"
#include "core/write/output.h"
#include "core/write/paths.h"
#include "core/write/shared.h"

namespace vismap {

namespace {

using detail::kUnit;
using detail::Q;
using detail::quantize;
using detail::write_fragment;
constexpr int kDecimals = 2;
static_assert(kUnit == 100, "format_units prints kDecimals digits");

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
class PathData final : public detail::PathSink {
 public:
  // `stroked`: closed subpaths end with z (the stroke needs the closing edge); fill-only paths
  // leave it out, since filling closes every subpath anyway.
  PathData(std::string& out, bool stroked) : out_(out), stroked_(stroked) {}
  void move(Q q) override {
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
  void line(Q q) override {
    const bool cmd = need_l_;
    if (cmd) out_ += 'l';
    need_l_ = false;
    number(q.x - cur_.x, !cmd);
    number(q.y - cur_.y, true);
    cur_ = q;
  }
  void close() override {
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

// The lines over the fills: <g class="lines"> holding one <g class="KIND"> per kind that has
// chains, one <path> per chain. Points rounded to units as the fills' (a chain's point that is
// a fragment's vertex prints as that vertex); points that round onto the previous are skipped,
// and a chain whose points all round to one is not drawn: a line shorter than the output's unit
// (1/100 px) is no line (it was drawn as a dot of the line's width, "M649.53 824.9l0 0", where a
// crossing line passes a rounding's length between two silhouettes; issue 45).
void write_lines(std::string& out, const LineSet& lines, const SvgStyle& style) {
  if (!(style.line_width > 0) || !std::isfinite(style.line_width))
    throw InputError(InputErrorKind::BadScene, "svg", "", "line width", -1,
                     "must be a positive number of pixels");
  char width[32];
  std::snprintf(width, sizeof width, "%g", style.line_width);
  out += "<g class=\"lines\" fill=\"none\" stroke-width=\"";
  out += width;
  out += "\" stroke-linecap=\"round\" stroke-linejoin=\"round\">\n";
  std::vector<Q> pts;
  // The hidden parts first (under the visible ones), dashed, in a group of their own.
  for (int hidden = 1; hidden >= 0; --hidden) {
    bool any = false;
    for (size_t k = 0; k < kLineKinds; ++k) {
      bool open = false;
      for (size_t c = 0; c < lines.chain_count(); ++c) {
        if (size_t(lines.kind[c]) != k || lines.hidden[c] != hidden) continue;
        detail::chain_points(lines, c, pts);
        if (pts.size() < 2) continue;  // shorter than a unit: nothing to draw (issue 45)
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
        d.move(pts[0]);
        for (size_t i = 1; i < pts.size(); ++i) d.line(pts[i]);
        if (lines.closed[c] && pts.size() > 2) d.close();
        out += "\"/>\n";
      }
      if (open) out += "</g>\n";
    }
    if (any && hidden) out += "</g>\n";
  }
  out += "</g>\n";
}

// --merge: the visible fragments of one mesh with the same fill joined into regions (across the
// edges they share; T-junctions inserted and near-equal vertices welded first,
// core/util/conform.h), each region one <path> of its boundary loops (holes are loops of the other
// orientation, so the default nonzero rule fills them right). Points that lie exactly on the
// straight line of their neighbours in units are dropped (T-junction vertices, collinear chains): a
// neighbour that keeps such a point keeps it on that line, so nothing opens. Shade: the boundary
// edges a region shares with another region are stroked in its colour (the seam cover of the
// unmerged writer) in a second path; its outline is not.
struct MergedRegions {
  const PlanarMap& map;
  ConformedPolygons P;
  std::vector<uint32_t> color;  // per polygon: its fill
  struct Edge {                 // a boundary edge of a region
    uint32_t region, a, b;
    bool shared;                // with another region
  };
  std::vector<Edge> bd;         // in the writer's order: mesh, colour, region, start vertex
  uint32_t mesh_of(size_t p) const { return map.mesh[P.fragment[p]]; }
};

MergedRegions merge_regions(const PlanarMap& map, const Scene& scene, const Camera& camera,
                            bool shade) {
  MergedRegions R{map, conform_polygons(map, 1), {}, {}};
  ConformedPolygons& P = R.P;
  weld_vertices(P, 1e-6);
  const size_t np = P.size();
  const std::vector<uint64_t> base = scene.triangle_id_base();
  std::vector<uint32_t>& color = R.color;
  color.resize(np);
  {
    std::unordered_map<uint64_t, uint32_t> by_source;
    for (size_t p = 0; p < np; ++p) {
      const uint32_t f = P.fragment[p], m = map.mesh[f], t = map.triangle[f];
      const uint64_t key = uint64_t(m) << 32 | t;
      auto it = by_source.find(key);
      if (it == by_source.end())
        it = by_source.emplace(key, detail::fill_color(map, scene, camera, shade, base, f, "svg"))
                 .first;
      color[p] = it->second;
    }
  }
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
      if (R.mesh_of(q) != R.mesh_of(p) || color[q] != color[p]) continue;
      const uint32_t a = find(p), b = find(q);
      if (a != b) root[std::max(a, b)] = std::min(a, b);
    }
  for (uint32_t p = 0; p < np; ++p)
    for (uint32_t i = P.off[p], n = P.off[p + 1]; i < n; ++i) {
      const uint32_t a = P.v[i], b = P.v[i + 1 < n ? i + 1 : P.off[p]];
      auto it = edge.find(ekey(b, a));
      if (it != edge.end() && find(it->second) == find(p)) continue;
      R.bd.push_back({find(p), a, b, it != edge.end()});
    }
  using Edge = MergedRegions::Edge;
  std::sort(R.bd.begin(), R.bd.end(), [&](const Edge& x, const Edge& y) {
    const uint32_t mx = R.mesh_of(x.region), my = R.mesh_of(y.region);
    if (mx != my) return mx < my;
    if (color[x.region] != color[y.region]) return color[x.region] < color[y.region];
    if (x.region != y.region) return x.region < y.region;
    return x.a < y.a;
  });
  return R;
}

// One boundary loop in units: repeats dropped, and points on their neighbours' line (edge k runs
// from point k to point k+1; a dropped point's two edges become one, shared if either was).
void loop_points(const ConformedPolygons& P, const std::vector<uint32_t>& loop_v,
                 const std::vector<uint8_t>& loop_shared, std::vector<Q>& pts,
                 std::vector<uint8_t>& pshared) {
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
}

// The shared runs of a loop (edge k from point k to k + 1), as open subpaths; the whole loop
// closed when every edge is shared.
void stroke_shared(PathData& sd, const std::vector<Q>& pts, const std::vector<uint8_t>& pshared) {
  const size_t n = pts.size();
  bool all = true;
  for (uint8_t v : pshared) all = all && v;
  if (all) {
    sd.move(pts[0]);
    for (size_t k = 1; k < n; ++k) sd.line(pts[k]);
    sd.close();
    return;
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

// Region bd[i, j) (its boundary edges, sorted by start vertex) as its <path>s, fill colour c.
class RegionWriter {
 public:
  RegionWriter(const MergedRegions& R, bool shade) : R_(R), shade_(shade), used_(R.bd.size(), 0) {}

  void write(std::string& out, size_t i, size_t j, uint32_t c) {
    const auto& bd = R_.bd;
    fills_.clear();
    strokes_.clear();
    bool every_edge_shared = shade_;  // then one path, filled and stroked, does both
    for (size_t e = i; e < j; ++e) every_edge_shared = every_edge_shared && bd[e].shared;
    PathData fd(fills_, every_edge_shared), sd(strokes_, true);
    for (size_t e = i; e < j; ++e) {
      if (used_[e]) continue;
      loop_v_.clear();
      loop_shared_.clear();
      for (size_t k = e; k < j && !used_[k]; k = next_from(bd[k].b, i, j)) {
        used_[k] = 1;
        loop_v_.push_back(bd[k].a);
        loop_shared_.push_back(bd[k].shared);
      }
      loop_points(R_.P, loop_v_, loop_shared_, pts_, pshared_);
      if (pts_.size() < 3) continue;
      fd.move(pts_[0]);
      for (size_t k = 1; k < pts_.size(); ++k) fd.line(pts_[k]);
      fd.close();
      if (shade_ && !every_edge_shared) stroke_shared(sd, pts_, pshared_);
    }
    if (fills_.empty()) return;
    if (every_edge_shared)
      out += "<path d=\"" + fills_ + "\"/>\n";
    else if (shade_)
      out += "<path stroke=\"none\" d=\"" + fills_ + "\"/>\n";
    else
      out += "<path fill=\"" + hex_color(c) + "\" d=\"" + fills_ + "\"/>\n";
    if (!strokes_.empty()) out += "<path fill=\"none\" d=\"" + strokes_ + "\"/>\n";
  }

 private:
  // The first unused boundary edge of bd[i, j) starting at vertex v, or j.
  size_t next_from(uint32_t v, size_t i, size_t j) const {
    const auto& bd = R_.bd;
    size_t lo = std::lower_bound(bd.begin() + i, bd.begin() + j, v,
                                 [](const MergedRegions::Edge& e, uint32_t x) { return e.a < x; }) -
                bd.begin();
    for (; lo < j && bd[lo].a == v; ++lo)
      if (!used_[lo]) return lo;
    return j;
  }

  const MergedRegions& R_;
  const bool shade_;
  std::vector<uint8_t> used_;
  std::vector<uint32_t> loop_v_;
  std::vector<uint8_t> loop_shared_, pshared_;
  std::vector<Q> pts_;
  std::string fills_, strokes_;
};

void write_merged(std::string& out, const PlanarMap& map, const Scene& scene, const Camera& camera,
                  bool shade) {
  const MergedRegions R = merge_regions(map, scene, camera, shade);
  const auto& bd = R.bd;
  RegionWriter region(R, shade);
  // A group per mesh (titled), in it (shade) a group per colour, in that a region's paths each.
  for (size_t i = 0; i < bd.size();) {
    const uint32_t mesh = R.mesh_of(bd[i].region);
    out += "<g><title>" + xml_escape(scene.meshes[mesh].name) + "</title>\n";
    while (i < bd.size() && R.mesh_of(bd[i].region) == mesh) {
      const uint32_t c = R.color[bd[i].region];
      if (shade) out += "<g color=\"" + hex_color(c) + "\">\n";
      while (i < bd.size() && R.mesh_of(bd[i].region) == mesh && R.color[bd[i].region] == c) {
        const uint32_t r = bd[i].region;
        size_t j = i;
        while (j < bd.size() && bd[j].region == r) ++j;
        region.write(out, i, j, c);
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
  if (style.merge) {
    const bool shade = fill == Fill::Shade;
    std::string out;
    const std::string w = std::to_string(map.width), h = std::to_string(map.height);
    out += "<svg xmlns=\"http://www.w3.org/2000/svg\" viewBox=\"0 0 " + w + " " + h +
           "\" width=\"" + w + "\" height=\"" + h + "\"";
    out += shade ? ">\n<style>path{vector-effect:non-scaling-stroke}</style>\n"
                   "<g fill=\"currentColor\" stroke=\"currentColor\" stroke-width=\"1\" "
                   "stroke-linejoin=\"bevel\">\n"
                 : " shape-rendering=\"crispEdges\">\n";
    write_merged(out, map, scene, camera, shade);
    if (shade) out += "</g>\n";
    if (style.lines) {
      if (!shade) out += "<style>path{vector-effect:non-scaling-stroke}</style>\n";
      write_lines(out, *style.lines, style);
    }
    return out + "</svg>\n";
  }
  const detail::FillPlan plan = detail::plan_fills(map, scene, camera, fill, "svg");
  const detail::QuantizedMap& q = plan.q;
  const std::vector<uint32_t>& order = plan.order;
  const std::vector<detail::TrianglePath>& paths = plan.paths;
  const bool shade = plan.stroke_seams;

  std::string out;
  out.reserve(64 + q.v.size() * 12 + map.fragment_count() * 16);
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

  // Shade: paths of one colour (plan_fills puts them together) share a <g color=...>, which
  // keeps the per-path overhead to `<path d=""/>`.
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
  if (shade) out += "</g>\n";
  if (style.lines) {
    if (!shade) out += "<style>path{vector-effect:non-scaling-stroke}</style>\n";
    write_lines(out, *style.lines, style);
  }
  out += "</svg>\n";
  return out;
}

}  // namespace vismap
