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

/* One round over a grid of `grid` items (the host's bound; clip_apply keeps the queue within it):
 * items past the device-side queue length write zero counts, for the scans over the grid.
 * resume: the host has made room after a stop, this round runs whatever the state says.
 * packed: one count per item, children + (finished << VM_CLIP_PACK_SHIFT), in next_count. */
inline void clip_counts(__global uint* next_count, __global uint* done_count, uint i, uint packed,
                        uint next, uint done) {
  if (packed) {
    next_count[i] = next | (done << VM_CLIP_PACK_SHIFT);
  } else {
    next_count[i] = next;
    done_count[i] = done;
  }
}

__kernel void clip_find(__global const VmFragMeta* meta, __global const VmLine* lines, uint grid,
                        __global const uint* states, uint sc, uint resume, uint packed,
                        __global const uint* cand_offset,
                        __global const uint* cand_count, __global const uint* cand,
                        __global const VmEdge* edges, __global uint* split_at,
                        __global uint* next_count, __global uint* done_count,
                        __global uint* status) {
  uint i = get_global_id(0);
  if (i >= grid) return;
  const uint nq = clip_queue_length(states + sc * VM_CLIP_WORDS, resume);
  if (i >= nq) {
    split_at[i] = VM_NONE;
    clip_counts(next_count, done_count, i, packed, 0, 0);
    return;
  }
  VmFragMeta m = meta[i];
  if (m.nlines == 0) { /* a root fragment outside its region (frag_init) */
    split_at[i] = VM_NONE;
    clip_counts(next_count, done_count, i, packed, 0, 0);
    return;
  }
  __global const VmLine* L = lines + (size_t)i * VM_MAXL;
  uint off = cand_offset[m.tri], n = cand_count[m.tri];
  int sgn[VM_MAXL];
  /* The fragment's box (from approximate vertices, widened by a grid unit: only a filter) lets
   * most far-away segments go without the exact tests. */
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
      split_at[i] = k;
      clip_counts(next_count, done_count, i, packed, 2, 0);
      return;
    }
  }
  split_at[i] = VM_NONE;
  clip_counts(next_count, done_count, i, packed, 0, 1);
}

/* Writes the round's children and finished fragments if both fit (the next round's grid
 * next_grid, the finished list's done_cap) and no child needs more than VM_MAXL lines; else the
 * round has no effect and the rounds stop,
 * the queue as it was. The state is in two copies: this round's (copy sc) and the next round's,
 * written by work-item 0 only; every item reads only this round's, so none sees a half-written
 * one. */
__kernel void clip_apply(__global const VmFragMeta* meta, __global const VmLine* lines, uint grid,
                         __global uint* states, uint sc, uint resume, uint packed,
                         __global const uint* totals, uint next_grid, uint done_cap,
                         __global const uint* cand_offset, __global const uint* cand,
                         __global const VmEdge* edges, __global const uint* split_at,
                         __global const uint* next_offset, __global const uint* done_offset,
                         __global VmFragMeta* next_meta, __global VmLine* next_lines,
                         __global VmFragMeta* done_meta, __global VmLine* done_lines) {
  uint i = get_global_id(0);
  if (i >= grid) return;
  __global const uint* state = states + sc * VM_CLIP_WORDS;
  __global uint* next_state = states + (sc ^ 1u) * VM_CLIP_WORDS;
  const uint nq = clip_queue_length(state, resume);
  const uint tn = totals[VM_TOTAL_NEXT], pmask = (1u << VM_CLIP_PACK_SHIFT) - 1u;
  const uint nn = packed ? tn & pmask : tn;
  const uint dn = packed ? tn >> VM_CLIP_PACK_SHIFT : totals[VM_TOTAL_DONE];
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
    uint d = done_base + (packed ? next_offset[i] >> VM_CLIP_PACK_SHIFT : done_offset[i]);
    done_meta[d] = m;
    for (uint j = 0; j < m.nlines; ++j) done_lines[(size_t)d * VM_MAXL + j] = L[j];
    return;
  }
  VmEdge E = edges[cand[cand_offset[m.tri] + k]];
  int sgn[VM_MAXL];
  cuts(L, m.nlines, E, sgn);
  uint o = packed ? next_offset[i] & pmask : next_offset[i];
  Line3 LE = edge_line(E);
  VmLine cut = vm_line(LE), rev = vm_line(line_reversed(LE));
  VmFragMeta c = m;
  c.next = k + 1;
  c.nlines = split_side(L, m.nlines, sgn, 1, cut, next_lines + (size_t)o * VM_MAXL, 1);
  next_meta[o] = c;
  c.nlines = split_side(L, m.nlines, sgn, -1, rev, next_lines + (size_t)(o + 1) * VM_MAXL, 1);
  next_meta[o + 1] = c;
}
