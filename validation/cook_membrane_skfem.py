"""Cook's membrane in plane strain, linear elasticity, mixed Taylor–Hood P2–P1 triangles
(scikit-fem), the independent reference of tetfem's mixed element: the tip's vertical
displacement under refinement. Same geometry, μ, κ and shear traction as
tetfem_fixtures::cook::CookMembrane (mm, N/mm²)."""
import sys
import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
import skfem
from skfem import (MeshTri, ElementTriP2, ElementTriP1, ElementVector, Basis, FacetBasis,
                   BilinearForm, LinearForm, asm, bmat, condense, solve)
from skfem.helpers import dot, ddot, sym_grad, div

MU, KAPPA, TAU = 80.194, 400889.806, 6.25


def tip(n):
    m = MeshTri.init_tensor(np.linspace(0, 1, n + 1), np.linspace(0, 1, n + 1))
    xi, eta = m.p
    m = MeshTri(np.vstack([48.0 * xi, 44.0 * xi + eta * (44.0 - 28.0 * xi)]), m.t)
    eu = ElementVector(ElementTriP2())
    ep = ElementTriP1()
    bu = Basis(m, eu, intorder=4)
    bp = Basis(m, ep, intorder=4)

    @BilinearForm
    def a(u, v, w):
        e, f = sym_grad(u), sym_grad(v)
        # 2μ dev ε : dev ε in plane strain (ε_zz = 0, the 3-D deviator)
        return 2 * MU * ddot(e, f) - 2 * MU / 3 * div(u) * div(v)

    @BilinearForm
    def b(u, q, w):
        return -div(u) * q

    @BilinearForm
    def c(p, q, w):
        return -p * q / KAPPA

    A = asm(a, bu)
    B = asm(b, bu, bp)
    C = asm(c, bp)
    K = bmat([[A, B.T], [B, C]], "csr")
    right = m.facets_satisfying(lambda x: np.abs(x[0] - 48.0) < 1e-9)
    fb = FacetBasis(m, eu, facets=right, intorder=4)

    @LinearForm
    def load(v, w):
        return TAU * v[1]

    f = np.concatenate([asm(load, fb), np.zeros(bp.N)])
    left = bu.get_dofs(lambda x: np.abs(x[0]) < 1e-9).all()
    x = solve(*condense(K, f, D=left))
    u = x[: bu.N]
    # tip node (48, 60): its y DOF
    node = np.where((np.abs(m.p[0] - 48) < 1e-9) & (np.abs(m.p[1] - 60) < 1e-9))[0][0]
    ydofs = bu.nodal_dofs[1]
    return u[ydofs[node]], bu.N + bp.N


for n in [int(a) for a in sys.argv[1:]] or [4, 8, 16, 32, 64, 128]:
    t, dofs = tip(n)
    print(f"n = {n}: {dofs} DOFs, tip u_y = {t:.6f} mm", flush=True)
