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
use tetfem::analysis::nonlinear::NewtonOptions;
use tetfem::analysis::{Definition, Static, StaticOptions};
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
/// The total load on the upper block's top face (N, along −z).
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

/// Block 0 at the origin, block 1 `GAP` above it.
fn stacked() -> Bodies {
    let up = Placement::translated(Vector3::new(0.0, 0.0, SIDE + GAP)).unwrap();
    Bodies::new(vec![(block(), Placement::identity()), (block(), up)]).unwrap()
}

/// The two blocks' definition: rubber, `kind`, the supports and load of the module docs.
fn definition(bodies: &Bodies, kind: ModelKind) -> Definition {
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
    let top = mesh.faces_on_plane(&mesh.boundary_faces().unwrap(), 2, 2.0 * SIDE + GAP, tol);
    assert!(!top.is_empty());
    loads
        .add_total_force_on_faces(&mesh, &top, Vector3::new(0.0, 0.0, -F))
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

/// The upper block rests on the lower one: (a) the barrier's force on it balances F, (b) the
/// clamp's reactions balance F, (c) no surface triangles meet and the smallest distance stays
/// positive, at the solution and over every Newton iterate.
fn rests(kind: ModelKind) {
    let bodies = stacked();
    let of = bodies.node_bodies();
    let definition = definition(&bodies, kind);
    let options = StaticOptions {
        newton: NewtonOptions {
            load_steps: 4,
            // The lumped tangent converges linearly (see SurfaceContact's docs): a budget for it.
            max_iterations: 200,
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
    let sink = -u[3 * of.iter().position(|&b| b == 1).unwrap() + 2];
    println!(
        "{kind:?}: {steps} load steps, {iterations} Newton iterations, relative residual \
         {:.3e}; barrier on upper {on_upper:.12e} N, on lower {on_lower:.12e} N, clamp \
         {clamp:.12e} N, rollers z {rollers:.3e} N; smallest distance {distance:.4e} m \
         (d̂ {D_HAT:e}), smallest over iterates {:?}; first upper node sinks {sink:.4e} m",
        outcome.relative_residual, outcome.smallest_surface_distance,
    );
    // Newton stops at ‖r_f‖ ≤ 1e-10·‖f_f‖; a body's z balance misses by the sum of its free
    // z residuals, at most √n_f·‖r_f‖ ≈ 20·1e-10 of F here: 1e-8 holds it with room.
    let tolerance = 1e-8 * F;
    // (a) The barrier holds the upper block up against F (the rollers carry no z force).
    assert!(
        (on_upper - F).abs() <= tolerance,
        "barrier on upper {on_upper} N vs F = {F} N"
    );
    // The barrier's forces on the two bodies are equal and opposite (each pair's gradient
    // sums to zero): round-off of the ~50 pairs' sums, far below the tolerance.
    assert!(
        (on_upper + on_lower).abs() <= tolerance,
        "{on_upper} + {on_lower}"
    );
    // (b) The clamp carries F.
    assert!(
        (clamp - F).abs() <= tolerance,
        "clamp {clamp} N vs F = {F} N"
    );
    // (c) No triangles meet; the blocks touch through the barrier, inside d̂.
    assert!(surface.intersections(u).unwrap().is_empty());
    assert!(distance > 0.0 && distance < D_HAT, "{distance:e}");
    let over_iterates = outcome.smallest_surface_distance.unwrap();
    assert!(
        over_iterates > 0.0 && over_iterates <= distance,
        "{over_iterates:e}"
    );
}

#[test]
fn block_rests_on_clamped_block_linear_model() {
    rests(ModelKind::Linear);
}

#[test]
fn block_rests_on_clamped_block_neo_hookean() {
    rests(ModelKind::NeoHookean);
}
