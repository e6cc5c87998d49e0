#include "server/config.h"

#include <cctype>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <stdexcept>

namespace vismap::server {

using nlohmann::json;

std::string read_file(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) throw std::runtime_error(path + ": cannot open");
  std::ostringstream s;
  s << f.rdbuf();
  return s.str();
}

static std::string trim(std::string s) {
  auto space = [](char c) { return std::isspace(static_cast<unsigned char>(c)) != 0; };
  while (!s.empty() && space(s.back())) s.pop_back();
  size_t i = 0;
  while (i < s.size() && space(s[i])) ++i;
  return s.substr(i);
}

// The token a client must send, from a file. An empty or all-whitespace file is an error in
// every path (flag and config key): it once started the server with auth off (issue 15, bug 6).
static std::string read_token(const std::string& path) {
  std::string token = trim(read_file(path));
  if (token.empty())
    throw std::runtime_error(path + ": token file is empty; refusing to start without auth");
  return token;
}

template <class T>
static void get(const json& j, const char* key, T& out, const std::string& origin) {
  try {
    out = j.at(key).get<T>();
  } catch (const json::exception& e) {
    throw std::runtime_error(origin + ": key '" + key + "': " + e.what());
  }
}

// Beast's zlib refuses a window of 8 bits (a zlib bug it works around), hence 9 ... 15.
static void check_deflate(const Config& cfg, const std::string& origin) {
  if (cfg.deflate_level < 1 || cfg.deflate_level > 9)
    throw std::runtime_error(origin + ": deflate_level must be 1 ... 9");
  if (cfg.deflate_window_bits < 9 || cfg.deflate_window_bits > 15)
    throw std::runtime_error(origin + ": deflate_window_bits must be 9 ... 15");
  if (cfg.deflate_mem_level < 1 || cfg.deflate_mem_level > 9)
    throw std::runtime_error(origin + ": deflate_mem_level must be 1 ... 9");
}

void apply_json(Config& cfg, const std::string& text, const std::string& origin) {
  json j = json::parse(text, nullptr, false);
  if (j.is_discarded() || !j.is_object()) throw std::runtime_error(origin + ": not a JSON object");
  for (auto& [k, v] : j.items()) {
    if (k == "address")
      get(j, "address", cfg.address, origin);
    else if (k == "port")
      get(j, "port", cfg.port, origin);
    else if (k == "library")
      get(j, "library", cfg.library, origin);
    else if (k == "www")
      get(j, "www", cfg.www, origin);
    else if (k == "token_file") {
      std::string path;
      get(j, "token_file", path, origin);
      cfg.token = read_token(path);
    } else if (k == "device")
      get(j, "device", cfg.device, origin);
    else if (k == "renderers")
      get(j, "renderers", cfg.renderers, origin);
    else if (k == "io_threads")
      get(j, "io_threads", cfg.io_threads, origin);
    else if (k == "load_threads")
      get(j, "load_threads", cfg.load_threads, origin);
    else if (k == "encode_threads")
      get(j, "encode_threads", cfg.encode_threads, origin);
    else if (k == "drain_timeout_s")
      get(j, "drain_timeout_s", cfg.drain_timeout_s, origin);
    else if (k == "log_level")
      get(j, "log_level", cfg.log_level, origin);
    else if (k == "permessage_deflate")
      get(j, "permessage_deflate", cfg.permessage_deflate, origin);
    else if (k == "deflate_level")
      get(j, "deflate_level", cfg.deflate_level, origin);
    else if (k == "deflate_window_bits")
      get(j, "deflate_window_bits", cfg.deflate_window_bits, origin);
    else if (k == "deflate_mem_level")
      get(j, "deflate_mem_level", cfg.deflate_mem_level, origin);
    else if (k == "frame_level")
      get(j, "frame_level", cfg.frame_level, origin);
    else if (k == "limits") {
      if (!v.is_object()) throw std::runtime_error(origin + ": 'limits' is not an object");
      Limits& l = cfg.limits;
      for (auto& [lk, lv] : v.items()) {
        const char* key = lk.c_str();
        if (lk == "max_message_bytes")
          get(v, key, l.max_message_bytes, origin);
        else if (lk == "max_control_bytes")
          get(v, key, l.max_control_bytes, origin);
        else if (lk == "max_scene_bytes")
          get(v, key, l.max_scene_bytes, origin);
        else if (lk == "max_triangles")
          get(v, key, l.max_triangles, origin);
        else if (lk == "max_session_bytes")
          get(v, key, l.max_session_bytes, origin);
        else if (lk == "render_memory_bytes")
          get(v, key, l.render_memory_bytes, origin);
        else if (lk == "max_sessions")
          get(v, key, l.max_sessions, origin);
        else if (lk == "max_connections")
          get(v, key, l.max_connections, origin);
        else if (lk == "max_connections_per_address")
          get(v, key, l.max_connections_per_address, origin);
        else if (lk == "max_viewport")
          get(v, key, l.max_viewport, origin);
        else if (lk == "handshake_timeout_s")
          get(v, key, l.handshake_timeout_s, origin);
        else if (lk == "idle_timeout_s")
          get(v, key, l.idle_timeout_s, origin);
        else if (lk == "render_time_limit_s")
          get(v, key, l.render_time_limit_s, origin);
        else
          throw std::runtime_error(origin + ": unknown key 'limits." + lk + "'");
      }
    } else {
      throw std::runtime_error(origin + ": unknown key '" + k + "'");
    }
  }
  if (cfg.renderers == 0 || cfg.io_threads == 0 || cfg.load_threads == 0 || cfg.encode_threads == 0)
    throw std::runtime_error(
        origin + ": renderers, io_threads, load_threads and encode_threads must be >= 1");
  check_deflate(cfg, origin);
  if (cfg.frame_level < 0 || cfg.frame_level > 19)
    throw std::runtime_error(origin + ": frame_level must be 0 (the coder's default) ... 19");
  if (cfg.limits.render_time_limit_s < 0)
    throw std::runtime_error(origin + ": limits.render_time_limit_s must be >= 0");
}

static const char* kUsage =
    "usage: vismapd --port PORT [--address ADDR] [--config FILE] [--library DIR] [--www DIR]\n"
    "               [--token-file FILE] [--device DEV] [--renderers N] [--max-sessions N]\n"
    "               [--log-level info|warn|off] [--permessage-deflate on|off]\n"
    "Serves WebSocket sessions, /health and /metrics on one port (proto/PROTOCOL.md).\n"
    "Flags override the JSON config file; see docs/SERVER.md for every key.\n";

bool parse_args(Config& cfg, int argc, char** argv, std::string& usage) {
  // --config first, so flags override the file whatever their order.
  for (int i = 1; i + 1 < argc; ++i)
    if (std::string(argv[i]) == "--config") apply_json(cfg, read_file(argv[i + 1]), argv[i + 1]);
  for (int i = 1; i < argc; ++i) {
    std::string a = argv[i];
    if (a == "--help" || a == "-h") {
      usage = kUsage;
      return false;
    }
    if (i + 1 >= argc) throw std::runtime_error("flag " + a + " needs a value");
    std::string v = argv[++i];
    auto num = [&](uint64_t hi) -> uint64_t {
      size_t used = 0;
      unsigned long long n = 0;
      try {
        n = std::stoull(v, &used);
      } catch (...) {
        used = 0;
      }
      if (used != v.size() || n > hi)
        throw std::runtime_error("flag " + a + ": bad number '" + v + "'");
      return n;
    };
    if (a == "--config")
      continue;
    else if (a == "--port")
      cfg.port = static_cast<uint16_t>(num(65535));
    else if (a == "--address")
      cfg.address = v;
    else if (a == "--library")
      cfg.library = v;
    else if (a == "--www")
      cfg.www = v;
    else if (a == "--token-file")
      cfg.token = read_token(v);
    else if (a == "--device")
      cfg.device = v;
    else if (a == "--renderers")
      cfg.renderers = static_cast<uint32_t>(std::max<uint64_t>(1, num(64)));
    else if (a == "--max-sessions")
      cfg.limits.max_sessions = static_cast<uint32_t>(num(100000));
    else if (a == "--log-level")
      cfg.log_level = v;
    else if (a == "--permessage-deflate") {
      if (v != "on" && v != "off")
        throw std::runtime_error("flag --permessage-deflate: expected on or off, got '" + v + "'");
      cfg.permessage_deflate = v == "on";
    } else
      throw std::runtime_error("unknown flag " + a + " (see --help)");
  }
  return true;
}

}  // namespace vismap::server
