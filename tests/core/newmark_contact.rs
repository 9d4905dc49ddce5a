//! Newmark with barrier contact, the contact force taken at the step's end (issue 35): the
//! barrier can only take energy out of a step, so a block dropped on a floor never gains energy
//! at any step size, and with the linear model each step loses exactly the barrier's convexity
//! gap κ·Σ A·[b(d⁺) − b(d) − b′(d⁺)·(d⁺ − d)].

use std::sync::Arc;

use nalgebra::Vector3;
use tetfem::analysis::dynamics::{
    Integrator, IntegratorOptions, InternalForce, LinearSystem, MassKind, Newmark, NonlinearForce,
    Rayleigh, State, critical_time_step,
};
use tetfem::contact::{Contact, ContactParameters, Obstacle};
use tetfem::model::ModelKind;
use tetfem::{Loads, TetMesh};

use super::contact_drop::{DROP, SIDE, block};

const GRAVITY: f64 = 9.81;
/// Long enough for the fall (0.064 s), the impact and the rise back to the apex; short of a
/// second impact.
const DURATION: f64 = 0.25;

/// A Newmark drop: the system, the force (model and floor) and the integrator at
/// `multiple` × the explicit critical step.
fn drop_setup(
    model: ModelKind,
    multiple: f64,
) -> (
    Arc<TetMesh>,
    Arc<LinearSystem>,
    Arc<NonlinearForce>,
    Newmark,
) {
    let (mesh, rubber, constraints) = block();
    let parameters = ContactParameters::for_mesh(&mesh, rubber.youngs_modulus()).unwrap();
    let system = LinearSystem::new_free_body(
        &mesh,
        &rubber,
        &constraints,
        &Loads::new(&mesh),
        Vector3::new(0.0, 0.0, -GRAVITY),
        MassKind::Lumped,
        Rayleigh::default(),
    )
    .unwrap();
    let dt = multiple * critical_time_step(&system).unwrap().dt;
    let floor = Obstacle::half_space("floor", Vector3::zeros(), Vector3::z()).unwrap();
    let contact = Contact::new(&mesh, vec![floor], parameters).unwrap();
    let mesh = Arc::new(mesh);
    let force = Arc::new(
        NonlinearForce::new(Arc::clone(&mesh), model.build(&rubber), &system)
            .unwrap()
            .with_contact(contact)
            .unwrap(),
    );
    let system = Arc::new(system);
    let integrator = Newmark::with_force(
        Arc::clone(&system),
        InternalForce::Nonlinear(Arc::clone(&force)),
        dt,
        IntegratorOptions::default(),
    )
    .unwrap();
    (mesh, system, force, integrator)
}

/// What a drop did: the largest H − H(0) (J), the lowest height of any node (m), the
/// restitution (rebound height of the centre of mass over the drop), the energy lost by the end
/// H(0) − H(end) (J) and the fall's work m·g·DROP.
struct DropRun {
    gain: f64,
    lost: f64,
    lowest: f64,
    restitution: f64,
    fall: f64,
}

fn run_drop(model: ModelKind, multiple: f64) -> DropRun {
    let (mesh, system, force, mut integrator) = drop_setup(model, multiple);
    let dt = integrator.time_step();
    let mass = 1000.0 * SIDE.powi(3);
    let fall = mass * GRAVITY * DROP;
    // H = kinetic + elastic + gravity + barrier.
    let total = |state: &State| {
        let e = force.energy(&system, state).unwrap();
        (
            e.total() + force.contact_energy(&state.displacement).unwrap(),
            e.gravity_potential,
        )
    };
    let mut state = State::at_rest(system.free_count());
    let (start, _) = total(&state);
    let (mut gain, mut lowest, mut last) = (f64::NEG_INFINITY, f64::INFINITY, start);
    // The gravity potential V = m·g·Δz_cm: its lowest value (deepest compression) and the
    // highest after it (the rebound's apex).
    let (mut deepest, mut apex) = (f64::INFINITY, f64::NEG_INFINITY);
    let steps = (DURATION / dt).ceil() as usize;
    for _ in 0..steps {
        integrator.step(&mut state).unwrap();
        let full = force.full_displacement(&state.displacement).unwrap();
        for (n, x) in mesh.nodes().iter().enumerate() {
            lowest = lowest.min(x.z + full[3 * n + 2]);
        }
        let (h, potential) = total(&state);
        gain = gain.max(h - start);
        last = h;
        if potential < deepest {
            (deepest, apex) = (potential, potential);
        }
        apex = apex.max(potential);
    }
    DropRun {
        gain,
        lost: start - last,
        lowest,
        // The centre of mass touches down after falling DROP (V = −fall); it rises back
        // apex + fall over the fall's DROP.
        restitution: (apex + fall) / fall,
        fall,
    }
}

#[test]
fn newmark_drop_never_gains_energy_at_any_step() {
    for multiple in [0.5, 1.0, 10.0, 100.0] {
        let run = run_drop(ModelKind::NeoHookean, multiple);
        println!(
            "{multiple}× dt_crit: largest H − H(0) {:.3e} of the fall's {:.3e} J, lost {:.3e} J, lowest node {:.3e} m, restitution {:.4}",
            run.gain, run.fall, run.lost, run.lowest, run.restitution
        );
        // Every iterate keeps every gap open (barrier and CCD), so every accepted state does;
        // the floor is at z = 0 and the whole body stays above it.
        assert!(run.lowest > 0.0, "{multiple}×: node at {}", run.lowest);
        // The barrier only takes energy out of a step; what may rise is the Newton tolerance's
        // share (residual ≤ 1e-8 of the step's force scale, times the step's move: ~1e-8 of
        // the fall's work per step, over ≤ 700 steps) and the neo-Hookean trapezoid's O(dt³)
        // error at these small strains: 1e-6 of the fall's work bounds both.
        assert!(
            run.gain <= 1e-6 * run.fall,
            "{multiple}×: H rose by {:e} J",
            run.gain
        );
    }
}

#[test]
fn newmark_drop_rebounds_less_at_long_steps() {
    let restitution: Vec<f64> = [0.5, 1.0, 10.0]
        .iter()
        .map(|&m| run_drop(ModelKind::NeoHookean, m).restitution)
        .collect();
    println!("restitution at 0.5, 1, 10× dt_crit: {restitution:?}");
    // Measured: 0.565, 0.560, 0.254 (and 0.567, 0.565, 0.562, 0.557 at 0.25, 0.1, 0.05 and
    // 0.02×: no approach to 1 as dt shrinks). The barrier's loss per step is its convexity gap
    // over the step's move: its stiffness at a contact node grows without bound as the gap
    // closes, so no step resolves the contact nodes' normal oscillation and the end-point rule
    // removes it (their normal kinetic energy at each touch, as in Deuflhard, Krause & Ertel's
    // contact-stabilised Newmark): a loss tied to the contact nodes' share of the mass on this
    // 4×4×4 mesh, not to dt. Longer steps through the impact lose more on top of it.
    assert!(restitution[0] >= restitution[1] && restitution[1] >= restitution[2]);
    // Some of the fall's energy stays in the block's vibration after the impact, so even the
    // exact elastic impact rebounds below 1; the bound 0.5 is under the measured 0.56.
    assert!(restitution[0] > 0.5 && restitution[0] <= 1.0);
}

#[test]
fn linear_bounce_loses_exactly_the_barrier_convexity_gap_each_step() {
    // The linear model: the elastic trapezoid is exact, the floor a half-space (gap affine in
    // u, so the barrier is convex in u), so each step changes H = kinetic + elastic + gravity +
    // barrier by E_c(u⁺) − E_c(u) − ∇E_c(u⁺)·(u⁺ − u) = κ·Σ A·[b(d⁺) − b(d) − b′(d⁺)·(d⁺ − d)]
    // ≤ 0, up to the Newton tolerance.
    let (_mesh, system, force, mut integrator) = drop_setup(ModelKind::Linear, 1.0);
    let contact = force.contact().unwrap().clone();
    let fall = 1000.0 * SIDE.powi(3) * GRAVITY * DROP;
    let mut state = State::at_rest(system.free_count());
    let total = |state: &State| {
        force.energy(&system, state).unwrap().total()
            + force.contact_energy(&state.displacement).unwrap()
    };
    let (mut lost, mut worst) = (0.0, 0.0_f64);
    let steps = (DURATION / integrator.time_step()).ceil() as usize;
    for _ in 0..steps {
        let before = state.clone();
        integrator.step(&mut state).unwrap();
        let (u0, u1) = (
            force.full_displacement(&before.displacement).unwrap(),
            force.full_displacement(&state.displacement).unwrap(),
        );
        let mut f1 = vec![0.0; u1.len()];
        contact.add_force(&u1, &mut f1).unwrap();
        let pushed: f64 = f1
            .iter()
            .zip(u1.iter().zip(&u0))
            .map(|(f, (a, b))| f * (a - b))
            .sum();
        // −∇E_c(u⁺)·Δu = f_c(u⁺)·Δu.
        let gap = contact.energy(&u1).unwrap() - contact.energy(&u0).unwrap() + pushed;
        let change = total(&state) - total(&before);
        // Convexity: the gap is never positive (up to the energies' round-off).
        assert!(gap <= 1e-12 * fall, "gap {gap:e}");
        worst = worst.max((change - gap).abs());
        lost -= gap;
    }
    println!(
        "linear bounce at 1× dt_crit: lost {lost:.3e} J of the fall's {fall:.3e} J, largest |ΔH − gap| per step {worst:.3e} J"
    );
    // Per step the identity holds to Newton's tolerance (1e-8 of the force scale times the
    // step's move, ~1e-10 of the fall's work) and the energies' round-off: 1e-8 of the fall.
    assert!(worst <= 1e-8 * fall, "{worst:e}");
    // The impact loses something (the barrier is not linear), and less than what fell.
    assert!(lost > 0.0 && lost < fall);
}
