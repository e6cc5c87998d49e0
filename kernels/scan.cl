/* Exclusive prefix sum of uint counts: the "scan" of count-scan-fill and of the Reyes work
 * queue's compaction, in one launch for at most VM_SCAN_SMALL_MAX counts (scan_blocks for one
 * block, scan_small for a few) and two up to VM_SCAN_FINISH_MAX blocks (issue 17: each launch
 * costs ~5.5 us on a GPU); most count-and-fill pairs fuse it into their own kernels instead
 * (vm_group_offset and vm_group_base, below). scan_blocks scans
 * VM_SCAN_BLOCK counts per work-group and writes each block's total to block_sums[sum_slot +
 * group]: with one block that is the grand total, written straight into the caller's totals
 * slot. scan_finish then adds to each block the sum of the blocks before it, which each
 * work-group sums for itself (no second scan, no third launch), and its last group writes the
 * grand total. Above VM_SCAN_FINISH_MAX blocks the host scans the block sums recursively and
 * scan_add adds them. Integer sums: the offsets are the same however they are grouped. */
/* VM_SCAN_WG, VM_SCAN_PER_ITEM, VM_SCAN_BLOCK, VM_SCAN_FINISH_MAX and VM_SCAN_SMALL_MAX:
 * layout.h (the host launches by them). */

/* Inclusive scan of a work-group's VM_SCAN_WG values in a (Hillis-Steele), in place; every item
 * of the group calls it, after a barrier that follows its write of a[lid]. */
inline void vm_group_scan(__local uint* a, uint lid) {
#ifdef VM_SERIAL_GROUP_SCAN /* a CPU device (ClRuntime::build): one item, one barrier */
  if (lid == 0) {
    uint run = 0;
    for (uint k = 0; k < VM_SCAN_WG; ++k) a[k] = run += a[k];
  }
  barrier(CLK_LOCAL_MEM_FENCE);
#else
  for (uint off = 1; off < VM_SCAN_WG; off <<= 1) {
    uint t = lid >= off ? a[lid - off] : 0;
    barrier(CLK_LOCAL_MEM_FENCE);
    a[lid] += t;
    barrier(CLK_LOCAL_MEM_FENCE);
  }
#endif
}

__kernel __attribute__((reqd_work_group_size(VM_SCAN_WG, 1, 1))) void scan_blocks(
    __global const uint* in, __global uint* out, uint n, __global uint* block_sums, uint sum_slot) {
  __local uint partial[VM_SCAN_WG];
  uint lid = get_local_id(0);
  uint base = get_group_id(0) * VM_SCAN_BLOCK + lid * VM_SCAN_PER_ITEM;
  uint v[VM_SCAN_PER_ITEM];
  uint sum = 0;
  for (int k = 0; k < VM_SCAN_PER_ITEM; ++k) {
    uint i = base + k;
    v[k] = i < n ? in[i] : 0;
    sum += v[k];
  }
  partial[lid] = sum;
  barrier(CLK_LOCAL_MEM_FENCE);
  vm_group_scan(partial, lid); /* of the per-item sums */
  uint run = partial[lid] - sum; /* exclusive */
  for (int k = 0; k < VM_SCAN_PER_ITEM; ++k) {
    uint i = base + k;
    if (i < n) out[i] = run;
    run += v[k];
  }
  if (lid == VM_SCAN_WG - 1) block_sums[sum_slot + get_group_id(0)] = partial[lid];
}

/* The sum of sums[0..g) by the whole work-group (every item calls it: barriers), at most
 * VM_SCAN_FINISH_MAX / VM_SCAN_WG = 16 loads an item; tmp is free again on return. */
inline uint vm_sum_before(__global const uint* sums, uint g, __local uint* tmp) {
  const uint lid = get_local_id(0);
  uint sum = 0;
  for (uint b = lid; b < g; b += VM_SCAN_WG) sum += sums[b];
  tmp[lid] = sum;
  barrier(CLK_LOCAL_MEM_FENCE);
#ifdef VM_SERIAL_GROUP_SCAN /* a CPU device: one item sums, one barrier */
  if (lid == 0)
    for (uint k = 1; k < VM_SCAN_WG; ++k) tmp[0] += tmp[k];
  barrier(CLK_LOCAL_MEM_FENCE);
#else
  for (uint off = VM_SCAN_WG / 2; off > 0; off >>= 1) {
    if (lid < off) tmp[lid] += tmp[lid + off];
    barrier(CLK_LOCAL_MEM_FENCE);
  }
#endif
  const uint total = tmp[0];
  barrier(CLK_LOCAL_MEM_FENCE);
  return total;
}

/* At most VM_SCAN_SMALL_MAX counts in one launch of one work-group: each item sums a run of
 * ceil(n / VM_SCAN_WG) counts, the group scans the sums, and each item writes its run's offsets;
 * the total to total[slot]. Where scan_blocks and scan_finish would be two launches (~5.5 us
 * each on a GPU), two passes over at most 64 KiB in one group. */
__kernel __attribute__((reqd_work_group_size(VM_SCAN_WG, 1, 1))) void scan_small(
    __global const uint* in, __global uint* out, uint n, __global uint* total, uint slot) {
  __local uint partial[VM_SCAN_WG];
  const uint lid = get_local_id(0), run_len = (n + VM_SCAN_WG - 1) / VM_SCAN_WG;
  const uint begin = min(n, lid * run_len), end = min(n, begin + run_len);
  uint sum = 0;
  for (uint i = begin; i < end; ++i) sum += in[i];
  partial[lid] = sum;
  barrier(CLK_LOCAL_MEM_FENCE);
  vm_group_scan(partial, lid);
  uint run = partial[lid] - sum; /* exclusive */
  for (uint i = begin; i < end; ++i) {
    const uint c = in[i];
    out[i] = run;
    run += c;
  }
  if (lid == VM_SCAN_WG - 1) total[slot] = partial[lid];
}

/* Group g (of nblocks, g > 0 adds) adds the sum of block_sums[0..g) to block g's offsets; the
 * last group writes the grand total to total[slot]. */
__kernel __attribute__((reqd_work_group_size(VM_SCAN_WG, 1, 1))) void scan_finish(
    __global uint* out, uint n, __global const uint* block_sums, uint nblocks,
    __global uint* total, uint slot) {
  __local uint partial[VM_SCAN_WG];
  const uint lid = get_local_id(0), g = get_group_id(0);
  const uint base = vm_sum_before(block_sums, g, partial);
  if (g > 0)
    for (uint k = 0; k < VM_SCAN_PER_ITEM; ++k) {
      const uint i = g * VM_SCAN_BLOCK + k * VM_SCAN_WG + lid;
      if (i < n) out[i] += base;
    }
  if (g + 1 == nblocks && lid == 0) total[slot] = base + block_sums[g];
}

/* Fused count and fill (issue 17): a producer kernel, launched in work-groups of VM_SCAN_WG,
 * scans its group's counts itself (vm_group_offset: the item's offset within its group; the
 * group's total to sums[g]); the host reads the groups' totals (it needs the count to size the
 * output) and writes back each group's base, the totals before it (ClRuntime::GroupSums); the
 * consumer, launched over the same items and groups, adds its group's base (vm_group_base), so no
 * scan launch runs between them. Every item of the group calls vm_group_offset (barriers); tmp
 * is free again on return. */
inline uint vm_group_offset(uint count, __local uint* tmp, __global uint* sums) {
  const uint lid = get_local_id(0);
  tmp[lid] = count;
  barrier(CLK_LOCAL_MEM_FENCE);
  vm_group_scan(tmp, lid);
  const uint inclusive = tmp[lid];
  if (lid == VM_SCAN_WG - 1) sums[get_group_id(0)] = inclusive;
  barrier(CLK_LOCAL_MEM_FENCE);
  return inclusive - count;
}

/* The totals of the groups before this one, as the host wrote them; 0 when groups is 0 (the
 * offsets are global). */
inline uint vm_group_base(__global const uint* bases, uint groups) {
  return groups ? bases[get_group_id(0)] : 0u;
}

/* Zeroes n words of a and of b: two fills in one launch. */
__kernel void zero_words2(uint n, __global uint* a, __global uint* b) {
  uint i = get_global_id(0);
  if (i >= n) return;
  a[i] = 0;
  b[i] = 0;
}

__kernel void scan_add(__global uint* out, uint n, __global const uint* block_offsets) {
  uint i = get_global_id(0);
  if (i < n) out[i] += block_offsets[i / VM_SCAN_BLOCK];
}
