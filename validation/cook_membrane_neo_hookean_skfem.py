"""Cook's membrane in plane strain, nearly incompressible Neo-Hookean, mixed Taylor–Hood
triangles (scikit-fem, Newton written here): the independent reference of tetfem's mixed
Neo-Hookean tip. Same geometry, μ, κ, dead shear traction and energy as
tetfem_fixtures::cook::CookMembrane with tetfem's Neo-Hookean model (mm, N/mm²):

    W(F) = μ/2·(J^(−2/3)·I₁ − 3) + κ/2·(J − 1)²,   I₁ = F:F (3-D, F₃₃ = 1 in plane strain),

whose Cauchy stress is tetfem's σ = μ·J^(−5/3)·dev(F·Fᵀ) + κ(J − 1)·I. The mixed form
Π(u, p) = ∫ μ/2·(J^(−2/3)·I₁ − 3) + p·(J − 1) − p²/(2κ) dx − ∫ τ·u_y ds has the same
stationary displacement (p = κ(J − 1) eliminates back to W). Newton on the saddle, the load
in `STEPS` equal increments, each to a residual 1e-10 of its first.

Usage: python3 cook_membrane_neo_hookean_skfem.py [order] [n ...]
(order 2: P2–P1, order 3: P3–P2; default P2–P1 on n = 8 … 128)."""
import sys
import time
import numpy as np
import scipy.sparse.linalg as spla
from skfem import (MeshTri, ElementTriP1, ElementTriP2, ElementTriP3, ElementVector, Basis,
                   FacetBasis, BilinearForm, LinearForm, asm, bmat, condense)

MU, KAPPA, TAU = 80.194, 400889.806, 6.25
STEPS = 8


def kinematics(grad_u):
    """F (2×2 plane part), J, F⁻ᵀ and I₁ = F:F + 1 at the quadrature points."""
    f = grad_u.copy()
    f[0, 0] += 1.0
    f[1, 1] += 1.0
    j = f[0, 0] * f[1, 1] - f[0, 1] * f[1, 0]
    finv_t = np.array([[f[1, 1], -f[1, 0]], [-f[0, 1], f[0, 0]]]) / j
    i1 = np.einsum("ij...,ij...->...", f, f) + 1.0
    return f, j, finv_t, i1


def ddot(a, b):
    return np.einsum("ij...,ij...->...", a, b)


def tip(order, n):
    m = MeshTri.init_tensor(np.linspace(0, 1, n + 1), np.linspace(0, 1, n + 1))
    xi, eta = m.p
    m = MeshTri(np.vstack([48.0 * xi, 44.0 * xi + eta * (44.0 - 28.0 * xi)]), m.t)
    eu = ElementVector({2: ElementTriP2, 3: ElementTriP3}[order]())
    ep = {2: ElementTriP1, 3: ElementTriP2}[order]()
    q = 2 * order + 2
    bu = Basis(m, eu, intorder=q)
    bp = Basis(m, ep, intorder=q)

    @BilinearForm
    def k_uu(du, v, w):
        f, j, fit, i1 = kinematics(w["u"].grad)
        a, b = du.grad, v.grad
        c = j ** (-2.0 / 3.0)
        fit_a = ddot(fit, a)
        f_a = ddot(f, a)
        # F⁻ᵀ·dFᵀ·F⁻ᵀ : ∇v
        t = np.einsum("ik...,lk...,lj...,ij...->...", fit, a, fit, b)
        dev = MU * c * (ddot(a, b) - 2.0 / 3.0 * fit_a * ddot(f, b)
                        + 2.0 / 9.0 * i1 * fit_a * ddot(fit, b)
                        - 2.0 / 3.0 * f_a * ddot(fit, b) + i1 / 3.0 * t)
        vol = w["p"].value * j * (fit_a * ddot(fit, b) - t)
        return dev + vol

    @BilinearForm
    def k_pu(du, qq, w):
        _, j, fit, _ = kinematics(w["u"].grad)
        return qq * j * ddot(fit, du.grad)

    @BilinearForm
    def k_pp(pp, qq, w):
        return -pp * qq / KAPPA

    @LinearForm
    def r_u(v, w):
        f, j, fit, i1 = kinematics(w["u"].grad)
        p_dev = MU * j ** (-2.0 / 3.0) * (f - i1 / 3.0 * fit)
        return ddot(p_dev + w["p"].value * j * fit, v.grad)

    @LinearForm
    def r_p(qq, w):
        _, j, _, _ = kinematics(w["u"].grad)
        return qq * (j - 1.0 - w["p"].value / KAPPA)

    right = m.facets_satisfying(lambda x: np.abs(x[0] - 48.0) < 1e-9)
    fb = FacetBasis(m, eu, facets=right, intorder=q)

    @LinearForm
    def load(v, w):
        return TAU * v[1]

    f_ext = asm(load, fb)
    left = bu.get_dofs(lambda x: np.abs(x[0]) < 1e-9).all()
    nu = bu.N
    u = np.zeros(nu)
    p = np.zeros(bp.N)
    iterations = 0
    for step in range(1, STEPS + 1):
        first = None
        for _ in range(30):
            wu, wp = bu.interpolate(u), bp.interpolate(p)
            ru = asm(r_u, bu, u=wu, p=wp) - step / STEPS * f_ext
            rp = asm(r_p, bp, u=wu, p=wp)
            r = np.concatenate([ru, rp])
            r[left] = 0.0
            norm = np.linalg.norm(r)
            first = first or norm
            if norm <= 1e-10 * first:
                break
            kuu = asm(k_uu, bu, u=wu, p=wp)
            kpu = asm(k_pu, bu, bp, u=wu, p=wp)
            kpp = asm(k_pp, bp)
            k = bmat([[kuu, kpu.T], [kpu, kpp]], "csc")
            a, b, x, interior = condense(k, -r, D=left)
            dx = np.zeros(len(r))
            dx[interior] = spla.spsolve(a, b)
            u += dx[:nu]
            p += dx[nu:]
            iterations += 1
        else:
            raise RuntimeError(f"n = {n}: step {step} did not converge ({norm:.3e})")
    node = np.where((np.abs(m.p[0] - 48) < 1e-9) & (np.abs(m.p[1] - 60) < 1e-9))[0][0]
    return u[bu.nodal_dofs[1][node]], bu.N + bp.N, iterations


if __name__ == "__main__":
    args = [int(a) for a in sys.argv[1:]]
    order = args[0] if args else 2
    for n in args[1:] or [8, 16, 32, 64, 128]:
        start = time.perf_counter()
        t, dofs, its = tip(order, n)
        print(f"P{order}–P{order - 1} n = {n}: {dofs} DOFs, tip u_y = {t:.6f} mm, "
              f"{its} Newton iterations, {time.perf_counter() - start:.1f} s", flush=True)
