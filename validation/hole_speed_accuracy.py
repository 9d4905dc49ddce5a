#!/usr/bin/env python3
"""Speed against accuracy on a curved 3-D problem with a stress concentration: tetfem beside
scikit-fem and MFEM on identical meshes, in one run (issue 37, item 1 b).

The problem: a plate with a central circular hole under uniaxial tension, one eighth modelled.
Hole radius a = 1, quarter plate x in [0, L], y in [0, W] outside the hole, half thickness
z in [0, T] (L = W = 4, T = 0.5: the whole plate is 8 x 8 x 1 with a hole of diameter 2),
E = 1e5, nu = 0.3, traction (1, 0, 0) on x = L, symmetry rollers u_x = 0 on x = 0, u_y = 0 on
y = 0 and u_z = 0 on z = 0 (the mid-plane). The quantity: the hoop stress sigma_xx at the hole's
edge on the symmetry plane x = 0, at the mid-plane: the node (0, a, 0).

Mesh (built once per size in numpy, the same arrays given to every code): a mapped O-grid of
hexahedra in logical coordinates (psi, s, zeta) in [0,1]^3 (psi along the quarter hole from the
y axis to the x axis, s from the hole outwards, geometric grading beta = 2.5 toward the hole,
zeta through the thickness), 2n x n x max(1, n/2) cells, each split into 6 tets around its main
diagonal (Kuhn's split, conforming); the vertices on the hole lie on the circle, the tets are
straight-sided (P2 adds a node at each straight edge's middle, in all three codes). Curved P2 (MFEM
curved, tetfem curved): the same tets isoparametric, each edge node the exact map of its logical edge's
midpoint (the hole's edge nodes on the circle); tetfem's recovery there uses the isoparametric
gradient and the curved volume (recovered_sxx_curved), as MFEM's GetVectorGradient and volume do.

Stress at the node, the same definition in every code: tetfem's nodal recovery
(`tetfem::post::output::fields::recovered_nodal_stress` of `tet_node_stress`, what its VTU
output reports as nodal stress): the volume-weighted average over the tets that hold the node of
each tet's own linear-elastic stress at that node, sum V_e sigma_e(x_n) / sum V_e (constant per
tet for P1; for P2 the tet's linear stress evaluated at the node). tetfem's Python binding gives
the displacement and the tet-mean stress only, so this script evaluates the formula from each
code's displacement on the few tets at the node (checked against tetfem's own tet stresses).

Reference: MFEM on isoparametric curved tets (the hole exact to the geometry's polynomial order:
the logical mesh is curved with SetCurvature(p) and its nodes mapped by the exact blending map),
order 3 and 4 on the finer meshes, same recovery; its error is estimated by the spread of the
last levels. Kirsch's infinite-plate value is 3; Howland's / Peterson's finite-width value for
d/D = 0.25 is about 3.24 (gross section): quoted for orientation only.

Usage (from the project root, after validation/setup_peers.sh):
    python3 validation/hole_speed_accuracy.py [--repeat 3] [--quick]
    python3 validation/side_by_side.py --accuracy-hole       # the same, from the harness
Writes validation/report/speed_accuracy_hole.{csv,png} and the section "Speed against accuracy:
plate with a hole" of validation/SIDE_BY_SIDE.md.
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
HEADING = "## Speed against accuracy: plate with a hole"

A, L, W, T = 1.0, 4.0, 4.0, 0.5
E, NU, TRACTION = 1.0e5, 0.3, 1.0
BETA = 2.5
LAM = E * NU / ((1 + NU) * (1 - 2 * NU))
MU = E / (2 * (1 + NU))


# ----------------------------------------------------------------------------------------- mesh
def cells(n: int) -> tuple[int, int, int]:
    """Cells along the hole (psi), outwards (s) and through the thickness (zeta) at size n."""
    return 2 * n, n, max(1, n // 2)


def blend(q):
    """The exact map from logical (psi, s, zeta) in [0,1]^3 to the plate: the hole's point at angle
    theta = (1 - psi) pi/2 joined by a straight line to the point of the outer boundary with the
    same arc parameter (x = L for psi >= 1/2, y = W above), graded toward the hole."""
    import numpy as np
    psi, s, zeta = q[:, 0], q[:, 1], q[:, 2]
    phi = 1.0 - psi
    theta = phi * math.pi / 2
    inner = np.column_stack([A * np.cos(theta), A * np.sin(theta)])
    outer = np.where((phi <= 0.5)[:, None], np.column_stack([np.full_like(phi, L), 2 * phi * W]),
                     np.column_stack([2 * (1 - phi) * L, np.full_like(phi, W)]))
    g = (np.exp(BETA * s) - 1) / (math.exp(BETA) - 1)
    xy = inner + g[:, None] * (outer - inner)
    return np.column_stack([xy, zeta * T])


def logical_mesh(n: int):
    """Logical vertex coordinates (N, 3) and tets (M, 4), Kuhn's 6-tet split of every hex cell."""
    import numpy as np
    ni, nj, nk = cells(n)
    i, j, k = np.meshgrid(np.arange(ni + 1), np.arange(nj + 1), np.arange(nk + 1), indexing="ij")
    q = np.column_stack([i.ravel(order="F") / ni, j.ravel(order="F") / nj, k.ravel(order="F") / nk])

    def idx(a, b, c):
        return (c * (nj + 1) + b) * (ni + 1) + a

    ci, cj, ck = np.meshgrid(np.arange(ni), np.arange(nj), np.arange(nk), indexing="ij")
    ci, cj, ck = ci.ravel(), cj.ravel(), ck.ravel()
    steps = np.eye(3, dtype=int)
    tets = []
    for perm in ((0, 1, 2), (0, 2, 1), (1, 0, 2), (1, 2, 0), (2, 0, 1), (2, 1, 0)):
        corner = np.zeros(3, dtype=int)
        path = [idx(ci, cj, ck)]
        for axis in perm:
            corner = corner + steps[axis]
            path.append(idx(ci + corner[0], cj + corner[1], ck + corner[2]))
        tets.append(np.column_stack(path))
    tets = np.vstack(tets).astype(np.int64)
    return q, tets


def signed_volumes(p, t):
    import numpy as np
    a, b, c, d = (p[t[:, i]] for i in range(4))
    return np.einsum("ij,ij->i", np.cross(b - a, c - a), d - a) / 6.0


def plate_mesh(n: int):
    """The physical mesh: points (N, 3), positively oriented tets (M, 4), the target node's index
    and the logical coordinates (for MFEM's curved reference)."""
    import numpy as np
    q, t = logical_mesh(n)
    p = blend(q)
    neg = signed_volumes(p, t) < 0
    t[neg] = t[neg][:, [0, 2, 1, 3]]
    if np.any(signed_volumes(p, t) <= 0) or np.any(signed_volumes(q, t) <= 0):
        raise RuntimeError(f"plate mesh n={n}: degenerate or inverted tets")
    target = int(np.flatnonzero((q[:, 0] == 0) & (q[:, 1] == 0) & (q[:, 2] == 0))[0])
    return p, t, target, q


def tet10(p, t, q=None):
    """P2 nodes: points (N + edges, 3) and tets (M, 10) in tetfem's order (corners, then edges 01,
    12, 02, 03, 13, 23). Straight tets (the edge nodes at the physical midpoints), or with the
    logical coordinates `q` curved ones: each edge node the exact map of its logical edge's midpoint
    (exact blending, as MFEM's SetCurvature(2) and the map: the nodes on the hole on the circle)."""
    import numpy as np
    pairs = [(0, 1), (1, 2), (0, 2), (0, 3), (1, 3), (2, 3)]
    e = np.vstack([np.sort(t[:, [a, b]], axis=1) for a, b in pairs])
    uniq, inv = np.unique(e, axis=0, return_inverse=True)
    if q is None:
        mids = 0.5 * (p[uniq[:, 0]] + p[uniq[:, 1]])
    else:
        mids = blend(0.5 * (q[uniq[:, 0]] + q[uniq[:, 1]]))
    t10 = np.column_stack([t, (len(p) + inv.reshape(6, -1)).T])
    return np.vstack([p, mids]), t10


def write_gmsh22_tet10(path, p10, t10):
    """A Gmsh 2.2 ASCII file of 10-node tets (Gmsh's edge order 01, 12, 02, 03, 23, 13)."""
    import numpy as np
    gm = t10[:, [0, 1, 2, 3, 4, 5, 6, 7, 9, 8]] + 1
    with open(path, "w") as f:
        f.write("$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n%d\n" % len(p10))
        np.savetxt(f, np.column_stack([np.arange(1, len(p10) + 1), p10]), fmt="%d %.17g %.17g %.17g")
        f.write("$EndNodes\n$Elements\n%d\n" % len(gm))
        ids = np.arange(1, len(gm) + 1)
        np.savetxt(f, np.column_stack([ids, np.full(len(gm), 11), np.full(len(gm), 2), np.ones(len(gm), int),
                                       np.ones(len(gm), int), gm]), fmt="%d")
        f.write("$EndElements\n")


# ------------------------------------------------------------------------------------- recovery
def recovered_sxx_at(X, U, node_xyz):
    """sum_e V_e sigma_xx,e(node) / sum_e V_e over the tets e given (X, U: (k, nn, 3) positions and
    displacements of their nodes, corners first; nn = 4 for P1, 10 for P2 with the six edge nodes
    in any order, each matched to its corner pair by position). sigma = lam tr(eps) I + 2 mu eps."""
    import numpy as np
    total, weight = 0.0, 0.0
    for x, u in zip(X, U):
        corners = x[:4]
        k = int(np.argmin(np.linalg.norm(corners - node_xyz, axis=1)))
        if np.linalg.norm(corners[k] - node_xyz) > 1e-9:
            raise RuntimeError("recovery: a tet does not hold the node")
        jac = np.column_stack([corners[1] - corners[0], corners[2] - corners[0], corners[3] - corners[0]])
        inv = np.linalg.inv(jac)
        glam = np.vstack([-inv.sum(axis=0), inv])  # gradients of the barycentric coordinates (4, 3)
        vol = abs(np.linalg.det(jac)) / 6.0
        if len(x) == 4:
            grad = u[:4].T @ glam
        else:
            # P2 at corner k: grad u = 3 u_k (x) glam_k - sum_{i!=k} u_i (x) glam_i + 4 sum_{j!=k} u_kj (x) glam_j
            grad = 3.0 * np.outer(u[k], glam[k])
            for i in range(4):
                if i != k:
                    grad -= np.outer(u[i], glam[i])
            for m in range(4, len(x)):
                d = np.linalg.norm(0.5 * (corners[:, None] + corners[None, :]) - x[m], axis=2)
                i, j = np.unravel_index(np.argmin(d + np.eye(4)), d.shape)
                if d[i, j] > 1e-9:
                    raise RuntimeError("recovery: an edge node is not at an edge's middle")
                if k in (i, j):
                    other = j if i == k else i
                    grad += 4.0 * np.outer(u[m], glam[other])
        eps = 0.5 * (grad + grad.T)
        sxx = LAM * np.trace(eps) + 2 * MU * eps[0, 0]
        total += vol * sxx
        weight += vol
    return total / weight


def quadratic_ref_grads(lam):
    """Reference gradients of the ten quadratic shape functions (tetfem's node order: corners, then
    the edges 01, 12, 02, 03, 13, 23) at barycentric points lam (m, 4): (m, 10, 3)."""
    import numpy as np
    pairs = [(0, 1), (1, 2), (0, 2), (0, 3), (1, 3), (2, 3)]
    dl = np.array([[-1.0, -1.0, -1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    corner = (4 * lam[:, :, None] - 1) * dl[None, :, :]
    edge = np.stack([4 * (lam[:, j, None] * dl[i] + lam[:, i, None] * dl[j]) for i, j in pairs], axis=1)
    return np.concatenate([corner, edge], axis=1)


def collapsed_gauss_3():
    """The 27-point collapsed Gauss rule on the unit tet (exact for degree 3): barycentric points
    (27, 4) and weights (27,), the Duffy map's Jacobian (1 - a)^2 (1 - b) in the weights."""
    import numpy as np
    gx, gw = np.polynomial.legendre.leggauss(3)
    gx, gw = 0.5 * (gx + 1), 0.5 * gw
    a, b, c = (g.ravel() for g in np.meshgrid(gx, gx, gx, indexing="ij"))
    wa, wb, wc = (g.ravel() for g in np.meshgrid(gw, gw, gw, indexing="ij"))
    xi = np.stack([a, b * (1 - a), c * (1 - a) * (1 - b)], axis=1)
    lam = np.concatenate([1 - xi.sum(axis=1, keepdims=True), xi], axis=1)
    return lam, wa * wb * wc * (1 - a) ** 2 * (1 - b)


def recovered_sxx_curved(X, U, node_xyz):
    """The same recovery on isoparametric 10-node tets in tetfem's node order (X, U: (k, 10, 3)):
    sum_e V_e sigma_xx,e(node) / sum_e V_e with grad N = J^-T grad_xi N at the node's corner
    (J = sum_a x_a (x) grad_xi N_a) and V_e the curved volume (integral of det J, a cubic, by the
    3-point collapsed Gauss rule, exact for degree 3) — what MFEM's GetVectorGradient and
    curved_volume give on its curved mesh. Vectorized over tets and points: it is timed, as
    MFEM's compiled recovery is, so a Python loop here would charge tetfem ~20 ms a call that
    MFEM does not pay (the loop it replaced took 18.6 ms on 8 tets, this 0.8 ms; same value to
    7e-16 relative)."""
    import numpy as np
    X, U = np.asarray(X, dtype=float), np.asarray(U, dtype=float)
    k = np.argmin(np.linalg.norm(X[:, :4] - node_xyz, axis=2), axis=1)
    if np.max(np.linalg.norm(X[np.arange(len(X)), k] - node_xyz, axis=1)) > 1e-9:
        raise RuntimeError("recovery: a tet does not hold the node")
    lam, w = collapsed_gauss_3()
    jac = np.einsum("eai,qaj->eqij", X, quadratic_ref_grads(lam))
    vol = np.einsum("q,eq->e", w, np.linalg.det(jac))
    at_node = quadratic_ref_grads(np.eye(4)[k])
    grads = np.einsum("eaj,eji->eai", at_node, np.linalg.inv(np.einsum("eai,eaj->eij", X, at_node)))
    grad = np.einsum("eai,eaj->eij", U, grads)
    eps = 0.5 * (grad + np.transpose(grad, (0, 2, 1)))
    sxx = LAM * np.trace(eps, axis1=1, axis2=2) + 2 * MU * eps[:, 0, 0]
    return float(np.sum(vol * sxx) / np.sum(vol))


# -------------------------------------------------------------------------------------- workers
def solve_tetfem(order: int, p, t, target, q=None):
    import numpy as np
    import tetfem
    with tempfile.TemporaryDirectory() as d:
        tm = time.perf_counter()
        if order == 1:
            mesh = tetfem.Mesh(p, t)
        else:
            # The binding's Mesh(points, tets) takes 4-node tets only: the 10-node mesh goes by file.
            # With q: curved (isoparametric) tets, the edge nodes on the map (the reader keeps them).
            p10, t10 = tet10(p, t, q)
            path = os.path.join(d, "plate.msh")
            write_gmsh22_tet10(path, p10, t10)
            tm = time.perf_counter()
            mesh = tetfem.Mesh.read(path, order=2)
        mesh_s = time.perf_counter() - tm
    t0 = time.perf_counter()
    material = tetfem.Material(E, NU, 1.0)
    cons = (tetfem.Constraints(mesh).fix(mesh.nodes_on_plane("x", 0.0), "x")
            .fix(mesh.nodes_on_plane("y", 0.0), "y").fix(mesh.nodes_on_plane("z", 0.0), "z"))
    loads = tetfem.Loads(mesh).add_traction(mesh.faces_on_plane("x", L), (TRACTION, 0.0, 0.0))
    res = tetfem.solve_static(mesh, material, cons, loads)
    pts, tets, u = mesh.points, mesh.tets, np.asarray(res.displacement)
    at = np.flatnonzero(np.any(tets[:, :4] == target, axis=1))
    if q is None:
        sxx = recovered_sxx_at(pts[tets[at]], u[tets[at]], p[target])
    else:
        sxx = recovered_sxx_curved(pts[tets[at]], u[tets[at]], p[target])
    seconds = time.perf_counter() - t0
    if q is not None:
        # The edge nodes as written: the binding's mesh kept the curved positions.
        p10, _ = tet10(p, t, q)
        kept = float(np.max(np.abs(pts - p10)))
        if kept > 1e-12:
            raise RuntimeError(f"tetfem moved the curved edge nodes by {kept:.1e}")
        return dict(sxx=sxx, seconds=seconds, mesh_seconds=mesh_s, dofs=3 * len(pts) - cons.count,
                    recovery_check=None, binding=tetfem.__file__)
    # The recovery's formula checked against tetfem's own tet stresses: for P1 the tet stress is
    # the constant stress; for P2 the tet mean of a linear stress is the mean of its corner values.
    check = []
    for e in at[:3]:
        vals = [recovered_sxx_at(pts[tets[[e]]], u[tets[[e]]], pts[tets[e, c]]) for c in range(4)]
        check.append(abs(np.mean(vals) - res.stress[e][0, 0]) / abs(res.stress[e][0, 0]))
    return dict(sxx=sxx, seconds=seconds, mesh_seconds=mesh_s, dofs=3 * len(pts) - cons.count,
                recovery_check=max(check), binding=tetfem.__file__)


def solve_skfem(order: int, p, t, target):
    import numpy as np
    from skfem import Basis, ElementTetP1, ElementTetP2, ElementVector, FacetBasis, LinearForm, MeshTet, asm
    from skfem.models.elasticity import linear_elasticity
    from sksparse.cholmod import analyze
    tm = time.perf_counter()
    m = MeshTet(np.ascontiguousarray(p.T), np.ascontiguousarray(t.T))
    mesh_s = time.perf_counter() - tm
    t0 = time.perf_counter()
    basis = Basis(m, ElementVector(ElementTetP1() if order == 1 else ElementTetP2()), intorder=2 * (order - 1))
    K = asm(linear_elasticity(LAM, MU), basis)
    fb = FacetBasis(m, basis.elem, facets=m.facets_satisfying(lambda x: np.isclose(x[0], L)))

    @LinearForm
    def traction(v, w):
        return TRACTION * v[0]

    f = asm(traction, fb)
    fixed = np.concatenate([basis.get_dofs(lambda x: np.isclose(x[c], 0.0)).all(f"u^{c + 1}") for c in range(3)])
    free = np.setdiff1d(np.arange(basis.N), fixed)
    Kff = K.tocsr()[free][:, free].tocsc()
    fac = analyze(Kff)
    fac.cholesky_inplace(Kff)
    u = np.zeros(basis.N)
    u[free] = fac(f[free])
    at = np.flatnonzero(np.any(t == target, axis=1))
    parts = [(b, uc) for uc, b in basis.split(u)]
    sub = parts[0][0]
    ed = sub.element_dofs[:, at].T  # (k, nn): scalar dofs of each tet, corners first
    X = sub.doflocs.T[ed]
    U = np.stack([uc[ed] for _, uc in parts], axis=-1)
    sxx = recovered_sxx_at(X, U, p[target])
    seconds = time.perf_counter() - t0
    return dict(sxx=sxx, seconds=seconds, mesh_seconds=mesh_s, dofs=len(free))


def write_mfem_mesh(path, points, tets, attrs_of):
    """MFEM mesh v1.0 text file; boundary attribute of each boundary triangle from attrs_of."""
    import numpy as np
    faces = np.vstack([tets[:, [0, 1, 2]], tets[:, [0, 1, 3]], tets[:, [0, 2, 3]], tets[:, [1, 2, 3]]])
    key = np.sort(faces, axis=1)
    _, first, counts = np.unique(key, axis=0, return_index=True, return_counts=True)
    tris = faces[first[counts == 1]]
    attr = attrs_of(tris)
    with open(path, "w") as f:
        f.write(f"MFEM mesh v1.0\n\ndimension\n3\n\nelements\n{len(tets)}\n")
        np.savetxt(f, np.column_stack([np.ones(len(tets), int), np.full(len(tets), 4), tets]), fmt="%d")
        f.write(f"\nboundary\n{len(tris)}\n")
        np.savetxt(f, np.column_stack([attr, np.full(len(tris), 2), tris]), fmt="%d")
        f.write(f"\nvertices\n{len(points)}\n3\n")
        np.savetxt(f, points, fmt="%.17g")


def boundary_attributes(q):
    """Attributes from logical coordinates: 1 x = 0 (psi = 0), 2 y = 0 (psi = 1), 3 z = 0, 4 x = L
    (s = 1, psi >= 1/2), 5 the rest (hole, top, y = W: traction-free)."""
    import numpy as np

    def attrs(tris):
        c = q[tris]
        a = np.full(len(tris), 5)
        on = lambda axis, v: np.all(np.abs(c[:, :, axis] - v) < 1e-12, axis=1)  # noqa: E731
        a[on(1, 1.0) & np.all(c[:, :, 0] >= 0.5 - 1e-12, axis=1)] = 4
        a[on(2, 0.0)] = 3
        a[on(0, 1.0)] = 2
        a[on(0, 0.0)] = 1
        return a
    return attrs


def curved_volume(mfem, tr, order: int) -> float:
    """An element's volume, ∫ det J over the reference tet by a rule exact for det J (degree
    3(order − 1), at least 1). MFEM's GetElementVolume is not exact on curved tets: it left the
    recovered stress 2.2e-4 (4x2x1 cells) and 1.7e-6 (8x4x2) relative from the same recovery with
    exact volumes, which is what tetfem computes (its curved volume's rule is exact for P2)."""
    rule = mfem.IntRules.Get(mfem.Geometry.TETRAHEDRON, max(1, 3 * (order - 1)))
    volume = 0.0
    for k in range(rule.GetNPoints()):
        point = rule.IntPoint(k)
        tr.SetIntPoint(point)
        volume += point.weight * tr.Weight()
    return volume


def solve_mfem(order: int, p, t, target, q, curved: bool = False):
    """MFEM assembly (H1 order `order`, ElasticityIntegrator), rollers eliminated, CHOLMOD solve (the
    PyPI wheel of PyMFEM has no sparse direct solver). `curved`: the reference's isoparametric mesh."""
    import numpy as np
    import scipy.sparse as sp
    import mfem.ser as mfem
    from sksparse.cholmod import analyze
    with tempfile.TemporaryDirectory() as d:
        path = os.path.join(d, "plate.mesh")
        tm = time.perf_counter()
        write_mfem_mesh(path, q if curved else p, t, boundary_attributes(q))
        m = mfem.Mesh(path, 1, 0)
        if curved:
            m.SetCurvature(order, False, 3, mfem.Ordering.byVDIM)
            nodes = m.GetNodes().GetDataArray()
            nodes[:] = blend(nodes.reshape(-1, 3).copy()).ravel()
        mesh_s = time.perf_counter() - tm
    t0 = time.perf_counter()
    fec = mfem.H1_FECollection(order, 3)
    fes = mfem.FiniteElementSpace(m, fec, 3, mfem.Ordering.byVDIM)
    ess = []
    for c in range(3):
        marker = mfem.intArray([1 if a == c + 1 else 0 for a in range(1, 6)])
        lst = mfem.intArray()
        fes.GetEssentialTrueDofs(marker, lst, c)
        ess += lst.ToList()
    ess_arr = mfem.intArray(sorted(set(ess)))
    bf = mfem.BilinearForm(fes)
    # MFEM keeps pointers to the coefficients and markers: they must outlive the assembly.
    lam_c, mu_c = mfem.ConstantCoefficient(LAM), mfem.ConstantCoefficient(MU)
    bf.AddDomainIntegrator(mfem.ElasticityIntegrator(lam_c, mu_c))
    bf.Assemble()
    lf = mfem.LinearForm(fes)
    trac = mfem.VectorConstantCoefficient(mfem.Vector([TRACTION, 0.0, 0.0]))
    load_marker = mfem.intArray([0, 0, 0, 1, 0])
    lf.AddBoundaryIntegrator(mfem.VectorBoundaryLFIntegrator(trac), load_marker)
    lf.Assemble()
    x = mfem.GridFunction(fes)
    x.Assign(0.0)
    Am, X, B = mfem.SparseMatrix(), mfem.Vector(), mfem.Vector()
    bf.FormLinearSystem(ess_arr, x, lf, Am, X, B)
    n = Am.Height()
    Acsr = sp.csr_matrix((Am.GetDataArray().copy(), Am.GetJArray().copy(), Am.GetIArray().copy()), shape=(n, n))
    mask = np.ones(n, dtype=bool)
    mask[np.array(ess_arr.ToList(), dtype=np.int64)] = False
    free = np.flatnonzero(mask)
    Kff = Acsr[free][:, free].tocsc()
    fac = analyze(Kff)
    fac.cholesky_inplace(Kff)
    u = np.zeros(n)
    u[free] = fac(B.GetDataArray()[free])
    x.Assign(mfem.Vector(u))
    # The recovery with MFEM's own gradient at the node (a corner of each tet that holds it).
    ref_corner = [(0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)]
    total = weight = 0.0
    grad = mfem.DenseMatrix(3, 3)
    for e in np.flatnonzero(np.any(t == target, axis=1)):
        verts = list(m.GetElementVertices(int(e)))
        ip = mfem.IntegrationPoint()
        ip.Set3(*ref_corner[verts.index(target)])
        tr = m.GetElementTransformation(int(e))
        tr.SetIntPoint(ip)
        x.GetVectorGradient(tr, grad)
        g = grad.GetDataArray().copy()
        eps = 0.5 * (g + g.T)
        vol = curved_volume(mfem, tr, order)
        total += vol * (LAM * np.trace(eps) + 2 * MU * eps[0, 0])
        weight += vol
    seconds = time.perf_counter() - t0
    return dict(sxx=total / weight, seconds=seconds, mesh_seconds=mesh_s, dofs=len(free))


def worker(code: str, order: int, n: int, out: str) -> None:
    import numpy as np
    p, t, target, q = plate_mesh(n)
    if code == "tetfem":
        r = solve_tetfem(order, p, t, target)
    elif code == "tetfem-curved":
        r = solve_tetfem(order, p, t, target, q)
    elif code == "scikit-fem":
        r = solve_skfem(order, p, t, target)
    elif code == "MFEM":
        r = solve_mfem(order, p, t, target, q)
    elif code == "MFEM-curved":
        r = solve_mfem(order, p, t, target, q, curved=True)
    else:
        raise ValueError(code)
    r.update(code=code, order=order, n=n, tets=len(t), vertices=len(p),
             mesh_sha=hash_arrays(np, p, t))
    with open(out, "w") as f:
        json.dump(r, f)


def hash_arrays(np, p, t) -> str:
    import hashlib
    h = hashlib.sha256(np.ascontiguousarray(p).tobytes())
    h.update(np.ascontiguousarray(t).tobytes())
    return h.hexdigest()[:12]



# --------------------------------------------------------------------------------------- driver
# (code, order, sizes n). "MFEM-curved" and "tetfem-curved" P2: the same vertices, isoparametric
# (the hole a circle to second order: the edge nodes on the exact map).
SWEEP = [("tetfem", 1, [2, 4, 8, 12, 16, 24]), ("scikit-fem", 1, [2, 4, 8, 12, 16, 24]),
         ("MFEM", 1, [2, 4, 8, 12, 16, 24]), ("tetfem", 2, [2, 4, 6, 8, 12, 16]),
         ("scikit-fem", 2, [2, 4, 6, 8, 12, 16]), ("MFEM", 2, [2, 4, 6, 8, 12, 16]),
         ("MFEM-curved", 2, [2, 4, 6, 8, 12]), ("tetfem-curved", 2, [2, 4, 6, 8, 12, 16])]
QUICK_SWEEP = [(c, o, [n for n in sizes if n <= 4]) for c, o, sizes in SWEEP]
# The reference runs (order, n) on the curved mesh, the last the reference itself.
REFERENCE = [(3, 4), (4, 4), (3, 8), (4, 6), (4, 8)]
QUICK_REFERENCE = [(3, 4), (4, 4)]


def mesh_name(n: int) -> str:
    return "x".join(str(c) for c in cells(n))


def run_worker(code: str, order: int, n: int) -> dict:
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    from side_by_side import peer_env
    env = peer_env(1)
    env["RAYON_NUM_THREADS"] = "1"
    python = TETFEM_PYTHON if code.startswith("tetfem") else PEERS_PYTHON
    with tempfile.TemporaryDirectory() as d:
        out = os.path.join(d, "r.json")
        subprocess.run([python, os.path.abspath(__file__), "--worker", code, str(order), str(n), out],
                       env=env, check=True, capture_output=True, text=True)
        with open(out) as f:
            return json.load(f)


def load() -> str:
    with open("/proc/loadavg") as f:
        return " ".join(f.read().split()[:3])


def reference(levels) -> tuple[float, float, list[dict]]:
    """The reference value, its error estimate (the largest difference from it among the curved
    runs of order >= 3 on the two finest meshes or lower order) and the runs."""
    runs = []
    for order, n in levels:
        print(f"hole: reference MFEM curved order {order}, n={n}", file=sys.stderr)
        runs.append(run_worker("MFEM-curved", order, n))
    ref = runs[-1]["sxx"]
    spread = max(abs(r["sxx"] - ref) for r in runs[-3:-1]) / abs(ref)
    return ref, spread, runs


def sweep(repeat: int, plan) -> dict:
    """Every (code, order, n) of `plan` `repeat` times, interleaved (all codes at one size before the
    next size), the fastest of each kept."""
    runs: dict = {}
    for rep in range(repeat):
        for n in sorted({n for _, _, sizes in plan for n in sizes}):
            for code, order, sizes in plan:
                if n not in sizes:
                    continue
                print(f"hole: pass {rep + 1}/{repeat} {code} P{order} n={n} (load {load()})", file=sys.stderr)
                r = run_worker(code, order, n)
                key = (code, order, n)
                if key not in runs or r["seconds"] < runs[key]["seconds"]:
                    runs[key] = r
    return runs


def pareto(points: list[dict]) -> list[dict]:
    """No other point both faster and at least as accurate (codes on one mesh and order agree to
    round-off, so equal errors count as equal and only the faster stays)."""
    return [p for p in points
            if not any(q["seconds"] < p["seconds"] and q["error"] <= p["error"] * (1 + 1e-6) for q in points)]


def time_to(points, code, target):
    """The fastest run of `code` (or, for "tetfem best", of tetfem straight or curved) at or below the
    target error."""
    codes = ("tetfem", "tetfem curved") if code == "tetfem best" else (code,)
    ok = [p for p in points if p["code"] in codes and p["error"] <= target]
    return min(ok, key=lambda p: p["seconds"]) if ok else None


def draw(csv: str) -> None:
    """validation/report/speed_accuracy_hole.png from the CSV (speed_accuracy_chart.py in the peers'
    Python, which has matplotlib)."""
    report = os.path.dirname(csv)
    subprocess.run([PEERS_PYTHON, os.path.join(ROOT, "validation", "speed_accuracy_chart.py"), csv,
                    os.path.join(report, "speed_accuracy_hole.png"), "--fronts",
                    "--title", "Plate with a hole (3-D, 1/8 model): speed against accuracy of the hole-edge stress\n"
                    "tetfem, scikit-fem and MFEM on identical meshes; tetfem and MFEM curved: the same vertices, isoparametric P2",
                    "--xlabel", "wall time, constraints + assembly + factorization + solve + recovery (s, one thread)",
                    "--ylabel", r"relative error of $\sigma_{xx}$ at (0, a, 0) vs curved MFEM order-4 reference"], check=True)


def write_outputs(points, ref, spread, ref_runs, blas, repeat, loads, binding) -> list[str]:
    report = os.path.join(ROOT, "validation", "report")
    os.makedirs(report, exist_ok=True)
    csv = os.path.join(report, "speed_accuracy_hole.csv")
    front = pareto(points)
    with open(csv, "w") as f:
        f.write(f"# plate with a hole, sigma_xx at (0, a, 0), reference {ref:.9f} (MFEM curved); peers' BLAS: {blas}\n")
        f.write("code,order,mesh,n,free_dofs,sxx,relative_error,seconds,mesh_seconds,pareto\n")
        for p in sorted(points, key=lambda p: (p["code"], p["order"], p["n"])):
            f.write(f"{p['code']},{p['order']},{mesh_name(p['n'])},{p['n']},{p['dofs']},{p['sxx']:.12e},"
                    f"{p['error']:.6e},{p['seconds']:.6e},{p['mesh_seconds']:.6e},{int(p in front)}\n")
    draw(csv)
    spreads = []
    for order in (1, 2):
        for n in sorted({p["n"] for p in points if p["order"] == order}):
            vals = [p["sxx"] for p in points if p["order"] == order and p["n"] == n and not p["code"].endswith(" curved")]
            spreads.append(max(abs(v - vals[0]) for v in vals) / abs(vals[0]))
    ref_text = ", ".join(f"order {r['order']} n={r['n']} ({r['dofs']} DOFs): {r['sxx']:.7f}" for r in ref_runs)
    lines = [HEADING, "",
             f"Generated by `python3 validation/hole_speed_accuracy.py` (or `side_by_side.py --accuracy-hole`), "
             f"{datetime.now(timezone.utc):%Y-%m-%d %H:%M} UTC, {os.cpu_count()} cores shared with other work "
             f"(load average before / after the timed sweep: {loads[0]} / {loads[1]}), one thread per code, "
             f"fastest of {repeat} interleaved runs.", "",
             "Problem: plate 8 × 8 × 1 with a central hole of radius a = 1 under uniaxial tension 1 (E = 1e5, "
             "ν = 0.3), one eighth modelled (x ≥ 0, y ≥ 0, z ≥ 0 the mid-plane; symmetry rollers u_x = 0 on x = 0, "
             "u_y = 0 on y = 0, u_z = 0 on z = 0; traction (1, 0, 0) on x = 4). Quantity: σ_xx at the hole's edge on "
             "the symmetry plane x = 0, mid-plane: the node (0, a, 0). Kirsch's infinite thin plate gives 3; "
             "Howland's / Peterson's finite-width plane-stress value for d/D = 0.25 is about 3.24 (gross section). "
             "This plate is also short (length = width) and 3-D (the mid-plane of a plate as thick as the hole's "
             "radius), so its converged value is higher; the formulas are quoted for orientation only.", "",
             "Meshes: an O-grid of hexahedra (2n along the quarter hole × n outwards, graded toward the hole, × "
             "max(1, n/2) through the half thickness; mesh column = these counts), each split into 6 tets "
             "(Kuhn), built once in numpy and given to every code (tetfem P1 through `tetfem.Mesh(points, tets)`, "
             "P2 through a Gmsh 2.2 file of 10-node tets and `tetfem.Mesh.read`, because the binding's "
             "`Mesh(points, tets)` takes 4-node tets only; scikit-fem `MeshTet(p, t)`; MFEM a mesh file). "
             "Straight-sided tets in every code (P2: a node at each edge's middle), so the hole is a polygon "
             "and all three codes solve the same discrete problem: their values agree to "
             f"{max(spreads):.1e} relative at every mesh and order. Beside them, \"MFEM curved\" and \"tetfem "
             "curved\" P2: the same vertices and tets, the P2 tets isoparametric (every edge node the exact map "
             "of its logical edge's midpoint, so those on the hole lie on the circle: MFEM by `SetCurvature(2)` "
             "and the map, tetfem by a Gmsh file of those 10-node tets, whose edge nodes its reader keeps and "
             "its element now uses: the geometry the quadratic map of the ten nodes). The two curved codes "
             "have the same geometry; tetfem integrates the curved stiffness with Walkington's 14-point "
             "degree-5 rule (weights det J), MFEM with its default rule (degree 6 here), so their values "
             "differ by that quadrature error, which shrinks under refinement (the CSV gives both); with "
             "MFEM's degree-5 rule, the same 14 points, the two agree to 12 digits "
             "(`tests/core/curved_tet10.rs`). The recovery's volumes are exact in both (MFEM's by a rule "
             "exact for det J: its `GetElementVolume` is not on curved tets).", "",
             "Stress at the node, the same definition in every code: tetfem's nodal recovery "
             "(`post::output::fields::recovered_nodal_stress` of `tet_node_stress`, its VTU nodal stress), "
             "Σₑ Vₑ σₑ(xₙ) / Σₑ Vₑ over the tets holding the node, each tet's stress evaluated at the node "
             "(constant for P1, linear for P2). tetfem's binding returns the displacement and the tet-mean "
             "stress, so the formula is evaluated from each code's displacement on the tets at the node "
             "(numpy for tetfem and scikit-fem, MFEM's `GetVectorGradient` at the node for MFEM); checked against "
             "tetfem's own tet stresses to 1e-12.", "",
             "Time: what a user waits for once the mesh object exists — constraints, loads, assembly, "
             "factorization, solve and the recovery at the node (tetfem: `solve_static`, which also computes "
             "every tet's stress; the peers: scikit-fem or MFEM assembly, rollers eliminated, CHOLMOD with its own "
             "ordering choice). Python imports and the mesh objects' construction are not timed (the CSV gives "
             "the latter). "
             f"Peers' BLAS: {blas}. tetfem: one rayon thread (RAYON_NUM_THREADS=1), its own Rust kernels, "
             f"Python binding {binding}.", "",
             f"Reference: MFEM on the same O-grid with isoparametric curved tets (the logical mesh curved with "
             f"`SetCurvature(p)`, its nodes mapped by the exact blending map, so the hole is a circle to order p), "
             f"same recovery: {ref_text}. Reference = the last, {ref:.7f}; its error estimated by its largest "
             f"difference from the two runs before it: {spread:.1e} relative.", "",
             "| code | elements | mesh | free DOFs | σ_xx | error | wall time [s] | Pareto |",
             "|---|---|---|---|---|---|---|---|"]
    for p in sorted(points, key=lambda p: (p["order"], p["n"], p["code"])):
        lines.append(f"| {p['code']} | P{p['order']} | {mesh_name(p['n'])} | {p['dofs']} | {p['sxx']:.7f} | "
                     f"{p['error']:.2e} | {p['seconds']:.4f} | {'◆' if p in front else ''} |")
    lines += ["", "Fronts' positions: each code's least time to an error at or below the target (over P1 and P2; "
              "\"tetfem best\": over tetfem straight and curved), and the peer's time over tetfem's best.", "",
              "| code | to 10 % | to 1 % | to 0.3 % | to 0.1 % |", "|---|---|---|---|---|"]
    targets = (0.1, 0.01, 0.003, 0.001)
    for code in ("tetfem best", "tetfem", "tetfem curved", "scikit-fem", "MFEM", "MFEM curved"):
        cells_ = []
        for target in targets:
            best, ours = time_to(points, code, target), time_to(points, "tetfem best", target)
            if best is None:
                least = min((p for p in points if p["code"] == code or
                             (code == "tetfem best" and p["code"].startswith("tetfem"))), key=lambda p: p["error"])
                cells_.append(f"not reached (least error {least['error']:.1e})")
                continue
            text = f"{best['seconds']:.3f} s (P{best['order']}, {mesh_name(best['n'])})"
            if not code.startswith("tetfem"):
                text += f", {best['seconds'] / ours['seconds']:.1f}× tetfem's best" if ours else ", tetfem: not reached"
            cells_.append(text)
        lines.append(f"| {code} | " + " | ".join(cells_) + " |")
    lines += ["", "![Speed against accuracy: plate with a hole, tetfem beside scikit-fem and MFEM]"
              "(report/speed_accuracy_hole.png)", "",
              "Data: [report/speed_accuracy_hole.csv](report/speed_accuracy_hole.csv)."]
    return lines


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--quick", action="store_true", help="small meshes only (a check of the harness)")
    ap.add_argument("--out", default=os.path.join(ROOT, "validation", "SPEED_ACCURACY.md"))
    ap.add_argument("--chart-only", action="store_true", help="redraw the PNG from the last CSV, run nothing")
    a = ap.parse_args()
    if a.chart_only:
        draw(os.path.join(ROOT, "validation", "report", "speed_accuracy_hole.csv"))
        return 0
    for python in (PEERS_PYTHON, TETFEM_PYTHON):
        if not os.path.exists(python):
            print(f"hole: {python} not found (validation/setup_peers.sh; TETFEM_PEERS_PYTHON / TETFEM_PYTHON). "
                  "Skipping.", file=sys.stderr)
            return 0
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    from side_by_side import blas_probe
    blas = blas_probe(1)
    # A failed probe returns its traceback: keep its last line (the CSV header is one line).
    blas = blas.strip().splitlines()[-1] if blas.strip() else "unknown"
    ref, spread, ref_runs = reference(QUICK_REFERENCE if a.quick else REFERENCE)
    before = load()
    runs = sweep(a.repeat, QUICK_SWEEP if a.quick else SWEEP)
    after = load()
    points = [dict(r, error=abs(r["sxx"] - ref) / abs(ref), code=r["code"].replace("-curved", " curved"))
              for r in runs.values()]
    binding = next(iter(r["binding"] for r in runs.values() if "binding" in r))
    so = [f for f in os.listdir(os.path.dirname(binding)) if f.endswith(".so")]
    if so:
        stamp = datetime.fromtimestamp(os.path.getmtime(os.path.join(os.path.dirname(binding), so[0])), timezone.utc)
        binding = f"`{os.path.dirname(binding)}` (built {stamp:%Y-%m-%d %H:%M} UTC)"
    section = write_outputs(points, ref, spread, ref_runs, blas, a.repeat, (before, after), binding)
    old = open(a.out).read() if os.path.exists(a.out) else (
        "# Speed against accuracy, tetfem beside its peers\n\nWritten by programs — do not edit by hand. "
        "The static cantilever's section is in [SIDE_BY_SIDE.md](SIDE_BY_SIDE.md#accuracy-per-second).\n")
    head, _, rest = old.partition(HEADING)
    tail = ""
    if rest and "\n## " in rest:
        tail = "\n## " + rest.split("\n## ", 1)[1]
    with open(a.out + ".tmp", "w") as f:
        f.write(head.rstrip("\n") + "\n\n" + "\n".join(section) + "\n" + tail)
    os.replace(a.out + ".tmp", a.out)
    print(f"wrote {a.out}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    if len(sys.argv) > 1 and sys.argv[1] == "--worker":
        worker(sys.argv[2], int(sys.argv[3]), int(sys.argv[4]), sys.argv[5])
        sys.exit(0)
    sys.exit(main())
