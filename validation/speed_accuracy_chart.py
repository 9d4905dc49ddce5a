#!/usr/bin/env python3
"""Draws validation/report/speed_accuracy.png from the CSV side_by_side.py --accuracy writes: wall time
against relative tip error, log-log, each point labelled with its mesh and order, the Pareto front
(no run both faster and at least as accurate) drawn through its points.

With --fronts each code's own Pareto front is drawn too (a step line in its colour), beside the
front over all codes (black); --title, --xlabel and --ylabel name another problem's chart
(hole_speed_accuracy.py's plate with a hole).

Usage: speed_accuracy_chart.py CSV PNG [--fronts] [--title T] [--xlabel X] [--ylabel Y]
(needs matplotlib: the peers' venv has it).
"""

import argparse
import csv
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

COLOURS = {"tetfem": "#d62728", "tetfem curved": "#ff7f0e", "scikit-fem": "#1f77b4", "MFEM": "#2ca02c",
           "MFEM curved": "#9467bd"}
MARKERS = {1: "o", 2: "s"}
# Where each code's labels sit (offset in points, alignment): runs of the same mesh and order have
# the same error in every code, so their labels would overlap at one height.
LABELS = {"tetfem": ((-6, 6), "right"), "scikit-fem": ((6, -11), "left"), "MFEM": ((6, 5), "left"),
          "MFEM curved": ((6, 5), "left"), "tetfem curved": ((-6, -11), "right")}


def own_front(pts):
    """The code's own Pareto front: its runs that no other run of the same code beats in both time and
    error, by increasing time."""
    pts = sorted(pts, key=lambda r: float(r["seconds"]))
    front, best = [], float("inf")
    for r in pts:
        if float(r["relative_error"]) < best * (1 - 1e-9):
            front.append(r)
            best = float(r["relative_error"])
    return front


METHOD_MARKERS = {"backward-euler": "v", "newmark": "D"}
METHOD_NAMES = {"backward-euler": "BE", "newmark": "Newmark"}


def swing_chart(rows, out, header) -> None:
    """The swinging beam (dynamic_speed_accuracy.py's CSV): one line per code, order, mesh and
    method through its steps per period (32 ... 1024, faster to the left), labelled at its
    coarsest step; colour by code, marker by method, filled for P2."""
    fig, ax = plt.subplots(figsize=(12, 8), dpi=110)
    keys = sorted({(r["code"], r["order"], r["mesh"], r["method"]) for r in rows})
    for code, order, mesh, method in keys:
        pts = sorted((r for r in rows if (r["code"], r["order"], r["mesh"], r["method"]) == (code, order, mesh, method)),
                     key=lambda r: int(r["steps_per_period"]))
        xs = [float(r["seconds"]) for r in pts]
        ys = [float(r["relative_error"]) for r in pts]
        ax.plot(xs, ys, marker=METHOD_MARKERS[method], color=COLOURS[code], linewidth=0.9, markersize=6,
                markerfacecolor=COLOURS[code] if order == "2" else "white", alpha=0.85,
                label=f"{code} P{order} {mesh} {METHOD_NAMES[method]}")
        offset, align = LABELS[code]
        ax.annotate(f"P{order} {mesh} {METHOD_NAMES[method]}", (xs[0], ys[0]), textcoords="offset points",
                    xytext=offset, ha=align, fontsize=6.5, color=COLOURS[code])
    front = sorted((r for r in rows if r["pareto"] == "1"), key=lambda r: float(r["seconds"]))
    if front:
        ax.step([float(r["seconds"]) for r in front], [float(r["relative_error"]) for r in front], where="post",
                color="black", linestyle="--", linewidth=1.5, label="Pareto front, both codes (circled)")
        ax.scatter([float(r["seconds"]) for r in front], [float(r["relative_error"]) for r in front], s=150,
                   facecolors="none", edgecolors="black", linewidths=1.4, zorder=5)
    for target in (1e-1, 1e-2, 1e-3):
        ax.axhline(target, color="grey", linewidth=0.8, linestyle=":")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("wall time, static shape + matrices + factorization + loop over one period (s, one thread)")
    ax.set_ylabel("relative tip-trajectory error over one period (max over 32 samples)")
    ax.set_title("Swinging beam: speed against accuracy, tetfem beside scikit-fem (same meshes, M and K); "
                 "along each line 32, 64, ..., 1024 steps per period", fontsize=10)
    ax.grid(True, which="both", linewidth=0.3)
    ax.legend(loc="center left", bbox_to_anchor=(1.01, 0.5), fontsize=7)
    fig.text(0.01, 0.005, header[:180], fontsize=7, color="grey")
    fig.tight_layout(rect=(0, 0.02, 1, 1))
    fig.savefig(out)


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("csv")
    ap.add_argument("png")
    ap.add_argument("--fronts", action="store_true", help="draw each code's own Pareto front")
    ap.add_argument("--swing", action="store_true", help="the swinging beam's CSV (dynamic_speed_accuracy.py)")
    ap.add_argument("--title", default="Static cantilever: speed against accuracy, tetfem beside scikit-fem and "
                    "MFEM on identical meshes")
    ap.add_argument("--xlabel", default="wall time, mesh to displacement (s, one thread)")
    ap.add_argument("--ylabel", default="relative tip-deflection error (vs Richardson reference)")
    a = ap.parse_args()
    path, out = a.csv, a.png
    with open(path) as f:
        header = f.readline().lstrip("# ").strip()
        rows = list(csv.DictReader(f))
    if a.swing:
        swing_chart(rows, out, header)
        return 0
    fig, ax = plt.subplots(figsize=(14, 7.5), dpi=110)
    for code in COLOURS:
        for order in MARKERS:
            pts = [r for r in rows if r["code"] == code and int(r["order"]) == order]
            if not pts:
                continue
            xs = [float(r["seconds"]) for r in pts]
            ys = [float(r["relative_error"]) for r in pts]
            ax.plot(xs, ys, marker=MARKERS[order], color=COLOURS[code], linestyle="-", linewidth=1,
                    markersize=7, label=f"{code} P{order}" + (" (isoparametric: the hole curved)" if code.endswith(" curved") else ""),
                    alpha=0.9)
            for r, x, y in zip(pts, xs, ys):
                offset, align = LABELS[code]
                ax.annotate(f"{r['mesh']} P{order}", (x, y), textcoords="offset points", xytext=offset,
                            ha=align, fontsize=7, color=COLOURS[code])
    if a.fronts:
        for code in COLOURS:
            pts = own_front([r for r in rows if r["code"] == code])
            if pts:
                ax.step([float(r["seconds"]) for r in pts], [float(r["relative_error"]) for r in pts],
                        where="post", color=COLOURS[code], linestyle="--", linewidth=2.2, alpha=0.45,
                        label=f"{code}: its own front")
    front = sorted((r for r in rows if r["pareto"] == "1"), key=lambda r: float(r["seconds"]))
    if front:
        ax.step([float(r["seconds"]) for r in front], [float(r["relative_error"]) for r in front],
                where="post", color="black", linestyle="--", linewidth=1.5,
                label="Pareto front, all codes (circled)")
        ax.scatter([float(r["seconds"]) for r in front], [float(r["relative_error"]) for r in front],
                   s=160, facecolors="none", edgecolors="black", linewidths=1.5, zorder=5)
    for target in (1e-2, 1e-3):
        ax.axhline(target, color="grey", linewidth=0.8, linestyle=":")
    ax.set_xscale("log")
    ax.set_yscale("log")
    # Room on the right for the last points' labels, which are written to their right.
    ax.margins(x=0.1)
    ax.set_xlabel(a.xlabel)
    ax.set_ylabel(a.ylabel)
    ax.set_title(a.title, fontsize=11)
    ax.grid(True, which="both", linewidth=0.3)
    # Beside the axes, not on them: inside, the legend covered point labels.
    ax.legend(loc="center left", bbox_to_anchor=(1.01, 0.5), fontsize=9)
    fig.text(0.01, 0.005, header[:180], fontsize=7, color="grey")
    fig.tight_layout(rect=(0, 0.02, 1, 1))
    fig.savefig(out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
