// Cells thinner than occlusion's fine sample grid (docs/NUMERICS.md §2, "Thin cells"). Three
// lines through grid points can meet so nearly in one point that the triangle between them has
// no point of the fine grid (2^-VM_POINT_BITS grid units) inside; such a fragment used to be
// dropped as a sliver, a hole. It is now decided at an exact rational point inside it.
//
// The scene: three front triangles F1..F3, each with an edge on one of three lines L1..L3 that
// bound a triangle Δ of height 6e-10 grid units (found by a search: L3 passes 2^-30.6 grid units
// from L1 ^ L2), each on the side of its line away from Δ, so that together they cover a small back
// triangle B everywhere except Δ. B's only visible piece is Δ.
#include <gtest/gtest.h>

#include <array>
#include <cmath>

#include "core/check/scene_check.h"
#include "core/pipeline.h"
#include "core/scene.h"
#include "tests/support/triangle_scene.h"

namespace {

using namespace vismap;
using test_support::add_triangle;

Renderer& renderer() {
  static Renderer r;
  return r;
}

using P2 = std::array<long long, 2>;

// The three lines, each through two grid points (grid units, 256 per pixel).
const P2 kLine[3][2] = {{{12757, 24849}, {52765, 40891}},
                        {{23767, 53781}, {41767, 11785}},
                        {{21098, 51248}, {42060, 18122}}};
// Where L1 and L2 cross (Δ is within 1e-9 grid units of it).
const double kX = 32734.29949787681, kY = 32859.293904842525;

struct Line {
  __int128 a, b, c;
};

Line line(int i) {
  const P2 &p = kLine[i][0], &q = kLine[i][1];
  Line L{-(q[1] - p[1]), q[0] - p[0], 0};
  L.c = -(L.a * p[0] + L.b * p[1]);
  return L;
}

// Exact side of Δ's vertex L_j ^ L_k against L_i: the sign of det[L_i; L_j; L_k] times the sign
// of the vertex's w (coefficients < 2^17, c < 2^33: products < 2^70).
int inner_side(int i) {
  Line Li = line(i), Lj = line((i + 1) % 3), Lk = line((i + 2) % 3);
  __int128 w = Lj.a * Lk.b - Lk.a * Lj.b;
  __int128 X = Lj.b * Lk.c - Lk.b * Lj.c, Y = Lj.c * Lk.a - Lk.c * Lj.a;
  __int128 d = Li.a * X + Li.b * Y + Li.c * w;
  return (d > 0) == (w > 0) ? 1 : -1;
}

// World units = pixels: grid point g is at g / 256 (exact in float).
void add_grid_triangle(Scene& s, const std::string& name, const double (&g)[3][2], double z) {
  double p[3][3];
  for (int k = 0; k < 3; ++k) p[k][0] = g[k][0] / 256, p[k][1] = g[k][1] / 256, p[k][2] = z;
  add_triangle(s, name, p);
}

// front_over_delta: a fourth, nearest triangle covering Δ (then B is hidden everywhere).
Scene thin_cell_scene(bool front_over_delta, Camera& cam) {
  Scene s;
  // B around Δ, 1000 grid units (4 px) across.
  const double b[3][2] = {{kX + 1000, kY}, {kX - 500, kY + 866}, {kX - 500, kY - 866}};
  add_grid_triangle(s, "B", b, 10);
  for (int i = 0; i < 3; ++i) {
    // F_i: the edge on line i and an apex 20000 grid units off it on the side away from Δ.
    const P2 &p = kLine[i][0], &q = kLine[i][1];
    Line L = line(i);
    double len = std::hypot(double(L.a), double(L.b));
    double out = -inner_side(i);
    const double f[3][2] = {{double(p[0]), double(p[1])},
                            {double(q[0]), double(q[1])},
                            {std::round(kX + out * 20000 * double(L.a) / len),
                             std::round(kY + out * 20000 * double(L.b) / len)}};
    add_grid_triangle(s, "F" + std::to_string(i + 1), f, 20 + i);
  }
  if (front_over_delta) {
    const double g[3][2] = {{kX + 100, kY}, {kX - 50, kY + 87}, {kX - 50, kY - 87}};
    add_grid_triangle(s, "G", g, 30);
  }
  cam = test_support::ortho_view_256(s);
  return s;
}

size_t fragments_of(const PlanarMap& m, uint32_t mesh) {
  size_t n = 0;
  for (size_t f = 0; f < m.fragment_count(); ++f) n += m.mesh[f] == mesh;
  return n;
}

TEST(ThinCells, AFragmentThinnerThanTheFineGridIsDecidedNotDropped) {
  for (bool covered : {false, true}) {
    Camera cam;
    Scene scene = thin_cell_scene(covered, cam);
    RenderStats st;
    PlanarMap map = renderer().render(scene, cam, {}, &st);
    const std::string what = covered ? "Δ covered by G" : "Δ open";
    EXPECT_GE(st.thin_fragments, 1u) << what;
    EXPECT_EQ(st.sliver_fragments, 0u) << what;
    // B (mesh 0) is visible in Δ only, and only while nothing covers Δ.
    EXPECT_EQ(fragments_of(map, 0), covered ? 0u : 1u) << what;
    if (covered) {
      EXPECT_GE(fragments_of(map, 4), 1u) << what;
    }

    check::SceneCheckOptions opts;
    opts.pixels = 256;
    check::SceneFigures f = check::check_scene(renderer(), scene, cam, opts);
    const std::string fig = what + ": " + check::to_json(f).dump();
    EXPECT_EQ(f.crossing_lines, 0u) << fig;
    EXPECT_EQ(*f.area_error, 0.0) << fig;
    EXPECT_EQ(*f.wrong_source, 0u) << fig;
    EXPECT_EQ(*f.overlap_area, 0.0) << fig;
    EXPECT_EQ(check::over_tolerance(f), std::vector<std::string>{}) << fig;
  }
}

}  // namespace
