"""Reader for the compact frame, version 1 (proto/COMPACT.md), as numpy arrays.

The reference is read_compact in core/stream/compact.cpp; this reader accepts exactly the frames it
accepts (one difference: after the zstd frame nothing may follow, where libzstd would also skip
empty or skippable frames), and raises ValueError naming the part for everything else.

Speed: the walk (COMPACT.md, Decoding 4) finds its connectivity (which rule predicts each vertex
from which vertices, which triangle predicts each triangle) with numpy, then carries the
positions in one Python loop over the vertices and the ids and shades by pointer jumping
(_walk). A bunny frame at 1920x1080 (31,620 triangles, 16,371 vertices, 122 KB) decodes in
~60-80 ms of CPU on the (shared, loaded) build machine; the literal loop (_walk_plain, which the
tests hold _walk to) takes ~200-230 ms. `tests/test_decoders.py --time` prints both."""
import struct
from dataclasses import dataclass
from typing import Optional

import numpy as np

from . import _meshopt, _wire

MAGIC = b"VMCF"
VERSION = 1
HEADER_BYTES = 44
SHADE = 1  # flags bit 0: a shade byte per triangle
MAX_TRIANGLES = 1 << 28
MAX_MESHES = 1 << 24
# A payload may be at most this many times its compressed size, plus 4096 (COMPACT.md, header).
MAX_RATIO = 256
COMPRESSION = {1: "zstd", 2: "deflate"}


class GridTriangles:
    """What compact and delta frames share once decoded: triangles on the grid (xy, indices,
    quantum) with their sources (source, mesh, mesh_base, mesh_color, shade)."""

    @property
    def triangle_count(self):
        return len(self.source)

    @property
    def vertex_count(self):
        return len(self.xy) // 2

    @property
    def face_id(self):
        """Per triangle: the source triangle's number within its mesh (FORMAT.md's face id)."""
        return self.source - self.mesh_base[self.mesh]

    def pixels(self):
        """Vertex positions in pixels, float64 (vertices, 2)."""
        return self.xy.reshape(-1, 2) / self.quantum

    def colors(self):
        """Fill colour per triangle, uint8 (triangles, 3) sRGB: the mesh colour times shade/255 as
        the SVG writer rounds it, or without shades the id colour of `--fill id` (id + 1)."""
        if self.shade is None:
            rgb = (self.source.astype(np.uint32) + 1) & 0xFFFFFF
            return np.stack([rgb >> 16, (rgb >> 8) & 255, rgb & 255], axis=1).astype(np.uint8)
        return srgb8(self.mesh_color[self.mesh].astype(np.float64) * (self.shade / 255.0)[:, None])


@dataclass(eq=False)
class CompactFrame(GridTriangles):
    """One decoded compact frame. Flat arrays, as proto/COMPACT.md and the C++ CompactFrame."""
    version: int
    width: int
    height: int
    flags: int
    quantum: int              # grid steps per pixel
    compression: str          # "zstd" or "deflate"
    xy: np.ndarray            # int32, 2 per vertex: grid steps (pixels * quantum), (0, 0) top-left, y down
    indices: np.ndarray       # uint32, 3 per triangle, clockwise on screen (positive shoelace, y down)
    source: np.ndarray        # uint32 per triangle: global source triangle id (FORMAT.md)
    mesh: np.ndarray          # uint32 per triangle: the mesh's index in the frame's mesh table
    mesh_base: np.ndarray     # uint32 per mesh: its first global triangle id
    mesh_color: np.ndarray    # float32 (meshes, 3): linear RGB in [0, 1]
    shade: Optional[np.ndarray] = None  # uint8 per triangle when flags & 1, else None


def srgb8(linear):
    """Linear [0, 1] to sRGB bytes, rounded half away from zero like the SVG writer's lround."""
    c = np.clip(linear, 0.0, 1.0)
    s = np.where(c <= 0.0031308, 12.92 * c, 1.055 * np.power(c, 1.0 / 2.4) - 0.055) * 255.0
    r = np.floor(s)
    return (r + (s - r >= 0.5)).astype(np.uint8)


def _fail(part, msg):
    raise ValueError(f"compact frame: {part}: {msg}")


def _inflate(codec, z, size):
    return _wire.inflate(codec, z, size, _fail)


def _varints(sec, part, count):
    """`count` LEB128 numbers filling `sec` exactly, unzigzagged, as int64."""
    z = _wire.leb128(sec, part, _fail)
    if len(z) != count:
        _fail(part, f"{len(z)} numbers, {count} expected")
    return _wire.unzigzag(z)


def read_compact(data) -> CompactFrame:
    """Decodes a compact frame (bytes-like); raises ValueError naming the part on malformed bytes."""
    return _read(data, plain=False)


def _read(data, plain):
    """plain: the walk as the literal loop of COMPACT.md (_walk_plain, the tests' oracle for _walk)."""
    data = bytes(data) if not isinstance(data, bytes) else data
    if len(data) < HEADER_BYTES:
        _fail("header", f"{len(data)} bytes, the header alone is {HEADER_BYTES}")
    if data[:4] != MAGIC:
        _fail("header", "magic is not VMCF")
    version, width, height, flags, quantum, nv, nt, nm, codec, size = struct.unpack_from("<10I", data, 4)
    if version != VERSION:
        _fail("header", f"version {version} (this reader knows {VERSION})")
    if codec not in COMPRESSION:
        _fail("header", f"unknown compression {codec}")
    if flags & ~SHADE:
        _fail("header", "unknown flag bits")
    if not (1 <= width <= 65536 and 1 <= height <= 65536):
        _fail("header", "viewport out of range")
    if not 1 <= quantum <= 256:
        _fail("header", "quantum out of 1 ... 256")
    if width * quantum >= 1 << 31 or height * quantum >= 1 << 31:
        _fail("header", "viewport times quantum over 2^31")
    if nt > MAX_TRIANGLES or nv > 3 * nt or (nt > 0 and nv < 3) or nm == 0 or nm > MAX_MESHES:
        _fail("header", "counts out of range")
    z = memoryview(data)[HEADER_BYTES:]
    if size > MAX_RATIO * len(z) + 4096:
        _fail("header", "payload size out of proportion")
    payload = _inflate(codec, z, size)

    # Mesh table, section sizes, sections: they fill the payload exactly.
    if len(payload) < 16 * nm:
        _fail("mesh table", "payload ends inside it")
    table = np.frombuffer(payload, np.dtype([("base", "<u4"), ("rgb", "<f4", 3)]), nm)
    mesh_base = table["base"].astype(np.uint32)
    mesh_color = table["rgb"].astype(np.float32)
    down = np.flatnonzero(mesh_base[1:] < mesh_base[:-1])
    if len(down):
        _fail(f"mesh {down[0] + 1}", "first ids not ascending")
    bad = np.flatnonzero(~((mesh_color >= 0) & (mesh_color <= 1)).all(axis=1))
    if len(bad):
        _fail(f"mesh {bad[0]}", "color not in [0,1]")
    at = 16 * nm
    if len(payload) < at + 16:
        _fail("section sizes", "payload ends inside it")
    sizes = struct.unpack_from("<4I", payload, at)
    at += 16
    sections = []
    for name, n in zip(("positions", "indices", "ids", "shades"), sizes):
        if n > len(payload) - at:
            _fail(name, "payload ends inside it")
        sections.append(payload[at:at + n])
        at += n
    if at != len(payload):
        _fail("payload", "trailing bytes")
    vsec, isec, idsec, ssec = sections
    shaded = bool(flags & SHADE)
    if len(ssec) != (nt if shaded else 0):
        _fail("shades", "one byte per triangle expected" if shaded else "present without the shade flag")

    # Every number takes a byte at least, the index codec 1 + T + 16: refused before allocating.
    for name, sec, need in (("positions", vsec, 2 * nv), ("ids", idsec, nt), ("indices", isec, 17 + nt)):
        if len(sec) < need:
            _fail(name, f"{len(sec)} bytes, too short for {nt} triangles and {nv} vertices")
    indices = _meshopt.decode_index_buffer(3 * nt, isec)
    if nt:
        over = np.flatnonzero(indices >= nv)
        if len(over):
            _fail(f"triangle {over[0] // 3}", "vertex index out of range")
    res = _varints(vsec, "positions", 2 * nv)
    rid = _varints(idsec, "ids", nt)
    walk = _walk_plain if plain else _walk
    xs, ys, src, shade = walk(indices, nv, nt, res, rid, ssec if shaded else None,
                              width * quantum, height * quantum, int(mesh_base[0]))

    xy = np.empty(2 * nv, np.int32)
    xy[0::2] = xs
    xy[1::2] = ys
    source = np.array(src, np.uint32)
    if nt:
        p = xy.astype(np.int64).reshape(-1, 2)[indices.reshape(-1, 3)]
        o = (p[:, 1, 0] - p[:, 0, 0]) * (p[:, 2, 1] - p[:, 0, 1]) - \
            (p[:, 1, 1] - p[:, 0, 1]) * (p[:, 2, 0] - p[:, 0, 0])
        flat = np.flatnonzero(o <= 0)
        if len(flat):
            _fail(f"triangle {flat[0]}", "not clockwise on screen")
    # The mesh holding an id: the last whose first id is at most it.
    mesh = (np.searchsorted(mesh_base, source, side="right") - 1).astype(np.uint32)
    return CompactFrame(version, width, height, flags, quantum, COMPRESSION[codec], xy, indices, source,
                        mesh, mesh_base, mesh_color, np.array(shade, np.uint8) if shaded else None)


def _walk_plain(indices, nv, nt, res, rid, sres, xmax, ymax, first_id):
    """COMPACT.md, Decoding 4, word for word: positions, source ids and shades from their
    residuals, in triangle order. `edges` maps a directed edge (a << 32 | b) to 3 * triangle + the
    corner at a. ~10x slower than _walk, which must give the same result (tests/test_decoders.py)."""
    idx, res, rid = indices.tolist(), res.tolist(), rid.tolist()
    X = [0] * nv
    Y = [0] * nv
    placed = bytearray(nv)
    edges = {}
    src = [0] * nt
    shade = [0] * nt if sres is not None else None
    last = -1
    r = 0
    for t in range(nt):
        c0, c1, c2 = idx[3 * t], idx[3 * t + 1], idx[3 * t + 2]
        for v, p, q in ((c0, c1, c2), (c1, c2, c0), (c2, c0, c1)):
            if placed[v]:
                continue
            if placed[p] and placed[q]:
                e = edges.get(q << 32 | p)
                o = idx[e - e % 3 + (e + 2) % 3] if e is not None else -1
                if o >= 0 and placed[o]:  # parallelogram across the edge (q, p)
                    px, py = X[p] + X[q] - X[o], Y[p] + Y[q] - Y[o]
                else:  # the edge's midpoint, rounded toward -inf
                    px, py = (X[p] + X[q]) >> 1, (Y[p] + Y[q]) >> 1
            elif placed[p]:
                px, py = X[p], Y[p]
            elif placed[q]:
                px, py = X[q], Y[q]
            elif last >= 0:
                px, py = X[last], Y[last]
            else:
                px = py = 0
            x, y = px + res[r], py + res[r + 1]
            r += 2
            if x < 0 or y < 0 or x > xmax or y > ymax:
                _fail(f"vertex {v}", "outside the viewport")
            X[v], Y[v] = x, y
            placed[v] = 1
            last = v
        e = edges.get(c1 << 32 | c0)
        if e is None:
            e = edges.get(c2 << 32 | c1)
            if e is None:
                e = edges.get(c0 << 32 | c2)
        pred = e // 3 if e is not None else t - 1
        ident = (src[pred] if pred >= 0 else 0) + rid[t]
        if ident < first_id or ident > 0xFFFFFFFF:
            _fail(f"triangle {t}", "source id out of range")
        src[t] = ident
        if shade is not None:
            shade[t] = ((shade[pred] if pred >= 0 else 0) + sres[t]) & 255
        edges.setdefault(c0 << 32 | c1, 3 * t)
        edges.setdefault(c1 << 32 | c2, 3 * t + 1)
        edges.setdefault(c2 << 32 | c0, 3 * t + 2)
    if r != 2 * nv:
        _fail("indices", "a vertex no triangle uses")
    return X, Y, src, shade


def _path_sums(parent, value):
    """Per node, the sums of `value` (nodes x columns) over the node and its ancestors (parent <
    node, -1: root). Pointer jumping: total[i] sums the path from i up to, not including, up[i];
    each round doubles that path. A sentinel node n (value 0, its own parent) ends every path."""
    n = len(parent)
    total = np.concatenate([value, np.zeros((1,) + value.shape[1:], value.dtype)])
    up = np.append(np.where(parent >= 0, parent, n), n)
    while up[0] != n or np.any(up != n):  # node 0 is always a root: the first test is cheap
        total += total[up]
        up = up[up]
    return total[:n]


# Prediction rules of _walk's vertex loop.
_PARALLELOGRAM, _MIDPOINT, _COPY, _ZERO = 0, 1, 2, 3


def _walk(indices, nv, nt, res, rid, sres, xmax, ymax, first_id):
    """The walk of _walk_plain in two steps. Which rule predicts a vertex, from which vertices, and
    which triangle predicts a triangle depend on the connectivity alone, so numpy finds them for
    all at once: corner i = 3t + k is where its vertex is placed when i is the vertex's first
    corner; a vertex is placed at corner i when its first corner is before i; the edge map holds
    (a, b) at triangle t when the first triangle with the directed edge (a, b) is before t, and
    then holds that triangle's entry (an entry is never replaced). Then two plain loops carry the
    values: positions in placement order, ids and shades in triangle order (each prediction reads
    values placed before it)."""
    if nt == 0:
        return [], [], [], [] if sres is not None else None
    I = indices.astype(np.int64)
    tri = I.reshape(-1, 3)
    nxt = tri[:, [1, 2, 0]].ravel()  # corner i's c_(k+1)
    prv = tri[:, [2, 0, 1]].ravel()  # corner i's c_(k+2)
    used, first = np.unique(I, return_index=True)
    if len(used) != nv:  # indices are < nv: used == arange(nv) exactly when every vertex is used
        _fail("indices", "a vertex no triangle uses")
    # The edge map: directed edge (c_k, c_(k+1)) of corner j = 3t + k; its entry is the first j.
    # Every lookup asks for the twin (b, a) of one of the triangle's own edges (a, b): twin[j] is
    # the twin's entry, -1 if no corner has it; the map holds it at triangle t if twin[j] < 3t.
    fwd = I << 32 | nxt
    order = np.argsort(fwd, kind="stable")  # equal keys keep corner order: the first is the entry
    s = np.minimum(np.searchsorted(fwd[order], nxt << 32 | I), len(I) - 1)
    twin = np.where(fwd[order[s]] == (nxt << 32 | I), order[s], -1)
    held = (twin >= 0) & (twin // 3 < np.arange(len(I)) // 3)

    corner = np.sort(first)  # the corners where vertices are placed, in placement order
    v, p, q = I[corner], nxt[corner], prv[corner]
    has_p, has_q = first[p] < corner, first[q] < corner
    j = corner - corner % 3 + (corner + 1) % 3  # the corner of the edge (p, q): its twin is (q, p)
    e = twin[j]
    o = I[e - e % 3 + (e + 2) % 3]  # e's third corner (garbage where e = -1, then unused)
    both = has_p & has_q
    para = both & held[j] & (first[o] < corner)
    last = np.concatenate([[0], v[:-1]])
    mode = np.where(para, _PARALLELOGRAM, np.where(both, _MIDPOINT, _COPY))
    a = np.where(has_p, p, np.where(has_q, q, last))
    mode[0] = _ZERO if not (has_p[0] or has_q[0]) else mode[0]  # before the first vertex: (0, 0)

    X = [0] * nv
    Y = [0] * nv
    for v_, m, a_, b_, o_, rx, ry in zip(v.tolist(), mode.tolist(), a.tolist(), q.tolist(), o.tolist(),
                                         res[0::2].tolist(), res[1::2].tolist()):
        if m == _PARALLELOGRAM:
            x, y = X[a_] + X[b_] - X[o_] + rx, Y[a_] + Y[b_] - Y[o_] + ry
        elif m == _MIDPOINT:
            x, y = ((X[a_] + X[b_]) >> 1) + rx, ((Y[a_] + Y[b_]) >> 1) + ry
        elif m == _COPY:
            x, y = X[a_] + rx, Y[a_] + ry
        else:
            x, y = rx, ry
        if x < 0 or y < 0 or x > xmax or y > ymax:
            _fail(f"vertex {v_}", "outside the viewport")
        X[v_], Y[v_] = x, y

    # Each triangle's predictor: the first held of the twins of (c0, c1), (c1, c2), (c2, c0),
    # that is of (c1, c0), (c2, c1), (c0, c2); else t - 1.
    h = held.reshape(-1, 3)
    tw = twin.reshape(-1, 3) // 3
    pred = np.where(h[:, 0], tw[:, 0], np.where(h[:, 1], tw[:, 1], np.where(h[:, 2], tw[:, 2],
                                                                                 np.arange(nt) - 1)))
    # A triangle's id is the sum of the residuals on its path of predictors to triangle 0, its
    # shade that sum mod 256: prefix sums on the predictor tree by pointer jumping (log2 of the
    # depth rounds of numpy). A frame whose ids all lie in [0, 2^32) has every residual in
    # (-2^32, 2^32), so the sums fit int64 once larger residuals are refused.
    big = np.flatnonzero((rid >= 1 << 32) | (rid <= -(1 << 32)))
    if len(big):
        _fail(f"triangle {big[0]}", "source id out of range")
    sums = _path_sums(pred, np.stack([rid, np.frombuffer(sres, np.uint8) if sres is not None else rid], 1))
    src = sums[:, 0]
    bad = np.flatnonzero((src < first_id) | (src > 0xFFFFFFFF))
    if len(bad):
        _fail(f"triangle {bad[0]}", "source id out of range")
    shade = None if sres is None else sums[:, 1] & 255
    return X, Y, src, shade
