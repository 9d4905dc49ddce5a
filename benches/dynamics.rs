//! Time-stepping costs at ~10k and ~130k DOFs (and ~290k with TETFEM_BENCH_LARGE=1): one
//! backward-Euler step after factorization, one Newmark step, one explicit step, the product
//! K_ff·x in the scalar CSC, the full 3×3 node-block and the upper node-block formats (the last
//! is what the integrators use), and one numeric factorization of
//! M + dt²K. `cargo bench --bench dynamics`.

use std::sync::Arc;
use std::time::Duration;

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use nalgebra::Vector3;
use tetfem::analysis::dynamics::{
    LinearSystem, MassKind, Method, Rayleigh, State, critical_time_step,
};
use tetfem::linalg::block_sparse::BlockMatrix3;
use tetfem::{CscMatrix, SparseCholesky};
use tetfem_fixtures::cantilever::Cantilever;

fn sizes() -> Vec<[usize; 3]> {
    let mut sizes = vec![[40, 8, 8], [100, 20, 20]];
    if std::env::var_os("TETFEM_BENCH_LARGE").is_some() {
        sizes.push([130, 26, 26]);
    }
    sizes
}

fn stepping(c: &mut Criterion) {
    for cells in sizes() {
        let problem = Cantilever {
            gravity: 9.81,
            ..Cantilever::peer_benchmark(cells)
        };
        let mesh = problem.mesh().unwrap();
        let constraints = problem.constraints(&mesh).unwrap();
        let loads = problem.loads(&mesh).unwrap();
        let system = Arc::new(
            LinearSystem::new(
                &mesh,
                &problem.material,
                &constraints,
                &loads,
                Vector3::new(0.0, 0.0, -9.81),
                MassKind::Lumped,
                Rayleigh::default(),
            )
            .unwrap(),
        );
        let dt_crit = critical_time_step(&system).unwrap().dt;
        let label = format!(
            "{}x{}x{} ({} dofs)",
            cells[0],
            cells[1],
            cells[2],
            mesh.dof_count()
        );
        let mut group = c.benchmark_group("dynamics");
        group.sample_size(10).warm_up_time(Duration::from_secs(1));
        for (method, dt) in [
            (Method::BackwardEuler, 100.0 * dt_crit),
            (Method::Newmark, 100.0 * dt_crit),
            (Method::Explicit, 0.9 * dt_crit),
        ] {
            let mut integrator = method.integrator(Arc::clone(&system), dt).unwrap();
            let mut state = State::at_rest(system.free_count());
            integrator.step(&mut state).unwrap(); // factorization happens here, outside the timing
            group.bench_function(
                BenchmarkId::new(format!("step-{}", integrator.name()), &label),
                |b| b.iter(|| integrator.step(&mut state).unwrap()),
            );
        }
        // The product that bounds an explicit step, in three formats of K_ff, side by side.
        let upper = system.stiffness_blocks();
        let mut upper_work = upper.workspace();
        let blocks =
            BlockMatrix3::from_free_matrix(system.stiffness(), system.dofs().free_dofs()).unwrap();
        let x: Vec<f64> = (0..system.free_count()).map(|i| (i % 7) as f64).collect();
        let mut y = vec![0.0; x.len()];
        group.bench_function(BenchmarkId::new("spmv-csc", &label), |b| {
            b.iter(|| system.stiffness().mul_vec(&x, &mut y).unwrap())
        });
        group.bench_function(BenchmarkId::new("spmv-node-blocks", &label), |b| {
            b.iter(|| blocks.mul_vec(&x, &mut y).unwrap())
        });
        group.bench_function(BenchmarkId::new("spmv-upper-node-blocks", &label), |b| {
            b.iter(|| upper.mul_vec_with(&x, &mut y, &mut upper_work).unwrap())
        });
        let mut a = CscMatrix::from_values(
            Arc::clone(system.stiffness().pattern()),
            system
                .stiffness()
                .values()
                .iter()
                .map(|k| k * dt_crit * dt_crit * 1e4)
                .collect(),
        )
        .unwrap();
        if let tetfem::analysis::dynamics::Mass::Lumped(m) = system.mass() {
            a.add_diagonal(1.0, m).unwrap();
        }
        let mut cholesky = SparseCholesky::analyze(&a).unwrap();
        cholesky.factorize(&a).unwrap();
        group.bench_function(BenchmarkId::new("factorize-M+dt2K", &label), |b| {
            b.iter(|| cholesky.factorize(&a).unwrap())
        });
        group.finish();
    }
}

criterion_group! {
    name = benches;
    // No HTML plots: criterion's plotting needs system fonts, which a headless machine lacks.
    config = Criterion::default().without_plots();
    targets = stepping
}
criterion_main!(benches);
