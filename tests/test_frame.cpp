// The front door (core/frame/): one FrameSpec, one run_frame, for every caller. The format table
// and the CLI agree; a frame's bytes are the writer's; the time limit is one budget for the whole
// frame and the cancel flag stops it; a scene's facts are found once and shared by its frames.
#include <gtest/gtest.h>

#include <atomic>
#include <thread>

#include "core/error.h"
#include "core/frame/frame.h"
#include "core/write/output.h"
#include "tests/support/triangle_scene.h"

namespace {

using namespace vismap;

Renderer& renderer() {
  static Renderer r;
  return r;
}

std::shared_ptr<const Scene> bunny() {
  static auto s = std::make_shared<const Scene>(load_scene(VISMAP_SOURCE_DIR "/data/bunny.ply"));
  return s;
}

frame::FrameSpec bunny_spec(frame::OutputFormat format) {
  frame::FrameSpec spec;
  spec.scene = std::make_shared<frame::SceneState>(bunny());
  spec.camera = frame::scene_camera(*bunny(), 256, 256);
  fit_near_far(spec.camera, *bunny());
  spec.output.format = format;
  return spec;
}

TEST(Frame, FormatTableNamesEveryFormatOnce) {
  for (const frame::FormatRow& r : frame::kFormats) {
    EXPECT_EQ(frame::format_named(r.name), r.format) << r.name;
    if (r.extension) {
      EXPECT_EQ(frame::format_of_path(std::string("x") + r.extension), r.format) << r.name;
    }
  }
  EXPECT_EQ(frame::format_of_path("X.SVG"), frame::OutputFormat::Svg);
  EXPECT_EQ(frame::format_of_path("frame.vmc"), frame::OutputFormat::Compact);
  EXPECT_FALSE(frame::format_of_path("frame.delta"));
  EXPECT_FALSE(frame::format_named("jpeg"));
  EXPECT_EQ(frame::file_format_names(), "svg, pdf, eps, png, bin or compact");
  EXPECT_EQ(frame::file_format_extensions(), ".svg .pdf .eps .png .bin .vmc");
}

// run_frame's bytes are the writer's on the renderer's own map: the front door adds nothing.
TEST(Frame, BytesAreTheWritersOnTheSameMap) {
  const frame::Frame f = frame::run_frame(renderer(), bunny_spec(frame::OutputFormat::Svg));
  RenderOptions ro;
  const PlanarMap map = renderer().render(*bunny(), f.rendered.camera, ro);
  EXPECT_EQ(f.encoded.bytes, write_svg(map, *bunny(), f.rendered.camera, Fill::Shade));
  EXPECT_GT(f.rendered.map.fragment_count(), 100u);
  EXPECT_FALSE(f.lines);

  frame::FrameSpec lines = bunny_spec(frame::OutputFormat::Bin);
  lines.output.style = frame::DrawStyle::FillLines;
  const frame::Frame g = frame::run_frame(renderer(), lines);
  ASSERT_TRUE(g.lines);
  EXPECT_GT(g.lines->chain_count(), 0u);
  EXPECT_EQ(g.encoded.header.value("line_chains", size_t(0)), g.lines->chain_count());
  const BinFrame b = read_bin(g.encoded.bytes);
  EXPECT_TRUE(b.has_lines);
  EXPECT_EQ(b.lines.chain_count(), g.lines->chain_count());
}

// A stream's encoder is kept from frame to frame: a delta stream's second frame of the same view
// codes against the first. (Version 1: a version 2 stream whose client holds nothing sends these
// frames as their smaller compact frames, leaving the client's state alone.)
TEST(Frame, AStreamsEncoderKeepsItsState) {
  frame::FrameSpec spec = bunny_spec(frame::OutputFormat::Delta);
  spec.output.delta_version = 1;
  const auto enc = frame::make_encoder(spec.output);
  const frame::Frame a = frame::finish_frame(frame::render_frame(renderer(), spec), spec, *enc);
  const frame::Frame b = frame::finish_frame(frame::render_frame(renderer(), spec), spec, *enc);
  EXPECT_TRUE(a.encoded.header.value("keyframe", false));
  EXPECT_FALSE(b.encoded.header.value("keyframe", true));
  EXPECT_LT(b.encoded.bytes.size(), a.encoded.bytes.size());
  EXPECT_GT(enc->state_bytes(), 0u);
}

// One budget for the whole frame, counted from `started`: a frame whose limit was spent before
// it began (as the CLI counts the load) stops at its first check and names the whole limit.
TEST(Frame, TheTimeLimitCountsFromWhenTheFrameBegan) {
  frame::FrameSpec spec = bunny_spec(frame::OutputFormat::Svg);
  spec.time_limit_s = 0.5;
  spec.started = Clock::now() - std::chrono::seconds(1);
  try {
    (void)frame::run_frame(renderer(), spec);
    FAIL() << "a frame past its limit rendered";
  } catch (const InputError& e) {
    EXPECT_EQ(e.kind(), InputErrorKind::TimeLimit);
    EXPECT_NE(std::string(e.what()).find("time limit of 0.5 s"), std::string::npos) << e.what();
  }
  spec.started = Clock::now();
  spec.time_limit_s = 600;
  EXPECT_NO_THROW((void)frame::run_frame(renderer(), spec));
}

// The lines and the encoder do not start past the limit: the render's part ends within it, the
// rest is refused.
TEST(Frame, LinesDoNotStartPastTheLimit) {
  frame::FrameSpec spec = bunny_spec(frame::OutputFormat::Svg);
  spec.output.style = frame::DrawStyle::Lines;
  spec.time_limit_s = 30;
  spec.started = Clock::now();
  frame::RenderedFrame r = frame::render_frame(renderer(), spec);
  spec.started = Clock::now() - std::chrono::seconds(31);
  const auto enc = frame::make_encoder(spec.output);
  try {
    (void)frame::finish_frame(std::move(r), spec, *enc);
    FAIL() << "lines drawn past the limit";
  } catch (const InputError& e) {
    EXPECT_EQ(e.kind(), InputErrorKind::TimeLimit);
    EXPECT_NE(std::string(e.what()).find("before drawing its lines"), std::string::npos)
        << e.what();
  }
}

// The cancel flag stops the frame at its next check; the renderer is usable at once after.
TEST(Frame, CancelStopsTheFrame) {
  frame::FrameSpec spec = bunny_spec(frame::OutputFormat::Svg);
  std::atomic<bool> cancel{true};
  spec.cancel = &cancel;
  try {
    (void)frame::run_frame(renderer(), spec);
    FAIL() << "a cancelled frame rendered";
  } catch (const InputError& e) {
    EXPECT_EQ(e.kind(), InputErrorKind::Cancelled);
    EXPECT_STREQ(to_string(e.kind()), "cancelled");
  }
  cancel = false;
  EXPECT_GT(frame::run_frame(renderer(), spec).rendered.map.fragment_count(), 100u);
}

// The facts are the scene state's: found once (Now, or Repeat from the second frame), then given
// to every frame of that scene; Found takes them only once someone found them; the map is the
// same with them or without.
TEST(Frame, FactsAreFoundOncePerSceneAndShared) {
  frame::FrameSpec spec = bunny_spec(frame::OutputFormat::Bin);
  spec.facts = frame::FactsPolicy::Found;
  const frame::Frame none = frame::run_frame(renderer(), spec);
  EXPECT_FALSE(none.rendered.stats.has_facts);
  EXPECT_FALSE(spec.scene->facts());

  spec.facts = frame::FactsPolicy::Repeat;
  const frame::Frame first = frame::run_frame(renderer(), spec);  // (the state's second frame)
  EXPECT_TRUE(first.rendered.stats.has_facts);
  const auto found = spec.scene->facts();
  ASSERT_TRUE(found);
  const frame::Frame again = frame::run_frame(renderer(), spec);
  EXPECT_EQ(spec.scene->facts(), found);  // (not found again)
  EXPECT_EQ(again.rendered.stats.facts_ms, 0);
  EXPECT_EQ(none.encoded.bytes, again.encoded.bytes);

  frame::FrameSpec single = bunny_spec(frame::OutputFormat::Bin);  // a new scene state
  EXPECT_FALSE(frame::run_frame(renderer(), single).rendered.stats.has_facts);  // Repeat, 1st
  single.facts = frame::FactsPolicy::Off;
  EXPECT_FALSE(frame::run_frame(renderer(), single).rendered.stats.has_facts);
}

}  // namespace
