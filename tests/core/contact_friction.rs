//! A block on an inclined plane with Coulomb friction (issue 18, item 2): it sticks for
//! tan θ < μ and slides with acceleration g·(sin θ − μ·cos θ) for tan θ > μ — with backward
//! Euler (lagged smoothed friction in its Newton step) and with the explicit method (friction as
//! a per-node implicit velocity update).

use std::sync::Arc;

use nalgebra::Vector3;
use tetfem::analysis::dynamics::{
    BackwardEuler, Integrator, IntegratorOptions, InternalForce, LinearSystem, Mass, MassKind,
    NonlinearForce, Rayleigh, State, SymplecticEuler, critical_time_step,
};
use tetfem::contact::{Contact, ContactParameters, Obstacle};
use tetfem::model::ModelKind;
use tetfem::{BoxSplit, Constraints, Loads, Material, TetMesh};

const G: f64 = 9.81;
const MU: f64 = 0.5;
const DT: f64 = 2e-3;

/// Mass-weighted mean x-velocity of the block at each step (the plane is z = 0, gravity tilted
/// by θ about y), over `steps` steps of backward Euler with step DT.
fn slide(theta: f64, steps: usize) -> (Vec<f64>, f64) {
    let run = slide_with(theta, None, steps);
    (run.speeds, run.slip_velocity)
}

/// What [`slide_with`] measured.
struct Slide {
    /// Mass-weighted mean x-velocity after each step (m/s).
    speeds: Vec<f64>,
    /// ε_v (m/s).
    slip_velocity: f64,
    /// The time step (s).
    dt: f64,
    /// The smallest gap of any node at any step (m), and the barrier's stable step
    /// 2·√(mᵢ/(κ·Aᵢ·b″(d))) of the stiffest bottom node at that gap (s): the explicit step must
    /// stay below it.
    lowest_gap: f64,
    barrier_step: f64,
}

/// The block of [`slide`] with backward Euler (`explicit` = `None`, step DT) or with the explicit
/// method at `explicit` times the elastic critical step.
fn slide_with(theta: f64, explicit: Option<f64>, steps: usize) -> Slide {
    let size = 0.1;
    let material = Material::new(1e6, 0.3, 1000.0).unwrap();
    let parameters = {
        let probe = TetMesh::box_grid(
            Vector3::zeros(),
            Vector3::repeat(size),
            [2, 2, 2],
            BoxSplit::Lecture6,
        )
        .unwrap();
        ContactParameters::for_mesh(&probe, material.youngs_modulus()).unwrap()
    };
    // Just above the barrier's reach (2·d̂ above the plane): it settles onto it in a few steps.
    let lift = 2.0 * parameters.activation_distance;
    let mesh = TetMesh::box_grid(
        Vector3::new(0.0, 0.0, lift),
        Vector3::new(size, size, size + lift),
        [2, 2, 2],
        BoxSplit::Lecture6,
    )
    .unwrap();
    let gravity = G * Vector3::new(theta.sin(), 0.0, -theta.cos());
    let build = |damping: Rayleigh| {
        LinearSystem::new_free_body(
            &mesh,
            &material,
            &Constraints::new(&mesh),
            &Loads::new(&mesh),
            gravity,
            MassKind::Lumped,
            damping,
        )
        .unwrap()
    };
    let critical = critical_time_step(&build(Rayleigh::default())).unwrap().dt;
    // Explicit: stiffness-proportional damping β = 0.3·dt_crit (damping ratio βω/2 ≤ 0.3 up
    // to the highest mode ω_max = 2/dt_crit, which keeps the damped stable step above 0.7·dt_crit)
    // lets the landing's ringing die out. It damps deformation and the bounce on the barrier
    // (β·K_T holds the barrier's Hessian) but not a rigid slide (K_T·v = 0), so Coulomb's law
    // is what is measured; undamped, the ringing's sideways node velocities tilt each node's
    // friction off the slide and lower its mean (measured: +3.5 % acceleration). Backward Euler
    // damps it numerically.
    let system = match explicit {
        Some(_) => build(Rayleigh::new(0.0, 0.3 * critical).unwrap()),
        None => build(Rayleigh::default()),
    };
    let plane = Obstacle::half_space("plane", Vector3::zeros(), Vector3::z())
        .unwrap()
        .with_friction(MU)
        .unwrap();
    let contact = Contact::new(&mesh, vec![plane], parameters).unwrap();
    let slip_velocity = contact.slip_velocity();
    let mesh = Arc::new(mesh);
    let force = NonlinearForce::new(
        Arc::clone(&mesh),
        ModelKind::Corotational.build(&material),
        &system,
    )
    .unwrap()
    .with_contact(contact)
    .unwrap();
    let system = Arc::new(system);
    let force = Arc::new(force);
    let (mut integrator, dt): (Box<dyn Integrator>, f64) = match explicit {
        None => (
            Box::new(
                BackwardEuler::with_force(
                    Arc::clone(&system),
                    InternalForce::Nonlinear(Arc::clone(&force)),
                    DT,
                    IntegratorOptions::default(),
                )
                .unwrap(),
            ),
            DT,
        ),
        Some(fraction) => (
            Box::new(
                SymplecticEuler::with_force(
                    Arc::clone(&system),
                    InternalForce::Nonlinear(Arc::clone(&force)),
                    fraction * critical,
                )
                .unwrap(),
            ),
            fraction * critical,
        ),
    };
    let Mass::Lumped(mass) = system.mass() else {
        unreachable!()
    };
    let total: f64 = mass.iter().step_by(3).sum();
    let mut state = State::at_rest(system.free_count());
    let mut speeds = Vec::new();
    let mut lowest_gap = f64::INFINITY;
    for _ in 0..steps {
        integrator.step(&mut state).unwrap();
        let momentum: f64 = (0..mass.len())
            .step_by(3)
            .map(|i| mass[i] * state.velocity[i])
            .sum();
        speeds.push(momentum / total);
        let full = force.full_displacement(&state.displacement).unwrap();
        for n in 0..mesh.node_count() {
            lowest_gap = lowest_gap.min(mesh.nodes()[n].z + full[3 * n + 2]);
        }
    }
    // The stiffest bottom node: the largest area per mass (every DOF is free: mass[3n]).
    let contact = force.contact().unwrap();
    let (kappa, d_hat) = (
        contact.parameters().stiffness,
        contact.parameters().activation_distance,
    );
    let barrier_step = (0..mesh.node_count())
        .filter(|&n| mesh.nodes()[n].z == lift)
        .map(|n| {
            let area = bottom_area(&mesh, n);
            let stiffness =
                kappa * area * tetfem::contact::barrier::second_derivative(lowest_gap, d_hat);
            2.0 * (mass[3 * n] / stiffness).sqrt()
        })
        .fold(f64::INFINITY, f64::min);
    Slide {
        speeds,
        slip_velocity,
        dt,
        lowest_gap,
        barrier_step,
    }
}

/// A third of the area of the bottom triangles (z = min) around node `n`: its barrier area Aᵢ.
fn bottom_area(mesh: &TetMesh, n: usize) -> f64 {
    mesh.boundary_faces()
        .unwrap()
        .iter()
        .filter(|f| {
            f.nodes.contains(&n)
                && f.nodes
                    .iter()
                    .all(|&k| mesh.nodes()[k].z == mesh.nodes()[n].z)
        })
        .map(|f| f.area_vector(mesh).unwrap().norm() / 3.0)
        .sum()
}

#[test]
fn block_slides_with_coulomb_acceleration_above_the_friction_angle() {
    let theta = 0.7f64.atan();
    let steps = 250;
    let (speeds, _) = slide(theta, steps);
    // Over the second half (0.25–0.5 s): the landing transient is gone.
    let (a, b) = (steps / 2, steps - 1);
    let measured = (speeds[b] - speeds[a]) / ((b - a) as f64 * DT);
    let expected = G * (theta.sin() - MU * theta.cos());
    println!("sliding: a = {measured:.5} m/s², Coulomb {expected:.5} m/s²");
    // Issue 18 asks for 2 %.
    assert!(
        (measured / expected - 1.0).abs() < 0.02,
        "{measured} vs {expected}"
    );
}

#[test]
fn block_sticks_below_the_friction_angle() {
    let theta = 0.3f64.atan();
    let (speeds, slip_velocity) = slide(theta, 250);
    let last = *speeds.last().unwrap();
    // Without friction it would move at g·sin θ·t ≈ 0.7 m/s by now; the smoothed friction
    // lets it creep below ε_v (the stick speed it resolves to).
    println!("sticking: speed {last:.3e} m/s, ε_v {slip_velocity:.3e} m/s");
    assert!(last.abs() < slip_velocity, "{last} vs {slip_velocity}");
}

/// The explicit step: a quarter of the elastic critical step (1.8e-4 s). The barrier adds its
/// own bound 2·√(mᵢ/(κ·Aᵢ·b″(d))) per node, which tightens as a gap d closes; landing from 2·d̂
/// with the default κ the lowest gap stays near 0.6·d̂ (measured 1.0e-4 m), where that bound is
/// 8e-4 s, four times the step (each run asserts the step stayed below it at the lowest gap it
/// reached).
const EXPLICIT_FRACTION: f64 = 0.25;

/// Slope of the speeds over the second half of a run (m/s²): the landing transient is over.
fn acceleration(run: &Slide) -> f64 {
    let n = run.speeds.len();
    let (a, b) = (n / 2, n - 1);
    (run.speeds[b] - run.speeds[a]) / ((b - a) as f64 * run.dt)
}

#[test]
fn explicit_block_slides_with_coulomb_acceleration_above_the_friction_angle() {
    let theta = 0.7f64.atan();
    let probe = slide_with(theta, Some(EXPLICIT_FRACTION), 1);
    // 0.5 s, as the backward Euler test (2787 steps).
    let run = slide_with(theta, Some(EXPLICIT_FRACTION), (0.5 / probe.dt) as usize);
    let measured = acceleration(&run);
    let expected = G * (theta.sin() - MU * theta.cos());
    println!(
        "explicit sliding (dt {:.3e} s, {} steps): a = {measured:.5} m/s², Coulomb {expected:.5} m/s²; lowest gap {:.3e} m, barrier step there {:.3e} s",
        run.dt,
        run.speeds.len(),
        run.lowest_gap,
        run.barrier_step
    );
    assert!(run.dt < run.barrier_step && run.lowest_gap > 0.0);
    // Issue 18 asks for 2 %.
    assert!(
        (measured / expected - 1.0).abs() < 0.02,
        "{measured} vs {expected}"
    );
}

#[test]
fn explicit_block_sticks_below_the_friction_angle() {
    let theta = 0.3f64.atan();
    let probe = slide_with(theta, Some(EXPLICIT_FRACTION), 1);
    // 1 s: the landing's slow rocking (period ≈ 0.1 s) decays over the first half.
    let run = slide_with(theta, Some(EXPLICIT_FRACTION), (1.0 / probe.dt) as usize);
    let n = run.speeds.len();
    // The mean over the second half (0.5–1 s, about five periods of what ringing is left): the
    // block's displacement over it divided by its duration.
    let creep = run.speeds[n / 2..].iter().sum::<f64>() / (n - n / 2) as f64;
    let swing = run.speeds[n / 2..]
        .iter()
        .fold(0.0f64, |m, v| m.max(v.abs()));
    // At a steady creep s every contact node moves at s, and the per-node update balances the
    // block's load along the plane, m·g·sin θ, with Σ μ·λᵢ·f₁(s) = μ·m·g·cos θ·f₁(s): so
    // f₁(s/ε_v) = 2x − x² = tan θ/μ, x = 1 − √(1 − tan θ/μ).
    let derived = run.slip_velocity * (1.0 - (1.0 - theta.tan() / MU).sqrt());
    println!(
        "explicit sticking: mean creep {creep:.4e} m/s (largest |speed| {swing:.3e} m/s), derived {derived:.4e} m/s, ε_v {:.3e} m/s (frictionless it would reach {:.2} m/s); lowest gap {:.3e} m",
        run.slip_velocity,
        G * theta.sin(),
        run.lowest_gap
    );
    assert!(run.dt < run.barrier_step && run.lowest_gap > 0.0);
    // Sticking: the mean speed is the smoothed creep, below ε_v.
    assert!(creep > 0.0 && creep < run.slip_velocity);
    // The remaining ringing biases a five-period mean by about its amplitude over ω·T
    // (≈ 2e-4 m/s over 50 rad/s × 0.5 s ≈ 1e-5 m/s, 15 % of the creep): 30 % allowed.
    assert!((creep / derived - 1.0).abs() < 0.3, "{creep} vs {derived}");
}
