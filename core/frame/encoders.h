// Frame encoders: a planar map (and its lines) to one frame's bytes in an output format
// (formats.h). One encoder codes a stream's frames one after another; a format that codes a
// frame against the previous one (delta) keeps that state here.
#pragma once

#include <array>
#include <atomic>
#include <cstdint>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>

#include "core/camera.h"
#include "core/frame/formats.h"
#include "core/lines/lines.h"
#include "core/pipeline.h"
#include "core/planar_map.h"
#include "core/scene.h"
#include "core/stream/compact.h"
#include "core/write/output.h"

namespace vismap::frame {

// What is drawn: the fills, the lines, or both (docs/LINES.md).
enum class DrawStyle : uint8_t { Fill, Lines, FillLines };
const char* style_name(DrawStyle s);  // "fill", "lines", "fill+lines"
std::optional<DrawStyle> style_named(std::string_view name);

// How a frame is written.
struct OutputSpec {
  OutputFormat format = OutputFormat::Svg;
  Fill fill = Fill::Shade;  // svg, pdf, eps, png; compact and delta: a shade byte unless Id
  DrawStyle style = DrawStyle::Fill;
  LineOptions lines;  // the line drawing's rules and selection (style lines, fill+lines)
  // svg, pdf, eps, png: line widths and colours, --merge (its fill and lines are set per frame).
  SvgStyle svg;
  bool attributes = false;  // barycentrics and 1/w, where the format carries them (bin)
  // compact and delta: grid steps per pixel, the entropy coder and its level (0: its default).
  uint32_t quantum = 16;
  Compression compression = Compression::Zstd;
  int level = 0;
  // delta (proto/DELTA.md): a keyframe every N frames (0: the first and on request), the format
  // version written, and whether the client holds the scene's sources.
  uint32_t keyframe_every = 0;
  uint32_t delta_version = 2;
  bool client_holds_scene = false;

  bool draws_lines() const { return style != DrawStyle::Fill; }
  bool draws_fills() const { return style != DrawStyle::Lines; }
};

struct EncodedFrame {
  std::string bytes;
  nlohmann::json header = nlohmann::json::object();  // the format's own frame header fields
  CompactStats compact;                               // compact frames: what write_compact measured
};

// What an encoder is given: the map, the scene it came from, the view, the screen triangles
// (where needs_screen()), and the lines (where the style draws them).
struct FrameInput {
  const PlanarMap& map;
  const std::shared_ptr<const Scene>& scene;
  const Camera& camera;
  const ScreenTriangles* screen = nullptr;
  const LineSet* lines = nullptr;
};

// One stream's encoder. encode() is called for one frame at a time and in frame order, so an
// encoder may keep state from one frame to the next without a lock. What it keeps must stay
// bounded by about one frame (state_bytes() reports it).
class FrameEncoder {
 public:
  virtual ~FrameEncoder() = default;
  virtual EncodedFrame encode(const FrameInput& in) = 0;
  virtual uint64_t state_bytes() const { return 0; }
  // The client lost its state: the next frame must stand alone. Safe from another thread while
  // encode() runs.
  virtual void request_keyframe() {}
};

// Whether the render must keep its screen triangles (RenderOptions::keep_screen_triangles) for
// the frame's lines or its encoder (delta frames are coded from them).
bool needs_screen(const OutputSpec& o);

// The encoder for the spec's format: the one place a format's writer is chosen.
std::unique_ptr<FrameEncoder> make_encoder(const OutputSpec& spec);

}  // namespace vismap::frame
