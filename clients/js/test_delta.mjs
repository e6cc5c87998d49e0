// The browser's delta decoder (server/www/delta.js) in Node 20 against the reference
// (core/stream/delta.cpp through `vismap decode FRAMES... --json`): the test vectors decode in
// sequence to their JSON (zstd through the zstd CLI as options.zstd, refused with a clear error
// without it, and repacked with raw deflate); a skipped frame throws DeltaOutOfSync and a keyframe
// recovers; calls not awaited one by one still decode in order; every truncation and many
// mutations of vector 1 after vector 0 (and of vector 0 after vectors 0 and 1) throw
// DeltaFrameError and nothing else and leave the state so that the next vector decodes exactly, the C++ decoder agreeing on acceptance and arrays;
// hand-made frames (clients/python/tests/delta_craft.py) and bunny orbits (vismap_delta_orbit)
// decode frame by frame as C++ decodes them.
//   node clients/js/test_delta.mjs [--vismap build/vismap] [--orbit build/tests/vismap_delta_orbit]
//                                  [--python /usr/bin/python3] [--time]
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
const { DeltaDecoder, DeltaOutOfSync, DeltaFrameError, llround } = await import(path.join(ROOT, 'server', 'www', 'delta.js'));

const args = process.argv.slice(2);
const arg = (name) => (args.includes(name) ? args[args.indexOf(name) + 1] : null);
const exists = (p) => p && fs.existsSync(p);
const vismap = exists(arg('--vismap')) ? arg('--vismap') : null;
const orbit = exists(arg('--orbit')) ? arg('--orbit') : null;
const python = arg('--python') || 'python3';
const timing = args.includes('--time');
const tmp = fs.mkdtempSync(path.join(os.tmpdir(), 'vismap-delta-js-'));
const ARRAYS = ['xy', 'indices', 'source', 'mesh', 'shade'];

function assert(cond, ...what) {
  if (!cond) throw new Error(`assertion failed: ${what.map((w) => (typeof w === 'string' ? w : JSON.stringify(w))).join(' ')}`);
}

function same(f, ref, what) {
  for (const k of ['width', 'height', 'quantum']) assert(f[k] === ref[k], what, k, f[k], ref[k]);
  assert(f.xy.length / 2 === ref.vertices && f.source.length === ref.triangles, what, 'counts',
    f.xy.length / 2, ref.vertices, f.source.length, ref.triangles);
  for (const k of ARRAYS) {
    const a = f[k];
    const b = ref[k];
    assert(a.length === b.length, what, k, a.length, b.length);
    for (let i = 0; i < a.length; ++i) assert(a[i] === b[i], what, k, 'at', i, a[i], b[i]);
  }
}

function valid(f, what) {
  const nv = f.xy.length / 2;
  const nt = f.source.length;
  assert(f.xy instanceof Int32Array && f.indices instanceof Uint32Array && f.source instanceof Uint32Array, what);
  assert(f.mesh instanceof Uint32Array && f.shade instanceof Uint8Array && f.meshColor instanceof Float32Array, what);
  assert(f.indices.length === 3 * nt && f.mesh.length === nt && f.shade.length === nt, what);
  assert(f.meshColor.length === 3 * f.meshBase.length, what);
  for (let t = 0; t < nt; ++t) {
    const [a, b, c] = [0, 1, 2].map((k) => f.indices[3 * t + k]);
    assert(a < nv && b < nv && c < nv, what, 'index');
    const o = (BigInt(f.xy[2 * b]) - BigInt(f.xy[2 * a])) * (BigInt(f.xy[2 * c + 1]) - BigInt(f.xy[2 * a + 1])) -
      (BigInt(f.xy[2 * b + 1]) - BigInt(f.xy[2 * a + 1])) * (BigInt(f.xy[2 * c]) - BigInt(f.xy[2 * a]));
    assert(o > 0n, what, 'orientation', t);
    assert(f.source[t] >= f.meshBase[f.mesh[t]], what, 'mesh');
  }
}

// A copy of the decoder's state (its arrays are replaced, never written, by a decode).
function fork(dec) {
  const c = new DeltaDecoder({ zstd: dec.zstd });
  for (const k of ['have', 'last', 'base', 'colors', 'vertex', 'tri', 'whole', 'partial', 'view', 'held']) c[k] = dec[k];
  return c;
}

// Resolves to the frame, or null when refused with a DeltaFrameError; anything else fails.
async function decode(dec, bytes, what) {
  try {
    return await dec.decode(bytes);
  } catch (e) {
    if (e instanceof DeltaFrameError && e.message.startsWith('delta frame: ')) return null;
    throw new Error(`${what}: ${e.constructor.name} instead of DeltaFrameError: ${e.stack}`);
  }
}

// `vismap decode PATHS... --json`: the last frame's JSON, or null when C++ refuses one of them.
// (sources: the held scene's message, a path, given first.)
function cliDecode(paths, sources = null) {
  const held = sources ? ['--sources', sources] : [];
  const r = spawnSync(vismap, ['decode', ...held, ...paths, '--json'], { encoding: 'utf8', maxBuffer: 1 << 28 });
  assert(r.status !== null, 'vismap decode died', r.signal);
  return r.status === 0 ? JSON.parse(r.stdout.split('\n').slice(paths.length - 1).join('\n')) : null;
}

function write(name, bytes) {
  const p = path.join(tmp, name);
  fs.writeFileSync(p, bytes);
  return p;
}

const haveZstd = spawnSync('zstd', ['--version']).status === 0;
function zstdCli(bytes, size) {
  const out = execFileSync('zstd', ['-d', '-c', '-q'], { input: bytes, maxBuffer: size + 1024 });
  return new Uint8Array(out.buffer, out.byteOffset, out.length);
}

const read = (p) => new Uint8Array(fs.readFileSync(p));
const vector = (k) => read(path.join(VECTORS, `delta_cornell_${k}.vmd`));
const vectorJson = (k) => JSON.parse(fs.readFileSync(path.join(VECTORS, `delta_cornell_${k}.json`), 'utf8'));

function unpack(frame) {
  const codec = new DataView(frame.buffer, frame.byteOffset).getUint32(36, true);
  return new Uint8Array(codec === 2 ? zlib.inflateRawSync(frame.subarray(48)) : zstdCli(frame.subarray(48), 1 << 26));
}

// The frame with a payload (its own by default) compressed anew with raw deflate.
function repack(frame, payload = unpack(frame)) {
  const z = zlib.deflateRawSync(payload);
  const out = new Uint8Array(48 + z.length);
  out.set(frame.subarray(0, 48));
  const dv = new DataView(out.buffer);
  dv.setUint32(36, 2, true);
  dv.setUint32(40, payload.length, true);
  out.set(z, 48);
  return out;
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

// Malformed variants of a deflate frame: header fields set to edge values, flips in the message,
// and payloads flipped, cut, grown or with section sizes moved, recompressed.
function* mutations(frame, random, count) {
  const dv = new DataView(frame.buffer, frame.byteOffset, frame.byteLength);
  const key = dv.getUint32(16, true) & 1;
  const sizesAt = 148 + (key ? 24 * dv.getUint32(32, true) : 0);
  const ns = dv.getUint32(4, true) === 1 ? 10 : 11; // sections
  const payload = unpack(frame);
  const int = (n) => Math.floor(random() * n);
  for (let i = 0; i < 11; ++i) {
    const v0 = dv.getUint32(4 + 4 * i, true);
    for (const v of [0, 1, 2, 0xffffffff, v0 + 1, v0 - 1]) {
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
      const lo = kind === 2 ? sizesAt + 4 * ns : 0;
      for (let n = [1, 1, 2, 3][int(4)]; n > 0; --n) {
        const at = lo + int(b.length - lo);
        b[at] ^= random() < 0.6 ? 1 << int(8) : 1 + int(255);
      }
      what = 'payload bytes flipped';
    } else if (kind === 3) {
      const at = int(b.length);
      const n = 1 + int(3);
      if (random() < 0.5) b = new Uint8Array([...b.subarray(0, at), ...b.subarray(at + n)]);
      else b = new Uint8Array([...b.subarray(0, at), ...Array.from({ length: n }, () => int(256)), ...b.subarray(at)]);
      what = `payload cut or grown at ${at}`;
    } else {
      const pv = new DataView(b.buffer);
      const i = int(ns);
      const j = (i + 1 + int(ns - 1)) % ns;
      const d = 1 + int(3);
      pv.setUint32(sizesAt + 4 * i, (pv.getUint32(sizesAt + 4 * i, true) + d) >>> 0, true);
      pv.setUint32(sizesAt + 4 * j, (pv.getUint32(sizesAt + 4 * j, true) - d) >>> 0, true);
      what = `section sizes ${i} += ${d}, ${j} -= ${d}`;
    }
    yield [what, repack(frame, b)];
  }
}

// Each case after `base`: refused (then `target` decodes to `ref`, on a sample and at the end)
// or a valid frame; on the accepted ones and every `every`-th refused, C++ agrees.
async function checkMutations(base, target, ref, cases, every, sources = null) {
  let dec = new DeltaDecoder();
  if (sources) await dec.holdScene(read(sources));
  for (const f of base) await dec.decode(f);
  const paths = base.map((f, k) => write(`base_${k}.vmd`, f));
  let accepted = 0;
  let checked = 0;
  for (let k = 0; k < cases.length; ++k) {
    const [what, data] = cases[k];
    const before = fork(dec);
    const f = await decode(dec, data, what);
    if (f) {
      valid(f, what);
      ++accepted;
      dec = before;
    } else if (k % 25 === 0) {
      same(await fork(dec).decode(target), ref, `${what}: the target after it`);
    }
    if (vismap && (f || k % every === 0)) {
      const cpp = cliDecode([...paths, write('mutated.vmd', data)], sources);
      ++checked;
      assert((cpp === null) === (f === null), what, `C++ ${cpp === null ? 'refuses' : 'accepts'}, JS not`);
      if (f) same(f, cpp, what);
    }
  }
  same(await dec.decode(target), ref, 'the target after every refusal');
  return [accepted, checked];
}

const tests = {
  async vectors() {
    const dec = new DeltaDecoder();
    try {
      await dec.decode(vector(0));
      assert(false, 'zstd frame decoded without a zstd decoder');
    } catch (e) {
      assert(e instanceof DeltaFrameError && /zstd frames need a native decoder; ask .*deflate/.test(e.message), e.message);
    }
    assert(!dec.hasState && dec.lastIndex === null, 'state after a refusal');
    const runs = [['deflate', new DeltaDecoder(), (k) => repack(vector(k))]];
    if (haveZstd) runs.push(['zstd', new DeltaDecoder({ zstd: zstdCli }), vector]);
    else console.log('  (no zstd CLI: the vectors only repacked with deflate)');
    for (const [name, d, frame] of runs) {
      for (let k = 0; k < 3; ++k) {
        const buf = frame(k);
        const f = await d.decode(buf.buffer.slice(buf.byteOffset, buf.byteOffset + buf.length)); // an ArrayBuffer
        same(f, vectorJson(k), `vector ${k} (${name})`);
        valid(f, `vector ${k}`);
        assert(f.keyframe === (k === 0) && f.index === k && d.lastIndex === k && f.compression === name, 'fields', k);
        assert(f.rows.length === 12 && f.eye.length === 3 && f.projection === 'perspective', 'camera', k);
      }
    }
    // Version 2 (proto/vectors/README.md): the held torus, a compact frame at 3, frame 4 based on 2.
    if (haveZstd) {
      const d = new DeltaDecoder({ zstd: zstdCli });
      const v2 = (name) => read(path.join(VECTORS, `delta2_torus_${name}.vmd`));
      assert((await decode(d, v2(0), 'held keyframe without the scene')) === null, 'held keyframe accepted');
      await d.holdScene(v2('sources'));
      assert(d.holdsScene, 'holdsScene');
      for (let k = 0; k < 5; ++k) {
        const f = await d.decode(v2(k));
        same(f, JSON.parse(fs.readFileSync(path.join(VECTORS, `delta2_torus_${k}.json`), 'utf8')), `version 2 vector ${k}`);
        valid(f, `version 2 vector ${k}`);
        assert(f.keyframe === (k === 0) && !!f.compact === (k === 3) && d.lastIndex === (k === 3 ? 2 : k), 'v2 fields', k);
      }
    }
    assert(llround(-2.5) === -3 && llround(2.5) === 3 && llround(-0.5) === -1 && llround(0.49999999999999994) === 0 &&
      llround(-1.5) === -2 && Math.round(-2.5) === -2, 'llround');
  },

  async outOfSync() {
    const v = [0, 1, 2].map((k) => repack(vector(k)));
    const dec = new DeltaDecoder();
    const refuses = async (k, what) => {
      try {
        await dec.decode(v[k]);
      } catch (e) {
        assert(e instanceof DeltaOutOfSync && e instanceof DeltaFrameError && /keyframe/.test(e.message), what, e.message);
        return;
      }
      assert(false, what, 'decoded');
    };
    await refuses(1, 'no keyframe yet');
    await dec.decode(v[0]);
    await refuses(2, 'vector 1 lost');
    same(await dec.decode(v[1]), vectorJson(1), 'vector 1 after a refused vector 2');
    same(await dec.decode(v[2]), vectorJson(2), 'vector 2');
    await refuses(2, 'repeated');
    same(await dec.decode(v[0]), vectorJson(0), 'a keyframe in the middle');
    await refuses(2, 'vector 2 after the keyframe');
    same(await dec.decode(v[1]), vectorJson(1), 'vector 1 after the keyframe');
    // Calls not awaited one by one decode in call order.
    const d2 = new DeltaDecoder();
    const all = await Promise.allSettled([d2.decode(v[0]), d2.decode(v[2]), d2.decode(v[1]), d2.decode(v[2])]);
    assert(all.map((r) => r.status).join() === 'fulfilled,rejected,fulfilled,fulfilled', all.map((r) => r.status));
    same(all[3].value, vectorJson(2), 'queued vector 2');
    dec.reset();
    await refuses(1, 'after reset');
  },

  async truncated() {
    const v0 = repack(vector(0));
    const v1 = repack(vector(1));
    const dec = new DeltaDecoder();
    await dec.decode(v0);
    for (let n = 0; n < v1.length; ++n) {
      assert((await decode(dec, v1.subarray(0, n), `cut to ${n}`)) === null, `vector 1 cut to ${n} accepted`);
      if (n % 50 === 0) same(await fork(dec).decode(v1), vectorJson(1), `vector 1 after a cut to ${n}`);
    }
    for (const junk of [[0], [1, 2, 3]]) {
      assert((await decode(fork(dec), new Uint8Array([...v1, ...junk]), 'junk')) === null, 'bytes after the stream accepted');
    }
    same(await dec.decode(v1), vectorJson(1), 'vector 1 after every truncation');
    const huge = v0.slice();
    new DataView(huge.buffer).setUint32(40, 2 ** 31, true);
    const t0 = performance.now();
    assert((await decode(new DeltaDecoder(), huge, 'huge')) === null && performance.now() - t0 < 1000, 'huge payload');
    for (const bad of [[], [0x56, 0x4d, 0x44, 0x46], Array(100).fill(255)]) {
      assert((await decode(new DeltaDecoder(), new Uint8Array(bad), 'bad')) === null, 'accepted', bad.length);
    }
  },

  async mutations() {
    const v0 = repack(vector(0));
    const v1 = repack(vector(1));
    const cases = [...mutations(v1, rng(16), 1500)];
    const [accepted, checked] = await checkMutations([v0], v1, vectorJson(1), cases, 10);
    console.log(`  ${cases.length} mutations of vector 1: ${accepted} still valid frames, ${checked} compared with vismap decode`);
    const v2 = repack(vector(2));
    const keyCases = [...mutations(v0, rng(17), 400)]; // the keyframe (its mesh table) after vectors 0 and 1
    const [a2, c2] = await checkMutations([v0, v1], v2, vectorJson(2), keyCases, 10);
    console.log(`  ${keyCases.length} mutations of vector 0 after vector 1: ${a2} still valid, ${c2} compared`);
  },

  async craft() {
    const dir = path.join(tmp, 'craft');
    const r = spawnSync(python, [path.join(ROOT, 'clients', 'python', 'tests', 'delta_craft.py'), dir], { encoding: 'utf8' });
    if (r.status !== 0) {
      console.log(`  (${python} clients/python/tests/delta_craft.py failed: hand-made frames skipped) ${r.stderr.slice(-200)}`);
      return;
    }
    const manifest = JSON.parse(fs.readFileSync(path.join(dir, 'manifest.json'), 'utf8'));
    const zstd = haveZstd ? zstdCli : null;
    for (const [name, files] of Object.entries(manifest.sequences)) {
      const dec = new DeltaDecoder({ zstd });
      for (let k = 0; k < files.length; ++k) {
        const data = read(path.join(dir, files[k]));
        if (!zstd && new DataView(data.buffer).getUint32(36, true) === 1) break;
        const f = await dec.decode(data);
        valid(f, `${name} ${k}`);
        if (vismap) same(f, cliDecode(files.slice(0, k + 1).map((n) => path.join(dir, n))), `${name} frame ${k}`);
        if (name === 'halves' && k === 0) assert(Array.from(f.xy.subarray(0, 6)).join() === '-3,2,3,2,-2,5', 'halves', Array.from(f.xy));
      }
    }
    for (const [name, files] of Object.entries(manifest.refused)) {
      const dec = new DeltaDecoder({ zstd });
      if (!zstd) break;
      for (const n of files.slice(0, -1)) await dec.decode(read(path.join(dir, n)));
      assert((await decode(dec, read(path.join(dir, files[files.length - 1])), name)) === null, name, 'accepted');
    }
  },

  async bunny() {
    // Version 1, and version 2: held (facing flips, edge references) and not held (every frame the
    // compact frame: the keyframe with every source is larger).
    const v2 = ['--version', '2'];
    const streams = {
      bunny_hd: ['--frames', '5', '--width', '1920', '--height', '1080', '--compression', 'deflate'],
      bunny_q4: ['--frames', '7', '--width', '640', '--height', '480', '--quantum', '4', '--compression', 'deflate',
        '--step', '10', '--keyframe-every', '3'],
      bunny_v2_hd_held: ['--frames', '5', '--width', '1920', '--height', '1080', '--compression', 'deflate', ...v2,
        '--held', '1'],
      bunny_v2_q4_held: ['--frames', '7', '--width', '640', '--height', '480', '--quantum', '4', '--compression',
        'deflate', '--step', '10', '--keyframe-every', '3', ...v2, '--held', '1'],
      bunny_v2_compact: ['--frames', '2', '--width', '640', '--height', '480', '--compression', 'deflate', ...v2],
    };
    for (const [name, flags] of Object.entries(streams)) {
      const out = path.join(tmp, name);
      fs.mkdirSync(out);
      execFileSync(orbit, [path.join(ROOT, 'data', 'bunny.ply'), out, ...flags], { stdio: 'ignore' });
      const paths = fs.readdirSync(out).filter((n) => n.startsWith('delta_')).sort().map((n) => path.join(out, n));
      const sources = fs.existsSync(path.join(out, 'sources.vmd')) ? path.join(out, 'sources.vmd') : null;
      const dec = new DeltaDecoder();
      if (sources) await dec.holdScene(read(sources));
      for (let k = 0; k < paths.length; ++k) {
        const data = read(paths[k]);
        const before = fork(dec);
        const f = await dec.decode(data);
        same(f, cliDecode(paths.slice(0, k + 1), sources), `${name} frame ${k}`);
        valid(f, `${name} frame ${k}`);
        assert(!!f.compact === name.endsWith('_compact'), `${name} frame ${k}`, 'compact');
        assert(f.keyframe === (!f.compact && (k === 0 || (name.includes('q4') && k % 3 === 0))), `${name} frame ${k}`,
          'keyframe');
        if (timing) {
          const times = [];
          for (let i = 0; i < 15; ++i) {
            const d = fork(before);
            const t0 = performance.now();
            await d.decode(data);
            times.push(performance.now() - t0);
          }
          times.sort((x, y) => x - y);
          console.log(`  ${name} frame ${k}: ${f.keyframe ? 'keyframe, ' : ''}${data.length} bytes, ${f.source.length} triangles, ` +
            `${f.xy.length / 2} vertices: ${times[0].toFixed(2)} ms min, ${times[7].toFixed(2)} ms median (15 runs)`);
        }
      }
      if (name === 'bunny_q4' || name === 'bunny_v2_q4_held') {
        const base = paths.slice(0, 2).map(read);
        const target = read(paths[2]);
        const cases = [...mutations(target, rng(7), 60)];
        const [accepted, checked] = await checkMutations(base, target, cliDecode(paths.slice(0, 3), sources), cases, 4,
          sources);
        console.log(`  ${cases.length} mutations of ${name} frame 2: ${accepted} still valid, ${checked} compared`);
      }
    }
  },
};

let failed = false;
try {
  for (const [name, fn] of Object.entries(tests)) {
    if (name === 'bunny' && !(vismap && orbit)) {
      console.log('no --vismap and --orbit: bunny streams skipped');
      continue;
    }
    const t0 = performance.now();
    await fn();
    console.log(`ok ${name} (${((performance.now() - t0) / 1000).toFixed(1)} s)`);
  }
  if (!vismap) console.log('no --vismap: the comparison with the C++ decoder skipped');
} catch (e) {
  console.error(e.stack || e);
  failed = true;
} finally {
  fs.rmSync(tmp, { recursive: true, force: true });
}
console.log(failed ? 'FAILED' : 'ok');
process.exit(failed ? 1 : 0);
