#include "core/stages/clip.h"

#include <algorithm>
#include <vector>

namespace vismap::stages {

namespace {

// Passes run per read-back after the first (doubled, up to kMaxPassesPerRead, while a batch
// shrinks the queue less than 4x: a long tail of small queues, as the teapot in its stadium's 90
// rounds, then costs fewer reads); a pass (clip_find and clip_apply: two launches) runs
// VM_CLIP_LEVELS rounds. The queue length lives on the device (VM_CLIP_* state, clip.cl),
// so a batch of passes needs no host decision in between; a pass after the queue has emptied
// costs its launches over a grid of items that leave at once. Measured queues (1024^2): the
// bunny shrinks from 7,650 after round 1 to 0 in 11 more rounds, the teapot in 17, the Cornell
// box with the armadillo in 53 (growing 492 -> 1,420 in rounds 8-16). Two passes (six rounds)
// per read waste at most one pass's launches a frame: on the issue-17 GPU model a read (17 us)
// is three launches (5.5 us), so a longer batch would pay more in idle passes than it saves.
constexpr uint32_t kPassesPerRead = 2, kMaxPassesPerRead = 8;

// Scratch words a pass holds per item: its cuts, its children's offset, each level's finished
// offsets, and the counts of an unfused pass.
constexpr uint64_t kScratchBytes = 4 * (VM_CLIP_NODES + 1 + VM_CLIP_LEVELS + 2);

// Rounds a pass ran, from its counts: level 0 on a non-empty queue, level l > 0 on the
// fragments level l - 1 split (level l's finished, and half of level l + 1's, the last level's
// being the children).
uint32_t rounds_of_pass(uint32_t levels, uint32_t nq, uint32_t children, const uint32_t* done) {
  uint32_t ran = nq > 0, nodes = children;
  for (uint32_t l = levels - 1; l > 0; --l) {
    nodes = done[l] + nodes / 2;
    ran += nodes > 0;
  }
  return ran;
}

struct Queue {
  cl::Buffer meta, lines;
  uint32_t cap = 0;
};

}  // namespace

ClipStatus clip_fragments(ClRuntime& rt, const ScreenSet& s, const cl_int4& region,
                          cl_int clip_region, const Candidates& cand, const ClipEdges& ce,
                          const CullBounds& cull, cl::Buffer& totals, const Deadline& deadline,
                          const RegionBudget& budget,
                          const std::function<void(uint32_t)>& after_round, Fragments& out) {
  // Long on purpose (~175 lines): the queue's two buffers, the device state's two copies and the
  // finished list are one state machine that every round reads, grows and swaps; the lambdas below
  // share it, and the batch loop reads as clip.cl's rounds.
  constexpr Stage kStage = Stage::Clip;
  const uint32_t S = s.count, L = rt.maxl();
  const uint64_t per_fragment = sizeof(VmFragMeta) + uint64_t(L) * sizeof(VmLine);
  const uint64_t before = budget.used(rt);  // everything the region holds besides the fragments
  // Finished fragments are ~1.2 per screen triangle on the bench scenes (bunny 1.17, dragon
  // 1.23): room for 1.25 avoids growing (a copy, and old and new held at once). The floor of
  // 1024 saves small scenes a growth; a budgeted bucket keeps to what it needs.
  uint32_t nq = S, done_cap = std::max<uint32_t>(S + S / 4, budget.limited() ? 16 : 1024);
  if (!budget.allows(before + (uint64_t(S) + done_cap) * per_fragment))
    return ClipStatus::OverBudget;
  auto alloc_queue = [&](uint32_t cap) {
    cap = std::max<uint32_t>(cap, 1);
    return Queue{rt.alloc(size_t(cap) * sizeof(VmFragMeta), "fragment queue"),
                 rt.alloc(size_t(cap) * L * sizeof(VmLine), "fragment lines"), cap};
  };
  // The queue in two buffers: round r reads q[live] and writes q[live ^ 1].
  Queue q[2] = {alloc_queue(S), Queue{}};
  uint32_t live = 0;
  // Two copies of the device-side queue state: round r reads state copy sc, writes sc ^ 1.
  cl::Buffer state = rt.alloc(2 * VM_CLIP_WORDS * 4, "clip queue state");
  uint32_t sc = 0;
  rt.launch(kStage, "frag_init", S, s.tris, S, s.bb, region, clip_region, q[0].meta, q[0].lines,
            state);
  out.meta = rt.alloc(size_t(done_cap) * sizeof(VmFragMeta), "finished fragments");
  out.lines = rt.alloc(size_t(done_cap) * L * sizeof(VmLine), "finished fragment lines");
  out.count = 0;
  out.rounds = 0;
  auto grow_done = [&](uint32_t need) {  // grow the finished list, keeping what it holds
    const uint32_t cap = std::max<uint32_t>(done_cap + done_cap / 2, need);
    cl::Buffer m2 = rt.alloc(size_t(cap) * sizeof(VmFragMeta), "finished fragments");
    cl::Buffer l2 = rt.alloc(size_t(cap) * L * sizeof(VmLine), "finished fragment lines");
    rt.copy(kStage, out.meta, m2, size_t(out.count) * sizeof(VmFragMeta));
    rt.copy(kStage, out.lines, l2, size_t(out.count) * L * sizeof(VmLine));
    out.meta = m2;
    out.lines = l2;
    done_cap = cap;
  };
  cl::Buffer split_at, ncount, dcount, noff, doff, block_sums;
  uint32_t scratch = 0, count_cap = 0;
  // A pass over `grid` items of q[qi], in two halves: find (the cuts and, for a grid of at
  // most VM_CLIP_FUSED_MAX, each work-group's scan of its counts; above, one level, its counts
  // scanned into totals by two scans; returns the levels) and apply, which writes the children
  // to q[qi ^ 1] if they fit next_grid (else the passes stop, clip.cl). resume: run even though
  // the state says stopped (the host made room).
  auto find = [&](uint32_t qi, uint32_t grid, cl_uint resume) {
    // Under a budget: this pass's, as it needs; else reused while it is at most 4x the grid
    // (the first pass's, sized for every screen triangle, is not kept for the small ones).
    const cl_uint fused = grid <= VM_CLIP_FUSED_MAX;
    const cl_uint levels = fused ? VM_CLIP_LEVELS : 1;
    if (grid > scratch || budget.limited() || grid < scratch / 4) {
      const size_t groups = (size_t(grid) + VM_SCAN_WG - 1) / VM_SCAN_WG;
      split_at = rt.alloc(size_t(grid) * VM_CLIP_NODES * 4, "split edges");
      noff = rt.alloc(size_t(grid) * 4, "queue offsets");
      doff = rt.alloc(size_t(grid) * VM_CLIP_LEVELS * 4, "done offsets");
      block_sums = rt.alloc(groups * VM_CLIP_COUNTS * 4, "clip group totals");
      scratch = grid;
    }
    if (!fused && (count_cap < grid || budget.limited())) {
      ncount = rt.alloc(size_t(grid) * 4, "queue counts");
      dcount = rt.alloc(size_t(grid) * 4, "done counts");
      count_cap = grid;
    }
    rt.launch_grouped(kStage, "clip_find", grid, VM_SCAN_WG, q[qi].meta, q[qi].lines, grid, state,
                      sc, resume, fused, levels, cand.offset, cand.count, cand.list, ce.edges,
                      split_at, fused ? noff : ncount, fused ? doff : dcount, block_sums, totals,
                      s.tris, cull.grid, cull.tile_leaf, cull.leaf_cull, cl_int(cull.on ? 1 : 0));
    if (!fused) {
      rt.scan_to(kStage, ncount, noff, grid, totals, VM_TOTAL_NEXT);
      rt.scan_to(kStage, dcount, doff, grid, totals, VM_TOTAL_DONE);
    }
    return levels;
  };
  auto apply = [&](uint32_t qi, uint32_t grid, uint32_t next_grid, cl_uint resume, cl_uint levels) {
    const cl_uint fused = grid <= VM_CLIP_FUSED_MAX;  // as find's
    rt.launch_grouped(kStage, "clip_apply", grid, VM_SCAN_WG, q[qi].meta, q[qi].lines, grid, state,
                      sc, resume, fused, levels, totals, block_sums, next_grid, done_cap,
                      cand.offset, cand.list, ce.edges, split_at, noff, doff, q[qi ^ 1].meta,
                      q[qi ^ 1].lines, out.meta, out.lines);
    sc ^= 1;
  };
  auto check_status = [](const uint32_t* tot) {
    if (tot[VM_TOTAL_STATUS] & VM_STATUS_HASH_FULL) throw DeviceError("edge hash table full");
    return (tot[VM_TOTAL_STATUS] & VM_STATUS_LINES_OVERFLOW) == 0;
  };
  bool resume = false;  // the passes stopped for room, which the next (exact) pass makes
  // A batch's grid is `growth` times the queue it starts from: 4, doubled (up to 16) each time
  // the children outgrew it (a pass of three rounds can grow the queue 8x; a folded surface's
  // grows 1.5x a round).
  uint32_t growth = 4;
  uint32_t passes = 0;  // that ran on a non-empty queue (VM_CLIP_PASSES): each swaps the queue
  uint32_t batch = kPassesPerRead;  // passes the next batch runs
  while (nq > 0) {
    deadline.check(kStage);
    // An exact pass (the first, every pass under a budget, after a stop) reads its counts
    // before placing its children and sizes the next queue from them; otherwise a batch runs
    // `batch` passes over a grid of `growth` times the queue it starts from (the queue
    // shrinks on the bench scenes after the first round; it may grow up to the grid), read back
    // once.
    const uint32_t room = std::min(q[0].cap, q[1].cap);
    if (passes == 0 || budget.limited() || resume || room < nq) {
      const cl_uint levels = find(live, nq, resume);
      uint32_t tot[VM_TOTAL_SLOTS];
      uint32_t nn = 0, dn = 0, done[VM_CLIP_LEVELS] = {};
      if (nq <= VM_CLIP_FUSED_MAX) {  // fused: the pass's counts are its groups' totals
        std::vector<uint32_t> sums(VM_CLIP_COUNTS * ((size_t(nq) + VM_SCAN_WG - 1) / VM_SCAN_WG));
        rt.read_async(kStage, totals, 0, sizeof tot, tot);
        rt.read(kStage, block_sums, 0, sums.size() * 4, sums.data());
        for (size_t g = 0; g < sums.size(); g += VM_CLIP_COUNTS) {
          nn += sums[g];
          for (uint32_t l = 0; l < VM_CLIP_LEVELS; ++l) done[l] += sums[g + 1 + l];
        }
      } else {
        rt.read(kStage, totals, 0, sizeof tot, tot);
        nn = tot[VM_TOTAL_NEXT];
        done[0] = tot[VM_TOTAL_DONE];
      }
      for (uint32_t d : done) dn += d;
      if (!check_status(tot)) return ClipStatus::LinesOverflow;
      const bool grow = uint64_t(out.count) + dn > done_cap;
      const uint32_t cap = grow ? std::max<uint32_t>(done_cap + done_cap / 2, out.count + dn) : 0;
      // Held at once: the finished list (old and new while it grows), this pass's queue and
      // its scratch, and the next pass's queue.
      const uint64_t held =
          before + (uint64_t(done_cap) + cap + nq + nn) * per_fragment + kScratchBytes * nq;
      if (!budget.allows(held)) return ClipStatus::OverBudget;
      if (grow) grow_done(out.count + dn);
      Queue& next = q[live ^ 1];
      // Under a budget the next queue is what it needs; otherwise room for a batch to grow.
      if (budget.limited() || next.cap < nn)
        next = alloc_queue(budget.limited()
                               ? nn
                               : uint32_t(std::min<uint64_t>(growth * uint64_t(nn), UINT32_MAX)));
      apply(live, nq, next.cap, resume, levels);  // cannot stop: the host made room for it
      out.count += dn;
      out.rounds += rounds_of_pass(levels, nq, nn, done);
      ++passes;
      nq = nn;
      live ^= 1;
      resume = false;
      // The queue just read is free: resized to room for a batch (the root queue, one slot per
      // screen triangle, is mostly far too big for the rounds after the first).
      Queue& spare = q[live ^ 1];
      const uint64_t want = growth * uint64_t(nn);
      if (!budget.limited() && (spare.cap < want || spare.cap > 4 * want))
        spare = alloc_queue(uint32_t(std::min<uint64_t>(want, UINT32_MAX)));
    } else {
      const uint32_t grid = uint32_t(std::min<uint64_t>(growth * uint64_t(nq), room));
      // Room in the finished list for one fragment an item a pass (at most 2^(levels - 1) = 4):
      // a batch that fills the list stops, and costs its launches, a read and an exact pass to
      // go on (the Cornell box with the armadillo finishes 2.4 fragments a screen triangle,
      // against the 1.25 the list starts with); a growth is a copy (two launches).
      const uint64_t reserve = uint64_t(out.count) + uint64_t(batch) * nq;
      if (reserve > done_cap) grow_done(uint32_t(std::min<uint64_t>(reserve, UINT32_MAX)));
      const uint32_t nq_before = nq;
      for (uint32_t p = 0; p < batch; ++p) {
        const cl_uint levels = find(live ^ (p & 1), grid, 0);
        apply(live ^ (p & 1), grid, grid, 0, levels);
      }
      uint32_t tot[VM_TOTAL_SLOTS], st[VM_CLIP_WORDS];
      rt.read_async(kStage, totals, 0, sizeof tot, tot);
      rt.read(kStage, state, size_t(sc) * VM_CLIP_WORDS * 4, sizeof st, st);
      if (!check_status(tot)) return ClipStatus::LinesOverflow;
      live ^= (st[VM_CLIP_PASSES] - passes) & 1;
      passes = st[VM_CLIP_PASSES];
      out.rounds = st[VM_CLIP_ROUNDS];
      out.count = st[VM_CLIP_DONE];
      nq = st[VM_CLIP_NQ];
      resume = st[VM_CLIP_STOP] != 0;
      if (st[VM_CLIP_STOP] == VM_CLIP_STOP_QUEUE) growth = std::min<uint32_t>(growth * 2, 16);
      batch =
          uint64_t(nq) * 4 > nq_before ? std::min(2 * batch, kMaxPassesPerRead) : kPassesPerRead;
    }
    if (after_round) after_round(out.rounds);
  }
  // What occlusion and emit add: two words per fragment, and at most a copy of each.
  const uint64_t after = before + uint64_t(done_cap) * per_fragment;
  if (!budget.allows(after + uint64_t(out.count) * (8 + per_fragment)))
    return ClipStatus::OverBudget;
  return ClipStatus::Done;
}

}  // namespace vismap::stages
