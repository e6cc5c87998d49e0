// A frame's time limit (RenderOptions::time_limit_s), checked on the host between launches and
// clip rounds: past it the render stops with InputError TimeLimit, naming the stage.
#pragma once

#include <cstdio>
#include <string>
#include <utility>

#include "core/device/stage.h"
#include "core/error.h"
#include "core/util/clock.h"

namespace vismap::stages {

class Deadline {
 public:
  Deadline() = default;
  // source: the scene's file, for the message.
  Deadline(double seconds, std::string source)
      : limited_(seconds > 0),
        seconds_(seconds),
        source_(std::move(source)),
        at_(Clock::now() + std::chrono::duration_cast<Clock::duration>(
                               std::chrono::duration<double>(seconds > 0 ? seconds : 0))) {}
  void check(Stage stage) const {
    if (!limited_ || Clock::now() <= at_) return;
    char limit[32];
    std::snprintf(limit, sizeof limit, "%g", seconds_);
    throw InputError(InputErrorKind::TimeLimit, source_, "", "", -1,
                     std::string("the frame passed its time limit of ") + limit + " s (in stage " +
                         stage_name(stage) + ")");
  }

 private:
  bool limited_ = false;
  double seconds_ = 0;
  std::string source_;
  Clock::time_point at_{};
};

}  // namespace vismap::stages
