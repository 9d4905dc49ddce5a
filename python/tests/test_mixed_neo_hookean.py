"""tetfem.mixed_neo_hookean_transient: nearly incompressible Neo-Hookean rubber stepped by
backward Euler in the mixed form (stabilized P1–P1 on 4-node tets, Taylor–Hood P2–P1 on 10-node
tets), from Python: a rubber block dropped on the ground keeps its volume within 1 % through the
impact and no node crosses the ground; the returned volume is the deformed tets' own volume on
4-node tets; a free block in translation moves by exactly v·t; the corotational law
(model="corotational") swings a rubber beam keeping its volume; bad input raises naming the
argument."""
import numpy as np
import pytest

import tetfem

E, NU, RHO = 1e6, 0.499, 1000.0  # soft rubber (Pa, –, kg/m³): κ = 500 μ
SIDE, GAP, SPEED = 0.1, 0.002, 2.0  # the block's edge (m), its height above ground (m), m/s


def block(order):
    """A rubber cube of edge SIDE a gap GAP above the ground z = 0."""
    cells = (4, 4, 4) if order == 1 else (2, 2, 2)
    return tetfem.Mesh.box(
        min=(0.0, 0.0, GAP), max=(SIDE, SIDE, GAP + SIDE), cells=cells, order=order
    )


def drop(order, steps=30):
    mesh = block(order)
    rubber = tetfem.Material(E, NU, RHO)
    loads = tetfem.Loads(mesh).add_gravity((0.0, 0.0, -9.81), rubber)
    ground = tetfem.Obstacle.half_space("ground", (0.0, 0.0, 0.0), (0.0, 0.0, 1.0))
    run = tetfem.mixed_neo_hookean_transient(
        mesh, rubber, tetfem.Constraints(mesh), loads, 1e-3, steps,
        initial_velocity=(0.0, 0.0, -SPEED), obstacles=[ground],
    )
    return mesh, run


def tet_volumes(points, tets):
    """The volume of each 4-node tet of `points` (…, n, 3) (m³), independent of the library."""
    x = points[..., tets, :]  # (…, t, 4, 3)
    a, b, c = (x[..., k, :] - x[..., 0, :] for k in (1, 2, 3))
    return np.einsum("...i,...i->...", np.cross(a, b), c) / 6.0


@pytest.mark.parametrize("order", [1, 2])
def test_a_dropped_rubber_block_keeps_its_volume_above_the_ground(order):
    mesh, run = drop(order)
    frames = 31
    assert run["displacement"].shape == (frames, mesh.node_count, 3)
    assert run["pressure"].shape == (frames, mesh.node_count)
    for key in ("time", "volume_change", "kinetic_energy", "elastic_energy", "smallest_gap",
                "newton_iterations"):
        assert run[key].shape == (frames,), key
    np.testing.assert_allclose(run["time"], 1e-3 * np.arange(frames), rtol=1e-12)
    z = mesh.points[:, 2] + run["displacement"][..., 2]  # (frames, n)
    lowest, height = z.min(), (z.max(axis=1) - z.min(axis=1)).min()
    print(f"order {order} ({run['element']}): |V/V0 − 1| ≤ {np.abs(run['volume_change']).max():.3e}, "
          f"lowest node {lowest:.3e} m, least height {height:.5f} m, smallest gap {run['smallest_gap'].min():.3e} m, "
          f"peak pressure {run['pressure'].max():.4e} Pa, Newton {run['newton_iterations'].sum()}")
    assert run["element"] == ("stabilized P1–P1" if order == 1 else "Taylor–Hood P2–P1")
    # The target: the volume within 1 % through the impact (J − 1 ≈ −p/κ, κ = 167 MPa).
    assert np.abs(run["volume_change"]).max() < 0.01
    # The barrier keeps every node above the ground at every accepted step.
    assert lowest > 0.0 and run["smallest_gap"].min() > 0.0
    # It did hit the ground: the impact compressed it (positive pressure, a smaller height).
    assert run["pressure"].max() > 0.0 and run["smallest_gap"].min() < GAP
    assert height < SIDE
    assert run["newton_iterations"][0] == 0 and (run["newton_iterations"][1:] > 0).all()


def test_the_volume_is_the_deformed_tets_own_on_four_node_tets():
    mesh, run = drop(1, steps=20)
    deformed = mesh.points + run["displacement"]
    volumes = tet_volumes(deformed, mesh.tets).sum(axis=-1)
    rest = tet_volumes(mesh.points, mesh.tets).sum()
    # det F·V per tet is the deformed tet's volume: one number by two formulas, to round-off.
    np.testing.assert_allclose(run["volume_change"], volumes / rest - 1.0, rtol=0, atol=1e-12)


def test_a_free_block_in_translation_moves_by_v_t():
    # No load and a uniform velocity: the internal force of a rigid translation is zero, so
    # backward Euler's predictor u + dt·v is each step's solution, exactly.
    mesh = block(1)
    rubber = tetfem.Material(E, NU, RHO)
    v = np.array([0.3, -0.2, 0.5])
    run = tetfem.mixed_neo_hookean_transient(
        mesh, rubber, tetfem.Constraints(mesh), tetfem.Loads(mesh), 1e-2, 5, initial_velocity=v
    )
    expected = run["time"][:, None, None] * v
    # Round-off of t·v summed over five steps (1e-15 m on displacements of 2e-2 m).
    np.testing.assert_allclose(run["displacement"], np.broadcast_to(expected, run["displacement"].shape),
                               rtol=0, atol=1e-14)
    np.testing.assert_allclose(run["pressure"], 0.0, atol=1e-6)  # Pa, against κ = 1.7e8
    np.testing.assert_allclose(run["kinetic_energy"], 0.5 * RHO * SIDE**3 * v @ v, rtol=1e-12)


def test_friction_on_the_ground_decelerates_a_sliding_block_at_mu_g():
    # A flat block 0.1 mm above the ground sliding along x at 1 m/s, pressed on the ground by
    # gravity. Frictionless, nothing pushes along x (the ground's normal is z): every node
    # moves by t along x. With μ = 0.3, Coulomb's μ·m·g decelerates it at μ·g once it rests
    # on the ground (the first steps press it from its start inside the barrier's reach).
    mesh = tetfem.Mesh.box(min=(0.0, 0.0, 1e-4), max=(0.1, 0.1, 0.0501), cells=(4, 4, 2), order=1)
    rubber = tetfem.Material(E, NU, RHO)
    loads = tetfem.Loads(mesh).add_gravity((0.0, 0.0, -9.81), rubber)
    steps, dt, mu, settled = 40, 1e-3, 0.3, 10

    def slide(friction):
        ground = tetfem.Obstacle.half_space("ground", (0, 0, 0), (0, 0, 1), friction=friction)
        run = tetfem.mixed_neo_hookean_transient(
            mesh, rubber, tetfem.Constraints(mesh), loads, dt, steps,
            initial_velocity=(1.0, 0.0, 0.0), obstacles=[ground],
        )
        return run["time"], run["displacement"][:, :, 0].mean(axis=1)

    t, smooth = slide(0.0)
    _, rough = slide(mu)
    # x(t) − t is a parabola of curvature −μg/2 from `settled` on: fit it.
    deceleration = -2.0 * np.polyfit(t[settled:], rough[settled:] - t[settled:], 2)[0]
    print(f"frictionless |x − t| ≤ {np.abs(smooth - t).max():.1e} m; μ = {mu}: deceleration "
          f"{deceleration:.4f} m/s² (μg = {mu * 9.81:.4f})")
    # An identity of the frictionless run: round-off of t over 40 steps.
    np.testing.assert_allclose(smooth, t, rtol=0, atol=1e-14)
    # The lagged friction's normal force is the settled block's weight, its smoothing acts
    # below a slip of ε_v·dt, far below the 1 mm a step here (measured 2e-3 off μg): 1 %.
    assert abs(deceleration / (mu * 9.81) - 1.0) < 0.01


def test_bad_input_raises_naming_the_argument():
    mesh = block(1)
    rubber = tetfem.Material(E, NU, RHO)
    constraints, loads = tetfem.Constraints(mesh), tetfem.Loads(mesh)
    run = tetfem.mixed_neo_hookean_transient
    with pytest.raises(tetfem.InvalidInputError, match="dt"):
        run(mesh, rubber, constraints, loads, -1e-3, 2)
    with pytest.raises(tetfem.InvalidInputError, match="tolerance"):
        run(mesh, rubber, constraints, loads, 1e-3, 2, tolerance=2.0)
    with pytest.raises(tetfem.InvalidInputError, match="initial_velocity"):
        run(mesh, rubber, constraints, loads, 1e-3, 2, initial_velocity=np.zeros((5, 3)))
    moving = tetfem.Obstacle.half_space("floor", (0, 0, 0), (0, 0, 1)).moving(velocity=(0, 0, 1))
    with pytest.raises(tetfem.InvalidInputError, match="floor motion"):
        run(mesh, rubber, constraints, loads, 1e-3, 2, obstacles=[moving])
    inside = tetfem.Obstacle.half_space("wall", (0, 0, 0.05), (0, 0, 1))
    with pytest.raises(tetfem.TetfemError, match="wall"):
        run(mesh, rubber, constraints, loads, 1e-3, 2, obstacles=[inside])
    timed = tetfem.Loads(mesh).add_gravity((0, 0, -9.81), rubber, amplitude=tetfem.Amplitude.ramp())
    with pytest.raises(tetfem.InvalidInputError, match="loads"):
        run(mesh, rubber, constraints, timed, 1e-3, 2)
    other = block(2)
    with pytest.raises(tetfem.InvalidInputError):
        run(other, rubber, constraints, loads, 1e-3, 2)


@pytest.mark.parametrize("order", [1, 2])
def test_a_corotational_rubber_beam_swings_keeping_its_volume(order):
    # The corotational law (model="corotational") in the same mixed backward Euler: a soft
    # rubber cantilever (1 × 0.1 × 0.1 m, E = 1 MPa, ν = 0.4999) released under gravity swings
    # down by a large part of its length within 0.2 s.
    mesh = tetfem.Mesh.box(max=(1.0, 0.1, 0.1), cells=(10, 1, 1) if order == 1 else (5, 1, 1),
                           order=order)
    rubber = tetfem.Material(1e6, 0.4999, RHO)
    constraints = tetfem.Constraints(mesh).fix(mesh.nodes_on_plane("x", 0.0))
    loads = tetfem.Loads(mesh).add_gravity((0.0, 0.0, -9.81), rubber)
    run = tetfem.mixed_neo_hookean_transient(mesh, rubber, constraints, loads, 1e-2, 20,
                                             model="corotational")
    tip = mesh.nodes_on_plane("x", 1.0)
    fall = run["displacement"][:, tip, 2].mean(axis=1).min()
    energy = run["kinetic_energy"] + run["elastic_energy"]
    print(f"order {order}: corotational tip fall {fall:.4f} m, |V/V0 − 1| ≤ "
          f"{np.abs(run['volume_change']).max():.2e}, Newton {run['newton_iterations'].sum()}")
    assert run["model"] == "corotational"
    # A large swing (a fifth of the length), not a small-strain one.
    assert fall < -0.2
    # The 1 %: the corotational law holds tr ε = −p/κ, J − 1 differs by the strain's
    # square (a few 1e-3 at this swing's strain).
    assert np.abs(run["volume_change"]).max() < 0.01
    # The stored energy is the law's, positive once the beam bends.
    assert (energy[1:] > 0.0).all()


def test_a_model_without_a_mixed_law_is_refused_by_the_library_naming_it():
    mesh = block(1)
    rubber = tetfem.Material(E, NU, RHO)
    constraints, loads = tetfem.Constraints(mesh), tetfem.Loads(mesh)
    with pytest.raises(tetfem.InvalidInputError, match="st-venant-kirchhoff"):
        tetfem.mixed_neo_hookean_transient(mesh, rubber, constraints, loads, 1e-3, 2,
                                           model="st_venant_kirchhoff")
