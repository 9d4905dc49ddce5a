"""A force model per material region from Python (issue 36: "each body with its … force
model"): ``model=`` takes a list of names, one per material of a ``MaterialMap``, in
``solve_static`` and ``Simulation``; a linear body beside a Neo-Hookean one solves as each
alone, and what the library's rule refuses is named."""

import numpy as np
import pytest

import tetfem

RUBBER = tetfem.Material(1e6, 0.3, 1000.0)
# Body 1 starts 5 cm beyond body 0 (0.1 m cubes): out of each other's reach.
B_AT = 0.15


def block():
    return tetfem.Mesh.box(max=(0.1, 0.1, 0.1), cells=(2, 2, 2), split="lecture6")


def clamped_and_loaded(mesh, starts):
    """Each body clamped on its face at x = start, 500 N along z on its face at start + 0.1."""
    constraints = tetfem.Constraints(mesh)
    loads = tetfem.Loads(mesh)
    for x in starts:
        constraints.fix(mesh.nodes_on_plane("x", x))
        loads.add_total_force(mesh.faces_on_plane("x", x + 0.1), (0.0, 0.0, 500.0))
    return constraints, loads


def solve(mesh, material, model, starts):
    constraints, loads = clamped_and_loaded(mesh, starts)
    return tetfem.solve_static(mesh, material, constraints, loads, model=model, load_steps=4)


def test_a_linear_and_a_neo_hookean_body_solve_as_each_alone():
    both = tetfem.Mesh.bodies([block(), block()], translations=[[0, 0, 0], [B_AT, 0, 0]])
    per_body = tetfem.MaterialMap([RUBBER, RUBBER], both.body_of_tet, names=["a", "b"])
    mixed = solve(both, per_body, ["linear", "neo-hookean"], [0.0, B_AT])
    assert mixed.model == "per-material"
    alone_b = tetfem.Mesh.bodies([block()], translations=[[B_AT, 0, 0]])
    a = solve(block(), RUBBER, "linear", [0.0])
    b = solve(alone_b, RUBBER, "neo-hookean", [B_AT])
    b_linear = solve(alone_b, RUBBER, "linear", [B_AT])
    n = block().node_count
    u = mixed.displacement
    scale = np.abs(u).max()
    da = np.abs(u[:n] - a.displacement).max()
    db = np.abs(u[n:] - b.displacement).max()
    gap = np.abs(b.displacement - b_linear.displacement).max()
    print(f"max |u| {scale:.4e} m: body 0 vs alone {da:.2e} m, body 1 vs alone {db:.2e} m, "
          f"neo-hookean vs linear {gap:.2e} m")
    # The model mattered: body 1's two models differ by percents of |u|.
    assert gap > 1e-2 * scale
    # The bodies share no tet: each body's equations are its alone ones. Newton stops at
    # 1e-10 of the load (the combined load is sqrt(2) times each alone) past its quadratic
    # convergence's last step, so the answers agree far below that tolerance times |u|;
    # 1e-9 of |u| holds the difference of where the two loops stopped (measured 3.5e-17 m and
    # 5.5e-17 m, round-off: the last Newton step of each lands there).
    assert da <= 1e-9 * scale
    assert db <= 1e-9 * scale


def test_a_simulation_takes_a_model_per_material_and_names_what_it_refuses():
    both = tetfem.Mesh.bodies([block(), block()], translations=[[0, 0, 0], [B_AT, 0, 0]])
    per_body = tetfem.MaterialMap([RUBBER, RUBBER], both.body_of_tet, names=["a", "b"])
    constraints, _ = clamped_and_loaded(both, [0.0, B_AT])
    sim = tetfem.Simulation(both, per_body, constraints, dt=1e-3,
                            model=["linear", "neo-hookean"])
    assert sim.model == "per-material"
    same = tetfem.Simulation(both, per_body, constraints, dt=1e-3, model=["linear", "linear"])
    assert same.model == "linear"
    with pytest.raises(tetfem.InvalidInputError, match="2 materials"):
        tetfem.Simulation(both, per_body, constraints, dt=1e-3, model=["linear"])
    with pytest.raises(tetfem.InvalidInputError, match="rubbery"):
        tetfem.Simulation(both, per_body, constraints, dt=1e-3, model=["linear", "rubbery"])
    with pytest.raises(tetfem.InvalidInputError, match="model"):
        tetfem.Simulation(both, per_body, constraints, dt=1e-3, model=[])
