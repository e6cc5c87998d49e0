// The z-buffer floor (Renderer::raster_ids, kernels/raster.cl): the plain id raster the
// pipeline's time is compared against in bench/. It must see the same scene as the pipeline.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

#include "core/pipeline.h"

namespace {

using namespace vismap;

Renderer& renderer() {
  static Renderer r;
  return r;
}

Mesh quad(float z) {  // a unit square at depth z, two triangles
  Mesh m;
  m.name = "quad";
  m.positions = {-1, -1, z, 1, -1, z, 1, 1, z, -1, 1, z};
  m.indices = {0, 1, 2, 0, 2, 3};
  return m;
}

TEST(ZBuffer, NearestTriangleWinsEachPixel) {
  Scene s;
  s.meshes.push_back(quad(-0.5f));  // behind: triangles 0, 1
  s.meshes.push_back(quad(0.5f));   // in front: triangles 2, 3
  s.meshes[1].positions[0] = 0;     // the front quad covers only the right half
  s.meshes[1].positions[9] = 0;
  Camera c;
  c.width = c.height = 64;
  c.eye = {0, 0, 5};
  c.target = {0, 0, 0};
  c.projection = Camera::Projection::Orthographic;
  c.ortho_height = 2.5;
  fit_near_far(c, s);
  std::vector<uint32_t> ids;
  RasterStats rs = renderer().raster_ids(s, c, &ids);
  ASSERT_EQ(ids.size(), 64u * 64u);
  EXPECT_EQ(rs.screen_triangles, 4u);
  auto at = [&](int x, int y) { return ids[size_t(y) * 64 + x]; };
  EXPECT_EQ(at(0, 0), 0xffffffffu);  // outside both
  EXPECT_LT(at(16, 32), 2u);         // left half: only the back quad
  EXPECT_GE(at(48, 32), 2u);         // right half: the front quad
  EXPECT_NE(at(48, 32), 0xffffffffu);
}

// Every big visible fragment of the exact map shows its source at its centre pixel.
TEST(ZBuffer, AgreesWithThePlanarMap) {
  const std::string path = std::string(VISMAP_SHARED_DATA_DIR) + "/stanford/bun_zipper_res3.ply";
  if (!std::filesystem::exists(path)) GTEST_SKIP() << path << " not present";
  Scene scene = load_scene(path);
  Camera cam = frame_scene(scene, 512, 512);
  PlanarMap map = renderer().render(scene, cam);
  std::vector<uint32_t> ids;
  renderer().raster_ids(scene, cam, &ids);
  size_t checked = 0, agree = 0;
  for (size_t f = 0; f < map.fragment_count(); ++f) {
    double a = 0, cx = 0, cy = 0;
    for (uint32_t v = map.offsets[f], n = map.offsets[f + 1]; v < n; ++v) {
      uint32_t w = v + 1 < n ? v + 1 : map.offsets[f];
      double cr = map.xy[2 * v] * map.xy[2 * w + 1] - map.xy[2 * w] * map.xy[2 * v + 1];
      a += cr;
      cx += (map.xy[2 * v] + map.xy[2 * w]) * cr;
      cy += (map.xy[2 * v + 1] + map.xy[2 * w + 1]) * cr;
    }
    a /= 2;
    if (a < 25) continue;
    cx /= 6 * a;
    cy /= 6 * a;
    ++checked;
    agree += ids[size_t(cy) * 512 + size_t(cx)] == map.triangle[f];
  }
  ASSERT_GT(checked, 300u);
  EXPECT_GE(double(agree) / checked, 0.97) << agree << " of " << checked;
}

}  // namespace
