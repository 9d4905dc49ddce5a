"""Threads and Ctrl-C: a Simulation used from a second thread while it runs gives a clear
TetfemError (not a PanicException that ``except Exception`` misses), and Ctrl-C (SIGINT) stops
a long run or solve with KeyboardInterrupt soon after the signal, the state left at the last
completed step."""

import os
import signal
import threading
import time

import numpy as np
import pytest

import tetfem


def cantilever(method="backward-euler", cells=(20, 2, 2), **options):
    """A steel cantilever under an end load (scenes/cantilever_dynamic.toml's problem)."""
    mesh = tetfem.Mesh.box(max=(1.0, 0.1, 0.1), cells=cells, split="mirrored6")
    steel = tetfem.Material(200e9, 0.3, 7850.0)
    constraints = tetfem.Constraints(mesh).fix(mesh.nodes_on_plane("x", 0.0))
    loads = tetfem.Loads(mesh).add_total_force(mesh.faces_on_plane("x", 1.0), (0.0, 0.0, -10e3))
    return mesh, steel, constraints, loads, tetfem.Simulation(
        mesh, steel, constraints, loads, dt=1e-4, method=method, **options
    )


def busy(call):
    """Whether ``call()`` raised the busy TetfemError (any other exception propagates)."""
    try:
        call()
    except tetfem.TetfemError as error:
        assert "Simulation is busy" in str(error), error
        return True
    return False


def test_a_second_thread_gets_a_busy_tetfem_error_and_runs_meanwhile():
    """While one thread runs, another thread's run, step, getters and setters raise TetfemError
    (an ``except Exception`` catches it). Observing that error at all also shows the GIL is
    released while stepping: a run holding the GIL from start to end would leave the main
    thread no moment at which the run is in progress."""
    *_, sim = cantilever()
    stop = threading.Event()
    recorded = []

    def keep_going(s):
        recorded.append(s.steps)  # the run's own thread may read its state in the callback
        return not stop.is_set()

    worker = threading.Thread(target=lambda: sim.run(10**9, callback=keep_going))
    worker.start()
    try:
        deadline = time.monotonic() + 60.0
        while not busy(lambda: sim.steps):
            assert time.monotonic() < deadline, "the run never showed as in progress"
        calls = {
            "run": lambda: sim.run(1),
            "step": sim.step,
            "time": lambda: sim.time,
            "displacement": lambda: sim.displacement,
            "velocity setter": lambda: setattr(sim, "velocity", (0.0, 0.0, 0.0)),
            "dt setter": lambda: setattr(sim, "dt", 1e-5),
            "energy": sim.energy,
            "von_mises": sim.von_mises,
        }
        for name, call in calls.items():
            # `busy` catches TetfemError, an Exception: a PanicException (a BaseException, as
            # before) or a RuntimeError ("Already mutably borrowed") would fail the test.
            assert busy(call), f"{name} did not raise while another thread runs"
        assert "busy" in repr(sim)
        # What reads no state works meanwhile.
        assert sim.method == "backward-euler" and sim.free_count > 0
    finally:
        stop.set()
        worker.join()
    # Afterwards the object is usable again and its step count is the callback's last record.
    assert sim.steps == recorded[-1] and sim.dt == 1e-4
    sim.run(2)
    assert sim.steps == recorded[-1] + 2


def test_a_static_solver_solving_in_another_thread_is_busy_not_a_panic():
    mesh = tetfem.Mesh.box(max=(1.0, 0.1, 0.1), cells=(40, 6, 6))
    steel = tetfem.Material.steel()
    constraints = tetfem.Constraints(mesh).fix(mesh.nodes_on_plane("x", 0.0))
    loads = tetfem.Loads(mesh).add_gravity((0, 0, -9.81), steel)
    solver = tetfem.StaticSolver(mesh, steel, constraints, linear_solver="iterative")
    seen = []
    done = threading.Event()

    def solve_repeatedly():
        for _ in range(5):
            solver.solve(loads)
        done.set()

    worker = threading.Thread(target=solve_repeatedly)
    worker.start()
    while not done.is_set():
        try:
            solver.factor_len
        except tetfem.TetfemError as error:
            assert "StaticSolver is busy" in str(error)
            seen.append(error)
    worker.join()
    # CG solves of 7k DOFs with the GIL released: the main thread sees one in progress.
    assert seen
    assert solver.factor_len == 0


def sigint_after(seconds):
    """A started timer that sends SIGINT to this process (as Ctrl-C does) after ``seconds``.

    Python's own handler (KeyboardInterrupt) is installed first: a process started in the
    background by a non-interactive shell inherits SIGINT ignored, and Python then installs no
    handler, so the signal would be dropped before tetfem could see it (a CI script run with
    ``&`` failed these tests that way)."""
    signal.signal(signal.SIGINT, signal.default_int_handler)
    timer = threading.Timer(seconds, os.kill, (os.getpid(), signal.SIGINT))
    timer.start()
    return timer


def test_ctrl_c_stops_a_long_run_between_steps_with_a_consistent_state():
    mesh, steel, constraints, loads, sim = cantilever()
    clock = time.perf_counter()
    sim.run(20)
    per_step = (time.perf_counter() - clock) / 20
    # A run of about 15 s unless interrupted; the signal comes after 0.5 s.
    steps = int(15.0 / per_step)
    timer = sigint_after(0.5)
    clock = time.perf_counter()
    try:
        with pytest.raises(KeyboardInterrupt):
            sim.run(steps)
    finally:
        timer.cancel()
    elapsed = time.perf_counter() - clock
    # Honoured at the next step boundary (steps take milliseconds): 3 s leaves room for a
    # loaded machine and is far below the 15 s that a run ignoring the signal takes.
    assert elapsed < 3.0, f"KeyboardInterrupt after {elapsed:.1f} s"
    taken = sim.steps
    assert 20 < taken < 20 + steps
    # The state is that of the last completed step: a fresh run of as many steps has the same
    # bits, time and step count.
    *_, fresh = cantilever()
    history = fresh.run(taken)
    assert history["step"].tolist() == list(range(1, taken + 1))
    assert fresh.time == sim.time
    assert np.array_equal(fresh.displacement, sim.displacement)
    assert np.array_equal(fresh.velocity, sim.velocity)
    # And it carries on from there.
    assert sim.run(3)["step"].tolist() == [taken + 1, taken + 2, taken + 3]


def test_ctrl_c_stops_a_newton_solve_between_iterations():
    mesh = tetfem.Mesh.box(max=(1.0, 0.1, 0.1), cells=(10, 2, 2))
    rubber = tetfem.Material(1e6, 0.3, 1000.0)
    constraints = tetfem.Constraints(mesh).fix(mesh.nodes_on_plane("x", 0.0))
    loads = tetfem.Loads(mesh).add_total_force(mesh.faces_on_plane("x", 1.0), (0.0, 0.0, -5.0))

    def solve(load_steps):
        return tetfem.solve_static(
            mesh, rubber, constraints, loads, model="corotational", load_steps=load_steps
        )

    clock = time.perf_counter()
    solve(20)
    per_load_step = (time.perf_counter() - clock) / 20
    load_steps = int(15.0 / per_load_step)  # about 15 s unless interrupted
    timer = sigint_after(0.5)
    clock = time.perf_counter()
    try:
        with pytest.raises(KeyboardInterrupt):
            solve(load_steps)
    finally:
        timer.cancel()
    elapsed = time.perf_counter() - clock
    # One call: before, Ctrl-C waited for the whole solve (15 s); now the next Newton
    # iteration after the 50 ms check interval stops it (iterations take milliseconds here).
    assert elapsed < 3.0, f"KeyboardInterrupt after {elapsed:.1f} s"
