// vismapd on loopback, in process, with the real pipeline: handshake, uploads, frames in both
// formats, every error code a session can get, every limit, concurrency, slow and vanishing
// clients, a bounded soak and the graceful stop. Every wait is bounded.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <random>
#include <thread>

#include <nlohmann/json.hpp>

#include "clients/wsclient.h"
#include "core/output.h"
#include "server/server.h"

using namespace vismap::server;
using namespace vismap::client;
using nlohmann::json;
namespace fs = std::filesystem;

namespace {

// A closed tetrahedron: 4 triangles.
const std::string kTet =
    "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\n"
    "f 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n";

std::string b64(const std::string& in) {
  static const char* a = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  size_t i = 0;
  for (; i + 2 < in.size(); i += 3) {
    uint32_t v = (uint8_t(in[i]) << 16) | (uint8_t(in[i + 1]) << 8) | uint8_t(in[i + 2]);
    for (int k = 3; k >= 0; --k) out += a[(v >> (6 * k)) & 63];
  }
  if (i + 1 == in.size()) {
    uint32_t v = uint8_t(in[i]) << 16;
    out += a[v >> 18], out += a[(v >> 12) & 63], out += "==";
  } else if (i + 2 == in.size()) {
    uint32_t v = (uint8_t(in[i]) << 16) | (uint8_t(in[i + 1]) << 8);
    out += a[v >> 18], out += a[(v >> 12) & 63], out += a[(v >> 6) & 63], out += '=';
  }
  return out;
}

class ServerTest : public ::testing::Test {
 protected:
  void SetUp() override {
    lib_ = fs::temp_directory_path() / ("vismapd_test_" + std::to_string(::getpid()));
    fs::create_directories(lib_);
    std::ofstream(lib_ / "tet.obj") << kTet;
    cfg_.port = 0;
    cfg_.log_level = "off";
    cfg_.library = lib_.string();
    cfg_.drain_timeout_s = 10;
  }
  void TearDown() override {
    server_.reset();
    fs::remove_all(lib_);
  }
  void start() {
    server_ = std::make_unique<Server>(cfg_);
    port_ = std::to_string(server_->start());
  }
  std::string url() const { return "ws://127.0.0.1:" + port_ + "/"; }

  // Next JSON message (skips nothing).
  static json next(WsClient& c, double t = 30) {
    Message m = c.read(t);
    EXPECT_FALSE(m.binary);
    return json::parse(m.data);
  }
  static void expect_error(WsClient& c, const std::string& code, bool fatal = false) {
    json j = next(c);
    EXPECT_EQ(j["type"], "error") << j.dump();
    EXPECT_EQ(j["code"], code) << j.dump();
    EXPECT_EQ(j["fatal"], fatal) << j.dump();
  }
  static int close_code(WsClient& c) {
    try {
      for (int i = 0; i < 10; ++i) c.read(10);
    } catch (const Closed& e) {
      return e.code;
    }
    return -1;
  }
  void hello(WsClient& c, const std::string& format = "svg", json extra = json::object()) {
    c.connect(url());
    json h = {{"type", "hello"}, {"version", 1}, {"format", format}, {"viewport", {{"width", 128}, {"height", 96}}}};
    h.update(extra);
    c.send_text(h.dump());
    json w = next(c);
    ASSERT_EQ(w["type"], "welcome") << w.dump();
  }
  void upload(WsClient& c, const std::string& name = "tet.obj", const std::string& bytes = kTet) {
    c.send_text(json{{"type", "scene"}, {"name", name}, {"size", bytes.size()}}.dump());
    c.send_binary(bytes);
  }
  void ready(WsClient& c) {
    upload(c);
    json r = next(c, 60);
    ASSERT_EQ(r["type"], "scene_ready") << r.dump();
    EXPECT_EQ(r["triangles"], 4);
  }
  // Waits (up to `tries` x 10 ms) until the server counts at most n active sessions.
  void wait_sessions_at_most(int64_t n, int tries = 200) {
    for (int i = 0; i < tries && server_->metrics().sessions_active > n; ++i)
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  // Sends a camera and returns {header, payload}.
  std::pair<json, Message> frame(WsClient& c, uint64_t seq, double angle = 0) {
    c.send_text(json{{"type", "camera"}, {"seq", seq}, {"eye", {3 * std::sin(angle), 1.5, 3 * std::cos(angle)}},
                     {"target", {0.25, 0.25, 0.25}}}.dump());
    json h = next(c, 60);
    EXPECT_EQ(h["type"], "frame") << h.dump();
    Message p = c.read(60);
    EXPECT_EQ(h["bytes"], p.data.size());
    return {h, p};
  }

  Config cfg_;
  fs::path lib_;
  std::unique_ptr<Server> server_;
  std::string port_;
};

TEST_F(ServerTest, HealthMetricsAndViewerOverHttp) {
  start();
  auto h = http_get("127.0.0.1", port_, "/health");
  EXPECT_EQ(h.status, 200);
  EXPECT_EQ(json::parse(h.body)["status"], "ok");
  auto m = http_get("127.0.0.1", port_, "/metrics");
  EXPECT_EQ(m.status, 200);
  EXPECT_NE(m.body.find("vismap_sessions_active 0"), std::string::npos);
  EXPECT_NE(m.body.find("vismap_render_ms_count"), std::string::npos);
  auto v = http_get("127.0.0.1", port_, "/");
  EXPECT_EQ(v.status, 200);
  EXPECT_NE(v.body.find("<html"), std::string::npos);
  EXPECT_EQ(http_get("127.0.0.1", port_, "/nope.html").status, 404);
  EXPECT_EQ(http_get("127.0.0.1", port_, "/../CMakeLists.txt").status, 404);
}

TEST_F(ServerTest, HandshakeAndVersionMismatch) {
  start();
  WsClient ok;
  hello(ok);
  WsClient old;
  old.connect(url());
  old.send_text(R"({"type":"hello","version":99})");
  expect_error(old, "version_mismatch", true);
  EXPECT_EQ(close_code(old), 1008);
  WsClient rude;
  rude.connect(url());
  rude.send_text(R"({"type":"ping"})");
  expect_error(rude, "unexpected_message", true);
  EXPECT_EQ(close_code(rude), 1000);
}

TEST_F(ServerTest, UploadAndSvgFrames) {
  start();
  WsClient c;
  hello(c);
  ready(c);
  for (uint64_t i = 0; i < 3; ++i) {
    auto [h, p] = frame(c, i, 0.4 * i);
    EXPECT_EQ(h["seq"], i);
    EXPECT_EQ(h["format"], "svg");
    EXPECT_FALSE(p.binary);
    EXPECT_NE(p.data.find("<svg"), std::string::npos);
    EXPECT_GE(h["render_ms"].get<double>(), 0);
  }
  // Counted when the server's write completes, which may be just after the client has the bytes.
  bool counted = false;
  for (int i = 0; i < 200 && !counted; ++i) {
    counted = http_get("127.0.0.1", port_, "/metrics").body.find("vismap_frames_total 3\n") != std::string::npos;
    if (!counted) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  EXPECT_TRUE(counted);
}

TEST_F(ServerTest, Base64UploadAndBinFrames) {
  start();
  WsClient c;
  hello(c, "bin", {{"attributes", true}});
  c.send_text(json{{"type", "scene"}, {"name", "tet.obj"}, {"data", b64(kTet)}}.dump());
  ASSERT_EQ(next(c, 60)["type"], "scene_ready");
  auto [h, p] = frame(c, 1);
  EXPECT_TRUE(p.binary);
  vismap::BinFrame f = vismap::read_bin(p.data);
  EXPECT_EQ(f.width, 128u);
  EXPECT_EQ(f.height, 96u);
  EXPECT_GT(f.triangle_count(), 0u);
}

TEST_F(ServerTest, LibraryScenes) {
  start();
  WsClient c;
  hello(c);
  c.send_text(R"({"type":"scene","library":"../tet.obj"})");
  expect_error(c, "bad_message");
  c.send_text(R"({"type":"scene","library":"missing.obj"})");
  expect_error(c, "file_not_found");
  c.send_text(R"({"type":"scene","library":"tet.obj"})");
  json r = next(c, 60);
  EXPECT_EQ(r["type"], "scene_ready");
  EXPECT_EQ(r["triangles"], 4);
  frame(c, 5);
}

TEST_F(ServerTest, ErrorCodesKeepTheSessionGoing) {
  start();
  WsClient c;
  hello(c);
  c.send_text(R"({"type":"camera","seq":1})");
  expect_error(c, "no_scene");
  c.send_text("{oops");
  expect_error(c, "bad_json");
  c.send_text(R"({"type":"teleport"})");
  expect_error(c, "unknown_message");
  c.send_text(R"({"type":"camera","eye":"up"})");
  expect_error(c, "bad_message");
  c.send_text(R"({"type":"hello","version":1})");
  expect_error(c, "unexpected_message");
  c.send_binary("stray bytes");
  expect_error(c, "unexpected_message");
  upload(c, "tet.xyz");
  expect_error(c, "unknown_format");
  upload(c, "bad.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 99\n");
  json j = next(c, 60);
  EXPECT_EQ(j["type"], "error");
  EXPECT_TRUE(j["code"] == "index_out_of_range" || j["code"] == "parse_error") << j.dump();
  upload(c, "nan.obj", "v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n");
  j = next(c, 60);
  EXPECT_EQ(j["type"], "error");
  EXPECT_TRUE(j["code"] == "non_finite_vertex" || j["code"] == "parse_error") << j.dump();
  // The loaders' remaining kinds, end to end: each an error with its code, the session goes on.
  upload(c, "empty.obj", "# no faces\nv 0 0 0\n");
  EXPECT_EQ(next(c, 60)["code"], "empty_mesh");
  upload(c, "short.ply", "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\n"
                         "property float y\nproperty float z\nelement face 1\n"
                         "property list uchar int vertex_indices\nend_header\n\x01\x02");
  EXPECT_EQ(next(c, 60)["code"], "truncated");
  upload(c, "scene.json", R"({"meshes":[{"file":"x.obj","scal":2}]})");
  EXPECT_EQ(next(c, 60)["code"], "bad_scene");
  c.send_text(json{{"type", "scene"}, {"name", "tet.obj"}, {"size", 10}}.dump());
  c.send_binary("12345");  // header announced 10 bytes
  expect_error(c, "bad_message");
  ready(c);
  c.send_text(R"({"type":"camera","seq":9,"eye":[0.25,0.25,0.25],"target":[0.25,0.25,0.25]})");
  j = next(c, 60);
  EXPECT_EQ(j["code"], "bad_camera") << j.dump();
  EXPECT_EQ(j["seq"], 9);
  auto [h, p] = frame(c, 10);  // still serving
  EXPECT_EQ(h["seq"], 10);
  c.send_text(R"({"type":"ping","seq":3})");
  EXPECT_EQ(next(c)["type"], "pong");
}

TEST_F(ServerTest, LimitsOnSizes) {
  cfg_.limits.max_scene_bytes = 1000;
  cfg_.limits.max_message_bytes = 4096;
  cfg_.limits.max_control_bytes = 256;
  cfg_.limits.max_triangles = 2;
  start();
  WsClient c;
  hello(c);
  c.send_text(json{{"type", "scene"}, {"name", "big.obj"}, {"size", 2000}}.dump());
  expect_error(c, "too_large");
  c.send_text(json{{"type", "scene"}, {"name", "big.obj"}, {"data", b64(std::string(1500, 'v'))}}.dump());
  expect_error(c, "too_large");
  c.send_text(json{{"type", "ping"}, {"pad", std::string(300, 'x')}}.dump());
  expect_error(c, "too_large");
  upload(c);  // 4 triangles > max_triangles 2
  expect_error(c, "too_large");
  c.send_binary(std::string(10000, 'x'));  // over max_message_bytes: discarded, session goes on
  expect_error(c, "too_large");
  c.send_text(R"({"type":"ping","seq":1})");
  EXPECT_EQ(next(c)["type"], "pong");
  WsClient early;  // before hello, only max_control_bytes: a big first message closes the session
  early.connect(url());
  early.send_text(std::string(1000, ' '));
  expect_error(early, "too_large", true);
}

TEST_F(ServerTest, LimitOnSessionMemory) {
  cfg_.limits.max_session_bytes = 150;
  start();
  WsClient c;
  hello(c);
  upload(c);
  expect_error(c, "too_large");
}

// limits.render_memory_bytes bounds the device memory of one frame: a scene that alone holds
// more gets too_large for that frame and the session goes on; a small budget renders in buckets.
TEST_F(ServerTest, LimitOnRenderMemory) {
  cfg_.limits.render_memory_bytes = 64;
  start();
  WsClient c;
  hello(c);
  ready(c);
  c.send_text(json{{"type", "camera"}, {"seq", 1}, {"eye", {0, 1.5, 3}}, {"target", {0.25, 0.25, 0.25}}}.dump());
  json e = next(c, 60);
  EXPECT_EQ(e["type"], "error") << e.dump();
  EXPECT_EQ(e["code"], "too_large") << e.dump();
  EXPECT_NE(e["message"].get<std::string>().find("memory budget"), std::string::npos) << e.dump();
  c.send_text(R"({"type":"ping","seq":2})");
  EXPECT_EQ(next(c)["type"], "pong");
}

TEST_F(ServerTest, SmallRenderMemoryRendersInBuckets) {
  cfg_.limits.render_memory_bytes = 16 << 10;
  start();
  WsClient c;
  hello(c);
  ready(c);
  auto [h, p] = frame(c, 1);
  EXPECT_GT(h["buckets"].get<uint32_t>(), 1u) << h.dump();
  EXPECT_GT(h["fragments"].get<uint64_t>(), 0u);
  EXPECT_NE(p.data.find("<path"), std::string::npos);
}

TEST_F(ServerTest, LimitOnSessionCount) {
  cfg_.limits.max_sessions = 2;
  start();
  WsClient a, b, c;
  hello(a);
  hello(b);
  c.connect(url());
  expect_error(c, "busy", true);
  EXPECT_EQ(close_code(c), 1013);
  a.close();
  wait_sessions_at_most(1);
  WsClient d;
  hello(d);
}

TEST_F(ServerTest, LimitOnConnections) {
  cfg_.limits.max_connections = 3;
  cfg_.limits.max_sessions = 10;
  start();
  WsClient a, b;
  hello(a);
  hello(b);
  WsClient c;  // third connection: allowed
  hello(c);
  EXPECT_GE(wait_for_server_close("127.0.0.1", port_, "", 5), 0);  // fourth: closed at once
  EXPECT_LT(wait_for_server_close("127.0.0.1", port_, "", 5), 1.0);
  c.close();
  wait_sessions_at_most(2);
  WsClient d;
  hello(d);
}

TEST_F(ServerTest, HandshakeAndIdleTimeouts) {
  cfg_.limits.handshake_timeout_s = 0.3;
  cfg_.limits.idle_timeout_s = 0.5;
  start();
  double waited = wait_for_server_close("127.0.0.1", port_, "", 10);
  EXPECT_GE(waited, 0.2);
  EXPECT_LT(waited, 5);
  waited = wait_for_server_close("127.0.0.1", port_, "GET / HTTP/1.1\r\nHost: x\r\n", 10);  // never ends
  EXPECT_GE(waited, 0.2);
  WsClient silent;
  silent.connect(url());
  expect_error(silent, "timeout", true);
  WsClient idle;
  hello(idle);
  expect_error(idle, "timeout", true);
}

TEST_F(ServerTest, TokenAuthentication) {
  cfg_.token = "s3cret";
  start();
  WsClient bad;
  bad.connect(url());
  bad.send_text(R"({"type":"hello","version":1,"token":"guess"})");
  expect_error(bad, "unauthorized", true);
  EXPECT_EQ(close_code(bad), 1008);
  WsClient good;
  hello(good, "svg", {{"token", "s3cret"}});
}

TEST_F(ServerTest, FiftyConcurrentSessions) {
  start();
  constexpr int kSessions = 50;
  std::atomic<int> ok{0};
  std::vector<std::thread> threads;
  for (int s = 0; s < kSessions; ++s)
    threads.emplace_back([&, s] {
      try {
        WsClient c;
        hello(c, s % 2 ? "bin" : "svg");
        ready(c);
        for (int i = 0; i < 3; ++i) frame(c, i, 0.1 * s + i);
        ok++;
        c.close();
      } catch (const std::exception& e) {
        ADD_FAILURE() << "session " << s << ": " << e.what();
      }
    });
  for (auto& t : threads) t.join();
  EXPECT_EQ(ok, kSessions);
}

// A height field of n x n quads (2 n^2 triangles), as OBJ text.
std::string grid_obj(int n) {
  std::string s;
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i)
      s += "v " + std::to_string(double(i) / n) + " " + std::to_string(0.1 * std::sin(i * 0.7) * std::cos(j * 0.3)) +
           " " + std::to_string(double(j) / n) + "\n";
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      int a = j * (n + 1) + i + 1, b = a + 1, c = a + n + 1, d = c + 1;
      s += "f " + std::to_string(a) + " " + std::to_string(c) + " " + std::to_string(b) + "\n";
      s += "f " + std::to_string(b) + " " + std::to_string(c) + " " + std::to_string(d) + "\n";
    }
  return s;
}

// A session that streams cameras for a big scene as fast as it can holds at most one pending
// frame, so a small session keeps getting its frames: at least one per heavy frame, never
// behind a backlog of the heavy session's cameras.
TEST_F(ServerTest, HeavySessionCannotStarveALightOne) {
  start();
  WsClient heavy;
  hello(heavy);
  std::string big = grid_obj(100);  // 20,000 triangles
  upload(heavy, "grid.obj", big);
  ASSERT_EQ(next(heavy, 120)["type"], "scene_ready");
  std::atomic<bool> stop{false};
  std::atomic<uint64_t> heavy_sent{0};
  std::thread spam([&] {  // 5 cameras per frame read: the server renders only the latest
    try {
      for (uint64_t i = 0; !stop;) {
        for (int k = 0; k < 5; ++k, ++i)
          heavy.send_text(json{{"type", "camera"}, {"seq", i}, {"eye", {0.5 + 2 * std::sin(0.01 * i), 1.5, 2 * std::cos(0.01 * i)}},
                               {"target", {0.5, 0, 0.5}}}.dump());
        heavy_sent = i;
        EXPECT_EQ(next(heavy, 60)["type"], "frame");
        heavy.read(60);
      }
    } catch (const std::exception& e) {
      ADD_FAILURE() << "heavy session: " << e.what();
    }
  });
  WsClient light;
  hello(light);
  ready(light);
  uint64_t frames_before = server_->metrics().frames;
  for (int i = 0; i < 20; ++i) frame(light, i, 0.2 * i);
  uint64_t total = server_->metrics().frames - frames_before;  // light (20) + heavy frames meanwhile
  stop = true;
  spam.join();
  std::printf("light frames 20, heavy frames meanwhile %llu, heavy cameras sent %llu\n",
              static_cast<unsigned long long>(total - 20), static_cast<unsigned long long>(heavy_sent.load()));
  EXPECT_LE(total - 20, 20u + 2);  // the heavy session got no more turns than the light one
  EXPECT_GT(heavy_sent.load(), total - 20);  // while sending many more cameras than it got frames
}

TEST_F(ServerTest, SlowClientGetsTheLatestCamera) {
  start();
  WsClient c;
  hello(c);
  ready(c);
  constexpr int kCameras = 100;
  for (int i = 0; i < kCameras; ++i)
    c.send_text(json{{"type", "camera"}, {"seq", i}, {"eye", {3 * std::sin(0.05 * i), 1, 3 * std::cos(0.05 * i)}}}.dump());
  // Every camera is either rendered or replaced by a newer one; the last one is always rendered.
  uint64_t frames = 0, skipped = 0, last = 0;
  while (last != kCameras - 1) {
    json h = next(c, 60);
    ASSERT_EQ(h["type"], "frame") << h.dump();
    c.read(60);
    ++frames;
    skipped += h["skipped"].get<uint64_t>();
    EXPECT_TRUE(h["seq"].get<uint64_t>() > last || frames == 1);
    last = h["seq"];
  }
  EXPECT_EQ(frames + skipped, uint64_t(kCameras));
  EXPECT_THROW(c.read(0.3), Timeout);  // nothing left queued behind the last frame
}

TEST_F(ServerTest, DisconnectMidFrameLeavesOthersServing) {
  start();
  WsClient keep;
  hello(keep);
  ready(keep);
  for (int k = 0; k < 5; ++k) {
    WsClient gone;
    hello(gone);
    ready(gone);
    gone.send_text(R"({"type":"camera","seq":1})");
    if (k % 2) gone.send_text(R"({"type":"scene","name":"x.obj","size":100})");  // and mid-upload
    gone.drop();
  }
  frame(keep, 1);
  wait_sessions_at_most(1, 500);
  EXPECT_EQ(server_->metrics().sessions_active, 1);
  frame(keep, 2);
}

TEST_F(ServerTest, BoundedSoakWithHostileClients) {
  cfg_.limits.max_message_bytes = 1 << 16;
  start();
  std::atomic<bool> stop{false};
  std::vector<std::thread> threads;
  for (int t = 0; t < 6; ++t)
    threads.emplace_back([&, t] {
      std::mt19937 rng(t);
      while (!stop) {
        try {
          WsClient c;
          hello(c, t % 2 ? "bin" : "svg");
          ready(c);
          for (int i = 0; i < 20 && !stop; ++i) {
            switch (rng() % 6) {
              case 0: c.send_text(std::string(rng() % 50, char('!' + rng() % 90))); break;
              case 1: {
                std::string junk(rng() % 2000, '\0');
                for (char& ch : junk) ch = char(rng());
                c.send_binary(junk);
                break;
              }
              case 2: c.send_text(R"({"type":"scene","name":"a.obj","size":7})"); break;
              default:
                c.send_text(json{{"type", "camera"}, {"seq", i}, {"eye", {std::sin(i), 0.5, std::cos(i) * 3}}}.dump());
            }
            while (true) c.read(0.01);  // drain whatever came back
          }
        } catch (const Timeout&) {
        } catch (const Closed&) {
        } catch (const std::exception&) {
        }
      }
    });
  std::this_thread::sleep_for(std::chrono::seconds(3));
  stop = true;
  for (auto& t : threads) t.join();
  EXPECT_EQ(json::parse(http_get("127.0.0.1", port_, "/health").body)["status"], "ok");
  WsClient c;
  hello(c);
  ready(c);
  frame(c, 1);
}

TEST_F(ServerTest, GracefulStopFinishesFramesAndRefusesNewConnections) {
  start();
  WsClient c;
  hello(c);
  ready(c);
  c.send_text(R"({"type":"camera","seq":1})");
  std::thread stopper([&] { server_->stop(); });
  bool header = false, payload = false;
  int code = -1;
  try {
    for (int i = 0; i < 10; ++i) {
      Message m = c.read(15);
      if (header && !payload) payload = true;
      else if (!m.binary && json::parse(m.data)["type"] == "frame") header = true;
    }
  } catch (const Closed& e) {
    code = e.code;
  }
  stopper.join();
  EXPECT_EQ(code, 1001);
  EXPECT_EQ(header, payload);  // never half a frame
  WsClient late;
  EXPECT_ANY_THROW(late.connect(url(), 2));
}


// Issue 15, bug 8: with --renderers 2 every other frame failed with device_error "no OpenCL
// device found", and 3 or 8 segfaulted at start inside PoCL: the Renderers were built
// concurrently, racing the OpenCL ICD loader's lazy initialisation. Three renderers, three
// sessions rendering at once: every frame is a frame.
TEST_F(ServerTest, SeveralRenderersBuiltConcurrentlyAllRender) {
  cfg_.renderers = 3;
  start();
  std::vector<std::thread> threads;
  std::atomic<int> frames{0};
  for (int s = 0; s < 3; ++s)
    threads.emplace_back([&, s] {
      try {
        WsClient c;
        hello(c);
        ready(c);
        for (int i = 0; i < 4; ++i) {
          auto [h, p] = frame(c, i, 0.3 * i + s);
          if (h["type"] == "frame") frames++;
        }
      } catch (const std::exception& e) {
        ADD_FAILURE() << "session " << s << ": " << e.what();
      }
    });
  for (auto& t : threads) t.join();
  EXPECT_EQ(frames, 12);
}

}  // namespace
