#!/usr/bin/env python3
"""tetfem side by side with the peers of ../shared/peers, in one run, on identical problems.

The cantilever L=10, W=H=1, E=1e5, nu=0.3, clamped at x=0, end load P=1, meshes n x n/10 x n/10
of the lecture's 6-tet split: tetfem (scale binary, one process per run) against scikit-fem
assembly + CHOLMOD (AMD and METIS orderings) and MFEM assembly, each in its own process. The
meshes, DOF numbering and loads are identical (the tip deflections printed must agree to ~1e-9),
so the stiffness matrices are the same and the factorizations compare like for like.

Each (size, code) runs `--repeat` times interleaved; the table keeps the fastest of each, since
the machine is shared and noise only ever adds time. Writes validation/SIDE_BY_SIDE.md.

Usage (from the project root, after `validation/setup_peers.sh`):
    python3 validation/side_by_side.py                 # sizes 80,160,200 at 1 and 2 threads
    python3 validation/side_by_side.py --sizes 40,80 --threads 1 --repeat 1   # quick
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from datetime import datetime, timezone

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
PEERS = os.environ.get("TETFEM_PEERS", os.path.join(ROOT, "..", "shared", "peers"))
PYTHON = os.environ.get("TETFEM_PEERS_PYTHON", "/work/peers-venv/bin/python")
SCALE = os.path.join(ROOT, "target", "release", "scale")
PHASES = ["mesh", "pattern", "assembly", "constraints", "symbolic", "numeric", "solve"]


def run_tetfem(n: int, threads: int, ordering: str) -> dict:
    env = dict(os.environ, RAYON_NUM_THREADS=str(threads))
    out = subprocess.run([SCALE, "--cells", f"{n},{n // 10},{n // 10}", "--threads", str(threads),
                          "--ordering", ordering], capture_output=True, text=True, env=env, check=True)
    line = next(l for l in out.stdout.splitlines() if l.startswith("RESULT "))
    f = line.split()[1:]
    seconds = [float(x) for x in f[7].split(",")]
    peak = [float(x) for x in f[8].split(",")]
    return dict(dofs=int(f[3]), factor=int(f[6]), tip=float(f[9]), peak=peak[-1], refill=float(f[16]),
                **{p: s for p, s in zip(PHASES, seconds)})


def run_peer(n: int, solver: str, threads: int, ordering: str = "default") -> dict:
    env = dict(os.environ, OPENBLAS_NUM_THREADS=str(threads), OMP_NUM_THREADS=str(threads),
               NGS_THREADS=str(threads))
    with tempfile.TemporaryDirectory() as d:
        path = os.path.join(d, "r.json")
        cmd = [PYTHON, "cantilever_static.py", "--nx", str(n), "--ny", str(n // 10), "--nz", str(n // 10),
               "--solver", solver, "--json", path, "--wait-idle", "0"]
        if solver == "cholmod":
            cmd += ["--ordering", ordering, "--nnz-factor"]
        subprocess.run(cmd, cwd=PEERS, capture_output=True, text=True, env=env, check=True)
        with open(path) as f:
            r = json.load(f)
    t = r["times"]
    return dict(tip=r["tip"], assemble=t.get("assemble"), analyze=t.get("analyze"),
                factorize=t.get("factorize"), solve=t.get("solve"), factor=r.get("nnz_factor"),
                peak=r.get("peak_rss_mib"))


def fastest(runs: list[dict]) -> dict:
    out = dict(runs[0])
    for r in runs[1:]:
        for k, v in r.items():
            if isinstance(v, float) and k not in ("tip", "peak") and out.get(k) is not None:
                out[k] = min(out[k], v)
    return out


def ratio(a, b) -> str:
    return f"{a / b:.2f}" if a and b else "–"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sizes", default="80,160,200", help="comma list of n (mesh n x n/10 x n/10)")
    ap.add_argument("--threads", default="1,2")
    ap.add_argument("--repeat", type=int, default=2)
    ap.add_argument("--out", default=os.path.join(ROOT, "validation", "SIDE_BY_SIDE.md"))
    a = ap.parse_args()
    if not os.path.exists(PYTHON):
        print(f"side_by_side: peers' Python not found at {PYTHON}; run validation/setup_peers.sh "
              "or set TETFEM_PEERS_PYTHON. Skipping.", file=sys.stderr)
        return 0
    subprocess.run(["cargo", "build", "--release", "--bin", "scale"], cwd=ROOT, check=True)
    rows = []
    for n in [int(s) for s in a.sizes.split(",")]:
        for threads in [int(s) for s in a.threads.split(",")]:
            runs = {k: [] for k in ("tetfem", "tetfem_amd", "cholmod_metis", "cholmod_amd", "mfem")}
            for _ in range(a.repeat):
                print(f"side_by_side: n={n}, {threads} thread(s)", file=sys.stderr)
                runs["tetfem"].append(run_tetfem(n, threads, "nested-dissection"))
                runs["cholmod_metis"].append(run_peer(n, "cholmod", threads, "metis"))
                runs["tetfem_amd"].append(run_tetfem(n, threads, "amd"))
                runs["cholmod_amd"].append(run_peer(n, "cholmod", threads, "amd"))
                runs["mfem"].append(run_peer(n, "mfem", threads))
            rows.append((n, threads, {k: fastest(v) for k, v in runs.items()}))
    lines = ["# tetfem side by side with scikit-fem, MFEM and CHOLMOD", "",
             "Generated by `python3 validation/side_by_side.py` — do not edit by hand. "
             f"{datetime.now(timezone.utc):%Y-%m-%d %H:%M} UTC, {os.cpu_count()} cores, "
             f"fastest of {a.repeat} interleaved runs per entry (seconds). Peers: scikit-fem assembly + "
             "CHOLMOD (SuiteSparse 5.12, OpenBLAS) via scikit-sparse, PyMFEM assembly. Ratio < 1: tetfem faster.",
             "", "| mesh | DOFs | threads | phase | tetfem | peer | peer value | tetfem / peer |",
             "|---|---|---|---|---|---|---|---|"]
    for n, threads, r in rows:
        t, tamd, cm, ca, mf = r["tetfem"], r["tetfem_amd"], r["cholmod_metis"], r["cholmod_amd"], r["mfem"]
        mesh = f"{n}x{n // 10}x{n // 10}"
        first = t["pattern"] + t["assembly"]
        entries = [
            ("assembly K (pattern + values)", first, "scikit-fem", cm["assemble"]),
            ("assembly K (pattern + values)", first, "MFEM", mf["assemble"]),
            ("refill K (values only, in place)", t["refill"], "MFEM assembly", mf["assemble"]),
            ("K's values into a new array", t["assembly"], "MFEM assembly", mf["assemble"]),
            ("symbolic (METIS)", t["symbolic"], "CHOLMOD analyze METIS", cm["analyze"]),
            ("numeric factorization (METIS)", t["numeric"], "CHOLMOD METIS", cm["factorize"]),
            ("numeric factorization (AMD)", tamd["numeric"], "CHOLMOD AMD", ca["factorize"]),
            ("solve, 1 rhs (METIS)", t["solve"], "CHOLMOD METIS", cm["solve"]),
        ]
        for phase, ours, peer, theirs in entries:
            lines.append(f"| {mesh} | {t['dofs']} | {threads} | {phase} | {ours:.4f} | {peer} | "
                         f"{theirs:.4f} | {ratio(ours, theirs)} |")
        lines.append(f"| {mesh} | {t['dofs']} | {threads} | factor size (values) | {t['factor']} | "
                     f"CHOLMOD METIS nnz(L) | {cm['factor']} | {ratio(t['factor'], cm['factor'])} |")
        tip_diff = abs(t["tip"] - cm["tip"]) / abs(cm["tip"])
        lines.append(f"| {mesh} | {t['dofs']} | {threads} | tip deflection | {t['tip']:.10e} | "
                     f"scikit-fem + CHOLMOD | {cm['tip']:.10e} | rel. diff {tip_diff:.1e} |")
    lines += ["", "The refill writes K's values into its existing array (`Assembler::refill_stiffness`, best of 3), "
              "what a time stepper or Newton loop pays per matrix; the row below it is the assembly phase's values "
              "into a newly allocated array on the existing pattern, page faults of the first touch included.",
              "", "tetfem's factor size counts the stored values of faer's supernodal factor, including the "
              "zero padding of its dense supernode blocks; CHOLMOD's nnz(L) counts its own supernodal storage."]
    with open(a.out + ".tmp", "w") as f:
        f.write("\n".join(lines) + "\n")
    os.replace(a.out + ".tmp", a.out)
    print(f"wrote {a.out}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
