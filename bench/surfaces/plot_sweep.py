"""Plots bench/surfaces/patch_sweep.cpp's CSVs (docs/SURFACES.md): largest measured error and
warm frame time against the tolerance, one series per file.
  python3 bench/surfaces/plot_sweep.py OUT_DIR A.csv B.csv ..."""
import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))
import svgplot  # noqa: E402

out = sys.argv[1]
runs = svgplot.read_runs(sys.argv[2:])
err, frame, tess = [], [], []
for name, rows in runs:
    err.append((name + " largest error", [(float(r["tolerance_px"]), float(r["max_error_px"])) for r in rows], "line"))
    frame.append((name + " frame", [(float(r["tolerance_px"]), float(r["frame_ms"])) for r in rows], "line"))
    tess.append((name + " tessellate", [(float(r["tolerance_px"]), float(r["tessellate_ms"])) for r in rows], "dashed"))
err.append(("tolerance", [(t, t) for t in (0.1, 4.0)], "dashed"))
svgplot.line_plot(os.path.join(out, "patch_error.svg"), "Bezier patches: measured error against the tolerance (1024x1024)",
                  "tolerance (px)", "largest screen error (px)", err, logx=True, logy=True)
svgplot.line_plot(os.path.join(out, "patch_time.svg"), "Bezier patches: warm time against the tolerance (PoCL, 2 cores)",
                  "tolerance (px)", "ms", frame + tess, logx=True, logy=True)
