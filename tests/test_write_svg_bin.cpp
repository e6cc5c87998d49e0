// Writers: SVG (well-formed, one path per source triangle, id colours, number formatting,
// seam strokes only on shared edges, exact shared vertices) and the binary format (round trip,
// malformed input, size).
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <map>
#include <random>
#include <regex>
#include <set>
#include <string>
#include <vector>

#include "core/error.h"
#include "core/write/output.h"

using namespace vismap;

namespace {

// ---- fixtures -------------------------------------------------------------------------------

Mesh make_mesh(std::string name, std::vector<float> pos, std::vector<uint32_t> idx,
               std::vector<uint32_t> face_ids, uint32_t source_triangles) {
  Mesh m;
  m.name = std::move(name);
  m.positions = std::move(pos);
  m.indices = std::move(idx);
  m.face_ids = std::move(face_ids);
  m.source_triangles = source_triangles;
  return m;
}

// Mesh 0 (name needing escapes): two triangles in the z=0 plane, source faces 0 and 2 (face 1
// was dropped). Mesh 1: one triangle, face 0. Global ids: 0, 2, 3.
Scene two_mesh_scene() {
  Scene s;
  s.meshes.push_back(make_mesh("quad <&>\"'\x01\xff", {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0},
                               {0, 1, 2, 0, 2, 3}, {0, 2}, 3));
  s.meshes.push_back(make_mesh("second", {0, 0, -1, 1, 0, -1, 0, 1, -1}, {0, 1, 2}, {0}, 1));
  return s;
}

void add_fragment(PlanarMap& m, uint32_t mesh, uint32_t tri,
                  std::vector<std::pair<double, double>> pts) {
  for (auto [x, y] : pts) {
    m.xy.push_back(x);
    m.xy.push_back(y);
  }
  m.offsets.push_back(uint32_t(m.xy.size() / 2));
  m.mesh.push_back(mesh);
  m.triangle.push_back(tri);
}

// A 10x10 square at (10.1, 20.2) made of four fragments (positive shoelace, y down):
//   mesh 0 triangle 0 split into two fragments (0 and 3), mesh 0 triangle 1 (fragment 2),
//   mesh 1 triangle 0 (fragment 1), with a T-junction: fragment 2's left edge runs from
//   (10.1,30.2) to (10.1,20.2)... see the picture in the test that uses the edges.
PlanarMap square_map() {
  PlanarMap m;
  m.width = 64;
  m.height = 48;
  const double x0 = 10.1, x1 = 15.1, x2 = 20.1, y0 = 20.2, y1 = 25.2, y2 = 30.2;
  // Left column x0..x1: fragment 0 = top half (mesh0 tri0), fragment 3 = bottom half (mesh0 tri0).
  // Right column x1..x2: fragment 1 = top half (mesh1), fragment 2 = bottom half (mesh0 tri1).
  add_fragment(m, 0, 0, {{x0, y0}, {x1, y0}, {x1, y1}, {x0, y1}});
  add_fragment(m, 1, 0, {{x1, y0}, {x2, y0}, {x2, y1}, {x1, y1}});
  add_fragment(m, 0, 1, {{x1, y1}, {x2, y1}, {x2, y2}, {x1, y2}});
  add_fragment(m, 0, 0, {{x0, y1}, {x1, y1}, {x1, y2}, {x0, y2}});
  return m;
}

Camera eye_camera() {
  Camera c;
  c.eye = {0.5, 0.5, 5};
  c.target = {0.5, 0.5, 0};
  c.near_plane = 1;
  c.far_plane = 10;
  c.width = 64;
  c.height = 48;
  return c;
}

// ---- a small XML well-formedness check ----------------------------------------------------

std::string xml_error(const std::string& s) {
  std::vector<std::string> stack;
  size_t i = 0;
  auto name_char = [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_' || c == ':' ||
           c == '.';
  };
  auto check_text = [&](size_t a, size_t b) -> std::string {
    for (size_t k = a; k < b; ++k) {
      if (s[k] == '<') return "'<' in text or attribute at " + std::to_string(k);
      if (s[k] == '&') {
        static const std::regex ent("&(lt|gt|amp|quot|apos|#[0-9]+|#x[0-9a-fA-F]+);");
        std::smatch mm;
        std::string rest = s.substr(k, 12);
        if (!std::regex_search(rest, mm, ent) || mm.position(0) != 0)
          return "bad entity at " + std::to_string(k);
      }
      const unsigned char c = static_cast<unsigned char>(s[k]);
      if (c < 0x20 && c != '\t' && c != '\n' && c != '\r')
        return "control character at " + std::to_string(k);
    }
    return "";
  };
  bool root_seen = false;
  while (i < s.size()) {
    if (s[i] != '<') {
      size_t j = s.find('<', i);
      if (j == std::string::npos) j = s.size();
      if (stack.empty() && s.find_first_not_of(" \t\r\n", i) < j) return "text outside root";
      if (auto e = check_text(i, j); !e.empty()) return e;
      i = j;
      continue;
    }
    if (s.compare(i, 4, "<!--") == 0) {
      size_t j = s.find("-->", i + 4);
      if (j == std::string::npos) return "unterminated comment";
      if (s.substr(i + 4, j - i - 4).find("--") != std::string::npos) return "-- in comment";
      i = j + 3;
      continue;
    }
    if (s.compare(i, 2, "<?") == 0) {
      i = s.find("?>", i);
      if (i == std::string::npos) return "unterminated PI";
      i += 2;
      continue;
    }
    const bool closing = s.compare(i, 2, "</") == 0;
    size_t j = i + (closing ? 2 : 1);
    size_t n0 = j;
    while (j < s.size() && name_char(s[j])) ++j;
    const std::string name = s.substr(n0, j - n0);
    if (name.empty()) return "empty tag name at " + std::to_string(i);
    if (closing) {
      while (j < s.size() && std::isspace(static_cast<unsigned char>(s[j]))) ++j;
      if (j >= s.size() || s[j] != '>') return "bad closing tag at " + std::to_string(i);
      if (stack.empty() || stack.back() != name) return "mismatched </" + name + ">";
      stack.pop_back();
      i = j + 1;
      continue;
    }
    if (stack.empty() && root_seen) return "second root element";
    root_seen = true;
    std::set<std::string> attrs;
    while (true) {
      const size_t ws = j;
      while (j < s.size() && std::isspace(static_cast<unsigned char>(s[j]))) ++j;
      if (j >= s.size()) return "unterminated tag";
      if (s[j] == '>') {
        stack.push_back(name);
        ++j;
        break;
      }
      if (s.compare(j, 2, "/>") == 0) {
        j += 2;
        break;
      }
      if (ws == j) return "no space before attribute at " + std::to_string(j);
      size_t a0 = j;
      while (j < s.size() && name_char(s[j])) ++j;
      const std::string an = s.substr(a0, j - a0);
      if (an.empty() || j + 1 >= s.size() || s[j] != '=' || (s[j + 1] != '"' && s[j + 1] != '\''))
        return "bad attribute at " + std::to_string(a0);
      if (!attrs.insert(an).second) return "duplicate attribute " + an;
      const char q = s[j + 1];
      const size_t v0 = j + 2, v1 = s.find(q, v0);
      if (v1 == std::string::npos) return "unterminated attribute";
      if (auto e = check_text(v0, v1); !e.empty()) return e;
      j = v1 + 1;
    }
    i = j;
  }
  if (!stack.empty()) return "unclosed <" + stack.back() + ">";
  if (!root_seen) return "no root element";
  return "";
}

// python3's XML parser as a second opinion, when a system python is there.
void expect_python_parses(const std::string& svg) {
  if (std::system("test -x /usr/bin/python3") != 0) return;
  char path[] = "/tmp/vismap_svg_XXXXXX";
  const int fd = mkstemp(path);
  ASSERT_GE(fd, 0);
  {
    std::ofstream f(path, std::ios::binary);
    f << svg;
  }
  const std::string cmd = std::string(
                              "/usr/bin/python3 -c \"import sys,xml.etree.ElementTree as E; "
                              "r=E.parse(sys.argv[1]).getroot(); "
                              "sys.exit(0 if r.tag.endswith('svg') else 1)\" ") +
                          path + " 2>/dev/null";
  EXPECT_EQ(std::system(cmd.c_str()), 0) << "python3 xml.etree rejects the SVG";
  std::remove(path);
  ::close(fd);
}

// ---- path data ------------------------------------------------------------------------------

// One subpath in milli-pixels: its points and whether it was closed with z.
struct Subpath {
  std::vector<std::pair<int64_t, int64_t>> pts;
  bool closed = false;
};

// Parses the path data write_svg emits (M m l z, implicit pairs) exactly, in milli-pixels.
std::vector<Subpath> parse_d(const std::string& d) {
  std::vector<Subpath> out;
  size_t i = 0;
  char cmd = 0;
  int64_t cx = 0, cy = 0, sx = 0, sy = 0;
  auto number = [&]() -> int64_t {
    while (i < d.size() && d[i] == ' ') ++i;
    const size_t a = i;
    if (i < d.size() && d[i] == '-') ++i;
    bool dot = false;
    while (i < d.size() &&
           (std::isdigit(static_cast<unsigned char>(d[i])) || (d[i] == '.' && !dot))) {
      dot = dot || d[i] == '.';
      ++i;
    }
    const std::string t = d.substr(a, i - a);
    EXPECT_FALSE(t.empty() || t == "-") << "bad number at " << a << " in " << d;
    return std::llround(std::stod(t) * 1000.0);
  };
  while (i < d.size()) {
    const char c = d[i];
    if (c == 'M' || c == 'm' || c == 'l' || c == 'L') {
      cmd = c;
      ++i;
    } else if (c == 'z' || c == 'Z') {
      EXPECT_FALSE(out.empty());
      if (!out.empty()) out.back().closed = true;
      cx = sx, cy = sy;
      cmd = 0;
      ++i;
      continue;
    } else if (c == ' ') {
      ++i;
      continue;
    }
    EXPECT_NE(cmd, 0) << "number without a command in " << d;
    if (cmd == 0) return out;
    const int64_t x = number(), y = number();
    const bool rel = cmd == 'm' || cmd == 'l';
    const int64_t ax = rel ? cx + x : x, ay = rel ? cy + y : y;
    if (cmd == 'M' || cmd == 'm') {
      out.push_back({});
      sx = ax, sy = ay;
      cmd = cmd == 'M' ? 'L' : 'l';
    }
    out.back().pts.push_back({ax, ay});
    cx = ax, cy = ay;
  }
  return out;
}

struct SvgPath {
  std::string color;  // fill= or color= value
  std::vector<Subpath> subpaths;
};

// Paths in document order with their colour: their own fill, or the enclosing <g color>.
std::vector<SvgPath> paths_of(const std::string& svg) {
  static const std::regex re(
      "<g color=\"(#[0-9a-f]{6})\">|<path (?:fill=\"(#[0-9a-f]{6})\" )?d=\"([^\"]*)\"/>");
  std::vector<SvgPath> r;
  std::string group;
  for (auto it = std::sregex_iterator(svg.begin(), svg.end(), re); it != std::sregex_iterator();
       ++it) {
    if ((*it)[1].matched) {
      group = (*it)[1].str();
      continue;
    }
    r.push_back({(*it)[2].matched ? (*it)[2].str() : group, parse_d((*it)[3].str())});
  }
  return r;
}

double signed_area(const Subpath& s) {  // milli-pixel^2, implicitly closed
  double a = 0;
  for (size_t k = 0; k < s.pts.size(); ++k) {
    const auto& p = s.pts[k];
    const auto& q = s.pts[(k + 1) % s.pts.size()];
    a += double(p.first) * double(q.second) - double(q.first) * double(p.second);
  }
  return a / 2;
}

using Seg = std::pair<std::pair<int64_t, int64_t>, std::pair<int64_t, int64_t>>;

// Segments a renderer strokes: explicit ones, plus the closing one of closed subpaths.
std::multiset<Seg> stroked(const std::vector<SvgPath>& paths) {
  std::multiset<Seg> r;
  for (const SvgPath& p : paths)
    for (const Subpath& s : p.subpaths) {
      for (size_t k = 0; k + 1 < s.pts.size(); ++k) r.insert({s.pts[k], s.pts[k + 1]});
      if (s.closed) r.insert({s.pts.back(), s.pts.front()});
    }
  return r;
}

bool has_segment(const std::multiset<Seg>& s, std::pair<int64_t, int64_t> a,
                 std::pair<int64_t, int64_t> b) {
  return s.count({a, b}) + s.count({b, a}) > 0;
}

size_t count(const std::string& s, const std::string& what) {
  size_t n = 0;
  for (size_t i = s.find(what); i != std::string::npos; i = s.find(what, i + 1)) ++n;
  return n;
}

}  // namespace

// ---- SVG ------------------------------------------------------------------------------------

TEST(Svg, NumberFormatting) {
  EXPECT_EQ(svg_number(0.5), ".5");
  EXPECT_EQ(svg_number(-0.5), "-.5");
  EXPECT_EQ(svg_number(3.0), "3");
  EXPECT_EQ(svg_number(0.0), "0");
  EXPECT_EQ(svg_number(-0.0), "0");
  EXPECT_EQ(svg_number(-0.0004), "0");
  EXPECT_EQ(svg_number(12.3456), "12.35");
  EXPECT_EQ(svg_number(-0.07), "-.07");
  EXPECT_EQ(svg_number(-2.25), "-2.25");
  EXPECT_EQ(svg_number(1000000.1), "1000000.1");
  EXPECT_EQ(svg_number(0.25), ".25");
  EXPECT_EQ(svg_number(0.004), "0");
  // Equal doubles print equal text, whichever way they were computed.
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-100, 2000);
  for (int k = 0; k < 1000; ++k) {
    const double v = u(rng);
    double w;
    std::memcpy(&w, &v, sizeof v);
    EXPECT_EQ(svg_number(v), svg_number(w));
    EXPECT_NEAR(std::stod(svg_number(v)), v, 0.005 + 1e-9);
  }
}

TEST(Svg, WellFormedXmlBothFills) {
  const Scene s = two_mesh_scene();
  for (Fill fill : {Fill::Shade, Fill::Id}) {
    const std::string svg = write_svg(square_map(), s, eye_camera(), fill);
    EXPECT_EQ(xml_error(svg), "") << svg;
    expect_python_parses(svg);
    EXPECT_NE(svg.find("viewBox=\"0 0 64 48\" width=\"64\" height=\"48\""), std::string::npos);
    EXPECT_NE(svg.find("xmlns=\"http://www.w3.org/2000/svg\""), std::string::npos);
    // The mesh name is escaped, and invalid characters replaced.
    EXPECT_NE(svg.find("quad &lt;&amp;&gt;&quot;&apos;??"), std::string::npos) << svg;
  }
  // The checker itself catches what it should.
  EXPECT_NE(xml_error("<svg><g></svg>"), "");
  EXPECT_NE(xml_error("<svg a=\"<\"/>"), "");
  EXPECT_NE(xml_error("<svg>a & b</svg>"), "");
}

TEST(Svg, OnePathPerSourceTriangle) {
  const Scene s = two_mesh_scene();
  for (Fill fill : {Fill::Shade, Fill::Id}) {
    const std::string svg = write_svg(square_map(), s, eye_camera(), fill);
    const auto paths = paths_of(svg);
    ASSERT_EQ(paths.size(), 3u) << svg;  // (mesh0,tri0) (mesh0,tri1) (mesh1,tri0)
    EXPECT_EQ(count(svg, "<path"), 3u);
    // Mesh 0 triangle 0 has two fragments -> two subpaths; order is mesh, then triangle (in
    // shade mode the seam handling may cut a fragment into several pieces).
    if (fill == Fill::Id) {
      EXPECT_EQ(paths[0].subpaths.size(), 2u);
      EXPECT_EQ(paths[1].subpaths.size(), 1u);
      EXPECT_EQ(paths[2].subpaths.size(), 1u);
    }
    // Each path fills exactly its fragments: 2 x 25 px^2, 25, 25 (in milli-pixel^2, y down
    // positive), whatever pieces the seam handling cut them into.
    auto area = [](const SvgPath& p) {
      double a = 0;
      for (const auto& sp : p.subpaths) {
        EXPECT_GE(signed_area(sp), 0) << "a piece is reversed";
        a += signed_area(sp);
      }
      return a;
    };
    EXPECT_NEAR(area(paths[0]), 50e6, 1);
    EXPECT_NEAR(area(paths[1]), 25e6, 1);
    EXPECT_NEAR(area(paths[2]), 25e6, 1);
    EXPECT_EQ(count(svg, "<g>"), 2u) << "one group per mesh";
  }
}

TEST(Svg, IdFillIsGlobalIdPlusOne) {
  const Scene s = two_mesh_scene();
  const std::string svg = write_svg(square_map(), s, eye_camera(), Fill::Id);
  const auto paths = paths_of(svg);
  ASSERT_EQ(paths.size(), 3u);
  EXPECT_EQ(paths[0].color, "#000001");  // mesh 0 face 0
  EXPECT_EQ(paths[1].color, "#000003");  // mesh 0 face 2
  EXPECT_EQ(paths[2].color, "#000004");  // mesh 1 face 0, base 3
  EXPECT_NE(svg.find("shape-rendering=\"crispEdges\""), std::string::npos);
  EXPECT_EQ(svg.find("stroke"), std::string::npos) << "no stroke in id mode";
  // No seam handling in id mode: plain polygons, and no z (filling closes them).
  EXPECT_EQ(svg.find('z'), std::string::npos);
  for (const auto& p : paths)
    for (const auto& sp : p.subpaths) EXPECT_EQ(sp.pts.size(), 4u);

  // Ids that do not fit 24 bits are an error, the largest that fits is not.
  Scene big = s;
  big.meshes[0].face_ids = {0xFFFFFE, 2};
  big.meshes[0].source_triangles = 0xFFFFFF;
  PlanarMap one;
  one.width = one.height = 8;
  add_fragment(one, 0, 0, {{0, 0}, {4, 0}, {0, 4}});
  EXPECT_NE(write_svg(one, big, eye_camera(), Fill::Id).find("#ffffff"), std::string::npos);
  big.meshes[0].face_ids = {0xFFFFFF, 2};
  big.meshes[0].source_triangles = 0x1000000;
  EXPECT_THROW(write_svg(one, big, eye_camera(), Fill::Id), InputError);
}

TEST(Svg, ShadeIsLambertTimesColourTwoSided) {
  Scene s = two_mesh_scene();
  s.meshes[0].color = {1.0f, 0.5f, 0.0f};
  // Mesh 1: a triangle seen edge-on from the eye (its plane contains the view ray).
  s.meshes[1] = make_mesh("edge-on", {0.5, 0.5, 1, 0.5, 0.5, -1, 2, 0.5, 0}, {0, 1, 2}, {0}, 1);
  s.meshes[1].color = {1, 1, 1};
  Camera c = eye_camera();
  c.projection = Camera::Projection::Orthographic;  // light along the view: quad faces it fully
  auto colors = [&](const Scene& sc) {
    std::vector<std::string> r;
    for (const auto& p : paths_of(write_svg(square_map(), sc, c, Fill::Shade)))
      r.push_back(p.color);
    return r;
  };
  auto cl = colors(s);
  ASSERT_EQ(cl.size(), 3u);
  // Facing the light: full colour; linear 0.5 is sRGB 188 (0xbc).
  EXPECT_EQ(cl[0], "#ffbc00");
  // Edge-on: only the ambient term 0.12 -> sRGB 0.3797 -> 97 (0x61).
  EXPECT_EQ(cl[2], "#616161");
  // Two-sided: flipping the winding of mesh 0 keeps its shade.
  Scene flipped = s;
  flipped.meshes[0].indices = {0, 2, 1, 0, 3, 2};
  EXPECT_EQ(colors(flipped)[0], "#ffbc00");
  // Perspective: light at the eye; a triangle facing the eye off-axis gets less than full.
  c.projection = Camera::Projection::Perspective;
  c.eye = {3, 0.5, 1};
  const auto persp = colors(s);
  EXPECT_NE(persp[0], "#ffbc00");
  EXPECT_EQ(persp[0].substr(5), "00");
}

TEST(Svg, SharedVerticesReconstructExactly) {
  // Every vertex is written once per path that uses it, relative to different predecessors;
  // reconstructed exactly they must be the same milli-pixel point in every path.
  const Scene s = two_mesh_scene();
  const PlanarMap m = square_map();
  for (Fill fill : {Fill::Shade, Fill::Id}) {
    std::set<std::pair<int64_t, int64_t>> written;
    for (const auto& p : paths_of(write_svg(m, s, eye_camera(), fill)))
      for (const auto& sp : p.subpaths) written.insert(sp.pts.begin(), sp.pts.end());
    for (size_t v = 0; v < m.vertex_count(); ++v) {
      const std::pair<int64_t, int64_t> q{
          std::llround(std::stod(svg_number(m.xy[2 * v])) * 1000),
          std::llround(std::stod(svg_number(m.xy[2 * v + 1])) * 1000)};
      EXPECT_TRUE(written.count(q)) << "vertex " << v << " not reconstructed exactly";
    }
  }
}

TEST(Svg, SeamStrokesOnlyOnSharedEdges) {
  // Square of 4 fragments: outline edges must not be stroked (no fattening), the inner cross
  // (shared edges, including the vertical line that fragment pairs share) must be.
  const Scene s = two_mesh_scene();
  const std::string svg = write_svg(square_map(), s, eye_camera(), Fill::Shade);
  EXPECT_NE(svg.find("stroke=\"currentColor\""), std::string::npos);
  const auto st = stroked(paths_of(svg));
  using P = std::pair<int64_t, int64_t>;
  const int64_t x0 = 10100, x1 = 15100, x2 = 20100, y0 = 20200, y1 = 25200, y2 = 30200;
  for (auto [a, b] : std::vector<std::pair<P, P>>{{{x0, y0}, {x1, y0}},
                                                  {{x1, y0}, {x2, y0}},
                                                  {{x2, y0}, {x2, y1}},
                                                  {{x2, y1}, {x2, y2}},
                                                  {{x2, y2}, {x1, y2}},
                                                  {{x1, y2}, {x0, y2}},
                                                  {{x0, y2}, {x0, y1}},
                                                  {{x0, y1}, {x0, y0}}})
    EXPECT_FALSE(has_segment(st, a, b)) << "outline edge stroked";
  for (auto [a, b] : std::vector<std::pair<P, P>>{
           {{x1, y0}, {x1, y1}}, {{x1, y1}, {x1, y2}}, {{x0, y1}, {x1, y1}}, {{x1, y1}, {x2, y1}}})
    EXPECT_TRUE(has_segment(st, a, b)) << "shared edge not stroked";
}

TEST(Svg, TJunctionEdgesAreShared) {
  // An occluder triangle whose long edge borders two fragments that split it (T-junction):
  // the long edge and the two short ones are shared, the outline is not.
  Scene s = two_mesh_scene();
  PlanarMap m;
  m.width = m.height = 64;
  add_fragment(m, 1, 0, {{10, 10}, {30, 10}, {10, 30}});            // hypotenuse (30,10)-(10,30)
  add_fragment(m, 0, 0, {{30, 10}, {40, 10}, {20, 20}});            // along it: (20,20)-(30,10)
  add_fragment(m, 0, 1, {{20, 20}, {40, 10}, {40, 30}, {10, 30}});  // (10,30)-(20,20)
  const auto st = stroked(paths_of(write_svg(m, s, eye_camera(), Fill::Shade)));
  EXPECT_TRUE(has_segment(st, {30000, 10000}, {10000, 30000}));
  EXPECT_TRUE(has_segment(st, {20000, 20000}, {30000, 10000}));
  EXPECT_TRUE(has_segment(st, {10000, 30000}, {20000, 20000}));
  EXPECT_FALSE(has_segment(st, {10000, 10000}, {30000, 10000}));
  EXPECT_FALSE(has_segment(st, {40000, 10000}, {40000, 30000}));
  EXPECT_FALSE(has_segment(st, {10000, 30000}, {10000, 10000}));
}

TEST(Svg, TJunctionVertexJoinsTheLongEdgeAfterRounding) {
  // The junction's vertex lies exactly on the long edge, but rounding to 1/100 px moves it off
  // the rounded edge by 0.005 px: a gap that crispEdges (Fill::Id) shows as background specks.
  // The long fragment must pass through the rounded vertex. (Fill::Shade strokes the edge.)
  Scene s = two_mesh_scene();
  PlanarMap m;
  m.width = m.height = 64;
  add_fragment(m, 1, 0, {{10, 10}, {30, 10.006}, {10, 30}});      // edge to (10,30)
  add_fragment(m, 0, 0, {{30, 10.006}, {40, 10}, {20, 20.003}});  // rounds to (20,20)
  add_fragment(m, 0, 1, {{20, 20.003}, {40, 10}, {40, 30}, {10, 30}});
  bool found = false;
  for (const SvgPath& p : paths_of(write_svg(m, s, eye_camera(), Fill::Id)))
    for (const Subpath& sp : p.subpaths) {
      const std::set<std::pair<int64_t, int64_t>> pts(sp.pts.begin(), sp.pts.end());
      if (pts.count({10000, 10000})) found = pts.count({20000, 20000}) && pts.count({30000, 10010});
    }
  EXPECT_TRUE(found);
  // and that edge is stroked in Fill::Shade
  const auto st = stroked(paths_of(write_svg(m, s, eye_camera(), Fill::Shade)));
  EXPECT_TRUE(has_segment(st, {30000, 10010}, {10000, 30000}));
}

TEST(Svg, IsolatedFragmentHasNoStrokedEdge) {
  const Scene s = two_mesh_scene();
  PlanarMap m;
  m.width = m.height = 64;
  add_fragment(m, 0, 0, {{10, 10}, {30, 10}, {30, 30}, {10, 30}});
  const auto paths = paths_of(write_svg(m, s, eye_camera(), Fill::Shade));
  ASSERT_EQ(paths.size(), 1u);
  double area = 0;
  for (const auto& sp : paths[0].subpaths) area += signed_area(sp);
  EXPECT_NEAR(area, 400e6, 1);
  const auto st = stroked(paths);
  for (auto [a, b] :
       std::vector<std::pair<std::pair<int64_t, int64_t>, std::pair<int64_t, int64_t>>>{
           {{10000, 10000}, {30000, 10000}},
           {{30000, 10000}, {30000, 30000}},
           {{30000, 30000}, {10000, 30000}},
           {{10000, 30000}, {10000, 10000}}})
    EXPECT_FALSE(has_segment(st, a, b));
}

TEST(Svg, BadMapsAreInputErrors) {
  const Scene s = two_mesh_scene();
  PlanarMap m = square_map();
  m.mesh[1] = 7;
  EXPECT_THROW(write_svg(m, s, eye_camera(), Fill::Shade), InputError);
  m = square_map();
  m.triangle[0] = 2;
  EXPECT_THROW(write_svg(m, s, eye_camera(), Fill::Shade), InputError);
  m = square_map();
  m.xy[3] = std::nan("");
  EXPECT_THROW(write_svg(m, s, eye_camera(), Fill::Id), InputError);
  m = square_map();
  m.offsets.back() += 1;
  EXPECT_THROW(write_bin(m, s), InputError);
}

TEST(Svg, SizeOfABunnySizedMap) {
  // ~60k fragments of a few pixels each (as the bunny at 1024x1024), every one its own source
  // triangle: the worst case for per-path overhead. Must stay under 3 MB.
  const int n = 174;  // 174^2 * 2 = 60552 triangles
  Scene s;
  Mesh mesh = make_mesh("grid", {}, {}, {}, 0);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> jit(-1.2, 1.2);
  std::vector<double> px, py;
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) {
      const bool inner = i > 0 && j > 0 && i < n && j < n;
      px.push_back(100 + 4.7 * i + (inner ? jit(rng) : 0));
      py.push_back(80 + 4.7 * j + (inner ? jit(rng) : 0));
      for (float c : {float(i), float(j), float((i * 7 + j * 3) % 5)}) mesh.positions.push_back(c);
    }
  PlanarMap m;
  m.width = m.height = 1024;
  auto vid = [&](int i, int j) { return j * (n + 1) + i; };
  uint32_t t = 0;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const int a = vid(i, j), b = vid(i + 1, j), c = vid(i + 1, j + 1), d = vid(i, j + 1);
      for (auto tri : {std::array<int, 3>{a, b, c}, std::array<int, 3>{a, c, d}}) {
        for (int k : tri) mesh.indices.push_back(uint32_t(k));
        mesh.face_ids.push_back(t);
        add_fragment(
            m, 0, t++,
            {{px[tri[0]], py[tri[0]]}, {px[tri[1]], py[tri[1]]}, {px[tri[2]], py[tri[2]]}});
      }
    }
  mesh.source_triangles = t;
  s.meshes.push_back(mesh);
  Camera cam = eye_camera();
  cam.eye = {80, 90, 300};
  const std::string shade = write_svg(m, s, cam, Fill::Shade);
  const std::string id = write_svg(m, s, cam, Fill::Id);
  const double per = double(shade.size()) / double(m.fragment_count());
  std::printf("SVG %zu fragments: shade %zu bytes (%.1f B/fragment), id %zu bytes\n",
              m.fragment_count(), shade.size(), per, id.size());
  EXPECT_LT(shade.size(), 3u << 20);
  // Id mode cannot group paths by colour (every colour is unique): 27 more bytes per path.
  EXPECT_LT(id.size(), 4u << 20);
  EXPECT_EQ(count(shade, "<path"), m.fragment_count());
  const std::string bin = write_bin(m, s);
  EXPECT_EQ(bin.size(), 24u + 32u * m.fragment_count());
  if (const char* dir = std::getenv("VISMAP_SVG_DUMP")) {
    std::ofstream(std::string(dir) + "/grid_shade.svg") << shade;
    std::ofstream(std::string(dir) + "/grid_id.svg") << id;
  }
}

// ---- binary ---------------------------------------------------------------------------------

namespace {

PlanarMap with_attributes(PlanarMap m) {
  for (size_t v = 0; v < m.vertex_count(); ++v) {
    m.bary.push_back(float(v) * 0.125f);
    m.bary.push_back(0.25f);
    m.bary.push_back(1.0f - float(v) * 0.125f - 0.25f);
    m.inv_w.push_back(0.5f + float(v) / 16.0f);
  }
  return m;
}

// A small map with a triangle, a pentagon (3 fan triangles) and a quad: 6 triangles.
PlanarMap small_map() {
  PlanarMap m;
  m.width = 320;
  m.height = 200;
  add_fragment(m, 1, 0, {{1.5, 2.25}, {10, 2}, {3, 9}});
  add_fragment(m, 0, 1, {{20, 20}, {30, 20}, {35, 28}, {25, 35}, {18, 27}});
  add_fragment(m, 0, 0, {{100.125, 50}, {120, 50}, {120, 70}, {100.125, 70}});
  return m;
}

void expect_round_trip(const PlanarMap& m, const Scene& s) {
  const bool attrs = !m.bary.empty();
  const std::string bytes = write_bin(m, s);
  ASSERT_EQ(bytes.size(), 24u + (attrs ? 80u : 32u) * 6u);
  EXPECT_EQ(bytes.substr(0, 4), "VMAP");
  const BinFrame f = read_bin(bytes);
  EXPECT_EQ(f.version, 1u);
  EXPECT_EQ(f.width, 320u);
  EXPECT_EQ(f.height, 200u);
  EXPECT_EQ(f.flags, attrs ? 1u : 0u);
  ASSERT_EQ(f.triangle_count(), 6u);
  // Expected fan: fragment f's vertices (0, i, i+1).
  const std::vector<uint32_t> src_frag = {0, 1, 1, 1, 2, 2};
  const std::vector<std::array<uint32_t, 3>> verts = {{0, 1, 2}, {3, 4, 5},  {3, 5, 6},
                                                      {3, 6, 7}, {8, 9, 10}, {8, 10, 11}};
  const std::vector<uint32_t> ids = {3, 2, 2, 2, 0, 0};  // global: mesh1 base 3; mesh0 faces 0, 2
  for (size_t t = 0; t < 6; ++t) {
    EXPECT_EQ(f.mesh[t], m.mesh[src_frag[t]]) << t;
    EXPECT_EQ(f.triangle_id[t], ids[t]) << t;
    for (int c = 0; c < 3; ++c) {
      const uint32_t v = verts[t][c];
      EXPECT_EQ(f.xy[6 * t + 2 * c], float(m.xy[2 * v])) << t;
      EXPECT_EQ(f.xy[6 * t + 2 * c + 1], float(m.xy[2 * v + 1])) << t;
      if (attrs) {
        for (int j = 0; j < 3; ++j) EXPECT_EQ(f.bary[9 * t + 3 * c + j], m.bary[3 * v + j]);
        EXPECT_EQ(f.inv_w[3 * t + c], m.inv_w[v]);
      }
    }
  }
  EXPECT_EQ(f.bary.empty(), !attrs);
  // Writing what was read gives the same bytes (positions are already float).
  if (!attrs) {
    PlanarMap back;
    back.width = f.width;
    back.height = f.height;
    std::vector<uint32_t> tri_of_id = {0, 0, 1, 0};  // mesh 0: face 0 -> tri 0, face 2 -> tri 1
    for (size_t t = 0; t < f.triangle_count(); ++t)
      add_fragment(back, f.mesh[t], f.mesh[t] == 1 ? 0 : tri_of_id[f.triangle_id[t]],
                   {{f.xy[6 * t], f.xy[6 * t + 1]},
                    {f.xy[6 * t + 2], f.xy[6 * t + 3]},
                    {f.xy[6 * t + 4], f.xy[6 * t + 5]}});
    EXPECT_EQ(write_bin(back, s), bytes);
  }
}

void expect_error(const std::string& bytes, InputErrorKind kind, const std::string& what) {
  try {
    read_bin(bytes);
    ADD_FAILURE() << "accepted: " << what;
  } catch (const InputError& e) {
    EXPECT_EQ(e.kind(), kind) << what << ": " << e.what();
    EXPECT_NE(std::string(e.what()).find("binary frame"), std::string::npos);
  }
}

void set_u32(std::string& b, size_t at, uint32_t v) {
  for (int i = 0; i < 4; ++i) b[at + i] = char(v >> (8 * i));
}

}  // namespace

TEST(Bin, RoundTripWithoutAttributes) {
  expect_round_trip(small_map(), two_mesh_scene());
}

TEST(Bin, RoundTripWithAttributes) {
  expect_round_trip(with_attributes(small_map()), two_mesh_scene());
}

TEST(Bin, LayoutIsLittleEndianAtSpecOffsets) {
  const std::string b = write_bin(small_map(), two_mesh_scene());
  auto u32 = [&](size_t at) {
    uint32_t v = 0;
    for (int i = 0; i < 4; ++i) v |= uint32_t(uint8_t(b[at + i])) << (8 * i);
    return v;
  };
  EXPECT_EQ(u32(4), 1u);                       // version
  EXPECT_EQ(u32(8), 320u);                     // width
  EXPECT_EQ(u32(12), 200u);                    // height
  EXPECT_EQ(u32(16), 0u);                      // flags
  EXPECT_EQ(u32(20), 6u);                      // triangles
  EXPECT_EQ(u32(24), 0x3FC00000u);             // x of the first vertex: 1.5f
  EXPECT_EQ(u32(24 + 6 * 4 * 6), 1u);          // mesh of triangle 0
  EXPECT_EQ(u32(24 + 6 * 4 * 6 + 4 * 6), 3u);  // global id of triangle 0
  EXPECT_EQ(write_bin(PlanarMap{}, two_mesh_scene()).size(), 24u);
  EXPECT_EQ(read_bin(write_bin(PlanarMap{}, two_mesh_scene())).triangle_count(), 0u);
}

TEST(Bin, MalformedFramesThrow) {
  for (const PlanarMap& m : {small_map(), with_attributes(small_map())}) {
    const std::string good = write_bin(m, two_mesh_scene());
    for (size_t n = 0; n < good.size(); ++n)
      expect_error(good.substr(0, n), InputErrorKind::Truncated,
                   "truncated to " + std::to_string(n));
    expect_error(good + '\0', InputErrorKind::ParseError, "trailing byte");
    std::string b = good;
    b[0] = 'X';
    expect_error(b, InputErrorKind::ParseError, "bad magic");
    for (uint32_t v : {0u, 2u, 0x01000000u}) {
      b = good;
      set_u32(b, 4, v);
      expect_error(b, InputErrorKind::ParseError, "version " + std::to_string(v));
    }
    b = good;
    set_u32(b, 16, 4);  // bit 1 is the line section (FORMAT.md "Lines"); bit 2 is unknown
    expect_error(b, InputErrorKind::ParseError, "unknown flag");
    b = good;
    set_u32(b, 16, 2 | (m.bary.empty() ? 0 : 1));  // a line section the frame does not have
    expect_error(b, InputErrorKind::Truncated, "line section");
    b = good;
    set_u32(b, 16, m.bary.empty() ? 1 : 0);  // flag says attributes when there are none, or v.v.
    expect_error(b, m.bary.empty() ? InputErrorKind::Truncated : InputErrorKind::ParseError,
                 "flag inconsistent with size");
    b = good;
    set_u32(b, 20, 7);
    expect_error(b, InputErrorKind::Truncated, "count too large");
    b = good;
    set_u32(b, 20, 0xFFFFFFFFu);
    expect_error(b, InputErrorKind::Truncated, "count huge");
    b = good;
    set_u32(b, 20, 5);
    expect_error(b, InputErrorKind::ParseError, "count too small");
    b = good;
    set_u32(b, 24, 0x7FC00000u);  // NaN x
    expect_error(b, InputErrorKind::ParseError, "NaN position");
  }
}

TEST(Bin, TruncationMessageNamesSection) {
  const std::string good = write_bin(with_attributes(small_map()), two_mesh_scene());
  try {
    read_bin(good.substr(0, 24 + 6 * 32 + 10));  // inside the bary section
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("bary"), std::string::npos) << e.what();
  }
}
