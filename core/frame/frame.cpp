#include "core/frame/frame.h"

#include <cstdio>

#include "core/error.h"
#include "core/stages/deadline.h"

namespace vismap::frame {

namespace {

Clock::time_point start_of(const FrameSpec& spec) {
  return spec.started == Clock::time_point{} ? Clock::now() : spec.started;
}

// Seconds of the frame's limit left at this point (none: 0; past it: a millisecond, so that the
// next check stops the frame).
double seconds_left(const FrameSpec& spec, Clock::time_point started) {
  if (!(spec.time_limit_s > 0)) return 0;
  return std::max(1e-3, spec.time_limit_s - ms_since(started) / 1000);
}

// Host work that is not interrupted (the lines, the encoding) does not start past the frame's
// limit or once it is cancelled: the render's own check (stages::Deadline), at that point.
void check_before(const FrameSpec& spec, Clock::time_point started, const char* what) {
  stages::Deadline(spec.time_limit_s, spec.scene->scene()->source, started, spec.cancel)
      .check_at(std::string("before ") + what);
}

TessellateOptions dice_options(const FrameSpec& spec, Clock::time_point started) {
  TessellateOptions to;
  to.tolerance_px = float(spec.tolerance_px);
  to.implicit_tolerance_px = float(spec.implicit_tolerance_px);
  to.memory_budget = spec.memory_budget;
  to.time_limit_s = spec.time_limit_s;
  to.started = started;
  to.cancel = spec.cancel;
  to.loop_plans = &spec.scene->loop_plans();
  if (spec.loop_plan_bytes) to.loop_plan_cache_bytes = to.loop_plan_max_bytes = spec.loop_plan_bytes;
  return to;
}

// The facts this frame takes (FactsPolicy): the scene state's, found now where the policy asks
// for them and none were found before, within a quarter of the time left. A diced scene is new
// every frame: its facts are found for this frame alone (Now) or not at all.
std::shared_ptr<const facts::SceneFacts> frame_facts(const FrameSpec& spec, const Scene& rendered,
                                                     uint64_t frames_before,
                                                     Clock::time_point started, double* ms) {
  if (!spec.cull || spec.facts == FactsPolicy::Off) return nullptr;
  const Clock::time_point t0 = Clock::now();
  std::shared_ptr<const facts::SceneFacts> f;
  if (spec.scene->scene()->has_surfaces()) {
    if (spec.facts == FactsPolicy::Now &&
        facts::scene_facts_fit(rendered.triangle_count(), spec.memory_budget)) {
      f = std::make_shared<const facts::SceneFacts>(
          facts::find_scene_facts(rendered, seconds_left(spec, started) / 4));
      *ms = ms_since(t0);
    }
    return f;
  }
  if ((f = spec.scene->facts())) return f;
  const bool repeat = frames_before > 0 && spec.memory_budget == 0;
  if (spec.facts == FactsPolicy::Now || (spec.facts == FactsPolicy::Repeat && repeat)) {
    f = spec.scene->find_facts(spec.memory_budget, seconds_left(spec, started) / 4);
    *ms = ms_since(t0);
  }
  return f;
}

}  // namespace

RenderedFrame render_frame(Renderer& renderer, const FrameSpec& spec) {
  const Clock::time_point started = start_of(spec);
  RenderedFrame out;
  out.scene = spec.scene->scene();
  out.camera = spec.camera;
  const uint64_t frames_before = spec.scene->begin_frame();
  if (out.scene->has_surfaces()) {
    const Clock::time_point t0 = Clock::now();
    out.scene = std::make_shared<const Scene>(
        renderer.tessellate(*out.scene, spec.camera, dice_options(spec, started), &out.dice));
    out.dice_ms = ms_since(t0);
  }
  RenderOptions ro;
  ro.attributes = spec.output.attributes && format_row(spec.output.format).carries_attributes;
  ro.memory_budget = spec.memory_budget;
  ro.time_limit_s = spec.time_limit_s;
  ro.started = started;
  ro.cancel = spec.cancel;
  ro.cull = spec.cull;
  ro.progress = spec.progress;
  ro.keep_screen_triangles = needs_screen(spec.output);
  const Clock::time_point t0 = Clock::now();
  double facts_ms = 0;
  ro.scene_facts = frame_facts(spec, *out.scene, frames_before, started, &facts_ms);
  if (spec.before_render) spec.before_render(ro);
  out.map = renderer.render(*out.scene, out.camera, ro, &out.stats,
                            ro.keep_screen_triangles ? &out.screen : nullptr);
  out.stats.facts_ms = facts_ms;
  out.render_ms = ms_since(t0);
  return out;
}

Frame finish_frame(RenderedFrame rendered, const FrameSpec& spec, FrameEncoder& encoder) {
  const Clock::time_point started = start_of(spec);
  Frame f;
  if (spec.output.draws_lines()) {
    check_before(spec, started, "drawing its lines");
    const Clock::time_point t0 = Clock::now();
    f.lines = extract_lines(rendered.map, rendered.screen, *rendered.scene, rendered.camera,
                            spec.output.lines);
    f.lines_ms = ms_since(t0);
  }
  check_before(spec, started, "encoding");
  const Clock::time_point t0 = Clock::now();
  f.encoded = encoder.encode({rendered.map, rendered.scene, rendered.camera,
                              needs_screen(spec.output) ? &rendered.screen : nullptr,
                              f.lines ? &*f.lines : nullptr});
  f.encode_ms = ms_since(t0);
  f.rendered = std::move(rendered);
  return f;
}

std::shared_ptr<const Scene> dice_for_view(Renderer& renderer, const FrameSpec& spec,
                                           TessellateStats* stats) {
  const std::shared_ptr<const Scene>& scene = spec.scene->scene();
  if (!scene->has_surfaces()) return scene;
  return std::make_shared<const Scene>(
      renderer.tessellate(*scene, spec.camera, dice_options(spec, start_of(spec)), stats));
}

Frame run_frame(Renderer& renderer, const FrameSpec& spec) {
  FrameSpec s = spec;
  s.started = start_of(spec);  // (one limit for both halves)
  const std::unique_ptr<FrameEncoder> encoder = make_encoder(s.output);
  return finish_frame(render_frame(renderer, s), s, *encoder);
}

Camera scene_camera(const Scene& scene, uint32_t width, uint32_t height) {
  if (!scene.camera) return frame_scene(scene, width, height);
  Camera c = *scene.camera;
  c.width = width;
  c.height = height;
  return c;
}

}  // namespace vismap::frame
