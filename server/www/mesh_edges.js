// Which edges of a decoded frame's triangles two triangles share (server/www: the WebGL draw's
// strokes, decode_worker.js, and the 2D canvas's, viewer.js drawCompact; both stroke the shared
// edges 1 px wide in the fill colour, as the SVG writer does). An ES module.

// Per triangle a 3-bit mask of its shared edges: edge k (corner k to k + 1) used by another
// triangle too, in either direction. Counted on each vertex's list of the corners that follow it
// (typed arrays, prefix sums: a Map of edges took ~60% of the 2D canvas draw's script time for a
// 1920x1080 bunny frame, bench/stream/clients.py).
export function sharedEdges(indices, nv) {
  const n = indices.length / 3;
  const first = new Int32Array(nv + 1);
  const next = new Int32Array(indices.length);
  for (let i = 0; i < indices.length; ++i) ++first[indices[i] + 1];
  for (let a = 0; a < nv; ++a) first[a + 1] += first[a];
  const fill = first.slice(0, nv);
  for (let i = 0; i < indices.length; i += 3) {
    for (let k = 0; k < 3; ++k) next[fill[indices[i + k]]++] = indices[i + (k + 1) % 3];
  }
  const uses = (a, b) => {
    let u = 0;
    for (let j = first[a], e = first[a + 1]; j < e; ++j) u += next[j] === b;
    for (let j = first[b], e = first[b + 1]; j < e; ++j) u += next[j] === a;
    return u;
  };
  const mask = new Uint8Array(n);
  for (let t = 0; t < n; ++t) {
    const a = indices[3 * t], b = indices[3 * t + 1], c = indices[3 * t + 2];
    mask[t] = (uses(a, b) >= 2 ? 1 : 0) | (uses(b, c) >= 2 ? 2 : 0) | (uses(c, a) >= 2 ? 4 : 0);
  }
  return mask;
}

