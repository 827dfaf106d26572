#!/usr/bin/env python3
"""Fits and plots the accuracy sweep (bench/accuracy_sweep.py's CSV). Not a test.

Fits mean relative error = a * m_P^-b and p99 = c * m_P^-d by least squares in log-log over all
rows, prints the constants (core/graph/proximity_graph.cpp's graph_size_for_error uses them), and
writes an SVG plot of mean error against m_P, one line per (mesh, n_P).

Usage: bench/accuracy_plot.py docs/accuracy.csv docs/accuracy.svg
Standard library only (the SVG is written by hand).
"""
import csv
import math
import sys


def fit(xs, ys):
    """Least squares of log y = log a - b log x; returns (a, b)."""
    lx = [math.log(x) for x in xs]
    ly = [math.log(y) for y in ys]
    n = len(lx)
    mx, my = sum(lx) / n, sum(ly) / n
    sxx = sum((x - mx) ** 2 for x in lx)
    sxy = sum((x - mx) * (y - my) for x, y in zip(lx, ly))
    slope = sxy / sxx
    return math.exp(my - slope * mx), -slope


def main() -> int:
    if len(sys.argv) != 3:
        print(__doc__, file=sys.stderr)
        return 1
    with open(sys.argv[1]) as f:
        rows = list(csv.DictReader(f))
    m = [float(r["neighbors"]) for r in rows]
    a, b = fit(m, [float(r["mean"]) for r in rows])
    c, d = fit(m, [float(r["p99"]) for r in rows])
    worst = max(float(r["max"]) / float(r["mean"]) for r in rows)
    print(f"mean = {a:.4g} * m_P^-{b:.4g}")
    print(f"p99  = {c:.4g} * m_P^-{d:.4g}")
    print(f"max/mean ratio over all runs: up to {worst:.2f}")

    # Plot: x = m_P (linear), y = mean error in % (log).
    width, height, left, right, top, bottom = 640, 420, 70, 190, 30, 50
    xs = sorted({float(r["neighbors"]) for r in rows})
    ys = [100 * float(r["mean"]) for r in rows]
    x0, x1 = min(xs) - 1, max(xs) + 1
    y0, y1 = math.log10(min(ys) * 0.8), math.log10(max(ys) * 1.2)

    def px(x):
        return left + (x - x0) / (x1 - x0) * (width - left - right)

    def py(y):
        return top + (y1 - math.log10(y)) / (y1 - y0) * (height - top - bottom)

    colors = ["#1b9e77", "#d95f02", "#7570b3", "#e7298a", "#66a61e", "#e6ab02", "#a6761d",
              "#666666", "#1f78b4"]
    series = {}
    for r in rows:
        series.setdefault((r["mesh"], int(r["samples"])), []).append(
            (float(r["neighbors"]), 100 * float(r["mean"])))
    out = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" '
           f'font-family="sans-serif" font-size="12">',
           f'<rect width="{width}" height="{height}" fill="white"/>',
           f'<text x="{left}" y="18">Mean relative error of graph distances vs m_P '
           f'(m_st = 2 m_P)</text>']
    for tick in [0.1, 0.2, 0.5, 1, 2, 5, 10]:
        if y0 <= math.log10(tick) <= y1:
            y = py(tick)
            out.append(f'<line x1="{left}" y1="{y:.1f}" x2="{width - right}" y2="{y:.1f}" '
                       f'stroke="#ddd"/><text x="{left - 8}" y="{y + 4:.1f}" '
                       f'text-anchor="end">{tick}%</text>')
    for x in xs:
        out.append(f'<text x="{px(x):.1f}" y="{height - bottom + 18}" '
                   f'text-anchor="middle">{int(x)}</text>')
    out.append(f'<text x="{(left + width - right) / 2}" y="{height - 10}" '
               f'text-anchor="middle">m_P (neighbours per sample)</text>')
    out.append(f'<rect x="{left}" y="{top}" width="{width - left - right}" '
               f'height="{height - top - bottom}" fill="none" stroke="black"/>')
    # The fit.
    pts = " ".join(f"{px(x):.1f},{py(100 * a * x ** -b):.1f}"
                   for x in [x0 + 0.5 + i * (x1 - x0 - 1) / 40 for i in range(41)])
    out.append(f'<polyline points="{pts}" fill="none" stroke="black" stroke-dasharray="5,4"/>')
    for i, ((mesh, samples), pts_) in enumerate(sorted(series.items())):
        color = colors[i % len(colors)]
        pts_.sort()
        poly = " ".join(f"{px(x):.1f},{py(y):.1f}" for x, y in pts_)
        out.append(f'<polyline points="{poly}" fill="none" stroke="{color}" stroke-width="1.5"/>')
        for x, y in pts_:
            out.append(f'<circle cx="{px(x):.1f}" cy="{py(y):.1f}" r="2.5" fill="{color}"/>')
        ly = top + 14 + 16 * i
        out.append(f'<line x1="{width - right + 10}" y1="{ly - 4}" x2="{width - right + 30}" '
                   f'y2="{ly - 4}" stroke="{color}" stroke-width="2"/>'
                   f'<text x="{width - right + 35}" y="{ly}">{mesh} n_P={samples}</text>')
    ly = top + 14 + 16 * len(series)
    out.append(f'<line x1="{width - right + 10}" y1="{ly - 4}" x2="{width - right + 30}" '
               f'y2="{ly - 4}" stroke="black" stroke-dasharray="5,4"/>'
               f'<text x="{width - right + 35}" y="{ly}">fit {100 * a:.0f}% m_P^-{b:.2f}</text>')
    out.append("</svg>")
    with open(sys.argv[2], "w") as f:
        f.write("\n".join(out) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
