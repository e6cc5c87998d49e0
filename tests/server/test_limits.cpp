// Issue 35's server cases, scaled down to seconds, against the real vismapd binary: a heavy
// request (a deep .sexp upload, a dense implicit from three sessions, crumpled Bezier patches,
// Loop control meshes at a fine tolerance, a scene file of 10^4 instances) is answered with an
// error code within its limits while a bystander session on a small mesh keeps getting frames,
// and the memory the request took goes back when it ends. bench/server_limits.py runs the same
// cases at full size and prints the figures (docs/SERVER.md "Resource model").
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <random>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "clients/wsclient.h"
#include "tests/server/server_fixture.h"
#include "tests/server/vismapd_process.h"

namespace {

// An icosphere of 20 * 4^levels triangles, as OBJ (the bystander's mesh, the Loop control
// meshes: `jitter` moves each vertex radially by up to that fraction).
std::string icosphere_obj(int levels, double jitter = 0, unsigned seed = 0) {
  const double t = (1 + std::sqrt(5.0)) / 2;
  std::vector<std::array<double, 3>> v = {{-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0},
                                          {0, -1, t}, {0, 1, t}, {0, -1, -t}, {0, 1, -t},
                                          {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}};
  std::vector<std::array<uint32_t, 3>> f = {
      {0, 11, 5},  {0, 5, 1},  {0, 1, 7},  {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
      {11, 10, 2}, {10, 7, 6}, {7, 1, 8},  {3, 9, 4},  {3, 4, 2},   {3, 2, 6}, {3, 6, 8},
      {3, 8, 9},   {4, 9, 5},  {2, 4, 11}, {6, 2, 10}, {8, 6, 7},   {9, 8, 1}};
  auto unit = [](std::array<double, 3> p) {
    const double n = std::sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
    return std::array<double, 3>{p[0] / n, p[1] / n, p[2] / n};
  };
  for (auto& p : v) p = unit(p);
  for (int l = 0; l < levels; ++l) {
    std::map<std::pair<uint32_t, uint32_t>, uint32_t> mid;
    auto m = [&](uint32_t a, uint32_t b) {
      auto [it, fresh] = mid.try_emplace({std::min(a, b), std::max(a, b)}, uint32_t(v.size()));
      if (fresh)
        v.push_back(
            unit({(v[a][0] + v[b][0]) / 2, (v[a][1] + v[b][1]) / 2, (v[a][2] + v[b][2]) / 2}));
      return it->second;
    };
    std::vector<std::array<uint32_t, 3>> g;
    for (auto [a, b, c] : f) {
      const uint32_t ab = m(a, b), bc = m(b, c), ca = m(c, a);
      g.insert(g.end(), {{a, ab, ca}, {b, bc, ab}, {c, ca, bc}, {ab, bc, ca}});
    }
    f = std::move(g);
  }
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-jitter, jitter);
  std::string s;
  for (auto& p : v) {
    const double k = 1 + u(rng);
    s += "v " + std::to_string(k * p[0]) + " " + std::to_string(k * p[1]) + " " +
         std::to_string(k * p[2]) + "\n";
  }
  for (auto [a, b, c] : f)
    s += "f " + std::to_string(a + 1) + " " + std::to_string(b + 1) + " " + std::to_string(c + 1) +
         "\n";
  return s;
}

double pct(std::vector<double> v, double p) {
  if (v.empty()) return NAN;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, size_t(std::ceil(p / 100 * v.size())) - 1)];
}

// A session on a small mesh that asks for a frame, waits for it and asks again until stopped.
class Bystander {
  using Clock = std::chrono::steady_clock;

 public:
  Bystander(const std::string& url, const std::string& scene) {
    c_.connect(url);
    c_.send_text(
        R"({"type":"hello","version":1,"format":"bin","viewport":{"width":256,"height":256}})");
    if (json::parse(c_.read(30).data)["type"] != "welcome") throw std::runtime_error("no welcome");
    c_.send_text(json{{"type", "scene"}, {"library", scene}}.dump());
    if (json::parse(c_.read(60).data)["type"] != "scene_ready")
      throw std::runtime_error("bystander scene not loaded");
    thread_ = std::thread([this] { run(); });
  }
  ~Bystander() { stop(); }
  void stop() {
    running_ = false;
    if (thread_.joinable()) thread_.join();
  }
  size_t frames() const { return frames_; }
  int errors() const { return errors_; }
  // Latencies (seconds) of the frames asked for in [t0, t1).
  std::vector<double> during(Clock::time_point t0, Clock::time_point t1) {
    std::lock_guard lk(mu_);
    std::vector<double> out;
    for (auto [t, s] : lat_)
      if (t >= t0 && t < t1) out.push_back(s);
    return out;
  }

 private:
  void run() {
    try {
      for (uint64_t seq = 1; running_; ++seq) {
        const double a = 0.1 * double(seq);
        const auto t = Clock::now();
        c_.send_text(json{
            {"type", "camera"},
            {"seq", seq},
            {"eye", {3 * std::sin(a), 1, 3 * std::cos(a)}},
            {"target",
             {0, 0, 0}}}.dump());
        json h = json::parse(c_.read(120).data);
        if (h["type"] != "frame") {
          ++errors_;
          continue;
        }
        c_.read(30);  // the payload
        std::lock_guard lk(mu_);
        lat_.push_back({t, std::chrono::duration<double>(Clock::now() - t).count()});
        ++frames_;
      }
    } catch (const std::exception&) {
      ++errors_;
    }
    c_.close();
  }
  WsClient c_;
  std::thread thread_;
  std::atomic<bool> running_{true};
  std::atomic<size_t> frames_{0};
  std::atomic<int> errors_{0};
  std::mutex mu_;
  std::vector<std::pair<Clock::time_point, double>> lat_;
};

// What a heavy session asks for: a scene (uploaded bytes, or a library name) with hello's extra
// fields, then one camera if the scene loads.
struct Heavy {
  std::string name, bytes, library = {};
  json hello = json::object();
};
// Its answers: the error code or "scene_ready" / "frame", and their messages.
struct Answer {
  std::string load, frame, message;
};

Answer ask(const std::string& url, const Heavy& h) {
  Answer a;
  WsClient c;
  c.connect(url);
  json hello = {{"type", "hello"},
                {"version", 1},
                {"format", "bin"},
                {"viewport", {{"width", 256}, {"height", 256}}}};
  hello.update(h.hello);
  c.send_text(hello.dump());
  if (json::parse(c.read(30).data)["type"] != "welcome") return {"no welcome", "", ""};
  if (!h.library.empty()) {
    c.send_text(json{{"type", "scene"}, {"library", h.library}}.dump());
  } else {
    c.send_text(json{{"type", "scene"}, {"name", h.name}, {"size", h.bytes.size()}}.dump());
    c.send_binary(h.bytes, 60);
  }
  json r = json::parse(c.read(120).data);
  a.load = r.value("code", r["type"].get<std::string>());
  a.message = r.value("message", "");
  if (r["type"] == "scene_ready") {
    c.send_text(R"({"type":"camera","seq":1})");
    json f = json::parse(c.read(120).data);
    a.frame = f.value("code", f["type"].get<std::string>());
    a.message = f.value("message", "");
    if (f["type"] == "frame") c.read(60);
  }
  c.close();
  return a;
}

// vismapd with small limits (3 s, 256 MiB a frame, 64 MiB a session), a library holding the
// bystander's icosphere (1,280 triangles), and a bystander session.
class HeavyCase : public ::testing::Test {
 protected:
  static constexpr double kTimeLimit = 3;
  static constexpr uint64_t kFrameBytes = 256ull << 20, kSessionBytes = 64ull << 20;

  void SetUp() override {
    lib_ = fs::temp_directory_path() /
           ("vismapd_limits_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(lib_ / "lib");
    std::ofstream(lib_ / "lib" / "bystander.obj") << icosphere_obj(3);
    json conf = {{"library", (lib_ / "lib").string()},
                 {"log_level", "info"},
                 {"limits",
                  {{"render_time_limit_s", kTimeLimit},
                   {"render_memory_bytes", kFrameBytes},
                   {"max_session_bytes", kSessionBytes},
                   {"max_triangles", 1000000},
                   {"idle_timeout_s", 120}}}};
    std::ofstream(lib_ / "conf.json") << conf.dump();
    d_ = std::make_unique<Vismapd>(
        std::vector<std::string>{"--port", "0", "--config", (lib_ / "conf.json").string()});
    url_ = "ws://127.0.0.1:" + d_->port() + "/";
  }
  void TearDown() override {
    by_.reset();
    d_.reset();
    fs::remove_all(lib_);
  }
  std::string write(const std::string& name, const std::string& text) {
    std::ofstream(lib_ / "lib" / name) << text;
    return name;
  }

  // Runs the heavy sessions at once beside the bystander: `warm` first, alone (it builds the
  // kernels the case uses: PoCL's compiled code stays for the process's life), then the idle
  // figure, then the case. Returns the answers; checks the bystander and the memory.
  std::vector<Answer> run(const std::vector<Heavy>& heavy, const Heavy& warm) {
    Answer w = ask(url_, warm);
    EXPECT_EQ(w.frame, "frame") << w.load << " " << w.message;
    by_ = std::make_unique<Bystander>(url_, "bystander.obj");
    while (by_->frames() < 3) std::this_thread::sleep_for(std::chrono::milliseconds(20));
    const size_t trims = d_->events("memory_trimmed").size();
    const double idle = d_->settled_rss_mib();
    const auto t0 = std::chrono::steady_clock::now();
    std::vector<Answer> out(heavy.size());
    std::vector<std::thread> th;
    for (size_t i = 0; i < heavy.size(); ++i)
      th.emplace_back([&, i] { out[i] = ask(url_, heavy[i]); });
    for (std::thread& t : th) t.join();
    const auto t1 = std::chrono::steady_clock::now();
    const double took = std::chrono::duration<double>(t1 - t0).count();
    for (const Answer& a : out)
      std::printf("answer: %s, %s: %s\n", a.load.c_str(), a.frame.c_str(), a.message.c_str());
    const double peak = d_->status_mib("VmHWM:");
    // The bystander goes on: frames after the case, and no error at any time.
    const size_t before = by_->frames();
    for (int i = 0; i < 3000 && by_->frames() < before + 2; ++i)
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    EXPECT_GE(by_->frames(), before + 2) << "the bystander's frames stopped";
    by_->stop();
    EXPECT_EQ(by_->errors(), 0);
    const std::vector<double> lat = by_->during(t0, t1);
    // The case's memory goes back: the sessions ended, the server trimmed after them.
    for (int i = 0; i < 500 && d_->events("memory_trimmed").size() == trims; ++i)
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    const double after = d_->settled_rss_mib();
    std::printf(
        "case: %.2f s; bystander %zu frames during it, p50 %.0f ms, p99 %.0f ms; "
        "RSS MiB idle %.0f, peak %.0f (process), after %.0f\n",
        took, lat.size(), 1000 * pct(lat, 50), 1000 * pct(lat, 99), idle, peak, after);
#if !defined(__SANITIZE_ADDRESS__)  // ASan's allocator keeps freed blocks in its quarantine
    EXPECT_LT(after, idle + kReturnMargin) << "memory kept after the case";
#endif
    return out;
  }
  // What may stay resident after a case beyond the idle figure (allocator arenas of the threads
  // that ran it, the heap's fragmentation); measured in bench/server_limits.py.
  static constexpr double kReturnMargin = 48;

  fs::path lib_;
  std::unique_ptr<Vismapd> d_;
  std::unique_ptr<Bystander> by_;
  std::string url_;
};

std::string sphere_sexp() {
  return "(- (+ (square x) (square y) (square z)) 1)";
}

}  // namespace

// Issue 35, case 1: a sphere under 10^5 nested (+ ... 0) (a 4 MB upload) grew the load thread past
// 14 GB. Here 2 x 10^4 under max_session_bytes 64 MiB: the bounds search is charged to the
// session and refused (in 0.7 s; under ASan it may pass the 3 s limit first: time_limit).
TEST_F(HeavyCase, DeepSexpUploadIsChargedToItsSession) {
  std::string deep;
  for (int i = 0; i < 20000; ++i) deep += "(+ ";
  deep += sphere_sexp();
  for (int i = 0; i < 20000; ++i) deep += " 0)";
  auto a = run({{"deep.sexp", deep}}, {"ball.sexp", sphere_sexp()});
  const bool charged =
      a[0].load == "too_large" &&
      a[0].message.find("deep.sexp: the bounds search would hold more than") != std::string::npos;
  const bool timed =
      a[0].load == "time_limit" && a[0].message.find(
                                       "deep.sexp: the load passed its time limit of 3 s (in "
                                       "the bounds search)") != std::string::npos;
  EXPECT_TRUE(charged || timed) << a[0].load << ": " << a[0].message;
}

// Issue 35, case 3: three sessions asked for a dense implicit (the architecture model at
// implicit_tolerance 0.7) and got answers after 108 and 180 s against a 30 s limit while a
// bystander waited 108 s. Here a box of 20^3 sine cells at 0.7 px and 512^2 from three sessions:
// each answer is a frame, time_limit or too_large within the limits.
TEST_F(HeavyCase, DenseImplicitFromThreeSessionsKeepsTheLimits) {
  // With its bounds given: no bounds search, whose time under a sanitizer would be the load's.
  const std::string dense =
      R"j({"meshes": [{"expression": "(* (sin (* 15 x)) (sin (* 15 y)) (sin (* 15 z)))", )j"
      R"j("bounds": [-2, -2, -2, 2, 2, 2]}]})j";
  Heavy h{"dense.json", dense};
  h.hello = {{"implicit_tolerance", 0.7}, {"viewport", {{"width", 512}, {"height", 512}}}};
  auto a = run({h, h, h}, {"ball.sexp", sphere_sexp()});
  for (const Answer& x : a) {
    EXPECT_EQ(x.load, "scene_ready") << x.message;
    EXPECT_TRUE(x.frame == "time_limit" || x.frame == "too_large" || x.frame == "frame")
        << x.frame << ": " << x.message;
  }
}

// Issue 35, case 4: 100,000 crumpled patches ran 157 s and peaked at 9.2 GB against limits of
// 10 s and 2 GiB. Here 4,000 under render_memory_bytes 256 MiB: refused from the dice's count;
// the message names the upload (it said '<input>').
TEST_F(HeavyCase, CrumpledPatchesAreRefusedFromTheCount) {
  std::mt19937 rng(35);
  std::uniform_real_distribution<float> u(-1, 1);
  std::string bpt = "4000\n";
  for (int p = 0; p < 4000; ++p) {
    bpt += "3 3\n";
    for (int k = 0; k < 16; ++k)
      bpt += std::to_string(u(rng)) + " " + std::to_string(u(rng)) + " " + std::to_string(u(rng)) +
             "\n";
  }
  Heavy h{"crumpled.bpt", bpt};
  h.hello = {{"viewport", {{"width", 1024}, {"height", 1024}}}};
  std::string one = "1\n3 3\n";
  for (int k = 0; k < 16; ++k)
    one += std::to_string(k % 4) + " " + std::to_string(k / 4) + " " +
           std::to_string((k % 3) * 0.2) + "\n";
  auto a = run({h}, {"one.bpt", one});
  EXPECT_EQ(a[0].load, "scene_ready") << a[0].message;
  EXPECT_EQ(a[0].frame, "too_large") << a[0].message;
  EXPECT_NE(a[0].message.find("crumpled.bpt: mesh 'crumpled'"), std::string::npos) << a[0].message;
  EXPECT_NE(a[0].message.find("over the memory budget"), std::string::npos) << a[0].message;
}

// Issue 35, case 6: six sessions' Loop plans (5 MB control meshes at tolerance 0.001) took the
// server from 2.6 to 8.6 GB, kept after they closed. Here three sessions, each its own
// 1,280-face control mesh at 0.001: each plan is charged to its session (64 MiB) and refused.
TEST_F(HeavyCase, LoopPlansAreChargedToTheirSessions) {
  std::vector<Heavy> h;
  for (unsigned i = 0; i < 3; ++i) {
    const std::string obj = icosphere_obj(3, 0.02, i);
    std::string pts, idx;
    for (size_t p = 0, q = 0; (q = obj.find('\n', p)) != std::string::npos; p = q + 1) {
      const std::string line = obj.substr(p + 2, q - p - 2);
      std::string& to = obj[p] == 'v' ? pts : idx;
      if (obj[p] == 'f') {  // 1-based to 0-based
        std::istringstream in(line);
        for (int k = 0, x = 0; k < 3 && in >> x; ++k) to += std::to_string(x - 1) + " ";
      } else {
        to += line + " ";
      }
    }
    h.push_back({"loop" + std::to_string(i) + ".pbrt",
                 "WorldBegin\nShape \"loopsubdiv\" \"point P\" [" + pts +
                     "] \"integer indices\" [" + idx + "]\nWorldEnd\n"});
    h.back().hello = {{"tolerance", 0.001}, {"viewport", {{"width", 1024}, {"height", 1024}}}};
  }
  Heavy warm{
      "octa.pbrt",
      "WorldBegin\nShape \"loopsubdiv\" \"point P\" [1 0 0 -1 0 0 0 1 0 0 -1 0 0 0 1 0 0 "
      "-1] \"integer indices\" [0 2 4 2 1 4 1 3 4 3 0 4 2 0 5 1 2 5 3 1 5 0 3 5]\nWorldEnd\n"};
  auto a = run(h, warm);
  for (const Answer& x : a) {
    EXPECT_EQ(x.load, "scene_ready") << x.message;
    EXPECT_EQ(x.frame, "too_large") << x.message;
    EXPECT_NE(x.message.find("faces would take the plan past"), std::string::npos) << x.message;
  }
}

// Issue 35, case 7: a scene file naming the bunny 10,000 times reached bad_alloc at 7.6 GB after
// 48 s. Here a 3,200-triangle grid named 10,000 times: refused from entries x triangles.
TEST_F(HeavyCase, InstancesAreCountedBeforeCopying) {
  write("grid.obj", grid_obj(40));
  std::string j = R"({"meshes": [)";
  for (int i = 0; i < 10000; ++i)
    j += std::string(i ? "," : "") + R"({"file": "grid.obj", "translate": [)" +
         std::to_string(i % 100) + ", " + std::to_string(i / 100) + ", 0]}";
  write("many.json", j + "]}");
  Heavy h;
  h.library = "many.json";
  Heavy warm;
  warm.library = "bystander.obj";
  auto a = run({h}, warm);
  EXPECT_EQ(a[0].load, "too_large") << a[0].message;
  EXPECT_NE(a[0].message.find("10000 entries name grid.obj"), std::string::npos) << a[0].message;
}
