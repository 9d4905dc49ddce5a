"""Meshes, selections and matrices through the Python API."""

import sys

import numpy as np
import pytest

import tetfem
from conftest import SCENES, optional_import


@pytest.mark.parametrize("split,per_cell", [("mirrored6", 6), ("lecture6", 6), ("five", 5)])
def test_box_splits(split, per_cell):
    mesh = tetfem.Mesh.box(max=(2.0, 1.0, 0.5), cells=(4, 2, 3), min=(-1.0, 0.0, 0.0), split=split)
    assert mesh.tet_count == per_cell * 4 * 2 * 3
    assert mesh.node_count == 5 * 3 * 4
    # The tets fill the box: volumes summed in floating point, 1e-12 relative.
    assert mesh.volume == pytest.approx(3.0 * 1.0 * 0.5, rel=1e-12)
    lo, hi = mesh.bounding_box
    assert lo.tolist() == [-1.0, 0.0, 0.0] and hi.tolist() == [2.0, 1.0, 0.5]


def test_mesh_from_arrays_round_trip():
    box = tetfem.Mesh.box(max=(1.0, 0.1, 0.1), cells=(5, 2, 2))
    again = tetfem.Mesh(box.points, box.tets)
    assert np.array_equal(again.points, box.points) and np.array_equal(again.tets, box.tets)
    assert again.reoriented_count == 0
    # A negatively oriented tet is reoriented (nodes 1 and 2 swapped), not refused.
    flipped = box.tets.copy()
    flipped[0, [1, 2]] = flipped[0, [2, 1]]
    assert tetfem.Mesh(box.points, flipped).reoriented_count == 1
    # Lists work as well as arrays.
    assert tetfem.Mesh(box.points.tolist(), box.tets.tolist()).tet_count == box.tet_count


def test_selections_agree():
    mesh = tetfem.Mesh.box(max=(1.0, 0.1, 0.1), cells=(10, 2, 2))
    x = mesh.points[:, 0]
    plane = mesh.nodes_on_plane("x", 0.5)
    assert plane.tolist() == mesh.nodes_where(np.abs(x - 0.5) < 1e-9).tolist()
    assert plane.tolist() == mesh.nodes_on_plane(0, 0.5).tolist()
    assert len(plane) == 9
    in_box = mesh.nodes_in_box((0.45, -1, -1), (0.55, 1, 1))
    assert in_box.tolist() == plane.tolist()
    end_faces = mesh.faces_on_plane("x", 1.0)
    assert end_faces.shape == (8, 3)  # 2×2 cells, two triangles each
    assert (mesh.points[end_faces][:, :, 0] == 1.0).all()
    assert mesh.faces_where(x >= 1.0 - 1e-12).tolist() == end_faces.tolist()
    # Outward normals of the end faces point along +x.
    p = mesh.points[end_faces]
    normals = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    assert (normals[:, 0] > 0).all()
    assert len(mesh.tets_in_box((0, -1, -1), (0.5, 1, 1))) == mesh.tet_count // 2


def test_gmsh_groups():
    mesh = tetfem.Mesh.read(SCENES / "l_bracket.msh")
    names = {g["name"] for g in mesh.groups}
    assert {"clamp", "load"} <= names
    clamp = mesh.nodes_in_group("clamp")
    faces = mesh.faces_in_group("clamp")
    assert len(clamp) > 0 and len(faces) > 0
    assert set(np.unique(faces)) <= set(clamp.tolist())


def test_reactions_balance_the_loads():
    mesh = tetfem.Mesh.box(max=(1.0, 0.1, 0.1), cells=(20, 2, 2))
    steel = tetfem.Material.steel()
    constraints = tetfem.Constraints(mesh).fix(mesh.nodes_on_plane("x", 0.0))
    loads = tetfem.Loads(mesh).add_gravity((0, 0, -9.81), steel)
    loads.add_pressure(mesh.faces_on_plane("z", 0.1), 1e3)
    loads.add_nodal_force(mesh.nodes_on_plane("x", 1.0), (0.0, 10.0, 0.0))
    result = tetfem.solve_static(mesh, steel, constraints, loads)
    total = result.reactions.sum(axis=0) + loads.resultant
    # Equilibrium: reactions cancel the applied resultant (~800 N) to the solve's rounding.
    assert np.abs(total).max() < 1e-8 * np.abs(loads.resultant).max()
    # Weight ρ·g·V and pressure·area on the top face, both along −z.
    assert loads.resultant[2] == pytest.approx(-(7850 * 9.81 * 0.01 + 1e3 * 0.1), rel=1e-12)


def test_stiffness_matrices():
    scipy = optional_import("scipy.sparse", reason="scipy not installed: CSR tests skipped")
    from scipy.sparse.linalg import spsolve

    mesh = tetfem.Mesh.box(max=(1.0, 0.1, 0.1), cells=(10, 2, 2))
    steel = tetfem.Material.steel()
    constraints = tetfem.Constraints(mesh).fix(mesh.nodes_on_plane("x", 0.0))
    loads = tetfem.Loads(mesh).add_total_force(mesh.faces_on_plane("x", 1.0), (0, 0, -1e3))
    solver = tetfem.StaticSolver(mesh, steel, constraints)
    k = solver.stiffness()
    k_ff = solver.free_stiffness()
    free = solver.free_dofs
    assert scipy.issparse(k) and k.shape == (mesh.dof_count, mesh.dof_count)
    assert k_ff.shape == (len(free), len(free))
    # Symmetric, and K_ff is K restricted to the free DOFs.
    assert abs(k - k.T).max() == 0.0
    assert abs(k[free][:, free] - k_ff).max() == 0.0
    result = solver.solve(loads)
    u = result.displacement.reshape(-1)
    f = loads.forces.reshape(-1)
    # SciPy's sparse LU on the same K_ff agrees with tetfem's Cholesky to the solves' rounding
    # (κ ≈ 1e6 here: ~1e-10 relative, 1e-8 with margin).
    u_scipy = spsolve(k_ff.tocsc(), f[free])
    assert np.abs(u_scipy - u[free]).max() < 1e-8 * np.abs(u).max()
    # K·u − f are the reactions.
    assert np.abs(k @ u - f - result.reactions.reshape(-1)).max() < 1e-8 * np.abs(f).max() * 10
    # A second load case reuses the factorization: double the load, double the displacement.
    twice = tetfem.Loads(mesh).add_total_force(mesh.faces_on_plane("x", 1.0), (0, 0, -2e3))
    assert np.allclose(solver.solve(twice).displacement, 2 * result.displacement, rtol=1e-12, atol=0)


def test_help_documents_every_class():
    for name in tetfem.__all__:
        obj = getattr(tetfem, name)
        if callable(obj):
            assert obj.__doc__ and len(obj.__doc__) > 20, name


def test_tetgen_files_with_markers_and_attributes(tmp_path):
    """A TetGen .node/.ele pair written here (1-based, with node markers and tet attributes)
    reads back as the same mesh, and its markers and attributes select nodes and tets."""
    box = tetfem.Mesh.box(max=(1.0, 1.0, 1.0), cells=(2, 1, 1), split="five")
    points, tets = box.points, box.tets
    markers = (points[:, 2] == 0.0).astype(int)  # 1 on the bottom face
    attributes = np.arange(len(tets)) % 2 + 1  # regions 1 and 2
    with open(tmp_path / "part.node", "w") as f:
        f.write(f"{len(points)} 3 0 1\n")
        for i, (p, m) in enumerate(zip(points, markers)):
            f.write(f"{i + 1} {float(p[0])!r} {float(p[1])!r} {float(p[2])!r} {m}\n")
    with open(tmp_path / "part.ele", "w") as f:
        f.write(f"{len(tets)} 4 1\n")
        for i, (t, a) in enumerate(zip(tets, attributes)):
            f.write(f"{i + 1} {t[0] + 1} {t[1] + 1} {t[2] + 1} {t[3] + 1} {a}\n")
    mesh = tetfem.Mesh.read(tmp_path / "part.node")
    assert np.array_equal(mesh.points, points) and np.array_equal(mesh.tets, tets)
    assert mesh.nodes_with_marker(1).tolist() == np.flatnonzero(markers).tolist()
    assert mesh.tets_with_attribute(2.0).tolist() == np.flatnonzero(attributes == 2).tolist()
    steel = tetfem.Material.steel()
    aluminium = tetfem.Material(70e9, 0.33, 2700.0)
    of_tet = (attributes == 2).astype(np.int64)
    materials = tetfem.MaterialMap([steel, aluminium], of_tet)
    constraints = tetfem.Constraints(mesh).fix(mesh.nodes_with_marker(1))
    loads = tetfem.Loads(mesh).add_gravity((0, 0, -9.81), materials)
    # The weight uses each tet's density: ρ₁·V₁ + ρ₂·V₂ (volumes of the two regions).
    volumes = np.zeros(2)
    for t, tet in enumerate(tets):
        a, b, c, d = points[tet]
        volumes[of_tet[t]] += abs(np.dot(b - a, np.cross(c - a, d - a))) / 6
    weight = 9.81 * (7850 * volumes[0] + 2700 * volumes[1])
    assert loads.resultant[2] == pytest.approx(-weight, rel=1e-12)
    result = tetfem.solve_static(mesh, materials, constraints, loads)
    assert result.displacement[:, 2].min() < 0.0


def test_global_stiffness_and_mass_matrices():
    optional_import("scipy.sparse", reason="scipy not installed: CSR tests skipped")
    mesh = tetfem.Mesh.box(max=(1.0, 0.1, 0.1), cells=(10, 2, 2))
    steel = tetfem.Material.steel()
    constraints = tetfem.Constraints(mesh).fix(mesh.nodes_on_plane("x", 0.0))
    k = tetfem.stiffness_matrix(mesh, steel)
    assert abs(k - tetfem.StaticSolver(mesh, steel, constraints).stiffness()).max() == 0.0
    # K holds the rigid translations in its null space: K·1 = 0 per axis (to rounding of the
    # ~1e10 N/m entries: 1e-6 N/m relative 1e-16).
    ones_x = np.tile([1.0, 0.0, 0.0], mesh.node_count)
    assert np.abs(k @ ones_x).max() < 1e-6 * abs(k).max()
    total = 7850.0 * mesh.volume  # kg
    for kind in ["lumped", "consistent"]:
        m = tetfem.mass_matrix(mesh, steel, mass=kind)
        # Each axis carries the whole mass: 1ᵀ·M·1 = 3·ρ·V (summation rounding, 1e-12).
        assert m.sum() == pytest.approx(3 * total, rel=1e-12), kind
        sim = tetfem.Simulation(mesh, steel, constraints, dt=1e-4, mass=kind)
        free = sim.free_dofs
        assert abs(m[free][:, free] - sim.free_mass()).max() == 0.0, kind
    with pytest.raises(tetfem.InvalidInputError, match="mass = 'heavy'"):
        tetfem.mass_matrix(mesh, steel, mass="heavy")


def test_matrices_without_scipy_are_csr_arrays(monkeypatch):
    """Without SciPy the matrices come as (indptr, indices, data, shape): the same CSR arrays."""
    mesh = tetfem.Mesh.box(max=(1.0, 0.1, 0.1), cells=(4, 1, 1))
    steel = tetfem.Material.steel()
    monkeypatch.setitem(sys.modules, "scipy", None)  # `import scipy.sparse` now raises ImportError
    monkeypatch.setitem(sys.modules, "scipy.sparse", None)
    indptr, indices, data, shape = tetfem.stiffness_matrix(mesh, steel)
    _, _, mass, _ = tetfem.mass_matrix(mesh, steel)
    monkeypatch.undo()
    assert shape == (mesh.dof_count, mesh.dof_count) and len(indptr) == mesh.dof_count + 1
    assert mass.sum() == pytest.approx(3 * 7850.0 * mesh.volume, rel=1e-12)
    scipy = optional_import("scipy.sparse", reason="scipy not installed: comparison skipped")
    k = tetfem.stiffness_matrix(mesh, steel)
    assert np.array_equal(k.indptr, indptr) and np.array_equal(k.indices, indices)
    assert np.array_equal(k.data, data) and scipy.issparse(k)


def test_a_quadratic_file_read_as_corners_says_so():
    """Issue 33: ``Mesh.read`` of a 10-node file kept its 185 corners of 990 nodes with
    ``warnings == []``. Read with ``order=1`` it still keeps the corners, and says so in
    ``warnings`` and with a ``UserWarning``, naming the file and the order (issue 34 reads it
    at its own order by default: ``test_p2.py``)."""
    path = SCENES / "l_bracket_p2.msh"
    with pytest.warns(UserWarning, match="l_bracket_p2.msh.*10-node tets .order 2"):
        mesh = tetfem.Mesh.read(path, order=1)
    assert mesh.node_count == 185
    notes = [w for w in mesh.warnings if "order 2" in w]
    assert len(notes) == 1 and "990 nodes" in notes[0] and str(path) in notes[0], mesh.warnings
    linear = tetfem.Mesh.read(SCENES / "l_bracket.msh")
    assert not [w for w in linear.warnings if "order 2" in w]


def test_tetgen_faces_are_selected_by_marker():
    """Issue 33: Python could not select TetGen faces by marker. ``faces_with_marker`` gives
    the boundary faces that are ``.face`` triangles with the marker, as scenes'
    ``{ face_marker = … }`` do: checked against the file's own rows."""
    mesh = tetfem.Mesh.read(SCENES / "tetgen_bar.node")
    rows = [line.split() for line in (SCENES / "tetgen_bar.face").read_text().splitlines()]
    rows = [r for r in rows[2:] if r and not r[0].startswith("#")]
    for marker in (0, 1, 2):
        # The .node file is 1-based and every point is used, so node i is file point i + 1.
        expected = sorted(tuple(sorted(int(n) - 1 for n in r[1:4])) for r in rows if int(r[4]) == marker)
        got = sorted(tuple(sorted(f)) for f in mesh.faces_with_marker(marker).tolist())
        assert got == expected
        nodes = sorted({n for face in expected for n in face})
        assert mesh.nodes_with_face_marker(marker).tolist() == nodes
    with pytest.raises(tetfem.InvalidInputError, match=r"no face marker 5 \(it has: 0 \(160 faces\)"):
        mesh.faces_with_marker(5)
    with pytest.raises(tetfem.InvalidInputError, match="face marker"):
        tetfem.Mesh.box(max=(1.0, 1.0, 1.0), cells=(1, 1, 1)).faces_with_marker(1)
