#!/usr/bin/env python3
"""The benchmark (issue 5), driven by bench/run.sh. Per scene and resolution:

  - bench/vismap_bench (one process, N renders): first-run costs apart from warm medians, the
    time of every stage, counts, device memory, output size;
  - `vismap render --stats` as a whole process, repeated: wall time (median), peak RSS
    (/usr/bin/time -v), load/render/write split;
  - `vismap check` error figures where the CLI has the command and the scene allows.

Writes OUT/results.csv, sweep.csv, raw.jsonl, env.txt, results.md and plots/*.svg. Numbers on a
shared machine are noisy: medians of several runs, and ratios within one run are what to compare.
"""

import argparse
import csv
import datetime
import json
import os
import re
import statistics
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import svgplot  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SHARED = os.path.join(os.path.dirname(ROOT), "shared", "data")
GEN = os.path.join(ROOT, "bench", "scenes")
STAGES = ["transform", "silhouettes", "bin", "cull", "crossings", "candidates", "clip", "occlusion", "emit"]

# name, path, small enough for the exact `vismap check` reference (CGAL; the README calls the
# bunny already too big for it: the others get the pixel comparison only, --pixels 1024)
SCENES = [
    ("bunny", os.path.join(ROOT, "data/bunny.ply"), False),
    ("teapot", os.path.join(SHARED, "teapot/teapot_c3d.obj"), True),
    ("happy_res3", os.path.join(SHARED, "stanford/happy_vrip_res3.ply"), False),
    ("igea", os.path.join(SHARED, "extra_scans/igea.ply"), False),
    ("dragon", os.path.join(ROOT, "data/dragon_vrip.ply.gz"), False),
    ("cornell_armadillo", os.path.join(ROOT, "data/scenes/cornell_armadillo.json"), False),
    ("dragon_bunnies", os.path.join(ROOT, "data/scenes/dragon_bunnies.json"), False),
    ("teapot_stadium", os.path.join(GEN, "teapot_stadium.json"), False),
    ("bunny_loop1", os.path.join(GEN, "bunny_loop1.ply"), False),
    ("bunny_loop2", os.path.join(GEN, "bunny_loop2.ply"), False),
    ("bunny_loop3", os.path.join(GEN, "bunny_loop3.ply"), False),
]
QUICK = ["bunny", "teapot", "teapot_stadium", "bunny_loop1"]
# Tile sweeps at 1024^2. Big tiles make the per-tile work quadratic (see the bunny sweep), so the
# dragon stops at 32 px; the stadium (one tile holds ~100k triangles already) is not swept.
SWEEP = {"bunny": [0, 8, 16, 32, 64, 128, 256], "dragon": [0, 8, 16, 32]}


def log(*a):
    print("bench:", *a, file=sys.stderr, flush=True)


def sh(cmd):
    try:
        return subprocess.run(cmd, shell=True, capture_output=True, text=True, timeout=30).stdout.strip()
    except Exception:
        return ""


def generate(build, quick):
    """Synthetic inputs into bench/scenes/ (gitignored); skipped when already there."""
    tool = os.path.join(build, "bench", "make_subdivided")
    bunny = os.path.join(ROOT, "data/bunny.ply")
    jobs = [(os.path.join(GEN, "stadium.obj"), [tool, "--stadium", os.path.join(GEN, "stadium.obj")]),
            (os.path.join(GEN, "teapot_loop2.ply"),
             [tool, os.path.join(SHARED, "teapot/teapot_c3d.obj"), os.path.join(GEN, "teapot_loop2.ply"),
              "--levels", "2", "--weld"])]
    for lv in (1, 2) if quick else (1, 2, 3):
        out = os.path.join(GEN, f"bunny_loop{lv}.ply")
        jobs.append((out, [tool, bunny, out, "--levels", str(lv)]))
    for out, cmd in jobs:
        if not os.path.exists(out):
            log("generating", os.path.basename(out))
            subprocess.run(cmd, check=True)


def run_driver(build, path, res, runs, tiles, timeout, budget):
    cmd = [os.path.join(build, "bench", "vismap_bench"), path, "--width", str(res), "--height", str(res),
           "--runs", str(runs), "--tile-pixels", ",".join(map(str, tiles)), "--budget-s", str(budget)]
    try:
        p = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        log("driver timed out:", " ".join(cmd))
        return [], "timeout"
    if p.returncode != 0:
        log("driver failed:", p.stderr.strip()[-500:])
        return [], "failed: " + p.stderr.strip()[-200:]
    return [json.loads(line) for line in p.stdout.splitlines() if line.startswith("{")], ""


STAT_RE = {
    "load_ms": r"time: load ([\d.]+) ms", "render_ms": r"render ([\d.]+) ms",
    "write_ms": r"write ([\d.]+) ms", "total_ms": r"total ([\d.]+) ms",
    "out_bytes": r"fragments, (\d+) bytes",
    "device_peak_mb": r"device memory peak ([\d.]+) MB", "buckets": r"(\d+) bucket\(s\)",
}

# --memory-budget rows: (scene, resolution, budget). The target: the 4.4M-triangle bunny
# at 4096^2 within 1 GiB (peak RSS of the whole process; with PoCL device memory is host memory).
BUDGET_ROWS = [("bunny_loop3", 4096, "700M")]


def run_cli(build, path, res, camera, repeats, timeout, budget, extra=()):
    """Whole process, repeated: wall (median), peak RSS (max), the CLI's own load/render/write."""
    exe = os.path.join(build, "vismap")
    walls, rss, parts = [], [], {k: [] for k in STAT_RE}
    with tempfile.TemporaryDirectory() as tmp:
        out = os.path.join(tmp, "out.svg")
        cmd = ["/usr/bin/time", "-v", exe, "render", path, "-o", out, "--stats",
               "--width", str(res), "--height", str(res)] + (camera.split() if camera else []) + list(extra)
        start = time.perf_counter()
        for _ in range(repeats):
            if walls and time.perf_counter() - start > budget:
                break
            t0 = time.perf_counter()
            try:
                p = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
            except subprocess.TimeoutExpired:
                return {"cli_note": "timeout"}
            wall = (time.perf_counter() - t0) * 1000
            if p.returncode != 0:
                return {"cli_note": "failed: " + p.stderr.strip()[-200:]}
            walls.append(wall)
            m = re.search(r"Maximum resident set size \(kbytes\): (\d+)", p.stderr)
            if m:
                rss.append(int(m.group(1)) / 1024)
            for k, rx in STAT_RE.items():
                m = re.search(rx, p.stderr)
                if m:
                    parts[k].append(float(m.group(1)))
    r = {"process_ms": statistics.median(walls), "process_min_ms": min(walls), "process_max_ms": max(walls),
         "process_runs": len(walls), "peak_rss_mb_cli": max(rss) if rss else None}
    for k, v in parts.items():
        if v:
            r["cli_" + k] = statistics.median(v)
    return r


def check_supported(build):
    p = subprocess.run([os.path.join(build, "vismap"), "--help"], capture_output=True, text=True)
    return "vismap check" in p.stdout + p.stderr


CHECK_KEYS = ["area_error", "overlap_area", "wrong_source", "pixel_error", "pipeline_ms", "reference_ms"]


def run_check(build, path, res, camera, exact, timeout):
    cmd = [os.path.join(build, "vismap"), "check", path, "--width", str(res), "--height", str(res)]
    cmd += camera.split() if camera else []
    if not exact:
        cmd += ["--pixels", "1024"]
    try:
        p = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return {"check_note": f"timeout {timeout}s"}
    try:  # exit status 4 = a figure over tolerance: still a result
        j = json.loads(p.stdout.strip().splitlines()[-1])
    except Exception:
        return {"check_note": "failed: " + p.stderr.strip()[-200:]}
    r = {"check_" + k: j.get(k) for k in CHECK_KEYS}
    if j.get("over_tolerance"):
        r["check_over_tolerance"] = ",".join(j["over_tolerance"])
    r["check_note"] = "exact" if exact else "pixels 1024"
    return r


def environment(build):
    pocl = sh("dpkg-query -W -f='${Version}' pocl-opencl-icd")
    cpu = sh("grep -m1 'model name' /proc/cpuinfo | cut -d: -f2").strip()
    return {
        "date": datetime.datetime.now().isoformat(timespec="seconds"),
        "commit": sh(f"git -C {ROOT} rev-parse --short HEAD") + (" (dirty)" if sh(f"git -C {ROOT} status --porcelain -uno") else ""),
        "nproc": sh("nproc"), "cpu": cpu, "pocl": pocl,
        "device": sh(f"{os.path.join(build, 'vismap')} devices | head -1"),
        "loadavg_start": open("/proc/loadavg").read().split()[:3],
    }


def _cell(v):
    if v is None:
        return ""
    return f"{v:.4g}" if isinstance(v, (int, float)) else str(v)


def f1(v, nd=1):
    return "" if v is None or v == "" else f"{v:.{nd}f}"


def write_outputs(out, rows, sweep, env, have_check):
    os.makedirs(os.path.join(out, "plots"), exist_ok=True)
    budget_rows = [r for r in rows if r.get("kind") == "budget"]
    rows = [r for r in rows if r.get("kind") != "budget"]
    cols = ["scene", "triangles", "width", "height", "tile_pixels_effective", "bins", "runs", "load_ms", "init_ms",
            "first_render_ms", "upload_ms", "pipeline_ms", "pipeline_min_ms", "pipeline_max_ms", "kernels_ms",
            "host_ms"] + ["stage_" + s + "_ms" for s in STAGES] + [
            "triangles_per_s", "screen_triangles", "silhouette_edges", "crossing_lines", "fragments",
            "visible_fragments", "fragments_per_visible", "culled_triangles", "dropped_fragments",
            "output_fragments", "output_triangles", "clip_rounds", "host_syncs", "peak_device_bytes",
            "zbuffer_ms", "zbuffer_kernels_ms", "zbuffer_ratio",
            "svg_bytes", "svg_ms", "bin_bytes", "bin_ms", "peak_rss_mb", "process_ms", "process_min_ms",
            "process_max_ms", "process_runs", "peak_rss_mb_cli", "cli_load_ms", "cli_render_ms", "cli_write_ms",
            "cli_total_ms", "check_area_error", "check_overlap_area", "check_wrong_source", "check_pixel_error",
            "check_pipeline_ms", "check_reference_ms", "check_note", "check_over_tolerance", "note"]

    def flat(r):
        d = dict(r)
        for s in STAGES:
            d["stage_" + s + "_ms"] = r.get("stages", {}).get(s)
        if r.get("visible_fragments"):  # fragments clipped per visible fragment (issue 32)
            d["fragments_per_visible"] = round(r["fragments"] / r["visible_fragments"], 3)
        return d

    for name, data in (("results.csv", rows), ("sweep.csv", sweep)):
        with open(os.path.join(out, name), "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=cols, extrasaction="ignore")
            w.writeheader()
            for r in data:
                w.writerow(flat(r))
    with open(os.path.join(out, "raw.jsonl"), "w") as f:
        for r in rows + budget_rows + sweep:
            f.write(json.dumps(r) + "\n")
    with open(os.path.join(out, "env.txt"), "w") as f:
        for k, v in env.items():
            f.write(f"{k}: {v}\n")

    md = [f"# vismap benchmark {env['date']}", "",
          f"Commit {env['commit']}; {env['nproc']} cores, {env['cpu']}; PoCL {env['pocl']}; device "
          f"`{env['device']}`; load average at start {' '.join(env['loadavg_start'])}, end "
          f"{' '.join(env.get('loadavg_end', []))}.", "",
          "Shared machine: absolute times are noisy (other builds running). Warm times are medians of "
          "the runs column; whole-process times are medians of process_runs separate processes. "
          "Compare ratios within one run.", "",
          "## Pipeline (in-process driver, warm, scene resident on the device)", "",
          "| scene | triangles | res | tile px | bins | first render ms | upload ms | pipeline ms (min-max) | kernels ms | host ms | Mtri/s | device MB | out fragments | SVG MB | SVG write ms |",
          "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for r in rows:
        if "pipeline_ms" not in r:
            md.append(f"| {r['scene']} | | {r['width']} | | | | | {r.get('note', '')} | | | | | | | |")
            continue
        md.append(f"| {r['scene']} | {r['triangles']:.0f} | {r['width']} | {r['tile_pixels_effective']:.0f} | "
                  f"{r['bins']:.0f} | {f1(r['first_render_ms'])} | {f1(r['upload_ms'])} | {f1(r['pipeline_ms'])} "
                  f"({f1(r['pipeline_min_ms'])}-{f1(r['pipeline_max_ms'])}) | {f1(r['kernels_ms'])} | {f1(r['host_ms'])} | "
                  f"{r['triangles_per_s'] / 1e6:.2f} | {r['peak_device_bytes'] / 1e6:.1f} | {r['output_fragments']:.0f} | "
                  f"{r['svg_bytes'] / 1e6:.2f} | {f1(r['svg_ms'])} |")
    md += ["", "## Work against the output: fragments clipped per visible fragment (issue 32)", "",
           "| scene | res | screen triangles | culled (provably hidden) | fragments | dropped in the rounds | visible | fragments / visible |",
           "|---|---:|---:|---:|---:|---:|---:|---:|"]
    for r in rows:
        if not r.get("visible_fragments"):
            continue
        md.append(f"| {r['scene']} | {r['width']} | {r['screen_triangles']:.0f} | {r.get('culled_triangles', 0):.0f} | "
                  f"{r['fragments']:.0f} | {r.get('dropped_fragments', 0):.0f} | {r['visible_fragments']:.0f} | "
                  f"{r['fragments'] / r['visible_fragments']:.2f} |")
    md += ["", "## Stage times (ms, median of warm runs; OpenCL event time) and share of the kernel sum", "",
           "| scene | res | " + " | ".join(STAGES) + " | top stage |", "|---|---:|" + "---:|" * len(STAGES) + "---|"]
    for r in rows:
        st = r.get("stages")
        if not st:
            continue
        tot = sum(st.values()) or 1
        top = max(st, key=st.get)
        md.append(f"| {r['scene']} | {r['width']} | " + " | ".join(f"{st.get(s, 0):.1f}" for s in STAGES) +
                  f" | {top} {100 * st[top] / tot:.0f}% |")
    md += ["", "## Whole process (`vismap render --stats`, SVG, kernels cached)", "",
           "| scene | res | process ms median (min-max, n) | load ms | render ms | write ms | peak RSS MB | output MB | load share |",
           "|---|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for r in rows:
        if "process_ms" not in r:
            if r.get("cli_note"):
                md.append(f"| {r['scene']} | {r['width']} | {r['cli_note']} | | | | | | |")
            continue
        share = r.get("cli_load_ms", 0) / r["process_ms"] if r["process_ms"] else 0
        md.append(f"| {r['scene']} | {r['width']} | {f1(r['process_ms'])} ({f1(r['process_min_ms'])}-"
                  f"{f1(r['process_max_ms'])}, {r['process_runs']}) | {f1(r.get('cli_load_ms'))} | "
                  f"{f1(r.get('cli_render_ms'))} | {f1(r.get('cli_write_ms'))} | {f1(r.get('peak_rss_mb_cli'))} | "
                  f"{r.get('cli_out_bytes', 0) / 1e6:.2f} | {100 * share:.0f}% |")
    md += ["", "## Error and time (`vismap check`)", ""]
    if not have_check:
        md.append("`vismap check` was not run (`--no-check`, or a CLI without it): no error columns.")
    else:
        md += ["| scene | res | area error | overlap area | wrong source | pixel error | pipeline ms | reference ms | mode |",
               "|---|---:|---:|---:|---:|---:|---:|---:|---|"]
        for r in rows:
            if "check_note" in r:
                md.append(f"| {r['scene']} | {r['width']} | " + " | ".join(_cell(r.get("check_" + k)) for k in CHECK_KEYS)
                          + f" | {r['check_note']}"
                          + (f"; over tolerance: {r['check_over_tolerance']}" if r.get("check_over_tolerance") else "")
                          + " |")
    if sweep:
        md += ["", "## Tile size sweep (RenderOptions::tile_pixels; 0 = the pipeline's choice)", "",
               "| scene | res | tile px | bins | pipeline ms | bin ms | candidates ms | clip ms | occlusion ms | device MB |",
               "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
        for r in sweep:
            st = r["stages"]
            md.append(f"| {r['scene']} | {r['width']} | {r['tile_pixels']:.0f}{' (auto ' + str(int(r['tile_pixels_effective'])) + ')' if r['tile_pixels'] == 0 else ''} | "
                      f"{r['bins']:.0f} | {f1(r['pipeline_ms'])} | {f1(st.get('bin'))} | {f1(st.get('candidates'))} | "
                      f"{f1(st.get('clip'))} | {f1(st.get('occlusion'))} | {r['peak_device_bytes'] / 1e6:.1f} |")
    if budget_rows:
        md += ["", "## Memory budget (`vismap render --memory-budget`, whole process)", "",
               "| scene | res | budget | buckets | device peak MB | peak RSS MB | process ms (min-max, runs) |",
               "|---|---:|---:|---:|---:|---:|---|"]
        for r in budget_rows:
            md.append(f"| {r['scene']} | {r['width']} | {r['memory_budget']} | {r.get('cli_buckets', 0):.0f} | "
                      f"{f1(r.get('cli_device_peak_mb'))} | {f1(r.get('peak_rss_mb_cli'))} | "
                      f"{f1(r.get('process_ms'))} ({f1(r.get('process_min_ms'))}-{f1(r.get('process_max_ms'))}, "
                      f"{r.get('process_runs', '')}) {r.get('cli_note', '')} |")
    md += ["", "## Targets (CPU, PoCL, kernels cached)", ""] + targets(rows, budget_rows)
    plots(out, rows, sweep)
    md += ["", "Plots: " + ", ".join(f"[{p}](plots/{p})" for p in sorted(os.listdir(os.path.join(out, "plots"))))]
    with open(os.path.join(out, "results.md"), "w") as f:
        f.write("\n".join(md) + "\n")


def find(rows, scene, res):
    for r in rows:
        if r["scene"] == scene and r["width"] == res:
            return r
    return {}


def targets(rows, budget_rows=()):
    out = ["| target | limit | measured | met |", "|---|---:|---:|---|"]

    def line(what, limit, value, unit):
        if value is None:
            out.append(f"| {what} | {limit} {unit} | not measured | |")
            return
        ok = value <= limit
        out.append(f"| {what} | {limit} {unit} | {value:.3g} {unit} | {'met' if ok else 'MISSED'} "
                   f"({value / limit:.2f}x the limit) |")

    b = find(rows, "bunny", 1024)
    line("bunny 1024^2 whole process (median)", 300, b.get("process_ms"), "ms")
    line("bunny 1024^2 pipeline (warm median)", 100, b.get("pipeline_ms"), "ms")
    line("bunny 1024^2 pipeline (CLI, first render in process)", 100, b.get("cli_render_ms"), "ms")
    line("bunny 1024^2 peak RSS (CLI)", 200, b.get("peak_rss_mb_cli"), "MB")
    line("bunny 1024^2 SVG size", 3, b.get("svg_bytes", 0) / 1e6 if b.get("svg_bytes") else None, "MB")
    s = find(rows, "bunny_loop1", 1024)
    line("bunny Loop x1 (277,804 tris) whole process", 1000, s.get("process_ms"), "ms")
    d = find(rows, "dragon", 1024)
    line("dragon 1024^2 pipeline (warm median)", 1500, d.get("pipeline_ms"), "ms")
    if d.get("process_ms"):
        out.append(f"| dragon: loading not dominating | load < 50% of process | load {f1(d.get('cli_load_ms'))} ms = "
                   f"{100 * d.get('cli_load_ms', 0) / d['process_ms']:.0f}% of {f1(d['process_ms'])} ms | "
                   f"{'met' if d.get('cli_load_ms', 0) < 0.5 * d['process_ms'] else 'MISSED'} |")
    for r in rows:
        if r.get("zbuffer_ratio") and r.get("kind") == "row":
            line(f"{r['scene']} {r['width']}^2 pipeline / z-buffer id raster (same device; the "
                 f"issue's 10x is for the GPU)", 10, r["zbuffer_ratio"], "x")
    big = [r for r in budget_rows if r["scene"] == "bunny_loop3" and r["width"] == 4096]
    if big:
        line(f"bunny Loop x3 (4.4M) 4096^2, --memory-budget {big[0]['memory_budget']}: peak RSS", 1024,
             big[0].get("peak_rss_mb_cli"), "MB")
    else:
        out.append("| bunny Loop x3 4096^2 within 1 GiB (`--memory-budget`) | 1024 MB | not run | |")
    return out


def plots(out, rows, sweep):
    P = os.path.join(out, "plots")
    ok = [r for r in rows if "pipeline_ms" in r]
    series = []
    for res in (1024, 4096):
        rr = [r for r in ok if r["width"] == res]
        fam = [r for r in rr if r["scene"].startswith("bunny")]
        series.append((f"bunny family {res}^2 pipeline", [(r["triangles"], r["pipeline_ms"]) for r in fam], "line"))
        series.append((f"bunny family {res}^2 process", [(r["triangles"], r.get("process_ms")) for r in fam], "line"))
        series.append((f"other scenes {res}^2 pipeline", [(r["triangles"], r["pipeline_ms"]) for r in rr
                                                          if not r["scene"].startswith("bunny")], "points"))
    svgplot.line_plot(os.path.join(P, "time_vs_triangles.svg"), "Time against input triangles",
                      "input triangles", "ms", series, logx=True, logy=True)
    series = []
    for name in sorted({r["scene"] for r in ok}):
        series.append((name, [(r["width"] * r["height"], r["pipeline_ms"]) for r in ok if r["scene"] == name], "line"))
    svgplot.line_plot(os.path.join(P, "time_vs_resolution.svg"), "Pipeline time against resolution",
                      "pixels", "ms", series, logx=True, logy=True)
    if sweep:
        series = []
        for name in sorted({r["scene"] for r in sweep}):
            pts = [(r["bins"], r["pipeline_ms"]) for r in sweep if r["scene"] == name and r["tile_pixels"] != 0]
            series.append((name, pts, "line"))
            series.append((name + " auto", [(r["bins"], r["pipeline_ms"]) for r in sweep
                                            if r["scene"] == name and r["tile_pixels"] == 0], "points"))
        svgplot.line_plot(os.path.join(P, "time_vs_bins.svg"), "Pipeline time against bin count (tile size sweep)",
                          "bins (tiles)", "ms", series, logx=True, logy=True)
    series = []
    for res in (1024, 4096):
        rr = [r for r in ok if r["width"] == res]
        series.append((f"device MB {res}^2", [(r["triangles"], r["peak_device_bytes"] / 1e6) for r in rr], "points"))
        series.append((f"host RSS MB {res}^2", [(r["triangles"], r.get("peak_rss_mb_cli")) for r in rr], "points"))
    svgplot.line_plot(os.path.join(P, "memory_vs_triangles.svg"), "Memory against input triangles",
                      "input triangles", "MB", series, logx=True, logy=True)
    for res in (1024, 4096):
        rr = [r for r in ok if r["width"] == res]
        svgplot.stacked_bars(os.path.join(P, f"stages_{res}.svg"), f"Stage times at {res}^2 (warm median)", "ms",
                             [(r["scene"], dict(r["stages"], host=r["host_ms"])) for r in rr], STAGES + ["host"])
        svgplot.stacked_bars(os.path.join(P, f"stage_shares_{res}.svg"), f"Stage shares at {res}^2 (warm median)",
                             "% of pipeline", [(r["scene"], dict(r["stages"], host=r["host_ms"])) for r in rr],
                             STAGES + ["host"], normalize=True)


def replot(out):
    rows, sweep = [], []
    for line in open(os.path.join(out, "raw.jsonl")):
        r = json.loads(line)
        kind = r.get("kind") or ("row" if any(k in r for k in ("process_ms", "cli_note", "note")) else "sweep")
        (rows if kind in ("row", "budget") else sweep).append(r)
    env = {}
    for line in open(os.path.join(out, "env.txt")):
        k, _, v = line.rstrip("\n").partition(": ")
        env[k] = v
    for k in ("loadavg_start", "loadavg_end"):
        if k in env:
            env[k] = [x.strip(" '[]") for x in env[k].split(",")]
    write_outputs(out, rows, sweep, env, any("check_note" in r for r in rows))
    log("rewrote", out)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--build", default=os.path.join(ROOT, "build"))
    ap.add_argument("--quick", action="store_true", help="4 scenes at 1024^2, fewer runs, sweep on bunny only")
    ap.add_argument("--out", help="default bench/results/YYYY-MM-DD[-quick]")
    ap.add_argument("--scenes", help="comma-separated subset of: " + ",".join(s[0] for s in SCENES))
    ap.add_argument("--res", default=None, help="comma-separated resolutions (default 1024,4096; quick 1024)")
    ap.add_argument("--runs", type=int, default=None, help="warm runs per row (default 5, quick 3)")
    ap.add_argument("--replot", metavar="DIR", help="rewrite results.md, CSVs and plots of DIR from its raw.jsonl")
    ap.add_argument("--no-cli", action="store_true")
    ap.add_argument("--no-check", action="store_true")
    ap.add_argument("--no-sweep", action="store_true")
    ap.add_argument("--only-budget", action="store_true", help="only the --memory-budget rows")
    ap.add_argument("--timeout", type=int, default=900, help="seconds per tool call")
    ap.add_argument("--budget", type=float, default=20,
                    help="seconds of repeats per row and tool (at least one run each; default 20)")
    a = ap.parse_args()
    if a.replot:
        return replot(a.replot)

    names = a.scenes.split(",") if a.scenes else (QUICK if a.quick else [s[0] for s in SCENES])
    resolutions = [int(x) for x in a.res.split(",")] if a.res else ([1024] if a.quick else [1024, 4096])
    runs = a.runs or (3 if a.quick else 5)
    out = a.out or os.path.join(ROOT, "bench", "results",
                                datetime.date.today().isoformat() + ("-quick" if a.quick else ""))
    os.makedirs(out, exist_ok=True)
    generate(a.build, a.quick and not any(n == "bunny_loop3" for n in names))
    env = environment(a.build)
    have_check = check_supported(a.build) and not a.no_check
    rows, sweep = [], []
    for res in resolutions:  # every scene at the first resolution first: partial runs stay useful
        for name, path, exact_ok in SCENES:
            if name not in names or a.only_budget:
                continue
            if not os.path.exists(path):
                log("missing", path)
                continue
            log(f"{name} {res}^2: driver")
            drv, note = run_driver(a.build, path, res, runs, [0], a.timeout, a.budget)
            r = drv[0] if drv else {"scene": path, "width": res, "height": res, "note": note}
            r["scene"] = name
            r["kind"] = "row"
            if not a.no_cli and drv:
                log(f"{name} {res}^2: process")
                r.update(run_cli(a.build, path, res, r.get("cli_camera", ""), 3 if a.quick else 5, a.timeout,
                                 a.budget))
            if have_check and drv and res == 1024 and (not a.quick or name == "bunny"):
                log(f"{name} {res}^2: check")
                r.update(run_check(a.build, path, res, r.get("cli_camera", ""), exact_ok, a.timeout))
            rows.append(r)
            if not a.no_sweep and res == 1024 and name in SWEEP and (not a.quick or name == "bunny"):
                log(f"{name} {res}^2: tile sweep")
                sw, _ = run_driver(a.build, path, res, max(2, runs - 2), SWEEP[name], a.timeout * 2, a.budget / 2)
                for s in sw:
                    s["scene"] = name
                    s["kind"] = "sweep"
                sweep += sw
            # keep partial results on disk as we go
            env["loadavg_end"] = open("/proc/loadavg").read().split()[:3]
            write_outputs(out, rows, sweep, env, have_check)
    for name, res, mb in BUDGET_ROWS:
        path = dict((s[0], s[1]) for s in SCENES).get(name)
        if a.no_cli or name not in names or res not in resolutions or not path or not os.path.exists(path):
            continue
        log(f"{name} {res}^2: process with --memory-budget {mb}")
        r = {"scene": name, "width": res, "height": res, "kind": "budget", "memory_budget": mb}
        r.update(run_cli(a.build, path, res, "", 3, a.timeout, a.budget, ["--memory-budget", mb]))
        rows.append(r)
        write_outputs(out, rows, sweep, env, have_check)
    log("wrote", out)


if __name__ == "__main__":
    main()
