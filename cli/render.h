// `vismap render`: its flags (RenderArgs), the command, and what --stats prints.
#pragma once

#include <array>
#include <optional>
#include <string>

#include "cli/args.h"
#include "core/frame/frame.h"
#include "core/frame/implicit_2d.h"

namespace vismap::cli {

struct RenderArgs {
  std::string scene, out;
  ViewArgs view;
  frame::OutputSpec output;   // format, fill, coding, style, lines
  bool format_given = false;  // --format (else OUT's extension)
  bool stats = false;
  bool cull = true;    // --no-cull: clip every triangle in view (FrameSpec::cull)
  bool facts = false;  // --scene-facts: FactsPolicy Now (else Repeat: none in one frame)
  uint64_t memory_budget = 0;
  double time_limit_s = 0;
  std::optional<std::array<double, 4>> bounds;  // 2D implicit: the window X0,Y0,X1,Y1
};

RenderArgs parse_render(int argc, char** argv);  // throws UsageError
int cmd_render(int argc, char** argv);

// What `render --stats` prints: everything a frame measured, once the output is written.
struct RenderReport {
  const RenderArgs& args;
  const DeviceInfo& device;
  const frame::Frame& frame;
  uint64_t dropped_degenerate = 0;
  double load_ms = 0, total_ms = 0;
};
void print_render_stats(const RenderReport& r);
void print_implicit_2d_stats(const DeviceInfo& device, const implicit::Tape& tape,
                             const frame::Frame2D& f, double load_ms, double device_ms);

}  // namespace vismap::cli
