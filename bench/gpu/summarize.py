#!/usr/bin/env python3
"""summary.md for bench/gpu/run.sh, from OUT/{env.txt,devices.txt,steps.tsv,maps.tsv,bench.jsonl}.
Standard library only (the GPU machine runs it with whatever python3 it has).

    python3 summarize.py OUT > OUT/summary.md
"""

import csv
import json
import os
import sys

out = sys.argv[1]


def read(name):
    try:
        with open(os.path.join(out, name)) as f:
            return f.read()
    except OSError:
        return ""


def tsv(name):
    text = read(name)
    return list(csv.DictReader(text.splitlines(), delimiter="\t")) if text else []


def f1(v, nd=1):
    return "" if v is None else f"{v:.{nd}f}"


md = ["# vismap GPU run (bench/gpu/run.sh)", "", "```", read("env.txt").strip(), "```", "",
      "## Devices (`vismap devices`)", "", "```", read("devices.txt").strip() or "(none)", "```", ""]

steps = tsv("steps.tsv")
bad = [s for s in steps if s["status"] != "ok"]
md += [f"## Steps: {len(steps) - len(bad)} of {len(steps)} ok", ""]
if bad:
    md += ["| step | status | s | last output |", "|---|---|---:|---|"]
    md += [f"| {s['step']} | {s['status']} | {s['seconds']} | {s['note'].replace('|', '/')} |" for s in bad]
    md.append("")

md += ["## Maps (`vismap render --format bin`, the CLI's camera), byte for byte", "",
       "GPU twice in two processes; against the PoCL map pack.sh made (whole: `cmp`; else sha256);",
       "against PoCL on this machine if it has PoCL (`-`: not run).", "",
       "| scene | bytes | GPU run 2 | packed PoCL | PoCL here | GPU render ms, 1st / 2nd | PoCL render ms |",
       "|---|---:|---|---|---|---:|---:|"]
for m in tsv("maps.tsv"):
    md.append(f"| {m['scene']} | {m['gpu_bytes']} | {m['gpu_repeat']} | {m['vs_packed_pocl']} | "
              f"{m['vs_pocl_here']} | {m['gpu_render_ms']} / {m['gpu2_render_ms']} | {m['pocl_render_ms']} |")
md += ["", "Render ms: the CLI's `--stats` render time, a whole process each (the 1st of a scene may pay the",
       "device compiler's per-kernel work; the program itself is built by the warm-up and cached).", ""]

rows = []
for line in read("bench.jsonl").splitlines():
    try:
        rows.append(json.loads(line))
    except ValueError:
        pass
md += ["## vismap_bench (one process: first render, then warm medians; z-buffer = id raster, same device)", "",
       "ratio = pipeline / z-buffer (the raster floor; issue 5's target on the GPU: 10 or less). "
       "syncs = host round trips per render.", "",
       "| run | scene | res | triangles | first ms | pipeline ms (min-max, n) | kernels ms | host ms | syncs | "
       "z-buffer ms | ratio | Mtri/s | device MB | top stage |",
       "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|"]
for r in rows:
    st = r.get("stages") or {}
    tot = sum(st.values()) or 1
    top = max(st, key=st.get) if st else ""
    md.append(
        f"| {r['run']} | {r['scene_name']} | {r['width']:.0f} | {r['triangles']:.0f} | {f1(r['first_render_ms'])} | "
        f"{f1(r['pipeline_ms'], 2)} ({f1(r['pipeline_min_ms'], 2)}-{f1(r['pipeline_max_ms'], 2)}, {r['runs']:.0f}) | "
        f"{f1(r['kernels_ms'], 2)} | {f1(r['host_ms'], 2)} | {r['host_syncs']:.0f} | {f1(r['zbuffer_ms'], 3)} | "
        f"{f1(r['zbuffer_ratio'], 1)} | {r['triangles_per_s'] / 1e6:.1f} | {r['peak_device_bytes'] / 1e6:.1f} | "
        f"{top} {100 * st.get(top, 0) / tot:.0f}% |")
if rows:
    stages = list(dict.fromkeys(k for r in rows for k in (r.get("stages") or {})))
    md += ["", "Stage times, ms (median of warm runs, OpenCL event time):", "",
           "| run | scene | res | " + " | ".join(stages) + " |", "|---|---|---:|" + "---:|" * len(stages)]
    for r in rows:
        st = r.get("stages") or {}
        md.append(f"| {r['run']} | {r['scene_name']} | {r['width']:.0f} | " +
                  " | ".join(f1(st.get(s), 2) for s in stages) + " |")
    md += ["", "Devices in the bench lines: " + "; ".join(sorted({f"{r['run']}: {r['device']}" for r in rows}))]
print("\n".join(md))
