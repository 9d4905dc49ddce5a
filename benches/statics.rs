//! Static pipeline phases at ~10k and ~100k DOFs (and ~430k with TETFEM_BENCH_LARGE=1):
//! element stiffness, pattern build, refill of K, symbolic analysis (AMD and nested dissection),
//! numeric factorization (tetfem's kernel and faer's), one solve.
//!
//! `cargo bench --bench statics`. Sizes are cantilever box beams of the lecture's split.

use std::hint::black_box;
use std::time::Duration;

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use tetfem::{
    Assembler, CholeskyOptions, DofMap, FillOrdering, NumericFactorization, SparseCholesky,
};
use tetfem_fixtures::cantilever::Cantilever;

fn sizes() -> Vec<[usize; 3]> {
    let mut sizes = vec![[60, 6, 6], [140, 14, 14]];
    if std::env::var_os("TETFEM_BENCH_LARGE").is_some() {
        sizes.push([150, 30, 30]);
    }
    sizes
}

fn element(c: &mut Criterion) {
    let problem = Cantilever::peer_benchmark([1, 1, 1]);
    let mesh = problem.mesh().unwrap();
    c.bench_function("element/stiffness", |b| {
        b.iter(|| {
            black_box(
                mesh.element(black_box(0))
                    .unwrap()
                    .stiffness(&problem.material),
            )
        })
    });
}

fn pipeline(c: &mut Criterion) {
    for cells in sizes() {
        let problem = Cantilever::peer_benchmark(cells);
        let mesh = problem.mesh().unwrap();
        let dofs = mesh.dof_count();
        let label = format!("{}x{}x{} ({dofs} dofs)", cells[0], cells[1], cells[2]);
        let mut group = c.benchmark_group("statics");
        group.sample_size(10).warm_up_time(Duration::from_secs(1));
        if dofs > 200_000 {
            group.measurement_time(Duration::from_secs(30));
        }
        group.bench_function(BenchmarkId::new("pattern", &label), |b| {
            b.iter(|| black_box(Assembler::new(&mesh)))
        });
        let assembler = Assembler::new(&mesh);
        let mut k = assembler.stiffness(&mesh, &problem.material).unwrap();
        group.bench_function(BenchmarkId::new("refill", &label), |b| {
            b.iter(|| {
                assembler
                    .reassemble(
                        &mesh,
                        |t| mesh.element(t).unwrap().stiffness(&problem.material),
                        &mut k,
                    )
                    .unwrap()
            })
        });
        let constraints = problem.constraints(&mesh).unwrap();
        let map = DofMap::new(&constraints);
        let k_ff = map.restriction(k.pattern()).unwrap().restrict(&k).unwrap();
        for ordering in [FillOrdering::Amd, FillOrdering::NestedDissection] {
            let options = CholeskyOptions {
                ordering,
                threads: 1,
            };
            group.bench_function(
                BenchmarkId::new(format!("symbolic-{ordering:?}"), &label),
                |b| b.iter(|| black_box(SparseCholesky::analyze_with(&k_ff, options).unwrap())),
            );
        }
        for threads in [1, 2] {
            let options = CholeskyOptions {
                ordering: FillOrdering::NestedDissection,
                threads,
            };
            let mut cholesky = SparseCholesky::analyze_with(&k_ff, options).unwrap();
            // tetfem's numeric kernel (the default) beside faer's, on the same analysis.
            for (name, kernel) in [
                ("numeric-nd", NumericFactorization::Supernodal),
                ("numeric-nd-faer", NumericFactorization::Faer),
            ] {
                group.bench_function(
                    BenchmarkId::new(format!("{name}-{threads}thr"), &label),
                    |b| b.iter(|| cholesky.factorize_with(&k_ff, kernel).unwrap()),
                );
            }
            cholesky.factorize(&k_ff).unwrap();
            let rhs = map
                .restrict(problem.loads(&mesh).unwrap().as_slice())
                .unwrap();
            let mut x = rhs.clone();
            group.bench_function(
                BenchmarkId::new(format!("solve-nd-{threads}thr"), &label),
                |b| {
                    b.iter(|| {
                        x.copy_from_slice(&rhs);
                        cholesky.solve_in_place(&mut x).unwrap()
                    })
                },
            );
        }
        group.finish();
    }
}

criterion_group! {
    name = benches;
    // No HTML plots: criterion's plotting needs system fonts, which a headless machine lacks.
    config = Criterion::default().without_plots();
    targets = element, pipeline
}
criterion_main!(benches);
