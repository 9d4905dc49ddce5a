//! The Rust sparse Cholesky backends side by side on the same K_ff: faer's supernodal
//! factorization (tetfem's default), nalgebra-sparse's `CscCholesky` and sprs-ldl's simplicial
//! LDLᵀ, all given the same METIS nested-dissection ordering (nalgebra-sparse applies none of its
//! own, so the matrix is permuted for it beforehand). Each factorization is timed with its
//! symbolic analysis, at ~1.5k and ~10k DOFs, where the simplicial codes still finish in
//! seconds; at 132k DOFs they take 385–526 s (`../shared/notes`).
//!
//! Before timing, each backend's solution is checked against faer's, so that the comparison
//! is between factorizations that give the same answer.
//!
//! `cargo bench --bench backends`.

use std::hint::black_box;
use std::time::Duration;

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use tetfem::linalg::ordering::nested_dissection;
use tetfem::{CscMatrix, SparseCholesky};
use tetfem_fixtures::cantilever::{Cantilever, FreeSystem};

/// P·A·Pᵀ with `perm[new] = old`, as a nalgebra-sparse matrix (both triangles).
fn permuted_nalgebra(a: &CscMatrix, perm: &[usize]) -> nalgebra_sparse::CscMatrix<f64> {
    let n = a.dim();
    let mut inverse = vec![0; n];
    for (new, &old) in perm.iter().enumerate() {
        inverse[old] = new;
    }
    let mut coo = nalgebra_sparse::CooMatrix::new(n, n);
    for col in 0..n {
        for k in a.col_ptr()[col]..a.col_ptr()[col + 1] {
            coo.push(inverse[a.row_idx()[k]], inverse[col], a.values()[k]);
        }
    }
    nalgebra_sparse::CscMatrix::from(&coo)
}

fn as_sprs(a: &CscMatrix) -> sprs::CsMat<f64> {
    sprs::CsMat::new_csc(
        (a.dim(), a.dim()),
        a.col_ptr().to_vec(),
        a.row_idx().to_vec(),
        a.values().to_vec(),
    )
}

fn max_relative_difference(a: &[f64], b: &[f64]) -> f64 {
    let scale = a.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    a.iter()
        .zip(b)
        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()))
        / scale
}

fn backends(c: &mut Criterion) {
    for cells in [[20, 4, 4], [40, 8, 8]] {
        let problem = Cantilever::peer_benchmark(cells);
        let mesh = problem.mesh().unwrap();
        let FreeSystem {
            stiffness: k_ff,
            load: rhs,
            ..
        } = problem.free_system(&mesh).unwrap();
        let perm = nested_dissection(k_ff.pattern()).unwrap();
        let label = format!("{}dofs", k_ff.dim());

        // The reference solution, and each backend's, compared before any timing.
        let mut reference = rhs.clone();
        let mut cholesky = SparseCholesky::analyze(&k_ff).unwrap();
        cholesky.factorize(&k_ff).unwrap();
        cholesky.solve_in_place(&mut reference).unwrap();
        let permuted = permuted_nalgebra(&k_ff, &perm);
        let nalgebra_factor =
            nalgebra_sparse::factorization::CscCholesky::factor(&permuted).unwrap();
        let permuted_rhs =
            nalgebra::DVector::from_iterator(perm.len(), perm.iter().map(|&o| rhs[o]));
        let y = nalgebra_factor.solve(&permuted_rhs);
        let mut nalgebra_solution = vec![0.0; rhs.len()];
        for (new, &old) in perm.iter().enumerate() {
            nalgebra_solution[old] = y[new];
        }
        let sprs_matrix = as_sprs(&k_ff);
        let sprs_factor = sprs_ldl::LdlNumeric::new_perm(
            sprs_matrix.view(),
            sprs::PermOwned::new(perm.clone()),
            sprs::SymmetryCheck::DontCheckSymmetry,
        )
        .unwrap();
        let sprs_solution = sprs_factor.solve(&rhs);
        // Three direct solvers on κ ≈ 1e6–1e7: agreement to ~1e-9 of the largest displacement.
        for (name, solution) in [
            ("nalgebra-sparse", &nalgebra_solution),
            ("sprs-ldl", &sprs_solution),
        ] {
            let difference = max_relative_difference(&reference, solution);
            assert!(
                difference < 1e-8,
                "{name} differs from faer by {difference:e}"
            );
        }
        println!(
            "{label}: nnz(L) faer {} (supernodal, padded), nalgebra-sparse {}, sprs-ldl {}",
            cholesky.factor_len(),
            nalgebra_factor.l().nnz(),
            sprs_factor.nnz()
        );

        let mut group = c.benchmark_group("cholesky-backends");
        group.sample_size(10);
        group.measurement_time(Duration::from_secs(10));
        group.bench_function(BenchmarkId::new("faer-supernodal-metis", &label), |b| {
            b.iter(|| {
                let mut factor = SparseCholesky::analyze(black_box(&k_ff)).unwrap();
                factor.factorize(&k_ff).unwrap();
                factor
            })
        });
        group.bench_function(BenchmarkId::new("nalgebra-sparse-metis", &label), |b| {
            b.iter(|| {
                nalgebra_sparse::factorization::CscCholesky::factor(black_box(&permuted)).unwrap()
            })
        });
        group.bench_function(BenchmarkId::new("sprs-ldl-metis", &label), |b| {
            b.iter(|| {
                sprs_ldl::LdlNumeric::new_perm(
                    black_box(sprs_matrix.view()),
                    sprs::PermOwned::new(perm.clone()),
                    sprs::SymmetryCheck::DontCheckSymmetry,
                )
                .unwrap()
            })
        });
        group.finish();
    }
}

criterion_group! {
    name = benches;
    // No HTML plots: criterion's plotting needs system fonts, which a headless machine lacks.
    config = Criterion::default().without_plots();
    targets = backends
}
criterion_main!(benches);
