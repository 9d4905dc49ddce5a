#!/usr/bin/env python3
"""The broad phase's cost against surface size (issue 36): the three timings of
benches/self_contact.rs (the hierarchy over the triangles, the candidate pairs within d̂, and
the barrier's active pairs after the exact distances) at 1,536, 6,144 and 24,576 surface
triangles, each against an n·log n line through its smallest size.

Runs `cargo bench --bench self_contact` (about a minute) unless --no-run, reads criterion's
median of each timing (target/criterion/self_contact/<timing>/<size>/new/estimates.json),
writes validation/broad_phase.csv and draws validation/broad_phase_chart.png (log–log: time
against triangles; a timing at or below its n·log n line grows no faster than n log n).

Usage: python3 validation/broad_phase_chart.py [--no-run]
"""

import argparse
import csv
import json
import math
import pathlib
import re
import subprocess
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

HERE = pathlib.Path(__file__).resolve().parent
ROOT = HERE.parent
CRITERION = ROOT / "target" / "criterion" / "self_contact"
TIMINGS = {
    "bvh_build": "hierarchy over the triangles",
    "candidates": "candidate pairs within d̂ (two hierarchies, every vertex and edge queried)",
    "active_pairs": "active pairs (candidates + exact distances)",
}


def measured() -> list:
    """(timing, triangles, candidates, median seconds) of every benchmark criterion stored."""
    rows = []
    for timing in TIMINGS:
        for size in sorted((CRITERION / timing).glob("*triangles*")):
            numbers = [int(s) for s in re.findall(r"\d+", size.name)]
            with open(size / "new" / "estimates.json") as f:
                median = json.load(f)["median"]["point_estimate"] * 1e-9
            rows.append((timing, numbers[0], numbers[1], median))
    return sorted(rows)


def chart(rows: list, path: pathlib.Path) -> None:
    fig, ax = plt.subplots(figsize=(7.5, 5.0))
    for (timing, label), colour in zip(TIMINGS.items(), ["tab:blue", "tab:orange", "tab:green"]):
        points = sorted((n, t) for name, n, _, t in rows if name == timing)
        n = [p[0] for p in points]
        t = [p[1] * 1e3 for p in points]
        ax.plot(n, t, "o-", color=colour, label=label)
        reference = [t[0] * (m * math.log(m)) / (n[0] * math.log(n[0])) for m in n]
        ax.plot(n, reference, ":", color=colour, label="n·log n through its first point")
    ax.set_xscale("log")
    ax.set_yscale("log")
    # Room above the data for the legend, so that it hides none of the lines.
    times = [t * 1e3 for _, _, _, t in rows]
    ax.set_ylim(min(times) / 2, max(times) * 60)
    sizes = sorted({n for _, n, _, _ in rows})
    ax.set_xticks(sizes, [f"{n:,}" for n in sizes])
    ax.minorticks_off()
    ax.set_xlabel("surface triangles (two blocks)")
    ax.set_ylabel("median wall time (ms)")
    ax.set_title("Body–body contact: broad phase cost against surface size")
    ax.grid(True, which="major", alpha=0.3)
    ax.legend(fontsize=8, loc="upper left")
    fig.tight_layout()
    fig.savefig(path, dpi=120)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--no-run", action="store_true", help="read criterion's last results")
    args = parser.parse_args()
    if not args.no_run:
        subprocess.run(
            ["cargo", "bench", "--bench", "self_contact", "--", "--noplot"], cwd=ROOT, check=True
        )
    rows = measured()
    if not rows:
        print(f"no results under {CRITERION}", file=sys.stderr)
        return 1
    with open(HERE / "broad_phase.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["timing", "triangles", "candidate_pairs", "median_s", "ratio_to_previous", "n_log_n_ratio"])
        previous = {}
        for timing, n, k, t in rows:
            ratio = nlogn = ""
            if timing in previous:
                m, s = previous[timing]
                ratio = f"{t / s:.3f}"
                nlogn = f"{n * math.log(n) / (m * math.log(m)):.3f}"
            w.writerow([timing, n, k, f"{t:.6e}", ratio, nlogn])
            previous[timing] = (n, t)
    chart(rows, HERE / "broad_phase_chart.png")
    return 0


if __name__ == "__main__":
    sys.exit(main())
