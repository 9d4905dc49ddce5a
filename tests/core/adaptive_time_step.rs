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
}

fn norm(x: &[f64]) -> f64 {
    x.iter().map(|x| x * x).sum::<f64>().sqrt()
}

impl Samples {
    /// Keeps `state` if its time is a multiple of `interval` (to 1e-9 of it).
    fn keep(&mut self, state: &State, interval: f64) {
        self.scale.0 = self.scale.0.max(norm(&state.displacement));
        self.scale.1 = self.scale.1.max(norm(&state.velocity));
        let k = (state.time / interval).round();
        if (state.time - k * interval).abs() < 1e-9 * interval {
            let sample = (state.displacement.clone(), state.velocity.clone());
            self.at.insert(k as i64, sample);
        }
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
    Ok((report, samples))
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
/// barrier (backward Euler; the library's contact takes the implicit methods).
fn drop_on_ground() -> Definition {
    let mesh = TetMesh::box_grid(
        Vector3::new(0.0, 0.0, 5e-3),
        Vector3::new(0.1, 0.1, 0.105),
        [2, 2, 2],
        BoxSplit::Mirrored6,
    )
    .unwrap();
    let rubber = Material::new(1e5, 0.3, 1000.0).unwrap();
    let parameters = ContactParameters::for_mesh(&mesh, rubber.youngs_modulus()).unwrap();
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

/// The contact drop over 80 ms (fall, impact at 32 ms, rebound) by backward Euler at a
/// tolerance of 5 %. The error measure asserted is the centroid's trajectory (above): after the
/// impact the barrier's stiff contact excites the block's internal modes, which backward Euler
/// damps out at the steps the control picks and which a run at 1/16 of them resolves, so the
/// full state's difference there measures the reference's ringing rather than the run's error
/// of its motion; the centroid is what a drop is run for. The full-state error (the estimate's
/// own norm) is printed beside it.
///
/// Measured with the estimate on the smooth part (backward Euler's e_v without the barrier's
/// acceleration, `adaptive.rs`'s module doc): the run gets through the impact — 3430 steps,
/// 3 rejected, dt 5.2e-6 … 1e-3 s, where before it stopped at t ≈ 31.5 ms with steps of 8e-11 s
/// — and the reference at 1/16 of its smallest step runs with it in 48 s. Its estimate is
/// 3.47e-2 against a true centroid error of 7.09e-2: ratio 0.49, just below the band (full
/// state: 7.1e-1, ratio 0.05, the reference's ringing). What the estimate leaves out is the
/// impact's own error (how the step resolves the barrier's impulse), which the control does
/// not limit either: the true error exceeds the 5 % asked. Keeping the barrier's share in e_u
/// (dt/2·Δv, an impulse half a step off) stalled again at t = 36.3 ms at 8e-11 s.
///
/// Before (whole acceleration in the estimate): at the impact (t ≈ 31 ms) the accepted
/// steps shrank by 0.8× each, every one just within the tolerance, from 1.4e-5 s down to the
/// smallest step 8e-11 s (duration/MAX_STEPS), where a step is rejected: the error per unit
/// step e_v/dt stays constant as dt falls, i.e. the estimated jerk grows as 1/dt — the IPC
/// barrier's force grows without bound as a gap closes. At t = 31.536 ms the lowest node is
/// 4.1e-6 m above the ground (2.3 % of d̂ = 1.73e-4 m) and still falls at 0.275 m/s, 88 % of
/// its impact speed (0.313 m/s): at this stiffness the barrier takes less than a quarter of the
/// impact's kinetic energy over 97 % of its reach. With κ raised by hand
/// (`Contact::with_parameters`) to what stores the block's impact energy within a tenth of d̂
/// (8.8e7 Pa/m, 50× the default) the run reached the end in 62k steps (dt down to 4.3e-8 s).
/// Ignored (not loosened) until the impact's error is estimated (an event's: the time of
/// impact from the CCD and the barrier's time scale √(m/κ_eff)).
///
/// Measured again with the tolerance budget (the control spreads what is left of the
/// tolerance over the time left; `adaptive.rs`'s module doc): at 5 %, estimated 5.97e-2
/// against a true centroid error of 4.57e-2 (ratio 1.31, in the band; 1 968 steps, 3 rejected,
/// dt 1.04e-5 … 1e-3 s); at 2 %, estimated 2.40e-2 against 6.34e-2 (ratio 0.38; 5 844 steps, 4
/// rejected, dt 3.91e-6 … 2.5e-4 s): the impact's error, neither estimated nor limited, is
/// larger at the tighter tolerance than at the looser one — it depends on where the steps fall
/// at the onset, not on the tolerance. Full state: ratios 0.09 and 0.03 (the reference's
/// ringing). The run took 101 s with both references. Fixed steps against the same references
/// (`benches/adaptive_time_step.rs`, scene `drop`): at 5 % the cheapest fixed dt meeting it is
/// 1.25e-4 s (4.74e-2, 640 steps; the adaptive run costs 3.68× its CPU time); against the
/// reference of the 2 % run the fixed runs' centroid error stays at 7.26e-2 and 7.22e-2 for
/// dt = 6.25e-5 and 3.1e-5 s: the impact's error does not fall with dt at these steps (a
/// hypothesis, not measured: backward Euler damps the barrier's stiff contact mode while
/// ω_c·dt ≫ 1, which changes the rebound), so it must be estimated as an event, not from the
/// smooth motion.
#[test]
#[ignore = "contact onset: the impact's error is not estimated; at 2 % the estimate is 0.38x the true centroid error (see the doc comment)"]
fn contact_drop_effectivity() {
    let definition = drop_on_ground();
    let span = (0.08, 0.002);
    let method = Method::BackwardEuler;
    for tolerance in [5e-2, 2e-2] {
        let (report, samples) = adaptive(
            &definition,
            method,
            (1e-3, tolerance),
            span,
            Rayleigh::default(),
        )
        .unwrap();
        let exact = reference(
            &definition,
            method,
            report.dt_range.0,
            span,
            Rayleigh::default(),
        );
        let (centroid, full) = (exact.centroid_error_of(&samples), exact.error_of(&samples));
        let estimated = report.estimated_error;
        eprintln!(
            "contact drop at {tolerance:e}: estimated {estimated:.3e}; true: centroid \
             {centroid:.3e} (ratio {:.2}), full state {full:.3e} (ratio {:.2}); {} steps, {} \
             rejected, dt {:.2e}..{:.2e}",
            estimated / centroid,
            estimated / full,
            report.accepted,
            report.rejected,
            report.dt_range.0,
            report.dt_range.1
        );
        assert_effective(estimated, centroid, "contact drop (centroid)");
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
