// What the compact and delta frame decoders share (proto/COMPACT.md): the payload's raw deflate
// through the platform's DecompressionStream("deflate-raw"), an injectable zstd decoder, and a
// section's LEB128 numbers. `fail(part, message)` throws the calling decoder's own error.

// ---------------------------------------------------------------------------------------------
// Raw deflate: exactly `size` bytes, the stream ending exactly at the message's end.

// Node 20's DecompressionStream ignores bytes after the end of the deflate stream (Chromium's
// refuses them, as the Compression Streams spec asks). Where they are ignored, a stream that ends
// exactly at the message's end is told by its prefix one byte shorter failing: the last byte
// holds the end-of-block code's last bit.
let lenientInflate = null;

async function inflate(bytes, size) {
  const ds = new DecompressionStream('deflate-raw');
  const writer = ds.writable.getWriter();
  writer.write(bytes).catch(() => {});
  writer.close().catch(() => {});
  const reader = ds.readable.getReader();
  const out = new Uint8Array(size);
  let n = 0;
  for (;;) {
    const { value, done } = await reader.read();
    if (done) break;
    if (value.length > size - n) {
      reader.cancel().catch(() => {});
      throw new RangeError('longer than stated');
    }
    out.set(value, n);
    n += value.length;
  }
  return n === size ? out : null;
}

async function isLenient() {
  // 0x03 0x00: an empty final fixed-Huffman block; 0x2a: a byte after it.
  if (lenientInflate === null) {
    lenientInflate = inflate(new Uint8Array([0x03, 0x00, 0x2a]), 0).then(() => true, () => false);
  }
  return lenientInflate;
}

export async function inflateExactly(z, size, fail) {
  let out;
  try {
    out = await inflate(z, size);
  } catch (e) {
    fail('payload', `not one raw deflate stream of the stated size (${e.message})`);
  }
  if (out === null) fail('payload', `fewer bytes after decompression than the header's ${size}`);
  if (await isLenient()) {
    let ends = false;
    try {
      ends = z.length === 0 || (await inflate(z.subarray(0, z.length - 1), size)) === null;
    } catch {
      ends = true;
    }
    if (!ends) fail('payload', 'bytes after the end of the deflate stream');
  }
  return out;
}

// The payload of compression 1 (zstd) or 2 (raw deflate). zstd: (bytes, size) => Uint8Array (or
// a promise of one), a decoder of one frame that throws on anything else (a WebAssembly build,
// or the tests' zstd CLI); without one, zstd frames are refused with an error that says to ask
// for deflate.
export async function decompress(codec, z, size, zstd, fail) {
  if (codec === 2) return inflateExactly(z, size, fail);
  if (!zstd) fail('payload', 'zstd frames need a native decoder; ask the server for compression: "deflate"');
  let payload;
  try {
    payload = await zstd(z, size);
  } catch (e) {
    fail('payload', `zstd: ${e.message}`);
  }
  if (!(payload instanceof Uint8Array) || payload.length !== size) {
    fail('payload', `not one zstd frame of the stated size ${size}`);
  }
  return payload;
}

// ---------------------------------------------------------------------------------------------
// A section's numbers: LEB128 varints (at most 10 bytes, 64-bit wrap as in C++), as Numbers:
// exact below 2^53, else +-Infinity (no valid frame holds such a number: every sum or range it
// enters leaves its range). next(): zigzag-signed; uint(): unsigned.

export class Numbers {
  constructor(bytes, part, fail) {
    this.b = bytes;
    this.p = 0;
    this.part = part;
    this.fail = fail;
  }

  next() {
    const b = this.b;
    let p = this.p;
    let z = 0;
    for (let shift = 0; shift < 28; shift += 7) { // up to 4 bytes: 28 bits in int32 arithmetic
      if (p >= b.length) this.fail(this.part, 'ends inside a number');
      const c = b[p++];
      z |= (c & 0x7f) << shift;
      if (c < 0x80) {
        this.p = p;
        return (z >>> 1) ^ -(z & 1);
      }
    }
    const big = this.long(z, p);
    const s = big & 1n ? -(big >> 1n) - 1n : big >> 1n;
    return s >= 2n ** 53n ? Infinity : s <= -(2n ** 53n) ? -Infinity : Number(s);
  }

  uint() {
    const b = this.b;
    let p = this.p;
    let z = 0;
    for (let shift = 0; shift < 28; shift += 7) {
      if (p >= b.length) this.fail(this.part, 'ends inside a number');
      const c = b[p++];
      z |= (c & 0x7f) << shift;
      if (c < 0x80) {
        this.p = p;
        return z;
      }
    }
    const big = this.long(z, p);
    return big >= 2n ** 53n ? Infinity : Number(big);
  }

  long(z, p) { // five bytes or more: rare, exactly in BigInt, mod 2^64
    const b = this.b;
    let big = BigInt(z);
    for (let shift = 28n; shift < 70n; shift += 7n) {
      if (p >= b.length) this.fail(this.part, 'ends inside a number');
      const c = b[p++];
      big |= BigInt(c & 0x7f) << shift;
      if (c < 0x80) {
        this.p = p;
        return big & 0xffffffffffffffffn;
      }
    }
    this.fail(this.part, 'a number longer than 64 bits');
  }

  done() { // every section is read to its end
    if (this.p !== this.b.length) this.fail(this.part, 'trailing bytes');
  }
}
