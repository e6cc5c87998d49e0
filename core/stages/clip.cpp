#include "core/stages/clip.h"

#include <algorithm>

namespace vismap::stages {

ClipStatus clip_fragments(ClRuntime& rt, const ScreenSet& s, const cl_int4& region,
                          cl_int clip_region, const Candidates& cand, const ClipEdges& ce,
                          cl::Buffer& totals, const Deadline& deadline, const RegionBudget& budget,
                          const std::function<void(uint32_t)>& after_round, Fragments& out) {
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
  cl::Buffer qmeta = rt.alloc(size_t(S) * sizeof(VmFragMeta), "fragment queue");
  cl::Buffer qlines = rt.alloc(size_t(S) * L * sizeof(VmLine), "fragment lines");
  rt.launch(kStage, "frag_init", S, s.tris, S, region, clip_region, qmeta, qlines);
  out.meta = rt.alloc(size_t(done_cap) * sizeof(VmFragMeta), "finished fragments");
  out.lines = rt.alloc(size_t(done_cap) * L * sizeof(VmLine), "finished fragment lines");
  out.count = 0;
  out.rounds = 0;
  while (nq > 0) {
    deadline.check(kStage);
    ++out.rounds;
    cl::Buffer split_at = rt.alloc(size_t(nq) * 4, "split edges");
    cl::Buffer ncount = rt.alloc(size_t(nq) * 4, "queue counts");
    cl::Buffer dcount = rt.alloc(size_t(nq) * 4, "done counts");
    cl::Buffer noff = rt.alloc(size_t(nq) * 4, "queue offsets");
    cl::Buffer doff = rt.alloc(size_t(nq) * 4, "done offsets");
    rt.launch(kStage, "clip_find", nq, qmeta, qlines, nq, cand.offset, cand.count, cand.list,
              ce.edges, split_at, ncount, dcount, totals);
    rt.scan_to(kStage, ncount, noff, nq, totals, VM_TOTAL_NEXT);
    rt.scan_to(kStage, dcount, doff, nq, totals, VM_TOTAL_DONE);
    uint32_t tot[VM_TOTAL_SLOTS];
    rt.read(kStage, totals, 0, sizeof tot, tot);
    if (tot[VM_TOTAL_STATUS] & VM_STATUS_LINES_OVERFLOW) return ClipStatus::LinesOverflow;
    if (tot[VM_TOTAL_STATUS] & VM_STATUS_HASH_FULL) throw DeviceError("edge hash table full");
    const uint32_t nn = tot[VM_TOTAL_NEXT], dn = tot[VM_TOTAL_DONE];
    const uint32_t cap = uint64_t(out.count) + dn > done_cap
                             ? std::max<uint32_t>(done_cap + done_cap / 2, out.count + dn)
                             : 0;
    // Held at once: the finished list (old and new while it grows), this round's queue and its
    // five words per item, and the next round's queue.
    const uint64_t held = before + (uint64_t(done_cap) + cap + nq + nn) * per_fragment + 20ull * nq;
    if (!budget.allows(held)) return ClipStatus::OverBudget;
    if (cap) {  // grow the finished list, keeping what it holds
      cl::Buffer m2 = rt.alloc(size_t(cap) * sizeof(VmFragMeta), "finished fragments");
      cl::Buffer l2 = rt.alloc(size_t(cap) * L * sizeof(VmLine), "finished fragment lines");
      if (out.count) {
        rt.copy(kStage, out.meta, m2, size_t(out.count) * sizeof(VmFragMeta));
        rt.copy(kStage, out.lines, l2, size_t(out.count) * L * sizeof(VmLine));
      }
      out.meta = m2;
      out.lines = l2;
      done_cap = cap;
    }
    cl::Buffer nmeta = rt.alloc(std::max<size_t>(nn, 1) * sizeof(VmFragMeta), "fragment queue");
    cl::Buffer nlines = rt.alloc(std::max<size_t>(nn, 1) * L * sizeof(VmLine), "fragment lines");
    rt.launch(kStage, "clip_apply", nq, qmeta, qlines, nq, cand.offset, cand.list, ce.edges,
              split_at, noff, doff, out.count, nmeta, nlines, out.meta, out.lines);
    out.count += dn;
    nq = nn;
    qmeta = nmeta;
    qlines = nlines;
    if (after_round) after_round(out.rounds);
  }
  // What occlusion and emit add: two words per fragment, and at most a copy of each.
  const uint64_t after = before + uint64_t(done_cap) * per_fragment;
  if (!budget.allows(after + uint64_t(out.count) * (8 + per_fragment)))
    return ClipStatus::OverBudget;
  return ClipStatus::Done;
}

}  // namespace vismap::stages
