// The JavaScript decoders' half of bench/stream/clients.py's frame-by-frame agreement check:
// decodes the frames the C++ client saved (vismap-client --out DIR: frame_NNNN.vmc or .vmd, and
// sources.vmd for a delta stream whose client held the scene) with server/www's compact.js and
// delta.js, in order, and prints one JSON object: {digests: [...]}, per frame the digest of the
// decoded arrays as vismap-client's digest() makes it (null for a frame that did not decode),
// or {error}. zstd frames are inflated by the zstd command (Debian's zstd), as the clients' tests.
//   node bench/stream/js_digests.mjs DIR
import { execFileSync } from 'node:child_process';
import fs from 'node:fs';
import path from 'node:path';
import { fileURLToPath } from 'node:url';

const www = path.join(path.dirname(fileURLToPath(import.meta.url)), '../../server/www');
const { decodeCompact } = await import(path.join(www, 'compact.js'));
const { DeltaDecoder } = await import(path.join(www, 'delta.js'));

function zstd(bytes, size) {
  const out = execFileSync('zstd', ['-d', '-c', '-q'], { input: bytes, maxBuffer: size + 1024 });
  return new Uint8Array(out.buffer, out.byteOffset, out.length);
}

// "length:h" per array (xy, indices, source, shade as uint32), h = sum of v_i (2i + 1) mod 2^32.
function digest(f) {
  return [f.xy, f.indices, f.source, f.shade].map((v) => {
    let h = 0;
    for (let i = 0; i < v.length; ++i) h = (h + Math.imul(v[i] >>> 0, 2 * i + 1)) >>> 0;
    return `${v.length}:${h.toString(16).padStart(8, '0')}`;
  }).join('/');
}

const dir = process.argv[2];
try {
  const files = fs.readdirSync(dir).filter((n) => /^frame_\d+\.(vmc|vmd)$/.test(n)).sort();
  const delta = new DeltaDecoder({ zstd });
  if (fs.existsSync(path.join(dir, 'sources.vmd'))) await delta.holdScene(new Uint8Array(fs.readFileSync(path.join(dir, 'sources.vmd'))));
  const digests = [];
  for (const n of files) {
    const bytes = new Uint8Array(fs.readFileSync(path.join(dir, n)));
    try {
      digests.push(digest(n.endsWith('.vmc') ? await decodeCompact(bytes, { zstd }) : await delta.decode(bytes)));
    } catch (e) {
      digests.push(null);
    }
  }
  console.log(JSON.stringify({ digests }));
} catch (e) {
  console.log(JSON.stringify({ error: String(e.message || e) }));
}
