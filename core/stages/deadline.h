// A frame's time limit (RenderOptions::time_limit_s, counted from RenderOptions::started) and its
// cancel flag, checked on the host between launches and clip rounds: past the limit the render
// stops with InputError TimeLimit naming the stage; cancelled, with InputError Cancelled.
#pragma once

#include <atomic>
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
  // source: the scene's file, for the message. started: when the limit began (the default: now).
  Deadline(double seconds, std::string source, Clock::time_point started = {},
           const std::atomic<bool>* cancel = nullptr)
      : limited_(seconds > 0),
        seconds_(seconds),
        source_(std::move(source)),
        at_((started == Clock::time_point{} ? Clock::now() : started) +
            std::chrono::duration_cast<Clock::duration>(
                std::chrono::duration<double>(seconds > 0 ? seconds : 0))),
        cancel_(cancel) {}
  void check(Stage stage) const { check_at(std::string("in stage ") + stage_name(stage)); }
  // The same for work outside a stage; `where` ends the message: "(before drawing its lines)".
  void check_at(const std::string& where) const {
    if (cancel_ && cancel_->load(std::memory_order_relaxed))
      throw InputError(InputErrorKind::Cancelled, source_, "", "", -1,
                       "the frame was cancelled (" + where + ")");
    if (!limited_ || Clock::now() <= at_) return;
    char limit[32];
    std::snprintf(limit, sizeof limit, "%g", seconds_);
    throw InputError(InputErrorKind::TimeLimit, source_, "", "", -1,
                     std::string("the frame passed its time limit of ") + limit + " s (" + where +
                         ")");
  }

 private:
  bool limited_ = false;
  double seconds_ = 0;
  std::string source_;
  Clock::time_point at_{};
  const std::atomic<bool>* cancel_ = nullptr;
};

}  // namespace vismap::stages
