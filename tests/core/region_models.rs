//! A force model per material region (issue 36: "each body with its … force model"): a
//! [`ModelMap`] of a kind per material ([`ModelMap::with_kinds`]), a definition's
//! `region_models`, and the library's rule of what a mix may be combined with.

use nalgebra::Vector3;
use tetfem::analysis::combination::Formulation;
use tetfem::analysis::dynamics::{InternalForce, Method, StepNewtonOptions};
use tetfem::analysis::nonlinear::NewtonOptions;
use tetfem::analysis::transient::{TimeStep, Transient, TransientOptions, Unobserved};
use tetfem::analysis::{Analysis, Combination, Definition, Static, StaticOptions};
use tetfem::contact::surface::SurfaceBarrier;
use tetfem::fe::materials::MaterialMap;
use tetfem::mesh::bodies::{Bodies, Placement};
use tetfem::model::{ModelKind, ModelMap};
use tetfem::{Constraints, Loads, TetMesh};

use crate::self_contact_solve::{D_HAT, KAPPA, SIDE, block, body_momenta, rubber, two_blocks};

/// Where body B starts along x (m): 5 cm beyond A, far out of reach of each other.
const B_AT: f64 = SIDE + 0.05;
/// The total tip load (N, along z): 500 N on a 0.1 m rubber cube (E = 1 MPa) bends it by
/// strains of several percent, where the Neo-Hookean and linear answers differ visibly.
const TIP_LOAD: f64 = 500.0;

/// The materials of `bodies`: the same rubber, one material per body (named `body 0`, …).
fn per_body(bodies: &Bodies) -> MaterialMap {
    let of_tet = bodies.tet_bodies().iter().map(|&b| b as u32).collect();
    let names = (0..bodies.count()).map(|b| format!("body {b}")).collect();
    MaterialMap::new(vec![rubber(); bodies.count()], names, of_tet).unwrap()
}

/// Each body clamped on its face at x = `starts[b]` and loaded by [`TIP_LOAD`] along z spread
/// over the nodes of its face at x = `starts[b]` + SIDE.
fn held_and_loaded(mesh: &TetMesh, starts: &[f64]) -> (Constraints, Loads) {
    let mut constraints = Constraints::new(mesh);
    let mut loads = Loads::new(mesh);
    for &x in starts {
        constraints
            .fix_nodes(&mesh.nodes_on_plane(0, x, 1e-9))
            .unwrap();
        let tip = mesh.nodes_on_plane(0, x + SIDE, 1e-9);
        for &n in &tip {
            let share = TIP_LOAD / tip.len() as f64;
            loads
                .add_nodal_force(n, Vector3::new(0.0, 0.0, share))
                .unwrap();
        }
    }
    (constraints, loads)
}

/// Newton to its round-off floor: the combined run and each body alone then stop where the
/// forces' round-off does, not at a tolerance relative to different loads.
fn options() -> StaticOptions {
    StaticOptions {
        newton: NewtonOptions {
            tolerance: 1e-14,
            load_steps: 4,
            ..NewtonOptions::default()
        },
        ..StaticOptions::default()
    }
}

/// The static solution of `mesh` under `materials` with the models `kinds` (one per material).
fn solve(
    mesh: &TetMesh,
    materials: MaterialMap,
    kinds: Vec<ModelKind>,
    starts: &[f64],
) -> Vec<f64> {
    let (constraints, loads) = held_and_loaded(mesh, starts);
    let definition = Definition::builder(mesh.clone(), materials)
        .model(kinds[0])
        .region_models(kinds)
        .unwrap()
        .constraints(constraints)
        .unwrap()
        .loads(loads)
        .unwrap()
        .build()
        .unwrap();
    Static::new(&definition, options())
        .unwrap()
        .solve()
        .unwrap()
        .displacement
}

fn max_abs(v: &[f64]) -> f64 {
    v.iter().fold(0.0, |m, x| m.max(x.abs()))
}

fn max_diff(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).fold(0.0, |m, (x, y)| m.max((x - y).abs()))
}

#[test]
fn a_linear_and_a_neo_hookean_body_solve_as_each_alone() {
    let cells = 2;
    let b_place = Placement::translated(Vector3::new(B_AT, 0.0, 0.0)).unwrap();
    let bodies = Bodies::new(vec![
        (block(cells), Placement::identity()),
        (block(cells), b_place),
    ])
    .unwrap();
    let mesh = bodies.mesh().clone();
    let both = solve(
        &mesh,
        per_body(&bodies),
        vec![ModelKind::Linear, ModelKind::NeoHookean],
        &[0.0, B_AT],
    );
    // Each body alone, on the same coordinates (B placed by the same placement).
    let a = block(cells);
    let a_alone = solve(
        &a,
        MaterialMap::uniform(rubber(), a.tet_count()),
        vec![ModelKind::Linear],
        &[0.0],
    );
    let b = Bodies::new(vec![(block(cells), b_place)])
        .unwrap()
        .mesh()
        .clone();
    let b_alone = solve(
        &b,
        MaterialMap::uniform(rubber(), b.tet_count()),
        vec![ModelKind::NeoHookean],
        &[B_AT],
    );
    let b_linear = solve(
        &b,
        MaterialMap::uniform(rubber(), b.tet_count()),
        vec![ModelKind::Linear],
        &[B_AT],
    );
    let split = 3 * a.node_count();
    let (both_a, both_b) = both.split_at(split);
    let scale = max_abs(&both);
    let (da, db) = (max_diff(both_a, &a_alone), max_diff(both_b, &b_alone));
    let model_gap = max_diff(&b_alone, &b_linear);
    println!(
        "max |u| {scale:.4e} m; body 0 (linear) vs alone {da:.3e} m, body 1 (neo-hookean) vs \
         alone {db:.3e} m; neo-hookean vs linear on body 1 {model_gap:.3e} m"
    );
    // The model mattered: B's two models differ by percents of |u|.
    assert!(model_gap > 1e-2 * scale, "{model_gap:e}");
    // Round-off, not a tolerance: the bodies share no tet, so the combined tangent is block
    // diagonal and each body's equations are the alone ones; what differs is the order of
    // the factorization's sums (one ordering of both) and how many Newton iterations the
    // common loop takes (the linear alone run is one linear solve). Newton runs to its
    // round-off floor in both, so the answers agree to that floor: 1e-10 of |u| is 10⁶ ε,
    // the conditioning of a soft cube's stiffness (E·h ~ 1e5 N/m against its 10⁻¹⁶ relative
    // round-off per sum) with margin.
    assert!(da <= 1e-10 * scale, "{da:e}");
    assert!(db <= 1e-10 * scale, "{db:e}");
}

#[test]
fn every_region_linear_is_the_linear_fast_path_bit_for_bit() {
    let bodies = two_blocks(2, 0.05);
    let mesh = bodies.mesh().clone();
    let starts = [0.0, SIDE + 0.05];
    let (constraints, loads) = held_and_loaded(&mesh, &starts);
    let build = |kinds: Option<Vec<ModelKind>>| {
        let builder = Definition::builder(mesh.clone(), per_body(&bodies))
            .constraints(constraints.clone())
            .unwrap()
            .loads(loads.clone())
            .unwrap();
        match kinds {
            Some(k) => builder.region_models(k).unwrap().build().unwrap(),
            None => builder.build().unwrap(),
        }
    };
    let plain = build(None);
    let listed = build(Some(vec![ModelKind::Linear; 2]));
    let (p, l) = (
        Static::new(&plain, options()).unwrap(),
        Static::new(&listed, options()).unwrap(),
    );
    assert!(p.is_linear_path() && l.is_linear_path());
    assert_eq!(
        p.solve().unwrap().displacement,
        l.solve().unwrap().displacement
    );
    // The transient force is the linear fast path too.
    let run = Transient::new(
        &listed,
        TransientOptions::new(Method::BackwardEuler, TimeStep::Seconds(1e-3)),
    )
    .unwrap();
    assert!(matches!(run.force(), InternalForce::Linear));
}

#[test]
fn a_linear_and_a_neo_hookean_block_collide_conserving_momentum() {
    let bodies = two_blocks(2, 0.004);
    let mesh = bodies.mesh().clone();
    let definition = Definition::builder(mesh, per_body(&bodies))
        .region_models(vec![ModelKind::Linear, ModelKind::NeoHookean])
        .unwrap()
        .surface_contact(
            SurfaceBarrier::new(D_HAT, KAPPA).unwrap(),
            bodies.node_bodies(),
        )
        .unwrap()
        .build()
        .unwrap();
    let mut options = TransientOptions::new(Method::BackwardEuler, TimeStep::Seconds(1e-3));
    // The momentum error of a step is dt·Σr over the x DOFs of its last residual (the
    // internal and barrier forces sum to zero): 1e-11 of the inertial residual keeps the
    // drift far below the 1e-9 asked (as in tests/core/self_contact_solve.rs).
    options.solver.newton = StepNewtonOptions {
        tolerance: 1e-11,
        max_iterations: 200,
        relax_contact_nodes: true,
    };
    let mut run = Transient::new(&definition, options).unwrap();
    let force = match run.force() {
        InternalForce::Nonlinear(force) => std::sync::Arc::clone(force),
        InternalForce::Linear => panic!("a Neo-Hookean region and the barrier step through Newton"),
    };
    assert_eq!(force.name(), "per-material");
    let v = [Vector3::new(1.0, 0.0, 0.0), Vector3::new(-1.0, 0.0, 0.0)];
    run.state_mut().velocity = bodies.velocity(&v).unwrap();
    let system = std::sync::Arc::clone(run.system());
    let start = body_momenta(&system, &bodies, &run.state().velocity);
    let scale: f64 = start.iter().map(|(_, p)| p.abs()).sum();
    let contact = force.surface_contact().unwrap();
    let (mut drift, mut smallest) = (0.0f64, f64::INFINITY);
    let relative = |velocity: &[f64]| {
        let p = body_momenta(&system, &bodies, velocity);
        p[1].1 / p[1].0 - p[0].1 / p[0].0
    };
    let approach = relative(&run.state().velocity);
    for step in 0..14 {
        run.run((step, step + 1), &mut Unobserved).unwrap();
        let state = run.state();
        let p: f64 = body_momenta(&system, &bodies, &state.velocity)
            .iter()
            .map(|(_, p)| p)
            .sum();
        drift = drift.max(p.abs() / scale);
        smallest = smallest.min(contact.smallest_distance(&state.displacement).unwrap());
        assert!(
            contact
                .intersections(&state.displacement)
                .unwrap()
                .is_empty()
        );
    }
    let parting = relative(&run.state().velocity);
    println!(
        "linear + neo-hookean head on: momentum drift {drift:.2e}, smallest distance \
         {smallest:.3e} m, relative velocity {approach:.3} → {parting:.3} m/s"
    );
    // They met (within d̂) and turned: the barrier acted between the two models' bodies.
    assert!(smallest > 0.0 && smallest < D_HAT, "{smallest:e}");
    assert!(parting > approach, "{approach} → {parting}");
    // 1e-9: the bound; the barrier and element forces are internal.
    assert!(drift <= 1e-9, "{drift:e}");
}

#[test]
fn the_rule_refuses_a_nonlinear_region_in_modal_and_any_mix_in_mixed_by_name() {
    let bodies = two_blocks(1, 0.05);
    let mesh = bodies.mesh().clone();
    let definition = Definition::builder(mesh.clone(), per_body(&bodies))
        .region_models(vec![ModelKind::Linear, ModelKind::NeoHookean])
        .unwrap()
        .build()
        .unwrap();
    let error = definition.check(Analysis::Modal).unwrap_err().to_string();
    println!("{error}");
    assert!(
        error.contains("body 1") && error.contains("neo-hookean") && error.contains("modal"),
        "{error}"
    );
    for analysis in [Analysis::Static, Analysis::Transient(Method::Explicit)] {
        assert!(definition.check(analysis).is_ok());
    }
    let mixed = Combination {
        formulation: Formulation::Mixed,
        order: 2,
        ..definition.combination(Analysis::Static)
    };
    let error = mixed.check().unwrap_err().to_string();
    println!("{error}");
    assert!(
        error.contains("mixed") && error.contains("body 1") && error.contains("neo-hookean"),
        "{error}"
    );
    // Linear regions only: modal runs them.
    let linear = Definition::builder(mesh.clone(), per_body(&bodies))
        .region_models(vec![ModelKind::Linear; 2])
        .unwrap()
        .build()
        .unwrap();
    assert!(linear.check(Analysis::Modal).is_ok());
    // Not one kind per material: named with both counts, by the builder and by the map.
    let error = Definition::builder(mesh.clone(), per_body(&bodies))
        .region_models(vec![ModelKind::Linear])
        .unwrap_err()
        .to_string();
    assert!(
        error.contains("1 kinds") && error.contains("2 materials"),
        "{error}"
    );
    let error = ModelMap::with_kinds(vec![ModelKind::Linear; 3], &per_body(&bodies))
        .unwrap_err()
        .to_string();
    assert!(
        error.contains("3 kinds") && error.contains("2 materials"),
        "{error}"
    );
    // The map answers the fast paths' questions.
    let map = ModelMap::with_kinds(
        vec![ModelKind::Linear, ModelKind::Corotational],
        &per_body(&bodies),
    )
    .unwrap();
    assert_eq!(map.kinds(), [ModelKind::Linear, ModelKind::Corotational]);
    assert!(!map.is_linear() && map.uniform_kind().is_none());
    assert_eq!(map.name(), "per-material");
    let uniform = ModelMap::new(ModelKind::Linear, &per_body(&bodies));
    assert!(uniform.is_linear() && uniform.uniform_kind() == Some(ModelKind::Linear));
}
