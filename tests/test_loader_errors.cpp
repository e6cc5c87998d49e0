// Every kind of bad input gets an InputError of the right kind whose message names the file and
// the element (and index) at fault. Bad files are written into a temporary folder.
#include <zlib.h>

#include <cmath>
#include <cstring>

#include "tests/loader_test_util.h"

using namespace vismap;
using vismap::test::expect_error;
using vismap::test::TempDir;
using K = InputErrorKind;

namespace {

const char* kTriPlyHead =
    "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
    "property float z\nelement face 2\nproperty list uchar int vertex_indices\nend_header\n";

std::string binary_ply(int faces_written) {
  std::string b =
      "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
      "property float z\nelement face 3\nproperty list uchar int vertex_indices\nend_header\n";
  float v[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
  b.append(reinterpret_cast<const char*>(v), sizeof v);
  for (int f = 0; f < faces_written; ++f) {
    b += char(3);
    int32_t idx[3] = {0, 1, 2};
    b.append(reinterpret_cast<const char*>(idx), sizeof idx);
  }
  return b;
}

std::string gzip(const std::string& s) {
  z_stream z{};
  deflateInit2(&z, 6, Z_DEFLATED, 15 + 16, 8, Z_DEFAULT_STRATEGY);
  std::string out(deflateBound(&z, s.size()) + 32, '\0');
  z.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(s.data()));
  z.avail_in = uInt(s.size());
  z.next_out = reinterpret_cast<Bytef*>(out.data());
  z.avail_out = uInt(out.size());
  deflate(&z, Z_FINISH);
  out.resize(z.total_out);
  deflateEnd(&z);
  return out;
}

}  // namespace

TEST(LoadErrors, MissingFileAndUnknownFormat) {
  TempDir dir;
  expect_error(dir.path() + "/nope.ply", K::FileNotFound, {});
  expect_error(dir.write("mesh.xyz", "1 2 3\n"), K::UnknownFormat, {".xyz"});
  expect_error(dir.write("noext", "ply\n"), K::UnknownFormat, {});
  try {
    load_scene_from_memory("upload.fbx", "bytes");
    ADD_FAILURE();
  } catch (const InputError& e) {
    EXPECT_EQ(e.kind(), K::UnknownFormat);
    EXPECT_NE(std::string(e.what()).find("upload.fbx"), std::string::npos);
  }
}

TEST(LoadErrors, TruncatedAsciiAndBinaryPly) {
  TempDir dir;
  expect_error(dir.write("a.ply", std::string(kTriPlyHead) + "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n3 0"),
               K::Truncated, {"face 1"});
  expect_error(dir.write("v.ply", std::string(kTriPlyHead) + "0 0 0\n1 0"), K::Truncated, {"vertex 1"});
  expect_error(dir.write("b.ply", binary_ply(2)), K::Truncated, {"face 2"});
  expect_error(dir.write("h.ply", "ply\nformat ascii 1.0\nelement vertex 3\n"), K::Truncated, {"end_header"});
  EXPECT_EQ(load_scene(dir.write("ok.ply", binary_ply(3))).meshes[0].source_triangles, 3u);
}

TEST(LoadErrors, TruncatedGzipAndGlb) {
  TempDir dir;
  std::string bunny = test::read_bytes(test::data_dir() + "/bunny.ply");
  std::string gz = gzip(bunny);
  EXPECT_EQ(load_scene(dir.write("ok.ply.gz", gz)).triangle_count(), 69451u);
  expect_error(dir.write("cut.ply.gz", gz.substr(0, gz.size() / 2)), K::Truncated, {"gzip"});
  expect_error(dir.write("junk.ply.gz", "this is not gzip at all"), K::ParseError, {"gzip"});
  std::string glb = test::read_bytes(test::data_dir() + "/scenes/strip_fan.glb");
  expect_error(dir.write("cut.glb", glb.substr(0, glb.size() - 10)), K::Truncated, {"bytes"});
  expect_error(dir.write("tiny.glb", glb.substr(0, 6)), K::Truncated, {"header"});
  try {
    load_scene_from_memory("cut.glb", glb.substr(0, 100));
    ADD_FAILURE();
  } catch (const InputError& e) {
    EXPECT_EQ(e.kind(), K::Truncated);
  }
}

TEST(LoadErrors, NonFiniteVertices) {
  TempDir dir;
  expect_error(dir.write("nan.ply", std::string(kTriPlyHead) + "0 0 0\n1 0 0\n0 nan 0\n3 0 1 2\n3 0 1 2\n"),
               K::NonFiniteVertex, {"vertex 2", "y"});
  expect_error(dir.write("inf.obj", "v 0 0 0\nv 1 0 0\nv 0 1 inf\nf 1 2 3\n"), K::NonFiniteVertex,
               {"vertex 2", "line 3"});
  expect_error(dir.write("inf.off", "OFF\n3 1 0\n0 0 0\n-inf 0 0\n0 1 0\n3 0 1 2\n"),
               K::NonFiniteVertex, {"vertex 1"});
  std::string stl(80, ' ');
  uint32_t n = 1;
  stl.append(reinterpret_cast<const char*>(&n), 4);
  float t[12] = {0, 0, 1, 0, 0, 0, 1, 0, 0, 0, NAN, 0};
  stl.append(reinterpret_cast<const char*>(t), 48);
  stl.append(2, '\0');
  expect_error(dir.write("nan.stl", stl), K::NonFiniteVertex, {"vertex 2"});
  // Overflowing a float after a scene transform is caught as well.
  dir.write("tri.obj", "v 1e38 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\n");
  expect_error(dir.write("big.json", R"({"meshes":[{"file":"tri.obj","scale":1e10}]})"),
               K::NonFiniteVertex, {"vertex 0"});
}

TEST(LoadErrors, IndexOutOfRange) {
  TempDir dir;
  expect_error(dir.write("i.ply", std::string(kTriPlyHead) + "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n3 0 99 2\n"),
               K::IndexOutOfRange, {"face 1", "99"});
  expect_error(dir.write("neg.ply", std::string(kTriPlyHead) + "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n3 0 -1 2\n"),
               K::IndexOutOfRange, {"face 1", "-1"});
  expect_error(dir.write("i.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 7\n"), K::IndexOutOfRange,
               {"face 1", "7", "line 5"});
  expect_error(dir.write("i.off", "OFF\n3 2 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n3 0 1 3\n"),
               K::IndexOutOfRange, {"face 1", "3"});
  // glTF: an index accessor pointing past the 3 vertices of triangle_camera.gltf's buffer.
  std::string g = test::read_bytes(test::data_dir() + "/scenes/triangle_camera.gltf");
  size_t at = g.find("base64,") + 7;
  // Replace the buffer by 9 zero floats and indices 0, 1, 5.
  std::string bytes(36, '\0');
  uint16_t idx[4] = {0, 1, 5, 0};
  bytes.append(reinterpret_cast<const char*>(idx), 8);
  static const char* b64 = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string enc;
  for (size_t i = 0; i < bytes.size(); i += 3) {
    uint32_t v = uint8_t(bytes[i]) << 16 | (i + 1 < bytes.size() ? uint8_t(bytes[i + 1]) << 8 : 0) |
                 (i + 2 < bytes.size() ? uint8_t(bytes[i + 2]) : 0);
    enc += b64[v >> 18 & 63];
    enc += b64[v >> 12 & 63];
    enc += i + 1 < bytes.size() ? b64[v >> 6 & 63] : '=';
    enc += i + 2 < bytes.size() ? b64[v & 63] : '=';
  }
  g.replace(at, g.find('"', at) - at, enc);
  expect_error(dir.write("i.gltf", g), K::IndexOutOfRange, {"index 2", "5"});
}

TEST(LoadErrors, EmptyMeshes) {
  TempDir dir;
  expect_error(dir.write("e.ply",
                         "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
                         "property float z\nelement face 0\nproperty list uchar int vertex_indices\n"
                         "end_header\n0 0 0\n"),
               K::EmptyMesh, {"no triangles"});
  expect_error(dir.write("e.obj", "v 0 0 0\n"), K::EmptyMesh, {});
  expect_error(dir.write("e.off", "OFF\n0 0 0\n"), K::EmptyMesh, {});
  expect_error(dir.write("e.stl", "solid x\nendsolid x\n"), K::EmptyMesh, {});
  expect_error(dir.write("d.obj", "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n"), K::EmptyMesh, {"degenerate"});
  expect_error(dir.write("e.json", R"({"meshes": []})"), K::EmptyMesh, {"meshes"});
}

TEST(LoadErrors, ParseErrorsNameTheLine) {
  TempDir dir;
  expect_error(dir.write("p.off", "OFF\n3 1 0\n0 0 0\n1 zero 0\n0 1 0\n3 0 1 2\n"), K::ParseError,
               {"vertex 1", "line 4", "zero"});
  expect_error(dir.write("p.ply", std::string(kTriPlyHead) + "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n3 0 x 2\n"),
               K::ParseError, {"face 1", "line 14"});
  expect_error(dir.write("h.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty blob x\nend_header\n"),
               K::ParseError, {"header line 4", "blob"});
  expect_error(dir.write("p.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 three\n"), K::ParseError,
               {"face 0", "line 4"});
  expect_error(dir.write("p.stl", "solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0\nendloop\n"),
               K::ParseError, {"facet 0", "line 5"});
  expect_error(dir.write("p.gltf", "{\"asset\": {\"version\": \"2.0\"}, \"meshes\": ["), K::ParseError, {"glTF"});
}

TEST(LoadErrors, BadJsonAndSceneKeys) {
  TempDir dir;
  dir.write("tri.obj", "v 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\n");
  expect_error(dir.write("j1.json", "{\"meshes\": [\n {\"file\": \"tri.obj\",}\n]}"), K::ParseError, {"line 2"});
  expect_error(dir.write("j2.json", "{\"meshes\": [\n {\"file\": \"tri.obj\""), K::Truncated, {"line 2"});
  expect_error(dir.write("k1.json", R"({"meshes":[{"file":"tri.obj"},{"file":"tri.obj","scal":2}]})"),
               K::BadScene, {"meshes[1].scal", "unknown key"});
  expect_error(dir.write("k2.json", R"({"meshes":[{"file":"tri.obj","scale":"big"}]})"), K::BadScene,
               {"meshes[0].scale"});
  expect_error(dir.write("k3.json", R"({"meshes":[{"file":"tri.obj","translate":[1,2]}]})"), K::BadScene,
               {"meshes[0].translate"});
  expect_error(dir.write("k4.json", R"({"meshes":[{"file":"tri.obj","color":[1,"r",0]}]})"), K::BadScene,
               {"meshes[0].color[1]"});
  expect_error(dir.write("k5.json", R"({"meshes":[{"file":"tri.obj"}],"camera":{"width":-4}})"), K::BadScene,
               {"camera.width"});
  expect_error(dir.write("k6.json", R"({"meshes":[{"file":"tri.obj"}],"camera":{"fov":30}})"), K::BadScene,
               {"camera.fov", "unknown key"});
  expect_error(dir.write("k7.json", R"({"meshes":[{"file":"tri.obj"}],"lights":[]})"), K::BadScene, {"lights"});
  expect_error(dir.write("k8.json", R"({"meshes":[{"file":"tri.obj","matrix":[1,0,0],"scale":2}]})"),
               K::BadScene, {"meshes[0].matrix"});
  expect_error(dir.write("k9.json", R"({"meshes":[{"translate":[0,0,0]}]})"), K::BadScene, {"meshes[0].file"});
  expect_error(dir.write("c.json", R"({"meshes":[{"file":"tri.obj"}],"camera":{"eye":[0,0,0],"target":[0,0,0]}})"),
               K::BadCamera, {"camera"});
  // A missing referenced file names that file.
  expect_error(dir.write("m.json", R"({"meshes":[{"file":"gone.ply"}]})"), K::FileNotFound, {"gone.ply"});
  // A number too large for any JSON number type (found by the loader fuzzer): ParseError, not
  // an escaping nlohmann exception.
  expect_error(dir.write("n.json", R"({"meshes":[{"file":"tri.obj","scale":)" + std::string(400, '2') + "}]}"),
               K::ParseError, {"n.json"});
  // Uploaded scene files cannot reach the file system.
  try {
    load_scene_from_memory("up.json", R"({"meshes":[{"file":"/etc/passwd.ply"}]})");
    ADD_FAILURE();
  } catch (const InputError& e) {
    EXPECT_EQ(e.kind(), K::BadScene);
    EXPECT_NE(std::string(e.what()).find("meshes[0].file"), std::string::npos) << e.what();
  }
}
