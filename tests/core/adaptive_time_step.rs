//! Error-controlled time stepping (issue 37, item 3): `Transient::run_adaptive`'s own estimate
//! of its trajectory error against the true error — an independent fixed-step run at 1/16 of
//! the smallest step the adaptive run took — on a swinging beam (linear and corotational), a
//! contact drop and a shaken base; its step growing where the motion is smooth; a rejected step
//! leaving no trace; the explicit method refused by name; the run landing on its output times.

use std::collections::BTreeMap;

use nalgebra::Vector3;
use tetfem::analysis::Definition;
use tetfem::analysis::dynamics::{IntegratorOptions, Method, Rayleigh, State, TimeData};
use tetfem::analysis::transient::{
    AdaptiveReport, AdaptiveStep, Flow, StepView, TimeStep, Transient, TransientOptions,
};
use tetfem::base::error::Result;
use tetfem::bc::amplitude::Amplitude;
use tetfem::bc::boundary_motion::Motion;
use tetfem::contact::{Contact, ContactParameters, Obstacle};
use tetfem::fe::materials::MaterialMap;
use tetfem::model::ModelKind;
use tetfem::{BoxSplit, Constraints, Material, TetMesh};

/// A cantilever 0.5 × 0.05 × 0.05 m (ρ = 1000 kg/m³, ν = 0.3) of `youngs` Pa, clamped at
/// x = 0 and released from rest under gravity: it swings about its sagging shape. At E = 10 MPa
/// the first bending period is about 0.3 s (Euler–Bernoulli: 1.875²/(2π)·√(EI/(ρA·L⁴)) =
/// 3.2 Hz); at 0.5 MPa with the corotational model it swings down through large rotations.
fn swing(model: ModelKind, youngs: f64) -> Definition {
    let mesh = TetMesh::box_grid(
        Vector3::zeros(),
        Vector3::new(0.5, 0.05, 0.05),
        [10, 1, 1],
        BoxSplit::Mirrored6,
    )
    .unwrap();
    let materials = MaterialMap::uniform(
        Material::new(youngs, 0.3, 1000.0).unwrap(),
        mesh.tet_count(),
    );
    let mut constraints = Constraints::new(&mesh);
    constraints
        .fix_nodes(&mesh.nodes_on_plane(0, 0.0, 1e-9))
        .unwrap();
    Definition::builder(mesh, materials)
        .model(model)
        .constraints(constraints)
        .unwrap()
        .gravity(Vector3::new(0.0, 0.0, -9.81))
        .unwrap()
        .build()
        .unwrap()
}

/// The states at the landing times k·interval (k = 1, 2, …), and the largest ‖u‖ and ‖v‖ of
/// every step.
#[derive(Default)]
struct Samples {
    at: BTreeMap<i64, (Vec<f64>, Vec<f64>)>,
    scale: (f64, f64),
    /// The contact nodes' barrier stiffnesses κᵢ (Pa/m) at the run's end, where the run has a
    /// contact (`None` with the linear force).
    kappa: Option<Vec<f64>>,
}

fn norm(x: &[f64]) -> f64 {
    x.iter().map(|x| x * x).sum::<f64>().sqrt()
}

impl Samples {
    /// Keeps `state` if its time is a multiple of `interval` (to 1e-9 of it).
    fn keep(&mut self, state: &State, interval: f64) {
        self.scale_by(state);
        let k = (state.time / interval).round();
        if (state.time - k * interval).abs() < 1e-9 * interval {
            let sample = (state.displacement.clone(), state.velocity.clone());
            self.at.insert(k as i64, sample);
        }
    }

    /// Takes `state`'s ‖u‖ and ‖v‖ into the largest seen.
    fn scale_by(&mut self, state: &State) {
        self.scale.0 = self.scale.0.max(norm(&state.displacement));
        self.scale.1 = self.scale.1.max(norm(&state.velocity));
    }

    /// max over the common landings of √((‖Δu‖/S_u)² + (‖Δv‖/S_v)²), S from `self` (the
    /// reference): the norm the adaptive run's estimate is in.
    fn error_of(&self, run: &Samples) -> f64 {
        let (su, sv) = self.scale;
        let mut worst: f64 = 0.0;
        for (k, (u, v)) in &run.at {
            let (ur, vr) = &self.at[k];
            let du: Vec<f64> = u.iter().zip(ur).map(|(a, b)| a - b).collect();
            let dv: Vec<f64> = v.iter().zip(vr).map(|(a, b)| a - b).collect();
            worst = worst.max((norm(&du) / su).hypot(norm(&dv) / sv));
        }
        worst
    }
}

fn options(method: Method, dt: f64, damping: Rayleigh) -> TransientOptions {
    let mut options = TransientOptions::new(method, TimeStep::Seconds(dt));
    options.damping = damping;
    options.solver = IntegratorOptions::default();
    options
}

/// The adaptive run of `definition` to `end` landing every `interval`, from a first step `dt`.
fn adaptive(
    definition: &Definition,
    method: Method,
    (dt, tolerance): (f64, f64),
    (end, interval): (f64, f64),
    damping: Rayleigh,
) -> Result<(AdaptiveReport, Samples)> {
    let mut run = Transient::new(definition, options(method, dt, damping))?;
    let mut control = AdaptiveStep::new(tolerance)?;
    control.output_interval = Some(interval);
    let mut samples = Samples::default();
    let report = run.run_adaptive(end, &control, &mut |view: &StepView<'_>| -> Result<Flow> {
        samples.keep(view.state, interval);
        Ok(Flow::Continue)
    })?;
    samples.kappa = run.force().node_stiffnesses();
    Ok((report, samples))
}

/// The graded fixed-step reference: a fresh run from rest that covers each of the adaptive
/// run's accepted steps `steps` ((end time, dt), in order, from t = 0) with `per_step` equal
/// steps of its own, its clock set to the step's end after each (as the adaptive run's is at
/// a landing, so that both share the end times exactly). Its schedule is fixed in advance: it
/// takes nothing else from the run under test (no state, no estimate, no restart), so its
/// error is that of a fixed-step run everywhere at ≤ 1/`per_step` of the run's local step.
fn graded_reference(
    definition: &Definition,
    method: Method,
    steps: &[(f64, f64)],
    per_step: usize,
    (interval, damping): (f64, Rayleigh),
) -> Result<Samples> {
    let first = steps.first().map_or(interval, |(t, _)| *t);
    let mut run = Transient::new(
        definition,
        options(method, first / per_step as f64, damping),
    )?;
    let mut samples = Samples::default();
    let mut start = 0.0;
    for (taken, &(end, _)) in steps.iter().enumerate() {
        run.integrator_mut()
            .set_time_step((end - start) / per_step as f64)?;
        let first_step = taken * per_step;
        run.run(
            (first_step, first_step + per_step),
            &mut |view: &StepView<'_>| -> Result<Flow> {
                samples.scale_by(view.state);
                Ok(Flow::Continue)
            },
        )?;
        // The sum of `per_step` steps of (end − start)/per_step is end to round-off: set it to
        // the run's end time, the integrator told (its history is keyed to the state's time).
        let history = run.integrator().history()?;
        run.state_mut().time = end;
        let (integrator, state) = run.parts_mut();
        integrator.restore(state, &history)?;
        samples.keep(run.state(), interval);
        samples.kappa = run.force().node_stiffnesses();
        start = end;
    }
    Ok(samples)
}

/// The fixed-step reference at the largest step ≤ `smallest`/16 that divides `interval`.
fn reference(
    definition: &Definition,
    method: Method,
    smallest: f64,
    (end, interval): (f64, f64),
    damping: Rayleigh,
) -> Samples {
    let per_interval = (16.0 * interval / smallest).ceil();
    let dt = interval / per_interval;
    let steps = (end / interval).round() as usize * per_interval as usize;
    let mut run = Transient::new(definition, options(method, dt, damping)).unwrap();
    let mut samples = Samples::default();
    // Sampled by step count: over millions of steps the running sum t += dt drifts from k·interval.
    run.run((0, steps), &mut |view: &StepView<'_>| -> Result<Flow> {
        let mut state = view.state.clone();
        if view.step.is_multiple_of(per_interval as usize) {
            state.time = (view.step / per_interval as usize) as f64 * interval;
        }
        samples.keep(&state, interval);
        Ok(Flow::Continue)
    })
    .unwrap();
    samples.kappa = run.force().node_stiffnesses();
    samples
}

/// (estimated, true) error of the adaptive run, and the report.
fn effectivity(
    definition: &Definition,
    method: Method,
    (dt, tolerance): (f64, f64),
    span: (f64, f64),
    damping: Rayleigh,
) -> (f64, f64, AdaptiveReport) {
    let (report, samples) = adaptive(definition, method, (dt, tolerance), span, damping).unwrap();
    let exact = reference(definition, method, report.dt_range.0, span, damping);
    let truth = exact.error_of(&samples);
    eprintln!(
        "{method:?} tol {tolerance:e}: estimated {:.3e}, true {truth:.3e}, ratio {:.2}; \
         {} steps, {} rejected, {} dt changes, dt {:.2e}..{:.2e}",
        report.estimated_error,
        report.estimated_error / truth,
        report.accepted,
        report.rejected,
        report.dt_changes,
        report.dt_range.0,
        report.dt_range.1
    );
    (report.estimated_error, truth, report)
}

/// The target: the reported error within 0.5–2× the true one.
fn assert_effective(estimated: f64, truth: f64, case: &str) {
    let ratio = estimated / truth;
    assert!(
        (0.5..=2.0).contains(&ratio),
        "{case}: estimated {estimated:e} against true {truth:e} (ratio {ratio:.2})"
    );
}

/// Newmark on the undamped swing at two tolerances, backward Euler (first order: small steps)
/// over one period at the looser one.
#[test]
fn swing_effectivity() {
    let definition = swing(ModelKind::Linear, 1e7);
    let cases = [
        (Method::Newmark, 1e-2, 0.6),
        (Method::Newmark, 1e-3, 0.6),
        (Method::BackwardEuler, 1e-2, 0.3),
    ];
    for (method, tolerance, end) in cases {
        let (estimated, truth, _) = effectivity(
            &definition,
            method,
            (1e-3, tolerance),
            (end, 0.01),
            Rayleigh::default(),
        );
        assert_effective(estimated, truth, &format!("{method:?} at {tolerance:e}"));
    }
}

/// With a little stiffness damping (β = 1e-4 s: ζ = βω/2 ≈ 1e-3 on the first mode, the
/// modes the sudden load excites above 4000 rad/s damped at ζ ≥ 0.2) the motion is left to
/// the first mode: the steps grow once the start's transient has died out. Estimated against
/// true error as above. The start's errors count only while they live (the run's error model
/// decays them with their mode, `error_decay`), yet its transient still needs the shorter
/// steps: measured, the smallest of the first 10 ms against the largest of the last 100 ms
/// 1.04e-4 against 1.67e-3 s (Newmark, 16×) and 2.44e-6 against 2.08e-4 s (backward Euler,
/// 85×); 4× is asserted, what the earlier control (every error undecayed) also met.
#[test]
fn swing_damped_steps_grow() {
    let definition = swing(ModelKind::Linear, 1e7);
    let damping = Rayleigh::new(0.0, 1e-4).unwrap();
    for method in [Method::Newmark, Method::BackwardEuler] {
        let (estimated, truth, report) =
            effectivity(&definition, method, (1e-3, 1e-2), (0.3, 0.01), damping);
        assert_effective(estimated, truth, &format!("damped {method:?}"));
        // The smallest step of the first 10 ms against the largest of the last 100 ms: the
        // start's transient needs steps at least 4× shorter (measured 16× and 85×: the doc).
        let early = (report.steps.iter())
            .filter(|(t, _)| *t <= 0.01)
            .map(|(_, dt)| *dt)
            .fold(f64::INFINITY, f64::min);
        let late = (report.steps.iter())
            .filter(|(t, _)| *t >= 0.2)
            .map(|(_, dt)| *dt)
            .fold(0.0, f64::max);
        eprintln!("{method:?}: early {early:e}, late {late:e}");
        assert!(
            late >= 4.0 * early,
            "{method:?}: early {early:e}, late {late:e}"
        );
    }
}

/// A first attempt far too long is rejected; the step then taken from the restored state has
/// the bits of one step of that length taken by a fresh run from rest: nothing of the rejected
/// attempt is left in the state or the integrator.
#[test]
fn rejected_step_leaves_no_trace() {
    let definition = swing(ModelKind::Linear, 1e7);
    for method in [Method::Newmark, Method::BackwardEuler] {
        let mut run =
            Transient::new(&definition, options(method, 0.1, Rayleigh::default())).unwrap();
        let control = AdaptiveStep::new(1e-3).unwrap();
        let mut first: Option<State> = None;
        let report = run
            .run_adaptive(0.3, &control, &mut |view: &StepView<'_>| -> Result<Flow> {
                first = Some(view.state.clone());
                Ok(Flow::Stop)
            })
            .unwrap();
        assert!(
            report.rejected >= 1,
            "{method:?}: the 0.1 s attempt was kept"
        );
        let dt = report.steps[0].1;
        assert!(dt < 0.1);
        let mut fresh =
            Transient::new(&definition, options(method, dt, Rayleigh::default())).unwrap();
        fresh.step().unwrap();
        let first = first.unwrap();
        assert_eq!(first.steps, 1);
        assert_eq!(first.displacement, fresh.state().displacement, "{method:?}");
        assert_eq!(first.velocity, fresh.state().velocity, "{method:?}");
    }
}

/// The run lands on every multiple of the output interval and ends exactly at its end time.
#[test]
fn lands_on_output_times_and_end() {
    let definition = swing(ModelKind::Linear, 1e7);
    let (report, samples) = adaptive(
        &definition,
        Method::Newmark,
        (7e-4, 1e-2),
        (0.105, 0.01),
        Rayleigh::default(),
    )
    .unwrap();
    // 0.01, 0.02, …, 0.10 and the end 0.105 (k = 10.5 rounds to 11: not a multiple, so kept
    // apart below).
    let landed: Vec<i64> = samples.at.keys().copied().collect();
    assert_eq!(landed, (1..=10).collect::<Vec<_>>());
    assert_eq!(report.steps.last().unwrap().0, 0.105);
    for k in 1..=10 {
        let t = k as f64 * 0.01;
        assert!(
            report.steps.iter().any(|(time, _)| *time == t),
            "no step ends at {t}"
        );
    }
}

#[test]
fn explicit_is_refused_by_name() {
    let definition = swing(ModelKind::Linear, 1e7);
    let mut run = Transient::new(
        &definition,
        options(Method::Explicit, 1e-6, Rayleigh::default()),
    )
    .unwrap();
    let control = AdaptiveStep::new(1e-3).unwrap();
    let error = run
        .run_adaptive(0.01, &control, &mut tetfem::analysis::transient::Unobserved)
        .unwrap_err()
        .to_string();
    assert!(
        error.contains("time_tolerance") && error.contains("explicit"),
        "{error}"
    );
}

/// A rubber cube of 0.1 m (E = 100 kPa, ν = 0.3, ρ = 1000 kg/m³, linear model) released from
/// rest 5 mm above a fixed ground under gravity: it falls (32 ms), lands on the IPC barrier and
/// bounces; nothing holds it but the ground. The linear model steps through Newton with the
/// barrier (backward Euler; the library's contact takes the implicit methods). Its mesh: 2 × 2
/// × 2 cells, its bottom 5 mm above the ground (the barrier's scales: [`drop_with_barrier`]).
fn drop_mesh() -> TetMesh {
    tetfem_fixtures::drop::drop_mesh().unwrap()
}

/// the drop ([`drop_mesh`]) with the barrier's stiffness κ of `ContactParameters::for_mesh` times
/// `factor`.
fn drop_with_stiffness(factor: f64) -> Definition {
    drop_with_barrier(factor, None)
}

/// the drop ([`drop_mesh`]) with the impact-aware barrier stiffness at the fraction `fraction` of d̂
/// (`ContactParameters::with_impact_fraction`), the default κ its floor.
fn drop_with_impact(fraction: f64) -> Definition {
    drop_with_barrier(1.0, Some(fraction))
}

/// the drop ([`drop_mesh`]) with κ times `factor` and the impact fraction `impact`, if any.
fn drop_with_barrier(factor: f64, impact: Option<f64>) -> Definition {
    let mesh = drop_mesh();
    let rubber = Material::new(1e5, 0.3, 1000.0).unwrap();
    let mut parameters = ContactParameters::for_mesh(&mesh, rubber.youngs_modulus()).unwrap();
    parameters.stiffness *= factor;
    if let Some(fraction) = impact {
        parameters = parameters.with_impact_fraction(fraction).unwrap();
    }
    let ground = Obstacle::half_space("ground", Vector3::zeros(), Vector3::z()).unwrap();
    let contact = Contact::new(&mesh, vec![ground], parameters).unwrap();
    let materials = MaterialMap::uniform(rubber, mesh.tet_count());
    Definition::builder(mesh, materials)
        .gravity(Vector3::new(0.0, 0.0, -9.81))
        .unwrap()
        .contact(contact)
        .build()
        .unwrap()
}

/// The mean vertical displacement of the nodes (the body is free: every DOF is free, in node
/// order): the centroid's height change for equal nodal masses.
fn mean_z(u: &[f64]) -> f64 {
    u.iter().skip(2).step_by(3).sum::<f64>() / (u.len() / 3) as f64
}

impl Samples {
    /// max over the common landings of |z̄ − z̄_ref| over the largest |z̄_ref|: the error of the
    /// centroid's trajectory relative to its travel.
    fn centroid_error_of(&self, run: &Samples) -> f64 {
        let travel = (self.at.values())
            .map(|(u, _)| mean_z(u).abs())
            .fold(0.0, f64::max);
        (run.at.iter())
            .map(|(k, (u, _))| (mean_z(u) - mean_z(&self.at[k].0)).abs() / travel)
            .fold(0.0, f64::max)
    }
}

/// The drop's span: 80 ms (fall, impact at 32 ms, rebound), landing every 2 ms.
const DROP_SPAN: (f64, f64) = (0.08, 0.002);

/// The drop's adaptive run at `tolerance` ([`contact_drop_effectivity`]): backward Euler from
/// a first step of 1 ms over [`DROP_SPAN`].
fn drop_run(definition: &Definition, tolerance: f64) -> (AdaptiveReport, Samples) {
    let span = DROP_SPAN;
    adaptive(
        definition,
        Method::BackwardEuler,
        (1e-3, tolerance),
        span,
        Rayleigh::default(),
    )
    .unwrap()
}

/// The drop's graded reference at `per_step` steps per step of the run `report`
/// ([`graded_reference`]).
fn drop_graded(definition: &Definition, report: &AdaptiveReport, per_step: usize) -> Samples {
    let landing = (DROP_SPAN.1, Rayleigh::default());
    graded_reference(
        definition,
        Method::BackwardEuler,
        &report.steps,
        per_step,
        landing,
    )
    .unwrap()
}

/// The largest relative difference of two runs' κᵢ at their ends (0 where either has none).
fn kappa_difference(a: &Samples, b: &Samples) -> f64 {
    match (&a.kappa, &b.kappa) {
        (Some(a), Some(b)) => (a.iter().zip(b))
            .map(|(x, y)| (x - y).abs() / x.abs().max(y.abs()))
            .fold(0.0, f64::max),
        _ => 0.0,
    }
}

/// The drop at `tolerance` against its graded references at 16 and 32 steps per step of the
/// run (see [`contact_drop_effectivity`]): the reference's own error bounded, then the
/// effectivity in the band with the true error anywhere within that bound.
fn drop_effectivity_graded(tolerance: f64) {
    let definition = drop_with_impact(0.25);
    let (report, samples) = drop_run(&definition, tolerance);
    let (fine, finer) = (
        drop_graded(&definition, &report, 16),
        drop_graded(&definition, &report, 32),
    );
    let truth = finer.centroid_error_of(&samples);
    // The references' difference: at first order the error of the one at 32 (measured: the
    // differences 8 → 16 and 16 → 32 halve at 5 %, 3.9e-3 and 2.1e-3; at 2 % they fall slower,
    // 1.2e-3 and 9.1e-4, yet the one at 32 is 2.2e-4 from a uniform reference at 2e-8 s there).
    let own = finer.centroid_error_of(&fine);
    let estimated = report.estimated_error;
    eprintln!(
        "contact drop at {tolerance:e}: estimated {estimated:.3e}; true centroid {truth:.3e} \
         (ratio {:.2}) against the graded reference at 32, {:.3e} at 16; the references' \
         difference {own:.3e}; full state {:.3e}; {} steps, {} rejected, dt {:.2e}..{:.2e}; \
         κᵢ: run against 32 {:.1e}, 16 against 32 {:.1e}",
        estimated / truth,
        fine.centroid_error_of(&samples),
        finer.error_of(&samples),
        report.accepted,
        report.rejected,
        report.dt_range.0,
        report.dt_range.1,
        kappa_difference(&samples, &finer),
        kappa_difference(&fine, &finer),
    );
    // The reference adequate: its own error (≈ `own`) at most a quarter of the run's, so it
    // moves the effectivity by at most ~25 % (measured 6.0 % at 5 %, 4.6 % at 2 %).
    assert!(
        own <= truth / 4.0,
        "at {tolerance:e}: the references at 16 and 32 differ by {own:e}, the run's error {truth:e}"
    );
    // The band holds wherever in truth ± own the true error is.
    for truth in [truth - own, truth, truth + own] {
        assert_effective(estimated, truth, &format!("contact drop at {tolerance:e}"));
    }
}

/// The contact drop over 80 ms (fall, impact at 32 ms, rebound) by backward Euler at a
/// tolerance of 5 %, with the impact-aware barrier stiffness at f = ¼ (`drop_with_impact`; the
/// references too), its estimate against the true error of its centroid's trajectory.
///
/// The error measure asserted is the centroid's trajectory (above): after the impact the
/// barrier's stiff contact excites the block's internal modes, which backward Euler damps out
/// at the steps the control picks and which a run at 1/16 of them resolves, so the full
/// state's difference there measures the reference's ringing rather than the run's error of
/// its motion; the centroid is what a drop is run for. The full-state error (the estimate's
/// own norm) is printed beside it. With the option on, backward Euler's estimate has a second
/// norm, the body's mean motion with the barrier's force in it (`adaptive.rs`'s module doc,
/// "The impact in the estimate").
///
/// The reference is graded ([`graded_reference`]): a fresh fixed-step run from rest covering
/// each of the run's accepted steps with 32 equal steps, so everywhere at 1/32 of the run's
/// local step (3.3e-7 … 1e-3 s at 5 %: 1e-8 … 3.1e-5 s), 370 k steps instead of the 4 million of
/// a uniform one at 1/16 of the smallest step. It is independent of the run: it takes its step
/// schedule only (no state, no estimate, no restart from the run's states, no extrapolation),
/// and for a first-order method its error is ~1/32 of the run's where the run's is local
/// truncation. Its adequacy is asserted, not assumed: the graded references at 16 and at 32
/// differ by at most a quarter of the run's error (at first order their difference is the
/// error of the one at 32), and the band holds with the true error moved by that difference
/// either way. The impact-aware κᵢ is chosen from a landing node's approach at the step that
/// meets the barrier, so it depends on the step: the run's κᵢ at its end differ from the
/// reference's by up to 16 %, those of the references at 16 and 32 by 1.5 % (that of 8 and 16:
/// 2.6 %) — converging with the reference's step, and the run's κ error is part of its error.
///
/// Measured at 5 % (11 548 steps, 15 rejected, dt 3.26e-7 … 1e-3 s): estimated 5.592e-2;
/// true centroid error 3.415e-2 against the graded reference at 32 (effectivity 1.64), 3.222e-2
/// at 16 (1.74), 2.858e-2 at 8 (1.96); the references at 16 and 32 differ by 2.06e-3 (6.0 % of
/// the run's error), at 8 and 16 by 3.87e-3. Against the uniform reference at 1/16 of the
/// smallest step (2.0e-8 s, 4 million steps; [`contact_drop_uniform_reference`]): 3.560e-2
/// (1.57); it and the graded reference at 32 differ by 1.57e-3 (4.6 % of the run's error,
/// inside the ±2.06e-3 the test allows), that at 16 by 3.61e-3. The graded references built on
/// the 5 % and the 2 % runs' schedules (different steps, different κᵢ) differ by 1.8e-3. Run
/// time of this test: 73.7 s at load 13–17 on 2 cores (`cargo test --release --test core
/// contact_drop_effectivity`; the run 2.8 s, the references 31.5 s and 56.5 s).
/// At 2 %: [`contact_drop_effectivity_at_2_percent`] (ignored for its run time).
#[test]
fn contact_drop_effectivity() {
    drop_effectivity_graded(5e-2);
}

/// The drop of [`contact_drop_effectivity`] at a tolerance of 2 %, against its graded
/// references at 16 and 32 the same way. Measured (30 745 steps, 10 rejected, dt 8.14e-8 …
/// 2.5e-4 s): estimated 2.236e-2; true centroid error 1.970e-2 against the graded reference at
/// 32 (effectivity 1.13), 1.879e-2 at 16 (1.19), 1.758e-2 at 8 (1.27); the references at 16 and
/// 32 differ by 9.1e-4 (4.6 % of the run's error), at 8 and 16 by 1.2e-3. Against the uniform
/// reference of the 5 % run (2.0e-8 s) this run's true error is 1.948e-2 (1.15), and that
/// reference and the graded one at 32 differ by 2.2e-4. The uniform reference at 1/16 of this
/// run's own smallest step (5.1e-9 s, 15.7 million steps) gave 3.122e-2 (0.72, in the band too):
/// it stands apart from the three others, which agree within 1.8e-3 — it is 1.17e-2 from the
/// graded one at 32 and 1.18e-2 from the uniform one at 2e-8 s, and already 7.2e-4 of the
/// travel from the latter in the free fall (28 ms), where backward Euler's truncation error at
/// 5.1e-9 s is ~1e-7 of it; its κᵢ of the four symmetric landing corners spread by 7 % (the
/// others' by < 0.3 %). Over 15.7 million steps its per-step solve and round-off errors add up
/// beyond the truncation error it was to undercut (measured; the cause not pinned). Ignored for its run time: 5.6 s for the run, 80 s and
/// 148 s for the references (490 k and 980 k steps) at load 12–21.
#[test]
#[ignore = "about 4 minutes: its graded references take 1.5 million steps (see the doc comment)"]
fn contact_drop_effectivity_at_2_percent() {
    drop_effectivity_graded(2e-2);
}

/// The drop of [`contact_drop_effectivity`] at 5 % and 2 % against the uniform fixed-step
/// reference at 1/16 of the run's smallest step (the wording: 2e-8 s at 5 %, 4 million
/// steps; 5.1e-9 s at 2 %, 15.7 million), the check the graded reference replaced in CI; its
/// difference from the graded reference at 32 printed beside. Measured: at 5 %, 3.560e-2
/// (effectivity 1.57; 592 s for the reference at load 7–21), 1.57e-3 from the graded reference;
/// at 2 %, 3.122e-2 (0.72), 1.17e-2 from the graded reference (this reference is the one that
/// is off: [`contact_drop_effectivity_at_2_percent`]). Both tolerances took 2 887 s at load
/// ~1–2.
#[test]
#[ignore = "about 50 minutes: its references at 1/16 of the smallest step are 2e-8 s at 5 % (4 million steps) and 5.1e-9 s at 2 % (15.7 million; see the doc comment)"]
fn contact_drop_uniform_reference() {
    let definition = drop_with_impact(0.25);
    let method = Method::BackwardEuler;
    for tolerance in [5e-2, 2e-2] {
        let (report, samples) = drop_run(&definition, tolerance);
        let uniform = reference(
            &definition,
            method,
            report.dt_range.0,
            DROP_SPAN,
            Rayleigh::default(),
        );
        let graded = drop_graded(&definition, &report, 32);
        let centroid = uniform.centroid_error_of(&samples);
        let estimated = report.estimated_error;
        eprintln!(
            "contact drop at {tolerance:e}: estimated {estimated:.3e}; true centroid against \
             the uniform reference {centroid:.3e} (ratio {:.2}), full state {:.3e}; against \
             the graded reference at 32 {:.3e}; the two references differ by {:.3e}; κᵢ \
             {:.1e}",
            estimated / centroid,
            uniform.error_of(&samples),
            graded.centroid_error_of(&samples),
            uniform.centroid_error_of(&graded),
            kappa_difference(&uniform, &graded),
        );
        assert_effective(estimated, centroid, "contact drop (uniform reference)");
    }
}

/// The closest approach of a fixed-step backward Euler drop to 60 ms (through the first
/// contact, 31–60 ms): the lowest gap d_min and ω_c·dt there
/// ([`ClosestApproach`](tetfem_fixtures::drop::ClosestApproach), shared with the bench).
fn closest_approach(definition: &Definition, dt: f64) -> (f64, f64) {
    let mut probe = tetfem_fixtures::drop::ClosestApproach::new(&drop_mesh());
    let mut run = Transient::new(
        definition,
        options(Method::BackwardEuler, dt, Rayleigh::default()),
    )
    .unwrap();
    let steps = (0.06 / dt).round() as usize;
    run.run((0, steps), &mut |view: &StepView<'_>| -> Result<Flow> {
        probe.observe(view, dt)?;
        Ok(Flow::Continue)
    })
    .unwrap();
    (probe.gap, probe.resolution)
}

/// Why the drop's impact error is neither estimated nor controlled through dt (see
/// [`contact_drop_effectivity`]): with the default barrier stiffness κ the node that lands
/// stops within about one step — the contact line search keeps a fifth of the gap per Newton
/// step — so its closest gap d_min falls in proportion to dt and the barrier's frequency there,
/// ω_c ∝ d̂/d_min, rises as 1/dt: ω_c·dt stays near 3 at every dt (measured 2.4–3.5 from 5e-4
/// down to 9.8e-7 s, d_min/dt 0.015–0.023 m/s). No step resolves the barrier (the resolved
/// closest gap, where κ·A·b(d) stores the node's kinetic energy, is ~1e-14 m), so what the
/// steps do to the impact does not converge with dt. With κ 50× larger the barrier stores the
/// impact energy at d ≈ d̂/3.5: d_min converges and ω_c·dt falls with dt. The impact-aware
/// stiffness (`ContactParameters::with_impact_fraction`, f = ¼) does the same with κ chosen
/// from the landing nodes' kinetic energy: d_min near f·d̂ at both steps.
#[test]
fn contact_impact_resolution() {
    let (coarse, fine) = (1.25e-4, 3.90625e-6);
    let default = drop_with_stiffness(1.0);
    let (gap_coarse, at_coarse) = closest_approach(&default, coarse);
    let (gap_fine, at_fine) = closest_approach(&default, fine);
    eprintln!(
        "default κ: dt {coarse:e}: d_min {gap_coarse:.3e}, ω_c·dt {at_coarse:.2}; dt {fine:e}: \
         d_min {gap_fine:.3e}, ω_c·dt {at_fine:.2}"
    );
    // Unresolved at both steps, and d_min ∝ dt: over the 32× between them it falls at least
    // 16× (measured 28×; a gap set by the barrier, not the step, would not move).
    assert!(at_coarse > 1.0 && at_fine > 1.0);
    assert!(gap_coarse / gap_fine >= 16.0);
    let stiff = drop_with_stiffness(50.0);
    let (gap_coarse, at_coarse) = closest_approach(&stiff, coarse);
    let (gap_fine, at_fine) = closest_approach(&stiff, fine);
    eprintln!(
        "50 κ: dt {coarse:e}: d_min {gap_coarse:.3e}, ω_c·dt {at_coarse:.2}; dt {fine:e}: \
         d_min {gap_fine:.3e}, ω_c·dt {at_fine:.2}"
    );
    // Resolved at the fine step (ω_c·dt ≤ 0.1, ten steps per radian), and d_min set by the
    // barrier: within 2× over the same 32× (it converges to d̂/3.5 as dt → 0).
    assert!(at_fine <= 0.1);
    assert!(gap_coarse / gap_fine <= 2.0);
    // The impact-aware stiffness at f = ¼ does the same without a hand-picked κ: κ from the
    // landing nodes' kinetic energy stops them near f·d̂.
    let aware = drop_with_impact(0.25);
    let (gap_coarse, at_coarse) = closest_approach(&aware, coarse);
    let (gap_fine, at_fine) = closest_approach(&aware, fine);
    let d_hat = ContactParameters::for_mesh(&drop_mesh(), 1e5)
        .unwrap()
        .activation_distance;
    eprintln!(
        "impact f = 0.25: dt {coarse:e}: d_min {gap_coarse:.3e}, ω_c·dt {at_coarse:.2}; dt \
         {fine:e}: d_min {gap_fine:.3e}, ω_c·dt {at_fine:.2}; f·d̂ = {:.3e}",
        0.25 * d_hat
    );
    // Resolved at the fine step (ω_c·dt ≤ 0.1), and d_min set by the barrier, near f·d̂ at
    // both steps: each node's κᵢ stores its own kinetic energy at f·d̂, but the body behind a
    // landing node pushes it on and the nodes land at different speeds, so between f·d̂/5
    // and 2·f·d̂ (measured 0.29 and 0.55 f·d̂ at these steps with the per-node κᵢ, 1.46 and
    // 0.69 with the one κ of every node before it; the default κ's d_min fell 28× over the
    // same 32×, to 0.0016 f·d̂, so this band separates a gap set by the barrier from one set
    // by dt).
    assert!(at_fine <= 0.1);
    for gap in [gap_coarse, gap_fine] {
        assert!((0.2..=2.0).contains(&(gap / (0.25 * d_hat))), "{gap:e}");
    }
}

/// The cantilever of [`swing`] without gravity, its clamp shaken along z by 5 mm·sin(2π·2 Hz·t)
/// (below its first mode, 3.2 Hz) from rest, with a little stiffness damping (β = 1e-4 s, as in
/// `swing_damped_steps_grow`: the modes the sudden start excites above 4000 rad/s die out),
/// over half a second by Newmark at a tolerance of 1e-2. The support's velocity jumps from 0 to
/// A·ω at the start, exciting modes that β damps: with their errors decayed (`error_decay`) the
/// smallest step is 2.6e-5 s (measured; 8.1e-7 s when every error counted to the end, 2e-6 s
/// with the earlier continuous control), so the reference at 1/16 of it takes 307 200 steps.
/// Measured: estimated 9.05e-3 against true 7.76e-3 (ratio 1.17; 1.33 before), 2 078 steps.
#[test]
fn shaken_base_effectivity() {
    let mesh = TetMesh::box_grid(
        Vector3::zeros(),
        Vector3::new(0.5, 0.05, 0.05),
        [10, 1, 1],
        BoxSplit::Mirrored6,
    )
    .unwrap();
    let materials =
        MaterialMap::uniform(Material::new(1e7, 0.3, 1000.0).unwrap(), mesh.tet_count());
    let clamp = mesh.nodes_on_plane(0, 0.0, 1e-9);
    let mut constraints = Constraints::new(&mesh);
    constraints.fix_nodes(&clamp).unwrap();
    let mut data = TimeData::default();
    let shake = Motion::Uniform {
        displacement: Vector3::new(0.0, 0.0, 5e-3),
        amplitude: Amplitude::sine(1.0, 2.0, 0.0, 0.0).unwrap(),
    };
    data.motion.add(&clamp, [true; 3], shake).unwrap();
    let definition = Definition::builder(mesh, materials)
        .constraints(constraints)
        .unwrap()
        .time_data(data)
        .build()
        .unwrap();
    let damping = Rayleigh::new(0.0, 1e-4).unwrap();
    let (estimated, truth, _) = effectivity(
        &definition,
        Method::Newmark,
        (1e-3, 1e-2),
        (0.5, 0.01),
        damping,
    );
    assert_effective(estimated, truth, "shaken base");
}

/// With the impact-aware stiffness each contact node's κᵢ is part of what a step depends on:
/// a fixed-step drop checkpointed at its first step with a node within d̂ holding a raised κᵢ
/// and resumed on a fresh run with the checkpoint's per-node record
/// (`IMPACT_STIFFNESS_RECORD`) continues with the same bits as the run that never stopped.
/// Resumed without it (every node at κ₀, as a new run starts) it does not: the record is
/// needed.
#[test]
fn impact_stiffness_restarts_with_the_same_bits() {
    use tetfem::analysis::dynamics::{Checkpoint, IMPACT_STIFFNESS_RECORD, InternalForce};
    let definition = drop_with_impact(0.25);
    let parameters = ContactParameters::for_mesh(&drop_mesh(), 1e5).unwrap();
    let dt = 3.125e-5;
    let new_run = || {
        Transient::new(
            &definition,
            options(Method::BackwardEuler, dt, Rayleigh::default()),
        )
        .unwrap()
    };
    // Stops at the first step where a node within d̂ holds κᵢ above κ₀.
    let mut first = new_run();
    first
        .run((0, 4000), &mut |view: &StepView<'_>| -> Result<Flow> {
            let contact = view.force.contact().unwrap();
            let (gaps, _) = contact.gaps_and_pressures(&view.state.displacement)?;
            let kappas = contact.node_stiffnesses().unwrap();
            let raised = (gaps.iter().zip(&kappas))
                .any(|(d, k)| *d < parameters.activation_distance && *k > parameters.stiffness);
            Ok(if raised { Flow::Stop } else { Flow::Continue })
        })
        .unwrap();
    let stop = first.state().steps;
    assert!(stop < 4000, "no node within d̂ held a raised κᵢ");
    let end = stop + 200;
    let mut straight = new_run();
    straight
        .run((0, end), &mut tetfem::analysis::transient::Unobserved)
        .unwrap();
    let values = first.force().node_stiffnesses().unwrap();
    let record = first.barrier_record();
    let records = vec![(IMPACT_STIFFNESS_RECORD.to_string(), values)];
    let taken = Checkpoint::take(first.integrator(), first.state(), vec![], records).unwrap();
    let read = Checkpoint::from_bytes(&taken.to_bytes(), std::path::Path::new("mem")).unwrap();
    let resume = |per_node: bool| -> State {
        let mut run = new_run();
        *run.state_mut() = read.restore(run.integrator_mut()).unwrap();
        let InternalForce::Nonlinear(force) = run.force() else {
            panic!("the drop's force has contact");
        };
        if per_node {
            force.set_barrier_record(record);
            let values = read.record(IMPACT_STIFFNESS_RECORD).unwrap();
            force.set_node_stiffnesses(values).unwrap();
        }
        run.run((stop, end), &mut tetfem::analysis::transient::Unobserved)
            .unwrap();
        run.state().clone()
    };
    let bits = |x: &[f64]| x.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
    let resumed = resume(true);
    assert_eq!(
        bits(&resumed.displacement),
        bits(&straight.state().displacement)
    );
    assert_eq!(bits(&resumed.velocity), bits(&straight.state().velocity));
    let approximate = resume(false);
    assert_ne!(
        bits(&approximate.displacement),
        bits(&straight.state().displacement)
    );
}

/// The per-node stiffness makes the barrier conservative (each node's κᵢ·Aᵢ·b(dᵢ) is one
/// fixed potential while it holds energy: `tetfem::contact::impact`), and backward Euler on a
/// convex potential (linear elasticity, gravity, the barrier of a half-space's linear gap)
/// only loses energy, so the drop's total energy — kinetic, elastic, gravity's and the
/// barrier's — never rises above its start through the landing and the rebound. The one κ of
/// every node before it (raised under nodes already within d̂ by a node landing later and
/// faster) ended this drop at this step 5.2e-4 J above its start, its largest excess 6.7e-4 J
/// (`benches/adaptive_time_step.rs drop-fixed`, measured); per node the largest E − E₀ was
/// −4.6e-11 J. The bound, 1e-6 of the fall's energy m·g·h = 0.049 J, leaves the Newton
/// tolerance's residual work room and is 1e-4 of the excess it rules out.
#[test]
fn impact_stiffness_adds_no_energy() {
    let definition = drop_with_impact(0.25);
    let dt = 9.765625e-7;
    let mut run = Transient::new(
        &definition,
        options(Method::BackwardEuler, dt, Rayleigh::default()),
    )
    .unwrap();
    let steps = (0.08 / dt).round() as usize;
    let mut largest = f64::NEG_INFINITY;
    run.run((0, steps), &mut |view: &StepView<'_>| -> Result<Flow> {
        let energies = view.force.energy(view.system, view.state)?;
        let contact = view.force.contact().unwrap();
        // Every DOF is free: the free displacement is the full one.
        let total = energies.kinetic
            + energies.elastic
            + energies.gravity_potential
            + energies.load_potential
            + contact.energy(&view.state.displacement)?;
        largest = largest.max(total);
        Ok(Flow::Continue)
    })
    .unwrap();
    // The body starts at rest, undeformed and outside d̂: E₀ = 0.
    let fall = 1.0 * 9.81 * 5e-3;
    eprintln!("impact fraction ¼, dt {dt:e}: largest E − E₀ {largest:.3e} J");
    assert!(largest <= 1e-6 * fall, "{largest:e} J");
}
