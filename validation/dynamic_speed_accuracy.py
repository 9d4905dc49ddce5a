#!/usr/bin/env python3
"""Speed against accuracy of the swinging beam: tetfem beside scikit-fem and MFEM on identical meshes
and matrices, in one run (issue 37, item 1 c).

The beam: L = 10, W = 2, H = 1 (the swinging beam of `validate`'s "Speed vs accuracy"), E = 1e5,
nu = 0.3, rho = 1000, clamped at x = 0, released at rest from its static shape under an end load
of 1 (uniform traction (0, 0, -1/(W H)) on x = L), then free (no load). Meshes: tetfem's
`Mesh.box(split="lecture6")` (its points and tets given to scikit-fem and MFEM as they are), P1 and
P2 (a node at each edge's middle; MFEM H1 order 1 and 2).

Integrators, the same formulas in every code (tetfem's `Simulation`; for the peers a Python loop on
their own assembled M and K, with CHOLMOD factorizations made once):
- backward Euler (consistent mass): (M + dt^2 K) v1 = M v0 - dt K u0, u1 = u0 + dt v1;
- Newmark, average acceleration (beta = 1/4, gamma = 1/2; consistent mass): (M + dt^2/4 K) a1 =
  -K (u0 + dt v0 + dt^2/4 a0), v1 = v0 + dt/2 (a0 + a1), u1 = u0 + dt v0 + dt^2/4 (a0 + a1),
  a0 from M a0 = -K u0;
- explicit (lumped mass, tetfem's `SymplecticEuler`, the velocity form of central differences):
  v1 = v0 - dt Ml^-1 K u0, u1 = u0 + dt v1, at dt = 0.9 and 0.45 of tetfem's critical step 2/omega_max
  (the same step count in every code). Ml: row sums for P1 (rho V/4 a node), HRZ for P2 (the
  consistent diagonal scaled to the element's mass: rho V/36 a corner, 4 rho V/27 an edge node);
  the peers take diag(M) * 3 rho L W H / trace(M) of their consistent M, which is both (every
  straight tet's diagonal has the same proportions), then the free rows.
So M and K are the same matrices in every code and the codes solve the same discrete problem: their
trajectories agree to round-off (printed in the section).

Quantity: the tip trajectory (mean z-displacement of the vertices on x = L) over one period T1 of
the reference's first mode, sampled 32 times; error = max over the samples of |tip - reference| /
max |reference|. Reference: MFEM order 5 on 16 x 4 x 4 cells graded toward the clamped face's edges
(the singular lines that hold uniform meshes to a slow rate; see `grade`), solved exactly in time by
modal superposition of its lowest 48 modes (`modal`), T1 its own first period. Its space error is
estimated from the spread of the levels before it (MFEM orders 3 to 5 on graded meshes), the
modes left out from the change between half of them and all; an independent check runs one level
with Newmark at T1/2048 and T1/4096 against its modal solution. No compared run enters it.

Time: what a user waits for once the mesh exists: the static solve for the initial shape, the
matrices, the factorization(s) and the time loop with the tip sampled.

Usage: python3 validation/dynamic_speed_accuracy.py [--repeat 2] [--quick] [--rewrite]
Writes validation/report/speed_accuracy_swing.{csv,json,png} and the section "Speed against
accuracy: swinging beam" of validation/SPEED_ACCURACY.md. The chart needs matplotlib in the peers'
Python (TETFEM_PEERS_PYTHON) or in TETFEM_CHART_PYTHON.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
import time
from datetime import datetime, timezone

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
PEERS_PYTHON = os.environ.get("TETFEM_PEERS_PYTHON", "/work/peers-venv/bin/python")
TETFEM_PYTHON = os.environ.get("TETFEM_PYTHON", "/work/pyenv/bin/python")
CHART_PYTHON = os.environ.get("TETFEM_CHART_PYTHON", PEERS_PYTHON)
HEADING = "## Speed against accuracy: swinging beam"
L, W, H = 10.0, 2.0, 1.0
E, NU, RHO, LOAD = 1.0e5, 0.3, 1000.0, 1.0
LAM, MU = E * NU / ((1 + NU) * (1 - 2 * NU)), E / (2 * (1 + NU))
SAMPLES = 32
CODES = ("tetfem", "scikit-fem", "MFEM")
METHODS = ("backward-euler", "newmark", "explicit")
# Explicit steps as fractions of the critical step: the usual 0.9 and half of it (the time error
# of either is far below the lumped mass's space error, so the second shows only its cost).
EXPLICIT_FRACTIONS = (0.9, 0.45)

# The compared runs: (order, cells, {method: steps per period}); explicit: fractions of dt_crit.
# P1 locks in bending (errors near 100 %): a few steps show it. Backward Euler is first order (its
# error ~ 2 pi^2 / steps), so its steps go to 2048 on the P2 meshes where that is cheap; on the two
# finest (16k and 37k DOFs, 10 to 60 s a run) only Newmark runs, at the steps that can reach 1 %
# (its phase error on the second bending mode, at 6 omega_1, is ~7e-3 at T1/128). Explicit steps
# are set by the critical step (15k a period on P2 40x8x4), so it runs on the smaller meshes.
PLAN = [
    (1, "10x2x1", {"backward-euler": [32, 128, 512], "newmark": [32, 128, 512], "explicit": (0.9,)}),
    (1, "20x4x2", {"backward-euler": [32, 512], "newmark": [32, 512], "explicit": (0.9,)}),
    (1, "40x8x4", {"backward-euler": [32, 512], "newmark": [32, 512], "explicit": (0.9,)}),
    (2, "10x2x1", {"backward-euler": [32, 128, 512, 2048], "newmark": [32, 64, 128, 256, 512, 1024],
                   "explicit": EXPLICIT_FRACTIONS}),
    (2, "20x4x2", {"backward-euler": [128, 512, 2048], "newmark": [32, 64, 128, 256, 512],
                   "explicit": EXPLICIT_FRACTIONS}),
    (2, "30x6x3", {"newmark": [128, 256, 512]}),
    (2, "40x8x4", {"newmark": [256, 512]}),
]
QUICK_PLAN = [
    (1, "10x2x1", {"backward-euler": [32, 128], "newmark": [32, 128], "explicit": (0.9,)}),
    (2, "10x2x1", {"backward-euler": [32, 128], "newmark": [32, 128], "explicit": (0.9,)}),
]
# The reference levels (MFEM order, cells; "g": graded toward the clamped face's edges), the last
# the reference itself, each solved by modal superposition exact in time (`modal`); CHECK is also
# run with Newmark at T1/NEWMARK_CHECK_STEPS, a check of the modal solution independent of it.
REFERENCE = [(3, "10x4x2g"), (4, "10x4x2g"), (4, "16x4x4g"), (5, "16x4x4g")]
CHECK = (3, "10x4x2g")
QUICK_REFERENCE = [(2, "10x2x1"), (3, "10x2x1"), (4, "10x2x1")]
QUICK_CHECK = (2, "10x2x1")
NEWMARK_CHECK_STEPS = (2048, 4096)
# Modes in the modal reference: the static shape under an end load is 97 % the first bending mode;
# the shares of the tip fall with frequency (measured on order 3 10x4x2g: 3e-3 at omega = 16 omega_1,
# 2e-4 at 69 omega_1, below 2e-5 past the 20th mode), so 48 leave out less than the space error.
MODES = 48


# ------------------------------------------------------------------------------------ the mesh
def box(cells):
    """The box mesh (points, tets) of order 1 for a cells string "20x4x2" (tetfem's lecture-split box,
    from tetfem itself or a cached file) or "20x4x2g" (the same tets, the points graded: see `grade`)."""
    import numpy as np
    counts = tuple(int(c) for c in cells.rstrip("g").split("x"))
    path = os.path.join(tempfile.gettempdir(), f"swing_box_{counts[0]}_{counts[1]}_{counts[2]}.npz")
    if not os.path.exists(path):
        subprocess.run([TETFEM_PYTHON, "-c",
                        "import sys, numpy as np, tetfem\n"
                        f"m = tetfem.Mesh.box(max=({L}, {W}, {H}), cells={counts}, split='lecture6')\n"
                        "np.savez(sys.argv[1], p=m.points, t=m.tets)", path], check=True)
    d = np.load(path)
    return (grade(d["p"]) if cells.endswith("g") else d["p"]), d["t"]


# The grading of the "g" meshes: exponential toward the clamped face x = 0, tanh toward the faces
# y = 0, W and z = 0, H. The clamped face's edges are singular lines (the stress grows like r^(lambda - 1)
# there, lambda < 1), which hold uniform meshes of any order to a slow algebraic rate; cells graded
# toward them take most of that error away (measured, the first period: MFEM order 4 on the uniform
# 20x4x2 61.848, on 16x4x4g 61.875, order 5 on 16x4x4g 61.876).
GRADE_X, GRADE_YZ = 6.0, 3.0


def grade(p):
    """x -> L (e^(b x/L) - 1)/(e^b - 1) (b = GRADE_X), y -> W (1 + tanh(g (2y/W - 1))/tanh g)/2 and the
    same in z (g = GRADE_YZ): monotone in each coordinate, so the tets stay valid."""
    import numpy as np
    q = np.array(p, dtype=float)
    q[:, 0] = L * np.expm1(GRADE_X * p[:, 0] / L) / math.expm1(GRADE_X)
    q[p[:, 0] == L, 0] = L  # the tip face exactly on its plane (the map's round-off there is 1 ulp)
    for axis, extent in ((1, W), (2, H)):
        u = 2 * p[:, axis] / extent - 1
        q[:, axis] = extent * 0.5 * (1 + np.tanh(GRADE_YZ * u) / math.tanh(GRADE_YZ))
    return q


def tip_vertices(p):
    """The vertices on x = L (the tip face), whose mean z-displacement is the tip."""
    import numpy as np
    return np.flatnonzero(np.abs(p[:, 0] - L) < 1e-12)


# ------------------------------------------------------------------------------------ tetfem
def tetfem_mesh(order, cells):
    """tetfem's mesh: its own box for the uniform meshes; for the graded ones the points and tets as
    arrays (P1) or, P2, a Gmsh 2.2 file of 10-node tets with the edge nodes at the straight edges'
    middles (the binding's Mesh(points, tets) takes 4-node tets only)."""
    import tetfem
    if not cells.endswith("g"):
        counts = tuple(int(c) for c in cells.split("x"))
        return tetfem.Mesh.box(max=(L, W, H), cells=counts, split="lecture6", order=order)
    p, t = box(cells)
    if order == 1:
        return tetfem.Mesh(p, t)
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    from hole_speed_accuracy import tet10, write_gmsh22_tet10
    with tempfile.TemporaryDirectory() as d:
        path = os.path.join(d, "beam.msh")
        write_gmsh22_tet10(path, *tet10(p, t))
        return tetfem.Mesh.read(path, order=2)


def tetfem_simulation(order, cells, method, dt):
    """tetfem's mesh, the static shape under the end load and a `Simulation` released from it."""
    import numpy as np
    import tetfem
    mesh = tetfem_mesh(order, cells)
    t0 = time.perf_counter()
    material = tetfem.Material(E, NU, RHO)
    cons = tetfem.Constraints(mesh).fix(mesh.nodes_on_plane("x", 0.0))
    loads = tetfem.Loads(mesh).add_total_force(mesh.faces_on_plane("x", L), (0.0, 0.0, -LOAD))
    shape = np.asarray(tetfem.solve_static(mesh, material, cons, loads).displacement)
    mass = "lumped" if method == "explicit" else "consistent"
    sim = tetfem.Simulation(mesh, material, cons, None, dt=dt, method=method, mass=mass,
                            initial_displacement=shape)
    return mesh, sim, shape, t0


def run_tetfem(order, cells, method, steps, period):
    import numpy as np
    p, _ = box(cells)
    mesh, sim, shape, t0 = tetfem_simulation(order, cells, method, period / steps)
    if not np.array_equal(mesh.points[: len(p)], p):
        raise RuntimeError("tetfem's mesh does not start with the box's points")
    tip = tip_vertices(p)
    traj = [float(shape[tip, 2].mean())]
    for k in range(1, steps + 1):
        sim.step()
        if k % (steps // SAMPLES) == 0:
            traj.append(float(sim.displacement[tip, 2].mean()))
    seconds = time.perf_counter() - t0
    return dict(traj=traj, seconds=seconds, dofs=int(sim.free_count))


def critical_step(order, cells):
    """tetfem's explicit critical step 2/omega_max (lumped mass, Lanczos iteration with its proof)."""
    _, sim, _, _ = tetfem_simulation(order, cells, "explicit", 1.0)
    return dict(dt_crit=float(sim.critical_time_step))


# ------------------------------------------------------------------------------------ the peers
def lumped(M_full):
    """The lumped mass of a consistent M on straight tets: diag(M) scaled to the body's mass 3 rho L W H
    (over the three axes). For P1 that is the row sum rho V/4 a node, for P2 HRZ (rho V/36 a corner,
    4 rho V/27 an edge node): tetfem's LUMPED_MASS weights."""
    d = M_full.diagonal()
    return d * (3.0 * RHO * L * W * H / d.sum())


def skfem_system(order, cells):
    """scikit-fem's free K, M, end load, tip DOFs (in the free numbering), lumped mass and start time."""
    import numpy as np
    from skfem import Basis, BilinearForm, ElementTetP1, ElementTetP2, ElementVector, FacetBasis, LinearForm, MeshTet, asm
    from skfem.helpers import dot
    from skfem.models.elasticity import linear_elasticity
    p, t = box(cells)
    m = MeshTet(np.ascontiguousarray(p.T), np.ascontiguousarray(t.T))
    t0 = time.perf_counter()
    basis = Basis(m, ElementVector(ElementTetP1() if order == 1 else ElementTetP2()), intorder=2 * order)
    K = asm(linear_elasticity(LAM, MU), basis)

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
    tip = np.searchsorted(free, basis.nodal_dofs[2, tip_vertices(p)])
    return dict(K=Kff, M=Mff, f=f[free], tip=tip, lumped=lumped(M)[free], t0=t0)


def mfem_system(order, cells):
    """MFEM's (H1 order `order`, ElasticityIntegrator, VectorMassIntegrator, the end traction by
    VectorBoundaryLFIntegrator) free K, M, load, tip DOFs, lumped mass and start time. The mesh file
    is the box's vertices and tets as they are; boundary attribute 1 on x = 0, 2 on x = L, 3 else."""
    import numpy as np
    import scipy.sparse as sp
    import mfem.ser as mfem
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    from hole_speed_accuracy import write_mfem_mesh
    p, t = box(cells)

    def attrs(tris):
        x = p[tris][:, :, 0]
        a = np.full(len(tris), 3)
        a[np.all(x == 0.0, axis=1)] = 1
        a[np.all(x == L, axis=1)] = 2
        return a

    with tempfile.TemporaryDirectory() as d:
        path = os.path.join(d, "beam.mesh")
        write_mfem_mesh(path, p, t, attrs)
        m = mfem.Mesh(path, 1, 0)
    t0 = time.perf_counter()
    fec = mfem.H1_FECollection(order, 3)
    fes = mfem.FiniteElementSpace(m, fec, 3, mfem.Ordering.byVDIM)
    ess = mfem.intArray()
    fes.GetEssentialTrueDofs(mfem.intArray([1, 0, 0]), ess)
    # MFEM keeps pointers to the coefficients and markers: they must outlive the assembly.
    lam_c, mu_c, rho_c = mfem.ConstantCoefficient(LAM), mfem.ConstantCoefficient(MU), mfem.ConstantCoefficient(RHO)
    trac = mfem.VectorConstantCoefficient(mfem.Vector([0.0, 0.0, -LOAD / (W * H)]))
    end_marker = mfem.intArray([0, 1, 0])
    matrices = []
    for integrator in (mfem.ElasticityIntegrator(lam_c, mu_c), mfem.VectorMassIntegrator(rho_c)):
        bf = mfem.BilinearForm(fes)
        bf.AddDomainIntegrator(integrator)
        bf.Assemble()
        bf.Finalize()
        a = bf.SpMat()
        n = a.Height()
        matrices.append(sp.csr_matrix((a.GetDataArray().copy(), a.GetJArray().copy(), a.GetIArray().copy()),
                                      shape=(n, n)))
    lf = mfem.LinearForm(fes)
    lf.AddBoundaryIntegrator(mfem.VectorBoundaryLFIntegrator(trac), end_marker)
    lf.Assemble()
    f = lf.GetDataArray().copy()
    K, M = matrices
    mask = np.ones(K.shape[0], dtype=bool)
    mask[np.array(ess.ToList(), dtype=np.int64)] = False
    free = np.flatnonzero(mask)
    # H1 numbers the vertex DOFs first, in vertex order; byVDIM puts the axes of a DOF together.
    tipdofs = np.array([fes.DofToVDof(int(v), 2) for v in tip_vertices(p)])
    if not np.array_equal(tipdofs, 3 * tip_vertices(p) + 2):
        raise RuntimeError("MFEM's vertex DOFs are not numbered as its vertices")
    return dict(K=K[free][:, free].tocsc(), M=M[free][:, free].tocsc(), f=f[free],
                tip=np.searchsorted(free, tipdofs), lumped=lumped(M)[free], t0=t0)


def run_peer(system, method, steps, period):
    """The three loops on a peer's assembled matrices, CHOLMOD factorizations made once."""
    import numpy as np
    from sksparse.cholmod import cholesky
    Kff, Mff, ff, tip, t0 = system["K"], system["M"], system["f"], system["tip"], system["t0"]
    u = cholesky(Kff)(ff)
    v = np.zeros_like(u)
    dt = period / steps
    K = Kff.tocsr()
    traj = [float(u[tip].mean())]

    def sample(k, u):
        if k % (steps // SAMPLES) == 0:
            traj.append(float(u[tip].mean()))

    if method == "backward-euler":
        fac = cholesky((Mff + dt * dt * Kff).tocsc())
        Mr = Mff.tocsr()
        for k in range(1, steps + 1):
            v = fac(Mr @ v - dt * (K @ u))
            u = u + dt * v
            sample(k, u)
    elif method == "newmark":
        a = cholesky(Mff)(-(K @ u))
        fac = cholesky((Mff + 0.25 * dt * dt * Kff).tocsc())
        for k in range(1, steps + 1):
            pred = u + dt * v + 0.25 * dt * dt * a
            a1 = fac(-(K @ pred))
            u = pred + 0.25 * dt * dt * a1
            v = v + 0.5 * dt * (a + a1)
            a = a1
            sample(k, u)
    else:
        step = dt / system["lumped"]
        for k in range(1, steps + 1):
            v = v - step * (K @ u)
            u = u + dt * v
            sample(k, u)
    seconds = time.perf_counter() - t0
    return dict(traj=traj, seconds=seconds, dofs=len(ff))


def modal(order, cells, period):
    """The trajectory of MFEM's order-`order` discretization exact in time: u(t) = sum_i phi_i c_i
    cos(omega_i t) over its lowest MODES modes (K phi = omega^2 M phi, M-orthonormal, by shift-invert
    Lanczos at 0 on a CHOLMOD factor of K), c = Phi^T M u0 of the static shape u0, sampled at
    k T/32 with T = `period` (0: its own first period 2 pi/omega_1). `truncation`: how far the sum over
    the lower half of the modes is from the whole, relative to the amplitude (the modes' shares of the
    tip fall fast with frequency, so the rest past MODES is below it)."""
    import numpy as np
    from scipy.sparse.linalg import LinearOperator, eigsh
    from sksparse.cholmod import cholesky
    s = mfem_system(order, cells)
    K, M = s["K"], s["M"]
    fac = cholesky(K)
    u0 = fac(s["f"])
    op = LinearOperator(K.shape, matvec=lambda x: fac(x), dtype=float)
    vals, vecs = eigsh(K, k=MODES, M=M, sigma=0.0, OPinv=op, which="LM")
    by = np.argsort(vals)
    omega, vecs = np.sqrt(vals[by]), vecs[:, by]
    own = 2 * np.pi / omega[0]
    period = period or own
    ell = np.zeros(len(u0))
    ell[s["tip"]] = 1.0 / len(s["tip"])
    share = (ell @ vecs) * (vecs.T @ (M @ u0))
    times = np.arange(1, SAMPLES + 1) * period / SAMPLES
    waves = np.cos(np.outer(times, omega)) * share
    traj = [float(ell @ u0)] + [float(x) for x in waves.sum(axis=1)]
    half = [float(ell @ u0)] + [float(x) for x in waves[:, : MODES // 2].sum(axis=1)]
    seconds = time.perf_counter() - s["t0"]
    return dict(traj=traj, period=own, dofs=len(u0), truncation=trajectory_error(half, traj), modes=MODES,
                seconds=seconds)


def worker(args):
    code, order, cells, method, steps, period, out = args
    order, steps, period = int(order), int(steps), float(period)
    if code == "modal":
        r = modal(order, cells, period)
    elif code == "critical":
        r = critical_step(order, cells)
    elif code == "tetfem":
        r = run_tetfem(order, cells, method, steps, period)
    elif code == "scikit-fem":
        r = run_peer(skfem_system(order, cells), method, steps, period)
    elif code == "MFEM":
        r = run_peer(mfem_system(order, cells), method, steps, period)
    else:
        raise ValueError(code)
    with open(out, "w") as f:
        json.dump(r, f)


# ------------------------------------------------------------------------------------ the driver
def call(code, order, cells, method="newmark", steps=0, period=0.0):
    """One worker process (one run), one thread: OpenBLAS's real kernel for the peers
    (side_by_side.peer_env), one rayon thread for tetfem."""
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    from side_by_side import peer_env
    env = peer_env(1)
    env["RAYON_NUM_THREADS"] = "1"
    python = TETFEM_PYTHON if code in ("tetfem", "critical") else PEERS_PYTHON
    with tempfile.TemporaryDirectory() as d:
        out = os.path.join(d, "r.json")
        run = subprocess.run([python, os.path.abspath(__file__), "--worker", code, str(order), cells, method,
                              str(steps), repr(period), out], env=env, capture_output=True, text=True)
        if run.returncode != 0:
            raise RuntimeError(f"{code} P{order} {cells} {method} {steps}: {run.stderr[-2000:]}")
        with open(out) as f:
            return json.load(f)


def load() -> str:
    with open("/proc/loadavg") as f:
        return " ".join(f.read().split()[:3])


def mfem_installed() -> bool:
    return subprocess.run([PEERS_PYTHON, "-c", "import mfem.ser"], capture_output=True).returncode == 0


def trajectory_error(traj, ref):
    """max over the samples of |traj - ref| / max |ref|."""
    scale = max(abs(r) for r in ref)
    return max(abs(x - y) for x, y in zip(traj, ref)) / scale


def reference(levels, check):
    """The reference trajectory (MFEM's modal solution on the last level, exact in time), its period
    (the last level's own first period) and its error: the space part the largest difference of the
    last level from the two before it (all sampled at the last level's period), the truncation its
    bound; and the check of the modal machinery: Newmark at T1/NEWMARK_CHECK_STEPS on the level
    `check` against that level's modal trajectory."""
    t_start = time.perf_counter()
    order, cells = levels[-1]
    print(f"swing: reference MFEM order {order} {cells}, {MODES} modes", file=sys.stderr)
    last = call("modal", order, cells, period=0.0)
    period = last["period"]
    runs = []
    for order, cells in levels[:-1]:
        print(f"swing: reference level MFEM order {order} {cells}, {MODES} modes", file=sys.stderr)
        runs.append(dict(call("modal", order, cells, period=period), order=order, cells=cells))
    runs.append(dict(last, order=levels[-1][0], cells=levels[-1][1]))
    ref = runs[-1]["traj"]
    for r in runs:
        r["difference"] = trajectory_error(r["traj"], ref)
    space = max(r["difference"] for r in runs[-3:-1])
    truncation = runs[-1]["truncation"]
    level = next(r for r in runs if (r["order"], r["cells"]) == check)
    checks = []
    for steps in NEWMARK_CHECK_STEPS:
        print(f"swing: check MFEM order {check[0]} {check[1]}, Newmark at T1/{steps}", file=sys.stderr)
        newmark = call("MFEM", check[0], check[1], "newmark", steps, period)
        checks.append(dict(steps=steps, difference=trajectory_error(newmark["traj"], level["traj"]),
                           seconds=newmark["seconds"]))
    return dict(traj=ref, period=period, levels=runs, space_error=space, truncation=truncation,
                check=list(check), checks=checks, seconds=time.perf_counter() - t_start)


def explicit_steps(plan, period):
    """Steps per period for each explicit run: the least multiple of SAMPLES with dt at or below the
    fraction of tetfem's critical step (the same count in every code)."""
    steps = {}
    for order, cells, methods in plan:
        if "explicit" not in methods:
            continue
        dt_crit = call("critical", order, cells)["dt_crit"]
        for fraction in methods["explicit"]:
            n = math.ceil(period / (fraction * dt_crit) / SAMPLES) * SAMPLES
            steps[(order, cells, fraction)] = dict(steps=n, dt_crit=dt_crit, dt_over_crit=period / n / dt_crit)
    return steps


def sweep(plan, codes, repeat, period, explicit):
    """Every run of the plan in every code, `repeat` times, interleaved (all codes on one run before
    the next), the fastest of each kept."""
    runs = {}
    for rep in range(repeat):
        for order, cells, methods in plan:
            for method, steps_list in methods.items():
                for s in steps_list:
                    steps = explicit[(order, cells, s)]["steps"] if method == "explicit" else s
                    for code in codes:
                        print(f"swing: pass {rep + 1}/{repeat} {code} P{order} {cells} {method} T/{steps} "
                              f"(load {load()})", file=sys.stderr)
                        r = call(code, order, cells, method, steps, period)
                        key = (code, order, cells, method, steps)
                        if key not in runs or r["seconds"] < runs[key]["seconds"]:
                            runs[key] = r
    return runs


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeat", type=int, default=2)
    ap.add_argument("--quick", action="store_true", help="small meshes and a cheap reference (a check of the harness)")
    ap.add_argument("--out", default=os.path.join(ROOT, "validation", "SPEED_ACCURACY.md"))
    ap.add_argument("--rewrite", action="store_true",
                    help="rewrite the CSV, chart and section from report/speed_accuracy_swing.json, run nothing")
    a = ap.parse_args()
    if a.rewrite:
        with open(os.path.join(ROOT, "validation", "report", "speed_accuracy_swing.json")) as f:
            d = json.load(f)
        write(d, a.out)
        return 0
    started = time.perf_counter()
    codes = CODES if mfem_installed() else CODES[:2]
    if "MFEM" not in codes:
        print("swing: PyMFEM does not import in the peers' Python: no MFEM runs, and no reference", file=sys.stderr)
        return 1
    plan = QUICK_PLAN if a.quick else PLAN
    ref = reference(QUICK_REFERENCE if a.quick else REFERENCE, QUICK_CHECK if a.quick else CHECK)
    explicit = explicit_steps(plan, ref["period"])
    before = load()
    runs = sweep(plan, codes, a.repeat, ref["period"], explicit)
    after = load()
    points = []
    for (code, order, cells, method, steps), r in runs.items():
        p = dict(code=code, order=order, cells=cells, method=method, steps=steps,
                 error=trajectory_error(r["traj"], ref["traj"]), seconds=r["seconds"], dofs=r["dofs"], traj=r["traj"])
        if method == "explicit":
            p["dt_over_crit"] = next(e["dt_over_crit"] for (o, c, _), e in explicit.items()
                                     if (o, c) == (order, cells) and e["steps"] == steps)
        points.append(p)
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    from side_by_side import blas_probe
    blas = blas_probe(1).strip().splitlines()[-1]
    d = dict(points=points, reference={k: v for k, v in ref.items() if k != "traj"}, ref_traj=ref["traj"],
             loads=[before, after], repeat=a.repeat, blas=blas, codes=list(codes),
             stamp=f"{datetime.now(timezone.utc):%Y-%m-%d %H:%M}", quick=a.quick,
             script_seconds=time.perf_counter() - started)
    with open(os.path.join(ROOT, "validation", "report", "speed_accuracy_swing.json"), "w") as f:
        json.dump(d, f, indent=0)
    write(d, a.out)
    return 0


# ------------------------------------------------------------------------------------ the outputs
def pareto(points):
    """No other run both faster and at least as accurate (the codes' runs of one mesh, order, method
    and step agree to round-off, so equal errors count as equal and only the fastest stays)."""
    return [p for p in points
            if not any(q["seconds"] < p["seconds"] and q["error"] <= p["error"] * (1 + 1e-6) for q in points)]


def same_run(p, q):
    return all(p[k] == q[k] for k in ("order", "cells", "method", "steps"))


def agreement(points, peer):
    """The largest difference between `peer`'s tip trajectory and tetfem's on the same run, relative
    to the reference's amplitude (the scale of the errors), and of the two errors, relative."""
    traj, err = 0.0, 0.0
    for p in points:
        if p["code"] != peer:
            continue
        q = next(q for q in points if q["code"] == "tetfem" and same_run(p, q))
        scale = max(abs(x) for x in q["traj"])
        traj = max(traj, max(abs(x - y) for x, y in zip(p["traj"], q["traj"])) / scale)
        err = max(err, abs(p["error"] - q["error"]) / q["error"])
    return traj, err


def front_cell(points, code, target, methods=METHODS, margin=0.0):
    """The least time of `code` (over `methods`) to an error at or below `target` (with `margin`, the
    reference's own error, added to each run's: a run certainly below the target), and the run."""
    ok = [p for p in points if p["code"] == code and p["method"] in methods and p["error"] + margin <= target]
    return min(ok, key=lambda p: p["seconds"]) if ok else None


def run_name(p):
    steps = f"T/{p['steps']}" + (f" = {p['dt_over_crit']:.2f} dt_crit" if p["method"] == "explicit" else "")
    return f"P{p['order']} {p['cells']}, {p['method']}, {steps}"


def fronts_table(points, codes, methods, label, margin=0.0):
    lines = [f"| {label} | to 10 % | to 1 % | to 0.1 % |", "|---|---|---|---|"]
    for code in codes:
        cells = []
        for target in (0.1, 0.01, 0.001):
            b = front_cell(points, code, target, methods, margin)
            ours = front_cell(points, "tetfem", target, methods, margin)
            if b is None:
                least = min((p["error"] for p in points if p["code"] == code and p["method"] in methods))
                cells.append(f"not reached (least error {least:.1e})")
                continue
            text = f"{b['seconds']:.3f} s ({run_name(b)})"
            if code != "tetfem":
                text += f", {b['seconds'] / ours['seconds']:.1f}× tetfem" if ours else ", tetfem: not reached"
            cells.append(text)
        lines.append(f"| {code} | " + " | ".join(cells) + " |")
    return lines


def ratios_table(points, codes):
    """Each peer's wall time over tetfem's on the same run, over the meshes and steps of a row."""
    ratios = {}
    for p in points:
        if p["code"] == "tetfem":
            continue
        q = next(q for q in points if q["code"] == "tetfem" and same_run(p, q))
        ratios.setdefault((p["code"], p["order"], p["method"]), []).append(p["seconds"] / q["seconds"])
    lines = ["| peer | elements | method | runs | least | median | most |", "|---|---|---|---|---|---|---|"]
    for code in codes[1:]:
        for (c, order, method), r in sorted(ratios.items()):
            if c != code:
                continue
            r = sorted(r)
            lines.append(f"| {code} | P{order} | {method} | {len(r)} | {r[0]:.1f}× | {r[len(r) // 2]:.1f}× | "
                         f"{r[-1]:.1f}× |")
    return lines


def write_csv(points, front, path, header):
    with open(path, "w") as f:
        f.write(f"# {header}\n")
        f.write("code,order,mesh,method,steps_per_period,dt_over_crit,free_dofs,relative_error,seconds,pareto\n")
        for p in sorted(points, key=lambda p: (p["code"], p["order"], p["cells"], p["method"], p["steps"])):
            crit = f"{p['dt_over_crit']:.4f}" if p["method"] == "explicit" else ""
            f.write(f"{p['code']},{p['order']},{p['cells']},{p['method']},{p['steps']},{crit},{p['dofs']},"
                    f"{p['error']:.6e},{p['seconds']:.6e},{int(p in front)}\n")


def write(d, out):
    """The CSV, the chart and the Markdown section from the run's record `d`."""
    points, ref, codes = d["points"], d["reference"], d["codes"]
    report = os.path.join(ROOT, "validation", "report")
    front = pareto(points)
    ref_error = ref["space_error"] + ref["truncation"]
    csv = os.path.join(report, "speed_accuracy_swing.csv")
    write_csv(points, front, csv, f"swinging beam, tip trajectory over T1 = {ref['period']:.6f} (MFEM order "
              f"{reference_name(ref)}); reference error ~{ref_error:.1e}; peers' BLAS: {d['blas']}")
    chart = subprocess.run([CHART_PYTHON, os.path.abspath(__file__), "--chart", csv,
                            os.path.join(report, "speed_accuracy_swing.png"), repr(ref_error)],
                           capture_output=True, text=True)
    if chart.returncode != 0:
        print(f"swing: chart not drawn ({CHART_PYTHON}): {chart.stderr.strip()[-300:]}", file=sys.stderr)
    lines = section(d, front, ref_error)
    old = open(out).read() if os.path.exists(out) else "# Speed against accuracy, tetfem beside its peers\n"
    head, _, rest = old.partition(HEADING)
    tail = ("\n## " + rest.split("\n## ", 1)[1]) if rest and "\n## " in rest else ""
    with open(out + ".tmp", "w") as f:
        f.write(head.rstrip("\n") + "\n\n" + "\n".join(lines) + "\n" + tail)
    os.replace(out + ".tmp", out)
    print(f"wrote {out}", file=sys.stderr)


def reference_name(ref):
    """"order cells" of the reference's last level."""
    last = ref["levels"][-1]
    return f"{last['order']} {last['cells']}"


def section(d, front, ref_error):
    """The Markdown section: setup, reference, agreement, the runs, the fronts, the speed ratios."""
    points, ref, codes = d["points"], d["reference"], d["codes"]
    levels = ", ".join(f"order {r['order']} {r['cells']} ({r['dofs']} DOFs, {r['seconds']:.0f} s): "
                       f"{r['difference']:.1e}" for r in ref["levels"][:-1])
    last = ref["levels"][-1]
    agree = "; ".join("{}: trajectories within {:.1e} of the amplitude, errors within {:.1e} relative".format(
        peer, *agreement(points, peer)) for peer in codes[1:])
    biggest = max((p for p in points if p["method"] == "newmark"), key=lambda p: (p["dofs"], p["steps"]))
    explicit_runs = [p for p in points if p["method"] == "explicit" and p["code"] == "tetfem"]
    lines = [HEADING, "",
             f"Generated by `python3 validation/dynamic_speed_accuracy.py --repeat {d['repeat']}`, {d['stamp']} UTC, "
             f"{os.cpu_count()} cores shared with other work (load average before / after the timed sweep: "
             f"{d['loads'][0]} / {d['loads'][1]}), one thread per code, fastest of {d['repeat']} interleaved runs; "
             f"the whole script took {d['script_seconds'] / 60:.1f} min. Peers' BLAS: {d['blas']} "
             "(CHOLMOD's supernodal factor calls it); tetfem: its own Rust kernels, one rayon thread.", "",
             "Beam 10 × 2 × 1 (E = 1e5, ν = 0.3, ρ = 1000), clamped at x = 0, released at rest from its static "
             "shape under an end load of 1, free over one period T₁ = "
             f"{ref['period']:.5f} of the reference's first mode. tetfem's lecture-split box mesh is given to "
             "scikit-fem and MFEM as it is (P1 / P2 = MFEM H1 order 1 / 2), so M and K are the same matrices in "
             "the three codes. tetfem: `Simulation` (Python binding); scikit-fem and MFEM: their assembled M and "
             "K with the same loops in Python — backward Euler and Newmark (β = 1/4, γ = 1/2) on consistent "
             "mass with CHOLMOD factors made once, and the explicit method as tetfem's (symplectic Euler, the "
             "velocity form of central differences: v⁺ = v − dt M_l⁻¹ K u, u⁺ = u + dt v⁺) on the lumped mass "
             "M_l — row sums for P1 (ρV/4 a node), HRZ for P2 (ρV/36 a corner, 4ρV/27 an edge node), which "
             "the peers get as diag(M) · 3ρLWH / trace(M) of their consistent M — at 0.9 of tetfem's critical "
             "step 2/ω_max, and on the P2 10x2x1 and 20x4x2 meshes at 0.45 too (the same step count in every code; "
             "the column \"steps / T₁\"). "
             "Time: static solve for the initial shape + matrices + factorizations + the loop, tip sampled 32 "
             "times. Error: max over the samples of |tip − reference| / max |reference|.", "",
             f"Reference: MFEM order {last['order']} on {last['cells']} ({last['dofs']} DOFs; \"g\": the box's "
             "tets with the points graded toward the clamped face x = 0 (exponential, first cell 1/55 of the "
             "uniform one's length for 16 cells) and toward the faces y = 0, W and z = 0, H (tanh), whose edges "
             "on the clamped face are singular lines that hold uniform meshes of any order to a slow rate), "
             f"solved exactly in time by modal superposition: u(t) = Σᵢ φᵢ cᵢ cos(ωᵢ t) over its lowest {last['modes']} "
             "modes (shift-invert Lanczos on a CHOLMOD factor of K), cᵢ = φᵢᵀ M u₀ of the static shape, T₁ = 2π/ω₁ "
             f"its own; the solve took {last['seconds']:.0f} s. The levels before it, sampled at the same times, differ from it "
             f"by {levels}; its space error is estimated as the largest of the last two, {ref['space_error']:.1e}; "
             f"the modes past the {last['modes']}th as the change from the lower half of them to all, "
             f"{ref['truncation']:.1e}: the reference is good to about {ref_error:.1e}. Check of the modal solution "
             f"by an independent integrator: MFEM order {ref['check'][0]} {ref['check'][1]} with Newmark differs from "
             "its modal solution by " + ", ".join(f"{c['difference']:.1e} at T₁/{c['steps']}" for c in ref["checks"])
             + " (falling with dt: Newmark's phase error on the higher modes, at 16 to 70 ω₁, that the end load's "
             "local deformation excites and the modal sum has exact; what is left is those past the last mode, "
             f"which Newmark has and the sum leaves out). No compared run enters the reference; it took "
             f"{ref['seconds'] / 60:.1f} min. "
             f"Same discrete problem, same result: {agree}.", "",
             "| code | elements | mesh | method | steps / T₁ | free DOFs | error | wall time [s] | Pareto |",
             "|---|---|---|---|---|---|---|---|---|"]
    for p in sorted(points, key=lambda p: (p["order"], p["dofs"], METHODS.index(p["method"]), p["steps"],
                                          codes.index(p["code"]))):
        steps = f"{p['steps']}" + (f" ({p['dt_over_crit']:.2f} dt_crit)" if p["method"] == "explicit" else "")
        lines.append(f"| {p['code']} | P{p['order']} | {p['cells']} | {p['method']} | {steps} | {p['dofs']} | "
                     f"{p['error']:.2e} | {p['seconds']:.4f} | {'◆' if p in front else ''} |")
    lines += ["", "Fronts' positions: each code's least wall time to an error at or below the target, over every "
              "element, mesh, method and step, and the peer's time over tetfem's.", ""]
    lines += fronts_table(points, codes, METHODS, "code")
    lines += ["", f"The same counting only the runs certainly below the target: each run's error plus the reference's "
              f"own ({ref_error:.1e}) at or below it (a run within the reference's error of a target may be on either "
              "side of it):", ""]
    lines += fronts_table(points, codes, METHODS, "code", ref_error)
    lines += ["", "The same by method (the explicit runs' error is the lumped mass's space error: their step is "
              "far below what the accuracy needs):", ""]
    for method in METHODS:
        lines += fronts_table(points, codes, (method,), f"{method}")
        lines.append("")
    lines += ["Each peer's wall time over tetfem's on the same run (same mesh, order, method and step), over the "
              "meshes and steps of each row:", ""]
    lines += ratios_table(points, codes)
    lines += ["", f"The largest Newmark run, P{biggest['order']} {biggest['cells']} ({biggest['dofs']} free DOFs) at "
              f"T₁/{biggest['steps']}, took " + ", ".join(
                  f"{p['code']} {p['seconds']:.1f} s" for p in points if same_run(p, biggest)) + "."]
    if explicit_runs:
        worst = max(explicit_runs, key=lambda p: p["steps"])
        lines[-1] += (f" The explicit runs need {min(p['steps'] for p in explicit_runs)} to {worst['steps']} steps "
                      "a period (P2's HRZ mass and its short edges make its critical step small).")
    lines += ["", "![Speed against accuracy: swinging beam, tetfem beside scikit-fem and MFEM]"
              "(report/speed_accuracy_swing.png)", "",
              "Data: [report/speed_accuracy_swing.csv](report/speed_accuracy_swing.csv) (and the trajectories: "
              "[report/speed_accuracy_swing.json](report/speed_accuracy_swing.json))."]
    return lines


# ------------------------------------------------------------------------------------ the chart
COLOURS = {"tetfem": "#d62728", "scikit-fem": "#1f77b4", "MFEM": "#2ca02c"}
ORDER_MARKERS = {"1": "o", "2": "s"}
METHOD_TITLES = {"backward-euler": "backward Euler (consistent mass)", "newmark": "Newmark β = 1/4 (consistent mass)",
                 "explicit": "explicit, central differences (lumped mass)"}


def draw(csv_path, png, ref_error):
    """Three panels (one per method) of wall time against error, log–log, sharing both axes: a line per
    code, order and mesh through its steps (more steps to the right), labelled once (at tetfem's run
    with the fewest steps: the codes' runs of a mesh have the same error); the Pareto front over every
    code and method drawn in each panel, its points circled in their own panel; the targets 10 %, 1 %
    and 0.1 % dotted; below the reference's own error shaded (not resolved)."""
    import csv
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D
    with open(csv_path) as f:
        header = f.readline().lstrip("# ").strip()
        rows = list(csv.DictReader(f))
    for r in rows:
        r["x"], r["y"] = float(r["seconds"]), float(r["relative_error"])
    front = sorted((r for r in rows if r["pareto"] == "1"), key=lambda r: r["x"])
    fig, axes = plt.subplots(1, 3, figsize=(17, 7.2), dpi=110, sharex=True, sharey=True)
    for ax, method in zip(axes, METHODS):
        mine = [r for r in rows if r["method"] == method]
        for code, order, mesh in sorted({(r["code"], r["order"], r["mesh"]) for r in mine}):
            pts = sorted((r for r in mine if (r["code"], r["order"], r["mesh"]) == (code, order, mesh)),
                         key=lambda r: int(r["steps_per_period"]))
            ax.plot([r["x"] for r in pts], [r["y"] for r in pts], marker=ORDER_MARKERS[order], color=COLOURS[code],
                    linewidth=0.9, markersize=5.5, alpha=0.85,
                    markerfacecolor=COLOURS[code] if order == "2" else "white")
            if code == "tetfem":
                ax.annotate(f"P{order} {mesh}", (pts[0]["x"], pts[0]["y"]), textcoords="offset points",
                            xytext=(-5, 4), ha="right", fontsize=7, color="black")
        ax.step([r["x"] for r in front], [r["y"] for r in front], where="post", color="black", linestyle="--",
                linewidth=1.2)
        own = [r for r in front if r["method"] == method]
        ax.scatter([r["x"] for r in own], [r["y"] for r in own], s=130, facecolors="none", edgecolors="black",
                   linewidths=1.3, zorder=5)
        for target in (1e-1, 1e-2, 1e-3):
            ax.axhline(target, color="grey", linewidth=0.8, linestyle=":")
        ax.axhspan(1e-6, ref_error, color="grey", alpha=0.15, linewidth=0)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_title(METHOD_TITLES[method], fontsize=10)
        ax.grid(True, which="both", linewidth=0.3)
    lo = min(r["y"] for r in rows)
    axes[0].set_ylim(min(lo, ref_error) / 2, max(r["y"] for r in rows) * 1.5)
    axes[0].set_xlim(min(r["x"] for r in rows) / 3, max(r["x"] for r in rows) * 1.5)
    fig.supxlabel("wall time: static shape + matrices + factorization + loop over one period (s, one thread)",
                  y=0.085, fontsize=10)
    axes[0].set_ylabel("relative tip-trajectory error over one period T₁ (max over 32 samples)")
    handles = [Line2D([], [], color=c, linewidth=2, label=code) for code, c in COLOURS.items()
               if any(r["code"] == code for r in rows)]
    handles += [Line2D([], [], color="black", marker="o", markerfacecolor="white", linestyle="", label="P1"),
                Line2D([], [], color="black", marker="s", linestyle="", label="P2"),
                Line2D([], [], color="black", linestyle="--", label="Pareto front, all codes and methods "
                       "(its points circled in their panel)"),
                Line2D([], [], color="grey", linewidth=6, alpha=0.3, label=f"below the reference's error ({ref_error:.0e})"),
                Line2D([], [], color="grey", linestyle=":", label="10 %, 1 %, 0.1 %")]
    fig.legend(handles=handles, loc="lower center", ncol=len(handles), fontsize=8.5, frameon=False,
               bbox_to_anchor=(0.5, 0.02))
    fig.suptitle("Swinging beam: speed against accuracy, tetfem beside scikit-fem and MFEM (same meshes, M and K); "
                 "along each line more steps per period to the right", fontsize=11)
    fig.text(0.01, 0.005, header[:230], fontsize=6.5, color="grey")
    fig.tight_layout(rect=(0, 0.1, 1, 0.96))
    fig.savefig(png)


if __name__ == "__main__":
    if len(sys.argv) > 1 and sys.argv[1] == "--worker":
        worker(sys.argv[2:])
        sys.exit(0)
    if len(sys.argv) > 1 and sys.argv[1] == "--chart":
        draw(sys.argv[2], sys.argv[3], float(sys.argv[4]))
        sys.exit(0)
    sys.exit(main())
