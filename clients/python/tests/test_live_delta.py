#!/usr/bin/env python3
"""End-to-end delta frames: vismapd (protocol version 3) streams them and Session(fmt="delta")
decodes them, zstd and raw deflate, at two quanta; a `keyframe` message makes the next frame a
keyframe. Starts vismapd on an ephemeral loopback port.

    /usr/bin/python3 clients/python/tests/test_live_delta.py --vismapd build/vismapd

Exits 77 (skipped) when the server does not stream delta frames (its welcome to a hello asking
`format: "delta"` is an error, names another format or protocol version 1), or without numpy,
zstandard or websockets."""
import argparse
import asyncio
import json
import os
import signal
import subprocess
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
try:
    import numpy as np  # noqa: F401
    import zstandard  # noqa: F401
    import websockets  # noqa: F401
    import vismap_client as vc
except ImportError as e:
    print(f"skipped: {e}")
    sys.exit(77)

TET = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n"


async def speaks_delta(url):
    """None when the server streams delta frames, else why not."""
    async with websockets.connect(url, max_size=None) as ws:
        await ws.send(json.dumps({"type": "hello", "versions": [1, 2], "format": "delta"}))
        msg = json.loads(await asyncio.wait_for(ws.recv(), 30))
    if msg.get("type") != "welcome":
        return f"it answers a delta hello with {msg.get('type')} {msg.get('code')}: {msg.get('message')}"
    if msg.get("version", 1) < 2 or msg.get("format") != "delta":
        return f"its welcome says version {msg.get('version')}, format {msg.get('format')}"
    return None


async def delta_session(url, compression, quantum, hold):
    """Protocol version 3: DELTA.md version 2 frames, each delta, keyframe or (when smaller) the
    compact frame, never larger than compact_bytes; with hold, the sources message first."""
    async with vc.Session(url, fmt="delta", compression=compression, quantum=quantum, width=96, height=64,
                          hold_scene=hold) as s:
        assert s.welcome["version"] == 3, s.welcome
        ready = await s.upload("tet.obj", TET)
        assert ready["triangles"] == 4
        assert (s.sources_bytes > 0) == hold and s.delta.holds_scene == hold
        for seq in range(4):
            if seq == 3:
                await s.send({"type": "keyframe"})
            header, f = await s.frame(eye=[2.0, 1.0 + 0.2 * seq, 3.0], target=[0.25, 0.25, 0.25])
            assert header["format"] == "delta" and header["seq"] == s._seq, header
            assert isinstance(f, vc.DeltaFrame), type(f)
            assert header["bytes"] <= header["compact_bytes"], header
            assert f.compact == (header["coding"] == "compact"), header
            assert f.keyframe == (header["coding"] == "keyframe"), header
            assert f.keyframe or f.compact or seq not in (0, 3), (seq, header)
            assert (f.width, f.height) == (96, 64) and f.compression == (compression or "zstd")
            assert f.quantum == (quantum or 16) and f.triangle_count > 0
            assert set(f.source.tolist()) <= {0, 1, 2, 3}
        assert s.keyframes_requested == 0


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--vismapd", required=True)
    a = ap.parse_args()
    if not os.path.exists(a.vismapd):
        print(f"skipped: {a.vismapd} is not built")
        sys.exit(77)
    with tempfile.TemporaryDirectory() as lib:
        proc = subprocess.Popen([a.vismapd, "--port", "0", "--library", lib], stderr=subprocess.PIPE, text=True)
        try:
            event = json.loads(proc.stderr.readline())
            assert event["event"] == "listening", event
            url = f"ws://127.0.0.1:{event['port']}/"
            why = asyncio.run(speaks_delta(url))
            if why:
                print(f"skipped: this vismapd does not stream delta frames: {why}")
                sys.exit(77)
            for compression, quantum, hold in ((None, None, False), ("deflate", 4, True), ("zstd", 256, True)):
                asyncio.run(delta_session(url, compression, quantum, hold))
        finally:
            proc.send_signal(signal.SIGTERM)
            try:
                proc.wait(timeout=20)
            except subprocess.TimeoutExpired:
                proc.kill()
    print("ok")


if __name__ == "__main__":
    main()
