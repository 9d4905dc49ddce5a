"""Static solves through the Python API against the Rust scene runner on the same problem.

Each test builds a shipped scene's problem with the Python API (mesh, selections, constraints,
loads in the scene's order) and compares with the Rust scene runner's summary of that scene
file (``run_scene``: TOML parsing, the CLI crate's scene builder, its solver choice). The two
paths share the library but nothing of the set-up, so equal bits mean the binding builds the
same problem. ``test_tip_matches_the_tetfem_binary`` repeats the comparison against a separate
process: the ``tetfem`` command-line binary's JSON.
"""

import json
import os
import shutil
import subprocess

import numpy as np
import pytest

import tetfem
from conftest import REPO, SCENES, probe_mean, skip_outside_ci


def cantilever_static():
    """scenes/cantilever_static.toml through the Python API."""
    mesh = tetfem.Mesh.box(max=(1.0, 0.1, 0.1), cells=(40, 4, 4), split="mirrored6")
    steel = tetfem.Material(200e9, 0.3, 7850.0)
    constraints = tetfem.Constraints(mesh).fix(mesh.nodes_on_plane("x", 0.0))
    loads = tetfem.Loads(mesh)
    loads.add_total_force(mesh.faces_on_plane("x", 1.0), (0.0, 0.0, -10e3))
    loads.add_gravity((0.0, 0.0, -9.81), steel)
    result = tetfem.solve_static(mesh, steel, constraints, loads)
    return mesh, result, {"tip": mesh.nodes_on_plane("x", 1.0)}


def rubber_cantilever_large():
    """scenes/rubber_cantilever_large.toml (corotational model, Newton)."""
    mesh = tetfem.Mesh.box(max=(0.5, 0.05, 0.05), cells=(20, 2, 2), split="five")
    rubber = tetfem.Material(5e6, 0.45, 1100.0)
    constraints = tetfem.Constraints(mesh).fix(mesh.nodes_on_plane("x", 0.0))
    loads = tetfem.Loads(mesh).add_total_force(mesh.faces_on_plane("x", 0.5), (0.0, 0.0, -30.0))
    result = tetfem.solve_static(mesh, rubber, constraints, loads, model="corotational")
    return mesh, result, {"tip": mesh.nodes_on_plane("x", 0.5)}


def bimaterial_bar():
    """scenes/bimaterial_bar.toml (a MaterialMap: steel where the tet centroid is in the box)."""
    mesh = tetfem.Mesh.box(max=(1.0, 0.1, 0.1), cells=(20, 2, 2))
    steel = tetfem.Material(200e9, 0.0, 7850.0)
    aluminium = tetfem.Material(70e9, 0.0, 2700.0)
    of_tet = np.ones(mesh.tet_count, dtype=np.int64)
    of_tet[mesh.tets_in_box((-1.0, -1.0, -1.0), (0.5, 1.0, 1.0))] = 0
    materials = tetfem.MaterialMap([steel, aluminium], of_tet, names=["steel", "aluminium"])
    constraints = tetfem.Constraints(mesh).fix(mesh.nodes_on_plane("x", 0.0))
    loads = tetfem.Loads(mesh).add_total_force(mesh.faces_on_plane("x", 1.0), (1e5, 0.0, 0.0))
    result = tetfem.solve_static(mesh, materials, constraints, loads)
    probes = {"end": mesh.nodes_on_plane("x", 1.0), "interface": mesh.nodes_on_plane("x", 0.5)}
    return mesh, result, probes


def l_bracket():
    """scenes/l_bracket.toml (a Gmsh mesh, constraints and loads on physical groups)."""
    mesh = tetfem.Mesh.read(SCENES / "l_bracket.msh")
    steel = tetfem.Material(200e9, 0.3, 7850.0)
    constraints = tetfem.Constraints(mesh).fix(mesh.nodes_in_group("clamp"))
    loads = tetfem.Loads(mesh).add_total_force(mesh.faces_in_group("load"), (0.0, -2000.0, 0.0))
    result = tetfem.solve_static(mesh, steel, constraints, loads)
    return mesh, result, {"load_face": mesh.nodes_in_group("load")}


CASES = {
    "cantilever_static": cantilever_static,
    "rubber_cantilever_large": rubber_cantilever_large,
    "bimaterial_bar": bimaterial_bar,
    "l_bracket": l_bracket,
}


@pytest.mark.parametrize("name", sorted(CASES))
def test_probes_equal_the_scene_runner_bit_for_bit(name):
    mesh, result, probes = CASES[name]()
    summary = tetfem.run_scene(SCENES / f"{name}.toml", write_files=False)
    assert summary["nodes"] == mesh.node_count and summary["tets"] == mesh.tet_count
    by_name = {p["name"]: p["displacement"] for p in summary["probes"]}
    assert set(by_name) == set(probes)
    for probe, nodes in probes.items():
        # Exact equality: the same problem, solved by the same code, summed in the same order.
        assert probe_mean(result.displacement, nodes) == by_name[probe], probe
    assert result.relative_residual == summary["relative_residual"]
    assert float(result.von_mises.max()) == summary["max_von_mises"]
    assert float(np.sqrt((result.displacement**2).sum(axis=1)).max()) == pytest.approx(
        summary["max_displacement"], rel=1e-15  # |u| summed by numpy vs Rust: last-bit rounding
    )


def test_cantilever_tip_value_is_the_bending_one():
    """The compared number is the physical one: the 40×4×4 tip sags about 1.55 mm (the scene's
    comment; Euler–Bernoulli 2.06 mm, linear tets are stiff in bending)."""
    mesh, result, probes = cantilever_static()
    tip_z = probe_mean(result.displacement, probes["tip"])[2]
    assert -1.60e-3 < tip_z < -1.50e-3


def tetfem_binary():
    """The `tetfem` binary of this checkout's release build, if built (CI builds it in
    `cargo test --release` before the Python tests)."""
    target = os.environ.get("CARGO_TARGET_DIR", str(REPO / "target"))
    path = os.path.join(target, "release", "tetfem")
    return path if os.path.exists(path) else shutil.which("tetfem")


def test_tip_matches_the_tetfem_binary(tmp_path):
    binary = tetfem_binary()
    if binary is None:
        skip_outside_ci("no tetfem binary: run `cargo build --release` first (CI has one)")
    out = subprocess.run(
        [binary, "run", str(SCENES / "cantilever_static.toml"), "--json", "--quiet", "--out", str(tmp_path)],
        check=True,
        capture_output=True,
        text=True,
    ).stdout
    summary = json.loads(out)
    mesh, result, probes = cantilever_static()
    rust_tip = summary["probes"][0]["displacement"]
    print(f"cantilever tip: python {probe_mean(result.displacement, probes['tip'])}, binary {rust_tip}")
    assert probe_mean(result.displacement, probes["tip"]) == rust_tip


@pytest.mark.parametrize("cells", [(40, 4, 4), (20, 2, 2)])
def test_default_run_static_tip_matches_the_binary(cells, tmp_path):
    """The default run of `cargo run --release` (the fixture crate's cantilever: end load, then
    gravity) against the same beam built here: equal bits."""
    binary = tetfem_binary()
    if binary is None:
        skip_outside_ci("no tetfem binary: run `cargo build --release` first (CI has one)")
    cell_text = ",".join(map(str, cells))
    out = subprocess.run(
        [binary, "--cells", cell_text, "--static-only", "--json", "--quiet", "--out", str(tmp_path)],
        check=True,
        capture_output=True,
        text=True,
    ).stdout
    rust = json.loads(out)["static"]
    mesh = tetfem.Mesh.box(max=(1.0, 0.1, 0.1), cells=cells)
    steel = tetfem.Material(200e9, 0.3, 7850.0)
    constraints = tetfem.Constraints(mesh).fix(mesh.nodes_on_plane("x", 0.0))
    loads = tetfem.Loads(mesh)
    loads.add_total_force(mesh.faces_on_plane("x", 1.0), (0.0, 0.0, -10e3))
    loads.add_gravity((0.0, 0.0, -9.81), steel)
    result = tetfem.solve_static(mesh, steel, constraints, loads)
    tip = probe_mean(result.displacement, mesh.nodes_on_plane("x", 1.0))
    print(f"default run {cells}: tip python {tip[2]!r}, binary {rust['probes'][0]['displacement'][2]!r}")
    assert tip == rust["probes"][0]["displacement"]
    assert result.relative_residual == rust["relative_residual"]
