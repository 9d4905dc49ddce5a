"""Round trip through meshio, when it is installed."""

import numpy as np
import pytest

import tetfem
from conftest import optional_import

meshio = optional_import("meshio", reason="meshio not installed: round-trip test skipped")


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
