"""Curved (isoparametric) 10-node tets through the binding: a Gmsh file's edge nodes off their
midpoints are kept where the file puts them, and the element uses them (it reproduces a linear
field exactly on the bent tets, which only the isoparametric element does)."""

import numpy as np

import tetfem

GRADIENT = np.array([[1e-3, 2e-4, -3e-4], [5e-4, -2e-3, 1e-4], [-1e-4, 3e-4, 4e-4]])
OFFSET = np.array([1e-4, -2e-4, 3e-4])


def write_gmsh22(path, points, tets):
    """Gmsh 2.2 ASCII of 10-node tets (type 11; Gmsh's edge order 01, 12, 02, 03, 23, 13)."""
    gm = tets[:, [0, 1, 2, 3, 4, 5, 6, 7, 9, 8]] + 1
    with open(path, "w") as f:
        f.write("$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n%d\n" % len(points))
        for i, p in enumerate(points):
            f.write("%d %.17g %.17g %.17g\n" % (i + 1, *p))
        f.write("$EndNodes\n$Elements\n%d\n" % len(gm))
        for i, t in enumerate(gm):
            f.write("%d 11 2 1 1 %s\n" % (i + 1, " ".join(map(str, t))))
        f.write("$EndElements\n")


def test_a_curved_gmsh_file_keeps_its_edge_nodes_and_passes_the_patch_test(tmp_path):
    box = tetfem.Mesh.box(max=(1.0, 1.0, 1.0), cells=(3, 3, 3), order=2)
    points, tets = box.points.copy(), box.tets
    edge_nodes = np.unique(tets[:, 4:])
    inside = edge_nodes[np.all((points[edge_nodes] > 1e-9) & (points[edge_nodes] < 1 - 1e-9), axis=1)]
    rng = np.random.default_rng(7)
    # Up to 0.02 per coordinate (0.06 of the cell size): bent, not folded.
    points[inside] += rng.uniform(-0.02, 0.02, size=(len(inside), 3))
    path = tmp_path / "bent.msh"
    write_gmsh22(path, points, tets)
    mesh = tetfem.Mesh.read(str(path), order=2)
    assert mesh.order == 2
    assert np.array_equal(mesh.points, points)  # every node where the file put it, bit for bit
    on_boundary = np.any((points < 1e-12) | (points > 1 - 1e-12), axis=1)
    constraints = tetfem.Constraints(mesh).prescribe_linear(mesh.nodes_where(on_boundary), GRADIENT, OFFSET)
    material = tetfem.Material(1e9, 0.3, 1000.0)
    result = tetfem.solve_static(mesh, material, constraints, tetfem.Loads(mesh), linear_solver="direct")
    exact = points @ GRADIENT.T + OFFSET
    error = np.abs(result.displacement - exact).max() / np.abs(exact).max()
    # The isoparametric element holds every linear field on bent tets (its degree-3 rule makes
    # ∫∇N dV exact): Cholesky rounding only, κ·ε ≈ 1e-13; a straight-sided element on these
    # nodes, or the 4-point rule, misses by 1e-5 and more.
    assert error < 1e-10
