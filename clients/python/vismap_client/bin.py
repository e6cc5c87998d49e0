"""Reader for the binary triangle list, version 1 (proto/FORMAT.md), as numpy arrays."""
import struct
from dataclasses import dataclass, field

import numpy as np

MAGIC = b"VMAP"
VERSION = 1
HEADER_BYTES = 24
ATTRIBUTES = 1  # flags bit 0: barycentrics and 1/w present
LINES = 2       # flags bit 1: the line section (FORMAT.md "Lines")
LINE_KINDS = ("contour", "boundary", "crease", "intersection", "border")


def _empty_f32():
    return np.zeros(0, np.float32)


@dataclass(eq=False)
class BinFrame:
    """One binary frame: struct-of-arrays, as in proto/FORMAT.md. The arrays are little-endian
    views of the message's bytes (read-only when it was `bytes`), flat like the format:"""
    version: int
    width: int
    height: int
    flags: int
    xy: np.ndarray           # float32, 6 per triangle: 3 vertices x (x, y), pixels, y down
    mesh: np.ndarray         # uint32 per triangle: the mesh's index in the scene
    triangle_id: np.ndarray  # uint32 per triangle: global source triangle id
    bary: np.ndarray = field(default_factory=_empty_f32)   # float32, 9 per triangle if flags & 1
    inv_w: np.ndarray = field(default_factory=_empty_f32)  # float32, 3 per triangle if flags & 1
    # flags & 2, the line section: chain c is points[chain_end[c-1]:chain_end[c]] (x, y float32
    # pairs); chain_info: bits 0-7 the kind (LINE_KINDS), bit 8 closed, bit 9 hidden.
    chain_end: np.ndarray = field(default_factory=lambda: np.zeros(0, np.uint32))
    chain_info: np.ndarray = field(default_factory=lambda: np.zeros(0, np.uint32))
    line_points: np.ndarray = field(default_factory=_empty_f32)

    @property
    def triangle_count(self):
        return len(self.mesh)


def _fail(part, msg):
    raise ValueError(f"bin frame: {part}: {msg}")


def _first_bad(ok, per):
    """Index of the first triangle whose `per` values are not all ok."""
    return int(np.flatnonzero(~ok.reshape(-1, per).all(axis=1))[0])


def read_bin(data) -> BinFrame:
    """Parses a binary frame (bytes-like); raises ValueError naming the part on malformed bytes."""
    data = bytes(data) if not isinstance(data, bytes) else data
    if len(data) < HEADER_BYTES:
        _fail("header", f"{len(data)} bytes, the header alone is {HEADER_BYTES}")
    if data[:4] != MAGIC:
        _fail("header", "magic is not VMAP")
    version, width, height, flags, t = struct.unpack_from("<5I", data, 4)
    if version != VERSION:
        _fail("header", f"version {version} (this reader knows {VERSION})")
    if flags & ~(ATTRIBUTES | LINES):
        _fail("header", "unknown flag bits")
    sections = [("positions", "<f4", 6), ("mesh", "<u4", 1), ("triangle_id", "<u4", 1)]
    if flags & ATTRIBUTES:
        sections += [("bary", "<f4", 9), ("inv_w", "<f4", 3)]
    arrays, offset = {}, HEADER_BYTES
    for name, dtype, per in sections:
        n = 4 * per * t
        if len(data) < offset + n:
            _fail(name, f"truncated: {len(data)} bytes, {t} triangles need {offset + n} to its end")
        arrays[name] = np.frombuffer(data, dtype, per * t, offset)
        offset += n
    if flags & LINES:
        if len(data) < offset + 8:
            _fail("lines", f"truncated: {len(data)} bytes, the line section's counts end at {offset + 8}")
        c, n = struct.unpack_from("<2I", data, offset)
        end = offset + 8 + 8 * c + 8 * n
        if len(data) < end:
            _fail("lines", f"truncated: {len(data)} bytes, the line section ends at {end}")
        arrays["chain_end"] = np.frombuffer(data, "<u4", c, offset + 8)
        arrays["chain_info"] = np.frombuffer(data, "<u4", c, offset + 8 + 4 * c)
        arrays["line_points"] = np.frombuffer(data, "<f4", 2 * n, offset + 8 + 8 * c)
        offset = end
    if len(data) != offset:
        _fail("frame", f"{len(data) - offset} trailing bytes after {t} triangles")
    f = BinFrame(version, width, height, flags, arrays["positions"], arrays["mesh"], arrays["triangle_id"])
    ok = np.isfinite(f.xy)
    if not ok.all():
        _fail(f"triangle {_first_bad(ok, 6)}", "non-finite position")
    if flags & ATTRIBUTES:
        f.bary, f.inv_w = arrays["bary"], arrays["inv_w"]
        ok = np.isfinite(f.bary)
        if not ok.all():
            _fail(f"triangle {_first_bad(ok, 9)}", "non-finite barycentric")
        ok = np.isfinite(f.inv_w) & (f.inv_w > 0)
        if not ok.all():
            _fail(f"triangle {_first_bad(ok, 3)}", "1/w not positive and finite")
    if flags & LINES:
        f.chain_end, f.chain_info, f.line_points = arrays["chain_end"], arrays["chain_info"], arrays["line_points"]
        ends = f.chain_end.astype(np.int64)
        starts = np.concatenate(([0], ends[:-1]))
        if len(ends) and (np.any(ends <= starts) or ends[-1] != len(f.line_points) // 2):
            _fail("lines", "chain ends not increasing or not ending at the point count")
        if not len(ends) and len(f.line_points):
            _fail("lines", "points without chains")
        info = f.chain_info
        if np.any((info & 0xFF) >= len(LINE_KINDS)) or np.any(info & ~np.uint32(0x3FF)):
            _fail("lines", "bad chain info word")
        if not np.isfinite(f.line_points).all():
            _fail("lines", "non-finite point")
    return f
