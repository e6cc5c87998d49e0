"""Decoder for the delta frame, versions 1 and 2 (proto/DELTA.md), as numpy arrays.

The reference is DeltaDecoder::decode in core/stream/delta.cpp; this decoder keeps the same state
(the source vertices and triangles it was sent, the whole set, the previous frame's polygon sources,
the last index), accepts the frames it accepts (one difference: an id gap that would wrap 64-bit
arithmetic back into range, which C++ takes, is refused here as out of range) and gives the same
arrays bit for bit. A frame that does not apply raises DeltaOutOfSync; any other bad frame
ValueError ("delta frame: PART: what"); either leaves the state as it was. Version 2 streams may
hold compact frames (drawn alone, the state left alone) and start from a held scene
(hold_scene: the sources message).

Exactness: the projection is DELTA.md's, operation by operation in IEEE doubles (numpy's
element-wise float64 ops are IEEE's, one rounding each, no fused multiply-add), rounded half away
from zero as C's llround (not numpy's or Python's round, which round half to even); edge points
are integer arithmetic; the shade is core/stream/delta.cpp's expression in the same order.

Speed: the sections' numbers, the store's updates, the whole set, the projection, orientations
and shades are numpy; the corners (twins and point predictions chain them) are one Python loop.
A 1920x1080 bunny orbit delta frame (18-23 KB: 31,000 triangles, of them 26,000-28,000 whole,
2,200-2,500 polygons with 9,000-10,000 corners) decodes in 35-50 ms (best of 7) on the build
machine, a shared 2-vCPU VM under load average 3-5, of which the corner loop ~40%; a 53 KB frame
(4,900 polygons, 20,000 corners) and a 330 KB keyframe in 45-75 ms. `tests/test_delta.py --time`."""
import struct
from dataclasses import dataclass

import numpy as np

from . import _wire
from .compact import GridTriangles, read_compact

MAGIC = b"VMDF"
VERSIONS = (1, 2)
HEADER_BYTES = 48
KEYFRAME = 1
HELD = 2     # version 2, keyframes: the store starts from the held scene
SOURCES = 4  # version 2: the sources message
NO_BASE = 0xFFFFFFFF
MAX_RATIO = 256
MAX_SOURCES = 1 << 26  # triangles, and vertices, a client holds (as core/stream/delta.cpp)
CAMERA_BYTES = 4 + 18 * 8
SECTIONS = ("vertices", "vertex positions", "triangles", "removed", "added", "polygons", "corner codes",
            "vertex refs", "points", "edge steps", "flips")  # version 1: the first ten
COMPRESSION = {1: "zstd", 2: "deflate"}
# Corner codes (DELTA.md, "Corner codes").
VERTEX_REF, NEW_POINT, TWIN, EDGE_POINT, POINT_REF = 3, 4, 5, 6, 9
EDGE_REF, EDGE_REFS, POINT_REF2 = 9, 2, 15  # version 2: 9 + 3i + k, then 15 + j
UNSENT = 0xFFFFFFFF  # a triangle not sent yet


class DeltaOutOfSync(ValueError):
    """The frame applies to a frame this decoder has not decoded last (one was lost or reordered,
    or no keyframe yet): ask the server for a keyframe (protocol message `keyframe`)."""


def _fail(part, msg):
    raise ValueError(f"delta frame: {part}: {msg}")


@dataclass(eq=False)
class DeltaFrame(GridTriangles):
    """One decoded delta frame: triangles on the grid, as the C++ DeltaFrame."""
    width: int
    height: int
    quantum: int              # grid steps per pixel
    index: int                # this frame's number in the session's delta stream
    keyframe: bool
    compression: str          # "zstd" or "deflate"
    projection: str           # "perspective" or "orthographic"
    eye: np.ndarray           # float64 (3,): the camera (and the shade's light)
    target: np.ndarray        # float64 (3,)
    rows: np.ndarray          # float64 (12,): rows x, y, w of the view-projection, 4 each
    xy: np.ndarray            # int32, 2 per vertex: grid steps, (0, 0) top-left, y down
    indices: np.ndarray       # uint32, 3 per triangle, positive orientation on the grid
    source: np.ndarray        # uint32 per triangle: global source triangle id
    mesh: np.ndarray          # uint32 per triangle
    shade: np.ndarray         # uint8 per triangle: llround(255 k), k the --fill shade factor
    mesh_base: np.ndarray     # uint32 per mesh: its first global triangle id
    mesh_color: np.ndarray    # float32 (meshes, 3): linear RGB
    compact: bool = False     # a compact frame in a version 2 stream (no camera; state untouched)


def llround(g):
    """C's llround of float64 values (nearest, ties away from zero), exact below 2^52: the
    fraction g - trunc(g) is exact there."""
    t = np.trunc(g)
    f = g - t
    return (t + (f >= 0.5) - (f <= -0.5)).astype(np.int64)


def project_to_grid(rows, width, height, quantum, p):
    """core/stream/delta.cpp's project_to_grid for float64 points p (n, 3): (x, y) int64 and whether
    each is in front (cw > 0) and not far outside (|grid| < 1e9)."""
    r = [float(v) for v in rows]
    x, y, z = p[:, 0], p[:, 1], p[:, 2]
    cx = r[0] * x + r[1] * y + r[2] * z + r[3]  # numpy evaluates these left to right, as C++
    cy = r[4] * x + r[5] * y + r[6] * z + r[7]
    cw = r[8] * x + r[9] * y + r[10] * z + r[11]
    with np.errstate(all="ignore"):
        gx = (cx / cw + 1.0) * 0.5 * float(width) * float(quantum)
        gy = (1.0 - cy / cw) * 0.5 * float(height) * float(quantum)
        ok = (cw > 0) & (np.abs(gx) < 1e9) & (np.abs(gy) < 1e9)
    gx = np.where(ok, gx, 0.0)
    gy = np.where(ok, gy, 0.0)
    return llround(gx), llround(gy), ok


def shades(p, eye, target, ortho):
    """core/stream/delta.cpp's shade_of for triangles p (n, 3 corners, 3) float64: llround(255 k),
    k = 0.12 + 0.88 min(1, |n.l| / (|n| |l|)) (1 where that is not finite), as uint8."""
    e1 = p[:, 1] - p[:, 0]
    e2 = p[:, 2] - p[:, 0]
    # the headlight along the view, for both projections (ortho kept for the callers)
    l = np.broadcast_to(np.asarray(eye, np.float64) - np.asarray(target, np.float64), e1.shape)
    n0 = e1[:, 1] * e2[:, 2] - e1[:, 2] * e2[:, 1]
    n1 = e1[:, 2] * e2[:, 0] - e1[:, 0] * e2[:, 2]
    n2 = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
    with np.errstate(all="ignore"):
        ndl = np.abs(n0 * l[:, 0] + n1 * l[:, 1] + n2 * l[:, 2]) / \
            (np.sqrt(n0 * n0 + n1 * n1 + n2 * n2) * np.sqrt(l[:, 0] * l[:, 0] + l[:, 1] * l[:, 1] + l[:, 2] * l[:, 2]))
    ndl = np.where(np.isfinite(ndl), ndl, 1.0)
    k = (0.12 + 0.88 * np.where(1.0 < ndl, 1.0, ndl)) * 255.0  # std::min(ndl, 1.0)
    return llround(k).astype(np.uint8)


def div_round(q, n):
    """floor(q / n + 1/2) exactly, n > 0 (DELTA.md's div for edge points)."""
    return (2 * q + n) // (2 * n)


def _count(vals, part, limit, per=1, too_many="more than the scene has"):
    """A section's count n (its first number, at most `limit`), checked against its length:
    n records of `per` numbers follow, exactly."""
    if len(vals) == 0:
        _fail(part, "ends inside a number")
    n = int(vals[0])
    if n > limit:
        _fail(part, too_many)
    if len(vals) != 1 + per * n:
        _fail(part, "ends early" if len(vals) < 1 + per * n else "trailing bytes")
    return n


def _ids(vals, part, limit):
    """An id list: a count, then that many ascending gaps (every gap after the first >= 1), each
    id below `limit`; as int64. `vals` are the section's numbers."""
    _count(vals, part, limit, too_many="more ids than the scene has")
    return _gaps(vals[1:], part, limit)


def _gaps(gaps, part, limit):
    if len(gaps) == 0:
        return np.zeros(0, np.int64)
    if len(gaps) > 1 and (gaps[1:] == 0).any():
        _fail(part, "not ascending")
    if (gaps >= np.uint64(limit)).any():
        _fail(part, "out of range")
    ids = np.cumsum(gaps.astype(np.int64))
    if ids[-1] >= limit:
        _fail(part, "out of range")
    return ids


def _first_uses(v, n):
    """The distinct values of v (each in [0, n)) in the order of their first occurrence. Without
    a sort: writing the positions in reverse leaves each value's first where numpy assigns in
    order (as it does, though it does not promise it); checked, with a sort as the fallback."""
    at = np.arange(len(v))
    first = np.full(n, len(v), np.int64)
    first[v[::-1]] = at[::-1]
    mine = first[v]
    if not (mine <= at).all():  # not each value's first position: sort instead
        _, first_at = np.unique(v, return_index=True)
        return v[np.sort(first_at)]
    return v[mine == at]


def _flags(sec, at, n, part):
    """A list of flags (DELTA.md): n bits from sec[at:], as a bool array, and the next offset."""
    nb = (n + 7) // 8
    if len(sec) - at < nb:
        _fail(part, "ends early")
    bits = np.unpackbits(np.frombuffer(sec, np.uint8, nb, at), bitorder="little")
    if bits[n:].any():
        _fail(part, "a flag past the list's end")
    return bits[:n].astype(bool), at + nb


def _header(data):
    """The 48-byte header's fields, checked as far as the header alone tells."""
    if len(data) < HEADER_BYTES:
        _fail("header", f"{len(data)} bytes, the header alone is {HEADER_BYTES}")
    if data[:4] != MAGIC:
        _fail("header", "magic is not VMDF")
    h = struct.unpack_from("<11I", data, 4)
    version, width, height, flags, quantum, index, base, nm, codec, size, whole_count = h
    if version not in VERSIONS:
        _fail("header", f"version {version} (this decoder knows 1, 2)")
    if flags & ~(KEYFRAME if version == 1 else KEYFRAME | HELD | SOURCES):
        _fail("header", "unknown flag bits")
    if flags & HELD and not flags & KEYFRAME:
        _fail("header", "held without keyframe")
    if flags & SOURCES and flags != SOURCES:
        _fail("header", "sources with other flags")
    if not (1 <= width <= 65536 and 1 <= height <= 65536):
        _fail("header", "viewport out of range")
    if not 1 <= quantum <= 256:
        _fail("header", "quantum out of 1 ... 256")
    if codec not in COMPRESSION:
        _fail("header", f"unknown compression {codec}")
    if nm == 0 or nm > 1 << 24:
        _fail("header", "mesh count out of range")
    return h


def _payload(data, codec, size):
    z = memoryview(data)[HEADER_BYTES:]
    if size > MAX_RATIO * len(z) + 4096:
        _fail("header", "payload size out of proportion")
    return _wire.inflate(codec, z, size, _fail)


def _mesh_table(payload, at, nm):
    """A keyframe's mesh table: (first ids, colours, triangle count, vertex count), next offset."""
    if len(payload) - at < 24 * nm:
        _fail("mesh", "ends early")
    table = np.frombuffer(payload, np.dtype([("first", "<u4"), ("tris", "<u4"), ("verts", "<u4"),
                                             ("rgb", "<f4", 3)]), nm, at)
    tris_end = np.cumsum(table["tris"].astype(np.uint64))
    verts_end = np.cumsum(table["verts"].astype(np.uint64))
    first = np.concatenate([[0], tris_end[:-1]]).astype(np.uint64)
    bad = np.flatnonzero(table["first"].astype(np.uint64) != first)
    if len(bad):
        _fail(f"mesh {bad[0]}", "first ids do not follow the counts")
    colors = table["rgb"].astype(np.float32)
    bad = np.flatnonzero(~((colors >= 0) & (colors <= 1)).all(axis=1))
    if len(bad):
        _fail(f"mesh {bad[0]}", "color not in [0, 1]")
    if tris_end[-1] > MAX_SOURCES or verts_end[-1] > MAX_SOURCES:
        _fail("mesh", "more than 2^26 triangles or vertices")
    return first, colors, int(tris_end[-1]), int(verts_end[-1]), at + 24 * nm


def _empty_store(n_tris, n_verts):
    try:  # (as C++: the store is sized by the mesh table, up to 2^26 of each)
        return np.full((n_verts, 3), np.nan, np.float32), np.full((n_tris, 3), UNSENT, np.uint32)
    except MemoryError:
        _fail("mesh", f"no memory for {n_verts} vertices and {n_tris} triangles")


def _sections(payload, at, names):
    """The section sizes and the sections, which must fill the payload to its end."""
    if len(payload) - at < 4 * len(names):
        _fail("section sizes", "ends early")
    sizes = struct.unpack_from(f"<{len(names)}I", payload, at)
    at += 4 * len(names)
    sec = {name: b"" for name in SECTIONS}
    for name, n in zip(names, sizes):
        if n > len(payload) - at:
            _fail(name, "ends early")
        sec[name] = payload[at:at + n]
        at += n
    if at != len(payload):
        _fail("camera", "trailing bytes")
    return sec


def _add_sources(sec, vertex, tri):
    """The vertices and triangles sections into copies of the store (the inputs stay as they were)."""
    n_tris, n_verts = len(tri), len(vertex)
    vals = _wire.leb128(sec["vertices"], "vertices", _fail)
    n = _count(vals, "vertices", n_verts)
    gv = _gaps(vals[1:], "vertices", n_verts)
    if len(sec["vertex positions"]) != 12 * n:
        _fail("vertex positions", "ends early" if len(sec["vertex positions"]) < 12 * n else "trailing bytes")
    if n:
        pos = np.frombuffer(sec["vertex positions"], "<f4").reshape(n, 3)
        bad = np.flatnonzero(~np.isfinite(pos).all(axis=1))
        if len(bad):
            _fail(f"vertices {bad[0]}", "not finite")
        vertex = vertex.copy()
        vertex[gv] = pos
    vals = _wire.leb128(sec["triangles"], "triangles", _fail)
    n = _count(vals, "triangles", n_tris, per=4)
    if n:
        v = vals[1:].reshape(n, 4)
        ids = _gaps(v[:, 0].copy(), "triangles", n_tris)
        d = _wire.unzigzag(v[:, 1:].ravel())
        if (np.abs(d) >= 1 << 32).any():  # (the running number must stay in [0, 2^28))
            _fail("triangles", "names a vertex not sent")
        gvs = np.cumsum(d)
        if gvs.min() < 0 or gvs.max() >= n_verts or np.isnan(vertex[gvs, 0]).any():
            _fail("triangles", "names a vertex not sent")
        tri = tri.copy()
        tri[ids] = gvs.reshape(n, 3).astype(np.uint32)
    return vertex, tri


def _facing(view, vertex, tv):
    """DELTA.md's facing of triangles tv (n, 3 global vertex numbers) at view (rows, width, height,
    quantum): 0 degenerate, 1 positive, 2 negative, 3 a vertex that does not project."""
    used, inv = np.unique(tv.ravel(), return_inverse=True)
    gx, gy, ok = project_to_grid(view[0], view[1], view[2], view[3], vertex[used].astype(np.float64))
    x, y, ok = gx[inv].reshape(-1, 3), gy[inv].reshape(-1, 3), ok[inv].reshape(-1, 3)
    o = (x[:, 1] - x[:, 0]) * (y[:, 2] - y[:, 0]) - (y[:, 1] - y[:, 0]) * (x[:, 2] - x[:, 0])
    f = np.where(o > 0, 1, np.where(o < 0, 2, 0))
    return np.where(ok.all(axis=1), f, 3)


def _flips(before, now, vertex, tri):
    """Ascending ids of the held triangles whose facing differs between the two views."""
    known = np.flatnonzero(tri[:, 0] != UNSENT)
    if len(known) == 0:
        return known.astype(np.int64)
    tv = tri[known].astype(np.int64)
    return known[_facing(before, vertex, tv) != _facing(now, vertex, tv)].astype(np.int64)


class DeltaDecoder:
    """The client's side of a delta stream (proto/DELTA.md): decode(bytes) -> DeltaFrame."""

    def __init__(self):
        self._held = None  # hold_scene's (mesh_base, colors, vertex, tri)
        self.reset()

    def hold_scene(self, data):
        """Keeps the scene of a sources message (DELTA.md, "The held scene"): keyframes flagged held
        start from it. ValueError when malformed (what was held before stays)."""
        data = bytes(data) if not isinstance(data, bytes) else data
        h = _header(data)
        if not h[3] & SOURCES:
            _fail("header", "not a sources message")
        payload = _payload(data, h[8], h[9])
        mesh_base, colors, n_tris, n_verts, at = _mesh_table(payload, 0, h[7])
        vertex, tri = _empty_store(n_tris, n_verts)
        sec = _sections(payload, at, SECTIONS[:3])
        vertex, tri = _add_sources(sec, vertex, tri)
        bad = np.flatnonzero(np.isnan(vertex[:, 0]))
        if len(bad):
            _fail(f"vertices {bad[0]}", "not sent")
        self._held = (mesh_base, colors, vertex, tri)

    @property
    def holds_scene(self):
        return self._held is not None

    def reset(self):
        """Drops the state: the next frame must be a keyframe."""
        self._have = False
        self._last = 0
        self._base = np.zeros(0, np.uint64)   # per mesh: first global triangle id
        self._colors = np.zeros((0, 3), np.float32)
        self._vertex = np.zeros((0, 3), np.float32)  # per global vertex, NaN: not sent
        self._tri = np.zeros((0, 3), np.uint32)      # per global triangle, UNSENT: not sent
        self._whole = np.zeros(0, np.int64)          # sorted
        self._partial = np.zeros(0, np.int64)        # sorted: the previous frame's polygon sources
        self._view = None                            # the last frame's (rows, width, height, quantum)

    def _compact(self, data):
        """A compact frame in a version 2 stream: drawn as it is, the state left alone."""
        try:
            c = read_compact(data)
        except ValueError as e:
            raise ValueError(f"delta frame: compact frame: {e}") from e
        if c.shade is None:
            _fail("compact frame", "no shades")
        zero = np.zeros(3, np.float64)
        return DeltaFrame(c.width, c.height, c.quantum, 0, False, c.compression, "perspective", zero,
                          zero.copy(), np.zeros(12, np.float64), c.xy, c.indices, c.source, c.mesh,
                          c.shade, c.mesh_base.astype(np.uint32), c.mesh_color.copy(), True)

    @property
    def has_state(self):
        return self._have

    @property
    def last_index(self):
        """The index of the last frame decoded, None before the first keyframe."""
        return self._last if self._have else None

    def decode(self, data) -> DeltaFrame:
        """Decodes the next frame of the stream; raises DeltaOutOfSync when it does not apply to
        the last decoded frame (ask for a keyframe), ValueError when malformed. Both leave the
        state as it was."""
        data = bytes(data) if not isinstance(data, bytes) else data
        if data[:4] == b"VMCF":
            return self._compact(data)
        version, width, height, flags, quantum, index, base, nm, codec, size, whole_count = _header(data)
        if flags & SOURCES:
            _fail("header", "a sources message (hold_scene takes it)")
        key = bool(flags & KEYFRAME)
        held = bool(flags & HELD)
        if held and self._held is None:
            raise DeltaOutOfSync("delta frame: header: a keyframe of the held scene, and this decoder holds none")
        if not key and not self._have:
            raise DeltaOutOfSync("delta frame: header: no keyframe decoded yet: ask for one")
        if not key and (base != self._last or nm != len(self._base)):
            raise DeltaOutOfSync(f"delta frame: header: based on frame {base}, the last decoded is "
                                 f"{self._last}: ask for a keyframe")
        payload = _payload(data, codec, size)

        # Camera.
        if len(payload) < CAMERA_BYTES:
            _fail("camera", "ends early")
        if payload[0] > 1:
            _fail("camera", "unknown projection")
        ortho = payload[0] == 1
        cam = np.frombuffer(payload, "<f8", 18, 4).astype(np.float64)
        eye, target, rows = cam[0:3].copy(), cam[3:6].copy(), cam[6:18].copy()
        if not np.isfinite(cam[:6]).all():
            _fail("camera", "eye or target not finite")
        if not np.isfinite(rows).all():
            _fail("camera", "projection not finite")
        at = CAMERA_BYTES

        # The store: a keyframe's mesh table sizes it anew (or names the held scene's). Nothing of
        # self changes before the end.
        if key:
            mesh_base, colors, n_tris, n_verts, at = _mesh_table(payload, at, nm)
            if held:
                hb, hc, vertex, tri = self._held
                if len(hb) != len(mesh_base) or (hb != mesh_base).any() or (hc != colors).any() or \
                        len(tri) != n_tris or len(vertex) != n_verts:
                    _fail("mesh", "not the held scene's meshes")
            else:
                vertex, tri = _empty_store(n_tris, n_verts)
            whole = np.zeros(0, np.int64)
            partial = np.zeros(0, np.int64)
        else:
            mesh_base, colors = self._base, self._colors
            vertex, tri, whole, partial = self._vertex, self._tri, self._whole, self._partial
            n_tris, n_verts = len(tri), len(vertex)
        sec = _sections(payload, at, SECTIONS[:10 if version == 1 else 11])

        # Version 2: the facing flips since the last frame, on the store before this frame's sources.
        view = (rows, width, height, quantum)
        flips = np.zeros(0, np.int64)
        if version >= 2 and not key:
            flips = _flips(self._view, view, vertex, tri)
        vertex, tri = _add_sources(sec, vertex, tri)

        # The whole set's change: the flips' bits, then the lists of the rest.
        fin = flips[np.isin(flips, whole)]
        fout = flips[~np.isin(flips, whole)]
        bits_in, fat = _flags(sec["flips"], 0, len(fin), "flips")
        bits_out, fat = _flags(sec["flips"], fat, len(fout), "flips")
        if fat != len(sec["flips"]):
            _fail("flips", "trailing bytes")
        removed = _ids(_wire.leb128(sec["removed"], "removed", _fail), "removed", n_tris)
        added = _ids(_wire.leb128(sec["added"], "added", _fail), "added", n_tris)
        for name, lst in (("removed", removed), ("added", added)):
            if np.isin(lst, flips).any():
                _fail(name, "an id the flips cover")
        removed = np.sort(np.concatenate([fin[bits_in], removed]))
        added = np.sort(np.concatenate([fout[bits_out], added]))
        at = np.searchsorted(whole, removed)
        if len(removed) and (at.max() >= len(whole) or (whole[np.minimum(at, len(whole) - 1)] != removed).any()):
            _fail("removed", "an id that was not drawn whole")
        kept = np.delete(whole, at)
        at = np.searchsorted(kept, added)
        if len(added) and len(kept) and (kept[np.minimum(at, len(kept) - 1)] == added).any():
            _fail("added", "an id that is drawn whole already")
        whole = np.insert(kept, at, added)  # both sorted: so is the result
        if len(whole) != whole_count:
            _fail("added", "the whole set has the wrong size")

        # The polygons' sources (DELTA.md, "Polygons section"): flags for the removed ids and for
        # the previous polygon sources, then the others; then the counts.
        psec = sec["polygons"]
        candidates = flips[~np.isin(flips, whole) & ~np.isin(flips, removed) & ~np.isin(flips, partial)]
        order = []
        fat = 0
        for lst in (removed, partial, candidates):
            bits, fat = _flags(psec, fat, len(lst), "polygons")
            order.append(lst[bits])
        pv = _wire.leb128(psec[fat:], "polygons", _fail)
        if len(pv) == 0:
            _fail("polygons", "ends inside a number")
        nr = int(pv[0])
        if nr > n_tris:
            _fail("polygons", "more sources than the scene has")
        if len(pv) < 1 + nr:
            _fail("polygons", "ends early")
        order.append(_gaps(pv[1:1 + nr], "polygons", n_tris))
        order = np.concatenate(order).astype(np.int64)
        partial = np.sort(order)
        if len(partial) > 1 and (partial[1:] == partial[:-1]).any():
            _fail("polygons", "a source named twice")
        at = 1 + nr
        if len(pv) < at + len(order):
            _fail("polygons", "ends early")
        counts = pv[at:at + len(order)]
        at += len(order)
        if (counts >= np.uint64(1 << 20)).any():
            _fail("polygons", "too many")
        counts = counts.astype(np.int64) + 1
        npoly = int(counts.sum())
        if npoly > 1 << 28:
            _fail("polygons", "too many")
        if len(pv) != at + npoly:
            _fail("polygons", "ends early" if len(pv) < at + npoly else "trailing bytes")
        poly_source = np.repeat(order, counts)
        ncorner = pv[at:]
        if (ncorner > np.uint64((1 << 20) - 3)).any():
            _fail("polygons", "too many corners")
        ncorner = ncorner.astype(np.int64) + 3
        if npoly and (tri[poly_source, 0] == UNSENT).any():
            _fail(f"polygons {np.flatnonzero(tri[poly_source, 0] == UNSENT)[0]}", "unknown source")

        codes = _wire.leb128(sec["corner codes"], "corner codes", _fail)
        if len(codes) != int(ncorner.sum()):
            _fail("corner codes", "ends early" if len(codes) < int(ncorner.sum()) else "trailing bytes")
        refs = _wire.unzigzag(_wire.leb128(sec["vertex refs"], "vertex refs", _fail))
        pts = _wire.unzigzag(_wire.leb128(sec["points"], "points", _fail))
        steps = _wire.leb128(sec["edge steps"], "edge steps", _fail)

        # Whole triangles: their vertices take the first slots, in order of first use, projected.
        whole_tri = tri[whole].astype(np.int64)
        if len(whole) and (whole_tri[:, 0] == UNSENT).any():
            _fail(f"added {whole[np.flatnonzero(whole_tri[:, 0] == UNSENT)[0]]}", "a triangle not sent")
        flat = whole_tri.ravel()
        first_verts = _first_uses(flat, n_verts)  # the vertex of each slot
        slot_of = np.full(n_verts, -1, np.int64)
        slot_of[first_verts] = np.arange(len(first_verts))
        wslot = slot_of[flat].reshape(-1, 3)  # each whole triangle's corners' slots
        wx, wy, front = project_to_grid(rows, width, height, quantum, vertex[first_verts].astype(np.float64))
        if not front.all():
            bad = first_verts[np.flatnonzero(~front)[0]]
            _fail(f"whole {whole[np.flatnonzero((whole_tri == bad).any(axis=1))[0]]}", "a vertex behind the camera")

        # The polygons' vertices (own corners, edge ends, vertex refs) projected at once.
        corner_src = np.repeat(poly_source, ncorner)
        is_ref = codes == VERTEX_REF
        if int(is_ref.sum()) != len(refs):
            _fail("vertex refs", "ends early" if int(is_ref.sum()) > len(refs) else "trailing bytes")
        ref_gv = tri[corner_src[is_ref], 0].astype(np.int64) + refs
        if len(ref_gv) and (ref_gv.min() < 0 or ref_gv.max() >= n_verts):
            _fail("polygons", "vertex ref")
        if len(ref_gv) and np.isnan(vertex[ref_gv, 0]).any():
            _fail("polygons", "names a vertex not sent")
        need = np.unique(np.concatenate([tri[order].astype(np.int64).ravel(), ref_gv]))
        gx, gy, ok_ = project_to_grid(rows, width, height, quantum, vertex[need].astype(np.float64))

        # Polygons: the corner loop.
        need_l = need.tolist()
        px = dict(zip(need_l, gx.tolist()))
        py = dict(zip(need_l, gy.tolist()))
        ok = dict(zip(need_l, ok_.tolist()))
        pslot = slot_of[need]
        slot = {g: s for g, s in zip(need_l, pslot.tolist()) if s >= 0}
        nx = len(first_verts)  # the next slot
        out_x, out_y = [], []  # slots nx0, nx0 + 1, ...: polygon-only vertices and new points
        point_slot = []        # per new point of the frame: its slot
        edges = {}             # version 2: (min, max) source edge -> the first points made on it
        v2 = version >= 2
        point_ref = POINT_REF2 if v2 else POINT_REF
        point_x, point_y = [], []
        twin = {}
        fan_a, fan_b, fan_c, fan_src = [], [], [], []
        xmax, ymax = width * quantum, height * quantum
        codes_l, refs_l, pts_l, steps_l = codes.tolist(), refs.tolist(), pts.tolist(), steps.tolist()
        tri_l = tri[poly_source].tolist() if npoly else []
        ci = ri = pi = si = 0
        lx = ly = 0
        for i, (src, nc, tv) in enumerate(zip(poly_source.tolist(), ncorner.tolist(), tri_l)):
            ring, ring_id = [], []
            point_before = False
            bx = by = 0  # the previous corner's point, when point_before
            for _ in range(nc):
                code = codes_l[ci]
                ci += 1
                if code <= TWIN and code != NEW_POINT:
                    if code < VERTEX_REF:
                        g = tv[code]
                    elif code == VERTEX_REF:
                        g = tv[0] + refs_l[ri]
                        ri += 1
                    else:
                        g = twin.get(ring_id[-1]) if ring_id else None
                        if g is None:
                            _fail(f"polygons {i}", "a twin corner without an earlier edge")
                        if g >= n_verts:
                            k = g - n_verts
                            ring.append(point_slot[k])
                            ring_id.append(g)
                            point_before, bx, by = True, point_x[k], point_y[k]
                            continue
                    s = slot.get(g)
                    if s is None:
                        if not ok[g]:
                            _fail(f"polygons {i}", "a vertex behind the camera")
                        s = slot[g] = nx
                        nx += 1
                        out_x.append(px[g])
                        out_y.append(py[g])
                    ring.append(s)
                    ring_id.append(g)
                    point_before = False
                    continue
                if code < POINT_REF:  # a new point
                    if code == NEW_POINT:
                        if pi + 2 > len(pts_l):
                            _fail("points", "ends early")
                        if point_before:
                            lx, ly = bx, by
                        x = lx = lx + pts_l[pi]
                        y = ly = ly + pts_l[pi + 1]
                        pi += 2
                    else:  # a step along own edge k, as this side projects its ends
                        k = code - EDGE_POINT
                        a, b = tv[k], tv[(k + 1) % 3]
                        if not ok[a] or not ok[b]:
                            _fail(f"polygons {i}", "a vertex behind the camera")
                        dx, dy = px[b] - px[a], py[b] - py[a]
                        ns = max(abs(dx), abs(dy))
                        if si >= len(steps_l):
                            _fail("edge steps", "ends early")
                        st = steps_l[si]
                        si += 1
                        if ns < 2 or st < 1 or st >= ns:
                            _fail(f"edge steps {len(point_slot)}", "out of the edge")
                        x = px[a] + (2 * st * dx + ns) // (2 * ns)
                        y = py[a] + (2 * st * dy + ns) // (2 * ns)
                        if v2:
                            on = edges.setdefault((a, b) if a < b else (b, a), [])
                            if len(on) < EDGE_REFS:
                                on.append(len(point_slot))
                    if x < 0 or y < 0 or x > xmax or y > ymax:
                        _fail(f"points {len(point_slot)}", "outside the viewport")
                    g = n_verts + len(point_slot)
                    point_slot.append(nx)
                    point_x.append(x)
                    point_y.append(y)
                    out_x.append(x)
                    out_y.append(y)
                    ring.append(nx)
                    nx += 1
                else:
                    if code < point_ref:  # version 2: a point made on own edge k's source edge
                        k, e = (code - EDGE_REF) % 3, (code - EDGE_REF) // 3
                        a, b = tv[k], tv[(k + 1) % 3]
                        on = edges.get((a, b) if a < b else (b, a), ())
                        if e >= len(on):
                            _fail(f"polygons {i}", "no such point on the edge")
                        k = on[e]
                    else:  # the j-th most recent new point
                        j = code - point_ref
                        if j >= len(point_slot):
                            _fail(f"polygons {i}", "point ref out of range")
                        k = len(point_slot) - 1 - j
                    ring.append(point_slot[k])
                    g = n_verts + k
                    x, y = point_x[k], point_y[k]
                ring_id.append(g)
                point_before, bx, by = True, x, y
            m = len(ring_id)
            for k in range(m):
                twin.setdefault(ring_id[(k + 1) % m], ring_id[k])
            fan_a.extend([ring[0]] * (m - 2))
            fan_b.extend(ring[1:m - 1])
            fan_c.extend(ring[2:m])
            fan_src.extend([src] * (m - 2))
        if pi != len(pts_l):
            _fail("points", "trailing bytes")
        if si != len(steps_l):
            _fail("edge steps", "trailing bytes")

        # The triangles: whole ones in either orientation, the fans' positive ones.
        xs = np.concatenate([wx, np.array(out_x, np.int64)])
        ys = np.concatenate([wy, np.array(out_y, np.int64)])

        def orient(a, b, c):
            return (xs[b] - xs[a]) * (ys[c] - ys[a]) - (ys[b] - ys[a]) * (xs[c] - xs[a])

        a, b, c = wslot[:, 0], wslot[:, 1], wslot[:, 2]
        o = orient(a, b, c)
        b, c = np.where(o < 0, c, b), np.where(o < 0, b, c)
        keep = o != 0
        fa, fb, fc = (np.array(v, np.int64) for v in (fan_a, fan_b, fan_c))
        fkeep = orient(fa, fb, fc) > 0
        indices = np.stack([np.concatenate([a[keep], fa[fkeep]]), np.concatenate([b[keep], fb[fkeep]]),
                            np.concatenate([c[keep], fc[fkeep]])], axis=1).ravel().astype(np.uint32)
        source = np.concatenate([whole[keep], np.array(fan_src, np.int64)[fkeep]])
        mesh = (np.searchsorted(mesh_base, source.astype(np.uint64), side="right") - 1).astype(np.uint32)
        p = vertex[tri[source].astype(np.int64)].astype(np.float64)
        shade = shades(p, eye, target, ortho)
        xy = np.empty(2 * len(xs), np.int32)
        xy[0::2] = xs
        xy[1::2] = ys

        # Commit the state.
        self._base, self._colors = mesh_base, colors
        self._vertex, self._tri, self._whole, self._partial = vertex, tri, whole, partial
        self._last, self._have, self._view = index, True, view
        return DeltaFrame(width, height, quantum, index, key, COMPRESSION[codec],
                          "orthographic" if ortho else "perspective", eye, target, rows, xy, indices,
                          source.astype(np.uint32), mesh, shade.astype(np.uint8),
                          mesh_base.astype(np.uint32), colors.copy())
