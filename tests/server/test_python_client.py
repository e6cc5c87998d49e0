#!/usr/bin/env python3
"""End-to-end: the vismapd binary, the Python client and the JSON schemas of proto/schemas.
Starts vismapd on an ephemeral loopback port, runs svg and bin sessions, validates every control
message against its schema, parses binary frames with read_bin, then stops the server with
SIGTERM and checks the graceful stop. Bounded: every wait has a timeout."""
import argparse
import asyncio
import json
import os
import signal
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(ROOT, "clients", "python"))
try:
    import jsonschema  # noqa: E402
    import vismap_client as vc  # noqa: E402
except ImportError as e:  # run scripts/setup.sh --tests
    print(f"skipped: {e}")
    sys.exit(77)

TET = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n"
SCHEMAS = {}
for name in os.listdir(os.path.join(ROOT, "proto", "schemas")):
    with open(os.path.join(ROOT, "proto", "schemas", name)) as f:
        SCHEMAS[name[:-5]] = json.load(f)


def check(msg):
    """Validates a message (dict) against the schema named by its type."""
    jsonschema.validate(msg, SCHEMAS[msg["type"]])
    return msg


async def raw_session(url, fmt):
    async with vc.websockets.connect(url, max_size=None) as ws:
        async def recv():
            return await asyncio.wait_for(ws.recv(), 60)
        hello = check({"type": "hello", "version": 1, "format": fmt, "attributes": fmt == "bin",
                       "viewport": {"width": 200, "height": 150}})
        await ws.send(json.dumps(hello))
        welcome = check(json.loads(await recv()))
        assert welcome["type"] == "welcome" and welcome["version"] == 1
        await ws.send(json.dumps(check({"type": "scene", "name": "tet.obj", "size": len(TET)})))
        await ws.send(TET)
        ready = check(json.loads(await recv()))
        assert ready["type"] == "scene_ready" and ready["triangles"] == 4, ready
        for seq in range(3):
            cam = check({"type": "camera", "seq": seq, "eye": [2.0, 1.0 + seq, 3.0], "target": [0.25, 0.25, 0.25]})
            await ws.send(json.dumps(cam))
            header = check(json.loads(await recv()))
            assert header["type"] == "frame" and header["seq"] == seq, header
            payload = await recv()
            assert len(payload) == header["bytes"] or len(payload.encode()) == header["bytes"]
            if fmt == "bin":
                f = vc.read_bin(payload)
                assert (f.width, f.height) == (200, 150)
                assert f.flags & 1 and f.triangle_count > 0 and len(f.bary) == 9 * f.triangle_count
            else:
                assert isinstance(payload, str) and "<svg" in payload
        for bad, code in [("{x", "bad_json"), ('{"type":"nope"}', "unknown_message"),
                          ('{"type":"camera","eye":[1]}', "bad_message")]:
            await ws.send(bad)
            err = check(json.loads(await recv()))
            assert err["type"] == "error" and err["code"] == code and not err["fatal"], err


async def raw_session_v2(url, compression):
    """Protocol version 2, compact frames: welcome, frame headers and errors against the schemas."""
    async with vc.websockets.connect(url, max_size=None) as ws:
        async def recv():
            return await asyncio.wait_for(ws.recv(), 60)
        bad = check({"type": "hello", "versions": [1, 2], "format": "compact", "attributes": True})
        await ws.send(json.dumps(bad))
        err = check(json.loads(await recv()))
        assert err["code"] == "bad_message" and "barycentrics" in err["message"], err
        hello = check({"type": "hello", "versions": [1, 2], "format": "compact", "quantum": 8,
                       "compression": compression, "viewport": {"width": 200, "height": 150}})
        await ws.send(json.dumps(hello))
        welcome = check(json.loads(await recv()))
        assert welcome["version"] == 2 and welcome["format"] == "compact", welcome
        assert welcome["formats"] == ["svg", "bin", "compact", "delta"], welcome
        await ws.send(json.dumps(check({"type": "scene", "name": "tet.obj", "size": len(TET)})))
        await ws.send(TET)
        check(json.loads(await recv()))
        await ws.send(json.dumps(check({"type": "camera", "seq": 4, "eye": [2.0, 1.0, 3.0]})))
        header = check(json.loads(await recv()))
        assert header["format"] == "compact" and header["out_triangles"] > 0, header
        payload = await recv()
        assert isinstance(payload, bytes) and len(payload) == header["bytes"]
        assert payload[:4] == b"VMCF", payload[:8]


async def client_session(url):
    async with vc.Session(url, fmt="bin", width=64, height=64) as s:
        check(s.welcome)
        check(await s.upload("tet.obj", TET))
        header, frame = await s.frame(eye=[0.3, 0.2, 3.0], target=[0.25, 0.25, 0.25])
        check(header)
        assert frame.triangle_count > 0
        try:
            await s.frame(eye=[0.25, 0.25, 0.25], target=[0.25, 0.25, 0.25])
            raise AssertionError("degenerate camera accepted")
        except vc.ServerError as e:
            assert e.code == "bad_camera" and not e.fatal


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--vismapd", required=True)
    a = ap.parse_args()
    with tempfile.TemporaryDirectory() as lib:
        proc = subprocess.Popen([a.vismapd, "--port", "0", "--library", lib], stderr=subprocess.PIPE, text=True)
        try:
            line = proc.stderr.readline()
            event = json.loads(line)
            assert event["event"] == "listening", line
            url = f"ws://127.0.0.1:{event['port']}/"
            asyncio.run(raw_session(url, "svg"))
            asyncio.run(raw_session(url, "bin"))
            asyncio.run(raw_session_v2(url, "zstd"))
            asyncio.run(raw_session_v2(url, "deflate"))
            asyncio.run(client_session(url))
        finally:
            proc.send_signal(signal.SIGTERM)
            try:
                rc = proc.wait(timeout=20)
            except subprocess.TimeoutExpired:
                proc.kill()
                raise
        log = [json.loads(l) for l in proc.stderr.read().splitlines() if l.strip()]
        assert rc == 0, rc
        assert log and log[-1]["event"] == "stopped", log[-3:]
        assert all("ts" in e and "event" in e for e in log)
    print("ok")


if __name__ == "__main__":
    main()
