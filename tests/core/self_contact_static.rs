//! Body–body contact in static equilibrium (issue 36): two blocks of one mesh ([`Bodies`]),
//! one resting on the other, solved by the static analysis of a [`Definition`] with
//! `surface_contact` ([`Static`]) — Newton over load steps with the surface barrier's energy,
//! force and lumped PSD tangent, every line search bounded by the collision-free step.
//!
//! The supports make the problem well posed with nothing the contact should carry held twice:
//! the lower block is clamped on its bottom face (z = 0); the upper one has rollers only — u_x = 0
//! on its x = 0 face and u_y = 0 on its y = 0 face, which hold its two lateral translations and
//! its turn about z and carry no z force. Its z translation and its turns about x and y are held
//! by the barrier alone, so every newton of the load F on its top face reaches the lower block
//! through the contact and the clamp: both balances below are exact identities up to Newton's
//! residual.

use nalgebra::Vector3;
use tetfem::analysis::dynamics::Method;
use tetfem::analysis::nonlinear::NewtonOptions;
use tetfem::analysis::transient::{TimeStep, Transient, TransientOptions, Unobserved};
use tetfem::analysis::{Definition, Static, StaticOptions};
use tetfem::bc::constraints::DofMap;
use tetfem::contact::surface::{SurfaceBarrier, SurfaceContact};
use tetfem::fe::materials::MaterialMap;
use tetfem::mesh::bodies::{Bodies, Placement};
use tetfem::model::ModelKind;
use tetfem::{BoxSplit, Constraints, Loads, Material, TetMesh};

const SIDE: f64 = 0.1;
/// d̂ (m): well below the 0.05 m surface edges of a 2-cell block (no reach warning).
const D_HAT: f64 = 2e-3;
/// κ (J/m²): as the head-on tests (tests/core/self_contact_solve.rs): at d = d̂/10 the facing
/// faces' pairs push with ≈ 1 kN, well above F, so the equilibrium gap lies inside (d̂/10, d̂).
const KAPPA: f64 = 1e3;
/// The gap at rest (m): inside d̂, so the barrier holds the upper block from the first load step.
const GAP: f64 = 0.5 * D_HAT;
/// The total load on the upper block's top face (N, along −z): at 50 N the barrier at the rest
/// gap pushes harder than F and opens it (the lower block's top sinks by ~0.5 mm); ten times
/// F closes it.
const F: f64 = 50.0;

fn block() -> TetMesh {
    TetMesh::box_grid(
        Vector3::zeros(),
        Vector3::repeat(SIDE),
        [2; 3],
        BoxSplit::Lecture6,
    )
    .unwrap()
}

/// Block 0 at the origin, block 1 `gap` (m) above it.
fn stacked(gap: f64) -> Bodies {
    let up = Placement::translated(Vector3::new(0.0, 0.0, SIDE + gap)).unwrap();
    Bodies::new(vec![(block(), Placement::identity()), (block(), up)]).unwrap()
}

/// The two blocks' definition: rubber, `kind`, the supports of the module docs and the load
/// `force` (N, along −z) on the upper block's top face, `gap` (m) the blocks' gap at rest.
fn definition(bodies: &Bodies, kind: ModelKind, gap: f64, force: f64) -> Definition {
    let mesh = bodies.mesh().clone();
    let of = bodies.node_bodies();
    let tol = 1e-9;
    let mut constraints = Constraints::new(&mesh);
    constraints
        .fix_nodes(&mesh.nodes_on_plane(2, 0.0, tol))
        .unwrap();
    let upper = |nodes: Vec<usize>| {
        nodes
            .into_iter()
            .filter(|&n| of[n] == 1)
            .collect::<Vec<_>>()
    };
    constraints
        .fix_axes(
            &upper(mesh.nodes_on_plane(0, 0.0, tol)),
            [true, false, false],
        )
        .unwrap();
    constraints
        .fix_axes(
            &upper(mesh.nodes_on_plane(1, 0.0, tol)),
            [false, true, false],
        )
        .unwrap();
    let mut loads = Loads::new(&mesh);
    let top = mesh.faces_on_plane(&mesh.boundary_faces().unwrap(), 2, 2.0 * SIDE + gap, tol);
    assert!(!top.is_empty());
    loads
        .add_total_force_on_faces(&mesh, &top, Vector3::new(0.0, 0.0, -force))
        .unwrap();
    let rubber = Material::new(1e6, 0.3, 1000.0).unwrap();
    let materials = MaterialMap::uniform(rubber, mesh.tet_count());
    Definition::builder(mesh, materials)
        .model(kind)
        .constraints(constraints)
        .unwrap()
        .loads(loads)
        .unwrap()
        .surface_contact(SurfaceBarrier::new(D_HAT, KAPPA).unwrap(), of)
        .unwrap()
        .build()
        .unwrap()
}

/// Σ over the nodes of `body` of the z components of `force` (N).
fn z_sum(force: &[f64], of: &[usize], body: usize) -> f64 {
    (0..of.len())
        .filter(|&n| of[n] == body)
        .map(|n| force[3 * n + 2])
        .sum()
}

/// The upper block rests on the lower one under `force` (N): (a) the barrier's force on it
/// balances the load, (b) the clamp's reactions balance it, (c) no surface triangles meet and
/// the smallest distance stays positive, at the solution and over every Newton iterate.
/// Returns the definition, the static displacement and the smallest distance there (m).
fn rests(kind: ModelKind, force: f64) -> (Definition, Vec<f64>, f64) {
    let bodies = stacked(GAP);
    let of = bodies.node_bodies();
    let definition = definition(&bodies, kind, GAP, force);
    let options = StaticOptions {
        newton: NewtonOptions {
            load_steps: 4,
            ..NewtonOptions::default()
        },
        ..StaticOptions::default()
    };
    let analysis = Static::new(&definition, options).unwrap();
    assert!(analysis.warnings().is_empty(), "{:?}", analysis.warnings());
    assert!(!analysis.is_linear_path());
    let outcome = analysis.solve().unwrap();
    let u = &outcome.displacement;
    let (steps, iterations) = outcome.newton_counts().unwrap();
    let surface = SurfaceContact::new(
        bodies.mesh(),
        &of,
        definition.surface_contact.as_ref().unwrap().barrier,
    )
    .unwrap();
    let mut barrier = vec![0.0; u.len()];
    surface.add_force(u, &mut barrier).unwrap();
    let on_upper = z_sum(&barrier, &of, 1);
    let on_lower = z_sum(&barrier, &of, 0);
    let clamp = z_sum(&outcome.reactions, &of, 0);
    let rollers = z_sum(&outcome.reactions, &of, 1);
    let distance = surface.smallest_distance(u).unwrap();
    println!(
        "{kind:?}, F = {force} N: {steps} load steps, {iterations} Newton iterations, relative \
         residual {:.3e}; barrier on upper {on_upper:.12e} N, on lower {on_lower:.12e} N, \
         clamp {clamp:.12e} N, rollers z {rollers:.3e} N; smallest distance {distance:.4e} m \
         (rest gap {GAP:e}, d̂ {D_HAT:e}), smallest over iterates {:?}",
        outcome.relative_residual, outcome.smallest_surface_distance,
    );
    // Newton stops at ‖r_f‖ ≤ 1e-10·‖f_f‖; a body's z balance misses by the sum of its free
    // z residuals, at most √n_f·‖r_f‖ ≈ 20·1e-10 of the load here: 1e-8 holds it with room.
    let tolerance = 1e-8 * force;
    // (a) The barrier holds the upper block up against the load (the rollers carry no z).
    assert!(
        (on_upper - force).abs() <= tolerance,
        "barrier on upper {on_upper} N vs F = {force} N"
    );
    // The barrier's forces on the two bodies are equal and opposite (each pair's gradient
    // sums to zero): round-off of the pairs' sums, far below the tolerance.
    assert!(
        (on_upper + on_lower).abs() <= tolerance,
        "{on_upper} + {on_lower}"
    );
    // (b) The clamp carries the load.
    assert!(
        (clamp - force).abs() <= tolerance,
        "clamp {clamp} N vs F = {force} N"
    );
    // The load has no lateral part: the supports' lateral reactions (the clamp's and the
    // rollers', against the blocks' Poisson spread) sum to zero to the same tolerance.
    for axis in 0..2 {
        let lateral: f64 = outcome.reactions.iter().skip(axis).step_by(3).sum();
        assert!(lateral.abs() <= tolerance, "axis {axis}: Σ R = {lateral} N");
    }
    // (c) No triangles meet; the blocks touch through the barrier, inside d̂.
    assert!(surface.intersections(u).unwrap().is_empty());
    assert!(distance > 0.0 && distance < D_HAT, "{distance:e}");
    let over_iterates = outcome.smallest_surface_distance.unwrap();
    assert!(
        over_iterates > 0.0 && over_iterates <= distance,
        "{over_iterates:e}"
    );
    (definition, u.clone(), distance)
}

#[test]
fn block_rests_on_clamped_block_linear_model() {
    rests(ModelKind::Linear, F);
}

#[test]
fn block_rests_on_clamped_block_neo_hookean() {
    let (_, _, light) = rests(ModelKind::NeoHookean, F);
    // Ten times the load closes the gap, below the rest gap (the barrier's force falls with
    // distance, so a larger load is held nearer).
    let (_, _, heavy) = rests(ModelKind::NeoHookean, 10.0 * F);
    assert!(heavy < light && heavy < GAP, "{heavy:e} vs {light:e}");
}

/// The static answer is backward Euler's long-time limit: with a step far above the blocks'
/// periods (~10 ms) each step is a static solve plus a mass term M/Δt² ~ 1e-7 of the
/// stiffness, so a few steps from rest settle onto the static state.
#[test]
fn static_rest_is_backward_eulers_limit() {
    let (definition, u_static, _) = rests(ModelKind::NeoHookean, F);
    let options = TransientOptions::new(Method::BackwardEuler, TimeStep::Seconds(10.0));
    let mut run = Transient::new(&definition, options).unwrap();
    run.run((0, 5), &mut Unobserved).unwrap();
    let u_dynamic = DofMap::new(&definition.constraints)
        .expand(&run.state().displacement)
        .unwrap();
    let largest = u_static.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
    let apart = u_static
        .iter()
        .zip(&u_dynamic)
        .fold(0.0_f64, |m, (a, b)| m.max((a - b).abs()));
    println!("backward Euler (5 steps of 10 s) vs static: {apart:.3e} m of {largest:.3e} m");
    // Each step's mass term M/Δt² ≈ 1 kg/100 s² is ~1e-7 of the ~1e5 N/m stiffness, and
    // the steps' Newton tolerance leaves its own error: 1e-6 of the largest displacement
    // holds both with room.
    assert!(apart <= 1e-6 * largest, "{apart:e} of {largest:e}");
}

/// An upper block beyond d̂ is held by nothing at the first load step (the rollers leave its
/// z translation free, and no pair is within d̂): an error, not a panic nor a block flying off.
#[test]
fn block_beyond_the_barrier_reach_is_an_error() {
    let gap = 2.0 * D_HAT;
    let definition = definition(&stacked(gap), ModelKind::NeoHookean, gap, F);
    let err = Static::new(&definition, StaticOptions::default())
        .unwrap()
        .solve()
        .unwrap_err();
    println!("beyond d̂: {err}");
    // The factorization finds the free direction (the upper block's z translation).
    assert!(err.to_string().contains("not positive definite"), "{err}");
}
