"""Obstacles with friction in ``Simulation`` (issue 34, item 5): the force law of the scene
runner's dynamic contact (every model, the linear one too, through the Newton step with the
barrier, ``NonlinearForce::with_contact``), compared with ``run_scene`` on the same scene bit for
bit, and the barrier's promise: no node ever inside the obstacle."""

import csv

import numpy as np
import pytest

import tetfem
from conftest import probe_mean

DROP_SCENE = """
title = "soft block dropped onto the ground, small"
[mesh.box]
min = [0.0, 0.0, 0.05]
max = [0.2, 0.2, 0.25]
cells = [3, 3, 3]
[material]
youngs_modulus = 1e5
poisson_ratio = 0.3
density = 1000.0
[[loads]]
gravity = [0.0, 0.0, -9.81]
[[probes]]
name = "bottom"
where = {{ plane = {{ axis = "z", at = 0.05 }} }}
[analysis]
type = "dynamic"
method = "{method}"
model = "{model}"
dt = 0.02
duration = 0.5
initial_velocity = [0.3, 0.0, 0.0]
[[obstacles]]
kind = "half_space"
name = "ground"
point = [0.0, 0.0, 0.0]
normal = [0.0, 0.0, 1.0]
friction = 0.5
"""


@pytest.mark.parametrize("method,model", [("backward_euler", "linear"), ("backward_euler", "neo-hookean")])
def test_dynamic_contact_equals_the_scene_runner(tmp_path, method, model):
    scene = tmp_path / "drop.toml"
    scene.write_text(DROP_SCENE.format(method=method, model=model))
    summary = tetfem.run_scene(scene, output_dir=tmp_path / "out")
    with open(tmp_path / "out" / "drop.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    steps = summary["steps"]
    assert steps == 25 and len(rows) == steps + 1

    mesh = tetfem.Mesh.box(max=(0.2, 0.2, 0.25), min=(0.0, 0.0, 0.05), cells=(3, 3, 3))
    soft = tetfem.Material(1e5, 0.3, 1000.0)
    loads = tetfem.Loads(mesh).add_gravity((0.0, 0.0, -9.81), soft)
    ground = tetfem.Obstacle.half_space("ground", (0.0, 0.0, 0.0), (0.0, 0.0, 1.0), friction=0.5)
    sim = tetfem.Simulation(
        mesh, soft, tetfem.Constraints(mesh), loads, dt=0.02, method=method.replace("_", "-"),
        model=model, initial_velocity=(0.3, 0.0, 0.0), obstacles=[ground],
    )
    bottom = mesh.nodes_on_plane("z", 0.05)
    trajectory, lowest = [], []
    def record(s):
        trajectory.append(probe_mean(s.displacement, bottom))
        lowest.append((mesh.points[:, 2] + s.displacement[:, 2]).min())
    history = sim.run(steps, callback=record)
    # The same force law and integrator from the same library calls: equal bits, every step.
    for axis, column in enumerate(["bottom_ux_m", "bottom_uy_m", "bottom_uz_m"]):
        assert [p[axis] for p in trajectory] == [float(r[column]) for r in rows[1:]], column
    assert history["kinetic"].tolist() == [float(r["kinetic_J"]) for r in rows[1:]]
    print(f"{model}: lowest point {min(lowest):.3e} m, final bottom {trajectory[-1]}")
    # The block fell the 5 cm onto the ground (free fall takes 0.1 s) and rests on it ...
    assert trajectory[-1][2] < -0.045
    # ... and the barrier kept every node outside the obstacle at every step.
    assert min(lowest) > 0.0
    # Friction slowed the 0.3 m/s slide: less than the frictionless 0.15 m in 0.5 s.
    assert 0.0 < trajectory[-1][0] < 0.15


LANDING_SCENE = """
[mesh.box]
min = [0.0, 0.0, 0.002]
max = [0.1, 0.1, 0.102]
cells = [2, 2, 2]
[material]
youngs_modulus = 1e5
poisson_ratio = 0.3
density = 1000.0
[[loads]]
gravity = [0.0, 0.0, -9.81]
[[probes]]
name = "bottom"
where = {{ plane = {{ axis = "z", at = 0.002 }} }}
[analysis]
type = "dynamic"
method = "backward_euler"
dt = 1e-3
duration = 0.04
[[obstacles]]
kind = "half_space"
name = "ground"
point = [0.0, 0.0, 0.0]
normal = [0.0, 0.0, 1.0]
[contact]
impact_fraction = {fraction}
"""


def test_contact_impact_fraction_equals_the_scene_key(tmp_path):
    """``contact_impact_fraction`` is the scenes' ``[contact] impact_fraction``: a block landing
    2 mm below gives the same bits step by step through the landing; a value outside (0, 1) is
    refused by the library's check, naming it."""
    scene = tmp_path / "landing.toml"
    scene.write_text(LANDING_SCENE.format(fraction=0.25))
    summary = tetfem.run_scene(scene, output_dir=tmp_path / "out")
    with open(tmp_path / "out" / "landing.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    mesh = tetfem.Mesh.box(max=(0.1, 0.1, 0.102), min=(0.0, 0.0, 0.002), cells=(2, 2, 2))
    rubber = tetfem.Material(1e5, 0.3, 1000.0)
    loads = tetfem.Loads(mesh).add_gravity((0.0, 0.0, -9.81), rubber)
    ground = tetfem.Obstacle.half_space("ground", (0.0, 0.0, 0.0), (0.0, 0.0, 1.0))
    def landing(**contact):
        sim = tetfem.Simulation(
            mesh, rubber, tetfem.Constraints(mesh), loads, dt=1e-3, obstacles=[ground], **contact
        )
        bottom = mesh.nodes_on_plane("z", 0.002)
        trajectory = []
        sim.run(summary["steps"], callback=lambda s: trajectory.append(probe_mean(s.displacement, bottom)))
        return trajectory
    aware = landing(contact_impact_fraction=0.25)
    assert [p[2] for p in aware] == [float(r["bottom_uz_m"]) for r in rows[1:]]
    # The option acts on this landing: without it the bottom moves otherwise.
    assert aware[-1] != landing()[-1]
    for bad in (0.0, 1.0, 1.5):
        with pytest.raises(tetfem.TetfemError, match="impact_fraction"):
            landing(contact_impact_fraction=bad)


def test_newton_settings_equal_the_scene_keys(tmp_path):
    """``nonlinear_solver``, ``newton_tolerance`` and ``relax_contact_nodes`` are the scenes'
    ``analysis`` keys of the same names: the drop with all three set gives the same bits step by
    step as ``run_scene``, and ``newton_stats`` its summary's Newton counts; each acts (the defaults move the bottom otherwise: ``"auto"``
    refactors a mesh this small, so ``"rest_preconditioned"`` is a choice that changes the
    path); values the library refuses raise ``InvalidInputError`` naming them."""
    keys = 'nonlinear_solver = "rest_preconditioned"\nnewton_tolerance = 1e-6\nrelax_contact_nodes = false\n'
    text = DROP_SCENE.format(method="backward_euler", model="neo-hookean").replace(
        "initial_velocity = [0.3, 0.0, 0.0]\n", "initial_velocity = [0.3, 0.0, 0.0]\n" + keys
    )
    scene = tmp_path / "drop.toml"
    scene.write_text(text)
    summary = tetfem.run_scene(scene, output_dir=tmp_path / "out")
    with open(tmp_path / "out" / "drop.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    mesh = tetfem.Mesh.box(max=(0.2, 0.2, 0.25), min=(0.0, 0.0, 0.05), cells=(3, 3, 3))
    soft = tetfem.Material(1e5, 0.3, 1000.0)
    loads = tetfem.Loads(mesh).add_gravity((0.0, 0.0, -9.81), soft)
    ground = tetfem.Obstacle.half_space("ground", (0.0, 0.0, 0.0), (0.0, 0.0, 1.0), friction=0.5)
    bottom = mesh.nodes_on_plane("z", 0.05)

    def drop(**settings):
        sim = tetfem.Simulation(
            mesh, soft, tetfem.Constraints(mesh), loads, dt=0.02, model="neo-hookean",
            initial_velocity=(0.3, 0.0, 0.0), obstacles=[ground], **settings,
        )
        trajectory, counts = [], []
        def record(s):
            trajectory.append(probe_mean(s.displacement, bottom))
            counts.append(s.newton_stats["total_iterations"])
        sim.run(summary["steps"], callback=record)
        return trajectory, counts, sim.newton_stats

    settings = dict(nonlinear_solver="rest_preconditioned", newton_tolerance=1e-6, relax_contact_nodes=False)
    chosen, counts, stats = drop(**settings)
    assert [p[0] for p in chosen] == [float(r["bottom_ux_m"]) for r in rows[1:]]
    assert [p[2] for p in chosen] == [float(r["bottom_uz_m"]) for r in rows[1:]]
    # The counts are the scene runner's, read in the callback step by step as after the run.
    assert stats == summary["newton"]
    assert counts[-1] == stats["total_iterations"] and counts == sorted(counts)
    assert stats["steps"] == summary["steps"] and stats["cg_iterations"] > 0
    for name, default in [("nonlinear_solver", "auto"), ("newton_tolerance", None), ("relax_contact_nodes", True)]:
        assert drop(**{**settings, name: default})[0][-1] != chosen[-1], name
    # Without Newton (the linear model, no obstacle: the block clamped at its base) no counts.
    clamped = tetfem.Constraints(mesh).fix(mesh.nodes_on_plane("z", 0.05))
    linear = tetfem.Simulation(mesh, soft, clamped, loads, dt=0.02)
    linear.step()
    assert linear.newton_stats is None
    for name, bad in [("nonlinear_solver", "newton"), ("newton_tolerance", 1.5), ("newton_tolerance", 0.0)]:
        with pytest.raises(tetfem.InvalidInputError, match=name.split("_")[-1]):
            drop(**{name: bad})
