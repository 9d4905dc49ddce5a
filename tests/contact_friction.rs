//! A block on an inclined plane with Coulomb friction (issue 18, item 2): it sticks for
//! tan θ < μ and slides with acceleration g·(sin θ − μ·cos θ) for tan θ > μ.

use std::sync::Arc;

use nalgebra::Vector3;
use tetfem::contact::{Contact, ContactParameters, Obstacle};
use tetfem::dynamics::{
    BackwardEuler, Integrator, IntegratorOptions, InternalForce, LinearSystem, Mass, MassKind,
    NonlinearForce, Rayleigh, State,
};
use tetfem::model::ModelKind;
use tetfem::{BoxSplit, Constraints, Loads, Material, TetMesh};

const G: f64 = 9.81;
const MU: f64 = 0.5;
const DT: f64 = 2e-3;

/// Mass-weighted mean x-velocity of the block at each step (the plane is z = 0, gravity tilted
/// by θ about y), over `steps` steps.
fn slide(theta: f64, steps: usize) -> (Vec<f64>, f64) {
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
    let system = LinearSystem::new_free_body(
        &mesh,
        &material,
        &Constraints::new(&mesh),
        &Loads::new(&mesh),
        gravity,
        MassKind::Lumped,
        Rayleigh::default(),
    )
    .unwrap();
    let plane = Obstacle::half_space("plane", Vector3::zeros(), Vector3::z())
        .unwrap()
        .with_friction(MU)
        .unwrap();
    let contact = Contact::new(&mesh, vec![plane], parameters).unwrap();
    let slip_velocity = contact.slip_velocity();
    let force = NonlinearForce::new(
        Arc::new(mesh),
        ModelKind::Corotational.build(&material),
        &system,
    )
    .unwrap()
    .with_contact(contact)
    .unwrap();
    let system = Arc::new(system);
    let mut integrator = BackwardEuler::with_force(
        Arc::clone(&system),
        InternalForce::Nonlinear(Arc::new(force)),
        DT,
        IntegratorOptions::default(),
    )
    .unwrap();
    let Mass::Lumped(mass) = system.mass() else {
        unreachable!()
    };
    let total: f64 = mass.iter().step_by(3).sum();
    let mut state = State::at_rest(system.free_count());
    let mut speeds = Vec::new();
    for _ in 0..steps {
        integrator.step(&mut state).unwrap();
        let momentum: f64 = (0..mass.len())
            .step_by(3)
            .map(|i| mass[i] * state.velocity[i])
            .sum();
        speeds.push(momentum / total);
    }
    (speeds, slip_velocity)
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
