// A region's share of --memory-budget (RenderOptions::memory_budget), checked by the stages
// whose output size is only known once counted (crossing pairs and entries, candidates, clip
// fragments): before allocating, a stage asks whether the region would pass its budget, and if
// so stops with a status; the pipeline then halves the region (a bucket) and renders the halves,
// or, for a region of one 16-px cell, fails the frame with InputError TooLarge. Nothing is
// dropped. Bytes are counted from the sizes allocated since the region began (an upper bound of
// what it holds, and deterministic: the same scene and budget always split the same way).
#pragma once

#include <cstdint>

#include "core/device/cl_runtime.h"
#include "core/util/format.h"

namespace vismap::stages {

class RegionBudget {
 public:
  RegionBudget() = default;  // no limit
  RegionBudget(const ClRuntime& rt, uint64_t limit) : limit_(limit), base_(rt.allocated_bytes()) {}

  bool limited() const { return limit_ != 0; }
  uint64_t limit() const { return limit_; }
  // Bytes allocated for the region so far.
  uint64_t used(const ClRuntime& rt) const { return rt.allocated_bytes() - base_; }
  // Whether `held` bytes in all fit. On false, `needed` records them (the largest seen).
  bool allows(uint64_t held) const {
    if (limit_ == 0 || held <= limit_) return true;
    if (held > needed_) needed_ = held;
    return false;
  }
  // Whether allocating `more` bytes now keeps the region within its budget.
  bool allows_more(const ClRuntime& rt, uint64_t more) const { return allows(used(rt) + more); }
  // The same for something the region can do without (the cull): nothing recorded in needed().
  bool fits_more(const ClRuntime& rt, uint64_t more) const {
    return limit_ == 0 || used(rt) + more <= limit_;
  }
  // Allocations since `mark` (a used() value) are freed and will not be held again (a stage run
  // again from there, e.g. the clipping after a rebuild with more lines).
  void forget_since(const ClRuntime& rt, uint64_t mark) { base_ += used(rt) - mark; }
  // What the region would have needed where a stage stopped (0 if none did).
  uint64_t needed() const { return needed_; }

 private:
  uint64_t limit_ = 0, base_ = 0;
  mutable uint64_t needed_ = 0;
};

}  // namespace vismap::stages
