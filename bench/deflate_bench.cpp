// deflate_bench: what WebSocket permessage-deflate costs and gains per frame format
// (docs/SERVER.md, "permessage-deflate"). Renders one frame of a scene (the bunny at 1920x1080 by
// default) and, for its svg, bin and compact payloads:
//  1. codec: compresses each payload the way Beast's permessage-deflate does (its own zlib port,
//     beast::zlib::deflate_stream, in 4 KiB output pieces, block + full flush, the 4-byte marker
//     dropped) at several levels, and inflates it as a Beast client does; best of --reps runs,
//     single thread: server CPU ms and client CPU ms per frame, and the bytes;
//  2. wire: vismapd in process with permessage-deflate off and on (--level), one session per
//     format; TCP bytes the client received per frame (TCP_INFO) and the time from the frame
//     header to the last payload byte (deflate on the server's network thread, inflate in the
//     client, pipelined).
//
//   deflate_bench [--scene data/bunny.ply] [--width 1920 --height 1080] [--reps 5] [--level 1]
//                 [--frames 2] [--device DEV]
#include <algorithm>
#include <boost/beast/zlib.hpp>
#include <chrono>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "clients/wsclient.h"
#include "core/pipeline.h"
#include "core/scene.h"
#include "core/stream/compact.h"
#include "core/util/clock.h"
#include "core/write/output.h"
#include "server/config.h"
#include "server/server.h"

using nlohmann::json;
using vismap::Clock;
using vismap::ms_since;
namespace zlib = boost::beast::zlib;

// As beast::websocket::detail::impl_base::deflate, for one whole message.
static std::string pmd_deflate(zlib::deflate_stream& zo, const std::string& in) {
  std::string out;
  zlib::z_params zs;
  zs.next_in = in.data();
  zs.avail_in = in.size();
  char buf[4096];
  boost::beast::error_code ec;
  for (;;) {
    zs.next_out = buf;
    zs.avail_out = sizeof buf;
    size_t before = zs.total_out;
    if (zs.avail_in) {
      zo.write(zs, zlib::Flush::none, ec);
      ec = {};
    }
    if (zs.avail_in == 0 && zs.avail_out > 0) {
      zo.write(zs, zlib::Flush::block, ec);
      ec = {};
      if (zs.avail_out >= 6) {
        zo.write(zs, zlib::Flush::full, ec);
        out.append(buf, zs.total_out - before - 4);
        return out;
      }
    }
    out.append(buf, zs.total_out - before);
  }
}

static std::string pmd_inflate(zlib::inflate_stream& zi, std::string in, size_t size) {
  in += std::string("\x00\x00\xff\xff", 4);
  std::string out(size + 64, '\0');
  zlib::z_params zs;
  zs.next_in = in.data();
  zs.avail_in = in.size();
  zs.next_out = out.data();
  zs.avail_out = out.size();
  boost::beast::error_code ec;
  zi.write(zs, zlib::Flush::sync, ec);
  out.resize(zs.total_out);
  return out;
}

int main(int argc, char** argv) {
  std::string scene_path = "data/bunny.ply", device;
  uint32_t width = 1920, height = 1080;
  int reps = 5, level = 1, frames = 2;
  for (int i = 1; i + 1 < argc; i += 2) {
    std::string a = argv[i], v = argv[i + 1];
    if (a == "--scene")
      scene_path = v;
    else if (a == "--width")
      width = std::stoul(v);
    else if (a == "--height")
      height = std::stoul(v);
    else if (a == "--reps")
      reps = std::stoi(v);
    else if (a == "--level")
      level = std::stoi(v);
    else if (a == "--frames")
      frames = std::stoi(v);
    else if (a == "--device")
      device = v;
    else {
      std::fprintf(stderr, "unknown flag %s\n", a.c_str());
      return 2;
    }
  }
  vismap::Scene scene = vismap::load_scene(scene_path);
  vismap::Camera cam = scene.camera ? *scene.camera : vismap::frame_scene(scene, width, height);
  cam.width = width;
  cam.height = height;
  vismap::fit_near_far(cam, scene);
  vismap::Renderer renderer(device);
  auto t0 = Clock::now();
  vismap::PlanarMap map = renderer.render(scene, cam);
  std::printf("scene %s, %ux%u, %zu fragments, render %.0f ms (%s)\n\n", scene_path.c_str(), width,
              height, map.fragment_count(), ms_since(t0), renderer.device().name.c_str());

  struct Payload {
    std::string name, bytes;
    double encode_ms;
  };
  std::vector<Payload> payloads;
  auto encode = [&](const std::string& name, auto f) {
    double best = 1e30;
    std::string b;
    for (int r = 0; r < std::max(1, reps / 2); ++r) {
      auto t = Clock::now();
      b = f();
      best = std::min(best, ms_since(t));
    }
    payloads.push_back({name, std::move(b), best});
  };
  encode("svg", [&] { return vismap::write_svg(map, scene, cam, vismap::Fill::Shade); });
  encode("bin", [&] { return vismap::write_bin(map, scene); });
  vismap::CompactOptions co;
  co.shade = true;
  encode("compact (zstd)", [&] { return vismap::write_compact(map, scene, cam, co); });
  co.compression = vismap::Compression::Deflate;
  encode("compact (deflate)", [&] { return vismap::write_compact(map, scene, cam, co); });

  std::printf(
      "1. codec: Beast's permessage-deflate coder, window 15, best of %d, one thread\n\n"
      "| payload | bytes | encode ms | level | memLevel | deflated bytes | ratio | server deflate "
      "ms | client inflate ms |\n|---|---:|---:|---:|---:|---:|---:|---:|---:|\n",
      reps);
  std::vector<json> rows;
  for (const Payload& p : payloads)
    for (auto [lvl, mem] : {std::pair{1, 8}, {6, 8}, {8, 4}}) {
      double def = 1e30, inf = 1e30;
      std::string z;
      for (int r = 0; r < reps; ++r) {
        zlib::deflate_stream zo;
        zo.reset(lvl, 15, mem, zlib::Strategy::normal);
        auto t = Clock::now();
        z = pmd_deflate(zo, p.bytes);
        def = std::min(def, ms_since(t));
        zlib::inflate_stream zi;
        zi.reset(15);
        t = Clock::now();
        std::string back = pmd_inflate(zi, z, p.bytes.size());
        inf = std::min(inf, ms_since(t));
        if (back != p.bytes) {
          std::fprintf(stderr, "%s: inflate does not give the payload back\n", p.name.c_str());
          return 1;
        }
      }
      std::printf("| %s | %zu | %.1f | %d | %d | %zu | %.2f | %.1f | %.1f |\n", p.name.c_str(),
                  p.bytes.size(), p.encode_ms, lvl, mem, z.size(),
                  double(p.bytes.size()) / z.size(), def, inf);
      rows.push_back({{"payload", p.name},
                      {"bytes", p.bytes.size()},
                      {"encode_ms", p.encode_ms},
                      {"level", lvl},
                      {"mem_level", mem},
                      {"deflated_bytes", z.size()},
                      {"deflate_ms", def},
                      {"inflate_ms", inf}});
    }

  // 2. Over a socket, through vismapd: the library is the scene's folder (no upload).
  std::printf(
      "\n2. wire: vismapd in process, permessage-deflate level %d (window 15, memLevel 8), %d "
      "frames per row, lock step\n\n"
      "| format | permessage-deflate | payload bytes | wire bytes | header to payload ms | process "
      "CPU ms in that time |\n|---|---|---:|---:|---:|---:|\n",
      level, frames);
  namespace fs = std::filesystem;
  fs::path sp = fs::absolute(scene_path);
  for (bool on : {false, true}) {
    vismap::server::Config cfg;
    cfg.port = 0;
    cfg.log_level = "warn";
    cfg.device = device;
    cfg.library = sp.parent_path().string();
    cfg.permessage_deflate = on;
    cfg.deflate_level = level;
    vismap::server::Server server(cfg);
    std::string url = "ws://127.0.0.1:" + std::to_string(server.start()) + "/";
    for (const char* fmt : {"svg", "bin", "compact"}) {
      vismap::client::WsClient c;
      c.connect(url, 30, /*permessage_deflate=*/true);
      c.send_text(json{{"type", "hello"},
                       {"version", 2},
                       {"format", fmt},
                       {"viewport", {{"width", width}, {"height", height}}}}
                      .dump());
      c.read(60);
      c.send_text(json{{"type", "scene"}, {"library", sp.filename().string()}}.dump());
      json r = json::parse(c.read(300).data);
      if (r["type"] != "scene_ready") throw std::runtime_error(r.dump());
      uint64_t payload = 0, wire = 0;
      double transfer = 0, cpu = 0;
      auto cpu_ms = [] {
        timespec ts{};
        clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
        return ts.tv_sec * 1e3 + ts.tv_nsec / 1e6;
      };
      for (int i = 0; i < frames; ++i) {
        uint64_t w0 = c.wire_bytes_received();
        c.send_text(json{{"type", "camera"}, {"seq", i}}.dump());
        json h = json::parse(c.read(300).data);
        if (h["type"] != "frame") throw std::runtime_error(h.dump());
        auto t = Clock::now();
        double c0 = cpu_ms();
        auto p = c.read(300);
        transfer += ms_since(t);
        cpu += cpu_ms() - c0;
        payload += p.data.size();
        wire += c.wire_bytes_received() - w0;
      }
      if (c.deflate_negotiated() != on) throw std::runtime_error("negotiation differs from config");
      c.close();
      std::printf("| %s | %s | %llu | %llu | %.1f | %.1f |\n", fmt, on ? "on" : "off",
                  static_cast<unsigned long long>(payload / frames),
                  static_cast<unsigned long long>(wire / frames), transfer / frames, cpu / frames);
      std::fflush(stdout);
      rows.push_back({{"format", fmt},
                      {"permessage_deflate", on},
                      {"level", level},
                      {"payload_bytes", payload / frames},
                      {"wire_bytes", wire / frames},
                      {"transfer_ms", transfer / frames},
                      {"cpu_ms", cpu / frames}});
    }
    server.stop();
  }
  std::printf("\n");
  for (auto& r : rows) std::printf("%s\n", r.dump().c_str());
  return 0;
}
