// A frame's time limit (RenderOptions::time_limit_s), checked on the host between launches and
// clip rounds: past it the render stops with InputError TimeLimit, naming the stage.
#pragma once

#include <string>

#include "core/clock.h"
#include "core/error.h"
#include "core/stages/stage.h"

namespace vismap::stages {

class Deadline {
 public:
  Deadline() = default;
  explicit Deadline(double seconds)
      : limited_(seconds > 0),
        seconds_(seconds),
        at_(Clock::now() +
            std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(seconds))) {}
  void check(Stage stage) const {
    if (limited_ && Clock::now() > at_)
      throw InputError(InputErrorKind::TimeLimit, "", "", "", -1,
                       "the frame passed its time limit of " + std::to_string(seconds_) +
                           " s (in stage " + stage_name(stage) + ")");
  }

 private:
  bool limited_ = false;
  double seconds_ = 0;
  Clock::time_point at_{};
};

}  // namespace vismap::stages
