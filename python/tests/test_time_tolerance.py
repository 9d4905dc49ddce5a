"""Error-controlled time stepping from Python: the scene key ``analysis.time_tolerance`` through
``tetfem.run_scene`` (the bindings run it as the command-line tool does), its summary's
``time_stepping`` (the run's own error estimate, accepted and rejected steps, smallest and largest
step), the frames landed on the multiples of ``every``·dt, and its refusal of the explicit method
as a ``SceneError`` naming the key."""

import pytest

import tetfem

# A cantilever 0.5 × 0.05 × 0.05 m (E = 10 MPa) released from rest under gravity: it swings with a
# period of about 0.3 s (the Rust tests tests/core/adaptive_time_step.rs and
# crates/cli/tests/time_tolerance.rs run the same beam and measure the estimate against the true
# error).
SWING = """
title = "swing"

[mesh.box]
max = [0.5, 0.05, 0.05]
cells = [10, 1, 1]
split = "mirrored6"

[material]
youngs_modulus = 1e7
poisson_ratio = 0.3
density = 1000.0

[[constraints]]
where = { plane = { axis = "x", at = 0.0 } }

[[loads]]
gravity = [0.0, 0.0, -9.81]

[analysis]
type = "dynamic"
method = "METHOD"
dt = 1e-3
duration = 0.1
time_tolerance = 1e-2

[output]
every = 10
"""


def write(tmp_path, method):
    path = tmp_path / "swing.toml"
    path.write_text(SWING.replace("METHOD", method))
    return path


def test_the_summary_reports_the_error_controlled_run(tmp_path):
    summary = tetfem.run_scene(write(tmp_path, "newmark"), output_dir=tmp_path / "out")
    stepping = summary["time_stepping"]
    assert stepping["tolerance"] == 1e-2
    # The run's own estimate stays within what it was asked for (the control adds up the
    # accepted steps' local errors to at most the tolerance).
    assert 0.0 < stepping["estimated_error"] <= 1e-2
    assert stepping["accepted_steps"] == summary["steps"]
    assert 0.0 < stepping["dt_min"] <= stepping["dt_max"] <= stepping["output_interval"]
    assert stepping["output_interval"] == pytest.approx(1e-2, rel=1e-15)
    assert summary["end_time"] == 0.1
    assert summary["units"]["time_stepping.dt_max"] == "s"
    # Frames at 0, 0.01, …, 0.1 s exactly: 11 of them.
    assert summary["frames"] == 11


def test_a_fixed_step_summary_has_no_time_stepping(tmp_path):
    text = SWING.replace("METHOD", "newmark").replace("time_tolerance = 1e-2\n", "")
    path = tmp_path / "fixed.toml"
    path.write_text(text)
    summary = tetfem.run_scene(path, write_files=False)
    assert "time_stepping" not in summary
    assert summary["steps"] == 100


def test_the_explicit_method_is_refused_naming_the_key(tmp_path):
    with pytest.raises(tetfem.SceneError, match="time_tolerance.*explicit"):
        tetfem.run_scene(write(tmp_path, "explicit"), write_files=False)


def swing_simulation(method="newmark"):
    """The beam of SWING through the Simulation API."""
    mesh = tetfem.Mesh.box(max=(0.5, 0.05, 0.05), cells=(10, 1, 1), split="mirrored6")
    material = tetfem.Material(1e7, 0.3, 1000.0)
    constraints = tetfem.Constraints(mesh).fix(mesh.nodes_on_plane("x", 0.0))
    loads = tetfem.Loads(mesh).add_gravity((0.0, 0.0, -9.81), material)
    return tetfem.Simulation(mesh, material, constraints, loads, dt=1e-3, method=method)


def test_simulation_run_adaptive_equals_the_scene_run(tmp_path):
    sim = swing_simulation()
    result = sim.run_adaptive(0.1, 1e-2, output_interval=1e-2)
    summary = tetfem.run_scene(write(tmp_path, "newmark"), write_files=False)
    stepping = summary["time_stepping"]
    # The same library run on the same beam: the same steps and the same estimate, bit for bit.
    assert result["accepted_steps"] == stepping["accepted_steps"]
    assert result["rejected_steps"] == stepping["rejected_steps"]
    assert result["estimated_error"] == stepping["estimated_error"]
    assert (result["dt_min"], result["dt_max"]) == (stepping["dt_min"], stepping["dt_max"])
    assert sim.time == 0.1 and sim.steps == result["accepted_steps"]
    assert len(result["time"]) == len(result["dt"]) == result["accepted_steps"]
    # Every output time is landed on exactly.
    landed = set(result["time"].tolist())
    assert all(k * 1e-2 in landed for k in range(1, 11))


def test_simulation_run_adaptive_refuses_the_explicit_method():
    sim = swing_simulation("explicit")
    with pytest.raises(tetfem.InvalidInputError, match="time_tolerance"):
        sim.run_adaptive(0.1, 1e-2)
