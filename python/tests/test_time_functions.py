"""Time functions as native calls (issue 34, item 5): amplitudes on loads (``Loads.add_*(...,
amplitude=...)``), moving supports (``Constraints.prescribe(..., amplitude=...)``,
``prescribe_linear(..., amplitude=...)``, ``prescribe_rigid``), in static solves (taken at the
pseudo-time t = 1) and in ``Simulation`` (the library's ``TimeData``), and obstacles on 10-node
meshes.

Each test checks against something that could be false: linearity of the static solve, a rigid
motion's zero strain, the scene runner's run of the same scene, equilibrium and the barrier's
promise of no penetration.
"""

import csv

import numpy as np
import pytest

import tetfem
from conftest import probe_mean


def beam(cells=(10, 2, 2), order=1):
    mesh = tetfem.Mesh.box(max=(1.0, 0.1, 0.1), cells=cells, order=order)
    steel = tetfem.Material(200e9, 0.3, 7850.0)
    constraints = tetfem.Constraints(mesh).fix(mesh.nodes_on_plane("x", 0.0))
    return mesh, steel, constraints


def test_amplitude_kinds_evaluate_as_the_library():
    ramp = tetfem.Amplitude.ramp(0.0, 2.0)
    assert ramp.value(1.0) == 0.5 and ramp.rate(1.0) == 0.5 and ramp.value(3.0) == 1.0
    assert ramp.value(np.array([-1.0, 0.5, 2.0])).tolist() == [0.0, 0.25, 1.0]
    table = tetfem.Amplitude.table([[0.0, 0.0], [1.0, 0.3], [2.0, 1.0]])
    assert table.value(1.0) == 0.3 and table.value(1.5) == pytest.approx(0.65, rel=1e-15)
    assert tetfem.Amplitude.table([0.0, 1.0], [2.0, 4.0]).value(0.5) == 3.0
    sine = tetfem.Amplitude.sine(2.0, 0.25)
    # 2·sin(2π·0.25·1) = 2 (to the rounding of π/2).
    assert sine.value(1.0) == pytest.approx(2.0, rel=1e-15)
    step = tetfem.Amplitude.smooth_step(0.0, 1.0)
    assert step.value(0.5) == 0.5 and step.rate(0.0) == 0.0 and step.acceleration(1.0) == 0.0
    assert tetfem.Amplitude.constant(3.0).is_constant and not ramp.is_constant
    assert tetfem.STATIC_TIME == 1.0
    with pytest.raises(tetfem.InvalidInputError, match="strictly increase"):
        tetfem.Amplitude.table([[0.0, 0.0], [0.0, 1.0]])
    with pytest.raises(tetfem.InvalidInputError, match="end"):
        tetfem.Amplitude.ramp(1.0, 1.0)


@pytest.mark.parametrize(
    "amplitude,factor",
    [
        (tetfem.Amplitude.ramp(0.0, 2.0), 0.5),
        (np.array([[0.0, 0.0], [1.0, 0.3], [2.0, 1.0]]), 0.3),  # a table as an array
        (-1.5, -1.5),  # a constant
    ],
)
def test_ramped_static_load_is_the_constant_one_times_its_value_at_t1(amplitude, factor):
    mesh, steel, constraints = beam()
    tip = mesh.faces_on_plane("x", 1.0)
    constant = tetfem.Loads(mesh).add_total_force(tip, (0.0, 0.0, -1e4))
    ramped = tetfem.Loads(mesh).add_total_force(tip, (0.0, 0.0, -1e4), amplitude=amplitude)
    np.testing.assert_array_equal(ramped.forces, factor * constant.forces)
    u1 = tetfem.solve_static(mesh, steel, constraints, constant, linear_solver="direct").displacement
    ua = tetfem.solve_static(mesh, steel, constraints, ramped, linear_solver="direct").displacement
    # Linear: u(a·f) = a·u(f); the two solves differ by the factorization's rounding of a
    # scaled right-hand side (κ·ε ≈ 1e-13 here, far under a wrong factor's 1).
    assert np.abs(ua - factor * u1).max() <= 1e-12 * np.abs(factor * u1).max()


def test_gravity_with_an_amplitude_is_a_load_not_the_tracked_gravity():
    mesh, steel, constraints = beam()
    plain = tetfem.Loads(mesh).add_gravity((0.0, 0.0, -9.81), steel)
    ramped = tetfem.Loads(mesh).add_gravity((0.0, 0.0, -9.81), steel, amplitude=tetfem.Amplitude.ramp(0.0, 4.0))
    np.testing.assert_array_equal(ramped.forces, 0.25 * plain.forces)
    assert plain.gravity.tolist() == [0.0, 0.0, -9.81] and ramped.gravity.tolist() == [0.0, 0.0, 0.0]


def test_support_translated_by_an_amplitude_moves_the_body_rigidly():
    mesh = tetfem.Mesh.box(max=(1.0, 0.1, 0.1), cells=(10, 2, 2))
    steel = tetfem.Material(200e9, 0.3, 7850.0)
    d = np.array([1e-3, -2e-3, 5e-4])
    constraints = tetfem.Constraints(mesh).prescribe(
        mesh.nodes_on_plane("x", 0.0), d, amplitude=tetfem.Amplitude.ramp(0.0, 2.0)
    )
    result = tetfem.solve_static(mesh, steel, constraints, tetfem.Loads(mesh), linear_solver="direct")
    # Nothing but the support acts: every node follows it by d·a(1) = d/2, no strain, up to
    # the solve's rounding κ(K_ff)·ε ≈ 1e-12 of |d| (a missed amplitude is off by d/2 itself).
    assert np.abs(result.displacement - 0.5 * d).max() < 1e-10 * np.abs(d).max()
    # What a strain of |d|/L would give, E·|d|/L = 4e8 Pa and E·A·|d|/L = 4e6 N: stress and
    # reactions are 1e-8 of them at most (the rounding above, differentiated over h = 0.05).
    assert result.von_mises.max() < 1e-8 * 4e8
    assert np.abs(result.reactions).max() < 1e-8 * 4e6


def rotation(axis, angle):
    k = np.asarray(axis, float) / np.linalg.norm(axis)
    kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(angle) * kx + (1 - np.cos(angle)) * kx @ kx


def test_rigid_rotation_of_the_only_support_turns_the_body_without_strain():
    mesh = tetfem.Mesh.box(max=(1.0, 0.1, 0.1), cells=(8, 2, 2))
    rubber = tetfem.Material(5e6, 0.45, 1100.0)
    angle = 0.6  # rad
    point = np.array([0.0, 0.05, 0.05])
    constraints = tetfem.Constraints(mesh).prescribe_rigid(
        mesh.nodes_on_plane("x", 0.0), axis=(0.0, 1.0, 1.0), point=point, angle=angle,
        translation=(0.01, 0.0, 0.0), amplitude=tetfem.Amplitude.smooth_step(0.0, 1.0),
    )
    result = tetfem.solve_static(mesh, rubber, constraints, tetfem.Loads(mesh), model="corotational")
    exact = (mesh.points - point) @ rotation((0.0, 1.0, 1.0), angle).T + point + (0.01, 0, 0) - mesh.points
    error = np.abs(result.displacement - exact).max()
    print(f"rigid rotation: max nodal error {error:.2e} m, max von Mises {result.von_mises.max():.2e} Pa")
    # The corotational model has no strain under a rigid rotation: Newton converges to it
    # (residual 1e-10 of the loadless reference); a linear model would leave ~0.1 m errors.
    assert error < 1e-8
    assert result.von_mises.max() < 1e-3 * rubber.youngs_modulus * 1e-6
    with pytest.raises(tetfem.InvalidInputError, match="axis"):
        tetfem.Constraints(mesh).prescribe_rigid([0], axis=(0.0, 0.0, 0.0), angle=1.0)


def test_prescribe_linear_with_amplitude_is_the_constant_field_times_a1():
    mesh = tetfem.Mesh.box(max=(1.0, 1.0, 1.0), cells=(3, 3, 3), split="five")
    material = tetfem.Material(1e9, 0.3, 1000.0)
    gradient = np.array([[1e-3, 2e-4, 0.0], [0.0, -2e-3, 1e-4], [1e-4, 0.0, 4e-4]])
    points = mesh.points
    boundary = mesh.nodes_where(np.any((points < 1e-12) | (points > 1 - 1e-12), axis=1))
    table = np.array([[0.0, 0.0], [1.0, 0.25]])
    c = tetfem.Constraints(mesh).prescribe_linear(boundary, gradient, amplitude=table)
    u = tetfem.solve_static(mesh, material, c, tetfem.Loads(mesh), linear_solver="direct").displacement
    # The patch test at a quarter of the field: exact up to the solve's rounding.
    assert np.abs(u - 0.25 * points @ gradient.T).max() < 1e-12 * np.abs(points @ gradient.T).max()


def test_nonlinear_reactions_with_a_moving_support_balance():
    mesh, steel, _ = beam()
    rubber = tetfem.Material(5e6, 0.45, 1100.0)
    c = tetfem.Constraints(mesh).fix(mesh.nodes_on_plane("x", 0.0))
    c.prescribe(mesh.nodes_on_plane("x", 1.0), (0.0, 0.0, -0.05), amplitude=tetfem.Amplitude.ramp(0.0, 1.0))
    for model in ["linear", "corotational", "neo-hookean"]:
        result = tetfem.solve_static(mesh, rubber, c, tetfem.Loads(mesh), model=model)
        r = result.reactions
        assert r.shape == (mesh.node_count, 3)
        # No load: the two supports' reactions cancel (to Newton's residual, 1e-10 of them).
        total = r.sum(axis=0)
        assert np.abs(total).max() < 1e-8 * np.abs(r).max(), model
        # The support's force on the body (K·u − f) pushes the moved end down, along its motion.
        assert r[mesh.nodes_on_plane("x", 1.0), 2].sum() < 0.0, model


AMPLITUDE_SCENE = """
title = "cantilever under a ramped tip load on a shaken base"
[mesh]
order = {order}
[mesh.box]
max = [1.0, 0.1, 0.1]
cells = [10, 2, 2]
[material]
youngs_modulus = 200e9
poisson_ratio = 0.3
density = 7850.0
[[amplitudes]]
name = "shake"
sine = {{ amplitude = 1.0, frequency_hz = 50.0 }}
[[constraints]]
where = {{ plane = {{ axis = "x", at = 0.0 }} }}
displacement = [0.0, 0.0, 1e-4]
amplitude = "shake"
[[loads]]
where = {{ plane = {{ axis = "x", at = 1.0 }} }}
total_force = [0.0, -500.0, -1000.0]
amplitude = {{ table = [[0.0, 0.0], [0.004, 1.0], [0.006, 0.5]] }}
[[loads]]
gravity = [0.0, 0.0, -9.81]
amplitude = {{ ramp = {{ start = 0.0, end = 0.01 }} }}
[[probes]]
name = "tip"
where = {{ plane = {{ axis = "x", at = 1.0 }} }}
[analysis]
type = "dynamic"
method = "{method}"
model = "{model}"
dt = 2e-4
duration = 0.01
"""


@pytest.mark.parametrize(
    "method,model,order",
    [("newmark", "linear", 1), ("backward_euler", "corotational", 1), ("newmark", "linear", 2)],
)
def test_amplitudes_in_simulation_equal_the_scene_runner(tmp_path, method, model, order):
    scene = tmp_path / "shaken.toml"
    scene.write_text(AMPLITUDE_SCENE.format(method=method, model=model, order=order))
    summary = tetfem.run_scene(scene, output_dir=tmp_path / "out")
    with open(tmp_path / "out" / "shaken.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    steps = summary["steps"]
    assert steps == 50 and len(rows) == steps + 1

    mesh, steel, _ = beam(order=order)
    base = mesh.nodes_on_plane("x", 0.0)
    constraints = tetfem.Constraints(mesh).prescribe(
        base, (0.0, 0.0, 1e-4), amplitude=tetfem.Amplitude.sine(1.0, 50.0)
    )
    tip_faces = mesh.faces_on_plane("x", 1.0)
    loads = tetfem.Loads(mesh).add_total_force(
        tip_faces, (0.0, -500.0, -1000.0), amplitude=[[0.0, 0.0], [0.004, 1.0], [0.006, 0.5]]
    )
    loads.add_gravity((0.0, 0.0, -9.81), steel, amplitude=tetfem.Amplitude.ramp(0.0, 0.01))
    sim = tetfem.Simulation(
        mesh, steel, constraints, loads, dt=2e-4, method=method.replace("_", "-"), model=model
    )
    tip = mesh.nodes_on_plane("x", 1.0)
    trajectory, bases, reactions = [], [], []

    def record(s):
        u = s.displacement
        trajectory.append(probe_mean(u, tip))
        bases.append(u[base, 2].copy())
        reactions.append(s.reactions().sum(axis=0))

    history = sim.run(steps, callback=record)
    scene_tip = np.array([[float(r[f"tip_u{a}_m"]) for a in "xyz"] for r in rows[1:]])
    ours = np.array(trajectory)
    scale = np.abs(scene_tip).max()
    print(f"{method}/{model}/P{order}: tip max {scale:.3e} m, max difference {np.abs(ours - scene_tip).max():.1e} m")
    # The same library calls on the same data: equal to the CSV's printed digits (the CSV
    # writes 17 significant digits, so 1e-12 relative is far above its rounding).
    assert np.abs(ours - scene_tip).max() <= 1e-12 * scale
    kinetic = np.array([float(r["kinetic_J"]) for r in rows[1:]])
    assert np.abs(history["kinetic"] - kinetic).max() <= 1e-12 * np.abs(kinetic).max()
    # The shaken base's reaction (M·a + C·v − f_int − f_ext on its rows, the base moving at
    # u_c(t)): the scene's one support set. Summed by numpy here, in node order there: equal
    # to the sums' rounding, 1e-12 of the largest reaction.
    scene_r = np.array([[float(r[f"reaction0_F{a}_N"]) for a in "xyz"] for r in rows[1:]])
    assert np.abs(np.array(reactions) - scene_r).max() <= 1e-12 * np.abs(scene_r).max()
    assert np.abs(scene_r).max() > 1.0  # N: the base pushes the beam around
    # The loads and the base moved: a tip well away from rest, and the base at 1e-4·sin(2π·50·t).
    assert scale > 1e-5
    times = history["time"]
    for t, row in zip(times, bases):
        assert np.allclose(row, 1e-4 * np.sin(2 * np.pi * 50.0 * t), rtol=0, atol=1e-18)


def test_rigid_motion_in_simulation_moves_the_support_exactly():
    mesh = tetfem.Mesh.box(max=(1.0, 0.1, 0.1), cells=(6, 2, 2))
    rubber = tetfem.Material(5e6, 0.45, 1100.0)
    end = mesh.nodes_on_plane("x", 0.0)
    turn = tetfem.Amplitude.smooth_step(0.0, 0.05)
    constraints = tetfem.Constraints(mesh).prescribe_rigid(
        end, axis=(1.0, 0.0, 0.0), point=(0.0, 0.05, 0.05), angle=np.pi / 2, amplitude=turn
    )
    sim = tetfem.Simulation(mesh, rubber, constraints, dt=5e-3, method="backward-euler", model="corotational")
    sim.run(12)
    u = sim.displacement
    theta = np.pi / 2 * turn.value(sim.time)
    assert theta == pytest.approx(np.pi / 2, rel=1e-15)  # past the step's end
    exact = (mesh.points[end] - (0.0, 0.05, 0.05)) @ rotation((1.0, 0.0, 0.0), theta).T + (0.0, 0.05, 0.05) - mesh.points[end]
    assert np.abs(u[end] - exact).max() < 1e-15


def test_moving_dof_must_not_be_fixed_twice():
    mesh, _, _ = beam()
    c = tetfem.Constraints(mesh).fix(mesh.nodes_on_plane("x", 0.0))
    with pytest.raises(tetfem.InvalidInputError, match="node"):
        c.prescribe(mesh.nodes_on_plane("x", 0.0), (0.0, 0.0, 1e-3), amplitude=tetfem.Amplitude.ramp())
    # The refused call left the constraints as they were: the solve runs as before.
    assert c.count == 3 * len(mesh.nodes_on_plane("x", 0.0))


def test_p2_block_pressed_onto_the_ground_stays_out_and_balances():
    # 0.1 mm above the ground, within the barrier's reach d̂ (1e-3 of the diagonal, 0.3 mm):
    # the ground alone holds it in z, so it must touch from the first load step on.
    mesh = tetfem.Mesh.box(min=(0.0, 0.0, 1e-4), max=(0.2, 0.2, 0.1), cells=(2, 2, 2), order=2)
    soft = tetfem.Material(1e6, 0.3, 1000.0)
    # Symmetry planes hold it sideways (x and y, and the turn about z).
    constraints = tetfem.Constraints(mesh).fix(mesh.nodes_on_plane("x", 0.0), axes="x")
    constraints.fix(mesh.nodes_on_plane("y", 0.0), axes="y")
    load = np.array([0.0, 0.0, -200.0])
    loads = tetfem.Loads(mesh).add_total_force(mesh.faces_on_plane("z", 0.1), load)
    ground = tetfem.Obstacle.half_space("ground", (0.0, 0.0, 0.0), (0.0, 0.0, 1.0))
    result = tetfem.solve_static(mesh, soft, constraints, loads, obstacles=[ground])
    z = mesh.points[:, 2] + result.displacement[:, 2]
    print(f"P2 on ground: lowest node {z.min():.3e} m, contact force {result.contact_forces[0]}")
    # The barrier's promise, mid-edge nodes included: no node inside the ground.
    assert z.min() > 0.0
    # It rests on the ground: its lowest node within the barrier's reach d̂ = 1e-3 of the
    # bounding box's diagonal (the gap where the barrier's force is the load).
    (lo, hi) = mesh.bounding_box
    assert z.min() < 1e-3 * np.linalg.norm(hi - lo)
    # Equilibrium: reactions + load = force on the ground (Newton's residual, 1e-10 of it).
    balance = result.reactions.sum(axis=0) + load - result.contact_forces[0]
    assert np.abs(balance).max() < 1e-6 * np.abs(load).max()
    assert result.contact_forces[0][2] == pytest.approx(-200.0, rel=1e-6)


def test_p2_block_dropped_onto_the_ground_in_simulation():
    mesh = tetfem.Mesh.box(min=(0.0, 0.0, 0.02), max=(0.2, 0.2, 0.12), cells=(2, 2, 1), order=2)
    soft = tetfem.Material(1e5, 0.3, 1000.0)
    loads = tetfem.Loads(mesh).add_gravity((0.0, 0.0, -9.81), soft)
    ground = tetfem.Obstacle.half_space("ground", (0.0, 0.0, 0.0), (0.0, 0.0, 1.0), friction=0.3)
    sim = tetfem.Simulation(
        mesh, soft, tetfem.Constraints(mesh), loads, dt=0.01, method="backward-euler",
        obstacles=[ground],
    )
    lowest = []
    sim.run(30, callback=lambda s: lowest.append((mesh.points[:, 2] + s.displacement[:, 2]).min()))
    print(f"P2 drop: lowest point {min(lowest):.3e} m, final {lowest[-1]:.3e} m")
    # It fell the 2 cm (free fall: 0.064 s) onto the ground and rests there ...
    assert lowest[-1] < 0.001
    # ... and no node, corner or mid-edge, was ever inside the ground.
    assert min(lowest) > 0.0


MOVING_FLOOR_SCENE = """
title = "beam lowered by its clamp onto a floor"
[mesh.box]
max = [1.0, 0.1, 0.1]
cells = [10, 2, 2]
[material]
youngs_modulus = 1e6
poisson_ratio = 0.3
density = 1000.0
[[constraints]]
where = { plane = { axis = "x", at = 0.0 } }
displacement = [0.0, 0.0, -0.004]
amplitude = { ramp = { start = 0.0, end = 2.0 } }
[[loads]]
where = { plane = { axis = "x", at = 1.0 } }
total_force = [0.0, 0.0, -1.0]
[[probes]]
name = "tip"
where = { plane = { axis = "x", at = 1.0 } }
[analysis]
type = "static"
model = "corotational"
[[obstacles]]
kind = "half_space"
name = "floor"
point = [0.0, 0.0, -0.005]
normal = [0.0, 0.0, 1.0]
"""


def test_static_obstacles_with_a_moving_support_equal_the_scene_runner(tmp_path):
    # Obstacles together with a moving support: the library's static dispatch refuses the
    # pair, the scene runner solves it (Newton with the barrier, the motion through the load
    # steps); the native call solves it the same way, to the same bits.
    scene = tmp_path / "lowered.toml"
    scene.write_text(MOVING_FLOOR_SCENE)
    summary = tetfem.run_scene(scene, write_files=False)
    mesh = tetfem.Mesh.box(max=(1.0, 0.1, 0.1), cells=(10, 2, 2))
    soft = tetfem.Material(1e6, 0.3, 1000.0)
    clamp = mesh.nodes_on_plane("x", 0.0)
    constraints = tetfem.Constraints(mesh).prescribe(clamp, (0.0, 0.0, -0.004), amplitude=tetfem.Amplitude.ramp(0.0, 2.0))
    loads = tetfem.Loads(mesh).add_total_force(mesh.faces_on_plane("x", 1.0), (0.0, 0.0, -1.0))
    floor = tetfem.Obstacle.half_space("floor", (0.0, 0.0, -0.005), (0.0, 0.0, 1.0))
    result = tetfem.solve_static(mesh, soft, constraints, loads, model="corotational", obstacles=[floor])
    tip = probe_mean(result.displacement, mesh.nodes_on_plane("x", 1.0))
    assert tip == summary["probes"][0]["displacement"]
    # The clamp went down by 4 mm·a(1) = 2 mm exactly; the floor stopped the tip above -5 mm.
    assert np.all(result.displacement[clamp] == (0.0, 0.0, -0.002))
    z = mesh.points[:, 2] + result.displacement[:, 2]
    assert z.min() > -0.005 and tip[2] < -0.004
    balance = result.reactions.sum(axis=0) + loads.resultant - result.contact_forces.sum(axis=0)
    assert np.abs(balance).max() < 1e-7, balance  # Newton's residual, 1e-10 of the 1 N load
