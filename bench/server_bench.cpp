// server_bench: sessions x throughput x latency x bytes for vismapd on loopback.
// Starts vismapd in process (or uses --url), then for each session count S runs S concurrent
// clients that each upload the scene and orbit the camera for --frames frames in lock step
// (send camera, wait for the frame). Prints a markdown table and one JSON line per row.
//
//   server_bench --scene data/bunny.ply --sessions 1,8,50 --frames 30 --format bin
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <nlohmann/json.hpp>
#include <sstream>
#include <thread>
#include <vector>

#include "clients/wsclient.h"
#include "server/server.h"

using nlohmann::json;
using Clock = std::chrono::steady_clock;

static double pct(std::vector<double> v, double p) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<size_t>(std::ceil(p / 100 * v.size())) - 1)];
}

int main(int argc, char** argv) {
  std::string scene, url, format = "bin", device;
  std::vector<int> counts{1, 8, 50};
  int frames = 20, size = 512;
  for (int i = 1; i + 1 < argc; i += 2) {
    std::string a = argv[i], v = argv[i + 1];
    if (a == "--scene")
      scene = v;
    else if (a == "--url")
      url = v;
    else if (a == "--format")
      format = v;
    else if (a == "--frames")
      frames = std::stoi(v);
    else if (a == "--size")
      size = std::stoi(v);
    else if (a == "--device")
      device = v;
    else if (a == "--sessions") {
      counts.clear();
      std::stringstream ss(v);
      for (std::string t; std::getline(ss, t, ',');) counts.push_back(std::stoi(t));
    } else {
      std::fprintf(stderr, "unknown flag %s\n", a.c_str());
      return 2;
    }
  }
  if (scene.empty()) {
    std::fprintf(stderr,
                 "usage: server_bench --scene FILE [--sessions 1,8,50] [--frames N]\n"
                 "                    [--format svg|bin|compact] [--size PIXELS] [--url ws://...]\n"
                 "                    [--device DEV]\n");
    return 2;
  }
  std::ifstream f(scene, std::ios::binary);
  std::stringstream buf;
  buf << f.rdbuf();
  const std::string bytes = buf.str();
  const std::string name = std::filesystem::path(scene).filename().string();

  std::unique_ptr<vismap::server::Server> server;
  if (url.empty()) {
    vismap::server::Config cfg;
    cfg.port = 0;
    cfg.log_level = "warn";
    cfg.device = device;
    cfg.limits.max_sessions = 1000;
    server = std::make_unique<vismap::server::Server>(cfg);
    url = "ws://127.0.0.1:" + std::to_string(server->start()) + "/";
  }
  std::printf("scene %s (%zu bytes), %dx%d, format %s, %d frames per session, lock step\n\n",
              name.c_str(), bytes.size(), size, size, format.c_str(), frames);
  std::printf(
      "| sessions | frames/s (all) | frames/s per session | latency p50 ms | latency p99 ms | "
      "bytes/frame | render ms mean |\n");
  std::printf("|---:|---:|---:|---:|---:|---:|---:|\n");
  std::vector<json> rows;
  for (int S : counts) {
    std::mutex mu;
    std::vector<double> lat;
    double render_sum = 0;
    uint64_t byte_sum = 0, nframes = 0;
    std::atomic<int> failures{0}, ready{0};
    std::atomic<bool> go{false};
    std::vector<std::thread> threads;
    for (int s = 0; s < S; ++s)
      threads.emplace_back([&, s] {
        try {
          vismap::client::WsClient c;
          c.connect(url, 30);
          c.send_text(json{{"type", "hello"},
                           {"version", format == "compact" ? 2 : 1},
                           {"format", format},
                           {"viewport", {{"width", size}, {"height", size}}}}
                          .dump());
          c.read(60);
          c.send_text(json{{"type", "scene"}, {"name", name}, {"size", bytes.size()}}.dump());
          c.send_binary(bytes, 120);
          json r = json::parse(c.read(300).data);
          if (r["type"] != "scene_ready") throw std::runtime_error(r.dump());
          std::array<double, 3> eye = r["camera"]["eye"], t = r["camera"]["target"];
          double dx = eye[0] - t[0], dz = eye[2] - t[2];
          ++ready;
          while (!go) std::this_thread::sleep_for(std::chrono::milliseconds(1));
          std::vector<double> my;
          double my_render = 0;
          uint64_t my_bytes = 0;
          for (int i = 0; i < frames; ++i) {
            double a = 2 * M_PI * (i + 0.37 * s) / frames;
            std::array<double, 3> e{t[0] + dx * std::cos(a) + dz * std::sin(a), eye[1],
                                    t[2] - dx * std::sin(a) + dz * std::cos(a)};
            auto t0 = Clock::now();
            c.send_text(json{{"type", "camera"}, {"seq", i}, {"eye", e}}.dump());
            json h = json::parse(c.read(300).data);
            if (h["type"] != "frame") throw std::runtime_error(h.dump());
            auto p = c.read(300);
            my.push_back(std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
            my_bytes += p.data.size();
            my_render += h["render_ms"].get<double>();
          }
          c.close();
          std::lock_guard lk(mu);
          lat.insert(lat.end(), my.begin(), my.end());
          render_sum += my_render;
          byte_sum += my_bytes;
          nframes += frames;
        } catch (const std::exception& e) {
          std::fprintf(stderr, "session %d: %s\n", s, e.what());
          ++failures;
          ++ready;
        }
      });
    while (ready < S) std::this_thread::sleep_for(std::chrono::milliseconds(5));
    auto t0 = Clock::now();
    go = true;
    for (auto& t : threads) t.join();
    double secs = std::chrono::duration<double>(Clock::now() - t0).count();
    double fps = nframes / secs;
    json row = {{"sessions", S},
                {"frames", nframes},
                {"fps", fps},
                {"fps_per_session", fps / S},
                {"latency_p50_ms", pct(lat, 50)},
                {"latency_p99_ms", pct(lat, 99)},
                {"bytes_per_frame", nframes ? byte_sum / nframes : 0},
                {"render_ms_mean", nframes ? render_sum / nframes : 0},
                {"failures", failures.load()}};
    std::printf("| %d | %.1f | %.2f | %.1f | %.1f | %llu | %.1f |\n", S, fps, fps / S, pct(lat, 50),
                pct(lat, 99), static_cast<unsigned long long>(nframes ? byte_sum / nframes : 0),
                nframes ? render_sum / nframes : 0);
    std::fflush(stdout);
    rows.push_back(row);
  }
  std::printf("\n");
  for (auto& r : rows) std::printf("%s\n", r.dump().c_str());
  return 0;
}
