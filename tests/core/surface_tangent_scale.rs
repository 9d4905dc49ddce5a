//! The Newton direction with body–body contact above the size where the automatic choice
//! refactored before (`AUTO_REFACTOR_BELOW` free DOFs): two blocks of 5×5×5 cells (1,296 DOFs)
//! thrown at each other. With surface contact `NonlinearSolve::Auto` refactors at every size,
//! factoring the exact Hessian with the contact pairs' couplings on their own pattern
//! (`analysis::nonlinear::lumped::CoupledFactor`), so Newton converges in few iterations; the
//! preconditioned-CG path (the automatic choice at this size before) reaches the same
//! trajectory to the Newton tolerance.

use std::sync::Arc;

use nalgebra::Vector3;
use tetfem::analysis::dynamics::{
    AUTO_REFACTOR_BELOW, BackwardEuler, Integrator, IntegratorOptions, InternalForce, LinearSystem,
    MassKind, NewtonStats, NonlinearForce, NonlinearSolve, Rayleigh, State, StepNewtonOptions,
};
use tetfem::contact::surface::{SurfaceBarrier, SurfaceContact};
use tetfem::mesh::bodies::{Bodies, Placement};
use tetfem::model::ModelKind;
use tetfem::{BoxSplit, Constraints, Loads, Material, TetMesh};

const SIDE: f64 = 0.1;
const D_HAT: f64 = 2e-3;
/// κ (J/m²): as in `self_contact_solve.rs`, enough to turn a 1 m/s impact well before d̂/10.
const KAPPA: f64 = 1e3;

fn two_blocks(cells: usize) -> Bodies {
    let block = TetMesh::box_grid(
        Vector3::zeros(),
        Vector3::repeat(SIDE),
        [cells; 3],
        BoxSplit::Lecture6,
    )
    .unwrap();
    let b = Placement::translated(Vector3::new(SIDE + 0.005, 0.0, 0.0)).unwrap();
    Bodies::new(vec![(block.clone(), Placement::identity()), (block, b)]).unwrap()
}

/// 20 backward-Euler steps of 1 ms of the two blocks meeting at ±1 m/s with `solve`; the
/// displacement after each step and the Newton counts.
fn impact(bodies: &Bodies, solve: NonlinearSolve) -> (Vec<Vec<f64>>, NewtonStats) {
    let mesh = bodies.mesh();
    let material = Material::new(1e6, 0.3, 1000.0).unwrap();
    let system = Arc::new(
        LinearSystem::new_free_body(
            mesh,
            &material,
            &Constraints::new(mesh),
            &Loads::new(mesh),
            Vector3::zeros(),
            MassKind::Lumped,
            Rayleigh::default(),
        )
        .unwrap(),
    );
    let barrier = SurfaceBarrier::new(D_HAT, KAPPA).unwrap();
    let contact = SurfaceContact::new(mesh, &bodies.node_bodies(), barrier).unwrap();
    let force = NonlinearForce::new(
        Arc::new(mesh.clone()),
        ModelKind::NeoHookean.build(&material),
        &system,
    )
    .unwrap()
    .with_surface_contact(contact)
    .unwrap();
    let options = IntegratorOptions {
        newton: StepNewtonOptions {
            tolerance: 1e-10,
            max_iterations: 200,
            relax_contact_nodes: true,
        },
        nonlinear_solve: solve,
        ..IntegratorOptions::default()
    };
    let mut integrator = BackwardEuler::with_force(
        Arc::clone(&system),
        InternalForce::Nonlinear(Arc::new(force)),
        1e-3,
        options,
    )
    .unwrap();
    let mut state = State::at_rest(system.free_count());
    let v = [Vector3::new(1.0, 0.0, 0.0), Vector3::new(-1.0, 0.0, 0.0)];
    state.velocity = bodies.velocity(&v).unwrap();
    let mut trajectory = Vec::new();
    for _ in 0..20 {
        integrator.step(&mut state).unwrap();
        trajectory.push(state.displacement.clone());
    }
    (trajectory, integrator.newton_stats().unwrap())
}

#[test]
fn coupled_newton_converges_in_few_iterations_above_the_old_threshold() {
    let bodies = two_blocks(5);
    let dofs = 3 * bodies.mesh().node_count();
    assert!(dofs > AUTO_REFACTOR_BELOW, "{dofs} DOFs");
    let (coupled, stats) = impact(&bodies, NonlinearSolve::Auto);
    let (cg, cg_stats) = impact(
        &bodies,
        NonlinearSolve::RestPreconditionedCg {
            max_cg_iterations: 25,
            forcing: 1e-3,
        },
    );
    let largest = coupled
        .iter()
        .flatten()
        .fold(0.0_f64, |m, v| m.max(v.abs()));
    let difference = coupled
        .iter()
        .zip(&cg)
        .flat_map(|(a, b)| a.iter().zip(b).map(|(x, y)| (x - y).abs()))
        .fold(0.0_f64, f64::max);
    println!(
        "{dofs} DOFs, 20 steps: coupled factor {} Newton iterations (at most {} per step, {} \
         factorizations); preconditioned CG {} iterations (at most {} per step, {} CG iterations, \
         {} fallbacks); largest trajectory difference {difference:.3e} m of {largest:.3e} m",
        stats.total_iterations,
        stats.max_per_step,
        stats.factorizations,
        cg_stats.total_iterations,
        cg_stats.max_per_step,
        cg_stats.cg_iterations,
        cg_stats.fallbacks,
    );
    // The blocks meet (5 mm closing at 2 m/s in 2.5 ms) and press for the rest of the run:
    // Newton on the exact Hessian converges in a handful of iterations a step (measured 9 at
    // most), the preconditioned CG path on the lumped tangent linearly (measured 154 at most).
    assert!(stats.max_per_step <= 12, "{stats:?}");
    assert!(
        4 * stats.total_iterations < cg_stats.total_iterations,
        "{stats:?} vs {cg_stats:?}"
    );
    // Both stop at ‖r‖ ≤ 1e-10 of the step's force scale; a residual r moves the step by
    // J⁻¹·r, and J's smallest eigenvalue (the mass term M/dt², against the barrier's
    // stiffness in the largest) magnifies that fraction by up to ~1e4 here, compounded over 20
    // steps: 1e-5 of the largest displacement (measured 4.2e-6).
    assert!(difference < 1e-5 * largest, "{difference:e} of {largest:e}");
}
