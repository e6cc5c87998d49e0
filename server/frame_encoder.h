// Frame encoders: a planar map to one frame payload in the session's format (proto/PROTOCOL.md,
// "frame"). The session (ws_session.cpp) makes one encoder at hello and calls it on the encode
// pool, off the render workers.
#pragma once

#include <cstdint>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>

#include "core/camera.h"
#include "core/pipeline.h"
#include "core/planar_map.h"
#include "core/scene.h"
#include "server/protocol.h"

namespace vismap::server {

struct EncodedFrame {
  std::string bytes;                                 // the payload message
  nlohmann::json header = nlohmann::json::object();  // the format's own frame header fields
};

// One session's encoder. encode() runs on the encode pool, one frame at a time per session and in
// frame order (a session has at most one frame in flight), so an encoder may keep state from one
// frame to the next without a lock: a format that codes a frame against the previous one keeps
// that here. What it keeps must stay bounded by about one frame (state_bytes() reports it; the
// session counts it with its other buffers).
class FrameEncoder {
 public:
  virtual ~FrameEncoder() = default;
  // `screen`: the render's screen triangles, when needs_screen() asked for them.
  virtual EncodedFrame encode(const PlanarMap& map, const std::shared_ptr<const Scene>& scene,
                              const Camera& camera, const ScreenTriangles* screen) = 0;
  virtual uint64_t state_bytes() const { return 0; }
  // The render must keep its screen triangles (RenderOptions::keep_screen_triangles).
  virtual bool needs_screen() const { return false; }
  // The client lost its state (a `keyframe` message): the next frame must stand alone. Called
  // on the session's strand while encode() may run on the pool.
  virtual void request_keyframe() {}
};

// The encoder for hello's format and options: the one place a format's writer is chosen.
// level: compact and delta frames' entropy coder level (Config::frame_level; 0: its default).
std::unique_ptr<FrameEncoder> make_encoder(const Hello& hello, int level = 0);

}  // namespace vismap::server
