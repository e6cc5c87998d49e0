"""A vismapd session (proto/PROTOCOL.md) on Debian's python3-websockets."""
import asyncio
import json
import random

from .bin import read_bin
from .compact import read_compact
from .delta import DeltaDecoder, DeltaOutOfSync

try:
    import websockets
except ImportError:  # the decoders work without it; Session needs it
    websockets = None

# 2: compact and delta frames (proto/COMPACT.md, proto/DELTA.md); 3: delta version 2, hold_scene
PROTOCOL_VERSIONS = (1, 2, 3)
PROTOCOL_VERSION = PROTOCOL_VERSIONS[-1]
FORMATS = ("svg", "bin", "compact", "delta")


def read_frame(data):
    """A binary frame by its magic: BinFrame (VMAP) or CompactFrame (VMCF); ValueError otherwise
    (a delta frame, VMDF, needs the frames before it: DeltaDecoder)."""
    if bytes(data[:4]) == b"VMDF":
        raise ValueError("delta frame: header: decoded only in its stream, by a DeltaDecoder")
    return read_compact(data) if bytes(data[:4]) == b"VMCF" else read_bin(data)


class ServerError(Exception):
    """An error message from the server: .code (proto/PROTOCOL.md), .fatal, .seq."""

    def __init__(self, msg):
        super().__init__(f"{msg.get('code')}: {msg.get('message')}")
        self.code = msg.get("code")
        self.fatal = msg.get("fatal", False)
        self.seq = msg.get("seq")


class Session:
    """One vismapd session. Use as `async with Session(url, ...) as s:`.

    With retries > 0 the session survives the loss of its server (behind a load balancer such as
    deploy/nginx.conf): connecting retries with exponential backoff and jitter (backoff, doubling
    up to max_backoff seconds), and when the connection drops, or the server answers a fatal
    `shutting_down`, frame() reconnects, sends hello and the last scene again, and retries the
    camera. `reconnects` counts the reconnections.

    fmt="delta" (proto/DELTA.md) keeps a DeltaDecoder (`self.delta`, new on every connection:
    the server's stream starts with a keyframe). When a frame does not apply (DeltaOutOfSync: one
    was lost) or is malformed, the session sends `{"type": "keyframe"}`, after which the server's
    next delta frame is a keyframe; frame() then sends its camera once more and returns that
    keyframe's frame. `keyframes_requested` counts the requests. With hold_scene=True (protocol
    version 3) the server sends the scene's sources after each scene_ready, which the session
    gives to the decoder (`sources_bytes`: their size), and frames carry none."""

    def __init__(self, url, fmt="svg", width=1024, height=1024, attributes=False, token=None, timeout=60,
                 retries=0, backoff=0.1, max_backoff=2.0, quantum=None, compression=None, fill=None,
                 hold_scene=False):
        """fmt: "svg" (frames as str), "bin" (BinFrame), "compact" (CompactFrame, protocol
        version 2, proto/COMPACT.md) or "delta" (DeltaFrame, protocol version 2, proto/DELTA.md),
        the last two with optional quantum (grid steps per pixel, 1 ... 256) and compression
        ("zstd" or "deflate"); fill: "shade" or "id" (the server's default if None)."""
        if websockets is None:
            raise ImportError("vismap_client.Session needs the websockets module (Debian: python3-websockets)")
        if fmt not in FORMATS:
            raise ValueError(f"fmt must be one of {FORMATS}, got {fmt!r}")
        if fmt not in ("compact", "delta") and (quantum is not None or compression is not None):
            raise ValueError("quantum and compression are options of fmt='compact' and 'delta'")
        if fmt == "compact" and attributes:
            raise ValueError("compact frames carry no barycentrics; use fmt='bin' for attributes")
        if hold_scene and fmt != "delta":
            raise ValueError("hold_scene is an option of fmt='delta'")
        if fmt == "delta" and attributes:
            raise ValueError("delta frames carry no barycentrics (the client computes them from the "
                             "source triangles it holds: proto/DELTA.md); use fmt='bin' for attributes")
        self.url, self.fmt, self.timeout = url, fmt, timeout
        self.hello = {"type": "hello", "versions": list(PROTOCOL_VERSIONS), "format": fmt, "attributes": attributes,
                      "viewport": {"width": width, "height": height}}
        if quantum is not None:
            self.hello["quantum"] = quantum
        if compression is not None:
            self.hello["compression"] = compression
        if fill is not None:
            self.hello["fill"] = fill
        if token is not None:
            self.hello["token"] = token
        if hold_scene:
            self.hello["hold_scene"] = True
        self.hold_scene = hold_scene
        self.sources_bytes = 0
        self.retries, self.backoff, self.max_backoff = retries, backoff, max_backoff
        self.reconnects = 0
        self.ws = None
        self.welcome = None
        self.scene = None
        self._scene_source = None  # ("upload", name, bytes) or ("library", name): replayed on reconnect
        self._seq = 0
        self.delta = DeltaDecoder() if fmt == "delta" else None
        self.keyframes_requested = 0

    async def __aenter__(self):
        await self._open_with_retry()
        return self

    async def __aexit__(self, *exc):
        await self.ws.close()

    async def _open(self):
        self.ws = await websockets.connect(self.url, max_size=None, open_timeout=self.timeout)
        await self.send(self.hello)
        self.welcome = await self.recv_json()
        if self.fmt in ("compact", "delta") and self.welcome.get("version", 1) < 2:
            await self.ws.close()
            raise ValueError(f"the server speaks protocol version {self.welcome.get('version')}; "
                             f"{self.fmt} frames need version 2")
        if self.hold_scene and self.welcome.get("version", 1) < 3:
            await self.ws.close()
            raise ValueError(f"the server speaks protocol version {self.welcome.get('version')}; "
                             "hold_scene needs version 3")
        if self.delta is not None:
            self.delta.reset()  # a new connection is a new stream: it starts with a keyframe

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
        return await self._scene_ready()

    async def library(self, name):
        self._scene_source = ("library", name)
        await self.send({"type": "scene", "library": name})
        return await self._scene_ready()

    async def _scene_ready(self):
        """scene_ready; with hold_scene, then the sources message, given to the decoder."""
        self.scene = await self.recv_json()
        if self.hold_scene and self.scene.get("type") == "scene_ready":
            header = await self.recv_json()
            if header.get("type") != "sources":
                raise ValueError(f"expected the scene's sources, got {header}")
            data = await self.recv()
            if not isinstance(data, bytes) or len(data) != header.get("bytes"):
                raise ValueError("the sources message is not the binary message announced")
            self.delta.hold_scene(data)
            self.sources_bytes = len(data)
        return self.scene

    async def camera(self, **fields):
        """Sends a camera (fields as in schemas/camera.json); returns its seq."""
        self._seq += 1
        await self.send(dict({"type": "camera", "seq": self._seq}, **fields))
        return self._seq

    async def next_frame(self):
        """(header, payload): payload is str (svg), BinFrame (bin), CompactFrame (compact) or
        DeltaFrame (delta). A delta frame that does not apply raises DeltaOutOfSync, a malformed
        one ValueError, after asking the server for a keyframe."""
        header = await self.recv_json()
        if header.get("type") != "frame":
            raise ValueError(f"expected a frame, got {header}")
        payload = await self.recv()
        fmt = header.get("format")
        if fmt == "svg" and isinstance(payload, str):
            return header, payload
        if fmt == "delta" and isinstance(payload, bytes) and self.delta is not None:
            try:
                return header, self.delta.decode(payload)
            except ValueError:  # (DeltaOutOfSync too) the decoder's state is as it was
                self.keyframes_requested += 1
                await self.send({"type": "keyframe"})
                raise
        if fmt in ("bin", "compact", None) and isinstance(payload, bytes):
            return header, read_frame(payload)
        raise ValueError(f"a {fmt} frame header followed by a {type(payload).__name__} message")

    async def _camera_frame(self, fields):
        await self.camera(**fields)
        try:
            return await self.next_frame()
        except DeltaOutOfSync:  # a keyframe was asked for: the next frame is one
            await self.camera(**fields)
            return await self.next_frame()

    async def frame(self, **fields):
        """Sends a camera and returns its frame; with retries, reconnects when the server is lost.
        In a delta stream, a frame that does not apply is followed by a keyframe of the camera."""
        for attempt in range(self.retries + 1):
            try:
                return await self._camera_frame(fields)
            except (websockets.ConnectionClosed, OSError, ServerError) as e:
                lost = not isinstance(e, ServerError) or (e.fatal and e.code == "shutting_down")
                if not lost or attempt == self.retries:
                    raise
                await self.reconnect()
