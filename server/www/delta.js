// Decoder for the vismap delta frame, versions 1 and 2 (proto/DELTA.md), for the browser and Node 20.
// An ES module; raw deflate and the sections' numbers come from frame_io.js (shared with
// compact.js), zstd from an injected decoder. It keeps the state the reference keeps
// (DeltaDecoder in core/stream/delta.cpp: the source vertices and triangles sent so far, the whole set,
// the previous frame's polygon sources, the last index), accepts the frames it accepts (except an
// id gap that would wrap 64-bit arithmetic back into range, which C++ takes and this refuses) and
// gives the same arrays bit for bit.
//
//   import { DeltaDecoder, DeltaOutOfSync } from './delta.js';
//   const decoder = new DeltaDecoder();            // or new DeltaDecoder({ zstd: (bytes, size) => ... })
//   try {
//     const f = await decoder.decode(await blob.arrayBuffer());
//     // f.xy[2 * v], f.xy[2 * v + 1]: vertex v in grid steps (f.quantum per pixel, y down);
//     // f.indices[3 * t + k]: triangle t's corners; f.source[t], f.mesh[t], f.shade[t]
//   } catch (e) {
//     if (e instanceof DeltaOutOfSync) ws.send(JSON.stringify({ type: 'keyframe' }));
//   }
//
// Exactness: JS numbers are IEEE doubles, so the projection is DELTA.md's operation by operation
// in the order written (as C++ evaluates it), rounded half away from zero (llround; Math.round
// rounds -2.5 to -2); edge points are exact integer arithmetic (BigInt past 2^53), and so are
// orientations (coordinates of source vertices may reach 1e9 grid steps: BigInt past 2^26).
// Calls to decode run one after another in call order, whatever their awaits. Version 2 streams
// may hold compact frames (decoded by compact.js; {compact: true}, the state left alone) and
// start from a held scene (holdScene: the sources message).
//
// Time (clients/js/test_delta.mjs --time): a 1920x1080 bunny orbit delta frame (18-23 KB, 31,000
// triangles of which 26,000-28,000 whole, 2,200-2,500 polygons with 9,000-10,000 corners)
// decodes in 12-15 ms (best of 15) in Node 20 on the build machine (a shared 2-vCPU VM, load
// average 3-5, where compact.js takes 14-17 ms for the compact frame of the same view); a 53 KB
// frame (4,900 polygons) in ~17 ms, a 330 KB keyframe in 20-30 ms. Of a delta frame: the whole
// triangles ~60% (projection, orientation and shade of each), the corners ~20%, inflate ~15%.

import { decompress, Numbers } from './frame_io.js';
import { decodeCompact } from './compact.js';

const MAGIC = 0x46444d56; // "VMDF" little-endian
const COMPACT_MAGIC = 0x46434d56; // "VMCF"
const HEADER_BYTES = 48;
const KEYFRAME = 1;
const HELD = 2; // version 2, keyframes: the store starts from the held scene
const SOURCES = 4; // version 2: the sources message
const MAX_RATIO = 256;
const MAX_SOURCES = 2 ** 26; // triangles, and vertices, a client holds (as core/stream/delta.cpp)
const CAMERA_BYTES = 4 + 18 * 8;
const UNSENT = 0xffffffff;
const SECTIONS = ['vertices', 'vertex positions', 'triangles', 'removed', 'added', 'polygons', 'corner codes',
  'vertex refs', 'points', 'edge steps', 'flips']; // version 1: the first ten
// Corner codes (DELTA.md, "Corner codes").
const VERTEX_REF = 3;
const NEW_POINT = 4;
const TWIN = 5;
const EDGE_POINT = 6;
const POINT_REF = 9;
const EDGE_REF = 9; // version 2: 9 + 3i + k, a point made on own edge k's source edge
const EDGE_REFS = 2;
const POINT_REF2 = 15; // version 2: 15 + j
export class DeltaFrameError extends Error {
  constructor(part, message) {
    super(`delta frame: ${part}: ${message}`);
    this.name = 'DeltaFrameError';
    this.part = part;
  }
}

/** The frame applies to a frame this decoder has not decoded last: ask for a keyframe. */
export class DeltaOutOfSync extends DeltaFrameError {
  constructor(message) {
    super('header', message);
    this.name = 'DeltaOutOfSync';
  }
}

function fail(part, message) {
  throw new DeltaFrameError(part, message);
}

/** C's llround (nearest, ties away from zero) of a double below 2^52 in magnitude. */
export function llround(g) {
  const t = Math.trunc(g);
  const f = g - t; // exact below 2^52
  return f >= 0.5 ? t + 1 : f <= -0.5 ? t - 1 : t;
}

/**
 * core/stream/delta.cpp's project_to_grid: the world point (x, y, z) through the rows to the grid, into
 * out[at], out[at + 1]; false when not in front (cw <= 0) or far outside (|grid| >= 1e9).
 */
export function projectToGrid(r, width, height, quantum, x, y, z, out, at) {
  const cx = r[0] * x + r[1] * y + r[2] * z + r[3];
  const cy = r[4] * x + r[5] * y + r[6] * z + r[7];
  const cw = r[8] * x + r[9] * y + r[10] * z + r[11];
  if (!(cw > 0)) return false;
  const gx = (cx / cw + 1.0) * 0.5 * width * quantum;
  const gy = (1.0 - cy / cw) * 0.5 * height * quantum;
  if (!(Math.abs(gx) < 1e9 && Math.abs(gy) < 1e9)) return false;
  out[at] = llround(gx);
  out[at + 1] = llround(gy);
  return true;
}

// floor(s * d / n + 1/2) exactly, n > 0, 1 <= s < n, |d| <= n (DELTA.md's div for edge points).
function stepAlong(s, d, n) {
  if (n < 2 ** 26) { // 2 s d + n < 2^53: exact in doubles
    const num = 2 * s * d + n;
    const den = 2 * n;
    let r = num % den;
    if (r < 0) r += den;
    return (num - r) / den;
  }
  const num = 2n * BigInt(s) * BigInt(d) + BigInt(n);
  const den = 2n * BigInt(n);
  let q = num / den; // truncates toward zero
  if (num % den < 0n) q -= 1n;
  return Number(q);
}

// The sign of twice the signed area of (a, b, c) on the grid, exact.
function orient(xy, a, b, c) {
  const x1 = xy[2 * b] - xy[2 * a];
  const y1 = xy[2 * b + 1] - xy[2 * a + 1];
  const x2 = xy[2 * c] - xy[2 * a];
  const y2 = xy[2 * c + 1] - xy[2 * a + 1];
  const lim = 2 ** 26; // products below 2^52: exact in doubles
  if (Math.abs(x1) < lim && Math.abs(y1) < lim && Math.abs(x2) < lim && Math.abs(y2) < lim) {
    return Math.sign(x1 * y2 - y1 * x2);
  }
  const o = BigInt(x1) * BigInt(y2) - BigInt(y1) * BigInt(x2);
  return o > 0n ? 1 : o < 0n ? -1 : 0;
}

// A list of ids: a count, then ascending gaps (each after the first >= 1), each id < limit.
function readIds(s, limit) {
  const n = s.uint();
  if (n > limit) fail(s.part, 'more ids than the scene has');
  const ids = new Uint32Array(n);
  let id = 0;
  for (let i = 0; i < n; ++i) {
    const d = s.uint();
    if (i > 0 && d === 0) fail(s.part, 'not ascending');
    id += d;
    if (id >= limit) fail(s.part, 'out of range');
    ids[i] = id;
  }
  return ids;
}

// Flags (DELTA.md): a bit per entry of a list of n; set(i) for each set bit.
function readFlags(s, n, set) {
  for (let i = 0; i < n; i += 8) {
    if (s.p >= s.b.length) fail(s.part, 'ends early');
    const bits = s.b[s.p++];
    for (let b = 0; b < 8; ++b) {
      if ((bits >> b) & 1) {
        if (i + b >= n) fail(s.part, "a flag past the list's end");
        set(i + b);
      }
    }
  }
}

function hasId(sorted, id) { // binary search
  let lo = 0;
  let hi = sorted.length;
  while (lo < hi) {
    const mid = (lo + hi) >>> 1;
    if (sorted[mid] < id) lo = mid + 1;
    else hi = mid;
  }
  return lo < sorted.length && sorted[lo] === id;
}

function mergeSorted(a, b) { // two ascending lists without common ids
  const out = new Uint32Array(a.length + b.length);
  let i = 0;
  let j = 0;
  let n = 0;
  while (i < a.length || j < b.length) out[n++] = j === b.length || (i < a.length && a[i] < b[j]) ? a[i++] : b[j++];
  return out;
}

// DELTA.md's facing of held triangle id at view {rows, width, height, quantum}: 0 degenerate, 1
// positive, 2 negative, 3 a vertex that does not project; proj/state cache each vertex's grid.
function facing(view, vertex, tri, id, proj, state) {
  for (let k = 0; k < 3; ++k) {
    const gv = tri[3 * id + k];
    if (!state[gv]) {
      state[gv] = projectToGrid(view.rows, view.width, view.height, view.quantum, vertex[3 * gv], vertex[3 * gv + 1],
        vertex[3 * gv + 2], proj, 2 * gv) ? 1 : 2;
    }
    if (state[gv] === 2) return 3;
  }
  const o = orient(proj, tri[3 * id], tri[3 * id + 1], tri[3 * id + 2]);
  return o > 0 ? 1 : o < 0 ? 2 : 0;
}

// Ascending ids of the held triangles whose facing differs between the two views.
function facingFlips(before, now, vertex, tri) {
  const nVerts = vertex.length / 3;
  const pa = new Int32Array(2 * nVerts);
  const pb = new Int32Array(2 * nVerts);
  const sa = new Uint8Array(nVerts);
  const sb = new Uint8Array(nVerts);
  const flips = [];
  for (let id = 0, n = tri.length / 3; id < n; ++id) {
    if (tri[3 * id] === UNSENT) continue;
    if (facing(before, vertex, tri, id, pa, sa) !== facing(now, vertex, tri, id, pb, sb)) flips.push(id);
  }
  return Uint32Array.from(flips);
}

// The 48-byte header's fields, checked as far as the header alone tells.
function readHeader(msg) {
  if (msg.length < HEADER_BYTES) fail('header', `${msg.length} bytes, the header alone is ${HEADER_BYTES}`);
  const h = new DataView(msg.buffer, msg.byteOffset, HEADER_BYTES);
  const u32 = (i) => h.getUint32(i, true);
  if (u32(0) !== MAGIC) fail('header', 'magic is not VMDF');
  const r = {
    version: u32(4), width: u32(8), height: u32(12), flags: u32(16), quantum: u32(20), index: u32(24),
    base: u32(28), nm: u32(32), codec: u32(36), size: u32(40), wholeCount: u32(44),
  };
  if (r.version !== 1 && r.version !== 2) fail('header', `version ${r.version} (this decoder knows 1, 2)`);
  if (r.flags & ~(r.version === 1 ? KEYFRAME : KEYFRAME | HELD | SOURCES)) fail('header', 'unknown flag bits');
  if (r.flags & HELD && !(r.flags & KEYFRAME)) fail('header', 'held without keyframe');
  if (r.flags & SOURCES && r.flags !== SOURCES) fail('header', 'sources with other flags');
  if (r.width < 1 || r.height < 1 || r.width > 65536 || r.height > 65536) fail('header', 'viewport out of range');
  if (r.quantum < 1 || r.quantum > 256) fail('header', 'quantum out of 1 ... 256');
  if (r.codec !== 1 && r.codec !== 2) fail('header', `unknown compression ${r.codec}`);
  if (r.nm === 0 || r.nm > 2 ** 24) fail('header', 'mesh count out of range');
  r.key = (r.flags & KEYFRAME) !== 0;
  r.held = (r.flags & HELD) !== 0;
  return r;
}

// A keyframe's (or the sources message's) mesh table at `at`: {meshBase, colors, tris, verts}.
function readMeshTable(payload, pv, at, nm) {
  if (payload.length - at < 24 * nm) fail('mesh', 'ends early');
  const meshBase = new Uint32Array(nm);
  const colors = new Float32Array(3 * nm);
  let tris = 0;
  let verts = 0;
  for (let m = 0; m < nm; ++m, at += 24) {
    const first = pv.getUint32(at, true);
    if (first !== tris) fail(`mesh ${m}`, 'first ids do not follow the counts');
    meshBase[m] = first;
    tris += pv.getUint32(at + 4, true);
    verts += pv.getUint32(at + 8, true);
    for (let c = 0; c < 3; ++c) {
      const v = pv.getFloat32(at + 12 + 4 * c, true);
      if (!(v >= 0 && v <= 1)) fail(`mesh ${m}`, 'color not in [0, 1]');
      colors[3 * m + c] = v;
    }
    if (tris > MAX_SOURCES || verts > MAX_SOURCES) fail(`mesh ${m}`, 'more than 2^26 triangles or vertices');
  }
  return { meshBase, colors, tris, verts, at };
}

function emptyStore(tris, verts) {
  try { // (as C++: the store is sized by the mesh table, up to 2^26 of each)
    return { vertex: new Float32Array(3 * verts).fill(NaN), tri: new Uint32Array(3 * tris).fill(UNSENT) };
  } catch (e) {
    if (!(e instanceof RangeError)) throw e;
    fail('mesh', `no memory for ${verts} vertices and ${tris} triangles`);
  }
}

// The section sizes and sections (count of them), which must fill the payload.
function readSections(payload, pv, at, count) {
  if (payload.length - at < 4 * count) fail('section sizes', 'ends early');
  const sec = [];
  let from = at + 4 * count;
  for (let i = 0; i < SECTIONS.length; ++i) {
    const n = i < count ? pv.getUint32(at + 4 * i, true) : 0;
    if (n > payload.length - from) fail(SECTIONS[i], 'ends early');
    sec.push(new Numbers(payload.subarray(from, from + n), SECTIONS[i], fail));
    from += n;
  }
  if (from !== payload.length) fail('camera', 'trailing bytes');
  return sec;
}

// The vertices and triangles sections onto the store: {vertex, tri}, copies where changed.
function addSources(sec, vertex, tri) {
  const nTris = tri.length / 3;
  const nVerts = vertex.length / 3;
  {
    const s = sec[0];
    const n = s.uint();
    if (n > nVerts) fail('vertices', 'more than the scene has');
    const pos = sec[1].b;
    if (pos.length !== 12 * n) fail('vertex positions', pos.length < 12 * n ? 'ends early' : 'trailing bytes');
    const dv = new DataView(pos.buffer, pos.byteOffset, pos.byteLength);
    if (n > 0) vertex = vertex.slice();
    let gv = 0;
    for (let i = 0; i < n; ++i) {
      const d = s.uint();
      if (i > 0 && d === 0) fail('vertices', 'not ascending');
      gv += d;
      if (gv >= nVerts) fail(`vertices ${i}`, 'out of range');
      for (let c = 0; c < 3; ++c) {
        const v = dv.getFloat32(12 * i + 4 * c, true);
        if (!Number.isFinite(v)) fail(`vertices ${i}`, 'not finite');
        vertex[3 * gv + c] = v;
      }
    }
    s.done();
  }
  {
    const s = sec[2];
    const n = s.uint();
    if (n > nTris) fail('triangles', 'more than the scene has');
    if (n > 0) tri = tri.slice();
    let id = 0;
    let lastV = 0;
    for (let i = 0; i < n; ++i) {
      const d = s.uint();
      if (i > 0 && d === 0) fail(`triangles ${i}`, 'not ascending');
      id += d;
      if (id >= nTris) fail(`triangles ${i}`, 'out of range');
      for (let k = 0; k < 3; ++k) {
        lastV += s.next();
        if (!(lastV >= 0 && lastV < nVerts) || Number.isNaN(vertex[3 * lastV])) {
          fail(`triangles ${i}`, 'names a vertex not sent');
        }
        tri[3 * id + k] = lastV;
      }
    }
    s.done();
  }
  return { vertex, tri };
}

// The frame being decoded: the projections of the store's vertices (each once, when first
// named), the output vertices (a slot for each source vertex at its first use, one for each new
// point) and triangles. A class, not closures in apply(): V8 inlines its methods (closures made
// per call kept the whole triangles' loop 3x slower).
class Output {
  constructor(vertex, tri, meshBase, camera, maxV, maxT) {
    this.P = vertex;
    this.V = tri;
    this.meshBase = meshBase;
    this.c = camera;
    this.nVerts = vertex.length / 3;
    this.proj = new Int32Array(2 * this.nVerts);
    this.projected = new Uint8Array(this.nVerts); // 1: in front, 2: not
    this.slot = new Int32Array(this.nVerts).fill(-1);
    this.xy = new Int32Array(2 * maxV);
    this.indices = new Uint32Array(3 * maxT);
    this.source = new Uint32Array(maxT);
    this.mesh = new Uint32Array(maxT);
    this.shade = new Uint8Array(maxT);
    this.nv = 0;
    this.nt = 0;
    this.shadeId = -1;
    this.shadeValue = 0;
    this.meshLo = 0; // ids meshLo ... meshHi - 1 are in mesh meshValue
    this.meshHi = 0;
    this.meshValue = 0;
  }

  at(gv, what, index) { // gv if a sent vertex in front of the camera (projected), else fails
    const P = this.P;
    if (!(gv >= 0 && gv < this.nVerts) || Number.isNaN(P[3 * gv])) fail(`${what} ${index}`, 'names a vertex not sent');
    if (!this.projected[gv]) {
      const c = this.c;
      this.projected[gv] = projectToGrid(c.rows, c.width, c.height, c.quantum, P[3 * gv], P[3 * gv + 1], P[3 * gv + 2],
        this.proj, 2 * gv) ? 1 : 2;
    }
    if (this.projected[gv] === 2) fail(`${what} ${index}`, 'a vertex behind the camera');
    return gv;
  }

  slotOf(gv) { // the output vertex of a projected source vertex
    let s = this.slot[gv];
    if (s < 0) {
      s = this.slot[gv] = this.nv++;
      this.xy[2 * s] = this.proj[2 * gv];
      this.xy[2 * s + 1] = this.proj[2 * gv + 1];
    }
    return s;
  }

  point(x, y) { // a new point's output vertex
    const s = this.nv++;
    this.xy[2 * s] = x;
    this.xy[2 * s + 1] = y;
    return s;
  }

  emit(a, b, c, id, either) { // the triangle if positive on the grid (either: or negative, turned)
    let o = orient(this.xy, a, b, c);
    if (o < 0 && either) {
      const t = b;
      b = c;
      c = t;
      o = 1;
    }
    if (o <= 0) return;
    const t = this.nt++;
    this.indices[3 * t] = a;
    this.indices[3 * t + 1] = b;
    this.indices[3 * t + 2] = c;
    this.source[t] = id;
    if (!(id >= this.meshLo && id < this.meshHi)) this.findMesh(id);
    this.mesh[t] = this.meshValue;
    if (id !== this.shadeId) {
      this.shadeId = id;
      this.shadeValue = this.shadeOf(id);
    }
    this.shade[t] = this.shadeValue;
  }

  findMesh(id) { // the last mesh whose first id is at most id, and its range of ids
    const base = this.meshBase;
    let lo = 0;
    let hi = base.length;
    while (lo < hi) {
      const mid = (lo + hi) >>> 1;
      if (base[mid] <= id) lo = mid + 1;
      else hi = mid;
    }
    this.meshValue = lo - 1;
    this.meshLo = base[lo - 1];
    this.meshHi = lo < base.length ? base[lo] : 2 ** 32;
  }

  // The Lambert factor of --fill shade, as core/stream/delta.cpp's shade_of: every product and sum in
  // doubles, in its order.
  shadeOf(id) {
    const P = this.P;
    const a = 3 * this.V[3 * id];
    const b = 3 * this.V[3 * id + 1];
    const c = 3 * this.V[3 * id + 2];
    const p0x = P[a], p0y = P[a + 1], p0z = P[a + 2];
    const p1x = P[b], p1y = P[b + 1], p1z = P[b + 2];
    const p2x = P[c], p2y = P[c + 1], p2z = P[c + 2];
    const e1x = p1x - p0x, e1y = p1y - p0y, e1z = p1z - p0z;
    const e2x = p2x - p0x, e2y = p2y - p0y, e2z = p2z - p0z;
    const { eye, target } = this.c;
    const lx = eye[0] - target[0], ly = eye[1] - target[1], lz = eye[2] - target[2];
    const n0 = e1y * e2z - e1z * e2y;
    const n1 = e1z * e2x - e1x * e2z;
    const n2 = e1x * e2y - e1y * e2x;
    let ndl = Math.abs(n0 * lx + n1 * ly + n2 * lz) /
      (Math.sqrt(n0 * n0 + n1 * n1 + n2 * n2) * Math.sqrt(lx * lx + ly * ly + lz * lz));
    if (!Number.isFinite(ndl)) ndl = 1.0;
    return llround((0.12 + 0.88 * (1.0 < ndl ? 1.0 : ndl)) * 255.0);
  }

  result() {
    return {
      xy: this.xy.slice(0, 2 * this.nv), indices: this.indices.slice(0, 3 * this.nt),
      source: this.source.slice(0, this.nt), mesh: this.mesh.slice(0, this.nt), shade: this.shade.slice(0, this.nt),
    };
  }
}

export class DeltaDecoder {
  /** options.zstd: (bytes, size) => Uint8Array (or a promise of one), as compact.js's. */
  constructor(options = {}) {
    this.zstd = options.zstd || null;
    this.tail = Promise.resolve();
    this.held = null; // holdScene's {meshBase, colors, vertex, tri}
    this.reset();
  }

  /**
   * Keeps the scene of a sources message (DELTA.md, "The held scene"): keyframes flagged held
   * start from it. Rejects with a DeltaFrameError when malformed (what was held stays).
   */
  holdScene(arrayBuffer) {
    const run = this.tail.then(async () => {
      const msg = arrayBuffer instanceof Uint8Array ? arrayBuffer : new Uint8Array(arrayBuffer);
      const h = readHeader(msg);
      if (!(h.flags & SOURCES)) fail('header', 'not a sources message');
      const z = msg.subarray(HEADER_BYTES);
      if (h.size > MAX_RATIO * z.length + 4096) fail('header', 'payload size out of proportion');
      const payload = await decompress(h.codec, z, h.size, this.zstd, fail);
      const pv = new DataView(payload.buffer, payload.byteOffset, payload.byteLength);
      const t = readMeshTable(payload, pv, 0, h.nm);
      const empty = emptyStore(t.tris, t.verts);
      const sec = readSections(payload, pv, t.at, 3);
      const { vertex, tri } = addSources(sec, empty.vertex, empty.tri);
      for (let v = 0; v < vertex.length / 3; ++v) if (Number.isNaN(vertex[3 * v])) fail(`vertices ${v}`, 'not sent');
      this.held = { meshBase: t.meshBase, colors: t.colors, vertex, tri };
    });
    this.tail = run.catch(() => {});
    return run;
  }

  get holdsScene() {
    return this.held !== null;
  }

  /** Drops the state: the next frame must be a keyframe. */
  reset() {
    this.have = false;
    this.last = 0;
    this.base = new Uint32Array(0); // per mesh: first global triangle id
    this.colors = new Float32Array(0); // 3 per mesh
    this.vertex = new Float32Array(0); // 3 per global vertex, NaN: not sent
    this.tri = new Uint32Array(0); // 3 per global triangle, UNSENT: not sent
    this.whole = new Uint32Array(0); // sorted
    this.partial = new Uint32Array(0); // sorted: the previous frame's polygon sources
    this.view = null; // the last frame's {rows, width, height, quantum}
  }

  get hasState() {
    return this.have;
  }

  /** The index of the last frame decoded, null before the first keyframe. */
  get lastIndex() {
    return this.have ? this.last : null;
  }

  /**
   * Decodes the next frame (ArrayBuffer or Uint8Array). Resolves to {width, height, quantum,
   * index, keyframe, compression, projection, eye, target, rows, xy: Int32Array (2 per vertex,
   * grid steps), indices: Uint32Array (3 per triangle), source, mesh: Uint32Array, shade:
   * Uint8Array, meshBase: Uint32Array, meshColor: Float32Array (3 per mesh, linear RGB)}. Rejects
   * with DeltaOutOfSync when the frame does not apply to the last decoded one (ask the server
   * for a keyframe), with a DeltaFrameError when it is malformed; both leave the state alone.
   */
  decode(arrayBuffer) {
    const run = this.tail.then(() => this.decodeNow(arrayBuffer));
    this.tail = run.catch(() => {});
    return run;
  }

  async decodeNow(arrayBuffer) {
    const msg = arrayBuffer instanceof Uint8Array ? arrayBuffer : new Uint8Array(arrayBuffer);
    if (msg.length >= 4 && new DataView(msg.buffer, msg.byteOffset, 4).getUint32(0, true) === COMPACT_MAGIC) {
      return this.compactFrame(msg);
    }
    const { version, width, height, flags, quantum, index, base, nm, codec, size, wholeCount, key, held } =
      readHeader(msg);
    if (flags & SOURCES) fail('header', 'a sources message (holdScene takes it)');
    if (held && !this.held) throw new DeltaOutOfSync('a keyframe of the held scene, and this decoder holds none');
    if (!key && !this.have) throw new DeltaOutOfSync('no keyframe decoded yet: ask for one');
    if (!key && (base !== this.last || nm !== this.base.length)) {
      throw new DeltaOutOfSync(`based on frame ${base}, the last decoded is ${this.last}: ask for a keyframe`);
    }
    const z = msg.subarray(HEADER_BYTES);
    if (size > MAX_RATIO * z.length + 4096) fail('header', 'payload size out of proportion');
    const payload = await decompress(codec, z, size, this.zstd, fail);
    const { frame, state } = this.apply(payload, { version, width, height, quantum, index, key, held, nm, wholeCount });
    frame.compression = codec === 1 ? 'zstd' : 'deflate';
    Object.assign(this, state); // commit
    this.last = index;
    this.have = true;
    return frame;
  }

  // A compact frame in a version 2 stream: drawn as it is, the state left alone.
  async compactFrame(msg) {
    let c;
    try {
      c = await decodeCompact(msg, { zstd: this.zstd });
    } catch (e) {
      if (e instanceof DeltaFrameError || !(e instanceof Error)) throw e;
      fail('compact frame', e.message);
    }
    if (!c.shade) fail('compact frame', 'no shades');
    return {
      width: c.width, height: c.height, quantum: c.quantum, index: 0, keyframe: false, compact: true,
      compression: c.compression, projection: 'perspective', eye: new Float64Array(3), target: new Float64Array(3),
      rows: new Float64Array(12), xy: c.xy, indices: c.indices, source: c.source, mesh: c.mesh, shade: c.shade,
      meshBase: c.meshBase, meshColor: c.meshColor,
    };
  }

  // The payload on top of the state: the frame and the state after it (this is not changed).
  apply(payload, { version, width, height, quantum, index, key, held, nm, wholeCount }) {
    const pv = new DataView(payload.buffer, payload.byteOffset, payload.byteLength);
    if (payload.length < CAMERA_BYTES) fail('camera', 'ends early');
    if (payload[0] > 1) fail('camera', 'unknown projection');
    const ortho = payload[0] === 1;
    const cam = new Float64Array(18);
    for (let k = 0; k < 18; ++k) cam[k] = pv.getFloat64(4 + 8 * k, true);
    for (let k = 0; k < 6; ++k) if (!Number.isFinite(cam[k])) fail('camera', 'eye or target not finite');
    for (let k = 6; k < 18; ++k) if (!Number.isFinite(cam[k])) fail('camera', 'projection not finite');
    const eye = cam.slice(0, 3);
    const target = cam.slice(3, 6);
    const rows = cam.slice(6, 18);
    let at = CAMERA_BYTES;

    // The store: a keyframe's mesh table sizes it anew (or names the held scene's); copies where
    // this frame changes it.
    let meshBase = this.base;
    let colors = this.colors;
    let vertex = this.vertex;
    let tri = this.tri;
    let whole = this.whole;
    let partial = this.partial;
    if (key) {
      const t = readMeshTable(payload, pv, at, nm);
      at = t.at;
      meshBase = t.meshBase;
      colors = t.colors;
      if (held) {
        const h = this.held;
        const same = (a, b) => a.length === b.length && a.every((v, i) => v === b[i]);
        if (!same(h.meshBase, meshBase) || !same(h.colors, colors) || h.tri.length !== 3 * t.tris ||
            h.vertex.length !== 3 * t.verts) fail('mesh', "not the held scene's meshes");
        vertex = h.vertex;
        tri = h.tri;
      } else {
        ({ vertex, tri } = emptyStore(t.tris, t.verts));
      }
      whole = new Uint32Array(0);
      partial = new Uint32Array(0);
    }
    const nTris = tri.length / 3;
    const nVerts = vertex.length / 3;
    const sec = readSections(payload, pv, at, version === 1 ? 10 : 11);

    // Version 2: the facing flips since the last frame, on the store before this frame's sources.
    const view = { rows, width, height, quantum };
    const flips = version >= 2 && !key ? facingFlips(this.view, view, vertex, tri) : new Uint32Array(0);
    ({ vertex, tri } = addSources(sec, vertex, tri));

    // The whole set's change: the flips' bits, then the lists of the rest.
    const fin = [];
    const fout = [];
    for (const id of flips) (hasId(whole, id) ? fin : fout).push(id);
    const flagRemoved = [];
    const flagAdded = [];
    readFlags(sec[10], fin.length, (i) => flagRemoved.push(fin[i]));
    readFlags(sec[10], fout.length, (i) => flagAdded.push(fout[i]));
    sec[10].done();
    const restRemoved = readIds(sec[3], nTris);
    const restAdded = readIds(sec[4], nTris);
    sec[3].done();
    sec[4].done();
    for (const [name, list] of [['removed', restRemoved], ['added', restAdded]]) {
      for (const id of list) if (hasId(flips, id)) fail(`${name} ${id}`, 'an id the flips cover');
    }
    const removed = mergeSorted(Uint32Array.from(flagRemoved), restRemoved);
    const added = mergeSorted(Uint32Array.from(flagAdded), restAdded);
    {
      const kept = new Uint32Array(whole.length);
      let nk = 0;
      let j = 0;
      for (let i = 0; i < whole.length;) {
        if (j < removed.length && removed[j] === whole[i]) ++j, ++i;
        else if (j < removed.length && removed[j] < whole[i]) break; // removed[j] is not in the set
        else kept[nk++] = whole[i++];
      }
      if (j !== removed.length) fail('removed', 'an id that was not drawn whole');
      const next = new Uint32Array(nk + added.length);
      let a = 0;
      let k = 0;
      let n = 0;
      while (k < nk || a < added.length) {
        if (a === added.length || (k < nk && kept[k] < added[a])) next[n++] = kept[k++];
        else if (k === nk || added[a] < kept[k]) next[n++] = added[a++];
        else fail('added', 'an id that is drawn whole already');
      }
      whole = next;
      if (whole.length !== wholeCount) fail('added', 'the whole set has the wrong size');
    }

    // Output: at most 3 vertices and one triangle per whole triangle, and per corner a vertex
    // and a triangle (every corner takes a byte of the codes).
    const codes = sec[6];
    const refs = sec[7];
    const pts = sec[8];
    const steps = sec[9];
    const out = new Output(vertex, tri, meshBase, { rows, width, height, quantum, ortho, eye, target },
      3 * whole.length + codes.b.length, whole.length + codes.b.length);
    for (let i = 0; i < whole.length; ++i) {
      const id = whole[i];
      if (tri[3 * id] === UNSENT) fail(`added ${id}`, 'a triangle not sent');
      const a = out.slotOf(out.at(tri[3 * id], 'whole', id));
      const b = out.slotOf(out.at(tri[3 * id + 1], 'whole', id));
      const c = out.slotOf(out.at(tri[3 * id + 2], 'whole', id));
      out.emit(a, b, c, id, true); // either orientation: back faces are drawn too
    }

    // The polygons' sources (DELTA.md, "Polygons section").
    const s = sec[5];
    const order = [];
    const candidates = flips.filter((id) => !hasId(whole, id) && !hasId(removed, id) && !hasId(partial, id));
    for (const list of [removed, partial, candidates]) readFlags(s, list.length, (i) => order.push(list[i]));
    {
      const nr = s.uint();
      if (nr > nTris) fail('polygons', 'more sources than the scene has');
      let id = 0;
      for (let i = 0; i < nr; ++i) {
        const d = s.uint();
        if (i > 0 && d === 0) fail(`polygons ${i}`, 'not ascending');
        id += d;
        if (id >= nTris) fail(`polygons ${i}`, 'source out of range');
        order.push(id);
      }
    }
    partial = Uint32Array.from(order).sort();
    for (let i = 1; i < partial.length; ++i) if (partial[i] === partial[i - 1]) fail('polygons', 'a source named twice');
    const polyCount = new Float64Array(order.length);
    let npoly = 0;
    for (let i = 0; i < order.length; ++i) {
      const count = s.uint() + 1;
      if (count > 2 ** 20 || npoly + count > 2 ** 28) fail('polygons', 'too many');
      polyCount[i] = count;
      npoly += count;
    }

    // The corners.
    const xmax = width * quantum;
    const ymax = height * quantum;
    const pointSlot = new Int32Array(codes.b.length); // per new point: its output slot
    let npoints = 0;
    const twin = new Int32Array(nVerts + codes.b.length).fill(-1); // by corner identity
    const ring = [];
    const ringId = [];
    let lx = 0;
    let ly = 0;
    let p = 0;
    const v2 = version >= 2;
    const pointRef = v2 ? POINT_REF2 : POINT_REF;
    const edges = new Map(); // version 2: source edge (min * 2^26 + max) -> the first points made on it
    const edgeKey = (a, b) => (a < b ? a * 2 ** 26 + b : b * 2 ** 26 + a);
    for (let o = 0; o < order.length; ++o) {
      const id = order[o];
      for (let q = 0; q < polyCount[o]; ++q, ++p) {
        if (tri[3 * id] === UNSENT) fail(`polygons ${p}`, 'unknown source');
        const corners = s.uint() + 3;
        if (corners > 2 ** 20) fail(`polygons ${p}`, 'too many corners');
        ring.length = 0;
        ringId.length = 0;
        let pointBefore = false;
        for (let k = 0; k < corners; ++k) {
          const code = codes.uint();
          if (code < VERTEX_REF) {
            const gv = tri[3 * id + code];
            ring.push(out.slotOf(out.at(gv, 'polygons', p)));
            ringId.push(gv);
            pointBefore = false;
          } else if (code === VERTEX_REF) {
            const gv = tri[3 * id] + refs.next();
            if (!(gv >= 0 && gv < nVerts)) fail(`polygons ${p}`, 'vertex ref');
            ring.push(out.slotOf(out.at(gv, 'polygons', p)));
            ringId.push(gv);
            pointBefore = false;
          } else if (code === TWIN) {
            const t = ringId.length ? twin[ringId[ringId.length - 1]] : -1;
            if (t < 0) fail(`polygons ${p}`, 'a twin corner without an earlier edge');
            if (t < nVerts) {
              ring.push(out.slotOf(out.at(t, 'polygons', p)));
              pointBefore = false;
            } else {
              ring.push(pointSlot[t - nVerts]);
              pointBefore = true;
            }
            ringId.push(t);
          } else if (code === NEW_POINT || (code >= EDGE_POINT && code < EDGE_POINT + 3)) {
            let x;
            let y;
            if (code === NEW_POINT) {
              const prev = ring.length ? ring[ring.length - 1] : 0;
              const bx = pointBefore ? out.xy[2 * prev] : lx;
              const by = pointBefore ? out.xy[2 * prev + 1] : ly;
              x = lx = bx + pts.next();
              y = ly = by + pts.next();
            } else { // a step along own edge k, as this side projects its ends
              const e = code - EDGE_POINT;
              const a = out.at(tri[3 * id + e], 'polygons', p);
              const b = out.at(tri[3 * id + ((e + 1) % 3)], 'polygons', p);
              const proj = out.proj;
              const dx = proj[2 * b] - proj[2 * a];
              const dy = proj[2 * b + 1] - proj[2 * a + 1];
              const n = Math.max(Math.abs(dx), Math.abs(dy));
              const st = steps.uint();
              if (n < 2 || st < 1 || st >= n) fail(`edge steps ${npoints}`, 'out of the edge');
              x = proj[2 * a] + stepAlong(st, dx, n);
              y = proj[2 * a + 1] + stepAlong(st, dy, n);
              if (v2) {
                const key = edgeKey(a, b);
                let on = edges.get(key);
                if (!on) edges.set(key, (on = []));
                if (on.length < EDGE_REFS) on.push(npoints);
              }
            }
            if (!(x >= 0 && y >= 0 && x <= xmax && y <= ymax)) fail(`points ${npoints}`, 'outside the viewport');
            const at = out.point(x, y);
            pointSlot[npoints++] = at;
            ring.push(at);
            ringId.push(nVerts + npoints - 1);
            pointBefore = true;
          } else {
            let k;
            if (code < pointRef) { // version 2: a point made on own edge e's source edge
              const e = (code - EDGE_REF) % 3;
              const on = edges.get(edgeKey(tri[3 * id + e], tri[3 * id + ((e + 1) % 3)]));
              const i = Math.floor((code - EDGE_REF) / 3);
              if (!on || i >= on.length) fail(`polygons ${p}`, 'no such point on the edge');
              k = on[i];
            } else {
              const j = code - pointRef;
              if (j >= npoints) fail(`polygons ${p}`, 'point ref out of range');
              k = npoints - 1 - j;
            }
            ring.push(pointSlot[k]);
            ringId.push(nVerts + k);
            pointBefore = true;
          }
        }
        const m = ringId.length;
        for (let k = 0; k < m; ++k) {
          const b = ringId[(k + 1) % m];
          if (twin[b] < 0) twin[b] = ringId[k];
        }
        for (let k = 1; k + 1 < m; ++k) out.emit(ring[0], ring[k], ring[k + 1], id, false);
      }
    }
    s.done();
    codes.done();
    refs.done();
    pts.done();
    steps.done();

    const { xy, indices, source, mesh, shade } = out.result();
    return {
      frame: {
        width, height, quantum, index, keyframe: key, compression: null,
        projection: ortho ? 'orthographic' : 'perspective', eye, target, rows,
        xy, indices, source, mesh, shade, meshBase: meshBase.slice(), meshColor: colors.slice(),
      },
      state: { base: meshBase, colors, vertex, tri, whole, partial, view },
    };
  }
}
