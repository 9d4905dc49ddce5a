//! Time integration: stability exactly where theory puts it, energy behaviour of each method,
//! frequencies against modal analysis and beam theory, the static limit, and orders of accuracy.

use std::sync::Arc;

use nalgebra::Vector3;
use tetfem::analysis::dynamics::{
    BackwardEuler, Integrator, IntegratorOptions, InternalForce, LinearSystem, MassKind, Method,
    NonlinearForce, Rayleigh, State, critical_time_step, element_critical_step,
};
use tetfem::analysis::modal::lowest_modes;
use tetfem::linalg::iterative::CgOptions;
use tetfem::model::ModelKind;
use tetfem::{BoxSplit, CholeskyOptions, Error, LinearMethod, Material, SparseCholesky};
use tetfem_fixtures::cantilever::Cantilever;

/// A clamped box beam L × 1 × 1 with `cells`, E = 1e5, ν = 0.3, ρ = 1000 and a unit end load
/// (−z), lumped mass, no gravity. Returns the system and the free indices of the tip z-DOFs.
fn beam(
    length: f64,
    cells: [usize; 3],
    mass: MassKind,
) -> (Arc<LinearSystem>, Vec<usize>, tetfem::TetMesh) {
    wide_beam(length, 1.0, cells, mass)
}

/// As [`beam`] with a chosen width (y). A width of 2 separates the first bending mode (in z)
/// from the bending in y, which on a square section has nearly the same frequency and, through
/// the lecture split's slight asymmetry, mixes with it.
fn wide_beam(
    length: f64,
    width: f64,
    cells: [usize; 3],
    mass: MassKind,
) -> (Arc<LinearSystem>, Vec<usize>, tetfem::TetMesh) {
    let problem = Cantilever {
        length,
        width,
        split: BoxSplit::Lecture6,
        ..Cantilever::peer_benchmark(cells)
    };
    let mesh = problem.mesh().unwrap();
    let constraints = problem.constraints(&mesh).unwrap();
    let loads = problem.loads(&mesh).unwrap();
    let system = LinearSystem::new(
        &mesh,
        &problem.material,
        &constraints,
        &loads,
        Vector3::zeros(),
        mass,
        Rayleigh::default(),
    )
    .unwrap();
    let tip: Vec<usize> = problem
        .tip_nodes(&mesh)
        .iter()
        .map(|&n| system.dofs().free_index(3 * n + 2).unwrap())
        .collect();
    (Arc::new(system), tip, mesh)
}

/// The static shape under the end load, and the same system unloaded (free vibration from it).
fn released(system: &LinearSystem) -> (Arc<LinearSystem>, State) {
    let shape = system.static_displacement().unwrap();
    (
        Arc::new(system.clone().with_load_factor(0.0)),
        State::released_from(shape),
    )
}

fn tip(state: &State, tip: &[usize]) -> f64 {
    tip.iter().map(|&i| state.displacement[i]).sum::<f64>() / tip.len() as f64
}

#[test]
fn explicit_is_stable_below_the_critical_step_and_diverges_above_it() {
    let mut critical = Vec::new();
    for cells in [[8, 2, 2], [16, 4, 4]] {
        let (loaded, _, mesh) = beam(4.0, cells, MassKind::Lumped);
        let system = Arc::new(loaded.as_ref().clone().with_load_factor(0.0));
        // Free vibration in the first mode: the energy measured at (uₙ, vₙ) then oscillates only
        // by O((ω₁dt)²). (Released from the static shape, the top modes' share of the energy
        // oscillates by O(1) of itself at 0.9·dt_crit; measured 1.0 % and 0.4 % of the total.)
        let start = State::released_from(lowest_modes(&system, 1).unwrap().shapes.remove(0));
        let dt_crit = critical_time_step(&system).unwrap();
        let safe = element_critical_step(&mesh, &Material::new(1e5, 0.3, 1000.0).unwrap());
        // The element bound is a guaranteed lower bound on the true critical step.
        assert!(
            safe <= dt_crit.dt * (1.0 + 1e-6),
            "element bound {safe} above {}",
            dt_crit.dt
        );
        critical.push(dt_crit.dt);
        let e0 = system.energy(&start).unwrap().total();

        let dt = 0.9 * dt_crit.dt;
        let mut stable = Method::Explicit
            .integrator(Arc::clone(&system), dt)
            .unwrap();
        let mut state = start.clone();
        let mut worst: f64 = 0.0;
        let inverse_mass: Vec<f64> = match system.mass() {
            tetfem::analysis::dynamics::Mass::Lumped(m) => m.iter().map(|m| 1.0 / m).collect(),
            tetfem::analysis::dynamics::Mass::Consistent(_) => {
                unreachable!("lumped by construction")
            }
        };
        for _ in 0..10_000 {
            stable.step(&mut state).unwrap();
            // Symplectic Euler's velocity lives half a step behind its displacement; the energy
            // is measured with it brought to the displacement's time level,
            // v̄ = v − dt/2·M⁻¹K·u (otherwise it oscillates by O(ω·dt) from the offset alone).
            let ku = system.stiffness().mul(&state.displacement).unwrap();
            let mut synchronized = state.clone();
            for i in 0..ku.len() {
                synchronized.velocity[i] -= 0.5 * dt * inverse_mass[i] * ku[i];
            }
            worst = worst.max((system.energy(&synchronized).unwrap().total() - e0).abs() / e0);
        }
        println!(
            "{cells:?}: dt_crit {:.4e} (element bound {safe:.4e}), energy drift at 0.9·dt_crit {worst:.2e}",
            dt_crit.dt
        );
        // Free vibration below the critical step: bounded, energy within 6e-4 of the start,
        // about 10× the worst drift measured (6.3e-5 on 8×2×2, 1.2e-5 on 16×4×4): the
        // synchronized energy of the first mode oscillates by O((ω₁·dt)²) only, while an
        // instability or a wrong velocity update grows far past that.
        assert!(worst < 6e-4, "energy drift {worst}");

        let mut unstable = Method::Explicit
            .integrator(Arc::clone(&system), 1.1 * dt_crit.dt)
            .unwrap();
        let mut state = start.clone();
        let caught = (0..2_000).find_map(|_| unstable.step(&mut state).err());
        match caught {
            Some(Error::Diverged { step, .. }) => {
                println!("{cells:?}: at 1.1·dt_crit caught as Diverged at step {step}");
                // The top mode grows ×2.4 per step from round-off (1e-16): within ~50 steps.
                assert!(step < 500, "caught only at step {step}");
            }
            other => panic!("expected Diverged at 1.1·dt_crit, got {other:?}"),
        }
    }
    // Halving h halves the critical step (dt_crit ∝ h, the CFL condition): within 10 %.
    let ratio = critical[0] / critical[1];
    println!("dt_crit ratio coarse/fine = {ratio:.3}");
    assert!((ratio - 2.0).abs() < 0.2, "ratio {ratio}");
}

#[test]
fn backward_euler_at_huge_steps_is_stable_and_never_gains_energy() {
    let (loaded, _, _) = beam(4.0, [8, 2, 2], MassKind::Lumped);
    let (system, start) = released(&loaded);
    let dt_crit = critical_time_step(&system).unwrap().dt;
    for factor in [100.0, 1000.0] {
        let mut integrator = Method::BackwardEuler
            .integrator(Arc::clone(&system), factor * dt_crit)
            .unwrap();
        let mut state = start.clone();
        let e0 = system.energy(&state).unwrap().total();
        let mut previous = e0;
        for step in 0..300 {
            integrator.step(&mut state).unwrap();
            let e = system.energy(&state).unwrap().total();
            // E(n+1) − E(n) = −½ΔvᵀMΔv − ½ΔuᵀKΔu ≤ 0 exactly; allow round-off of the solve.
            assert!(
                e <= previous + 1e-12 * e0,
                "{factor}×: energy rose at step {step}: {previous:e} → {e:e}"
            );
            previous = e;
        }
        println!(
            "backward Euler at {factor}× dt_crit: energy {e0:.4e} → {previous:.4e} after 300 steps"
        );
        assert!(previous < e0);
    }
}

#[test]
fn newmark_conserves_energy_at_ten_times_the_critical_step() {
    let (loaded, _, _) = beam(4.0, [8, 2, 2], MassKind::Lumped);
    let (system, start) = released(&loaded);
    let dt = 10.0 * critical_time_step(&system).unwrap().dt;
    for mass in [MassKind::Lumped, MassKind::Consistent] {
        let (loaded, _, _) = beam(4.0, [8, 2, 2], mass);
        let (system, start_m) = released(&loaded);
        let start = if mass == MassKind::Lumped {
            start.clone()
        } else {
            start_m
        };
        let mut integrator = Method::Newmark.integrator(Arc::clone(&system), dt).unwrap();
        let mut state = start.clone();
        let e0 = system.energy(&state).unwrap().total();
        let mut worst: f64 = 0.0;
        for _ in 0..1000 {
            integrator.step(&mut state).unwrap();
            worst = worst.max((system.energy(&state).unwrap().total() - e0).abs() / e0);
        }
        println!(
            "Newmark ({mass:?}) at 10× dt_crit: max relative energy change over 1000 steps {worst:.2e}"
        );
        // Exactly conserved by the method; only round-off of 1000 solves remains.
        assert!(worst <= 1e-9, "{mass:?}: {worst:e}");
    }
}

#[test]
fn newmark_period_matches_the_first_mode() {
    let (loaded, tip_dofs, _) = wide_beam(10.0, 2.0, [20, 4, 2], MassKind::Lumped);
    let modes = lowest_modes(&loaded, 3).unwrap();
    let period = 2.0 * std::f64::consts::PI / modes.omega[0];
    // Released in the first mode's shape: the tip then moves in that mode alone, so its
    // crossings measure that mode's period (released from the static shape, the higher modes'
    // share shifted the crossings by 0.21 % of the period).
    let (system, _) = released(&loaded);
    let mut state = State::released_from(modes.shapes[0].clone());
    let dt = period / 400.0;
    let mut integrator = Method::Newmark.integrator(Arc::clone(&system), dt).unwrap();
    // Upward zero crossings of the tip, located by linear interpolation.
    let mut crossings = Vec::new();
    let mut previous = (state.time, tip(&state, &tip_dofs));
    while crossings.len() < 4 {
        integrator.step(&mut state).unwrap();
        let now = (state.time, tip(&state, &tip_dofs));
        if previous.1 < 0.0 && now.1 >= 0.0 {
            crossings
                .push(previous.0 + (now.0 - previous.0) * (-previous.1) / (now.1 - previous.1));
        }
        previous = now;
        assert!(state.time < 10.0 * period, "no oscillation found");
    }
    let measured = (crossings[3] - crossings[0]) / 3.0;
    let error = (measured - period).abs() / period;
    // Newmark's (average acceleration) period elongation: T̄/T = 1 + (ω·dt)²/12 + O((ω·dt)⁴).
    let elongation = (modes.omega[0] * dt).powi(2) / 12.0;
    println!(
        "modal period {period:.6e}, Newmark tip period {measured:.6e}, difference {error:.3e} \
         (predicted elongation {elongation:.3e})"
    );
    // 10× the predicted elongation (2.1e-5 at T/400): the period of the wrong mode, a wrong
    // mass or stiffness, or a first-order method (elongation O(ω·dt) ≈ 1.6e-2) all fail.
    assert!(error < 10.0 * elongation, "{error:e}");
    // And it is that elongation: measured 2.056e-5 against 2.056e-5 predicted; 10 % leaves
    // room for the O((ω·dt)⁴) term and the interpolated crossings.
    assert!(
        (error - elongation).abs() < 0.1 * elongation,
        "{error:e} vs {elongation:e}"
    );
}

#[test]
fn modal_frequencies_converge_toward_euler_bernoulli() {
    let material = Material::new(1e5, 0.3, 1000.0).unwrap();
    let (length, width, height) = (10.0f64, 1.0f64, 1.0f64);
    let inertia = width * height.powi(3) / 12.0;
    let exact = 1.875_104_068_7f64.powi(2) / (2.0 * std::f64::consts::PI * length * length)
        * (material.youngs_modulus() * inertia / (material.density() * width * height)).sqrt();
    let mut previous_error = f64::INFINITY;
    for n in [10usize, 20, 40] {
        let (system, _, _) = beam(length, [n, n / 10, n / 10], MassKind::Lumped);
        let modes = lowest_modes(&system, 2).unwrap();
        let f1 = modes.frequencies()[0];
        let error = (f1 - exact) / exact;
        println!(
            "{n}x{}x{}: f1 = {f1:.6e}, Euler–Bernoulli {exact:.6e}, error {:+.2}% ({} iterations)",
            n / 10,
            n / 10,
            100.0 * error,
            modes.iterations
        );
        // Linear tets are too stiff in bending: the frequency is too high and falls toward the
        // beam value as the mesh is refined.
        assert!(
            error > 0.0 && error < previous_error,
            "error {error} after {previous_error}"
        );
        previous_error = error;
        // Modes: M-orthonormal, and K·φ = ω²·M·φ to round-off.
        for (w, phi) in modes.omega.iter().zip(&modes.shapes) {
            let norm =
                tetfem::analysis::modal::mass_inner_product(system.mass(), phi, phi).unwrap();
            assert!((norm - 1.0).abs() < 1e-9);
            let k_phi = system.stiffness().mul(phi).unwrap();
            let mut m_phi = vec![0.0; phi.len()];
            system.mass().mul_vec(phi, &mut m_phi).unwrap();
            let residual = k_phi
                .iter()
                .zip(&m_phi)
                .map(|(k, m)| (k - w * w * m).powi(2))
                .sum::<f64>()
                .sqrt();
            let scale = k_phi.iter().map(|k| k * k).sum::<f64>().sqrt();
            assert!(
                residual < 1e-6 * scale,
                "eigen-residual {residual:e} vs {scale:e}"
            );
        }
        let cross = tetfem::analysis::modal::mass_inner_product(
            system.mass(),
            &modes.shapes[0],
            &modes.shapes[1],
        )
        .unwrap();
        assert!(cross.abs() < 1e-9);
    }
    // At 4 cells through the height the error measured here is 14 %; bound it by 20 %.
    assert!(previous_error < 0.2);
}

#[test]
fn heavily_damped_backward_euler_reaches_the_static_solution() {
    let problem = Cantilever::peer_benchmark([20, 2, 2]);
    let mesh = problem.mesh().unwrap();
    let constraints = problem.constraints(&mesh).unwrap();
    let loads = problem.loads(&mesh).unwrap();
    let undamped = LinearSystem::new(
        &mesh,
        &problem.material,
        &constraints,
        &loads,
        Vector3::zeros(),
        MassKind::Lumped,
        Rayleigh::default(),
    )
    .unwrap();
    let omega1 = lowest_modes(&undamped, 1).unwrap().omega[0];
    // Damping ratio 2 at the first mode (overdamped), steps of a tenth of its period.
    let damping = Rayleigh::from_damping_ratio(2.0, omega1, 2.0 * omega1).unwrap();
    let system = Arc::new(undamped.with_damping(damping));
    let dt = 0.1 * 2.0 * std::f64::consts::PI / omega1;
    let mut integrator = Method::BackwardEuler
        .integrator(Arc::clone(&system), dt)
        .unwrap();
    let mut state = State::at_rest(system.free_count());
    for _ in 0..5000 {
        integrator.step(&mut state).unwrap();
        if state.velocity.iter().map(|v| v * v).sum::<f64>().sqrt() * dt
            < 1e-14 * state.displacement.iter().map(|u| u * u).sum::<f64>().sqrt()
        {
            break;
        }
    }
    let statics = tetfem::solve_static(&mesh, &problem.material, &constraints, &loads).unwrap();
    let reference = system.dofs().restrict(&statics.displacement).unwrap();
    let diff = state
        .displacement
        .iter()
        .zip(&reference)
        .map(|(a, b)| (a - b).powi(2))
        .sum::<f64>()
        .sqrt();
    let norm = reference.iter().map(|b| b * b).sum::<f64>().sqrt();
    println!(
        "damped backward Euler after {} steps: relative difference to statics {:.2e}",
        state.steps,
        diff / norm
    );
    assert!(diff <= 1e-8 * norm);
}

/// Max |tip − reference| over the sampled times, relative to max |reference|.
fn trajectory_error(
    method: Method,
    system: &Arc<LinearSystem>,
    start: &State,
    tip_dofs: &[usize],
    end: f64,
    steps: usize,
    reference: &[f64],
) -> f64 {
    let mut integrator = method
        .integrator(Arc::clone(system), end / steps as f64)
        .unwrap();
    let mut state = start.clone();
    let samples = reference.len() - 1;
    let mut error: f64 = 0.0;
    for step in 1..=steps {
        integrator.step(&mut state).unwrap();
        if step % (steps / samples) == 0 {
            error = error.max((tip(&state, tip_dofs) - reference[step / (steps / samples)]).abs());
        }
    }
    error / reference.iter().fold(0.0f64, |m, r| m.max(r.abs()))
}

#[test]
fn orders_of_accuracy_are_one_for_backward_euler_and_two_for_newmark() {
    let (loaded, tip_dofs, _) = wide_beam(10.0, 2.0, [10, 2, 1], MassKind::Lumped);
    let mut modes = lowest_modes(&loaded, 1).unwrap();
    let omega1 = modes.omega[0];
    let system = Arc::new(loaded.as_ref().clone().with_load_factor(0.0));
    // Released in the first mode: the asymptotic orders show cleanly. From a shape with
    // higher-mode content, backward Euler's error for modes with ω·dt ≳ 1 is their whole
    // amplitude, independent of dt, which masks the order until dt resolves every mode.
    let start = State::released_from(modes.shapes.remove(0));
    let end = 2.0 * std::f64::consts::PI / omega1; // one period of the first mode
    let samples = 16;
    // Reference: Newmark with 8192 steps (error (ωdt)² smaller than the coarsest run's by 4096×).
    let fine_steps = 8192;
    let mut integrator = Method::Newmark
        .integrator(Arc::clone(&system), end / fine_steps as f64)
        .unwrap();
    let mut state = start.clone();
    let mut reference = vec![tip(&state, &tip_dofs)];
    for step in 1..=fine_steps {
        integrator.step(&mut state).unwrap();
        if step % (fine_steps / samples) == 0 {
            reference.push(tip(&state, &tip_dofs));
        }
    }
    for (method, expected, steps) in [
        (Method::BackwardEuler, 1.0, [256, 512, 1024]),
        (Method::Newmark, 2.0, [64, 128, 256]),
    ] {
        let errors: Vec<f64> = steps
            .iter()
            .map(|&n| trajectory_error(method, &system, &start, &tip_dofs, end, n, &reference))
            .collect();
        let orders: Vec<f64> = errors.windows(2).map(|w| (w[0] / w[1]).log2()).collect();
        println!("{method:?}: errors {errors:.3?}, observed orders {orders:.3?}");
        for order in orders {
            assert!((order - expected).abs() < 0.2, "{method:?}: order {order}");
        }
    }
}

#[test]
fn invalid_dynamic_input_is_an_error() {
    let (system, _, _) = beam(4.0, [4, 1, 1], MassKind::Lumped);
    for dt in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        for method in [Method::BackwardEuler, Method::Newmark, Method::Explicit] {
            assert!(matches!(
                method.integrator(Arc::clone(&system), dt),
                Err(Error::InvalidParameter { .. })
            ));
        }
    }
    let mut integrator = Method::Newmark
        .integrator(Arc::clone(&system), 1.0)
        .unwrap();
    assert!(integrator.set_time_step(-2.0).is_err());
    assert!(integrator.set_time_step(0.5).is_ok() && integrator.time_step() == 0.5);
    assert!(Rayleigh::from_damping_ratio(-0.1, 1.0, 2.0).is_err());
    assert!(Rayleigh::from_damping_ratio(0.05, 0.0, 2.0).is_err());
    assert!(Rayleigh::new(-1.0, 0.0).is_err());
    assert!("leapfrog".parse::<Method>().is_err());
    let mut wrong = State::at_rest(3);
    assert!(integrator.step(&mut wrong).is_err());
    let (consistent, _, _) = beam(4.0, [4, 1, 1], MassKind::Consistent);
    assert!(
        Method::Explicit
            .integrator(Arc::clone(&consistent), 1e-3)
            .is_err()
    );
    assert!(critical_time_step(&consistent).is_err());
    assert!(lowest_modes(&system, 0).is_err());
}

#[test]
fn changing_the_time_step_refactors_the_implicit_methods() {
    let (loaded, _, _) = beam(4.0, [8, 2, 2], MassKind::Lumped);
    let (system, start) = released(&loaded);
    let dt = 5.0 * critical_time_step(&system).unwrap().dt;
    for method in [Method::BackwardEuler, Method::Newmark] {
        let mut changed = method.integrator(Arc::clone(&system), dt).unwrap();
        let mut state = start.clone();
        for _ in 0..5 {
            changed.step(&mut state).unwrap();
        }
        changed.set_time_step(3.0 * dt).unwrap();
        let mut fresh = method.integrator(Arc::clone(&system), 3.0 * dt).unwrap();
        let mut reference = state.clone();
        for _ in 0..5 {
            changed.step(&mut state).unwrap();
            fresh.step(&mut reference).unwrap();
        }
        // The changed integrator refactored for 3·dt: it continues exactly as a fresh one.
        // (Newmark carries its acceleration; the fresh one recomputes it from the equation of
        // motion, which agrees to round-off.)
        let diff = state
            .displacement
            .iter()
            .zip(&reference.displacement)
            .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
        let scale = reference
            .displacement
            .iter()
            .fold(0.0f64, |m, v| m.max(v.abs()));
        assert!(diff <= 1e-9 * scale, "{method:?}: {diff:e} vs {scale:e}");
        assert!((state.time - reference.time).abs() < 1e-12 * state.time);
    }
}

/// One step of each method against its defining formula evaluated independently (scalar CSC
/// products, a fresh Cholesky of the step matrix), on a system with Rayleigh damping and rollers
/// that leave nodes with one or two free DOFs, so the node-block products go through padding.
#[test]
fn one_step_matches_its_formula_with_damping_and_partial_constraints() {
    let problem = Cantilever::peer_benchmark([8, 2, 2]);
    let mesh = problem.mesh().unwrap();
    let mut constraints = problem.constraints(&mesh).unwrap();
    let far = problem.tip_nodes(&mesh);
    constraints.fix_axes(&far, [false, true, false]).unwrap();
    let damping = Rayleigh {
        alpha: 0.3,
        beta: 2e-4,
    };
    let system = Arc::new(
        LinearSystem::new(
            &mesh,
            &problem.material,
            &constraints,
            &problem.loads(&mesh).unwrap(),
            Vector3::new(0.0, 0.0, -9.81),
            MassKind::Lumped,
            damping,
        )
        .unwrap(),
    );
    assert!(system.stiffness_blocks().is_padded());
    let n = system.free_count();
    let k = system.stiffness();
    let m = match system.mass() {
        tetfem::analysis::dynamics::Mass::Lumped(m) => m.clone(),
        tetfem::analysis::dynamics::Mass::Consistent(_) => unreachable!(),
    };
    let f = system.external_load();
    let start = State {
        displacement: (0..n).map(|i| 1e-4 * ((i % 13) as f64 - 6.0)).collect(),
        velocity: (0..n).map(|i| 1e-3 * ((i % 7) as f64 - 3.0)).collect(),
        ..State::at_rest(n)
    };
    let ku = k.mul(&start.displacement).unwrap();
    let kv = k.mul(&start.velocity).unwrap();
    let dt_critical = critical_time_step(&system).unwrap().dt;

    // Explicit: v⁺ = v + dt·(M⁻¹(f − K·u − β·K·v) − α·v), u⁺ = u + dt·v⁺.
    let dt = 0.5 * dt_critical;
    let mut state = start.clone();
    Method::Explicit
        .integrator(Arc::clone(&system), dt)
        .unwrap()
        .step(&mut state)
        .unwrap();
    for i in 0..n {
        let v = start.velocity[i]
            + dt * ((f[i] - ku[i] - damping.beta * kv[i]) / m[i]
                - damping.alpha * start.velocity[i]);
        let u = start.displacement[i] + dt * v;
        // Products summed in another order: round-off relative to the largest term.
        let scale = dt * (f[i].abs() + ku[i].abs() + kv[i].abs()) / m[i] + start.velocity[i].abs();
        assert!(
            (state.velocity[i] - v).abs() <= 1e-12 * scale,
            "explicit v[{i}]"
        );
        assert!((state.displacement[i] - u).abs() <= 1e-12 * (scale * dt + u.abs()));
    }

    // Backward Euler: ((1 + dt·α)·M + (dt·β + dt²)·K)·Δv = dt·(f − K·u − (dt + β)·K·v − α·M·v).
    let dt = 20.0 * dt_critical;
    let mut state = start.clone();
    Method::BackwardEuler
        .integrator(Arc::clone(&system), dt)
        .unwrap()
        .step(&mut state)
        .unwrap();
    let mut a = k.clone();
    for value in a.values_mut() {
        *value *= dt * damping.beta + dt * dt;
    }
    a.add_diagonal(1.0 + dt * damping.alpha, &m).unwrap();
    let mut rhs: Vec<f64> = (0..n)
        .map(|i| {
            dt * (f[i]
                - ku[i]
                - (dt + damping.beta) * kv[i]
                - damping.alpha * m[i] * start.velocity[i])
        })
        .collect();
    let mut cholesky = tetfem::SparseCholesky::analyze(&a).unwrap();
    cholesky.factorize(&a).unwrap();
    cholesky.solve_in_place(&mut rhs).unwrap();
    let dv_norm = rhs.iter().map(|x| x * x).sum::<f64>().sqrt();
    for i in 0..n {
        let v = start.velocity[i] + rhs[i];
        // Same factorization, right-hand sides equal to round-off: 1e-9 of ‖Δv‖ covers the
        // condition number (~1e4 at this dt) times the round-off of the right-hand side.
        assert!(
            (state.velocity[i] - v).abs() <= 1e-9 * dv_norm,
            "backward Euler v[{i}]"
        );
    }
}

/// A displaced, moving state on `n` free DOFs (deterministic, no symmetry).
fn moving_state(n: usize) -> State {
    State {
        displacement: (0..n).map(|i| 1e-3 * ((i % 13) as f64 - 6.0)).collect(),
        velocity: (0..n).map(|i| 1e-2 * ((i % 7) as f64 - 3.0)).collect(),
        ..State::at_rest(n)
    }
}

/// (max |a − b|, max |a|).
fn max_difference(a: &[f64], b: &[f64]) -> (f64, f64) {
    let scale = a.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let diff = a
        .iter()
        .zip(b)
        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
    (diff, scale)
}

#[test]
fn implicit_steps_on_two_cholesky_threads_match_one_thread() {
    let (system, _, _) = beam(5.0, [30, 6, 6], MassKind::Lumped);
    // The two-thread solve splits the elimination tree in two halves only for a supernodal
    // factor: check this pattern's has both halves, so that the comparison below exercises it.
    let options = |threads| IntegratorOptions {
        cholesky: CholeskyOptions {
            threads,
            ..Default::default()
        },
        ..Default::default()
    };
    let mut cholesky =
        SparseCholesky::analyze_with(system.stiffness(), options(2).cholesky).unwrap();
    cholesky.factorize(system.stiffness()).unwrap();
    let split = cholesky.supernodal_split().expect("a supernodal factor");
    assert!(split[1] > 0.0 && split[2] > 0.0, "two halves: {split:?}");

    let start = moving_state(system.free_count());
    let dt = 20.0 * critical_time_step(&system).unwrap().dt;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap();
    for method in [Method::BackwardEuler, Method::Newmark] {
        let run = |threads| {
            pool.install(|| {
                let mut integrator = method
                    .integrator_with(Arc::clone(&system), dt, options(threads))
                    .unwrap();
                let mut state = start.clone();
                for _ in 0..5 {
                    integrator.step(&mut state).unwrap();
                }
                state
            })
        };
        let (one, two, zero) = (run(1), run(2), run(0));
        let mut default = start.clone();
        let mut integrator = method.integrator(Arc::clone(&system), dt).unwrap();
        for _ in 0..5 {
            integrator.step(&mut default).unwrap();
        }
        // The default is one thread, and 0 counts as 1: the same computation, the same bits.
        for other in [&zero, &default] {
            assert_eq!(other.displacement, one.displacement, "{method:?}");
            assert_eq!(other.velocity, one.velocity, "{method:?}");
        }
        for (a, b) in [
            (&one.displacement, &two.displacement),
            (&one.velocity, &two.velocity),
        ] {
            let (diff, scale) = max_difference(a, b);
            // Another order of the factorization's and solves' sums: round-off (1e-16) times
            // the system's condition number (~1 + (dt·ω_max)² ≈ 1.6e3 at 20 critical steps)
            // times five steps stays far below 1e-10.
            assert!(diff <= 1e-10 * scale, "{method:?}: {diff:e} of {scale:e}");
        }
    }
}

#[test]
fn implicit_steps_on_the_iterative_path_match_the_direct_ones() {
    let (system, _, _) = beam(5.0, [30, 6, 6], MassKind::Lumped);
    let start = moving_state(system.free_count());
    let dt = 20.0 * critical_time_step(&system).unwrap().dt;
    let options = |linear_method| IntegratorOptions {
        linear_method,
        cg: CgOptions {
            relative_tolerance: 1e-12,
            ..Default::default()
        },
        ..Default::default()
    };
    for method in [Method::BackwardEuler, Method::Newmark] {
        let run = |linear_method| {
            let mut integrator = method
                .integrator_with(Arc::clone(&system), dt, options(linear_method))
                .unwrap();
            let mut state = start.clone();
            for _ in 0..5 {
                integrator.step(&mut state).unwrap();
            }
            let solver = integrator.linear_solver().expect("an implicit method");
            (state, solver.is_direct(), integrator.factor_len().unwrap())
        };
        let (direct, is_direct, factor_len) = run(LinearMethod::Direct);
        assert!(is_direct && factor_len > 0, "{method:?}");
        let (iterative, is_direct, factor_len) = run(LinearMethod::Iterative);
        assert!(!is_direct && factor_len == 0, "{method:?}");
        // On this 6.6k-DOF beam and 100 steps per matrix, the predicted times favour the
        // Cholesky by far.
        let (auto, is_direct, _) = run(LinearMethod::Auto);
        assert!(is_direct, "{method:?}: Auto took the iterative path");
        assert_eq!(auto.displacement, direct.displacement, "{method:?}");
        for (a, b) in [
            (&direct.displacement, &iterative.displacement),
            (&direct.velocity, &iterative.velocity),
        ] {
            let (diff, scale) = max_difference(a, b);
            // Each solve stops at a relative residual of 1e-12; its error is at most that times
            // the system's condition number (~1 + (dt·ω_max)² ≈ 1.6e3 at 20 critical steps),
            // 1.6e-9, over five steps: below 1e-8. A step that skipped the solve would be off
            // by order 1.
            // (That the iterative path ran is asserted above: no factor, `is_direct` false.)
            assert!(diff <= 1e-8 * scale, "{method:?}: {diff:e} of {scale:e}");
        }
    }
}

/// How a runaway is put into an integration: the state's fields are public, so a caller (or a
/// bug upstream) can hand an integrator any state.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Runaway {
    /// One velocity of the start state is NaN: the integrator's first step meets it.
    NotFiniteAtStart,
    /// One velocity becomes NaN after three steps.
    NotFinite,
    /// Every velocity ×1000 after three steps: the kinetic energy ×1e6, far above 10× what the
    /// start and the loads supplied, which is the guard's bound.
    Energy,
}

impl Runaway {
    /// Steps taken before the injection.
    fn steps_before(self) -> usize {
        match self {
            Runaway::NotFiniteAtStart => 0,
            Runaway::NotFinite | Runaway::Energy => 3,
        }
    }

    fn inject(self, state: &mut State) {
        match self {
            Runaway::NotFiniteAtStart | Runaway::NotFinite => {
                let middle = state.velocity.len() / 2;
                state.velocity[middle] = f64::NAN;
            }
            Runaway::Energy => state.velocity.iter_mut().for_each(|v| *v *= 1e3),
        }
    }

    /// Words of the guard's reason for this runaway.
    fn reason(self) -> &'static str {
        match self {
            // A start that is not finite is named as such (`Energy::check_start`).
            Runaway::NotFiniteAtStart => "starting state's kinetic energy",
            Runaway::NotFinite => "no longer finite",
            Runaway::Energy => "exceeds",
        }
    }

    /// Takes [`steps_before`](Self::steps_before) steps with `step`, injects the runaway and
    /// takes one more: `None` if that step is `Diverged` with this runaway's reason, caught in
    /// that step (the linear backward Euler and the explicit method check the state a step
    /// starts from, so they name the step count before it; the others the state they leave),
    /// else what happened instead.
    fn drive(
        self,
        state: &mut State,
        mut step: impl FnMut(&mut State) -> tetfem::Result<()>,
    ) -> Option<String> {
        let before = self.steps_before();
        for _ in 0..before {
            step(state).unwrap();
        }
        self.inject(state);
        match step(state) {
            Err(Error::Diverged { step, reason, .. }) => {
                println!("{self:?}: Diverged at step {step}: {reason}");
                let caught =
                    (step == before || step == before + 1) && reason.contains(self.reason());
                (!caught).then(|| format!("Diverged at step {step}: {reason}"))
            }
            other => Some(format!("{other:?}")),
        }
    }
}

/// Every integrator, driven into each [`Runaway`], stops with `Diverged`. Mutations tried (see
/// the notes of issue 22 item 10): without the guard's energy bound every `Energy` case runs
/// on; without the finiteness checks every `NotFinite*` case does.
#[test]
fn every_integrator_stops_with_diverged() {
    let (loaded, _, _) = beam(4.0, [8, 2, 2], MassKind::Lumped);
    let (system, _) = released(&loaded);
    let dt = critical_time_step(&system).unwrap().dt;
    let start = moving_state(system.free_count());
    // The nonlinear backward Euler: corotational, under the beam's end load from rest.
    let problem = Cantilever {
        end_load: 600.0,
        ..Cantilever::peer_benchmark([8, 2, 2])
    };
    let mesh = Arc::new(problem.mesh().unwrap());
    // Backward Euler with the corotational force through the seam: lumped mass, no damping.
    let nonlinear = || {
        let system = Arc::new(
            LinearSystem::new(
                &mesh,
                &problem.material,
                &problem.constraints(&mesh).unwrap(),
                &problem.loads(&mesh).unwrap(),
                Vector3::zeros(),
                MassKind::Lumped,
                Rayleigh::default(),
            )
            .unwrap(),
        );
        let force = NonlinearForce::new(
            Arc::clone(&mesh),
            ModelKind::Corotational.build(&problem.material),
            &system,
        )
        .unwrap();
        let n = system.free_count();
        let integrator = BackwardEuler::with_force(
            system,
            InternalForce::Nonlinear(Arc::new(force)),
            1e-3,
            IntegratorOptions::default(),
        )
        .unwrap();
        (integrator, n)
    };
    let mut missed = Vec::new();
    for runaway in [
        Runaway::NotFiniteAtStart,
        Runaway::NotFinite,
        Runaway::Energy,
    ] {
        for method in [Method::BackwardEuler, Method::Newmark, Method::Explicit] {
            // Half the critical step, so that the explicit method is stable until the injection.
            let mut integrator = method.integrator(Arc::clone(&system), 0.5 * dt).unwrap();
            print!("{}, ", integrator.name());
            if let Some(instead) = runaway.drive(&mut start.clone(), |s| integrator.step(s)) {
                missed.push(format!("{}, {runaway:?}: {instead}", integrator.name()));
            }
        }
        let (mut integrator, n) = nonlinear();
        let mut state = State::at_rest(n);
        print!("nonlinear backward Euler, ");
        if let Some(instead) = runaway.drive(&mut state, |s| integrator.step(s)) {
            missed.push(format!("nonlinear backward Euler, {runaway:?}: {instead}"));
        }
    }
    assert!(
        missed.is_empty(),
        "not stopped as Diverged:\n  {}",
        missed.join("\n  ")
    );
}

/// Issue 33: dt = 1e200 s made the implicit step matrix overflow, reported as "matrix value
/// inf"; the error now names dt, its value and the matrix it overflows. (Backward Euler's
/// matrix holds dt² = inf; Newmark's 4/dt² = 0 stays finite, so it runs.)
#[test]
fn a_time_step_that_overflows_the_step_matrix_is_named() {
    let (system, _, _) = beam(4.0, [4, 1, 1], MassKind::Lumped);
    let first_step = |dt: f64| {
        let mut state = State::at_rest(system.free_count());
        Method::BackwardEuler
            .integrator(Arc::clone(&system), dt)
            .and_then(|mut integrator| integrator.step(&mut state))
    };
    let message = first_step(1e200).unwrap_err().to_string();
    assert!(
        message.contains("invalid parameter dt = 1e200 s"),
        "{message}"
    );
    assert!(
        message.contains("(1 + dt·α)·M + (dt·β + dt²)·K overflows"),
        "{message}"
    );
    first_step(1e100).unwrap();
}

/// Issue 33: a density of 1e-300 kg/m³ made the power iteration overflow (ω_max² ≈ 1e307 is
/// finite, its square is not) and the critical step failed with "power iteration broke down".
/// The iteration now runs on A/G; the step scales exactly as √ρ (A = M^(−1/2)KM^(−1/2) scales by
/// 1/ρ and every iterate with it), so ρ = 1e-297 gives the step at ρ = 1000 times 1e-150.
#[test]
fn the_critical_step_scales_as_the_root_of_the_density_down_to_1e_minus_297() {
    let step = |density: f64| {
        let problem = Cantilever {
            material: Material::new(1e5, 0.3, density).unwrap(),
            ..Cantilever::peer_benchmark([4, 1, 1])
        };
        let mesh = problem.mesh().unwrap();
        let system = LinearSystem::new(
            &mesh,
            &problem.material,
            &problem.constraints(&mesh).unwrap(),
            &problem.loads(&mesh).unwrap(),
            Vector3::zeros(),
            MassKind::Lumped,
            Rayleigh::default(),
        )
        .unwrap();
        critical_time_step(&system).unwrap()
    };
    let (light, steel) = (step(1e-297), step(1e3));
    // Scaling ρ by 1e-300 scales A by 1e300 up to the rounding of ρ·V/4 (~1e-16 relative):
    // the iterates, bracket and certificate are the same, so the ratio is exact to rounding.
    let ratio = light.dt / (steel.dt * 1e-150);
    assert!((ratio - 1.0).abs() < 1e-12, "{ratio}");
    assert_eq!(light.iterations, steel.iterations);
}

/// The consistent mass couples a DOF only with DOFs of its own axis, but it is stored on the
/// stiffness pattern (3×3 blocks between nodes): `CscMatrix::without_zeros`, the copy the
/// integrators' products read, keeps exactly a third of the entries, and its product repeats
/// the stored matrix's to the bit (a skipped term is ±0 and a column sum starting at +0 is never
/// −0), for P1 and P2, on a vector of both signs and magnitudes from 1e-9 to 1e3.
#[test]
fn the_mass_without_its_zero_couplings_gives_the_same_product_bits() {
    let problem = Cantilever::peer_benchmark([6, 2, 2]);
    let mesh = problem.mesh().unwrap();
    let quadratic = tetfem::TetMesh::<tetfem::Tet10>::from_linear(&mesh).unwrap();
    compact_mass_repeats_the_product(&problem, &mesh, "P1");
    compact_mass_repeats_the_product(&problem, &quadratic, "P2");
}

/// The check of [`the_mass_without_its_zero_couplings_gives_the_same_product_bits`] on `mesh`.
fn compact_mass_repeats_the_product<E: tetfem::fe::element::ElementType>(
    problem: &Cantilever,
    mesh: &tetfem::TetMesh<E>,
    name: &str,
) {
    let system = consistent_system(problem, mesh);
    let tetfem::analysis::dynamics::Mass::Consistent(m) = system.mass() else {
        unreachable!("consistent by construction")
    };
    let compact = m.without_zeros().unwrap();
    assert_eq!(3 * compact.nnz(), m.nnz(), "{name}");
    // A deterministic spread of signs and 13 decades.
    let x: Vec<f64> = (0..m.dim())
        .map(|i| (i as f64 * 0.7548776662).sin() * 10f64.powi((i % 13) as i32 - 9))
        .collect();
    let (mut full, mut kept) = (vec![0.0; m.dim()], vec![0.0; m.dim()]);
    m.mul_vec(&x, &mut full).unwrap();
    compact.mul_vec(&x, &mut kept).unwrap();
    let same = full
        .iter()
        .zip(&kept)
        .all(|(a, b)| a.to_bits() == b.to_bits());
    assert!(same, "{name}: the products differ in their bits");
}

/// The three-vector mass product (`CscMatrix::product3_into`, one read of M for the Newmark
/// step's right-hand side and its guard's M·v and M·a) gives each vector the bits of the
/// one-vector product, on the serial path (P1, below 1e5 stored entries) and the parallel one
/// (P2 16×4×4: its consistent mass stores more).
#[test]
fn the_three_vector_mass_product_repeats_each_product_bits() {
    for (cells, quadratic) in [([6, 2, 2], false), ([16, 4, 4], true)] {
        let problem = Cantilever::peer_benchmark(cells);
        let linear = problem.mesh().unwrap();
        let system = match quadratic {
            true => {
                let mesh = tetfem::TetMesh::<tetfem::Tet10>::from_linear(&linear).unwrap();
                consistent_system(&problem, &mesh)
            }
            false => consistent_system(&problem, &linear),
        };
        let tetfem::analysis::dynamics::Mass::Consistent(m) = system.mass() else {
            unreachable!("consistent by construction")
        };
        let compact = m.without_zeros().unwrap();
        assert_eq!(compact.nnz() >= 100_000, quadratic, "{cells:?}");
        // Three deterministic spreads of signs and decades.
        let vector = |phase: f64| -> Vec<f64> {
            (0..m.dim())
                .map(|i| (i as f64 * 0.7548776662 + phase).sin() * 10f64.powi((i % 11) as i32 - 5))
                .collect()
        };
        let x = [vector(0.0), vector(1.0), vector(2.0)];
        let mut y = [vec![0.0; m.dim()], vec![0.0; m.dim()], vec![0.0; m.dim()]];
        let [y0, y1, y2] = &mut y;
        compact.product3_into([&x[0], &x[1], &x[2]], [y0, y1, y2]);
        for (x, y) in x.iter().zip(&y) {
            let mut alone = vec![0.0; m.dim()];
            compact.mul_vec(x, &mut alone).unwrap();
            let same = alone.iter().zip(y).all(|(a, b)| a.to_bits() == b.to_bits());
            assert!(
                same,
                "{cells:?}: a product of the three differs in its bits"
            );
        }
    }
}

/// The cantilever `problem`'s system on `mesh` with a consistent mass, no gravity.
fn consistent_system<E: tetfem::fe::element::ElementType>(
    problem: &Cantilever,
    mesh: &tetfem::TetMesh<E>,
) -> LinearSystem {
    LinearSystem::new(
        mesh,
        &problem.material,
        &problem.constraints(mesh).unwrap(),
        &problem.loads(mesh).unwrap(),
        Vector3::zeros(),
        MassKind::Consistent,
        Rayleigh::default(),
    )
    .unwrap()
}

/// The support reactions with a consistent mass need the free DOFs' acceleration: the linear
/// integrators hand theirs over (`Integrator::linear_acceleration`: Newmark's a⁺, backward
/// Euler's Δv/dt), and the reactions from it agree with those from the CG solve with M_ff that
/// `SupportReactions::at` makes, on the released beam 5 steps in, with and without mass
/// damping. And no acceleration is handed over for a state the integrator did not leave.
#[test]
fn the_linear_integrators_acceleration_gives_the_reactions_of_the_mass_solve() {
    use tetfem::analysis::dynamics::{SupportReactions, TimeData};
    let problem = Cantilever {
        split: BoxSplit::Lecture6,
        ..Cantilever::peer_benchmark([8, 2, 2])
    };
    let mesh = problem.mesh().unwrap();
    let loaded = consistent_system(&problem, &mesh);
    for alpha in [0.0, 2.0] {
        let damping = Rayleigh { alpha, beta: 0.0 };
        let (system, start) = released(&loaded.clone().with_damping(damping));
        // 20× the explicit element bound: a step of the implicit methods' usual size.
        let dt = 20.0 * element_critical_step(&mesh, &problem.material);
        for method in [Method::BackwardEuler, Method::Newmark] {
            let mut integrator = method.integrator(Arc::clone(&system), dt).unwrap();
            let mut state = start.clone();
            for _ in 0..5 {
                integrator.step(&mut state).unwrap();
            }
            let mut reactions = SupportReactions::new(
                &system,
                &mesh,
                &problem.material,
                &tetfem::Loads::new(&mesh),
                Vector3::zeros(),
                &TimeData::default(),
            )
            .unwrap();
            let force = InternalForce::Linear;
            let solved = reactions.at(&system, &force, &state).unwrap();
            let a = integrator
                .linear_acceleration(&state)
                .expect("the state it left");
            let handed = reactions
                .at_with(&system, &force, &state, Some(&a))
                .unwrap();
            let (difference, scale) = max_difference(&solved, &handed);
            println!(
                "{} α = {alpha}: reactions differ by {difference:e} of {scale:e} N",
                integrator.name()
            );
            // CG stops at 1e-12 of M_ff·a_f's right-hand side, and a_f enters the reactions
            // through M_cf alone: 1e-9 of the largest reaction leaves a margin of 1000 over it
            // (measured 1e-14 relative on a P2 beam, 2e-15 here).
            assert!(
                scale > 1.0 && difference <= 1e-9 * scale,
                "{}",
                integrator.name()
            );
            // The acceleration matters here: without it (a = 0) the reactions move by more than
            // 1e-5 of themselves (measured 2e-4: a_f enters through the clamp's M_cf alone),
            // 10⁴ times the tolerance above, so the comparison could fail.
            let still = reactions
                .at_with(&system, &force, &state, Some(&vec![0.0; a.len()]))
                .unwrap();
            let (inertia, _) = max_difference(&solved, &still);
            println!("  without the acceleration: {inertia:e} N");
            assert!(inertia > 1e-5 * scale, "{}", integrator.name());
            let mut elsewhere = state.clone();
            elsewhere.time += dt;
            assert!(integrator.linear_acceleration(&elsewhere).is_none());
        }
    }
}
