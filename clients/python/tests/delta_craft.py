#!/usr/bin/env python3
"""Hand-made delta frames (proto/DELTA.md) for what real streams seldom reach: projections that
round at exact halves on both sides of zero (llround, not round-half-even), edge points on edges
of every direction (the exact div), back faces and triangles with no area on the grid, a vertex
behind the camera that no triangle uses, orthographic shade, a source with no area in the world
(shade of a non-finite factor), meshes without triangles, ids leaving and entering the whole set,
polygons of removed and of previous sources, twins and point references, deflate, and frames
with nothing to draw.

`sequences()` gives {name: [frame bytes, ...]}: each sequence decodes in order. The decoders'
tests compare them with `vismap decode FRAMES... --json` (core/stream/delta.cpp):
clients/python/tests/test_delta.py here, clients/js/test_delta.mjs through
`python3 delta_craft.py OUTDIR` (main: the frames and a manifest)."""
import os
import struct
import sys
import zlib

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))


def varint(v):
    out = bytearray()
    while v >= 0x80:
        out.append((v & 0x7F) | 0x80)
        v >>= 7
    out.append(v)
    return bytes(out)


def zz(s):
    return 2 * s if s >= 0 else -2 * s - 1


def gaps(ids):
    out = varint(len(ids))
    last = 0
    for i in ids:
        out += varint(i - last)
        last = i
    return out


def bits(flags):
    out = bytearray((len(flags) + 7) // 8)
    for i, f in enumerate(flags):
        if f:
            out[i // 8] |= 1 << (i % 8)
    return bytes(out)


class Stream:
    """The encoder's side of a delta stream, written by hand: what the client holds (sources, whole
    set, previous polygon sources), so that each frame names only what DELTA.md lets it."""

    def __init__(self, width, height, quantum, meshes):
        """meshes: [(triangle count, vertex count, (r, g, b))]."""
        self.width, self.height, self.quantum = width, height, quantum
        self.meshes = meshes
        self.n_verts = sum(m[1] for m in meshes)
        self.index = 0
        self.base = None
        self.whole = []
        self.partial = []
        self.vertex = {}
        self.tri = {}

    def project(self, rows, gv):
        import numpy as np
        from vismap_client.delta import project_to_grid
        p = np.array([self.vertex[gv]], np.float32).astype(np.float64)
        x, y, ok = project_to_grid(rows, self.width, self.height, self.quantum, p)
        assert ok[0], gv
        return int(x[0]), int(y[0])

    def frame(self, rows, vertices=(), triangles=(), whole=(), polygons=(), key=False, ortho=False,
              eye=(0.0, 0.0, 5.0), target=(0.0, 0.0, 0.0), compression=1):
        """vertices: {gv: (x, y, z)}; triangles: {id: (a, b, c)}; whole: the whole set after this
        frame; polygons: [(source, [corner, ...])] with corners ("own", k), ("ref", gv),
        ("pt", x, y), ("twin",), ("edge", k, step), ("pref", j)."""
        if key:
            self.whole, self.partial, self.vertex, self.tri = [], [], {}, {}
        self.vertex.update(dict(vertices))
        self.tri.update(dict(triangles))
        whole = sorted(whole)
        removed = sorted(set(self.whole) - set(whole))
        added = sorted(set(whole) - set(self.whole))
        sources = {s for s, _ in polygons}
        flagged_r = [s for s in removed if s in sources]
        flagged_p = [s for s in self.partial if s in sources and s not in flagged_r]
        rest = sorted(sources - set(flagged_r) - set(flagged_p))
        order = flagged_r + flagged_p + rest
        by_src = {s: [c for t, c in polygons if t == s] for s in order}

        sec = {k: bytearray() for k in ("poly", "codes", "refs", "pts", "steps")}
        sec["poly"] += bits([s in sources for s in removed]) + bits([s in sources for s in self.partial])
        sec["poly"] += gaps(rest)
        for s in order:
            sec["poly"] += varint(len(by_src[s]) - 1)
        points = []  # coordinates of this frame's new points
        twin = {}
        last4 = (0, 0)
        for s in order:
            own = self.tri[s]
            for ring in by_src[s]:
                sec["poly"] += varint(len(ring) - 3)
                ids, prev_pt = [], None
                for c in ring:
                    kind = c[0]
                    if kind == "own":
                        sec["codes"] += varint(c[1])
                        ids.append(own[c[1]])
                        prev_pt = None
                    elif kind == "ref":
                        sec["codes"] += varint(3)
                        sec["refs"] += varint(zz(c[1] - own[0]))
                        ids.append(c[1])
                        prev_pt = None
                    elif kind == "twin":
                        sec["codes"] += varint(5)
                        t = twin[ids[-1]]
                        ids.append(t)
                        prev_pt = points[t - self.n_verts] if t >= self.n_verts else None
                    elif kind == "pref":
                        sec["codes"] += varint(9 + c[1])
                        k = len(points) - 1 - c[1]
                        ids.append(self.n_verts + k)
                        prev_pt = points[k]
                    else:
                        if kind == "pt":
                            base = prev_pt if prev_pt is not None else last4
                            sec["codes"] += varint(4)
                            sec["pts"] += varint(zz(c[1] - base[0])) + varint(zz(c[2] - base[1]))
                            p = last4 = (c[1], c[2])
                        else:  # ("edge", k, step)
                            k, st = c[1], c[2]
                            ax, ay = self.project(rows, own[k])
                            bx, by = self.project(rows, own[(k + 1) % 3])
                            dx, dy = bx - ax, by - ay
                            n = max(abs(dx), abs(dy))
                            assert 1 <= st < n
                            sec["codes"] += varint(6 + k)
                            sec["steps"] += varint(st)
                            p = (ax + (2 * st * dx + n) // (2 * n), ay + (2 * st * dy + n) // (2 * n))
                        points.append(p)
                        ids.append(self.n_verts + len(points) - 1)
                        prev_pt = p
                for k in range(len(ids)):
                    twin.setdefault(ids[(k + 1) % len(ids)], ids[k])

        nv = sorted(dict(vertices))
        s_vert = varint(len(nv))
        last = 0
        for g in nv:
            s_vert += varint(g - last)
            last = g
        s_pos = b"".join(struct.pack("<3f", *self.vertex[g]) for g in nv)
        s_tri = varint(len(triangles))
        last_id, last_v = 0, 0
        for i in sorted(dict(triangles)):
            s_tri += varint(i - last_id)
            last_id = i
            for v in self.tri[i]:
                s_tri += varint(zz(v - last_v))
                last_v = v
        sections = [s_vert, s_pos, s_tri, gaps(removed), gaps(added), bytes(sec["poly"]), bytes(sec["codes"]),
                    bytes(sec["refs"]), bytes(sec["pts"]), bytes(sec["steps"])]
        payload = struct.pack("<B3x6d12d", int(ortho), *eye, *target, *rows)
        if key:
            first = 0
            for tris, verts, rgb in self.meshes:
                payload += struct.pack("<3I3f", first, tris, verts, *rgb)
                first += tris
        payload += struct.pack("<10I", *map(len, sections)) + b"".join(sections)
        if compression == 1:
            import zstandard
            z = zstandard.ZstdCompressor(level=3).compress(payload)
        else:
            c = zlib.compressobj(6, zlib.DEFLATED, -15)
            z = c.compress(payload) + c.flush()
        if key:
            self.index = 0 if self.base is None else self.index + 1
        else:
            self.index += 1
        header = b"VMDF" + struct.pack("<11I", 1, self.width, self.height, int(key), self.quantum, self.index,
                                       0xFFFFFFFF if key else self.base, len(self.meshes), compression,
                                       len(payload), len(whole))
        self.base = self.index
        self.whole = whole
        self.partial = sorted(sources)
        return header + z


def screen_rows(width, height, quantum, scale=1.0):
    """Rows with cw = 1 and grid x = (sx * x + 1) * width * Q / 2: world (x, y) -> grid."""
    return (scale, 0.0, 0.0, 0.0, 0.0, scale, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0)


def sequences():
    out = {}

    # Exact halves: W = 4, Q = 1: grid x = 2 (x + 1), grid y = 2 (1 - y). Vertex x = -2.25 lands
    # on -2.5 (llround -3, round-half-even -2), x = -1.75 on -1.5 (-2), 0.25 on 2.5 (3, not 2).
    s = Stream(4, 4, 1, [(4, 8, (0.8, 0.5, 0.25))])
    rows = screen_rows(4, 4, 1)
    v = {0: (-2.25, 0.25, 0.0), 1: (0.25, 0.25, 0.0), 2: (-1.75, -1.25, 0.0), 3: (0.25, -1.25, 0.5),
         4: (-0.75, 0.75, 0.0), 5: (-0.25, 0.75, 0.0), 6: (1.75, -0.25, 0.0), 7: (0.0, 0.0, -9.0)}
    t = {0: (0, 1, 2), 1: (1, 3, 2), 2: (4, 5, 4), 3: (1, 6, 3)}
    f0 = s.frame(rows, v, t, whole=[0, 1, 2, 3], key=True)
    # The same with the light straight on (eye - target along +z, orthographic) and one whole
    # triangle removed and drawn as a polygon of its removed source instead.
    f1 = s.frame(rows, {}, {}, whole=[0, 2, 3],
                 polygons=[(1, [("own", 0), ("own", 1), ("pt", 1, 0), ("own", 2)])], ortho=True,
                 eye=(0.0, 0.0, 3.0), target=(0.0, 0.0, -1.0))
    out["halves"] = [f0, f1]

    # Edge points on edges in all eight directions, and at the exact halves of div.
    W, H, Q = 64, 48, 16
    s = Stream(W, H, Q, [(0, 0, (1.0, 1.0, 1.0)), (8, 12, (0.2, 0.4, 0.6)), (0, 0, (0.0, 0.0, 0.0)),
                         (3, 4, (1.0, 0.0, 0.0))])
    rows = (0.9, 0.05, 0.01, 0.02, -0.03, 0.8, 0.02, -0.01, 0.0, 0.0, -0.1, 1.0)
    ring = [(0.0, 0.0), (0.35, 0.1), (0.5, 0.45), (0.2, 0.7), (-0.3, 0.55), (-0.6, 0.2), (-0.5, -0.4),
            (0.1, -0.6), (0.55, -0.45)]
    v = {0: (0.0, 0.0, 0.3)}
    for i, (x, y) in enumerate(ring[1:], 1):
        v[i] = (x, y, 0.1 * i - 0.4)
    v[9], v[10], v[11] = (0.7, 0.7, 0.0), (0.75, 0.7, 0.0), (0.7, 0.75, 0.0)
    v.update({12: (-0.8, -0.8, 0.0), 13: (-0.7, -0.8, 0.0), 14: (-0.8, -0.7, 0.0), 15: (-0.75, -0.75, 0.0)})
    # (six of the eight fans positive on screen, two negative: their polygons draw nothing)
    t = {i: (0, (i + 1) % 8 + 1, i + 1) if i % 4 else (0, i + 1, (i + 1) % 8 + 1) for i in range(8)}
    t.update({8: (12, 13, 14), 9: (12, 14, 13), 10: (13, 15, 14)})  # mesh 3: a face and its back
    f0 = s.frame(rows, v, t, whole=[8, 9], key=True)
    polys = []
    for i in range(8):  # each fan triangle as a polygon with points on its two outer edges
        polys.append((i, [("own", 0), ("edge", 0, 1), ("own", 1), ("edge", 1, 2), ("edge", 1, 5), ("own", 2),
                          ("edge", 2, 3)]))
    f1 = s.frame(rows, {}, {}, whole=[8, 9, 10], polygons=polys)
    # Twins and point references: a quad split across two polygons of one source, the second
    # walking back the first's edges.
    polys = [(0, [("own", 0), ("pt", 500, 400), ("pt", 520, 380), ("own", 1)]),
             (0, [("own", 0), ("own", 2), ("pref", 0), ("twin",)]),
             (3, [("own", 0), ("ref", 5), ("ref", 6), ("pref", 1)])]
    f2 = s.frame(rows, {}, {}, whole=[9, 10], polygons=polys, compression=2)
    out["edges"] = [f0, f1, f2]

    # A source with no area in the world (its polygon's shade factor is not finite: 255), a
    # triangle whose projection has no area (its vertices on one ray), and a vertex behind the
    # camera that nothing uses.
    s = Stream(32, 32, 4, [(4, 9, (0.5, 0.5, 0.5))])
    rows = (1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0)  # cw = z
    v = {0: (0.0, 0.0, 1.0), 1: (0.5, 0.0, 1.0), 2: (1.0, 0.0, 1.0), 3: (0.0, 0.5, 2.0), 4: (0.5, 0.5, 2.0),
         5: (0.25, -0.3, 1.5), 6: (0.0, 0.0, -1.0), 7: (0.5, 0.0, 2.0), 8: (0.25, 0.0, 0.5)}
    t = {0: (0, 1, 2), 1: (3, 4, 5), 2: (0, 3, 4), 3: (0, 7, 8)}
    f0 = s.frame(rows, v, t, whole=[1, 2, 3], polygons=[(0, [("pt", 20, 20), ("pt", 30, 40), ("pt", 10, 40)])],
                 key=True, eye=(0.0, 0.0, 0.0))
    out["degenerate"] = [f0]

    # Nothing visible, then one triangle, then nothing again.
    s = Stream(8, 8, 2, [(2, 4, (0.5, 0.5, 0.5))])
    out["empty"] = [s.frame(rows, key=True),
                    s.frame(rows, {0: (0.0, 0.0, 1.0), 1: (0.5, 0.0, 1.0), 2: (0.0, 0.5, 1.0)}, {0: (0, 1, 2)}, whole=[0]),
                    s.frame(rows, whole=[])]
    return out


def refused():
    """{name: (frames that decode, then one every decoder refuses)}."""
    out = {}
    s = Stream(32, 32, 4, [(2, 4, (0.5, 0.5, 0.5))])
    rows = (1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0)  # cw = z
    v = {0: (0.0, 0.0, 1.0), 1: (0.5, 0.0, 1.0), 2: (0.0, 0.5, 1.0), 3: (0.2, 0.2, -1.0)}
    f0 = s.frame(rows, v, {0: (0, 1, 2), 1: (0, 1, 3)}, whole=[0], key=True)
    out["whole triangle behind the camera"] = ([f0], s.frame(rows, whole=[0, 1]))
    s.whole, s.index, s.base = [0], 0, 0
    out["polygon corner behind the camera"] = ([f0], s.frame(rows, whole=[0], polygons=[
        (1, [("own", 0), ("own", 1), ("own", 2)])]))
    return out


def main():
    """Writes every frame to OUTDIR and OUTDIR/manifest.json: {"sequences": {name: [file, ...]},
    "refused": {name: [file, ..., the refused one]}}."""
    import json
    out = sys.argv[1]
    os.makedirs(out, exist_ok=True)
    manifest = {"sequences": {}, "refused": {}}
    cases = [("sequences", n, f) for n, f in sequences().items()]
    cases += [("refused", n, good + [bad]) for n, (good, bad) in refused().items()]
    for i, (kind, name, frames) in enumerate(cases):
        files = []
        for k, f in enumerate(frames):
            files.append(f"{kind}_{i}_{k}.vmd")
            with open(os.path.join(out, files[-1]), "wb") as fh:
                fh.write(f)
        manifest[kind][name] = files
    with open(os.path.join(out, "manifest.json"), "w") as fh:
        json.dump(manifest, fh, indent=1)


if __name__ == "__main__":
    main()
