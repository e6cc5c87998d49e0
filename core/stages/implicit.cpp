#include "core/stages/implicit.h"

#include <algorithm>

#include "core/error.h"

namespace vismap::stages {

namespace {

void check_bytes(uint64_t bytes, uint64_t max_bytes, size_t round) {
  if (max_bytes && bytes > max_bytes)
    throw InputError(InputErrorKind::TooLarge, "", "", "implicit round", int64_t(round),
                     "needs " + std::to_string(bytes) + " bytes of device memory, over the cap of " +
                         std::to_string(max_bytes));
}

}  // namespace

ImplicitQueue run_implicit_queue(ClRuntime& rt, const implicit::SlotTape& tape, const float lo[3],
                                 float size, uint32_t dims, const std::vector<uint32_t>& splits,
                                 uint64_t max_bytes) {
  ImplicitQueue q;
  const uint32_t syncs0 = rt.host_syncs();
  const uint32_t slots = std::max<uint32_t>(tape.slots, 1), maxlen = uint32_t(tape.size());
  VmIRegion root{};
  for (int k = 0; k < 3; ++k) root.lo[k] = lo[k];
  root.size = size;
  root.tape_off = 0;
  root.tape_len = maxlen;
  cl::Buffer regions = rt.upload(std::vector<VmIRegion>{root}, "implicit regions");
  cl::Buffer pool = rt.upload(tape.code, "implicit tape");
  uint32_t n = 1;
  uint64_t clauses = maxlen;
  cl::Buffer totals = rt.alloc(VM_ITOTAL_SLOTS * sizeof(cl_uint), "implicit totals");
  for (size_t round = 0; round <= splits.size() && n > 0; ++round) {
    const bool last = round == splits.size();
    const uint32_t split = last ? 1 : splits[round];
    // Per region: slots of intervals and of liveness, a choice byte per clause, the result.
    check_bytes(uint64_t(n) * (slots * 9ull + maxlen + 8 + 12), max_bytes, round);
    cl::Buffer scratch = rt.alloc(size_t(n) * slots * sizeof(cl_float2), "implicit slots");
    cl::Buffer live = rt.alloc(size_t(n) * slots, "implicit liveness");
    cl::Buffer choices = rt.alloc(size_t(n) * maxlen, "implicit choices");
    cl::Buffer result = rt.alloc(size_t(n) * sizeof(cl_float2), "implicit results");
    cl::Buffer counts = rt.alloc(size_t(n) * sizeof(cl_uint), "implicit tape counts");
    cl::Buffer offsets = rt.alloc(size_t(n) * sizeof(cl_uint), "implicit tape offsets");
    cl::Buffer amb = rt.alloc(size_t(n) * sizeof(cl_uint), "implicit ambiguous");
    cl::Buffer amb_off = rt.alloc(size_t(n) * sizeof(cl_uint), "implicit ambiguous offsets");
    rt.fill_u32(totals, 0, VM_ITOTAL_SLOTS, Stage::Implicit);
    rt.launch(Stage::Implicit, "implicit_intervals", n, regions, n, pool, scratch, slots,
              tape.root_slot, choices, maxlen, result, totals);
    rt.launch(Stage::Implicit, "implicit_shorten_count", n, regions, n, pool, choices, maxlen,
              result, live, slots, tape.root_slot, counts, amb);
    const uint32_t pool_next = rt.scan(Stage::Implicit, counts, offsets, n);
    const uint32_t namb = rt.scan(Stage::Implicit, amb, amb_off, n);
    cl_uint tot[VM_ITOTAL_SLOTS];
    rt.read(Stage::Implicit, totals, 0, sizeof tot, tot);
    ImplicitRound r;
    r.regions = n;
    r.full = tot[VM_ITOTAL_FULL];
    r.empty = tot[VM_ITOTAL_EMPTY];
    r.ambiguous = namb;
    r.clauses = clauses;
    q.rounds.push_back(r);
    const uint32_t per = split == 1 ? 1 : (dims == 3 ? split * split * split : split * split);
    const uint64_t next_n = uint64_t(namb) * per;
    if (next_n > 0xffffffffull || pool_next == 0xffffffffu)
      throw InputError(InputErrorKind::TooLarge, "", "", "implicit round", int64_t(round),
                       "more than 2^32 regions");
    check_bytes(uint64_t(pool_next) * sizeof(VmIClause) + next_n * sizeof(VmIRegion), max_bytes,
                round);
    cl::Buffer next_pool = rt.alloc(std::max<size_t>(pool_next, 1) * sizeof(VmIClause),
                                    "implicit tape pool");
    cl::Buffer next = rt.alloc(std::max<size_t>(next_n, 1) * sizeof(VmIRegion), "implicit regions");
    rt.launch(Stage::Implicit, "implicit_shorten_fill", n, regions, n, pool, choices, maxlen,
              result, live, slots, tape.root_slot, counts, offsets, amb_off, next_pool, next,
              split, dims);
    regions = next;
    pool = next_pool;
    n = uint32_t(next_n);
    clauses = uint64_t(pool_next) * per;
    if (last) {
      q.leaves.resize(n);
      q.pool.resize(size_t(pool_next) * 4);
      if (n) rt.read_async(Stage::Implicit, regions, 0, n * sizeof(VmIRegion), q.leaves.data());
      if (pool_next)
        rt.read(Stage::Implicit, pool, 0, size_t(pool_next) * sizeof(VmIClause), q.pool.data());
    }
  }
  q.host_syncs = rt.host_syncs() - syncs0;
  return q;
}

std::vector<float> eval_leaf_points(ClRuntime& rt, const implicit::SlotTape& tape,
                                    const ImplicitQueue& q, const std::vector<float>& xyz,
                                    uint32_t m) {
  const uint32_t n = uint32_t(q.leaves.size());
  std::vector<float> out(size_t(n) * m);
  if (n == 0 || m == 0) return out;
  std::vector<cl_float4> pts(size_t(n) * m);
  for (size_t i = 0; i < pts.size(); ++i)
    pts[i] = cl_float4{{xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2], 0.f}};
  cl::Buffer reg = rt.upload(q.leaves, "implicit leaves");
  cl::Buffer pool = rt.upload(q.pool, "implicit leaf tapes");
  cl::Buffer p = rt.upload(pts, "implicit points");
  const uint32_t slots = std::max<uint32_t>(tape.slots, 1);
  cl::Buffer scratch = rt.alloc(pts.size() * slots * sizeof(float), "implicit point slots");
  cl::Buffer val = rt.alloc(out.size() * sizeof(float), "implicit values");
  rt.launch(Stage::Implicit, "implicit_points", pts.size(), reg, n, pool, scratch, slots,
            tape.root_slot, p, m, val);
  rt.read(Stage::Implicit, val, 0, out.size() * sizeof(float), out.data());
  return out;
}

}  // namespace vismap::stages
