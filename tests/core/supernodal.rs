//! tetfem's supernodal kernels against faer's: the numeric factorization (agreement, residual,
//! refactorization with new values, non-positive pivots) and the triangular solves on the same
//! factor (agreement, residual, the degenerate sizes, the simplicial fallback and bad input).

use std::sync::Arc;

use tetfem::linalg::Error;
use tetfem::{CholeskyOptions, CscMatrix, NumericFactorization, SparseCholesky, TriangularSolve};
use tetfem_fixtures::cantilever::Cantilever;

/// K_ff of a cantilever and a right-hand side with every component non-zero.
fn cantilever_system(cells: [usize; 3]) -> (CscMatrix, Vec<f64>) {
    let problem = Cantilever::peer_benchmark(cells);
    let mesh = problem.mesh().unwrap();
    let k_ff = problem.free_system(&mesh).unwrap().stiffness;
    let b = (0..k_ff.dim())
        .map(|i| (i * 7919 % 1000) as f64 / 1000.0 - 0.5)
        .collect();
    (k_ff, b)
}

fn max_relative_difference(a: &[f64], b: &[f64]) -> f64 {
    let scale = a.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    a.iter()
        .zip(b)
        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()))
        / scale
}

/// ‖v‖.
fn norm(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}

/// The normwise backward error of x for K·x = b, ‖K·x − b‖ / (‖K‖_F·‖x‖ + ‖b‖): the relative
/// size of the smallest perturbation of K and b that x solves exactly.
fn backward_error(k: &CscMatrix, x: &[f64], b: &[f64]) -> f64 {
    let r: Vec<f64> = (k.mul(x).unwrap().iter().zip(b))
        .map(|(a, b)| a - b)
        .collect();
    norm(&r) / (norm(k.values()) * norm(x) + norm(b))
}

fn relative_residual(a: &CscMatrix, x: &[f64], b: &[f64]) -> f64 {
    let r: f64 = a
        .mul(x)
        .unwrap()
        .iter()
        .zip(b)
        .map(|(ax, b)| (ax - b) * (ax - b))
        .sum();
    r.sqrt() / b.iter().map(|v| v * v).sum::<f64>().sqrt()
}

/// The default options (nested dissection) on `threads` threads.
fn on_threads(threads: usize) -> CholeskyOptions {
    CholeskyOptions {
        threads,
        ..Default::default()
    }
}

#[test]
fn supernodal_solve_agrees_with_faer_on_one_and_two_threads() {
    let (k, b) = cantilever_system([30, 6, 6]);
    for threads in [1, 2] {
        let options = on_threads(threads);
        let mut cholesky = SparseCholesky::analyze_with(&k, options).unwrap();
        cholesky.factorize(&k).unwrap();
        let split = cholesky
            .supernodal_split()
            .expect("an elasticity factor is supernodal");
        assert!(split[1] > 0.0 && split[2] > 0.0, "two halves: {split:?}");
        let mut reference = b.clone();
        cholesky
            .solve_in_place_with(&mut reference, TriangularSolve::Faer)
            .unwrap();
        let mut default = b.clone();
        cholesky.solve_in_place(&mut default).unwrap();
        assert!(max_relative_difference(&reference, &default) < 1e-12);
        for own_threads in [1, 2] {
            let mut x = b.clone();
            cholesky
                .solve_in_place_with(
                    &mut x,
                    TriangularSolve::Supernodal {
                        threads: own_threads,
                    },
                )
                .unwrap();
            let diff = max_relative_difference(&reference, &x);
            assert!(diff < 1e-12, "threads {own_threads}: {diff:e}");
            let residual = relative_residual(&k, &x, &b);
            assert!(
                residual < 1e-9,
                "threads {own_threads}: residual {residual:e}"
            );
        }
    }
}

#[test]
fn solve_is_repeatable_with_reused_workspaces() {
    let (k, b) = cantilever_system([12, 3, 3]);
    let mut cholesky = SparseCholesky::analyze(&k).unwrap();
    cholesky.factorize(&k).unwrap();
    let mut first = b.clone();
    cholesky.solve_in_place(&mut first).unwrap();
    for threads in [2, 1] {
        let mut again = b.clone();
        cholesky
            .solve_in_place_with(&mut again, TriangularSolve::Supernodal { threads })
            .unwrap();
        assert!(max_relative_difference(&first, &again) < 1e-12);
    }
}

fn matrix(n: usize, col_ptr: Vec<usize>, rows: Vec<usize>, values: Vec<f64>) -> CscMatrix {
    let pattern = faer::sparse::SymbolicSparseColMat::new_checked(n, n, col_ptr, None, rows);
    CscMatrix::from_values(Arc::new(pattern), values).unwrap()
}

#[test]
fn empty_and_one_by_one_matrices() {
    let empty = matrix(0, vec![0], vec![], vec![]);
    let mut cholesky = SparseCholesky::analyze(&empty).unwrap();
    cholesky.factorize(&empty).unwrap();
    let mut x: Vec<f64> = Vec::new();
    cholesky.solve_in_place(&mut x).unwrap();
    cholesky
        .solve_in_place_with(&mut x, TriangularSolve::Supernodal { threads: 2 })
        .unwrap();

    let one = matrix(1, vec![0, 1], vec![0], vec![4.0]);
    let mut cholesky = SparseCholesky::analyze(&one).unwrap();
    cholesky.factorize(&one).unwrap();
    for kernel in [
        TriangularSolve::Faer,
        TriangularSolve::Supernodal { threads: 1 },
        TriangularSolve::Supernodal { threads: 2 },
    ] {
        let mut x = vec![2.0];
        cholesky.solve_in_place_with(&mut x, kernel).unwrap();
        assert_eq!(x, vec![0.5]);
    }
}

#[test]
fn simplicial_factor_falls_back_to_faer() {
    // A tridiagonal matrix has no fill: faer's automatic choice keeps it simplicial.
    let n: usize = 6;
    let mut col_ptr = vec![0];
    let mut rows = Vec::new();
    let mut values = Vec::new();
    for j in 0..n {
        for i in j.saturating_sub(1)..(j + 2).min(n) {
            rows.push(i);
            values.push(if i == j { 2.5 } else { -1.0 });
        }
        col_ptr.push(rows.len());
    }
    let a = matrix(n, col_ptr, rows, values);
    let mut cholesky = SparseCholesky::analyze(&a).unwrap();
    cholesky.factorize(&a).unwrap();
    assert!(cholesky.supernodal_split().is_none(), "simplicial factor");
    let b: Vec<f64> = (0..n).map(|i| i as f64 + 1.0).collect();
    for kernel in [
        TriangularSolve::Faer,
        TriangularSolve::Supernodal { threads: 2 },
    ] {
        let mut x = b.clone();
        cholesky.solve_in_place_with(&mut x, kernel).unwrap();
        assert!(relative_residual(&a, &x, &b) < 1e-14);
    }
}

#[test]
fn wrong_rhs_length_and_unfactored_solve_are_errors() {
    let (k, b) = cantilever_system([4, 1, 1]);
    let mut cholesky = SparseCholesky::analyze(&k).unwrap();
    let mut x = b.clone();
    assert!(matches!(
        cholesky.solve_in_place(&mut x),
        Err(Error::Solver(_))
    ));
    cholesky.factorize(&k).unwrap();
    for len in [0, b.len() - 1, b.len() + 1] {
        let mut x = vec![1.0; len];
        for kernel in [
            TriangularSolve::Faer,
            TriangularSolve::Supernodal { threads: 1 },
            TriangularSolve::Supernodal { threads: 2 },
        ] {
            assert!(matches!(
                cholesky.solve_in_place_with(&mut x, kernel),
                Err(Error::InvalidParameter { .. })
            ));
        }
    }
}

#[test]
fn supernodal_factorization_agrees_with_faer_on_one_and_two_threads() {
    let (k, b) = cantilever_system([40, 8, 8]);
    for threads in [1, 2] {
        let options = on_threads(threads);
        let mut solutions = Vec::new();
        for kernel in [NumericFactorization::Faer, NumericFactorization::Supernodal] {
            let mut cholesky = SparseCholesky::analyze_with(&k, options).unwrap();
            assert!(cholesky.supernodal_split().is_some(), "a supernodal factor");
            cholesky.factorize_with(&k, kernel).unwrap();
            let mut x = b.clone();
            cholesky.solve_in_place(&mut x).unwrap();
            // K is well conditioned enough here (cond ~1e7) that a backward-stable solve
            // leaves a residual near ε·cond.
            let residual = relative_residual(&k, &x, &b);
            assert!(
                residual < 1e-9,
                "{kernel:?}, threads {threads}: {residual:e}"
            );
            solutions.push(x);
        }
        // The same factorization with the operations in another order: the solutions differ
        // by round-off amplified by the condition number.
        let difference = max_relative_difference(&solutions[0], &solutions[1]);
        assert!(difference < 1e-9, "threads {threads}: {difference:e}");
    }
}

#[test]
fn refactorization_with_new_values_reuses_the_analysis() {
    // The second factorization must not keep anything of the first: 4K gives a quarter of the
    // solution, exactly (its factor is 2L: square roots, products and quotients all scale by
    // powers of two without rounding).
    let (k, b) = cantilever_system([30, 6, 6]);
    let mut quadrupled = k.clone();
    quadrupled.values_mut().iter_mut().for_each(|v| *v *= 4.0);
    for threads in [1, 2] {
        let options = on_threads(threads);
        let mut cholesky = SparseCholesky::analyze_with(&k, options).unwrap();
        cholesky.factorize(&k).unwrap();
        let mut x = b.clone();
        cholesky.solve_in_place(&mut x).unwrap();
        cholesky.factorize(&quadrupled).unwrap();
        let mut quarter = b.clone();
        cholesky.solve_in_place(&mut quarter).unwrap();
        let mismatches = quarter
            .iter()
            .zip(&x)
            .filter(|&(q, x)| 4.0 * q != *x)
            .count();
        assert_eq!(mismatches, 0, "threads {threads}");
    }
}

#[test]
fn non_positive_pivot_names_the_failing_row() {
    let (mut k, _) = cantilever_system([30, 6, 6]);
    // Make one diagonal entry negative: the matrix is indefinite.
    let dof = k.dim() / 2;
    let position = (k.col_ptr()[dof]..k.col_ptr()[dof + 1])
        .find(|&p| k.row_idx()[p] == dof)
        .unwrap();
    k.values_mut()[position] = -1.0;
    let pivot = |kernel, threads| {
        let options = on_threads(threads);
        let mut cholesky = SparseCholesky::analyze_with(&k, options).unwrap();
        match cholesky.factorize_with(&k, kernel) {
            Err(Error::NotPositiveDefinite { pivot, dimension }) => {
                assert_eq!(dimension, k.dim());
                pivot
            }
            other => panic!("{kernel:?}, threads {threads}: {other:?}"),
        }
    };
    // Every other pivot stays positive (the leading blocks before it are unchanged, those after
    // it are never reached), so the failing row is the modified one.
    for threads in [1, 2] {
        assert_eq!(pivot(NumericFactorization::Supernodal, threads), dof);
    }
    // faer's kernel fails too; its reported index is not checked (faer 0.24 reports an index
    // that is neither the permuted nor the original position of the failing pivot).
    assert!(pivot(NumericFactorization::Faer, 1) < k.dim());
}

/// The single-precision copy of the factor solves in f32: not the f64 solution bit for bit,
/// but a backward-stable solve of K in f32, on one and two threads alike and whatever the
/// right-hand side's scale (f32's range is 1.2e-38 to 3.4e38); it goes stale with the next
/// factorization (an error, not the old factor's answer), and a simplicial factor or an
/// unfactored matrix has none.
#[test]
fn the_single_precision_copy_solves_with_the_rounded_factor() {
    let (k, b) = cantilever_system([30, 6, 6]);
    let mut cholesky = SparseCholesky::analyze_with(&k, on_threads(2)).unwrap();
    assert!(matches!(
        cholesky.make_single_precision_copy(),
        Err(Error::Solver(_))
    ));
    cholesky.factorize(&k).unwrap();
    assert!(cholesky.make_single_precision_copy().unwrap());
    let mut exact = b.clone();
    cholesky.solve_in_place(&mut exact).unwrap();
    let mut one = b.clone();
    cholesky
        .solve_in_place_with(&mut one, TriangularSolve::SupernodalSingle { threads: 1 })
        .unwrap();
    let mut two = b.clone();
    cholesky.solve_in_place_single(&mut two).unwrap();
    // The normwise backward error η (`backward_error`).
    let backward_error = |x: &[f64]| backward_error(&k, x, &b);
    let (single, double) = (backward_error(&one), backward_error(&exact));
    let single_two = backward_error(&two);
    let difference = max_relative_difference(&exact, &one);
    println!(
        "backward error: f32 copy {single:.2e} (two threads {single_two:.2e}), f64 factor \
         {double:.2e}; difference of the solutions {difference:.2e}"
    );
    // A triangular solve in precision u is backward stable: it solves exactly with L + δL,
    // |δL| ≤ γₙ·|L|, γₙ ≈ n·u for columns of length at most n (Higham, *Accuracy and
    // Stability*, Thm 8.5), and L's rounding to f32 adds u = 2⁻²⁴. n = the dimension bounds
    // every column: η < dim·2⁻²⁴ (1.3e-4 here; measured 1.1e-9 on either thread count, the
    // bound being for the worst case of every rounding adding up). The f64 factor stays at
    // round-off (measured 3.8e-18); a solve that read the wrong values would be off by O(1).
    let bound = k.dim() as f64 * 2f64.powi(-24);
    assert!(single < bound, "{single:e} against {bound:e}");
    assert!(single_two < bound, "{single_two:e} against {bound:e}");
    assert!(double < 1e-14, "{double:e}");
    assert!(
        difference > 1e-10,
        "{difference:e}: the f64 factor was read"
    );
    // Far outside f32's range (b·1e-45 would round to zero in f32, b·1e45 to infinity) the
    // right-hand side is brought into it by a power of two, exactly: the solve stays as
    // backward stable, its solution scaled back.
    for scale in [1e-45, 1e45] {
        let mut scaled: Vec<f64> = b.iter().map(|v| v * scale).collect();
        cholesky.solve_in_place_single(&mut scaled).unwrap();
        let back: Vec<f64> = scaled.iter().map(|v| v / scale).collect();
        let error = backward_error(&back);
        assert!(
            error < bound,
            "scale {scale:e}: {error:e} against {bound:e}"
        );
    }

    cholesky.factorize(&k).unwrap();
    assert!(!cholesky.has_single_precision_copy());
    assert!(matches!(
        cholesky.solve_in_place_single(&mut two),
        Err(Error::Solver(_))
    ));

    let (small, _) = cantilever_system([1, 1, 1]);
    let mut simplicial = SparseCholesky::analyze(&small).unwrap();
    simplicial.factorize(&small).unwrap();
    if simplicial.supernodal_split().is_none() {
        assert!(!simplicial.make_single_precision_copy().unwrap());
    }
}

/// Many right-hand sides at once (`SparseCholesky::solve_many_approximate`, 16 a pass over
/// the factor): on the f64 factor each column agrees with its own solve to round-off and has
/// its residual; on the f32 copy each is as backward stable as the one-column f32 solve; a
/// column's bits do not depend on the columns beside it (37 columns: two full batches and a
/// partial one, on one and two threads), and bad lengths are errors.
#[test]
fn many_right_hand_sides_solve_each_column_as_alone() {
    let (k, b) = cantilever_system([30, 6, 6]);
    let n = k.dim();
    let columns = 37;
    let rhs: Vec<f64> = (0..columns * n)
        .map(|i| {
            b[i % n] * (1.0 + (i / n) as f64 * 0.37) + if i % n == (i / n) * 11 { 1.0 } else { 0.0 }
        })
        .collect();
    let backward_error = |x: &[f64], b: &[f64]| backward_error(&k, x, b);
    for threads in [1, 2] {
        let mut cholesky = SparseCholesky::analyze_with(&k, on_threads(threads)).unwrap();
        cholesky.factorize(&k).unwrap();
        let mut many = rhs.clone();
        cholesky.solve_many_approximate(&mut many).unwrap();
        for (c, (x, b)) in many.chunks(n).zip(rhs.chunks(n)).enumerate() {
            let mut alone = b.to_vec();
            cholesky.solve_in_place(&mut alone).unwrap();
            // The same f64 operations in another order: a few ulps of cond(K)·|x|.
            let difference = max_relative_difference(&alone, x);
            assert!(
                difference < 1e-9,
                "column {c}: {difference:e} from its own solve"
            );
            let residual = relative_residual(&k, x, b);
            assert!(residual < 1e-10, "column {c}: residual {residual:e}");
        }
        assert!(cholesky.make_single_precision_copy().unwrap());
        let mut single = rhs.clone();
        cholesky.solve_many_approximate(&mut single).unwrap();
        // As for the one-column f32 solve (`the_single_precision_copy_solves_with_the_rounded_factor`):
        // η < dim·2⁻²⁴; a read of the f64 factor would be at round-off of f64 instead.
        let bound = n as f64 * 2f64.powi(-24);
        for (c, (x, b)) in single.chunks(n).zip(rhs.chunks(n)).enumerate() {
            let error = backward_error(x, b);
            assert!(error < bound, "column {c}: {error:e} against {bound:e}");
            assert!(
                max_relative_difference(&many[c * n..][..n], x) > 1e-10,
                "column {c}: the f64 factor was read"
            );
        }
        // Column 20 alone, and among others in another batch position: the same bits.
        let mut alone = rhs[20 * n..][..n].to_vec();
        cholesky.solve_many_approximate(&mut alone).unwrap();
        assert_eq!(alone, single[20 * n..][..n]);
        let mut shifted = rhs[3 * n..].to_vec();
        cholesky.solve_many_approximate(&mut shifted).unwrap();
        assert_eq!(shifted, single[3 * n..]);
        let mut ragged = vec![0.0; n + 1];
        assert!(matches!(
            cholesky.solve_many_approximate(&mut ragged),
            Err(Error::InvalidParameter { .. })
        ));
    }
}

/// Right-hand sides that are zero on most of the factor (unit vectors, a few DOFs at the two
/// ends of the elimination order, a zero column among them): the forward solves pass over the
/// supernodes whose part of the right-hand side is still zero (their solve and update would
/// add nothing), and the solutions are the ones faer's solve gives, on one and two threads,
/// one column or many at a time, f64 and the f32 copy alike; a zero right-hand side gives
/// zero.
#[test]
fn sparse_right_hand_sides_solve_as_dense_ones_do() {
    let (k, _) = cantilever_system([30, 6, 6]);
    let n = k.dim();
    let dofs = [0, 1, n / 2, n - 2, n - 1];
    let unit = |d: usize| {
        (0..n)
            .map(|i| f64::from(u8::from(i == d)))
            .collect::<Vec<_>>()
    };
    let mut rhs: Vec<Vec<f64>> = dofs.iter().map(|&d| unit(d)).collect();
    rhs.push(vec![0.0; n]);
    rhs.push(
        (0..n)
            .map(|i| {
                if dofs.contains(&i) {
                    i as f64 - 7.0
                } else {
                    0.0
                }
            })
            .collect(),
    );
    let backward_error = |x: &[f64], b: &[f64]| backward_error(&k, x, b);
    for threads in [1, 2] {
        let mut cholesky = SparseCholesky::analyze_with(&k, on_threads(threads)).unwrap();
        cholesky.factorize(&k).unwrap();
        let mut many: Vec<f64> = rhs.concat();
        cholesky.solve_many_approximate(&mut many).unwrap();
        for (c, b) in rhs.iter().enumerate() {
            let mut reference = b.clone();
            cholesky
                .solve_in_place_with(&mut reference, TriangularSolve::Faer)
                .unwrap();
            let mut x = b.clone();
            cholesky.solve_in_place(&mut x).unwrap();
            if norm(b) == 0.0 {
                assert!(x.iter().chain(&many[c * n..][..n]).all(|v| *v == 0.0));
                continue;
            }
            // The same f64 operations as a dense right-hand side's, less those on zeros.
            let difference = max_relative_difference(&reference, &x);
            assert!(
                difference < 1e-12,
                "rhs {c}, {threads} threads: {difference:e}"
            );
            let difference = max_relative_difference(&reference, &many[c * n..][..n]);
            assert!(
                difference < 1e-9,
                "rhs {c}, {threads} threads, many: {difference:e}"
            );
        }
        assert!(cholesky.make_single_precision_copy().unwrap());
        let mut single: Vec<f64> = rhs.concat();
        cholesky.solve_many_approximate(&mut single).unwrap();
        // As for the dense f32 solves above: η < dim·2⁻²⁴.
        let bound = n as f64 * 2f64.powi(-24);
        for (c, b) in rhs.iter().enumerate().filter(|(_, b)| norm(b) > 0.0) {
            let mut x = b.clone();
            cholesky.solve_in_place_single(&mut x).unwrap();
            for x in [&x[..], &single[c * n..][..n]] {
                let error = backward_error(x, b);
                assert!(error < bound, "rhs {c}, f32: {error:e} against {bound:e}");
            }
        }
    }
}
