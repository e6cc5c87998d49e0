// The whole wire format of proto/PROTOCOL.md: the client's control messages as C++ values and
// their JSON parsing, and the server's messages as the text it sends. No networking here: the
// session (ws_session.cpp) feeds text messages in and gets typed requests or a ProtoError, and
// sends what the *_message functions build.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <variant>

#include <nlohmann/json_fwd.hpp>

#include "core/camera.h"
#include "core/error.h"
#include "core/frame/formats.h"
#include "core/stream/compact.h"

namespace vismap::server {

// The protocol versions this server speaks (proto/PROTOCOL.md); hello picks the highest offered.
inline constexpr int kMinProtocolVersion = 1;
inline constexpr int kMaxProtocolVersion = 3;

// Protocol error codes (proto/PROTOCOL.md, "Error codes"). Scene and camera errors use the
// vismap::InputErrorKind strings (to_string(kind)) unchanged.
namespace code {
inline constexpr const char* bad_json = "bad_json";
inline constexpr const char* bad_message = "bad_message";
inline constexpr const char* unknown_message = "unknown_message";
inline constexpr const char* unexpected_message = "unexpected_message";
inline constexpr const char* version_mismatch = "version_mismatch";
inline constexpr const char* too_large = "too_large";
inline constexpr const char* unauthorized = "unauthorized";
inline constexpr const char* timeout = "timeout";
inline constexpr const char* busy = "busy";
inline constexpr const char* no_scene = "no_scene";
inline constexpr const char* shutting_down = "shutting_down";
inline constexpr const char* device_error = "device_error";
inline constexpr const char* file_not_found = "file_not_found";
inline constexpr const char* internal = "internal";
}  // namespace code

// A request the server refuses. fatal: the server closes the session after sending it.
struct ProtoError : std::runtime_error {
  ProtoError(std::string c, const std::string& msg, bool f = false)
      : std::runtime_error(msg), code(std::move(c)), fatal(f) {}
  std::string code;
  bool fatal;
};

// The frame formats a session may ask for, one row each in kFormats: the rows of core/frame's
// table (core/frame/formats.h: name, binary, attributes; the encoders) that a stream carries,
// with what the protocol adds. Adding one is a row there and here; the hello parser,
// welcome.formats, the frame header's `format`, the payload's message type and the per-format
// metrics all follow the table.
enum class Format : uint8_t { Svg, Bin, Compact, Delta };

struct FormatSpec {
  Format format;
  frame::OutputFormat output;  // its row in core/frame/formats.h
  const char* name;            // hello.format, frame.format, the metrics' format label
  int since_version;           // the protocol version that introduced it
  bool binary;                 // payload as a binary WebSocket message (else text)
  bool carries_attributes;     // hello.attributes: true puts barycentrics and 1/w in the frame
  const char* no_attributes;   // why attributes: true is refused; nullptr: accepted (or ignored)
};

constexpr FormatSpec stream_format(Format f, frame::OutputFormat o, int since_version,
                                   const char* no_attributes) {
  const frame::FormatRow& r = frame::format_row(o);
  return {f, o, r.name, since_version, r.binary, r.carries_attributes, no_attributes};
}

inline constexpr std::array<FormatSpec, 4> kFormats{{
    // v1 ignores attributes with svg: kept
    stream_format(Format::Svg, frame::OutputFormat::Svg, 1, nullptr),
    stream_format(Format::Bin, frame::OutputFormat::Bin, 1, nullptr),
    stream_format(Format::Compact, frame::OutputFormat::Compact, 2,
                  "compact frames carry no barycentrics; use format \"bin\" for attributes"),
    stream_format(Format::Delta, frame::OutputFormat::Delta, 2,
                  "delta frames carry no barycentrics: the client computes them from the source "
                  "triangles it holds (proto/DELTA.md)"),
}};

static_assert(
    [] {
      for (size_t i = 0; i < kFormats.size(); ++i)
        if (static_cast<size_t>(kFormats[i].format) != i) return false;
      return true;
    }(),
    "kFormats is indexed by Format");

constexpr const FormatSpec& format_spec(Format f) {
  return kFormats[static_cast<size_t>(f)];
}

struct Hello {
  int version = kMaxProtocolVersion;  // chosen: the highest of the client's versions we speak
  Format format = Format::Svg;
  bool attributes = false;
  bool fill_id = false;
  uint32_t width = 1024, height = 1024;
  std::string token;
  // Compact frames (version 2): grid steps per pixel and the payload's entropy coder.
  uint32_t quantum = 16;
  vismap::Compression compression = vismap::Compression::Zstd;
  // Delta frames (version 2): a keyframe every N frames besides the first and those the client
  // asks for (0: none).
  uint32_t keyframe_every = 0;
  // Delta frames (version 3): the client holds the scene; after each scene_ready the session
  // sends it the scene's sources once (a `sources` message), and frames carry none.
  bool hold_scene = false;
  // Line drawings (version 2; svg and bin frames): "fill", "lines" or "fill+lines", the
  // occluded parts, the crease angle (docs/LINES.md).
  std::string style = "fill";
  bool hidden = false;
  double crease_angle_deg = 45.0;
  // Curved surfaces (version 2, any format): diced within this many pixels (TessellateOptions).
  double tolerance_px = 0.2;
  // Implicit surfaces (version 2, any format): within this many pixels at their nearest depth
  // (TessellateOptions::implicit_tolerance_px).
  double implicit_tolerance_px = 4.0;
};

// Scene upload header. Exactly one source: `library` (a file in the server's library), `data`
// (base64 bytes inline) or `size` (bytes follow as the next binary message).
struct SceneRequest {
  std::string name;  // file name; its extension picks the loader
  std::string library;
  std::optional<std::string> data;  // decoded bytes
  uint64_t size = 0;
};

// Camera update. Missing fields keep the scene's framing camera (frame_scene) values.
struct CameraRequest {
  uint64_t seq = 0;
  std::optional<Vec3> eye, target, up;
  std::optional<double> fov_y_deg, ortho_height, near_plane, far_plane;
  std::optional<bool> orthographic;
  std::optional<uint32_t> width, height;
  void apply_to(Camera& c) const;
};

struct Ping {
  uint64_t seq = 0;
};

// Delta sessions (version 2): the client lost its state; the next frame is a keyframe.
struct KeyframeRequest {};

using Request = std::variant<Hello, SceneRequest, CameraRequest, Ping, KeyframeRequest>;

// Deepest JSON nesting a control message may have (ours need 3: {"viewport":{...}}, [x,y,z]).
inline constexpr int kMaxJsonDepth = 8;

// Checks a text message before anything builds a JSON DOM of it, in one streaming (SAX) pass
// that keeps no values: nesting deeper than kMaxJsonDepth is bad_message, and a message larger
// than max_control_bytes is too_large unless it is a flat `scene` message (the only kind that
// may carry bulk: base64 data). An 80 MB camera of nested arrays had been parsed into a 3.2 GB
// DOM before its size was looked at (issue 15, bug 4). Syntax errors are left to
// parse_request (bad_json).
void check_control_message(const std::string& text, uint64_t max_control_bytes);

// Parses one text message. Throws ProtoError (bad_json, bad_message, unknown_message,
// version_mismatch, too_large). Nesting is bounded by kMaxJsonDepth (checked_depth: the caller
// ran check_control_message on this text already).
Request parse_request(const std::string& text, uint64_t max_scene_bytes, uint32_t max_viewport,
                      bool checked_depth = false);

// The code for a core input error: to_string(kind).
std::string error_code(const vismap::InputError& e);

// ---- The server's messages

std::string error_json(const std::string& code, const std::string& message, bool fatal,
                       std::optional<uint64_t> seq = std::nullopt);

std::string pong_message(uint64_t seq);

// What welcome.limits reports (server/config.h's Limits, the part a client can act on).
struct WelcomeLimits {
  uint64_t max_message_bytes = 0, max_control_bytes = 0, max_scene_bytes = 0, max_triangles = 0,
           max_session_bytes = 0;
  uint32_t max_viewport = 0;
  double idle_timeout_s = 0;
};
// hello's answer: the version and format chosen, the session id, whether a library is served,
// the limits; from version 2 the formats this version offers.
std::string welcome_message(const Hello& hello, uint64_t session, bool library,
                            const WelcomeLimits& limits);

// A scene loaded: its size, bounds and framing camera.
std::string scene_ready_message(const std::string& name, uint64_t meshes, uint64_t triangles,
                                const Bounds& bounds, const Camera& camera, double load_ms);

// The text message before each frame's payload: the render's figures, then the format's own
// fields (core/frame/encoders.cpp, frame::EncodedFrame::header).
struct FrameHeader {
  uint64_t seq = 0;
  Format format = Format::Svg;
  uint64_t bytes = 0;  // the payload message's
  double render_ms = 0, encode_ms = 0, queue_ms = 0;
  uint64_t triangles = 0, fragments = 0, buckets = 0, skipped = 0;
};
std::string frame_message(const FrameHeader& header, const nlohmann::json& format_fields);

std::string base64_decode(const std::string& in, bool& ok);

// A file name from the library: a plain name or relative path without "..", "\\" or a leading
// "/". Returns false when the name may escape the library folder.
bool safe_library_name(const std::string& name);

}  // namespace vismap::server
