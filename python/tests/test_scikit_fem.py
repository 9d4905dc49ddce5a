"""Cross-check with scikit-fem on the same mesh, when it is installed (skipped otherwise, except under CI)."""

import numpy as np
import pytest

import tetfem
from conftest import optional_import

skfem = optional_import("skfem", reason="scikit-fem not installed: cross-check skipped")
optional_import("scipy.sparse", reason="scipy not installed: cross-check skipped")


def test_stiffness_and_cantilever_tip_agree_with_scikit_fem():
    from scipy.sparse.linalg import spsolve
    from skfem import Basis, ElementTetP1, ElementVector, MeshTet, asm
    from skfem.models.elasticity import lame_parameters, linear_elasticity

    mesh = tetfem.Mesh.box(max=(1.0, 0.1, 0.1), cells=(20, 2, 2))
    steel = tetfem.Material.steel()
    basis = Basis(MeshTet(mesh.points.T.copy(), mesh.tets.T.copy()), ElementVector(ElementTetP1()))
    # scikit-fem numbers vector DOFs 3·node + axis, as tetfem does.
    assert np.array_equal(basis.nodal_dofs, np.arange(mesh.dof_count).reshape(-1, 3).T)
    k_skfem = asm(linear_elasticity(*lame_parameters(200e9, 0.3)), basis).tocsr()
    k = tetfem.stiffness_matrix(mesh, steel)
    # The same element integrals summed in another order: entries agree to rounding,
    # 1e-12 of the largest entry.
    assert abs(k - k_skfem).max() < 1e-12 * abs(k).max()

    constraints = tetfem.Constraints(mesh).fix(mesh.nodes_on_plane("x", 0.0))
    loads = tetfem.Loads(mesh).add_total_force(mesh.faces_on_plane("x", 1.0), (0, 0, -1e4))
    result = tetfem.solve_static(mesh, steel, constraints, loads)
    free = np.setdiff1d(np.arange(mesh.dof_count), constraints.constrained_dofs)
    f = loads.forces.reshape(-1)
    u = np.zeros(mesh.dof_count)
    u[free] = spsolve(k_skfem[free][:, free].tocsc(), f[free])
    tip = mesh.nodes_on_plane("x", 1.0)
    ours, theirs = result.displacement[tip, 2].mean(), u.reshape(-1, 3)[tip, 2].mean()
    print(f"tip u_z: tetfem {ours!r}, scikit-fem {theirs!r}")
    # Two direct solves of a system with κ ≈ 1e7: agreement to ~1e-9 relative.
    assert ours == pytest.approx(theirs, rel=1e-9)
