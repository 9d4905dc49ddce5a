//! Triangular solves with the sparse Cholesky factor of a cantilever's K_ff, side by side and
//! interleaved (best of several repetitions): faer's supernodal solve, tetfem's supernodal
//! kernels on one and two threads, and a streaming read of the factor's values twice (the
//! practical bandwidth floor of a solve) on one and two threads, as one sequential stream per
//! thread and as four concurrent streams per thread (which one thread reads much faster), and
//! tetfem's kernels on the factor's single-precision copy; then 64 unit columns solved one at a
//! time and together (`SparseCholesky::solve_many_approximate`, 16 to a pass), on the f32 copy.
//!
//! `cargo bench --bench triangular_solve -- NX,NY,NZ [REPS]` (default 100,20,20, 9).

use std::hint::black_box;
use std::time::Instant;

use tetfem::{SparseCholesky, TriangularSolve};
use tetfem_fixtures::cantilever::{Cantilever, FreeSystem};

/// Sum of the values, twice, with independent partial sums so that the loop is bound by memory,
/// not by the latency of one running sum. Both passes read forwards: a backward pass measured
/// slower (the hardware prefetchers favour ascending addresses), while the solve's backward
/// sweep still reads each column upwards.
fn stream_sum_twice(values: &[f64]) -> f64 {
    let mut sum = [0.0; 8];
    let mut tail = 0.0;
    for _ in 0..2 {
        let mut chunks = black_box(values).chunks_exact(8);
        for c in &mut chunks {
            for k in 0..8 {
                sum[k] += c[k];
            }
        }
        tail += chunks.remainder().iter().sum::<f64>();
    }
    sum.iter().sum::<f64>() + tail
}

/// The same read as four concurrent sequential streams (one per quarter of the values), the
/// access pattern of the solve's four-column passes: one thread's bandwidth grows with the
/// number of streams the hardware prefetchers follow.
fn stream_sum_twice_four_streams(values: &[f64]) -> f64 {
    let q = values.len() / 4;
    let mut sum = [[0.0; 4]; 4];
    for _ in 0..2 {
        let v = black_box(values);
        let (a, rest) = v.split_at(q);
        let (b, rest) = rest.split_at(q);
        let (c, d) = rest.split_at(q);
        for (((a, b), c), d) in a
            .chunks_exact(4)
            .zip(b.chunks_exact(4))
            .zip(c.chunks_exact(4))
            .zip(d.chunks_exact(4))
        {
            for k in 0..4 {
                sum[0][k] += a[k];
                sum[1][k] += b[k];
                sum[2][k] += c[k];
                sum[3][k] += d[k];
            }
        }
    }
    sum.iter().flatten().sum()
}

fn stream_sum_twice_two_threads(values: &[f64]) -> f64 {
    let (a, b) = values.split_at(values.len() / 2);
    let (x, y) = rayon::join(|| stream_sum_twice(a), || stream_sum_twice(b));
    x + y
}

fn main() -> tetfem::Result<()> {
    let args: Vec<String> = std::env::args().filter(|a| a != "--bench").collect(); // cargo's flag
    let cells: Vec<usize> = args
        .get(1)
        .map_or("100,20,20", String::as_str)
        .split(',')
        .map(|s| s.trim().parse().expect("cells as NX,NY,NZ"))
        .collect();
    let cells: [usize; 3] = cells.try_into().expect("three cell counts");
    let reps: usize = args.get(2).map_or(9, |s| s.parse().expect("repetitions"));

    let problem = Cantilever::peer_benchmark(cells);
    let mesh = problem.mesh()?;
    let FreeSystem {
        stiffness: k_ff,
        load: b,
        ..
    } = problem.free_system(&mesh)?;
    // A load with every component non-zero exercises all of the factor.
    let b: Vec<f64> = b
        .iter()
        .enumerate()
        .map(|(i, v)| v + ((i * 7919 % 1000) as f64 / 1000.0 - 0.5))
        .collect();

    let clock = Instant::now();
    let mut cholesky = SparseCholesky::analyze(&k_ff)?;
    cholesky.factorize(&k_ff)?;
    let factor_seconds = clock.elapsed().as_secs_f64();
    let len = cholesky.factor_len();
    let bytes = 2.0 * 8.0 * len as f64;
    println!(
        "cells {cells:?}: {} DOFs, factor_len {len} ({:.2} GB read per solve), factorization {factor_seconds:.1} s",
        k_ff.dim(),
        bytes / 1e9
    );
    if let Some([top, p0, p1]) = cholesky.supernodal_split() {
        println!(
            "two-thread split of the factor's values: top {:.1} %, halves {:.1} % / {:.1} %",
            100.0 * top,
            100.0 * p0,
            100.0 * p1
        );
    }

    let kernels = [
        ("faer solve", Some(TriangularSolve::Faer)),
        (
            "own, 1 thread",
            Some(TriangularSolve::Supernodal { threads: 1 }),
        ),
        (
            "own, 2 threads",
            Some(TriangularSolve::Supernodal { threads: 2 }),
        ),
        ("stream ×2, 1 thread", None),
        ("stream ×2, 2 threads", None),
        ("stream ×2, 1t, 4 streams", None),
        ("stream ×2, 2t, 4 streams", None),
        (
            "own, f32 copy, 1 thread",
            Some(TriangularSolve::SupernodalSingle { threads: 1 }),
        ),
        (
            "own, f32 copy, 2 threads",
            Some(TriangularSolve::SupernodalSingle { threads: 2 }),
        ),
    ];
    // No copy without a supernodal plan (a small factor) or without the memory for it: the
    // f32 rows are then skipped, not an error.
    let single = cholesky.make_single_precision_copy()?;
    if !single {
        println!(
            "no single-precision copy (no supernodal plan at this size, or no memory): f32 rows skipped"
        );
    }
    let mut best = [f64::INFINITY; 9];
    let mut solutions: Vec<Vec<f64>> = vec![Vec::new(); 9];
    for _ in 0..reps {
        for (k, (_, kernel)) in kernels.iter().enumerate() {
            if !single && matches!(kernel, Some(TriangularSolve::SupernodalSingle { .. })) {
                continue;
            }
            let mut x = b.clone();
            let clock = Instant::now();
            match kernel {
                Some(kernel) => cholesky.solve_in_place_with(&mut x, *kernel)?,
                None => {
                    let values = black_box(cholesky.factor_values());
                    let sum = match k {
                        3 => stream_sum_twice(values),
                        4 => stream_sum_twice_two_threads(values),
                        5 => stream_sum_twice_four_streams(values),
                        _ => {
                            let (a, b) = values.split_at(values.len() / 2);
                            let (x, y) = rayon::join(
                                || stream_sum_twice_four_streams(a),
                                || stream_sum_twice_four_streams(b),
                            );
                            x + y
                        }
                    };
                    black_box(sum);
                }
            }
            best[k] = best[k].min(clock.elapsed().as_secs_f64());
            if kernel.is_some() {
                solutions[k] = x;
            }
        }
    }
    let names: Vec<&str> = kernels.iter().map(|(name, _)| *name).collect();
    print_results(&names, &best, &solutions, (bytes, len, single), &k_ff, &b)?;
    many_right_hand_sides(&k_ff, reps)
}

/// 64 unit columns (the contact columns of L-BFGS's rest factor, `contact_capacitance.rs`)
/// solved one at a time and together (`SparseCholesky::solve_many_approximate`, 16 a pass),
/// on the f32 copy, one and two threads, interleaved: best time per column of each.
fn many_right_hand_sides(k_ff: &tetfem::CscMatrix, reps: usize) -> tetfem::Result<()> {
    let n = k_ff.dim();
    let columns = 64;
    let mut units = vec![0.0; columns * n];
    for (c, column) in units.chunks_exact_mut(n).enumerate() {
        column[(c * 7919) % n] = 1.0;
    }
    for threads in [1, 2] {
        let options = tetfem::CholeskyOptions {
            threads,
            ..Default::default()
        };
        let mut cholesky = SparseCholesky::analyze_with(k_ff, options)?;
        cholesky.factorize(k_ff)?;
        if !cholesky.make_single_precision_copy()? {
            return Ok(());
        }
        let (mut one, mut many) = (f64::INFINITY, f64::INFINITY);
        for _ in 0..reps {
            let mut x = units.clone();
            let clock = Instant::now();
            for column in x.chunks_exact_mut(n) {
                cholesky.solve_in_place_single(column)?;
            }
            one = one.min(clock.elapsed().as_secs_f64());
            let mut x = units.clone();
            let clock = Instant::now();
            cholesky.solve_many_approximate(&mut x)?;
            many = many.min(clock.elapsed().as_secs_f64());
            black_box(&x);
        }
        println!(
            "{columns} unit columns, f32 copy, {threads} thread(s): one at a time {:.3} ms a column, together {:.3} ms a column ({:.2}×)",
            1e3 * one / columns as f64,
            1e3 * many / columns as f64,
            one / many
        );
    }
    Ok(())
}

/// The table of best times (s, GB/s and ratios to the streaming floor), the solutions'
/// agreement with faer's and the own solve's residual; `(bytes, len, single)`: bytes read per
/// solve, the factor's length, whether the f32 rows ran.
fn print_results(
    names: &[&str],
    best: &[f64; 9],
    solutions: &[Vec<f64>],
    (bytes, len, single): (f64, usize, bool),
    k_ff: &tetfem::CscMatrix,
    b: &[f64],
) -> tetfem::Result<()> {
    let diff = |a: &[f64], b: &[f64]| {
        let scale = a.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        a.iter()
            .zip(b)
            .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()))
            / scale
    };
    println!(
        "{:<26} {:>10} {:>10} {:>12} {:>12}",
        "kernel", "best s", "GB/s", "÷ stream 1t", "÷ stream 2t"
    );
    for (k, name) in names.iter().enumerate() {
        println!(
            "{:<26} {:>10.5} {:>10.2} {:>12.2} {:>12.2}",
            name,
            best[k],
            bytes / best[k] / 1e9,
            best[k] / best[3],
            best[k] / best[4]
        );
    }
    println!(
        "max |x_faer − x_own| / max |x_faer|: 1 thread {:.2e}, 2 threads {:.2e}",
        diff(&solutions[0], &solutions[1]),
        diff(&solutions[0], &solutions[2])
    );
    if single {
        println!(
            "max |x_faer − x_f32 copy| / max |x_faer|: {:.2e}",
            diff(&solutions[0], &solutions[7])
        );
    }
    let residual: f64 = k_ff
        .mul(&solutions[1])?
        .iter()
        .zip(b)
        .map(|(a, b)| (a - b) * (a - b))
        .sum::<f64>()
        .sqrt()
        / b.iter().map(|v| v * v).sum::<f64>().sqrt();
    println!("own solve residual ‖Kx − b‖/‖b‖ = {residual:.2e}");
    println!(
        "RESULT {} {len} {}",
        k_ff.dim(),
        best.iter()
            .map(|t| format!("{t:.6}"))
            .collect::<Vec<_>>()
            .join(" ")
    );
    Ok(())
}
