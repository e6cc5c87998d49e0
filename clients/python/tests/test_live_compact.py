#!/usr/bin/env python3
"""End-to-end compact frames: vismapd (protocol version 2) streams them and Session(fmt="compact")
decodes them, zstd and raw deflate, at two quanta. Starts vismapd on an ephemeral loopback port.

    /usr/bin/python3 clients/python/tests/test_live_compact.py --vismapd build/vismapd

Exits 77 (skipped) when the server speaks only protocol version 1 (no compact frames yet), or
without numpy, zstandard or websockets."""
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


async def server_version(url):
    async with websockets.connect(url, max_size=None) as ws:
        await ws.send(json.dumps({"type": "hello", "versions": [1, 2], "format": "bin"}))
        return json.loads(await asyncio.wait_for(ws.recv(), 30)).get("version")


async def compact_session(url, compression, quantum):
    async with vc.Session(url, fmt="compact", compression=compression, quantum=quantum, width=96, height=64) as s:
        assert s.welcome["version"] == 3, s.welcome  # (compact frames are as in version 2)
        ready = await s.upload("tet.obj", TET)
        assert ready["triangles"] == 4
        for seq in range(3):
            header, frame = await s.frame(eye=[2.0, 1.0 + seq, 3.0], target=[0.25, 0.25, 0.25])
            assert header["format"] == "compact" and header["seq"] == s._seq, header
            assert isinstance(frame, vc.CompactFrame), type(frame)
            assert (frame.width, frame.height) == (96, 64) and frame.compression == (compression or "zstd")
            assert frame.quantum == (quantum or 16) and frame.triangle_count > 0
            assert set(frame.source.tolist()) <= {0, 1, 2, 3}


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
            version = asyncio.run(server_version(url))
            if version < 2:
                print(f"skipped: this vismapd speaks protocol version {version}; compact frames need 2")
                sys.exit(77)
            for compression, quantum in ((None, None), ("zstd", 4), ("deflate", 16), ("deflate", 256)):
                asyncio.run(compact_session(url, compression, quantum))
        finally:
            proc.send_signal(signal.SIGTERM)
            try:
                proc.wait(timeout=20)
            except subprocess.TimeoutExpired:
                proc.kill()
    print("ok")


if __name__ == "__main__":
    main()
