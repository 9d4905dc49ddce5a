//! The large-deformation backward-Euler step against the linear one, side by side at ~20k DOFs
//! (50×10×10 cells) and ~133k (100×20×20, with TETFEM_BENCH_LARGE=1): the linear step, the
//! corotational step that refactors every Newton iteration (`NonlinearSolve::Refactor`) and
//! the one whose Newton iterations run CG preconditioned by the rest-state factor turned by
//! the nodes' rotations (what the default, `NonlinearSolve::Auto`, picks at these sizes). A rubber cantilever (0.5 × 0.05 × 0.05 m, E = 1 MPa, ν = 0.4, ρ = 1100 kg/m³)
//! released under gravity; every sample steps once from the same state, 5 steps (50 ms) into
//! the swing, at dt = 10 ms. Threads: RAYON_NUM_THREADS (the Cholesky uses as many, at most
//! two). `cargo bench --bench corotational`; not run in CI (a refactoring step at 133k DOFs
//! takes tens of seconds).

use std::sync::Arc;
use std::time::Duration;

use criterion::{BatchSize, BenchmarkId, Criterion, criterion_group, criterion_main};
use nalgebra::Vector3;
use tetfem::dynamics::{
    BackwardEuler, Integrator, IntegratorOptions, InternalForce, LinearSystem, MassKind,
    NonlinearSolve, Rayleigh, State,
};
use tetfem::model::ModelKind;
use tetfem::{BoxSplit, CholeskyOptions, Loads, Material};
use tetfem_fixtures::cantilever::Cantilever;

const DT: f64 = 1e-2;

fn sizes() -> Vec<[usize; 3]> {
    let mut sizes = vec![[50, 10, 10]];
    if std::env::var_os("TETFEM_BENCH_LARGE").is_some() {
        sizes.push([100, 20, 20]);
    }
    sizes
}

fn corotational_steps(c: &mut Criterion) {
    let threads = rayon::current_num_threads().min(2);
    for cells in sizes() {
        let problem = Cantilever {
            length: 0.5,
            width: 0.05,
            height: 0.05,
            cells,
            split: BoxSplit::Lecture6,
            material: Material::new(1e6, 0.4, 1100.0).unwrap(),
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
        let corotational = InternalForce::of_model(
            Arc::clone(&mesh),
            ModelKind::Corotational.build(&problem.material),
            &system,
        )
        .unwrap();
        let label = format!(
            "{}x{}x{} ({} dofs, {threads} threads)",
            cells[0],
            cells[1],
            cells[2],
            mesh.dof_count()
        );
        let mut group = c.benchmark_group("corotational");
        group
            .sample_size(10)
            .warm_up_time(Duration::from_millis(1))
            .measurement_time(Duration::from_secs(1));
        for (name, force, solve) in [
            ("linear", InternalForce::Linear, NonlinearSolve::Refactor),
            ("refactor", corotational.clone(), NonlinearSolve::Refactor),
            (
                "rest-preconditioned",
                corotational.clone(),
                NonlinearSolve::RestPreconditionedCg {
                    max_cg_iterations: 25,
                    forcing: 1e-3,
                },
            ),
        ] {
            let options = IntegratorOptions {
                cholesky: CholeskyOptions {
                    threads,
                    ..CholeskyOptions::default()
                },
                nonlinear_solve: solve,
                ..IntegratorOptions::default()
            };
            let mut integrator =
                BackwardEuler::with_force(Arc::clone(&system), force, DT, options).unwrap();
            // Into the swing, outside the timing (the factorizations of dt happen here).
            let mut start = State::at_rest(system.free_count());
            for _ in 0..5 {
                integrator.step(&mut start).unwrap();
            }
            group.bench_function(BenchmarkId::new(format!("step-{name}"), &label), |b| {
                b.iter_batched(
                    || start.clone(),
                    |mut state| integrator.step(&mut state).unwrap(),
                    BatchSize::LargeInput,
                )
            });
        }
        group.finish();
    }
}

criterion_group! {
    name = benches;
    // No HTML plots: criterion's plotting needs system fonts, which a headless machine lacks.
    config = Criterion::default().without_plots();
    targets = corotational_steps
}
criterion_main!(benches);
