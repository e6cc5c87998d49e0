// Decoder for the vismap binary triangle list, version 1 (proto/FORMAT.md), with its optional
// line section, for the browser and Node 20. An ES module with no dependencies. It accepts exactly
// the frames the reference (read_bin, core/write/bin.cpp) accepts and throws a BinFrameError
// ("bin frame: PART: what", PART the header, a section, a line chain or point, a triangle) for
// every other frame. The sections are views into the frame's bytes where they are 4-byte aligned
// (a WebSocket ArrayBuffer is), copies otherwise.
//
//   import { decodeBin, LINE_KINDS } from './bin.js';
//   const f = decodeBin(arrayBuffer);
//   // f.positions[6 * t + 2 * k], [... + 1]: triangle t's corner k in pixels (y down)
//   // f.mesh[t], f.triangleId[t]; f.bary, f.invW with attributes (flags bit 0), else null
//   // f.lines: null, or {chainEnd, chainInfo, points}: chain c's points are
//   //   points[2 * chainEnd[c - 1] ...] up to 2 * chainEnd[c] (chainEnd[-1] = 0); its kind
//   //   LINE_KINDS[chainInfo[c] & 255], closed (chainInfo[c] >> 8) & 1, hidden (... >> 9) & 1

const MAGIC = 0x50414d56; // "VMAP" little-endian
const VERSION = 1;
const HEADER_BYTES = 24;
const ATTRIBUTES = 1;
const LINES = 2;
const CLOSED = 1 << 8;
const HIDDEN = 1 << 9;

/** The line kinds in the order of their numbers: the SVG writer's class names. */
export const LINE_KINDS = ['contour', 'boundary', 'crease', 'intersection', 'border'];

export class BinFrameError extends Error {
  constructor(part, message) {
    super(`bin frame: ${part}: ${message}`);
    this.name = 'BinFrameError';
    this.part = part;
  }
}

const fail = (part, message) => { throw new BinFrameError(part, message); };

// `count` elements of `Type` at byte `offset` of `buffer` (absolute, 4-byte multiple).
function view(Type, buffer, offset, count) {
  return offset % 4 === 0 ? new Type(buffer, offset, count)
    : new Type(buffer.slice(offset, offset + 4 * count));
}

/** Decodes one frame: an ArrayBuffer, or a Uint8Array over part of one. */
export function decodeBin(input) {
  const bytes = input instanceof Uint8Array ? input : new Uint8Array(input);
  const size = bytes.length;
  if (size < HEADER_BYTES) fail('header', `${size} bytes, the header alone needs ${HEADER_BYTES}`);
  const dv = new DataView(bytes.buffer, bytes.byteOffset, size);
  const u32 = (at) => dv.getUint32(at, true);
  if (u32(0) !== MAGIC) fail('header', 'magic is not VMAP');
  const version = u32(4);
  if (version !== VERSION) fail('header', `unsupported version ${version} (this reader knows 1)`);
  const width = u32(8), height = u32(12), flags = u32(16), t = u32(20);
  if (flags & ~(ATTRIBUTES | LINES)) fail('header', `unknown flags ${flags}`);
  const attrs = (flags & ATTRIBUTES) !== 0;
  const triEnd = HEADER_BYTES + t * (attrs ? 80 : 32);
  let chains = 0, points = 0, need = triEnd;
  if ((flags & LINES) && size >= triEnd + 8) { chains = u32(triEnd); points = u32(triEnd + 4); }
  if (flags & LINES) need += 8 + 8 * chains + 8 * points;
  if (size < need && size >= triEnd) fail('section', `lines end at byte ${need} but the frame has ${size} bytes`);
  if (size < need) {
    const names = ['positions', 'mesh', 'triangle_id', 'bary', 'inv_w'];
    const ends = [24, 28, 32, 68, 80].map((b) => HEADER_BYTES + b * t);
    let s = 0;
    while (ends[s] <= size) ++s;
    fail('section', `${names[s]} ends at byte ${ends[s]} but the frame has ${size} bytes ` +
                    `(${t} triangles need ${need})`);
  }
  if (size > need) {
    fail('frame', `${size - need} trailing bytes after ${t} triangles` +
                  `${flags & LINES ? ' and the lines' : ''} (${need} bytes)`);
  }
  const buf = bytes.buffer, base = bytes.byteOffset;
  let lines = null;
  if (flags & LINES) {
    const chainEnd = view(Uint32Array, buf, base + triEnd + 8, chains);
    const chainInfo = view(Uint32Array, buf, base + triEnd + 8 + 4 * chains, chains);
    const pts = view(Float32Array, buf, base + triEnd + 8 + 8 * chains, 2 * points);
    let last = 0;
    for (let c = 0; c < chains; ++c) {
      const end = chainEnd[c], w = chainInfo[c];
      if (end <= last || end > points) {
        fail(`line chain ${c}`, `chain end ${end} after ${last} (chains hold at least one point, ${points} in all)`);
      }
      if ((w & 255) >= LINE_KINDS.length || (w & ~(255 | CLOSED | HIDDEN))) fail(`line chain ${c}`, `bad info word ${w}`);
      last = end;
    }
    if (last !== points) fail('lines', `chains end at point ${last} of ${points}`);
    for (let i = 0; i < pts.length; ++i) {
      if (!Number.isFinite(pts[i])) fail(`line point ${i >> 1}`, 'non-finite position');
    }
    lines = { chainEnd, chainInfo, points: pts };
  }
  const positions = view(Float32Array, buf, base + HEADER_BYTES, 6 * t);
  for (let i = 0; i < positions.length; ++i) {
    if (!Number.isFinite(positions[i])) fail(`triangle ${Math.floor(i / 6)}`, 'non-finite position');
  }
  const mesh = view(Uint32Array, buf, base + HEADER_BYTES + 24 * t, t);
  const triangleId = view(Uint32Array, buf, base + HEADER_BYTES + 28 * t, t);
  let bary = null, invW = null;
  if (attrs) {
    bary = view(Float32Array, buf, base + HEADER_BYTES + 32 * t, 9 * t);
    invW = view(Float32Array, buf, base + HEADER_BYTES + 68 * t, 3 * t);
    for (let i = 0; i < bary.length; ++i) {
      if (!Number.isFinite(bary[i])) fail(`triangle ${Math.floor(i / 9)}`, 'non-finite barycentric');
    }
    for (let i = 0; i < invW.length; ++i) {
      if (!(invW[i] > 0) || !Number.isFinite(invW[i])) fail(`triangle ${Math.floor(i / 3)}`, '1/w must be positive and finite');
    }
  }
  return { width, height, flags, triangles: t, positions, mesh, triangleId, bary, invW, lines };
}
