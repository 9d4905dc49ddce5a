#!/usr/bin/env python3
"""Speed against accuracy of the swinging beam: tetfem beside scikit-fem on identical meshes and
matrices, in one run (issue 37, item 1 c).

The beam: L = 10, W = 2, H = 1 (the swinging beam of `validate`'s "Speed vs accuracy"), E = 1e5,
nu = 0.3, rho = 1000, clamped at x = 0, released at rest from its static shape under an end load
of 1 (uniform traction (0, 0, -1/(W H)) on x = L), then free (no load). Meshes: tetfem's
`Mesh.box(split="lecture6")` (its points and tets given to scikit-fem as they are), P1 and P2
(a node at each edge's middle), consistent mass in both codes (so M and K are the same matrices
and the codes solve the same discrete problem).

Integrators, the same formulas in both codes (tetfem's `Simulation`, and for the peer a Python
loop on scikit-fem's assembled M and K with CHOLMOD factorizations made once):
- backward Euler: (M + dt^2 K) v1 = M v0 - dt K u0, u1 = u0 + dt v1;
- Newmark, average acceleration (beta = 1/4, gamma = 1/2): (M + dt^2/4 K) a1 =
  -K (u0 + dt v0 + dt^2/4 a0), v1 = v0 + dt/2 (a0 + a1), u1 = u0 + dt v0 + dt^2/4 (a0 + a1),
  a0 from M a0 = -K u0.
Quantity: the tip trajectory (mean z-displacement of the vertices on x = L) over one period T1 of
the reference's first mode, sampled 32 times; error = max over the samples of |tip - reference| /
max |reference|. Reference: scikit-fem P2 on 40 x 8 x 4 cells, Newmark at T1/2048 (no compared run);
its own error estimated from P2 20 x 4 x 2 at the same step (the space error of P2 falls ~4x per
halving of h, so the reference's is about a third of the difference).

Time: what a user waits for once the mesh exists: the static solve for the initial shape, the
matrices, the factorization(s) and the time loop with the tip sampled.

Usage: python3 validation/dynamic_speed_accuracy.py [--repeat 2] [--quick]
Writes validation/report/speed_accuracy_swing.{csv,png} and the section "Speed against accuracy:
swinging beam" of validation/SPEED_ACCURACY.md.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from datetime import datetime, timezone

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
PEERS_PYTHON = os.environ.get("TETFEM_PEERS_PYTHON", "/work/peers-venv/bin/python")
TETFEM_PYTHON = os.environ.get("TETFEM_PYTHON", "/work/pyenv/bin/python")
HEADING = "## Speed against accuracy: swinging beam"
L, W, H = 10.0, 2.0, 1.0
E, NU, RHO, LOAD = 1.0e5, 0.3, 1000.0, 1.0
SAMPLES = 32


def box(cells):
    """tetfem's lecture-split box mesh (points, tets) of order 1, from tetfem itself or a cached file."""
    import numpy as np
    path = os.path.join(tempfile.gettempdir(), f"swing_box_{cells[0]}_{cells[1]}_{cells[2]}.npz")
    if not os.path.exists(path):
        subprocess.run([TETFEM_PYTHON, "-c",
                        "import sys, numpy as np, tetfem\n"
                        f"m = tetfem.Mesh.box(max=({L}, {W}, {H}), cells={tuple(cells)}, split='lecture6')\n"
                        "np.savez(sys.argv[1], p=m.points, t=m.tets)", path], check=True)
    d = np.load(path)
    return d["p"], d["t"]


def run_tetfem(order, cells, method, steps, period):
    import numpy as np
    import tetfem
    p, t = box(cells)
    mesh = tetfem.Mesh.box(max=(L, W, H), cells=tuple(cells), split="lecture6", order=order)
    assert np.array_equal(mesh.points[: len(p)], p), "tetfem's box mesh changed between calls"
    tip = np.flatnonzero(np.abs(p[:, 0] - L) < 1e-12)
    t0 = time.perf_counter()
    material = tetfem.Material(E, NU, RHO)
    cons = tetfem.Constraints(mesh).fix(mesh.nodes_on_plane("x", 0.0))
    loads = tetfem.Loads(mesh).add_total_force(mesh.faces_on_plane("x", L), (0.0, 0.0, -LOAD))
    shape = np.asarray(tetfem.solve_static(mesh, material, cons, loads).displacement)
    sim = tetfem.Simulation(mesh, material, cons, None, dt=period / steps, method=method, mass="consistent",
                            initial_displacement=shape)
    traj = [float(shape[tip, 2].mean())]
    for k in range(1, steps + 1):
        sim.step()
        if k % (steps // SAMPLES) == 0:
            traj.append(float(sim.displacement[tip, 2].mean()))
    seconds = time.perf_counter() - t0
    return dict(traj=traj, seconds=seconds, dofs=int(sim.free_count))


def skfem_system(order, cells):
    import numpy as np
    from skfem import Basis, BilinearForm, ElementTetP1, ElementTetP2, ElementVector, FacetBasis, LinearForm, MeshTet, asm
    from skfem.helpers import dot
    from skfem.models.elasticity import linear_elasticity
    p, t = box(cells)
    m = MeshTet(np.ascontiguousarray(p.T), np.ascontiguousarray(t.T))
    t0 = time.perf_counter()
    basis = Basis(m, ElementVector(ElementTetP1() if order == 1 else ElementTetP2()), intorder=2 * order)
    lam, mu = E * NU / ((1 + NU) * (1 - 2 * NU)), E / (2 * (1 + NU))
    K = asm(linear_elasticity(lam, mu), basis)

    @BilinearForm
    def mass(u, v, w):
        return RHO * dot(u, v)

    M = asm(mass, basis)
    fb = FacetBasis(m, basis.elem, facets=m.facets_satisfying(lambda x: np.isclose(x[0], L)))

    @LinearForm
    def end(v, w):
        return -LOAD / (W * H) * v[2]

    f = asm(end, fb)
    fixed = basis.get_dofs(lambda x: np.isclose(x[0], 0.0)).all()
    free = np.setdiff1d(np.arange(basis.N), fixed)
    Kff, Mff = K.tocsr()[free][:, free].tocsc(), M.tocsr()[free][:, free].tocsc()
    tipn = np.flatnonzero(np.abs(p[:, 0] - L) < 1e-12)
    tipdofs = basis.nodal_dofs[2, tipn]
    tip = np.searchsorted(free, tipdofs)
    return Kff, Mff, f[free], tip, t0


def run_skfem(order, cells, method, steps, period):
    import numpy as np
    from sksparse.cholmod import cholesky
    Kff, Mff, ff, tip, t0 = skfem_system(order, cells)
    u = cholesky(Kff)(ff)
    v = np.zeros_like(u)
    dt = period / steps
    K = Kff.tocsr()
    traj = [float(u[tip].mean())]
    if method == "backward-euler":
        fac = cholesky((Mff + dt * dt * Kff).tocsc())
        Mr = Mff.tocsr()
        for k in range(1, steps + 1):
            v = fac(Mr @ v - dt * (K @ u))
            u = u + dt * v
            if k % (steps // SAMPLES) == 0:
                traj.append(float(u[tip].mean()))
    else:
        a = cholesky(Mff)(-(K @ u))
        fac = cholesky((Mff + 0.25 * dt * dt * Kff).tocsc())
        for k in range(1, steps + 1):
            pred = u + dt * v + 0.25 * dt * dt * a
            a1 = fac(-(K @ pred))
            u = pred + 0.25 * dt * dt * a1
            v = v + 0.5 * dt * (a + a1)
            a = a1
            if k % (steps // SAMPLES) == 0:
                traj.append(float(u[tip].mean()))
    seconds = time.perf_counter() - t0
    return dict(traj=traj, seconds=seconds, dofs=len(ff))


def period_of(order, cells):
    """T1 = 2 pi / omega1 of the generalized eigenproblem K x = omega^2 M x (scikit-fem's matrices)."""
    import numpy as np
    from scipy.sparse.linalg import LinearOperator, eigsh
    from sksparse.cholmod import cholesky
    Kff, Mff, _, _, _ = skfem_system(order, cells)
    fac = cholesky(Kff)
    op = LinearOperator(Kff.shape, matvec=lambda x: fac(x), dtype=float)
    vals = eigsh(Kff, k=1, M=Mff, sigma=0.0, OPinv=op, which="LM", return_eigenvectors=False)
    return 2 * np.pi / np.sqrt(vals[0])


def worker(args):
    code, order, cells, method, steps, period, out = args
    order, steps, period = int(order), int(steps), float(period)
    cells = [int(c) for c in cells.split("x")]
    if code == "period":
        r = dict(period=period_of(order, cells))
    elif code == "tetfem":
        r = run_tetfem(order, cells, method, steps, period)
    else:
        r = run_skfem(order, cells, method, steps, period)
    with open(out, "w") as f:
        json.dump(r, f)


def call(code, order, cells, method="newmark", steps=0, period=0.0):
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    from side_by_side import peer_env
    env = peer_env(1)
    env["RAYON_NUM_THREADS"] = "1"
    python = TETFEM_PYTHON if code == "tetfem" else PEERS_PYTHON
    with tempfile.TemporaryDirectory() as d:
        out = os.path.join(d, "r.json")
        subprocess.run([python, os.path.abspath(__file__), "--worker", code, str(order), cells, method,
                        str(steps), repr(period), out], env=env, check=True, capture_output=True, text=True)
        with open(out) as f:
            return json.load(f)


def load() -> str:
    with open("/proc/loadavg") as f:
        return " ".join(f.read().split()[:3])


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeat", type=int, default=2)
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--out", default=os.path.join(ROOT, "validation", "SPEED_ACCURACY.md"))
    ap.add_argument("--rewrite", action="store_true",
                    help="rewrite the CSV, chart and section from report/speed_accuracy_swing.json, run nothing")
    a = ap.parse_args()
    if a.rewrite:
        with open(os.path.join(ROOT, "validation", "report", "speed_accuracy_swing.json")) as f:
            d = json.load(f)
        a.repeat = d["repeat"]
        write(d["points"], d["period"], d["ref_cells"], d["ref_steps"], d["ref_error"], d["coarse_ref"],
              d["loads"], a, d["blas"], d["stamp"], d.get("agreement"))
        return 0
    ref_cells, coarse_ref = ("20x4x2", "10x2x1") if a.quick else ("40x8x4", "20x4x2")
    meshes = [(1, "10x2x1"), (1, "20x4x2"), (2, "10x2x1")] if a.quick else \
        [(1, "10x2x1"), (1, "20x4x2"), (1, "40x8x4"), (2, "10x2x1"), (2, "20x4x2")]
    steps_list = [32, 64, 128] if a.quick else [32, 64, 128, 256, 512, 1024]
    ref_steps = 512 if a.quick else 2048
    print(f"swing: period of P2 {ref_cells}", file=sys.stderr)
    period = call("period", 2, ref_cells)["period"]
    print(f"swing: reference P2 {ref_cells}, Newmark, T1/{ref_steps}", file=sys.stderr)
    ref = call("scikit-fem", 2, ref_cells, "newmark", ref_steps, period)["traj"]
    coarse = call("scikit-fem", 2, coarse_ref, "newmark", ref_steps, period)["traj"]
    scale = max(abs(r) for r in ref)
    ref_error = max(abs(x - y) for x, y in zip(ref, coarse)) / scale / 3.0
    before = load()
    runs = {}
    for _ in range(a.repeat):
        for order, cells in meshes:
            for steps in steps_list:
                for method in ("backward-euler", "newmark"):
                    for code in ("tetfem", "scikit-fem"):
                        print(f"swing: {code} P{order} {cells} {method} T/{steps} (load {load()})", file=sys.stderr)
                        r = call(code, order, cells, method, steps, period)
                        key = (code, order, cells, method, steps)
                        if key not in runs or r["seconds"] < runs[key]["seconds"]:
                            runs[key] = r
    after = load()
    points = []
    for (code, order, cells, method, steps), r in runs.items():
        err = max(abs(x - y) for x, y in zip(r["traj"], ref)) / scale
        points.append(dict(code=code, order=order, cells=cells, method=method, steps=steps, error=err,
                           seconds=r["seconds"], dofs=r["dofs"]))
    write(points, period, ref_cells, ref_steps, ref_error, coarse_ref, (before, after), a)
    return 0


def write(points, period, ref_cells, ref_steps, ref_error, coarse_ref, loads, a, blas=None, stamp=None,
          agreement=None):
    """The CSV, the chart, a JSON of the runs (for --rewrite) and the Markdown section."""
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    from side_by_side import blas_probe
    report = os.path.join(ROOT, "validation", "report")
    csv = os.path.join(report, "speed_accuracy_swing.csv")
    blas = blas or blas_probe(1)
    stamp = stamp or f"{datetime.now(timezone.utc):%Y-%m-%d %H:%M}"
    # How far the two codes' errors differ on the same run (full precision; the CSV rounds).
    spread = agreement if agreement is not None else max(
        abs(p["error"] - q["error"]) / max(p["error"], 1e-300) for p in points for q in points
        if p["code"] != q["code"] and (p["order"], p["cells"], p["method"], p["steps"])
        == (q["order"], q["cells"], q["method"], q["steps"]))
    with open(os.path.join(report, "speed_accuracy_swing.json"), "w") as f:
        json.dump(dict(points=points, period=period, ref_cells=ref_cells, ref_steps=ref_steps, ref_error=ref_error,
                       coarse_ref=coarse_ref, loads=list(loads), repeat=a.repeat, blas=blas, stamp=stamp,
                       agreement=spread), f, indent=0)
    front = [p for p in points if not any(q["seconds"] < p["seconds"] and q["error"] <= p["error"] * (1 + 1e-6)
                                          for q in points)]
    with open(csv, "w") as f:
        f.write(f"# swinging beam, tip trajectory over T1 = {period:.6f}; peers' BLAS: {blas}\n")
        f.write("code,order,mesh,method,steps_per_period,free_dofs,relative_error,seconds,pareto\n")
        for p in sorted(points, key=lambda p: (p["code"], p["order"], p["cells"], p["method"], p["steps"])):
            f.write(f"{p['code']},{p['order']},{p['cells']},{p['method']},{p['steps']},{p['dofs']},"
                    f"{p['error']:.6e},{p['seconds']:.6e},{int(p in front)}\n")
    subprocess.run([PEERS_PYTHON, os.path.join(ROOT, "validation", "speed_accuracy_chart.py"), csv,
                    os.path.join(report, "speed_accuracy_swing.png"), "--swing"], check=True)
    lines = [HEADING, "",
             f"Generated by `python3 validation/dynamic_speed_accuracy.py`, {stamp} "
             f"UTC, {os.cpu_count()} cores shared with other work (load average before / after: {loads[0]} / "
             f"{loads[1]}), one thread per code, fastest of {a.repeat} interleaved runs. Peers' BLAS: {blas}.", "",
             "Beam 10 × 2 × 1 (E = 1e5, ν = 0.3, ρ = 1000), clamped at x = 0, released at rest from its static "
             "shape under an end load of 1, free over one period T₁ = "
             f"{period:.5f} of the reference's first mode; tetfem's lecture-split box mesh given to scikit-fem "
             "as it is, consistent mass in both (same M and K). tetfem: `Simulation` (Python binding), "
             "scikit-fem: its assembled M and K with backward Euler and Newmark (β = 1/4, γ = 1/2) loops in "
             "Python on CHOLMOD factors made once. Time: static solve for the initial shape + matrices + "
             "factorizations + the loop, tip sampled 32 times. Error: max over the samples of |tip − reference| "
             f"/ max |reference|. Reference: scikit-fem P2 {ref_cells}, Newmark at T₁/{ref_steps}; its error "
             f"≈ {ref_error:.1e} (a third of its difference from P2 {coarse_ref} at the same step). The two codes' "
             f"errors agree to {spread:.1e} relative on every run (same discrete problem).", "",
             "| code | elements | mesh | method | steps / T₁ | free DOFs | error | wall time [s] | Pareto |",
             "|---|---|---|---|---|---|---|---|---|"]
    for p in sorted(points, key=lambda p: (p["order"], p["cells"], p["method"], p["steps"], p["code"])):
        lines.append(f"| {p['code']} | P{p['order']} | {p['cells']} | {p['method']} | {p['steps']} | {p['dofs']} | "
                     f"{p['error']:.2e} | {p['seconds']:.4f} | {'◆' if p in front else ''} |")
    lines += ["", "| code | least time to 10 % | to 1 % | to 0.1 % |", "|---|---|---|---|"]
    for code in ("tetfem", "scikit-fem"):
        cells = []
        for target in (0.1, 0.01, 0.001):
            ok = [p for p in points if p["code"] == code and p["error"] <= target]
            ours = [p for p in points if p["code"] == "tetfem" and p["error"] <= target]
            if not ok:
                cells.append("not reached")
                continue
            b = min(ok, key=lambda p: p["seconds"])
            text = f"{b['seconds']:.3f} s (P{b['order']} {b['cells']}, {b['method']}, T/{b['steps']})"
            if code != "tetfem" and ours:
                text += f", {b['seconds'] / min(p['seconds'] for p in ours):.1f}× tetfem"
            cells.append(text)
        lines.append(f"| {code} | " + " | ".join(cells) + " |")
    # Same mesh, order, method and step in both codes: the same discrete run, so the time ratio is
    # the codes' speed on it, at every accuracy.
    ratios = {}
    for p in points:
        if p["code"] != "scikit-fem":
            continue
        ours = next(q for q in points if q["code"] == "tetfem" and all(q[k] == p[k] for k in
                                                                         ("order", "cells", "method", "steps")))
        ratios.setdefault((p["order"], p["method"]), []).append(p["seconds"] / ours["seconds"])
    lines += ["", "scikit-fem's wall time over tetfem's on the same run (same mesh, order, method and step), over "
              "the meshes and steps of each row:", "", "| elements | method | runs | least | median | most |",
              "|---|---|---|---|---|---|"]
    for (order, method), r in sorted(ratios.items()):
        r = sorted(r)
        lines.append(f"| P{order} | {method} | {len(r)} | {r[0]:.1f}× | {r[len(r) // 2]:.1f}× | {r[-1]:.1f}× |")
    lines += ["", "Neither code reaches 1 % here: P2 on 20 × 4 × 2 cells, the finest compared mesh, stays "
              "at its space error (its period differs from the reference's, so its phase drifts over the period); "
              "a finer compared mesh needs a reference finer still (P2 80 × 16 × 8, about 270k DOFs, at "
              "T₁/2048: not run on this shared machine)."]
    lines += ["", "![Speed against accuracy: swinging beam, tetfem beside scikit-fem](report/speed_accuracy_swing.png)",
              "", "Data: [report/speed_accuracy_swing.csv](report/speed_accuracy_swing.csv)."]
    old = open(a.out).read() if os.path.exists(a.out) else "# Speed against accuracy, tetfem beside its peers\n"
    head, _, rest = old.partition(HEADING)
    tail = ("\n## " + rest.split("\n## ", 1)[1]) if rest and "\n## " in rest else ""
    with open(a.out + ".tmp", "w") as f:
        f.write(head.rstrip("\n") + "\n\n" + "\n".join(lines) + "\n" + tail)
    os.replace(a.out + ".tmp", a.out)
    print(f"wrote {a.out}", file=sys.stderr)


if __name__ == "__main__":
    if len(sys.argv) > 1 and sys.argv[1] == "--worker":
        worker(sys.argv[2:])
        sys.exit(0)
    sys.exit(main())
