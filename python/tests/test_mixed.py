"""tetfem.solve_static_mixed: the mixed displacement–pressure element from Python, on the
shipped Lamé tube (scenes/rubber_tube_mixed.*): the scene's answer, Lamé's, the displacement
element's locking beside it, the Neo-Hookean form's small-load limit, and the library's
refusals."""
from pathlib import Path

import numpy as np
import pytest

import tetfem

SCENES = Path(__file__).resolve().parents[2] / "scenes"
E, NU, P = 5e6, 0.4999, 5e4  # the scene's rubber and internal pressure (Pa)
A, B = 1.0, 2.0  # the tube's radii (m)


def tube(material, pressure=P):
    mesh = tetfem.Mesh.read(SCENES / "rubber_tube_mixed.msh")
    constraints = tetfem.Constraints(mesh)
    constraints.fix(mesh.nodes_in_group("x0"), "x")
    constraints.fix(mesh.nodes_in_group("y0"), "y")
    constraints.fix(mesh.nodes_in_group("ends"), "z")
    loads = tetfem.Loads(mesh)
    loads.add_pressure(mesh.faces_in_group("inner"), pressure)
    return mesh, constraints, loads


def bore_radial(mesh, u):
    """The mean radial displacement of the nodes at r = a (m)."""
    nodes = mesh.nodes_in_group("inner")
    x = mesh.points[nodes]
    r = np.hypot(x[:, 0], x[:, 1])
    return float(np.mean((u[nodes, 0] * x[:, 0] + u[nodes, 1] * x[:, 1]) / r))


def test_the_mixed_tube_is_lames_and_the_scenes():
    rubber = tetfem.Material(E, NU, 1100.0)
    mesh, constraints, loads = tube(rubber)
    mixed = tetfem.solve_static_mixed(mesh, rubber, constraints, loads)
    exact = (1 + NU) * P * A**2 / (E * (B**2 - A**2)) * ((1 - 2 * NU) * A + B**2 / A)
    ratio = bore_radial(mesh, mixed["displacement"]) / exact
    # Within 1 % of Lamé (the target; the polygonal bore costs 7e-4 on this mesh).
    assert abs(ratio - 1.0) < 0.01, ratio
    # The mean pressure −tr σ/3 of plane-strain Lamé is uniform: −2(1+ν)pa²/(3(b²−a²)).
    p_exact = -2 * (1 + NU) * P * A**2 / (3 * (B**2 - A**2))
    assert np.median(mixed["pressure"]) == pytest.approx(p_exact, rel=0.01)
    assert mixed["model"] == "linear" and mixed["newton_iterations"] == 0
    # The same solve as the scene (same mesh, supports, load and function): its probe's mean
    # displacement to round-off of the summation order.
    summary = tetfem.run_scene(SCENES / "rubber_tube_mixed.toml", write_files=False)
    probe = summary["probes"][0]["displacement"]
    nodes = mesh.nodes_in_group("inner")
    mean = mixed["displacement"][nodes].mean(axis=0)
    np.testing.assert_allclose(mean, probe, rtol=1e-9, atol=1e-15)
    # The displacement element on the same 10-node mesh is within a few per cent here; on the
    # 4-node tets of the same cells it locks (tests/core/mixed_tube.rs measures 0.478).


def test_neo_hookean_at_a_small_load_is_the_linear_mixed_solve():
    rubber = tetfem.Material(E, NU, 1100.0)
    mesh, constraints, loads = tube(rubber, pressure=P * 1e-4)
    linear = tetfem.solve_static_mixed(mesh, rubber, constraints, loads)
    rubbery = tetfem.solve_static_mixed(mesh, rubber, constraints, loads, model="neo-hookean", load_steps=1)
    u0, u1 = linear["displacement"], rubbery["displacement"]
    # The models agree to first order: their difference is of the order of the strain,
    # ~1e-6 at this load (2e-6 m bore displacement on a 1 m tube).
    assert np.abs(u1 - u0).max() <= 1e-4 * np.abs(u0).max()
    assert rubbery["newton_iterations"] >= 1


def test_the_stabilized_p1_block_in_uniaxial_tension_is_exact():
    # 4-node tets (the stabilized P1–P1): a 1 × 0.5 × 0.5 m block on rollers pulled by 1 kPa
    # is an affine displacement with a constant pressure, which the element reproduces.
    rubber = tetfem.Material(1e6, 0.4999, 1000.0)
    mesh = tetfem.Mesh.box(max=(1.0, 0.5, 0.5), cells=(2, 1, 1))
    constraints = tetfem.Constraints(mesh)
    for axis in "xyz":
        constraints.fix(mesh.nodes_on_plane(axis, 0.0), axis)
    loads = tetfem.Loads(mesh).add_traction(mesh.faces_on_plane("x", 1.0), (1000.0, 0.0, 0.0))
    mixed = tetfem.solve_static_mixed(mesh, rubber, constraints, loads)
    x = mesh.points
    # u = (σ/E)(x, −νy, −νz) and p = −σ/3: round-off of a system with κ/μ = 5e3.
    exact = 1e-3 * np.column_stack([x[:, 0], -0.4999 * x[:, 1], -0.4999 * x[:, 2]])
    np.testing.assert_allclose(mixed["displacement"], exact, rtol=0, atol=1e-12)
    np.testing.assert_allclose(mixed["pressure"], -1000.0 / 3.0, rtol=1e-9)


def test_what_the_mixed_element_cannot_do_is_refused_by_name():
    rubber = tetfem.Material(E, NU, 1100.0)
    linear_mesh = tetfem.Mesh.box(max=(1.0, 1.0, 1.0), cells=(2, 2, 2))
    constraints = tetfem.Constraints(linear_mesh).fix(linear_mesh.nodes_on_plane("z", 0.0))
    with pytest.raises(tetfem.InvalidInputError, match="mixed with model"):
        loads = tetfem.Loads(linear_mesh)
        tetfem.solve_static_mixed(linear_mesh, rubber, constraints, loads, model="st-venant-kirchhoff")
    mesh = tetfem.Mesh.box(max=(1.0, 1.0, 1.0), cells=(2, 2, 2), order=2)
    constraints = tetfem.Constraints(mesh).fix(mesh.nodes_on_plane("z", 0.0))
    with pytest.raises(tetfem.InvalidInputError, match="mixed with model"):
        tetfem.solve_static_mixed(mesh, rubber, constraints, tetfem.Loads(mesh), model="st-venant-kirchhoff")
