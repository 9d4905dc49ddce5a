"""Bad input raises a TetfemError subclass naming the culprit (never a crash, never a bare
Rust panic)."""

import numpy as np
import pytest

import tetfem

TET = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]


@pytest.fixture
def beam():
    mesh = tetfem.Mesh.box(max=(1.0, 0.1, 0.1), cells=(6, 2, 2))
    steel = tetfem.Material.steel()
    constraints = tetfem.Constraints(mesh).fix(mesh.nodes_on_plane("x", 0.0))
    loads = tetfem.Loads(mesh).add_gravity((0, 0, -9.81), steel)
    return mesh, steel, constraints, loads


def test_nan_coordinate_names_the_node():
    points = np.array(TET)
    points[3, 2] = np.nan
    with pytest.raises(tetfem.MeshError, match=r"node 3: coordinate 2 is not finite \(NaN\)"):
        tetfem.Mesh(points, [[0, 1, 2, 3]])


def test_infinite_box_corner():
    with pytest.raises(tetfem.TetfemError, match="max"):
        tetfem.Mesh.box(max=(np.inf, 1, 1), cells=(1, 1, 1))


def test_unconstrained_body():
    mesh = tetfem.Mesh.box(max=(1, 1, 1), cells=(2, 2, 2))
    steel = tetfem.Material.steel()
    loads = tetfem.Loads(mesh).add_gravity((0, 0, -9.81), steel)
    with pytest.raises(tetfem.NotConstrainedError, match="not fully constrained"):
        tetfem.solve_static(mesh, steel, tetfem.Constraints(mesh), loads)
    with pytest.raises(tetfem.NotConstrainedError):
        tetfem.Simulation(mesh, steel, tetfem.Constraints(mesh), loads, dt=1e-4)


@pytest.mark.parametrize(
    "points,tets,pattern",
    [
        (np.zeros((4, 2)), [[0, 1, 2, 3]], r"points.shape = \(4, 2\): must be a 2-D array of shape \(n, 3\)"),
        (np.zeros(12), [[0, 1, 2, 3]], r"points.shape = \(12,\)"),
        (TET, [[0, 1, 2]], r"tets.shape = \(1, 3\): must be a 2-D array of shape \(n, 4\)"),
        (TET, [[0.0, 1.5, 2.0, 3.0]], "must hold integer indices"),
        (TET, [[0, -1, 2, 3]], r"tets\[0, 1\] = -1: must be a non-negative index"),
        (["a", "b"], [[0, 1, 2, 3]], "must hold real numbers"),
    ],
)
def test_wrong_array_shape_or_type(points, tets, pattern):
    with pytest.raises(tetfem.InvalidInputError, match=pattern):
        tetfem.Mesh(points, tets)


def test_index_out_of_range_and_degenerate_tet():
    with pytest.raises(tetfem.MeshError, match="node index 9 is out of range"):
        tetfem.Mesh(TET, [[0, 1, 2, 9]])
    flat = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]]
    with pytest.raises(tetfem.MeshError, match="tet 0"):
        tetfem.Mesh(flat, [[0, 1, 2, 3]])


def test_invalid_input_errors_are_value_errors():
    # Code that catches ValueError for bad arguments catches tetfem's too.
    with pytest.raises(ValueError):
        tetfem.Material(200e9, 0.5, 7850)


@pytest.mark.parametrize(
    "kwargs,pattern",
    [
        ({"method": "rk4"}, "method = rk4: must be 'backward-euler', 'newmark' or 'explicit'"),
        ({"model": "hooke"}, 'model = hooke: must be one of "linear", "corotational"'),
        ({"mass": "heavy"}, "mass = 'heavy': must be 'lumped' or 'consistent'"),
        ({"linear_solver": "magic"}, "linear_solver = 'magic'"),
        ({"dt": "fast"}, "dt = 'fast'"),
        ({"dt": -1.0}, "dt = -1"),
        ({"damping": (-1.0, 0.0)}, "must be finite and ≥ 0|≥ 0|>= 0"),
    ],
)
def test_unknown_names_and_bad_settings(beam, kwargs, pattern):
    mesh, steel, constraints, loads = beam
    args = {"dt": 1e-4, **kwargs}
    with pytest.raises(tetfem.InvalidInputError, match=pattern):
        tetfem.Simulation(mesh, steel, constraints, loads, **args)


def test_unknown_split_model_and_axis(beam):
    mesh, steel, constraints, loads = beam
    with pytest.raises(tetfem.InvalidInputError, match="split = 'six'"):
        tetfem.Mesh.box(max=(1, 1, 1), cells=(1, 1, 1), split="six")
    with pytest.raises(tetfem.InvalidInputError, match="model = plastic"):
        tetfem.solve_static(mesh, steel, constraints, loads, model="plastic")
    with pytest.raises(tetfem.InvalidInputError, match="axis = 'w'"):
        mesh.nodes_on_plane("w", 0.0)
    with pytest.raises(tetfem.InvalidInputError, match="axis = 3"):
        mesh.nodes_on_plane(3, 0.0)


def test_selections_and_faces(beam):
    mesh, steel, constraints, loads = beam
    with pytest.raises(tetfem.InvalidInputError, match=r"mask.shape = \(3,\)"):
        mesh.nodes_where(np.array([True, False, True]))
    with pytest.raises(tetfem.InvalidInputError, match="must be a boolean mask"):
        mesh.nodes_where(np.zeros(mesh.node_count))
    with pytest.raises(tetfem.InvalidInputError, match=r"faces\[0\] = \[0, 1, 999\]"):
        tetfem.Loads(mesh).add_traction([[0, 1, 999]], (0, 0, 1))
    with pytest.raises(tetfem.InvalidInputError, match="node 10000 does not exist"):
        tetfem.Constraints(mesh).fix([10000])
    with pytest.raises(tetfem.InvalidInputError, match="needs a mesh read from a file"):
        mesh.nodes_in_group("clamp")


def test_conflicting_constraint_leaves_constraints_unchanged(beam):
    mesh = beam[0]
    end = mesh.nodes_on_plane("x", 1.0)
    constraints = tetfem.Constraints(mesh).prescribe(end, (0.0, 0.0, 1e-3))
    before = constraints.count
    with pytest.raises(tetfem.InvalidInputError, match="node"):
        constraints.prescribe(end, (0.0, 0.0, 2e-3))
    assert constraints.count == before


def test_objects_of_another_mesh(beam):
    mesh, steel, constraints, loads = beam
    other = tetfem.Mesh.box(max=(1.0, 0.1, 0.1), cells=(6, 2, 2))
    with pytest.raises(tetfem.InvalidInputError, match="another mesh"):
        tetfem.solve_static(other, steel, constraints, loads)
    with pytest.raises(tetfem.InvalidInputError, match=r"tet count|tets|length"):
        tetfem.solve_static(mesh, tetfem.MaterialMap([steel], np.zeros(3, dtype=int)), constraints, loads)


def test_material_argument_type(beam):
    mesh, steel, constraints, loads = beam
    with pytest.raises(tetfem.InvalidInputError, match="must be a tetfem.Material or a tetfem.MaterialMap"):
        tetfem.solve_static(mesh, "steel", constraints, loads)


def test_scene_error_names_line_and_key(tmp_path):
    scene = tmp_path / "bad.toml"
    scene.write_text('[mesh.box]\nmax = [1.0, 0.1, 0.1]\ncells = [4, 1, 1]\nsplit = "seven"\n')
    with pytest.raises(tetfem.SceneError, match="bad.toml"):
        tetfem.run_scene(scene, write_files=False)
    with pytest.raises(tetfem.TetfemIOError):
        tetfem.run_scene(tmp_path / "missing.toml")


def test_missing_mesh_file(tmp_path):
    with pytest.raises(tetfem.TetfemError):
        tetfem.Mesh.read(tmp_path / "nothing.msh")


def test_a_tolerance_the_solve_cannot_reach_raises_naming_it_and_the_residual():
    """tolerance=1e-14 is below double precision's floor for a beam's stiffness: before, the
    solve returned a residual far above it without a word."""
    mesh = tetfem.Mesh.box(max=(1.0, 0.1, 0.1), cells=(40, 4, 4))
    steel = tetfem.Material.steel()
    constraints = tetfem.Constraints(mesh).fix(mesh.nodes_on_plane("x", 0.0))
    loads = tetfem.Loads(mesh).add_gravity((0, 0, -9.81), steel)
    for solver in ["iterative", "direct"]:
        default = tetfem.solve_static(mesh, steel, constraints, loads, linear_solver=solver)
        # The floor of this matrix is above 1e-14 (ε·κ, κ ~ 1e6 here); a solve that reaches it
        # anyway would make this test vacuous.
        assert default.relative_residual > 1e-14, (solver, default.relative_residual)
        with pytest.raises(tetfem.SolverError, match=r"did not reach tolerance = 1e-14: its relative residual is \d"):
            tetfem.solve_static(mesh, steel, constraints, loads, linear_solver=solver, tolerance=1e-14)
        # A tolerance above what it reaches is met, and says so.
        met = tetfem.solve_static(mesh, steel, constraints, loads, linear_solver=solver, tolerance=1e-6)
        assert met.relative_residual <= 1e-6
    with pytest.raises(tetfem.SolverError, match="did not reach tolerance = 1e-14"):
        tetfem.solve_static(mesh, steel, constraints, loads, model="corotational", tolerance=1e-14)
    with pytest.raises(tetfem.InvalidInputError, match="tolerance = 0"):
        tetfem.solve_static(mesh, steel, constraints, loads, tolerance=0.0)


def test_a_newton_failure_is_labelled_newton_not_linear_solver():
    mesh = tetfem.Mesh.box(max=(1.0, 0.1, 0.1), cells=(10, 2, 2))
    rubber = tetfem.Material(1e6, 0.45, 1000.0)
    constraints = tetfem.Constraints(mesh).fix(mesh.nodes_on_plane("x", 0.0))
    # A tip load far beyond what 2 iterations of one load step can equilibrate.
    loads = tetfem.Loads(mesh).add_total_force(mesh.faces_on_plane("x", 1.0), (0.0, 0.0, -500.0))
    with pytest.raises(tetfem.SolverError) as raised:
        tetfem.solve_static(
            mesh, rubber, constraints, loads, model="neo-hookean", load_steps=1, max_iterations=2
        )
    message = str(raised.value)
    assert message.startswith("Newton's method: no convergence in 2 iterations at load step 1/1"), message
    assert "linear solver" not in message and "residual" in message


def test_history_steps_are_integers():
    mesh = tetfem.Mesh.box(max=(1.0, 0.1, 0.1), cells=(6, 2, 2))
    steel = tetfem.Material.steel()
    constraints = tetfem.Constraints(mesh).fix(mesh.nodes_on_plane("x", 0.0))
    sim = tetfem.Simulation(mesh, steel, constraints, dt=1e-4)
    history = sim.run(3)
    assert history["step"].dtype == np.int64 and history["step"].tolist() == [1, 2, 3]
    assert history["time"].dtype == np.float64
