// Decoder for the vismap compact frame, version 1 (proto/COMPACT.md), for the browser and Node 20.
// An ES module with no dependencies beyond its folder: raw deflate through the platform's
// DecompressionStream("deflate-raw") and the sections' numbers (frame_io.js, shared with
// delta.js), meshoptimizer's index codec and the walk written here. It accepts exactly the
// frames the reference (read_compact, core/stream/compact.cpp) accepts, except zstd frames, which need a
// native decoder (ask hello for compression: "deflate"), and throws a CompactFrameError
// ("compact frame: PART: what") for every other frame.
//
//   import { decodeCompact, triangleColors } from './compact.js';
//   const f = await decodeCompact(await blob.arrayBuffer());
//   // f.xy[2 * v], f.xy[2 * v + 1]: vertex v in grid steps (divide by f.quantum for pixels, y down)
//   // f.indices[3 * t + k]: triangle t's corners, clockwise on screen; f.source[t], f.mesh[t]
//   const rgb = triangleColors(f); // 3 sRGB bytes per triangle, as the SVG writer fills it
//
// Time (clients/js/test_compact.mjs --time): a 1920x1080 bunny frame (31,620 triangles, 122 KB)
// decodes in 14-17 ms (best of 30) in Node 20 and in headless Chromium 156 on the build machine,
// a shared 2-vCPU VM under load average 5-7, where a plain integer loop runs ~5x slower than on a
// desktop core: ~3 ms there. Of it: the walk ~70%, one inflate ~15% (Node inflates twice, below),
// the index codec ~7%. A per-vertex edge table keeps the walk in cache (EdgeMap).

import { decompress, Numbers } from './frame_io.js';

const MAGIC = 0x46434d56; // "VMCF" little-endian
const VERSION = 1;
const HEADER_BYTES = 44;
const SHADE = 1;
const ZSTD = 1;
const DEFLATE = 2;
const MAX_TRIANGLES = 2 ** 28;
const MAX_MESHES = 2 ** 24;
const MAX_RATIO = 256; // a payload is at most 256 times its compressed size, plus 4096

export class CompactFrameError extends Error {
  constructor(part, message) {
    super(`compact frame: ${part}: ${message}`);
    this.name = 'CompactFrameError';
    this.part = part;
  }
}

function fail(part, message) {
  throw new CompactFrameError(part, message);
}

// ---------------------------------------------------------------------------------------------
// meshoptimizer's index codec (meshopt_encodeIndexBuffer; src/indexcodec.cpp), versions 0 and 1:
// what libmeshoptimizer's decoder accepts. The buffer is a header byte 0xE0 | version, one code
// byte per triangle, the data bytes (code-aux bytes and varint-coded free indices), and a
// 16-byte code-aux table. The decoder keeps a FIFO of the last 16 edges and one of the last 16
// vertices; a code byte names an edge of the edge FIFO (high nibble) and the third vertex (low
// nibble: new, from the vertex FIFO, last index -1/+1 in version 1, or a free index), or, from
// 0xF0 up, a triangle of new/FIFO vertices through the code-aux table or a code-aux byte.

// A free index is a zigzag delta from the last one in 1..5 bytes of 7 bits (uint32 arithmetic):
// its value and its length. (Top-level functions: closures made per call defeat V8's inlining.)
function vbyte(buf, at) {
  let v = buf[at];
  if (v < 128) return v;
  v &= 127;
  for (let shift = 7; shift <= 28; shift += 7) {
    const g = buf[++at];
    v |= (g & 127) << shift;
    if (g < 128) break;
  }
  return v >>> 0;
}

function vbyteSize(buf, at) {
  let n = 1;
  while (n < 5 && buf[at + n - 1] >= 128) ++n;
  return n;
}

const unzigzag32 = (v) => (v >>> 1) ^ -(v & 1);

export function decodeIndexBuffer(indexCount, buf) {
  const nt = indexCount / 3;
  const out = new Uint32Array(indexCount);
  if (buf.length < 1 + nt + 16) fail('indices', 'shorter than the index codec needs');
  const head = buf[0];
  if ((head & 0xf0) !== 0xe0 || (head & 0x0f) > 1) fail('indices', 'not meshoptimizer index codec version 0 or 1');
  const fecmax = (head & 0x0f) >= 1 ? 13 : 15;
  const edges = new Uint32Array(32).fill(0xffffffff); // 16 x (a, b)
  const verts = new Uint32Array(16).fill(0xffffffff);
  let eo = 0;
  let vo = 0;
  let next = 0;
  let last = 0;
  let code = 1;
  let data = 1 + nt;
  const safeEnd = buf.length - 16; // each triangle reads at most 16 data bytes past a check
  const auxTable = safeEnd;

  for (let t = 0, o = 0; t < nt; ++t, o += 3) {
    const ct = buf[code++];
    let a;
    let b;
    let c;
    if (ct < 0xf0) {
      const s = (eo - 1 - (ct >> 4)) & 15;
      a = edges[2 * s];
      b = edges[2 * s + 1];
      const fec = ct & 15;
      if (fec < fecmax) {
        const isNew = fec === 0 ? 1 : 0;
        c = isNew ? next : verts[(vo - 1 - fec) & 15];
        next += isNew;
        verts[vo] = c;
        vo = (vo + isNew) & 15;
      } else {
        if (data > safeEnd) fail('indices', 'data runs into the code-aux table');
        if (fec !== 15) {
          last = (last + fec * 2 - 27) >>> 0;
        } else {
          last = (last + unzigzag32(vbyte(buf, data))) >>> 0;
          data += vbyteSize(buf, data);
        }
        c = last;
        verts[vo] = c;
        vo = (vo + 1) & 15;
      }
      edges[2 * eo] = c;
      edges[2 * eo + 1] = b;
      eo = (eo + 1) & 15;
      edges[2 * eo] = a;
      edges[2 * eo + 1] = c;
      eo = (eo + 1) & 15;
    } else {
      let feb;
      let fec;
      if (ct < 0xfe) {
        const aux = buf[auxTable + (ct & 15)];
        feb = aux >> 4;
        fec = aux & 15;
        a = next++;
        b = feb === 0 ? next : verts[(vo - feb) & 15];
        next += feb === 0 ? 1 : 0;
        c = fec === 0 ? next : verts[(vo - fec) & 15];
        next += fec === 0 ? 1 : 0;
        verts[vo] = a;
        vo = (vo + 1) & 15;
        verts[vo] = b;
        vo = (vo + (feb === 0 ? 1 : 0)) & 15;
        verts[vo] = c;
        vo = (vo + (fec === 0 ? 1 : 0)) & 15;
      } else {
        if (data > safeEnd) fail('indices', 'data runs into the code-aux table');
        const aux = buf[data++];
        const fea = ct === 0xfe ? 0 : 15;
        feb = aux >> 4;
        fec = aux & 15;
        if (aux === 0) next = 0; // reset
        a = fea === 0 ? next++ : 0;
        b = feb === 0 ? next++ : verts[(vo - feb) & 15];
        c = fec === 0 ? next++ : verts[(vo - fec) & 15];
        if (fea === 15) {
          a = last = (last + unzigzag32(vbyte(buf, data))) >>> 0;
          data += vbyteSize(buf, data);
        }
        if (feb === 15) {
          b = last = (last + unzigzag32(vbyte(buf, data))) >>> 0;
          data += vbyteSize(buf, data);
        }
        if (fec === 15) {
          c = last = (last + unzigzag32(vbyte(buf, data))) >>> 0;
          data += vbyteSize(buf, data);
        }
        verts[vo] = a;
        vo = (vo + 1) & 15;
        verts[vo] = b;
        vo = (vo + (feb === 0 || feb === 15 ? 1 : 0)) & 15;
        verts[vo] = c;
        vo = (vo + (fec === 0 || fec === 15 ? 1 : 0)) & 15;
      }
      edges[2 * eo] = b;
      edges[2 * eo + 1] = a;
      eo = (eo + 1) & 15;
      edges[2 * eo] = c;
      edges[2 * eo + 1] = b;
      eo = (eo + 1) & 15;
      edges[2 * eo] = a;
      edges[2 * eo + 1] = c;
      eo = (eo + 1) & 15;
    }
    out[o] = a;
    out[o + 1] = b;
    out[o + 2] = c;
  }
  if (data !== safeEnd) fail('indices', 'data bytes do not end at the code-aux table');
  return out;
}

// ---------------------------------------------------------------------------------------------
// The walk's directed-edge map: (a, b) -> its first entry, 3 * triangle + the corner at a. Kept
// per start vertex a: its first SLOTS edges inline, next to a's other edges, so a walk in
// vertex-cache order stays in cache (one hash table over all 3T edges missed it: ~40 ms for the
// bunny frame on the build machine, against ~2 ms here); further edges of a vertex go to a hash
// table (open addressing, linear probing, load at most 1/2).

const SLOTS = 8;

class EdgeMap {
  constructor(nv, nt) {
    this.adj = new Int32Array(2 * SLOTS * nv); // per vertex: SLOTS x (b, entry)
    this.count = new Int32Array(nv);
    this.nt = nt;
    this.mask = 0;
    this.keys = null; // the hash table: (a, b, entry + 1) per slot, made on first need
  }

  slot(a, b) {
    let h = Math.imul(a, 0x9e3779b1) ^ Math.imul(b + 0x7f4a7c15, 0x85ebca77);
    h = Math.imul(h ^ (h >>> 15), 0x2c1b3c6d);
    h = (h ^ (h >>> 13)) & this.mask;
    const k = this.keys;
    while (k[3 * h + 2] !== 0 && (k[3 * h] !== a || k[3 * h + 1] !== b)) h = (h + 1) & this.mask;
    return 3 * h;
  }

  find(a, b) { // the entry, or -1
    const n = this.count[a];
    const adj = this.adj;
    const end = 2 * SLOTS * a + 2 * Math.min(n, SLOTS);
    for (let s = 2 * SLOTS * a; s < end; s += 2) if (adj[s] === b) return adj[s + 1];
    return n > SLOTS ? this.keys[this.slot(a, b) + 2] - 1 : -1;
  }

  insert(a, b, entry) { // an edge already there keeps its first entry
    if (this.find(a, b) >= 0) return;
    const n = this.count[a]++;
    if (n < SLOTS) {
      this.adj[2 * SLOTS * a + 2 * n] = b;
      this.adj[2 * SLOTS * a + 2 * n + 1] = entry;
      return;
    }
    if (this.keys === null) {
      let cap = 16;
      while (cap < 6 * this.nt) cap *= 2;
      this.mask = cap - 1;
      this.keys = new Int32Array(3 * cap);
    }
    const s = this.slot(a, b);
    this.keys[s] = a;
    this.keys[s + 1] = b;
    this.keys[s + 2] = entry + 1;
  }
}

// The predicted position of the vertex before p and q in its triangle (COMPACT.md, Decoding 4),
// into out[0], out[1]; e: the map's entry for the edge (q, p), or -1.
function predict(xy, placed, indices, p, q, e, last, out) {
  if (placed[p] && placed[q]) {
    const o = e >= 0 ? indices[e - (e % 3) + ((e + 2) % 3)] : -1;
    if (o >= 0 && placed[o]) { // a parallelogram across the edge
      out[0] = xy[2 * p] + xy[2 * q] - xy[2 * o];
      out[1] = xy[2 * p + 1] + xy[2 * q + 1] - xy[2 * o + 1];
    } else { // the edge's midpoint, rounded toward -infinity
      out[0] = Math.floor((xy[2 * p] + xy[2 * q]) / 2);
      out[1] = Math.floor((xy[2 * p + 1] + xy[2 * q + 1]) / 2);
    }
  } else {
    const n = placed[p] ? p : placed[q] ? q : last; // (last: -1 before the first vertex)
    out[0] = n >= 0 ? xy[2 * n] : 0;
    out[1] = n >= 0 ? xy[2 * n + 1] : 0;
  }
}

// ---------------------------------------------------------------------------------------------

/**
 * Decodes a compact frame (ArrayBuffer or Uint8Array). Resolves to
 * {width, height, quantum, flags, compression, xy: Int32Array (2 per vertex, grid steps),
 *  indices: Uint32Array (3 per triangle), source: Uint32Array, mesh: Uint32Array,
 *  meshBase: Uint32Array, meshColor: Float32Array (3 per mesh, linear RGB), shade: Uint8Array|null};
 * rejects with a CompactFrameError on a malformed frame.
 * options.zstd: (bytes, size) => Uint8Array (or a promise of one), a zstd decoder of one frame
 * that throws on anything else (a WebAssembly build, or the tests' zstd CLI); without it zstd
 * frames are refused with a CompactFrameError that says to ask for deflate.
 */
export async function decodeCompact(arrayBuffer, options = {}) {
  const msg = arrayBuffer instanceof Uint8Array ? arrayBuffer : new Uint8Array(arrayBuffer);
  if (msg.length < HEADER_BYTES) fail('header', `${msg.length} bytes, the header alone is ${HEADER_BYTES}`);
  const h = new DataView(msg.buffer, msg.byteOffset, HEADER_BYTES);
  const u32 = (i) => h.getUint32(i, true);
  if (u32(0) !== MAGIC) fail('header', 'magic is not VMCF');
  const version = u32(4);
  if (version !== VERSION) fail('header', `version ${version} (this reader knows ${VERSION})`);
  const width = u32(8);
  const height = u32(12);
  const flags = u32(16);
  const quantum = u32(20);
  const nv = u32(24);
  const nt = u32(28);
  const nm = u32(32);
  const codec = u32(36);
  const size = u32(40);
  if (codec !== ZSTD && codec !== DEFLATE) fail('header', `unknown compression ${codec}`);
  if (flags & ~SHADE) fail('header', 'unknown flag bits');
  if (width < 1 || height < 1 || width > 65536 || height > 65536) fail('header', 'viewport out of range');
  if (quantum < 1 || quantum > 256) fail('header', 'quantum out of 1 ... 256');
  // (width, height <= 2^16 and quantum <= 2^8: the grid is at most 2^24 steps a side, so every
  // orientation below is exact in doubles, products under 2^49.)
  if (nt > MAX_TRIANGLES || nv > 3 * nt || (nt > 0 && nv < 3) || nm === 0 || nm > MAX_MESHES) {
    fail('header', 'counts out of range');
  }
  const z = msg.subarray(HEADER_BYTES);
  if (size > MAX_RATIO * z.length + 4096) fail('header', 'payload size out of proportion');
  const payload = await decompress(codec, z, size, options.zstd, fail);
  const frame = decodePayload(payload, { width, height, quantum, flags, nv, nt, nm });
  frame.compression = codec === ZSTD ? 'zstd' : 'deflate';
  return frame;
}

function decodePayload(payload, { width, height, quantum, flags, nv, nt, nm }) {
  // Mesh table, section sizes and sections: they fill the payload exactly.
  const pv = new DataView(payload.buffer, payload.byteOffset, payload.byteLength);
  if (payload.length < 16 * nm) fail('mesh table', 'payload ends inside it');
  const meshBase = new Uint32Array(nm);
  const meshColor = new Float32Array(3 * nm);
  for (let m = 0; m < nm; ++m) {
    meshBase[m] = pv.getUint32(16 * m, true);
    if (m > 0 && meshBase[m] < meshBase[m - 1]) fail(`mesh ${m}`, 'first ids not ascending');
    for (let c = 0; c < 3; ++c) {
      const v = pv.getFloat32(16 * m + 4 + 4 * c, true);
      if (!(v >= 0 && v <= 1)) fail(`mesh ${m}`, 'color not in [0,1]');
      meshColor[3 * m + c] = v;
    }
  }
  let at = 16 * nm;
  if (payload.length - at < 16) fail('section sizes', 'payload ends inside it');
  const sections = {};
  const sizes = [0, 1, 2, 3].map((i) => pv.getUint32(at + 4 * i, true));
  at += 16;
  ['positions', 'indices', 'ids', 'shades'].forEach((name, i) => {
    if (sizes[i] > payload.length - at) fail(name, 'payload ends inside it');
    sections[name] = payload.subarray(at, at + sizes[i]);
    at += sizes[i];
  });
  if (at !== payload.length) fail('payload', 'trailing bytes');
  const shaded = (flags & SHADE) !== 0;
  if (sections.shades.length !== (shaded ? nt : 0)) {
    fail('shades', shaded ? 'one byte per triangle expected' : 'present without the shade flag');
  }

  // Every number takes a byte at least, the index codec 1 + T + 16: refused before allocating.
  if (sections.positions.length < 2 * nv) fail('positions', `too short for ${2 * nv} numbers`);
  if (sections.ids.length < nt) fail('ids', `too short for ${nt} numbers`);
  const indices = decodeIndexBuffer(3 * nt, sections.indices);
  for (let i = 0; i < indices.length; ++i) {
    if (indices[i] >= nv) fail(`triangle ${(i / 3) | 0}`, 'vertex index out of range');
  }

  // The walk (COMPACT.md, Decoding 4).
  const xy = new Int32Array(2 * nv);
  const placed = new Uint8Array(nv);
  const source = new Uint32Array(nt);
  const mesh = new Uint32Array(nt);
  const shade = shaded ? new Uint8Array(nt) : null;
  const sres = sections.shades;
  const xmax = width * quantum;
  const ymax = height * quantum;
  const firstId = meshBase[0];
  const positions = new Numbers(sections.positions, 'positions', fail);
  const ids = new Numbers(sections.ids, 'ids', fail);
  const edges = new EdgeMap(nv, nt);
  const pxy = new Float64Array(2);
  let last = -1;
  let placedCount = 0;
  let m = 0;
  for (let t = 0; t < nt; ++t) {
    const o3 = 3 * t;
    // The map's entries for the twins (c1, c0), (c2, c1), (c0, c2), before this triangle's edges.
    const e0 = edges.find(indices[o3 + 1], indices[o3]);
    const e1 = edges.find(indices[o3 + 2], indices[o3 + 1]);
    const e2 = edges.find(indices[o3], indices[o3 + 2]);
    for (let k = 0; k < 3; ++k) { // corner k is predicted across the twin of corner k + 1's edge
      const v = indices[o3 + k];
      if (placed[v]) continue;
      const p = indices[o3 + (k + 1) % 3];
      const q = indices[o3 + (k + 2) % 3];
      predict(xy, placed, indices, p, q, k === 0 ? e1 : k === 1 ? e2 : e0, last, pxy);
      const x = pxy[0] + positions.next();
      const y = pxy[1] + positions.next();
      if (!(x >= 0 && y >= 0 && x <= xmax && y <= ymax)) fail(`vertex ${v}`, 'outside the viewport');
      xy[2 * v] = x;
      xy[2 * v + 1] = y;
      placed[v] = 1;
      ++placedCount;
      last = v;
    }
    const e = e0 >= 0 ? e0 : e1 >= 0 ? e1 : e2;
    const pred = e >= 0 ? (e / 3) | 0 : t - 1;
    const id = (pred >= 0 ? source[pred] : 0) + ids.next();
    if (!(id >= firstId && id <= 0xffffffff)) fail(`triangle ${t}`, 'source id out of range');
    source[t] = id;
    // The mesh holding the id: the last whose first id is at most it.
    if (!(meshBase[m] <= id && (m + 1 === nm || meshBase[m + 1] > id))) {
      let lo = 0;
      let hi = nm; // bisect for the first mesh whose first id is above id
      while (lo < hi) {
        const mid = (lo + hi) >>> 1;
        if (meshBase[mid] <= id) lo = mid + 1;
        else hi = mid;
      }
      m = lo - 1;
    }
    mesh[t] = m;
    if (shade) shade[t] = (pred >= 0 ? shade[pred] : 0) + sres[t];
    edges.insert(indices[o3], indices[o3 + 1], o3);
    edges.insert(indices[o3 + 1], indices[o3 + 2], o3 + 1);
    edges.insert(indices[o3 + 2], indices[o3], o3 + 2);
  }
  if (placedCount !== nv) fail('indices', 'a vertex no triangle uses');
  if (positions.p !== sections.positions.length) fail('positions', 'trailing bytes');
  if (ids.p !== sections.ids.length) fail('ids', 'trailing bytes');
  for (let t = 0; t < nt; ++t) {
    const i0 = 2 * indices[3 * t];
    const i1 = 2 * indices[3 * t + 1];
    const i2 = 2 * indices[3 * t + 2];
    const o = (xy[i1] - xy[i0]) * (xy[i2 + 1] - xy[i0 + 1]) - (xy[i1 + 1] - xy[i0 + 1]) * (xy[i2] - xy[i0]);
    if (!(o > 0)) fail(`triangle ${t}`, 'not clockwise on screen');
  }
  return {
    version: VERSION, width, height, quantum, flags, compression: null,
    xy, indices, source, mesh, meshBase, meshColor, shade,
  };
}

// ---------------------------------------------------------------------------------------------
// Colours: sRGB of mesh_color[mesh] x shade/255, rounded as the SVG writer rounds (lround), or
// without shades the id colour of `--fill id` (#RRGGBB = id + 1).

function srgb8(linear) {
  const c = Math.min(Math.max(linear, 0), 1);
  const s = (c <= 0.0031308 ? 12.92 * c : 1.055 * Math.pow(c, 1 / 2.4) - 0.055) * 255;
  const r = Math.floor(s);
  return s - r >= 0.5 ? r + 1 : r;
}

/** Triangle t's fill colour as [r, g, b] sRGB bytes. */
export function triangleColor(frame, t) {
  if (!frame.shade) {
    const rgb = (frame.source[t] + 1) & 0xffffff;
    return [rgb >>> 16, (rgb >>> 8) & 255, rgb & 255];
  }
  const m = frame.mesh[t];
  const k = frame.shade[t] / 255;
  return [0, 1, 2].map((c) => srgb8(frame.meshColor[3 * m + c] * k));
}

/** Every triangle's fill colour: a Uint8Array of 3 sRGB bytes per triangle. */
export function triangleColors(frame) {
  const nt = frame.source.length;
  const out = new Uint8Array(3 * nt);
  const cache = new Map(); // (mesh, shade) -> packed RGB: a frame has few distinct pairs
  for (let t = 0; t < nt; ++t) {
    let rgb;
    if (!frame.shade) {
      rgb = (frame.source[t] + 1) & 0xffffff;
    } else {
      const key = frame.mesh[t] * 256 + frame.shade[t];
      rgb = cache.get(key);
      if (rgb === undefined) {
        const [r, g, b] = triangleColor(frame, t);
        rgb = (r << 16) | (g << 8) | b;
        cache.set(key, rgb);
      }
    }
    out[3 * t] = rgb >>> 16;
    out[3 * t + 1] = (rgb >>> 8) & 255;
    out[3 * t + 2] = rgb & 255;
  }
  return out;
}
