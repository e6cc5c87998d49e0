// vismap-client: connects to vismapd, uploads a scene, orbits the camera for N frames, decodes
// bin, compact and delta frames, saves the frames and reports fps, latency, bytes and triangles.
// Its last stdout line is one JSON object. Speaks protocol version 1, and 2 for compact and delta
// frames. --cameras FILE replaces the orbit with given cameras (bench/stream/clients.py gives all
// three clients the same ones).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <thread>
#include <vector>

#include "clients/wsclient.h"
#include "core/stream/compact.h"
#include "core/stream/delta.h"
#include "core/write/output.h"

using nlohmann::json;
using namespace vismap::client;

static const char* kUsage =
    "usage: vismap-client --url ws://HOST:PORT/ (--scene FILE | --library NAME) --frames N\n"
    "                     [--format svg|bin|compact|delta] [--out DIR] [--width W] [--height H]\n"
    "                     [--attributes] [--fill shade|id] [--quantum Q]\n"
    "                     [--compression zstd|deflate] [--permessage-deflate]\n"
    "                     [--token-file FILE] [--timeout S] [--retries N] [--cameras FILE]\n"
    "                     [--hold-scene]\n"
    "  compact, delta (and --quantum, --compression) negotiate protocol version 2; bin,\n"
    "  compact and delta frames are decoded (read_bin, read_compact, DeltaDecoder: a delta\n"
    "  frame that does not apply asks the server for a keyframe) and their triangles counted.\n"
    "  --hold-scene (delta): protocol version 3, DELTA.md version 2; the client holds the scene\n"
    "  (the sources message after scene_ready) and frames are never larger than compact.\n"
    "  --cameras FILE: a JSON array of camera messages' fields (eye, target, up, fov_y_deg, ...),\n"
    "  one frame each, instead of the orbit (--frames is then the array's length).\n"
    "       vismap-client --health http://HOST:PORT/health   (exit 0 when the server answers 200 "
    "ok;\n"
    "                                                         a container HEALTHCHECK without "
    "curl)\n";

// A decoded frame's fingerprint, the same in the Python and JS clients (bench/stream/clients.py
// compares them frame by frame): per array (xy, indices, source, shade, each value as uint32),
// "length:h" with h = sum of value_i * (2i + 1) mod 2^32, joined by '/'.
template <class Frame>
static std::string digest(const Frame& f) {
  std::string out;
  auto one = [&](const auto& v) {
    uint32_t h = 0;
    for (size_t i = 0; i < v.size(); ++i) h += uint32_t(v[i]) * uint32_t(2 * i + 1);
    char b[40];
    std::snprintf(b, sizeof b, "%s%zu:%08x", out.empty() ? "" : "/", v.size(), h);
    out += b;
  };
  one(f.xy);
  one(f.indices);
  one(f.source);
  one(f.shade);
  return out;
}

// GET /health: 0 when the server answers 200 with status ok, 1 otherwise (stopping, refused,
// timeout).
static int health(const std::string& url_text, double timeout) {
  try {
    Url u = parse_url(url_text);
    HttpResponse r = http_get(u.host, u.port, u.target.empty() ? "/health" : u.target, timeout);
    while (!r.body.empty() && r.body.back() == '\n') r.body.pop_back();
    std::printf("%d %s\n", r.status, r.body.c_str());
    return r.status == 200 && json::parse(r.body, nullptr, false).value("status", "") == "ok" ? 0
                                                                                              : 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "vismap-client: health: %s\n", e.what());
    return 1;
  }
}

// Connects with exponential backoff (0.1 s doubling to 2 s): a server that restarts, or a load
// balancer whose backend just went away, gets `retries` more tries.
static void connect_with_retry(WsClient& c, const std::string& url, int retries, bool deflate) {
  double delay = 0.1;
  for (int attempt = 0;; ++attempt) {
    try {
      c.connect(url, 10, deflate);
      return;
    } catch (const std::exception& e) {
      if (attempt >= retries) throw;
      std::fprintf(stderr, "vismap-client: %s; retrying in %.1f s\n", e.what(), delay);
      std::this_thread::sleep_for(std::chrono::duration<double>(delay));
      delay = std::min(2 * delay, 2.0);
    }
  }
}

static std::string slurp(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) throw std::runtime_error(path + ": cannot open");
  std::ostringstream s;
  s << f.rdbuf();
  return s.str();
}

// Reads the next JSON control message; an error message becomes an exception.
static json next_json(WsClient& c, double timeout) {
  for (;;) {
    Message m = c.read(timeout);
    if (m.binary) throw std::runtime_error("unexpected binary message");
    json j = json::parse(m.data);
    if (j.value("type", "") == "error")
      throw std::runtime_error("server error " + j.value("code", "") + ": " +
                               j.value("message", ""));
    return j;
  }
}

static double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  size_t i = static_cast<size_t>(std::ceil(p / 100.0 * v.size())) - 1;
  return v[std::min(i, v.size() - 1)];
}

int main(int argc, char** argv) {
  std::string url, scene, library, format = "svg", out, token_file, health_url, fill, compression,
      cameras_file;
  int frames = 36, retries = 0;
  uint32_t width = 1024, height = 1024, quantum = 0;
  bool attributes = false, deflate = false, hold_scene = false;
  double timeout = 60;
  json cameras;  // --cameras: one camera message's fields per frame
  try {
    for (int i = 1; i < argc; ++i) {
      std::string a = argv[i];
      auto val = [&]() -> std::string {
        if (i + 1 >= argc) throw std::runtime_error(a + " needs a value");
        return argv[++i];
      };
      if (a == "--url")
        url = val();
      else if (a == "--scene")
        scene = val();
      else if (a == "--library")
        library = val();
      else if (a == "--frames")
        frames = std::stoi(val());
      else if (a == "--format")
        format = val();
      else if (a == "--out")
        out = val();
      else if (a == "--width")
        width = static_cast<uint32_t>(std::stoul(val()));
      else if (a == "--height")
        height = static_cast<uint32_t>(std::stoul(val()));
      else if (a == "--token-file")
        token_file = val();
      else if (a == "--timeout")
        timeout = std::stod(val());
      else if (a == "--retries")
        retries = std::stoi(val());
      else if (a == "--health")
        health_url = val();
      else if (a == "--attributes")
        attributes = true;
      else if (a == "--fill")
        fill = val();
      else if (a == "--quantum") {
        // The server's range, checked here too (one constant: kMaxQuantum).
        const std::string v = val();
        size_t used = 0;
        unsigned long q = 0;
        try {
          q = std::stoul(v, &used);
        } catch (...) {
          used = 0;
        }
        if (used == 0 || used != v.size() || q < vismap::kMinQuantum || q > vismap::kMaxQuantum)
          throw std::runtime_error("--quantum: expected an integer in " +
                                   vismap::quantum_range_text() + ", got '" + v + "'");
        quantum = static_cast<uint32_t>(q);
      } else if (a == "--compression")
        compression = val();
      else if (a == "--cameras")
        cameras_file = val();
      else if (a == "--permessage-deflate")
        deflate = true;
      else if (a == "--hold-scene")
        hold_scene = true;
      else if (a == "--help" || a == "-h") {
        std::fputs(kUsage, stdout);
        return 0;
      } else
        throw std::runtime_error("unknown flag " + a);
    }
    if (!health_url.empty()) return health(health_url, std::min(timeout, 10.0));
    if (!cameras_file.empty()) {
      json list = json::parse(slurp(cameras_file));
      if (!list.is_array() || list.empty())
        throw std::runtime_error(cameras_file + ": not a non-empty JSON array of cameras");
      cameras = std::move(list);
      frames = static_cast<int>(cameras.size());
    }
    if (url.empty() || (scene.empty() == library.empty()) || frames < 1 ||
        (format != "svg" && format != "bin" && format != "compact" && format != "delta") ||
        (!fill.empty() && fill != "shade" && fill != "id") ||
        (!compression.empty() && compression != "zstd" && compression != "deflate"))
      throw std::runtime_error("bad arguments");
  } catch (const std::exception& e) {
    std::fprintf(stderr, "vismap-client: %s\n%s", e.what(), kUsage);
    return 2;
  }

  try {
    WsClient c;
    connect_with_retry(c, url, retries, deflate);
    // Version 2 only where it is needed, so svg and bin keep working with a version 1 server.
    bool v2 = format == "compact" || format == "delta" || quantum || !compression.empty();
    json hello = {{"type", "hello"},
                  {"version", hold_scene ? 3 : v2 ? 2 : 1},
                  {"format", format},
                  {"attributes", attributes},
                  {"viewport", {{"width", width}, {"height", height}}}};
    if (!fill.empty()) hello["fill"] = fill;
    if (quantum) hello["quantum"] = quantum;
    if (!compression.empty()) hello["compression"] = compression;
    if (hold_scene) hello["hold_scene"] = true;
    if (!token_file.empty()) {
      std::string t = slurp(token_file);
      while (!t.empty() && (t.back() == '\n' || t.back() == '\r')) t.pop_back();
      hello["token"] = t;
    }
    c.send_text(hello.dump());
    json welcome = next_json(c, timeout);
    if (welcome.value("type", "") != "welcome") throw std::runtime_error("expected welcome");

    auto t_up = std::chrono::steady_clock::now();
    if (!library.empty()) {
      c.send_text(json{{"type", "scene"}, {"library", library}}.dump());
    } else {
      std::string bytes = slurp(scene);
      std::string name = std::filesystem::path(scene).filename().string();
      c.send_text(json{{"type", "scene"}, {"name", name}, {"size", bytes.size()}}.dump());
      c.send_binary(bytes, timeout);
    }
    json ready = next_json(c, timeout);
    if (ready.value("type", "") != "scene_ready") throw std::runtime_error("expected scene_ready");
    double upload_ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t_up).count();
    std::printf("scene: %s, %llu triangles, uploaded and loaded in %.1f ms\n",
                ready.value("name", "").c_str(),
                static_cast<unsigned long long>(ready.value("triangles", 0ull)), upload_ms);
    vismap::DeltaDecoder delta;
    uint64_t sources_bytes = 0;
    if (hold_scene) {  // the scene's sources, once (proto/DELTA.md, "The held scene")
      json sh = next_json(c, timeout);
      if (sh.value("type", "") != "sources") throw std::runtime_error("expected sources");
      Message m = c.read(timeout);
      delta.hold_scene(m.data);
      sources_bytes = m.data.size();
      if (!out.empty()) {
        std::filesystem::create_directories(out);
        std::ofstream(std::filesystem::path(out) / "sources.vmd", std::ios::binary) << m.data;
      }
    }

    // Orbit: rotate the framing camera's eye about the target around its up axis (y here).
    auto cam = ready["camera"];
    std::array<double, 3> eye = cam["eye"], target = cam["target"];
    double dx = eye[0] - target[0], dz = eye[2] - target[2];
    if (!out.empty()) std::filesystem::create_directories(out);
    std::vector<double> latency;
    uint64_t keyframes = 0, resyncs = 0;
    double render_ms_sum = 0, decode_ms_sum = 0;
    uint64_t bytes_sum = 0, triangles_sum = 0;
    json triangles = json::array();  // per frame (bin, compact, delta; null where not decoded)
    json decode_ms = json::array(), frame_bytes = json::array();  // per frame
    json server_ms = json::array(), coding = json::array();       // per frame: render, encode
    json digests = json::array();  // compact, delta: per frame, digest() of the decoded arrays
    const uint64_t wire0 = c.wire_bytes_received();
    auto t0 = std::chrono::steady_clock::now();
    for (int i = 0; i < frames; ++i) {
      double a = 2 * M_PI * i / frames;
      std::array<double, 3> e{target[0] + dx * std::cos(a) + dz * std::sin(a), eye[1],
                              target[2] - dx * std::sin(a) + dz * std::cos(a)};
      auto ts = std::chrono::steady_clock::now();
      json camera = cameras.is_array() ? cameras.at(i) : json{{"eye", e}};
      camera["type"] = "camera";
      camera["seq"] = i;
      c.send_text(camera.dump());
      json header = next_json(c, timeout);
      if (header.value("type", "") != "frame")
        throw std::runtime_error("expected frame, got " + header.dump());
      Message payload = c.read(timeout);
      latency.push_back(
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - ts).count());
      bytes_sum += payload.data.size();
      frame_bytes.push_back(payload.data.size());
      render_ms_sum += header.value("render_ms", 0.0);
      server_ms.push_back({header.value("render_ms", 0.0), header.value("encode_ms", 0.0)});
      if (header.contains("coding")) coding.push_back(header["coding"]);
      auto td = std::chrono::steady_clock::now();
      json count = nullptr;
      if (format == "bin")
        count = vismap::read_bin(payload.data).triangle_count();
      else if (format == "compact") {
        const vismap::CompactFrame f = vismap::read_compact(payload.data);
        count = f.triangle_count();
        digests.push_back(digest(f));
      } else if (format == "delta") {
        try {
          const vismap::DeltaFrame d = delta.decode(payload.data);
          count = d.triangle_count();
          digests.push_back(digest(d));
          keyframes += d.keyframe;
        } catch (const vismap::DeltaOutOfSync&) {  // lost state: the next frame stands alone
          ++resyncs;
          c.send_text(json{{"type", "keyframe"}}.dump());
        }
      }
      const double frame_decode_ms =
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - td).count();
      decode_ms_sum += frame_decode_ms;
      decode_ms.push_back(frame_decode_ms);
      if (count.is_number()) triangles_sum += count.get<uint64_t>();
      triangles.push_back(count);
      if (!out.empty()) {
        char name[64];
        std::snprintf(name, sizeof name, "frame_%04d.%s", i,
                      format == "compact" ? "vmc"
                      : format == "delta" ? "vmd"
                                          : format.c_str());
        std::ofstream(std::filesystem::path(out) / name, std::ios::binary) << payload.data;
      }
    }
    double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const uint64_t wire = c.wire_bytes_received() - wire0;  // frames, headers and cameras' acks
    c.close();
    json r = {{"frames", frames},
              {"fps", frames / secs},
              {"latency_p50_ms", percentile(latency, 50)},
              {"latency_p99_ms", percentile(latency, 99)},
              {"bytes_per_frame", bytes_sum / frames},
              {"render_ms_mean", render_ms_sum / frames},
              {"format", format}};
    // Added with protocol version 2: the run's figures under its format's name, the decoded
    // triangles (bin, compact; svg frames are not parsed: null) and the bytes on the wire.
    json per = {{"frames", frames},
                {"bytes_per_frame", bytes_sum / frames},
                {"wire_bytes_per_frame", wire / frames},
                {"triangles_per_frame", nullptr},
                {"decode_ms_mean", nullptr}};
    if (format != "svg") {
      per["decode_ms_mean"] = decode_ms_sum / frames;
      per["triangles_per_frame"] = triangles_sum / frames;
      r["decoded_triangles"] = triangles_sum;
    }
    r["triangles_per_frame"] = per["triangles_per_frame"];
    r["wire_bytes_per_frame"] = wire / frames;
    r["protocol"] = welcome.value("version", 1);
    r["permessage_deflate"] = c.deflate_negotiated();
    per["bytes"] = frame_bytes;  // per frame
    if (format != "svg") {
      per["triangles"] = triangles;
      per["decode_ms"] = decode_ms;
    }
    per["server_ms"] = server_ms;  // per frame: [render_ms, encode_ms] from the headers
    if (!digests.empty()) per["digests"] = digests;
    if (format == "delta") {
      per["keyframes"] = keyframes;
      per["resyncs"] = resyncs;  // frames that did not apply (then a keyframe was asked for)
      if (!coding.empty()) per["coding"] = coding;  // protocol 3: delta, keyframe or compact
      if (hold_scene) per["sources_bytes"] = sources_bytes;
    }
    r["by_format"] = {{format, per}};
    std::printf(
        "%d frames in %.2f s: %.1f fps, latency p50 %.1f ms p99 %.1f ms, %llu bytes/frame\n",
        frames, secs, frames / secs, r["latency_p50_ms"].get<double>(),
        r["latency_p99_ms"].get<double>(), static_cast<unsigned long long>(bytes_sum / frames));
    std::printf("%s\n", r.dump().c_str());
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "vismap-client: %s\n", e.what());
    return 1;
  }
}
