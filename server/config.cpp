#include "server/config.h"

#include <cctype>
#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <stdexcept>
#include <type_traits>
#include <utility>
#include <vector>

#include "core/camera.h"  // kMaxViewport

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

// Every setting, with its range, in one table (issue 45, item 7: `renderers: -1` aborted the
// process, and `max_scene_bytes: -5`, `drain_timeout_s: -1`, `frame_level: 2.5`, `max_viewport:
// 65536` were taken). visit_keys calls f(name, field, range) for each key; apply_json reads a
// key through it (a JSON integer in range, before it is narrowed to the field's type), and
// validate checks a whole Config against the same ranges (flags, and Configs built in code).
namespace {

// An integer in lo ... hi (every integer setting is a count, a size, a level or a port: none
// is negative).
struct IntRange {
  uint64_t lo, hi;
  const char* zero = nullptr;  // what 0 means, where lo is 0 (for the message)
};
// Seconds: a finite number in lo ... hi; lo excluded where open_lo.
struct SecRange {
  double lo;
  bool open_lo;
  double hi;
};
// A string; nonempty: "" refused.
struct Text {
  bool nonempty = false;
};
// One of a few words.
struct Choice {
  std::vector<std::string> words;
};
struct Flag {};

// Byte counts: at most 2^53, the largest integer every JSON reader holds exactly (and far from
// overflowing the sums and base64 sizes they enter).
constexpr uint64_t kMaxBytes = uint64_t{1} << 53;
// Render workers sharing one device; network, load and encode threads; open sessions.
constexpr uint64_t kMaxRenderers = 64;
constexpr uint64_t kMaxThreads = 256;
constexpr uint64_t kMaxSessions = 100000;
// Timeouts: at most 10^6 s (11.6 days); a steady_clock deadline cannot overflow.
constexpr double kMaxSeconds = 1e6;

template <class C, class F>
void visit_keys(C& c, F&& f) {
  f("address", c.address, Text{true});
  f("port", c.port, IntRange{0, 65535, "any free port"});
  f("library", c.library, Text{});
  f("www", c.www, Text{});
  f("device", c.device, Text{});
  f("renderers", c.renderers, IntRange{1, kMaxRenderers});
  f("io_threads", c.io_threads, IntRange{1, kMaxThreads});
  f("load_threads", c.load_threads, IntRange{1, kMaxThreads});
  f("encode_threads", c.encode_threads, IntRange{1, kMaxThreads});
  f("drain_timeout_s", c.drain_timeout_s, SecRange{0, false, kMaxSeconds});
  f("log_level", c.log_level, Choice{{"info", "warn", "off"}});
  f("permessage_deflate", c.permessage_deflate, Flag{});
  // Beast's zlib refuses a window of 8 bits (a zlib bug it works around), hence 9 ... 15.
  f("deflate_level", c.deflate_level, IntRange{1, 9});
  f("deflate_window_bits", c.deflate_window_bits, IntRange{9, 15});
  f("deflate_mem_level", c.deflate_mem_level, IntRange{1, 9});
  f("frame_level", c.frame_level, IntRange{0, 19, "the coder's default"});
  auto& l = c.limits;
  f("limits.max_message_bytes", l.max_message_bytes, IntRange{0, kMaxBytes, "derived"});
  f("limits.max_control_bytes", l.max_control_bytes, IntRange{1, kMaxBytes});
  f("limits.max_scene_bytes", l.max_scene_bytes, IntRange{1, kMaxBytes});
  // Triangle ids are 32-bit (core/load/load.cpp).
  f("limits.max_triangles", l.max_triangles, IntRange{1, UINT32_MAX});
  f("limits.max_session_bytes", l.max_session_bytes, IntRange{1, kMaxBytes});
  f("limits.render_memory_bytes", l.render_memory_bytes, IntRange{0, kMaxBytes, "no budget"});
  f("limits.max_sessions", l.max_sessions, IntRange{1, kMaxSessions});
  f("limits.max_connections", l.max_connections, IntRange{1, UINT32_MAX});
  f("limits.max_connections_per_address", l.max_connections_per_address,
    IntRange{0, UINT32_MAX, "no cap"});
  // The kernels' own limit (kMaxViewport = VM_MAX_VIEWPORT, kernels/layout.h).
  f("limits.max_viewport", l.max_viewport, IntRange{1, kMaxViewport});
  f("limits.handshake_timeout_s", l.handshake_timeout_s, SecRange{0, true, kMaxSeconds});
  f("limits.idle_timeout_s", l.idle_timeout_s, SecRange{0, true, kMaxSeconds});
  f("limits.render_time_limit_s", l.render_time_limit_s, SecRange{0, false, kMaxSeconds});
}

std::string num_text(double x) {
  std::ostringstream s;
  s << x;
  return s.str();
}

std::string range_text(const IntRange& r) {
  std::string s = "an integer in " + std::to_string(r.lo) + " ... " + std::to_string(r.hi);
  if (r.zero) s += std::string(" (0: ") + r.zero + ")";
  return s;
}
std::string range_text(const SecRange& r) {
  return std::string("a number of seconds ") + (r.open_lo ? "> " : ">= ") + num_text(r.lo) +
         " and <= " + num_text(r.hi);
}

[[noreturn]] void bad_key(const std::string& origin, const std::string& name,
                          const std::string& want, const std::string& got) {
  throw std::runtime_error(origin + ": key '" + name + "' must be " + want + ", got " + got);
}

// Checks a value already in its field (validate): the same ranges as a JSON value's.
struct CheckValue {
  const std::string& origin;
  template <class T>
  void operator()(const char* name, const T& v, const IntRange& r) const {
    bool below = false;
    if constexpr (std::is_signed_v<T>) below = v < 0;
    if (below || static_cast<uint64_t>(v) < r.lo || static_cast<uint64_t>(v) > r.hi)
      bad_key(origin, name, range_text(r), std::to_string(v));
  }
  void operator()(const char* name, double v, const SecRange& r) const {
    if (!std::isfinite(v) || v < r.lo || (r.open_lo && v == r.lo) || v > r.hi)
      bad_key(origin, name, range_text(r), num_text(v));
  }
  void operator()(const char* name, const std::string& v, const Text& t) const {
    if (t.nonempty && v.empty()) bad_key(origin, name, "a non-empty string", "\"\"");
  }
  void operator()(const char* name, const std::string& v, const Choice& c) const {
    for (const auto& w : c.words)
      if (v == w) return;
    bad_key(origin, name, choice_text(c), "'" + v + "'");
  }
  void operator()(const char*, bool, Flag) const {}
  static std::string choice_text(const Choice& c) {
    std::string s = "one of";
    for (size_t i = 0; i < c.words.size(); ++i) s += (i ? ", " : " ") + c.words[i];
    return s;
  }
};

// Reads one JSON value into its field, checked before it is narrowed.
struct ReadValue {
  const json& v;
  const std::string& origin;
  const std::string& name;
  template <class T>
  void operator()(const char*, T& out, const IntRange& r) const {
    // 2.5 and 3.0 are JSON floats, 1e30 too: not integers; -1 is not taken as 2^32 - 1.
    if (!v.is_number_integer()) bad_key(origin, name, range_text(r), v.dump());
    if (v.is_number_unsigned()) {
      uint64_t n = v.get<uint64_t>();
      if (n < r.lo || n > r.hi) bad_key(origin, name, range_text(r), v.dump());
      out = static_cast<T>(n);
    } else {
      int64_t n = v.get<int64_t>();
      if (n < 0 || static_cast<uint64_t>(n) < r.lo || static_cast<uint64_t>(n) > r.hi)
        bad_key(origin, name, range_text(r), v.dump());
      out = static_cast<T>(n);
    }
  }
  void operator()(const char*, double& out, const SecRange& r) const {
    if (!v.is_number()) bad_key(origin, name, range_text(r), v.dump());
    out = v.get<double>();
    CheckValue{origin}(name.c_str(), out, r);
  }
  void operator()(const char*, std::string& out, const Text& t) const {
    if (!v.is_string()) bad_key(origin, name, "a string", v.dump());
    out = v.get<std::string>();
    CheckValue{origin}(name.c_str(), out, t);
  }
  void operator()(const char*, std::string& out, const Choice& c) const {
    if (!v.is_string()) bad_key(origin, name, CheckValue::choice_text(c), v.dump());
    out = v.get<std::string>();
    CheckValue{origin}(name.c_str(), out, c);
  }
  void operator()(const char*, bool& out, Flag) const {
    if (!v.is_boolean()) bad_key(origin, name, "true or false", v.dump());
    out = v.get<bool>();
  }
};

// Applies one key ("renderers", "limits.max_sessions") of a JSON config; false: no such key.
bool apply_key(Config& cfg, const std::string& name, const json& v, const std::string& origin) {
  bool found = false;
  visit_keys(cfg, [&](const char* key, auto& field, const auto& range) {
    if (found || name != key) return;
    found = true;
    ReadValue{v, origin, name}(key, field, range);
  });
  return found;
}

// Applies one flag's text to its key: a number where the key takes an integer ("-1", "2.5" and
// "8x" are refused as the JSON values would be), the text itself otherwise.
void apply_flag(Config& cfg, const char* name, const std::string& text, const std::string& origin) {
  visit_keys(cfg, [&](const char* key, auto& field, const auto& range) {
    if (std::string(name) != key) return;
    json v = text;
    if constexpr (std::is_same_v<std::decay_t<decltype(range)>, IntRange>) {
      if (!text.empty() && text.size() <= 19 &&
          text.find_first_not_of("0123456789") == std::string::npos)
        v = std::stoull(text);
    }
    ReadValue{v, origin, key}(key, field, range);
  });
}

}  // namespace

void validate(const Config& cfg, const std::string& origin) {
  visit_keys(cfg, CheckValue{origin});
}

void apply_json(Config& cfg, const std::string& text, const std::string& origin) {
  json j = json::parse(text, nullptr, false);
  if (j.is_discarded() || !j.is_object()) throw std::runtime_error(origin + ": not a JSON object");
  for (auto& [k, v] : j.items()) {
    if (k == "token_file") {
      if (!v.is_string()) bad_key(origin, k, "a string", v.dump());
      cfg.token = read_token(v.get<std::string>());
    } else if (k == "limits") {
      if (!v.is_object()) throw std::runtime_error(origin + ": 'limits' is not an object");
      for (auto& [lk, lv] : v.items())
        if (!apply_key(cfg, "limits." + lk, lv, origin))
          throw std::runtime_error(origin + ": unknown key 'limits." + lk + "'");
    } else if (k.rfind("limits.", 0) == 0 || !apply_key(cfg, k, v, origin)) {
      throw std::runtime_error(origin + ": unknown key '" + k + "'");
    }
  }
  validate(cfg, origin);
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
  // Each flag sets one config key, read and range-checked as that key's JSON value is.
  static const std::pair<const char*, const char*> kFlags[] = {
      {"--port", "port"},
      {"--address", "address"},
      {"--library", "library"},
      {"--www", "www"},
      {"--device", "device"},
      {"--renderers", "renderers"},
      {"--max-sessions", "limits.max_sessions"},
      {"--log-level", "log_level"},
  };
  for (int i = 1; i < argc; ++i) {
    std::string a = argv[i];
    if (a == "--help" || a == "-h") {
      usage = kUsage;
      return false;
    }
    if (i + 1 >= argc) throw std::runtime_error("flag " + a + " needs a value");
    std::string v = argv[++i];
    if (a == "--config") continue;
    if (a == "--token-file") {
      cfg.token = read_token(v);
      continue;
    }
    if (a == "--permessage-deflate") {
      if (v != "on" && v != "off")
        throw std::runtime_error("flag --permessage-deflate: expected on or off, got '" + v + "'");
      cfg.permessage_deflate = v == "on";
      continue;
    }
    const char* key = nullptr;
    for (const auto& [flag, k] : kFlags)
      if (a == flag) key = k;
    if (!key) throw std::runtime_error("unknown flag " + a + " (see --help)");
    apply_flag(cfg, key, v, "flag " + a);
  }
  validate(cfg, "command line");
  return true;
}

}  // namespace vismap::server
