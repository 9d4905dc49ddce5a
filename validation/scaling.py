#!/usr/bin/env python3
"""Measures the PETSc engine on 1 and 2 MPI ranks for validation/SCALING.md.

Runs `mpirun -n R target/release/tetfem-petsc` (CG + GAMG, the engine's default) on
scenes/cantilever_static.toml at each size of `--cells`, with `png = false` (and at the sizes of
`--others` also CG + BoomerAMG and MUMPS's Cholesky), and compares every
displacement with tetfem's single-process Cholesky (the `compare_direct` example). Writes
validation/report/scaling.csv, one row per (size, ranks), headed by a comment line with the date,
commit, machine, load average and the PETSc and MPI the engine was built against;
`python3 docs/figures.py scaling` renders SCALING.md's tables from that CSV.

Needs the engine and the example built first (Debian's petsc-dev installed):

    cargo build --release -p tetfem-petsc --features petsc --bins --examples
    python3 validation/scaling.py                       # 3k to 452k DOFs and the others at 140k, ~15 min
    python3 validation/scaling.py --cells 40x4x4,80x8x8 # a quick look

Times are the engine's own phase times (max over ranks); memory is each rank's peak resident set
(VmHWM). On a shared machine times are pessimistic and noisy, iterations, residuals, agreement
and memory are not: the CSV records the load average before and after the runs.
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import re
import subprocess
import sys
import tempfile
from datetime import datetime, timezone

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
RELEASE = os.path.join(ROOT, "target", "release")
SCENE = os.path.join(ROOT, "scenes", "cantilever_static.toml")
CSV = os.path.join(ROOT, "validation", "report", "scaling.csv")
PHASES = ("build", "partition", "assembly", "constraints", "setup", "solve")
COLUMNS = ["cells", "dofs", "solver", "ranks", "iterations", "relative_residual", "vs_direct", *PHASES,
           "peak_mb_per_rank", "direct_seconds", "direct_peak_mb"]


def scene_with_cells(cells: str, folder: str) -> str:
    """The cantilever scene with `cells` = NxMxK and no PNG, written into `folder`."""
    with open(SCENE) as f:
        text = f.read()
    nx, ny, nz = cells.split("x")
    text, found = re.subn(r"cells = \[[^\]]*\]", f"cells = [{nx}, {ny}, {nz}]", text)
    if found != 1:
        raise SystemExit(f"{SCENE}: expected one `cells = [...]` line, found {found}")
    text = text.replace("png = true", "png = false")
    path = os.path.join(folder, "cantilever.toml")
    with open(path, "w") as f:
        f.write(text)
    return path


def engine_run(scene: str, ranks: int, solver: str, folder: str) -> dict:
    """One engine run: its summary's `petsc` block, and the displacement file it gathered."""
    out, displacement = os.path.join(folder, f"out{ranks}"), os.path.join(folder, f"u{ranks}.txt")
    command = ["mpirun", "--bind-to", "none", "-n", str(ranks)]
    if os.geteuid() == 0:
        command.append("--allow-run-as-root")
    command += [os.path.join(RELEASE, "tetfem-petsc"), scene, "--solver", solver, "--out", out,
                "--displacement", displacement, "--quiet"]
    subprocess.run(command, check=True, capture_output=True, text=True)
    with open(os.path.join(out, "cantilever_petsc_summary.json")) as f:
        petsc = json.load(f)["petsc"]
    petsc["displacement_file"] = displacement
    return petsc


def direct_comparison(scene: str, displacement: str) -> tuple[float, float, float]:
    """compare_direct's relative 2-norm difference, its direct solve's seconds and peak MB."""
    text = subprocess.run([os.path.join(RELEASE, "examples", "compare_direct"), scene, displacement],
                          check=True, capture_output=True, text=True).stdout
    found = re.search(r"relative difference ([0-9.e+-]+) \(2-norm\).*direct solve ([0-9.]+) s, "
                      r"peak memory ([0-9]+) kB", text)
    if not found:
        raise SystemExit(f"compare_direct printed no comparison: {text!r}")
    return float(found.group(1)), float(found.group(2)), int(found.group(3)) / 1024


def measure(cells: str, ranks: int, solver: str, folder: str) -> dict:
    scene = scene_with_cells(cells, folder)
    petsc = engine_run(scene, ranks, solver, folder)
    difference, direct_seconds, direct_mb = direct_comparison(scene, petsc["displacement_file"])
    row = {"cells": cells, "dofs": petsc["dofs"], "solver": solver, "ranks": petsc["ranks"], "iterations": petsc["iterations"],
           "relative_residual": f"{petsc['relative_residual']:.3e}", "vs_direct": f"{difference:.3e}",
           "peak_mb_per_rank": ";".join(f"{b / 2**20:.0f}" for b in petsc["peak_memory_per_rank"]),
           "direct_seconds": f"{direct_seconds:.3f}", "direct_peak_mb": f"{direct_mb:.0f}"}
    row.update({p: f"{petsc['seconds'][p]:.3f}" for p in PHASES})
    return row


def heading(load_before: float) -> str:
    """The CSV's comment line: when, on what, at which commit, against which PETSc."""
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True,
                            text=True).stdout.strip()
    with open("/proc/cpuinfo") as f:
        model = next((line.split(":", 1)[1].strip() for line in f if line.startswith("model name")), "unknown CPU")
    return (f"# {datetime.now(timezone.utc):%Y-%m-%d %H:%M} UTC, commit {commit}, {os.cpu_count()} cores ({model}), "
            f"load average {load_before:.1f} before and {os.getloadavg()[0]:.1f} after the runs")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--cells", default="40x4x4,80x8x8,160x16x16,240x24x24", help="comma list of NxMxK")
    ap.add_argument("--ranks", default="1,2")
    ap.add_argument("--others", default="160x16x16",
                    help="sizes (comma list) also solved by CG + BoomerAMG (hypre) and MUMPS's Cholesky")
    ap.add_argument("--out", default=CSV)
    args = ap.parse_args()
    for tool in ("tetfem-petsc", os.path.join("examples", "compare_direct")):
        if not os.path.exists(os.path.join(RELEASE, tool)):
            print(f"scaling: {os.path.join(RELEASE, tool)} is missing; build it with\n"
                  "  cargo build --release -p tetfem-petsc --features petsc --bins --examples", file=sys.stderr)
            return 2
    load_before = os.getloadavg()[0]
    runs = [(cells, "gamg") for cells in args.cells.split(",")]
    runs += [(cells, solver) for cells in args.others.split(",") if cells for solver in ("hypre", "mumps")]
    rows = []
    for cells, solver in runs:
        for ranks in map(int, args.ranks.split(",")):
            with tempfile.TemporaryDirectory() as folder:
                rows.append(measure(cells, ranks, solver, folder))
            print(f"scaling: {cells}, {solver} on {ranks} rank(s): {rows[-1]['iterations']} iterations, "
                  f"setup + solve {float(rows[-1]['setup']) + float(rows[-1]['solve']):.2f} s", file=sys.stderr)
    os.makedirs(os.path.dirname(args.out), exist_ok=True)
    with open(args.out, "w", newline="") as f:
        f.write(heading(load_before) + "\n")
        writer = csv.DictWriter(f, fieldnames=COLUMNS)
        writer.writeheader()
        writer.writerows(rows)
    print(f"scaling: wrote {os.path.relpath(args.out, ROOT)}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
