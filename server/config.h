// vismapd configuration: defaults, overridden by a JSON file (--config), overridden by flags.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace vismap {
struct RenderOptions;
}

namespace vismap::server {

struct Limits {
  uint64_t max_message_bytes = 0;          // one WebSocket message; 0: derived from max_scene_bytes
  uint64_t max_control_bytes = 64 << 10;   // one JSON control message
  uint64_t max_scene_bytes = 64ull << 20;  // one uploaded scene file
  uint64_t max_triangles = 5'000'000;      // per scene
  uint64_t max_session_bytes = 512ull << 20;  // upload + loaded scene, per session
  uint64_t render_memory_bytes = 2ull << 30;  // device memory per frame (RenderOptions::
                                              // memory_budget)
  uint32_t max_sessions = 64;
  uint32_t max_connections = 256;             // TCP connections, upgraded or not
  uint32_t max_connections_per_address = 64;  // of those, from one peer address; 0: no cap
  uint32_t max_viewport = 8192;               // width and height
  double handshake_timeout_s = 5;   // TCP accept -> WebSocket upgrade, and upgrade -> hello
  double idle_timeout_s = 60;       // no message from the client for this long
  double render_time_limit_s = 30;  // one frame (RenderOptions::time_limit_s); 0: none

  // What Beast enforces per message: a base64 scene in JSON must fit.
  uint64_t message_max() const {
    if (max_message_bytes) return max_message_bytes;
    uint64_t b64 = max_scene_bytes / 3 * 4 + 4096;
    return b64 < (1u << 20) ? (1u << 20) : b64;
  }
};

struct Config {
  std::string address = "127.0.0.1";
  uint16_t port = 8080;
  std::string library;     // folder of scenes clients may name; empty: none
  std::string www;         // folder served at /; empty: the built-in default
  std::string token;       // non-empty: hello must carry it
  std::string device;      // Renderer device string ("" = default)
  uint32_t renderers = 1;  // Renderer instances (worker threads) sharing the device
  uint32_t io_threads = 2;
  uint32_t load_threads = 2;       // scene parsing off the network threads
  uint32_t encode_threads = 2;     // SVG / bin encoding, off the render workers
  double drain_timeout_s = 10;     // graceful stop: longest wait for frames in flight
  // WebSocket permessage-deflate (RFC 7692), offered to clients that ask; Beast's deflate with
  // these settings compresses every message of a session that negotiated it (docs/SERVER.md has
  // the measured cost and gain per format behind the default).
  bool permessage_deflate = true;
  int deflate_level = 1;           // 1 (fastest) ... 9
  int deflate_window_bits = 15;    // 9 ... 15: the server's LZ77 window, 2^bits bytes
  int deflate_mem_level = 8;       // 1 ... 9: the deflater's hash memory, 2^(bits+9) bytes
  // Compact and delta frames' entropy coder level (their own zstd or deflate, not the WebSocket's):
  // 0 the coder's default (zstd 3, deflate 6), else zstd 1 ... 19 (deflate sessions: at most 9).
  // Higher: fewer bytes, more encode time (docs/SERVER.md, docs/STREAMING.md).
  int frame_level = 0;
  std::string log_level = "info";  // info | warn | off
  Limits limits;

  // Test seam, not a config key: called on the render worker just before Renderer::render with
  // the frame's options (a test stands in a long frame, or a pipeline error, with it).
  std::function<void(const RenderOptions&)> before_render;
};

// Applies a JSON object (same keys as Config/Limits, e.g.
// {"port":9000,"limits":{"max_sessions":8}}) to cfg. Unknown keys are an error: a typo must not
// silently keep a default; so is a value of the wrong type or out of its key's range (an
// integer key takes a JSON integer, not 2.5 or -1), with a message naming the key
// (docs/SERVER.md lists every key's range).
void apply_json(Config& cfg, const std::string& json_text, const std::string& origin);

// Parses argv into cfg (after --config is applied). Returns false and sets `usage` on --help.
// Throws std::runtime_error with a one-line message on a bad flag.
bool parse_args(Config& cfg, int argc, char** argv, std::string& usage);

// Throws std::runtime_error naming the first key whose value is out of its range (the ranges
// apply_json checks). Server's constructor calls it, so a Config built in code is checked too.
void validate(const Config& cfg, const std::string& origin);

std::string read_file(const std::string& path);

}  // namespace vismap::server
