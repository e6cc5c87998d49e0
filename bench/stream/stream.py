#!/usr/bin/env python3
"""The streaming bench (issue 16), driven by bench/stream/run.sh; docs/STREAMING.md explains it.

Per scene: vismap_stream_bench renders the orbit and measures every vector encoding (bytes,
encode ms, decode ms) and writes each frame's SVG; this script rasterizes the SVGs with
rsvg-convert (the exact raster), encodes the raster sequence with ffmpeg in every VIDEOS setting,
and measures bytes per frame (ffprobe packet sizes), PSNR against the exact raster, and encode
and decode time. Lossy vector encodings (compact, later delta) write their decoded frames as SVG
too; those are rasterized and compared against the exact raster the same way.

Writes OUT/results.csv, results.md, raw.jsonl (the tool's lines and one line per video),
env.txt and plots/bytes_vs_triangles.svg, after every scene (an interrupted run keeps what it
measured). Frames, rasters and videos go to FRAMES (default bench/out/stream/<tag>/, ignored by
git).
"""

import argparse
import csv
import datetime
import json
import math
import os
import re
import shutil
import statistics
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))
import svgplot  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(HERE))
SHARED = os.path.join(os.path.dirname(ROOT), "shared", "data")

SCENES = [
    ("cornell", os.path.join(ROOT, "data/cornell_box/CornellBox-Original.obj")),
    ("teapot", os.path.join(SHARED, "teapot/teapot_c3d.obj")),
    ("cornell_armadillo", os.path.join(ROOT, "data/scenes/cornell_armadillo.json")),
    ("bunny", os.path.join(ROOT, "data/bunny.ply")),
    ("dragon", os.path.join(ROOT, "data/dragon_vrip.ply.gz")),
    ("bunny_cut", os.path.join(ROOT, "data/scenes/bunny_cut.json")),
]
QUICK_SCENES = ["cornell", "teapot", "bunny"]
QUICK_FRAMES = 12

FPS = 5
# Colour conversion, both ways: BT.601 matrix, limited ("tv") range, as ffmpeg's default but
# named, so the encoder's input and the PSNR's conversion back are the same conversion.
TO_YUV = "scale=out_color_matrix=bt601:out_range=tv,format=yuv420p"
TO_RGB = "scale=in_color_matrix=bt601:in_range=tv,format=rgb24"
X264_LOW_DELAY = ["-c:v", "libx264", "-preset", "veryfast", "-tune", "zerolatency"]
# name, label, ffmpeg output options. The 20 Mbit/s setting is constant bitrate in the HRD sense
# (nal-hrd=cbr: x264 pads with filler data, so every frame after the first costs 20e6/8/FPS
# bytes on the wire); buffer 1 s.
VIDEOS = [
    ("x264_crf23", "x264 CRF 23", X264_LOW_DELAY + ["-crf", "23"]),
    ("x264_crf18", "x264 CRF 18", X264_LOW_DELAY + ["-crf", "18"]),
    ("x264_20M", "x264 20 Mbit/s CBR", X264_LOW_DELAY + [
        "-b:v", "20M", "-minrate", "20M", "-maxrate", "20M", "-bufsize", "20M",
        "-x264-params", "nal-hrd=cbr"]),
    ("x265_crf28", "x265 CRF 28 (medium)", ["-c:v", "libx265", "-preset", "medium", "-crf", "28",
                                             "-x265-params", "log-level=error"]),
]
# Vector encodings in the order the tables show them; others the tool reports follow.
VECTOR_ORDER = ["svg", "bin", "bin_attr", "compact", "delta", "delta_held", "delta_held_z19", "delta_v1_held"]


def log(*a):
    print("stream:", *a, file=sys.stderr, flush=True)


def sh(cmd):
    try:
        return subprocess.run(cmd, shell=True, capture_output=True, text=True, timeout=30).stdout.strip()
    except Exception:
        return ""


def run(cmd, **kw):
    p = subprocess.run(cmd, capture_output=True, text=True, **kw)
    if p.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd[:3])} ... failed ({p.returncode}): {p.stderr.strip()[-800:]}")
    return p


def timed(cmd):
    t0 = time.perf_counter()
    p = run(cmd)
    return (time.perf_counter() - t0) * 1000, p


def run_tool(build, path, frames_dir, nframes, extra):
    """vismap_stream_bench, its JSON lines streamed (progress on stderr)."""
    cmd = [os.path.join(build, "bench", "vismap_stream_bench"), path, "--out", frames_dir,
           "--frames", str(nframes)] + extra
    lines = []
    with subprocess.Popen(cmd, stdout=subprocess.PIPE, text=True) as p:
        for line in p.stdout:
            if not line.startswith("{"):
                continue
            j = json.loads(line)
            lines.append(j)
            if "frame" in j and (j["frame"] % 10 == 0 or j["frame"] == nframes - 1):
                log(f"  frame {j['frame']}: {j['visible_triangles']:.0f} triangles, "
                    f"render {j['render_ms']:.0f} ms")
    if p.returncode != 0:
        raise RuntimeError(f"vismap_stream_bench failed ({p.returncode})")
    return [j for j in lines if "frame" in j], next(j for j in lines if j.get("summary"))


def rasterize(svg_dir, png_dir, n, w, h):
    """rsvg-convert each frame (white background), one process at a time; ms per frame."""
    os.makedirs(png_dir, exist_ok=True)
    ms = []
    for i in range(n):
        src, dst = os.path.join(svg_dir, f"frame_{i:04d}.svg"), os.path.join(png_dir, f"frame_{i:04d}.png")
        t, _ = timed(["rsvg-convert", "-w", str(w), "-h", str(h), "-b", "white", "-f", "png", "-o", dst, src])
        ms.append(t)
    return ms


def seq(png_dir):
    return ["-framerate", str(FPS), "-i", os.path.join(png_dir, "frame_%04d.png")]


# Both inputs of a PSNR are retimed to frame numbers, so the filter pairs frame i with frame i.
RETIME = f"settb=1/{FPS},setpts=N"
PSNR_RE = re.compile(r"PSNR (.*) average:([\d.inf]+) min:([\d.inf]+) max:([\d.inf]+)")


def psnr(dist_input, ref_input, dist_chain, ref_chain, stats_path):
    """ffmpeg's psnr filter: 'average' is 10 log10(255^2 / MSE), the MSE over every frame, pixel
    and plane (planes weighted by their size). Returns (average, {plane: dB}, frames compared)."""
    lavfi = (f"[0:v]{RETIME}{',' + dist_chain if dist_chain else ''}[d];"
             f"[1:v]{RETIME}{',' + ref_chain if ref_chain else ''}[r];"
             f"[d][r]psnr=stats_file={stats_path}")
    p = run(["ffmpeg", "-hide_banner", "-nostats"] + dist_input + ref_input +
            ["-lavfi", lavfi, "-f", "null", "-"])
    m = PSNR_RE.search(p.stderr)
    if not m:
        raise RuntimeError("no PSNR in ffmpeg's output: " + p.stderr[-400:])
    planes = {k: float(v) for k, v in (kv.split(":") for kv in m.group(1).split())}
    with open(stats_path) as f:
        n = sum(1 for line in f if line.strip())
    return float(m.group(2)), planes, n


def packets(video):
    """Packet sizes (bytes) and keyframe flags from ffprobe, in presentation order (x265 codes
    B-frames out of order), so packet i is frame i."""
    p = run(["ffprobe", "-v", "error", "-select_streams", "v:0", "-show_entries", "packet=pts,size,flags",
             "-of", "json", video])
    pk = sorted(json.loads(p.stdout)["packets"], key=lambda q: int(q["pts"]))
    return [(int(q["size"]), "K" in q["flags"]) for q in pk]


def measure_videos(png_dir, vid_dir, n, tmp):
    os.makedirs(vid_dir, exist_ok=True)
    r = {}
    # The encoders' input, converted once: the exact raster as yuv420p (Y4M), so that an encode's
    # wall time is the codec's (plus process start), not PNG decoding and colour conversion.
    y4m = os.path.join(vid_dir, "exact.y4m")
    ms, _ = timed(["ffmpeg", "-v", "error", "-y"] + seq(png_dir) + ["-vf", TO_YUV, "-pix_fmt", "yuv420p",
                                                               "-f", "yuv4mpegpipe", y4m])
    r["png_to_yuv_ms"] = ms / n
    # The ceiling of any yuv420p video: the exact raster through RGB -> YUV 4:2:0 -> RGB alone.
    r["yuv420p_psnr_rgb"], _, _ = psnr(["-i", y4m], seq(png_dir), TO_RGB, "format=rgb24",
                                       os.path.join(tmp, "psnr_yuv420p.log"))
    raw = []
    for name, label, opts in VIDEOS:
        v = os.path.join(vid_dir, name + ".mkv")
        ms, _ = timed(["ffmpeg", "-v", "error", "-y", "-i", y4m] + opts + ["-pix_fmt", "yuv420p", v])
        pk = packets(v)
        if len(pk) != n:
            raise RuntimeError(f"{name}: {len(pk)} packets for {n} frames")
        sizes = [s for s, _ in pk]
        inter = [s for s, k in pk if not k]
        dec_ms, _ = timed(["ffmpeg", "-v", "error", "-i", v, "-f", "null", "-"])
        rgb, _, nr = psnr(["-i", v], seq(png_dir), TO_RGB, "format=rgb24", os.path.join(tmp, f"psnr_{name}_rgb.log"))
        _, yuv, ny = psnr(["-i", v], ["-i", y4m], "", "", os.path.join(tmp, f"psnr_{name}_y.log"))
        if nr != n or ny != n:
            raise RuntimeError(f"{name}: PSNR compared {nr}/{ny} frames of {n}")
        r.update({
            f"{name}_bytes": statistics.fmean(sizes),
            f"{name}_key_bytes": sum(s for s, k in pk if k) / max(1, sum(1 for _, k in pk if k)),
            f"{name}_inter_bytes": statistics.fmean(inter) if inter else None,
            f"{name}_file_bytes": os.path.getsize(v),
            f"{name}_keyframes": sum(1 for _, k in pk if k),
            f"{name}_psnr_rgb": rgb, f"{name}_psnr_y": yuv["y"],
            f"{name}_encode_ms": ms / n, f"{name}_decode_ms": dec_ms / n,
        })
        raw.append({"video": name, "label": label, "packet_bytes": sizes, "encode_wall_ms": ms,
                    "decode_wall_ms": dec_ms, "psnr_rgb": rgb, "psnr_yuv": yuv})
        log(f"  {label}: {r[name + '_bytes']:.0f} B/frame, PSNR {rgb:.2f} dB RGB / {yuv['y']:.2f} dB Y")
    os.remove(y4m)  # 3 MB a frame
    return r, raw


def measure_scene(build, name, path, args, frames_root, tmp):
    frames_dir = os.path.join(frames_root, name)
    if os.path.isdir(frames_dir):
        shutil.rmtree(frames_dir)
    os.makedirs(frames_dir)
    svg_dir = os.path.join(frames_dir, "svg")
    extra = ["--width", str(args.width), "--height", str(args.height)] + (
        ["--device", args.device] if args.device else [])
    log(f"{name}: rendering {args.frames} frames")
    t0 = time.perf_counter()
    frames, summary = run_tool(build, path, svg_dir, args.frames, extra)
    row = {"scene": name, "input_triangles": summary["input_triangles"], "frames": summary["frames"],
           "device": summary["device"]}
    for k in ("visible_triangles_mean", "visible_triangles_min", "visible_triangles_max", "fragments_mean",
              "render_ms_median", "render_ms_mean", "first_render_ms", "load_ms"):
        row[k] = summary[k]
    for e, s in summary["encodings"].items():
        row[f"{e}_bytes"] = s["bytes_mean"]
        row[f"{e}_encode_ms"] = s["encode_ms_mean"]
        row[f"{e}_decode_ms"] = s["decode_ms_mean"]
        row[f"{e}_encode_ms_median"] = s["encode_ms_median"]
        row[f"{e}_decode_ms_median"] = s["decode_ms_median"]
    log(f"{name}: rasterizing")
    png = os.path.join(frames_dir, "png")
    exact_png = os.path.join(png, "exact")
    row["svg_raster_ms"] = statistics.fmean(
        rasterize(summary["exact_svg_dir"], exact_png, args.frames, args.width, args.height))
    for e, s in summary["encodings"].items():
        if s.get("decoded_svg_dir"):  # lossy vector encodings: their decoded frames against exact
            d = os.path.join(png, e)
            rasterize(s["decoded_svg_dir"], d, args.frames, args.width, args.height)
            row[f"{e}_psnr_rgb"], _, _ = psnr(seq(d), seq(exact_png), "format=rgb24", "format=rgb24",
                                              os.path.join(tmp, f"psnr_{name}_{e}.log"))
    log(f"{name}: video")
    vr, vraw = measure_videos(exact_png, os.path.join(frames_dir, "video"), args.frames, tmp)
    row.update(vr)
    row["scene_wall_s"] = time.perf_counter() - t0
    raw = ([dict(j, scene=name) for j in frames] + [dict(summary, scene=name)] +
           [dict(v, scene=name) for v in vraw] + [{"row": row}])
    if args.clean:
        shutil.rmtree(frames_dir)
    return row, raw


# ---- outputs ------------------------------------------------------------------------------

def vector_names(rows):
    seen = {k[:-len("_encode_ms")] for r in rows for k in r if k.endswith("_encode_ms")}
    seen -= {v for v, _, _ in VIDEOS}
    return [e for e in VECTOR_ORDER if e in seen] + sorted(seen - set(VECTOR_ORDER))


def columns(rows):
    vec = vector_names(rows)
    cols = ["scene", "input_triangles", "frames", "visible_triangles_mean", "visible_triangles_min",
            "visible_triangles_max", "fragments_mean", "load_ms", "first_render_ms", "render_ms_median",
            "render_ms_mean"]
    for e in vec:
        cols += [f"{e}_bytes", f"{e}_encode_ms", f"{e}_decode_ms", f"{e}_encode_ms_median", f"{e}_decode_ms_median"]
        if any(f"{e}_psnr_rgb" in r for r in rows):
            cols.append(f"{e}_psnr_rgb")
    cols += ["svg_raster_ms", "png_to_yuv_ms", "yuv420p_psnr_rgb"]
    for v, _, _ in VIDEOS:
        cols += [f"{v}_{k}" for k in ("bytes", "key_bytes", "inter_bytes", "file_bytes", "keyframes", "psnr_rgb",
                                      "psnr_y", "encode_ms", "decode_ms")]
    return cols + ["scene_wall_s", "device"]


def crossings(rows, vec):
    """Where a vector encoding's bytes per frame cross a video's, between two scenes adjacent in
    visible triangles: interpolated linearly in log-log. Returns (enc, video, triangles, bytes)
    and sentences for the pairs that do not cross within the measured range."""
    rs = sorted(rows, key=lambda r: r["visible_triangles_mean"])
    found, notes = [], []
    side = {e: {"smaller": [], "larger": []} for e in vec}
    for e in vec:
        for v, label, _ in VIDEOS:
            pts = [(math.log(r["visible_triangles_mean"]), math.log(r[f"{e}_bytes"]), math.log(r[f"{v}_bytes"]))
                   for r in rs if r.get(f"{e}_bytes") and r.get(f"{v}_bytes") and r["visible_triangles_mean"] > 0]
            hit = False
            for (t1, a1, b1), (t2, a2, b2) in zip(pts, pts[1:]):
                g1, g2 = a1 - b1, a2 - b2
                if g1 == 0 or g1 * g2 < 0:
                    f = g1 / (g1 - g2) if g1 != g2 else 0
                    found.append((e, label, math.exp(t1 + f * (t2 - t1)), math.exp(a1 + f * (a2 - a1))))
                    hit = True
            if not hit and pts:
                side[e]["smaller" if pts[0][1] < pts[0][2] else "larger"].append(label)
    for e in vec:
        parts = [f"{k} than {', '.join(side[e][k])}" for k in ("smaller", "larger") if side[e][k]]
        if parts:
            notes.append(f"{e} is {' and '.join(parts)} in every scene measured")
    return found, notes


def fmt(v, nd=0):
    if v is None or v == "":
        return ""
    if isinstance(v, str):
        return v
    return f"{v:,.{nd}f}"


def kb(v):
    if v is None:
        return ""
    return f"{v / 1000:,.1f}" if v >= 100 else f"{v / 1000:,.3f}"


def write_outputs(out, rows, raw, env, args):
    os.makedirs(os.path.join(out, "plots"), exist_ok=True)
    cols = columns(rows)
    with open(os.path.join(out, "results.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=cols, extrasaction="ignore")
        w.writeheader()
        for r in rows:
            w.writerow(r)
    with open(os.path.join(out, "raw.jsonl"), "w") as f:  # rows included: --replot reads them back
        for j in raw:
            f.write(json.dumps(j) + "\n")
    with open(os.path.join(out, "env.txt"), "w") as f:
        for k, v in env.items():
            f.write(f"{k}: {v}\n")

    vec = vector_names(rows)
    vids = [(v, label) for v, label, _ in VIDEOS]
    series = [(e, [(r["visible_triangles_mean"], r.get(f"{e}_bytes")) for r in rows], "line") for e in vec]
    series += [(label, [(r["visible_triangles_mean"], r.get(f"{v}_bytes")) for r in rows], "dashed")
               for v, label in vids]
    cross, notes = crossings(rows, vec)
    if cross:
        series.append(("crossings", [(t, b) for _, _, t, b in cross], "points"))
    svgplot.line_plot(os.path.join(out, "plots", "bytes_vs_triangles.svg"),
                      f"Bytes per frame, {args.width}x{args.height}, {FPS} fps (scene means)",
                      "visible output triangles per frame", "bytes per frame", series, logx=True, logy=True,
                      width=980, height=520)
    # Every frame on its own: a frame's triangles against what that frame cost in each encoding
    # (video: that frame's packet, keyframes included).
    tri = {(j["scene"], j["frame"]): j["visible_triangles"] for j in raw if "frame" in j}
    fseries = [(e, [(t, j["encodings"][e]["bytes"]) for j in raw if "frame" in j and e in j["encodings"]
                    for t in [j["visible_triangles"]]], "points") for e in vec]
    for v, label in vids:
        fseries.append((label, [(tri.get((j["scene"], i)), b) for j in raw if j.get("video") == v
                                for i, b in enumerate(j["packet_bytes"])], "points"))
    svgplot.line_plot(os.path.join(out, "plots", "bytes_vs_triangles_frames.svg"),
                      f"Bytes per frame, {args.width}x{args.height}, {FPS} fps (every frame)",
                      "visible output triangles in the frame", "bytes for the frame", fseries, logx=True,
                      logy=True, width=980, height=520)

    md = [f"# vismap streaming bench {env['date']}", "",
          f"Commit {env['commit']}; {env['nproc']} cores, {env['cpu']}; device `{rows[0]['device'] if rows else ''}`; "
          f"{env['ffmpeg']}; libx264 {env['libx264']}, libx265 {env['libx265']}; rsvg-convert {env['rsvg']}. "
          f"Load average at start {env['loadavg_start']}, end {env.get('loadavg_end', '')}; "
          f"wall time {env.get('wall_s', '')} s.", "",
          f"Orbit of {args.frames} frames at {args.width}x{args.height}: 6 degrees of azimuth a frame about +Y "
          f"through the bounding-box centre, elevation 20 degrees, eye 1.7 bounding-box diagonals away, "
          f"35 degree vertical fov. Video at {FPS} fps, yuv420p (BT.601, limited range) from the exact raster "
          f"(rsvg-convert of the SVG, white background). docs/STREAMING.md has the methodology.", "",
          "## Bytes per frame (kB = 1000 bytes; video: mean packet size from ffprobe)", "",
          "| scene | input triangles | visible triangles (min-max) | " + " | ".join(vec) + " | " +
          " | ".join(label for _, label in vids) + " |",
          "|---|" + "---:|" * (2 + len(vec) + len(vids))]
    for r in rows:
        md.append(f"| {r['scene']} | {fmt(r['input_triangles'])} | {fmt(r['visible_triangles_mean'])} "
                  f"({fmt(r['visible_triangles_min'])}-{fmt(r['visible_triangles_max'])}) | " +
                  " | ".join(kb(r.get(f"{e}_bytes")) for e in vec) + " | " +
                  " | ".join(kb(r.get(f"{v}_bytes")) for v, _ in vids) + " |")
    md += ["", "A video's mean includes its keyframes (the first frame, and any the encoder's scene-cut "
           "detection adds). Keyframe mean (count) and inter frames alone, the steady state of a stream, "
           "in kB per frame:", "",
           "| scene | " + " | ".join(f"{label} key (n) / inter" for _, label in vids) + " |",
           "|---|" + "---:|" * len(vids)]
    for r in rows:
        md.append(f"| {r['scene']} | " + " | ".join(
            f"{kb(r.get(f'{v}_key_bytes'))} ({r.get(f'{v}_keyframes')}) / {kb(r.get(f'{v}_inter_bytes'))}"
            for v, _ in vids) + " |")
    md += ["", "## Quality: PSNR against the exact raster (dB)", "",
           "RGB: all three channels of the decoded frame converted back to RGB, the MSE over every frame, "
           "pixel and channel (ffmpeg's psnr `average`). Y: luma only, in the encoder's YUV. "
           "`yuv420p` is the exact raster through the colour conversion and 4:2:0 alone (no codec): the "
           "ceiling of any yuv420p video. svg, bin and bin_attr are exact (the raster is drawn from them).", "",
           "| scene | yuv420p (RGB) | " + "".join(f"{e} (RGB) | " for e in vec if any(f"{e}_psnr_rgb" in r for r in rows)) +
           " | ".join(f"{label} RGB / Y" for _, label in vids) + " |",
           "|---|---:|" + "---:|" * (sum(1 for e in vec if any(f"{e}_psnr_rgb" in r for r in rows)) + len(vids))]
    for r in rows:
        md.append(f"| {r['scene']} | {fmt(r.get('yuv420p_psnr_rgb'), 2)} | " +
                  "".join(f"{fmt(r.get(f'{e}_psnr_rgb'), 2)} | " for e in vec if any(f"{e}_psnr_rgb" in q for q in rows)) +
                  " | ".join(f"{fmt(r.get(f'{v}_psnr_rgb'), 2)} / {fmt(r.get(f'{v}_psnr_y'), 2)}" for v, _ in vids) + " |")
    md += ["", "## Time per frame (ms)", "",
           "Render: the warm pipeline, median and mean over frames (the warm-up render of frame 0 apart). "
           "Vector encode/decode: in process, mean over frames (medians in results.csv; svg decode: "
           "rsvg-convert to PNG, the whole process, mean). Video encode: ffmpeg's wall time encoding the "
           "exact raster from Y4M (converted from the PNGs once beforehand), per frame; decode: "
           "`ffmpeg -i video -f null -` per frame; both with process start, both cores. "
           "Shared 2-core machine: noisy.", "",
           "| scene | render median / mean | first render | " + " | ".join(f"{e} enc / dec" for e in vec) + " | " +
           " | ".join(f"{label} enc / dec" for _, label in vids) + " |",
           "|---|---:|---:|" + "---:|" * (len(vec) + len(vids))]
    for r in rows:
        def ed(e):
            d = r.get(f"{e}_decode_ms") if e != "svg" else r.get("svg_raster_ms")
            return f"{fmt(r.get(f'{e}_encode_ms'), 2)} / {fmt(d, 2)}"
        md.append(f"| {r['scene']} | {fmt(r['render_ms_median'])} / {fmt(r.get('render_ms_mean'))} | "
                  f"{fmt(r['first_render_ms'])} | " +
                  " | ".join(ed(e) for e in vec) + " | " +
                  " | ".join(f"{fmt(r.get(f'{v}_encode_ms'), 1)} / {fmt(r.get(f'{v}_decode_ms'), 1)}" for v, _ in vids) + " |")
    md += ["", "## Where vector and video cross", "",
           "Plots: [scene means](plots/bytes_vs_triangles.svg), [every frame](plots/bytes_vs_triangles_frames.svg). "
           "Break-even: the visible triangles at which an encoding's frame would cost what this scene's "
           "video costs per frame (video bytes / the encoding's bytes per visible triangle in this scene).", "",
           "| scene | encoding | bytes per visible triangle | " +
           " | ".join(f"= {label} at" for _, label in vids) + " |",
           "|---|---|---:|" + "---:|" * len(vids)]
    for r in rows:
        for e in vec:
            if not r.get(f"{e}_bytes") or not r["visible_triangles_mean"]:
                continue
            per = r[f"{e}_bytes"] / r["visible_triangles_mean"]
            md.append(f"| {r['scene']} | {e} | {per:.1f} | " +
                      " | ".join(fmt(r[f'{v}_bytes'] / per) if r.get(f"{v}_bytes") else "" for v, _ in vids) + " |")
    md += ["", "Between scenes: interpolated in log-log between the two scenes (ordered by mean visible "
           "triangles) whose sign of (vector bytes - video bytes) differs; scenes differ in more than "
           "triangle count, so this is a rough guide.", ""]
    for e, label, t, b in cross:
        md.append(f"- {e} = {label} at about {t:,.0f} visible triangles ({b / 1000:,.1f} kB per frame)")
    for n in notes:
        md.append(f"- {n}")
    with open(os.path.join(out, "results.md"), "w") as f:
        f.write("\n".join(md) + "\n")


def environment(build):
    def pkg(p):
        return sh(f"dpkg-query -W -f='${{Version}}' {p}")
    return {
        "date": datetime.datetime.now().isoformat(timespec="seconds"),
        "commit": sh(f"git -C {ROOT} rev-parse --short HEAD") + (" (dirty)" if sh(f"git -C {ROOT} status --porcelain -uno") else ""),
        "nproc": sh("nproc"), "cpu": sh("grep -m1 'model name' /proc/cpuinfo | cut -d: -f2").strip(),
        "ffmpeg": sh("ffmpeg -version | head -1 | cut -d' ' -f1-3"),
        "libx264": pkg("libx264-164"), "libx265": pkg("libx265-199"), "rsvg": pkg("librsvg2-bin"),
        "loadavg_start": " ".join(open("/proc/loadavg").read().split()[:3]),
    }


def replot(out):
    """Rewrites results.csv, results.md and the plots of a finished run from its raw.jsonl."""
    raw = [json.loads(line) for line in open(os.path.join(out, "raw.jsonl"))]
    rows = [j["row"] for j in raw if "row" in j]
    raw = [j for j in raw if "row" not in j]
    env = {}
    for line in open(os.path.join(out, "env.txt")):
        k, _, v = line.rstrip("\n").partition(": ")
        env[k] = v
    s = next(j for j in raw if j.get("summary"))
    args = argparse.Namespace(frames=s["frames"], width=s["width"], height=s["height"])
    write_outputs(out, rows, raw, env, args)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--build", default=os.path.join(ROOT, "build"))
    ap.add_argument("--quick", action="store_true", help=f"{QUICK_FRAMES} frames, scenes {','.join(QUICK_SCENES)}")
    ap.add_argument("--scenes", help="comma-separated: " + ",".join(n for n, _ in SCENES))
    ap.add_argument("--frames", type=int)
    ap.add_argument("--width", type=int, default=1920)
    ap.add_argument("--height", type=int, default=1080)
    ap.add_argument("--device", default="")
    ap.add_argument("--out", help="results folder (default bench/results/<date>-stream[-quick])")
    ap.add_argument("--frames-dir", help="SVG, PNG and video files (default bench/out/stream/<tag>)")
    ap.add_argument("--clean", action="store_true", help="delete each scene's frames once measured")
    ap.add_argument("--replot", metavar="DIR", help="rewrite DIR's tables and plots from its raw.jsonl")
    args = ap.parse_args()
    if args.replot:
        return replot(args.replot)
    names = args.scenes.split(",") if args.scenes else (QUICK_SCENES if args.quick else [n for n, _ in SCENES])
    known = dict(SCENES)
    for n in names:
        if n not in known:
            ap.error(f"unknown scene {n}")
    if args.frames is None:
        args.frames = QUICK_FRAMES if args.quick else 60
    for tool in ("rsvg-convert", "ffmpeg", "ffprobe"):
        if not shutil.which(tool):
            sys.exit(f"stream: {tool} missing (scripts/setup.sh --tests: librsvg2-bin; ffmpeg: apt-get install ffmpeg)")
    tag = datetime.date.today().isoformat() + "-stream" + ("-quick" if args.quick else "")
    out = args.out or os.path.join(ROOT, "bench", "results", tag)
    frames_root = os.path.abspath(args.frames_dir or os.path.join(ROOT, "bench", "out", "stream", tag))
    tmp = os.path.join(frames_root, "tmp")
    os.makedirs(tmp, exist_ok=True)
    env = environment(args.build)
    t0 = time.perf_counter()
    rows, raw = [], []
    for n in names:
        row, r = measure_scene(args.build, n, known[n], args, frames_root, tmp)
        rows.append(row)
        raw += r
        env["loadavg_end"] = " ".join(open("/proc/loadavg").read().split()[:3])
        env["wall_s"] = f"{time.perf_counter() - t0:.0f}"
        write_outputs(out, rows, raw, env, args)
        log(f"{n}: done in {row['scene_wall_s']:.0f} s; results in {out}")
    log(f"all done in {time.perf_counter() - t0:.0f} s; frames in {frames_root}")


if __name__ == "__main__":
    main()
