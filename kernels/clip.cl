/* Stage: clipping fragments by the silhouette edges in front of them (SVGPU §3.2), as a Reyes
 * work queue: every round each fragment looks along its candidate list for the first edge that
 * really cuts it, and is either split in two (both sides kept, both continue after that edge)
 * or finished. A scan of the per-item output counts places the children; no atomics decide
 * where anything goes, so the result is the same on every device.
 *
 * A fragment is a convex polygon stored by its supporting lines (each through two grid points),
 * never by rounded vertices, so every split is exact (DESIGN §3). */

#define VM_NONE 0xffffffffu

/* The root fragment of every screen triangle: its three edges, clipped to the region being
 * rendered when that is only part of the screen (clip_region set). The region's sides are grid
 * lines, so the clipped fragment is still bounded by lines through grid points and fragments of
 * neighbouring regions meet exactly. A triangle whose box meets the region but whose interior
 * does not gets nlines = 0 and is dropped by the first round. */
__kernel void frag_init(__global const VmScreenTri* tris, uint ntris, int4 region, int clip_region,
                        __global VmFragMeta* meta, __global VmLine* lines, __global uint* state) {
  uint t = get_global_id(0);
  if (t >= ntris) return;
  if (t == 0) /* the queue state of the first round (layout.h VM_CLIP_*) */
    for (int w = 0; w < VM_CLIP_WORDS; ++w) state[w] = w == VM_CLIP_NQ ? ntris : 0u;
  VmScreenTri s = tris[t];
  VmLine P[VM_MAXL], Q[VM_MAXL];
  uint n = 3;
  for (int i = 0; i < 3; ++i) {
    int j = i == 2 ? 0 : i + 1;
    P[i] = vm_line_of(s.x[i], s.y[i], s.x[j], s.y[j]);
  }
  if (clip_region) {
    /* The region's sides, directed so that its interior is on their positive side. */
    VmLine side[4] = {vm_line_of(region.x, region.y, region.z, region.y),
                      vm_line_of(region.z, region.y, region.z, region.w),
                      vm_line_of(region.z, region.w, region.x, region.w),
                      vm_line_of(region.x, region.w, region.x, region.y)};
    for (int k = 0; k < 4 && n > 0; ++k) {
      Line3 LE = line_of_vm(side[k]);
      int sgn[VM_MAXL];
      int pos = 0, neg = 0;
      Line3 first = line_of_vm(P[0]), cur = first;
      for (uint i = 0; i < n; ++i) {
        Line3 nxt = i + 1 == n ? first : line_of_vm(P[i + 1]);
        sgn[i] = vertex_side(cur, nxt, LE);
        pos |= sgn[i] > 0;
        neg |= sgn[i] < 0;
        cur = nxt;
      }
      if (!neg) continue; /* wholly inside this side */
      if (!pos) {         /* wholly outside: nothing of t in the region */
        n = 0;
        break;
      }
      /* Keep the positive side: as split_side, on private arrays (at most 3 + 4 lines). */
      uint m = 0;
      for (uint i = 0; i < n; ++i) {
        int s_prev = sgn[i == 0 ? n - 1 : i - 1], s_end = sgn[i];
        if (s_prev > 0 || s_end > 0) {
          Q[m++] = P[i];
          if (s_end <= 0) Q[m++] = side[k];
        }
      }
      n = m;
      for (uint i = 0; i < n; ++i) P[i] = Q[i];
    }
  }
  VmFragMeta m;
  m.tri = t;
  m.nlines = n;
  m.next = 0;
  m.pad = 0;
  meta[t] = m;
  for (uint i = 0; i < n; ++i) lines[(size_t)t * VM_MAXL + i] = P[i];
}

/* Signs of the fragment's vertices (vertex i = line i ^ line i+1) with respect to LE, and
 * whether the segment E really cuts the fragment's interior: its line strictly separates two
 * vertices, and no fragment edge line has both segment ends on its closed outer side
 * (separating axes of a convex polygon and a segment). */
inline bool cuts(__global const VmLine* L, uint n, VmEdge E, int* sgn) {
  /* Crossing lines (q = +inf) are infinite: only the segment of a silhouette edge is tested. */
  for (uint i = 0; i < n && !isinf(E.q0); ++i) {
    Line3 Li = line_of_vm(L[i]);
    if (line_eval_point(Li, E.x0, E.y0) <= 0 && line_eval_point(Li, E.x1, E.y1) <= 0) return false;
  }
  Line3 LE = edge_line(E);
  int pos = 0, neg = 0;
  Line3 first = line_of_vm(L[0]);
  Line3 cur = first;
  for (uint i = 0; i < n; ++i) {
    Line3 nxt = i + 1 == n ? first : line_of_vm(L[i + 1]);
    int s = vertex_side(cur, nxt, LE);
    sgn[i] = s;
    pos |= s > 0;
    neg |= s < 0;
    cur = nxt;
  }
  return pos && neg;
}

/* Lines of one side of the split: edges with a vertex strictly on that side, and the cutting
 * line right after the edge whose end leaves that side. Returns the line count. */
inline uint split_side(__global const VmLine* L, uint n, const int* sgn, int side, VmLine cut,
                       __global VmLine* out, int write) {
  uint m = 0;
  for (uint i = 0; i < n; ++i) {
    int s_prev = side * sgn[i == 0 ? n - 1 : i - 1], s_end = side * sgn[i];
    if (s_prev > 0 || s_end > 0) {
      if (write && m < VM_MAXL) out[m] = L[i];
      ++m;
      if (s_end <= 0) {
        if (write && m < VM_MAXL) out[m] = cut;
        ++m;
      }
    }
  }
  return m;
}

/* The queue length a round works on: none once the rounds have stopped (clip_apply). */
inline uint clip_queue_length(__global const uint* state, uint resume) {
  return state[VM_CLIP_STOP] && !resume ? 0u : state[VM_CLIP_NQ];
}

/* A round is two launches (issue 17) over a grid of `grid` items in work-groups of VM_SCAN_WG
 * (the host's bound; clip_apply keeps the queue within it): clip_find finds each item's cut and
 * scans the group's counts (children, finished) itself, writing each item's offset within its
 * group and the group's totals (block_sums[2g], [2g + 1]); clip_apply sums the groups before
 * its own and all of them, so no separate scan runs. Grids of more than VM_CLIP_FUSED_MAX items
 * (more groups than one group can sum in a few loads an item) are not fused: find writes the
 * counts, the host scans them (totals[VM_TOTAL_NEXT], [VM_TOTAL_DONE]) and apply reads those.
 * Items past the device-side queue length count zero. resume: the host has made room after a
 * stop, this round runs whatever the state says. */
__kernel __attribute__((reqd_work_group_size(VM_SCAN_WG, 1, 1))) void clip_find(
    __global const VmFragMeta* meta, __global const VmLine* lines, uint grid,
    __global const uint* states, uint sc, uint resume, uint fused,
    __global const uint* cand_offset, __global const uint* cand_count, __global const uint* cand,
    __global const VmEdge* edges, __global uint* split_at, __global uint* next_count,
    __global uint* done_count, __global uint* block_sums, __global uint* status) {
  __local uint scan_n[VM_SCAN_WG], scan_d[VM_SCAN_WG];
  const uint i = get_global_id(0), lid = get_local_id(0);
  const uint nq = clip_queue_length(states + sc * VM_CLIP_WORDS, resume);
  uint split = VM_NONE, children = 0, finished = 0;
  VmFragMeta m;
  m.nlines = 0;
  if (i < grid && i < nq) m = meta[i];
  if (m.nlines > 0) { /* (0: past the queue, or a root fragment outside its region, frag_init) */
    __global const VmLine* L = lines + (size_t)i * VM_MAXL;
    uint off = cand_offset[m.tri], n = cand_count[m.tri];
    int sgn[VM_MAXL];
    /* The fragment's box (from approximate vertices, widened by a grid unit: only a filter)
     * lets most far-away segments go without the exact tests. */
    double2 lo = (double2)(INFINITY, INFINITY), hi = (double2)(-INFINITY, -INFINITY);
    {
      Line3 first = line_of_vm(L[0]), cur = first;
      for (uint j = 0; j < m.nlines; ++j) {
        Line3 nxt = j + 1 == m.nlines ? first : line_of_vm(L[j + 1]);
        double2 v = vertex_approx(cur, nxt);
        lo = fmin(lo, v);
        hi = fmax(hi, v);
        cur = nxt;
      }
      lo -= (double2)(1.0, 1.0);
      hi += (double2)(1.0, 1.0);
    }
    for (uint k = m.next; k < n; ++k) {
      VmEdge E = edges[cand[off + k]];
      if (!isinf(E.q0) &&
          (fmax((double)E.x0, (double)E.x1) < lo.x || fmin((double)E.x0, (double)E.x1) > hi.x ||
           fmax((double)E.y0, (double)E.y1) < lo.y || fmin((double)E.y0, (double)E.y1) > hi.y))
        continue;
      if (cuts(L, m.nlines, E, sgn)) {
        VmLine cut = vm_line(edge_line(E));
        uint np = split_side(L, m.nlines, sgn, 1, cut, 0, 0);
        uint nn = split_side(L, m.nlines, sgn, -1, cut, 0, 0);
        if (np > VM_MAXL || nn > VM_MAXL) atomic_or(status, VM_STATUS_LINES_OVERFLOW);
        split = k;
        children = 2;
        break;
      }
    }
    finished = split == VM_NONE;
  }
  if (i < grid) split_at[i] = split;
  if (!fused) {
    if (i < grid) {
      next_count[i] = children;
      done_count[i] = finished;
    }
    return;
  }
  /* The group's exclusive offsets (scan.cl's group scan of each count). */
  scan_n[lid] = children;
  scan_d[lid] = finished;
  barrier(CLK_LOCAL_MEM_FENCE);
  vm_group_scan(scan_n, lid);
  vm_group_scan(scan_d, lid);
  if (i < grid) {
    next_count[i] = scan_n[lid] - children;
    done_count[i] = scan_d[lid] - finished;
  }
  if (lid == VM_SCAN_WG - 1) {
    block_sums[2 * get_group_id(0)] = scan_n[lid];
    block_sums[2 * get_group_id(0) + 1] = scan_d[lid];
  }
}

/* Writes the round's children and finished fragments if both fit (the next round's grid
 * next_grid, the finished list's done_cap) and no child needs more than VM_MAXL lines; else the
 * round has no effect and the rounds stop, the queue as it was. Fused (see clip_find): each
 * group first sums the block totals, those before it (its base) and all (the round's counts);
 * else next_offset / done_offset are global and the counts are in totals. The state is in two
 * copies: this round's (copy sc) and the next round's, written by work-item 0 only; every item
 * reads only this round's, so none sees a half-written one. */
__kernel __attribute__((reqd_work_group_size(VM_SCAN_WG, 1, 1))) void clip_apply(
    __global const VmFragMeta* meta, __global const VmLine* lines, uint grid,
    __global uint* states, uint sc, uint resume, uint fused, __global const uint* totals,
    __global const uint* block_sums, uint next_grid, uint done_cap,
    __global const uint* cand_offset, __global const uint* cand, __global const VmEdge* edges,
    __global const uint* split_at, __global const uint* next_offset,
    __global const uint* done_offset, __global VmFragMeta* next_meta,
    __global VmLine* next_lines, __global VmFragMeta* done_meta, __global VmLine* done_lines) {
  __local uint4 sums[VM_SCAN_WG];
  const uint i = get_global_id(0), lid = get_local_id(0), g = get_group_id(0);
  uint nn, dn, base_n = 0, base_d = 0;
  if (fused) {
    /* (before: .x children, .y finished; all: .z, .w) */
    const uint blocks = (grid + VM_SCAN_WG - 1) / VM_SCAN_WG;
    uint4 acc = (uint4)(0, 0, 0, 0);
    for (uint b = lid; b < blocks; b += VM_SCAN_WG) {
      const uint bn = block_sums[2 * b], bd = block_sums[2 * b + 1];
      if (b < g) acc.xy += (uint2)(bn, bd);
      acc.zw += (uint2)(bn, bd);
    }
    sums[lid] = acc;
    barrier(CLK_LOCAL_MEM_FENCE);
    for (uint o = VM_SCAN_WG / 2; o > 0; o >>= 1) {
      if (lid < o) sums[lid] += sums[lid + o];
      barrier(CLK_LOCAL_MEM_FENCE);
    }
    base_n = sums[0].x;
    base_d = sums[0].y;
    nn = sums[0].z;
    dn = sums[0].w;
  } else {
    nn = totals[VM_TOTAL_NEXT];
    dn = totals[VM_TOTAL_DONE];
  }
  if (i >= grid) return;
  __global const uint* state = states + sc * VM_CLIP_WORDS;
  __global uint* next_state = states + (sc ^ 1u) * VM_CLIP_WORDS;
  const uint nq = clip_queue_length(state, resume);
  const uint done_base = state[VM_CLIP_DONE];
  const uint stopped = resume ? 0u : state[VM_CLIP_STOP];
  const uint stop = stopped ? stopped
                    : totals[VM_TOTAL_STATUS] & VM_STATUS_LINES_OVERFLOW ? VM_CLIP_STOP_LINES
                    : nn > next_grid                   ? VM_CLIP_STOP_QUEUE
                    : (ulong)done_base + dn > done_cap ? VM_CLIP_STOP_DONE
                                                       : 0u;
  if (i == 0) {
    const int ran = !stopped;
    next_state[VM_CLIP_NQ] = stop ? state[VM_CLIP_NQ] : nn;
    next_state[VM_CLIP_DONE] = stop ? done_base : done_base + dn;
    next_state[VM_CLIP_STOP] = stop;
    next_state[VM_CLIP_ROUNDS] = state[VM_CLIP_ROUNDS] + (!stop && nq > 0);
    next_state[VM_CLIP_NEXT] = ran ? nn : state[VM_CLIP_NEXT];
    next_state[VM_CLIP_NDONE] = ran ? dn : state[VM_CLIP_NDONE];
  }
  if (stop || i >= nq) return;
  VmFragMeta m = meta[i];
  __global const VmLine* L = lines + (size_t)i * VM_MAXL;
  uint k = split_at[i];
  if (m.nlines == 0) return;
  if (k == VM_NONE) {
    uint d = done_base + base_d + done_offset[i];
    done_meta[d] = m;
    for (uint j = 0; j < m.nlines; ++j) done_lines[(size_t)d * VM_MAXL + j] = L[j];
    return;
  }
  VmEdge E = edges[cand[cand_offset[m.tri] + k]];
  int sgn[VM_MAXL];
  cuts(L, m.nlines, E, sgn);
  uint o = base_n + next_offset[i];
  Line3 LE = edge_line(E);
  VmLine cut = vm_line(LE), rev = vm_line(line_reversed(LE));
  VmFragMeta c = m;
  c.next = k + 1;
  c.nlines = split_side(L, m.nlines, sgn, 1, cut, next_lines + (size_t)o * VM_MAXL, 1);
  next_meta[o] = c;
  c.nlines = split_side(L, m.nlines, sgn, -1, rev, next_lines + (size_t)(o + 1) * VM_MAXL, 1);
  next_meta[o + 1] = c;
}
