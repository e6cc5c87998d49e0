#!/usr/bin/env python3
"""Error against run time (DESIGN §4): for each scene and each setting that trades speed for
accuracy, run `vismap check` and print run time and error figures side by side; draw error
against time as an SVG plot per scene.

Settings benched: RenderOptions::tile_pixels (--tile-pixels; 0 = chosen from the input).
Not benchable yet: the snap grid resolution (VM_GRID_SCALE is a compile-time constant in
kernels/layout.h) -- its effect is what snap_area_bound reports.

usage: bench/error_vs_time.py [--vismap build/vismap] [--out bench/out] [--repeat 3]
                              [--tiles 0,16,32,64,128,256] [SCENE[:reference|:pixels] ...]
Default scenes: bunny res4 and res3 (exact reference), teapot and the full bunny (pixels)."""
import argparse, json, os, statistics, subprocess, sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SHARED = os.path.join(os.path.dirname(ROOT), "shared", "data")
DEFAULT = [os.path.join(SHARED, "stanford/bun_zipper_res4.ply") + ":reference",
           os.path.join(SHARED, "stanford/bun_zipper_res3.ply") + ":reference",
           os.path.join(SHARED, "teapot/teapot_c3d.obj") + ":pixels",
           os.path.join(ROOT, "data/bunny.ply") + ":pixels"]


def run(vismap, scene, mode, tile, size):
    cmd = [vismap, "check", scene, "--width", str(size), "--height", str(size)]
    cmd += ["--tile-pixels", str(tile)] if tile else []
    cmd += ["--pixels", "512"] + (["--reference"] if mode == "reference" else [])
    p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode not in (0, 4):
        raise SystemExit("failed: %s\n%s" % (" ".join(cmd), p.stderr))
    return json.loads(p.stdout)


def svg_plot(path, title, rows, key):
    W, H, L, B = 520, 340, 70, 50
    xs = [r["pipeline_ms"] for r in rows]
    ys = [r[key] or 0.0 for r in rows]
    x0, x1 = 0, max(xs) * 1.1 or 1
    y1 = max(ys) * 1.2 if max(ys) > 0 else 1e-6
    sx = lambda x: L + (W - L - 20) * (x - x0) / (x1 - x0)
    sy = lambda y: H - B - (H - B - 30) * y / y1
    o = ['<svg xmlns="http://www.w3.org/2000/svg" width="%d" height="%d" font-family="sans-serif" font-size="11">' % (W, H),
         '<rect width="100%" height="100%" fill="white"/>',
         '<text x="%d" y="18" font-size="13">%s</text>' % (L, title),
         '<line x1="%d" y1="%d" x2="%d" y2="%d" stroke="black"/>' % (L, H - B, W - 20, H - B),
         '<line x1="%d" y1="%d" x2="%d" y2="30" stroke="black"/>' % (L, H - B, L),
         '<text x="%d" y="%d" text-anchor="middle">pipeline time (ms, median)</text>' % ((L + W) // 2, H - 12),
         '<text x="14" y="%d" transform="rotate(-90 14 %d)" text-anchor="middle">%s</text>' % (H // 2, H // 2, key)]
    for k in range(5):
        xv, yv = x0 + (x1 - x0) * k / 4, y1 * k / 4
        o.append('<text x="%.1f" y="%d" text-anchor="middle">%.0f</text>' % (sx(xv), H - B + 15, xv))
        o.append('<text x="%d" y="%.1f" text-anchor="end">%.2g</text>' % (L - 4, sy(yv) + 4, yv))
    for r, x, y in zip(rows, xs, ys):
        o.append('<circle cx="%.1f" cy="%.1f" r="4" fill="#1f77b4"/>' % (sx(x), sy(y)))
        o.append('<text x="%.1f" y="%.1f">tile %s</text>' % (sx(x) + 6, sy(y) - 6, r["tile"] or "auto"))
    o.append("</svg>")
    with open(path, "w") as fh:
        fh.write("\n".join(o) + "\n")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--vismap", default=os.path.join(ROOT, "build/vismap"))
    ap.add_argument("--out", default=os.path.join(ROOT, "bench/out"))
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--size", type=int, default=1024)
    ap.add_argument("--tiles", default="0,16,32,64,128,256")
    ap.add_argument("scenes", nargs="*")
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    tiles = [int(t) for t in a.tiles.split(",")]
    print("%-22s %5s %11s %11s %12s %10s %12s %12s %9s" % ("scene", "tile", "pipeline_ms", "ref_ms",
          "area_error", "overlap", "wrong_source", "pixel_error", "fragments"))
    for spec in a.scenes or DEFAULT:
        scene, _, mode = spec.partition(":")
        mode = mode or "reference"
        if not os.path.exists(scene):
            print("skip %s (not present)" % scene)
            continue
        name = os.path.basename(scene).split(".")[0]
        rows = []
        for tile in tiles:
            runs = [run(a.vismap, scene, mode, tile, a.size) for _ in range(a.repeat)]
            r = dict(runs[-1])
            r["pipeline_ms"] = statistics.median(x["pipeline_ms"] for x in runs)
            r["tile"] = tile
            rows.append(r)
            fmt = lambda v, f: (f % v) if v is not None else "-"
            print("%-22s %5s %11.1f %11s %12s %10s %12s %12s %9d" % (name, tile or "auto", r["pipeline_ms"],
                  fmt(r["reference_ms"], "%.0f"), fmt(r["area_error"], "%.3g"), fmt(r["overlap_area"], "%.3g"),
                  fmt(r["wrong_source"], "%d"), fmt(r["pixel_error"], "%.3g"), r["fragments"]), flush=True)
        with open(os.path.join(a.out, name + ".json"), "w") as fh:
            json.dump(rows, fh, indent=1)
        key = "area_error" if mode == "reference" else "pixel_error"
        svg_plot(os.path.join(a.out, name + ".svg"), "%s: %s against time" % (name, key), rows, key)


if __name__ == "__main__":
    main()
