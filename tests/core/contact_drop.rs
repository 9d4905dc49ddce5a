//! A soft block dropped onto rigid ground (issue 18, item 2): backward Euler at 100× the
//! explicit critical step with the IPC barrier, compared with the static contact solution.

use std::sync::Arc;

use nalgebra::Vector3;
use tetfem::analysis::dynamics::{
    BackwardEuler, Integrator, IntegratorOptions, InternalForce, LinearSystem, MassKind, Newmark,
    NonlinearForce, Rayleigh, State, SymplecticEuler, critical_time_step,
};
use tetfem::analysis::nonlinear::{NewtonOptions, solve_nonlinear_static_with_contact};
use tetfem::contact::{Contact, ContactParameters, Obstacle};
use tetfem::model::ModelKind;
use tetfem::{BoxSplit, Constraints, Loads, Material, TetMesh};

pub(crate) const SIDE: f64 = 0.2;
pub(crate) const DROP: f64 = 0.02;

/// A 20 cm rubber block (E = 100 kPa, 4×4×4 cells) with its underside DROP above z = 0, held
/// on its two mirror planes.
pub(crate) fn block() -> (TetMesh, Material, Constraints) {
    let mesh = TetMesh::box_grid(
        Vector3::new(0.0, 0.0, DROP),
        Vector3::new(SIDE, SIDE, DROP + SIDE),
        [4, 4, 4],
        BoxSplit::Lecture6,
    )
    .unwrap();
    let rubber = Material::new(1e5, 0.3, 1000.0).unwrap();
    // Frictionless contact leaves x, y and the turn about z free: hold them on the block's
    // two mirror planes, where the symmetric solution has no x (resp. y) motion, so the
    // constraints carry no reaction.
    let mut constraints = Constraints::new(&mesh);
    constraints
        .fix_axes(
            &mesh.nodes_on_plane(0, 0.5 * SIDE, 1e-9),
            [true, false, false],
        )
        .unwrap();
    constraints
        .fix_axes(
            &mesh.nodes_on_plane(1, 0.5 * SIDE, 1e-9),
            [false, true, false],
        )
        .unwrap();
    (mesh, rubber, constraints)
}

fn ground(height: f64) -> Obstacle {
    Obstacle::half_space("ground", Vector3::new(0.0, 0.0, height), Vector3::z()).unwrap()
}

#[test]
fn backward_euler_drop_at_100x_the_critical_step_rests_on_the_static_solution() {
    let (mesh, rubber, constraints) = block();
    let gravity = Vector3::new(0.0, 0.0, -9.81);
    let parameters = ContactParameters::for_mesh(&mesh, rubber.youngs_modulus()).unwrap();
    let d_hat = parameters.activation_distance;
    let loads = Loads::new(&mesh);
    let system = LinearSystem::new_free_body(
        &mesh,
        &rubber,
        &constraints,
        &loads,
        gravity,
        MassKind::Lumped,
        Rayleigh::default(),
    )
    .unwrap();
    let critical = critical_time_step(&system).unwrap().dt;
    let dt = 100.0 * critical;
    let contact = Contact::new(&mesh, vec![ground(0.0)], parameters).unwrap();
    let mesh = Arc::new(mesh);
    let force = NonlinearForce::new(
        Arc::clone(&mesh),
        ModelKind::NeoHookean.build(&rubber),
        &system,
    )
    .unwrap()
    .with_contact(contact)
    .unwrap();
    let force = Arc::new(force);
    let system = Arc::new(system);
    let mut integrator = BackwardEuler::with_force(
        Arc::clone(&system),
        InternalForce::Nonlinear(Arc::clone(&force)),
        dt,
        IntegratorOptions::default(),
    )
    .unwrap();
    let mut state = State::at_rest(system.free_count());
    let total_energy = |state: &State| {
        let e = force.energy(&system, state).unwrap();
        e.total() + force.contact_energy(&state.displacement).unwrap()
    };
    let lowest = |state: &State| {
        let full = force.full_displacement(&state.displacement).unwrap();
        (0..mesh.node_count())
            .map(|n| mesh.nodes()[n].z + full[3 * n + 2])
            .fold(f64::INFINITY, f64::min)
    };
    let mut previous = total_energy(&state);
    let mut touched = false;
    let mut lowest_seen = f64::INFINITY;
    for _ in 0..60 {
        integrator.step(&mut state).unwrap();
        let z = lowest(&state);
        lowest_seen = lowest_seen.min(z);
        // The barrier: no node on or below the ground at any step (not merely a bound).
        assert!(z > 0.0, "step {}: lowest node at {z:e}", state.steps);
        let energy = total_energy(&state);
        if touched {
            // Backward Euler dissipates; the Newton tolerance (1e-8 of the residual scale)
            // leaves O(1e-8) relative noise in the energy, so 1e-7 of its scale is allowed.
            assert!(
                energy <= previous + 1e-7 * previous.abs().max(1e-3),
                "step {}: energy rose from {previous:e} to {energy:e}",
                state.steps
            );
        }
        touched |= z < d_hat;
        previous = energy;
    }
    assert!(touched, "the block never reached the ground");
    println!(
        "dt = {dt:.3e} s (critical {critical:.3e} s), lowest node {lowest_seen:.3e} m (d̂ = {d_hat:.3e} m)"
    );

    // The static solution with the same contact: the block's reference placed half an
    // activation distance above the ground, so the barrier holds it from the first load step.
    // The same barrier: a gap tolerance it meets at once, so the static solve keeps the given
    // d̂ (its continuation to the exact contact would move the block down by the barrier's
    // resting gap, which the dynamic run keeps).
    let rest_ground = DROP - 0.5 * d_hat;
    let static_contact = Contact::new(&mesh, vec![ground(rest_ground)], parameters)
        .unwrap()
        .with_gap_tolerance(0.5)
        .unwrap();
    let mut gravity_loads = Loads::new(&mesh);
    gravity_loads.add_gravity(&mesh, &rubber, gravity).unwrap();
    let report = solve_nonlinear_static_with_contact(
        &mesh,
        ModelKind::NeoHookean.build(&rubber).as_ref(),
        &constraints,
        &gravity_loads,
        &static_contact,
        NewtonOptions::default(),
    )
    .unwrap();
    let dynamic = force.full_displacement(&state.displacement).unwrap();
    // Same deformed positions: the static u is measured from a reference that sits
    // `rest_ground` higher relative to its ground.
    let mut worst: f64 = 0.0;
    let mut sag: f64 = 0.0;
    for n in 0..mesh.node_count() {
        for a in 0..3 {
            let shift = if a == 2 { rest_ground } else { 0.0 };
            let expected = report.displacement[3 * n + a] - shift;
            worst = worst.max((dynamic[3 * n + a] - expected).abs());
        }
        sag = sag.max(-report.displacement[3 * n + 2]);
    }
    println!(
        "largest difference from the static contact solution {worst:.3e} m; its largest sag {sag:.3e} m; speed {:.3e}",
        state.velocity.iter().fold(0.0f64, |m, v| m.max(v.abs()))
    );
    // At rest (speed 0 at the end) backward Euler's step equation is the static one, and both
    // solves stop at a residual test (the step's 1e-8 of its reference, the static 1e-10 of
    // the load): the two solutions differ by the step tolerance times the conditioning of the
    // contact-stiffened Newton matrix. 1e-7 of the sag is 10× the step tolerance; measured
    // 3.8e-12 m against a 2.07e-3 m sag (1.8e-9 of it).
    assert!(worst <= 1e-7 * sag, "{worst:e} vs sag {sag:e}");
}

#[test]
fn explicit_drop_below_the_critical_step_stays_above_the_ground() {
    let (mesh, rubber, constraints) = block();
    let gravity = Vector3::new(0.0, 0.0, -9.81);
    // An explicit step cannot limit itself to the first time of impact: the barrier alone must
    // absorb each bottom node's share of the impact, κ·A·b(d) ≥ ½·m·v², which the default κ
    // (tuned for implicit steps) meets only for drops of a few mm. 100× the default κ.
    let default = ContactParameters::for_mesh(&mesh, rubber.youngs_modulus()).unwrap();
    let parameters = ContactParameters {
        stiffness: 100.0 * default.stiffness,
        ..default
    };
    let system = LinearSystem::new_free_body(
        &mesh,
        &rubber,
        &constraints,
        &Loads::new(&mesh),
        gravity,
        MassKind::Lumped,
        Rayleigh::default(),
    )
    .unwrap();
    // A fiftieth of the elastic critical step: the barrier's node stiffness κ·A·b″(d) adds its
    // own bound dt < 2√(m/(κ·A·b″(d))), which tightens as the gap d closes; at 100× κ a
    // tenth of the critical step let a bottom node cross the ground (Error::Diverged).
    let dt = 0.02 * critical_time_step(&system).unwrap().dt;
    let contact = Contact::new(&mesh, vec![ground(0.0)], parameters).unwrap();
    let mesh = Arc::new(mesh);
    let force = Arc::new(
        NonlinearForce::new(
            Arc::clone(&mesh),
            ModelKind::NeoHookean.build(&rubber),
            &system,
        )
        .unwrap()
        .with_contact(contact)
        .unwrap(),
    );
    let system = Arc::new(system);
    let mut integrator = SymplecticEuler::with_force(
        Arc::clone(&system),
        InternalForce::Nonlinear(Arc::clone(&force)),
        dt,
    )
    .unwrap();
    let mut state = State::at_rest(system.free_count());
    let total_energy = |state: &State| {
        let e = force.energy(&system, state).unwrap();
        e.total() + force.contact_energy(&state.displacement).unwrap()
    };
    let start = total_energy(&state);
    // The energy scale: the gravity work of the fall, m·g·DROP.
    let fall = rubber.density() * SIDE.powi(3) * 9.81 * DROP;
    let (mut lowest_seen, mut rise) = (f64::INFINITY, f64::NEG_INFINITY);
    // 0.25 s: the fall (0.064 s) and a few bounces.
    let steps = (0.25 / dt) as usize;
    for _ in 0..steps {
        integrator.step(&mut state).unwrap();
        let full = force.full_displacement(&state.displacement).unwrap();
        let z = (0..mesh.node_count())
            .map(|n| mesh.nodes()[n].z + full[3 * n + 2])
            .fold(f64::INFINITY, f64::min);
        lowest_seen = lowest_seen.min(z);
        rise = rise.max(total_energy(&state) - start);
    }
    let loss = start - total_energy(&state);
    println!(
        "explicit: dt = {dt:.3e} s, {steps} steps, lowest node {lowest_seen:.3e} m, largest energy rise {rise:.3e} J, lost {loss:.3e} J of the fall's {fall:.3e} J"
    );
    // Explicit contact acts on the velocity (issue 35): every gap stays open (a crossing
    // would have been Error::Diverged), whatever κ.
    assert!(lowest_seen > 0.0);
    // The contact is inelastic: energy never rises above the start by more than symplectic
    // Euler's O(ω·dt) oscillation of the energy in play (5 % of the fall's work bounds it at
    // this step), and the impacts lose some (measured: a third over the bounces of 0.25 s).
    assert!(rise < 0.05 * fall, "{rise:e} vs {fall:e}");
    assert!(loss > 0.0 && loss < fall, "{loss:e} vs {fall:e}");
}

#[test]
fn newmark_drop_onto_a_box_table_never_enters_it() {
    let (mesh, rubber, constraints) = block();
    let gravity = Vector3::new(0.0, 0.0, -9.81);
    let parameters = ContactParameters::for_mesh(&mesh, rubber.youngs_modulus()).unwrap();
    let system = LinearSystem::new_free_body(
        &mesh,
        &rubber,
        &constraints,
        &Loads::new(&mesh),
        gravity,
        MassKind::Lumped,
        Rayleigh::default(),
    )
    .unwrap();
    let dt = 10.0 * critical_time_step(&system).unwrap().dt;
    // A table wider than the block, its top at z = 0.
    let table = Obstacle::aligned_box(
        "table",
        Vector3::new(-0.1, -0.1, -0.3),
        Vector3::new(0.3, 0.3, 0.0),
    )
    .unwrap();
    let contact = Contact::new(&mesh, vec![table.clone()], parameters).unwrap();
    let mesh = Arc::new(mesh);
    let force = Arc::new(
        NonlinearForce::new(
            Arc::clone(&mesh),
            ModelKind::NeoHookean.build(&rubber),
            &system,
        )
        .unwrap()
        .with_contact(contact)
        .unwrap(),
    );
    let system = Arc::new(system);
    let mut integrator = Newmark::with_force(
        Arc::clone(&system),
        InternalForce::Nonlinear(Arc::clone(&force)),
        dt,
        IntegratorOptions::default(),
    )
    .unwrap();
    let mut state = State::at_rest(system.free_count());
    let total_energy = |state: &State| {
        let e = force.energy(&system, state).unwrap();
        e.total() + force.contact_energy(&state.displacement).unwrap()
    };
    let start = total_energy(&state);
    let fall = rubber.density() * SIDE.powi(3) * 9.81 * DROP;
    let (mut closest, mut highest) = (f64::INFINITY, f64::NEG_INFINITY);
    for _ in 0..(0.3 / dt) as usize {
        integrator.step(&mut state).unwrap();
        let full = force.full_displacement(&state.displacement).unwrap();
        for n in 0..mesh.node_count() {
            let x = mesh.nodes()[n] + Vector3::new(full[3 * n], full[3 * n + 1], full[3 * n + 2]);
            closest = closest.min(table.distance(&x));
        }
        highest = highest.max(total_energy(&state) - start);
    }
    println!(
        "Newmark: dt = {dt:.3e} s, closest node {closest:.3e} m, largest energy gain {highest:.3e} J of the fall's {fall:.3e} J"
    );
    // Every node (not only the surface) stays outside the box: the barrier and the CCD.
    assert!(closest > 0.0);
    // With the contact force at the step's end the barrier only takes energy out (measured:
    // +7e-15 J, round-off; with the trapezoid on the barrier the block gained about the fall's
    // work at this step): 1e-6 of the fall bounds Newton's tolerance and the neo-Hookean
    // trapezoid's share (tests/core/newmark_contact.rs).
    assert!(highest <= 1e-6 * fall, "{highest:e} J");
}
