#!/usr/bin/env python3
"""Writes the book's tables of measured figures from the programs that measure them.

Each table sits in a chapter between two marker comments,

    <!-- figures: NAME (written by docs/figures.py: do not edit) -->
    ...
    <!-- end figures: NAME -->

and this script replaces what lies between them, heading every table with the date, the
machine and the commit it was measured on. A chapter states what a table shows; its figures
come only from here (or from a report a program wrote, linked where it is cited), never typed.

Tables (all from release binaries of this checkout; `cargo build --release --workspace` first):

- default_run (getting-started.md): the report of `cargo run --release` (target/release/tetfem).
- accuracy (quadratic.md): tetfem P1 and P2 on the peers' cantilever, time to accuracy, one
  thread, fastest of 2 interleaved runs (target/release/accuracy, as side_by_side.py runs it).
- peers (quadratic.md): tetfem beside scikit-fem and MFEM, rendered from
  validation/report/speed_accuracy.csv as `side_by_side.py --accuracy` wrote it (the peers are
  not installed on every machine; the CSV's commit and date head the table).
- vtu_formats (scenes/index.md): the default run with binary and ASCII `.vtu` files, sizes
  and writing times, fastest of 2 interleaved runs.
- corotational (large-deformation.md): the corotational step's cost against a linear step at
  18k DOFs on one thread (target/release/corotational_cost, run twice, each method's fastest
  step; two threads on a shared 2-core machine measure the neighbours more than the code), and the 132k-DOF row from validation/report/corotational_cost.csv
  (the CSV that program wrote; about 10 minutes to measure, so not rerun here).
- scenes (scenes/README.md, included in the book): every shipped scene run once by
  target/release/tetfem (`run --json`): size, steps, the results its summary reports and the
  wall time of the process (about 25 s in all).
- mms_rates (quadratic.md): P1 and P2 errors and orders on the manufactured solution, as
  tests/core/mms_rates.rs prints them (the core test binary, `--nocapture`; about 13 s).
- effectivity (quadratic.md): the error estimate's effectivities, as tests/core/error_estimate.rs
  prints them (about 50 s).
- adequacy_curve (quadratic.md): the linear model's error against the rotation, read from the
  constant LINEAR_MODEL_ERROR_CURVE in src/post/adequacy/rotation.rs (the code's own table).
- rubber_orders (large-deformation.md): scenes/rubber_cantilever_large.toml at orders 1 and 2
  on 20×2×2 and 40×4×4 cells, the tips against the finest P2 run's, with wall times.
- scaling, scaling_model (validation/SCALING.md): the PETSc engine on 1 and 2 ranks and the
  memory/time arithmetic on it, rendered from validation/report/scaling.csv as
  `python3 validation/scaling.py` wrote it (PETSc is not installed on every machine; ~15 min).
- accuracy_target (quadratic.md): the solves `accuracy = 0.05` tries on
  scenes/cantilever_accuracy.toml and its choice, from the run's summary, times left out.

Timings are never compared: a run on another day or machine gives other times. The tables in
CHECKED (deterministic, and cheap to recompute) are: `--check` recomputes them and fails when
the text below their heading line differs, so a change of the code that moves one of their
figures fails CI until the table is rewritten (`python3 docs/figures.py NAME`). It needs the
release binaries and the core test binary that `cargo test --release` builds (about 15 s).

Measured on 2026-12-04 on a shared 2-core machine: 337 s for the first five at a load average
of 8–10 (other sessions' builds and tests). Times on a shared machine are noisy; compare the
ratios within one table.

Run: python3 docs/figures.py [NAME ...]   (default: every table)
     python3 docs/figures.py --check       (every marker pair present and well formed, the
                                            tables in CHECKED as their programs write them now,
                                            and what --links checks)
     python3 docs/figures.py --links       (no program run, under a second: every relative link
                                            of the book names a file that exists, and every
                                            '#anchor' into a chapter one of its headings; the
                                            prose cites tests and reports by such links)
     python3 docs/figures.py --help        (this text)
"""

from __future__ import annotations

import csv
import json
import math
import os
import re
import subprocess
import sys
import tempfile
import time
from datetime import datetime, timezone

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BOOK = os.path.join(ROOT, "docs", "src")
RELEASE = os.path.join(ROOT, "target", "release")
BEGIN = "<!-- figures: {} (written by docs/figures.py: do not edit) -->"
END = "<!-- end figures: {} -->"


def git(*args: str) -> str:
    return subprocess.run(["git", *args], cwd=ROOT, capture_output=True, text=True, check=True).stdout.strip()


# The load average when the table being written started to be measured (set by main before it
# runs a table's program: a heading written after the runs would otherwise give the load at
# their end, which includes the runs themselves).
START_LOAD = None


def machine() -> str:
    """The machine in a phrase: cores, CPU model, and whether others were loading it."""
    model = "unknown CPU"
    try:
        with open("/proc/cpuinfo") as f:
            model = next((line.split(":", 1)[1].strip() for line in f if line.startswith("model name")), model)
    except OSError:
        pass
    load = START_LOAD if START_LOAD is not None else os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    return f"{os.cpu_count()} cores ({model}), load average {load:.1f} at the start"


def stamp(what: str) -> str:
    """The heading line of a table measured now."""
    # Uncommitted edits to the book, to Markdown files (where tables are written) and to this script
    # do not change what is measured; to the code they do.
    changed = git("status", "--porcelain", "--untracked-files=no", "--", ".", ":(exclude)docs",
                  ":(exclude,glob)**/*.md")
    dirty = " with uncommitted changes to the code" if changed else ""
    return (f"*Written by `python3 docs/figures.py` from {what}, "
            f"{datetime.now(timezone.utc):%Y-%m-%d %H:%M} UTC, commit {git('rev-parse', '--short', 'HEAD')}{dirty}, "
            f"{machine()}.*")


def committed_stamp(path: str, writer: str) -> str:
    """The heading line of a table rendered from a file a program wrote and that was committed."""
    commit, date = git("log", "-1", "--format=%h %cs", "--", path).split()
    return (f"*Written by `python3 docs/figures.py` from `{os.path.relpath(path, ROOT)}`, which {writer} "
            f"wrote (committed {date} in {commit}).*")


def run(args: list[str], threads: int | None = None) -> str:
    env = dict(os.environ)
    if threads is not None:
        env["RAYON_NUM_THREADS"] = str(threads)
    return subprocess.run(args, cwd=ROOT, capture_output=True, text=True, check=True, env=env).stdout


def default_run() -> list[str]:
    with tempfile.TemporaryDirectory() as out:
        report = run([os.path.join(RELEASE, "tetfem"), "--quiet", "--out", out])
    report = report.replace(out, "out")  # the folder as the default run names it
    return [stamp("one run of `cargo run --release`"), "", "```text", report.rstrip("\n"), "```"]


# The peers' cantilever at n × n/10 × n/10 cells: P1 and P2 on the same meshes.
SIZES = {1: [10, 20, 40, 80, 160], 2: [10, 20, 40, 80]}


def accuracy() -> list[str]:
    binary = os.path.join(RELEASE, "accuracy")
    best: dict = {}
    for _ in range(2):  # interleaved: a slow moment of the machine hits one run of each, not all
        for order, sizes in SIZES.items():
            for n in sizes:
                r = json.loads(run([binary, "--order", str(order), "--cells", f"{n},{n // 10},{n // 10}"], threads=1))
                if (order, n) not in best or r["seconds"] < best[(order, n)]["seconds"]:
                    best[(order, n)] = r
    # Richardson extrapolation of the P2 tips at 20, 40, 80 cells along (the reference no run gives).
    t1, t2, t3 = (best[(2, n)]["tip"] for n in (20, 40, 80))
    rate = math.log2((t2 - t1) / (t3 - t2))
    reference = t3 + (t3 - t2) / (2**rate - 1)
    lines = [stamp("`target/release/accuracy`, one thread, fastest of 2 interleaved runs"), "",
             f"Reference tip: Richardson extrapolation of the P2 tips at 20, 40 and 80 cells along, "
             f"{reference:.6e} (observed order {rate:.2f}).", "",
             "| elements | cells | free DOFs | tip | error | wall time [s] |", "|---|---|---|---|---|---|"]
    for (order, n), r in sorted(best.items()):
        error = abs(r["tip"] - reference) / abs(reference)
        lines.append(f"| P{order} | {n}×{n // 10}×{n // 10} | {r['free_dofs']} | {r['tip']:.9e} | "
                     f"{100 * error:#.3g} % | {r['seconds']:#.3g} |")

    def cheapest(order: int, target: float):
        ok = [(r["seconds"], n) for (o, n), r in best.items()
              if o == order and abs(r["tip"] - reference) <= target * abs(reference)]
        return min(ok) if ok else None

    lines.append("")
    for target in (0.1, 0.01):
        p1, p2 = cheapest(1, target), cheapest(2, target)
        p1_text = (f"P1 in {p1[0]:.3g} s ({p1[1]} cells along)" if p1 else
                   f"no P1 run of the sweep (the finest, {best[(1, 160)]['seconds']:.3g} s, is "
                   f"{100 * abs(best[(1, 160)]['tip'] - reference) / abs(reference):.2g} % off)")
        ratio = f": P1 takes {p1[0] / p2[0]:.0f}× longer" if p1 and p2 else (
            f": at least {best[(1, 160)]['seconds'] / p2[0]:.0f}× longer for P1" if p2 else "")
        lines.append(f"- within {100 * target:g} %: P2 in {p2[0]:.3g} s ({p2[1]} cells along), {p1_text}{ratio}."
                     if p2 else f"- within {100 * target:g} %: no P2 run of the sweep.")
    return lines


def peers() -> list[str]:
    path = os.path.join(ROOT, "validation", "report", "speed_accuracy.csv")
    with open(path) as f:
        rows = [line.rstrip("\n").split(",") for line in f if line.strip() and not line.startswith("#")]
    header, rows = rows[0], rows[1:]
    points = [dict(zip(header, row)) for row in rows]

    def cheapest(code: str, order: str, target: float):
        ok = [p for p in points if p["code"] == code and p["order"] == order and float(p["relative_error"]) <= target]
        return min(ok, key=lambda p: float(p["seconds"])) if ok else None

    def finest(code: str, order: str):
        return max((p for p in points if p["code"] == code and p["order"] == order), key=lambda p: int(p["free_dofs"]))

    lines = [committed_stamp(path, "`python3 validation/side_by_side.py --accuracy`"), "",
             "One thread each; the tip's error against the reference of the CSV's first line.", "",
             "| code | P1: cheapest within 10 % | P1, finest mesh | P2: cheapest within 1 % | P2, finest mesh |",
             "| --- | --- | --- | --- | --- |"]
    for code in ("tetfem", "scikit-fem", "MFEM"):
        cells = []
        for order, target in (("1", 0.1), ("2", 0.01)):
            p = cheapest(code, order, target)
            f = finest(code, order)
            cells.append(f"{p['mesh']}, {float(p['seconds']):.3g} s" if p else "none")
            cells.append(f"{f['mesh']}: error {100 * float(f['relative_error']):.2g} %, {float(f['seconds']):.3g} s")
        lines.append(f"| {code} | " + " | ".join(cells) + " |")
    lines.append("")
    for target in (0.01, 0.001):
        ours, theirs = cheapest("tetfem", "2", target), cheapest("MFEM", "2", target)
        skfem = cheapest("scikit-fem", "2", target)
        if ours and theirs and skfem:
            lines.append(f"- To {100 * target:g} %: tetfem P2 in {float(ours['seconds']):.3g} s ({ours['mesh']}), "
                         f"{float(theirs['seconds']) / float(ours['seconds']):.1f}× sooner than MFEM order 2 and "
                         f"{float(skfem['seconds']) / float(ours['seconds']):.1f}× sooner than scikit-fem P2 on the "
                         "same mesh.")
    return lines


COST_COLUMNS = "| cells | free DOFs | threads | linear step [s] | refactoring, 1e-8 [s] (its) | " \
    "Newton-CG, 1e-8 [s] (its, CG its) | L-BFGS, 1e-8 [s] (its) | L-BFGS, 1e-2 [s] (its, distance) | " \
    "ratios to linear: refactoring / Newton-CG 1e-8 / L-BFGS 1e-8 / 3e-3 / 1e-2 / 1e-1 |"


def read_cost(csv_path: str) -> dict:
    """corotational_cost's CSV as {(method, tolerance): row}."""
    with open(csv_path) as f:
        header, *rows = [line.rstrip("\n").split(",") for line in f if line.strip()]
    return {(r[0], float(r[1])): dict(zip(header, r)) for r in rows}


def fastest_cost(runs: list[dict]) -> dict:
    """Each method's fastest mean step over the runs (noise on a shared machine only adds time),
    its cost over the fastest linear step; iterations and distances are the same in every run."""
    out = {key: dict(row, step_seconds=min(float(r[key]["step_seconds"]) for r in runs))
           for key, row in runs[0].items()}
    linear = out[("linear", 0.0)]["step_seconds"]
    for row in out.values():
        row["cost_over_linear"] = row["step_seconds"] / linear
    return out


def cost_row(by: dict, cells: str) -> str:
    linear, refactor = by[("linear", 0.0)], by[("refactor", 1e-8)]
    cg, lbfgs, loose = by[("newton_cg", 1e-8)], by[("lbfgs", 1e-8)], by[("lbfgs", 1e-2)]
    ratios = " / ".join(f"{float(r['cost_over_linear']):.1f}" for r in
                        (refactor, cg, lbfgs, by[("lbfgs", 3e-3)], loose, by[("lbfgs", 1e-1)]))
    sec = lambda r: f"{float(r['step_seconds']):#.3g}"  # noqa: E731
    return (f"| {cells} | {linear['free_dofs']} | {linear['threads']} | {sec(linear)} | "
            f"{sec(refactor)} ({refactor['iterations']}) | {sec(cg)} ({cg['iterations']}, {cg['cg_iterations']}) | "
            f"{sec(lbfgs)} ({lbfgs['iterations']}) | {sec(loose)} ({loose['iterations']}, "
            f"{float(loose['distance_from_refactoring']):.1e}".replace("e-0", "e-") + f") | {ratios} |")


def corotational() -> list[str]:
    binary = os.path.join(RELEASE, "corotational_cost")
    runs = []
    for _ in range(2):  # one thread, twice: each method's fastest step of the two
        with tempfile.TemporaryDirectory() as out:
            run([binary, "--cells", "50,10,10", "--out", out], threads=1)
            runs.append(read_cost(os.path.join(out, "corotational_cost.csv")))
    committed = os.path.join(ROOT, "validation", "report", "corotational_cost.csv")
    return [stamp("`target/release/corotational_cost --cells 50,10,10`, `RAYON_NUM_THREADS=1`, each method's "
                  "fastest step of 2 runs"), "",
            COST_COLUMNS, "|---|---|---|---|---|---|---|---|---|", cost_row(fastest_cost(runs), "50×10×10"), "",
            committed_stamp(committed, "`corotational_cost --cells 100,20,20` (one thread)"), "",
            COST_COLUMNS, "|---|---|---|---|---|---|---|---|---|", cost_row(read_cost(committed), "100×20×20")]


def folder_megabytes(path: str) -> float:
    return sum(os.path.getsize(os.path.join(d, f)) for d, _, files in os.walk(path) for f in files) / 1e6


def vtu_formats() -> list[str]:
    """The default run with binary and ASCII .vtu files, interleaved twice: sizes and writing times."""
    best: dict = {}
    for _ in range(2):
        for fmt in ("binary", "ascii"):
            with tempfile.TemporaryDirectory() as out:
                summary = json.loads(run([os.path.join(RELEASE, "tetfem"), "--quiet", "--json", "--out", out,
                                          "--vtu-format", fmt]))
                sizes = (folder_megabytes(os.path.join(out, "cantilever")),
                         folder_megabytes(os.path.join(out, "cantilever_swing")))
            times = (summary["static"]["output_seconds"], summary["dynamic"]["output_seconds"],
                     summary["dynamic"]["step_seconds"])
            old = best.get(fmt)
            best[fmt] = (sizes, times if old is None else tuple(min(a, b) for a, b in zip(old[1], times)))
    lines = [stamp("the default run (`target/release/tetfem --json`) with each `--vtu-format`, "
                   "fastest of 2 interleaved runs"), "",
             "| `--vtu-format` | static `cantilever/` [MB] | dynamic `cantilever_swing/` [MB] | "
             "writing: static / dynamic frames [s] | stepping (dynamic) [s] |", "| --- | --- | --- | --- | --- |"]
    for fmt, ((static_mb, dynamic_mb), (static_s, dynamic_s, steps_s)) in best.items():
        lines.append(f"| `{fmt}` | {static_mb:.1f} | {dynamic_mb:.1f} | {static_s:#.2g} / {dynamic_s:#.2g} | {steps_s:#.2g} |")
    (b_sizes, b_times), (a_sizes, a_times) = best["binary"], best["ascii"]
    lines += ["", f"Binary is {sum(a_sizes) / sum(b_sizes):.1f}× smaller than ASCII and "
              f"{(a_times[0] + a_times[1]) / (b_times[0] + b_times[1]):.1f}× faster to write, the same fields in both."]
    return lines


# Scenes written in millimetres (their comments say "Units: mm"): every other scene is SI, so
# its lengths (m) are shown ×1000 in mm; these are shown as they are.
MILLIMETRE_SCENES = {"cook_membrane_mixed.toml"}


def vector_mm(v: list[float], scale: float = 1e3) -> str:
    """A displacement in mm (`scale`: mm per length unit of the scene), components below 1e-6 mm
    (round-off of a symmetric scene) as 0."""
    return "(" + ", ".join(f"{scale * c:.4g}" if abs(scale * c) >= 1e-6 else "0" for c in v) + ") mm"


def vector_n(v: list[float]) -> str:
    """A force in N, components below 1e-6 of the largest (round-off) as 0."""
    big = max(abs(c) for c in v) or 1.0
    return "(" + ", ".join(f"{c:.5g}" if abs(c) >= 1e-6 * big else "0" for c in v) + ") N"


def scene_results(s: dict, scale: float = 1e3) -> str:
    """What a scene's summary reports that its description talks about, in one cell (`scale`:
    mm per length unit of the scene)."""
    out = []
    if s["analysis"].startswith("modal"):  # "modal", "modal (mixed)"
        out.append("f = " + ", ".join(f"{m['frequency_hz']:.4g}" for m in s["modes"][:3]) + " … Hz")
    if s["analysis"].startswith("dynamic"):  # "dynamic", "dynamic (mixed)"
        out.append(f"dt = {s['dt_over_critical']:.3g}× the explicit critical step")
    accuracy = s.get("accuracy")
    if accuracy:
        out.append(f"chose order {accuracy['order']} on {'×'.join(map(str, accuracy['cells']))} cells "
                   f"after {len(accuracy['trials'])} solves")
    error = s.get("estimated_error")
    if error:
        out.append(f"estimated error {100 * error['relative']:.3g} %")
    for probe in s.get("probes") or []:
        if "displacement" in probe:  # a static probe: its mean displacement
            out.append(f"`{probe['name']}` u = {vector_mm(probe['displacement'], scale)}")
        else:  # a dynamic probe: at the last step, and its extremes over the run per axis
            reach = [max(abs(lo), abs(hi)) for lo, hi in zip(probe["min"], probe["max"])]
            out.append(f"`{probe['name']}` u at the end {vector_mm(probe['last'], scale)}, largest |u| "
                       f"per axis {vector_mm(reach, scale)}")
    for contact in s.get("contact_forces") or []:
        text = f"`{contact['obstacle']}` force {vector_n(contact['force_n'])}"
        if contact.get("peak_n") is not None:
            text += f" at the end, peak {contact['peak_n']:.4g} N at t = {contact['peak_time_s']:.3g} s"
        out.append(text)
    newton = s.get("newton")
    if newton:
        if "total_iterations" in newton:
            out.append(f"Newton: {newton['total_iterations']} iterations over {newton['steps']} steps "
                       f"(at most {newton['max_per_step']} per step)")
        else:
            out.append(f"Newton: {newton['iterations']} iterations over {newton['load_steps']} load steps")
    return "; ".join(out)


def scenes() -> list[str]:
    """Every shipped scene run once by the release binary: its size, steps, results and wall time."""
    binary = os.path.join(RELEASE, "tetfem")
    folder = os.path.join(ROOT, "scenes")
    lines = [stamp("one run of `target/release/tetfem run scenes/NAME.toml --json` per scene (all threads, "
                   "outputs as the scene asks, PNG included); wall time from the start of the process to its end"),
             "", "| scene | analysis | tets / nodes / free DOFs | steps | results (from the run's summary) | "
             "wall time [s] | of it writing outputs [s] |", "| --- | --- | --- | --- | --- | --- | --- |"]
    for name in sorted(f for f in os.listdir(folder) if f.endswith(".toml")):
        with tempfile.TemporaryDirectory() as out:
            start = time.perf_counter()
            s = json.loads(run([binary, "run", os.path.join("scenes", name), "--json", "--quiet", "--out", out]))
            wall = time.perf_counter() - start
        if s["analysis"].startswith("dynamic"):
            steps = f"{s['steps']}"
        elif (s.get("newton") or {}).get("load_steps"):
            steps = f"{s['newton']['load_steps']} load steps"
        else:
            steps = "1 solve" if s["analysis"] == "static" else f"{len(s['modes'])} modes"
        lines.append(f"| `{name}` | {s['analysis']} | {s['tets']} / {s['nodes']} / {s['free_dofs']} | {steps} | "
                     f"{scene_results(s, 1.0 if name in MILLIMETRE_SCENES else 1e3)} | {wall:.2f} | "
                     f"{s['output_seconds']:.2f} |")
    return lines


def core_test(filter_: str) -> str:
    """The printed output of the core test binary's tests matching `filter_`, one thread: a test
    that checks a bound prints the figures it checked, and those are the figures of the table."""
    built = run(["cargo", "test", "--release", "--test", "core", "--no-run", "--message-format=json"])
    binary = next(json.loads(line)["executable"] for line in built.splitlines()
                  if '"executable":"' in line and json.loads(line)["target"]["name"] == "core")
    return run([binary, filter_, "--nocapture", "--test-threads=1"])


def test_stamp(what: str, checked: bool) -> str:
    """The heading of a table printed by a test (deterministic: no machine or load matters)."""
    again = ("`python3 docs/figures.py --check` recomputes it" if checked else
             "too long for `--check` to recompute (the test checks its bounds on every `cargo test`)")
    return (f"*Written by `python3 docs/figures.py` from what {what} prints (`cargo test --release --test core "
            f"-- --nocapture`), {datetime.now(timezone.utc):%Y-%m-%d} UTC, commit {git('rev-parse', '--short', 'HEAD')}; "
            f"deterministic; {again}.*")


def mms_rates() -> list[str]:
    """tests/core/mms_rates.rs: L2 and energy errors of P1 and P2 on the manufactured solution."""
    out = core_test("mms_rates::")
    levels = re.findall(r"P(\d) n = *(\d+): h = [\d.]+, DOFs +(\d+), L2 error (\S+), energy error (\S+)", out)
    orders = {d: (l2, en) for d, l2, en in re.findall(r"P(\d): L2 orders \[([^\]]*)\].*?energy orders \[([^\]]*)\]", out)}
    lines = [test_stamp("[`tests/core/mms_rates.rs`](../../tests/core/mms_rates.rs)", "mms_rates" in CHECKED), "",
             "| element | cells | DOFs | L2 error | energy error | L2 order | energy order |",
             "| --- | --- | --- | --- | --- | --- | --- |"]
    seen: dict = {}
    for degree, n, dofs, l2, energy in sorted(levels, key=lambda r: (r[0], int(r[1]))):
        k = seen.get(degree, 0)
        seen[degree] = k + 1
        rates = ["", ""]
        if k > 0:
            rates = [f"{float(orders[degree][i].split(',')[k - 1]):.3f}" for i in (0, 1)]
        # The errors as the test prints them (5 digits): rounding them again could differ in the last.
        lines.append(f"| P{degree} | {n}³ | {int(dofs):,}".replace(",", " ") +
                     f" | {l2} | {energy} | {rates[0]} | {rates[1]} |")
    return lines


def effectivity() -> list[str]:
    """tests/core/error_estimate.rs: the ZZ estimate's effectivity at three levels of each case."""
    out = core_test("error_estimate::")
    lines = [test_stamp("[`tests/core/error_estimate.rs`](../../tests/core/error_estimate.rs)", "effectivity" in CHECKED), "",
             "| case | level 1 | level 2 | level 3 |", "| --- | --- | --- | --- |"]
    cases = re.findall(r"(manufactured|cantilever), (P\d), (\S+) cells: effectivities \[([^\]]*)\]", out)
    for kind, element, levels, values in sorted(cases, key=lambda c: (c[0] != "manufactured", c[1])):
        lines.append(f"| {kind}, {element} ({levels.replace('/', ', ')} cells) | " +
                     " | ".join(v.strip() for v in values.split(",")) + " |")
    averaging = re.search(r"averaging: P1 16³ (\S+), P2 8³ (\S+)", out)
    reference = re.search(r"reference compliance (\S+) \(observed order (\S+)\)", out)
    if averaging:
        lines += ["", f"Plain averaging (`Recovery::Averaging`) on the manufactured solution: P1 on 16³ cells "
                  f"{averaging.group(1)}, P2 on 8³ cells {averaging.group(2)}."]
    if reference:
        lines += ["", f"Cantilever reference compliance f·u = {reference.group(1)} (Richardson, observed order "
                  f"{reference.group(2)})."]
    return lines


def adequacy_curve() -> list[str]:
    """The linear model's error against the largest rotation: the constant the run warns from."""
    path = os.path.join(ROOT, "src", "post", "adequacy", "rotation.rs")
    with open(path, encoding="utf-8") as f:
        body = re.search(r"LINEAR_MODEL_ERROR_CURVE: \[\(f64, f64\); \d+\] = \[(.*?)\];", f.read(), re.S).group(1)
    points = [(float(a), float(b)) for a, b in re.findall(r"\(([\d.]+), ([\d.]+)\)", body)]
    return [f"*Written by `python3 docs/figures.py` from the constant `LINEAR_MODEL_ERROR_CURVE` in "
            f"[`src/post/adequacy/rotation.rs`](../../src/post/adequacy/rotation.rs) (checked by `--check`).*", "",
            "| largest rotation | " + " | ".join(f"{a:g}°" for a, _ in points) + " |",
            "| --- | " + " | ".join("---" for _ in points) + " |",
            "| linear model's error | " + " | ".join(f"{100 * b:.3g} %" for _, b in points) + " |"]


def accuracy_target() -> list[str]:
    """scenes/cantilever_accuracy.toml: the solves an accuracy target tries, and its choice."""
    with tempfile.TemporaryDirectory() as out:
        s = json.loads(run([os.path.join(RELEASE, "tetfem"), "run", "scenes/cantilever_accuracy.toml", "--json",
                            "--quiet", "--out", out]))
    a = s["accuracy"]
    lines = [f"*Written by `python3 docs/figures.py` from the summary of `target/release/tetfem run "
             f"scenes/cantilever_accuracy.toml`, commit {git('rev-parse', '--short', 'HEAD')} (its times left out: "
             f"the rest is deterministic, and `--check` recomputes it).*", "",
             "| solve | order | cells | DOFs | estimated error |", "| --- | --- | --- | --- | --- |"]
    for i, t in enumerate(a["trials"], 1):
        lines.append(f"| {i} | {t['order']} | {'×'.join(map(str, t['cells']))} | {t['dofs']:,} | "
                     f"{100 * t['estimate']:.3g} % |".replace(",", " "))
    predicted = ", ".join(f"≈ {p['dofs']:,.0f} DOFs for order {p['order']}".replace(",", " ") for p in a["predictions"])
    lines += ["", f"Predicted from the first solves to reach {100 * a['target']:g} %: {predicted}. Chosen: order "
              f"{a['order']} on {'×'.join(map(str, a['cells']))} cells, estimate {100 * a['estimated_error']:.3g} % "
              f"({'met' if a['met'] else 'not met'})."]
    return lines


def rubber_orders() -> list[str]:
    """scenes/rubber_cantilever_large.toml at orders 1 and 2 on two meshes: the tip against the
    finest P2 run's (the large-deformation models on 10-node tets)."""
    with open(os.path.join(ROOT, "scenes", "rubber_cantilever_large.toml"), encoding="utf-8") as f:
        scene = f.read()
    runs = []
    for order, cells in ((1, (20, 2, 2)), (1, (40, 4, 4)), (2, (20, 2, 2)), (2, (40, 4, 4))):
        text = scene.replace("cells = [20, 2, 2]", f"cells = [{', '.join(map(str, cells))}]")
        text = text.replace("[mesh.box]", f"[mesh]\norder = {order}\n\n[mesh.box]").replace("png = true", "png = false")
        with tempfile.TemporaryDirectory() as out:
            path = os.path.join(out, "rubber.toml")
            with open(path, "w", encoding="utf-8") as f:
                f.write(text)
            start = time.perf_counter()
            summary = json.loads(run([os.path.join(RELEASE, "tetfem"), "run", path, "--json", "--quiet", "--out", out]))
            runs.append((order, cells, summary, time.perf_counter() - start))
    reference = runs[-1][2]["probes"][0]["displacement"][2]
    lines = [stamp("`target/release/tetfem run` of `scenes/rubber_cantilever_large.toml` with `[mesh] order` and "
                   "`cells` changed (no PNG), once each; the tips are deterministic, the times are not"), "",
             "| order | cells | free DOFs | tip u_z [m] | off the P2 40×4×4 tip | Newton iterations | wall time [s] |",
             "| --- | --- | --- | --- | --- | --- | --- |"]
    for order, cells, s, seconds in runs:
        tip = s["probes"][0]["displacement"][2]
        off = "reference" if s is runs[-1][2] else f"{100 * abs(tip - reference) / abs(reference):.2g} %"
        lines.append(f"| {order} | {'×'.join(map(str, cells))} | {s['free_dofs']} | {tip:.5f} | {off} | "
                     f"{s['newton']['iterations']} | {seconds:.2f} |")
    return lines


def read_scaling() -> tuple[str, str, list[dict]]:
    """validation/report/scaling.csv: its path, its heading comment and its rows."""
    path = os.path.join(ROOT, "validation", "report", "scaling.csv")
    with open(path) as f:
        comment = f.readline().lstrip("# ").strip()
        rows = list(csv.DictReader(f))
    return path, comment, rows


def peak_mb(row: dict) -> float:
    """The larger rank's peak resident set of a run (MB)."""
    return max(float(m) for m in row["peak_mb_per_rank"].split(";"))


def scaling_pairs(rows: list[dict]) -> list[tuple[dict, dict]]:
    """The GAMG runs as (1 rank, 2 ranks) pairs, by size."""
    gamg = [r for r in rows if r["solver"] == "gamg"]
    one = {r["dofs"]: r for r in gamg if r["ranks"] == "1"}
    return [(one[r["dofs"]], r) for r in gamg if r["ranks"] == "2" and r["dofs"] in one]


def scaling() -> list[str]:
    path, comment, rows = read_scaling()
    lines = [committed_stamp(path, "`python3 validation/scaling.py`") + f" *Measured {comment}.*", "",
             "| DOFs | solver | ranks | Krylov its | true rel. residual | vs direct | build | partition | assembly | "
             "constraints | set-up | solve | peak RSS per rank (MB) |", "|" + " --- |" * 13]
    for r in rows:
        times = " | ".join(f"{float(r[p]):.2f}" for p in ("build", "partition", "assembly", "constraints", "setup", "solve"))
        lines.append(f"| {int(r['dofs']):,} | {r['solver']} | {r['ranks']} | {r['iterations']} | "
                     f"{float(r['relative_residual']):.1e} | {float(r['vs_direct']):.1e} | {times} | "
                     f"{r['peak_mb_per_rank'].replace(';', ', ')} |")
    gamg = [r for r in rows if r["solver"] == "gamg"]
    its = [int(r["iterations"]) for r in gamg]
    agreement = [float(r["vs_direct"]) for r in rows]
    largest = max(gamg, key=lambda r: int(r["dofs"]))
    memory = ", ".join(f"{peak_mb(two) / peak_mb(one):.2f}× at {int(one['dofs']):,}" for one, two in scaling_pairs(rows))
    lines += ["", f"- **GAMG iterations**: {min(its)}–{max(its)} from {int(gamg[0]['dofs']):,} to "
              f"{int(largest['dofs']):,} DOFs, on 1 or 2 ranks.",
              f"- **Memory per rank at 2 ranks** against the 1-rank peak: {memory}.",
              f"- **Agreement** with tetfem's single-process Cholesky (‖u − u_direct‖₂/‖u_direct‖₂): "
              f"{min(agreement):.1e} to {max(agreement):.1e}.",
              f"- **tetfem's single-process Cholesky** at {int(largest['dofs']):,} DOFs: "
              f"{float(largest['direct_seconds']):.1f} s and {float(largest['direct_peak_mb']) / 1024:.1f} GB."]
    for r in rows:
        if r["solver"] != "gamg":
            name = {"hypre": "CG + BoomerAMG", "mumps": "MUMPS's Cholesky"}.get(r["solver"], r["solver"])
            ranks = "1 rank" if r["ranks"] == "1" else f"{r['ranks']} ranks"
            its = "" if r["solver"] == "mumps" else f"{r['iterations']} iterations, "
            lines.append(f"- **{name}** at {int(r['dofs']):,} DOFs on {ranks}: {its}set-up + solve {float(r['setup']) + float(r['solve']):.1f} s, "
                         f"{peak_mb(r):,.0f} MB per rank, {float(r['vs_direct']):.1e} from the direct solve.")
    return lines


def scaling_model() -> list[str]:
    """SCALING.md's arithmetic on the measured memory and times (no run)."""
    path, _, rows = read_scaling()
    pairs = scaling_pairs(rows)[-2:]
    lines = [committed_stamp(path, "`python3 validation/scaling.py`") + " *Arithmetic on its rows.*", "",
             "| DOFs | M₁ (MB) | M₂ (MB) | D = 2(M₁ − M₂) | R = 2M₂ − M₁ |", "| --- | --- | --- | --- | --- |"]
    split = []
    for one, two in pairs:
        n, m1, m2 = int(one["dofs"]), peak_mb(one), peak_mb(two)
        d, r = 2 * (m1 - m2), 2 * m2 - m1
        split.append((n, d, r))
        lines.append(f"| {n:,} | {m1:,.0f} | {m2:,.0f} | {d:,.0f} MB ({d * 1024 / n:.1f} kB/DOF) | {r:,.0f} MB |")
    (n0, _, r0), (n1, d1, r1) = split
    slope = (r1 - r0) / (n1 - n0)  # MB per DOF of the whole problem, held by every rank
    base, per_dof = r0 - slope * n0, d1 / n1
    lines += ["", f"A straight line through the two R values: R ≈ {base:.0f} MB + {slope * 1024:.2f} kB per DOF of the "
              f"whole problem; D per DOF taken at its {n1:,}-DOF value, {per_dof * 1024:.1f} kB. Per rank, for n DOFs "
              f"on N ranks: M(n, N) ≈ {base:.0f} MB + {slope * 1024:.2f} kB·n + {per_dof * 1024:.1f} kB·n/N.", "",
              "| n | N | replicated | distributed | per rank |", "| --- | --- | --- | --- | --- |"]
    for n, ranks in ((1e6, 4), (1e7, 32), (1e8, 256), (1e9, 2048)):
        rep, dist = slope * n / 1024, per_dof * n / ranks / 1024
        size = f"{n:.0e}".replace("e+0", "e")
        lines.append(f"| {size} | {ranks:,} | {rep:,.1f} GB | {dist:,.1f} GB | {base / 1024 + rep + dist:,.1f} GB |")
    big = max((r for r in rows if r["solver"] == "gamg" and r["ranks"] == "1"), key=lambda r: int(r["dofs"]))
    small = max((one for one, _ in pairs[:-1]), key=lambda r: int(r["dofs"]))
    per = lambda r: (float(r["setup"]) + float(r["solve"])) / int(r["dofs"]) * 1e6  # noqa: E731
    serial = (float(big["build"]) + float(big["partition"])) / int(big["dofs"]) * 1e9 / 3600
    lines += ["", f"The replicated part reaches 3 GB (a usual memory per core on a cluster node) at "
              f"{3 * 1024 / slope / 1e6:.1f} million DOFs. Set-up + solve per DOF on 1 rank: {per(small):.0f} µs at "
              f"{int(small['dofs']):,} DOFs ({small['iterations']} iterations), {per(big):.0f} µs at "
              f"{int(big['dofs']):,} ({big['iterations']}). The serial build + METIS at {int(big['dofs']):,} DOFs, "
              f"{float(big['build']) + float(big['partition']):.1f} s, is {serial:.1f} h at 1e9 DOFs if linear in n, "
              "on every rank."]
    return lines


TABLES = {  # name: (the file it is written into, relative to the repository, and its program)
    "default_run": ("docs/src/getting-started.md", default_run),
    "accuracy": ("docs/src/quadratic.md", accuracy),
    "peers": ("docs/src/quadratic.md", peers),
    "corotational": ("docs/src/large-deformation.md", corotational),
    "vtu_formats": ("docs/src/scenes/index.md", vtu_formats),
    "scenes": ("scenes/README.md", scenes),
    "mms_rates": ("docs/src/quadratic.md", mms_rates),
    "effectivity": ("docs/src/quadratic.md", effectivity),
    "adequacy_curve": ("docs/src/quadratic.md", adequacy_curve),
    "accuracy_target": ("docs/src/quadratic.md", accuracy_target),
    "rubber_orders": ("docs/src/large-deformation.md", rubber_orders),
    "scaling": ("validation/SCALING.md", scaling),
    "scaling_model": ("validation/SCALING.md", scaling_model),
}

# Tables whose figures are deterministic (no time in them) and cheap to re-derive: `--check`
# recomputes them and fails when the committed text differs below the heading line (whose date
# and commit change with every run).
CHECKED = {"mms_rates", "adequacy_curve", "accuracy_target", "scaling", "scaling_model"}


def span(text: str, name: str, path: str) -> tuple[int, int]:
    """Where the table NAME's lines go in a file: after its begin marker, before its end marker."""
    begin, end = BEGIN.format(name), END.format(name)
    if text.count(begin) != 1 or text.count(end) != 1 or text.index(begin) > text.index(end):
        raise SystemExit(f"{path}: needs exactly one '{begin}' followed by one '{end}'")
    return text.index(begin) + len(begin), text.index(end)


def marked_files() -> list[str]:
    """Every file that may hold a table's markers: the book's chapters and the Markdown files it
    includes or links as the home of figures (relative to the repository)."""
    found = []
    for folder, _, files in os.walk(BOOK):
        found += [os.path.relpath(os.path.join(folder, f), ROOT) for f in files if f.endswith(".md")]
    found += ["README.md", os.path.join("scenes", "README.md"), os.path.join("python", "README.md")]
    found += [os.path.join("validation", f) for f in os.listdir(os.path.join(ROOT, "validation")) if f.endswith(".md")]
    return sorted(found)


def below_heading(body: str) -> str:
    """A table's text without its first line (the heading with date, commit and machine)."""
    return body.strip("\n").split("\n", 1)[-1].strip("\n")


# A Markdown link [text](target) whose target is a path (not a web address or an e-mail).
LINK = re.compile(r"\]\(([^)\s]+)\)")
HEADING = re.compile(r"^#{1,6}\s+(.*?)\s*#*\s*$", re.MULTILINE)
INCLUDE = re.compile(r"\{\{#include\s+([^}\s]+)\s*\}\}")


def anchor(heading: str) -> str:
    """The id mdbook gives a heading: lower case, letters, digits, '_' and '-' kept, spaces to
    '-', everything else (backquotes, punctuation) dropped."""
    return "".join(c if c.isalnum() or c in "_-" else "-" if c == " " else ""
                   for c in heading.strip().lower())


def page_anchors(path: str) -> set[str]:
    """The heading ids of a chapter, with those of the files it includes (mdbook renders an
    included file's headings on the page)."""
    with open(path, encoding="utf-8") as f:
        text = f.read()
    for included in INCLUDE.findall(text):
        target = os.path.normpath(os.path.join(os.path.dirname(path), included.split(":")[0]))
        if os.path.isfile(target):
            with open(target, encoding="utf-8") as f:
                text += "\n" + f.read()
    # Fenced code holds comment lines that start with '#': they are not headings.
    text = re.sub(r"```.*?```", "", text, flags=re.DOTALL)
    return {anchor(h) for h in HEADING.findall(text)}


def broken_links() -> list[str]:
    """Every relative link in the book's chapters (and scenes/README.md, which the book
    includes) whose file does not exist, or whose '#anchor' into a chapter names no heading.
    Cheap: reads the Markdown only, runs nothing."""
    pages = [os.path.join(folder, f) for folder, _, files in os.walk(BOOK) for f in files if f.endswith(".md")]
    pages.append(os.path.join(ROOT, "scenes", "README.md"))
    broken = []
    for page in sorted(pages):
        with open(page, encoding="utf-8") as f:
            text = re.sub(r"```.*?```", "", f.read(), flags=re.DOTALL)
        for target in LINK.findall(text):
            if target.startswith(("http://", "https://", "mailto:")):
                continue
            path, _, fragment = target.partition("#")
            resolved = os.path.normpath(os.path.join(os.path.dirname(page), path)) if path else page
            where = f"{os.path.relpath(page, ROOT)}: ({target})"
            if not os.path.exists(resolved):
                broken.append(f"{where} names no file")
            elif fragment and resolved.endswith(".md") and resolved.startswith(BOOK) \
                    and fragment not in page_anchors(resolved):
                broken.append(f"{where} names no heading of {os.path.relpath(resolved, ROOT)}")
    return broken


def main(args: list[str]) -> int:
    global START_LOAD
    if "--help" in args or "-h" in args:
        print(__doc__)
        return 0
    if "--links" in args:
        broken = broken_links()
        print("\n".join(f"figures: {b}" for b in broken) or "figures: every relative link of the book resolves",
              file=sys.stderr)
        return 1 if broken else 0
    check = "--check" in args
    names = [a for a in args if a != "--check"] or list(TABLES)
    unknown = [n for n in names if n not in TABLES]
    if unknown:
        print(f"figures: unknown table {', '.join(unknown)}; tables: {', '.join(TABLES)}", file=sys.stderr)
        return 2
    stale = []
    for name in names:
        relative, measure = TABLES[name]
        path = os.path.join(ROOT, relative)
        with open(path, encoding="utf-8") as f:
            text = f.read()
        start, stop = span(text, name, relative)
        if check:
            if name in CHECKED and below_heading(text[start:stop]) != below_heading("\n".join(measure())):
                stale.append(f"{relative}: table '{name}' differs from what its program writes now "
                             f"(python3 docs/figures.py {name} rewrites it)")
            continue
        print(f"figures: {name} ({relative})", file=sys.stderr)
        START_LOAD = os.getloadavg()[0] if hasattr(os, "getloadavg") else None
        body = "\n".join(measure())
        text = text[:start] + "\n" + body + "\n" + text[stop:]
        with open(path, "w", encoding="utf-8") as f:
            f.write(text)
    # A marker left in a file for a table this script does not know would never be rewritten.
    for relative in marked_files():
        with open(os.path.join(ROOT, relative), encoding="utf-8") as f:
            for found in re.findall(r"<!-- figures: (\S+) \(written by", f.read()):
                if found not in TABLES:
                    print(f"figures: {relative} has a marker for unknown table '{found}'", file=sys.stderr)
                    return 1
    if check:
        # The prose cites its figures by links to tests and reports: a moved file breaks them.
        stale += broken_links()
    if stale:
        print("figures: " + "\nfigures: ".join(stale), file=sys.stderr)
        return 1
    checked = [n for n in names if n in CHECKED]
    print(f"figures: markers well formed; {', '.join(checked) or 'no table'} as its program writes it now; every relative link resolves"
          if check else "figures: done", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
