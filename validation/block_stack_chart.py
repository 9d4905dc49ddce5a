#!/usr/bin/env python3
"""The block stack's chart (issue 36): per-step wall time and smallest surface distance of the
shipped 8-block stack, scenes/block_stack.toml, against simulated time.

Runs the release binary on the scene (or reads a CSV it wrote, --csv), keeps the columns it
plots in validation/block_stack.csv and draws validation/block_stack_chart.png:
top, the wall time of each step (s), with the machine's load average as `uptime` gave it
(--load; the wall times scale with it, the iterations do not); bottom, the smallest distance
between surface primitives of different blocks within d̂ (mm), with d̂ as a line. Steps with no
pair within d̂ (the CSV's inf) are left out of the bottom panel and counted in its legend.

Usage: python3 validation/block_stack_chart.py [--binary target/release/tetfem] [--csv FILE]
       [--load "5.2"]
"""

import argparse
import csv
import math
import pathlib
import subprocess
import sys
import tempfile

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

HERE = pathlib.Path(__file__).resolve().parent
SCENE = HERE.parent / "scenes" / "block_stack.toml"
D_HAT = 1e-3  # the scene's [self_contact] distance (m)


def run_scene(binary: pathlib.Path) -> list:
    with tempfile.TemporaryDirectory() as out:
        subprocess.run([str(binary), "run", str(SCENE), "--out", out, "-q"], check=True)
        return read(pathlib.Path(out) / "block_stack.csv")


def read(path: pathlib.Path) -> list:
    with open(path) as f:
        return list(csv.DictReader(f))


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--binary", default=str(HERE.parent / "target/release/tetfem"))
    parser.add_argument("--csv", help="a CSV the scene's run wrote, instead of running it")
    parser.add_argument("--load", help="the load average during the run, for the title")
    args = parser.parse_args()
    rows = read(pathlib.Path(args.csv)) if args.csv else run_scene(pathlib.Path(args.binary))
    rows = [r for r in rows if int(r["step"]) > 0]
    keep = ["time_s", "step", "wall_seconds_per_step", "min_surface_distance_m", "contact_ground_fz_N"]
    with open(HERE / "block_stack.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(keep)
        for r in rows:
            w.writerow([r[k] for k in keep])
    t = [float(r["time_s"]) for r in rows]
    wall = [float(r["wall_seconds_per_step"]) for r in rows]
    dist = [float(r["min_surface_distance_m"]) for r in rows]
    near = [(ti, d) for ti, d in zip(t, dist) if math.isfinite(d)]
    far = len(dist) - len(near)
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(7, 6), sharex=True)
    top.plot(t, wall, "o-", ms=3, label=f"wall time per step ({len(wall)} steps, mean {sum(wall) / len(wall):.3f} s)")
    top.set_ylabel("wall time per step (s)")
    top.set_ylim(bottom=0)
    top.legend()
    load = f", load average {args.load} on 2 cores" if args.load else ""
    top.set_title(f"Eight soft blocks settling (13,608 DOFs, backward Euler, dt = 0.01 s)\n"
                  f"scenes/block_stack.toml{load}", fontsize=10)
    bottom.plot([ti for ti, _ in near], [d * 1e3 for _, d in near], "s-", ms=3,
                label=f"smallest surface distance ({len(near)} steps; {far} with no pair within d̂)")
    bottom.axhline(D_HAT * 1e3, color="grey", ls="--", label="d̂ = 1 mm (barrier reach)")
    bottom.set_ylabel("smallest distance (mm)")
    bottom.set_xlabel("simulated time (s)")
    bottom.set_ylim(bottom=0)
    bottom.legend()
    fig.tight_layout()
    fig.savefig(HERE / "block_stack_chart.png", dpi=120)
    print(f"{len(rows)} steps; wrote {HERE / 'block_stack_chart.png'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
