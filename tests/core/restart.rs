//! Checkpoints: for every integrator (backward Euler, Newmark, explicit; linear and with a
//! corotational model; Rayleigh damping, gravity and a suddenly applied end load), 100 steps,
//! a checkpoint through its file bytes, a fresh integrator restored from it and 100 more steps
//! give the same bits as 200 steps in one go. Bad checkpoints are refused by name.

use crate::common;

use std::path::Path;
use std::sync::Arc;

use nalgebra::Vector3;
use tetfem::analysis::dynamics::{
    Checkpoint, Integrator, IntegratorOptions, InternalForce, LinearSystem, MassKind, Method,
    NonlinearForce, Rayleigh, State, critical_time_step,
};
use tetfem::model::ModelKind;
use tetfem::{BoxSplit, Error};
use tetfem_fixtures::cantilever::Cantilever;

/// A clamped 4 × 1 × 1 beam (8×2×2 cells, E = 1e5, ν = 0.3, ρ = 1000) under a unit end load
/// and gravity, Rayleigh damping α = 0.5 /s, β = 1e-4 s, lumped mass, at rest.
fn problem() -> (Arc<LinearSystem>, Arc<tetfem::TetMesh>, tetfem::Material) {
    let beam = Cantilever {
        length: 4.0,
        split: BoxSplit::Lecture6,
        ..Cantilever::peer_benchmark([8, 2, 2])
    };
    let mesh = beam.mesh().unwrap();
    let system = LinearSystem::new(
        &mesh,
        &beam.material,
        &beam.constraints(&mesh).unwrap(),
        &beam.loads(&mesh).unwrap(),
        Vector3::new(0.0, 0.0, -9.81),
        MassKind::Lumped,
        Rayleigh::new(0.5, 1e-4).unwrap(),
    )
    .unwrap();
    (Arc::new(system), Arc::new(mesh), beam.material)
}

/// The force: linear, or the corotational model on the same mesh.
fn force(
    nonlinear: bool,
    system: &LinearSystem,
    mesh: &Arc<tetfem::TetMesh>,
    m: &tetfem::Material,
) -> InternalForce {
    match nonlinear {
        false => InternalForce::Linear,
        true => InternalForce::Nonlinear(Arc::new(
            NonlinearForce::new(Arc::clone(mesh), ModelKind::Corotational.build(m), system)
                .unwrap(),
        )),
    }
}

/// Every case: (method, nonlinear, dt as a multiple of the explicit critical step). The
/// explicit method runs at half its limit; the implicit ones above it (the linear ones well
/// above; the nonlinear ones at 3×, where Newton converges through the large swing).
const CASES: [(Method, bool, f64); 6] = [
    (Method::BackwardEuler, false, 20.0),
    (Method::Newmark, false, 20.0),
    (Method::Explicit, false, 0.5),
    (Method::BackwardEuler, true, 3.0),
    (Method::Newmark, true, 3.0),
    (Method::Explicit, true, 0.5),
];

fn integrator(
    method: Method,
    nonlinear: bool,
    dt: f64,
) -> (Box<dyn Integrator>, Arc<LinearSystem>) {
    let (system, mesh, material) = problem();
    let force = force(nonlinear, &system, &mesh, &material);
    let integrator = method
        .integrator_with_force(Arc::clone(&system), force, dt, IntegratorOptions::default())
        .unwrap();
    (integrator, system)
}

fn bits(values: &[f64]) -> Vec<u64> {
    values.iter().map(|v| v.to_bits()).collect()
}

#[test]
fn a_restored_run_continues_with_the_same_bits_for_every_method() {
    let (system, _, _) = problem();
    let critical = critical_time_step(&system).unwrap().dt;
    for (method, nonlinear, multiple) in CASES {
        let dt = multiple * critical;
        let case = format!("{method:?}, nonlinear {nonlinear}");
        let (mut straight, system) = integrator(method, nonlinear, dt);
        let mut whole = State::at_rest(system.free_count());
        for _ in 0..200 {
            straight.step(&mut whole).unwrap();
        }

        let (mut first, _) = integrator(method, nonlinear, dt);
        let mut state = State::at_rest(system.free_count());
        for _ in 0..100 {
            first.step(&mut state).unwrap();
        }
        let fingerprint = vec![("scene".to_string(), "abc".to_string())];
        let records = vec![("probe_min".to_string(), vec![-0.0, f64::MIN_POSITIVE, 1.5])];
        let checkpoint = Checkpoint::take(first.as_ref(), &state, fingerprint, records).unwrap();
        drop(first);
        let read = Checkpoint::from_bytes(&checkpoint.to_bytes(), Path::new("mem")).unwrap();
        // The file keeps every field, the records' −0 and subnormal-edge values too.
        assert_eq!(read, checkpoint, "{case}");
        assert_eq!(
            bits(read.record("probe_min").unwrap()),
            bits(&[-0.0, f64::MIN_POSITIVE, 1.5])
        );
        assert_eq!(read.fingerprint_entry("scene"), Some("abc"));
        assert!(
            read.history.guard.is_some(),
            "{case}: the guard is set by the first step"
        );
        assert_eq!(
            read.history.acceleration.is_some(),
            method == Method::Newmark || (method == Method::BackwardEuler && nonlinear),
            "{case}: Newmark keeps an acceleration, and nonlinear backward Euler the one its \
             Newton iterations start from"
        );
        assert_eq!(
            read.history.previous_acceleration.is_some(),
            method == Method::BackwardEuler && nonlinear,
            "{case}: nonlinear backward Euler keeps the step before's too"
        );

        let (mut second, _) = integrator(method, nonlinear, dt);
        let mut resumed = read.restore(second.as_mut()).unwrap();
        assert_eq!(resumed.steps, 100);
        for _ in 0..100 {
            second.step(&mut resumed).unwrap();
        }
        assert_eq!(resumed.steps, whole.steps, "{case}");
        assert_eq!(resumed.time.to_bits(), whole.time.to_bits(), "{case}: time");
        assert_eq!(
            bits(&resumed.displacement),
            bits(&whole.displacement),
            "{case}: u"
        );
        assert_eq!(bits(&resumed.velocity), bits(&whole.velocity), "{case}: v");
        common::restart::assert_same_history(
            &second.history().unwrap(),
            &straight.history().unwrap(),
            &case,
        );
        common::restart::assert_same_newton(second.newton_stats(), straight.newton_stats(), &case);
        // The run moved: a comparison of two states at rest would prove nothing.
        assert!(whole.displacement.iter().any(|u| u.abs() > 1e-6), "{case}");
    }
}

/// Newmark's stored acceleration is not the equation of motion's: restarting from u and v
/// alone (the acceleration recomputed) leaves the uninterrupted trajectory, which is why the
/// checkpoint keeps it.
#[test]
fn newmark_without_its_acceleration_would_leave_the_trajectory() {
    let (system, _, _) = problem();
    let dt = 20.0 * critical_time_step(&system).unwrap().dt;
    let (mut straight, _) = integrator(Method::Newmark, false, dt);
    let mut whole = State::at_rest(system.free_count());
    for _ in 0..200 {
        straight.step(&mut whole).unwrap();
    }
    let (mut first, _) = integrator(Method::Newmark, false, dt);
    let mut state = State::at_rest(system.free_count());
    for _ in 0..100 {
        first.step(&mut state).unwrap();
    }
    let (mut fresh, _) = integrator(Method::Newmark, false, dt);
    for _ in 0..100 {
        fresh.step(&mut state).unwrap();
    }
    assert_ne!(bits(&state.displacement), bits(&whole.displacement));
}

/// Backward Euler with the corotational force on an undamped, gravity-free beam under its end
/// load from rest (the set-up the removed `NonlinearBackwardEuler` wrapper made): restored from
/// its history alone (no checkpoint file), it continues with the same bits and Newton counts.
#[test]
fn nonlinear_backward_euler_restores_from_its_history() {
    let beam = Cantilever::peer_benchmark([6, 2, 2]);
    let mesh = Arc::new(beam.mesh().unwrap());
    let system = Arc::new(
        LinearSystem::new(
            &mesh,
            &beam.material,
            &beam.constraints(&mesh).unwrap(),
            &beam.loads(&mesh).unwrap(),
            Vector3::zeros(),
            MassKind::Lumped,
            Rayleigh::default(),
        )
        .unwrap(),
    );
    let make = || {
        let force = NonlinearForce::new(
            Arc::clone(&mesh),
            ModelKind::Corotational.build(&beam.material),
            &system,
        )
        .unwrap();
        Method::BackwardEuler
            .integrator_with_force(
                Arc::clone(&system),
                InternalForce::Nonlinear(Arc::new(force)),
                1e-3,
                IntegratorOptions::default(),
            )
            .unwrap()
    };
    let n = system.free_count();
    let mut straight = make();
    let mut whole = State::at_rest(n);
    for _ in 0..40 {
        straight.step(&mut whole).unwrap();
    }
    let mut first = make();
    let mut state = State::at_rest(n);
    for _ in 0..20 {
        first.step(&mut state).unwrap();
    }
    let history = first.history().unwrap();
    let mut second = make();
    second.restore(&state, &history).unwrap();
    for _ in 0..20 {
        second.step(&mut state).unwrap();
    }
    assert_eq!(bits(&state.displacement), bits(&whole.displacement));
    assert_eq!(bits(&state.velocity), bits(&whole.velocity));
    // The nonlinear path's counts are there to compare (the linear path has none).
    assert!(straight.newton_stats().is_some());
    common::restart::assert_same_newton(
        second.newton_stats(),
        straight.newton_stats(),
        "nonlinear backward Euler",
    );
}

#[test]
fn a_checkpoint_is_refused_by_another_method_or_time_step() {
    let (system, _, _) = problem();
    let dt = 20.0 * critical_time_step(&system).unwrap().dt;
    let (mut newmark, _) = integrator(Method::Newmark, false, dt);
    let mut state = State::at_rest(system.free_count());
    newmark.step(&mut state).unwrap();
    let checkpoint = Checkpoint::take(newmark.as_ref(), &state, vec![], vec![]).unwrap();

    let (mut euler, _) = integrator(Method::BackwardEuler, false, dt);
    match checkpoint.restore(euler.as_mut()) {
        Err(Error::InvalidParameter {
            name, requirement, ..
        }) => {
            assert_eq!(name, "method");
            assert!(requirement.contains("newmark"), "{requirement}");
        }
        other => panic!("expected the method named, got {other:?}"),
    }
    let (mut other_dt, _) = integrator(Method::Newmark, false, 2.0 * dt);
    match checkpoint.restore(other_dt.as_mut()) {
        Err(Error::InvalidParameter { name, .. }) => assert_eq!(name, "dt"),
        other => panic!("expected dt named, got {other:?}"),
    }
}

#[test]
fn damaged_or_foreign_files_are_parse_errors_naming_the_file() {
    let (system, _, _) = problem();
    let dt = critical_time_step(&system).unwrap().dt * 0.5;
    let (mut explicit, _) = integrator(Method::Explicit, false, dt);
    let mut state = State::at_rest(system.free_count());
    explicit.step(&mut state).unwrap();
    let bytes = Checkpoint::take(explicit.as_ref(), &state, vec![], vec![])
        .unwrap()
        .to_bytes();
    let path = Path::new("run/checkpoint.bin");
    let mut flipped = bytes.clone();
    flipped[40] ^= 1;
    let cases: [(&str, Vec<u8>, &str); 4] = [
        ("truncated", bytes[..bytes.len() / 2].to_vec(), "checksum"),
        ("a flipped bit", flipped, "checksum"),
        (
            "another file",
            b"# a scene, not a checkpoint\n".to_vec(),
            "TETFEMCP",
        ),
        ("empty", Vec::new(), "truncated"),
    ];
    for (what, bytes, expected) in cases {
        match Checkpoint::from_bytes(&bytes, path) {
            Err(e @ Error::Parse { .. }) => {
                let text = e.to_string();
                assert!(text.starts_with("run/checkpoint.bin"), "{what}: {text}");
                assert!(text.contains(expected), "{what}: {text}");
            }
            other => panic!("{what}: expected a parse error, got {other:?}"),
        }
    }
    // A missing file is an I/O error naming the path.
    let missing = Path::new("/nonexistent-dir/checkpoint.bin");
    match Checkpoint::read(missing) {
        Err(Error::Io { path, .. }) => assert_eq!(path, missing),
        other => panic!("expected an I/O error, got {other:?}"),
    }
}

/// The default large-deformation paths restart bit-identically too: L-BFGS on the turned rest
/// factor (what `NonlinearSolve::Auto` picks from 1,000 free DOFs without contact) and
/// rest-preconditioned CG, each named on a small beam and, for `Auto`, on a beam above the
/// crossover (1,800 free DOFs). Each step starts from the rest factor and an empty L-BFGS
/// memory, so a resumed run repeats the bits and every Newton count, factorizations aside.
#[test]
fn the_default_large_deformation_paths_restart_with_the_same_bits() {
    use tetfem::analysis::dynamics::NonlinearSolve;
    let lbfgs = NonlinearSolve::RestPreconditionedLbfgs { history: 5 };
    let cg = NonlinearSolve::RestPreconditionedCg {
        max_cg_iterations: 25,
        forcing: 1e-3,
    };
    for (cells, solve, label) in [
        ([8, 2, 2], lbfgs, "L-BFGS"),
        ([8, 2, 2], cg, "rest-preconditioned CG"),
        (
            [24, 4, 4],
            NonlinearSolve::Auto,
            "Auto above 1,000 free DOFs",
        ),
    ] {
        let beam = Cantilever {
            length: 4.0,
            split: BoxSplit::Lecture6,
            ..Cantilever::peer_benchmark(cells)
        };
        let mesh = Arc::new(beam.mesh().unwrap());
        let system = Arc::new(
            LinearSystem::new(
                &mesh,
                &beam.material,
                &beam.constraints(&mesh).unwrap(),
                &beam.loads(&mesh).unwrap(),
                Vector3::new(0.0, 0.0, -9.81),
                MassKind::Lumped,
                Rayleigh::new(0.0, 0.0).unwrap(),
            )
            .unwrap(),
        );
        let dt = 5.0 * critical_time_step(&system).unwrap().dt;
        let make = || {
            let force = force(true, &system, &mesh, &beam.material);
            let options = IntegratorOptions {
                nonlinear_solve: solve,
                ..IntegratorOptions::default()
            };
            Method::BackwardEuler
                .integrator_with_force(Arc::clone(&system), force, dt, options)
                .unwrap()
        };
        let n = system.free_count();
        let mut straight = make();
        let mut whole = State::at_rest(n);
        for _ in 0..30 {
            straight.step(&mut whole).unwrap();
        }
        let mut first = make();
        let mut state = State::at_rest(n);
        for _ in 0..15 {
            first.step(&mut state).unwrap();
        }
        let checkpoint = Checkpoint::take(first.as_ref(), &state, vec![], vec![]).unwrap();
        let read = Checkpoint::from_bytes(&checkpoint.to_bytes(), Path::new("mem")).unwrap();
        let mut second = make();
        let mut resumed = read.restore(second.as_mut()).unwrap();
        for _ in 0..15 {
            second.step(&mut resumed).unwrap();
        }
        let stats = straight.newton_stats().unwrap();
        println!("{label}: {n} free DOFs, {stats:?}");
        assert_eq!(
            bits(&resumed.displacement),
            bits(&whole.displacement),
            "{label}: u"
        );
        assert_eq!(bits(&resumed.velocity), bits(&whole.velocity), "{label}: v");
        common::restart::assert_same_newton(second.newton_stats(), Some(stats), label);
        // The named path ran (its own counters moved) and the beam moved.
        assert!(whole.displacement.iter().any(|u| u.abs() > 1e-6), "{label}");
        if solve == cg {
            assert!(stats.cg_iterations > 0, "{label}: {stats:?}");
        }
    }
}

/// The barrier record carries the stiffness in force through a checkpoint only where an impact
/// fraction raised it above κ: such a record has one more value and reads back to the same
/// bits, and a record at κ keeps the old count (so checkpoints of runs without the option are
/// unchanged) and reads back with κ in force.
#[test]
fn barrier_record_keeps_a_raised_stiffness() {
    use tetfem::analysis::dynamics::BarrierRecord;
    use tetfem::contact::ContactParameters;
    let parameters = ContactParameters {
        activation_distance: 1e-4,
        stiffness: 2e6,
        impact_fraction: Some(0.25),
    };
    let plain = BarrierRecord::start(parameters);
    assert_eq!(plain.to_values().len(), BarrierRecord::VALUES);
    let read = BarrierRecord::from_values(&plain.to_values()).unwrap();
    assert_eq!(read.stiffness_in_force.to_bits(), 2e6f64.to_bits());
    let raised = BarrierRecord {
        stiffness_in_force: 7.25e7,
        ..plain
    };
    let values = raised.to_values();
    assert_eq!(values.len(), BarrierRecord::VALUES + 1);
    let read = BarrierRecord::from_values(&values).unwrap();
    assert_eq!(read.stiffness_in_force.to_bits(), 7.25e7f64.to_bits());
    assert!(BarrierRecord::from_values(&values[..5]).is_none());
}
