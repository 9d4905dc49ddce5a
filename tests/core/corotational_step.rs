//! The large-deformation backward-Euler step whose Newton iterations solve by CG preconditioned
//! with the rest-state factor turned by the nodes' rotations
//! ([`NonlinearSolve::RestPreconditionedCg`], what the default picks from 1,000 DOFs) against
//! the step that refactors every Newton iteration ([`NonlinearSolve::Refactor`]): the same
//! trajectory of a large swing, a fallback when CG runs out of its budget, a named error when
//! Newton itself cannot converge, and named errors for bad options; and the same for the
//! tangent-free L-BFGS step ([`NonlinearSolve::RestPreconditionedLbfgs`]), whose trajectory
//! converges to Newton's as its tolerance shrinks.

use std::sync::Arc;

use nalgebra::Vector3;
use tetfem::BoxSplit;
use tetfem::analysis::dynamics::{
    AUTO_LBFGS_TOLERANCE, BackwardEuler, Integrator, IntegratorOptions, Method, NewtonStats,
    NonlinearSolve, State, StepNewtonOptions,
};
use tetfem_fixtures::swing::Swing;

/// The rubber swing of `tetfem_fixtures::swing` (E = 0.5 MPa: a static tip slope of 2.2 rad
/// by linear beam theory, far outside the linear range) on 10×2×2 cells of 5 tets.
fn swing() -> Swing {
    Swing::new([10, 2, 2], BoxSplit::Five, 5e5).unwrap()
}

/// Backward Euler on the swing's corotational force, solved as `solve` says to the default
/// Newton tolerance.
fn integrator(beam: &Swing, dt: f64, solve: NonlinearSolve) -> BackwardEuler {
    let threads = tetfem::CholeskyOptions::default().threads;
    beam.integrator(beam.corotational().unwrap(), dt, solve, 1e-8, threads)
        .unwrap()
}

/// Backward Euler on the swing's corotational force with `solve` and Newton options `newton`.
fn integrator_with(
    beam: &Swing,
    dt: f64,
    solve: NonlinearSolve,
    newton: StepNewtonOptions,
) -> Box<dyn Integrator> {
    let options = IntegratorOptions {
        nonlinear_solve: solve,
        newton,
        ..IntegratorOptions::default()
    };
    Method::BackwardEuler
        .integrator_with_force(
            Arc::clone(&beam.system),
            beam.corotational().unwrap(),
            dt,
            options,
        )
        .unwrap()
}

/// The displacements after each of `steps` steps from rest.
fn trajectory(integrator: &mut dyn Integrator, free: usize, steps: usize) -> Vec<Vec<f64>> {
    let mut state = State::at_rest(free);
    (0..steps)
        .map(|_| {
            integrator.step(&mut state).unwrap();
            state.displacement.clone()
        })
        .collect()
}

fn norm(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}

fn distance(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y) * (x - y))
        .sum::<f64>()
        .sqrt()
}

/// Runs `steps` steps of `solve` and of [`NonlinearSolve::Refactor`] side by side from rest;
/// returns the largest relative distance of the displacements and of the velocities over all
/// steps, the largest tip rotation, and both integrators' Newton counts.
fn side_by_side(
    beam: &Swing,
    dt: f64,
    steps: usize,
    solve: NonlinearSolve,
) -> (f64, f64, f64, NewtonStats, NewtonStats) {
    let mut reference = integrator(beam, dt, NonlinearSolve::Refactor);
    let mut tested = integrator(beam, dt, solve);
    let n = beam.system.free_count();
    let (mut a, mut b) = (State::at_rest(n), State::at_rest(n));
    let (mut du, mut dv, mut rotation): (f64, f64, f64) = (0.0, 0.0, 0.0);
    for _ in 0..steps {
        reference.step(&mut a).unwrap();
        tested.step(&mut b).unwrap();
        du = du.max(distance(&a.displacement, &b.displacement) / norm(&a.displacement));
        dv = dv.max(distance(&a.velocity, &b.velocity) / norm(&a.velocity));
        rotation = rotation.max(beam.tip_rotation(&a).unwrap());
    }
    (
        du,
        dv,
        rotation,
        tested.newton_stats().unwrap(),
        reference.newton_stats().unwrap(),
    )
}

/// How far (relative to the largest displacement or velocity) a trajectory may stand from the
/// refactoring one when both finish every step at the same Newton test (residual ≤ 1e-8 of
/// its reference). Measured on these swings: at most 7.7e-10 in u and 2.8e-8 in v (L-BFGS; the
/// velocity (u⁺ − u)/dt carries u's absolute difference over a smaller increment). 1e-6 is
/// 100× the step tolerance: room for rounding to change a step's iteration count on another
/// machine, and still below the distance of a trajectory whose steps stop at 1e-4 (2.2e-6,
/// `the_lbfgs_trajectory_converges_to_newtons_as_the_tolerance_shrinks`), so a path that
/// stopped its steps early would fail.
const TRAJECTORY: f64 = 1e-6;

/// The default (rest-preconditioned CG) follows the refactoring integrator's trajectory of a
/// large swing (tip rotation > 30°) at dt = 20 ms, ~100× the explicit critical step, within
/// 1e-6 relative at every step, in displacement and velocity ([`TRAJECTORY`]). Why it is reachable: both solve
/// every step's implicit equation until its residual is ≤ 1e-8 of its reference (the same Newton
/// test), so each step's u⁺ differs by ~1e-8 relative times the conditioning of the Newton
/// matrix, and backward Euler's dissipation does not amplify earlier differences; the velocity
/// (u⁺ − u)/dt carries the same absolute difference over a smaller increment.
#[test]
fn rest_preconditioned_cg_follows_the_refactoring_trajectory_of_a_large_swing() {
    let beam = swing();
    // Named: on a mesh this small `NonlinearSolve::Auto` (the default) refactors.
    let rest_preconditioned = NonlinearSolve::RestPreconditionedCg {
        max_cg_iterations: 25,
        forcing: 1e-3,
    };
    let (du, dv, rotation, cg, refactor) = side_by_side(&beam, 0.02, 25, rest_preconditioned);
    println!(
        "large swing, tip rotation up to {rotation:.1}°: largest relative difference {du:.2e} (u), {dv:.2e} (v); \
         CG path {} Newton its, {} CG its, {} factorizations, {} fallbacks; refactoring {} Newton its, {} factorizations",
        cg.total_iterations,
        cg.cg_iterations,
        cg.factorizations,
        cg.fallbacks,
        refactor.total_iterations,
        refactor.factorizations
    );
    assert!(rotation > 30.0, "a large swing: {rotation}°");
    assert!(du < TRAJECTORY && dv < TRAJECTORY, "{du:e}, {dv:e}");
    // The factor turned by the nodes' rotations keeps CG within its budget through the whole
    // swing (measured: 430 CG iterations, no fallback; unturned, the same swing fell back 3
    // times and needed 1132 CG iterations, from its first iterates of that time): one
    // factorization, the rest factor's.
    assert_eq!(cg.fallbacks, 0, "{cg:?}");
    // What makes the new path cheap: fewer factorizations than Newton iterations (the
    // refactoring path makes one per iteration, which this checks too).
    assert_eq!(refactor.factorizations, refactor.total_iterations);
    assert!(
        cg.factorizations < refactor.factorizations,
        "{} vs {}",
        cg.factorizations,
        refactor.factorizations
    );
}

/// One CG iteration cannot reach a forcing term of 1e-12: every Newton iteration falls back to
/// factoring its own matrix (counted), and the trajectory is still the refactoring one to the
/// same [`TRAJECTORY`] (the fallback *is* the refactoring solve, so the two agree to round-off per step).
#[test]
fn a_cg_budget_too_small_falls_back_to_factoring_and_stays_on_the_trajectory() {
    let beam = swing();
    let starved = NonlinearSolve::RestPreconditionedCg {
        max_cg_iterations: 1,
        forcing: 1e-12,
    };
    let (du, dv, _, cg, _) = side_by_side(&beam, 0.02, 10, starved);
    println!(
        "starved CG: {} Newton its, {} fallbacks, {} factorizations; difference {du:.2e} (u), {dv:.2e} (v)",
        cg.total_iterations, cg.fallbacks, cg.factorizations
    );
    assert!(cg.fallbacks > 0);
    assert!(du < TRAJECTORY && dv < TRAJECTORY, "{du:e}, {dv:e}");
}

/// L-BFGS with the turned rest factor as its initial inverse Hessian
/// ([`NonlinearSolve::RestPreconditionedLbfgs`], what the default picks from 1,000 DOFs without
/// contact) follows the refactoring trajectory of the same swing within [`TRAJECTORY`] relative, for the
/// same reason as CG: both stop at the same residual test (1e-8 of its reference). It never
/// needs its fallback here, and factors once (the rest matrix). Measured: 7.7e-10 (u) and
/// 2.8e-8 (v) relative, 321 L-BFGS iterations against 74 Newton iterations.
#[test]
fn rest_lbfgs_follows_the_refactoring_trajectory_of_a_large_swing() {
    let beam = swing();
    let lbfgs = NonlinearSolve::RestPreconditionedLbfgs { history: 5 };
    let (du, dv, rotation, quasi, refactor) = side_by_side(&beam, 0.02, 25, lbfgs);
    println!(
        "large swing, tip rotation up to {rotation:.1}°: largest relative difference {du:.2e} (u), {dv:.2e} (v); \
         L-BFGS {} its, {} fallbacks; refactoring {} Newton its",
        quasi.total_iterations, quasi.fallbacks, refactor.total_iterations
    );
    assert!(rotation > 30.0, "a large swing: {rotation}°");
    assert!(du < TRAJECTORY && dv < TRAJECTORY, "{du:e}, {dv:e}");
    assert_eq!(quasi.fallbacks, 0, "{quasi:?}");
    assert_eq!(quasi.factorizations, 1, "{quasi:?}");
}

/// The step tolerance is the accuracy the user buys: at tolerances 1e-2, 1e-3 and 1e-4 the
/// L-BFGS trajectory's largest distance from the refactoring one (converged to 1e-8) shrinks
/// with every decade and by at least 10× over the two (measured here: 2.1e-4, 3.1e-5, 2.2e-6
/// relative, 6.6× then 14×). The distance moves in whole iterations, a step stopping once its
/// residual passes the test, so one decade can gain little and the next much more (2.4× then
/// 30× with the first iterate u + dt·v + dt²·a): 10× over two decades is the rate asserted,
/// an order of magnitude per two of tolerance.
#[test]
fn the_lbfgs_trajectory_converges_to_newtons_as_the_tolerance_shrinks() {
    let beam = swing();
    let n = beam.system.free_count();
    let lbfgs = NonlinearSolve::RestPreconditionedLbfgs { history: 5 };
    let run = |tolerance: f64| {
        let newton = StepNewtonOptions {
            tolerance,
            ..StepNewtonOptions::default()
        };
        trajectory(&mut *integrator_with(&beam, 0.02, lbfgs, newton), n, 25)
    };
    let reference = trajectory(
        &mut integrator(&beam, 0.02, NonlinearSolve::Refactor),
        n,
        25,
    );
    let scale = reference.iter().map(|u| norm(u)).fold(0.0, f64::max);
    let deviation = |trajectory: &[Vec<f64>]| {
        (trajectory.iter().zip(&reference))
            .map(|(u, r)| distance(u, r))
            .fold(0.0, f64::max)
            / scale
    };
    let deviations: Vec<f64> = [1e-2, 1e-3, 1e-4]
        .into_iter()
        .map(|t| deviation(&run(t)))
        .collect();
    println!(
        "L-BFGS distance from Newton's trajectory at tolerances 1e-2, 1e-3, 1e-4: {deviations:?}"
    );
    for pair in deviations.windows(2) {
        assert!(pair[1] < pair[0], "{deviations:?}");
    }
    assert!(deviations[2] < deviations[0] / 10.0, "{deviations:?}");
}

/// The default settings above 1,000 free DOFs ([`NonlinearSolve::Auto`]: L-BFGS stopping at
/// the looser of the asked tolerance and [`AUTO_LBFGS_TOLERANCE`], or earlier by the
/// correction test of `AUTO_LBFGS_CORRECTION`) keep the trajectory of a large swing (tip
/// rotation > 30°, 1,800 DOFs, dt = 20 ms, 25 steps) within 1e-4 of the refactoring one in
/// displacement, relative to the largest displacement: the target for an animation
/// (measured 5.22e-5 in 153 iterations, a margin of 1.9×; with the residual test alone 1.45e-5
/// in 195; the correction test at τ = 1e-3 left the target, 7.5e-4). They stop early (fewer L-BFGS iterations than the same L-BFGS asked to
/// 1e-8, which is what the looser stop is for) and never fall back.
#[test]
fn the_default_above_a_thousand_dofs_stays_within_1e_4_of_the_refactoring_trajectory() {
    let beam = Swing::new([24, 4, 4], BoxSplit::Five, 5e5).unwrap();
    assert!(beam.system.free_count() >= tetfem::analysis::dynamics::AUTO_REFACTOR_BELOW);
    let n = beam.system.free_count();
    let reference = trajectory(
        &mut integrator(&beam, 0.02, NonlinearSolve::Refactor),
        n,
        25,
    );
    let mut auto = integrator(&beam, 0.02, NonlinearSolve::Auto);
    let default = trajectory(&mut auto, n, 25);
    let lbfgs = NonlinearSolve::RestPreconditionedLbfgs {
        history: tetfem::analysis::dynamics::AUTO_LBFGS_HISTORY,
    };
    let mut tight = integrator(&beam, 0.02, lbfgs);
    trajectory(&mut tight, n, 25);
    let scale = reference.iter().map(|u| norm(u)).fold(0.0, f64::max);
    let deviation = (default.iter().zip(&reference))
        .map(|(u, r)| distance(u, r))
        .fold(0.0, f64::max)
        / scale;
    let mut state = State::at_rest(n);
    let mut rotation: f64 = 0.0;
    let mut refactor = integrator(&beam, 0.02, NonlinearSolve::Refactor);
    for _ in 0..25 {
        refactor.step(&mut state).unwrap();
        rotation = rotation.max(beam.tip_rotation(&state).unwrap());
    }
    let (fast, slow) = (auto.newton_stats().unwrap(), tight.newton_stats().unwrap());
    println!(
        "{n} DOFs, tip rotation up to {rotation:.1}°: default (stopping at {AUTO_LBFGS_TOLERANCE:e}) {} its, distance {deviation:.2e}; \
         L-BFGS to 1e-8 {} its",
        fast.total_iterations, slow.total_iterations
    );
    assert!(rotation > 30.0, "a large swing: {rotation}°");
    // The trajectory target for the default settings.
    assert!(deviation < 1e-4, "{deviation:e}");
    assert!(
        fast.total_iterations < slow.total_iterations,
        "{fast:?} {slow:?}"
    );
    assert_eq!(fast.fallbacks, 0, "{fast:?}");
}

/// An L-BFGS step that runs out of its iterations goes on with preconditioned CG from where it
/// stands (a fresh budget, counted as a fallback) instead of failing: with 5 iterations allowed
/// L-BFGS cannot reach 1e-8 (it takes up to 10 here), so every step falls back, and the
/// trajectory is still the refactoring one within [`TRAJECTORY`] (Newton finishes each step to the same
/// test).
#[test]
fn an_lbfgs_step_out_of_iterations_goes_on_with_cg() {
    let beam = swing();
    let newton = StepNewtonOptions {
        max_iterations: 5,
        ..StepNewtonOptions::default()
    };
    let lbfgs = NonlinearSolve::RestPreconditionedLbfgs { history: 5 };
    let mut tested = integrator_with(&beam, 0.02, lbfgs, newton);
    let mut reference = integrator(&beam, 0.02, NonlinearSolve::Refactor);
    let n = beam.system.free_count();
    let (mut a, mut b) = (State::at_rest(n), State::at_rest(n));
    let mut du: f64 = 0.0;
    for _ in 0..10 {
        reference.step(&mut a).unwrap();
        tested.step(&mut b).unwrap();
        du = du.max(distance(&a.displacement, &b.displacement) / norm(&a.displacement));
    }
    let stats = tested.newton_stats().unwrap();
    println!("L-BFGS with 5 iterations: {stats:?}, difference {du:.2e}");
    assert!(stats.fallbacks > 0, "{stats:?}");
    assert!(stats.cg_iterations > 0, "{stats:?}");
    assert!(du < TRAJECTORY, "{du:e}");
}

/// A step Newton cannot finish in its budget stops with `Diverged` naming the step, on the new
/// path as on the old: never a silently unconverged step.
#[test]
fn an_unconverged_step_is_diverged_not_a_wrong_state() {
    let beam = swing();
    // L-BFGS's budget is spent twice: once by itself, once by its CG fallback.
    for (solve, iterations) in [
        (NonlinearSolve::Auto, "in 1 iterations"),
        (
            NonlinearSolve::RestPreconditionedLbfgs { history: 5 },
            "in 2 iterations",
        ),
    ] {
        let newton = StepNewtonOptions {
            tolerance: 1e-12,
            max_iterations: 1,
            relax_contact_nodes: true,
        };
        let mut integrator = integrator_with(&beam, 0.05, solve, newton);
        let mut state = State::at_rest(beam.system.free_count());
        match integrator.step(&mut state) {
            Err(tetfem::Error::Diverged { step, reason, .. }) => {
                assert_eq!(step, 0);
                assert!(reason.contains("Newton did not converge"), "{reason}");
                assert!(reason.contains(iterations), "{reason}");
            }
            other => panic!("expected Diverged, got {other:?}"),
        }
    }
}

/// Bad options are refused when the integrator is built, naming the option.
#[test]
fn bad_nonlinear_solve_options_are_named() {
    let beam = swing();
    for (solve, key) in [
        (
            NonlinearSolve::RestPreconditionedCg {
                max_cg_iterations: 0,
                forcing: 1e-6,
            },
            "nonlinear_solve.max_cg_iterations",
        ),
        (
            NonlinearSolve::RestPreconditionedCg {
                max_cg_iterations: 10,
                forcing: f64::NAN,
            },
            "nonlinear_solve.forcing",
        ),
        (
            NonlinearSolve::RestPreconditionedCg {
                max_cg_iterations: 10,
                forcing: 1.0,
            },
            "nonlinear_solve.forcing",
        ),
        (
            NonlinearSolve::RestPreconditionedLbfgs { history: 101 },
            "nonlinear_solve.history",
        ),
    ] {
        let options = IntegratorOptions {
            nonlinear_solve: solve,
            ..IntegratorOptions::default()
        };
        match Method::BackwardEuler.integrator_with_force(
            Arc::clone(&beam.system),
            beam.corotational().unwrap(),
            0.02,
            options,
        ) {
            Err(tetfem::Error::InvalidParameter { name, .. }) => assert_eq!(name, key),
            other => panic!(
                "expected InvalidParameter on {key}, got {:?}",
                other.map(|i| i.name())
            ),
        }
    }
    assert!("direct".parse::<NonlinearSolve>().is_err());
    assert_eq!(
        "refactor".parse::<NonlinearSolve>().unwrap(),
        NonlinearSolve::Refactor
    );
    assert_eq!(
        "rest_lbfgs".parse::<NonlinearSolve>().unwrap(),
        NonlinearSolve::RestPreconditionedLbfgs {
            history: tetfem::analysis::dynamics::AUTO_LBFGS_HISTORY
        }
    );
}

/// What turns the rest factor: for a rigid rotation x = R·X + c every tet's F is R, so each
/// node's volume-weighted sum Σ Vₑ·Fₑ is (Σ Vₑ)·R and its polar rotation is R itself, to
/// round-off (1e-13: a few ulps of F's entries through the sum and the polar iteration).
#[test]
fn nodal_rotations_of_a_rigid_rotation_are_that_rotation() {
    let beam = swing();
    let turn = nalgebra::Rotation3::from_axis_angle(
        &nalgebra::Unit::new_normalize(Vector3::new(0.3, -1.0, 0.5)),
        1.2,
    );
    let shift = Vector3::new(0.1, -0.2, 0.3);
    let nodes = beam.mesh.nodes();
    let u: Vec<f64> = nodes
        .iter()
        .flat_map(|x| {
            let moved = turn * x + shift - x;
            [moved.x, moved.y, moved.z]
        })
        .collect();
    let mut sums = vec![nalgebra::Matrix3::zeros(); nodes.len()];
    tetfem::model::assemble::nodal_deformation_gradients(beam.mesh.as_ref(), &u, &mut sums)
        .unwrap();
    for (node, sum) in sums.iter().enumerate() {
        let r = tetfem::model::rotation(sum);
        assert!(
            (r - turn.matrix()).amax() < 1e-13,
            "node {node}: {r} against {}",
            turn.matrix()
        );
    }
}

/// On a factor large enough to be supernodal, L-BFGS's H₀ solves read the rest factor rounded
/// to f32 (`LinearSolver::make_single_precision_copy`): the trajectory is still the refactoring
/// one to the Newton tolerance (each step stops at the same test on the exact residual; only
/// the iterates on the way differ). Measured 3.2e-10 (displacement) and 7.6e-10 (velocity); 1e-6
/// as the CLI's swing test allows. It takes 91 iterations and no fallback to Newton-CG (184
/// and 3 fallbacks, steps past 25 iterations, from the first iterate u + dt·v + dt²·a taken by
/// its residual only; 186 and 3 then with the f64 factor).
#[test]
fn lbfgs_on_the_single_precision_factor_follows_the_refactoring_trajectory() {
    let beam = Swing::new([24, 4, 4], BoxSplit::Five, 5e5).unwrap();
    // The path under test needs a supernodal factor (a simplicial one keeps no f32 copy).
    let mut cholesky = tetfem::SparseCholesky::analyze(beam.system.stiffness()).unwrap();
    cholesky.factorize(beam.system.stiffness()).unwrap();
    assert!(cholesky.supernodal_split().is_some());
    assert!(cholesky.make_single_precision_copy().unwrap());
    let (du, dv, rotation, stats, reference) = side_by_side(
        &beam,
        0.02,
        10,
        NonlinearSolve::RestPreconditionedLbfgs { history: 5 },
    );
    println!(
        "{} DOFs, tip rotation {rotation:.1}°: L-BFGS {stats:?} against {reference:?}; difference u {du:.2e}, v {dv:.2e}",
        beam.system.free_count()
    );
    assert!(du < 1e-6 && dv < 1e-6, "{du:e} {dv:e}");
    assert_eq!(stats.factorizations, 1);
}

/// The force passes of a step's iterations read each tet's rest element kept from the start
/// (`assemble::corner_elements`) instead of rebuilding it: the force, the energy (with the
/// force, and alone: four tets at a time in the models' lanes), the tangent and the nodal
/// deformation gradients are the same bits as the rebuilt ones (the same inverse and
/// determinant of the same Dm, the lanes the scalar path's operations), for both
/// large-deformation models at a deformed state; and a kept list of the wrong length is a
/// named error, not a panic.
#[test]
fn kept_rest_elements_give_the_rebuilt_forces_to_the_bit() {
    use tetfem::model::assemble;
    let beam = swing();
    let mesh = beam.mesh.as_ref();
    // A bend and a twist: every tet stretched and turned differently.
    let u: Vec<f64> = (mesh.nodes().iter())
        .flat_map(|x| {
            [
                0.1 * x.z * x.x,
                -0.3 * x.x * x.x + 0.05 * x.y,
                0.2 * x.x * x.y,
            ]
        })
        .collect();
    let kept = assemble::corner_elements(mesh);
    for kind in [
        tetfem::model::ModelKind::Corotational,
        tetfem::model::ModelKind::NeoHookean,
    ] {
        let model = kind.build(&beam.problem.material);
        let (rebuilt, energy) =
            assemble::internal_force_and_energy(mesh, model.as_ref(), &u).unwrap();
        let mut force = vec![f64::NAN; u.len()];
        let kept_energy = assemble::internal_force_and_energy_kept_into(
            mesh,
            &kept,
            model.as_ref(),
            &u,
            &mut force,
        )
        .unwrap();
        assert_eq!(force, rebuilt, "{}", kind.name());
        assert_eq!(kept_energy.to_bits(), energy.to_bits(), "{}", kind.name());
        assert!(energy > 0.0);
        let alone = assemble::energy(mesh, model.as_ref(), &u).unwrap();
        let alone_kept = assemble::energy_kept(mesh, &kept, model.as_ref(), &u).unwrap();
        assert_eq!(alone_kept.to_bits(), alone.to_bits(), "{}", kind.name());
        let assembler = tetfem::fe::assembly::Assembler::new(mesh);
        let mut tangent = tetfem::CscMatrix::zeros(Arc::clone(assembler.pattern())).unwrap();
        let mut tangent_kept = tangent.clone();
        for project in [false, true] {
            assemble::refill_tangent(mesh, &assembler, model.as_ref(), &u, project, &mut tangent)
                .unwrap();
            let parts = (u.as_slice(), project);
            assemble::refill_tangent_kept(
                mesh,
                &kept,
                &assembler,
                model.as_ref(),
                parts,
                &mut tangent_kept,
            )
            .unwrap();
            assert_eq!(tangent_kept.values(), tangent.values(), "{}", kind.name());
        }
        let short_energy = assemble::energy_kept(mesh, &kept[1..], model.as_ref(), &u);
        assert!(short_energy.is_err(), "{short_energy:?}");
        let short = assemble::internal_force_and_energy_kept_into(
            mesh,
            &kept[1..],
            model.as_ref(),
            &u,
            &mut force,
        );
        assert!(
            matches!(short, Err(tetfem::Error::DimensionMismatch { ref what, .. }) if what == "kept rest elements"),
            "{short:?}"
        );
    }
    let mut plain = vec![nalgebra::Matrix3::zeros(); mesh.node_count()];
    let mut from_kept = plain.clone();
    assemble::nodal_deformation_gradients(mesh, &u, &mut plain).unwrap();
    assemble::nodal_deformation_gradients_kept(mesh, &kept, &u, &mut from_kept).unwrap();
    assert_eq!(plain, from_kept);
}

/// The default's steps evaluate the force once an iteration and not once more: each iteration's
/// residual is evaluated where its direction starts (the first at the step's guess), and the
/// step's last correction, which the correction test shows converged before it is taken, is
/// taken without a pass of its own (the iterate before it is that close). Before, every step
/// made one pass more than its iterations (the residual where its last step landed, and its
/// guess compared with its start). Counted on the large swing of
/// [`the_default_above_a_thousand_dofs_stays_within_1e_4_of_the_refactoring_trajectory`]
/// (25 steps): force-and-energy passes = iterations + the first step's start (it has no guess)
/// + the line searches' extra trials, which a step whose correction test does not fire adds too.
#[test]
fn the_default_step_makes_one_force_pass_an_iteration() {
    use tetfem::analysis::dynamics::InternalForce;
    use tetfem::model::ModelKind;
    use tetfem_fixtures::counting::{Call, Counting};
    let beam = Swing::new([24, 4, 4], BoxSplit::Five, 5e5).unwrap();
    let (counted, calls) = Counting::wrap(ModelKind::Corotational.build(&beam.problem.material));
    let force = InternalForce::of_model(Arc::clone(&beam.mesh), counted, &beam.system).unwrap();
    let threads = tetfem::CholeskyOptions::default().threads;
    let mut auto = beam
        .integrator(force, 0.02, NonlinearSolve::Auto, 1e-8, threads)
        .unwrap();
    let n = beam.system.free_count();
    let steps = 25;
    let counted_run = trajectory(&mut auto, n, steps);
    let plain = trajectory(&mut integrator(&beam, 0.02, NonlinearSolve::Auto), n, steps);
    let stats = auto.newton_stats().unwrap();
    let tets = beam.mesh.tet_count();
    let passes = calls.passes(Call::ForceAndEnergy, tets);
    println!(
        "{} iterations, {passes} force-and-energy passes, {} energy passes in {steps} steps",
        stats.total_iterations,
        calls.passes(Call::Energy, tets)
    );
    // The counting model changes no bit.
    assert_eq!(counted_run, plain);
    assert_eq!(calls.of(Call::ForceAndEnergy) % tets, 0, "whole passes");
    assert!(
        passes < (stats.total_iterations + steps) as f64,
        "{passes} passes, {stats:?}"
    );
}
