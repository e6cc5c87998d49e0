// Protocol version 2 on loopback (proto/PROTOCOL.md, "Version 2"): the version choice, compact
// frames over the socket (byte for byte write_compact of the same render), their options and
// refusals, the per-format metrics, and permessage-deflate with frames still correct through it.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <tuple>

#include "core/lines/lines.h"
#include "core/pipeline.h"
#include "core/scene.h"
#include "core/stream/compact.h"
#include "core/stream/delta.h"
#include "core/write/output.h"
#include "tests/server/server_fixture.h"

namespace {

class ServerV2Test : public ServerTest {
 protected:
  // hello with version 2 (extra may set versions, format options, ...).
  void hello2(WsClient& c, const std::string& format, json extra = json::object()) {
    json e = {{"version", 2}};
    e.update(extra);
    hello(c, format, e);
  }
  // Sends hello and returns the server's answer (welcome or error), without asserting.
  json hello_answer(WsClient& c, json h) {
    c.connect(url());
    h["type"] = "hello";
    c.send_text(h.dump());
    return next(c);
  }
  // The frame the server renders for frame(c, seq, angle) on `scene` at 128x96, built the way
  // the session builds it: the framing camera, the request's eye and target, near/far fitted.
  // (screen: the render's screen triangles too, as a delta session keeps them.)
  vismap::PlanarMap render_like_the_server(const vismap::Scene& scene, double angle,
                                           vismap::Camera& cam,
                                           vismap::ScreenTriangles* screen = nullptr) {
    cam = vismap::frame_scene(scene, 128, 96);
    cam.eye = {3 * std::sin(angle), 1.5, 3 * std::cos(angle)};
    cam.target = {0.25, 0.25, 0.25};
    cam.near_plane = cam.far_plane = 0;
    vismap::fit_near_far(cam, scene);
    cam.validate();
    vismap::RenderOptions opts;
    opts.memory_budget = cfg_.limits.render_memory_bytes;
    opts.keep_screen_triangles = screen != nullptr;
    if (!renderer_) renderer_ = std::make_unique<vismap::Renderer>(cfg_.device);
    return renderer_->render(scene, cam, opts, nullptr, screen);
  }
  // Polls /metrics until it holds `line` (a frame is counted when the server's write completes,
  // which may be just after the client has its bytes).
  // Polls up to 10 s: the frame counters move in the write's completion, which a loaded
  // machine (the suite runs two tests at once, PoCL on both cores) can delay past 2 s.
  bool metrics_show(const std::string& line) {
    for (int i = 0; i < 1000; ++i) {
      if (http_get("127.0.0.1", port_, "/metrics").body.find(line + "\n") != std::string::npos)
        return true;
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    return false;
  }

  std::unique_ptr<vismap::Renderer> renderer_;
};

TEST_F(ServerV2Test, HelloPicksTheHighestVersionAndListsFormats) {
  start();
  WsClient both;
  json w = hello_answer(both, {{"versions", {1, 2}}});
  ASSERT_EQ(w["type"], "welcome") << w.dump();
  EXPECT_EQ(w["version"], 2);
  EXPECT_EQ(w["formats"], json::array({"svg", "bin", "compact", "delta"}));
  EXPECT_EQ(w["format"], "svg");
  WsClient future;  // a version this server does not speak is passed over, not refused
  w = hello_answer(future, {{"versions", {4, 3}}, {"format", "compact"}});
  EXPECT_EQ(w["version"], 3) << w.dump();
  EXPECT_EQ(w["format"], "compact");
  auto health = json::parse(http_get("127.0.0.1", port_, "/health").body);
  EXPECT_EQ(health["protocol"], 3);
  EXPECT_EQ(health["protocols"], json::array({1, 2, 3}));
}

// A version 1 session sees version 1 exactly: no `formats`, no compact, svg and bin as before.
TEST_F(ServerV2Test, Version1SessionIsUnchanged) {
  start();
  WsClient c;
  json w = hello_answer(c, {{"version", 1}, {"format", "compact"}});
  ASSERT_EQ(w["type"], "error") << w.dump();
  EXPECT_EQ(w["code"], "bad_message");
  EXPECT_FALSE(w["fatal"].get<bool>());
  EXPECT_NE(w["message"].get<std::string>().find("version 2"), std::string::npos) << w.dump();
  c.send_text(R"({"type":"hello","version":1,"format":"bin","quantum":0})");  // quantum: not v1
  w = next(c);
  ASSERT_EQ(w["type"], "welcome") << w.dump();
  EXPECT_EQ(w["version"], 1);
  EXPECT_FALSE(w.contains("formats"));
  ready(c);
  c.send_text(json{{"type", "camera"}, {"seq", 1}, {"eye", {3, 1.5, 3}}}.dump());
  json h = next(c, 60);
  ASSERT_EQ(h["type"], "frame") << h.dump();
  EXPECT_EQ(h["format"], "bin");
  EXPECT_FALSE(h.contains("vertices"));
  EXPECT_GT(vismap::read_bin(c.read(60).data).triangle_count(), 0u);
}

// The payload over the socket is write_compact of the same render, byte for byte (the pipeline
// is deterministic on one device), so it decodes to the same triangles, ids and shades.
TEST_F(ServerV2Test, CompactFrameEqualsWriteCompactOfTheSameRender) {
  start();
  WsClient c;
  hello2(c, "compact");
  const std::string grid = grid_obj(12);  // 288 triangles, folds occlude each other
  upload(c, "grid.obj", grid);
  ASSERT_EQ(next(c, 60)["type"], "scene_ready");
  vismap::Scene scene = vismap::load_scene_from_memory("grid.obj", grid);
  for (int i = 0; i < 2; ++i) {
    double angle = 0.7 * i;
    auto [h, p] = frame(c, i, angle);
    EXPECT_EQ(h["format"], "compact");
    EXPECT_TRUE(p.binary);
    vismap::CompactFrame f = vismap::read_compact(p.data);
    EXPECT_EQ(f.width, 128u);
    EXPECT_EQ(f.height, 96u);
    EXPECT_EQ(f.quantum, 16u);
    EXPECT_EQ(f.compression, vismap::Compression::Zstd);
    EXPECT_TRUE(f.flags & vismap::kCompactShade);
    EXPECT_EQ(h["out_triangles"], f.triangle_count());
    EXPECT_EQ(h["vertices"], f.vertex_count());
    EXPECT_GT(f.triangle_count(), 0u);
    EXPECT_GE(h["encode_ms"].get<double>(), 0);

    vismap::Camera cam;
    vismap::PlanarMap map = render_like_the_server(scene, angle, cam);
    vismap::CompactOptions o;
    o.shade = true;
    std::string mine = vismap::write_compact(map, scene, cam, o);
    EXPECT_TRUE(p.data == mine) << "server " << p.data.size() << " bytes, here " << mine.size();
    vismap::CompactFrame g = vismap::read_compact(mine);
    EXPECT_EQ(f.source, g.source);
    EXPECT_EQ(f.shade, g.shade);
  }
}

// Config::frame_level: compact frames coded at the configured level (here 19; a deflate session
// at deflate's highest, 9, not refused), byte for byte what write_compact makes at that level,
// and (zstd) smaller than at the coder's default on this scene; the decoded arrays are the same.
TEST_F(ServerV2Test, FrameLevelCodesCompactFramesAtThatLevel) {
  cfg_.frame_level = 19;
  start();
  const std::string grid = grid_obj(12);
  vismap::Scene scene = vismap::load_scene_from_memory("grid.obj", grid);
  for (const auto& [name, compression, level] :
       {std::tuple{"zstd", vismap::Compression::Zstd, 19},
        std::tuple{"deflate", vismap::Compression::Deflate, 9}}) {
    SCOPED_TRACE(name);
    WsClient c;
    hello2(c, "compact", {{"compression", name}});
    upload(c, "grid.obj", grid);
    ASSERT_EQ(next(c, 60)["type"], "scene_ready");
    auto [h, p] = frame(c, 1, 0.7);
    vismap::Camera cam;
    vismap::PlanarMap map = render_like_the_server(scene, 0.7, cam);
    vismap::CompactOptions o;
    o.shade = true;
    o.compression = compression;
    const std::string fast = vismap::write_compact(map, scene, cam, o);
    o.level = level;
    const std::string small = vismap::write_compact(map, scene, cam, o);
    EXPECT_TRUE(p.data == small) << "server " << p.data.size() << " bytes, here " << small.size();
    if (compression == vismap::Compression::Zstd) {
      EXPECT_LT(small.size(), fast.size());
    }
    EXPECT_LE(small.size(), fast.size());  // (deflate 9 and 6 may tie on a frame this small)
    EXPECT_EQ(vismap::read_compact(small).indices, vismap::read_compact(fast).indices);
  }
  // A delta session (version 3, the scene held): its frames as a DeltaEncoder at level 19 codes
  // them here, and they decode.
  WsClient c;
  hello(c, "delta", {{"version", 3}, {"hold_scene", true}});
  upload(c, "grid.obj", grid);
  ASSERT_EQ(next(c, 60)["type"], "scene_ready");
  ASSERT_EQ(next(c, 60)["type"], "sources");
  vismap::DeltaDecoder dec;
  dec.hold_scene(c.read(60).data);
  vismap::DeltaOptions o, fast_o;
  o.client_holds_scene = fast_o.client_holds_scene = true;
  o.level = 19;
  vismap::DeltaEncoder mine(scene, o), fast(scene, fast_o);
  size_t sent = 0, at_default = 0;
  for (int i = 0; i < 3; ++i) {
    auto [h, p] = frame(c, i, 0.3 * i);
    EXPECT_GT(dec.decode(p.data).triangle_count(), 0u);
    vismap::Camera cam;
    vismap::ScreenTriangles st;
    const vismap::PlanarMap map = render_like_the_server(scene, 0.3 * i, cam, &st);
    EXPECT_TRUE(mine.encode(map, st, cam) == p.data) << "frame " << i;
    sent += p.data.size();
    at_default += fast.encode(map, st, cam).size();
  }
  EXPECT_LT(sent, at_default);
}

TEST_F(ServerV2Test, CompactOptions) {
  start();
  struct Case {
    json extra;
    uint32_t quantum;
    vismap::Compression compression;
    bool shade;
  };
  const Case cases[] = {
      {json::object(), 16, vismap::Compression::Zstd, true},
      {{{"quantum", 1}, {"compression", "deflate"}}, 1, vismap::Compression::Deflate, true},
      {{{"quantum", 256}, {"fill", "id"}}, 256, vismap::Compression::Zstd, false},
      {{{"quantum", 4}, {"compression", "zstd"}, {"fill", "shade"}},
       4,
       vismap::Compression::Zstd,
       true},
  };
  for (const Case& k : cases) {
    SCOPED_TRACE(k.extra.dump());
    WsClient c;
    hello2(c, "compact", k.extra);
    ready(c);
    auto [h, p] = frame(c, 1);
    vismap::CompactFrame f = vismap::read_compact(p.data);
    EXPECT_EQ(f.quantum, k.quantum);
    EXPECT_EQ(f.compression, k.compression);
    EXPECT_EQ((f.flags & vismap::kCompactShade) != 0, k.shade);
    EXPECT_EQ(f.shade.size(), k.shade ? f.triangle_count() : 0u);
    EXPECT_GT(f.triangle_count(), 0u);
  }
}

// Each refusal is bad_message, not fatal, and names what is wrong; the session may send another
// hello, and the last one here is accepted.
TEST_F(ServerV2Test, BadCompactCombinationsAreRefused) {
  start();
  WsClient c;
  c.connect(url());
  const std::pair<const char*, const char*> bad[] = {
      {R"({"type":"hello","version":2,"format":"compact","attributes":true})", "barycentrics"},
      {R"({"type":"hello","version":2,"format":"compact","quantum":0})", "quantum"},
      {R"({"type":"hello","version":2,"format":"compact","quantum":257})", "quantum"},
      {R"({"type":"hello","version":2,"format":"compact","quantum":"16"})", "quantum"},
      {R"({"type":"hello","version":2,"format":"compact","quantum":2.5})", "quantum"},
      {R"({"type":"hello","version":2,"format":"compact","compression":"lz4"})", "compression"},
      {R"({"type":"hello","version":2,"format":"compact","compression":1})", "compression"},
      {R"({"type":"hello","version":2,"format":"png"})", "compact"},
      {R"({"type":"hello","versions":[1],"format":"compact"})", "version 2"},
      {R"({"type":"hello","version":2,"format":"compact","fill":"normals"})", "fill"},
  };
  for (auto [text, why] : bad) {
    c.send_text(text);
    json e = next(c);
    EXPECT_EQ(e["type"], "error") << text;
    EXPECT_EQ(e["code"], "bad_message") << text;
    EXPECT_FALSE(e["fatal"].get<bool>()) << text;
    EXPECT_NE(e["message"].get<std::string>().find(why), std::string::npos) << e.dump();
  }
  c.send_text(R"({"type":"hello","version":2,"format":"bin","attributes":true})");
  EXPECT_EQ(next(c)["type"], "welcome");
}

// Line drawings in svg and bin frames (hello's style): the svg frame is write_svg with the
// lines of the same render, the bin frame carries the same chains in its line section; a lines
// style in a format that cannot draw them, or a bad option, is bad_message.
TEST_F(ServerV2Test, LineStylesInSvgAndBinFrames) {
  start();
  const std::string grid = grid_obj(12);
  std::string svg_frame, bin_frame;
  uint64_t svg_chains = 0;
  {
    WsClient c;
    hello2(c, "svg", {{"style", "fill+lines"}, {"hidden", true}});
    upload(c, "grid.obj", grid);
    ASSERT_EQ(next(c, 60)["type"], "scene_ready");
    auto [h, p] = frame(c, 0, 0.0);
    svg_chains = h["line_chains"].get<uint64_t>();
    svg_frame = p.data;
  }
  {
    WsClient c;
    hello2(c, "bin", {{"style", "lines"}, {"hidden", true}});
    upload(c, "grid.obj", grid);
    ASSERT_EQ(next(c, 60)["type"], "scene_ready");
    auto [h, p] = frame(c, 0, 0.0);
    bin_frame = p.data;
  }
  // The same render here (after the sessions: as the compact test, one renderer at a time).
  vismap::Scene scene = vismap::load_scene_from_memory("grid.obj", grid);
  vismap::Camera cam;
  render_like_the_server(scene, 0.0, cam);
  vismap::RenderOptions ro;
  ro.memory_budget = cfg_.limits.render_memory_bytes;
  ro.keep_screen_triangles = true;
  vismap::ScreenTriangles screen;
  const vismap::PlanarMap map = renderer_->render(scene, cam, ro, nullptr, &screen);
  vismap::LineOptions lo;
  lo.hidden = true;
  const vismap::LineSet lines = vismap::extract_lines(map, screen, scene, cam, lo);
  ASSERT_GT(lines.chain_count(), 0u);
  EXPECT_EQ(svg_chains, lines.chain_count());
  vismap::SvgStyle st;
  st.lines = &lines;
  EXPECT_TRUE(svg_frame == vismap::write_svg(map, scene, cam, vismap::Fill::Shade, st));
  EXPECT_NE(svg_frame.find("<g class=\"lines\""), std::string::npos);
  const vismap::BinFrame f = vismap::read_bin(bin_frame);
  EXPECT_TRUE(f.has_lines);
  EXPECT_EQ(f.triangle_count(), 0u);
  EXPECT_EQ(f.lines.off, lines.off);
  EXPECT_EQ(f.lines.kind, lines.kind);

  WsClient c;
  c.connect(url());
  const std::pair<const char*, const char*> bad[] = {
      {R"({"type":"hello","version":2,"format":"compact","style":"lines"})", "style"},
      {R"({"type":"hello","version":2,"format":"delta","style":"fill+lines"})", "style"},
      {R"({"type":"hello","version":2,"format":"svg","style":"outline"})", "style"},
      {R"({"type":"hello","version":2,"format":"svg","hidden":true})", "hidden"},
      {R"({"type":"hello","version":2,"format":"svg","style":"lines","crease_angle":200})",
       "crease_angle"},
  };
  for (auto [text, why] : bad) {
    c.send_text(text);
    json e = next(c);
    EXPECT_EQ(e["code"], "bad_message") << text;
    EXPECT_NE(e["message"].get<std::string>().find(why), std::string::npos) << e.dump();
  }
}

TEST_F(ServerV2Test, MetricsCountFramesAndBytesPerFormat) {
  start();
  uint64_t bytes[3] = {0, 0, 0};
  const char* formats[] = {"svg", "bin", "compact"};
  for (int f = 0; f < 3; ++f) {
    WsClient c;
    hello2(c, formats[f]);
    ready(c);
    for (int i = 0; i <= f; ++i) bytes[f] += frame(c, i, 0.3 * i).second.data.size();
  }
  for (int f = 0; f < 3; ++f) {
    std::string label = std::string("{format=\"") + formats[f] + "\"} ";
    EXPECT_TRUE(metrics_show("vismap_frames_by_format_total" + label + std::to_string(f + 1)))
        << formats[f];
    EXPECT_TRUE(metrics_show("vismap_frame_bytes_total" + label + std::to_string(bytes[f])))
        << formats[f];
    EXPECT_TRUE(metrics_show(std::string("vismap_encode_ms_count{format=\"") + formats[f] + "\"} " +
                             std::to_string(f + 1)))
        << formats[f];
  }
  EXPECT_TRUE(metrics_show("vismap_frames_total 6"));
}

// Negotiated when offered by both sides; every format's frames still decode through it, and an
// SVG frame costs fewer bytes on the wire than its payload. Inflated bytes count against the
// message limit (a compressed bomb is too_large, the session goes on).
TEST_F(ServerV2Test, PermessageDeflateNegotiatedAndFramesStillCorrect) {
  cfg_.permessage_deflate = true;
  cfg_.limits.max_message_bytes = 1 << 20;
  start();
  WsClient plain;  // a client that does not offer it gets plain frames
  plain.connect(url(), 5, false);
  EXPECT_FALSE(plain.deflate_negotiated());
  plain.close();
  const char* formats[] = {"svg", "bin", "compact"};
  for (const char* fmt : formats) {
    SCOPED_TRACE(fmt);
    WsClient c;
    c.connect(url(), 5, /*permessage_deflate=*/true);
    EXPECT_TRUE(c.deflate_negotiated());
    c.send_text(json{{"type", "hello"},
                     {"version", 2},
                     {"format", fmt},
                     {"viewport", {{"width", 128}, {"height", 96}}}}
                    .dump());
    ASSERT_EQ(next(c)["type"], "welcome");
    const std::string grid = grid_obj(12);
    upload(c, "grid.obj", grid);
    ASSERT_EQ(next(c, 60)["type"], "scene_ready");
    uint64_t wire0 = c.wire_bytes_received();
    auto [h, p] = frame(c, 1);
    uint64_t wire = c.wire_bytes_received() - wire0;
    EXPECT_EQ(h["bytes"], p.data.size());
    if (std::string(fmt) == "svg") {
      EXPECT_NE(p.data.find("</svg>"), std::string::npos);
      EXPECT_LT(wire, p.data.size() / 2) << "wire " << wire << " payload " << p.data.size();
    } else if (std::string(fmt) == "bin") {
      EXPECT_GT(vismap::read_bin(p.data).triangle_count(), 0u);
    } else {
      EXPECT_EQ(vismap::read_compact(p.data).triangle_count(), h["out_triangles"]);
    }
    std::printf("permessage-deflate %s: payload %zu bytes, %llu on the wire\n", fmt, p.data.size(),
                static_cast<unsigned long long>(wire));
  }
  WsClient bomb;
  bomb.connect(url(), 5, true);
  bomb.send_text(R"({"type":"hello","version":2})");
  ASSERT_EQ(next(bomb)["type"], "welcome");
  bomb.send_binary(std::string(4 << 20, '\0'));  // 4 MiB, a few KiB deflated
  expect_error(bomb, "too_large");
  bomb.send_text(R"({"type":"ping","seq":7})");
  EXPECT_EQ(next(bomb)["seq"], 7);
}

TEST_F(ServerV2Test, PermessageDeflateOffNotNegotiated) {
  cfg_.permessage_deflate = false;
  start();
  WsClient c;
  c.connect(url(), 5, true);
  EXPECT_FALSE(c.deflate_negotiated());
  c.send_text(R"({"type":"hello","version":2})");
  EXPECT_EQ(next(c)["type"], "welcome");
}

// Delta sessions (proto/DELTA.md): the first frame is a keyframe, the next ones apply to it and
// decode to the same triangles as the same render encoded here; a `keyframe` message makes the
// next frame stand alone; a new scene starts from a keyframe; keyframe in another format is
// refused.
TEST_F(ServerV2Test, DeltaFramesApplyInSequenceAndKeyframesOnRequest) {
  start();
  WsClient c;
  hello2(c, "delta");
  const std::string grid = grid_obj(12);
  upload(c, "grid.obj", grid);
  ASSERT_EQ(next(c, 60)["type"], "scene_ready");
  vismap::Scene scene = vismap::load_scene_from_memory("grid.obj", grid);
  vismap::DeltaDecoder dec;
  vismap::DeltaOptions v1;  // protocol version 2 sessions get DELTA.md version 1
  v1.version = 1;
  vismap::DeltaEncoder mine(scene, v1);
  for (int i = 0; i < 4; ++i) {
    if (i == 2) c.send_text(json{{"type", "keyframe"}}.dump());
    const double angle = 0.3 * i;
    auto [h, p] = frame(c, i, angle);
    EXPECT_EQ(h["format"], "delta");
    EXPECT_TRUE(p.binary);
    EXPECT_EQ(h["keyframe"], i == 0 || i == 2) << "frame " << i;
    const vismap::DeltaFrame f = dec.decode(p.data);
    EXPECT_EQ(f.keyframe, i == 0 || i == 2);
    EXPECT_GT(f.triangle_count(), 0u);

    vismap::Camera cam;
    vismap::RenderOptions opts;
    opts.keep_screen_triangles = true;
    opts.memory_budget = cfg_.limits.render_memory_bytes;
    cam = vismap::frame_scene(scene, 128, 96);
    cam.eye = {3 * std::sin(angle), 1.5, 3 * std::cos(angle)};
    cam.target = {0.25, 0.25, 0.25};
    cam.near_plane = cam.far_plane = 0;
    vismap::fit_near_far(cam, scene);
    if (!renderer_) renderer_ = std::make_unique<vismap::Renderer>(cfg_.device);
    vismap::ScreenTriangles st;
    const vismap::PlanarMap map = renderer_->render(scene, cam, opts, nullptr, &st);
    if (i == 2) mine.request_keyframe();
    EXPECT_TRUE(mine.encode(map, st, cam) == p.data) << "frame " << i;
  }
  // A new scene: the next frame is a keyframe again.
  upload(c, "grid2.obj", grid_obj(6));
  ASSERT_EQ(next(c, 60)["type"], "scene_ready");
  auto [h, p] = frame(c, 9, 0.1);
  EXPECT_EQ(h["keyframe"], true);
  EXPECT_TRUE(dec.decode(p.data).keyframe);
}

// Protocol version 3, delta with hold_scene: the sources message follows scene_ready, frames
// are DELTA.md version 2 (delta, keyframe or, when smaller, the compact frame), coded as the
// same render encoded here, and decode with the scene held; hold_scene elsewhere is refused.
TEST_F(ServerV2Test, Version3DeltaSessionsHoldTheSceneAndNeverExceedCompact) {
  start();
  WsClient bad;
  EXPECT_EQ(
      hello_answer(bad, {{"version", 3}, {"format", "compact"}, {"hold_scene", true}})["code"],
      "bad_message");
  WsClient c;
  hello(c, "delta", {{"version", 3}, {"hold_scene", true}});
  const std::string grid = grid_obj(12);
  upload(c, "grid.obj", grid);
  ASSERT_EQ(next(c, 60)["type"], "scene_ready");
  const json sh = next(c, 60);
  ASSERT_EQ(sh["type"], "sources") << sh.dump();
  const Message sources = c.read(60);
  EXPECT_TRUE(sources.binary);
  EXPECT_EQ(sh["bytes"], sources.data.size());
  vismap::Scene scene = vismap::load_scene_from_memory("grid.obj", grid);
  EXPECT_EQ(sources.data, vismap::encode_delta_sources(scene, vismap::Compression::Zstd));
  vismap::DeltaDecoder dec;
  dec.hold_scene(sources.data);
  vismap::DeltaOptions o;
  o.client_holds_scene = true;
  vismap::DeltaEncoder mine(scene, o);
  for (int i = 0; i < 3; ++i) {
    auto [h, p] = frame(c, i, 0.3 * i);
    EXPECT_EQ(h["format"], "delta");
    ASSERT_TRUE(h.contains("coding")) << h.dump();
    EXPECT_LE(p.data.size(), h["compact_bytes"].get<size_t>());
    const vismap::DeltaFrame f = dec.decode(p.data);
    EXPECT_EQ(f.compact, h["coding"] == "compact");
    EXPECT_GT(f.triangle_count(), 0u);
    vismap::Camera cam;
    vismap::ScreenTriangles st;
    const vismap::PlanarMap map = render_like_the_server(scene, 0.3 * i, cam, &st);
    EXPECT_TRUE(mine.encode(map, st, cam) == p.data) << "frame " << i;
  }
}

TEST_F(ServerV2Test, KeyframeOutsideDeltaIsRefused) {
  start();
  WsClient c;
  hello2(c, "compact");
  c.send_text(json{{"type", "keyframe"}}.dump());
  json e = next(c);
  EXPECT_EQ(e["type"], "error");
  EXPECT_EQ(e["code"], "unexpected_message");
  EXPECT_EQ(e["fatal"], false);
}

// Curved surfaces (issue 18, docs/SURFACES.md) through a session: the tea set's Bezier patches
// and the Killeroo's Loop surface uploaded as files, diced for each frame at the hello's
// tolerance, seen from their framing camera; bin frames whose source ids are patches (or control
// triangles) and whose vertices moved with the camera.
TEST_F(ServerV2Test, CurvedSurfacesAreDicedPerFrame) {
  start();
  const std::string data = std::string(VISMAP_SOURCE_DIR) + "/../shared/data/";
  const std::pair<const char*, uint32_t> files[] = {{"teapot/teapot.bpt", 32},
                                                    {"teapot/newell_teacup.patches", 26},
                                                    {"teapot/newell_teaspoon.patches", 16},
                                                    {"killeroo/killeroo.pbrt", 8316}};
  for (auto [file, sources] : files) {
    std::ifstream in(data + file, std::ios::binary);
    if (!in) GTEST_SKIP() << data + file;
    std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    WsClient c;
    hello2(c, "bin", {{"tolerance", 1.0}});
    upload(c, fs::path(file).filename().string(), bytes);
    json r = next(c, 60);
    ASSERT_EQ(r["type"], "scene_ready") << file << r.dump();
    std::vector<vismap::BinFrame> frames;
    for (int k = 0; k < 2; ++k) {
      json cam = r["camera"];
      // the second frame from a little to the side
      if (k == 1)
        cam["eye"][0] = cam["eye"][0].get<double>() + 0.1 * r["bounds"]["hi"][0].get<double>();
      c.send_text(
          json{{"type", "camera"}, {"seq", k}, {"eye", cam["eye"]}, {"target", cam["target"]}}
              .dump());
      json h = next(c, 60);
      ASSERT_EQ(h["type"], "frame") << file << h.dump();
      Message p = c.read(60);
      frames.push_back(vismap::read_bin(p.data));
      const vismap::BinFrame& f = frames.back();
      EXPECT_GT(f.triangle_count(), 100u) << file;
      for (uint32_t id : f.triangle_id) ASSERT_LT(id, sources) << file;
    }
    EXPECT_NE(frames[0].xy, frames[1].xy) << file;
  }
}

// Implicit surfaces (issue 19, docs/IMPLICIT.md) through a session: a .sexp upload, and a
// library scene mixing an implicit slab (a file) with the bunny standing in it, both diced for
// each frame at the hello's implicit tolerance; bin frames carry both objects' triangles.
TEST_F(ServerV2Test, ImplicitSurfacesAreDicedPerFrame) {
  std::ofstream(lib_ / "slab.sexp")
      << "(max (- (abs x) 0.12) (- (abs (- y 0.045)) 0.01) (- (abs z) 0.12))";
  fs::copy_file(fs::path(VISMAP_SOURCE_DIR) / "data/bunny.ply", lib_ / "bunny.ply");
  std::ofstream(lib_ / "mixed.json")
      << R"({"meshes": [{"file": "bunny.ply"}, {"file": "slab.sexp", "color": [0.3, 0.5, 0.8]}]})";
  start();
  // The scene's framing camera's frame, after its scene_ready (empty when either fails).
  const auto first_frame = [](WsClient& c) {
    json r = next(c, 60);
    EXPECT_EQ(r["type"], "scene_ready") << r.dump();
    if (r["type"] != "scene_ready") return vismap::BinFrame{};
    c.send_text(json{{"type", "camera"},
                     {"seq", 1},
                     {"eye", r["camera"]["eye"]},
                     {"target", r["camera"]["target"]}}
                    .dump());
    json h = next(c, 60);
    EXPECT_EQ(h["type"], "frame") << h.dump();
    if (h["type"] != "frame") return vismap::BinFrame{};
    return vismap::read_bin(c.read(60).data);
  };
  {
    WsClient c;
    hello2(c, "bin", {{"implicit_tolerance", 8.0}});
    upload(c, "ring.sexp",
           "(- (sqrt (+ (square (- (sqrt (+ (square x) (square y))) 1)) (square z))) 0.3)");
    const vismap::BinFrame f = first_frame(c);
    EXPECT_GT(f.triangle_count(), 100u);
    // A bad expression is a non-fatal error naming the line and column.
    upload(c, "bad.sexp", "(+ x\n  (sqr y))");
    json e = next(c, 60);
    EXPECT_EQ(e["type"], "error") << e.dump();
    EXPECT_NE(e.value("message", "").find("line 2 column 4"), std::string::npos) << e.dump();
    EXPECT_EQ(e["fatal"], false);
  }
  WsClient c;
  hello2(c, "bin", {{"implicit_tolerance", 8.0}});
  c.send_text(R"({"type":"scene","library":"mixed.json"})");
  const vismap::BinFrame f = first_frame(c);
  size_t slab = 0, rabbit = 0;  // mesh 0 the bunny, 1 the slab
  for (uint32_t m : f.mesh) (m == 1 ? slab : rabbit) += 1;
  EXPECT_GT(slab, 10u);
  EXPECT_GT(rabbit, 1000u);
}

}  // namespace
