#!/usr/bin/env python3
"""Draws validation/report/speed_accuracy.png from the CSV side_by_side.py --accuracy writes: wall time
against relative tip error, log-log, each point labelled with its mesh and order, the Pareto front
(no run both faster and at least as accurate) drawn through its points.

Usage: speed_accuracy_chart.py CSV PNG (needs matplotlib: the peers' venv has it).
"""

import csv
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

COLOURS = {"tetfem": "#d62728", "scikit-fem": "#1f77b4", "MFEM": "#2ca02c"}
MARKERS = {1: "o", 2: "s"}
# Where each code's labels sit (offset in points, alignment): runs of the same mesh and order have
# the same error in every code, so their labels would overlap at one height.
LABELS = {"tetfem": ((-6, 6), "right"), "scikit-fem": ((6, -11), "left"), "MFEM": ((6, 5), "left")}


def main() -> int:
    path, out = sys.argv[1], sys.argv[2]
    with open(path) as f:
        header = f.readline().lstrip("# ").strip()
        rows = list(csv.DictReader(f))
    fig, ax = plt.subplots(figsize=(11, 7.5), dpi=110)
    for code in COLOURS:
        for order in MARKERS:
            pts = [r for r in rows if r["code"] == code and int(r["order"]) == order]
            if not pts:
                continue
            xs = [float(r["seconds"]) for r in pts]
            ys = [float(r["relative_error"]) for r in pts]
            ax.plot(xs, ys, marker=MARKERS[order], color=COLOURS[code], linestyle="-", linewidth=1,
                    markersize=7, label=f"{code} P{order}", alpha=0.9)
            for r, x, y in zip(pts, xs, ys):
                offset, align = LABELS[code]
                ax.annotate(f"{r['mesh']} P{order}", (x, y), textcoords="offset points", xytext=offset,
                            ha=align, fontsize=7, color=COLOURS[code])
    front = sorted((r for r in rows if r["pareto"] == "1"), key=lambda r: float(r["seconds"]))
    if front:
        ax.step([float(r["seconds"]) for r in front], [float(r["relative_error"]) for r in front],
                where="post", color="black", linestyle="--", linewidth=1.5, label="Pareto front")
        ax.scatter([float(r["seconds"]) for r in front], [float(r["relative_error"]) for r in front],
                   s=160, facecolors="none", edgecolors="black", linewidths=1.5, zorder=5)
    for target in (1e-2, 1e-3):
        ax.axhline(target, color="grey", linewidth=0.8, linestyle=":")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("wall time, mesh to displacement (s, one thread)")
    ax.set_ylabel("relative tip-deflection error (vs Richardson reference)")
    ax.set_title("Static cantilever: speed against accuracy, tetfem beside scikit-fem and MFEM on identical meshes",
                 fontsize=11)
    ax.grid(True, which="both", linewidth=0.3)
    ax.legend(loc="lower left", fontsize=9)
    fig.text(0.01, 0.005, header[:180], fontsize=7, color="grey")
    fig.tight_layout(rect=(0, 0.02, 1, 1))
    fig.savefig(out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
