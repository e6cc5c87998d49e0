// The loopback server fixture shared by the server test files (test_server.cpp,
// test_server_v2.cpp): an in-process vismapd on an ephemeral port with a library of one
// tetrahedron, and helpers for hello, uploads and frames. Every wait is bounded.
#pragma once

#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>

#include "clients/wsclient.h"
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

[[maybe_unused]] std::string b64(const std::string& in) {
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

// A height field of n x n quads (2 n^2 triangles), as OBJ text.
std::string grid_obj(int n) {
  std::string s;
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i)
      s += "v " + std::to_string(double(i) / n) + " " +
           std::to_string(0.1 * std::sin(i * 0.7) * std::cos(j * 0.3)) + " " +
           std::to_string(double(j) / n) + "\n";
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      int a = j * (n + 1) + i + 1, b = a + 1, c = a + n + 1, d = c + 1;
      s += "f " + std::to_string(a) + " " + std::to_string(c) + " " + std::to_string(b) + "\n";
      s += "f " + std::to_string(b) + " " + std::to_string(c) + " " + std::to_string(d) + "\n";
    }
  return s;
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
    json h = {{"type", "hello"},
              {"version", 1},
              {"format", format},
              {"viewport", {{"width", 128}, {"height", 96}}}};
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
    c.send_text(json{{"type", "camera"},
                     {"seq", seq},
                     {"eye", {3 * std::sin(angle), 1.5, 3 * std::cos(angle)}},
                     {"target", {0.25, 0.25, 0.25}}}
                    .dump());
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

}  // namespace
