# %% [markdown]
# # A curved bracket from numpy arrays
#
# A notebook-style script (each `# %%` is a cell; `curved_bracket.ipynb` holds the same cells,
# written by `python examples/python/to_notebook.py`): a quarter-ring steel bracket meshed with
# numpy (no mesh generator), clamped at one end and pushed down at the other, solved by tetfem,
# and plotted with matplotlib (deflection against mesh size, beside curved-beam theory) and with
# pyvista (the bent bracket coloured by von Mises stress, rendered off-screen to a PNG, and the
# same grid saved as a `.vtu` for ParaView).
#
# Run: `python examples/python/curved_bracket.py` or
# `jupyter nbconvert --to notebook --execute examples/python/curved_bracket.ipynb`
# (after `pip install ./python matplotlib pyvista`). It writes its files into the current folder.

# %%
import math
import sys

import numpy as np

import tetfem

INNER, OUTER, THICK = 0.4, 0.5, 0.1  # m: radii of the ring and its thickness along z
LOAD = 1e3  # N, along −z at the free end
steel = tetfem.Material(200e9, 0.3, 7850.0)  # Pa, -, kg/m³
IN_JUPYTER = "ipykernel" in sys.modules


def show(png):
    """In Jupyter, shows a PNG this notebook wrote in the cell's output (a script leaves it on disk)."""
    if IN_JUPYTER:
        from IPython.display import Image, display

        display(Image(png))

# %% [markdown]
# ## 1. The mesh, from arrays
#
# A structured grid in (r, θ, z) mapped to x = r cos θ, y = r sin θ; each grid cell is cut into
# the 6 tets around its diagonal from corner (0,0,0) to (1,1,1) (Kuhn's split). The same diagonal
# in every cell makes neighbouring cells cut their shared face the same way, so the mesh is
# conforming. `tetfem.Mesh(points, tets)` checks it (degenerate or duplicate tets raise
# `MeshError`) and turns any negatively oriented tet around.

# %%
# The 6 tets of a unit cell as corner numbers 0..7, corner c at offset (c & 1, c >> 1 & 1, c >> 2 & 1).
KUHN = np.array([[0, 1, 3, 7], [0, 1, 5, 7], [0, 2, 3, 7], [0, 2, 6, 7], [0, 4, 5, 7], [0, 4, 6, 7]])


def bracket(n_arc, n_radial, n_thick):
    """Points (n, 3) and tets (m, 4) of the quarter ring in n_arc × n_radial × n_thick cells."""
    r = np.linspace(INNER, OUTER, n_radial + 1)
    theta = np.linspace(0.0, math.pi / 2, n_arc + 1)
    z = np.linspace(0.0, THICK, n_thick + 1)
    R, T, Z = np.meshgrid(r, theta, z, indexing="ij")  # node (i, j, k) at index (i, j, k)
    points = np.column_stack([(R * np.cos(T)).ravel(), (R * np.sin(T)).ravel(), Z.ravel()])
    index = np.arange(points.shape[0]).reshape(R.shape)
    i, j, k = (a.ravel() for a in np.meshgrid(np.arange(n_radial), np.arange(n_arc), np.arange(n_thick), indexing="ij"))
    # corners[c] holds every cell's node at corner c.
    corners = np.stack([index[i + (c & 1), j + (c >> 1 & 1), k + (c >> 2 & 1)] for c in range(8)])
    tets = corners[KUHN].transpose(2, 0, 1).reshape(-1, 4)
    return points, tets


points, tets = bracket(20, 2, 2)
mesh = tetfem.Mesh(points, tets)
print(f"{mesh.node_count} nodes, {mesh.tet_count} tets, volume {mesh.volume:.6f} m³ "
      f"(exact {math.pi / 4 * (OUTER**2 - INNER**2) * THICK:.6f}: the chords cut the arc)")

# %% [markdown]
# ## 2. Clamp, load, solve
#
# Clamped on the face θ = 0 (the plane y = 0), a total force of 1 kN along −z spread over the
# face θ = 90° (the plane x = 0). The reactions at the clamp must carry the whole load.


# %%
def solve(points, tets):
    mesh = tetfem.Mesh(points, tets)
    constraints = tetfem.Constraints(mesh).fix(mesh.nodes_on_plane("y", 0.0))
    loads = tetfem.Loads(mesh).add_total_force(mesh.faces_on_plane("x", 0.0), (0.0, 0.0, -LOAD))
    result = tetfem.solve_static(mesh, steel, constraints, loads)
    tip = result.mean_displacement(mesh.nodes_on_plane("x", 0.0))[2]
    return mesh, result, tip


mesh, result, tip = solve(points, tets)
carried = result.reactions.sum(axis=0)  # N: Σ reactions = −Σ applied
print(f"tip u_z {tip:.4e} m, reactions {carried} N, max von Mises {result.von_mises.max():.3e} Pa")
# The clamp carries the load to the solve's accuracy (relative residual ~1e-15, so 1e-9 of the
# load is a bound that only a wrong reaction or a lost load breaks).
assert abs(carried[2] - LOAD) < 1e-9 * LOAD and np.all(np.abs(carried[:2]) < 1e-9 * LOAD)

# %% [markdown]
# ## 3. Against curved-beam theory
#
# A quarter ring of mean radius R loaded out of its plane by P at the free end bends and twists;
# Castigliano's theorem gives the end's deflection
# δ = P R³ / (E I) · π/4 + P R³ / (G J) · (3π/4 − 2), with I = h⁴/12 and the square's torsion
# constant J ≈ 0.1406 h⁴. Linear tets are too stiff in bending (they lock), so the coarse
# meshes sit below it and approach it as the mesh is refined; the beam formula itself ignores
# shear and the section's curvature, so expect agreement to a few percent, not more.

# %%
R, h = (INNER + OUTER) / 2, THICK
E, G = steel.youngs_modulus, steel.shear_modulus
castigliano = LOAD * R**3 / (E * h**4 / 12) * math.pi / 4 + LOAD * R**3 / (G * 0.1406 * h**4) * (3 * math.pi / 4 - 2)
study = []
for k in (1, 2, 4, 8):
    mesh, result, tip = solve(*bracket(10 * k, k, k))  # the last, 80×8×8, is plotted below
    study.append((3 * mesh.node_count, -tip))
    print(f"{10 * k}×{k}×{k} cells: {mesh.tet_count:5d} tets, deflection {-tip:.4e} m = {-tip / castigliano:.3f} × Castigliano's")
# Refining the mesh frees the locked bending: each finer mesh deflects more.
assert all(a[1] < b[1] for a, b in zip(study, study[1:]))

# %% [markdown]
# ## 4. Plot with matplotlib

# %%
import matplotlib

if not IN_JUPYTER:
    matplotlib.use("Agg")  # a script needs no display; Jupyter keeps its inline backend
import matplotlib.pyplot as plt

dofs, deflection = np.array(study).T
angle = np.degrees(np.arctan2(mesh.points[:, 1], mesh.points[:, 0]))
fig, (left, right) = plt.subplots(1, 2, figsize=(11, 4))
left.semilogx(dofs, deflection * 1e3, "o-", label="tetfem, linear tets")
left.axhline(castigliano * 1e3, color="k", ls="--", label="Castigliano (curved beam)")
left.set(xlabel="DOFs", ylabel="end deflection (mm)", title="Deflection against mesh size")
left.legend()
right.scatter(angle, -result.displacement[:, 2] * 1e3, s=4)
right.set(xlabel="angle θ along the ring (°)", ylabel="−u_z (mm)", title="Deflection along the ring, 80×8×8 cells")
fig.tight_layout()
fig.savefig("curved_bracket.png", dpi=100)
plt.close(fig)
show("curved_bracket.png")
print("wrote curved_bracket.png")

# %% [markdown]
# ## 5. Render with pyvista
#
# An unstructured grid of VTK tets (cell type 10) with the displacement on the points and von
# Mises stress on the cells, warped 200× and rendered off-screen. The grid is also saved as
# `curved_bracket.vtu`: open it in ParaView and colour by `von_mises`.

# %%
import os

if not os.environ.get("DISPLAY"):
    # Without a display VTK would try X first and warn before it falls back; go to EGL at once
    # (Mesa's EGL renders on the CPU where there is no GPU).
    os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
import pyvista as pv

pv.OFF_SCREEN = True  # no window: render into memory
cells = np.column_stack([np.full(mesh.tet_count, 4), mesh.tets]).ravel()
grid = pv.UnstructuredGrid(cells, np.full(mesh.tet_count, pv.CellType.TETRA, dtype=np.uint8), mesh.points)
grid.point_data["displacement"] = result.displacement  # m
grid.cell_data["von_mises"] = result.von_mises  # Pa
grid.save("curved_bracket.vtu")
warped = grid.warp_by_vector("displacement", factor=200.0)
plotter = pv.Plotter(off_screen=True, window_size=(1000, 600))
plotter.add_mesh(grid, style="wireframe", color="grey", opacity=0.3)
plotter.add_mesh(warped, scalars="von_mises", cmap="viridis", scalar_bar_args={"title": "von Mises (Pa)", "position_x": 0.15, "width": 0.7})
plotter.view_isometric()
plotter.screenshot("curved_bracket_3d.png")
show("curved_bracket_3d.png")
print("wrote curved_bracket.vtu and curved_bracket_3d.png (displacement ×200)")
