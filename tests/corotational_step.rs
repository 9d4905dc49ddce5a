//! The large-deformation backward-Euler step whose Newton iterations solve by CG preconditioned
//! with the rest-state factor turned by the nodes' rotations
//! ([`NonlinearSolve::RestPreconditionedCg`], what the default picks from 1,000 DOFs) against
//! the step that refactors every Newton iteration ([`NonlinearSolve::Refactor`]): the same
//! trajectory of a large swing, a fallback when CG runs out of its budget, a named error when
//! Newton itself cannot converge, and named errors for bad options.

use std::sync::Arc;

use nalgebra::Vector3;
use tetfem::dynamics::{
    Integrator, IntegratorOptions, InternalForce, LinearSystem, MassKind, Method, NewtonStats,
    NonlinearSolve, Rayleigh, State, StepNewtonOptions,
};
use tetfem::model::ModelKind;
use tetfem::{BoxSplit, Loads, Material, TetMesh};
use tetfem_fixtures::cantilever::Cantilever;

/// A rubber-like cantilever 0.5 × 0.05 × 0.05 m (E = 0.5 MPa, ν = 0.4, ρ = 1100 kg/m³),
/// clamped at x = 0, horizontal and at rest, released under gravity (−z): linear beam theory
/// puts its static tip slope at 2ρgL³/(E·h²) = 2.2 rad, so the swing is far outside the linear
/// range.
struct Swing {
    problem: Cantilever,
    mesh: Arc<TetMesh>,
    system: Arc<LinearSystem>,
    force: InternalForce,
}

fn swing() -> Swing {
    let problem = Cantilever {
        length: 0.5,
        width: 0.05,
        height: 0.05,
        cells: [10, 2, 2],
        split: BoxSplit::Five,
        material: Material::new(5e5, 0.4, 1100.0).unwrap(),
        end_load: 0.0,
        gravity: 0.0,
    };
    let mesh = Arc::new(problem.mesh().unwrap());
    let system = Arc::new(
        LinearSystem::new(
            &mesh,
            &problem.material,
            &problem.constraints(mesh.as_ref()).unwrap(),
            &Loads::new(mesh.as_ref()),
            Vector3::new(0.0, 0.0, -9.81),
            MassKind::Lumped,
            Rayleigh::default(),
        )
        .unwrap(),
    );
    let force = InternalForce::of_model(
        Arc::clone(&mesh),
        ModelKind::Corotational.build(&problem.material),
        &system,
    )
    .unwrap();
    Swing {
        problem,
        mesh,
        system,
        force,
    }
}

impl Swing {
    fn integrator(&self, dt: f64, solve: NonlinearSolve) -> Box<dyn Integrator> {
        let options = IntegratorOptions {
            nonlinear_solve: solve,
            ..IntegratorOptions::default()
        };
        Method::BackwardEuler
            .integrator_with_force(Arc::clone(&self.system), self.force.clone(), dt, options)
            .unwrap()
    }

    /// The angle (degrees) between the tip face's vertical edge at y = 0 and the z axis.
    fn tip_rotation(&self, state: &State) -> f64 {
        let u = self.system.dofs().expand(&state.displacement).unwrap();
        let nodes = self.mesh.nodes();
        let tip = self.problem.tip_nodes(self.mesh.as_ref());
        let at = |z: f64| {
            *tip.iter()
                .find(|&&n| nodes[n].y.abs() < 1e-9 && (nodes[n].z - z).abs() < 1e-9)
                .unwrap()
        };
        let (bottom, top) = (at(0.0), at(self.problem.height));
        let x = |n: usize| nodes[n] + Vector3::new(u[3 * n], u[3 * n + 1], u[3 * n + 2]);
        (x(top) - x(bottom)).angle(&Vector3::z()).to_degrees()
    }
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
    let mut reference = beam.integrator(dt, NonlinearSolve::Refactor);
    let mut tested = beam.integrator(dt, solve);
    let n = beam.system.free_count();
    let (mut a, mut b) = (State::at_rest(n), State::at_rest(n));
    let (mut du, mut dv, mut rotation): (f64, f64, f64) = (0.0, 0.0, 0.0);
    for _ in 0..steps {
        reference.step(&mut a).unwrap();
        tested.step(&mut b).unwrap();
        du = du.max(distance(&a.displacement, &b.displacement) / norm(&a.displacement));
        dv = dv.max(distance(&a.velocity, &b.velocity) / norm(&a.velocity));
        rotation = rotation.max(beam.tip_rotation(&a));
    }
    (
        du,
        dv,
        rotation,
        tested.newton_stats().unwrap(),
        reference.newton_stats().unwrap(),
    )
}

/// The default (rest-preconditioned CG) follows the refactoring integrator's trajectory of a
/// large swing (tip rotation > 30°) at dt = 20 ms, ~100× the explicit critical step, within
/// 1e-4 relative at every step, in displacement and velocity. Why 1e-4 is reachable: both solve
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
    assert!(du < 1e-4 && dv < 1e-4, "{du:e}, {dv:e}");
    // The factor turned by the nodes' rotations keeps CG within its budget through the whole
    // swing (measured: 577 CG iterations, no fallback; unturned, the same swing fell back 3
    // times and needed 1132 CG iterations): one factorization, the rest factor's.
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
/// same 1e-4 (the fallback *is* the refactoring solve, so the two agree to round-off per step).
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
    assert!(du < 1e-4 && dv < 1e-4, "{du:e}, {dv:e}");
}

/// A step Newton cannot finish in its budget stops with `Diverged` naming the step, on the new
/// path as on the old: never a silently unconverged step.
#[test]
fn an_unconverged_step_is_diverged_not_a_wrong_state() {
    let beam = swing();
    let options = IntegratorOptions {
        newton: StepNewtonOptions {
            tolerance: 1e-12,
            max_iterations: 1,
        },
        ..IntegratorOptions::default()
    };
    let mut integrator = Method::BackwardEuler
        .integrator_with_force(Arc::clone(&beam.system), beam.force.clone(), 0.05, options)
        .unwrap();
    let mut state = State::at_rest(beam.system.free_count());
    match integrator.step(&mut state) {
        Err(tetfem::Error::Diverged { step, reason, .. }) => {
            assert_eq!(step, 0);
            assert!(reason.contains("Newton did not converge"), "{reason}");
        }
        other => panic!("expected Diverged, got {other:?}"),
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
    ] {
        let options = IntegratorOptions {
            nonlinear_solve: solve,
            ..IntegratorOptions::default()
        };
        match Method::BackwardEuler.integrator_with_force(
            Arc::clone(&beam.system),
            beam.force.clone(),
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
