// The browser's bin frame decoder (server/www/bin.js, the web viewer's bin mode) in Node against
// the reference (read_bin, core/write/bin.cpp, through `vismap decode --json`): bunny frames
// made with `vismap render --format bin` (fill, lines, fill+lines with the hidden parts) decode
// to the same arrays, line section included; malformed frames (every truncation of a small
// frame, each of its bytes set to other values, the line section's counts and words changed)
// throw BinFrameError and nothing else, and this decoder accepts a mutated frame exactly when the
// C++ reader does, with the same arrays.
//   node clients/js/test_bin.mjs --vismap build/vismap
import { spawnSync } from 'node:child_process';
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { fileURLToPath } from 'node:url';

const ROOT = path.resolve(path.dirname(fileURLToPath(import.meta.url)), '..', '..');
const { decodeBin, BinFrameError, LINE_KINDS } = await import(path.join(ROOT, 'server', 'www', 'bin.js'));
const args = process.argv.slice(2);
const vismap = args[args.indexOf('--vismap') + 1];
if (!args.includes('--vismap') || !vismap) throw new Error('usage: test_bin.mjs --vismap PATH');
const tmp = fs.mkdtempSync(path.join(os.tmpdir(), 'vismap-bin-js-'));

function assert(cond, ...what) {
  if (!cond) throw new Error(`assertion failed: ${what.map((w) => (typeof w === 'string' ? w : JSON.stringify(w))).join(' ')}`);
}

function run(argv) {
  const r = spawnSync(vismap, argv, { encoding: 'utf8', maxBuffer: 1 << 28 });
  assert(r.status !== null, 'vismap died', r.signal);
  return r;
}

// The C++ verdict: the JSON of `vismap decode --json`, or null when it refuses the frame.
function cliDecode(bytes) {
  const p = path.join(tmp, 'frame.bin');
  fs.writeFileSync(p, bytes);
  const r = run(['decode', p, '--json']);
  return r.status === 0 ? JSON.parse(r.stdout) : null;
}

// Ours: the frame, or null when refused with a BinFrameError; anything else fails the test.
function decode(bytes, what) {
  try {
    return decodeBin(bytes);
  } catch (e) {
    if (e instanceof BinFrameError && e.message.startsWith('bin frame: ')) return null;
    throw new Error(`${what}: ${e.constructor.name} instead of BinFrameError: ${e.stack}`);
  }
}

// `vismap decode --json` prints the triangles' float32 positions with 6 decimals, the line
// points exactly (%.9g).
function same(f, ref, what) {
  assert(f.width === ref.width && f.height === ref.height && f.triangles === ref.triangles, what, 'header');
  assert(f.positions.length === ref.xy.length, what, 'positions');
  for (let i = 0; i < ref.xy.length; ++i) assert(Math.abs(f.positions[i] - ref.xy[i]) <= 5e-7 * Math.max(1, Math.abs(ref.xy[i])), what, 'xy', i);
  for (let t = 0; t < f.triangles; ++t) assert(f.mesh[t] === ref.mesh[t] && f.triangleId[t] === ref.triangle_id[t], what, 'ids', t);
  assert((f.lines === null) === (ref.line_chains === undefined), what, 'line section');
  if (!f.lines) return;
  assert(f.lines.chainEnd.length === ref.line_chains && f.lines.points.length === 2 * ref.line_points, what, 'line counts');
  for (let c = 0; c < ref.line_chains; ++c) {
    assert(f.lines.chainEnd[c] === ref.chain_end[c] && f.lines.chainInfo[c] === ref.chain_info[c], what, 'chain', c);
  }
  for (let i = 0; i < ref.line_xy.length; ++i) assert(f.lines.points[i] === Math.fround(ref.line_xy[i]), what, 'line point', i);
}

const read = (p) => { const b = fs.readFileSync(p); return b.buffer.slice(b.byteOffset, b.byteOffset + b.length); };

// 1. Bunny frames, each style.
const bunny = path.join(ROOT, 'data', 'bunny.ply');
const kinds = new Map();
for (const [name, extra] of [['fill', []], ['lines', ['--style', 'lines']],
  ['fill+lines hidden', ['--style', 'fill+lines', '--hidden']]]) {
  const out = path.join(tmp, 'bunny.bin');
  const r = run(['render', bunny, '-o', out, '--format', 'bin', '--width', '640', '--height', '480', ...extra]);
  assert(r.status === 0, name, r.stderr);
  const bytes = read(out);
  const f = decode(bytes, name);
  assert(f !== null, name, 'refused');
  const ref = cliDecode(new Uint8Array(bytes));
  assert(ref !== null, name, 'the C++ reader refused it');
  same(f, ref, `bunny ${name}`);
  if (name !== 'fill') assert(f.lines.chainEnd.length > 10, name, 'few chains');
  if (name === 'lines') assert(f.triangles === 0, 'a lines frame has no triangles');
  if (f.lines) {
    for (const w of f.lines.chainInfo) {
      const k = `${LINE_KINDS[w & 255]}${w & 512 ? ' hidden' : ''}`;
      kinds.set(k, (kinds.get(k) || 0) + 1);
    }
  }
  console.log(`ok: bunny ${name}: ${f.triangles} triangles, ${f.lines ? f.lines.chainEnd.length : 0} chains`);
}
assert(kinds.get('contour') > 0 && kinds.get('contour hidden') > 0, 'contour chains, visible and hidden', [...kinds]);
console.log(`ok: chain kinds ${JSON.stringify([...kinds])}`);

// 2. A small frame (a tetrahedron, fill+lines, hidden parts) mutated: our verdict is the C++ one.
const tet = path.join(tmp, 'tet.obj');
fs.writeFileSync(tet, 'v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n');
const small = path.join(tmp, 'tet.bin');
let r = run(['render', tet, '-o', small, '--format', 'bin', '--width', '64', '--height', '64',
  '--style', 'fill+lines', '--hidden', '--eye', '2,1.5,2.5', '--target', '0.25,0.25,0.25']);
assert(r.status === 0, r.stderr);
const base = new Uint8Array(read(small));
const f0 = decode(base.buffer, 'tet');
assert(f0 && f0.lines && f0.triangles > 0, 'tet frame');
let cases = 0, refused = 0;
function check(bytes, what) {
  const ours = decode(bytes.slice().buffer, what);  // an aligned copy: views
  const theirs = cliDecode(bytes);
  assert((ours === null) === (theirs === null), what, ours === null ? 'we refuse' : 'we accept',
    theirs === null ? 'C++ refuses' : 'C++ accepts');
  if (ours) same(ours, theirs, what); else ++refused;
  ++cases;
}
for (let n = 0; n < base.length; n += n < 64 ? 1 : 7) check(base.subarray(0, n), `truncated to ${n}`);
check(new Uint8Array([...base, 0, 0, 0, 0]), 'trailing bytes');
const dv = new DataView(base.buffer);
const triEnd = 24 + 80 * f0.triangles, chains = f0.lines.chainEnd.length;
const words = [[4, 'version'], [16, 'flags'], [20, 'triangle count'], [triEnd, 'chain count'],
  [triEnd + 4, 'point count'], [triEnd + 8, 'first chain end'], [triEnd + 8 + 4 * (chains - 1), 'last chain end'],
  [triEnd + 8 + 4 * chains, 'first chain info']];
for (const [at, name] of words) {
  const v = dv.getUint32(at, true);
  for (const w of [0, 1, v - 1, v + 1, v ^ 0x100, v ^ 0x200, v ^ 0x400, 5, 0xffffffff]) {
    const m = base.slice();
    new DataView(m.buffer).setUint32(at, w >>> 0, true);
    check(m, `${name} ${v} -> ${w >>> 0}`);
  }
}
for (const at of [0, 24, triEnd - 4, base.length - 4]) {  // magic, a position, an inv_w, a line point
  for (const v of [NaN, Infinity, -1, 0]) {
    const m = base.slice();
    new DataView(m.buffer).setFloat32(at, v, true);
    check(m, `float at ${at} -> ${v}`);
  }
}
for (let at = 0; at < base.length; at += 13) {  // single bytes
  const m = base.slice();
  m[at] ^= 0x80;
  check(m, `byte ${at} flipped`);
}
console.log(`ok: ${cases} mutated frames (${refused} refused), the same verdicts and arrays as read_bin`);
// A frame at an odd offset of its buffer decodes through copies.
const odd = new Uint8Array(base.length + 1);
odd.set(base, 1);
same(decodeBin(odd.subarray(1)), cliDecode(base), 'unaligned');
console.log('ok: an unaligned frame decodes');
fs.rmSync(tmp, { recursive: true, force: true });
