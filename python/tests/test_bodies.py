"""Several bodies from Python (issue 36): ``Mesh.bodies`` places meshes by rigid motions into one
mesh (the library's ``mesh::Bodies``), and ``Simulation(..., self_contact=True)`` runs the
surface barrier between them: the same steps as the scene runner's ``[[bodies]]`` scene, bit for
bit, and the barrier's promise (forces internal: momentum kept)."""

import csv

import numpy as np
import pytest

import tetfem
from conftest import probe_mean

HEAD_ON_SCENE = """
[mesh.box]
max = [0.1, 0.1, 0.1]
cells = [2, 2, 2]
split = "lecture6"
[material]
youngs_modulus = 1e6
poisson_ratio = 0.3
density = 1000.0
[[bodies]]
[[bodies]]
translation = [0.11, 0.0, 0.0]
velocity = [-1.0, 0.0, 0.0]
[[probes]]
name = "still"
where = { body = 0 }
[self_contact]
distance = 2e-3
stiffness = 1e3
[analysis]
type = "dynamic"
method = "backward_euler"
model = "neo-hookean"
dt = 5e-4
duration = 0.015
"""


def two_blocks():
    block = tetfem.Mesh.box(max=(0.1, 0.1, 0.1), cells=(2, 2, 2), split="lecture6")
    return block, tetfem.Mesh.bodies([block, block], translations=[[0, 0, 0], [0.11, 0, 0]])


def test_bodies_are_placed_and_numbered():
    block, both = two_blocks()
    n, m = block.node_count, block.tet_count
    assert both.node_count == 2 * n and both.tet_count == 2 * m
    assert both.body_of_node.tolist() == [0] * n + [1] * n
    assert both.body_of_tet.tolist() == [0] * m + [1] * m
    assert block.body_of_node is None
    # Body 1 is body 0 moved by 0.11 m along x (a translation is exact in floating point
    # only up to the sum's rounding: 1 ulp of 0.21 m).
    moved = both.points[n:] - both.points[:n]
    assert np.allclose(moved, [0.11, 0.0, 0.0], rtol=0.0, atol=1e-15)
    # A quarter turn about z maps (x, y, z) to (-y, x, z): cos(pi/2) is 6e-17, not 0.
    turned = tetfem.Mesh.bodies([block], rotations=[((0, 0, 1), 90.0)])
    p = block.points
    assert np.allclose(turned.points, np.column_stack([-p[:, 1], p[:, 0], p[:, 2]]), atol=1e-15)


def test_bodies_refuse_what_they_cannot_place():
    block, _ = two_blocks()
    with pytest.raises(tetfem.InvalidInputError, match="translations.shape"):
        tetfem.Mesh.bodies([block, block], translations=[[0, 0, 0]])
    with pytest.raises(tetfem.InvalidInputError, match="rotations"):
        tetfem.Mesh.bodies([block, block], rotations=[None])
    quadratic = tetfem.Mesh.box(max=(0.1, 0.1, 0.1), cells=(1, 1, 1), order=2)
    with pytest.raises(tetfem.InvalidInputError, match=r"meshes\[1\] order"):
        tetfem.Mesh.bodies([block, quadratic], translations=[[0, 0, 0], [0.2, 0, 0]])
    # Bodies placed into each other: the barrier's set-up names both bodies.
    overlapping = tetfem.Mesh.bodies([block, block], translations=[[0, 0, 0], [0.05, 0, 0]])
    with pytest.raises(tetfem.TetfemError, match="bodies 0 and 1") as caught:
        tetfem.Simulation(
            overlapping, tetfem.Material(1e6, 0.3, 1000.0), tetfem.Constraints(overlapping),
            dt=1e-3, model="neo-hookean", self_contact=True,
        )
    print(caught.value)


@pytest.mark.parametrize("friction", [0.0, 0.5])
def test_head_on_bodies_equal_the_scene_runner_and_keep_momentum(tmp_path, friction):
    scene = tmp_path / "head_on.toml"
    # With friction, body 1 also slides sideways along body 0 (0.5 m/s in y).
    text = HEAD_ON_SCENE.replace("stiffness = 1e3\n", f"stiffness = 1e3\nfriction = {friction}\n")
    text = text.replace("velocity = [-1.0, 0.0, 0.0]", "velocity = [-1.0, 0.5, 0.0]")
    scene.write_text(text)
    summary = tetfem.run_scene(scene, output_dir=tmp_path / "out")
    with open(tmp_path / "out" / "head_on.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    steps = summary["steps"]
    assert steps == 30 and len(rows) == steps + 1

    block, both = two_blocks()
    rubber = tetfem.Material(1e6, 0.3, 1000.0)
    velocity = np.array([[0.0, 0.0, 0.0], [-1.0, 0.5, 0.0]])[both.body_of_node]
    sim = tetfem.Simulation(
        both, rubber, tetfem.Constraints(both), dt=5e-4, model="neo-hookean",
        initial_velocity=velocity, self_contact=True, self_contact_distance=2e-3,
        self_contact_stiffness=1e3, self_contact_friction=friction,
    )
    still = np.flatnonzero(both.body_of_node == 0)
    mass = tetfem.mass_matrix(both, rubber)
    trajectory, momentum = [], []
    def record(s):
        trajectory.append(probe_mean(s.displacement, still))
        p = (mass @ s.velocity.reshape(-1)).reshape(-1, 3)
        momentum.append([p[still, 0].sum(), p[:, 0].sum(), p[still, 1].sum(), p[:, 1].sum()])
    sim.run(steps, callback=record)
    # The same barrier and integrator from the same library calls: equal bits, every step.
    for axis, column in enumerate(["still_ux_m", "still_uy_m", "still_uz_m"]):
        assert [t[axis] for t in trajectory] == [float(r[column]) for r in rows[1:]], column
    momentum = np.array(momentum)
    print(f"friction {friction}: body 0 momentum at the end ({momentum[-1, 0]:.4f}, "
          f"{momentum[-1, 2]:.4f}) N s, total drift {np.abs(momentum[:, 1] + 1.0).max():.2e} N s")
    # Body 1 (1 kg at -1 m/s) reached body 0 (contact from ~4 ms) and pushed it: body 0 took
    # momentum only through the barrier.
    assert momentum[-1, 0] < -0.3
    # The barrier's forces are internal: the total stays -1 N s up to Newton's residual
    # (1e-8 of the step's inertial residual per step, 30 steps: 1e-6 holds it).
    assert np.abs(momentum[:, 1] + 1.0).max() < 1e-6
    assert np.abs(momentum[:, 3] - 0.5).max() < 1e-6
    # Sideways, friction drags body 0 along (0.135 N s measured at mu = 0.5). Without it only
    # the edge-edge pairs where the faces' rims meet push sideways (3.0e-5 N s measured): more
    # than a thousand times less.
    if friction == 0.0:
        assert abs(momentum[-1, 2]) < 1e-4
    else:
        assert momentum[-1, 2] > 0.1


def test_a_block_resting_on_a_clamped_block_carries_its_load_through_the_barrier():
    block = tetfem.Mesh.box(max=(0.1, 0.1, 0.1), cells=(2, 2, 2), split="lecture6")
    stack = tetfem.Mesh.bodies([block, block], translations=[[0, 0, 0], [0, 0, 0.101]])
    constraints = tetfem.Constraints(stack)
    clamp = stack.nodes_on_plane("z", 0.0)
    constraints.fix(clamp)
    # Rollers: the upper block's lateral translations and turn about z (no z force).
    upper = stack.body_of_node == 1
    constraints.fix(np.intersect1d(stack.nodes_on_plane("x", 0.0), np.flatnonzero(upper)), "x")
    constraints.fix(np.intersect1d(stack.nodes_on_plane("y", 0.0), np.flatnonzero(upper)), "y")
    loads = tetfem.Loads(stack).add_total_force(stack.faces_on_plane("z", 0.201), (0, 0, -50.0))
    rubber = tetfem.Material(1e6, 0.3, 1000.0)
    result = tetfem.solve_static(
        stack, rubber, constraints, loads, model="neo-hookean", load_steps=4,
        self_contact=True, self_contact_distance=2e-3, self_contact_stiffness=1e3,
    )
    clamp_z = result.reactions[clamp, 2].sum()
    gap = (stack.points[:, 2] + result.displacement[:, 2])
    opening = gap[upper].min() - gap[~upper].max()
    print(f"clamp z reaction {clamp_z:.12f} N, gap {opening:.4e} m, residual "
          f"{result.relative_residual:.2e}")
    # The 50 N reach the clamp only through the barrier; Newton stops at 1e-10 of the load, so
    # the clamp's sum misses 50 N by at most the free residuals' sum (~20·1e-10·F): 1e-8 holds.
    assert abs(clamp_z - 50.0) <= 1e-8 * 50.0
    # The barrier holds the blocks apart, within its reach d-hat = 2 mm.
    assert 0.0 < opening < 2e-3


def test_friction_between_bodies_is_refused_where_nothing_lags_it():
    block, both = two_blocks()
    rubber = tetfem.Material(1e6, 0.3, 1000.0)
    with pytest.raises(tetfem.InvalidInputError, match="friction"):
        tetfem.solve_static(
            both, rubber, tetfem.Constraints(both).fix(both.nodes_on_plane("z", 0.0)),
            tetfem.Loads(both), model="neo-hookean", self_contact=True,
            self_contact_friction=0.3,
        )
    with pytest.raises(tetfem.InvalidInputError, match="friction"):
        tetfem.Simulation(
            both, rubber, tetfem.Constraints(both), dt=1e-5, method="explicit",
            model="neo-hookean", self_contact=True, self_contact_friction=0.3,
        )
