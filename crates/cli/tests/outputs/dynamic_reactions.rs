//! Support reactions of dynamic runs (issue 17, item 3): r_c = M·a + C·v − f_int − f_ext on the
//! constrained rows, per node in the frames, per `[[constraints]]` entry in the CSV and the
//! summary. A damped hanging bar settles to its weight; at every step the reactions close the
//! global momentum balance of each integrator's state; a shaken base carries the body's inertia.

use crate::common::vtu;

use std::ops::ControlFlow;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use tetfem::analysis::dynamics::{IntegratorOptions, Method, State};
use tetfem_cli::scene::{Analysis, DynamicOverrides, DynamicSetup, Scene, run_dynamic_scene};

fn out_dir(name: &str) -> PathBuf {
    Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join("dynamic_reactions")
        .join(name)
}

fn scene(text: &str, name: &str) -> Scene {
    let mut scene: Scene = text.parse().unwrap();
    scene.set_output_directory(out_dir(name));
    scene
}

fn shipped(name: &str) -> String {
    std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../scenes")
            .join(name),
    )
    .unwrap()
}

/// The shipped hanging bar (1 m steel, 0.1 m × 0.1 m, clamped at its top) as a dynamic scene:
/// backward Euler, dt = 1 ms, mass damping α (1/s), 100 steps.
fn hanging_bar(alpha: f64) -> String {
    shipped("hanging_bar.toml").replace("png = true", "png = false")
        + &format!(
            "\n[analysis]\ntype = \"dynamic\"\nmethod = \"backward_euler\"\ndt = 1e-3\nduration = 0.1\ndamping = {{ mass = {alpha:e} }}\n"
        )
}

/// Released from rest under gravity, the damped bar settles into its static shape, where the
/// clamp carries the whole weight W = ρ·g·V = 7850·9.81·0.01 = 770.085 N.
///
/// Tolerance from the decay: for M·ü + α·M·u̇ + K·u = 0 backward Euler multiplies each mode's
/// amplitude per step by a pair of roots of (1 + α·dt + ω²dt²)·z² − (2 + α·dt)·z + 1 = 0; while
/// α < 2ω (complex roots, checked below against the lowest mode) |z|² = 1/(1 + α·dt + ω²dt²) ≤
/// 1/(1 + α·dt) for every mode. The reaction's distance to W is a modal sum of those motions
/// (a = −αv − M⁻¹K(u − u_static)), starting at most a few W (the static-to-dynamic overshoot of a
/// suddenly applied load is below 2): after N steps it is below 10·W·(1 + α·dt)^(−N/2), plus
/// the round-off of summing the ~100 nodal reactions of size ~W (1e-12·W).
#[test]
fn a_damped_hanging_bar_settles_to_its_weight() {
    let alpha = 800.0;
    let s = scene(&hanging_bar(alpha), "hanging");
    let Analysis::Dynamic(settings) = s.analysis() else {
        panic!("dynamic scene")
    };
    let setup = DynamicSetup::from_scene(s.build().unwrap(), settings).unwrap();
    let modes = tetfem::analysis::modal::lowest_modes(&setup.system, 1).unwrap();
    assert!(alpha < 2.0 * modes.omega[0], "ω₁ = {}", modes.omega[0]);

    let summary = run_dynamic_scene(
        &s,
        &DynamicOverrides::default(),
        false,
        false,
        &mut |_, _| ControlFlow::Continue(()),
    )
    .unwrap();
    let weight = 7850.0 * 9.81 * 0.1 * 0.1 * 1.0;
    assert_eq!(summary.reactions.len(), 1);
    let r = summary.reactions[0].force_n;
    let steps = summary.steps as f64;
    let bound = 10.0 * weight * (1.0 + alpha * 1e-3f64).powf(-steps / 2.0) + 1e-12 * weight;
    eprintln!(
        "hanging bar: R = {r:?} N after {steps} steps, W = {weight} N, |R_z − W| = {:.3e} N, bound {bound:.3e} N",
        (r[2] - weight).abs()
    );
    assert!((r[2] - weight).abs() <= bound, "R_z = {} N", r[2]);
    assert!(r[0].abs() <= bound && r[1].abs() <= bound, "R = {r:?}");
    // At the start the clamp held only its own nodes' share: the reaction did change.
    let at_rest = DynamicSetup::from_scene(s.build().unwrap(), settings).unwrap();
    let mut reactions = at_rest.reactions.clone();
    let start = reactions
        .at(
            &at_rest.mesh,
            &at_rest.system,
            &at_rest.force,
            &at_rest.initial,
        )
        .unwrap();
    assert!(start.rows[0].force_n[2] < 0.2 * weight);

    // The corotational model settles to the same weight, to Newton's tolerance on top (each
    // step's free residual ≤ 1e-8 of the load, summed over √n_f ≈ 36 components: 1e-6·W).
    let s = scene(
        &hanging_bar(alpha).replace("[analysis]\n", "[analysis]\nmodel = \"corotational\"\n"),
        "hanging_corotational",
    );
    let summary = run_dynamic_scene(
        &s,
        &DynamicOverrides::default(),
        false,
        false,
        &mut |_, _| ControlFlow::Continue(()),
    )
    .unwrap();
    assert_eq!(summary.model, "corotational");
    let r = summary.reactions[0].force_n;
    eprintln!(
        "hanging bar, corotational: |R_z − W| = {:.3e} N",
        (r[2] - weight).abs()
    );
    assert!(
        (r[2] - weight).abs() <= bound + 1e-6 * weight,
        "R_z = {} N",
        r[2]
    );
}

/// Σ over all DOFs of axis k: (mass·acceleration, mass·velocity) of the full state, with
/// `free_acceleration` on the free DOFs and the supports' prescribed motion at time t.
fn momentum_terms(
    setup: &DynamicSetup,
    motion: &tetfem::bc::boundary_motion::BoundaryMotion,
    masses: &[f64],
    velocity: &[f64],
    free_acceleration: &[f64],
    t: f64,
) -> ([f64; 3], [f64; 3]) {
    let dofs = setup.system.dofs();
    let (mut ma, mut mv) = ([0.0; 3], [0.0; 3]);
    for ((&d, &v), &a) in dofs.free_dofs().iter().zip(velocity).zip(free_acceleration) {
        ma[d % 3] += masses[d] * a;
        mv[d % 3] += masses[d] * v;
    }
    let values = motion.evaluate(setup.mesh.nodes(), t).unwrap();
    for (d, [_, v, a]) in motion.dofs().into_iter().zip(values) {
        ma[d % 3] += masses[d] * a;
        mv[d % 3] += masses[d] * v;
    }
    (ma, mv)
}

/// Σ of the reactions over all DOFs of each axis.
fn reaction_sum(nodal: &[f64]) -> [f64; 3] {
    let mut sum = [0.0; 3];
    for (d, r) in nodal.iter().enumerate() {
        sum[d % 3] += r;
    }
    sum
}

/// The largest imbalance of Σ r + Σ f − Σ m·a − α·Σ m·v per axis over a run of `steps` steps of
/// `setup` with `method`, relative to the largest |Σ m·a| + |Σ r| + |Σ f| seen (the size of the
/// terms that cancel). Σ m·a is each method's own: backward Euler a⁺ = (v⁺ − v)/dt at the new
/// state; Newmark's trapezoid (v⁺ − v)/dt = (a + a⁺)/2, so the balance is taken at the step's
/// two ends averaged; the explicit method's v⁺ = v + dt·a at the step's start.
fn momentum_imbalance(shaken: &Shaken, method: Method, dt: f64, steps: usize) -> f64 {
    let Shaken {
        setup,
        motion,
        loads,
    } = shaken;
    let mut integrator = method
        .integrator_with_force(
            Arc::clone(&setup.system),
            setup.force.clone(),
            dt,
            IntegratorOptions::default(),
        )
        .unwrap();
    let masses = tetfem::fe::assembly::lumped_mass_of(&setup.mesh, &setup.materials).unwrap();
    let alpha = setup.system.damping().alpha;
    let mut reactions = setup.reactions.clone();
    let mut state = setup.initial.clone();
    let mut before = reactions
        .at(&setup.mesh, &setup.system, &setup.force, &state)
        .unwrap()
        .nodal;
    let (mut worst, mut scale) = (0.0f64, 0.0f64);
    for _ in 0..steps {
        let old: State = state.clone();
        integrator.step(&mut state).unwrap();
        // The integrator's own acceleration where it has one (as the runner takes it), else
        // the CG solve with a consistent mass.
        let a = integrator.linear_acceleration(&state);
        let after = reactions
            .at_with(
                &setup.mesh,
                &setup.system,
                &setup.force,
                (&state, a.as_deref()),
            )
            .unwrap()
            .nodal;
        let a: Vec<f64> = state
            .velocity
            .iter()
            .zip(&old.velocity)
            .map(|(v1, v0)| (v1 - v0) / dt)
            .collect();
        // (ΣR + Σf − α·Σm·v) at the time the method balances, and Σm·a there.
        let (balance_r, ma) = match method {
            Method::BackwardEuler => {
                let (ma, mv) =
                    momentum_terms(setup, motion, &masses, &state.velocity, &a, state.time);
                let r = reaction_sum(&after);
                ((0..3).map(|k| r[k] - alpha * mv[k]).collect::<Vec<_>>(), ma)
            }
            Method::Newmark => {
                // Free DOFs: Σm·(v⁺ − v)/dt; the supports' ü averaged over the two ends.
                let (ma0, mv0) =
                    momentum_terms(setup, motion, &masses, &old.velocity, &a, old.time);
                let (ma1, mv1) =
                    momentum_terms(setup, motion, &masses, &state.velocity, &a, state.time);
                let (r0, r1) = (reaction_sum(&before), reaction_sum(&after));
                (
                    (0..3)
                        .map(|k| 0.5 * (r0[k] + r1[k]) - 0.5 * alpha * (mv0[k] + mv1[k]))
                        .collect(),
                    [0, 1, 2].map(|k| 0.5 * (ma0[k] + ma1[k])),
                )
            }
            Method::Explicit => {
                let (ma, mv) = momentum_terms(setup, motion, &masses, &old.velocity, &a, old.time);
                let r = reaction_sum(&before);
                ((0..3).map(|k| r[k] - alpha * mv[k]).collect(), ma)
            }
        };
        for k in 0..3 {
            worst = worst.max((balance_r[k] + loads[k] - ma[k]).abs());
            scale = scale.max(ma[k].abs() + balance_r[k].abs() + loads[k].abs());
        }
        before = after;
    }
    assert!(scale > 0.0);
    worst / scale
}

/// A dynamic setup with its supports' motion and its loads' resultant per axis (N; constant).
struct Shaken {
    setup: DynamicSetup,
    motion: tetfem::bc::boundary_motion::BoundaryMotion,
    loads: [f64; 3],
}

/// The setup of the shipped shaken base with `extra` added to its `[analysis]`.
fn shaken_base(extra: &str) -> Shaken {
    setup_of(&shipped("shaken_base.toml"), extra)
}

/// The setup of scene `text` (with an `[analysis]` table) with `extra` added to it, with the
/// scene's force model.
fn setup_of(text: &str, extra: &str) -> Shaken {
    let text = text.replace("[analysis]\n", &format!("[analysis]\n{extra}"));
    let s = scene(&text, "shaken");
    let Analysis::Dynamic(settings) = s.analysis() else {
        panic!("dynamic scene")
    };
    let built = s.build().unwrap();
    assert!(built.time_data.loads.is_empty(), "the loads are constant");
    Shaken {
        motion: built.time_data.motion.clone(),
        loads: built.loads.resultant().into(),
        setup: DynamicSetup::from_scene(built, settings)
            .unwrap()
            .with_model(s.model())
            .unwrap(),
    }
}

/// The global momentum balance Σ r + Σ f = Σ m·a + α·Σ m·v holds at every step, for every
/// method, with lumped and (implicit methods) consistent mass, Rayleigh damping and a moving
/// base: Σ K·u = 0 and Σ K·v = 0 per axis (translations are in K's null space), a consistent
/// mass's column sums are the lumped masses, and the free rows hold the method's equation to its
/// solve's round-off. Tolerance: the direct solves leave relative residuals ~1e-12 and the terms
/// that cancel (K·u of single nodes, ~1e7 N here) are 1e2–1e3 × the balance's terms: 1e-9 of the
/// largest term.
#[test]
fn reactions_close_the_momentum_balance_for_every_method() {
    for (method, mass, dt) in [
        (Method::BackwardEuler, "lumped", 1e-4),
        (Method::Newmark, "lumped", 1e-4),
        (Method::Explicit, "lumped", 2e-6),
        (Method::BackwardEuler, "consistent", 1e-4),
        (Method::Newmark, "consistent", 1e-4),
    ] {
        let shaken = shaken_base(&format!(
            "mass = \"{mass}\"\ndamping = {{ mass = 30.0, stiffness = 2e-6 }}\n"
        ));
        let imbalance = momentum_imbalance(&shaken, method, dt, 60);
        eprintln!(
            "{method:?}, {mass} mass: momentum imbalance {imbalance:.3e} of the largest term"
        );
        assert!(imbalance <= 1e-9, "{method:?} {mass}: {imbalance:e}");
    }
}

/// With a nonlinear model the reactions take its internal force: the hanging bar released under
/// gravity with the corotational model (backward Euler, Newmark and explicit, lumped and
/// consistent mass, mass damping) keeps the same balance, now to Newton's tolerance: each step
/// stops at ‖r_f‖ ≤ 1e-8 of the load's norm, and Σ r_f is at most √n_f (≈ 36 here) times that,
/// so 1e-6 of the largest term leaves a margin.
#[test]
fn reactions_of_a_nonlinear_model_close_the_momentum_balance() {
    for (method, mass) in [
        (Method::BackwardEuler, "lumped"),
        (Method::Newmark, "lumped"),
        (Method::BackwardEuler, "consistent"),
        (Method::Explicit, "lumped"),
    ] {
        let dt = match method {
            Method::Explicit => 2e-6,
            _ => 1e-4,
        };
        let bar = setup_of(
            &hanging_bar(300.0),
            &format!("model = \"corotational\"\nmass = \"{mass}\"\n"),
        );
        assert!(bar.setup.force.is_nonlinear());
        let imbalance = momentum_imbalance(&bar, method, dt, 30);
        eprintln!("corotational, {method:?}, {mass} mass: momentum imbalance {imbalance:.3e}");
        assert!(imbalance <= 1e-6, "{method:?} {mass}: {imbalance:e}");
    }
}

/// The shipped shaken base (Newmark, no damping): at every step the base's reaction is the
/// body's total inertia force minus its weight, Σ r = Σ m·a − Σ f, to the round-off of the
/// identity above; and the CSV columns of a run are those reactions, bit for bit.
#[test]
fn the_shaken_base_carries_the_inertia_of_the_body() {
    let shaken = shaken_base("");
    let imbalance = momentum_imbalance(&shaken, Method::Newmark, 1e-4, 200);
    let setup = &shaken.setup;
    eprintln!("shaken base: momentum imbalance {imbalance:.3e} of the largest term");
    assert!(imbalance <= 1e-9, "{imbalance:e}");

    // The run's CSV: reaction0_Fz_N of each step is the library's Σ r_z over the base.
    let s = scene(&shipped("shaken_base.toml"), "shaken_csv");
    let summary = run_dynamic_scene(
        &s,
        &DynamicOverrides {
            length: Some(tetfem_cli::scene::RunLength::Steps(50)),
            ..Default::default()
        },
        true,
        false,
        &mut |_, _| ControlFlow::Continue(()),
    )
    .unwrap();
    let csv = summary
        .files
        .iter()
        .find(|f| f.extension().is_some_and(|e| e == "csv"))
        .unwrap();
    let text = std::fs::read_to_string(csv).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let column = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let (fz, mx) = (column("reaction0_Fz_N"), column("reaction0_Mx_Nm"));
    let mut integrator = Method::Newmark
        .integrator_with_force(
            Arc::clone(&setup.system),
            setup.force.clone(),
            1e-4,
            IntegratorOptions::default(),
        )
        .unwrap();
    let mut reactions = setup.reactions.clone();
    let mut state = setup.initial.clone();
    let mut biggest: f64 = 0.0;
    for (step, line) in lines.enumerate() {
        if step > 0 {
            integrator.step(&mut state).unwrap();
        }
        let row: Vec<f64> = line.split(',').map(|v| v.parse().unwrap()).collect();
        // As the runner: the integrator's acceleration where it has one.
        let a = integrator.linear_acceleration(&state);
        let at = reactions
            .at_with(
                &setup.mesh,
                &setup.system,
                &setup.force,
                (&state, a.as_deref()),
            )
            .unwrap();
        assert_eq!(row[fz], at.rows[0].force_n[2], "step {step}");
        assert_eq!(row[mx], at.rows[0].moment_nm[0], "step {step}");
        let r_z: f64 = reaction_sum(&at.nodal)[2];
        // The one constraint entry holds every constrained DOF.
        assert!((r_z - row[fz]).abs() <= 1e-12 * r_z.abs().max(1.0));
        biggest = biggest.max(row[fz].abs());
    }
    assert_eq!(summary.reactions[0].force_n[2].to_bits(), {
        let last = text.lines().last().unwrap();
        last.split(',')
            .nth(fz)
            .unwrap()
            .parse::<f64>()
            .unwrap()
            .to_bits()
    });
    // The base shakes 1 mm at 100 Hz: its reaction is far above the 1540 N weight.
    assert!(biggest > 1e4, "largest |R_z| = {biggest} N");
    // The last frame holds the same reactions per node (the state after 50 steps).
    let frame = summary
        .files
        .iter()
        .find(|f| f.to_string_lossy().ends_with("_0050.vtu"))
        .unwrap();
    let nodal = vtu::read_vtu(frame).values("reaction_force").to_vec();
    let at = reactions
        .at(&setup.mesh, &setup.system, &setup.force, &state)
        .unwrap();
    assert_eq!(nodal, at.nodal);
}
