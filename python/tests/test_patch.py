"""The patch test through the Python API: a linear displacement field prescribed on the
boundary of a distorted mesh is reproduced exactly inside (linear tets hold every linear
field), with constant stress."""

import numpy as np

import tetfem

GRADIENT = np.array([[1e-3, 2e-4, -3e-4], [5e-4, -2e-3, 1e-4], [-1e-4, 3e-4, 4e-4]])
OFFSET = np.array([1e-4, -2e-4, 3e-4])


def distorted_cube():
    """The unit cube in 4×4×4 cells with every interior node moved by up to 0.15 of a cell
    (fixed seed): a patch of irregular tets."""
    box = tetfem.Mesh.box(max=(1.0, 1.0, 1.0), cells=(4, 4, 4), split="five")
    points = box.points.copy()
    interior = np.all((points > 1e-9) & (points < 1 - 1e-9), axis=1)
    rng = np.random.default_rng(21)
    points[interior] += rng.uniform(-0.15, 0.15, size=(interior.sum(), 3)) * 0.25
    return tetfem.Mesh(points, box.tets)


def test_linear_field_is_reproduced_exactly_inside():
    mesh = distorted_cube()
    points = mesh.points
    boundary = np.unique(mesh.boundary_faces())
    assert 0 < len(boundary) < mesh.node_count  # there are interior nodes to test
    material = tetfem.Material(1e9, 0.3, 1000.0)
    constraints = tetfem.Constraints(mesh).prescribe_linear(boundary, GRADIENT, OFFSET)
    result = tetfem.solve_static(mesh, material, constraints, tetfem.Loads(mesh))
    exact = points @ GRADIENT.T + OFFSET
    error = np.abs(result.displacement - exact).max() / np.abs(exact).max()
    print(f"patch test: max relative nodal error {error:.2e}")
    # The discrete solution is the linear field itself; what remains is the rounding of the
    # Cholesky solve, about κ(K_ff)·ε ≈ 1e3·1e-16 here: 1e-10 leaves a wide margin and still
    # fails for any wrong element (errors of order 1e-2 and up).
    assert error < 1e-10

    # Constant strain ε = sym(GRADIENT) gives σ = λ·tr(ε)·I + 2μ·ε in every tet.
    strain = 0.5 * (GRADIENT + GRADIENT.T)
    lam, mu = material.lame_lambda, material.shear_modulus
    sigma = lam * np.trace(strain) * np.eye(3) + 2 * mu * strain
    stress_error = np.abs(result.stress - sigma).max() / np.abs(sigma).max()
    # Stress differentiates u over a tet of size ~0.25: the nodal rounding above, divided by the
    # tet size and multiplied by the modulus, relative to σ: within 1e-8.
    assert stress_error < 1e-8


def test_prescribe_rows_equal_prescribe_linear():
    """The same field given row by row (numpy) gives the same constraints and solution bits."""
    mesh = distorted_cube()
    boundary = np.unique(mesh.boundary_faces())
    rows = np.array([GRADIENT @ mesh.points[n] + OFFSET for n in boundary])
    by_rows = tetfem.Constraints(mesh).prescribe(boundary, rows)
    by_field = tetfem.Constraints(mesh).prescribe_linear(boundary, GRADIENT, OFFSET)
    assert by_rows.constrained_dofs.tolist() == by_field.constrained_dofs.tolist()
    material = tetfem.Material(1e9, 0.3, 1000.0)
    a = tetfem.solve_static(mesh, material, by_rows, tetfem.Loads(mesh)).displacement
    b = tetfem.solve_static(mesh, material, by_field, tetfem.Loads(mesh)).displacement
    # numpy's matrix-vector product and the binding's may round differently in the last bit.
    assert np.abs(a - b).max() <= 1e-15 * np.abs(a).max() * 10
