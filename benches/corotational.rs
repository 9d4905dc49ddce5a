//! The large-deformation backward-Euler step against the linear one, side by side at ~20k DOFs
//! (50×10×10 cells) and ~133k (100×20×20, with TETFEM_BENCH_LARGE=1): the linear step, the
//! corotational step that refactors every Newton iteration (`NonlinearSolve::Refactor`), the
//! one whose Newton iterations run CG preconditioned by the rest-state factor turned by the
//! nodes' rotations, and the tangent-free L-BFGS step on that factor (what the default,
//! `NonlinearSolve::Auto`, picks at these sizes), at the default tolerance 1e-8 and at 1e-2.
//! A rubber cantilever (0.5 × 0.05 × 0.05 m, E = 1 MPa, ν = 0.4, ρ = 1100 kg/m³)
//! released under gravity; every sample steps once from the same state, 5 steps (50 ms) into
//! the swing, at dt = 10 ms. Threads: RAYON_NUM_THREADS (the Cholesky uses as many, at most
//! two). `cargo bench --bench corotational`; not run in CI (a refactoring step at 133k DOFs
//! takes tens of seconds).

use std::time::Duration;

use criterion::{BatchSize, BenchmarkId, Criterion, criterion_group, criterion_main};
use tetfem::BoxSplit;
use tetfem::analysis::dynamics::{Integrator, InternalForce, NonlinearSolve, State};
use tetfem_fixtures::swing::Swing;

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
        let swing = Swing::new(cells, BoxSplit::Lecture6, 1e6).unwrap();
        let (mesh, system) = (&swing.mesh, &swing.system);
        let corotational = swing.corotational().unwrap();
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
        let lbfgs = NonlinearSolve::RestPreconditionedLbfgs { history: 5 };
        for (name, force, solve, tolerance) in [
            (
                "linear",
                InternalForce::Linear,
                NonlinearSolve::Refactor,
                1e-8,
            ),
            (
                "refactor",
                corotational.clone(),
                NonlinearSolve::Refactor,
                1e-8,
            ),
            (
                "rest-preconditioned",
                corotational.clone(),
                NonlinearSolve::RestPreconditionedCg {
                    max_cg_iterations: 25,
                    forcing: 1e-3,
                },
                1e-8,
            ),
            ("rest-lbfgs", corotational.clone(), lbfgs, 1e-8),
            (
                "rest-lbfgs-tolerance-1e-2",
                corotational.clone(),
                lbfgs,
                1e-2,
            ),
        ] {
            let mut integrator = swing
                .integrator(force, DT, solve, tolerance, threads)
                .unwrap();
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
