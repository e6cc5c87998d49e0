// The one way in for a frame (issue 44): a caller fills a FrameSpec (the scene's state, the
// camera, the output, the dicing tolerances, one time limit and one memory budget, a cancel flag
// and a progress callback) and calls run_frame, which dices the scene's curved surfaces for the
// view, renders the planar map, draws its lines where the style asks and encodes it. The CLI,
// `vismap check`, vismapd and the Python module call this and nothing below it.
//
// Limits, one policy for every caller (README "Limits"):
// - time_limit_s is the whole frame's, counted from `started` (the default: run_frame's start).
//   The CLI starts it when the command starts, so reading the scene counts too (the load itself
//   stops at the limit, LoadOptions::time_limit_s); vismapd when the frame leaves the queue.
//   Dicing, finding the scene's facts (at most a quarter of what is left), the render, the lines
//   and the encoding all draw on it: the dicer and the render stop inside when it passes
//   (InputError TimeLimit naming the stage); the lines and the encoder, host work bounded by the
//   map's size, are not interrupted but do not start past it.
// - memory_budget bounds the device memory of the dicing and of the render (buckets), each on
//   its own (the diced meshes are host memory by then); the facts' search only where it fits
//   half of it. 0: none.
// - cancel: once true, the frame stops at the next check of the time limit (InputError
//   Cancelled), and nothing is returned.
#pragma once

#include <atomic>
#include <functional>
#include <memory>
#include <optional>
#include <string>

#include "core/camera.h"
#include "core/frame/encoders.h"
#include "core/frame/formats.h"
#include "core/frame/scene_state.h"
#include "core/pipeline.h"
#include "core/util/clock.h"

namespace vismap::frame {

struct FrameSpec {
  std::shared_ptr<SceneState> scene;
  Camera camera;
  OutputSpec output;
  // Curved surfaces (TessellateOptions): diced within this many pixels of the surface; implicit
  // surfaces within implicit_tolerance_px at their nearest depth.
  double tolerance_px = 0.2;
  double implicit_tolerance_px = 4.0;
  // The limits (above); 0: none.
  double time_limit_s = 0;
  Clock::time_point started{};
  uint64_t memory_budget = 0;
  // The Loop plans' cap in host bytes (TessellateOptions::loop_plan_cache_bytes and
  // loop_plan_max_bytes); 0: their defaults.
  uint64_t loop_plan_bytes = 0;
  bool cull = true;  // RenderOptions::cull
  FactsPolicy facts = FactsPolicy::Repeat;
  const std::atomic<bool>* cancel = nullptr;
  // Called with the render's fraction done, in [0, 1], if set.
  std::function<void(double)> progress;
  // Called with the render's options just before the render (tests; vismapd's --render-delay).
  std::function<void(const RenderOptions&)> before_render;
};

// A frame rendered, before its lines and encoding.
struct RenderedFrame {
  std::shared_ptr<const Scene> scene;  // what was rendered: the diced scene where it has surfaces
  Camera camera;
  PlanarMap map;
  ScreenTriangles screen;  // kept where the lines or the encoder need them
  RenderStats stats;
  TessellateStats dice;
  double dice_ms = 0, render_ms = 0;  // wall time of each (the facts' search inside render_ms)
};

struct Frame {
  RenderedFrame rendered;
  std::optional<LineSet> lines;  // where the style asks for lines
  EncodedFrame encoded;
  double lines_ms = 0, encode_ms = 0;
};

// Dicing and the render: the part that needs the device (vismapd runs it on a render worker).
// A caller of the two halves sets spec.started, so that they share one limit.
RenderedFrame render_frame(Renderer& renderer, const FrameSpec& spec);
// The lines and the encoding, on the host. `encoder` codes the frame in the spec's format (a
// stream's, kept from frame to frame; make_encoder(spec.output)).
Frame finish_frame(RenderedFrame rendered, const FrameSpec& spec, FrameEncoder& encoder);
// The scene's curved surfaces diced for the spec's camera under its limits (the scene itself
// where it has none): what render_frame renders. For callers that check a map themselves
// (`vismap check`).
std::shared_ptr<const Scene> dice_for_view(Renderer& renderer, const FrameSpec& spec,
                                           TessellateStats* stats = nullptr);
// Both: one frame, with an encoder made for it.
Frame run_frame(Renderer& renderer, const FrameSpec& spec);

// The camera for a scene: its own (from the file) or one that frames it, at width x height.
Camera scene_camera(const Scene& scene, uint32_t width, uint32_t height);

}  // namespace vismap::frame
