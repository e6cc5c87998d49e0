"""Tiny SVG plots for bench/run.sh (no matplotlib here): line/scatter plots with linear or log
axes, and horizontal stacked bars. Plain standard library; output is a self-contained SVG."""

import csv
import math
import os
from xml.sax.saxutils import escape

COLORS = ["#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2",
          "#7f7f7f", "#bcbd22", "#17becf", "#393b79", "#637939"]


def read_runs(paths):
    """CSV files as (name, rows): the file's base name without extension, its rows as dicts."""
    runs = []
    for path in paths:
        with open(path) as f:
            runs.append((os.path.splitext(os.path.basename(path))[0], list(csv.DictReader(f))))
    return runs


def _ticks(lo, hi, log):
    if log:
        a, b = math.floor(math.log10(lo)), math.ceil(math.log10(hi))
        ticks = []
        for e in range(a, b + 1):
            for m in (1, 2, 5):
                v = m * 10 ** e
                if lo <= v <= hi:
                    ticks.append(v)
        return ticks
    span = hi - lo
    step = 10 ** math.floor(math.log10(span / 5)) if span > 0 else 1
    for m in (1, 2, 5, 10):
        if span / (step * m) <= 6:
            step *= m
            break
    start = math.ceil(lo / step) * step
    return [start + i * step for i in range(int((hi - start) / step) + 1)]


def _fmt(v):
    if v == 0:
        return "0"
    a = abs(v)
    if a >= 1e6:
        return f"{v / 1e6:g}M"
    if a >= 1e3:
        return f"{v / 1e3:g}k"
    return f"{v:g}"


def line_plot(path, title, xlabel, ylabel, series, logx=False, logy=False, width=880, height=440):
    """series: list of (label, [(x, y), ...], style) with style 'line', 'dashed' or 'points'."""
    pts = [(x, y) for _, s, _ in series for x, y in s if x is not None and y is not None
           and (not logx or x > 0) and (not logy or y > 0)]
    if not pts:
        return False
    xs, ys = [p[0] for p in pts], [p[1] for p in pts]
    x0, x1, y0, y1 = min(xs), max(xs), min(ys), max(ys)
    if logx:
        x0, x1 = x0 / 1.3, x1 * 1.3
    else:
        pad = (x1 - x0) * 0.05 or 1
        x0, x1 = x0 - pad, x1 + pad
    if logy:
        y0, y1 = y0 / 1.5, y1 * 1.5
    else:
        y0, y1 = 0 if y0 >= 0 else y0 * 1.1, y1 * 1.1 or 1
    L, R, T, B = 80, 300, 40, 60
    pw, ph = width - L - R, height - T - B

    def fx(x):
        t = (math.log10(x) - math.log10(x0)) / (math.log10(x1) - math.log10(x0)) if logx else (x - x0) / (x1 - x0)
        return L + t * pw

    def fy(y):
        t = (math.log10(y) - math.log10(y0)) / (math.log10(y1) - math.log10(y0)) if logy else (y - y0) / (y1 - y0)
        return T + ph - t * ph

    o = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" '
         f'font-family="sans-serif" font-size="12">',
         f'<rect width="{width}" height="{height}" fill="white"/>',
         f'<text x="{L + pw / 2}" y="22" text-anchor="middle" font-size="15">{escape(title)}</text>']
    for v in _ticks(x0, x1, logx):
        X = fx(v)
        o.append(f'<line x1="{X:.1f}" y1="{T}" x2="{X:.1f}" y2="{T + ph}" stroke="#ddd"/>')
        o.append(f'<text x="{X:.1f}" y="{T + ph + 16}" text-anchor="middle">{_fmt(v)}</text>')
    for v in _ticks(y0, y1, logy):
        Y = fy(v)
        o.append(f'<line x1="{L}" y1="{Y:.1f}" x2="{L + pw}" y2="{Y:.1f}" stroke="#ddd"/>')
        o.append(f'<text x="{L - 6}" y="{Y + 4:.1f}" text-anchor="end">{_fmt(v)}</text>')
    o.append(f'<rect x="{L}" y="{T}" width="{pw}" height="{ph}" fill="none" stroke="black"/>')
    o.append(f'<text x="{L + pw / 2}" y="{height - 18}" text-anchor="middle">{escape(xlabel)}'
             f'{" (log)" if logx else ""}</text>')
    o.append(f'<text transform="translate(18,{T + ph / 2}) rotate(-90)" text-anchor="middle">'
             f'{escape(ylabel)}{" (log)" if logy else ""}</text>')
    for i, (label, s, style) in enumerate(series):
        c = COLORS[i % len(COLORS)]
        s = sorted((x, y) for x, y in s if x is not None and y is not None
                   and (not logx or x > 0) and (not logy or y > 0))
        if not s:
            continue
        if style in ("line", "dashed") and len(s) > 1:
            d = " ".join(f"{fx(x):.1f},{fy(y):.1f}" for x, y in s)
            dash = ' stroke-dasharray="7,4"' if style == "dashed" else ""
            o.append(f'<polyline points="{d}" fill="none" stroke="{c}" stroke-width="2"{dash}/>')
        for x, y in s:
            o.append(f'<circle cx="{fx(x):.1f}" cy="{fy(y):.1f}" r="3.5" fill="{c}">'
                     f'<title>{escape(label)}: {_fmt(x)}, {y:.4g}</title></circle>')
        ly = T + 14 + 18 * i
        o.append(f'<rect x="{L + pw + 12}" y="{ly - 9}" width="12" height="10" fill="{c}"/>')
        o.append(f'<text x="{L + pw + 30}" y="{ly}">{escape(label)}</text>')
    o.append("</svg>")
    with open(path, "w") as f:
        f.write("\n".join(o) + "\n")
    return True


def stacked_bars(path, title, xlabel, rows, parts, width=860, row_h=24, normalize=False):
    """rows: list of (label, {part: value}); parts: the order of the stacked parts. normalize:
    every bar is 100% (shares)."""
    if not rows:
        return False
    if normalize:
        rows = [(lab, {p: 100.0 * v.get(p, 0) / (sum(v.get(q, 0) for q in parts) or 1) for p in parts})
                for lab, v in rows]
    L, R, T = 190, 30, 80
    height = T + row_h * len(rows) + 50
    pw = width - L - R
    vmax = max(sum(v.get(p, 0) for p in parts) for _, v in rows) or 1
    o = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" '
         f'font-family="sans-serif" font-size="12">',
         f'<rect width="{width}" height="{height}" fill="white"/>',
         f'<text x="{width / 2}" y="20" text-anchor="middle" font-size="15">{escape(title)}</text>']
    x = L
    for i, p in enumerate(parts):  # legend
        c = COLORS[i % len(COLORS)]
        if x + 16 + 8 * len(p) > width:
            x = L
        ly = 32 if i < (len(parts) + 1) // 2 else 52
        if i == (len(parts) + 1) // 2:
            x = L
        o.append(f'<rect x="{x}" y="{ly}" width="12" height="10" fill="{c}"/>'
                 f'<text x="{x + 16}" y="{ly + 9}">{escape(p)}</text>')
        x += 16 + 8 * len(p) + 14
    for r, (label, v) in enumerate(rows):
        y = T + r * row_h
        o.append(f'<text x="{L - 6}" y="{y + row_h * 0.65:.1f}" text-anchor="end">{escape(label)}</text>')
        x = L
        for i, p in enumerate(parts):
            w = pw * v.get(p, 0) / vmax
            if w > 0:
                o.append(f'<rect x="{x:.1f}" y="{y + 3}" width="{w:.1f}" height="{row_h - 6}" '
                         f'fill="{COLORS[i % len(COLORS)]}"><title>{escape(label)} {escape(p)}: '
                         f'{v.get(p, 0):.4g}</title></rect>')
            x += w
    y = T + row_h * len(rows) + 20
    o.append(f'<text x="{L + pw / 2}" y="{y + 16}" text-anchor="middle">{escape(xlabel)} '
             f'(full bar = {vmax:.4g})</text>')
    o.append("</svg>")
    with open(path, "w") as f:
        f.write("\n".join(o) + "\n")
    return True
