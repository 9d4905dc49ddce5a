"""Native calls at parity with scenes (issue 34, item 5): reactions of every model, obstacles
with friction in static solves, the error estimate and the model-adequacy advice.

Each test compares with the Rust scene runner on the same problem (``run_scene``: its own
set-up, the same library dispatch), with an analytic value, or with equilibrium.
"""

import math

import numpy as np
import pytest

import tetfem
from conftest import SCENES, probe_mean

# A clamped soft beam whose tip load presses it onto a floor 5 mm under it (and, in the
# friction case, drags it along the floor): the contact case of the tests below, once as a
# scene and once through the Python API.
FLOOR_SCENE = """
title = "beam pressed onto a floor"
[mesh.box]
max = [1.0, 0.1, 0.1]
cells = [10, 2, 2]
[material]
youngs_modulus = 1e6
poisson_ratio = 0.3
density = 1000.0
[[constraints]]
where = {{ plane = {{ axis = "x", at = 0.0 }} }}
[[loads]]
where = {{ plane = {{ axis = "x", at = 1.0 }} }}
total_force = [{fx}, 0.0, -1.0]
[[probes]]
name = "tip"
where = {{ plane = {{ axis = "x", at = 1.0 }} }}
[analysis]
type = "static"
model = "{model}"
[[obstacles]]
kind = "half_space"
name = "floor"
point = [0.0, 0.0, -0.005]
normal = [0.0, 0.0, 1.0]
friction = {mu}
"""


def floor_case(model="linear", mu=0.0, fx=0.0):
    mesh = tetfem.Mesh.box(max=(1.0, 0.1, 0.1), cells=(10, 2, 2))
    soft = tetfem.Material(1e6, 0.3, 1000.0)
    constraints = tetfem.Constraints(mesh).fix(mesh.nodes_on_plane("x", 0.0))
    loads = tetfem.Loads(mesh).add_total_force(mesh.faces_on_plane("x", 1.0), (fx, 0.0, -1.0))
    floor = tetfem.Obstacle.half_space("floor", (0.0, 0.0, -0.005), (0.0, 0.0, 1.0), friction=mu)
    result = tetfem.solve_static(mesh, soft, constraints, loads, model=model, obstacles=[floor])
    return mesh, loads, result


def run_floor_scene(tmp_path, model="linear", mu=0.0, fx=0.0):
    path = tmp_path / "floor.toml"
    path.write_text(FLOOR_SCENE.format(model=model, mu=mu, fx=fx))
    return tetfem.run_scene(path, write_files=False)


def rubber_cantilever():
    """scenes/rubber_cantilever_large.toml (corotational, Newton) through the Python API."""
    mesh = tetfem.Mesh.box(max=(0.5, 0.05, 0.05), cells=(20, 2, 2), split="five")
    rubber = tetfem.Material(5e6, 0.45, 1100.0)
    constraints = tetfem.Constraints(mesh).fix(mesh.nodes_on_plane("x", 0.0))
    loads = tetfem.Loads(mesh).add_total_force(mesh.faces_on_plane("x", 0.5), (0.0, 0.0, -30.0))
    return mesh, rubber, constraints, loads


@pytest.mark.parametrize("model", ["corotational", "neo-hookean", "st-venant-kirchhoff"])
def test_nonlinear_reactions_balance_the_load(model):
    mesh, rubber, constraints, loads = rubber_cantilever()
    result = tetfem.solve_static(mesh, rubber, constraints, loads, model=model)
    assert result.reactions is not None and result.reactions.shape == (mesh.node_count, 3)
    free = np.ones(mesh.node_count, dtype=bool)
    free[mesh.nodes_on_plane("x", 0.0)] = False
    # Reactions live on the constrained DOFs only (exact zeros elsewhere).
    assert np.all(result.reactions[free] == 0.0)
    total = result.reactions.sum(axis=0) + loads.resultant
    # Σ R + Σ f = Σ of the free residual components ≤ √n_f·‖r_f‖, ‖r_f‖ ≤ 1e-10·‖f‖ (Newton's
    # tolerance): 1e-7 × the 30 N load leaves room for √n_f ≈ 30 and summation round-off.
    assert np.abs(total).max() < 1e-7 * 30.0, total
    # The support carries the whole tip load upwards.
    assert result.reactions.sum(axis=0)[2] == pytest.approx(30.0, rel=1e-8)


def test_nonlinear_reactions_equal_the_scene_runner():
    mesh, rubber, constraints, loads = rubber_cantilever()
    result = tetfem.solve_static(mesh, rubber, constraints, loads, model="corotational")
    summary = tetfem.run_scene(SCENES / "rubber_cantilever_large.toml", write_files=False)
    (row,) = summary["reactions"]
    # The same reactions (one library function), summed by numpy here and by Rust there over
    # the same DOFs: equal up to the last bits of a 60-term sum of ~1 N terms.
    np.testing.assert_allclose(result.reactions.sum(axis=0), row["force_n"], rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("model,mu,fx", [("linear", 0.0, 0.0), ("corotational", 0.0, 0.0), ("linear", 0.5, 0.05)])
def test_static_contact_equals_the_scene_runner(tmp_path, model, mu, fx):
    mesh, loads, result = floor_case(model, mu, fx)
    summary = run_floor_scene(tmp_path, model, mu, fx)
    tip = mesh.nodes_on_plane("x", 1.0)
    # The same problem through the same library dispatch: equal bits.
    assert probe_mean(result.displacement, tip) == summary["probes"][0]["displacement"]
    (floor,) = summary["contact_forces"]
    assert floor["obstacle"] == "floor"
    assert result.contact_forces.shape == (1, 3)
    assert list(result.contact_forces[0]) == floor["force_n"]
    assert result.relative_residual == summary["relative_residual"]
    assert result.solver.startswith("newton")


@pytest.mark.parametrize("model,mu,fx", [("linear", 0.0, 0.0), ("corotational", 0.0, 0.0), ("linear", 0.5, 0.05)])
def test_static_contact_forces_and_reactions_balance_the_load(model, mu, fx):
    mesh, loads, result = floor_case(model, mu, fx)
    # The tip reaches the floor (the free beam would sag past it) but does not enter it: no
    # node of the beam's underside (z = 0) goes below the floor at z = −0.005. (Nodes above
    # it may: the static solve's contact is exact, the underside on the floor, and the tip's
    # cross-section squashed and turned under the floor's push.)
    bottom = np.asarray(mesh.nodes_on_plane("z", 0.0))
    assert result.displacement[bottom, 2].min() > -0.005
    assert result.displacement[:, 2].min() < -0.004
    # Supports push with R, the floor with −F_c (F_c the force on it): R + f − F_c = 0 up to
    # Newton's residual (1e-10 of the 1 N load, times √n_f, plus round-off): 1e-7 N.
    balance = result.reactions.sum(axis=0) + loads.resultant - result.contact_forces.sum(axis=0)
    assert np.abs(balance).max() < 1e-7, balance
    # The floor carries part of the load: a push down on it.
    assert result.contact_forces[0, 2] < -0.05
    if mu > 0.0:
        # Friction takes part of the sideways pull, within Coulomb's cone |F_t| ≤ μ·|F_n|.
        assert 0.0 < result.contact_forces[0, 0] <= mu * abs(result.contact_forces[0, 2]) * (1 + 1e-9)


def test_obstacle_distances_are_the_analytic_ones():
    sphere = tetfem.Obstacle.sphere("ball", (1.0, 0.0, 0.0), 0.5, friction=0.2)
    assert sphere.name == "ball" and sphere.friction == 0.2
    assert sphere.distance((3.0, 0.0, 0.0)) == pytest.approx(1.5, rel=1e-15)  # |x − c| − r
    floor = tetfem.Obstacle.half_space("floor", (0.0, 0.0, -1.0), (0.0, 0.0, 2.0))
    assert floor.distance((5.0, 7.0, 0.5)) == pytest.approx(1.5, rel=1e-15)  # (x − p)·n̂
    block = tetfem.Obstacle.box("block", (0.0, 0.0, 0.0), (1.0, 1.0, 1.0))
    assert block.distance((0.5, 0.5, 3.0)) == pytest.approx(2.0, rel=1e-15)
    assert block.distance((0.5, 0.5, 0.75)) == pytest.approx(-0.25, rel=1e-15)  # inside: < 0


def test_bad_obstacles_raise_naming_the_obstacle():
    with pytest.raises(tetfem.InvalidInputError, match="ball"):
        tetfem.Obstacle.sphere("ball", (0.0, 0.0, 0.0), -1.0)
    with pytest.raises(tetfem.InvalidInputError, match="friction"):
        tetfem.Obstacle.half_space("floor", (0.0, 0.0, 0.0), (0.0, 0.0, 1.0), friction=-0.1)


def test_a_body_inside_an_obstacle_is_refused():
    mesh = tetfem.Mesh.box(max=(1.0, 0.1, 0.1), cells=(4, 1, 1))
    steel = tetfem.Material.steel()
    constraints = tetfem.Constraints(mesh).fix(mesh.nodes_on_plane("x", 0.0))
    loads = tetfem.Loads(mesh)
    inside = tetfem.Obstacle.sphere("ball", (0.5, 0.05, 0.05), 0.2)
    with pytest.raises(tetfem.TetfemError, match="ball"):
        tetfem.solve_static(mesh, steel, constraints, loads, obstacles=[inside])


def test_estimate_error_equals_the_scene_summary():
    mesh = tetfem.Mesh.box(max=(1.0, 0.1, 0.1), cells=(40, 4, 4))
    steel = tetfem.Material(200e9, 0.3, 7850.0)
    constraints = tetfem.Constraints(mesh).fix(mesh.nodes_on_plane("x", 0.0))
    loads = tetfem.Loads(mesh)
    loads.add_total_force(mesh.faces_on_plane("x", 1.0), (0.0, 0.0, -10e3))
    loads.add_gravity((0.0, 0.0, -9.81), steel)
    result = tetfem.solve_static(mesh, steel, constraints, loads)
    estimate = tetfem.estimate_error(mesh, steel, result.displacement)
    summary = tetfem.run_scene(SCENES / "cantilever_static.toml", write_files=False)
    # The same displacement (bit-equal, test_static_matches_rust) and the same function.
    assert estimate["relative"] == summary["estimated_error"]["relative"]
    assert estimate["eta"] == summary["estimated_error"]["eta"]
    assert estimate["indicators"].shape == (mesh.tet_count,)
    assert estimate["eta"] == pytest.approx(math.sqrt((estimate["indicators"] ** 2).sum()), rel=1e-12)


def test_estimate_error_of_a_linear_field_is_zero():
    """P1 reproduces a linear displacement exactly and the recovered stress equals the constant
    element stress: η = 0 up to round-off."""
    mesh = tetfem.Mesh.box(max=(1.0, 1.0, 1.0), cells=(3, 3, 3))
    u = 1e-3 * mesh.points @ np.array([[1.0, 0.2, 0.0], [0.0, -0.3, 0.1], [0.0, 0.0, 0.5]])
    estimate = tetfem.estimate_error(mesh, tetfem.Material.steel(), u)
    # Round-off of a patch fit on O(1e8 Pa) stresses: 1e-9 relative.
    assert estimate["relative"] < 1e-9
    with pytest.raises(tetfem.InvalidInputError, match="displacement"):
        tetfem.estimate_error(mesh, tetfem.Material.steel(), u[:-1])


def test_model_advice_reads_a_rigid_rotation():
    mesh = tetfem.Mesh.box(max=(1.0, 1.0, 1.0), cells=(2, 2, 2))
    theta = math.radians(30.0)
    rotation = np.array([[math.cos(theta), -math.sin(theta), 0.0], [math.sin(theta), math.cos(theta), 0.0], [0, 0, 1]])
    u = mesh.points @ rotation.T - mesh.points
    advice = tetfem.model_advice(mesh, u)
    # A rigid rotation by 30°: every tet turns by 30° and stretches by nothing (round-off of
    # the polar decomposition: 1e-9).
    assert advice["max_rotation_deg"] == pytest.approx(30.0, abs=1e-9)
    assert advice["max_strain"] < 1e-9
    assert advice["suggested_model"] == "corotational"
    assert "corotational" in advice["warning"]
    small = tetfem.model_advice(mesh, 1e-6 * u)
    assert small["suggested_model"] is None and small["warning"] is None


def swinging_beam(method, model):
    """A clamped beam under gravity and a tip load, started from rest."""
    mesh = tetfem.Mesh.box(max=(1.0, 0.1, 0.1), cells=(8, 2, 2))
    material = tetfem.Material(1e7, 0.3, 1000.0)
    constraints = tetfem.Constraints(mesh).fix(mesh.nodes_on_plane("x", 0.0))
    loads = tetfem.Loads(mesh).add_gravity((0.0, 0.0, -9.81), material)
    loads.add_total_force(mesh.faces_on_plane("x", 1.0), (0.0, 5.0, 0.0))
    dt = "0.5crit" if method == "explicit" else 2e-3  # explicit: below its stability limit
    return tetfem.Simulation(mesh, material, constraints, loads, dt=dt, method=method, model=model)


@pytest.mark.parametrize(
    "method,model",
    [("newmark", "linear"), ("backward-euler", "corotational"), ("explicit", "linear"), ("newmark", "neo-hookean")],
)
def test_restored_run_equals_an_uninterrupted_one_bit_for_bit(tmp_path, method, model):
    straight = swinging_beam(method, model)
    straight.run(10)
    first = swinging_beam(method, model)
    first.run(4)
    first.checkpoint(tmp_path / "run.ckpt")
    first.run(3)  # moves on: the restore must bring back step 4, not keep this state
    resumed = swinging_beam(method, model)
    resumed.restore(tmp_path / "run.ckpt")
    assert resumed.steps == 4
    resumed.run(6)
    # Bit for bit: the same steps from the same state and history.
    assert resumed.steps == straight.steps and resumed.time == straight.time
    assert np.array_equal(resumed.displacement, straight.displacement)
    assert np.array_equal(resumed.velocity, straight.velocity)
    assert np.abs(straight.displacement).max() > 0.0  # it moved


def test_restore_refuses_another_simulation(tmp_path):
    newmark = swinging_beam("newmark", "linear")
    newmark.run(2)
    newmark.checkpoint(tmp_path / "run.ckpt")
    with pytest.raises(tetfem.InvalidInputError, match="method"):
        swinging_beam("backward-euler", "linear").restore(tmp_path / "run.ckpt")
    with pytest.raises(tetfem.InvalidInputError, match="model"):
        swinging_beam("newmark", "corotational").restore(tmp_path / "run.ckpt")
    (tmp_path / "bad.ckpt").write_bytes(b"not a checkpoint")
    with pytest.raises(tetfem.TetfemError):
        newmark.restore(tmp_path / "bad.ckpt")


def test_estimate_error_of_a_nonlinear_model_equals_the_scene_summary():
    # rubber_cantilever_large.toml: a corotational beam whose tip turns ~43°; its summary's
    # estimate is of the model's own run (second Piola–Kirchhoff stress).
    summary = tetfem.run_scene(SCENES / "rubber_cantilever_large.toml", write_files=False)
    assert "Piola" in summary["estimated_error"]["definition"]
    # The same beam, supports, load and Newton from Python.
    mesh = tetfem.Mesh.box(max=(0.5, 0.05, 0.05), cells=(20, 2, 2), split="five")
    rubber = tetfem.Material(5e6, 0.45, 1100.0)
    constraints = tetfem.Constraints(mesh).fix(mesh.nodes_on_plane("x", 0.0))
    loads = tetfem.Loads(mesh)
    loads.add_total_force(mesh.faces_on_plane("x", 0.5), (0.0, 0.0, -30.0))
    result = tetfem.solve_static(mesh, rubber, constraints, loads, model="corotational")
    estimate = tetfem.estimate_error(mesh, rubber, result.displacement, model="corotational")
    # Both Newton runs stop at 1e-10 of the load, and the estimate is smooth in u: 1e-7.
    assert estimate["relative"] == pytest.approx(summary["estimated_error"]["relative"], rel=1e-7)
    # The small-strain estimate of the same displacement is another number: the beam turns.
    small = tetfem.estimate_error(mesh, rubber, result.displacement)
    assert abs(small["relative"] - estimate["relative"]) > 1e-3
