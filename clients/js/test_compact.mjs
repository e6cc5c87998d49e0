// The browser's compact decoder (server/www/compact.js) in Node 20 against the reference
// (core/stream/compact.cpp through `vismap decode --json`): the test vectors decode to their JSON
// (the zstd one through the zstd CLI as options.zstd, and refused with a clear error without it);
// bunny frames made with `vismap render --compression deflate` decode to the same arrays, their
// colours are the SVG's; malformed frames (every truncation, byte flips, header fields, payloads
// mutated and recompressed) throw CompactFrameError and nothing else, and where the C++ reader
// accepts a mutated frame this one accepts it with the same arrays, and vice versa.
//   node clients/js/test_compact.mjs [--vismap build/vismap] [--time]
// Exits 77 (skipped) where DecompressionStream("deflate-raw") is missing (Node < 20).
import { execFileSync, spawnSync } from 'node:child_process';
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import zlib from 'node:zlib';

const ROOT = path.resolve(path.dirname(fileURLToPath(import.meta.url)), '..', '..');
const VECTORS = path.join(ROOT, 'proto', 'vectors');
try {
  new DecompressionStream('deflate-raw');
} catch {
  console.log('skipped: no DecompressionStream("deflate-raw") (Node 20 or later has it)');
  process.exit(77);
}
const { decodeCompact, triangleColors, triangleColor, CompactFrameError } =
  await import(path.join(ROOT, 'server', 'www', 'compact.js'));

const args = process.argv.slice(2);
const vismap = args.includes('--vismap') ? args[args.indexOf('--vismap') + 1] : null;
const timing = args.includes('--time');
const tmp = fs.mkdtempSync(path.join(os.tmpdir(), 'vismap-compact-js-'));
const ARRAYS = [['xy', 'xy'], ['indices', 'indices'], ['source', 'source'], ['mesh', 'mesh'],
  ['meshBase', 'mesh_base'], ['shade', 'shade']];

function assert(cond, ...what) {
  if (!cond) throw new Error(`assertion failed: ${what.map((w) => (typeof w === 'string' ? w : JSON.stringify(w))).join(' ')}`);
}

function same(f, ref, what) {
  for (const k of ['width', 'height', 'quantum']) assert(f[k] === ref[k], what, k, f[k], ref[k]);
  assert(f.xy.length / 2 === ref.vertices && f.source.length === ref.triangles, what, 'counts');
  for (const [ours, theirs] of ARRAYS) {
    const a = f[ours] ? Array.from(f[ours]) : [];
    const b = ref[theirs];
    assert(a.length === b.length, what, ours, a.length, b.length);
    for (let i = 0; i < a.length; ++i) assert(a[i] === b[i], what, ours, 'at', i, a[i], b[i]);
  }
}

function valid(f, what) {
  const nv = f.xy.length / 2;
  const nt = f.source.length;
  assert(f.indices.length === 3 * nt && f.mesh.length === nt && (f.shade === null) === !(f.flags & 1), what);
  for (let t = 0; t < nt; ++t) {
    const [a, b, c] = [0, 1, 2].map((k) => f.indices[3 * t + k]);
    assert(a < nv && b < nv && c < nv, what, 'index');
    const o = (f.xy[2 * b] - f.xy[2 * a]) * (f.xy[2 * c + 1] - f.xy[2 * a + 1]) -
      (f.xy[2 * b + 1] - f.xy[2 * a + 1]) * (f.xy[2 * c] - f.xy[2 * a]);
    assert(o > 0, what, 'orientation', t);
    assert(f.source[t] >= f.meshBase[f.mesh[t]], what, 'mesh');
  }
  for (let i = 0; i < f.xy.length; ++i) assert(f.xy[i] >= 0 && f.xy[i] <= (i & 1 ? f.height : f.width) * f.quantum, what);
}

// Resolves to the frame, or null when refused with a CompactFrameError; anything else fails.
async function decode(bytes, what, options) {
  try {
    return await decodeCompact(bytes, options);
  } catch (e) {
    if (e instanceof CompactFrameError && e.message.startsWith('compact frame: ')) return null;
    throw new Error(`${what}: ${e.constructor.name} instead of CompactFrameError: ${e.stack}`);
  }
}

function cliDecode(bytes) {
  const p = path.join(tmp, 'frame.vmc');
  fs.writeFileSync(p, bytes);
  const r = spawnSync(vismap, ['decode', p, '--json'], { encoding: 'utf8', maxBuffer: 1 << 28 });
  assert(r.status !== null, 'vismap decode died', r.signal);
  return r.status === 0 ? JSON.parse(r.stdout) : null;
}

function zstdCli(bytes, size) {
  const out = execFileSync('zstd', ['-d', '-c', '-q'], { input: bytes, maxBuffer: size + 1024 });
  return new Uint8Array(out.buffer, out.byteOffset, out.length);
}
const haveZstd = spawnSync('zstd', ['--version']).status === 0;

function render(name, ...flags) {
  const out = path.join(tmp, name);
  execFileSync(vismap, ['render', path.join(ROOT, 'data', 'bunny.ply'), '-o', out, ...flags], { stdio: 'ignore' });
  return new Uint8Array(fs.readFileSync(out));
}

// A small deterministic PRNG (mulberry32): the mutations are the same on every run.
function rng(seed) {
  let a = seed >>> 0;
  return () => {
    a = (a + 0x6d2b79f5) >>> 0;
    let t = a;
    t = Math.imul(t ^ (t >>> 15), t | 1);
    t ^= t + Math.imul(t ^ (t >>> 7), t | 61);
    return ((t ^ (t >>> 14)) >>> 0) / 4294967296;
  };
}

function* mutations(frame, random, count) {
  const dv = new DataView(frame.buffer, frame.byteOffset, frame.byteLength);
  const nm = dv.getUint32(32, true);
  const payload = new Uint8Array(zlib.inflateRawSync(frame.subarray(44)));
  const pack = (p) => {
    const z = zlib.deflateRawSync(p);
    const out = new Uint8Array(44 + z.length);
    out.set(frame.subarray(0, 44));
    new DataView(out.buffer).setUint32(40, p.length, true);
    out.set(z, 44);
    return out;
  };
  const int = (n) => Math.floor(random() * n);
  for (let i = 0; i < 10; ++i) {
    const v0 = dv.getUint32(4 + 4 * i, true);
    for (const v of [0, 1, 2, 3, 0xffffffff, v0 + 1, v0 - 1]) {
      const b = frame.slice();
      new DataView(b.buffer).setUint32(4 + 4 * i, v >>> 0, true);
      yield [`header field ${i} = ${v}`, b];
    }
  }
  for (let k = 0; k < count; ++k) {
    const kind = k % 5;
    if (kind === 0) {
      const b = frame.slice();
      const at = int(b.length);
      b[at] ^= random() < 0.5 ? 1 << int(8) : 1 + int(255);
      yield [`message byte ${at} flipped`, b];
      continue;
    }
    let b = payload.slice();
    let what;
    if (kind === 1 || kind === 2) {
      const lo = kind === 2 ? 16 * nm + 16 : 0;
      for (let n = [1, 1, 2, 3][int(4)]; n > 0; --n) {
        const at = lo + int(b.length - lo);
        b[at] ^= random() < 0.6 ? 1 << int(8) : 1 + int(255);
      }
      what = 'payload bytes flipped';
    } else if (kind === 3) {
      const at = int(b.length);
      const n = 1 + int(3);
      if (random() < 0.5) {
        b = new Uint8Array([...b.subarray(0, at), ...b.subarray(at + n)]);
      } else {
        b = new Uint8Array([...b.subarray(0, at), ...Array.from({ length: n }, () => int(256)), ...b.subarray(at)]);
      }
      what = `payload cut or grown at ${at}`;
    } else {
      const pv = new DataView(b.buffer);
      const i = int(4);
      const j = (i + 1 + int(3)) % 4;
      const d = 1 + int(3);
      pv.setUint32(16 * nm + 4 * i, (pv.getUint32(16 * nm + 4 * i, true) + d) >>> 0, true);
      pv.setUint32(16 * nm + 4 * j, (pv.getUint32(16 * nm + 4 * j, true) - d) >>> 0, true);
      what = `section sizes ${i} += ${d}, ${j} -= ${d}`;
    }
    yield [what, pack(b)];
  }
}

const tests = {
  async vectors() {
    const ref = JSON.parse(fs.readFileSync(path.join(VECTORS, 'compact_cornell.json'), 'utf8'));
    const deflate = new Uint8Array(fs.readFileSync(path.join(VECTORS, 'compact_cornell_deflate.vmc')));
    const f = await decodeCompact(deflate.buffer.slice(deflate.byteOffset, deflate.byteOffset + deflate.length));
    same(f, ref, 'deflate vector');
    valid(f, 'deflate vector');
    assert(f.compression === 'deflate' && f.meshColor.length === 3 * f.meshBase.length);
    const zstd = new Uint8Array(fs.readFileSync(path.join(VECTORS, 'compact_cornell.vmc')));
    try {
      await decodeCompact(zstd);
      assert(false, 'zstd frame decoded without a zstd decoder');
    } catch (e) {
      assert(e instanceof CompactFrameError && /zstd frames need a native decoder; ask .*deflate/.test(e.message), e.message);
    }
    if (haveZstd) {
      const g = await decodeCompact(zstd, { zstd: zstdCli });
      same(g, ref, 'zstd vector');
      assert(g.compression === 'zstd');
    } else {
      console.log('  (no zstd CLI: the zstd vector checked only for its refusal)');
    }
    for (const bad of [[], [0x56, 0x4d, 0x43, 0x46], Array(100).fill(255)]) {
      assert((await decode(new Uint8Array(bad), 'bad')) === null, 'accepted', bad.length);
    }
  },

  async truncated() {
    const data = new Uint8Array(fs.readFileSync(path.join(VECTORS, 'compact_cornell_deflate.vmc')));
    for (let n = 0; n < data.length; ++n) {
      assert((await decode(data.subarray(0, n), `cut to ${n}`)) === null, `cut to ${n} accepted`);
    }
    // Counts at the format's limit over a small payload: refused before anything that size is made.
    const huge = data.slice();
    new DataView(huge.buffer).setUint32(28, 2 ** 28, true);
    const t0 = performance.now();
    assert((await decode(huge, 'huge')) === null && performance.now() - t0 < 1000, '2^28 triangles');
    for (const junk of [[0], [1, 2, 3]]) {
      const b = new Uint8Array([...data, ...junk]);
      assert((await decode(b, 'junk')) === null, 'bytes after the deflate stream accepted');
    }
  },

  async bunny() {
    const frames = {
      'bunny_deflate.vmc': ['--format', 'compact', '--compression', 'deflate', '--width', '1920', '--height', '1080'],
      'bunny_deflate_id.vmc': ['--format', 'compact', '--compression', 'deflate', '--fill', 'id', '--quantum', '4',
        '--width', '640', '--height', '480'],
    };
    for (const [name, flags] of Object.entries(frames)) {
      const data = render(name, ...flags);
      const ref = cliDecode(data);
      const f = await decodeCompact(data);
      same(f, ref, name);
      valid(f, name);
      const svg = path.join(tmp, `${name}.svg`);
      execFileSync(vismap, ['decode', path.join(tmp, name), '-o', svg], { stdio: 'ignore' });
      const fills = new Set([...fs.readFileSync(svg, 'utf8').matchAll(/fill="#([0-9a-f]{6})"/g)].map((m) => m[1]));
      const rgb = triangleColors(f);
      const ours = new Set();
      const hex = (r, g, b) => ((r << 16) | (g << 8) | b).toString(16).padStart(6, '0');
      for (let t = 0; t < f.source.length; ++t) ours.add(hex(rgb[3 * t], rgb[3 * t + 1], rgb[3 * t + 2]));
      assert(fills.size === ours.size && [...fills].every((c) => ours.has(c)), name, 'colours', fills.size, ours.size);
      const [r, g, b] = triangleColor(f, 7);
      assert(hex(r, g, b) === hex(rgb[21], rgb[22], rgb[23]), 'triangleColor');
      if (timing) {
        const times = [];
        for (let i = 0; i < 30; ++i) {
          const t0 = performance.now();
          await decodeCompact(data);
          times.push(performance.now() - t0);
        }
        times.sort((x, y) => x - y);
        console.log(`  ${name}: ${f.source.length} triangles, ${f.xy.length / 2} vertices, ${data.length} bytes: ` +
          `decode ${times[0].toFixed(2)} ms min, ${times[15].toFixed(2)} ms median (30 runs)`);
      }
    }
  },

  async malformed() {
    const random = rng(16);
    const cases = [];
    const vector = new Uint8Array(fs.readFileSync(path.join(VECTORS, 'compact_cornell_deflate.vmc')));
    for (const [w, d] of mutations(vector, random, 1500)) cases.push([`vector: ${w}`, d]);
    if (vismap) {
      const bunny = new Uint8Array(fs.readFileSync(path.join(tmp, 'bunny_deflate_id.vmc')));
      for (const [w, d] of mutations(bunny, random, 40)) cases.push([`bunny: ${w}`, d]);
    }
    let accepted = 0;
    let checked = 0;
    for (let k = 0; k < cases.length; ++k) {
      const [what, data] = cases[k];
      const f = await decode(data, what);
      if (f) {
        valid(f, what);
        ++accepted;
      }
      if (vismap && (k % 12 === 0 || f)) {
        const ref = cliDecode(data);
        ++checked;
        assert((ref === null) === (f === null), what, `C++ ${ref === null ? 'refuses' : 'accepts'}, JS not`);
        if (f) same(f, ref, what);
      }
    }
    console.log(`  ${cases.length} malformed frames: ${accepted} still valid frames, ${checked} compared with vismap decode`);
  },
};

let failed = false;
try {
  for (const [name, fn] of Object.entries(tests)) {
    if (!vismap && name === 'bunny') {
      console.log('no --vismap: bunny frames and the comparison with the C++ reader skipped');
      continue;
    }
    const t0 = performance.now();
    await fn();
    console.log(`ok ${name} (${((performance.now() - t0) / 1000).toFixed(1)} s)`);
  }
} catch (e) {
  console.error(e.stack || e);
  failed = true;
} finally {
  fs.rmSync(tmp, { recursive: true, force: true });
}
console.log(failed ? 'FAILED' : 'ok');
process.exit(failed ? 1 : 0);
