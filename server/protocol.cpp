#include "server/protocol.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <nlohmann/json.hpp>

namespace vismap::server {

using nlohmann::json;

namespace {

[[noreturn]] void bad(const std::string& msg) {
  throw ProtoError(code::bad_message, msg);
}

const json* field(const json& j, const char* key) {
  auto it = j.find(key);
  return it == j.end() || it->is_null() ? nullptr : &*it;
}

// The helpers below read a field that must be there (callers test optional ones with field()).
const json* required(const json& j, const char* key) {
  const json* v = field(j, key);
  if (!v) bad(std::string("'") + key + "' is required");
  return v;
}

double number(const json& j, const char* key) {
  const json* v = required(j, key);
  if (!v->is_number()) bad(std::string("'") + key + "' must be a number");
  double d = v->get<double>();
  if (!std::isfinite(d)) bad(std::string("'") + key + "' must be finite");
  return d;
}

uint64_t uint(const json& j, const char* key, uint64_t hi) {
  const json* v = required(j, key);
  if (!v->is_number_unsigned() && !(v->is_number_integer() && v->get<int64_t>() >= 0))
    bad(std::string("'") + key + "' must be a non-negative integer");
  uint64_t n = v->get<uint64_t>();
  if (n > hi) bad(std::string("'") + key + "' is larger than " + std::to_string(hi));
  return n;
}

std::string string(const json& j, const char* key) {
  const json* v = required(j, key);
  if (!v->is_string()) bad(std::string("'") + key + "' must be a string");
  return v->get<std::string>();
}

Vec3 vec3(const json& j, const char* key) {
  const json* v = required(j, key);
  if (!v->is_array() || v->size() != 3) bad(std::string("'") + key + "' must be [x, y, z]");
  Vec3 r{};
  for (int i = 0; i < 3; ++i) {
    if (!(*v)[i].is_number()) bad(std::string("'") + key + "' must hold numbers");
    r[i] = (*v)[i].get<double>();
    if (!std::isfinite(r[i])) bad(std::string("'") + key + "' must be finite");
  }
  return r;
}

void viewport(const json& j, uint32_t& w, uint32_t& h, uint32_t max_viewport) {
  w = static_cast<uint32_t>(uint(j, "width", max_viewport));
  h = static_cast<uint32_t>(uint(j, "height", max_viewport));
  if (w == 0 || h == 0) bad("viewport width and height must be >= 1");
}

Hello parse_hello(const json& j, uint32_t max_viewport) {
  Hello h;
  std::vector<int> offered;
  if (const json* v = field(j, "version")) {
    if (!v->is_number_integer()) bad("'version' must be an integer");
    offered.push_back(v->get<int>());
  }
  if (const json* v = field(j, "versions")) {
    if (!v->is_array()) bad("'versions' must be an array of integers");
    for (const json& e : *v) {
      if (!e.is_number_integer()) bad("'versions' must be an array of integers");
      offered.push_back(e.get<int>());
    }
  }
  if (offered.empty()) bad("hello needs 'version' or 'versions'");
  h.version = 0;
  for (int v : offered)
    if (v >= kMinProtocolVersion && v <= kMaxProtocolVersion) h.version = std::max(h.version, v);
  if (h.version == 0)
    throw ProtoError(code::version_mismatch,
                     "server speaks protocol versions " + std::to_string(kMinProtocolVersion) +
                         " to " + std::to_string(kMaxProtocolVersion),
                     true);
  if (field(j, "format")) {
    std::string f = string(j, "format");
    const FormatSpec* spec = nullptr;
    std::string offered_names;
    for (const FormatSpec& s : kFormats) {
      if (f == s.name) spec = &s;
      if (s.since_version <= h.version)
        offered_names += (offered_names.empty() ? "\"" : ", \"") + std::string(s.name) + "\"";
    }
    if (spec && spec->since_version > h.version)
      bad("format \"" + f + "\" needs protocol version " + std::to_string(spec->since_version) +
          " (this session speaks version " + std::to_string(h.version) + ")");
    if (!spec) bad("'format' must be one of " + offered_names);
    h.format = spec->format;
  }
  if (const json* v = field(j, "attributes")) {
    if (!v->is_boolean()) bad("'attributes' must be a boolean");
    h.attributes = v->get<bool>();
  }
  if (field(j, "fill")) {
    std::string f = string(j, "fill");
    if (f != "shade" && f != "id") bad("'fill' must be \"shade\" or \"id\"");
    h.fill_id = f == "id";
  }
  if (const json* v = field(j, "viewport")) {
    if (!v->is_object()) bad("'viewport' must be {\"width\":W,\"height\":H}");
    viewport(*v, h.width, h.height, max_viewport);
  }
  if (field(j, "token")) h.token = string(j, "token");
  if (h.version >= 2) {  // version 1 ignores these fields, as any field it does not list
    if (field(j, "quantum")) {
      const json* v = field(j, "quantum");
      if (!v->is_number_integer() || v->get<int64_t>() < int64_t{kMinQuantum} ||
          v->get<int64_t>() > int64_t{kMaxQuantum})
        bad("'quantum' must be an integer in " + quantum_range_text());
      h.quantum = v->get<uint32_t>();
    }
    if (field(j, "compression")) {
      std::string c = string(j, "compression");
      if (c == "zstd")
        h.compression = vismap::Compression::Zstd;
      else if (c == "deflate")
        h.compression = vismap::Compression::Deflate;
      else
        bad("'compression' must be \"zstd\" or \"deflate\" (raw deflate)");
    }
    if (field(j, "style")) {
      h.style = string(j, "style");
      if (h.style != "fill" && h.style != "lines" && h.style != "fill+lines")
        bad("'style' must be \"fill\", \"lines\" or \"fill+lines\"");
    }
    if (const json* v = field(j, "hidden")) {
      if (!v->is_boolean()) bad("'hidden' must be a boolean");
      h.hidden = v->get<bool>();
    }
    if (const json* v = field(j, "crease_angle")) {
      if (!v->is_number() || !(v->get<double>() >= 0 && v->get<double>() <= 180))
        bad("'crease_angle' must be a number of degrees from 0 to 180");
      h.crease_angle_deg = v->get<double>();
    }
    if (const json* v = field(j, "tolerance")) {
      if (!v->is_number() || !(v->get<double>() >= 1e-3 && v->get<double>() <= 1000))
        bad("'tolerance' must be a number of pixels from 0.001 to 1000");
      h.tolerance_px = v->get<double>();
    }
    if (const json* v = field(j, "implicit_tolerance")) {
      if (!v->is_number() || !(v->get<double>() >= 1e-2 && v->get<double>() <= 1000))
        bad("'implicit_tolerance' must be a number of pixels from 0.01 to 1000");
      h.implicit_tolerance_px = v->get<double>();
    }
    if (h.style != "fill" && h.format != Format::Svg && h.format != Format::Bin)
      bad("'style': lines are drawn in svg and bin frames, not " +
          std::string(format_spec(h.format).name));
    if (h.hidden && h.style == "fill") bad("'hidden': needs 'style' \"lines\" or \"fill+lines\"");
    if (field(j, "keyframe_every")) {
      const json* v = field(j, "keyframe_every");
      if (!v->is_number_integer() || v->get<int64_t>() < 0 || v->get<int64_t>() > 1000000)
        bad("'keyframe_every' must be an integer from 0 to 1000000 (frames; 0: on request only)");
      h.keyframe_every = v->get<uint32_t>();
    }
  }
  if (h.version >= 3) {
    if (const json* v = field(j, "hold_scene")) {
      if (!v->is_boolean()) bad("'hold_scene' must be a boolean");
      h.hold_scene = v->get<bool>();
      if (h.hold_scene && h.format != Format::Delta)
        bad("'hold_scene' is for delta frames (the client holds the scene's sources)");
    }
  }
  if (h.attributes && format_spec(h.format).no_attributes)
    bad(std::string("'attributes': ") + format_spec(h.format).no_attributes);
  return h;
}

SceneRequest parse_scene(const json& j, uint64_t max_scene_bytes) {
  SceneRequest s;
  int sources = 0;
  if (field(j, "library")) {
    s.library = string(j, "library");
    s.name = s.library;
    ++sources;
  }
  if (field(j, "name")) s.name = string(j, "name");
  if (field(j, "data")) {
    const json* d = field(j, "data");
    if (!d->is_string()) bad("'data' must be a base64 string");
    const std::string& b64 = d->get_ref<const std::string&>();
    if (b64.size() / 4 * 3 > max_scene_bytes + 3)
      throw ProtoError(code::too_large, "scene is larger than max_scene_bytes (" +
                                            std::to_string(max_scene_bytes) + ")");
    bool ok = true;
    s.data = base64_decode(b64, ok);
    if (!ok) bad("'data' is not valid base64");
    if (s.data->size() > max_scene_bytes)
      throw ProtoError(code::too_large, "scene is larger than max_scene_bytes (" +
                                            std::to_string(max_scene_bytes) + ")");
    ++sources;
  }
  if (field(j, "size")) {
    s.size = uint(j, "size", UINT64_MAX);
    if (s.size > max_scene_bytes)
      throw ProtoError(code::too_large, "scene of " + std::to_string(s.size) +
                                            " bytes is larger than max_scene_bytes (" +
                                            std::to_string(max_scene_bytes) + ")");
    if (s.size == 0) bad("'size' must be >= 1");
    ++sources;
  }
  if (sources != 1) bad("scene needs exactly one of 'library', 'data' or 'size'");
  if (s.name.empty()) bad("scene needs a 'name' (its extension picks the format)");
  if (s.name.size() > 255) bad("'name' is longer than 255 characters");
  return s;
}

CameraRequest parse_camera(const json& j, uint32_t max_viewport) {
  CameraRequest c;
  if (field(j, "seq")) c.seq = uint(j, "seq", UINT64_MAX);
  if (field(j, "eye")) c.eye = vec3(j, "eye");
  if (field(j, "target")) c.target = vec3(j, "target");
  if (field(j, "up")) c.up = vec3(j, "up");
  if (field(j, "fov_y_deg")) c.fov_y_deg = number(j, "fov_y_deg");
  if (field(j, "ortho_height")) c.ortho_height = number(j, "ortho_height");
  if (field(j, "near")) c.near_plane = number(j, "near");
  if (field(j, "far")) c.far_plane = number(j, "far");
  if (field(j, "projection")) {
    std::string p = string(j, "projection");
    if (p != "perspective" && p != "orthographic")
      bad("'projection' must be \"perspective\" or \"orthographic\"");
    c.orthographic = p == "orthographic";
  }
  if (const json* v = field(j, "viewport")) {
    if (!v->is_object()) bad("'viewport' must be {\"width\":W,\"height\":H}");
    uint32_t w, h;
    viewport(*v, w, h, max_viewport);
    c.width = w;
    c.height = h;
  }
  return c;
}

// A SAX consumer that keeps nothing: it follows the depth and notes the top-level "type".
// Returning false stops the parse at once.
struct Precheck : nlohmann::json_sax<json> {
  int max_depth;
  int depth = 0;
  bool too_deep = false;
  bool type_key = false;  // the last top-level key was "type"
  std::string type;

  explicit Precheck(int d) : max_depth(d) {}
  bool value() {
    type_key = false;
    return true;
  }
  bool null() override { return value(); }
  bool boolean(bool) override { return value(); }
  bool number_integer(number_integer_t) override { return value(); }
  bool number_unsigned(number_unsigned_t) override { return value(); }
  bool number_float(number_float_t, const string_t&) override { return value(); }
  bool string(string_t& v) override {
    if (type_key && type.empty()) type = v.substr(0, 64);
    return value();
  }
  bool binary(binary_t&) override { return value(); }
  bool open(std::size_t) {
    type_key = false;
    if (++depth > max_depth) too_deep = true;
    return !too_deep;
  }
  bool start_object(std::size_t n) override { return open(n); }
  bool start_array(std::size_t n) override { return open(n); }
  bool end_object() override { return --depth, true; }
  bool end_array() override { return --depth, true; }
  bool key(string_t& k) override {
    type_key = depth == 1 && k == "type";
    return true;
  }
  bool parse_error(std::size_t, const std::string&, const nlohmann::detail::exception&) override {
    return false;
  }
};

void check_depth(const std::string& text) {
  Precheck p(kMaxJsonDepth);
  json::sax_parse(text, &p, json::input_format_t::json, /*strict=*/true);
  if (p.too_deep)
    throw ProtoError(code::bad_message,
                     "message nests deeper than " + std::to_string(kMaxJsonDepth) + " levels");
}

}  // namespace

void check_control_message(const std::string& text, uint64_t max_control_bytes) {
  if (text.size() <= max_control_bytes) return check_depth(text);
  // Over the control limit: only a flat scene message may pass, so depth 1 is enough to know.
  Precheck p(1);
  json::sax_parse(text, &p, json::input_format_t::json, /*strict=*/true);
  if (p.too_deep || p.type != "scene")
    throw ProtoError(code::too_large, "control message of " + std::to_string(text.size()) +
                                          " bytes is larger than max_control_bytes (" +
                                          std::to_string(max_control_bytes) + ")");
}

void CameraRequest::apply_to(Camera& c) const {
  if (eye) c.eye = *eye;
  if (target) c.target = *target;
  if (up) c.up = *up;
  if (fov_y_deg) c.fov_y_deg = *fov_y_deg;
  if (ortho_height) c.ortho_height = *ortho_height;
  if (near_plane) c.near_plane = *near_plane;
  if (far_plane) c.far_plane = *far_plane;
  if (orthographic)
    c.projection =
        *orthographic ? Camera::Projection::Orthographic : Camera::Projection::Perspective;
  if (width) c.width = *width;
  if (height) c.height = *height;
}

Request parse_request(const std::string& text, uint64_t max_scene_bytes, uint32_t max_viewport,
                      bool checked_depth) {
  if (!checked_depth) check_depth(text);
  json j = json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (j.is_discarded()) throw ProtoError(code::bad_json, "message is not valid JSON");
  if (!j.is_object()) throw ProtoError(code::bad_message, "message must be a JSON object");
  const json* t = field(j, "type");
  if (!t || !t->is_string()) throw ProtoError(code::bad_message, "message needs a string 'type'");
  const std::string& type = t->get_ref<const std::string&>();
  if (type == "hello") return parse_hello(j, max_viewport);
  if (type == "scene") return parse_scene(j, max_scene_bytes);
  if (type == "camera") return parse_camera(j, max_viewport);
  if (type == "ping") {
    Ping p;
    if (field(j, "seq")) p.seq = uint(j, "seq", UINT64_MAX);
    return p;
  }
  if (type == "keyframe") return KeyframeRequest{};
  std::string shown = type.size() > 40 ? type.substr(0, 40) + "..." : type;
  throw ProtoError(code::unknown_message, "unknown message type '" + shown + "'");
}

std::string error_code(const vismap::InputError& e) {
  return vismap::to_string(e.kind());
}

std::string error_json(const std::string& c, const std::string& message, bool fatal,
                       std::optional<uint64_t> seq) {
  json j = {{"type", "error"}, {"code", c}, {"message", message}, {"fatal", fatal}};
  if (seq) j["seq"] = *seq;
  return j.dump(-1, ' ', false, json::error_handler_t::replace);
}

std::string pong_message(uint64_t seq) {
  return json{{"type", "pong"}, {"seq", seq}}.dump();
}

std::string welcome_message(const Hello& h, uint64_t session, bool library,
                            const WelcomeLimits& L) {
  json limits = {
      {"max_message_bytes", L.max_message_bytes}, {"max_control_bytes", L.max_control_bytes},
      {"max_scene_bytes", L.max_scene_bytes},     {"max_triangles", L.max_triangles},
      {"max_session_bytes", L.max_session_bytes}, {"max_viewport", L.max_viewport},
      {"idle_timeout_s", L.idle_timeout_s}};
  json welcome = {{"type", "welcome"},   {"version", h.version},
                  {"session", session},  {"server", "vismapd"},
                  {"format", format_spec(h.format).name}, {"library", library},
                  {"limits", limits}};
  if (h.version >= 2) {
    json formats = json::array();
    for (const FormatSpec& s : kFormats)
      if (s.since_version <= h.version) formats.push_back(s.name);
    welcome["formats"] = formats;
  }
  return welcome.dump();
}

namespace {

json camera_json(const Camera& c) {
  bool ortho = c.projection == Camera::Projection::Orthographic;
  return {{"projection", ortho ? "orthographic" : "perspective"},
          {"eye", c.eye},
          {"target", c.target},
          {"up", c.up},
          {"fov_y_deg", c.fov_y_deg},
          {"ortho_height", c.ortho_height},
          {"near", c.near_plane},
          {"far", c.far_plane},
          {"viewport", {{"width", c.width}, {"height", c.height}}}};
}

}  // namespace

std::string scene_ready_message(const std::string& name, uint64_t meshes, uint64_t triangles,
                                const Bounds& bounds, const Camera& camera, double load_ms) {
  return json{{"type", "scene_ready"},
              {"name", name},
              {"meshes", meshes},
              {"triangles", triangles},
              {"bounds", {{"lo", bounds.lo}, {"hi", bounds.hi}}},
              {"camera", camera_json(camera)},
              {"load_ms", load_ms}}
      .dump();
}

std::string frame_message(const FrameHeader& f, const json& format_fields) {
  json header = {{"type", "frame"},
                 {"seq", f.seq},
                 {"format", format_spec(f.format).name},
                 {"bytes", f.bytes},
                 {"render_ms", f.render_ms},
                 {"encode_ms", f.encode_ms},
                 {"queue_ms", f.queue_ms},
                 {"triangles", f.triangles},
                 {"fragments", f.fragments},
                 {"buckets", f.buckets},
                 {"skipped", f.skipped}};
  header.update(format_fields);
  return header.dump();
}

std::string base64_decode(const std::string& in, bool& ok) {
  static const auto table = [] {
    std::array<int8_t, 256> t{};
    t.fill(-1);
    const char* a = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    for (int i = 0; i < 64; ++i) t[static_cast<uint8_t>(a[i])] = static_cast<int8_t>(i);
    return t;
  }();
  std::string out;
  out.reserve(in.size() / 4 * 3);
  uint32_t acc = 0;
  int bits = 0;
  size_t pad = 0;
  ok = true;
  for (char ch : in) {
    if (ch == '=') {
      ++pad;
      continue;
    }
    if (ch == '\n' || ch == '\r') continue;
    int v = table[static_cast<uint8_t>(ch)];
    if (v < 0 || pad) {
      ok = false;
      return {};
    }
    acc = (acc << 6) | static_cast<uint32_t>(v);
    bits += 6;
    if (bits >= 8) {
      bits -= 8;
      out.push_back(static_cast<char>((acc >> bits) & 0xff));
    }
  }
  if (pad > 2) ok = false;
  return out;
}

bool safe_library_name(const std::string& name) {
  if (name.empty() || name.front() == '/' || name.find('\\') != std::string::npos) return false;
  if (name.find('\0') != std::string::npos) return false;
  size_t start = 0;
  while (start <= name.size()) {
    size_t end = name.find('/', start);
    if (end == std::string::npos) end = name.size();
    std::string part = name.substr(start, end - start);
    if (part.empty() || part == "." || part == "..") return false;
    start = end + 1;
  }
  return true;
}

}  // namespace vismap::server
