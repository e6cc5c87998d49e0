/* Stage: clipping fragments by the silhouette edges in front of them (SVGPU §3.2), as a Reyes
 * work queue: every round each fragment looks along its candidate list for the first edge that
 * really cuts it, and is either split in two (both sides kept, both continue after that edge)
 * or finished. A scan of the per-item output counts places the children; no atomics decide
 * where anything goes, so the result is the same on every device.
 *
 * A fragment is a convex polygon stored by its supporting lines (each through two grid points),
 * never by rounded vertices, so every split is exact (DESIGN §3). */

#define VM_NONE 0xffffffffu
/* A node's recorded cut when the fragment there was proven hidden and dropped. */
#define VM_DROP 0xfffffffeu

/* What the cull proved (cull.cl): the fine bins' leaves of the whole region with their bounds,
 * and the screen triangles the fragments come from. on = 0: nothing proven, nothing dropped. */
typedef struct {
  __global const VmScreenTri* tris;
  __global const uint* tile_leaf;
  __global const double2* leaf_cull;
  VmGrid g;
  int on;
} CullView;

/* Is the fragment of screen triangle t with box b (frag_box) proven hidden? */
inline bool frag_proven_hidden(const CullView* cv, uint t, const VmLine* L, uint nl, double4 b) {
  const VmScreenTri T = cv->tris[t];
  const int4 fb = (int4)((int)floor(b.x), (int)floor(b.y), (int)ceil(b.z), (int)ceil(b.w));
  return fragment_hidden(&T, L, nl, fb, cv->g, cv->tile_leaf, cv->leaf_cull);
}

/* Signs of the fragment's vertices (vertex i = line i ^ line i+1) with respect to LE, and
 * whether the segment E really cuts the fragment's interior: its line strictly separates two
 * vertices, and no fragment edge line has both segment ends on its closed outer side
 * (separating axes of a convex polygon and a segment). */
inline bool cuts(const VmLine* L, uint n, VmEdge E, int* sgn) {
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
 * line right after the edge whose end leaves that side. Returns the line count; writes at most
 * VM_MAXL of them to out (none when out is 0). */
inline uint split_side(const VmLine* L, uint n, const int* sgn, int side, VmLine cut, VmLine* out) {
  uint m = 0;
  for (uint i = 0; i < n; ++i) {
    int s_prev = side * sgn[i == 0 ? n - 1 : i - 1], s_end = side * sgn[i];
    if (s_prev > 0 || s_end > 0) {
      if (out && m < VM_MAXL) out[m] = L[i];
      ++m;
      if (s_end <= 0) {
        if (out && m < VM_MAXL) out[m] = cut;
        ++m;
      }
    }
  }
  return m;
}

/* The first candidate, from `from` of the n in cand, whose edge really cuts the fragment L (nl
 * lines; sgn: its vertex signs against that edge), or VM_NONE. The fragment's box (from
 * approximate vertices, widened by a grid unit: only a filter) lets most far-away segments go
 * without the exact tests. */
/* The fragment's box from its approximate vertices, widened by a grid unit so that it holds the
 * exact fragment (the vertices' rounding is far below that): (lo.x, lo.y, hi.x, hi.y). */
inline double4 frag_box(const VmLine* L, uint nl) {
  double2 lo = (double2)(INFINITY, INFINITY), hi = (double2)(-INFINITY, -INFINITY);
  Line3 first = line_of_vm(L[0]), cur = first;
  for (uint j = 0; j < nl; ++j) {
    Line3 nxt = j + 1 == nl ? first : line_of_vm(L[j + 1]);
    double2 v = vertex_approx(cur, nxt);
    lo = fmin(lo, v);
    hi = fmax(hi, v);
    cur = nxt;
  }
  return (double4)(lo.x - 1.0, lo.y - 1.0, hi.x + 1.0, hi.y + 1.0);
}

inline uint find_cut(const VmLine* L, uint nl, uint from, __global const uint* cand, uint n,
                     __global const VmEdge* edges, int* sgn, double4 box) {
  const double2 lo = box.xy, hi = box.zw;
  for (uint k = from; k < n; ++k) {
    VmEdge E = edges[cand[k]];
    if (!isinf(E.q0) &&
        (fmax((double)E.x0, (double)E.x1) < lo.x || fmin((double)E.x0, (double)E.x1) > hi.x ||
         fmax((double)E.y0, (double)E.y1) < lo.y || fmin((double)E.y0, (double)E.y1) > hi.y))
      continue;
    if (cuts(L, nl, E, sgn)) return k;
  }
  return VM_NONE;
}

/* The side of a split fragment P (n lines, vertex signs sgn against E): side 1 keeps the
 * positive side of E's line, -1 the negative, bounded by the line reversed. Lines to C (at most
 * VM_MAXL); returns the count, which may exceed VM_MAXL. */
inline uint split_child(const VmLine* P, uint n, const int* sgn, int side, VmEdge E, VmLine* C) {
  Line3 LE = edge_line(E);
  return split_side(P, n, sgn, side, vm_line(side > 0 ? LE : line_reversed(LE)), C);
}

/* One item's clip pass (issue 17): up to `levels` rounds of splits of fragment m (lines L), the
 * children of all but the last level held in private memory. The splits form a binary tree
 * (node h's children 2h, 2h + 1, the positive side first), walked in pre-order, so that each
 * level's fragments come in the order that rounds run one at a time give them, and the
 * finished list is the same.
 * find (place == 0): searches each node's cut, records it (splits[h - 1]), raises the
 * overflow flag for a child of more than VM_MAXL lines, and counts: count[0] the last level's
 * children, count[1 + l] the fragments finished at level l.
 * apply: takes the recorded cuts and writes the fragments finished at level l from
 * done_meta[done[l]] on, the last level's children from next_meta[queue] on. */
inline void clip_walk(uint levels, VmFragMeta m, __global const VmLine* L, __global uint* splits,
                      __global const uint* cand, uint ncand, __global const VmEdge* edges,
                      uint* count, __global uint* status, int place, uint queue, uint* done,
                      __global VmFragMeta* next_meta, __global VmLine* next_lines,
                      __global VmFragMeta* done_meta, __global VmLine* done_lines,
                      const CullView* cv, uint* dropped) {
  VmLine P[VM_CLIP_LEVELS][VM_MAXL];
  int sgn[VM_CLIP_LEVELS][VM_MAXL];
  uint nl[VM_CLIP_LEVELS], from[VM_CLIP_LEVELS], ks[VM_CLIP_LEVELS];
  for (uint j = 0; j < m.nlines; ++j) P[0][j] = L[j];
  nl[0] = m.nlines;
  from[0] = m.next;
  uint h = 1;
  int lev = 0;
  for (;;) {
    uint k;
    if (!place) {
      const double4 box = frag_box(P[lev], nl[lev]);
      /* (a root fragment is its whole triangle, which the cull kept: no test) */
      k = cv->on && (h > 1 || m.next > 0) && frag_proven_hidden(cv, m.tri, P[lev], nl[lev], box)
              ? VM_DROP
              : find_cut(P[lev], nl[lev], from[lev], cand, ncand, edges, sgn[lev], box);
      splits[h - 1] = k;
    } else {
      k = splits[h - 1];
      if (k != VM_NONE && k != VM_DROP) cuts(P[lev], nl[lev], edges[cand[k]], sgn[lev]);
    }
    ks[lev] = k;
    if (k == VM_DROP) { /* proven hidden (cull.cl): neither split further nor finished */
      ++*dropped;
    } else if (k == VM_NONE) { /* finished at this level */
      if (!place) {
        ++count[1 + lev];
      } else {
        const uint d = done[lev]++;
        VmFragMeta f = m;
        f.nlines = nl[lev];
        f.next = from[lev];
        done_meta[d] = f;
        for (uint j = 0; j < nl[lev]; ++j) done_lines[(size_t)d * VM_MAXL + j] = P[lev][j];
      }
    } else if (lev + 1 < (int)levels) { /* down to the positive child */
      const uint n = split_child(P[lev], nl[lev], sgn[lev], 1, edges[cand[k]], P[lev + 1]);
      if (n > VM_MAXL) atomic_or(status, VM_STATUS_LINES_OVERFLOW);
      nl[lev + 1] = min(n, (uint)VM_MAXL);
      from[lev + 1] = k + 1;
      h = 2 * h;
      ++lev;
      continue;
    } else { /* the last level's children: to the next round's queue */
      const VmEdge E = edges[cand[k]];
      VmFragMeta c = m;
      c.next = k + 1;
      for (int side = 1; side >= -1; side -= 2) {
        VmLine C[VM_MAXL];
        c.nlines = split_child(P[lev], nl[lev], sgn[lev], side, E, place ? C : 0);
        if (!place) {
          if (c.nlines > VM_MAXL) atomic_or(status, VM_STATUS_LINES_OVERFLOW);
          ++count[0];
        } else {
          const uint o = queue++;
          next_meta[o] = c;
          for (uint j = 0; j < c.nlines; ++j) next_lines[(size_t)o * VM_MAXL + j] = C[j];
        }
      }
    }
    /* The next node in pre-order: up past right children, then the right sibling, the negative
     * side of its parent's cut. */
    while (h & 1) {
      h >>= 1;
      --lev;
    }
    if (h == 0) return;
    ++h;
    const uint n = split_child(P[lev - 1], nl[lev - 1], sgn[lev - 1], -1, edges[cand[ks[lev - 1]]],
                               P[lev]);
    if (n > VM_MAXL) atomic_or(status, VM_STATUS_LINES_OVERFLOW);
    nl[lev] = min(n, (uint)VM_MAXL);
    from[lev] = ks[lev - 1] + 1;
  }
}

/* The root fragment of every screen triangle: its three edges, clipped to the region being
 * rendered when that is only part of the screen (clip_region set). The region's sides are grid
 * lines, so the clipped fragment is still bounded by lines through grid points and fragments of
 * neighbouring regions meet exactly. A triangle whose box meets the region but whose interior
 * does not gets nlines = 0 and is dropped by the first round. */
__kernel void frag_init(__global const VmScreenTri* tris, uint ntris, __global const int4* tri_bb,
                        int4 region, int clip_region, __global VmFragMeta* meta,
                        __global VmLine* lines, __global uint* state) {
  uint t = get_global_id(0);
  if (t >= ntris) return;
  if (t == 0) /* the queue state of the first round (layout.h VM_CLIP_*) */
    for (int w = 0; w < VM_CLIP_WORDS; ++w) state[w] = w == VM_CLIP_NQ ? ntris : 0u;
  VmScreenTri s = tris[t];
  VmLine P[VM_MAXL], Q[VM_MAXL];
  /* a triangle the cull left out (cull.cl: its box emptied) has no fragment */
  uint n = tri_bb[t].x > tri_bb[t].z ? 0 : 3;
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
      /* Keep the positive side (at most 3 + 4 lines). */
      n = split_side(P, n, sgn, 1, side[k], Q);
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

/* The queue length a round works on: none once the rounds have stopped (clip_apply). */
inline uint clip_queue_length(__global const uint* state, uint resume) {
  return state[VM_CLIP_STOP] && !resume ? 0u : state[VM_CLIP_NQ];
}

/* A pass is two launches (issue 17) over a grid of `grid` items in work-groups of VM_SCAN_WG
 * (the host's bound; clip_apply keeps the queue within it), and runs `levels` rounds
 * (clip_walk): clip_find finds each item's cuts and scans the group's counts itself (the last
 * level's children; the finished of each level), writing each item's offsets within its group
 * and the group's totals (block_sums[VM_CLIP_COUNTS g + c]); clip_apply sums the groups before
 * its own and all of them, so no separate scan runs. Grids of more than VM_CLIP_FUSED_MAX items
 * (more groups than one group can sum in a few loads an item) are not fused and run one level:
 * find writes the counts, the host scans them (totals[VM_TOTAL_NEXT], [VM_TOTAL_DONE]) and apply
 * reads those. Items past the device-side queue length count zero. resume: the host has made
 * room after a stop, this pass runs whatever the state says.
 * Offsets: next_offset[i] for the children; done_offset[l grid + i] for the level-l finished.
 * splits: VM_CLIP_NODES per item. */
__kernel __attribute__((reqd_work_group_size(VM_SCAN_WG, 1, 1))) void clip_find(
    __global const VmFragMeta* meta, __global const VmLine* lines, uint grid,
    __global const uint* states, uint sc, uint resume, uint fused, uint levels,
    __global const uint* cand_offset, __global const uint* cand_count, __global const uint* cand,
    __global const VmEdge* edges, __global uint* splits, __global uint* next_count,
    __global uint* done_count, __global uint* block_sums, __global uint* status,
    __global const VmScreenTri* tris, VmGrid cull_grid, __global const uint* cull_tile_leaf,
    __global const double2* leaf_cull, int cull_on) {
  /* Two counts a word (a group's totals are at most 8 VM_SCAN_WG = 2048 < 2^16): .x the
   * children and level 0's finished, .y levels 1 and 2's. */
  __local uint scan_a[VM_SCAN_WG], scan_b[VM_SCAN_WG];
  const uint i = get_global_id(0), lid = get_local_id(0);
  const uint nq = clip_queue_length(states + sc * VM_CLIP_WORDS, resume);
  uint count[VM_CLIP_COUNTS] = {0, 0, 0, 0};
  VmFragMeta m;
  m.nlines = 0;
  if (i < grid && i < nq) m = meta[i];
  const CullView cv = {tris, cull_tile_leaf, leaf_cull, cull_grid, cull_on};
  uint dropped = 0; /* (counted by clip_apply, once the pass takes effect) */
  if (m.nlines > 0) /* (0: past the queue, or a root fragment outside its region, frag_init) */
    clip_walk(levels, m, lines + (size_t)i * VM_MAXL, splits + (size_t)i * VM_CLIP_NODES,
              cand + cand_offset[m.tri], cand_count[m.tri], edges, count, status, 0, 0, 0, 0, 0,
              0, 0, &cv, &dropped);
  if (!fused) { /* one level */
    if (i < grid) {
      next_count[i] = count[0];
      done_count[i] = count[1];
    }
    return;
  }
  const uint a = count[0] | count[1] << 16, b = count[2] | count[3] << 16;
  scan_a[lid] = a;
  scan_b[lid] = b;
  barrier(CLK_LOCAL_MEM_FENCE);
  vm_group_scan(scan_a, lid);
  vm_group_scan(scan_b, lid);
  if (i < grid) { /* exclusive offsets within the group */
    const uint ea = scan_a[lid] - a, eb = scan_b[lid] - b;
    next_count[i] = ea & 0xffffu;
    for (uint l = 0; l < levels; ++l)
      done_count[(size_t)l * grid + i] = (l == 0 ? ea >> 16 : l == 1 ? eb : eb >> 16) & 0xffffu;
  }
  if (lid == VM_SCAN_WG - 1) {
    __global uint* sums = block_sums + VM_CLIP_COUNTS * get_group_id(0);
    sums[0] = scan_a[lid] & 0xffffu;
    sums[1] = scan_a[lid] >> 16;
    sums[2] = scan_b[lid] & 0xffffu;
    sums[3] = scan_b[lid] >> 16;
  }
}

/* Writes the pass's children and finished fragments if both fit (the next pass's grid
 * next_grid, the finished list's done_cap) and no child needs more than VM_MAXL lines; else the
 * pass has no effect and the passes stop, the queue as it was. The finished list grows by each
 * level's finished in turn, as rounds one at a time would add them. Fused (see clip_find): each
 * group first sums the block totals, those before it (its base) and all (the pass's counts);
 * else next_offset / done_offset are global and the counts are in totals. The state is in two
 * copies: this pass's (copy sc) and the next pass's, written by work-item 0 only; every item
 * reads only this pass's, so none sees a half-written one. */
__kernel __attribute__((reqd_work_group_size(VM_SCAN_WG, 1, 1))) void clip_apply(
    __global const VmFragMeta* meta, __global const VmLine* lines, uint grid,
    __global uint* states, uint sc, uint resume, uint fused, uint levels,
    __global uint* totals, __global const uint* block_sums, uint next_grid, uint done_cap,
    __global const uint* cand_offset, __global const uint* cand, __global const VmEdge* edges,
    __global uint* splits, __global const uint* next_offset,
    __global const uint* done_offset, __global VmFragMeta* next_meta,
    __global VmLine* next_lines, __global VmFragMeta* done_meta, __global VmLine* done_lines) {
  /* (the counts as clip_find's, VM_CLIP_COUNTS == 4; dropped fragments are counted here, in
   * totals[VM_TOTAL_DROPPED], as the pass takes effect) */
  __local uint4 before_sums[VM_SCAN_WG], all_sums[VM_SCAN_WG];
  const uint i = get_global_id(0), lid = get_local_id(0), g = get_group_id(0);
  uint4 before = (uint4)(0, 0, 0, 0), all;
  if (fused) {
    const uint blocks = (grid + VM_SCAN_WG - 1) / VM_SCAN_WG;
    uint4 acc = (uint4)(0, 0, 0, 0), acc_all = (uint4)(0, 0, 0, 0);
    for (uint b = lid; b < blocks; b += VM_SCAN_WG) {
      const uint4 v = vload4(b, block_sums);
      if (b < g) acc += v;
      acc_all += v;
    }
    before_sums[lid] = acc;
    all_sums[lid] = acc_all;
    barrier(CLK_LOCAL_MEM_FENCE);
#ifdef VM_SERIAL_GROUP_SCAN /* a CPU device: one item sums, one barrier (as scan.cl) */
    if (lid == 0)
      for (uint k = 1; k < VM_SCAN_WG; ++k) {
        before_sums[0] += before_sums[k];
        all_sums[0] += all_sums[k];
      }
    barrier(CLK_LOCAL_MEM_FENCE);
#else
    for (uint o = VM_SCAN_WG / 2; o > 0; o >>= 1) {
      if (lid < o) {
        before_sums[lid] += before_sums[lid + o];
        all_sums[lid] += all_sums[lid + o];
      }
      barrier(CLK_LOCAL_MEM_FENCE);
    }
#endif
    before = before_sums[0];
    all = all_sums[0];
  } else {
    all = (uint4)(totals[VM_TOTAL_NEXT], totals[VM_TOTAL_DONE], 0, 0);
  }
  if (i >= grid) return;
  const uint nn = all.x, dn = all.y + all.z + all.w;
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
  const uint done_all[VM_CLIP_LEVELS] = {all.y, all.z, all.w};
  if (i == 0) {
    /* Rounds that ran: level 0 on the queue, level l on the fragments the level above split
     * (level l's finished and half the level below's). */
    uint ran = nq > 0, nodes = nn;
    for (int l = (int)levels - 1; l > 0; --l) {
      nodes = done_all[l] + nodes / 2;
      ran += nodes > 0;
    }
    next_state[VM_CLIP_NQ] = stop ? state[VM_CLIP_NQ] : nn;
    next_state[VM_CLIP_DONE] = stop ? done_base : done_base + dn;
    next_state[VM_CLIP_STOP] = stop;
    next_state[VM_CLIP_ROUNDS] = state[VM_CLIP_ROUNDS] + (stop ? 0u : ran);
    next_state[VM_CLIP_PASSES] = state[VM_CLIP_PASSES] + (!stop && nq > 0);
  }
  if (stop || i >= nq) return;
  const VmFragMeta m = meta[i];
  if (m.nlines == 0) return;
  const uint done_before[VM_CLIP_LEVELS] = {before.y, before.z, before.w};
  uint done[VM_CLIP_LEVELS], at = done_base;
  for (uint l = 0; l < levels; ++l) {
    done[l] = at + done_before[l] + done_offset[(size_t)l * grid + i];
    at += done_all[l];
  }
  const CullView cv = {0, 0, 0, {0, 0, 0, 0}, 0}; /* (apply reads the recorded drops) */
  uint dropped = 0;
  clip_walk(levels, m, lines + (size_t)i * VM_MAXL, splits + (size_t)i * VM_CLIP_NODES,
            cand + cand_offset[m.tri], 0, edges, 0, 0, 1, before.x + next_offset[i], done,
            next_meta, next_lines, done_meta, done_lines, &cv, &dropped);
  if (dropped) atomic_add(&totals[VM_TOTAL_DROPPED], dropped);
}
