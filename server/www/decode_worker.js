// The web viewer's decoder (a module Worker, server/www/viewer.js): compact and delta frames are
// decoded here, off the page's thread, and turned into what the page draws in one step, handed
// back as transferred buffers (no copy):
//   gl  one buffer for WebGL 2 (gl_draw.js), instances for two draws: first, per edge that a
//       triangle shares with another, a stroke 1 px wide in the triangle's colour (as the SVG
//       writer strokes shared edges: 20 bytes, float32 ax, ay, bx, by in pixels, uint8 r, g, b,
//       255), then per triangle its fill (28 bytes: float32 x0, y0, x1, y1, x2, y2 in pixels,
//       uint8 r, g, b, 255). Corners are exact in float32 (grid steps over a power of two);
//   2d  the frame's xy, indices and colours, for the 2D canvas fallback (viewer.js drawCompact).
// Messages in: {id, kind: 'compact'|'delta'|'sources'|'reset', bytes, target: 'gl'|'2d'}; out:
// {id, ok: true, frame: {...}, decodeMs, buildMs} or {id, ok: false, error, outOfSync}. A delta
// session's DeltaDecoder lives here (the held scene's sources too); 'reset' drops it.
import { decodeCompact, triangleColors } from './compact.js';
import { DeltaDecoder, DeltaOutOfSync } from './delta.js';
import { sharedEdges } from './mesh_edges.js';

export const STROKE_BYTES = 20;
export const FILL_BYTES = 28;

let delta = new DeltaDecoder();

// The buffer described above, from a frame's grid triangles and sRGB colours: {buffer, strokes,
// fills} (instance counts; the fills start at strokes * STROKE_BYTES).
export function glInstances(f, colors) {
  const q = f.quantum, xy = f.xy, ix = f.indices, n = ix.length / 3;
  const mask = sharedEdges(ix, xy.length / 2);
  let strokes = 0;
  for (let t = 0; t < n; ++t) strokes += (mask[t] & 1) + ((mask[t] >> 1) & 1) + ((mask[t] >> 2) & 1);
  const buffer = new ArrayBuffer(strokes * STROKE_BYTES + n * FILL_BYTES);
  const fl = new Float32Array(buffer);
  const u8 = new Uint8Array(buffer);
  const at = (t, k) => ix[3 * t + k];
  let s = 0;
  for (let t = 0; t < n; ++t) {
    for (let k = 0; k < 3; ++k) {
      if (!((mask[t] >> k) & 1)) continue;
      const a = at(t, k), b = at(t, (k + 1) % 3), o = (s * STROKE_BYTES) / 4;
      fl[o] = xy[2 * a] / q;
      fl[o + 1] = xy[2 * a + 1] / q;
      fl[o + 2] = xy[2 * b] / q;
      fl[o + 3] = xy[2 * b + 1] / q;
      u8.set([colors[3 * t], colors[3 * t + 1], colors[3 * t + 2], 255], s * STROKE_BYTES + 16);
      ++s;
    }
  }
  const base = strokes * STROKE_BYTES;
  for (let t = 0; t < n; ++t) {
    const o = (base + t * FILL_BYTES) / 4;
    for (let k = 0; k < 3; ++k) {
      fl[o + 2 * k] = xy[2 * at(t, k)] / q;
      fl[o + 2 * k + 1] = xy[2 * at(t, k) + 1] / q;
    }
    u8.set([colors[3 * t], colors[3 * t + 1], colors[3 * t + 2], 255], base + t * FILL_BYTES + 24);
  }
  return { buffer, strokes, fills: n };
}

async function decode(kind, bytes) {
  if (kind === 'compact') return decodeCompact(bytes);
  return delta.decode(bytes);
}

if (typeof self !== 'undefined') self.onmessage = async (e) => {
  const { id, kind, bytes, target } = e.data;
  try {
    if (kind === 'reset') {
      delta = new DeltaDecoder();
      return;
    }
    if (kind === 'sources') {
      await delta.holdScene(bytes);
      self.postMessage({ id, ok: true });
      return;
    }
    const t0 = performance.now();
    const f = await decode(kind, bytes);
    const t1 = performance.now();
    const colors = triangleColors(f);
    const frame = {
      width: f.width, height: f.height, quantum: f.quantum, triangles: f.indices.length / 3,
      keyframe: !!f.keyframe, compact: !!f.compact,
    };
    const transfer = [];
    if (target === 'gl') {
      frame.gl = glInstances(f, colors);
      transfer.push(frame.gl.buffer);
    } else {
      frame.xy = f.xy;
      frame.indices = f.indices;
      frame.colors = colors;
      transfer.push(f.xy.buffer, f.indices.buffer, colors.buffer);
    }
    self.postMessage({ id, ok: true, frame, decodeMs: t1 - t0, buildMs: performance.now() - t1 }, transfer);
  } catch (err) {
    self.postMessage({ id, ok: false, error: String(err.message || err), outOfSync: err instanceof DeltaOutOfSync });
  }
};
