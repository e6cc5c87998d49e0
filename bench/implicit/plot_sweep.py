"""Plots bench/implicit/implicit_sweep.cpp's CSVs (docs/IMPLICIT.md "3D"): the measured error and
the pixel error against the tolerance, and the warm frame and tessellation times, one series per
file.
  python3 bench/implicit/plot_sweep.py OUT_DIR A.csv B.csv ..."""
import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))
import svgplot  # noqa: E402

out = sys.argv[1]
runs = svgplot.read_runs(sys.argv[2:])
err, time = [], []
for name, rows in runs:
    tol = [float(r["tolerance_px"]) for r in rows]
    err.append((name + " largest |f|/|grad f|", list(zip(tol, [float(r["max_error_px"]) for r in rows])), "line"))
    time.append((name + " frame", list(zip(tol, [float(r["frame_ms"]) for r in rows])), "line"))
    time.append((name + " tessellate", list(zip(tol, [float(r["tessellate_ms"]) for r in rows])), "dashed"))
err.append(("tolerance (the bound)", [(t, t) for t in (4.0, 16.0)], "dashed"))
svgplot.line_plot(os.path.join(out, "implicit_error.svg"),
                  "Implicit surfaces: measured error against the tolerance (1024x1024)",
                  "tolerance (px)", "largest vertex distance (px)", err, logx=True, logy=True)
svgplot.line_plot(os.path.join(out, "implicit_time.svg"),
                  "Implicit surfaces: warm time against the tolerance (PoCL, 2 cores)",
                  "tolerance (px)", "ms", time, logx=True, logy=True)
