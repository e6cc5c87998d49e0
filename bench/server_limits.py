#!/usr/bin/python3
"""Issue 35's server cases, full size, against a real vismapd with a bystander session.

Starts vismapd (--vismapd, default build/server/vismapd) on a free port with a scene library in a
temporary folder and the limits given (--time-limit, --memory, --session-bytes), opens a
bystander session on a small mesh (bun_zipper_res4.ply, 948 triangles, from ../shared/data, else a
generated sphere of ~1,000) that asks for a frame, waits for it and asks again for the whole run,
then runs each heavy case in sessions of its own, one case after another:

  deep_sexp     a sphere under 10^5 nested (+ ... 0), uploaded (~600 KB)
  spheres       10^5 small spheres, (min ...) of them, uploaded (~5 MB)
  architecture  the MPR architecture model (library) at implicit_tolerance 0.7, three sessions
  patches       100,000 crumpled Bezier patches (random control points, ~40 MB .bpt), uploaded
  loop          six sessions, each its own 4-5 MB Loop control mesh (pbrt loopsubdiv, an
                icosphere of 81,920 faces, jittered) at tolerance 0.001
  instances     a scene file naming bunny.ply 10,000 times (library)

Per case: the heavy sessions' answers (scene_ready, frame or error code) and the seconds from
request to answer; the server's RSS (VmRSS sampled every 20 ms) settled before the case, its
peak during it and settled after it (the sessions closed, a memory_trimmed event seen or 5 s);
the bystander's frames and latency p50/p99 during the case. A markdown table on stdout and
one JSON line per case; --json FILE writes them all.

    /usr/bin/python3 bench/server_limits.py [--vismapd build/server/vismapd]
        [--cases deep_sexp,spheres,architecture,patches,loop,instances]
        [--time-limit 10] [--memory 2G] [--session-bytes 512M] [--renderers 1] [--json OUT]
Needs Debian's python3-websockets.
"""
import argparse
import asyncio
import json
import math
import os
import random
import shutil
import statistics
import subprocess
import sys
import tempfile
import threading
import time

import websockets

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SHARED = os.environ.get("VISMAP_SHARED_DATA", os.path.join(ROOT, "..", "shared", "data"))


def parse_bytes(s):
    mult = {"K": 1 << 10, "M": 1 << 20, "G": 1 << 30}
    return int(float(s[:-1]) * mult[s[-1]]) if s[-1] in mult else int(s)


# ---- inputs ---------------------------------------------------------------------------------

def icosphere(levels, r=1.0, jitter=0.0, seed=0):
    t = (1 + 5 ** 0.5) / 2
    v = [(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t), (0, -1, -t),
         (0, 1, -t), (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)]
    f = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4),
         (11, 10, 2), (10, 7, 6), (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8),
         (3, 8, 9), (4, 9, 5), (2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1)]
    v = [tuple(c / math.sqrt(sum(x * x for x in p)) for c in p) for p in v]
    for _ in range(levels):
        mid = {}

        def m(a, b):
            k = (min(a, b), max(a, b))
            if k not in mid:
                p = [(v[a][i] + v[b][i]) / 2 for i in range(3)]
                n = math.sqrt(sum(x * x for x in p))
                mid[k] = len(v)
                v.append(tuple(x / n for x in p))
            return mid[k]

        nf = []
        for a, b, c in f:
            ab, bc, ca = m(a, b), m(b, c), m(c, a)
            nf += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        f = nf
    rng = random.Random(seed)
    v = [tuple(r * x * (1 + jitter * rng.uniform(-1, 1)) for x in p) for p in v]
    return v, f


def obj_text(v, f):
    return "".join("v %.6f %.6f %.6f\n" % p for p in v) + "".join(
        "f %d %d %d\n" % (a + 1, b + 1, c + 1) for a, b, c in f)


def loop_pbrt(seed):
    v, f = icosphere(6, jitter=0.02, seed=seed)
    pts = " ".join("%.5f %.5f %.5f" % p for p in v)
    idx = " ".join("%d %d %d" % t for t in f)
    return ('LookAt 0 0 4 0 0 0 0 1 0\nCamera "perspective" "float fov" [40]\nWorldBegin\n'
            'Shape "loopsubdiv" "point P" [%s] "integer indices" [%s]\nWorldEnd\n' % (pts, idx))


def deep_sexp(n):
    return "(+ " * n + "(- (+ (square x) (square y) (square z)) 1)" + " 0)" * n


def spheres_sexp(n, seed=35):
    rng = random.Random(seed)
    terms = []
    for _ in range(n):
        x, y, z = (rng.uniform(-10, 10) for _ in range(3))
        terms.append("(- (+ (square (- x %.3f)) (square (- y %.3f)) (square (- z %.3f))) 0.01)"
                     % (x, y, z))
    return "(min " + " ".join(terms) + ")"


def crumpled_bpt(n, seed=35):
    rng = random.Random(seed)
    out = [str(n)]
    for _ in range(n):
        out.append("3 3")
        for _ in range(16):
            out.append("%.4f %.4f %.4f" % (rng.uniform(-1, 1), rng.uniform(-1, 1),
                                           rng.uniform(-1, 1)))
    return "\n".join(out) + "\n"


def make_library(lib):
    """The library folder: the bystander mesh, bunny + the 10^4-instance scene, the architecture."""
    small = os.path.join(SHARED, "stanford", "bun_zipper_res4.ply")
    if os.path.exists(small):
        shutil.copy(small, os.path.join(lib, "bystander.ply"))
        bystander = "bystander.ply"
    else:
        v, f = icosphere(3)  # 1,280 triangles
        with open(os.path.join(lib, "bystander.obj"), "w") as o:
            o.write(obj_text(v, f))
        bystander = "bystander.obj"
    shutil.copy(os.path.join(ROOT, "data", "bunny.ply"), os.path.join(lib, "bunny.ply"))
    entries = [{"file": "bunny.ply", "translate": [0.2 * (i % 100), 0.2 * (i // 100), 0]}
               for i in range(10000)]
    with open(os.path.join(lib, "instances.json"), "w") as o:
        json.dump({"meshes": entries}, o)
    arch = os.path.join(SHARED, "implicit", "mpr_architecture.sexp")
    if os.path.exists(arch):
        shutil.copy(arch, os.path.join(lib, "architecture.sexp"))
    return bystander


# ---- the server and its memory --------------------------------------------------------------

class Vismapd:
    def __init__(self, exe, lib, cfg):
        self.conf = os.path.join(lib, "..", "conf.json")
        with open(self.conf, "w") as o:
            json.dump(cfg, o)
        self.proc = subprocess.Popen([exe, "--port", "0", "--config", self.conf],
                                     stderr=subprocess.PIPE, text=True)
        self.events = []
        self.port = None
        for line in self.proc.stderr:
            j = json.loads(line)
            if j.get("event") == "listening":
                self.port = j["port"]
                break
        self.lock = threading.Lock()
        threading.Thread(target=self._read_log, daemon=True).start()
        self.peak = 0.0
        self.sampling = True
        threading.Thread(target=self._sample, daemon=True).start()

    def _read_log(self):
        for line in self.proc.stderr:
            try:
                j = json.loads(line)
            except ValueError:
                continue
            with self.lock:
                self.events.append(j)

    def status_mib(self, key):
        try:
            with open("/proc/%d/status" % self.proc.pid) as f:
                for line in f:
                    if line.startswith(key):
                        return int(line.split()[1]) / 1024
        except OSError:
            pass
        return 0.0

    def _sample(self):
        while self.sampling and self.proc.poll() is None:
            self.peak = max(self.peak, self.status_mib("VmRSS:"))
            time.sleep(0.02)

    def count(self, event):
        with self.lock:
            return sum(1 for e in self.events if e.get("event") == event)

    def settled(self, after_trims=None, timeout=5.0):
        """RSS once a memory_trimmed event past after_trims was seen (or timeout) and it holds."""
        t0 = time.time()
        while after_trims is not None and self.count("memory_trimmed") <= after_trims and \
                time.time() - t0 < timeout:
            time.sleep(0.05)
        last = self.status_mib("VmRSS:")
        for _ in range(20):
            time.sleep(0.1)
            now = self.status_mib("VmRSS:")
            if abs(now - last) < 1:
                return now
            last = now
        return last

    def stop(self):
        self.sampling = False
        self.proc.terminate()
        try:
            self.proc.wait(10)
        except subprocess.TimeoutExpired:
            self.proc.kill()


# ---- sessions -------------------------------------------------------------------------------

async def hello(url, **fields):
    ws = await websockets.connect(url, max_size=None, ping_interval=None, compression=None)
    await ws.send(json.dumps(dict({"type": "hello", "version": 1, "format": "bin",
                                   "viewport": {"width": 512, "height": 512}}, **fields)))
    w = json.loads(await ws.recv())
    assert w["type"] == "welcome", w
    return ws


async def answer(ws):
    """The next reply that answers a request: scene_ready, frame (with its payload) or error."""
    while True:
        m = await ws.recv()
        if isinstance(m, bytes):
            continue
        j = json.loads(m)
        if j["type"] == "frame":
            await ws.recv()
        if j["type"] in ("scene_ready", "frame", "error"):
            return j


async def heavy_session(url, scene, hello_fields, results):
    """One heavy session: load (upload or library), then one camera if the scene loaded."""
    t0 = time.time()
    rec = {"load": None, "load_s": None, "frame": None, "frame_s": None}
    try:
        ws = await hello(url, **hello_fields)
        if "library" in scene:
            await ws.send(json.dumps({"type": "scene", "library": scene["library"]}))
        else:
            data = scene["data"].encode()
            await ws.send(json.dumps({"type": "scene", "name": scene["name"], "size": len(data)}))
            await ws.send(data)
        r = await answer(ws)
        rec["load"] = r.get("code", r["type"])
        rec["load_s"] = time.time() - t0
        if r["type"] == "scene_ready":
            t1 = time.time()
            await ws.send(json.dumps({"type": "camera", "seq": 1}))
            r = await answer(ws)
            rec["frame"] = r.get("code", r["type"])
            rec["frame_s"] = time.time() - t1
            if r["type"] == "frame":  # the server's own figures: render and queue wait
                rec["render_ms"], rec["queue_ms"] = r["render_ms"], r["queue_ms"]
            if r["type"] == "error":
                rec["message"] = r["message"][:160]
        else:
            rec["message"] = r["message"][:160]
        await ws.close()
    except Exception as e:  # noqa: BLE001 - a dropped connection is a result too
        rec["exception"] = repr(e)
    results.append(rec)


class Bystander:
    def __init__(self, url, scene):
        self.url, self.scene = url, scene
        self.lat = []  # (t_sent, seconds)
        self.errors = 0
        self.running = True

    async def run(self):
        ws = await hello(self.url)
        await ws.send(json.dumps({"type": "scene", "library": self.scene}))
        r = await answer(ws)
        assert r["type"] == "scene_ready", r
        target = r["camera"]["target"]
        eye = r["camera"]["eye"]
        d = math.dist(eye, target)
        seq = 0
        while self.running:
            seq += 1
            a = seq * 0.1
            cam = {"type": "camera", "seq": seq,
                   "eye": [target[0] + d * math.sin(a), target[1], target[2] + d * math.cos(a)]}
            t = time.time()
            await ws.send(json.dumps(cam))
            r = await answer(ws)
            if r["type"] == "frame":
                self.lat.append((t, time.time() - t))
            else:
                self.errors += 1
        await ws.close()

    def during(self, t0, t1):
        return [s for (t, s) in self.lat if t0 <= t < t1]


def pct(v, p):
    if not v:
        return float("nan")
    v = sorted(v)
    return v[min(len(v) - 1, max(0, math.ceil(p / 100 * len(v)) - 1))]


# ---- the cases ------------------------------------------------------------------------------

def cases(lib):
    arch = os.path.exists(os.path.join(lib, "architecture.sexp"))
    out = {
        "deep_sexp": lambda: [({"name": "deep.sexp", "data": deep_sexp(100000)}, {})],
        "spheres": lambda: [({"name": "spheres.sexp", "data": spheres_sexp(100000)}, {})],
        "patches": lambda: [({"name": "crumpled.bpt", "data": crumpled_bpt(100000)},
                             {"viewport": {"width": 1024, "height": 1024}})],
        "loop": lambda: [({"name": "loop%d.pbrt" % i, "data": loop_pbrt(i)},
                          {"tolerance": 0.001}) for i in range(6)],
        "instances": lambda: [({"library": "instances.json"}, {})],
    }
    if arch:
        out["architecture"] = lambda: [({"library": "architecture.sexp"},
                                        {"implicit_tolerance": 0.7,
                                         "viewport": {"width": 1024, "height": 1024}})] * 3
    return out


async def run_case(url, server, bystander, name, sessions):
    base = server.settled()
    trims = server.count("memory_trimmed")
    server.peak = server.status_mib("VmRSS:")
    t0 = time.time()
    results = []
    await asyncio.gather(*(heavy_session(url, s, h, results) for s, h in sessions))
    t1 = time.time()
    await asyncio.sleep(0.5)  # bystander frames just after
    peak = server.peak
    after = server.settled(after_trims=trims)
    lat = bystander.during(t0, t1)
    return {"case": name, "sessions": len(sessions), "wall_s": round(t1 - t0, 2),
            "answers": results, "rss_before_mib": round(base), "rss_peak_mib": round(peak),
            "rss_after_mib": round(after), "bystander_frames": len(lat),
            "bystander_p50_ms": round(1000 * pct(lat, 50), 1),
            "bystander_p99_ms": round(1000 * pct(lat, 99), 1),
            "bystander_max_ms": round(1000 * max(lat), 1) if lat else None}


async def main_async(a):
    tmp = tempfile.mkdtemp(prefix="server_limits_")
    lib = os.path.join(tmp, "lib")
    os.makedirs(lib)
    small = make_library(lib)
    cfg = {"library": lib, "renderers": a.renderers, "log_level": "info",
           "limits": {"render_time_limit_s": a.time_limit,
                      "render_memory_bytes": parse_bytes(a.memory),
                      "max_session_bytes": parse_bytes(a.session_bytes),
                      "idle_timeout_s": 600}}
    server = Vismapd(a.vismapd, lib, cfg)
    url = "ws://127.0.0.1:%d/" % server.port
    rows = []
    try:
        bystander = Bystander(url, small)
        task = asyncio.create_task(bystander.run())
        await asyncio.sleep(3)
        idle = server.settled()
        lat = bystander.during(0, time.time())
        rows.append({"case": "idle", "rss_mib": round(idle), "bystander_frames": len(lat),
                     "bystander_p50_ms": round(1000 * pct(lat, 50), 1),
                     "bystander_p99_ms": round(1000 * pct(lat, 99), 1)})
        print(json.dumps(rows[-1]), flush=True)
        table = cases(lib)
        for name in a.cases.split(","):
            if name not in table:
                print(json.dumps({"case": name, "skipped": "no input (shared data?)"}))
                continue
            sessions = await asyncio.get_running_loop().run_in_executor(None, table[name])
            for rep in range(a.repeat):
                row = await run_case(url, server, bystander, name, sessions)
                row["run"] = rep + 1
                row["alive"] = server.proc.poll() is None
                rows.append(row)
                print(json.dumps(row), flush=True)
                if not row["alive"]:
                    break
            if not rows[-1].get("alive", True):
                break
        bystander.running = False
        await asyncio.wait_for(task, 120)
    finally:
        server.stop()
        shutil.rmtree(tmp, ignore_errors=True)
    print()
    print("| case | run | answers: load s, frame s (render s) | RSS MiB before / peak / after "
          "| bystander frames, p50 / p99 / max ms |")
    print("|---|---|---|---|---|")
    for r in rows[1:]:
        ans = "; ".join(
            "%s %.1f%s" % (x["load"], x["load_s"] or 0,
                           ", %s %.1f%s" % (x["frame"], x["frame_s"],
                                            " (%.1f)" % (x["render_ms"] / 1000)
                                            if "render_ms" in x else "") if x["frame"] else "")
            for x in r["answers"])
        print("| %s | %d | %s | %d / %d / %d | %d, %s / %s / %s |" % (
            r["case"], r["run"], ans, r["rss_before_mib"], r["rss_peak_mib"], r["rss_after_mib"],
            r["bystander_frames"], r["bystander_p50_ms"], r["bystander_p99_ms"],
            r["bystander_max_ms"]))
    if a.json:
        with open(a.json, "w") as o:
            json.dump({"config": cfg, "rows": rows, "load": os.getloadavg()}, o, indent=1)
    return rows


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--vismapd", default=os.path.join(ROOT, "build", "server", "vismapd"))
    p.add_argument("--cases", default="deep_sexp,spheres,architecture,patches,loop,instances")
    p.add_argument("--time-limit", type=float, default=10)
    p.add_argument("--memory", default="2G")
    p.add_argument("--session-bytes", default="512M")
    p.add_argument("--renderers", type=int, default=1)
    p.add_argument("--repeat", type=int, default=1,
                   help="run each case this many times in a row (the first run of a case also "
                        "builds its kernels: PoCL's JIT memory stays)")
    p.add_argument("--json")
    a = p.parse_args()
    asyncio.run(main_async(a))


if __name__ == "__main__":
    sys.exit(main())
