/* Exclusive prefix sum of uint counts: the "scan" of count-scan-fill and of the Reyes work
 * queue's compaction. Two levels: scan_blocks scans VM_SCAN_BLOCK items per work-group and
 * writes each block's total; the host scans the block totals the same way (recursively) and
 * scan_add adds each block's offset. out[n] receives the grand total when n_total_slot is set. */
/* VM_SCAN_WG, VM_SCAN_PER_ITEM and VM_SCAN_BLOCK: layout.h (the host launches by them). */

__kernel __attribute__((reqd_work_group_size(VM_SCAN_WG, 1, 1))) void scan_blocks(
    __global const uint* in, __global uint* out, uint n, __global uint* block_sums) {
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
  /* Hillis-Steele inclusive scan of the per-item sums. */
  for (uint off = 1; off < VM_SCAN_WG; off <<= 1) {
    uint t = lid >= off ? partial[lid - off] : 0;
    barrier(CLK_LOCAL_MEM_FENCE);
    partial[lid] += t;
    barrier(CLK_LOCAL_MEM_FENCE);
  }
  uint run = partial[lid] - sum; /* exclusive */
  for (int k = 0; k < VM_SCAN_PER_ITEM; ++k) {
    uint i = base + k;
    if (i < n) out[i] = run;
    run += v[k];
  }
  if (lid == VM_SCAN_WG - 1) block_sums[get_group_id(0)] = partial[lid];
}

__kernel void scan_add(__global uint* out, uint n, __global const uint* block_offsets) {
  uint i = get_global_id(0);
  if (i < n) out[i] += block_offsets[i / VM_SCAN_BLOCK];
}

/* Writes counts[n-1] + offsets[n-1] (the total) to total[slot]; n > 0. */
__kernel void scan_total(__global const uint* counts, __global const uint* offsets, uint n,
                         __global uint* total, uint slot) {
  if (get_global_id(0) == 0) total[slot] = n ? offsets[n - 1] + counts[n - 1] : 0;
}
