#!/usr/bin/env python3
"""vismap_client.DeltaDecoder against the reference (core/stream/delta.cpp via `vismap decode
FRAMES... --json`): the delta test vectors decode in sequence to their JSON exactly (as sent, zstd,
and repacked with raw deflate); a skipped frame raises DeltaOutOfSync and a keyframe recovers; every
truncation and many mutations of vector 1 after vector 0 (and of the keyframe, vector 0, after
vectors 0 and 1) raise ValueError and nothing else, and leave the state so that the next vector
then decodes exactly (where the C++ decoder accepts a mutated
frame Python accepts it with the same arrays, and vice versa); hand-made frames (delta_craft.py:
ties of the rounding on both sides of zero, edge points in all directions, twins, back faces,
non-finite shade factors, deflate) decode as C++ decodes them; bunny orbits made by
vismap_delta_orbit (zstd at 1920x1080, deflate at quantum 4 with keyframes mid-stream) decode
frame by frame as C++ decodes them; Session(fmt="delta") says hello and, against a stand-in
server that loses a frame, asks for a keyframe and returns it.

    /usr/bin/python3 clients/python/tests/test_delta.py [--vismap build/vismap]
        [--orbit build/tests/vismap_delta_orbit] [--time]

Exits 77 (skipped) without numpy or zstandard (scripts/setup.sh --tests installs them)."""
import argparse
import asyncio
import copy
import json
import os
import random
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
sys.path.insert(0, HERE)
try:
    import numpy as np
    import zstandard
    import vismap_client as vc
    from vismap_client import delta
    import delta_craft
except ImportError as e:  # run scripts/setup.sh --tests
    print(f"skipped: {e}")
    sys.exit(77)

ARRAYS = ("xy", "indices", "source", "mesh", "shade")


def read(path):
    with open(path, "rb") as f:
        return f.read()


def vector(k):
    return read(os.path.join(VECTORS, f"delta_cornell_{k}.vmd"))


def vector_json(k):
    return json.loads(read(os.path.join(VECTORS, f"delta_cornell_{k}.json")))


def same(f, ref, what):
    """The frame's arrays equal the JSON's (`vismap decode --json` or a vector) exactly."""
    for k in ("width", "height", "quantum"):
        assert getattr(f, k) == ref[k], (what, k, getattr(f, k), ref[k])
    assert f.vertex_count == ref["vertices"] and f.triangle_count == ref["triangles"], \
        (what, f.vertex_count, ref["vertices"], f.triangle_count, ref["triangles"])
    for k in ARRAYS:
        got = getattr(f, k).tolist()
        if got != ref[k]:
            i = next((i for i, (a, b) in enumerate(zip(got, ref[k])) if a != b), min(len(got), len(ref[k])))
            raise AssertionError(f"{what}: {k} differs at {i} of {len(got)} / {len(ref[k])}: "
                                 f"{got[i:i + 6]} against {ref[k][i:i + 6]}")


def same_frames(a, b, what):
    for k in ARRAYS + ("mesh_base", "mesh_color", "rows", "eye", "target"):
        x, y = getattr(a, k), getattr(b, k)
        assert x.dtype == y.dtype and np.array_equal(x, y), (what, k)
    for k in ("width", "height", "quantum", "index", "keyframe", "projection"):
        assert getattr(a, k) == getattr(b, k), (what, k)


def valid(f, what):
    """What DELTA.md promises of a decoded frame."""
    t, v = f.triangle_count, f.vertex_count
    assert f.xy.dtype == np.int32 and f.indices.dtype == np.uint32 and f.source.dtype == np.uint32, what
    assert f.mesh.dtype == np.uint32 and f.shade.dtype == np.uint8 and len(f.indices) == 3 * t, what
    assert len(f.mesh) == t and len(f.shade) == t and f.mesh_color.shape == (len(f.mesh_base), 3), what
    if t:
        assert f.indices.max() < v, what
        p = f.xy.astype(np.int64).reshape(-1, 2)
        c = p[f.indices.reshape(-1, 3)]
        o = (c[:, 1, 0] - c[:, 0, 0]) * (c[:, 2, 1] - c[:, 0, 1]) - (c[:, 1, 1] - c[:, 0, 1]) * (c[:, 2, 0] - c[:, 0, 0])
        assert (o > 0).all(), what
        assert (f.mesh_base[f.mesh] <= f.source).all(), what
        assert f.colors().shape == (t, 3), what


def decode(dec, data, what):
    """dec.decode(data), or None when refused with ValueError; anything else fails the test."""
    try:
        return dec.decode(data)
    except ValueError as e:
        assert str(e).startswith("delta frame: "), f"{what}: {e}"
        return None
    except Exception as e:
        raise AssertionError(f"{what}: {type(e).__name__} instead of ValueError: {e}") from e


def cli_decode(vismap, paths, sources=None):
    """`vismap decode PATHS... --json` (after `--sources SOURCES`, a held scene): the last frame's
    JSON, or None when the C++ decoder refuses one of them."""
    held = ["--sources", sources] if sources else []
    r = subprocess.run([vismap, "decode", *held, *paths, "--json"], capture_output=True, text=True,
                       timeout=120)
    assert r.returncode >= 0, f"vismap decode died: {r.returncode} {r.stderr}"
    if r.returncode != 0:
        return None
    return json.loads("\n".join(r.stdout.split("\n")[len(paths) - 1:]))


def repack(data, codec=2, payload=None):
    """The frame with its payload (or another) compressed anew: codec 2 raw deflate, 1 zstd."""
    if payload is None:
        payload = unpack(data)
    if codec == 1:
        z = zstandard.ZstdCompressor(level=3).compress(payload)
    else:
        c = zlib.compressobj(6, zlib.DEFLATED, -15)
        z = c.compress(payload) + c.flush()
    return data[:36] + struct.pack("<2I", codec, len(payload)) + data[44:48] + z


def unpack(data):
    codec = struct.unpack_from("<I", data, 36)[0]
    z = data[48:]
    return zstandard.ZstdDecompressor().decompress(z) if codec == 1 else zlib.decompress(z, -15)


# ---------------------------------------------------------------------------------------------

def test_vectors():
    for codec in (1, 2):
        dec = vc.DeltaDecoder()
        assert not dec.has_state and dec.last_index is None
        for k in range(3):
            data = vector(k) if codec == 1 else repack(vector(k))
            f = dec.decode(data)
            what = f"vector {k} ({'zstd' if codec == 1 else 'deflate'})"
            same(f, vector_json(k), what)
            valid(f, what)
            assert f.keyframe == (k == 0) and f.index == k and dec.last_index == k, what
            assert f.compression == ("zstd" if codec == 1 else "deflate") and f.projection == "perspective", what
            assert f.rows.shape == (12,) and f.eye.shape == (3,) and np.isfinite(f.rows).all(), what
            assert len(data) == vector_json(k)["bytes"] or codec == 2, what
    try:
        vc.read_frame(vector(0))
        raise AssertionError("read_frame decoded a delta frame without its stream")
    except ValueError:
        pass
    # Version 2 (proto/vectors/README.md): the held torus, a compact frame at 3, frame 4 based on 2.
    dec = vc.DeltaDecoder()
    try:
        dec.decode(read(os.path.join(VECTORS, "delta2_torus_0.vmd")))
        raise AssertionError("a held keyframe decoded without the held scene")
    except vc.DeltaOutOfSync:
        pass
    dec.hold_scene(read(os.path.join(VECTORS, "delta2_torus_sources.vmd")))
    assert dec.holds_scene
    for k in range(5):
        f = dec.decode(read(os.path.join(VECTORS, f"delta2_torus_{k}.vmd")))
        what = f"version 2 vector {k}"
        same(f, json.loads(read(os.path.join(VECTORS, f"delta2_torus_{k}.json"))), what)
        valid(f, what)
        assert f.keyframe == (k == 0) and f.compact == (k == 3), what
        assert dec.last_index == (2 if k == 3 else k), what  # a compact frame leaves the state alone


def test_rounding():
    """llround is C's (ties away from zero), not numpy's or Python's round (ties to even)."""
    g = np.array([0.5, -0.5, 1.5, -1.5, 2.5, -2.5, 0.49999999999999994, -0.49999999999999994, 1e9 - 0.5, -7.0])
    assert delta.llround(g).tolist() == [1, -1, 2, -2, 3, -3, 0, 0, 1e9, -7]
    assert [delta.div_round(q, 4) for q in (-6, -2, 2, 6, -5, 5)] == [-1, 0, 1, 2, -1, 1]  # floor(q/4 + 1/2)
    # A degenerate source (no normal) and a camera with eye = target (no view direction): the
    # factor is not finite, k = 1; a face seen head-on is 255 and one at 60 degrees 0.12 + 0.44.
    p = np.array([[[0, 0, 0], [1, 0, 0], [2, 0, 0]], [[0, 0, 0], [1, 0, 0], [0, 1, 0]]], np.float64)
    assert delta.shades(p, np.zeros(3), np.zeros(3), False).tolist() == [255, 255]
    eye = np.array([0.0, np.sin(np.pi / 3), np.cos(np.pi / 3)]) * 5.0
    assert delta.shades(p[1:], np.array([0.0, 0.0, 3.0]), np.zeros(3), False).tolist() == [255]
    assert delta.shades(p[1:], eye, np.zeros(3), False).tolist() == [int(np.floor((0.12 + 0.88 * 0.5) * 255 + 0.5))]


def test_out_of_sync():
    v = [vector(k) for k in range(3)]
    dec = vc.DeltaDecoder()
    for k in (1, 2):
        try:
            dec.decode(v[k])
            raise AssertionError(f"vector {k} decoded without a keyframe")
        except vc.DeltaOutOfSync as e:
            assert isinstance(e, ValueError) and "keyframe" in str(e)
    assert not dec.has_state
    dec.decode(v[0])
    try:
        dec.decode(v[2])  # vector 1 lost
        raise AssertionError("vector 2 decoded after vector 0")
    except vc.DeltaOutOfSync:
        pass
    same(dec.decode(v[1]), vector_json(1), "vector 1 after a refused vector 2")
    same(dec.decode(v[2]), vector_json(2), "vector 2")
    try:
        dec.decode(v[2])  # a repeated frame
        raise AssertionError("vector 2 decoded twice")
    except vc.DeltaOutOfSync:
        pass
    same(dec.decode(v[0]), vector_json(0), "a keyframe in the middle")  # always applies, resets
    try:
        dec.decode(v[2])
        raise AssertionError("vector 2 decoded after the keyframe")
    except vc.DeltaOutOfSync:
        pass
    same(dec.decode(v[1]), vector_json(1), "vector 1 after the keyframe")
    dec.reset()
    assert not dec.has_state
    try:
        dec.decode(v[1])
        raise AssertionError("vector 1 decoded after reset")
    except vc.DeltaOutOfSync:
        pass


def test_truncated():
    """Every prefix of vector 1 (and of vector 0) is refused with ValueError; the state survives."""
    v0, v1 = vector(0), vector(1)
    dec = vc.DeltaDecoder()
    dec.decode(v0)
    for n in range(len(v1)):
        assert decode(dec, v1[:n], f"vector 1 cut to {n}") is None, f"vector 1 cut to {n} accepted"
        if n % 50 == 0:
            same(copy.copy(dec).decode(v1), vector_json(1), f"vector 1 after vector 1 cut to {n}")
    for n in range(len(v0)):
        assert decode(dec, v0[:n], f"vector 0 cut to {n}") is None, f"vector 0 cut to {n} accepted"
    same(dec.decode(v1), vector_json(1), "vector 1 after every truncation")
    assert decode(copy.copy(dec), vector(2) + b"\0", "trailing byte") is None
    huge = v0[:40] + struct.pack("<I", 1 << 31) + v0[44:]  # refused before allocating for it
    t0 = time.perf_counter()
    assert decode(vc.DeltaDecoder(), huge, "huge payload") is None and time.perf_counter() - t0 < 1


def mutations(data, rng, count):
    """Deterministic malformed variants of a frame: header fields set to edge values, flips in the
    message, and payloads flipped, cut, grown or with section sizes moved, recompressed so that
    the damage reaches the sections (delta frames are mostly compressed bytes)."""
    payload = unpack(data)
    codec = struct.unpack_from("<I", data, 36)[0]
    key = struct.unpack_from("<I", data, 16)[0] & 1
    nm = struct.unpack_from("<I", data, 32)[0]
    sizes_at = 148 + (24 * nm if key else 0)
    ns = 10 if struct.unpack_from("<I", data, 4)[0] == 1 else 11  # sections
    out = []
    for i in range(11):  # header fields
        v0 = struct.unpack_from("<I", data, 4 + 4 * i)[0]
        for v in (0, 1, 2, 0xFFFFFFFF, v0 + 1, v0 - 1):
            out.append((f"header field {i} = {v}", data[:4 + 4 * i] + struct.pack("<I", v & 0xFFFFFFFF) +
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
            lo = sizes_at + 4 * ns if kind == 2 else 0
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
            what = f"payload cut or grown at {at}"
        else:  # move bytes between sections
            s = list(struct.unpack_from(f"<{ns}I", b, sizes_at))
            i, j = rng.sample(range(ns), 2)
            d = rng.choice((1, 2, 3))
            s[i] += d
            s[j] -= d
            struct.pack_into(f"<{ns}I", b, sizes_at, *[x & 0xFFFFFFFF for x in s])
            what = f"section sizes {s}"
        out.append((what, repack(data, codec, bytes(b))))
    return out


def check_mutations(base_frames, target, ref, cases, vismap, tmp, every=10, sources=None):
    """Each case applied after base_frames (after the held scene `sources`, a path): refused with
    ValueError (then the state decodes `target` to `ref`, checked on a sample and at the end) or
    accepted as a valid frame; on the accepted ones and a sample of the refused, the C++ decoder
    agrees."""
    dec = vc.DeltaDecoder()
    if sources:
        dec.hold_scene(read(sources))
    for f in base_frames:
        dec.decode(f)
    paths = []
    for k, f in enumerate(base_frames):
        paths.append(os.path.join(tmp, f"base_{k}.vmd"))
        with open(paths[-1], "wb") as fh:
            fh.write(f)
    mutated = os.path.join(tmp, "mutated.vmd")
    accepted = checked = 0
    for k, (what, data) in enumerate(cases):
        before = copy.copy(dec)
        f = decode(dec, data, what)
        if f is not None:
            valid(f, what)
            accepted += 1
            dec = before  # (the frame applied: go on from the state before it)
        elif k % 25 == 0:
            same(copy.copy(dec).decode(target), ref, f"{what}: the target after it")
        if vismap and (f is not None or k % every == 0):
            with open(mutated, "wb") as fh:
                fh.write(data)
            cpp = cli_decode(vismap, paths + [mutated], sources)
            checked += 1
            assert (cpp is None) == (f is None), f"{what}: C++ {'refuses' if cpp is None else 'accepts'}, Python not"
            if f is not None:
                same(f, cpp, what)
    same(dec.decode(target), ref, "the target after every refusal")
    return accepted, checked


def test_mutations(vismap, tmp):
    rng = random.Random(16)
    v0, v1 = vector(0), vector(1)
    cases = mutations(v1, rng, 2000)
    accepted, checked = check_mutations([v0], v1, vector_json(1), cases, vismap, tmp)
    print(f"  {len(cases)} mutations of vector 1: {accepted} still valid frames, {checked} compared with vismap decode")
    cases = mutations(v0, rng, 600)  # the keyframe (its mesh table), after vectors 0 and 1: then vector 2
    accepted, checked = check_mutations([v0, v1], vector(2), vector_json(2), cases, vismap, tmp)
    print(f"  {len(cases)} mutations of vector 0 after vector 1: {accepted} still valid, {checked} compared")
    cases = mutations(repack(v1), rng, 300)  # deflate
    accepted, checked = check_mutations([repack(v0)], repack(v1), vector_json(1), cases, vismap, tmp)
    print(f"  {len(cases)} mutations of vector 1 in deflate: {accepted} still valid, {checked} compared")
    for bad in (b"", b"VMDF", b"VMDF" + bytes(44), b"\xff" * 100, b"VMCF" + bytes(44)):
        assert decode(vc.DeltaDecoder(), bad, "junk") is None


def test_craft(vismap, tmp):
    """Hand-made frames: decode as C++ decodes them (with --vismap) and as worked out by hand."""
    seqs = delta_craft.sequences()
    for name, frames in seqs.items():
        dec = vc.DeltaDecoder()
        paths = []
        for k, data in enumerate(frames):
            f = dec.decode(data)
            valid(f, f"{name} {k}")
            paths.append(os.path.join(tmp, f"craft_{k}.vmd"))
            with open(paths[-1], "wb") as fh:
                fh.write(data)
            if vismap:
                same(f, cli_decode(vismap, paths), f"{name} frame {k}")
            if name == "halves" and k == 0:  # x = -2.25 -> -2.5 -> -3, 0.25 -> 2.5 -> 3, -1.75 -> -1.5 -> -2
                assert f.xy[:6].tolist() == [-3, 2, 3, 2, -2, 5], f.xy[:6]
            if name == "degenerate":  # the polygon of the source with no normal: 255
                assert f.shade[f.source == 0].tolist() == [255], f.shade
    for name, (good, bad) in delta_craft.refused().items():
        dec = vc.DeltaDecoder()
        for data in good:
            dec.decode(data)
        assert decode(dec, bad, name) is None, f"{name}: accepted"
        if vismap:
            paths = []
            for k, data in enumerate(good + [bad]):
                paths.append(os.path.join(tmp, f"refused_{k}.vmd"))
                with open(paths[-1], "wb") as fh:
                    fh.write(data)
            assert cli_decode(vismap, paths) is None, f"{name}: C++ accepts"


def orbit_frames(orbit, tmp, name, *flags):
    """The orbit's frames, and its sources message (a held stream) or None."""
    out = os.path.join(tmp, name)
    os.makedirs(out, exist_ok=True)
    subprocess.run([orbit, os.path.join(ROOT, "data", "bunny.ply"), out, *flags], check=True,
                   capture_output=True, timeout=600)
    sources = os.path.join(out, "sources.vmd")
    return ([os.path.join(out, n) for n in sorted(os.listdir(out)) if n.startswith("delta_")],
            sources if os.path.exists(sources) else None)


# Version 1 and version 2 streams: held (facing flips, edge references), and not held (every
# frame the compact frame: the keyframe with every source is larger).
BUNNY_STREAMS = {
    "bunny_zstd": ("--frames", "5", "--width", "1920", "--height", "1080"),
    "bunny_deflate": ("--frames", "7", "--width", "640", "--height", "480", "--quantum", "4",
                      "--compression", "deflate", "--step", "10", "--keyframe-every", "3"),
    "bunny_v2_held": ("--frames", "5", "--width", "1920", "--height", "1080", "--version", "2",
                      "--held", "1"),
    "bunny_v2_held_deflate": ("--frames", "7", "--width", "640", "--height", "480", "--quantum", "4",
                              "--compression", "deflate", "--step", "10", "--keyframe-every", "3",
                              "--version", "2", "--held", "1"),
    "bunny_v2_compact": ("--frames", "2", "--width", "640", "--height", "480", "--version", "2"),
}


def test_bunny(vismap, orbit, tmp, timing):
    for name, flags in BUNNY_STREAMS.items():
        paths, sources = orbit_frames(orbit, tmp, name, *flags)
        dec = vc.DeltaDecoder()
        if sources:
            dec.hold_scene(read(sources))
        for k, p in enumerate(paths):
            data = read(p)
            before = copy.copy(dec)
            f = dec.decode(data)
            what = f"{name} frame {k}"
            same(f, cli_decode(vismap, paths[:k + 1], sources), what)
            valid(f, what)
            assert f.compact == name.endswith("_compact") and f.triangle_count > 1000, what
            assert f.keyframe == (not f.compact and (k == 0 or ("deflate" in name and k % 3 == 0))), what
            if timing:
                best = min(_timed(lambda: copy.copy(before).decode(data)) for _ in range(7))
                print(f"  {what}: {'keyframe, ' if f.keyframe else ''}{len(data)} bytes, {f.triangle_count} "
                      f"triangles, {f.vertex_count} vertices: {best * 1e3:.1f} ms")
        if name in ("bunny_deflate", "bunny_v2_held_deflate"):
            base = [read(p) for p in paths[:2]]
            rng = random.Random(7)
            cases = mutations(read(paths[2]), rng, 60)
            accepted, checked = check_mutations(base, read(paths[2]), cli_decode(vismap, paths[:3], sources),
                                                cases, vismap, tmp, every=4, sources=sources)
            print(f"  {len(cases)} mutations of {name} frame 2: {accepted} still valid, {checked} compared")


def _timed(fn):
    t0 = time.perf_counter()
    fn()
    return time.perf_counter() - t0


def test_session_hello():
    if vc.websockets is None:
        print("  (no websockets: hello not checked)")
        return
    s = vc.Session("ws://127.0.0.1:1/", fmt="delta", quantum=8, compression="deflate", width=64, height=32)
    assert s.hello == {"type": "hello", "versions": [1, 2, 3], "format": "delta", "attributes": False,
                       "viewport": {"width": 64, "height": 32}, "quantum": 8, "compression": "deflate"}, s.hello
    assert isinstance(s.delta, vc.DeltaDecoder) and vc.Session("ws://x/", fmt="compact").delta is None
    for bad in (dict(fmt="delta", attributes=True), dict(fmt="svg", compression="zstd")):
        try:
            vc.Session("ws://x/", **bad)
            raise AssertionError(f"Session accepted {bad}")
        except ValueError:
            pass


def test_session_stub():
    """Session(fmt="delta") against a stand-in for a version 2 server that streams the vectors and
    loses vector 1 once: the session asks for a keyframe, sends its camera again and returns the
    keyframe; the stream then goes on."""
    if vc.websockets is None:
        print("  (no websockets: skipped)")
        return
    v = [vector(k) for k in range(3)]
    log = []

    async def serve(ws):
        hello = json.loads(await ws.recv())
        log.append(hello)
        await ws.send(json.dumps({"type": "welcome", "version": 2, "session": "s", "format": hello["format"]}))
        plan = [0, 2, 0, 1]  # the vectors sent for the cameras: vector 1 is lost, then a keyframe
        asked = False
        async for m in ws:
            msg = json.loads(m)
            log.append(msg)
            if msg["type"] == "keyframe":
                asked = True
            elif msg["type"] == "camera":
                k = plan.pop(0)
                assert k != 0 or asked or len(plan) == 3, "a keyframe sent unasked"
                await ws.send(json.dumps({"type": "frame", "seq": msg["seq"], "format": "delta", "bytes": len(v[k])}))
                await ws.send(v[k])

    async def run():
        async with vc.websockets.serve(serve, "127.0.0.1", 0) as server:
            port = server.sockets[0].getsockname()[1]
            async with vc.Session(f"ws://127.0.0.1:{port}/", fmt="delta", timeout=20) as s:
                _, f = await s.frame(eye=[1, 2, 3])
                same(f, vector_json(0), "first frame")
                header, f = await s.frame(eye=[1, 2, 4])  # vector 2 arrives: out of sync, keyframe
                assert f.keyframe and s.keyframes_requested == 1 and header["seq"] == 3, (header, s.keyframes_requested)
                same(f, vector_json(0), "the keyframe asked for")
                _, f = await s.frame(eye=[1, 2, 5])
                same(f, vector_json(1), "the frame after the keyframe")

    asyncio.run(run())
    kinds = [m["type"] for m in log]
    assert kinds == ["hello", "camera", "camera", "keyframe", "camera", "camera"], kinds
    assert log[0]["format"] == "delta" and log[4]["eye"] == [1, 2, 4], log


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--vismap", help="the vismap CLI (the C++ decoder for comparison)")
    ap.add_argument("--orbit", help="vismap_delta_orbit (bunny streams; needs --vismap)")
    ap.add_argument("--time", action="store_true", help="print decode times of the bunny frames")
    a = ap.parse_args()
    vismap = a.vismap if a.vismap and os.path.exists(a.vismap) else None
    with tempfile.TemporaryDirectory() as tmp:
        tests = [("vectors", test_vectors), ("rounding", test_rounding), ("out_of_sync", test_out_of_sync),
                 ("truncated", test_truncated), ("mutations", lambda: test_mutations(vismap, tmp)),
                 ("craft", lambda: test_craft(vismap, tmp)), ("session_hello", test_session_hello),
                 ("session_stub", test_session_stub)]
        if vismap and a.orbit and os.path.exists(a.orbit):
            tests.append(("bunny", lambda: test_bunny(vismap, a.orbit, tmp, a.time)))
        else:
            print("no --vismap and --orbit: bunny streams skipped")
        if not vismap:
            print("no --vismap: the comparison with the C++ decoder skipped")
        for name, fn in tests:
            t0 = time.perf_counter()
            fn()
            print(f"ok {name} ({time.perf_counter() - t0:.1f} s)")
    print("ok")


if __name__ == "__main__":
    main()
