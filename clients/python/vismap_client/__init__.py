"""Python client for vismapd (proto/PROTOCOL.md) and readers for its frames as numpy arrays: the
binary triangle list (proto/FORMAT.md, read_bin), the compact frame (proto/COMPACT.md,
read_compact) and the delta stream (proto/DELTA.md, DeltaDecoder: each frame applies to the one
before; DeltaOutOfSync when one was lost).

    import asyncio, vismap_client as vc
    async def main():
        async with vc.Session("ws://127.0.0.1:8080/", fmt="compact", compression="deflate") as s:
            ready = await s.upload("bunny.ply", open("bunny.ply", "rb").read())
            header, frame = await s.frame(eye=[1, 0.5, 2])
            print(header["render_ms"], frame.triangle_count, frame.pixels()[frame.indices[:3]])
    asyncio.run(main())

    frame = vc.read_compact(open("b.vmc", "rb").read())   # or vc.read_frame: bin or compact
    decoder = vc.DeltaDecoder()                            # a delta stream, frame by frame:
    frames = [decoder.decode(open(p, "rb").read()) for p in ("f0.vmd", "f1.vmd")]

Install (offline, Debian's interpreter): /usr/bin/python3 -m pip install --no-build-isolation
--no-deps --no-index clients/python (add --target DIR or --user as needed).
"""
from .bin import BinFrame, read_bin
from .compact import CompactFrame, read_compact
from .delta import DeltaDecoder, DeltaFrame, DeltaOutOfSync
from .session import FORMATS, PROTOCOL_VERSION, PROTOCOL_VERSIONS, ServerError, Session, read_frame, websockets

__all__ = ["BinFrame", "CompactFrame", "DeltaDecoder", "DeltaFrame", "DeltaOutOfSync", "FORMATS", "PROTOCOL_VERSION",
           "PROTOCOL_VERSIONS", "ServerError", "Session", "read_bin", "read_compact", "read_frame", "websockets"]
__version__ = "2.2.0"
