//! Numeric Cholesky factorization of a cantilever's K_ff, side by side and interleaved (best of
//! several repetitions): faer's `factorize_numeric_llt` and tetfem's supernodal kernel, on one
//! and two threads, with the factor's size (nnz(L) as PARDISO counts it, and as stored), the
//! factorization's flop rate and the agreement of the two solutions. PARDISO and CHOLMOD on the
//! same K: `validation/factor_side_by_side.sh`.
//!
//! `cargo bench --bench factorization -- NX,NY,NZ [REPS]` (default 160,16,16, 3).

use std::time::Instant;

use tetfem::{CholeskyOptions, NumericFactorization, SparseCholesky};
use tetfem_fixtures::cantilever::{Cantilever, FreeSystem};

fn main() -> tetfem::Result<()> {
    // `cargo bench` appends `--bench` to a harness-less target's arguments: not one of ours.
    let mut args = std::env::args().skip(1).filter(|a| a != "--bench");
    let cells: Vec<usize> = args
        .next()
        .unwrap_or_else(|| "160,16,16".into())
        .split(',')
        .map(|s| s.parse().expect("cells NX,NY,NZ"))
        .collect();
    let reps: usize = args.next().map_or(3, |s| s.parse().expect("REPS"));
    let cantilever = Cantilever::peer_benchmark([cells[0], cells[1], cells[2]]);
    let mesh = cantilever.mesh()?;
    let FreeSystem {
        stiffness, load, ..
    } = cantilever.free_system(&mesh)?;
    println!(
        "{} DOFs, nnz(K) {}",
        stiffness.dim(),
        stiffness.values().len()
    );
    let kernels = [
        ("faer", NumericFactorization::Faer),
        ("tetfem", NumericFactorization::Supernodal),
    ];
    for threads in [1, 2] {
        let options = CholeskyOptions {
            threads,
            ..Default::default()
        };
        let mut solvers: Vec<SparseCholesky> = kernels
            .iter()
            .map(|_| SparseCholesky::analyze_with(&stiffness, options))
            .collect::<tetfem::linalg::Result<_>>()?;
        let flops = solvers[0].factor_flops();
        if threads == 1 {
            // nnz(L) as PARDISO and CHOLMOD count it (lower triangle with supernodal padding)
            // beside faer's stored length (which adds the diagonal blocks' upper triangles).
            println!(
                "nnz(L) {} (lower triangle), {} stored, {:.3e} flops",
                solvers[0].factor_nnz_lower(),
                solvers[0].factor_len(),
                flops
            );
        }
        let mut best = [f64::INFINITY; 2];
        for _ in 0..reps {
            for (k, (_, kernel)) in kernels.iter().enumerate() {
                let start = Instant::now();
                solvers[k].factorize_with(&stiffness, *kernel)?;
                best[k] = best[k].min(start.elapsed().as_secs_f64());
            }
        }
        let mut solutions = Vec::new();
        for solver in &mut solvers {
            let mut x = load.clone();
            solver.solve_in_place(&mut x)?;
            solutions.push(x);
        }
        let scale = solutions[0].iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let diff = solutions[0]
            .iter()
            .zip(&solutions[1])
            .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
        for (k, (name, _)) in kernels.iter().enumerate() {
            println!(
                "threads {threads}: {name:7} {:8.3} s  {:5.1} GFLOP/s",
                best[k],
                flops / best[k] / 1e9
            );
        }
        println!(
            "threads {threads}: tetfem / faer {:.2}; solutions differ by {:.1e} relative",
            best[1] / best[0],
            diff / scale
        );
    }
    Ok(())
}
