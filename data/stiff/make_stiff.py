#!/usr/bin/env python3
"""Writes the stiff-case corpus (DESIGN §5): one small scene per degeneracy class, NAME.obj (one
object per mesh) + NAME.json (the scene file with its camera). Deterministic; rerun after editing:
    python3 data/stiff/make_stiff.py
Most cases use an orthographic 256x256 camera with 1 world unit = 1 pixel, looking down -z from
z=100 at (128,128): world (x, y) lands on pixel (x, 256 - y), so integer world coordinates are
grid points and "on a tile border" / "collinear" hold exactly after snapping."""
import json, math, os, random

NCROWD = 60
HERE = os.path.dirname(os.path.abspath(__file__))
ORTHO = {"type": "orthographic", "eye": [128, 128, 100], "target": [128, 128, 0], "up": [0, 1, 0],
         "ortho_height": 256, "near": 1, "far": 200, "width": 256, "height": 256}


def quad(x0, y0, x1, y1, z):
    return [[(x0, y0, z), (x1, y0, z), (x1, y1, z)], [(x0, y0, z), (x1, y1, z), (x0, y1, z)]]


def write(name, meshes, camera, comment, shared=True):
    """meshes: list of (mesh name, list of triangles (3 xyz tuples)). shared: merge equal vertices
    within a mesh (else every triangle gets its own three vertices: soup)."""
    lines = ["# vismap stiff case %s: %s" % (name, comment)]
    base = 1
    for mname, tris in meshes:
        lines.append("o " + mname)
        verts, index, faces = [], {}, []
        for t in tris:
            f = []
            for p in t:
                key = tuple(p)
                if not shared or key not in index:
                    index[key] = len(verts)
                    verts.append(key)
                f.append(index[key] if shared else len(verts) - 1)
            faces.append(f)
        for v in verts:
            lines.append("v %.17g %.17g %.17g" % v)
        for f in faces:
            lines.append("f %d %d %d" % tuple(base + i for i in f))
        base += len(verts)
    with open(os.path.join(HERE, name + ".obj"), "w") as fh:
        fh.write("\n".join(lines) + "\n")
    scene = {"comment": comment, "meshes": [{"file": name + ".obj"}], "camera": camera}
    with open(os.path.join(HERE, name + ".json"), "w") as fh:
        json.dump(scene, fh, indent=1)
        fh.write("\n")


def main():
    rnd = random.Random(20240611)
    bg = ("background", quad(8, 8, 248, 248, 0))

    # Slivers: needles thinner than a grid unit (1/256 px) and a few grid units, over a quad.
    s = []
    for k in range(12):
        x = 20 + 17 * k
        w = [1e-4, 2e-3, 1.0 / 256, 0.01, 0.1][k % 5]
        s.append([(x, 20, 10), (x + w, 20, 10), (x + 3, 230, 10)])
        s.append([(20, x, 12), (235, x + w * 3, 12), (235, x + w * 3 + w, 12)])
    write("sliver_needles", [bg, ("slivers", s)], ORTHO,
          "needle triangles thinner than a grid unit crossing each other over a quad")

    # Vertices exactly on tile borders (multiples of 8..128 px) and a fan around a tile corner.
    t = []
    for (cx, cy) in [(64, 64), (128, 128), (192, 64), (64, 192)]:
        ring = [(cx + 32 * math.cos(a * math.pi / 4), cy + 32 * math.sin(a * math.pi / 4)) for a in range(8)]
        ring = [(round(x / 16) * 16, round(y / 16) * 16) for x, y in ring]
        for i in range(8):
            a, b = ring[i], ring[(i + 1) % 8]
            if a != b:
                t.append([(cx, cy, 5 + i), (a[0], a[1], 5), (b[0], b[1], 5)])
    write("tile_border_vertices", [bg, ("fans", t)], ORTHO,
          "fans whose centres and rims lie on 16/32/64/128-pixel tile borders and corners")

    # Collinear silhouette and triangle edges: front quads share supporting lines with the
    # background's triangle edges (diagonal included) and with each other.
    c = [quad(40, 40, 128, 128, 10)[0], quad(128, 40, 216, 128, 10)[1],
         [(40, 128, 20), (128, 216, 20), (40, 216, 20)],  # on the diagonal's line y = x + 88
         [(128, 128, 30), (248, 248, 30), (128, 248, 30)]]  # along the background diagonal
    write("collinear_edges", [bg, ("front", c)], ORTHO,
          "front triangles whose edges lie on the background's edges and diagonal")

    # T-junctions: a big triangle whose long edge carries the vertices of a strip of small ones.
    tj = [[(20, 20, 10), (236, 20, 10), (128, 120, 10)]]
    for k in range(8):
        x0, x1 = 20 + 27 * k, 20 + 27 * (k + 1)
        tj.append([(x0, 20, 10), (x1, 10, 10), (x1, 20, 10)])
        tj.append([(x0, 20, 10), (x0, 10, 10), (x1, 10, 10)])
    tj.append([(128, 120, 10), (60, 200, 15), (200, 200, 15)])
    write("t_junctions", [bg, ("tjunction", tj)], ORTHO,
          "one triangle edge carrying eight vertices of neighbouring triangles (T-junctions)")

    # Non-manifold edges: four fins on one edge, seen from above at an angle (perspective).
    fins = []
    for k in range(4):
        a = math.radians(20 + 45 * k)
        fins.append([(0, 0, 0), (0, 1, 0), (0.8 * math.cos(a), 0.5, 0.8 * math.sin(a))])
    floor_ = [[(-1, -0.2, -1), (1, -0.2, 1), (1, -0.2, -1)], [(-1, -0.2, -1), (-1, -0.2, 1), (1, -0.2, 1)]]
    cam = {"type": "perspective", "eye": [1.5, 2.0, 2.5], "target": [0, 0.4, 0], "up": [0, 1, 0],
           "fov_y_deg": 40, "width": 320, "height": 320}
    write("non_manifold_edge", [("floor", floor_), ("fins", fins)], cam,
          "four triangles sharing one edge (non-manifold), over a floor")

    # Soup with duplicated vertices: a closed cube whose triangles do not share vertices, plus a
    # duplicate face.
    cube = []
    P = [(x, y, z) for x in (0, 1) for y in (0, 1) for z in (0, 1)]
    for f in [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]:
        a, b, c2, d = (P[i] for i in f)
        cube += [[a, b, c2], [a, c2, d]]
    cube.append(cube[3])
    camc = {"type": "perspective", "eye": [2.2, 1.7, 2.9], "target": [0.5, 0.5, 0.5], "up": [0, 1, 0],
            "fov_y_deg": 35, "width": 256, "height": 256}
    write("soup_duplicated_vertices", [("cube", cube)], camc,
          "a cube as triangle soup (no shared vertices) with one duplicated face", shared=False)

    # Coplanar overlaps: three meshes in the same plane overlapping, plus overlap within a mesh.
    cp = [("a", quad(30, 30, 160, 160, 10)), ("b", quad(90, 90, 220, 220, 10)),
          ("c", [[(40, 200, 10), (200, 40, 10), (220, 220, 10)], [(60, 60, 10), (230, 80, 10), (80, 230, 10)]])]
    write("coplanar_overlap", [bg] + cp, ORTHO,
          "overlapping triangles in one plane, across meshes and within one (tie rule)")

    # Nearly touching: planes 1e-3 apart (relative depth gap ~1e-5, above VM_TIE_EPS), and a
    # tilted plane that touches another along a line.
    nt = [("low", quad(30, 30, 200, 200, 10.0)), ("high", quad(60, 60, 230, 230, 10.001)),
          ("tilted", [[(20, 120, 10.0), (236, 120, 10.0), (128, 250, 10.5)]])]
    write("nearly_touching", [bg] + nt, ORTHO,
          "parallel planes 1e-3 apart and a tilted plane touching one along a line")

    # Near plane crossing and behind the camera.
    nb = [[(-3, -1, -5), (3, -1, -5), (0, -1, 4)],       # crosses the near plane, runs behind
          [(-1, -0.5, 2), (1, -0.5, 2), (0, 1, 3)],      # entirely behind the camera
          [(-2, 1.5, -0.05), (2, 1.5, -0.05), (0, -2, -8)],  # vertices just beyond near
          [(-4, -2, -10), (4, -2, -10), (4, 3, -10)], [(-4, -2, -10), (4, 3, -10), (-4, 3, -10)]]
    camn = {"type": "perspective", "eye": [0, 0, 0], "target": [0, 0, -1], "up": [0, 1, 0],
            "fov_y_deg": 60, "near": 0.1, "far": 50, "width": 256, "height": 256}
    write("near_plane_behind_camera", [("tris", nb)], camn,
          "triangles crossing the near plane, behind the camera, and a wall behind them")

    # Grazing views: a quad exactly edge-on, others within 1e-3 degrees of it, and a backdrop.
    gz = []
    for k, ang in enumerate([0.0, 1e-5, 1e-3, 0.5]):
        a = math.radians(ang)
        y = 0.3 * (k - 1.5)
        gz.append([(-1, y, -1), (1, y + 2 * math.sin(a), 1), (1, y, -1)])
    back = [[(-2, -2, -3), (2, -2, -3), (2, 2, -3)], [(-2, -2, -3), (2, 2, -3), (-2, 2, -3)]]
    camg = {"type": "perspective", "eye": [0, 0.0, 4], "target": [0, 0, 0], "up": [0, 1, 0],
            "fov_y_deg": 40, "width": 256, "height": 256}
    write("grazing_view", [("backdrop", back), ("grazing", gz)], camg,
          "triangles seen exactly edge-on and within 1e-5..0.5 degrees of it")

    # Far from the origin (1e6) and tiny (1e-6): the same little overlapping pair.
    def pair(o, s):
        return [("a", [[(o + 0, o + 0, o + 0), (o + 4 * s, o + 1 * s, o + 0), (o + 1 * s, o + 4 * s, o + 0)]]),
                ("b", [[(o + 1 * s, o + 1 * s, o + 1 * s), (o + 5 * s, o + 2 * s, o - 1 * s), (o + 2 * s, o + 5 * s, o + 0.5 * s)]])]
    o, s = 1.0e6, 16.0  # floats at 1e6 have a 1/16 step: keep coordinates representable
    camf = {"type": "perspective", "eye": [o + 2.5 * s, o + 2.5 * s, o + 20 * s], "target": [o + 2.5 * s, o + 2.5 * s, o],
            "up": [0, 1, 0], "fov_y_deg": 30, "width": 256, "height": 256}
    write("far_coordinates_1e6", pair(o, s), camf, "an interpenetrating pair around (1e6, 1e6, 1e6)")
    o, s = 0.0, 1e-6
    camt = {"type": "perspective", "eye": [2.5 * s, 2.5 * s, 20 * s], "target": [2.5 * s, 2.5 * s, 0],
            "up": [0, 1, 0], "fov_y_deg": 30, "width": 256, "height": 256}
    write("tiny_scene_1e-6", pair(o, s), camt, "an interpenetrating pair 5e-6 across")

    # One tile holding most of the scene: NCROWD small overlapping triangles inside a 6-pixel square
    # in the middle of a large backdrop (the teapot in a stadium).
    crowd = []
    for k in range(NCROWD):
        cx, cy = 125 + 6 * rnd.random(), 125 + 6 * rnd.random()
        pts = [(cx + 1.5 * rnd.uniform(-1, 1), cy + 1.5 * rnd.uniform(-1, 1), 10 + 5 * rnd.random()) for _ in range(3)]
        crowd.append(pts)
    write("one_tile_crowded", [bg, ("crowd", crowd)], ORTHO,
          "%d overlapping triangles inside a 6x6-pixel square over a large backdrop" % NCROWD)

    # Penetrating triangles: a pair crossing in an X, a triangle through a fan, cyclic overlap.
    pen = [("a", [[(30, 40, 0), (220, 60, 40), (120, 220, 20)]]),
           ("b", [[(40, 200, 40), (200, 30, 0), (230, 200, 20)]]),
           ("c", [[(60, 60, 30), (200, 110, 5), (90, 180, 15)]])]
    write("penetrating_triangles", [bg] + pen, ORTHO, "three mutually penetrating triangles")
    cyc = []
    for k in range(3):
        a = 2 * math.pi * k / 3
        dx, dy = math.cos(a), math.sin(a)
        px, py = -dy, dx
        p0 = (128 + 100 * dx - 20 * px, 128 + 100 * dy - 20 * py, 10)
        p1 = (128 + 100 * dx + 20 * px, 128 + 100 * dy + 20 * py, 10)
        p2 = (128 - 60 * dx, 128 - 60 * dy, 30)
        cyc.append(("blade%d" % k, [[p0, p1, p2]]))
    write("cyclic_overlap", [bg] + cyc, ORTHO, "three blades overlapping cyclically (no depth order)")

    # Triple points: large triangles over the middle of the view on random planes near z = 20,
    # so that they all penetrate one another and most triples meet at a point inside all three;
    # there the three independently snapped crossing lines bound a snap-sized cell, which the
    # three can order cyclically (docs/NUMERICS.md §2).
    rt = random.Random(31337)
    trip = []
    for k in range(9):
        z0, gx, gy = rt.uniform(16, 24), rt.uniform(-0.3, 0.3), rt.uniform(-0.3, 0.3)
        b = rt.uniform(0, 2 * math.pi)
        pts = []
        for j in range(3):
            t = b + 2 * math.pi * j / 3
            x, y = 128 + 115 * math.cos(t), 128 + 115 * math.sin(t)
            pts.append((x, y, z0 + gx * (x - 128) + gy * (y - 128)))
        trip.append(("t%d" % k, [pts]))
    write("triple_points", [bg] + trip, ORTHO, "nine large mutually penetrating triangles (many triple points)")

    # Concurrent planes: six triangles whose planes all pass through one point (128.3, 127.6, 20),
    # so that all their triple points coincide before snapping: a cluster of cycle cells.
    conc = []
    cx, cy, cz = 128.3, 127.6, 20.0
    for k in range(6):
        a = math.pi * k / 6 + 0.1
        gx, gy = 0.3 * math.cos(a), 0.3 * math.sin(a)  # depth slope of plane k
        b = 2 * math.pi * k / 6
        pts = []
        for j in range(3):
            t = b + 2 * math.pi * j / 3
            x, y = cx + 110 * math.cos(t), cy + 110 * math.sin(t)
            pts.append((x, y, cz + gx * (x - cx) + gy * (y - cy)))
        conc.append(("p%d" % k, [pts]))
    write("concurrent_planes", [bg] + conc, ORTHO, "six triangles whose planes share one point")

    # Vertex exactly on another triangle's edge, on screen.
    ve = [("base", [[(40, 40, 10), (220, 40, 10), (130, 220, 10)]]),
          ("touch", [[(130, 40, 20), (220, 130, 20), (240, 20, 20)], [(85, 130, 5), (20, 200, 5), (60, 240, 5)]])]
    write("vertex_on_edge", [bg] + ve, ORTHO, "vertices of one mesh exactly on the edges of another")

    # Ten coplanar triangles (test_random.cpp, coplanar kind, seed 5). After vertex snapping their
    # depth planes differ: some pairs tie (ordered by the tie rule over their whole overlap), others
    # cross beyond the band, and where both meet the pairwise order is cyclic: the exact reference
    # has no answer there (tie_cycle_area, docs/NUMERICS.md §3).
    tc = [
        [(-0.25, 0.0, -0.25), (0.75, -0.5, -0.25), (-0.75, -0.25, -0.25)],
        [(0.25, 0.75, -0.25), (-0.75, 0.25, -0.25), (0.25, 0.5, -0.25)],
        [(0.25, 0.0, -0.25), (0.5, 0.0, -0.25), (-0.75, 1.0, -0.25)],
        [(0.5, -1.0, -0.25), (-0.75, -0.5, -0.25), (-0.25, -0.25, -0.25)],
        [(0.75, -0.75, -0.25), (0.5, -0.75, -0.25), (-1.0, 0.25, -0.25)],
        [(1.0, 1.0, -0.25), (0.25, 0.25, -0.25), (-0.75, -1.0, -0.25)],
        [(-0.25, 0.75, -0.25), (0.75, -0.5, -0.25), (-1.0, 0.0, -0.25)],
        [(0.75, 0.25, -0.25), (-0.75, -0.75, -0.25), (-1.0, -0.75, -0.25)],
        [(0.25, -0.5, -0.25), (1.0, 0.25, -0.25), (0.0, -0.5, -0.25)],
        [(-0.25, 0.75, -0.25), (-0.25, -0.25, -0.25), (0.5, 0.25, -0.25)],
    ]
    camtc = {"type": "orthographic", "eye": [0.13578527558693249, -0.25823597666731046, 3.8860112442737655],
             "target": [-0.17150966287419567, 0.013197640818983725, -0.08746272154176707], "up": [0, 1, 0],
             "ortho_height": 2.7148667951055456, "near": 2.7138039582726803, "far": 5.570515354275117,
             "width": 256, "height": 256}
    write("tie_cycle", [("m0", tc)], camtc, "ten coplanar triangles whose tie and crossing orders are cyclic", shared=False)

    # Coplanar and nearly coplanar, seen obliquely (issue 45): the nearness changes by a factor ~2
    # over each overlap, so the tie band taken at a point (VM_TIE_EPS of the local |q|) is
    # narrower than the pair's (of the largest |q| over the overlap), and a rule that lets the
    # sample point decide overlaps or leaves holes. One band for every decision
    # (docs/NUMERICS.md §3). Three coplanar triangles in one mesh; two plates 1e-6 apart; two
    # plates whose vertices are jittered by up to 1e-6 across each other.
    oblique = {"type": "perspective", "eye": [0.45, -2.3, 1.05], "target": [0, 0, 0], "up": [0, 0, 1],
               "fov_y_deg": 55, "near": 0.5, "far": 6, "width": 256, "height": 256}
    ct = [[(-1, -1, 0), (1, -0.8, 0), (0.05, 1, 0)],
          [(-0.9, 0.7, 0), (0.8, 0.9, 0), (0.1, -1.05, 0)],
          [(-1.1, -0.05, 0), (1.05, 0.2, 0), (0.2, 0.95, 0)]]
    write("coplanar_triple", [("m0", ct)], oblique, "three coplanar triangles in one mesh, seen obliquely")
    pl = [("lower", quad(-1, -1, 1, 1, 0)), ("upper", quad(-0.6, -1.2, 1.3, 0.7, 1e-6))]
    campl = dict(oblique, eye=[0.1, -1.2, 2.5], fov_y_deg=50)
    write("plates_1e-6", pl, campl, "two plates 1e-6 apart (inside the tie band), seen obliquely; "
          "the z-buffer of pixel_error, comparing depths against the band at the sample, showed 0.12 % "
          "of the pixels wrong (the map was right)")
    jr = random.Random(45)

    def jittered(x0, y0, x1, y1, n):
        z = {(i, j): jr.uniform(-1e-6, 1e-6) for i in range(n + 1) for j in range(n + 1)}
        p = lambda i, j: (x0 + (x1 - x0) * i / n, y0 + (y1 - y0) * j / n, z[(i, j)])
        out = []
        for i in range(n):
            for j in range(n):
                out += [[p(i, j), p(i + 1, j), p(i + 1, j + 1)], [p(i, j), p(i + 1, j + 1), p(i, j + 1)]]
        return out
    jp = [("lower", jittered(-1, -1, 1, 1, 3)), ("upper", jittered(-0.7, -1.1, 1.2, 0.8, 3))]
    write("jittered_plates", jp, oblique, "two plates of 18 triangles, every vertex jittered by up to 1e-6 in depth, seen obliquely")

    # Closed shells facing opposite ways in one mesh (issue 45): an outward cube and a smaller
    # inward one (its faces wound the other way). The whole mesh's signed volume is positive; a
    # cull by that sign drops the inward cube's near faces and draws its inside. Back faces are
    # culled only where every closed component faces the same way (core/util/mesh_topology.h).
    def cube(cx, cy, cz, h, inward):
        v = lambda i, j, k: (cx + (2 * i - 1) * h, cy + (2 * j - 1) * h, cz + (2 * k - 1) * h)
        faces = [((0, 0, 0), (0, 1, 0), (1, 1, 0), (1, 0, 0)), ((0, 0, 1), (1, 0, 1), (1, 1, 1), (0, 1, 1)),
                 ((0, 0, 0), (1, 0, 0), (1, 0, 1), (0, 0, 1)), ((0, 1, 0), (0, 1, 1), (1, 1, 1), (1, 1, 0)),
                 ((0, 0, 0), (0, 0, 1), (0, 1, 1), (0, 1, 0)), ((1, 0, 0), (1, 1, 0), (1, 1, 1), (1, 0, 1))]
        out = []
        for f in faces:
            a, b, c, d = [v(*q) for q in f]
            for t in ([a, b, c], [a, c, d]):
                out.append(t[::-1] if inward else t)
        return out
    shells = cube(-0.7, 0, 0, 0.5, False) + cube(0.7, 0.1, 0.1, 0.4, True)
    camsh = {"type": "perspective", "eye": [0.6, 1.7, 3.4], "target": [0, 0, 0], "up": [0, 1, 0],
             "fov_y_deg": 45, "near": 1, "far": 10, "width": 256, "height": 256}
    write("opposite_shells", [("shells", shells)], camsh, "one mesh holding an outward cube and an inward one")

    # A sliver (8e-5 wide, thinner than a grid unit) crossing the viewport's top edge at a slant
    # (issue 45, found by a random search). Its clipped polygon snapped into a folded one, whose
    # two fan triangles overlapped (0.0037 px^2, coverage_error 0.30), and compare_maps counted
    # the culled and unculled maps, byte-identical, as differing (cull_differing 1). Now the hull
    # of a folded snapped polygon is cut (transform.cl snapped_convex) and compare_maps makes a
    # source's fragments disjoint first.
    sl = [[(0.589334153, 1.39532774, 0.147584793), (-0.354412406, 1.02139503, -0.132301331),
           (-0.354453667, 1.02136961, -0.132264276)]]
    camsl = {"type": "perspective", "eye": [0.3, 0.2, 3], "target": [0, 0, 0], "up": [0, 1, 0],
             "fov_y_deg": 40, "near": 0.5, "far": 10, "width": 64, "height": 64}
    write("sliver_viewport_edge", [("s", sl)], camsl, "a sliver crossing the viewport's edge at a slant")


if __name__ == "__main__":
    main()
