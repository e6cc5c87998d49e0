// vismapd on loopback, in process, with the real pipeline: handshake, uploads, frames in both
// formats, every error code a session can get, every limit, concurrency, slow and vanishing
// clients, a bounded soak and the graceful stop. Every wait is bounded.
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <boost/asio.hpp>
#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <nlohmann/json.hpp>
#include <random>
#include <thread>

#include "clients/wsclient.h"
#include "core/error.h"
#include "core/facts/scene_facts.h"
#include "core/pipeline.h"
#include "core/write/output.h"
#include "server/server.h"
#include "tests/server/server_fixture.h"
#include "tests/server/vismapd_process.h"

namespace {

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
    counted = http_get("127.0.0.1", port_, "/metrics").body.find("vismap_frames_total 3\n") !=
              std::string::npos;
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
  upload(c, "short.ply",
         "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\n"
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
  c.send_text(
      json{{"type", "scene"}, {"name", "big.obj"}, {"data", b64(std::string(1500, 'v'))}}.dump());
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
  c.send_text(
      json{{"type", "camera"}, {"seq", 1}, {"eye", {0, 1.5, 3}}, {"target", {0.25, 0.25, 0.25}}}
          .dump());
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
  waited =
      wait_for_server_close("127.0.0.1", port_, "GET / HTTP/1.1\r\nHost: x\r\n", 10);  // never ends
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
  std::atomic<uint64_t> heavy_frames{0};  // received by the heavy client
  std::thread spam([&] {  // 5 cameras per frame read: the server renders only the latest
    try {
      for (uint64_t i = 0; !stop;) {
        for (int k = 0; k < 5; ++k, ++i)
          heavy.send_text(json{
              {"type", "camera"},
              {"seq", i},
              {"eye", {0.5 + 2 * std::sin(0.01 * i), 1.5, 2 * std::cos(0.01 * i)}},
              {"target",
               {0.5, 0, 0.5}}}.dump());
        heavy_sent = i;
        EXPECT_EQ(next(heavy, 60)["type"], "frame");
        heavy.read(60);
        ++heavy_frames;
      }
    } catch (const std::exception& e) {
      ADD_FAILURE() << "heavy session: " << e.what();
    }
  });
  WsClient light;
  hello(light);
  ready(light);
  // Counted where the heavy client receives them: the server's frame counter moves after a
  // frame's send completes, so it could lag the light client's 20th frame by one (it read 19
  // once, and the difference wrapped around).
  const uint64_t heavy_before = heavy_frames;
  for (int i = 0; i < 20; ++i) frame(light, i, 0.2 * i);
  const uint64_t meanwhile = heavy_frames - heavy_before;
  stop = true;
  spam.join();
  std::printf("light frames 20, heavy frames meanwhile %llu, heavy cameras sent %llu\n",
              static_cast<unsigned long long>(meanwhile),
              static_cast<unsigned long long>(heavy_sent.load()));
  EXPECT_LE(meanwhile, 20u + 2);  // the heavy session got no more turns than the light one
  EXPECT_GT(heavy_sent.load(), meanwhile);  // while sending many more cameras than it got frames
}

TEST_F(ServerTest, SlowClientGetsTheLatestCamera) {
  start();
  WsClient c;
  hello(c);
  ready(c);
  constexpr int kCameras = 100;
  for (int i = 0; i < kCameras; ++i)
    c.send_text(json{{"type", "camera"},
                     {"seq", i},
                     {"eye", {3 * std::sin(0.05 * i), 1, 3 * std::cos(0.05 * i)}}}
                    .dump());
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

// A WebSocket client on a raw socket that reads at a set rate, for the slow-reader test: its
// receive buffer is small (SO_RCVBUF before connect), so the server's send can only go as fast
// as it reads, as over a slow link. Unmasked server frames, masked client frames (RFC 6455).
class ThrottledClient {
 public:
  ThrottledClient(const std::string& port, int rcvbuf) {
    fd_ = ::socket(AF_INET, SOCK_STREAM, 0);
    ::setsockopt(fd_, SOL_SOCKET, SO_RCVBUF, &rcvbuf, sizeof rcvbuf);
    timeval tv{20, 0};  // no read or write waits longer
    ::setsockopt(fd_, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
    ::setsockopt(fd_, SOL_SOCKET, SO_SNDTIMEO, &tv, sizeof tv);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_port = htons(static_cast<uint16_t>(std::stoi(port)));
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    if (::connect(fd_, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0)
      throw std::runtime_error("connect failed");
    write_all(
        "GET / HTTP/1.1\r\nHost: 127.0.0.1\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
        "Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n\r\n");
    std::string head;
    while (head.size() < 4 || head.compare(head.size() - 4, 4, "\r\n\r\n") != 0) head += take(1);
    if (head.find(" 101 ") == std::string::npos) throw std::runtime_error("upgrade: " + head);
  }
  ~ThrottledClient() { ::close(fd_); }
  void send(const std::string& payload, bool binary) {
    std::string f(1, static_cast<char>(binary ? 0x82 : 0x81));
    size_t n = payload.size();
    if (n < 126) {
      f += static_cast<char>(0x80 | n);
    } else if (n < 65536) {
      f += static_cast<char>(0x80 | 126);
      for (int k = 1; k >= 0; --k) f += static_cast<char>((n >> (8 * k)) & 0xff);
    } else {
      f += static_cast<char>(0x80 | 127);
      for (int k = 7; k >= 0; --k) f += static_cast<char>((uint64_t(n) >> (8 * k)) & 0xff);
    }
    const char mask[4] = {0x12, 0x34, 0x56, 0x78};
    f.append(mask, 4);
    for (size_t i = 0; i < n; ++i) f += static_cast<char>(payload[i] ^ mask[i % 4]);
    write_all(f);
  }
  // The next data message; reads at most bytes_per_s (0: as fast as it comes). Answers pings;
  // throws on a close frame or a dropped connection.
  std::string read_message(double bytes_per_s = 0) {
    rate_ = bytes_per_s;
    std::string msg;
    for (;;) {
      std::string h = take(2);
      int op = h[0] & 0x0f;
      bool fin = (h[0] & 0x80) != 0;
      uint64_t n = h[1] & 0x7f;
      if (n >= 126) {
        std::string e = take(n == 126 ? 2 : 8);
        n = 0;
        for (char c : e) n = (n << 8) | static_cast<uint8_t>(c);
      }
      std::string payload = take(n);
      if (op == 0x8) throw std::runtime_error("closed by the server");
      if (op == 0x9) {
        send_control(0xA, payload);
        continue;
      }
      if (op == 0xA) continue;
      msg += payload;
      if (fin) return msg;
    }
  }

 private:
  void send_control(int op, const std::string& payload) {
    std::string f(1, static_cast<char>(0x80 | op));
    f += static_cast<char>(0x80 | payload.size());
    f.append(4, '\0');  // mask key 0: the payload as is
    write_all(f + payload);
  }
  void write_all(const std::string& s) {
    for (size_t off = 0; off < s.size();) {
      ssize_t k = ::send(fd_, s.data() + off, s.size() - off, MSG_NOSIGNAL);
      if (k <= 0) throw std::runtime_error("send failed");
      off += static_cast<size_t>(k);
    }
  }
  // n bytes, in reads of at most 8 KiB paced to rate_.
  std::string take(uint64_t n) {
    std::string out;
    while (out.size() < n) {
      if (!buf_.empty()) {
        size_t k = std::min<size_t>(buf_.size(), n - out.size());
        out.append(buf_, 0, k);
        buf_.erase(0, k);
        continue;
      }
      char tmp[8192];
      ssize_t k = ::recv(fd_, tmp, sizeof tmp, 0);
      if (k <= 0)
        throw std::runtime_error("connection dropped after " + std::to_string(total_) + " bytes");
      total_ += static_cast<uint64_t>(k);
      buf_.append(tmp, static_cast<size_t>(k));
      if (rate_ > 0) std::this_thread::sleep_for(std::chrono::duration<double>(k / rate_));
    }
    return out;
  }
  int fd_ = -1;
  std::string buf_;
  double rate_ = 0;
  uint64_t total_ = 0;
};

// Issue 45, item 8: the idle timeout counted from the client's last message, and Beast's own
// idle timeout (keep-alive pings queued behind the frame) counted bytes received only, so a
// client reading a big frame slowly was cut off mid-frame (a 2.7 MB frame read at 150 KB/s).
// Here a 2 s idle timeout and a ~0.9 MB frame read at 150 kB/s (about six seconds): the whole
// frame arrives, and the session still answers the next camera. On a3eef30 the connection
// dropped mid-frame, or the frame was followed by a timeout error.
TEST_F(ServerTest, SlowReaderIsNotCutOffMidFrame) {
  cfg_.limits.idle_timeout_s = 2;
  start();
  ThrottledClient c(port_, 32 << 10);
  c.send(json{{"type", "hello"},
              {"version", 1},
              {"format", "svg"},
              {"viewport", {{"width", 1024}, {"height", 1024}}}}
             .dump(),
         false);
  ASSERT_EQ(json::parse(c.read_message())["type"], "welcome");
  const std::string scene = grid_obj(100);  // 20,000 triangles, nearly all visible: ~0.9 MB SVG
  c.send(json{{"type", "scene"}, {"name", "grid.obj"}, {"size", scene.size()}}.dump(), false);
  c.send(scene, true);
  json r = json::parse(c.read_message());
  ASSERT_EQ(r["type"], "scene_ready") << r.dump();
  constexpr double kRate = 150e3;  // bytes per second, as the issue's reader
  for (uint64_t seq = 1; seq <= 2; ++seq) {
    c.send(json{{"type", "camera"},
                {"seq", seq},
                {"eye", {0.5, 1.6, 0.5 + 0.01 * seq}},
                {"target", {0.5, 0, 0.5}},
                {"up", {0, 0, -1}}}
               .dump(),
           false);
    json h = json::parse(c.read_message());
    ASSERT_EQ(h["type"], "frame") << h.dump();
    std::string payload = c.read_message(kRate);  // paced: 5 s or more for 750 kB
    EXPECT_EQ(payload.size(), h["bytes"].get<uint64_t>());
    if (seq == 1) {
      ASSERT_GT(payload.size(), 750'000u) << "the frame must take several idle timeouts to read";
    }
  }
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
              case 0:
                c.send_text(std::string(rng() % 50, char('!' + rng() % 90)));
                break;
              case 1: {
                std::string junk(rng() % 2000, '\0');
                for (char& ch : junk) ch = char(rng());
                c.send_binary(junk);
                break;
              }
              case 2:
                c.send_text(R"({"type":"scene","name":"a.obj","size":7})");
                break;
              default:
                c.send_text(json{
                    {"type", "camera"}, {"seq", i}, {"eye", {std::sin(i), 0.5, std::cos(i) * 3}}}
                                .dump());
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
      if (header && !payload)
        payload = true;
      else if (!m.binary && json::parse(m.data)["type"] == "frame")
        header = true;
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

// Peak resident memory of this process (VmHWM), in MiB.
double peak_rss_mib() {
  std::ifstream f("/proc/self/status");
  std::string line;
  while (std::getline(f, line))
    if (line.rfind("VmHWM:", 0) == 0) return std::stod(line.substr(6)) / 1024;
  return 0;
}

// Issue 15, bug 4: an 80 MB camera of nested arrays (under max_message_bytes) was parsed into a
// 3.2 GB DOM before its size was checked against max_control_bytes. Here 6 MB of nesting: the
// old DOM took ~270 MB; checked before parsing it costs a few copies of the message.
TEST_F(ServerTest, ControlMessageSizeCheckedBeforeParsing) {
  start();
  WsClient c;
  hello(c);
  constexpr size_t kDepth = 3'000'000;
  std::string msg = R"({"type":"camera","seq":1,"eye":)" + std::string(kDepth, '[') +
                    std::string(kDepth, ']') + "}";
  double before = peak_rss_mib();
  c.send_text(msg, 30);
  expect_error(c, "too_large");
  double grew = peak_rss_mib() - before;
  std::printf("peak RSS grew %.0f MiB for a %.0f MiB message\n", grew, msg.size() / 1048576.0);
  EXPECT_LT(grew, 120) << "the message was parsed into a DOM";
  c.send_text(R"({"type":"ping","seq":2})");
  EXPECT_EQ(next(c)["type"], "pong");
}

// Issue 15, bug 4, second half: JSON nesting is bounded in every control message, small ones
// too (the old parser answered this ping).
TEST_F(ServerTest, DeepJsonNestingRefusedBeforeParsing) {
  start();
  WsClient c;
  hello(c);
  c.send_text(R"({"type":"ping","seq":1,"x":)" + std::string(50, '[') + std::string(50, ']') + "}");
  expect_error(c, "bad_message");
  c.send_text(R"({"type":"ping","seq":2,"x":[[1]]})");
  EXPECT_EQ(next(c)["type"], "pong");
}

// Issue 15, bug 7: SIGTERM during a 26 s frame with drain_timeout_s 3 exited after 16.7 s and
// sessions saw EOF. Here a 2.5 s frame and a 0.6 s drain: stop() returns by the deadline and the
// session gets shutting_down and close 1001 first.
TEST_F(ServerTest, DrainDeadlineKeptWithCloseGoingAway) {
  cfg_.drain_timeout_s = 0.6;
  std::atomic<bool> rendering{false};
  cfg_.before_render = [&](const vismap::RenderOptions&) {
    rendering = true;
    std::this_thread::sleep_for(std::chrono::milliseconds(2500));
  };
  start();
  WsClient c;
  hello(c);
  ready(c);
  c.send_text(R"({"type":"camera","seq":1})");
  for (int i = 0; i < 500 && !rendering; ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  ASSERT_TRUE(rendering);
  std::atomic<double> stop_s{-1};
  std::atomic<bool> clean{true};
  std::thread stopper([&] {
    auto t0 = std::chrono::steady_clock::now();
    clean = server_->stop();
    stop_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  });
  json e = next(c, 5);
  EXPECT_EQ(e["code"], "shutting_down") << e.dump();
  EXPECT_EQ(e["fatal"], true);
  EXPECT_EQ(close_code(c), 1001);
  stopper.join();
  EXPECT_LT(stop_s, 0.6 + 0.4);
  EXPECT_FALSE(clean);  // the frame was still on the worker: left behind
}

// limits.render_time_limit_s reaches the pipeline as RenderOptions::time_limit_s, and the
// pipeline's InputError TimeLimit reaches the client as time_limit, not fatal: the session goes
// on. (The pipeline error is stood in by the test seam; the next test uses the real pipeline.)
TEST_F(ServerTest, TimeLimitIsANonFatalError) {
  cfg_.limits.render_time_limit_s = 0.25;
  std::atomic<int> calls{0};
  std::atomic<double> seen{-1};
  cfg_.before_render = [&](const vismap::RenderOptions& o) {
    seen = o.time_limit_s;
    if (calls++ == 0)
      throw vismap::InputError(vismap::InputErrorKind::TimeLimit, "", "", "", -1,
                               "render took longer than 0.25 s");
  };
  start();
  WsClient c;
  hello(c);
  ready(c);
  c.send_text(R"({"type":"camera","seq":4})");
  json e = next(c, 60);
  EXPECT_EQ(e["type"], "error") << e.dump();
  EXPECT_EQ(e["code"], "time_limit") << e.dump();
  EXPECT_EQ(e["fatal"], false);
  EXPECT_EQ(e["seq"], 4);
  auto [h, p] = frame(c, 5);
  EXPECT_EQ(h["seq"], 5);
  EXPECT_EQ(seen, 0.25);
}

// A session's scene gets its view-independent facts (core/facts/scene_facts.h) on the load pool
// after scene_ready; from then on every frame is given them, whichever renderer draws it, and
// the frames are the same bytes with and without them.
TEST_F(ServerTest, SceneFactsFoundAfterTheLoadAndGivenToFrames) {
  std::mutex mu;
  std::vector<bool> given;
  cfg_.renderers = 2;
  cfg_.before_render = [&](const vismap::RenderOptions& o) {
    std::lock_guard lk(mu);
    given.push_back(o.scene_facts != nullptr && o.scene_facts->cap > 0);
  };
  start();
  WsClient c;
  hello(c);
  ready(c);
  std::vector<std::string> payload;
  for (uint64_t i = 0; i < 200; ++i) {
    payload.push_back(frame(c, i, 0.3).second.data);
    std::lock_guard lk(mu);
    if (given.size() >= 3 && given[given.size() - 3]) break;  // (and two more after it)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  for (size_t i = 1; i < payload.size(); ++i) EXPECT_EQ(payload[i], payload[0]) << i;
  std::lock_guard lk(mu);
  const auto first = std::find(given.begin(), given.end(), true);
  ASSERT_NE(first, given.end()) << "no frame was given the scene's facts";
  EXPECT_TRUE(std::all_of(first, given.end(), [](bool g) { return g; }));
}

TEST_F(ServerTest, TimeLimitFromThePipeline) {
  cfg_.limits.render_time_limit_s = 1e-6;
  start();
  WsClient c;
  hello(c);
  ready(c);
  c.send_text(R"({"type":"camera","seq":1})");
  json j = next(c, 60);
  EXPECT_EQ(j["code"], "time_limit") << j.dump();
  EXPECT_EQ(j["fatal"], false);
  c.send_text(R"({"type":"ping","seq":2})");
  EXPECT_EQ(next(c)["type"], "pong");
}

// Library confinement (issue 15): a name must resolve (realpath) to a regular file inside the
// library. A symlink out of it, a FIFO (which had blocked a load thread in open() for good) and
// a device are refused with a non-fatal file_not_found; a symlink inside the library is fine.
TEST_F(ServerTest, LibraryRefusesSymlinksOutFifosAndDevices) {
  fs::path outside = lib_.string() + "_outside";
  fs::create_directories(outside);
  std::ofstream(outside / "secret.obj") << kTet;
  fs::create_symlink(outside / "secret.obj", lib_ / "link.obj");
  fs::create_directory_symlink(outside, lib_ / "out");
  fs::create_symlink("/dev/zero", lib_ / "zero.obj");
  fs::create_symlink(lib_ / "tet.obj", lib_ / "alias.obj");
  ASSERT_EQ(::mkfifo((lib_ / "fifo.obj").c_str(), 0600), 0);
  start();
  WsClient c;
  hello(c);
  for (const char* name : {"link.obj", "out/secret.obj", "zero.obj", "fifo.obj"}) {
    c.send_text(json{{"type", "scene"}, {"library", name}}.dump());
    json e = next(c, 10);
    EXPECT_EQ(e["code"], "file_not_found") << name << ": " << e.dump();
    EXPECT_EQ(e["fatal"], false);
    std::string m = e.value("message", "");
    EXPECT_EQ(m.find(lib_.string()), std::string::npos) << m;
    EXPECT_EQ(m.find(outside.string()), std::string::npos) << m;
  }
  c.send_text(R"({"type":"scene","library":"alias.obj"})");
  EXPECT_EQ(next(c, 60)["type"], "scene_ready");
  fs::remove_all(outside);
}

// Error messages for library scenes name library-relative files, never the server's folder,
// including files a scene file references.
TEST_F(ServerTest, LibraryErrorsHideServerPaths) {
  std::ofstream(lib_ / "bad.obj") << "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n";
  std::ofstream(lib_ / "refs.json") << R"({"meshes":[{"file":"missing.obj"}]})";
  start();
  WsClient c;
  hello(c);
  for (const char* name : {"bad.obj", "refs.json"}) {
    c.send_text(json{{"type", "scene"}, {"library", name}}.dump());
    json e = next(c, 30);
    EXPECT_EQ(e["type"], "error") << e.dump();
    EXPECT_EQ(e["fatal"], false);
    std::string m = e.value("message", "");
    EXPECT_EQ(m.find(lib_.string()), std::string::npos) << m;
    EXPECT_NE(m.find(name), std::string::npos) << m;
  }
}

// Issue 15, weak spot (a): session slots were taken at the upgrade, so connections that never
// send hello held all of max_sessions. Now a slot is taken at hello.
TEST_F(ServerTest, SessionSlotTakenOnlyAfterHello) {
  cfg_.limits.max_sessions = 2;
  start();
  std::vector<std::unique_ptr<WsClient>> silent;
  for (int i = 0; i < 3; ++i) {
    silent.push_back(std::make_unique<WsClient>());
    silent.back()->connect(url());
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  WsClient a, b;
  hello(a);
  hello(b);
  WsClient c;  // the server is full now: refused at once, as before
  c.connect(url());
  expect_error(c, "busy", true);
  EXPECT_EQ(close_code(c), 1013);
}

// Issue 15, weak spot (b): one peer with 300 slow connections held the 256-connection cap.
// limits.max_connections_per_address caps one address; other addresses still get in.
TEST_F(ServerTest, PerAddressConnectionLimit) {
  cfg_.limits.max_connections = 10;
  cfg_.limits.max_connections_per_address = 2;
  start();
  WsClient a, b;
  hello(a);
  hello(b);
  double waited = wait_for_server_close("127.0.0.1", port_, "", 5);  // third from 127.0.0.1
  EXPECT_GE(waited, 0);
  EXPECT_LT(waited, 1.0);
  // Another peer address (all of 127/8 is loopback): served.
  boost::asio::io_context io;
  boost::asio::ip::tcp::socket s(io);
  s.open(boost::asio::ip::tcp::v4());
  s.bind({boost::asio::ip::make_address("127.0.0.2"), 0});
  s.connect({boost::asio::ip::make_address("127.0.0.1"), static_cast<uint16_t>(std::stoi(port_))});
  std::string req = "GET /health HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n";
  boost::asio::write(s, boost::asio::buffer(req));
  std::string got;
  boost::system::error_code ec;
  boost::asio::read(s, boost::asio::dynamic_buffer(got), ec);
  EXPECT_EQ(got.rfind("HTTP/1.1 200", 0), 0u) << got;
  a.close();
  wait_sessions_at_most(1);
  for (int i = 0; i < 200 && server_->metrics().sessions_active > 1; ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  WsClient d;  // a slot of 127.0.0.1 is free again
  hello(d);
}

// Issue 15, weak spot (c): vismapd keeps freed memory for reuse (then M_MMAP_MAX=0), so one big
// upload stayed resident for good. A session that held a big message hands the heap's free
// pages back when it ends (and a big upload once its load is done).
TEST(VismapdProcess, MemoryReturnedAfterABigUpload) {
  Vismapd d({"--port", "0", "--log-level", "info"});
  std::string url = "ws://127.0.0.1:" + d.port() + "/";
  double base = d.settled_rss_mib(), peak = 0, after = 0;
  {
    WsClient c;
    c.connect(url);
    c.send_text(R"({"type":"hello","version":1})");
    ASSERT_EQ(json::parse(c.read(30).data)["type"], "welcome");
    std::string big;
    big.reserve(48 << 20);
    while (big.size() < (48u << 20)) big += "# a comment line, forty-eight MiB of them....\n";
    c.send_text(json{{"type", "scene"}, {"name", "big.obj"}, {"size", big.size()}}.dump());
    c.send_binary(big, 60);
    json r = json::parse(c.read(60).data);
    EXPECT_EQ(r["type"], "error") << r.dump();  // no faces
    c.close();
  }
  peak = d.status_mib("VmHWM:");
  // A trim after the session's end (and one when the upload's load was done).
  auto trimmed_after_close = [&] {
    auto closes = d.events("session_close");
    if (closes.empty()) return false;
    for (const json& t : d.events("memory_trimmed"))
      if (t["ts"].get<double>() >= closes.back()["ts"].get<double>()) return true;
    return false;
  };
  for (int i = 0; i < 300 && !trimmed_after_close(); ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  after = d.rss_mib();
  EXPECT_TRUE(trimmed_after_close());
  std::printf("vismapd RSS: %.0f MiB settled, %.0f MiB peak (48 MiB upload), %.0f MiB after\n",
              base, peak, after);
  EXPECT_GT(peak, base + 48);  // the spike was real
  // Measured: without the trims 158 MiB stayed (of a 206 MiB peak); with them 112-136, once 176.
  // How much comes back depends on where the buffers were: malloc_trim madvises free chunks in
  // every arena but shrinks only the main arena's top, and a thread arena's top is trimmed on
  // free only past M_TRIM_THRESHOLD (512 MiB, keep_freed_memory_for_reuse). So this asserts
  // that the trim runs when the session ends, and prints the figures.
}

// Issue 15: a .ply.gz upload's inflated bytes count against the session (the loader gets the
// session's remaining max_session_bytes as LoadOptions::max_bytes). 3 MiB of PLY that gzip
// makes ~10 KiB, in a session of 1 MiB: too_large, and the session goes on.
TEST_F(ServerTest, GzipInflatedBytesChargedToTheSession) {
  cfg_.limits.max_session_bytes = 1 << 20;
  start();
  std::string ply = "ply\nformat ascii 1.0\n";
  while (ply.size() < (3u << 20)) ply += "comment padding that inflates to three mebibytes\n";
  ply +=
      "element vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
      "element face 1\nproperty list uchar int vertex_indices\nend_header\n"
      "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
  fs::path raw = lib_ / "pad.ply";
  std::ofstream(raw, std::ios::binary) << ply;
  ASSERT_EQ(std::system(("gzip -kf " + raw.string()).c_str()), 0);
  std::ifstream in(raw.string() + ".gz", std::ios::binary);
  std::string gz((std::istreambuf_iterator<char>(in)), {});
  ASSERT_LT(gz.size(), 100000u);
  WsClient c;
  hello(c);
  upload(c, "pad.ply.gz", gz);
  json r = next(c, 60);
  EXPECT_EQ(r["code"], "too_large") << r.dump();
  EXPECT_EQ(r["fatal"], false);
  c.send_text(R"({"type":"ping","seq":1})");
  EXPECT_EQ(next(c)["type"], "pong");
}

// Issue 15, bug 7, on the real binary: SIGTERM during a long frame (VISMAPD_TEST_FRAME_DELAY_S
// makes each frame take 4 s more) with drain_timeout_s 0.6: the session gets shutting_down and
// close 1001, and the process exits 0 by the deadline (it had waited for the frame, 16.7 s after
// a 3 s drain).
TEST(VismapdProcess, SigtermDuringAFrameExitsByTheDrainDeadline) {
  fs::path dir = fs::temp_directory_path() / ("vismapd_sigterm_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  std::ofstream(dir / "tet.obj") << kTet;
  std::ofstream(dir / "conf.json")
      << R"({"drain_timeout_s":0.6,"library":")" + dir.string() + R"("})";
  ::setenv("VISMAPD_TEST_FRAME_DELAY_S", "4", 1);
  Vismapd d({"--port", "0", "--config", (dir / "conf.json").string()});
  ::unsetenv("VISMAPD_TEST_FRAME_DELAY_S");
  WsClient c;
  c.connect("ws://127.0.0.1:" + d.port() + "/");
  c.send_text(R"({"type":"hello","version":1})");
  ASSERT_EQ(json::parse(c.read(30).data)["type"], "welcome");
  c.send_text(R"({"type":"scene","library":"tet.obj"})");
  ASSERT_EQ(json::parse(c.read(60).data)["type"], "scene_ready");
  c.send_text(R"({"type":"camera","seq":1})");
  std::this_thread::sleep_for(std::chrono::milliseconds(300));  // the frame is on the worker
  auto t0 = std::chrono::steady_clock::now();
  d.signal(SIGTERM);
  json e = json::parse(c.read(5).data);
  EXPECT_EQ(e["code"], "shutting_down") << e.dump();
  int code = -1;
  try {
    c.read(5);
  } catch (const Closed& x) {
    code = x.code;
  }
  EXPECT_EQ(code, 1001);
  int status = d.wait_exit(5);
  double took = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::printf("exit %d after %.2f s (drain 0.6 s, frame 4 s)\n", status, took);
  EXPECT_EQ(status, 0);
  EXPECT_LT(took, 0.6 + 0.6);
  fs::remove_all(dir);
}

}  // namespace
