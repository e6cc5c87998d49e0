#!/usr/bin/python3
"""The streaming scenes through all three clients, in every encoding each decodes (issues 16, 34).

Starts vismapd on a free port with a scene library (a temporary folder holding copies of the
stream bench's scene files, bench/stream/stream.py's SCENES) and, per scene, sends the same
cameras through
  - the C++ client, vismap-client (--cameras FILE): svg, bin, compact, delta (zstd);
  - the Python client, vismap_client (clients/python): svg, bin, compact, delta (zstd);
  - the web viewer, server/www in headless Chromium (bench/stream/browser.mjs): svg, compact,
    delta (raw deflate, the only codec a browser inflates natively; decoded in its worker and
    drawn as the viewer chooses: WebGL 2 on a GPU, the 2D canvas over a software rasterizer such
    as SwiftShader here; --viewer-query draw=webgl or draw=2d decides);
  - the JavaScript decoders (compact.js, delta.js) in node on the frames the C++ client received
    (bench/stream/js_digests.mjs).
Delta is protocol version 3 with the scene held (hello hold_scene: the sources message once after
scene_ready, DELTA.md version 2 frames, each never larger than the compact frame).
The cameras: the stream bench's orbit (6 degrees of azimuth a frame about +Y through the
bounding-box centre from scene_ready's bounds, elevation 20 degrees, 1.7 diagonals away, 35
degree fov), the first --frames of it, at --width x --height (1920x1080).

Per (scene, format, client): frames received and decoded, mean payload bytes per frame, the
client's decode ms (median; delta: over the frames after the keyframe), and for the browser the
draw ms (median) as the page measures them, and a screenshot of the last frame per mode; per
scene, the browser's compact and delta screenshots against its svg one (fraction of object pixels
that differ by more than 48/255, limit 1% as tests/server/test_viewer.mjs), the C++ client's
decoded triangles per frame against the Python client's (bin), and for compact and delta the
decoded arrays of every frame, as a digest (vismap-client's digest(): per array xy, indices,
source, shade the sum of v_i (2i + 1) mod 2^32), C++ against Python against JavaScript. A
combination that fails is a FAIL row (with its reason) and the exit status is 1. Per (scene,
format) also the latency table: the server's render and encode ms (the frame headers, C++
client's stream), wire bytes, each client's decode and the browser's draw, p50 and p95.

Writes OUT/results.md, results.csv, raw.json, env.txt (default bench/results/<date>-stream-clients);
screenshots to SHOTS (default bench/out/stream-clients/<date>, ignored by git).

    /usr/bin/python3 bench/stream/clients.py [--build build] [--scenes bunny,dragon] [--frames 6]
                                             [--clients cpp,python,browser] [--out DIR]
Needs Debian's python3 (numpy, websockets, zstandard), node 20 with playwright-core and
/usr/bin/chromium for the browser (skipped with a SKIP row otherwise).
"""

import argparse
import asyncio
import datetime
import json
import math
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import threading
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, os.path.join(ROOT, "clients", "python"))
sys.path.insert(0, HERE)
import vismap_client as vc  # noqa: E402
from stream import SCENES  # noqa: E402

FORMATS = {"cpp": ["svg", "bin", "compact", "delta"], "python": ["svg", "bin", "compact", "delta"],
           "browser": ["svg", "compact", "delta"]}
CODEC = {"cpp": "zstd", "python": "zstd", "browser": "deflate"}
MAX_DIFFERING = 0.01  # of object pixels, as tests/server/test_viewer.mjs


def log(*a):
    print("clients:", *a, file=sys.stderr, flush=True)


def median(v):
    v = [x for x in v if x is not None]
    return statistics.median(v) if v else None


def sh(cmd):
    try:
        return subprocess.run(cmd, shell=True, capture_output=True, text=True, timeout=30).stdout.strip()
    except Exception:
        return ""


# ---- the library and the server ----------------------------------------------------------

def make_library(lib, names):
    """Copies of the scene files, laid out so that relative references (cornell_armadillo.json's
    ../cornell_box/, ../armadillo.obj) resolve inside the library (it refuses symlinks out)."""
    known = dict(SCENES)
    out = {}
    for n in names:
        src = known[n]
        if n == "bunny_cut":  # data/scenes/bunny_cut.json: ../bunny.ply and quad.obj beside it
            data = os.path.dirname(os.path.dirname(src))
            os.makedirs(os.path.join(lib, "data", "scenes"), exist_ok=True)
            shutil.copy(src, os.path.join(lib, "data", "scenes"))
            shutil.copy(os.path.join(data, "scenes", "quad.obj"), os.path.join(lib, "data", "scenes"))
            shutil.copy(os.path.join(data, "bunny.ply"), os.path.join(lib, "data"))
            out[n] = "data/scenes/" + os.path.basename(src)
        elif n == "cornell_armadillo":
            data = os.path.dirname(os.path.dirname(src))
            os.makedirs(os.path.join(lib, "data", "scenes"), exist_ok=True)
            shutil.copy(src, os.path.join(lib, "data", "scenes"))
            shutil.copy(os.path.join(data, "armadillo.obj"), os.path.join(lib, "data"))
            shutil.copytree(os.path.join(data, "cornell_box"), os.path.join(lib, "data", "cornell_box"),
                            dirs_exist_ok=True)
            out[n] = "data/scenes/" + os.path.basename(src)
        elif src.endswith(".obj"):  # its folder: the .mtl it names (the Cornell box's colours)
            shutil.copytree(os.path.dirname(src), os.path.join(lib, n), dirs_exist_ok=True)
            out[n] = n + "/" + os.path.basename(src)
        else:
            os.makedirs(os.path.join(lib, n), exist_ok=True)
            shutil.copy(src, os.path.join(lib, n))
            out[n] = n + "/" + os.path.basename(src)
    return out


class Server:
    def __init__(self, build, lib, www):
        exe = os.path.join(build, "server", "vismapd")
        self.p = subprocess.Popen([exe, "--port", "0", "--library", lib, "--www", www],
                                  stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        self.lines, ready = [], threading.Event()
        self.port = None

        def read():
            for line in self.p.stderr:
                self.lines.append(line)
                try:
                    e = json.loads(line)
                except ValueError:
                    continue
                if e.get("event") == "listening":
                    self.port = e["port"]
                    ready.set()
            ready.set()
        threading.Thread(target=read, daemon=True).start()
        ready.wait(120)
        if self.port is None:
            raise RuntimeError("vismapd did not start: " + "".join(self.lines[-5:]))
        self.url = f"ws://127.0.0.1:{self.port}/"

    def errors(self):
        """The server's log lines at warning level or above (what it said went wrong)."""
        out = []
        for line in self.lines:
            try:
                e = json.loads(line)
            except ValueError:
                continue
            if e.get("level") in ("warn", "warning", "error"):
                out.append(line.strip())
        return out

    def stop(self):
        self.p.terminate()
        try:
            self.p.wait(30)
        except subprocess.TimeoutExpired:
            self.p.kill()


# ---- cameras ------------------------------------------------------------------------------

def orbit(bounds, frames, step_deg, elevation_deg=20, distance_diag=1.7, fov_y_deg=35):
    """bench/stream/stream_bench.cpp's orbit_camera, as camera messages (near/far fitted)."""
    lo, hi = bounds["lo"], bounds["hi"]
    c = [(a + b) / 2 for a, b in zip(lo, hi)]
    d = distance_diag * math.dist(lo, hi)
    el = math.radians(elevation_deg)
    cams = []
    for i in range(frames):
        az = math.radians(i * step_deg)
        eye = [c[0] + d * math.cos(el) * math.sin(az), c[1] + d * math.sin(el), c[2] + d * math.cos(el) * math.cos(az)]
        cams.append({"eye": eye, "target": c, "up": [0, 1, 0], "projection": "perspective", "fov_y_deg": fov_y_deg})
    return cams


# ---- the clients --------------------------------------------------------------------------

def row(scene, fmt, client, frames):
    return {"scene": scene, "format": fmt, "client": client, "codec": CODEC[client] if fmt in ("compact", "delta") else "",
            "status": "FAIL", "frames": frames, "received": 0, "decoded": 0, "bytes_mean": None, "keyframe_bytes": None,
            "decode_ms_median": None, "draw_ms_median": None, "paths_ms_median": None, "keyframe_decode_ms": None,
            "keyframe_draw_ms": None, "triangles_mean": None, "wall_s": None, "note": "",
            # per frame, for the latency table and the digests check (raw.json)
            "frame_bytes": [], "render_ms": [], "encode_ms": [], "decode_ms": [], "draw_ms": [], "script_ms": [],
            "upload_ms": [], "digests": None, "coding": None, "sources_bytes": None}


def digest(f):
    """vismap-client's digest() of a decoded frame: per array (xy, indices, source, shade, values as
    uint32) "length:h", h = sum of v_i (2i + 1) mod 2^32, joined by '/'."""
    import numpy as np
    out = []
    for v in (f.xy, f.indices, f.source, f.shade):
        v = np.asarray(v).astype(np.int64).astype(np.uint32)
        h = int((v * (2 * np.arange(len(v), dtype=np.uint32) + 1)).sum(dtype=np.uint32))
        out.append(f"{len(v)}:{h:08x}")
    return "/".join(out)


def percentile(v, q):
    v = sorted(x for x in v if x is not None)
    if not v:
        return None
    k = (len(v) - 1) * q / 100
    lo, hi = math.floor(k), math.ceil(k)
    return v[lo] + (v[hi] - v[lo]) * (k - lo)


def after_keyframe(fmt, values):
    """Delta medians are over the frames after the first (the keyframe)."""
    return values[1:] if fmt == "delta" and len(values) > 1 else values


def bytes_of(fmt, sizes):
    """(mean bytes per frame, the keyframe's bytes): delta's mean is over the frames after it."""
    if not sizes:
        return None, None
    return statistics.fmean(after_keyframe(fmt, sizes)), sizes[0] if fmt == "delta" else None


def run_cpp(a, url, scene, lib_name, fmt, cams, tmp):
    r = row(scene, fmt, "cpp", len(cams))
    path = os.path.join(tmp, f"cams_{scene}.json")
    with open(path, "w") as f:
        json.dump(cams, f)
    frames_dir = os.path.join(tmp, f"frames_{scene}_{fmt}")
    shutil.rmtree(frames_dir, ignore_errors=True)
    cmd = [os.path.join(a.build, "clients", "vismap-client"), "--url", url, "--library", lib_name, "--format", fmt,
           "--width", str(a.width), "--height", str(a.height), "--cameras", path, "--timeout", str(a.timeout)]
    if fmt in ("compact", "delta"):
        cmd += ["--out", frames_dir]  # for the JavaScript decoders (js_digests.mjs)
    if fmt == "delta":
        cmd.append("--hold-scene")
    t0 = time.perf_counter()
    p = subprocess.run(cmd, capture_output=True, text=True)
    r["wall_s"] = time.perf_counter() - t0
    if p.returncode != 0:
        r["note"] = f"exit {p.returncode}: " + (p.stderr.strip().splitlines() or [""])[-1][:300]
        return r, None
    j = json.loads(p.stdout.strip().splitlines()[-1])
    per = j["by_format"][fmt]
    r["received"] = j["frames"]
    r["frame_bytes"] = per["bytes"]
    r["render_ms"] = [m[0] for m in per.get("server_ms", [])]
    r["encode_ms"] = [m[1] for m in per.get("server_ms", [])]
    r["decode_ms"] = per.get("decode_ms", [])
    r["digests"] = per.get("digests")
    r["coding"] = per.get("coding")
    r["sources_bytes"] = per.get("sources_bytes")
    if fmt in ("compact", "delta"):
        r["frames_dir"] = frames_dir
    r["bytes_mean"], r["keyframe_bytes"] = bytes_of(fmt, per["bytes"])
    tri = per.get("triangles")
    if fmt == "svg":
        r["decoded"] = r["received"]  # not parsed: received whole is all the C++ client checks
        r["note"] = "svg not parsed"
    else:
        r["decoded"] = sum(1 for t in tri if t is not None)
        ms = per["decode_ms"]
        r["decode_ms_median"] = median(after_keyframe(fmt, ms))
        if fmt == "delta":
            r["keyframe_decode_ms"] = ms[0]
        r["triangles_mean"] = statistics.fmean(t for t in tri if t is not None) if r["decoded"] else None
        if per.get("resyncs"):
            r["note"] = f"{per['resyncs']} frames did not apply"
        if fmt == "delta":
            coded = per.get("coding") or []
            r["note"] = "; ".join(x for x in [r["note"], f"held: sources {per.get('sources_bytes', 0):,} B once",
                                             f"coded {', '.join(f'{coded.count(k)} {k}' for k in ('keyframe', 'delta', 'compact') if coded.count(k))}"] if x)
    r["status"] = "OK" if r["received"] == r["frames"] == r["decoded"] else "FAIL"
    return r, tri


async def python_client(a, url, lib_name, fmt, cams, r):
    tri, ms, sizes = [], [], []
    async with vc.Session(url, fmt=fmt, width=a.width, height=a.height, timeout=a.timeout,
                          hold_scene=fmt == "delta") as s:
        await s.library(lib_name)
        r["sources_bytes"] = s.sources_bytes or None
        for cam in cams:
            await s.camera(**cam)
            header = await s.recv_json()
            if header.get("type") != "frame":
                raise ValueError(f"expected a frame, got {header}")
            r["render_ms"].append(header.get("render_ms"))
            r["encode_ms"].append(header.get("encode_ms"))
            payload = await s.recv()
            sizes.append(len(payload))
            r["received"] += 1
            t0 = time.perf_counter()
            if fmt == "svg":
                if not isinstance(payload, str):
                    raise ValueError("svg frame as a binary message")
                f = None
            elif fmt == "bin":
                f = vc.read_bin(payload)
            elif fmt == "compact":
                f = vc.read_compact(payload)
            else:
                f = s.delta.decode(payload)  # raises on a frame that does not apply: a FAIL
            ms.append((time.perf_counter() - t0) * 1000)
            tri.append(f.triangle_count if f is not None else None)
            if fmt in ("compact", "delta"):
                r["digests"] = (r["digests"] or []) + [digest(f)]
            r["decoded"] += 1
    return tri, ms, sizes


def run_python(a, url, scene, lib_name, fmt, cams):
    r = row(scene, fmt, "python", len(cams))
    t0 = time.perf_counter()
    try:
        tri, ms, sizes = asyncio.run(python_client(a, url, lib_name, fmt, cams, r))
    except Exception as e:  # a FAIL row says what, the run goes on
        r["note"] = f"{type(e).__name__}: {e}"[:300]
        r["wall_s"] = time.perf_counter() - t0
        return r, None
    r["wall_s"] = time.perf_counter() - t0
    r["bytes_mean"], r["keyframe_bytes"] = bytes_of(fmt, sizes)
    r["frame_bytes"], r["decode_ms"] = sizes, ms
    if fmt == "svg":
        r["note"] = "svg not parsed"
    else:
        r["decode_ms_median"] = median(after_keyframe(fmt, ms))
        if fmt == "delta":
            r["keyframe_decode_ms"] = ms[0]
        r["triangles_mean"] = statistics.fmean(tri)
    r["status"] = "OK" if r["received"] == r["frames"] == r["decoded"] else "FAIL"
    return r, tri


def run_browser(a, port, scene, lib_name, cams, shots, tmp):
    plan = os.path.join(tmp, f"plan_{scene}.json")
    with open(plan, "w") as f:
        json.dump([{"scene": scene, "library": lib_name, "width": a.width, "height": a.height, "cameras": cams}], f)
    node = shutil.which("node")
    rows = {m: row(scene, m, "browser", len(cams)) for m in FORMATS["browser"]}
    if not node:
        for r in rows.values():
            r["status"], r["note"] = "SKIP", "no node"
        return list(rows.values()), [], {}
    t0 = time.perf_counter()
    p = subprocess.run([node, os.path.join(HERE, "browser.mjs"), "--port", str(port), "--plan", plan, "--out", shots,
                        "--frame-timeout", str(a.timeout)] + (["--query", a.viewer_query] if a.viewer_query else []), capture_output=True, text=True)
    wall = time.perf_counter() - t0
    sys.stderr.write(p.stderr)
    try:
        out = json.loads(p.stdout.strip().splitlines()[-1])
    except (ValueError, IndexError):
        out = None
    if p.returncode == 77 or (out and out.get("skipped")):
        for r in rows.values():
            r["status"], r["note"] = "SKIP", (out or {}).get("skipped", "skipped")
        return list(rows.values()), [], {}
    if p.returncode != 0 or out is None:
        for r in rows.values():
            r["note"] = f"browser.mjs exit {p.returncode}: " + (p.stderr.strip().splitlines() or [""])[-1][:300]
        return list(rows.values()), [], {}
    for run in out["runs"]:
        r = rows[run["mode"]]
        r["wall_s"] = wall / len(out["runs"])
        t = run["timings"]
        good = [e for e in t if not e.get("error")]
        r["received"], r["decoded"] = len(t), len(good)
        for k in ("decode_ms", "draw_ms", "script_ms", "upload_ms"):
            r[k] = [e.get(k) for e in good]
        r["frame_bytes"] = [e.get("bytes") for e in good]
        renderers = sorted({e["renderer"] for e in good if e.get("renderer")})
        if good:
            r["bytes_mean"], r["keyframe_bytes"] = bytes_of(run["mode"], [e["bytes"] for e in good])
            key = [e for e in good if e.get("keyframe")]
            rest = [e for e in good if not e.get("keyframe")] if run["mode"] == "delta" else good
            r["decode_ms_median"] = median([e["decode_ms"] for e in rest])
            r["draw_ms_median"] = median([e["draw_ms"] for e in rest])
            r["paths_ms_median"] = median([e.get("paths_ms") for e in rest])
            if run["mode"] == "delta" and key:
                r["keyframe_decode_ms"], r["keyframe_draw_ms"] = key[0]["decode_ms"], key[0]["draw_ms"]
            if run["mode"] != "svg":
                r["triangles_mean"] = statistics.fmean(e["triangles"] for e in good)
        r["note"] = "; ".join(run["errors"])[:300]
        if renderers:
            r["codec"] += ", " + "+".join(renderers)
        if run["mode"] == "svg":
            r["note"] = ("decode = innerHTML parse; draw = to the 2nd animation frame " + r["note"]).strip()
        r["status"] = "OK" if r["received"] == r["frames"] == r["decoded"] and not run["errors"] else "FAIL"
    return list(rows.values()), out["compare"], {"chromium": out.get("chromium")}


def js_digests(frames_dir):
    """The JavaScript decoders' digests of the frames the C++ client saved (js_digests.mjs)."""
    node = shutil.which("node")
    if not node or not frames_dir or not os.path.isdir(frames_dir):
        return None, "no node or no frames"
    p = subprocess.run([node, os.path.join(HERE, "js_digests.mjs"), frames_dir], capture_output=True, text=True)
    try:
        out = json.loads(p.stdout.strip().splitlines()[-1])
    except (ValueError, IndexError):
        return None, f"js_digests.mjs exit {p.returncode}: {p.stderr.strip()[-200:]}"
    return out.get("digests"), out.get("error")


def digest_check(n, fmt, c, p, j, why):
    """C++, Python and JavaScript decoded the same arrays in every frame."""
    ok = bool(c) and c == p == j
    if ok:
        result = f"{len(c)} frames, all equal"
    else:
        k = next((i for i in range(max(len(c or []), len(p or []), len(j or [])))
                  if not (c and p and j and i < min(len(c), len(p), len(j)) and c[i] == p[i] == j[i])), 0)
        result = (f"frame {k}: C++ {(c or [None] * (k + 1))[k] if c and k < len(c) else None}, "
                  f"Python {p[k] if p and k < len(p) else None}, JS {j[k] if j and k < len(j) else why}")
    return {"scene": n, "check": f"{fmt}: decoded arrays per frame, C++ = Python = JavaScript", "result": result,
            "status": "OK" if ok else "FAIL"}


# ---- outputs ------------------------------------------------------------------------------

COLUMNS = ["scene", "format", "client", "codec", "status", "frames", "received", "decoded", "bytes_mean", "keyframe_bytes",
           "decode_ms_median", "draw_ms_median", "paths_ms_median", "keyframe_decode_ms", "keyframe_draw_ms", "triangles_mean",
           "wall_s", "note"]


def fmt_num(v, nd=1):
    if v is None or v == "":
        return "–"
    if isinstance(v, float):
        return f"{v:,.{nd}f}"
    return f"{v:,}" if isinstance(v, int) else str(v)


def draw_paths(r):
    return f" (paths {r['paths_ms_median']:.2f})" if r.get("paths_ms_median") is not None else ""


def p50_95(v, nd=1):
    lo, hi = percentile(v, 50), percentile(v, 95)
    return "–" if lo is None else f"{lo:,.{nd}f} / {hi:,.{nd}f}"


def latency_table(rows):
    """Per scene and format, from this run: the server's render and encode (frame headers of the
    C++ client's stream; the same frames as the Python client's), bytes on the wire, each
    client's decode and the browser's draw: p50 / p95 over the frames (delta: after the first)."""
    md = ["", "## Latency", "",
          "Per scene and format, p50 / p95 over the frames in ms (delta: the frames after the first, the "
          "keyframe), from this run: server render and encode (the frame headers' render_ms and encode_ms), "
          "wire bytes (mean payload per frame: zstd for C++ and Python, raw deflate in the browser), each "
          "client's decode (browser: the worker's, inflate included) and the browser's draw (WebGL 2: upload "
          "and draw calls, ended by reading one pixel back; svg: to the second animation frame) and script "
          "(the page's own thread for the frame).", "",
          "| scene | format | render | encode | bytes (zstd / deflate) | C++ decode | Python decode | browser decode | "
          "browser draw | browser script |", "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|"]
    by = {(r["scene"], r["format"], r["client"]): r for r in rows}
    for scene in dict.fromkeys(r["scene"] for r in rows):
        for fmt in ("svg", "bin", "compact", "delta"):
            c, p, b = (by.get((scene, fmt, k)) for k in ("cpp", "python", "browser"))
            if not (c or p or b):
                continue
            cut = (lambda v: after_keyframe(fmt, v or []))
            server = c or p
            zb = statistics.fmean(cut(server["frame_bytes"])) if server and server["frame_bytes"] else None
            db = statistics.fmean(cut(b["frame_bytes"])) if b and b["frame_bytes"] else None
            md.append(f"| {scene} | {fmt} | {p50_95(cut(server['render_ms'])) if server else '–'} | "
                      f"{p50_95(cut(server['encode_ms']), 2) if server else '–'} | "
                      f"{fmt_num(zb, 0)} / {fmt_num(db, 0) if fmt in ('compact', 'delta') else '–'} | "
                      f"{p50_95(cut(c['decode_ms']), 2) if c and fmt != 'svg' else '–'} | "
                      f"{p50_95(cut(p['decode_ms']), 2) if p and fmt != 'svg' else '–'} | "
                      f"{p50_95(cut(b['decode_ms']), 2) if b else '–'} | {p50_95(cut(b['draw_ms']), 2) if b else '–'} | "
                      f"{p50_95(cut(b['script_ms']), 2) if b and fmt != 'svg' else '–'} |")
    return md


def write_outputs(out, a, rows, checks, env):
    os.makedirs(out, exist_ok=True)
    import csv
    with open(os.path.join(out, "results.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=COLUMNS)
        w.writeheader()
        for r in rows:
            w.writerow({k: r.get(k) for k in COLUMNS})
    with open(os.path.join(out, "raw.json"), "w") as f:
        json.dump({"rows": rows, "checks": checks, "env": env}, f, indent=1)
    with open(os.path.join(out, "env.txt"), "w") as f:
        for k, v in env.items():
            f.write(f"{k}: {v}\n")
    md = [f"# The five streaming scenes through all three clients, {env['date']}", "",
          f"Commit {env['commit']}; {env['nproc']} cores, {env['cpu']}; {env.get('chromium', '')}; "
          f"load average at start {env['loadavg_start']}, end {env.get('loadavg_end', '?')}; wall {env.get('wall_s', '?')} s.",
          "",
          f"Cameras: the stream bench's orbit (bench/stream/stream.py), its first {a.frames} frames "
          f"({a.step_deg:g} degrees apart) at {a.width}x{a.height}, the same cameras for every client. "
          "Bytes: mean payload per frame. Decode and draw: medians over the frames, ms, measured in the "
          "client (C++: steady_clock around read_bin/read_compact/DeltaDecoder::decode; Python: perf_counter "
          "around read_bin/read_compact/DeltaDecoder.decode; browser: performance.now() in the page around "
          "the worker's decode, inflate included, and around the draw (WebGL 2: the buffer upload and the two "
          "draw calls; the 2D canvas with --viewer-query draw=2d: drawCompact), ended by reading one pixel "
          "back, which makes the browser finish rasterizing; svg mode: decode is "
          "the innerHTML assignment, draw the time to the second requestAnimationFrame; paths: the part of a 2D "
          "canvas draw that builds the Path2Ds in script, the rest is Skia's fill, stroke and raster). Delta: "
          "protocol version 3 with the scene held, bytes and medians over "
          "the frames after the keyframe (frame 0), the keyframe's own in the CSV. C++ and Python take zstd, "
          "the browser raw deflate (what it inflates natively).", "",
          "| scene | format | client | codec | status | frames decoded | bytes/frame | decode ms | draw ms | triangles | note |",
          "|---|---|---|---|---|---:|---:|---:|---:|---:|---|"]
    for r in rows:
        md.append(f"| {r['scene']} | {r['format']} | {r['client']} | {r['codec']} | {r['status']} | "
                  f"{r['decoded']}/{r['frames']} | {fmt_num(r['bytes_mean'], 0)} | {fmt_num(r['decode_ms_median'], 2)} | "
                  f"{fmt_num(r['draw_ms_median'], 2)}{draw_paths(r)} | {fmt_num(r['triangles_mean'], 0)} | {r['note']} |")
    md += latency_table(rows)
    md += ["", "## Checks", "",
           "Browser screenshots of the last frame, compact and delta against svg mode: the fraction of object "
           f"pixels that differ by more than 48/255 in a channel (limit {100 * MAX_DIFFERING:g}%). C++ against "
           "Python: the decoded triangle count of every frame.", "",
           "| scene | check | result | status |", "|---|---|---|---|"]
    for c in checks:
        md.append(f"| {c['scene']} | {c['check']} | {c['result']} | {c['status']} |")
    with open(os.path.join(out, "results.md"), "w") as f:
        f.write("\n".join(md) + "\n")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--build", default=os.path.join(ROOT, "build"))
    ap.add_argument("--scenes", default=",".join(n for n, _ in SCENES))
    ap.add_argument("--frames", type=int, default=6)
    ap.add_argument("--step-deg", type=float, default=6)
    ap.add_argument("--width", type=int, default=1920)
    ap.add_argument("--height", type=int, default=1080)
    ap.add_argument("--clients", default="cpp,python,browser")
    ap.add_argument("--www", default=os.path.join(ROOT, "server", "www"),
                    help="the web viewer's folder (another version of server/www, to compare)")
    ap.add_argument("--viewer-query", default="", help="more URL parameters for the viewer, e.g. draw=2d")
    ap.add_argument("--timeout", type=float, default=300, help="seconds a client waits for one message")
    ap.add_argument("--out", default=os.path.join(ROOT, "bench", "results",
                                                  datetime.date.today().isoformat() + "-stream-clients"))
    ap.add_argument("--shots", default=os.path.join(ROOT, "bench", "out", "stream-clients",
                                                    datetime.date.today().isoformat()))
    a = ap.parse_args()
    names = a.scenes.split(",")
    clients = a.clients.split(",")
    for n in names:
        if n not in dict(SCENES):
            ap.error(f"unknown scene {n}")
    env = {"date": datetime.datetime.now().isoformat(timespec="seconds"),
           "commit": sh(f"git -C {ROOT} rev-parse --short HEAD") + (" (dirty)" if sh(f"git -C {ROOT} status --porcelain -uno") else ""),
           "nproc": sh("nproc"), "cpu": sh("grep -m1 'model name' /proc/cpuinfo | cut -d: -f2").strip(),
           "node": sh("node --version"), "python": sys.version.split()[0], "numpy": __import__("numpy").__version__,
           "build_type": sh(f"grep '^CMAKE_BUILD_TYPE' {a.build}/CMakeCache.txt | cut -d= -f2"),
           "loadavg_start": " ".join(open("/proc/loadavg").read().split()[:3]),
           "frames": a.frames, "step_deg": a.step_deg, "viewport": f"{a.width}x{a.height}", "www": a.www, "viewer_query": a.viewer_query}
    os.makedirs(a.shots, exist_ok=True)
    rows, checks = [], []
    t_start = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="vismap-clients-") as tmp:
        lib = os.path.join(tmp, "library")
        lib_names = make_library(lib, names)
        server = Server(a.build, lib, a.www)
        log(f"vismapd on port {server.port}")
        try:
            for n in names:
                t0 = time.perf_counter()

                async def ready():
                    async with vc.Session(server.url, timeout=a.timeout) as s:
                        return await s.library(lib_names[n])
                sr = asyncio.run(ready())
                cams = orbit(sr["bounds"], a.frames, a.step_deg)
                log(f"{n}: {sr['triangles']} triangles, loaded in {sr.get('load_ms', 0):.0f} ms")
                counts, byfmt = {}, {}
                for client in ("cpp", "python"):
                    if client not in clients:
                        continue
                    for fmt in FORMATS[client]:
                        if client == "cpp":
                            r, tri = run_cpp(a, server.url, n, lib_names[n], fmt, cams, tmp)
                        else:
                            r, tri = run_python(a, server.url, n, lib_names[n], fmt, cams)
                        counts[(client, fmt)] = tri
                        byfmt[(client, fmt)] = r
                        rows.append(r)
                        log(f"{n} {fmt} {client}: {r['status']} {r['decoded']}/{r['frames']}, "
                            f"{fmt_num(r['bytes_mean'], 0)} B, decode {fmt_num(r['decode_ms_median'], 2)} ms "
                            f"{r['note']}")
                if "cpp" in clients and "python" in clients:
                    for fmt in ("bin", "compact", "delta"):
                        c, p = counts.get(("cpp", fmt)), counts.get(("python", fmt))
                        ok = c is not None and c == p
                        checks.append({"scene": n, "check": f"{fmt}: C++ vs Python triangles per frame",
                                       "result": f"C++ {c} / Python {p}" if not ok else f"equal ({', '.join(map(str, c))})",
                                       "status": "OK" if ok else "FAIL"})
                    for fmt in ("compact", "delta"):
                        rc, rp = byfmt.get(("cpp", fmt)), byfmt.get(("python", fmt))
                        j, why = js_digests(rc.get("frames_dir") if rc else None)
                        checks.append(digest_check(n, fmt, rc and rc["digests"], rp and rp["digests"], j, why))
                if "browser" in clients:
                    brows, compare, benv = run_browser(a, server.port, n, lib_names[n], cams, a.shots, tmp)
                    rows += brows
                    env.update({k: v for k, v in benv.items() if v})
                    for c in compare:
                        if c.get("error"):
                            checks.append({"scene": n, "check": f"browser {c['mode']} vs svg screenshot",
                                           "result": c["error"], "status": "FAIL"})
                            continue
                        ok = c["fraction"] <= MAX_DIFFERING and c["objectA"] > 100 and c["objectB"] > 100
                        checks.append({"scene": n, "check": f"browser {c['mode']} vs svg screenshot",
                                       "result": f"{100 * c['fraction']:.2f}% of {c['object']:,} object pixels differ "
                                                 f"(svg {c['objectA']:,}, {c['mode']} {c['objectB']:,})",
                                       "status": "OK" if ok else "FAIL"})
                    if not compare and any(r["status"] != "SKIP" for r in brows):
                        checks.append({"scene": n, "check": "browser screenshots", "result": "none compared",
                                       "status": "FAIL"})
                env["loadavg_end"] = " ".join(open("/proc/loadavg").read().split()[:3])
                env["wall_s"] = f"{time.perf_counter() - t_start:.0f}"
                env["server_warnings"] = len(server.errors())
                write_outputs(a.out, a, rows, checks, env)
                log(f"{n}: done in {time.perf_counter() - t0:.0f} s")
        finally:
            server.stop()
            for line in server.errors()[-20:]:
                log("server:", line)
    failed = [r for r in rows if r["status"] == "FAIL"] + [c for c in checks if c["status"] == "FAIL"]
    log(f"{len(rows)} rows, {len(checks)} checks, {len(failed)} FAIL; results in {a.out}")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
