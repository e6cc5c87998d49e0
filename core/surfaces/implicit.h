// Stage implicit (kernels/implicit.cl, docs/IMPLICIT.md): MPR's region queue for an implicit
// surface's tape. Rounds of interval evaluation over boxes, each ambiguous box's tape shortened
// (MPR §4: min/max clauses decided over the box become copies of their winner) and handed to its
// children; full and empty boxes leave the queue. Count, scan, allocate, fill: every buffer is
// sized from the previous round's counts.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <vector>

#include "core/device/cl_runtime.h"
#include "core/implicit/implicit.h"

namespace vismap::surfaces {

struct ImplicitRound {
  uint64_t regions = 0, full = 0, empty = 0, ambiguous = 0;
  uint64_t culled = 0;  // regions wholly outside one of the planes (they leave as if empty)
  uint64_t clauses = 0;  // clauses evaluated in the round (sum of the regions' tape lengths)
  uint64_t leaves = 0;   // ambiguous regions that became leaves (the rest split)
  uint64_t occluded = 0;  // regions hidden behind full boxes (they leave as if empty)
};

// A 3D queue's occlusion (docs/IMPLICIT.md "Hidden regions"): the depth image (width x height
// words, float bits, +inf where nothing covers; kept for the caller) and its mapping. Each
// round's full boxes beyond the near plane are drawn into it; a region whose box, grown by twice
// the leaf side at its farthest depth, lies behind it wherever it projects leaves the queue.
// Only where every ray of the view starts outside the solid (the caller proves it).
struct ImplicitOcclusion {
  VmIOcclusion map{};
  cl::Buffer image;
};

// The depth image's bytes with its pyramid (level k + 1 the greatest of each 2 x 2 of level k,
// down to 1 x 1; kernels/implicit.cl vm_mip_off), and level 0's texel count.
inline uint64_t occlusion_bytes(const VmIOcclusion& m) {
  uint64_t n = 0;
  for (int k = 0;; ++k) {
    const uint64_t w = (uint64_t(m.width) + (uint64_t(1) << k) - 1) >> k;
    const uint64_t h = (uint64_t(m.height) + (uint64_t(1) << k) - 1) >> k;
    n += w * h;
    if (w == 1 && h == 1) return 4 * n;
  }
}

// The most a region queue may hold where no memory budget says less (3D dicing and the 2D mode).
inline constexpr uint64_t kMaxImplicitQueueBytes = uint64_t(4) << 30;

// The queue's cap for a frame's memory budget (0: none): the budget, at most the above.
inline uint64_t implicit_queue_cap(uint64_t memory_budget) {
  return memory_budget && memory_budget < kMaxImplicitQueueBytes ? memory_budget
                                                                  : kMaxImplicitQueueBytes;
}

struct ImplicitQueue {
  // The leaves (ambiguous regions that split no further), each with its shortened tape (a slice
  // of pool: VmIRegion::tape_off / tape_len in clauses of 4 words), in the order of their rounds.
  std::vector<VmIRegion> leaves;
  std::vector<uint32_t> pool;  // 4 words per clause, as SlotTape::code
  std::vector<ImplicitRound> rounds;
  uint32_t launches = 0, host_syncs = 0;
};

// The box [lo, lo + size] in `dims` (2: z fixed at lo[2]; 3) as one region, then one round per
// entry of `splits` (each ambiguous region split splits[i] ways per axis), then a last round
// whose ambiguous regions are all leaves. With a `view` (3D frames), an ambiguous region becomes
// a leaf in an earlier round once it is small enough for its depth (VmIView), so leaves have the
// sides of several rounds; the last round's leaves must be (else TooLarge). Without one, only the
// last round has leaves. Throws InputError TooLarge when a round's buffers would pass `max_bytes`
// (0: no cap), naming the round. `planes` (a, b, c, d; empty: none): a region with
// a x + b y + c z + d < 0 over its whole box, by more than twice the leaf side at its farthest
// depth, is culled (3D frames: the view's planes in the expression's space), so only what the
// frame can see is split further. check_time (when given) runs after each round's counts are
// read: it throws past the frame's time limit, so one long dice stops within a round of it.
ImplicitQueue run_implicit_queue(ClRuntime& rt, const implicit::SlotTape& tape, const float lo[3],
                                 float size, uint32_t dims, const std::vector<uint32_t>& splits,
                                 uint64_t max_bytes = 0,
                                 const std::vector<std::array<float, 4>>& planes = {},
                                 const std::function<void()>& check_time = {},
                                 const VmIView* view = nullptr,
                                 const ImplicitOcclusion* occlusion = nullptr);

// Plain evaluation on the device of each leaf's tape at its points (m per leaf, xyz per point),
// in batches that keep the scratch under 256 MiB; the launches made are added to *launches.
// check_time (when given) runs after each batch.
std::vector<float> eval_leaf_points(ClRuntime& rt, const implicit::SlotTape& tape,
                                    const ImplicitQueue& q, const std::vector<float>& xyz,
                                    uint32_t m, uint32_t* launches = nullptr,
                                    const std::function<void()>& check_time = {});

}  // namespace vismap::surfaces
