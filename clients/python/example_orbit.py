#!/usr/bin/env python3
"""Orbits the camera around a scene on a running vismapd and prints per-frame stats.

    python3 clients/python/example_orbit.py --url ws://127.0.0.1:8080/ --scene data/bunny.ply --frames 36
"""
import argparse
import asyncio
import math
import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import vismap_client as vc  # noqa: E402


async def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--url", default="ws://127.0.0.1:8080/")
    ap.add_argument("--scene", help="scene file to upload")
    ap.add_argument("--library", help="scene name in the server's library")
    ap.add_argument("--frames", type=int, default=36)
    ap.add_argument("--format", choices=["svg", "bin", "compact"], default="bin")
    ap.add_argument("--out", help="folder for the SVG frames")
    a = ap.parse_args()
    async with vc.Session(a.url, fmt=a.format, attributes=a.format == "bin") as s:
        if a.scene:
            ready = await s.upload(os.path.basename(a.scene), open(a.scene, "rb").read())
        else:
            ready = await s.library(a.library)
        print(f"{ready['name']}: {ready['triangles']} triangles")
        cam = ready["camera"]
        t, e = cam["target"], cam["eye"]
        dx, dz = e[0] - t[0], e[2] - t[2]
        if a.out:
            os.makedirs(a.out, exist_ok=True)
        t0 = time.perf_counter()
        for i in range(a.frames):
            ang = 2 * math.pi * i / a.frames
            eye = [t[0] + dx * math.cos(ang) + dz * math.sin(ang), e[1], t[2] - dx * math.sin(ang) + dz * math.cos(ang)]
            header, frame = await s.frame(eye=eye)
            n = header["fragments"] if a.format == "svg" else frame.triangle_count
            print(f"frame {header['seq']}: {header['render_ms']:.1f} ms render, {header['bytes']} bytes, {n} triangles/fragments")
            if a.out and a.format == "svg":
                with open(os.path.join(a.out, f"frame_{i:04d}.svg"), "w") as f:
                    f.write(frame)
        dt = time.perf_counter() - t0
        print(f"{a.frames / dt:.1f} fps")


if __name__ == "__main__":
    asyncio.run(main())
