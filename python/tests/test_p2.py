"""10-node (quadratic, P2) tets through the native calls (issue 34, item 5): ``Mesh.box(...,
order=2)``, ``Mesh.read`` of a quadratic file at its own order, and every analysis on them,
compared with the Rust scene runner on the same mesh, with exact identities and analytic values.
"""

import math

import numpy as np
import pytest

import tetfem
from conftest import SCENES, probe_mean

EDGES = [(0, 1), (1, 2), (0, 2), (0, 3), (1, 3), (2, 3)]


def test_box_of_order_2_has_a_node_at_each_edge_midpoint():
    mesh = tetfem.Mesh.box(max=(1.0, 1.0, 1.0), cells=(2, 2, 2), order=2)
    linear = tetfem.Mesh.box(max=(1.0, 1.0, 1.0), cells=(2, 2, 2))
    assert mesh.order == 2 and linear.order == 1
    assert mesh.tets.shape == (linear.tet_count, 10)
    # The corners are the linear box's tets, node for node.
    assert np.array_equal(mesh.tets[:, :4], linear.tets)
    p = mesh.points
    for k, (i, j) in enumerate(EDGES):
        # Exact: the midpoint of two grid points is computed as (a + b) / 2 once.
        np.testing.assert_allclose(p[mesh.tets[:, 4 + k]], 0.5 * (p[mesh.tets[:, i]] + p[mesh.tets[:, j]]), rtol=0, atol=1e-15)
    # 27 grid points plus one node per distinct edge; no node left unused.
    edges = {tuple(sorted((t[i], t[j]))) for t in linear.tets for i, j in EDGES}
    assert mesh.node_count == 27 + len(edges)
    assert mesh.volume == pytest.approx(1.0, rel=1e-14)  # the sum of 48 tet volumes
    with pytest.raises(tetfem.InvalidInputError, match="order"):
        tetfem.Mesh.box(max=(1.0, 1.0, 1.0), cells=(2, 2, 2), order=3)


GRADIENT = np.array([[1e-3, 2e-4, -3e-4], [5e-4, -2e-3, 1e-4], [-1e-4, 3e-4, 4e-4]])
OFFSET = np.array([1e-4, -2e-4, 3e-4])


def test_p2_patch_test_reproduces_a_linear_field_exactly():
    mesh = tetfem.Mesh.box(max=(1.0, 1.0, 1.0), cells=(3, 3, 3), split="five", order=2)
    points = mesh.points
    # Every boundary node, the edge nodes of boundary faces too (boundary_faces lists corners).
    on_boundary = np.any((points < 1e-12) | (points > 1 - 1e-12), axis=1)
    boundary = mesh.nodes_where(on_boundary)
    assert 0 < len(boundary) < mesh.node_count
    material = tetfem.Material(1e9, 0.3, 1000.0)
    constraints = tetfem.Constraints(mesh).prescribe_linear(boundary, GRADIENT, OFFSET)
    result = tetfem.solve_static(mesh, material, constraints, tetfem.Loads(mesh), linear_solver="direct")
    exact = points @ GRADIENT.T + OFFSET
    error = np.abs(result.displacement - exact).max() / np.abs(exact).max()
    print(f"P2 patch test: max relative nodal error {error:.2e}")
    # Quadratic tets hold every linear field: what remains is the rounding of the Cholesky
    # solve, κ(K_ff)·ε ≈ 1e3·1e-16; a wrong element gives 1e-3 and up.
    assert error < 1e-12
    strain = 0.5 * (GRADIENT + GRADIENT.T)
    lam, mu = material.lame_lambda, material.shear_modulus
    sigma = lam * np.trace(strain) * np.eye(3) + 2 * mu * strain
    # Stress differentiates the nodal rounding over a tet of size ~0.3 (×3/h) times E: 1e-10.
    assert np.abs(result.stress - sigma).max() / np.abs(sigma).max() < 1e-10


def cantilever_p2(cells=(20, 2, 2)):
    """scenes/cantilever_p2.toml through the Python API."""
    mesh = tetfem.Mesh.box(max=(1.0, 0.1, 0.1), cells=cells, split="mirrored6", order=2)
    steel = tetfem.Material(200e9, 0.3, 7850.0)
    constraints = tetfem.Constraints(mesh).fix(mesh.nodes_on_plane("x", 0.0))
    loads = (
        tetfem.Loads(mesh)
        .add_total_force(mesh.faces_on_plane("x", 1.0), (0.0, 0.0, -10e3))
        .add_gravity((0.0, 0.0, -9.81), steel)
    )
    return mesh, steel, constraints, loads


def test_p2_cantilever_equals_the_scene_runner():
    summary = tetfem.run_scene(SCENES / "cantilever_p2.toml", write_files=False)
    mesh, steel, constraints, loads = cantilever_p2()
    result = tetfem.solve_static(mesh, steel, constraints, loads)
    tip = probe_mean(result.displacement, mesh.nodes_on_plane("x", 1.0))
    print(f"P2 cantilever tip {tip}, scene {summary['probes'][0]['displacement']}")
    # The same mesh, loads and library solve: equal bits.
    assert tip == summary["probes"][0]["displacement"]
    assert result.relative_residual == summary["relative_residual"]
    # The scene's comment: −2.05 mm on these quadratic tets (beam theory −2.06 mm with weight).
    assert tip[2] == pytest.approx(-2.05e-3, rel=0.01)
    (row,) = summary["reactions"]
    # The same reactions summed by numpy here and by Rust there: the last bits of a sum.
    np.testing.assert_allclose(result.reactions.sum(axis=0), row["force_n"], rtol=1e-12, atol=1e-9)
    estimate = tetfem.estimate_error(mesh, steel, result.displacement)
    assert estimate["relative"] == summary["estimated_error"]["relative"]
    assert estimate["indicators"].shape == (mesh.tet_count,)


def test_p2_file_is_read_at_its_order_and_solved_as_the_scene_runner():
    summary = tetfem.run_scene(SCENES / "l_bracket_p2.toml", write_files=False)
    mesh = tetfem.Mesh.read(SCENES / "l_bracket_p2.msh")
    assert mesh.order == 2 and mesh.node_count == 990 and mesh.tets.shape[1] == 10
    assert not [w for w in mesh.warnings if "order 2" in w]
    steel = tetfem.Material(200e9, 0.3, 7850.0)
    constraints = tetfem.Constraints(mesh).fix(mesh.nodes_in_group("clamp"))
    loads = tetfem.Loads(mesh).add_total_force(mesh.faces_in_group("load"), (0.0, -2000.0, 0.0))
    result = tetfem.solve_static(mesh, steel, constraints, loads)
    face = probe_mean(result.displacement, mesh.nodes_in_group("load"))
    assert face == summary["probes"][0]["displacement"]
    with pytest.raises(tetfem.MeshError, match="l_bracket.msh"):
        tetfem.Mesh.read(SCENES / "l_bracket.msh", order=2)


MODAL_P2 = """
title = "P2 cantilever modes"
[mesh]
order = 2
[mesh.box]
max = [1.0, 0.1, 0.1]
cells = [10, 2, 2]
[material]
youngs_modulus = 200e9
poisson_ratio = 0.3
density = 7850.0
[[constraints]]
where = { plane = { axis = "x", at = 0.0 } }
[analysis]
type = "modal"
modes = 4
mass = "consistent"
"""


def test_p2_modal_frequencies_equal_the_scene_runner(tmp_path):
    scene = tmp_path / "modal_p2.toml"
    scene.write_text(MODAL_P2)
    summary = tetfem.run_scene(scene, write_files=False)
    mesh = tetfem.Mesh.box(max=(1.0, 0.1, 0.1), cells=(10, 2, 2), order=2)
    steel = tetfem.Material(200e9, 0.3, 7850.0)
    constraints = tetfem.Constraints(mesh).fix(mesh.nodes_on_plane("x", 0.0))
    modes = tetfem.modal_analysis(mesh, steel, constraints, count=4, mass="consistent")
    print(f"P2 modal frequencies {modes.frequencies} Hz")
    assert modes.frequencies.tolist() == [m["frequency_hz"] for m in summary["modes"]]
    # Euler–Bernoulli first bending mode f₁ = 1.875²/(2π)·√(EI/(ρA L⁴)) = 81.5 Hz; shear
    # (Timoshenko, L/h = 10) lowers it by about 1 % and the coarse mesh raises it a little: 3 %.
    f1 = 1.875**2 / (2 * math.pi) * math.sqrt(200e9 * 0.1**4 / 12 / (7850.0 * 0.01))
    assert modes.frequencies[0] == pytest.approx(f1, rel=0.03)


DYNAMIC_P2 = """
title = "P2 cantilever, step load"
[mesh]
order = 2
[mesh.box]
max = [1.0, 0.1, 0.1]
cells = [10, 2, 2]
[material]
youngs_modulus = 200e9
poisson_ratio = 0.3
density = 7850.0
[[constraints]]
where = {{ plane = {{ axis = "x", at = 0.0 }} }}
[[loads]]
where = {{ plane = {{ axis = "x", at = 1.0 }} }}
total_force = [0.0, 0.0, -10e3]
[[probes]]
name = "tip"
where = {{ plane = {{ axis = "x", at = 1.0 }} }}
[analysis]
type = "dynamic"
method = "{method}"
model = "{model}"
dt = 1e-4
duration = 0.002
"""


@pytest.mark.parametrize("method,model", [("backward_euler", "linear"), ("newmark", "corotational")])
def test_p2_dynamic_run_equals_the_scene_runner(tmp_path, method, model):
    scene = tmp_path / "dynamic_p2.toml"
    scene.write_text(DYNAMIC_P2.format(method=method, model=model))
    summary = tetfem.run_scene(scene, write_files=False)
    mesh = tetfem.Mesh.box(max=(1.0, 0.1, 0.1), cells=(10, 2, 2), order=2)
    steel = tetfem.Material(200e9, 0.3, 7850.0)
    constraints = tetfem.Constraints(mesh).fix(mesh.nodes_on_plane("x", 0.0))
    loads = tetfem.Loads(mesh).add_total_force(mesh.faces_on_plane("x", 1.0), (0.0, 0.0, -10e3))
    sim = tetfem.Simulation(mesh, steel, constraints, loads, dt=1e-4, method=method.replace("_", "-"), model=model)
    history = sim.run(summary["steps"])
    # The same system and integrator from the same library calls: equal bits.
    assert history["total"][-1] == summary["final_energy"]["total"]
    assert history["kinetic"][-1] == summary["final_energy"]["kinetic"]
    assert history["kinetic"][-1] > 0  # the step load set the beam moving


def test_p2_static_nonlinear_model_at_small_load_matches_the_linear_one():
    mesh, steel, constraints, loads = cantilever_p2(cells=(10, 2, 2))
    linear = tetfem.solve_static(mesh, steel, constraints, loads)
    corot = tetfem.solve_static(mesh, steel, constraints, loads, model="corotational")
    tip = mesh.nodes_on_plane("x", 1.0)
    a, b = probe_mean(linear.displacement, tip)[2], probe_mean(corot.displacement, tip)[2]
    print(f"P2 tip: linear {a:.6e}, corotational {b:.6e}")
    # Rotations ~3e-3 rad: the models differ by O(θ²) ≈ 1e-5 relative; 1e-4 leaves room.
    assert b == pytest.approx(a, rel=1e-4)
    total = corot.reactions.sum(axis=0) + loads.resultant
    # Newton's residual ≤ 1e-10·‖f‖ over ~100 free components: equilibrium to 1e-7 of 10 kN.
    assert np.abs(total).max() < 1e-7 * 10e3


P2_FLOOR_SCENE = """
title = "P2 beam pressed onto a floor"
[mesh]
order = 2
[mesh.box]
max = [1.0, 0.1, 0.1]
cells = [4, 1, 1]
[material]
youngs_modulus = 1e6
poisson_ratio = 0.3
density = 1000.0
[[constraints]]
where = { plane = { axis = "x", at = 0.0 } }
[[loads]]
where = { plane = { axis = "x", at = 1.0 } }
total_force = [0.0, 0.0, -1.0]
[[probes]]
name = "tip"
where = { plane = { axis = "x", at = 1.0 } }
[analysis]
type = "static"
[[obstacles]]
kind = "half_space"
name = "floor"
point = [0.0, 0.0, -0.005]
normal = [0.0, 0.0, 1.0]
friction = 0.2
"""


def test_obstacles_on_p2_equal_the_scene_runner(tmp_path):
    # Obstacles on 10-node tets (the boundary's corner and mid-edge nodes touch), as the
    # scene runner solves them: the same Newton with the barrier, the same bits.
    scene = tmp_path / "floor_p2.toml"
    scene.write_text(P2_FLOOR_SCENE)
    summary = tetfem.run_scene(scene, write_files=False)
    mesh = tetfem.Mesh.box(max=(1.0, 0.1, 0.1), cells=(4, 1, 1), order=2)
    soft = tetfem.Material(1e6, 0.3, 1000.0)
    constraints = tetfem.Constraints(mesh).fix(mesh.nodes_on_plane("x", 0.0))
    loads = tetfem.Loads(mesh).add_total_force(mesh.faces_on_plane("x", 1.0), (0.0, 0.0, -1.0))
    floor = tetfem.Obstacle.half_space("floor", (0.0, 0.0, -0.005), (0.0, 0.0, 1.0), friction=0.2)
    result = tetfem.solve_static(mesh, soft, constraints, loads, obstacles=[floor])
    tip = probe_mean(result.displacement, mesh.nodes_on_plane("x", 1.0))
    (probe,) = summary["probes"]
    assert tip == probe["displacement"]
    z = mesh.points[:, 2] + result.displacement[:, 2]
    print(f"P2 beam on the floor: tip {tip}, lowest node {z.min():.3e} m")
    # The floor held it: the free tip would sag ~4 cm under 1 N at E = 1 MPa; it stops at
    # the floor (within the barrier's reach d̂ = 1 mm), no node (mid-edge ones included) below it.
    assert z.min() > -0.005 and tip[2] < -0.004
    balance = result.reactions.sum(axis=0) + loads.resultant - result.contact_forces.sum(axis=0)
    # Newton's residual (1e-10 of the 1 N load) and the friction lag's tolerance: 1e-7 N.
    assert np.abs(balance).max() < 1e-7, balance
