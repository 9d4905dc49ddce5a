//! Friction between bodies (issue 36): IPC's lagged smoothed Coulomb friction between surface
//! pairs ([`tetfem::contact::surface::friction`]), its normal forces and tangent planes frozen
//! at each backward-Euler step's start ([`NonlinearForce::begin_step`]).
//!
//! The sliding scenes: a 0.1 × 0.1 × 0.05 m block (2 × 2 × 1 cells, 0.5 kg) resting under
//! gravity on a 0.3 × 0.2 × 0.05 m block clamped at its bottom; the upper block lies well
//! inside the lower one's top face, so the barrier's pairs under it push along z only.

use std::sync::Arc;

use nalgebra::Vector3;
use tetfem::analysis::Definition;
use tetfem::analysis::dynamics::Method;
use tetfem::analysis::dynamics::{
    BackwardEuler, Integrator, IntegratorOptions, InternalForce, LinearSystem, MassKind,
    NonlinearForce, Rayleigh, State, StepNewtonOptions,
};
use tetfem::analysis::transient::{TimeStep, Transient, TransientOptions, Unobserved};
use tetfem::contact::surface::{SurfaceBarrier, SurfaceContact, SurfaceFrictionLag};
use tetfem::fe::materials::MaterialMap;
use tetfem::mesh::bodies::{Bodies, Placement};
use tetfem::model::ModelKind;
use tetfem::{BoxSplit, Constraints, Error, Loads, Material, TetMesh};

const G: f64 = 9.81;
/// d̂ (m): a fiftieth of the 0.05 m cells (no reach warning).
const D_HAT: f64 = 1e-3;
/// κ (J/m²): the upper block's ≈ 5 N weight over its ≈ 100 pairs is held near d ≈ d̂/2, where
/// |b′| ≈ 1.2e-3 m (100 · 100 · 1.2e-3 ≈ 12 N ≥ 5 N: the rest gap lies inside (d̂/2, d̂)).
const KAPPA: f64 = 100.0;
/// The time step (s).
const DT: f64 = 1e-3;

fn rubber() -> Material {
    Material::new(1e6, 0.3, 1000.0).unwrap()
}

fn grid(size: Vector3<f64>, cells: [usize; 3]) -> TetMesh {
    TetMesh::box_grid(Vector3::zeros(), size, cells, BoxSplit::Lecture6).unwrap()
}

/// The lower block (body 0) and the upper one (body 1) `gap` (m) above it. The upper block's
/// edges lie between the lower block's rows of nodes (x = 0.06 and 0.16 m, y = 0.075 and
/// 0.175 m; rows every 0.05 m), at least 10 mm from any: a row under an edge would meet it
/// obliquely, and as the block moved off it the barrier would push it along.
fn slider(gap: f64) -> Bodies {
    let lower = grid(Vector3::new(0.3, 0.2, 0.05), [6, 4, 1]);
    let upper = grid(Vector3::new(0.1, 0.1, 0.05), [2, 2, 1]);
    let at = Placement::translated(Vector3::new(0.06, 0.075, 0.05 + gap)).unwrap();
    Bodies::new(vec![(lower, Placement::identity()), (upper, at)]).unwrap()
}

/// The system (lower block clamped at z = 0, gravity, `loads`) and its force with the surface
/// barrier of friction `mu`.
fn sliding_setup(
    bodies: &Bodies,
    mu: f64,
    slip_velocity: Option<f64>,
    loads: &Loads,
) -> (Arc<LinearSystem>, Arc<NonlinearForce>) {
    let mesh = bodies.mesh();
    let mut constraints = Constraints::new(mesh);
    let bottom: Vec<usize> = bodies
        .node_range(0)
        .unwrap()
        .filter(|&n| mesh.nodes()[n].z.abs() < 1e-12)
        .collect();
    constraints.fix_nodes(&bottom).unwrap();
    let system = LinearSystem::new_free_body(
        mesh,
        &rubber(),
        &constraints,
        loads,
        Vector3::new(0.0, 0.0, -G),
        MassKind::Lumped,
        Rayleigh::default(),
    )
    .unwrap();
    let mut barrier = SurfaceBarrier::new(D_HAT, KAPPA)
        .unwrap()
        .with_friction(mu)
        .unwrap();
    if let Some(v) = slip_velocity {
        barrier = barrier.with_slip_velocity(v).unwrap();
    }
    let contact = SurfaceContact::new(mesh, &bodies.node_bodies(), barrier).unwrap();
    let force = NonlinearForce::new(
        Arc::new(mesh.clone()),
        ModelKind::NeoHookean.build(&rubber()),
        &system,
    )
    .unwrap()
    .with_surface_contact(contact)
    .unwrap();
    (Arc::new(system), Arc::new(force))
}

fn integrator(system: &Arc<LinearSystem>, force: &Arc<NonlinearForce>) -> BackwardEuler {
    integrator_with_step(system, force, DT)
}

/// [`integrator`] with step `dt` (s).
fn integrator_with_step(
    system: &Arc<LinearSystem>,
    force: &Arc<NonlinearForce>,
    dt: f64,
) -> BackwardEuler {
    let options = IntegratorOptions {
        // The momentum error of a step is dt·Σr of its last residual r; 1e-11 of the inertial
        // residual keeps the drifts below far under the bounds checked.
        newton: StepNewtonOptions {
            tolerance: 1e-11,
            max_iterations: 200,
            relax_contact_nodes: true,
        },
        ..IntegratorOptions::default()
    };
    BackwardEuler::with_force(
        Arc::clone(system),
        InternalForce::Nonlinear(Arc::clone(force)),
        dt,
        options,
    )
    .unwrap()
}

/// Body `body`'s mass (kg), momentum (N·s) and mean displacement (m, mass-weighted) at `state`.
fn body_motion(
    system: &LinearSystem,
    bodies: &Bodies,
    body: usize,
    state: &State,
) -> (f64, Vector3<f64>, Vector3<f64>) {
    let n = state.velocity.len();
    let (mut mv, mut m1) = (vec![0.0; n], vec![0.0; n]);
    system.mass().mul_vec(&state.velocity, &mut mv).unwrap();
    system.mass().mul_vec(&vec![1.0; n], &mut m1).unwrap();
    let nodes = bodies.node_range(body).unwrap();
    let (mut mass, mut p, mut mu) = (0.0, Vector3::zeros(), Vector3::zeros());
    for (k, &d) in system.dofs().free_dofs().iter().enumerate() {
        if nodes.contains(&(d / 3)) {
            mass += m1[k] / 3.0;
            p[d % 3] += mv[k];
            mu[d % 3] += m1[k] * state.displacement[k];
        }
    }
    (mass, p, mu / mass)
}

/// The upper block settled on the lower one from rest at gap 1.5·d̂ (above the barrier's
/// reach: it falls onto the barrier, which then holds its weight; started inside d̂ the
/// barrier's stored energy would throw it up past the divergence guard's budget): 30 backward
/// Euler steps of 10 ms, whose numerical damping at ω·dt ≈ 2 (the block bouncing on the
/// barrier, ω ≈ 200 rad/s) stills the bounce that steps of 1 ms leave ringing. Without
/// friction (it falls straight down: friction would have nothing to resist), on the system of
/// `bodies` with no load besides gravity.
fn settled(bodies: &Bodies) -> State {
    let (system, force) = sliding_setup(bodies, 0.0, None, &Loads::new(bodies.mesh()));
    let mut be = integrator_with_step(&system, &force, 1e-2);
    let mut state = State::at_rest(system.free_count());
    for _ in 0..30 {
        be.step(&mut state).unwrap();
    }
    state
}

/// Gives every free DOF of body `body` along x the velocity `v` (m/s).
fn push(system: &LinearSystem, bodies: &Bodies, body: usize, state: &mut State, v: f64) {
    let nodes = bodies.node_range(body).unwrap();
    for (k, &d) in system.dofs().free_dofs().iter().enumerate() {
        if nodes.contains(&(d / 3)) && d % 3 == 0 {
            state.velocity[k] = v;
        }
    }
}

struct Slide {
    /// The upper block's mean x-velocity after each step (m/s).
    speeds: Vec<f64>,
    /// Its mean x-displacement from the push to the end (m).
    travel: f64,
    /// Its mean z-velocity at the push (m/s): how settled it was.
    settle_speed: f64,
    /// Σλ at the push over the weight m·g (μ > 0).
    normal_over_weight: f64,
}

/// The upper block settled ([`settled`]), then pushed along x at `v0` (m/s), `steps` steps.
fn slide(mu: f64, v0: f64, steps: usize) -> Slide {
    let bodies = slider(1.5 * D_HAT);
    let loads = Loads::new(bodies.mesh());
    let (system, force) = sliding_setup(&bodies, mu, None, &loads);
    let mut state = settled(&bodies);
    let (mass, p, start) = body_motion(&system, &bodies, 1, &state);
    let settle_speed = p.z / mass;
    push(&system, &bodies, 1, &mut state, v0);
    // A new integrator from the pushed state: its divergence guard budgets the push's energy.
    let mut be = integrator(&system, &force);
    let contact = force.surface_contact().unwrap();
    let full = force.full_displacement(&state.displacement).unwrap();
    contact.begin_friction(&full, DT).unwrap();
    let normal = contact.friction_lag().map_or(0.0, |l| l.friction_limit()) / mu.max(1e-300);
    contact.end_friction();
    let mut speeds = Vec::new();
    for _ in 0..steps {
        be.step(&mut state).unwrap();
        let (mass, p, _) = body_motion(&system, &bodies, 1, &state);
        speeds.push(p.x / mass);
    }
    let end = body_motion(&system, &bodies, 1, &state).2;
    let contact = force.surface_contact().unwrap();
    assert!(
        contact
            .intersections(&force.full_displacement(&state.displacement).unwrap())
            .unwrap()
            .is_empty()
    );
    Slide {
        speeds,
        travel: end.x - start.x,
        settle_speed,
        normal_over_weight: normal / (mass * G),
    }
}

/// A block sliding on another decelerates at μ·g and stops after v₀²/(2μg).
#[test]
fn a_sliding_block_decelerates_at_mu_g_and_stops() {
    let (mu, v0) = (0.5, 0.5);
    let a = mu * G;
    // It stops after v₀/(μg) ≈ 0.10 s: 160 steps see it at rest.
    let r = slide(mu, v0, 160);
    // The deceleration while sliding: the least-squares slope of the speed between the 5th
    // step (past the shear wave the push's friction starts) and the last above v₀/5.
    let window: Vec<(f64, f64)> = r
        .speeds
        .iter()
        .enumerate()
        .skip(5)
        .take_while(|(_, v)| **v > 0.2 * v0)
        .map(|(i, &v)| ((i + 1) as f64 * DT, v))
        .collect();
    let n = window.len() as f64;
    let (mt, mv) = window
        .iter()
        .fold((0.0, 0.0), |(t, v), (ti, vi)| (t + ti / n, v + vi / n));
    let slope = window.iter().map(|(t, v)| (t - mt) * (v - mv)).sum::<f64>()
        / window.iter().map(|(t, _)| (t - mt) * (t - mt)).sum::<f64>();
    let rest = v0 * v0 / (2.0 * a);
    let last = *r.speeds.last().unwrap();
    // At rest: the mean speed over the last 40 steps (from 0.12 s, past the stop at ≈ 0.10 s),
    // its displacement over them divided by their time.
    let resting = r.speeds[r.speeds.len() - 40..].iter().sum::<f64>() / 40.0;
    println!(
        "sliding, μ = {mu}: settled z-speed {:.2e} m/s, Σλ/mg {:.4}; deceleration {:.4} m/s² over {} steps \
         (μg = {a:.4}); travel {:.5} m (v₀²/2μg = {rest:.5}); final speed {last:.2e} m/s, mean over the last 40 steps {resting:.2e} m/s",
        r.settle_speed,
        r.normal_over_weight,
        -slope,
        window.len(),
        r.travel
    );
    // Sliding, the friction force is μ·Σλ with Σλ the lagged normal forces, which balance the
    // weight once settled: the issue asks 2 %.
    assert!((-slope / a - 1.0).abs() < 0.02, "deceleration {}", -slope);
    // Backward Euler's x_{n+1} = x_n + dt·v_{n+1} shortens the travel by ≈ v₀·dt/2 (1 % here)
    // besides the deceleration's own 2 %: 3 %.
    assert!((r.travel / rest - 1.0).abs() < 0.03, "travel {}", r.travel);
    // At rest: the shear vibration the stop leaves (μ·m·g·h/(G·A) ≈ 3e-5 m at ≈ 600 rad/s)
    // swings the mean speed by ≈ 1e-2 m/s at most; the creep below ε_v ≈ 3.7e-4 m/s moves it
    // on by less: a mean of 1e-3 m/s (a 500th of v₀) over the last 40 steps.
    assert!(last.abs() < 1e-2, "final speed {last:e}");
    assert!(resting.abs() < 1e-3, "mean speed at rest {resting:e}");
}

/// Without friction the block keeps its speed: only the barrier's pairs at the upper block's
/// edges (oblique to the surface) and the elastic waves touch it.
#[test]
fn a_frictionless_block_keeps_its_speed() {
    let v0 = 0.5;
    // 60 steps: 30 mm of travel keep the front edge (from x = 0.16 m) short of the row at 0.2.
    let r = slide(0.0, v0, 60);
    let last = *r.speeds.last().unwrap();
    let lowest = r.speeds.iter().cloned().fold(f64::INFINITY, f64::min);
    println!(
        "sliding, μ = 0: speed after 60 steps {last:.6} m/s (lowest {lowest:.6}), travel {:.5} m",
        r.travel
    );
    // With μ = 0.5 the speed would fall by μ·g·0.1 s ≈ 0.49 m/s. Without, the lower block's
    // top nodes that pass under the upper block's edges meet them obliquely, so the barrier
    // pushes along x too (0.7 % of v₀ at the lowest, 0.2 % left after 100 steps): 1 % and
    // 0.5 %.
    assert!((lowest - v0).abs() < 1e-2 * v0, "{lowest}");
    assert!((last - v0).abs() < 5e-3 * v0, "{last}");
}

/// A lateral force below μ·N leaves the block stuck; above it, the block slides with
/// (F − μN)/m.
#[test]
fn below_mu_n_the_block_sticks_above_it_slides() {
    let mu = 0.5;
    let slip_velocity = 1e-4;
    let steps = 100;
    let duration = steps as f64 * DT;
    let travel = |ratio: f64| {
        let bodies = slider(1.5 * D_HAT);
        let mesh = bodies.mesh();
        let upper = bodies.node_range(1).unwrap();
        // Settled without the load first, as in the sliding test.
        let mut state = settled(&bodies);
        let rest_system = sliding_setup(&bodies, mu, Some(slip_velocity), &Loads::new(mesh)).0;
        // The lateral force ratio·μ·m·g, spread evenly over the upper block's bottom nodes: no
        // tipping moment about its bottom face, so its weight stays spread over the face.
        let (mass, _, _) = body_motion(&rest_system, &bodies, 1, &state);
        let bottom: Vec<usize> = upper
            .filter(|&n| (mesh.nodes()[n].z - 0.05).abs() < 0.01)
            .collect();
        let mut loads = Loads::new(mesh);
        let each = ratio * mu * mass * G / bottom.len() as f64;
        for &node in &bottom {
            loads
                .add_nodal_force(node, Vector3::new(each, 0.0, 0.0))
                .unwrap();
        }
        let (system, force) = sliding_setup(&bodies, mu, Some(slip_velocity), &loads);
        let mut be = integrator(&system, &force);
        let start = body_motion(&system, &bodies, 1, &state).2;
        let contact = force.surface_contact().unwrap();
        let mut normal = 0.0;
        for _ in 0..steps {
            let full = force.full_displacement(&state.displacement).unwrap();
            contact.begin_friction(&full, DT).unwrap();
            normal += contact.friction_lag().unwrap().friction_limit() / (mu * mass * G);
            contact.end_friction();
            be.step(&mut state).unwrap();
        }
        println!("ratio {ratio}: mean Σλ/mg {:.4}", normal / steps as f64);
        let (mass, _, end) = body_motion(&system, &bodies, 1, &state);
        (end.x - start.x, mass)
    };
    let (stuck, mass) = travel(0.5);
    let (slid, _) = travel(1.5);
    // Stuck: the creep below ε_v moves the contact at most ε_v·T; the block's shear under the
    // load, F·h/(G·A) (F = μ·m·g/2 ≈ 1.2 N, h = 0.05 m, G ≈ 3.8e5 Pa, A = 0.01 m²) ≈ 1.6e-5 m
    // at the top, at most twice that in the load's first swing: the bound is their sum.
    let shear = 0.5 * mu * mass * G * 0.05 / (1e6 / 2.6 * 0.01);
    let bound = slip_velocity * duration + 2.0 * shear;
    // Sliding: (F − μN)/m = μg/2, backward Euler's x_n = a·dt²·n(n+1)/2.
    let a = 0.5 * mu * G;
    let expected = a * DT * DT * (steps * (steps + 1)) as f64 / 2.0;
    println!(
        "lateral force 0.5·μN: travel {stuck:.3e} m (bound {bound:.3e}); 1.5·μN: travel \
         {slid:.5} m (a·dt²·n(n+1)/2 = {expected:.5})"
    );
    assert!(stuck.abs() < bound, "stuck travel {stuck:e}");
    // Sliding at (F − μN)/m: the lagged normal forces (their mean over the run within 1e-3 of
    // m·g) and the shear waves of the load's start move the travel by far less than 2 %.
    assert!((slid / expected - 1.0).abs() < 0.02, "slid {slid}");
}

/// Two free bodies thrown at each other with a tangential relative velocity: friction between
/// them is internal, so the total momentum stays (to 1e-9 of the bodies' Σ|m·v|), and it slows
/// their relative tangential motion, which the frictionless impact leaves.
#[test]
fn friction_between_free_bodies_conserves_momentum() {
    let run = |mu: f64| {
        let side = 0.1;
        let block = || grid(Vector3::repeat(side), [2, 2, 2]);
        let b = Placement::translated(Vector3::new(side + 0.004, 0.0, 0.0)).unwrap();
        let bodies = Bodies::new(vec![(block(), Placement::identity()), (block(), b)]).unwrap();
        let mesh = bodies.mesh();
        let system = Arc::new(
            LinearSystem::new_free_body(
                mesh,
                &rubber(),
                &Constraints::new(mesh),
                &Loads::new(mesh),
                Vector3::zeros(),
                MassKind::Lumped,
                Rayleigh::default(),
            )
            .unwrap(),
        );
        let barrier = SurfaceBarrier::new(2e-3, 1e3)
            .unwrap()
            .with_friction(mu)
            .unwrap();
        let contact = SurfaceContact::new(mesh, &bodies.node_bodies(), barrier).unwrap();
        let force = Arc::new(
            NonlinearForce::new(
                Arc::new(mesh.clone()),
                ModelKind::NeoHookean.build(&rubber()),
                &system,
            )
            .unwrap()
            .with_surface_contact(contact)
            .unwrap(),
        );
        let mut be = integrator(&system, &force);
        let mut state = State::at_rest(system.free_count());
        let v = [Vector3::new(1.0, 0.5, 0.0), Vector3::new(-1.0, -0.5, 0.0)];
        state.velocity = bodies.velocity(&v).unwrap();
        let scale: f64 = (0..2)
            .map(|b| {
                let (_, p, _) = body_motion(&system, &bodies, b, &state);
                p.norm()
            })
            .sum();
        let mut drift: f64 = 0.0;
        let mut lagged = 0;
        // The gap closes in 2 ms; the impact lasts ≈ 6 ms: 16 steps see them part.
        for _ in 0..16 {
            be.step(&mut state).unwrap();
            let total = body_motion(&system, &bodies, 0, &state).1
                + body_motion(&system, &bodies, 1, &state).1;
            drift = drift.max(total.norm() / scale);
            let contact = force.surface_contact().unwrap();
            contact
                .begin_friction(&force.full_displacement(&state.displacement).unwrap(), DT)
                .unwrap();
            lagged = lagged.max(contact.friction_lag().map_or(0, |l| l.len()));
            contact.end_friction();
        }
        let (ma, pa, _) = body_motion(&system, &bodies, 0, &state);
        let (mb, pb, _) = body_motion(&system, &bodies, 1, &state);
        let iterations = be.newton_stats().unwrap().total_iterations;
        (drift, pa.y / ma - pb.y / mb, lagged, iterations)
    };
    let (drift, sliding, lagged, iterations) = run(0.5);
    let (free_drift, free_sliding, _, free_iterations) = run(0.0);
    println!(
        "free bodies: momentum drift {drift:.2e} (μ = 0: {free_drift:.2e}); relative y-speed \
         after the impact {sliding:.4} m/s (μ = 0: {free_sliding:.4}; 1.0 before); most \
         lagged pairs {lagged}; Newton iterations over 16 steps {iterations} (μ = 0: \
         {free_iterations})"
    );
    // Friction and barrier forces sum to zero per pair: only the Newton residual's sum moves
    // the momentum (see the tolerance in `integrator`).
    assert!(drift < 1e-9, "momentum drift {drift:e}");
    assert!(lagged > 0, "friction was lagged in contact");
    // Frictionless: the faces' normal push leaves the tangential speed but for the pairs at
    // the faces' edges, which push obliquely once the faces have shifted along y (2 % seen):
    // 5 %, far from friction's effect below.
    assert!((free_sliding - 1.0).abs() < 0.05, "{free_sliding}");
    // With μ = 0.5 the normal impulse (≈ 2 m/s of relative normal speed turned) bounds the
    // tangential one by μ·2 = 1 m/s: a clear slow-down, above a tenth of the speed.
    assert!(sliding < 0.9, "{sliding}");
}

/// The force is −∂(E + B + D)/∂u: central differences of the potential during a step with
/// lagged friction agree with it, at slips on both sides of the smoothing distance ε.
#[test]
fn friction_force_is_the_potential_gradient() {
    let side = 0.1;
    let block = || grid(Vector3::repeat(side), [2, 2, 2]);
    let gap = 0.5 * 2e-3;
    let b = Placement::translated(Vector3::new(side + gap, 0.0, 0.0)).unwrap();
    let bodies = Bodies::new(vec![(block(), Placement::identity()), (block(), b)]).unwrap();
    let mesh = bodies.mesh();
    let system = LinearSystem::new_free_body(
        mesh,
        &rubber(),
        &Constraints::new(mesh),
        &Loads::new(mesh),
        Vector3::zeros(),
        MassKind::Lumped,
        Rayleigh::default(),
    )
    .unwrap();
    // ε = ε_v·dt = 1e-5 m: the slips below (1e-5 m waves plus a 1.5e-5 m shift of body 1
    // along y) fall on both sides of it.
    let barrier = SurfaceBarrier::new(2e-3, 1e3)
        .unwrap()
        .with_friction(0.5)
        .unwrap()
        .with_slip_velocity(1e-2)
        .unwrap();
    let contact = SurfaceContact::new(mesh, &bodies.node_bodies(), barrier).unwrap();
    let force = NonlinearForce::new(
        Arc::new(mesh.clone()),
        ModelKind::NeoHookean.build(&rubber()),
        &system,
    )
    .unwrap()
    .with_surface_contact(contact)
    .unwrap();
    let n = system.free_count();
    force.begin_step(&vec![0.0; n], DT).unwrap();
    let lag = force.surface_contact().unwrap().friction_lag().unwrap();
    assert!(!lag.is_empty());
    assert!((lag.epsilon() - 1e-5).abs() < 1e-20);
    let upper = bodies.node_range(1).unwrap();
    let u: Vec<f64> = (0..n)
        .map(|i| {
            let shift = if upper.contains(&(i / 3)) && i % 3 == 1 {
                1.5e-5
            } else {
                0.0
            };
            1e-5 * ((i as f64) * 0.7).sin() + shift
        })
        .collect();
    let x = force
        .surface_contact()
        .unwrap()
        .positions(&force.full_displacement(&u).unwrap())
        .unwrap();
    let slip = lag.largest_slip(&x);
    let mut work = force.workspace().unwrap();
    let mut f = vec![0.0; n];
    force.force_into(&u, &mut work, &mut f).unwrap();
    // Friction's own part: the force with and without the lag.
    let mut without = vec![0.0; n];
    force.end_friction();
    force.force_into(&u, &mut work, &mut without).unwrap();
    let friction = f
        .iter()
        .zip(&without)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    force.begin_step(&vec![0.0; n], DT).unwrap();
    let largest = f.iter().map(|v| v.abs()).fold(0.0, f64::max);
    let h = 1e-9;
    let mut worst: f64 = 0.0;
    for i in (0..n).step_by(5) {
        let (mut up, mut down) = (u.clone(), u.clone());
        up[i] += h;
        down[i] -= h;
        let fd = -(force.potential_energy(&up).unwrap() - force.potential_energy(&down).unwrap())
            / (2.0 * h);
        worst = worst.max((fd - f[i]).abs());
    }
    force.end_friction();
    println!(
        "friction derivative check: largest slip {slip:.3e} m (ε 1e-5), largest friction force \
         {friction:.3e} N, largest |f − FD| {worst:.3e} N of max |f| {largest:.3e} N"
    );
    assert!(friction > 0.0);
    // h = 1e-9 m against ε = 1e-5 m: truncation O(h²·f‴) with f‴ ~ μλ/ε² and round-off
    // O(ε_mach·E/h) are both below 1e-5 of the largest force (the barrier's).
    assert!(worst < 1e-5 * largest, "{worst:e} vs {largest:e}");
    // And below a millionth... of friction's own size the check is not blind to it.
    assert!(
        worst < 1e-3 * friction,
        "{worst:e} vs friction {friction:e}"
    );
}

/// Friction's Hessian is the derivative of its gradient (central differences on the lag
/// alone), and positive semi-definite.
#[test]
fn friction_hessian_is_the_gradient_derivative() {
    let side = 0.1;
    let block = || grid(Vector3::repeat(side), [1, 1, 1]);
    let b = Placement::translated(Vector3::new(side + 1e-3, 0.0, 0.0)).unwrap();
    let bodies = Bodies::new(vec![(block(), Placement::identity()), (block(), b)]).unwrap();
    let mesh = bodies.mesh();
    let barrier = SurfaceBarrier::new(2e-3, 1e3)
        .unwrap()
        .with_friction(0.3)
        .unwrap();
    let contact = SurfaceContact::new(mesh, &bodies.node_bodies(), barrier).unwrap();
    let x0 = contact
        .positions(&vec![0.0; 3 * mesh.node_count()])
        .unwrap();
    let found = tetfem::contact::surface::candidates(contact.surface(), &x0, None, 2e-3).unwrap();
    let epsilon = 1e-5;
    let lag =
        SurfaceFrictionLag::new(&barrier, contact.surface(), &x0, &found, 0.3, epsilon).unwrap();
    assert!(!lag.is_empty());
    let dofs = 3 * mesh.node_count();
    let x: Vec<Vector3<f64>> = x0
        .iter()
        .enumerate()
        .map(|(n, p)| p + 1e-5 * Vector3::new(0.0, (n as f64).sin(), (1.3 * n as f64).cos()))
        .collect();
    let mut h = vec![vec![0.0; dofs]; dofs];
    for (r, c, v) in lag.hessian_triplets(&x) {
        h[r][c] += v;
    }
    let step = 1e-10;
    let mut worst: f64 = 0.0;
    let mut largest: f64 = 0.0;
    for j in 0..dofs {
        let (mut up, mut down) = (x.clone(), x.clone());
        up[j / 3][j % 3] += step;
        down[j / 3][j % 3] -= step;
        let (mut gu, mut gd) = (vec![0.0; dofs], vec![0.0; dofs]);
        lag.add_gradient(&up, &mut gu).unwrap();
        lag.add_gradient(&down, &mut gd).unwrap();
        for i in 0..dofs {
            let fd = (gu[i] - gd[i]) / (2.0 * step);
            worst = worst.max((fd - h[i][j]).abs());
            largest = largest.max(h[i][j].abs());
        }
    }
    // PSD: vᵀHv ≥ 0 for a few directions (to round-off of the entries' size).
    for k in 0..5 {
        let v: Vec<f64> = (0..dofs).map(|i| ((i * (k + 2)) as f64).sin()).collect();
        let q: f64 = (0..dofs)
            .map(|i| (0..dofs).map(|j| v[i] * h[i][j] * v[j]).sum::<f64>())
            .sum();
        assert!(q >= -1e-12 * largest * dofs as f64, "vᵀHv = {q:e}");
    }
    println!("friction Hessian: largest |H − FD| {worst:.3e} of max |H| {largest:.3e} N/m");
    // Steps of 1e-10 m against slips of 1e-5 m (ε 1e-5 m): truncation ~ (h/y)² and round-off
    // ~ ε_mach·|g|/h both far below 1e-4 of the largest entry; the kink of f₁′ at y = ε is
    // not within h of any pair's slip here.
    assert!(worst < 1e-4 * largest, "{worst:e} vs {largest:e}");
}

/// Friction needs a normal force: bodies apart by more than d̂ lag nothing and feel the same
/// force as without friction, bit for bit.
#[test]
fn friction_with_zero_normal_force_does_nothing() {
    let side = 0.1;
    let block = || grid(Vector3::repeat(side), [2, 2, 2]);
    let b = Placement::translated(Vector3::new(side + 5e-3, 0.0, 0.0)).unwrap();
    let bodies = Bodies::new(vec![(block(), Placement::identity()), (block(), b)]).unwrap();
    let mesh = bodies.mesh();
    let system = LinearSystem::new_free_body(
        mesh,
        &rubber(),
        &Constraints::new(mesh),
        &Loads::new(mesh),
        Vector3::zeros(),
        MassKind::Lumped,
        Rayleigh::default(),
    )
    .unwrap();
    let forces: Vec<Vec<f64>> = [0.0, 0.8]
        .iter()
        .map(|&mu| {
            let barrier = SurfaceBarrier::new(2e-3, 1e3)
                .unwrap()
                .with_friction(mu)
                .unwrap();
            let contact = SurfaceContact::new(mesh, &bodies.node_bodies(), barrier).unwrap();
            let force = NonlinearForce::new(
                Arc::new(mesh.clone()),
                ModelKind::NeoHookean.build(&rubber()),
                &system,
            )
            .unwrap()
            .with_surface_contact(contact)
            .unwrap();
            let n = system.free_count();
            force.begin_step(&vec![0.0; n], DT).unwrap();
            let lagged = force.surface_contact().unwrap().friction_lag();
            assert_eq!(lagged.map_or(0, |l| l.len()), 0, "μ = {mu}");
            let u: Vec<f64> = (0..n).map(|i| 1e-4 * ((i as f64) * 0.3).sin()).collect();
            let mut f = vec![0.0; n];
            force
                .force_into(&u, &mut force.workspace().unwrap(), &mut f)
                .unwrap();
            f
        })
        .collect();
    assert_eq!(forces[0], forces[1]);
}

/// A friction coefficient that is negative or not finite is refused naming the value.
#[test]
fn bad_friction_is_an_error_naming_the_value() {
    let barrier = SurfaceBarrier::new(2e-3, 1e3).unwrap();
    for (mu, text) in [(-0.2, "-0.2"), (f64::NAN, "NaN"), (f64::INFINITY, "inf")] {
        let err = barrier.with_friction(mu).unwrap_err();
        let message = err.to_string();
        assert!(matches!(err, Error::InvalidParameter { .. }), "{message}");
        assert!(
            message.contains("friction") && message.contains(text),
            "{message}"
        );
    }
    // A field set by hand is checked where the contact is made.
    let mut bad = barrier;
    bad.friction = -1.0;
    let bodies = Bodies::new(vec![(
        grid(Vector3::repeat(0.1), [1, 1, 1]),
        Placement::identity(),
    )])
    .unwrap();
    let err = SurfaceContact::new(bodies.mesh(), &bodies.node_bodies(), bad).unwrap_err();
    assert!(err.to_string().contains("friction"), "{err}");
    let err = barrier.with_slip_velocity(0.0).unwrap_err().to_string();
    assert!(err.contains("slip_velocity"), "{err}");
}

/// The problem definition every front end builds ([`Definition::surface_contact`] with the
/// barrier's μ, stepped by [`Transient`]) carries the friction: the impact of
/// `friction_between_free_bodies_conserves_momentum` through it slows the relative tangential
/// speed as the direct force does, and not without μ.
#[test]
fn the_definition_route_carries_surface_friction() {
    let relative_y = |mu: f64| {
        let side = 0.1;
        let block = || grid(Vector3::repeat(side), [2, 2, 2]);
        let b = Placement::translated(Vector3::new(side + 0.004, 0.0, 0.0)).unwrap();
        let bodies = Bodies::new(vec![(block(), Placement::identity()), (block(), b)]).unwrap();
        let mesh = bodies.mesh().clone();
        let materials = MaterialMap::uniform(rubber(), mesh.tet_count());
        let barrier = SurfaceBarrier::new(2e-3, 1e3)
            .unwrap()
            .with_friction(mu)
            .unwrap();
        let definition = Definition::builder(mesh, materials)
            .model(ModelKind::NeoHookean)
            .surface_contact(barrier, bodies.node_bodies())
            .unwrap()
            .build()
            .unwrap();
        let mut options = TransientOptions::new(Method::BackwardEuler, TimeStep::Seconds(DT));
        // The direct test's Newton budget: with friction between the faces Newton converges
        // linearly in this impact (the default 25 iterations end at 1e-8 of the residual).
        options.solver.newton = StepNewtonOptions {
            tolerance: 1e-11,
            max_iterations: 200,
            relax_contact_nodes: true,
        };
        let mut run = Transient::new(&definition, options).unwrap();
        let v = [Vector3::new(1.0, 0.5, 0.0), Vector3::new(-1.0, -0.5, 0.0)];
        run.state_mut().velocity = bodies.velocity(&v).unwrap();
        run.run((0, 16), &mut Unobserved).unwrap();
        let InternalForce::Nonlinear(force) = run.force() else {
            panic!("surface contact runs through the nonlinear force");
        };
        assert_eq!(force.surface_contact().unwrap().barrier().friction, mu);
        let velocity = &run.state().velocity;
        let mean_y = |body: usize| {
            let nodes: Vec<usize> = bodies.node_range(body).unwrap().collect();
            nodes.iter().map(|&n| velocity[3 * n + 1]).sum::<f64>() / nodes.len() as f64
        };
        mean_y(0) - mean_y(1)
    };
    let (with, without) = (relative_y(0.5), relative_y(0.0));
    println!(
        "definition route: relative y-speed after the impact {with:.4} m/s (μ = 0: {without:.4})"
    );
    // As in the direct test: friction slows the tangential motion well below 0.9 m/s, the
    // frictionless impact leaves it within 5 % of 1 m/s (a plain node mean here: the blocks'
    // lumped masses are equal node for node, so it is the same comparison).
    assert!(with < 0.9, "{with}");
    assert!((without - 1.0).abs() < 0.05, "{without}");
}
