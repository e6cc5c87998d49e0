// Each format loads with the counts SOURCES.md lists, faces in file order, transforms applied.
#include <array>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "tests/loader_test_util.h"

using namespace vismap;
using vismap::test::TempDir;

namespace {

void expect_ids_in_order(const Mesh& m) {
  ASSERT_EQ(m.face_ids.size(), m.triangle_count());
  for (size_t i = 1; i < m.face_ids.size(); ++i) {
    ASSERT_LT(m.face_ids[i - 1], m.face_ids[i]);
  }
  if (!m.face_ids.empty()) {
    EXPECT_LT(m.face_ids.back(), m.source_triangles);
  }
}

#define REQUIRE_SHARED()                 \
  if (!vismap::test::have_shared()) {    \
    GTEST_SKIP() << "no ../shared/data"; \
  }

}  // namespace

TEST(LoadPly, BunnyAsciiEveryFaceInOrder) {
  std::string path = test::data_dir() + "/bunny.ply";
  Scene s = load_scene(path);
  ASSERT_EQ(s.meshes.size(), 1u);
  const Mesh& m = s.meshes[0];
  EXPECT_EQ(m.vertex_count(), 35947u);
  EXPECT_EQ(m.triangle_count(), 69451u);
  EXPECT_EQ(m.source_triangles, 69451u);
  EXPECT_EQ(s.dropped_degenerate, 0u);
  EXPECT_FALSE(m.soup);
  EXPECT_EQ(m.name, "bunny");
  EXPECT_EQ(s.source, path);
  EXPECT_FLOAT_EQ(m.positions[0], -0.0378297f);
  EXPECT_FLOAT_EQ(m.positions[2], 0.00447467f);
  // The last face of the file is "3 17277 17346 17345".
  EXPECT_EQ(m.face_ids.back(), 69450u);
  EXPECT_EQ(m.indices[3 * 69450 + 0], 17277u);
  EXPECT_EQ(m.indices[3 * 69450 + 2], 17345u);
  expect_ids_in_order(m);
}

TEST(LoadPly, NonManifoldHappyBuddhaKeepsAllFaces) {
  REQUIRE_SHARED();
  Scene s = load_scene(test::shared_dir() + "/stanford/happy_vrip_res3.ply");
  EXPECT_EQ(s.meshes[0].vertex_count(), 32328u);
  EXPECT_EQ(s.meshes[0].source_triangles, 67240u);
  EXPECT_EQ(s.triangle_count(), 67240u);  // duplicate faces included: SOURCES.md, zero_area_tris=0
}

TEST(LoadPly, BinaryTristripsIgea) {
  REQUIRE_SHARED();
  Scene s = load_scene(test::shared_dir() + "/extra_scans/igea.ply");
  EXPECT_EQ(s.meshes[0].vertex_count(), 134345u);
  EXPECT_EQ(s.meshes[0].source_triangles, 268686u);
  EXPECT_EQ(s.triangle_count() + s.dropped_degenerate, 268686u);
  expect_ids_in_order(s.meshes[0]);
}

TEST(LoadPly, AsciiBinaryLittleAndBigEndianAgree) {
  TempDir dir;
  const char* head =
      "element vertex 5\nproperty float x\nproperty float y\nproperty float z\n"
      "property uchar red\nelement face 2\nproperty list uchar int vertex_indices\n"
      "property int flags\nend_header\n";
  std::string ascii = std::string("ply\nformat ascii 1.0\ncomment test\n") + head +
                      "0 0 0 1\n1 0 0 2\n1 1 0 3\n0 1 0 4\n0.5 0.5 1 5\n4 0 1 2 3 7\n3 3 2 4 8\n";
  auto binary = [&](bool big) {
    std::string b = std::string("ply\nformat ") +
                    (big ? "binary_big_endian" : "binary_little_endian") + " 1.0\n" + head;
    auto put = [&](const void* p, size_t n) {
      std::string s(static_cast<const char*>(p), n);
      if (big) std::reverse(s.begin(), s.end());
      b += s;
    };
    float v[5][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0.5f, 0.5f, 1}};
    for (int i = 0; i < 5; ++i) {
      for (float f : v[i]) put(&f, 4);
      b += char(i + 1);
    }
    std::vector<std::vector<int32_t>> faces = {{0, 1, 2, 3}, {3, 2, 4}};
    for (auto& f : faces) {
      b += char(f.size());
      for (int32_t i : f) put(&i, 4);
      int32_t flags = 7;
      put(&flags, 4);
    }
    return b;
  };
  Scene a = load_scene(dir.write("a.ply", ascii));
  Scene le = load_scene(dir.write("le.PLY", binary(false)));  // extensions are case-insensitive
  Scene be = load_scene(dir.write("be.ply", binary(true)));
  for (const Scene* s : {&a, &le, &be}) {
    const Mesh& m = s->meshes[0];
    EXPECT_EQ(m.positions, a.meshes[0].positions);
    // The quad is fanned into 2 triangles (ids 0, 1), the triangle after it is id 2.
    EXPECT_EQ(m.indices, (std::vector<uint32_t>{0, 1, 2, 0, 2, 3, 3, 2, 4}));
    EXPECT_EQ(m.face_ids, (std::vector<uint32_t>{0, 1, 2}));
    EXPECT_EQ(m.source_triangles, 3u);
  }
}

TEST(LoadPly, GzipDragonInDragonBunniesScene) {
  // Loads data/dragon_vrip.ply.gz (871,414 triangles) once, through the composed scene.
  Scene s = load_scene(test::data_dir() + "/scenes/dragon_bunnies.json");
  ASSERT_EQ(s.meshes.size(), 4u);
  EXPECT_EQ(s.meshes[0].name, "dragon");
  EXPECT_EQ(s.meshes[0].vertex_count(), 437645u);
  EXPECT_EQ(s.meshes[0].source_triangles, 871414u);
  EXPECT_EQ(s.meshes[0].triangle_count() + s.dropped_degenerate, 871414u);
  expect_ids_in_order(s.meshes[0]);
  for (int i = 1; i < 4; ++i) EXPECT_EQ(s.meshes[i].source_triangles, 69451u);
  ASSERT_TRUE(s.camera.has_value());
  auto base = s.triangle_id_base();
  EXPECT_EQ(base[1], 871414u);
}

TEST(LoadObj, TeapotAndArmadillo) {
  REQUIRE_SHARED();
  Scene t = load_scene(test::shared_dir() + "/teapot/teapot_c3d.obj");
  ASSERT_EQ(t.meshes.size(), 1u);
  EXPECT_EQ(t.meshes[0].vertex_count(), 3644u);
  EXPECT_EQ(t.meshes[0].source_triangles, 6320u);
  EXPECT_TRUE(t.meshes[0].soup);  // open seams: vertices duplicated between patches
  Scene a = load_scene(test::data_dir() + "/armadillo.obj");
  EXPECT_EQ(a.meshes[0].source_triangles, 29170u);
  EXPECT_FALSE(a.meshes[0].soup);
}

TEST(LoadObj, CornellBoxSplitsByMaterialWithKdColors) {
  Scene s = load_scene(test::data_dir() + "/cornell_box/CornellBox-Original.obj");
  std::vector<std::string> names;
  for (const Mesh& m : s.meshes) names.push_back(m.name);
  EXPECT_EQ(names, (std::vector<std::string>{"floor", "ceiling", "backWall", "rightWall",
                                             "leftWall", "shortBox", "tallBox", "light"}));
  EXPECT_EQ(s.triangle_count(), 36u);
  EXPECT_FLOAT_EQ(s.meshes[4].color[0], 0.63f);  // leftWall Kd 0.63 0.065 0.05
  EXPECT_FLOAT_EQ(s.meshes[3].color[1], 0.45f);  // rightWall Kd 0.14 0.45 0.091
  EXPECT_EQ(s.meshes[5].source_triangles, 12u);
}

TEST(LoadObj, NegativeIndicesTexturesNormalsAndPolygons) {
  TempDir dir;
  std::string p =
      dir.write("p.obj",
                "# comment\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0.5 1.5 0\nvt 0 0\nvn 0 0 1\n"
                "f 1/1/1 2/1/1 3/1/1 5//1 4\nf -3 -2 -1\n");
  Scene s = load_scene(p);
  EXPECT_EQ(s.meshes[0].indices, (std::vector<uint32_t>{0, 1, 2, 0, 2, 4, 0, 4, 3, 2, 3, 4}));
  EXPECT_EQ(s.meshes[0].face_ids, (std::vector<uint32_t>{0, 1, 2, 3}));
}

TEST(LoadOff, CgalModelsAndDegenerateDropping) {
  REQUIRE_SHARED();
  Scene a = load_scene(test::shared_dir() + "/cgal/armadillo.off");
  EXPECT_EQ(a.meshes[0].vertex_count(), 26002u);
  EXPECT_EQ(a.triangle_count(), 52000u);
  Scene t = load_scene(test::shared_dir() + "/cgal/tetra_intersected_by_triangle.off");
  EXPECT_EQ(t.meshes[0].source_triangles, 5u);
  // degtri_sliding.off: 8 faces, 4 of them zero-area slivers on the x axis.
  Scene d = load_scene(test::shared_dir() + "/cgal/degtri_sliding.off");
  EXPECT_EQ(d.meshes[0].source_triangles, 8u);
  EXPECT_EQ(d.triangle_count() + d.dropped_degenerate, 8u);
  EXPECT_GT(d.dropped_degenerate, 0u);
  expect_ids_in_order(d.meshes[0]);
}

TEST(LoadOff, ColorsCommentsAndRepeatedIndexDropped) {
  TempDir dir;
  std::string p = dir.write("c.off",
                            "COFF # colored\n4 3 0\n0 0 0 255 0 0 255\n1 0 0 0 255 0 255\n"
                            "0 1 0 0 0 255 255\n1 1 0 9 9 9 9\n3 0 1 1\n3 0 1 2 1 0 0\n3 1 3 2\n");
  Scene s = load_scene(p);
  EXPECT_EQ(s.dropped_degenerate, 1u);
  EXPECT_EQ(s.meshes[0].face_ids, (std::vector<uint32_t>{1, 2}));
  EXPECT_EQ(s.meshes[0].source_triangles, 3u);
}

TEST(LoadStl, AsciiAndBinarySoup) {
  TempDir dir;
  std::string ascii =
      "solid t\nfacet normal 0 0 1\n outer loop\n  vertex 0 0 0\n  vertex 1 0 0\n  vertex 0 1 0\n"
      " endloop\nendfacet\nfacet normal 0 0 1\n outer loop\n  vertex 1 0 0\n  vertex 1 1 0\n"
      "  vertex 0 1 0\n endloop\nendfacet\nendsolid t\n";
  std::string bin(80, 'x');
  uint32_t n = 2;
  bin.append(reinterpret_cast<const char*>(&n), 4);
  float tris[2][12] = {{0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 0}, {0, 0, 1, 1, 0, 0, 1, 1, 0, 0, 1, 0}};
  for (auto& t : tris) {
    bin.append(reinterpret_cast<const char*>(t), 48);
    bin.append(2, '\0');
  }
  for (const std::string& p : {dir.write("a.stl", ascii), dir.write("b.stl", bin)}) {
    Scene s = load_scene(p);
    const Mesh& m = s.meshes[0];
    EXPECT_TRUE(m.soup) << p;
    EXPECT_EQ(m.vertex_count(), 6u) << p;
    EXPECT_EQ(m.face_ids, (std::vector<uint32_t>{0, 1})) << p;
    EXPECT_FLOAT_EQ(m.positions[12 + 1], 1.0f) << p;  // second facet, second vertex, y
  }
}

TEST(LoadGltf, NodeHierarchyColorAndCamera) {
  Scene s = load_scene(test::data_dir() + "/scenes/triangle_camera.gltf");
  ASSERT_EQ(s.meshes.size(), 1u);
  const Mesh& m = s.meshes[0];
  // parent translate (10,0,0) * child rotate 90 deg about z * scale 2: (1,0,0) -> (10,2,0).
  EXPECT_NEAR(m.positions[3], 10.0f, 1e-5);
  EXPECT_NEAR(m.positions[4], 2.0f, 1e-5);
  EXPECT_NEAR(m.positions[6], 8.0f, 1e-5);
  EXPECT_NEAR(m.positions[7], 0.0f, 1e-5);
  EXPECT_FLOAT_EQ(m.color[2], 0.6f);
  ASSERT_TRUE(s.camera.has_value());
  const Camera& c = *s.camera;
  EXPECT_EQ(c.projection, Camera::Projection::Perspective);
  EXPECT_NEAR(c.eye[2], 5.0, 1e-12);
  EXPECT_NEAR(c.target[2], 4.0, 1e-12);  // looks down its -Z
  EXPECT_NEAR(c.up[1], 1.0, 1e-12);
  EXPECT_NEAR(c.fov_y_deg, 0.5 * 180 / M_PI, 1e-9);
  EXPECT_DOUBLE_EQ(c.near_plane, 0.1);
  EXPECT_DOUBLE_EQ(c.far_plane, 100.0);
  EXPECT_EQ(c.width, 1536u);  // aspectRatio 1.5 at the default height 1024
}

TEST(LoadGltf, GlbStripFanOrthographicFromFileAndMemory) {
  std::string path = test::data_dir() + "/scenes/strip_fan.glb";
  for (const Scene& s :
       {load_scene(path), load_scene_from_memory("up.glb", test::read_bytes(path))}) {
    ASSERT_EQ(s.meshes.size(), 2u);
    EXPECT_EQ(s.meshes[0].indices, (std::vector<uint32_t>{0, 1, 2, 2, 1, 3}));  // strip
    EXPECT_EQ(s.meshes[1].indices, (std::vector<uint32_t>{1, 3, 0, 3, 2, 0}));  // fan around 0
    EXPECT_FLOAT_EQ(s.meshes[1].positions[3], 2.0f);  // matrix translates by (1,0,0)
    ASSERT_TRUE(s.camera.has_value());
    EXPECT_EQ(s.camera->projection, Camera::Projection::Orthographic);
    EXPECT_DOUBLE_EQ(s.camera->ortho_height, 4.0);
    EXPECT_NEAR(s.camera->target[1], 4.0, 1e-12);  // rotated to look down -y
    EXPECT_NEAR(s.camera->up[2], -1.0, 1e-12);
  }
}

TEST(LoadSceneFile, TwoQuadsInstancedWithColorsAndCamera) {
  Scene s = load_scene(test::data_dir() + "/scenes/two_quads.json");
  ASSERT_EQ(s.meshes.size(), 2u);
  EXPECT_EQ(s.meshes[1].name, "front");
  EXPECT_FLOAT_EQ(s.meshes[1].positions[0], 0.0f);  // (-0.5,-0.5,0) + (0.5,0.5,0.5)
  EXPECT_FLOAT_EQ(s.meshes[1].positions[2], 0.5f);
  EXPECT_FLOAT_EQ(s.meshes[0].color[0], 0.8f);
  ASSERT_TRUE(s.camera.has_value());
  EXPECT_EQ(s.camera->projection, Camera::Projection::Orthographic);
  EXPECT_EQ(s.camera->width, 512u);
  EXPECT_DOUBLE_EQ(s.camera->far_plane, 10.0);
}

TEST(LoadSceneFile, TransformsComposeScaleThenRotateThenTranslate) {
  TempDir dir;
  dir.write("tri.obj", "v 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\n");
  std::string p = dir.write("s.json", R"({"meshes": [
    {"file": "tri.obj", "scale": [2, 1, 1], "rotate_deg": [0, 0, 90], "translate": [0, 0, 5]},
    {"file": "tri.obj", "rotate_axis_angle": [0, 0, 1, 90], "scale": 3},
    {"file": "tri.obj", "matrix": [1,0,0,0, 0,1,0,0, 0,0,1,0, 7,8,9,1]},
    {"file": "tri.obj", "scale": [-1, 1, 1]}]})");
  Scene s = load_scene(p);
  ASSERT_EQ(s.meshes.size(), 4u);
  auto& a = s.meshes[0].positions;  // (1,0,0) -> scale (2,0,0) -> rot z 90 (0,2,0) -> (0,2,5)
  EXPECT_NEAR(a[0], 0, 1e-6);
  EXPECT_NEAR(a[1], 2, 1e-6);
  EXPECT_NEAR(a[2], 5, 1e-6);
  EXPECT_NEAR(s.meshes[1].positions[1], 3, 1e-6);
  EXPECT_FLOAT_EQ(s.meshes[2].positions[0], 8.0f);
  // A mirror reverses the winding so that normals keep pointing out.
  EXPECT_EQ(s.meshes[3].indices, (std::vector<uint32_t>{0, 2, 1}));
}

TEST(LoadSceneFile, CornellArmadillo) {
  Scene s = load_scene(test::data_dir() + "/scenes/cornell_armadillo.json");
  ASSERT_EQ(s.meshes.size(), 9u);
  EXPECT_EQ(s.meshes[8].name, "armadillo");
  EXPECT_EQ(s.triangle_count(), 36u + 29170u);
  ASSERT_TRUE(s.camera.has_value());
  // The armadillo stands inside the box, on the floor.
  float lo = 1e9f, hi = -1e9f;
  for (size_t i = 1; i < s.meshes[8].positions.size(); i += 3) {
    lo = std::min(lo, s.meshes[8].positions[i]);
    hi = std::max(hi, s.meshes[8].positions[i]);
  }
  EXPECT_NEAR(lo, 0.0f, 1e-3);
  EXPECT_LT(hi, 1.99f);
}

TEST(LoadOptions, MaxTrianglesIsEnforced) {
  LoadOptions o;
  o.max_triangles = 1000;
  test::expect_error(test::data_dir() + "/bunny.ply", InputErrorKind::TooLarge, {"1000"}, o);
  o.max_triangles = 69451;
  EXPECT_EQ(load_scene(test::data_dir() + "/bunny.ply", o).triangle_count(), 69451u);
}

TEST(LoadGltf, ExternalBufferRelativeToTheFile) {
  TempDir dir;
  std::filesystem::create_directories(dir.path() + "/sub");
  float pos[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
  dir.write("sub/tri.bin", std::string(reinterpret_cast<const char*>(pos), sizeof pos));
  std::string gltf = R"({"asset":{"version":"2.0"},"scenes":[{"nodes":[0]}],"nodes":[{"mesh":0}],
    "meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}],
    "buffers":[{"byteLength":36,"uri":"tri.bin"}],
    "bufferViews":[{"buffer":0,"byteLength":36}],
    "accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}]})";
  Scene s = load_scene(dir.write("sub/tri.gltf", gltf));
  EXPECT_EQ(s.triangle_count(), 1u);
  EXPECT_EQ(s.meshes[0].face_ids, (std::vector<uint32_t>{0}));
  EXPECT_FALSE(s.camera.has_value());
  // The same bytes from memory may not read tri.bin; a missing buffer file is FileNotFound.
  EXPECT_THROW(load_scene_from_memory("up.gltf", gltf), InputError);
  std::string missing = dir.write("gone.gltf", gltf);
  test::expect_error(missing, InputErrorKind::FileNotFound, {"tri.bin"});
}

// Bezier patches (core/load/patches.cpp): the Newell tea set, in .bpt and in .patches.
namespace {

std::string teapot_dir() {
  return test::shared_dir() + "/teapot";
}

// Control point (i, j) of patch p (i along v, j along u; core/scene.h).
std::array<float, 3> control(const Mesh& m, size_t p, int i, int j) {
  const float* q = &m.patches[48 * p + 3 * (4 * i + j)];
  return {q[0], q[1], q[2]};
}

// The signed volume that the control nets enclose, each grid cell as the triangles
// (i,j) (i,j+1) (i+1,j+1) and (i,j) (i+1,j+1) (i+1,j), whose normals turn like S_u x S_v:
// positive when the patches face outward (core/util/mesh_topology.h's convention for triangles).
double control_net_volume(const Mesh& m) {
  double v = 0;
  auto tet = [](const std::array<float, 3>& a, const std::array<float, 3>& b,
                const std::array<float, 3>& c) {
    return (double(a[0]) * (double(b[1]) * c[2] - double(b[2]) * c[1]) -
            double(a[1]) * (double(b[0]) * c[2] - double(b[2]) * c[0]) +
            double(a[2]) * (double(b[0]) * c[1] - double(b[1]) * c[0])) /
           6;
  };
  for (size_t p = 0; p < m.patch_count(); ++p)
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) {
        auto a = control(m, p, i, j), b = control(m, p, i, j + 1), c = control(m, p, i + 1, j + 1),
             d = control(m, p, i + 1, j);
        v += tet(a, b, c) + tet(a, c, d);
      }
  return v;
}

}  // namespace

TEST(LoadPatches, NewellTeaSetCounts) {
  REQUIRE_SHARED();
  struct Case {
    const char* file;
    size_t patches;
  };
  for (Case c : {Case{"teapot.bpt", 32}, Case{"newell_teapot.patches", 32},
                 Case{"newell_teacup.patches", 26}, Case{"newell_teaspoon.patches", 16}}) {
    std::string path = teapot_dir() + "/" + c.file;
    Scene s = load_scene(path);
    ASSERT_EQ(s.meshes.size(), 1u) << c.file;
    const Mesh& m = s.meshes[0];
    EXPECT_EQ(m.patch_count(), c.patches) << c.file;
    EXPECT_EQ(m.patches.size(), 48 * c.patches) << c.file;
    EXPECT_EQ(m.source_triangles, c.patches) << c.file;  // ids run over the patches
    EXPECT_TRUE(m.positions.empty() && m.indices.empty() && m.face_ids.empty()) << c.file;
    EXPECT_TRUE(m.is_surface() && s.has_surfaces()) << c.file;
    EXPECT_EQ(m.name, std::filesystem::path(c.file).stem().string());
    EXPECT_FLOAT_EQ(m.color[0], 0.8f);
    EXPECT_EQ(s.triangle_count(), 0u);
    EXPECT_EQ(s.source, path);
    EXPECT_FALSE(scene_bounds(s).empty);
  }
}

TEST(LoadPatches, BptAndPatchesTeapotsAreTheSamePatchesInTheSameOrder) {
  REQUIRE_SHARED();
  Scene a = load_scene(teapot_dir() + "/teapot.bpt");
  Scene b = load_scene(teapot_dir() + "/newell_teapot.patches");
  // Point for point, in the same order: no reordering or transposition between the two files.
  EXPECT_EQ(a.meshes[0].patches, b.meshes[0].patches);
  const Mesh& m = a.meshes[0];
  // By hand from the files: teapot.bpt line 3 (patch 0's first point) and newell_teapot.patches
  // line 35 (point 1); .bpt line 6 (the 4th point: the end of the first row, j = 3) and
  // line 15 (the 13th: the start of the last row, i = 3); the last patch's last point, .bpt
  // line 545 and .patches line 305 (point 271, the last index of line 33).
  EXPECT_EQ(control(m, 0, 0, 0), (std::array<float, 3>{1.4f, 0.0f, 2.4f}));
  EXPECT_EQ(control(m, 0, 0, 3), (std::array<float, 3>{0.0f, -1.4f, 2.4f}));
  EXPECT_EQ(control(m, 0, 3, 0), (std::array<float, 3>{1.5f, 0.0f, 2.4f}));
  EXPECT_EQ(control(m, 31, 3, 3), (std::array<float, 3>{1.5f, 0.0f, 0.15f}));
}

TEST(LoadPatches, TeapotFacesOutward) {
  REQUIRE_SHARED();
  // The rows of a file's 16 points run along u: stored as (k / 4, k % 4), S_u x S_v points out.
  // The rim's first point: S_u ~ P01 - P00 = (0, -0.784, 0) (around the z axis), S_v ~ P10 - P00
  // = (-0.0625, 0, 0.13125) (up over the lip), S_u x S_v = (-0.103, 0, -0.049): away from the
  // lip's inside. Over the whole pot the control nets enclose +32.10 (measured).
  for (const char* f : {"teapot.bpt", "newell_teapot.patches"}) {
    Scene s = load_scene(teapot_dir() + "/" + f);
    EXPECT_NEAR(control_net_volume(s.meshes[0]), 32.105, 0.01) << f;
  }
}

TEST(LoadPatches, BadInputNamesTheLine) {
  using K = InputErrorKind;
  TempDir dir;
  std::string pts;  // 16 point lines of one .bpt patch
  for (int k = 0; k < 16; ++k) pts += std::to_string(k % 4) + " " + std::to_string(k / 4) + " 0\n";
  std::string one = "1\n3 3\n" + pts;
  ASSERT_EQ(load_scene(dir.write("ok.bpt", one)).meshes[0].patch_count(), 1u);
  // .bpt, line by line: count 1, degrees 2, points 3..18.
  test::expect_error(dir.write("trunc.bpt", "1\n3 3\n" + pts.substr(0, pts.size() - 6)),
                     K::Truncated, {"line 18: file ends before point 15 of patch 0"});
  test::expect_error(dir.write("short.bpt", "2\n3 3\n" + pts + "\n\n"), K::Truncated,
                     {"patch 1", "file ends before patch 1 of 2"});
  test::expect_error(dir.write("extra.bpt", one + "3 3\n"), K::ParseError,
                     {"line 19: content after the 1 patches"});
  test::expect_error(
      dir.write("nan.bpt", "1\n3 3\n" + pts.substr(0, 6 * 6) + "0 nan 0\n" + pts.substr(7 * 6)),
      K::NonFiniteVertex, {"patch 0", "line 9: coordinate y is not finite"});
  test::expect_error(
      dir.write("big.bpt", "1\n3 3\n" + pts.substr(0, 6) + "1e39 0 0\n" + pts.substr(12)),
      K::NonFiniteVertex, {"line 4: coordinate x is not finite"});
  test::expect_error(
      dir.write("word.bpt", "1\n3 3\n" + pts.substr(0, 12) + "0 one 0\n" + pts.substr(18)),
      K::ParseError, {"line 5: expected a number, got 'one'"});
  test::expect_error(dir.write("two.bpt", "1\n3 3\n0 0\n" + pts.substr(6)), K::ParseError,
                     {"line 3: expected 3 numbers, got 2"});
  test::expect_error(dir.write("quad.bpt", "1\n3 2\n" + pts), K::ParseError,
                     {"line 2: degrees 3 2: only bicubic patches (3 3) are supported"});
  test::expect_error(dir.write("zero.bpt", "0\n"), K::EmptyMesh, {"line 1: no patches"});
  test::expect_error(dir.write("neg.bpt", "-1\n"), K::ParseError, {"line 1: bad patch count"});
  test::expect_error(dir.write("empty.bpt", ""), K::Truncated,
                     {"line 1: file ends before the patch count"});
  // A count the bytes cannot hold is refused before anything is allocated for it.
  test::expect_error(dir.write("huge.bpt", "5000000000\n3 3\n" + pts), K::TooLarge,
                     {"line 1: 5000000000 patches, limit is 2^32 - 1"});
  // A count larger than the file: the reading stops at its end (nothing reserved past its bytes).
  test::expect_error(dir.write("lie.bpt", "1000000000\n3 3\n" + pts), K::Truncated,
                     {"patch 1", "line 19: file ends before patch 1 of 1000000000"});
  LoadOptions few;
  few.max_triangles = 1;
  test::expect_error(dir.write("two_ok.bpt", "2\n3 3\n" + pts + "3 3\n" + pts), K::TooLarge,
                     {"2 triangles, limit is 1"}, few);

  // .patches: count 1, one index line 2, point count 3, points 4..19.
  std::string idx = "1,2,3,4,5,6,7,8,9,10,11,12,13,14,15,16\n", cpts;
  for (int k = 0; k < 16; ++k) cpts += std::to_string(k % 4) + "," + std::to_string(k / 4) + ",0\n";
  std::string onep = "1\n" + idx + "16\n" + cpts;
  ASSERT_EQ(load_scene(dir.write("ok.patches", onep)).meshes[0].patch_count(), 1u);
  // Repeated indices (Newell's degenerate lid and bottom patches) are legal.
  ASSERT_EQ(
      load_scene(dir.write("rep.patches", "1\n1,1,1,1,5,6,7,8,9,10,11,12,13,14,15,16\n16\n" + cpts))
          .meshes[0]
          .patch_count(),
      1u);
  test::expect_error(
      dir.write("oob.patches", "1\n1,2,3,4,5,6,7,8,9,10,11,12,13,14,15,17\n16\n" + cpts),
      K::IndexOutOfRange,
      {"patch 0", "line 2: point index 17 out of range (16 points, numbered from 1)"});
  test::expect_error(
      dir.write("zero.patches", "1\n0,2,3,4,5,6,7,8,9,10,11,12,13,14,15,16\n16\n" + cpts),
      K::IndexOutOfRange, {"line 2: point index 0 out of range"});
  test::expect_error(
      dir.write("fifteen.patches", "1\n1,2,3,4,5,6,7,8,9,10,11,12,13,14,15\n16\n" + cpts),
      K::ParseError, {"line 2: expected 16 point indices, got 15"});
  test::expect_error(
      dir.write("hole.patches", "1\n1,2,3,4,5,6,7,8,9,,11,12,13,14,15,16\n16\n" + cpts),
      K::ParseError, {"line 2: expected an integer, got ''"});
  test::expect_error(dir.write("few.patches", "2\n" + idx + "16\n" + cpts), K::ParseError,
                     {"line 3: expected 16 point indices, got 1"});
  test::expect_error(dir.write("morepatches.patches", "1\n" + idx + idx + "16\n" + cpts),
                     K::ParseError, {"line 3: expected 1 point count, got 16"});
  test::expect_error(dir.write("fewpts.patches", "1\n" + idx + "17\n" + cpts), K::Truncated,
                     {"line 20: file ends before point 17 of 17"});
  test::expect_error(dir.write("morepts.patches", onep + "0,0,0\n"), K::ParseError,
                     {"line 20: content after the 16 points"});
  test::expect_error(dir.write("inf.patches", "1\n" + idx + "16\n" + cpts.substr(0, 6) +
                                                  "0,-inf,0\n" + cpts.substr(12)),
                     K::NonFiniteVertex, {"point 1", "line 5: coordinate y is not finite"});
  test::expect_error(dir.write("x.patches", "1\n" + idx + "16\n0,0;0\n" + cpts.substr(6)),
                     K::ParseError, {"line 4: expected 3 numbers, got 2"});
  test::expect_error(dir.write("zero2.patches", "0\n16\n" + cpts), K::EmptyMesh,
                     {"line 1: no patches"});
  test::expect_error(dir.write("lie.patches", "1\n" + idx + "4000000000\n" + cpts), K::Truncated,
                     {"point 16", "line 20: file ends before point 17 of 4000000000"});
  test::expect_error(dir.write("huge.patches", "1\n" + idx + "5000000000\n" + cpts), K::TooLarge,
                     {"line 3: 5000000000 points, limit is 2^32 - 1"});
}

TEST(LoadPatches, SceneFileTransformsControlPointsAndTransposesWhenMirrored) {
  REQUIRE_SHARED();
  TempDir dir;
  std::string bpt = teapot_dir() + "/teapot.bpt", pat = teapot_dir() + "/newell_teapot.patches";
  std::string p = dir.write("s.json", R"({"meshes": [
    {"file": ")" + bpt + R"(", "scale": 2, "translate": [1, 0, -3], "color": [1, 0, 0]},
    {"file": ")" + pat + R"(", "matrix": [-1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1]},
    {"file": ")" + bpt + R"(", "name": "pot", "scale": [1, 1, 1]}]})");
  Scene s = load_scene(p);
  ASSERT_EQ(s.meshes.size(), 3u);
  const Mesh &moved = s.meshes[0], &mirrored = s.meshes[1], &plain = s.meshes[2];
  EXPECT_EQ(moved.color, (std::array<float, 3>{1, 0, 0}));
  EXPECT_EQ(plain.name, "pot");
  ASSERT_EQ(moved.patch_count(), 32u);
  // (1.4, 0, 2.4) * 2 + (1, 0, -3) = (3.8, 0, 1.8).
  auto a = control(moved, 0, 0, 0);
  EXPECT_FLOAT_EQ(a[0], 3.8f);
  EXPECT_FLOAT_EQ(a[1], 0.0f);
  EXPECT_FLOAT_EQ(a[2], 1.8f);
  for (size_t q = 0; q < 32; ++q)
    for (int i = 0; i < 4; ++i)
      for (int j = 0; j < 4; ++j) {
        auto o = control(plain, q, i, j), t = control(moved, q, i, j);
        for (int c = 0; c < 3; ++c)
          ASSERT_FLOAT_EQ(t[c], 2 * o[c] + (c == 0 ? 1.0f : c == 2 ? -3.0f : 0.0f));
        // Mirrored in x and transposed: P'_ij = mirror(P_ji).
        auto mj = control(mirrored, q, j, i);
        ASSERT_EQ(mj, (std::array<float, 3>{-o[0], o[1], o[2]})) << q << " " << i << " " << j;
      }
  // Still outward after the mirror (a linear map, so the open teapot's volume is comparable).
  EXPECT_NEAR(control_net_volume(mirrored), 32.105, 0.01);
  EXPECT_NEAR(control_net_volume(plain), 32.105, 0.01);
}

TEST(LoadPatches, SceneFileTransformToInfinityIsRefused) {
  REQUIRE_SHARED();
  TempDir dir;
  std::string p = dir.write(
      "s.json", R"({"meshes": [{"file": ")" + teapot_dir() + R"(/teapot.bpt", "scale": 1e39}]})");
  test::expect_error(p, InputErrorKind::NonFiniteVertex,
                     {"patch 0", "control point 0 not finite after the transform of meshes[0]"});
}

TEST(LoadPatches, FromMemoryAndUnknownFormatListsThem) {
  std::string pts;
  for (int k = 0; k < 16; ++k) pts += std::to_string(k % 4) + " " + std::to_string(k / 4) + " 1\n";
  Scene s = load_scene_from_memory("m.bpt", "1\n3 3\n" + pts);
  EXPECT_EQ(s.meshes[0].patch_count(), 1u);
  EXPECT_EQ(control(s.meshes[0], 0, 2, 1), (std::array<float, 3>{1, 2, 1}));  // point k = 9
  try {
    load_scene_from_memory("m.bezier", "");
    ADD_FAILURE() << "loaded an unknown format";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(".bpt .patches"), std::string::npos) << e.what();
  }
}

// Issue 45, item 5: polygons were fanned from their first corner, right only where they are
// convex. Concave and self-touching faces are now cut into ears (core/util/polygon.h), the same
// k - 2 triangles in the face's place; convex ones keep the fan exactly.
namespace {
// Twice the area of the triangles in the xy plane: unsigned (covered, counting overlaps twice)
// and signed (counter-clockwise positive).
std::pair<double, double> xy_area2(const Scene& s) {
  double cover = 0, sum = 0;
  for (const Mesh& m : s.meshes)
    for (size_t t = 0; t + 2 < m.indices.size(); t += 3) {
      const float* a = &m.positions[3 * size_t(m.indices[t])];
      const float* b = &m.positions[3 * size_t(m.indices[t + 1])];
      const float* c = &m.positions[3 * size_t(m.indices[t + 2])];
      const double d = (double(b[0]) - a[0]) * (double(c[1]) - a[1]) -
                       (double(b[1]) - a[1]) * (double(c[0]) - a[0]);
      cover += std::fabs(d);
      sum += d;
    }
  return {cover, sum};
}
const std::string kPolygons = std::string(VISMAP_SOURCE_DIR) + "/tests/data/polygons/";
}  // namespace

TEST(LoadPolygons, CShapedOctagonLeavesItsOpeningOpen) {
  // The fan from corner 1 covered 9 + the opening's 2 (area 7 + 2 over its own): every reader.
  TempDir dir;
  const std::string off =
      "OFF\n8 1 0\n0 0 0\n3 0 0\n3 1 0\n1 1 0\n1 2 0\n3 2 0\n3 3 0\n0 3 0\n8 0 1 2 3 4 5 6 7\n";
  const std::string ply =
      "ply\nformat ascii 1.0\nelement vertex 8\nproperty float x\nproperty float y\n"
      "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
      "0 0 0\n3 0 0\n3 1 0\n1 1 0\n1 2 0\n3 2 0\n3 3 0\n0 3 0\n8 0 1 2 3 4 5 6 7\n";
  for (const std::string& path :
       {kPolygons + "c_shape.obj", dir.write("c.off", off), dir.write("c.ply", ply)}) {
    Scene s = load_scene(path);
    ASSERT_EQ(s.triangle_count(), 6u) << path;  // k - 2
    EXPECT_EQ(s.meshes[0].face_ids, (std::vector<uint32_t>{0, 1, 2, 3, 4, 5})) << path;
    const auto [cover, sum] = xy_area2(s);
    EXPECT_DOUBLE_EQ(cover, 14.0) << path << ": covered twice the area 7, no more";
    EXPECT_DOUBLE_EQ(sum, 14.0) << path << ": every triangle counter-clockwise, as the face";
    EXPECT_TRUE(s.warnings.empty()) << s.warnings[0];
  }
}

TEST(LoadPolygons, RingTouchingItselfIsCutRight) {
  Scene s = load_scene(kPolygons + "ring.obj");
  const auto [cover, sum] = xy_area2(s);
  EXPECT_DOUBLE_EQ(cover, 24.0);  // 16 - 4, twice
  EXPECT_DOUBLE_EQ(sum, 24.0);
  EXPECT_LE(s.triangle_count(), 8u);  // k - 2, less the zero-area ones along the bridge
  EXPECT_TRUE(s.warnings.empty());
}

// assimp's 66-gon ring (Debian's assimp-testmodels): a disk 13x its area when fanned.
TEST(LoadPolygons, AssimpConcavePolygon) {
  const std::string path = "/usr/share/assimp/models/OBJ/concave_polygon.obj";
  if (!std::filesystem::exists(path)) GTEST_SKIP() << path << " absent (assimp-testmodels)";
  Scene s = load_scene(path);
  // The face's own area (twice, shoelace in its plane x = -1.146: y, z), read from the file.
  std::ifstream in(path);
  std::vector<std::array<double, 2>> v;
  std::string line;
  double face2 = 0;
  while (std::getline(in, line)) {
    std::istringstream ls(line);
    std::string kw;
    ls >> kw;
    if (kw == "v") {
      double x, y, z;
      ls >> x >> y >> z;
      v.push_back({y, z});
    } else if (kw == "f") {
      std::vector<int> c;
      for (std::string t; ls >> t;) c.push_back(std::stoi(t) - 1);
      for (size_t i = 0; i < c.size(); ++i) {
        const auto& a = v[c[i]];
        const auto& b = v[c[(i + 1) % c.size()]];
        face2 += a[0] * b[1] - b[0] * a[1];
      }
    }
  }
  double cover = 0;
  const Mesh& m = s.meshes[0];
  for (size_t t = 0; t < m.indices.size(); t += 3) {
    const float* a = &m.positions[3 * size_t(m.indices[t])];
    const float* b = &m.positions[3 * size_t(m.indices[t + 1])];
    const float* c = &m.positions[3 * size_t(m.indices[t + 2])];
    cover += std::fabs((double(b[1]) - a[1]) * (double(c[2]) - a[2]) -
                       (double(b[2]) - a[2]) * (double(c[1]) - a[1]));
  }
  EXPECT_NEAR(cover, std::fabs(face2), 1e-4 * std::fabs(face2))
      << "covered area against the ring's own; the fan covered 13x";
  EXPECT_TRUE(s.warnings.empty());
}

TEST(LoadPolygons, ConvexPolygonsKeepTheFan) {
  // A convex hexagon, a quad out of plane (a saddle), a square with a flat corner on an edge:
  // each exactly the fan from its first corner, as before.
  TempDir dir;
  std::string p = dir.write("convex.obj",
                            "v 2 0 0\nv 1 1.7 0\nv -1 1.7 0\nv -2 0 0\nv -1 -1.7 0\nv 1 -1.7 0\n"
                            "v 0 0 1\nv 1 0 0\nv 1 1 1\nv 0 1 0\n"
                            "v 0 0 0\nv 2 0 0\nv 2 2 0\nv 1 2 0\nv 0 2 0\n"
                            "f 1 2 3 4 5 6\nf 7 8 9 10\nf 11 12 13 14 15\n");
  Scene s = load_scene(p);
  const std::vector<uint32_t> fan = {0, 1, 2, 0, 2,  3,  0,  3,  4,  0,  4,  5,  6, 7,
                                     8, 6, 8, 9, 10, 11, 12, 10, 12, 13, 10, 13, 14};
  EXPECT_EQ(s.meshes[0].indices, fan);
}

// A polygon whose edges cross is not simple: it keeps the fan, and the load warns, naming the
// file, the face and its line (the CLI prints it on stderr).
TEST(LoadPolygons, StarPentagonIsWarnedOf) {
  const std::string path = kPolygons + "star.obj";
  Scene s = load_scene(path);
  EXPECT_EQ(s.triangle_count(), 4u);  // the triangle and the pentagon's 3
  ASSERT_EQ(s.warnings.size(), 1u);
  const std::string& w = s.warnings[0];
  for (const std::string& part :
       {path, std::string("face 1"), std::string("line 9"), std::string("not simple")})
    EXPECT_NE(w.find(part), std::string::npos) << part << " not in: " << w;
}
