// Parsing of the control messages (proto/PROTOCOL.md): every protocol error code that the parser
// decides, and the mirror of vismap::InputErrorKind codes.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "server/protocol.h"

using namespace vismap::server;

static std::string code_of(const std::string& text, uint64_t max_scene = 1000) {
  try {
    parse_request(text, max_scene, 4096);
  } catch (const ProtoError& e) {
    return e.code;
  }
  return "ok";
}

TEST(Protocol, HelloNegotiatesVersion) {
  auto r = parse_request(
      R"({"type":"hello","versions":[4,1],"format":"bin","viewport":{"width":64,"height":32}})", 10,
      4096);
  auto& h = std::get<Hello>(r);
  EXPECT_EQ(h.version, 1);
  EXPECT_EQ(h.format, Format::Bin);
  EXPECT_EQ(h.width, 64u);
  EXPECT_EQ(h.height, 32u);
}

TEST(Protocol, Version2IsPickedWhenOffered) {
  auto hello = [](const char* text) { return std::get<Hello>(parse_request(text, 10, 4096)); };
  EXPECT_EQ(hello(R"({"type":"hello","versions":[1,2]})").version, 2);
  EXPECT_EQ(hello(R"({"type":"hello","versions":[2,1,7]})").version, 2);
  EXPECT_EQ(hello(R"({"type":"hello","version":1,"versions":[2]})").version, 2);
  EXPECT_EQ(hello(R"({"type":"hello","version":1})").version, 1);
  Hello h = hello(R"({"type":"hello","version":2,"format":"compact"})");
  EXPECT_EQ(h.format, Format::Compact);
  EXPECT_EQ(h.quantum, 16u);
  EXPECT_EQ(h.compression, vismap::Compression::Zstd);
  EXPECT_FALSE(h.fill_id);
  h = hello(
      R"({"type":"hello","version":2,"format":"compact","quantum":3,"compression":"deflate","fill":"id"})");
  EXPECT_EQ(h.quantum, 3u);
  EXPECT_EQ(h.compression, vismap::Compression::Deflate);
  EXPECT_TRUE(h.fill_id);
  // Version 1 does not know quantum or compression: ignored, as any field it does not list.
  h = hello(R"({"type":"hello","version":1,"format":"bin","quantum":-4,"compression":9})");
  EXPECT_EQ(h.version, 1);
  EXPECT_EQ(h.quantum, 16u);
}

TEST(Protocol, CompactRefusals) {
  EXPECT_EQ(code_of(R"({"type":"hello","version":1,"format":"compact"})"), "bad_message");
  EXPECT_EQ(code_of(R"({"type":"hello","version":2,"format":"compact","attributes":true})"),
            "bad_message");
  EXPECT_EQ(code_of(R"({"type":"hello","version":2,"format":"compact","attributes":false})"), "ok");
  EXPECT_EQ(code_of(R"({"type":"hello","version":2,"quantum":0})"), "bad_message");
  EXPECT_EQ(code_of(R"({"type":"hello","version":2,"quantum":257})"), "bad_message");
  EXPECT_EQ(code_of(R"({"type":"hello","version":2,"quantum":256})"), "ok");
  EXPECT_EQ(code_of(R"({"type":"hello","version":2,"quantum":1})"), "ok");
  EXPECT_EQ(code_of(R"({"type":"hello","version":2,"quantum":1e3})"), "bad_message");
  // The CLI's words and range (issue 45, item 9: one constant, kMaxQuantum).
  try {
    parse_request(R"({"type":"hello","version":2,"quantum":300})", 1000, 4096);
    ADD_FAILURE() << "quantum 300 was accepted";
  } catch (const ProtoError& e) {
    EXPECT_NE(std::string(e.what()).find("1 ... 256 grid steps per pixel"), std::string::npos)
        << e.what();
  }
  EXPECT_EQ(code_of(R"({"type":"hello","version":2,"compression":"gzip"})"), "bad_message");
  EXPECT_EQ(code_of(R"({"type":"hello","version":2,"format":"delta"})"), "ok");
  EXPECT_EQ(code_of(R"({"type":"hello","version":1,"format":"delta"})"), "bad_message");
  EXPECT_EQ(code_of(R"({"type":"hello","version":2,"format":"delta","attributes":true})"),
            "bad_message");
  EXPECT_EQ(code_of(R"({"type":"hello","version":2,"format":"delta","keyframe_every":-1})"),
            "bad_message");
  EXPECT_EQ(code_of(R"({"type":"hello","version":2,"format":"delta","keyframe_every":30})"), "ok");
  // hold_scene: version 3, delta only, a boolean; version 2 ignores it as any unlisted field.
  EXPECT_EQ(code_of(R"({"type":"hello","version":3,"format":"delta","hold_scene":true})"), "ok");
  EXPECT_EQ(code_of(R"({"type":"hello","version":3,"format":"compact","hold_scene":true})"),
            "bad_message");
  EXPECT_EQ(code_of(R"({"type":"hello","version":3,"format":"delta","hold_scene":1})"),
            "bad_message");
  EXPECT_EQ(code_of(R"({"type":"hello","version":2,"format":"compact","hold_scene":true})"), "ok");
  EXPECT_EQ(code_of(R"({"type":"keyframe"})"), "ok");
  EXPECT_EQ(code_of(R"({"type":"hello","version":2,"format":"frobnicate"})"), "bad_message");
  try {
    parse_request(R"({"type":"hello","version":1,"format":"compact"})", 10, 4096);
  } catch (const ProtoError& e) {
    EXPECT_NE(std::string(e.what()).find("protocol version 2"), std::string::npos) << e.what();
    EXPECT_FALSE(e.fatal);
  }
}

TEST(Protocol, FormatTableNamesEveryFormat) {
  for (size_t i = 0; i < kFormats.size(); ++i) {
    EXPECT_EQ(static_cast<size_t>(kFormats[i].format), i);
    EXPECT_GE(kFormats[i].since_version, kMinProtocolVersion);
    EXPECT_LE(kFormats[i].since_version, kMaxProtocolVersion);
  }
  EXPECT_STREQ(format_spec(Format::Compact).name, "compact");
  EXPECT_TRUE(format_spec(Format::Compact).binary);
  EXPECT_FALSE(format_spec(Format::Svg).binary);
}

TEST(Protocol, VersionMismatchIsFatal) {
  try {
    parse_request(R"({"type":"hello","versions":[0,4]})", 10, 4096);
    FAIL();
  } catch (const ProtoError& e) {
    EXPECT_EQ(e.code, "version_mismatch");
    EXPECT_TRUE(e.fatal);
  }
}

TEST(Protocol, ErrorCodes) {
  EXPECT_EQ(code_of("{not json"), "bad_json");
  EXPECT_EQ(code_of(""), "bad_json");
  EXPECT_EQ(code_of("[1,2]"), "bad_message");
  EXPECT_EQ(code_of(R"({"kind":"hello"})"), "bad_message");
  EXPECT_EQ(code_of(R"({"type":"dance"})"), "unknown_message");
  EXPECT_EQ(code_of(R"({"type":"hello"})"), "bad_message");
  EXPECT_EQ(code_of(R"({"type":"hello","version":1,"format":"png"})"), "bad_message");
  EXPECT_EQ(code_of(R"({"type":"hello","version":1,"viewport":{"width":0,"height":5}})"),
            "bad_message");
  EXPECT_EQ(code_of(R"({"type":"hello","version":1,"viewport":{"width":99999,"height":5}})"),
            "bad_message");
  EXPECT_EQ(code_of(R"({"type":"scene","name":"a.obj"})"), "bad_message");
  EXPECT_EQ(code_of(R"({"type":"scene","name":"a.obj","size":10,"library":"x"})"), "bad_message");
  EXPECT_EQ(code_of(R"({"type":"scene","name":"a.obj","size":1001})"), "too_large");
  EXPECT_EQ(code_of(R"({"type":"scene","name":"a.obj","data":"!!!!"})"), "bad_message");
  EXPECT_EQ(code_of(R"({"type":"camera","eye":[1,2]})"), "bad_message");
  EXPECT_EQ(code_of(R"({"type":"camera","eye":[1,2,"x"]})"), "bad_message");
  EXPECT_EQ(code_of(R"({"type":"camera","fov_y_deg":"wide"})"), "bad_message");
  EXPECT_EQ(code_of(R"({"type":"camera","seq":-1})"), "bad_message");
  EXPECT_EQ(code_of(R"({"type":"camera","seq":3,"eye":[0,0,5]})"), "ok");
  EXPECT_EQ(code_of(R"({"type":"ping"})"), "ok");
}

TEST(Protocol, Base64Scene) {
  auto r = parse_request(R"({"type":"scene","name":"t.obj","data":"aGVsbG8="})", 100, 4096);
  EXPECT_EQ(*std::get<SceneRequest>(r).data, "hello");
  bool ok = false;
  EXPECT_EQ(base64_decode("aGk=", ok), "hi");
  EXPECT_TRUE(ok);
  base64_decode("a$b=", ok);
  EXPECT_FALSE(ok);
}

TEST(Protocol, CameraFieldsApply) {
  auto r = parse_request(
      R"({"type":"camera","seq":7,"eye":[1,2,3],"projection":"orthographic","ortho_height":4})", 1,
      4096);
  auto& c = std::get<CameraRequest>(r);
  vismap::Camera cam;
  c.apply_to(cam);
  EXPECT_EQ(c.seq, 7u);
  EXPECT_EQ(cam.eye[2], 3);
  EXPECT_EQ(cam.projection, vismap::Camera::Projection::Orthographic);
  EXPECT_EQ(cam.ortho_height, 4);
}

TEST(Protocol, InputErrorKindsMirrorToCodes) {
  using K = vismap::InputErrorKind;
  const std::pair<K, const char*> kinds[] = {{K::FileNotFound, "file_not_found"},
                                             {K::UnknownFormat, "unknown_format"},
                                             {K::Truncated, "truncated"},
                                             {K::ParseError, "parse_error"},
                                             {K::NonFiniteVertex, "non_finite_vertex"},
                                             {K::IndexOutOfRange, "index_out_of_range"},
                                             {K::EmptyMesh, "empty_mesh"},
                                             {K::BadScene, "bad_scene"},
                                             {K::BadCamera, "bad_camera"},
                                             {K::TooLarge, "too_large"}};
  for (auto [k, name] : kinds)
    EXPECT_EQ(error_code(vismap::InputError(k, "f", "", "", -1, "m")), name);
}

TEST(Protocol, LibraryNamesCannotEscape) {
  EXPECT_TRUE(safe_library_name("bunny.ply"));
  EXPECT_TRUE(safe_library_name("stanford/bunny.ply"));
  EXPECT_FALSE(safe_library_name("../etc/passwd"));
  EXPECT_FALSE(safe_library_name("a/../../b"));
  EXPECT_FALSE(safe_library_name("/etc/passwd"));
  EXPECT_FALSE(safe_library_name("a//b"));
  EXPECT_FALSE(safe_library_name("a\\b"));
  EXPECT_FALSE(safe_library_name(""));
}

TEST(Protocol, ErrorJson) {
  auto j = nlohmann::json::parse(error_json("busy", "full", true, 4));
  EXPECT_EQ(j["type"], "error");
  EXPECT_EQ(j["code"], "busy");
  EXPECT_EQ(j["fatal"], true);
  EXPECT_EQ(j["seq"], 4);
}

// Found by tests/fuzz/fuzz_protocol.cpp: a viewport without "height" dereferenced a null field.
TEST(Protocol, RegressionViewportMissingHeight) {
  EXPECT_EQ(code_of(R"({"type":"hello","version":1,"viewport":{"width":64,"h*ight":64}})"),
            "bad_message");
  EXPECT_EQ(code_of(R"({"type":"camera","viewport":{"height":64}})"), "bad_message");
}
