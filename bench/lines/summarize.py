#!/usr/bin/python3
"""Peer bench summary (bench/lines/run.sh): results.md from results.csv, and per scene one PNG
with the tools' drawings side by side (ImageMagick's convert, from run.sh's 512 px renders).

usage: summarize.py RESULTS.csv WORK_DIR RESULTS_DIR
"""
import csv
import os
import shutil
import subprocess
import sys

TOOLS = [("vismap", "vismap --style lines"),
         ("vismap_all", "vismap, no selection"),
         ("occt_outline", "OCCT PolyAlgo, one triangulated face"),
         ("occt_faces", "OCCT PolyAlgo, face per triangle"), ("freestyle", "Blender Freestyle SVG")]


def fmt(v, digits=4):
    try:
        return f"{float(v):.{digits}f}"
    except ValueError:
        return ""


def main():
    src, work, res = sys.argv[1:4]
    rows = list(csv.DictReader(open(src)))
    out = ["| scene | tool | wall s | SVG bytes | chains | recall | precision |",
           "|---|---|---:|---:|---:|---:|---:|"]
    for r in rows:
        label = dict(TOOLS).get(r["tool"], r["tool"])
        if r["status"] != "ok":
            wall = f"DNF (> {r['wall_s']} s)" if r["status"] == "DNF" else r["status"]
            out.append(f"| {r['scene']} | {label} | {wall} | | | | |")
            continue
        if r["chains"] == "0":
            out.append(f"| {r['scene']} | {label} | {float(r['wall_s']):.2f} (empty drawing) | "
                       f"{int(r['svg_bytes']):,} | 0 | | |")
            continue
        runs = f" (median of {r['runs']})" if r["runs"] not in ("", "1") else ""
        out.append(f"| {r['scene']} | {label} | {float(r['wall_s']):.2f}{runs} | {int(r['svg_bytes']):,} | "
                   f"{r['chains']} | {fmt(r['recall'])} | {fmt(r['precision'])} |")
    with open(os.path.join(res, "results.md"), "w") as f:
        f.write("# Line drawings against other tools (bench/lines/run.sh)\n\n")
        f.write("Whole process wall time; recall and precision from `vismap check --lines "
                "--lines-from` (4 x 4 samples per pixel, 1.5 px; docs/LINES.md). Environment: "
                "env.txt.\n\n")
        f.write("\n".join(out) + "\n")
    # Debian's ImageMagick by its path: another "convert" may come first on PATH.
    convert = "/usr/bin/convert" if os.path.exists("/usr/bin/convert") else shutil.which("convert")
    if not convert:
        print("summarize: no ImageMagick convert, no side-by-side pictures", file=sys.stderr)
        return
    for scene in dict.fromkeys(r["scene"] for r in rows):
        panels = []
        for tool, label in TOOLS:
            png = os.path.join(work, f"{scene}.{tool}.png")
            cell = os.path.join(work, f"{scene}.{tool}.cell.png")
            ok = os.path.exists(png) and any(r["scene"] == scene and r["tool"] == tool and r["chains"] not in ("", "0") for r in rows)
            args = [png] if ok else ["-size", "512x512", "xc:white"]
            subprocess.run([convert, *args, "-resize", "384x384", "-gravity", "south", "-background",
                            "white", "-splice", "0x22", "-font", "DejaVu-Sans", "-pointsize", "15", "-annotate", "+0+2",
                            label if ok else label + ": none", cell], check=True)
            panels.append(cell)
        subprocess.run([convert, *panels, "-bordercolor", "#cccccc", "-border", "1", "+append",
                        "-colors", "16", os.path.join(res, f"{scene}.png")], check=True)


if __name__ == "__main__":
    main()
