"""Time integration through the Python API: the energy history equals the Rust scene runner's
CSV, every method and model runs, energy is conserved where the method conserves it, and a
run past the explicit stability limit raises DivergedError."""

import csv
import threading

import numpy as np
import pytest

import tetfem
from conftest import SCENES, dense, probe_mean


def cantilever_dynamic(method="backward-euler"):
    """scenes/cantilever_dynamic.toml through the Python API: at rest, end load applied."""
    mesh = tetfem.Mesh.box(max=(1.0, 0.1, 0.1), cells=(20, 2, 2), split="mirrored6")
    steel = tetfem.Material(200e9, 0.3, 7850.0)
    constraints = tetfem.Constraints(mesh).fix(mesh.nodes_on_plane("x", 0.0))
    loads = tetfem.Loads(mesh).add_total_force(mesh.faces_on_plane("x", 1.0), (0.0, 0.0, -10e3))
    sim = tetfem.Simulation(mesh, steel, constraints, loads, dt=1e-4, method=method)
    return mesh, sim


def test_energy_history_equals_the_scene_csv_bit_for_bit(tmp_path):
    summary = tetfem.run_scene(SCENES / "cantilever_dynamic.toml", output_dir=tmp_path)
    with open(tmp_path / "cantilever_dynamic.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    steps = summary["steps"]
    assert steps == 300 and len(rows) == steps + 1  # the initial state, then one row per step

    mesh, sim = cantilever_dynamic()
    tip = mesh.nodes_on_plane("x", 1.0)
    tip_z = []
    start = sim.energy()
    history = sim.run(steps, callback=lambda s: tip_z.append(probe_mean(s.displacement, tip)[2]))

    terms = ["kinetic", "elastic", "gravity_potential", "load_potential", "total"]
    # The CSV holds each value in Rust's shortest round-trip form ({:e}), so float() gives the
    # exact f64 back and equality is bit for bit.
    # CSV columns carry their unit: energies `<term>_J`, probes `<probe>_u<axis>_m`, `time_s`.
    for term in terms:
        assert start[term] == float(rows[0][term + "_J"]), term
        assert history[term].tolist() == [float(r[term + "_J"]) for r in rows[1:]], term
    # The CSV's time is n·dt exactly; the Simulation's is the integrator's running sum t += dt,
    # which drifts by a few ulps over 300 steps (1e-12 relative is far above that, far below dt).
    assert [float(r["time_s"]) for r in rows] == [n * summary["dt"] for n in range(steps + 1)]
    assert history["time"].tolist() == pytest.approx([float(r["time_s"]) for r in rows[1:]], rel=1e-12)
    assert tip_z == [float(r["tip_uz_m"]) for r in rows[1:]]
    assert summary["final_energy"]["total"] == history["total"][-1]
    # The run did something: the beam swings down by about twice the static sag (~1.5 mm).
    assert min(tip_z) < -1e-3


@pytest.mark.parametrize("method", ["backward-euler", "newmark", "explicit"])
@pytest.mark.parametrize("model", ["linear", "corotational", "neo-hookean", "st-venant-kirchhoff"])
def test_every_method_and_model_runs(method, model):
    mesh = tetfem.Mesh.box(max=(1.0, 0.1, 0.1), cells=(8, 2, 2))
    steel = tetfem.Material.steel()
    constraints = tetfem.Constraints(mesh).fix(mesh.nodes_on_plane("x", 0.0))
    loads = tetfem.Loads(mesh).add_gravity((0, 0, -9.81), steel)
    dt = "0.5crit" if method == "explicit" else "20crit"
    sim = tetfem.Simulation(mesh, steel, constraints, loads, dt=dt, method=method, model=model)
    assert sim.method == method and sim.model == model
    history = sim.run(20)
    assert len(history["total"]) == 20 and sim.steps == 20
    assert np.isfinite(history["total"]).all()
    # Gravity pulls the beam down from rest: its potential becomes negative.
    assert history["gravity_potential"][-1] < 0.0
    assert sim.displacement[:, 2].min() < 0.0


# Tolerances: Newmark's average acceleration conserves the discrete energy of a linear
# undamped system exactly, so only the solves' rounding remains (measured 4.5e-12 over 300
# steps; 1e-9 leaves margin). The explicit method's energy (u at whole, v at staggered steps)
# oscillates by O((ω·dt)²) of the highest modes at 0.9× the critical step: measured 2.0e-3 on
# this 20×2×2 mesh (`docs/src/getting-started.md`: coarse meshes can miss 1e-3), so 5e-3 bounds it without
# hiding a growth (a diverging run grows without bound).
@pytest.mark.parametrize("method,tolerance", [("newmark", 1e-9), ("explicit", 5e-3)])
def test_energy_conserving_methods_keep_the_total(method, tolerance):
    """Released from its loaded static shape with the load removed, an undamped beam keeps its
    energy with Newmark (exactly conserving for linear systems, up to the solves' rounding) and
    with the explicit method below its critical step (a bounded oscillation of the discrete
    energy, O(dt²))."""
    mesh = tetfem.Mesh.box(max=(1.0, 0.1, 0.1), cells=(20, 2, 2))
    steel = tetfem.Material.steel()
    constraints = tetfem.Constraints(mesh).fix(mesh.nodes_on_plane("x", 0.0))
    loads = tetfem.Loads(mesh).add_total_force(mesh.faces_on_plane("x", 1.0), (0, 0, -1e4))
    bent = tetfem.solve_static(mesh, steel, constraints, loads).displacement
    dt = "0.9crit" if method == "explicit" else 1e-4
    sim = tetfem.Simulation(mesh, steel, constraints, dt=dt, method=method, initial_displacement=bent)
    start = sim.energy()["total"]
    history = sim.run(300)
    drift = np.abs(history["total"] - start).max() / start
    print(f"{method}: max relative energy drift over 300 steps = {drift:.2e}")
    assert drift < tolerance
    # ... and the beam does swing: kinetic energy takes a large share at some step.
    assert history["kinetic"].max() > 0.5 * start


def test_backward_euler_dissipates():
    mesh, sim = cantilever_dynamic("backward-euler")
    history = sim.run(300)
    # Backward Euler damps the swing: the kinetic energy of the last period is far below the
    # first's (numerical dissipation at 22× the critical step).
    assert history["kinetic"][-100:].max() < 0.5 * history["kinetic"][:100].max()


def test_explicit_past_the_critical_step_raises_diverged():
    mesh, _ = cantilever_dynamic()
    steel = tetfem.Material.steel()
    constraints = tetfem.Constraints(mesh).fix(mesh.nodes_on_plane("x", 0.0))
    loads = tetfem.Loads(mesh).add_total_force(mesh.faces_on_plane("x", 1.0), (0, 0, -1e4))
    sim = tetfem.Simulation(mesh, steel, constraints, loads, dt="2crit", method="explicit")
    with pytest.raises(tetfem.DivergedError, match="diverged") as raised:
        sim.run(100000)
    # The library's error names the remedy (the explicit method's, not a front end's hint).
    assert "a dt below the critical step (e.g. 0.9 of it) or an implicit method" in str(raised.value)


def test_callback_returning_false_stops_the_run():
    _, sim = cantilever_dynamic()
    history = sim.run(50, callback=lambda s: s.steps < 7)
    assert sim.steps == 7 and len(history["time"]) == 7
    assert history["time"][-1] == sim.time


def test_run_is_the_library_loop_and_its_callback_sees_each_step_state():
    """The callback is called after step k with step k's state (the library's loop holds the
    Simulation meanwhile, so reads come from what it saw): steps k, time k·dt, the energy row
    the run returns for that step; the run stopped by False leaves the Simulation at the last
    state the callback saw. Changing the Simulation inside the callback is refused."""
    _, sim = cantilever_dynamic()
    dt = sim.dt
    seen = []

    def watch(s):
        seen.append((s.steps, s.time, s.displacement.copy(), s.energy()["total"]))
        return s.steps < 5

    history = sim.run(20, callback=watch)
    assert [k for k, *_ in seen] == [1, 2, 3, 4, 5]
    assert history["step"].tolist() == [1, 2, 3, 4, 5]
    # time is k additions of dt: equal to k·dt up to k round-offs.
    for k, t, *_ in seen:
        assert t == pytest.approx(k * dt, rel=1e-14)
    # The returned rows are the steps the callback saw, bit for bit.
    assert history["time"].tolist() == [t for _, t, *_ in seen]
    assert history["total"].tolist() == [e for *_, e in seen]
    # The state moves step to step, and the Simulation is left at the last one seen.
    assert not np.array_equal(seen[0][2], seen[-1][2])
    assert np.array_equal(sim.displacement, seen[-1][2]) and sim.steps == 5

    def change(s):
        s.dt = 1e-5

    with pytest.raises(tetfem.TetfemError, match="callback"):
        sim.run(3, callback=change)
    # Refused inside the callback: the run stopped after its first step, dt unchanged.
    assert sim.steps == 6 and sim.dt == dt


def test_a_checkpoint_taken_in_the_callback_resumes_bit_for_bit(tmp_path):
    """A checkpoint written by the callback after step 3 holds step 3's state and the method's
    history (Newmark's acceleration): restored, 2 more steps equal the run that went on."""
    _, sim = cantilever_dynamic("newmark")
    path = tmp_path / "step3.bin"

    def at_three(s):
        if s.steps == 3:
            s.checkpoint(path)

    sim.run(5, callback=at_three)
    _, again = cantilever_dynamic("newmark")
    again.restore(path)
    assert again.steps == 3
    again.run(2)
    assert np.array_equal(again.displacement, sim.displacement)
    assert np.array_equal(again.velocity, sim.velocity)


def test_callback_exception_propagates():
    _, sim = cantilever_dynamic()

    def fail(s):
        raise KeyError("stop here")

    with pytest.raises(KeyError, match="stop here"):
        sim.run(5, callback=fail)
    assert sim.steps == 1


def test_modes_match_between_modal_analysis_and_simulation():
    mesh, sim = cantilever_dynamic()
    steel = tetfem.Material(200e9, 0.3, 7850.0)
    constraints = tetfem.Constraints(mesh).fix(mesh.nodes_on_plane("x", 0.0))
    modes = tetfem.modal_analysis(mesh, steel, constraints, count=4)
    again = sim.modes(4)
    assert modes.frequencies.tolist() == again.frequencies.tolist()
    # Euler–Bernoulli first bending frequency 1.875²/(2π)·√(EI/(ρAL⁴)) = 81.5 Hz; coarse linear
    # tets are stiff in bending (tips 5–25 % short), so the mesh's is above it, within 30 %.
    beam = 1.875**2 / (2 * np.pi) * np.sqrt(200e9 * 0.1**4 / 12 / (7850 * 0.01))
    assert beam < modes.frequencies[0] < 1.3 * beam
    # The shapes are M-orthonormal: ΦᵀMΦ = I (to the solver's rounding, 1e-10).
    mass = dense(sim.free_mass())
    free = sim.free_dofs
    phi = modes.shapes.reshape(4, -1)[:, free]
    gram = phi @ (mass @ phi.T)
    assert np.abs(gram - np.eye(4)).max() < 1e-10
    assert (modes.residuals <= 1e-13).all()


def test_the_gil_is_released_while_stepping():
    """Another Python thread runs while a run steps: it sees the run in progress (its calls on
    the Simulation then raise the busy TetfemError). A run that held the GIL from its start to
    its end would leave the other thread no moment at which the run is in progress. (Speed is
    not asserted here: it is the benchmarks' business.)"""
    mesh = tetfem.Mesh.box(max=(1.0, 0.1, 0.1), cells=(30, 6, 6))
    steel = tetfem.Material.steel()
    constraints = tetfem.Constraints(mesh).fix(mesh.nodes_on_plane("x", 0.0))
    loads = tetfem.Loads(mesh).add_gravity((0, 0, -9.81), steel)
    sim = tetfem.Simulation(mesh, steel, constraints, loads, dt=1e-4, method="newmark")
    seen_running = 0
    done = threading.Event()

    def stepper():
        sim.run(40)  # no callback: the GIL is free only inside the steps
        done.set()

    thread = threading.Thread(target=stepper)
    thread.start()
    while not done.is_set():
        try:
            sim.steps
        except tetfem.TetfemError as error:
            assert "Simulation is busy" in str(error)
            seen_running += 1
    thread.join()
    print(f"the main thread saw the run in progress {seen_running} times during 40 steps")
    assert seen_running > 0
    assert sim.steps == 40


def test_setting_the_state_restarts_from_it():
    """A run from a state set mid-way equals a fresh run started from that state."""
    mesh, sim = cantilever_dynamic("backward-euler")
    sim.run(10)
    u, v = sim.displacement, sim.velocity
    _, fresh = cantilever_dynamic("backward-euler")
    fresh.displacement = u
    fresh.velocity = v
    assert np.array_equal(fresh.displacement, u) and np.array_equal(fresh.velocity, v)
    assert fresh.steps == 0  # time and step count are the run's own
    a, b = sim.run(5), fresh.run(5)
    # Backward Euler's state is (u, v) alone: the same bits. (Newmark also carries the
    # acceleration of its last step, which a fresh run derives from equilibrium instead.)
    assert a["total"].tolist() == b["total"].tolist()
    with pytest.raises(tetfem.InvalidInputError, match=r"velocity.shape = \(2, 3\)"):
        fresh.velocity = np.zeros((2, 3))


SWING_TWO_RUBBERS = """
title = "Two-rubber beam released from horizontal (corotational, materials per region)"

[mesh.box]
max = [0.5, 0.05, 0.05]
cells = [20, 2, 2]
split = "five"

[material]
youngs_modulus = 5e5
poisson_ratio = 0.45
density = 1100.0

[[materials]]
youngs_modulus = 2e6
poisson_ratio = 0.4
density = 1200.0
where = { box = { min = [-1.0, -1.0, -1.0], max = [0.25, 1.0, 1.0] } }

[[constraints]]
where = { plane = { axis = "x", at = 0.0 } }

[[loads]]
gravity = [0.0, 0.0, -9.81]

[[probes]]
name = "tip"
where = { plane = { axis = "x", at = 0.5 } }

[analysis]
type = "dynamic"
method = "backward_euler"
model = "corotational"
dt = 5e-3
duration = 0.25

[output]
vtu = false
"""


def test_nonlinear_per_region_history_equals_the_scene_csv_bit_for_bit(tmp_path):
    """scenes/rubber_beam_swing.toml's set-up with a stiffer rubber on the clamped half, for 50
    steps: Newton per step, a corotational model per material."""
    scene = tmp_path / "two_rubbers.toml"
    scene.write_text(SWING_TWO_RUBBERS)
    summary = tetfem.run_scene(scene, output_dir=tmp_path / "out")
    with open(tmp_path / "out" / "two_rubbers.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert summary["steps"] == 50 and summary["model"] == "corotational"

    mesh = tetfem.Mesh.box(max=(0.5, 0.05, 0.05), cells=(20, 2, 2), split="five")
    soft = tetfem.Material(5e5, 0.45, 1100.0)
    stiff = tetfem.Material(2e6, 0.4, 1200.0)
    of_tet = np.zeros(mesh.tet_count, dtype=np.int64)
    of_tet[mesh.tets_in_box((-1.0, -1.0, -1.0), (0.25, 1.0, 1.0))] = 1
    materials = tetfem.MaterialMap([soft, stiff], of_tet)
    constraints = tetfem.Constraints(mesh).fix(mesh.nodes_on_plane("x", 0.0))
    loads = tetfem.Loads(mesh).add_gravity((0.0, 0.0, -9.81), materials)
    sim = tetfem.Simulation(mesh, materials, constraints, loads, dt=5e-3, model="corotational")
    history = sim.run(50)
    for term in ["kinetic", "elastic", "gravity_potential", "total"]:
        assert history[term].tolist() == [float(r[term + "_J"]) for r in rows[1:]], term
    # The beam falls and swings: its tip drops by centimetres (large rotation).
    assert float(rows[-1]["tip_uz_m"]) < -0.01
    with pytest.raises(tetfem.InvalidInputError, match="corotational"):
        sim.modes(2)  # modal analysis is linear only


def test_modal_analysis_equals_the_modal_scene_bit_for_bit():
    """scenes/l_bracket_modal.toml (Gmsh mesh, consistent mass, 8 modes) against
    modal_analysis on the same mesh and clamp."""
    summary = tetfem.run_scene(SCENES / "l_bracket_modal.toml", write_files=False)
    mesh = tetfem.Mesh.read(SCENES / "l_bracket.msh")
    steel = tetfem.Material(200e9, 0.3, 7850.0)
    constraints = tetfem.Constraints(mesh).fix(mesh.nodes_in_group("clamp"))
    modes = tetfem.modal_analysis(mesh, steel, constraints, count=8, mass="consistent")
    assert modes.omega.tolist() == [m["omega_rad_per_s"] for m in summary["modes"]]
    assert modes.frequencies.tolist() == [m["frequency_hz"] for m in summary["modes"]]
    assert len(modes.frequencies) == 8 and (np.diff(modes.frequencies) >= 0).all()
