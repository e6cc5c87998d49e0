// Line drawings (core/lines/lines.h): each line kind on small scenes whose answer is known, exact
// ends, chaining, the SVG groups, and the check against the id raster.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <string>

#include "core/error.h"
#include "core/lines/line_check.h"
#include "core/lines/lines.h"
#include "core/pipeline.h"
#include "core/scene.h"
#include "core/write/output.h"
#include "support/line_drawing.h"
#include "support/triangle_scene.h"

namespace vismap {
namespace {

using test_support::Drawn;
using test_support::ortho_view_256;

Renderer& renderer() {
  return test_support::line_renderer();
}

// A box [lo, hi], faces outward, as one mesh.
Mesh box(const std::string& name, const double (&lo)[3], const double (&hi)[3]) {
  Mesh m;
  m.name = name;
  for (int i = 0; i < 8; ++i) {
    m.positions.push_back(float(i & 1 ? hi[0] : lo[0]));
    m.positions.push_back(float(i & 2 ? hi[1] : lo[1]));
    m.positions.push_back(float(i & 4 ? hi[2] : lo[2]));
  }
  test_support::add_box_triangles(m);
  return m;
}

// A square in the plane z (or tilted: z grows by `slope` per unit of x from x0), two triangles.
Mesh square(const std::string& name, double x0, double y0, double x1, double y1, double z,
            double slope = 0, double xz = 0) {
  Mesh m;
  m.name = name;
  const double p[4][2] = {{x0, y0}, {x1, y0}, {x1, y1}, {x0, y1}};
  for (const auto& v : p)
    m.positions.insert(m.positions.end(),
                       {float(v[0]), float(v[1]), float(z + slope * (v[0] - xz))});
  m.indices = {0, 1, 2, 0, 2, 3};
  m.face_ids = {0, 1};
  m.source_triangles = 2;
  return m;
}

Drawn draw(const Scene& s, const Camera& cam, const LineOptions& o = {}) {
  Drawn d = test_support::draw_lines(s, cam, o);
  // VISMAP_LINES_SVG_DIR=DIR: each drawing as DIR/<test>-<n>.svg, to look at.
  if (const char* dir = std::getenv("VISMAP_LINES_SVG_DIR")) {
    static int n = 0;
    SvgStyle st;
    st.lines = &d.lines;
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    std::ofstream(std::string(dir) + "/" + info->name() + "-" + std::to_string(n++) + ".svg")
        << write_svg(d.map, s, cam, Fill::Shade, st);
  }
  return d;
}

size_t chains_of(const LineSet& l, LineKind k) {
  return size_t(std::count(l.kind.begin(), l.kind.end(), k));
}

Camera perspective(const Scene& s, Vec3 eye, Vec3 target) {
  Camera cam;
  cam.width = cam.height = 512;
  cam.eye = eye;
  cam.target = target;
  fit_near_far(cam, s);
  return cam;
}

TEST(Lines, CubeHasOneClosedContourAndThreeCreases) {
  Scene s;
  s.meshes.push_back(box("cube", {-1, -1, -1}, {1, 1, 1}));
  const Drawn d = draw(s, perspective(s, {4, 3, 5}, {0, 0, 0}));
  ASSERT_GT(d.map.fragment_count(), 0u);
  // The outline: six cube edges, one closed chain; the three edges at the near corner: creases
  // (90 degrees) meeting there; the faces' diagonals: nothing.
  EXPECT_EQ(chains_of(d.lines, LineKind::Contour), 1u);
  EXPECT_EQ(chains_of(d.lines, LineKind::Crease), 3u);
  EXPECT_EQ(d.lines.edges[size_t(LineKind::Boundary)], 0u);
  EXPECT_EQ(d.lines.edges[size_t(LineKind::Intersection)], 0u);
  EXPECT_EQ(d.lines.edges[size_t(LineKind::Border)], 0u);
  for (size_t c = 0; c < d.lines.chain_count(); ++c)
    EXPECT_TRUE(d.lines.kind[c] != LineKind::Contour || d.lines.closed[c]);
  // A crease angle over 90 degrees leaves only the outline.
  LineOptions wide;
  wide.crease_angle_deg = 95;
  const Drawn w = draw(s, perspective(s, {4, 3, 5}, {0, 0, 0}), wide);
  EXPECT_EQ(w.lines.edges[size_t(LineKind::Crease)], 0u);
  EXPECT_EQ(chains_of(w.lines, LineKind::Contour), 1u);
}

TEST(Lines, OpenSquareIsOneBoundaryLoop) {
  Scene s;
  s.meshes.push_back(square("sq", 64, 64, 192, 192, 0));
  const Drawn d = draw(s, ortho_view_256(s));
  ASSERT_EQ(d.lines.chain_count(), 1u);
  EXPECT_EQ(d.lines.kind[0], LineKind::Boundary);
  EXPECT_TRUE(d.lines.closed[0]);
  EXPECT_EQ(d.lines.edges[size_t(LineKind::Crease)], 0u);  // the diagonal is flat
}

// The back square's outline stops exactly at the front square's edge: no gap, no overshoot.
TEST(Lines, HiddenBoundaryStopsExactlyAtTheOccluder) {
  Scene s;
  s.meshes.push_back(square("back", 32, 32, 160, 160, 0));
  s.meshes.push_back(square("front", 96, 96, 224, 224, 10));
  const Camera cam = ortho_view_256(s);
  const Drawn d = draw(s, cam);
  EXPECT_EQ(d.lines.edges[size_t(LineKind::Contour)], 0u);
  EXPECT_EQ(d.lines.edges[size_t(LineKind::Intersection)], 0u);
  // The front square is a whole loop; the back one's visible outline an open chain from the
  // front's left edge (x = 96, y = 160 on screen: world y 96 is screen y 160) to its top edge.
  size_t closed = 0, open = 0;
  for (size_t c = 0; c < d.lines.chain_count(); ++c) {
    ASSERT_EQ(d.lines.kind[c], LineKind::Boundary);
    if (d.lines.closed[c]) {
      ++closed;
      continue;
    }
    ++open;
    const double* a = &d.lines.xy[2 * d.lines.off[c]];
    const double* b = &d.lines.xy[2 * (d.lines.off[c + 1] - 1)];
    // World (96, y) and (x, 96) are screen x = 96 and screen y = 256 - 96 = 160.
    const bool a_on = std::abs(a[0] - 96) < 1e-9 || std::abs(a[1] - 160) < 1e-9;
    const bool b_on = std::abs(b[0] - 96) < 1e-9 || std::abs(b[1] - 160) < 1e-9;
    EXPECT_TRUE(a_on && b_on) << a[0] << "," << a[1] << " " << b[0] << "," << b[1];
  }
  EXPECT_EQ(closed, 1u);
  EXPECT_EQ(open, 1u);
}

// Two squares crossing along world x = 128: one intersection chain there, its ends where the
// crossing leaves the squares' overlap.
TEST(Lines, CrossingSquaresDrawTheirIntersection) {
  Scene s;
  s.meshes.push_back(square("flat", 32, 64, 224, 192, 0));
  s.meshes.push_back(square("tilted", 64, 32, 192, 224, 0, 0.5, 128));
  const Drawn d = draw(s, ortho_view_256(s));
  ASSERT_EQ(chains_of(d.lines, LineKind::Intersection), 1u);
  for (size_t c = 0; c < d.lines.chain_count(); ++c) {
    if (d.lines.kind[c] != LineKind::Intersection) continue;
    double ylo = 1e9, yhi = -1e9;
    for (uint32_t i = d.lines.off[c]; i < d.lines.off[c + 1]; ++i) {
      EXPECT_NEAR(d.lines.xy[2 * i], 128, 1e-6);
      ylo = std::min(ylo, d.lines.xy[2 * i + 1]);
      yhi = std::max(yhi, d.lines.xy[2 * i + 1]);
    }
    EXPECT_NEAR(ylo, 256 - 192, 1e-6);
    EXPECT_NEAR(yhi, 256 - 64, 1e-6);
  }
}

// A box standing on a floor: the line where they meet is a border, not a contour.
TEST(Lines, BoxOnAFloorMeetsItAtABorder) {
  Scene s;
  Mesh floor = square("floor", -4, -4, 4, 4, 0);
  // The floor in y = 0 (square() builds in z): swap y and z, and keep it facing up.
  for (size_t v = 0; v < floor.positions.size(); v += 3)
    std::swap(floor.positions[v + 1], floor.positions[v + 2]);
  floor.indices = {0, 2, 1, 0, 3, 2};
  s.meshes.push_back(floor);
  s.meshes.push_back(box("box", {-1, 0, -1}, {1, 2, 1}));
  const Drawn d = draw(s, perspective(s, {10, 8, 12}, {0, 0.5, 0}));
  EXPECT_GT(d.lines.edges[size_t(LineKind::Border)], 0u);
  EXPECT_EQ(d.lines.edges[size_t(LineKind::Intersection)], 0u);
  EXPECT_GT(d.lines.edges[size_t(LineKind::Boundary)], 0u);  // the floor's rim
  EXPECT_GT(d.lines.edges[size_t(LineKind::Crease)], 0u);    // the box's visible edges
}

// --hidden: the cube's three edges at its far corner, and nothing of its outline; the back
// square's outline under the front square, ending exactly where the visible part ends.
TEST(Lines, HiddenPartsAreTheRestOfTheEdgeLines) {
  Scene s;
  s.meshes.push_back(box("cube", {-1, -1, -1}, {1, 1, 1}));
  LineOptions o;
  o.hidden = true;
  const Drawn d = draw(s, perspective(s, {4, 3, 5}, {0, 0, 0}), o);
  EXPECT_EQ(d.lines.hidden_edges[size_t(LineKind::Crease)], 3u);
  EXPECT_EQ(d.lines.hidden_edges[size_t(LineKind::Contour)], 0u);
  size_t hidden_chains = 0;
  for (size_t c = 0; c < d.lines.chain_count(); ++c) hidden_chains += d.lines.hidden[c];
  EXPECT_EQ(hidden_chains, 3u);  // three chains meeting at the far corner

  Scene q;
  q.meshes.push_back(square("back", 32, 32, 160, 160, 0));
  q.meshes.push_back(square("front", 96, 96, 224, 224, 10));
  const Drawn h = draw(q, ortho_view_256(q), o);
  ASSERT_EQ(h.lines.hidden_edges[size_t(LineKind::Boundary)], 2u);
  for (size_t c = 0; c < h.lines.chain_count(); ++c) {
    if (!h.lines.hidden[c]) continue;
    ASSERT_EQ(h.lines.off[c + 1] - h.lines.off[c], 3u);  // an L: (96,y) - corner - (x,160)
    const double* a = &h.lines.xy[2 * h.lines.off[c]];
    const double* m = a + 2;
    const double* b = a + 4;
    EXPECT_DOUBLE_EQ(m[0], 160);  // the back square's corner (160, 160) world, (160, 96) screen
    EXPECT_DOUBLE_EQ(m[1], 96);
    const bool a_on = a[0] == 96 || a[1] == 160, b_on = b[0] == 96 || b[1] == 160;
    EXPECT_TRUE(a_on && b_on) << a[0] << "," << a[1] << " " << b[0] << "," << b[1];
  }
}

TEST(Lines, SvgGroupsByKindAndKeepsTheFillOutputAsItWas) {
  Scene s;
  s.meshes.push_back(box("cube", {-1, -1, -1}, {1, 1, 1}));
  const Camera cam = perspective(s, {4, 3, 5}, {0, 0, 0});
  const Drawn d = draw(s, cam);
  const std::string plain = write_svg(d.map, s, cam, Fill::Shade);
  EXPECT_EQ(write_svg(d.map, s, cam, Fill::Shade, SvgStyle{}), plain);
  SvgStyle st;
  st.lines = &d.lines;
  const std::string both = write_svg(d.map, s, cam, Fill::Shade, st);
  EXPECT_EQ(both.substr(0, plain.size() - 7), plain.substr(0, plain.size() - 7));  // "</svg>\n"
  EXPECT_NE(both.find("<g class=\"contour\" stroke=\"#000000\">"), std::string::npos);
  EXPECT_NE(both.find("<g class=\"crease\""), std::string::npos);
  EXPECT_EQ(both.find("<g class=\"boundary\""), std::string::npos);  // no such lines: no group
  st.fill = false;
  const std::string only = write_svg(d.map, s, cam, Fill::Shade, st);
  EXPECT_EQ(only.find("<g color="), std::string::npos);  // no fills
  // One path per chain.
  size_t paths = 0;
  for (size_t at = only.find("<path"); at != std::string::npos; at = only.find("<path", at + 1))
    ++paths;
  EXPECT_EQ(paths, d.lines.chain_count());
}

// The binary format's line section: what write_bin writes read_bin reads back, and a frame
// whose section is damaged is refused.
TEST(Lines, BinaryLineSectionRoundTrips) {
  Scene s;
  s.meshes.push_back(box("cube", {-1, -1, -1}, {1, 1, 1}));
  const Camera cam = perspective(s, {4, 3, 5}, {0, 0, 0});
  LineOptions o;
  o.hidden = true;
  const Drawn d = draw(s, cam, o);
  for (bool tris : {true, false}) {
    const std::string bytes = write_bin(d.map, s, &d.lines, tris);
    const BinFrame f = read_bin(bytes);
    ASSERT_TRUE(f.has_lines);
    EXPECT_EQ(f.triangle_count() > 0, tris);
    ASSERT_EQ(f.lines.chain_count(), d.lines.chain_count());
    EXPECT_EQ(f.lines.off, d.lines.off);
    EXPECT_EQ(f.lines.kind, d.lines.kind);
    EXPECT_EQ(f.lines.closed, d.lines.closed);
    EXPECT_EQ(f.lines.hidden, d.lines.hidden);
    for (size_t i = 0; i < d.lines.xy.size(); ++i)
      EXPECT_EQ(f.lines.xy[i], double(float(d.lines.xy[i])));
    EXPECT_THROW(read_bin(bytes.substr(0, bytes.size() - 4)), InputError);  // truncated
    EXPECT_THROW(read_bin(bytes + std::string(4, '\0')), InputError);       // trailing
    // The first chain's info word with an unknown kind.
    const size_t info = bytes.size() - 8 * (d.lines.xy.size() / 2) - 4 * d.lines.chain_count();
    std::string bad = bytes;
    bad[info] = 9;
    EXPECT_THROW(read_bin(bad), InputError);
  }
  EXPECT_FALSE(read_bin(write_bin(d.map, s)).has_lines);  // unchanged without lines
}

// --merge: a plane of 2 x 16 x 16 triangles, one shade (orthographic: the light is the view
// direction), is one region: one path of four corners; a square in front of it cuts a hole,
// which the plane's path keeps as a second loop.
TEST(Lines, MergeJoinsOneFillIntoOneRegionWithHoles) {
  Scene s;
  Mesh plane;
  plane.name = "plane";
  for (int j = 0; j <= 16; ++j)
    for (int i = 0; i <= 16; ++i)
      plane.positions.insert(plane.positions.end(), {float(32 + 12 * i), float(32 + 12 * j), 0.f});
  test_support::add_grid_triangles(plane, 16);
  s.meshes.push_back(plane);
  SvgStyle st;
  st.merge = true;
  {
    const Camera cam = ortho_view_256(s);
    const Drawn d = draw(s, cam);
    const std::string svg = write_svg(d.map, s, cam, Fill::Shade, st);
    const size_t at = svg.find("<path stroke=\"none\" d=\"M");
    ASSERT_NE(at, std::string::npos) << svg;
    EXPECT_EQ(svg.find("<path", at + 1), std::string::npos) << svg;  // the only path
    const size_t d0 = svg.find("d=\"", at) + 3;
    const std::string d_attr = svg.substr(d0, svg.find('"', d0) - d0);
    EXPECT_EQ(std::count(d_attr.begin(), d_attr.end(), 'm'), 0) << d_attr;  // one loop
  }
  s.meshes.push_back(square("front", 96, 96, 160, 160, 10));
  const Camera cam = ortho_view_256(s);
  const Drawn d = draw(s, cam);
  const std::string svg = write_svg(d.map, s, cam, Fill::Shade, st);
  // The plane: an outer loop and the hole (a relative 'm'), its hole's edges stroked (shared
  // with the square); the square: one region.
  const size_t at = svg.find("<path stroke=\"none\" d=\"M");
  ASSERT_NE(at, std::string::npos) << svg;
  const size_t d0 = svg.find("d=\"", at) + 3;
  const std::string d_attr = svg.substr(d0, svg.find('"', d0) - d0);
  EXPECT_EQ(std::count(d_attr.begin(), d_attr.end(), 'm'), 1) << d_attr;
  EXPECT_NE(svg.find("<path fill=\"none\" d=\"M"), std::string::npos) << svg;
  // Unmerged, the plane alone writes one path per triangle.
  EXPECT_GT(std::count(svg.begin(), svg.end(), '\n'), 5);
}

// The drawing against the 4 x 4 supersampled id raster: on two cubes, one through the other,
// every place where surfaces meet has a line within 1.5 px and every line such a place; a
// planted line where nothing meets (a mutation) fails the precision, a drawing without its
// intersection lines the recall.
TEST(Lines, CheckAgainstTheSupersampledIdRaster) {
  Scene s;
  s.meshes.push_back(box("cube", {-1, -1, -1}, {1, 1, 1}));
  s.meshes.push_back(box("cube2", {-0.5, -0.5, 0.5}, {0.5, 0.5, 2.5}));  // penetrates the first
  const Camera cam = perspective(s, {4, 3, 5}, {0, 0, 0});
  const Drawn d = draw(s, cam);
  EXPECT_GT(d.lines.edges[size_t(LineKind::Intersection)], 0u);
  Camera fine = cam;
  fine.width *= 4;
  fine.height *= 4;
  std::vector<uint32_t> ids;
  renderer().raster_ids(s, fine, &ids);
  const LineCheck c = check_lines(d.lines, ids, cam.width, cam.height, 4, s);
  EXPECT_GT(c.reference_points, 4000u);
  EXPECT_GE(c.recall(), 0.995) << c.reference_near_line << " / " << c.reference_points;
  EXPECT_GE(c.precision(), 0.995) << c.line_near_reference << " / " << c.line_px;
  // A planted contour across the middle of a cube's face, 30 px long: no surfaces meet there.
  LineSet planted = d.lines;
  double cx = 0, cy = 0;
  for (size_t i = 0; i < d.lines.xy.size(); i += 2) cx += d.lines.xy[i], cy += d.lines.xy[i + 1];
  cx /= d.lines.xy.size() / 2;
  cy /= d.lines.xy.size() / 2;
  std::vector<uint8_t> img;
  const LineCheck before = check_lines(d.lines, ids, cam.width, cam.height, 4, s, 1.5, &img);
  // A spot inside a face: no drawn line and no reference point within 8 px.
  double px = -1, py = -1;
  for (int r = 0; r < 200 && px < 0; r += 4)
    for (int a = 0; a < 16 && px < 0; ++a) {
      const int x = int(cx + r * std::cos(a * M_PI / 8)), y = int(cy + r * std::sin(a * M_PI / 8));
      bool clear = x >= 20 && y >= 20 && x < int(cam.width) - 20 && y < int(cam.height) - 20;
      for (int v = -8; v <= 8 && clear; ++v)
        for (int u = -8; u <= 8 && clear; ++u) clear = img[size_t(y + v) * cam.width + x + u] == 0;
      if (clear && ids[size_t(4 * y) * fine.width + 4 * x] != ~0u) px = x, py = y;
    }
  ASSERT_GE(px, 0);
  planted.xy.insert(planted.xy.end(), {px - 6, py, px + 6, py});
  planted.off.push_back(uint32_t(planted.xy.size() / 2));
  planted.kind.push_back(LineKind::Contour);
  planted.closed.push_back(0);
  planted.hidden.push_back(0);
  const LineCheck p = check_lines(planted, ids, cam.width, cam.height, 4, s);
  EXPECT_LT(p.precision(), 0.995) << "a planted line is not caught";
  EXPECT_NEAR(p.line_px - before.line_px, 12, 1e-9);
  // Without its intersection lines the drawing misses where the cubes cross.
  LineSet no_x = d.lines;
  for (auto& k : no_x.kind)
    if (k == LineKind::Intersection) k = LineKind::Crease;  // creases are not checked
  EXPECT_LT(check_lines(no_x, ids, cam.width, cam.height, 4, s).recall(), 0.98);
}

}  // namespace
}  // namespace vismap
