"""Python client for vismapd (proto/PROTOCOL.md) on Debian's python3-websockets, and a reader
for the binary frame format (proto/FORMAT.md).

    import asyncio, vismap_client as vc
    async def main():
        async with vc.Session("ws://127.0.0.1:8080/", fmt="bin") as s:
            ready = await s.upload("bunny.ply", open("bunny.ply", "rb").read())
            header, frame = await s.frame(eye=[1, 0.5, 2])
            print(header["render_ms"], frame.triangle_count)
    asyncio.run(main())
"""
import array
import asyncio
import json
import random
import struct
import sys
from dataclasses import dataclass, field

import websockets

PROTOCOL_VERSION = 1


class ServerError(Exception):
    """An error message from the server: .code (proto/PROTOCOL.md), .fatal, .seq."""

    def __init__(self, msg):
        super().__init__(f"{msg.get('code')}: {msg.get('message')}")
        self.code = msg.get("code")
        self.fatal = msg.get("fatal", False)
        self.seq = msg.get("seq")


@dataclass
class BinFrame:
    """One binary frame: struct-of-arrays, as in proto/FORMAT.md."""
    version: int
    width: int
    height: int
    flags: int
    xy: array.array                 # float32, 6 per triangle (pixels, y down)
    mesh: array.array               # uint32 per triangle
    triangle_id: array.array        # uint32 per triangle (global source triangle id)
    bary: array.array = field(default_factory=lambda: array.array("f"))   # 9 per triangle if flags & 1
    inv_w: array.array = field(default_factory=lambda: array.array("f"))  # 3 per triangle if flags & 1

    @property
    def triangle_count(self):
        return len(self.mesh)


def read_bin(data: bytes) -> BinFrame:
    """Parses a binary frame; raises ValueError on malformed bytes."""
    if len(data) < 24 or data[:4] != b"VMAP":
        raise ValueError("not a vismap binary frame (magic)")
    version, width, height, flags, t = struct.unpack_from("<5I", data, 4)
    if version != 1:
        raise ValueError(f"unsupported binary frame version {version}")
    per = 80 if flags & 1 else 32
    if len(data) != 24 + per * t:
        raise ValueError(f"frame of {len(data)} bytes, expected {24 + per * t} for {t} triangles")

    def section(code, offset, count):
        a = array.array(code)
        a.frombytes(data[offset:offset + 4 * count])
        if sys.byteorder != "little":
            a.byteswap()
        return a

    f = BinFrame(version, width, height, flags, section("f", 24, 6 * t), section("I", 24 + 24 * t, t),
                 section("I", 24 + 28 * t, t))
    if flags & 1:
        f.bary = section("f", 24 + 32 * t, 9 * t)
        f.inv_w = section("f", 24 + 68 * t, 3 * t)
    return f


class Session:
    """One vismapd session. Use as `async with Session(url, ...) as s:`.

    With retries > 0 the session survives the loss of its server (behind a load balancer such as
    deploy/nginx.conf): connecting retries with exponential backoff and jitter (backoff, doubling
    up to max_backoff seconds), and when the connection drops, or the server answers a fatal
    `shutting_down`, frame() reconnects, sends hello and the last scene again, and retries the
    camera. `reconnects` counts the reconnections."""

    def __init__(self, url, fmt="svg", width=1024, height=1024, attributes=False, token=None, timeout=60,
                 retries=0, backoff=0.1, max_backoff=2.0):
        self.url, self.fmt, self.timeout = url, fmt, timeout
        self.hello = {"type": "hello", "version": PROTOCOL_VERSION, "format": fmt, "attributes": attributes,
                      "viewport": {"width": width, "height": height}}
        if token is not None:
            self.hello["token"] = token
        self.retries, self.backoff, self.max_backoff = retries, backoff, max_backoff
        self.reconnects = 0
        self.ws = None
        self.welcome = None
        self.scene = None
        self._scene_source = None  # ("upload", name, bytes) or ("library", name): replayed on reconnect
        self._seq = 0

    async def __aenter__(self):
        await self._open_with_retry()
        return self

    async def __aexit__(self, *exc):
        await self.ws.close()

    async def _open(self):
        self.ws = await websockets.connect(self.url, max_size=None, open_timeout=self.timeout)
        await self.send(self.hello)
        self.welcome = await self.recv_json()

    async def _open_with_retry(self):
        delay = self.backoff
        for attempt in range(self.retries + 1):
            try:
                return await self._open()
            except (OSError, asyncio.TimeoutError, websockets.WebSocketException, ServerError) as e:
                if self.ws is not None:
                    await self.ws.close()
                if attempt == self.retries or (isinstance(e, ServerError) and e.code != "busy"):
                    raise
                await asyncio.sleep(delay * random.uniform(0.5, 1.5))
                delay = min(2 * delay, self.max_backoff)

    async def reconnect(self):
        """Opens a new connection (with backoff), sends hello and the last scene again."""
        if self.ws is not None:
            await self.ws.close()
        await self._open_with_retry()
        self.reconnects += 1
        if self._scene_source is not None:
            if self._scene_source[0] == "upload":
                await self.upload(self._scene_source[1], self._scene_source[2])
            else:
                await self.library(self._scene_source[1])

    async def send(self, msg):
        await self.ws.send(json.dumps(msg))

    async def recv(self):
        return await self._wait(self.ws.recv())

    async def _wait(self, aw):
        return await asyncio.wait_for(aw, self.timeout)

    async def recv_json(self):
        """Next control message; an error message is raised as ServerError."""
        m = await self.recv()
        if isinstance(m, bytes):
            raise ValueError("expected a JSON message, got binary")
        msg = json.loads(m)
        if msg.get("type") == "error":
            raise ServerError(msg)
        return msg

    async def upload(self, name, data: bytes):
        """Uploads scene bytes (name's extension picks the loader); returns scene_ready."""
        self._scene_source = ("upload", name, data)
        await self.send({"type": "scene", "name": name, "size": len(data)})
        await self.ws.send(data)
        self.scene = await self.recv_json()
        return self.scene

    async def library(self, name):
        self._scene_source = ("library", name)
        await self.send({"type": "scene", "library": name})
        self.scene = await self.recv_json()
        return self.scene

    async def camera(self, **fields):
        """Sends a camera (fields as in schemas/camera.json); returns its seq."""
        self._seq += 1
        await self.send(dict({"type": "camera", "seq": self._seq}, **fields))
        return self._seq

    async def next_frame(self):
        """(header, payload): payload is str (svg) or BinFrame (bin)."""
        header = await self.recv_json()
        if header.get("type") != "frame":
            raise ValueError(f"expected a frame, got {header}")
        payload = await self.recv()
        if isinstance(payload, bytes):
            return header, read_bin(payload)
        return header, payload

    async def frame(self, **fields):
        """Sends a camera and returns its frame; with retries, reconnects when the server is lost."""
        for attempt in range(self.retries + 1):
            try:
                await self.camera(**fields)
                return await self.next_frame()
            except (websockets.ConnectionClosed, OSError, ServerError) as e:
                lost = not isinstance(e, ServerError) or (e.fatal and e.code == "shutting_down")
                if not lost or attempt == self.retries:
                    raise
                await self.reconnect()
