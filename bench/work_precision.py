#!/usr/bin/env python3
"""Work-precision diagram of the blmd integrators (docs/performance.md §7).

Reads the JSON of
    build/bin/blmd_bench --benchmark_filter=BM_BlmdWorkPrecision --benchmark_repetitions=5 \
        --benchmark_report_aggregates_only=true --benchmark_format=json > wp.json
and writes an SVG (log-log: relative RMS error of the phase current, and of the speed,
against the median CPU time of the 160 ms run) and prints the Markdown table of
docs/performance.md §7. Standard library only.

    bench/work_precision.py wp.json docs/figures/work-precision.svg
"""
import json
import math
import sys


def rows(path):
    with open(path) as f:
        data = json.load(f)
    out = []
    for b in data["benchmarks"]:
        if b.get("aggregate_name") != "median":
            continue
        name = b["run_name"]  # BM_BlmdWorkPrecision/events:1/step_ns:25000
        fields = dict(p.split(":") for p in name.split("/")[1:])
        out.append({
            "events": fields["events"] == "1",
            "step_ns": int(fields["step_ns"]),
            "ms": b["cpu_time"],
            "err_i": b["err_i"],
            "err_w": b["err_w"],
            "err_i_x": b.get("err_i_x", float("nan")),
            "err_w_x": b.get("err_w_x", float("nan")),
        })
    return out


def table(data):
    fixed_1us = next(r for r in data if not r["events"] and r["step_ns"] == 1000)
    print("| method | step | CPU time per 160 ms run (median) | vs fixed 1 µs | error i (rel. RMS) | error w (rel. RMS) | i vs extrapolated | w vs extrapolated |")
    print("|---|---|---|---|---|---|---|---|")
    for r in data:
        step = (f"max_step = {r['step_ns'] / 1000:g} µs" if r["events"]
                else f"dt = {r['step_ns'] / 1000:g} µs")
        print(f"| {'events' if r['events'] else 'fixed_euler'} | {step} | {r['ms']:.3g} ms | "
              f"{fixed_1us['ms'] / r['ms']:.2f}× | {r['err_i']:.3g} | {r['err_w']:.3g} | "
              f"{r['err_i_x']:.3g} | {r['err_w_x']:.3g} |")


def svg(data, path):
    width, height, margin = 720, 360, 60
    panels = [("err_i", "relative RMS error of i"), ("err_w", "relative RMS error of w")]
    times = [r["ms"] for r in data]
    t_lo, t_hi = math.log10(min(times)) - 0.2, math.log10(max(times)) + 0.2
    parts = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" '
             'font-family="sans-serif" font-size="11">',
             '<rect width="100%" height="100%" fill="white"/>']
    panel_w = (width - 2 * margin) / 2 - 20
    for p, (key, label) in enumerate(panels):
        x0 = margin + p * (panel_w + 60)
        y0, y1 = margin - 30, height - margin
        errs = [r[key] for r in data]
        e_lo, e_hi = math.log10(min(errs)) - 0.3, math.log10(max(errs)) + 0.3

        def X(ms):
            return x0 + (math.log10(ms) - t_lo) / (t_hi - t_lo) * panel_w

        def Y(e):
            return y1 - (math.log10(e) - e_lo) / (e_hi - e_lo) * (y1 - y0)

        parts.append(f'<rect x="{x0}" y="{y0}" width="{panel_w}" height="{y1 - y0}" '
                     'fill="none" stroke="black"/>')
        for d in range(math.ceil(t_lo), math.floor(t_hi) + 1):
            parts.append(f'<text x="{X(10 ** d)}" y="{y1 + 14}" text-anchor="middle">'
                         f'{10 ** d:g} ms</text>')
            parts.append(f'<line x1="{X(10 ** d)}" y1="{y0}" x2="{X(10 ** d)}" y2="{y1}" '
                         'stroke="#ddd"/>')
        for d in range(math.ceil(e_lo), math.floor(e_hi) + 1):
            parts.append(f'<text x="{x0 - 4}" y="{Y(10 ** d) + 4}" text-anchor="end">1e{d}</text>')
            parts.append(f'<line x1="{x0}" y1="{Y(10 ** d)}" x2="{x0 + panel_w}" '
                         f'y2="{Y(10 ** d)}" stroke="#ddd"/>')
        parts.append(f'<text x="{x0 + panel_w / 2}" y="{y1 + 30}" text-anchor="middle">'
                     f'CPU time of the 160 ms run</text>')
        parts.append(f'<text x="{x0 + panel_w / 2}" y="{y0 - 8}" text-anchor="middle">'
                     f'{label}</text>')
        for events, colour in ((False, "#c0392b"), (True, "#2471a3")):
            pts = sorted((r for r in data if r["events"] == events), key=lambda r: r["ms"])
            path_d = " ".join(f"{X(r['ms']):.1f},{Y(r[key]):.1f}" for r in pts)
            parts.append(f'<polyline points="{path_d}" fill="none" stroke="{colour}"/>')
            for r in pts:
                parts.append(f'<circle cx="{X(r["ms"]):.1f}" cy="{Y(r[key]):.1f}" r="3" '
                             f'fill="{colour}"/>')
                tag = f"{r['step_ns'] / 1000:g}"
                parts.append(f'<text x="{X(r["ms"]) + 5:.1f}" y="{Y(r[key]) - 5:.1f}" '
                             f'fill="{colour}" font-size="9">{tag}</text>')
    parts.append(f'<text x="{margin}" y="{height - 8}" fill="#c0392b">fixed_euler (labels: dt, µs)'
                 '</text>')
    parts.append(f'<text x="{margin + 260}" y="{height - 8}" fill="#2471a3">events (labels: '
                 'max_step, µs)</text>')
    parts.append("</svg>")
    with open(path, "w") as f:
        f.write("\n".join(parts) + "\n")


if __name__ == "__main__":
    data = rows(sys.argv[1])
    table(data)
    if len(sys.argv) > 2:
        svg(data, sys.argv[2])
