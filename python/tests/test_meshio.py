"""Round trip through meshio, when it is installed."""

import numpy as np
import pytest

import tetfem
from conftest import SCENES

meshio = pytest.importorskip("meshio", reason="meshio not installed: round-trip test skipped")


def test_round_trip_through_a_vtu_file(tmp_path):
    mesh = tetfem.Mesh.box(max=(1.0, 0.1, 0.1), cells=(6, 2, 2))
    steel = tetfem.Material.steel()
    constraints = tetfem.Constraints(mesh).fix(mesh.nodes_on_plane("x", 0.0))
    loads = tetfem.Loads(mesh).add_gravity((0, 0, -9.81), steel)
    result = tetfem.solve_static(mesh, steel, constraints, loads)
    out = tetfem.to_meshio(
        mesh, point_data={"displacement": result.displacement}, cell_data={"von_mises": result.von_mises}
    )
    out.write(tmp_path / "beam.vtu")
    back = meshio.read(tmp_path / "beam.vtu")
    again = tetfem.from_meshio(back)
    assert np.array_equal(again.points, mesh.points) and np.array_equal(again.tets, mesh.tets)
    assert np.array_equal(back.point_data["displacement"], result.displacement)
    assert np.array_equal(back.cell_data["von_mises"][0], result.von_mises)


def test_a_mesh_without_tets_is_refused():
    triangles = meshio.Mesh(np.zeros((3, 3)), [("triangle", np.array([[0, 1, 2]]))])
    with pytest.raises(tetfem.InvalidInputError, match="tetra"):
        tetfem.from_meshio(triangles)


def test_mesh_methods_delegate_to_the_functions():
    mesh = tetfem.Mesh.box(max=(1.0, 0.1, 0.1), cells=(3, 1, 1))
    again = tetfem.Mesh.from_meshio(mesh.to_meshio(cell_data={"index": np.arange(mesh.tet_count)}))
    assert np.array_equal(again.points, mesh.points) and np.array_equal(again.tets, mesh.tets)


def test_from_meshio_keeps_the_gmsh_physical_groups():
    """Issue 33: ``from_meshio`` dropped the physical groups meshio reads from a ``.msh`` file
    (``cell_data["gmsh:physical"]``, named by ``field_data``). They now select the same
    nodes (by position: meshio keeps the file's unused nodes, so indices differ), faces and
    tets as ``Mesh.read`` of the same file."""
    path = SCENES / "l_bracket.msh"
    read = tetfem.Mesh.read(path)
    converted = tetfem.from_meshio(meshio.read(path))
    summary = lambda mesh: sorted((g["dim"], g["tag"], g["name"], g["tets"]) for g in mesh.groups)
    assert summary(converted) == summary(read) and len(read.groups) > 0
    for group in read.groups:
        name = group["name"]
        points = lambda mesh: sorted(map(tuple, mesh.points[mesh.nodes_in_group(name)].tolist()))
        assert points(converted) == points(read)
        if group["dim"] == 2:
            faces = lambda mesh: sorted(
                sorted(map(tuple, mesh.points[face].tolist())) for face in mesh.faces_in_group(name)
            )
            assert faces(converted) == faces(read) and len(faces(read)) > 0
        if group["dim"] == 3:
            assert len(converted.tets_in_group(name)) == len(read.tets_in_group(name))
    # Without Gmsh tags there are no groups (and no error).
    assert tetfem.from_meshio(read.to_meshio()).groups == []
