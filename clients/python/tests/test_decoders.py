#!/usr/bin/env python3
"""The Python package's frame readers against the reference (core/stream/compact.cpp via `vismap
decode --json`): the compact test vectors (zstd and raw deflate) decode to their JSON exactly; bunny
frames made with `vismap render` (compact zstd with shades, compact deflate with ids at quantum
4, bin) decode to the same arrays as `vismap decode --json`; the fast walk equals the literal
one; malformed frames (every truncation, byte flips, header fields, payloads mutated and
recompressed) raise ValueError and nothing else, and where the C++ reader accepts a mutated
frame Python accepts it with the same arrays and vice versa; the package installs with pip
offline into a temporary folder and imports from there.

    /usr/bin/python3 clients/python/tests/test_decoders.py --vismap build/vismap [--time]

Exits 77 (skipped) without numpy or zstandard (scripts/setup.sh --tests installs them)."""
import argparse
import json
import os
import random
import re
import shutil
import struct
import subprocess
import sys
import tempfile
import time
import zlib

HERE = os.path.dirname(os.path.abspath(__file__))
PKG = os.path.dirname(HERE)
ROOT = os.path.dirname(os.path.dirname(PKG))
VECTORS = os.path.join(ROOT, "proto", "vectors")
sys.path.insert(0, PKG)
try:
    import numpy as np
    import zstandard
    import vismap_client as vc
    from vismap_client import compact
except ImportError as e:  # run scripts/setup.sh --tests
    print(f"skipped: {e}")
    sys.exit(77)

ARRAYS = ("xy", "indices", "source", "mesh", "mesh_base", "shade")


def read(path):
    with open(path, "rb") as f:
        return f.read()


def same(frame, ref, what):
    """The frame's arrays equal the JSON's (`vismap decode --json` or a vector) exactly."""
    for k in ("version", "width", "height", "quantum"):
        assert getattr(frame, k) == ref[k], (what, k, getattr(frame, k), ref[k])
    assert frame.vertex_count == ref["vertices"] and frame.triangle_count == ref["triangles"], what
    for k in ARRAYS:
        got = getattr(frame, k)
        got = [] if got is None else got.tolist()
        assert got == ref[k], (what, k, len(got), len(ref[k]))


def same_frames(a, b, what):
    for k in ("version", "width", "height", "flags", "quantum", "compression"):
        assert getattr(a, k) == getattr(b, k), (what, k)
    for k in ARRAYS + ("mesh_color",):
        x, y = getattr(a, k), getattr(b, k)
        assert (x is None) == (y is None), (what, k)
        assert x is None or (x.dtype == y.dtype and np.array_equal(x, y)), (what, k)


def valid(f, what):
    """What COMPACT.md promises of a decoded frame."""
    v, t = f.vertex_count, f.triangle_count
    assert f.xy.dtype == np.int32 and f.indices.dtype == np.uint32 and f.source.dtype == np.uint32, what
    assert len(f.indices) == 3 * t and len(f.mesh) == t and v <= 3 * t, what
    assert (f.shade is None) == (not f.flags & 1) and (f.shade is None or len(f.shade) == t), what
    if t:
        assert f.indices.max() < v and len(np.unique(f.indices)) == v, what
        p = f.xy.astype(np.int64).reshape(-1, 2)
        assert p.min() >= 0 and p[:, 0].max() <= f.width * f.quantum and p[:, 1].max() <= f.height * f.quantum, what
        c = p[f.indices.reshape(-1, 3)]
        o = (c[:, 1, 0] - c[:, 0, 0]) * (c[:, 2, 1] - c[:, 0, 1]) - (c[:, 1, 1] - c[:, 0, 1]) * (c[:, 2, 0] - c[:, 0, 0])
        assert (o > 0).all(), what
        assert (f.source >= f.mesh_base[0]).all() and (f.mesh_base[f.mesh] <= f.source).all(), what


def decode_both(data, what):
    """read_compact's result, after checking that the literal walk gives the same (or the same
    refusal); None when refused. Any exception but ValueError fails the test."""
    try:
        fast = vc.read_compact(data)
    except ValueError:
        fast = None
    except Exception as e:
        raise AssertionError(f"{what}: {type(e).__name__} instead of ValueError: {e}") from e
    try:
        plain = compact._read(data, plain=True)
    except ValueError:
        plain = None
    assert (fast is None) == (plain is None), f"{what}: the walks disagree on acceptance"
    if fast is not None:
        same_frames(fast, plain, what)
        valid(fast, what)
    return fast


def cli_decode(vismap, data, tmp):
    """`vismap decode --json` of the bytes: the JSON, or None when the C++ reader refuses them."""
    path = os.path.join(tmp, "frame.vmc")
    with open(path, "wb") as f:
        f.write(data)
    r = subprocess.run([vismap, "decode", path, "--json"], capture_output=True, text=True, timeout=60)
    assert r.returncode >= 0, f"vismap decode died: {r.returncode} {r.stderr}"
    if r.returncode != 0:
        return None
    return json.loads(r.stdout)


# ---------------------------------------------------------------------------------------------

def test_vectors():
    ref = json.loads(read(os.path.join(VECTORS, "compact_cornell.json")))
    for name, codec in (("compact_cornell.vmc", "zstd"), ("compact_cornell_deflate.vmc", "deflate")):
        data = read(os.path.join(VECTORS, name))
        f = decode_both(data, name)
        assert f is not None and f.compression == codec, name
        same(f, ref, name)
        assert len(data) == ref["bytes"] or codec == "deflate", name
        assert f.mesh_color.shape == (len(f.mesh_base), 3) and f.mesh_color.dtype == np.float32
        assert ((f.mesh_color >= 0) & (f.mesh_color <= 1)).all()
        assert vc.read_frame(data).triangle_count == f.triangle_count
        assert np.array_equal(f.face_id, f.source - f.mesh_base[f.mesh])


def render(vismap, tmp, name, *flags):
    out = os.path.join(tmp, name)
    subprocess.run([vismap, "render", os.path.join(ROOT, "data", "bunny.ply"), "-o", out, *flags],
                   check=True, capture_output=True, timeout=300)
    return out


def test_bunny(vismap, tmp, timing):
    frames = {
        "bunny_zstd.vmc": ("--format", "compact", "--width", "1920", "--height", "1080"),
        "bunny_deflate_id.vmc": ("--format", "compact", "--compression", "deflate", "--fill", "id",
                                 "--quantum", "4", "--width", "640", "--height", "480"),
    }
    for name, flags in frames.items():
        path = render(vismap, tmp, name, *flags)
        data = read(path)
        ref = json.loads(subprocess.run([vismap, "decode", path, "--json"], check=True, capture_output=True,
                                        text=True, timeout=60).stdout)
        f = decode_both(data, name)
        assert f is not None and f.triangle_count > 1000, name
        same(f, ref, name)
        # Fill colours: the same set as the SVG `vismap decode -o` draws (one path per colour).
        svg = os.path.join(tmp, name + ".svg")
        subprocess.run([vismap, "decode", path, "-o", svg], check=True, capture_output=True, timeout=60)
        fills = set(re.findall(r'fill="#([0-9a-f]{6})"', read(svg).decode()))
        ours = {"%02x%02x%02x" % tuple(c) for c in f.colors().tolist()}
        assert fills == ours, (name, len(fills), len(ours), sorted(fills ^ ours)[:5])
        if timing:
            for plain in (False, True):
                best = min(_timed(lambda: compact._read(data, plain)) for _ in range(7))
                print(f"  {name}: {f.triangle_count} triangles, {f.vertex_count} vertices, {len(data)} bytes: "
                      f"{best * 1e3:.1f} ms ({'literal walk' if plain else 'read_compact'})")
    # The bin frame: read_bin against decode --json (which prints floats with 6 decimals).
    path = render(vismap, tmp, "bunny.bin", "--format", "bin", "--width", "640", "--height", "480")
    ref = json.loads(subprocess.run([vismap, "decode", path, "--json"], check=True, capture_output=True,
                                    text=True, timeout=60).stdout)
    b = vc.read_bin(read(path))
    assert vc.read_frame(read(path)).triangle_count == b.triangle_count
    assert (b.width, b.height) == (ref["width"], ref["height"]) and b.triangle_count == ref["triangles"]
    assert b.mesh.tolist() == ref["mesh"] and b.triangle_id.tolist() == ref["triangle_id"]
    assert np.abs(b.xy.astype(np.float64) - np.array(ref["xy"])).max() <= 5.01e-7
    assert b.xy.dtype == np.float32 and b.flags & 1 == (len(b.bary) > 0)
    # With its line section (vismap render --style fill+lines --hidden): the same triangles, and
    # chains of every kind the bunny has, hidden ones among them.
    path = render(vismap, tmp, "bunny_lines.bin", "--format", "bin", "--width", "640", "--height", "480",
                  "--style", "fill+lines", "--hidden")
    L = vc.read_bin(read(path))
    assert L.flags & 2 and L.triangle_count == b.triangle_count and len(L.chain_end) > 10
    kinds = {vc.bin.LINE_KINDS[k & 0xFF] for k in L.chain_info.tolist()}
    assert "contour" in kinds, kinds
    assert any(k & (1 << 9) for k in L.chain_info.tolist())  # hidden parts
    assert int(L.chain_end[-1]) * 2 == len(L.line_points)


def _timed(fn):
    t0 = time.perf_counter()
    fn()
    return time.perf_counter() - t0


def test_truncated():
    for name in ("compact_cornell.vmc", "compact_cornell_deflate.vmc"):
        data = read(os.path.join(VECTORS, name))
        for n in range(len(data)):
            try:
                vc.read_compact(data[:n])
            except ValueError as e:
                assert str(e).startswith("compact frame: "), e
                continue
            raise AssertionError(f"{name} cut to {n} bytes was accepted")
        huge = data[:28] + struct.pack("<I", 1 << 28) + data[32:]  # refused before allocating for it
        t0 = time.perf_counter()
        try:
            vc.read_compact(huge)
            raise AssertionError("2^28 triangles accepted")
        except ValueError:
            assert time.perf_counter() - t0 < 1, "2^28 triangles took long to refuse"
        try:
            vc.read_compact(data + b"\0")
            raise AssertionError(f"{name} with a trailing byte was accepted")
        except ValueError:
            pass


def _payload(data):
    codec, size = struct.unpack_from("<2I", data, 36)
    z = data[44:]
    return codec, (zstandard.ZstdDecompressor().decompress(z) if codec == 1 else zlib.decompress(z, -15))


def _pack(data, codec, payload):
    if codec == 1:
        z = zstandard.ZstdCompressor(level=3).compress(payload)
    else:
        c = zlib.compressobj(6, zlib.DEFLATED, -15)
        z = c.compress(payload) + c.flush()
    return data[:40] + struct.pack("<I", len(payload)) + z


def _mutations(data, rng, count):
    """Deterministic malformed variants of a frame: flips in the message, header fields set to
    edge values, and payloads (the sections) flipped, cut, grown or with section sizes moved,
    then recompressed so the damage reaches the sections."""
    codec, payload = _payload(data)
    nm = struct.unpack_from("<I", data, 32)[0]
    out = []
    for i in range(10):  # header fields
        for v in (0, 1, 2, 3, 0xFFFFFFFF, struct.unpack_from("<I", data, 4 + 4 * i)[0] + 1,
                  struct.unpack_from("<I", data, 4 + 4 * i)[0] - 1):
            out.append(("header field %d = %d" % (i, v), data[:4 + 4 * i] + struct.pack("<I", v & 0xFFFFFFFF) +
                        data[8 + 4 * i:]))
    for k in range(count):
        kind = k % 5
        b = bytearray(data) if kind == 0 else bytearray(payload)
        if kind == 0:
            at = rng.randrange(len(b))
            b[at] ^= 1 << rng.randrange(8) if rng.random() < 0.5 else rng.randrange(1, 256)
            out.append((f"message byte {at} flipped", bytes(b)))
            continue
        if kind in (1, 2):  # flip payload bytes (kind 2: only in the sections)
            lo = 16 * nm + 16 if kind == 2 else 0
            for _ in range(rng.choice((1, 1, 2, 3))):
                at = rng.randrange(lo, len(b))
                b[at] ^= 1 << rng.randrange(8) if rng.random() < 0.6 else rng.randrange(1, 256)
            what = "payload bytes flipped"
        elif kind == 3:  # cut or grow the payload
            at = rng.randrange(len(b))
            if rng.random() < 0.5:
                del b[at:at + rng.randrange(1, 4)]
            else:
                b[at:at] = bytes(rng.randrange(256) for _ in range(rng.randrange(1, 4)))
            what = "payload cut or grown at %d" % at
        else:  # move bytes between sections
            s = list(struct.unpack_from("<4I", b, 16 * nm))
            i, j = rng.sample(range(4), 2)
            d = rng.choice((1, 2, 3))
            s[i] += d
            s[j] -= d
            struct.pack_into("<4I", b, 16 * nm, *[x & 0xFFFFFFFF for x in s])
            what = "section sizes %s" % s
        out.append((what, _pack(data, codec, bytes(b))))
    return out


def test_malformed(vismap, tmp):
    """Every mutation raises ValueError or decodes to a valid frame; on a sample, the C++ reader
    agrees (accepts exactly the same, with the same arrays)."""
    rng = random.Random(16)
    cases = []
    for name in ("compact_cornell.vmc", "compact_cornell_deflate.vmc"):
        cases += [(name + ": " + w, d) for w, d in _mutations(read(os.path.join(VECTORS, name)), rng, 1500)]
    bunny = read(os.path.join(tmp, "bunny_deflate_id.vmc"))
    cases += [("bunny: " + w, d) for w, d in _mutations(bunny, rng, 40)]
    accepted = 0
    checked = 0
    for k, (what, data) in enumerate(cases):
        f = decode_both(data, what)
        accepted += f is not None
        if vismap and (k % 12 == 0 or f is not None):
            ref = cli_decode(vismap, data, tmp)
            checked += 1
            assert (ref is None) == (f is None), f"{what}: C++ {'refuses' if ref is None else 'accepts'}, Python not"
            if f is not None:
                same(f, ref, what)
    print(f"  {len(cases)} malformed frames: {accepted} still valid frames, {checked} compared with vismap decode")
    for bad in (b"", b"VMCF", b"VMAP" + bytes(40), b"VMCF" + bytes(40), b"\xff" * 100):
        for reader in (vc.read_compact, vc.read_bin, vc.read_frame):
            try:
                reader(bad)
                raise AssertionError(f"{reader.__name__} accepted {bad[:8]!r}")
            except ValueError:
                pass


def test_bin_malformed():
    t = 2
    hdr = b"VMAP" + struct.pack("<5I", 1, 64, 48, 1, t)
    xy = np.array([0, 0, 10, 0, 0, 10] * t, np.float32).tobytes()
    body = xy + struct.pack("<2I", 0, 0) + struct.pack("<2I", 5, 6) + np.ones(9 * t, np.float32).tobytes() + \
        np.ones(3 * t, np.float32).tobytes()
    f = vc.read_bin(hdr + body)
    assert f.triangle_count == 2 and f.triangle_id.tolist() == [5, 6] and len(f.bary) == 18 and len(f.inv_w) == 6
    for n in range(len(hdr + body)):
        try:
            vc.read_bin((hdr + body)[:n])
            raise AssertionError(f"bin frame cut to {n} accepted")
        except ValueError:
            pass
    nan = np.float32(np.nan).tobytes()
    lines = struct.pack("<2I", 1, 2) + struct.pack("<2I", 2, 0) + np.zeros(4, np.float32).tobytes()
    g = vc.read_bin(b"VMAP" + struct.pack("<5I", 1, 64, 48, 3, t) + body + lines)
    assert g.chain_end.tolist() == [2] and len(g.line_points) == 4
    bad_kind = struct.pack("<2I", 1, 2) + struct.pack("<2I", 2, 7) + np.zeros(4, np.float32).tobytes()
    for what, data in [("flags", b"VMAP" + struct.pack("<5I", 1, 64, 48, 7, t) + body),
                       ("missing lines", b"VMAP" + struct.pack("<5I", 1, 64, 48, 3, t) + body),
                       ("line kind", b"VMAP" + struct.pack("<5I", 1, 64, 48, 3, t) + body + bad_kind),
                       ("version", b"VMAP" + struct.pack("<5I", 2, 64, 48, 1, t) + body),
                       ("trailing", hdr + body + b"\0\0\0\0"),
                       ("nan position", hdr + nan + body[4:]),
                       ("nan bary", hdr + body[:32 * t] + nan + body[32 * t + 4:]),
                       ("inv_w 0", hdr + body[:-4] + bytes(4))]:
        try:
            vc.read_bin(data)
            raise AssertionError(f"bin frame with bad {what} accepted")
        except ValueError as e:
            assert str(e).startswith("bin frame: "), e


def test_session_hello():
    if vc.websockets is None:
        print("  (no websockets: hello not checked)")
        return
    s = vc.Session("ws://127.0.0.1:1/", fmt="compact", quantum=8, compression="deflate", width=64, height=32)
    assert s.hello == {"type": "hello", "versions": [1, 2, 3], "format": "compact", "attributes": False,
                       "viewport": {"width": 64, "height": 32}, "quantum": 8, "compression": "deflate"}, s.hello
    assert "quantum" not in vc.Session("ws://x/", fmt="bin").hello
    for bad in (dict(fmt="png"), dict(fmt="bin", quantum=4), dict(fmt="compact", attributes=True)):
        try:
            vc.Session("ws://x/", **bad)
            raise AssertionError(f"Session accepted {bad}")
        except ValueError:
            pass


def test_session_stub():
    """Session(fmt="compact") against a stand-in for a version 2 server (welcome, scene_ready, a
    frame header and the vector as its binary payload): hello's fields, the frame decoded."""
    if vc.websockets is None:
        print("  (no websockets: skipped)")
        return
    import asyncio
    vector = read(os.path.join(VECTORS, "compact_cornell_deflate.vmc"))
    hellos = []

    async def serve(ws):
        hello = json.loads(await ws.recv())
        hellos.append(hello)
        await ws.send(json.dumps({"type": "welcome", "version": 2 if 2 in hello["versions"] else 1,
                                  "session": "s", "format": hello["format"]}))
        async for m in ws:
            msg = json.loads(m) if isinstance(m, str) else None
            if msg and msg["type"] == "scene":
                await ws.recv()
                await ws.send(json.dumps({"type": "scene_ready", "name": msg["name"], "triangles": 4}))
            elif msg and msg["type"] == "camera":
                await ws.send(json.dumps({"type": "frame", "seq": msg["seq"], "format": hello["format"],
                                          "bytes": len(vector)}))
                await ws.send(vector)

    async def run():
        async with vc.websockets.serve(serve, "127.0.0.1", 0) as server:
            port = server.sockets[0].getsockname()[1]
            async with vc.Session(f"ws://127.0.0.1:{port}/", fmt="compact", compression="deflate",
                                  timeout=20) as s:
                assert s.welcome["version"] == 2
                await s.upload("tet.obj", b"v 0 0 0\n")
                header, frame = await s.frame(eye=[1, 2, 3])
                assert header["seq"] == 1 and isinstance(frame, vc.CompactFrame) and frame.triangle_count == 116

    asyncio.run(run())
    assert hellos[0]["versions"] == [1, 2, 3] and hellos[0]["format"] == "compact", hellos
    assert hellos[0]["compression"] == "deflate" and "quantum" not in hellos[0], hellos


def test_install(tmp):
    """pip builds and installs the package offline (Debian's setuptools and wheel, no index) into
    a folder, and a fresh interpreter imports it from there and decodes a vector."""
    src = os.path.join(tmp, "src")
    shutil.copytree(PKG, src, ignore=shutil.ignore_patterns("__pycache__", "build", "*.egg-info", "tests"))
    target = os.path.join(tmp, "site")
    r = subprocess.run([sys.executable, "-m", "pip", "install", "--no-build-isolation", "--no-deps", "--no-index",
                        "--no-cache-dir", "--disable-pip-version-check", "--quiet", "--target", target, src],
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stdout + r.stderr
    code = ("import sys, vismap_client as vc; print(vc.__file__); "
            f"print(vc.read_compact(open({os.path.join(VECTORS, 'compact_cornell_deflate.vmc')!r}, 'rb').read())"
            ".triangle_count)")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60, cwd=tmp,
                       env=dict(os.environ, PYTHONPATH=target))
    assert r.returncode == 0, r.stderr
    where, count = r.stdout.split()
    assert where.startswith(target) and count == "116", r.stdout


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--vismap", help="the vismap CLI (bunny frames, and the C++ reader for comparison)")
    ap.add_argument("--time", action="store_true", help="print decode times of the bunny frames")
    ap.add_argument("--skip-install", action="store_true")
    a = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        tests = [("vectors", test_vectors), ("truncated", test_truncated), ("bin_malformed", test_bin_malformed),
                 ("session_hello", test_session_hello), ("session_stub", test_session_stub)]
        if a.vismap:
            tests += [("bunny", lambda: test_bunny(a.vismap, tmp, a.time)),
                      ("malformed", lambda: test_malformed(a.vismap, tmp))]
        else:
            print("no --vismap: bunny frames and the comparison with the C++ reader skipped")
        if not a.skip_install:
            tests.append(("install", lambda: test_install(tmp)))
        for name, fn in tests:
            t0 = time.perf_counter()
            fn()
            print(f"ok {name} ({time.perf_counter() - t0:.1f} s)")
    print("ok")


if __name__ == "__main__":
    main()
