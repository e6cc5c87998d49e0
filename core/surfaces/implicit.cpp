#include "core/surfaces/implicit.h"

#include <algorithm>

#include "core/error.h"

namespace vismap::surfaces {

namespace {

void check_bytes(uint64_t bytes, uint64_t max_bytes, size_t round) {
  if (max_bytes && bytes > max_bytes)
    throw InputError(InputErrorKind::TooLarge, "", "", "implicit round", int64_t(round),
                     "needs " + std::to_string(bytes) + " bytes of device memory, over the cap of " +
                         std::to_string(max_bytes));
}

}  // namespace

constexpr uint64_t kChunkBytes = uint64_t(256) << 20;
// Clauses a chunk may evaluate (its regions times their mean tape length), so that the time
// limit, checked after each chunk, is passed by at most a chunk's work: ~0.3 s on PoCL's CPU
// device (issue 35: one round of a dense 3D object ran 20 s past a 5 s limit).
constexpr uint64_t kChunkClauses = uint64_t(1) << 24;

ImplicitQueue run_implicit_queue(ClRuntime& rt, const implicit::SlotTape& tape, const float lo[3],
                                 float size, uint32_t dims, const std::vector<uint32_t>& splits,
                                 uint64_t max_bytes,
                                 const std::vector<std::array<float, 4>>& planes,
                                 const std::function<void()>& check_time, const VmIView* view,
                                 const ImplicitOcclusion* occlusion) {
  ImplicitQueue q;
  const uint32_t syncs0 = rt.host_syncs();
  const uint32_t slots = std::max<uint32_t>(tape.slots, 1), maxlen = uint32_t(tape.size());
  const VmIView sizing = view ? *view : VmIView{};
  VmIRegion root{};
  for (int k = 0; k < 3; ++k) root.lo[k] = lo[k];
  root.size = size;
  root.tape_off = 0;
  root.tape_len = maxlen;
  cl::Buffer regions = rt.upload(std::vector<VmIRegion>{root}, "implicit regions");
  cl::Buffer pool = rt.upload(tape.code, "implicit tape");
  uint32_t n = 1;
  uint64_t clauses = maxlen;  // the round's tape lengths summed: its choice bytes
  uint32_t per_in = 1;        // regions a parent of the last round (kernels: vm_choice_off)
  // What the round starts from and holds throughout: its regions and their tape pool. The caps
  // below count it with the round's own buffers and the next round's, which are all held at
  // once (issue 35, case 1: each group counted alone let a round hold more than the cap), and
  // the leaves the host holds so far.
  uint64_t held = sizeof(VmIRegion) + uint64_t(maxlen) * sizeof(VmIClause);
  cl::Buffer totals = rt.alloc(VM_ITOTAL_SLOTS * sizeof(cl_uint), "implicit totals");
  std::vector<cl_float4> pl(std::max<size_t>(planes.size(), 1), cl_float4{{0, 0, 0, 1}});
  for (size_t k = 0; k < planes.size(); ++k)
    pl[k] = cl_float4{{planes[k][0], planes[k][1], planes[k][2], planes[k][3]}};
  cl::Buffer plane_buf = rt.upload(pl, "implicit planes");
  const uint32_t nplanes = uint32_t(planes.size());
  const cl_uint occlude = occlusion && nplanes ? 1 : 0;
  const VmIOcclusion occ_map = occlude ? occlusion->map : VmIOcclusion{};
  cl::Buffer image = occlude ? occlusion->image : totals;  // a stand-in when unused
  const uint64_t image_bytes = occlude ? occlusion_bytes(occ_map) : 0;
  for (size_t round = 0; round <= splits.size() && n > 0; ++round) {
    const bool last = round == splits.size();
    const uint32_t split = last ? 1 : splits[round];
    const uint64_t host_held =
        q.leaves.size() * sizeof(VmIRegion) + q.pool.size() * 4 + image_bytes;
    // Per region: the result and counts; a choice byte per clause of its own tape; slots of
    // intervals and of liveness for the regions of one chunk at a time (at most 256 MiB: a
    // round of millions of regions on a tape of hundreds of slots runs in pieces).
    const uint64_t mean_len = std::max<uint64_t>(1, clauses / n);
    const uint32_t chunk = uint32_t(std::clamp<uint64_t>(
        std::min<uint64_t>(kChunkBytes / (slots * 9ull), kChunkClauses / mean_len), 1, n));
    const uint64_t working = uint64_t(n) * (8 + 32) + clauses + uint64_t(chunk) * slots * 9;
    check_bytes(held + working + host_held, max_bytes, round);
    cl::Buffer scratch = rt.alloc(size_t(chunk) * slots * sizeof(cl_float2), "implicit slots");
    cl::Buffer live = rt.alloc(size_t(chunk) * slots, "implicit liveness");
    cl::Buffer choices = rt.alloc(std::max<size_t>(clauses, 1), "implicit choices");
    cl::Buffer result = rt.alloc(size_t(n) * sizeof(cl_float2), "implicit results");
    cl::Buffer counts = rt.alloc(size_t(n) * sizeof(cl_uint), "implicit tape counts");
    cl::Buffer offsets = rt.alloc(size_t(n) * sizeof(cl_uint), "implicit tape offsets");
    cl::Buffer amb = rt.alloc(size_t(n) * sizeof(cl_uint), "implicit ambiguous");
    cl::Buffer amb_off = rt.alloc(size_t(n) * sizeof(cl_uint), "implicit ambiguous offsets");
    cl::Buffer leaf_counts = rt.alloc(size_t(n) * sizeof(cl_uint), "implicit leaf tape counts");
    cl::Buffer leaf_offsets = rt.alloc(size_t(n) * sizeof(cl_uint), "implicit leaf tape offsets");
    cl::Buffer leaf = rt.alloc(size_t(n) * sizeof(cl_uint), "implicit leaf flags");
    cl::Buffer leaf_idx = rt.alloc(size_t(n) * sizeof(cl_uint), "implicit leaf offsets");
    rt.fill_u32(totals, 0, VM_ITOTAL_SLOTS, Stage::Implicit);
    // Each chunk's launches get its end as their bound: a launch is rounded up to whole work
    // groups, and items past the chunk (but not past n) wrote past the chunk's scratch (issue 35:
    // 3,000 spheres spread over [-500, 500]^3 crashed the process in implicit_intervals).
    for (uint32_t first = 0; first < n; first += chunk) {
      const uint32_t m = std::min(chunk, n - first), end = first + m;
      rt.launch(Stage::Implicit, "implicit_intervals", m, regions, end, first, pool, scratch, slots,
                tape.root_slot, choices, per_in, result, totals, plane_buf, nplanes, sizing,
                occ_map, image, occlude);
      if (occlude) {  // this chunk's full boxes into the depth image, and its pyramid
        rt.launch(Stage::Implicit, "implicit_occluders", m, regions, n, first, m, per_in, result,
                  occ_map, sizing, image);
        ++q.launches;
        for (int k = 0;; ++k, ++q.launches) {  // level k + 1 from level k, down to 1 x 1
          const auto dim = [k](uint64_t n, int up) { return (n + (1u << (k + up)) - 1) >> (k + up); };
          if (dim(occ_map.width, 0) == 1 && dim(occ_map.height, 0) == 1) break;
          rt.launch(Stage::Implicit, "implicit_depth_mip",
                    size_t(dim(occ_map.width, 1) * dim(occ_map.height, 1)), image, occ_map,
                    cl_int(k));
        }
      }
      rt.launch(Stage::Implicit, "implicit_shorten_count", m, regions, end, first, pool, choices,
                per_in, result, live, slots, tape.root_slot, counts, amb, leaf_counts, leaf,
                sizing, cl_uint(last), totals);
      if (first) q.launches += 2;
      if (check_time && first + m < n) {  // wait for the chunk, then look at the clock
        cl_uint done = 0;
        rt.read(Stage::Implicit, totals, 0, sizeof done, &done);
        check_time();
      }
    }
    // Four scans, their totals into the totals buffer: one read a round.
    rt.scan_to(Stage::Implicit, counts, offsets, n, totals, VM_ITOTAL_POOL);
    rt.scan_to(Stage::Implicit, amb, amb_off, n, totals, VM_ITOTAL_SPLIT);
    rt.scan_to(Stage::Implicit, leaf_counts, leaf_offsets, n, totals, VM_ITOTAL_LEAF_POOL);
    rt.scan_to(Stage::Implicit, leaf, leaf_idx, n, totals, VM_ITOTAL_LEAVES);
    q.launches += 8;  // the fill, three kernels, four scans (each counted as one)
    cl_uint tot[VM_ITOTAL_SLOTS];
    rt.read(Stage::Implicit, totals, 0, sizeof tot, tot);
    if (check_time) check_time();
    if (tot[VM_ITOTAL_COARSE])
      throw InputError(InputErrorKind::TooLarge, "", "", "implicit round", int64_t(round),
                       std::to_string(tot[VM_ITOTAL_COARSE]) +
                           " leaves of the last level are larger than their depth allows");
    const uint32_t pool_next = tot[VM_ITOTAL_POOL], namb = tot[VM_ITOTAL_SPLIT];
    const uint32_t leaf_pool_n = tot[VM_ITOTAL_LEAF_POOL], nleaf = tot[VM_ITOTAL_LEAVES];
    ImplicitRound r;
    r.regions = n;
    r.full = tot[VM_ITOTAL_FULL];
    r.empty = tot[VM_ITOTAL_EMPTY];
    r.culled = tot[VM_ITOTAL_CULLED];
    r.occluded = tot[VM_ITOTAL_OCCLUDED];
    r.ambiguous = uint64_t(namb) + nleaf;
    r.leaves = nleaf;
    r.clauses = clauses;
    q.rounds.push_back(r);
    const uint32_t per = split == 1 ? 1 : (dims == 3 ? split * split * split : split * split);
    const uint64_t next_n = uint64_t(namb) * per;
    if (next_n > 0xffffffffull || uint64_t(pool_next) * per > 0xffffffffull ||
        q.pool.size() / 4 + leaf_pool_n > 0xffffffffull)
      throw InputError(InputErrorKind::TooLarge, "", "", "implicit round", int64_t(round),
                       "more than 2^32 regions");
    // The next round's inputs, and this round's leaves (copied to the host).
    const uint64_t next_held = uint64_t(pool_next) * sizeof(VmIClause) + next_n * sizeof(VmIRegion);
    const uint64_t leaf_bytes =
        uint64_t(leaf_pool_n) * sizeof(VmIClause) + uint64_t(nleaf) * sizeof(VmIRegion);
    check_bytes(held + working + next_held + 2 * leaf_bytes + host_held, max_bytes, round);
    cl::Buffer next_pool = rt.alloc(std::max<size_t>(pool_next, 1) * sizeof(VmIClause),
                                    "implicit tape pool");
    cl::Buffer next = rt.alloc(std::max<size_t>(next_n, 1) * sizeof(VmIRegion), "implicit regions");
    cl::Buffer leaf_pool = rt.alloc(std::max<size_t>(leaf_pool_n, 1) * sizeof(VmIClause),
                                    "implicit leaf tapes");
    cl::Buffer leaves = rt.alloc(std::max<size_t>(nleaf, 1) * sizeof(VmIRegion), "implicit leaves");
    for (uint32_t first = 0; first < n; first += chunk) {
      const uint32_t m = std::min(chunk, n - first);
      rt.launch(Stage::Implicit, "implicit_shorten_fill", m, regions, first + m, first, pool,
                choices, per_in, result, live, slots, tape.root_slot, counts, offsets, amb_off,
                next_pool, next, split, dims, leaf_counts, leaf_offsets, leaf_idx, leaf_pool,
                leaves);
      if (first) ++q.launches;
    }
    if (nleaf) {
      const size_t l0 = q.leaves.size(), p0 = q.pool.size();
      q.leaves.resize(l0 + nleaf);
      q.pool.resize(p0 + size_t(leaf_pool_n) * 4);
      rt.read_async(Stage::Implicit, leaves, 0, nleaf * sizeof(VmIRegion), q.leaves.data() + l0);
      rt.read(Stage::Implicit, leaf_pool, 0, size_t(leaf_pool_n) * sizeof(VmIClause),
              q.pool.data() + p0);
      for (size_t i = l0; i < q.leaves.size(); ++i) q.leaves[i].tape_off += uint32_t(p0 / 4);
    }
    regions = next;
    pool = next_pool;
    held = next_held;
    n = uint32_t(next_n);
    clauses = uint64_t(pool_next) * per;
    per_in = per;
  }
  q.host_syncs = rt.host_syncs() - syncs0;
  return q;
}

std::vector<float> eval_leaf_points(ClRuntime& rt, const implicit::SlotTape& tape,
                                    const ImplicitQueue& q, const std::vector<float>& xyz,
                                    uint32_t m, uint32_t* launches_out,
                                    const std::function<void()>& check_time) {
  uint32_t launches = 0;
  const size_t n = q.leaves.size();
  std::vector<float> out(n * m);
  if (n == 0 || m == 0) return out;
  // Each leaf's tape renumbered for its own scratch: value k of a tape of length L in slot k + 1,
  // its last value (the root) in slot 0, so a point needs L values of scratch, not the full
  // tape's slot count (hundreds on large models; a leaf's tape is a few dozen clauses). The
  // same operations on the same values: the results are those of the slot tape.
  std::vector<uint32_t> code = q.pool;
  std::vector<VmIRegion> leaves = q.leaves;
  std::vector<uint32_t> latest(std::max<uint32_t>(tape.slots, 1));
  uint32_t slots = 1;
  bool renumbered = true;
  for (const VmIRegion& L : leaves) {
    uint32_t* c = code.data() + 4 * size_t(L.tape_off);
    if (L.tape_len == 0 || c[4 * (L.tape_len - 1) + 1] != tape.root_slot) renumbered = false;
  }
  if (renumbered) {
    std::vector<uint8_t> done(q.pool.size() / 4, 0);  // leaves may share a tape (in 2D they do)
    for (const VmIRegion& L : leaves) {
      slots = std::max<uint32_t>(slots, L.tape_len);
      if (done[L.tape_off]) continue;
      done[L.tape_off] = 1;
      uint32_t* c = code.data() + 4 * size_t(L.tape_off);
      for (uint32_t k = 0; k < L.tape_len; ++k, c += 4) {
        const uint32_t op = c[0];
        const bool leaf = op <= uint32_t(implicit::Op::Z);
        const bool binary = op != implicit::kCopy && implicit::is_binary(implicit::Op(op));
        if (!leaf) c[2] = latest[c[2]];
        if (binary) c[3] = latest[c[3]];
        const uint32_t to = k + 1 == L.tape_len ? 0 : k + 1;
        latest[c[1]] = to;
        c[1] = to;
      }
    }
  } else {
    slots = std::max<uint32_t>(tape.slots, 1);  // code is the pool as it came
  }
  const uint32_t root = renumbered ? 0 : tape.root_slot;
  cl::Buffer pool = rt.upload(code, "implicit leaf tapes");
  // In batches of leaves, so the per-point scratch (slots floats a point) stays under 256 MiB
  // whatever the count: a 3D frame has millions of leaf corners. One scratch for all batches.
  const size_t per_leaf = size_t(m) * (slots * sizeof(float) + sizeof(cl_float4) + sizeof(float));
  const size_t batch = std::min(n, std::max<size_t>(1, (size_t(256) << 20) / per_leaf));
  cl::Buffer scratch = rt.alloc(batch * m * slots * sizeof(float), "implicit point slots");
  for (size_t first = 0; first < n; first += batch) {
    const size_t nb = std::min(batch, n - first);
    std::vector<VmIRegion> reg_b(leaves.begin() + first, leaves.begin() + first + nb);
    std::vector<cl_float4> pts(nb * m);
    const float* src = xyz.data() + 3 * first * m;
    for (size_t i = 0; i < pts.size(); ++i)
      pts[i] = cl_float4{{src[3 * i], src[3 * i + 1], src[3 * i + 2], 0.f}};
    cl::Buffer reg = rt.upload(reg_b, "implicit leaves");
    cl::Buffer p = rt.upload(pts, "implicit points");
    cl::Buffer val = rt.alloc(pts.size() * sizeof(float), "implicit values");
    ++launches;
    rt.launch(Stage::Implicit, "implicit_points", pts.size(), reg, uint32_t(nb), pool, scratch,
              slots, root, p, m, val);
    rt.read(Stage::Implicit, val, 0, pts.size() * sizeof(float), out.data() + first * m);
    if (check_time) check_time();
  }
  if (launches_out) *launches_out += launches;
  return out;
}

}  // namespace vismap::surfaces
