//! Body–body contact with Newmark and the explicit method (issue 36): the two-block head-on
//! impact of `self_contact_solve.rs` (its builders), stepped by Newmark with the surface
//! barrier at the step's end, and by symplectic Euler at the step bound the barrier sets.

use std::sync::Arc;

use nalgebra::Vector3;
use tetfem::analysis::dynamics::{
    EXPLICIT_SURFACE_DISTANCE_FRACTION, Integrator, IntegratorOptions, InternalForce, LinearSystem,
    Method, Newmark, NonlinearForce, State, StepNewtonOptions, SymplecticEuler, critical_time_step,
    surface_step_bound,
};
use tetfem::analysis::transient::{TimeStep, Transient, TransientOptions};
use tetfem::analysis::{Analysis, Combination, Definition};
use tetfem::base::warning::Warning;
use tetfem::contact::surface::SurfaceBarrier;
use tetfem::fe::materials::MaterialMap;
use tetfem::mesh::bodies::{Bodies, Placement};
use tetfem::model::{ModelElement, ModelKind};
use tetfem::{CellType, Error, Tet4, Tet10, TetMesh};

use crate::self_contact_solve::{
    D_HAT, KAPPA, SIDE, block, body_momenta, rubber, setup, two_blocks,
};

/// What a head-on run measured.
#[derive(Debug, Default)]
struct Measured {
    /// max over the steps of |Σ momentum_x| / Σ|m·v| at the start.
    momentum_drift: f64,
    /// The largest rise of kinetic + elastic + barrier energy over one step (J).
    largest_rise: f64,
    /// The largest |E − E₀| over the run (J).
    largest_change: f64,
    start_energy: f64,
    end_energy: f64,
    relative_start: f64,
    relative_end: f64,
    smallest_distance: f64,
    /// The displacement at the smallest distance.
    closest: Vec<f64>,
    steps: usize,
}

impl Measured {
    fn print(&self, name: &str) {
        println!(
            "{name}: {} steps, momentum drift {:.2e}, energy {:.6e} → {:.6e} J (largest rise \
             over a step {:.2e} J, largest |E − E₀| {:.2e} J), relative velocity {:.4} → \
             {:.4} m/s (restitution {:.4}), smallest distance {:.3e} m (d̂ {D_HAT:e})",
            self.steps,
            self.momentum_drift,
            self.start_energy,
            self.end_energy,
            self.largest_rise,
            self.largest_change,
            self.relative_start,
            self.relative_end,
            -self.relative_end / self.relative_start,
            self.smallest_distance
        );
    }
}

/// Steps `integrator` from `state` `steps` times (or until `step` fails, returned), checking
/// after each the exact intersection test and recording momentum, energy and distance.
fn watch<C: CellType>(
    (system, force, bodies): (&LinearSystem, &NonlinearForce, &Bodies<C>),
    state: &mut State,
    steps: usize,
    step: &mut dyn FnMut(&mut State) -> Result<(), Error>,
) -> (Measured, Option<Error>) {
    let contact = force.surface_contact().unwrap();
    let total = |state: &State| {
        force.energy(system, state).unwrap().total()
            + force.surface_energy(&state.displacement).unwrap()
    };
    let relative = |state: &State| {
        let p = body_momenta(system, bodies, &state.velocity);
        p[1].1 / p[1].0 - p[0].1 / p[0].0
    };
    let scale: f64 = body_momenta(system, bodies, &state.velocity)
        .iter()
        .map(|(_, p)| p.abs())
        .sum();
    let mut out = Measured {
        start_energy: total(state),
        relative_start: relative(state),
        smallest_distance: f64::INFINITY,
        largest_rise: f64::NEG_INFINITY,
        ..Measured::default()
    };
    let mut previous = out.start_energy;
    let mut failure = None;
    for _ in 0..steps {
        if let Err(e) = step(state) {
            failure = Some(e);
            break;
        }
        let u = &state.displacement;
        let crossing = contact.intersections(u).unwrap();
        assert!(
            crossing.is_empty(),
            "step {}: triangles {:?} intersect",
            state.steps,
            crossing.first()
        );
        let d = contact.smallest_distance(u).unwrap();
        if d < out.smallest_distance {
            out.smallest_distance = d;
            out.closest = u.clone();
        }
        let p: f64 = body_momenta(system, bodies, &state.velocity)
            .iter()
            .map(|(_, p)| p)
            .sum();
        out.momentum_drift = out.momentum_drift.max(p.abs() / scale);
        let energy = total(state);
        out.largest_rise = out.largest_rise.max(energy - previous);
        out.largest_change = out.largest_change.max((energy - out.start_energy).abs());
        previous = energy;
        out.steps += 1;
    }
    out.end_energy = previous;
    out.relative_end = relative(state);
    (out, failure)
}

/// The two blocks 1 cm apart at ±`speed` along x.
fn start<C: CellType>(bodies: &Bodies<C>, n: usize, speed: f64) -> State {
    let mut state = State::at_rest(n);
    let v = [
        Vector3::new(speed, 0.0, 0.0),
        Vector3::new(-speed, 0.0, 0.0),
    ];
    state.velocity = bodies.velocity(&v).unwrap();
    state
}

/// Newmark on the head-on impact of `bodies`: 24 steps of 1 ms (contact from 4 ms to ≈ 15 ms).
fn newmark_head_on<C: ModelElement>(bodies: Bodies<C>, kind: ModelKind) -> Measured {
    let barrier = SurfaceBarrier::new(D_HAT, KAPPA).unwrap();
    let (system, force) = setup(&bodies, kind, barrier);
    let options = IntegratorOptions {
        // As in self_contact_solve's backward Euler run: the momentum error of a step is
        // dt·Σr over its last residual, so 1e-11 of the step's reference keeps the run's drift
        // far below 1e-9.
        newton: StepNewtonOptions {
            tolerance: 1e-11,
            max_iterations: 200,
            relax_contact_nodes: true,
        },
        ..IntegratorOptions::default()
    };
    let mut newmark = Newmark::with_force(
        Arc::clone(&system),
        InternalForce::Nonlinear(Arc::clone(&force)),
        1e-3,
        options,
    )
    .unwrap();
    let mut state = start(&bodies, system.free_count(), 1.0);
    let (measured, failure) = watch((&system, &force, &bodies), &mut state, 24, &mut |s| {
        newmark.step(s)
    });
    assert!(failure.is_none(), "{failure:?}");
    let stats = newmark.newton_stats().unwrap();
    println!(
        "newmark {}: {} Newton iterations over 24 steps (most in one step {})",
        kind.name(),
        stats.total_iterations,
        stats.max_per_step
    );
    measured
}

fn check_newmark(r: &Measured, allowed_rise: f64) {
    // Barrier and elastic forces are internal: the Newton residual's sum alone moves the
    // momentum (see the tolerance in `newmark_head_on`).
    assert!(r.momentum_drift < 1e-9, "{:e}", r.momentum_drift);
    // The bodies met (a pair within d̂) and turned back.
    assert!(r.smallest_distance > 0.0 && r.smallest_distance < D_HAT);
    assert!(r.relative_start < 0.0 && r.relative_end > 0.0);
    assert!(
        r.largest_rise <= allowed_rise * r.start_energy,
        "energy rose by {:e} J over a step",
        r.largest_rise
    );
}

/// Linear elasticity: the trapezoid on the elastic force is exact, so the energy test is the
/// contact's alone.
#[test]
fn newmark_linear_blocks_bounce_without_gaining_energy() {
    let r = newmark_head_on(two_blocks(3, 0.01), ModelKind::Linear);
    r.print("newmark, linear");
    // End-point contact never adds energy where the barrier is convex along the step, and the
    // linear model's trapezoid is exact: what remains is the Newton tolerance's, ~1e-11
    // relative per step (measured 1e-15 J), allowed up to 1e-9 of the start energy.
    check_newmark(&r, 1e-9);
}

/// Neo-Hookean: the trapezoid on a non-quadratic energy is exact to O(dt³) per step only.
#[test]
fn newmark_neo_hookean_blocks_bounce_without_gaining_energy() {
    let r = newmark_head_on(two_blocks(3, 0.01), ModelKind::NeoHookean);
    r.print("newmark, neo-hookean");
    // The same impact with the linear model rises by 1e-15 J at most: the contact's end point
    // adds nothing, and the rise left here is the trapezoid's on the Neo-Hookean energy
    // (exact for quadratic energies only), measured 8.8e-5 of the start energy over one
    // 1 ms step during the squeeze; bounded at 2e-4. Over the impact the energy falls.
    check_newmark(&r, 2e-4);
    assert!(r.end_energy < r.start_energy);
}

/// 10-node tets (contact on the quadratic faces' linear sub-triangles): 2×2×2-cell blocks.
#[test]
fn newmark_quadratic_blocks_bounce_without_gaining_energy() {
    let b = Placement::translated(Vector3::new(SIDE + 0.01, 0.0, 0.0)).unwrap();
    let quadratic = || TetMesh::<Tet10>::from_linear(&block(2)).unwrap();
    let bodies = Bodies::new(vec![(quadratic(), Placement::identity()), (quadratic(), b)]).unwrap();
    let r = newmark_head_on(bodies, ModelKind::NeoHookean);
    r.print("newmark, neo-hookean, 10-node tets");
    // As for the 4-node Neo-Hookean run: the trapezoid's own error on a non-quadratic energy,
    // measured 1.1e-4 of the start energy over one step, bounded at 2e-4.
    check_newmark(&r, 2e-4);
    assert!(r.end_energy < r.start_energy);
}

/// The definition route (what scenes and Python run): Newmark is admitted with a warning that
/// impacts lose energy, the explicit method without one, the modal analysis refused.
#[test]
fn the_rule_admits_newmark_with_a_warning_and_explicit() {
    let combination = |analysis| Combination {
        model: ModelKind::NeoHookean,
        analysis,
        surface_contact: true,
        ..Combination::default()
    };
    let warnings = combination(Analysis::Transient(Method::Newmark))
        .check()
        .unwrap();
    assert!(
        matches!(
            warnings.as_slice(),
            [Warning::ImpactLosesEnergy {
                method: "newmark",
                ..
            }]
        ),
        "{warnings:?}"
    );
    println!("{}", warnings[0]);
    for method in [Method::Explicit, Method::BackwardEuler] {
        let warnings = combination(Analysis::Transient(method)).check().unwrap();
        assert!(warnings.is_empty(), "{method:?}: {warnings:?}");
    }
    let err = combination(Analysis::Modal)
        .check()
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("surface_contact") && err.contains("modal"),
        "{err}"
    );
}

/// Friction between bodies is lagged at the implicit dynamic methods' steps only: a static
/// solve or an explicit step would ignore μ, so the rule refuses it there, naming friction.
#[test]
fn friction_between_bodies_is_refused_where_nothing_lags_it() {
    let with_friction = |analysis| Combination {
        model: ModelKind::NeoHookean,
        analysis,
        surface_contact: true,
        surface_friction: true,
        ..Combination::default()
    };
    for analysis in [Analysis::Static, Analysis::Transient(Method::Explicit)] {
        let err = with_friction(analysis).check().unwrap_err().to_string();
        assert!(
            err.contains("friction") && err.contains(analysis.name().as_str()),
            "{err}"
        );
    }
    for method in [Method::BackwardEuler, Method::Newmark] {
        assert!(with_friction(Analysis::Transient(method)).check().is_ok());
    }
}

/// The definition of the head-on impact with barrier stiffness `kappa`.
fn definition(bodies: &Bodies<Tet4>, kappa: f64) -> Definition {
    let mesh = bodies.mesh().clone();
    let materials = MaterialMap::uniform(rubber(), mesh.tet_count());
    Definition::builder(mesh, materials)
        .model(ModelKind::NeoHookean)
        .surface_contact(
            SurfaceBarrier::new(D_HAT, kappa).unwrap(),
            bodies.node_bodies(),
        )
        .unwrap()
        .build()
        .unwrap()
}

/// The explicit method at the default step (the critical step, which with surface contact is
/// the barrier's bound): no intersection at any step, momentum kept, energy bounded.
#[test]
fn explicit_blocks_bounce_at_the_default_step() {
    let bodies = two_blocks(3, 0.01);
    let definition = definition(&bodies, KAPPA);
    let options = TransientOptions::new(Method::Explicit, TimeStep::CriticalMultiple(1.0));
    let mut run = Transient::new(&definition, options).unwrap();
    let limit = run.step_limit().unwrap();
    let InternalForce::Nonlinear(force) = run.force().clone() else {
        panic!("surface contact runs through the nonlinear force");
    };
    let system = Arc::clone(run.system());
    let body = critical_time_step(&system).unwrap().dt;
    let bound = surface_step_bound(&system, force.surface_contact().unwrap(), body).unwrap();
    println!("explicit: {limit:?}; body alone {body:.4e} s; {bound:?}");
    assert_eq!(limit.source, "surface barrier bound");
    assert_eq!(limit.dt, bound.dt);
    // The barrier at d̂/10 is far stiffer than the rubber here: it sets the step.
    assert!(bound.dt < body, "{} vs {body}", bound.dt);
    *run.state_mut() = start(&bodies, system.free_count(), 1.0);
    // 25 ms: the blocks meet at 4 ms and part by ≈ 16 ms.
    let steps = (0.025 / limit.dt).ceil() as usize;
    let (integrator, state) = run.parts_mut();
    let (r, failure) = watch((&system, &force, &bodies), state, steps, &mut |s| {
        integrator.step(s)
    });
    r.print("explicit, neo-hookean, default dt");
    assert!(failure.is_none(), "{failure:?}");
    // Symplectic Euler's forces are internal and sum to round-off: momentum is kept to far
    // below 1e-9 without any solve.
    assert!(r.momentum_drift < 1e-9, "{:e}", r.momentum_drift);
    assert!(r.smallest_distance >= EXPLICIT_SURFACE_DISTANCE_FRACTION * D_HAT);
    assert!(r.relative_start < 0.0 && r.relative_end > 0.0);
    // The bound against the step's stiffness where the bodies came closest: the largest
    // eigenvalue of M^{-1/2}·K_T·M^{-1/2} (K_T with the barrier's projected Hessian, its
    // off-pattern entries lumped onto the diagonal: above the exact one) by power iteration.
    let omega2 = largest_eigenvalue(&system, &force, &r.closest);
    let bound_omega2 = (2.0 / limit.dt).powi(2);
    println!(
        "at the closest approach ({:.3e} m): ω² = {omega2:.4e} 1/s², the bound's {bound_omega2:.4e} \
         ({:.1}× above)",
        r.smallest_distance,
        bound_omega2 / omega2
    );
    // Power iteration converges from below; run to a relative change of 1e-9, it is the
    // eigenvalue to far better than the margin asserted.
    assert!(omega2 <= bound_omega2, "{omega2:e} > {bound_omega2:e}");
    // A stable symplectic step keeps a modified energy: the total (with the velocity half a
    // step behind) oscillates by O(ω·dt) about it without drift; measured below 1 % here,
    // bounded at 2 % of the start energy.
    assert!(
        r.largest_change <= 0.02 * r.start_energy,
        "|E − E₀| reached {:e} J of {:e} J",
        r.largest_change,
        r.start_energy
    );
}

/// A dt above the barrier's bound is refused when the integrator is made, naming both.
#[test]
fn explicit_dt_above_the_barrier_bound_is_an_error_naming_both() {
    let bodies = two_blocks(3, 0.01);
    let barrier = SurfaceBarrier::new(D_HAT, KAPPA).unwrap();
    let (system, force) = setup(&bodies, ModelKind::NeoHookean, barrier);
    let body = critical_time_step(&system).unwrap().dt;
    let bound = surface_step_bound(&system, force.surface_contact().unwrap(), body).unwrap();
    // 0.9 of the body's own critical step: stable without contact, above the barrier's bound.
    let dt = 0.9 * body;
    assert!(dt > bound.dt);
    let err = SymplecticEuler::with_force(
        Arc::clone(&system),
        InternalForce::Nonlinear(Arc::clone(&force)),
        dt,
    )
    .unwrap_err();
    let text = err.to_string();
    println!("{text}");
    assert!(matches!(err, Error::InvalidParameter { .. }));
    let short = tetfem::base::error::short_number;
    assert!(text.contains(&short(dt)), "{text}");
    assert!(text.contains(&short(bound.dt)), "{text}");
    // At the bound it runs; a larger step set later is refused the same way.
    let mut explicit = SymplecticEuler::with_force(
        Arc::clone(&system),
        InternalForce::Nonlinear(force),
        bound.dt,
    )
    .unwrap();
    assert!(explicit.set_time_step(dt).is_err());
    assert_eq!(explicit.time_step(), bound.dt);
}

/// A barrier far too soft for the impact: the run stops by name at the step that brings a pair
/// below d̂/10 (where the bound no longer holds), before any intersection.
#[test]
fn explicit_with_a_barrier_too_soft_stops_naming_the_step() {
    let bodies = two_blocks(3, 0.01);
    let definition = definition(&bodies, 1e-3);
    let options = TransientOptions::new(Method::Explicit, TimeStep::CriticalMultiple(0.9));
    let mut run = Transient::new(&definition, options).unwrap();
    let InternalForce::Nonlinear(force) = run.force().clone() else {
        panic!("surface contact runs through the nonlinear force");
    };
    let system = Arc::clone(run.system());
    let dt = run.integrator().time_step();
    *run.state_mut() = start(&bodies, system.free_count(), 1.0);
    let steps = (0.025 / dt).ceil() as usize;
    let (integrator, state) = run.parts_mut();
    let (r, failure) = watch((&system, &force, &bodies), state, steps, &mut |s| {
        integrator.step(s)
    });
    let Some(Error::Diverged { step, reason, .. }) = failure else {
        panic!("the soft barrier ran through: {failure:?}");
    };
    println!(
        "stopped at step {step} after {} clean steps: {reason}",
        r.steps
    );
    assert_eq!(step, r.steps + 1);
    assert!(reason.contains("surface"), "{reason}");
}

/// λ_max of M^{-1/2}·K_T(u)·M^{-1/2} (1/s²) by power iteration, K_T the force's projected
/// tangent with contact (lumped mass).
fn largest_eigenvalue(system: &LinearSystem, force: &NonlinearForce, u: &[f64]) -> f64 {
    let tetfem::analysis::dynamics::Mass::Lumped(m) = system.mass() else {
        panic!("lumped mass");
    };
    let mut work = force.workspace().unwrap();
    let mut k = force.zero_tangent().unwrap();
    force.tangent_into(u, true, &mut work, &mut k).unwrap();
    let n = u.len();
    let scale: Vec<f64> = m.iter().map(|m| 1.0 / m.sqrt()).collect();
    let mut x: Vec<f64> = (0..n)
        .map(|i| 1.0 + 0.3 * ((i as f64) * 0.77).sin())
        .collect();
    let (mut y, mut z) = (vec![0.0; n], vec![0.0; n]);
    let mut lambda = 0.0;
    for _ in 0..20_000 {
        let norm = x.iter().map(|v| v * v).sum::<f64>().sqrt();
        x.iter_mut().for_each(|v| *v /= norm);
        for i in 0..n {
            z[i] = scale[i] * x[i];
        }
        k.mul_vec(&z, &mut y).unwrap();
        for i in 0..n {
            y[i] *= scale[i];
        }
        let next: f64 = x.iter().zip(&y).map(|(a, b)| a * b).sum();
        std::mem::swap(&mut x, &mut y);
        if (next - lambda).abs() <= 1e-9 * next {
            return next;
        }
        lambda = next;
    }
    lambda
}

/// Where the Neo-Hookean Newmark rise comes from: the same blocks far apart (no pair within
/// d̂, the barrier inactive), each squeezed by a velocity field v_x = −ε̇·(x − x_c) of the
/// impact's strain rate, rise over a step without any contact — the trapezoid on the
/// non-quadratic elastic energy, not the end-point barrier.
#[test]
fn newmark_neo_hookean_rises_without_contact_too() {
    let bodies = two_blocks(3, 0.5);
    let barrier = SurfaceBarrier::new(D_HAT, KAPPA).unwrap();
    let (system, force) = setup(&bodies, ModelKind::NeoHookean, barrier);
    let options = IntegratorOptions {
        newton: StepNewtonOptions {
            tolerance: 1e-11,
            max_iterations: 200,
            relax_contact_nodes: true,
        },
        ..IntegratorOptions::default()
    };
    let mut newmark = Newmark::with_force(
        Arc::clone(&system),
        InternalForce::Nonlinear(Arc::clone(&force)),
        1e-3,
        options,
    )
    .unwrap();
    let mesh = bodies.mesh();
    let node_body = bodies.node_bodies();
    let mut state = State::at_rest(system.free_count());
    // 20 1/s: the 2 m/s closing over the 0.1 m blocks.
    for (n, x) in mesh.nodes().iter().enumerate() {
        let centre = SIDE / 2.0 + node_body[n] as f64 * (SIDE + 0.5);
        state.velocity[3 * n] = -20.0 * (x.x - centre);
    }
    let (r, failure) = watch((&system, &force, &bodies), &mut state, 24, &mut |s| {
        newmark.step(s)
    });
    assert!(failure.is_none(), "{failure:?}");
    println!(
        "newmark, neo-hookean, no contact: largest rise over a step {:.2e} J of {:.3e} J \
         (smallest distance {:.3e} m)",
        r.largest_rise, r.start_energy, r.smallest_distance
    );
    assert!(r.smallest_distance.is_infinite(), "no pair within d̂");
    // The Newton tolerance leaves ~1e-11 of the energy per step: a rise above 1e-9 of it is
    // the integrator's own on this energy.
    assert!(
        r.largest_rise > 1e-9 * r.start_energy,
        "{:e}",
        r.largest_rise
    );
}
