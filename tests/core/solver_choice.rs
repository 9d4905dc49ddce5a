//! `LinearMethod::Auto`: the cost model's choice as a pure function of sizes, the memory budget
//! as a hard limit, the factorization's flop count against brute-force counts, and the chosen
//! solver's results against the direct solve.

use std::sync::Arc;

use tetfem::linalg::Error;
use tetfem::linalg::linear_solver::{
    ChoiceInputs, ChoiceReason, CostModel, MethodChoice, SolveInfo, ThreadRates, choose_method,
};
use tetfem::{CscMatrix, LinearMethod, SolverOptions, SparseCholesky, StaticSolver};
use tetfem_fixtures::cantilever::Cantilever;

/// Sizes of the scale study's beams (5k×k×k cells) as `benches/solver_choice.rs` prints them:
/// (nnz(K_ff), factor values, factor flops).
const BEAM_K8: (usize, usize, f64) = (381_798, 2_662_479, 8.0438e8);
const BEAM_K20: (usize, usize, f64) = (5_624_442, 110_591_901, 1.6369e11);
const BEAM_K40: (usize, usize, f64) = (44_095_302, 1_944_684_027, 9.8511e12);

fn inputs((nnz, factor_len, flops): (usize, usize, f64)) -> ChoiceInputs {
    ChoiceInputs {
        matrix_entries: nnz,
        factor_len,
        factor_flops: flops,
        factor_bytes: 8 * factor_len,
        memory_budget: None,
        cholesky_threads: 1,
        iterative_threads: 2,
        iteration_estimate: true,
    }
}

fn choose(inputs: &ChoiceInputs, expected_solves: usize) -> MethodChoice {
    let options = SolverOptions {
        expected_solves,
        ..Default::default()
    };
    choose_method(inputs, &options).unwrap()
}

#[test]
fn auto_chooses_direct_for_a_small_problem_and_iterative_for_a_large_one() {
    let small = choose(&inputs(BEAM_K8), 1);
    assert_eq!(small.method, LinearMethod::Direct, "{small}");
    assert_eq!(small.reason, ChoiceReason::PredictedFaster);
    let p = small.predicted.unwrap();
    assert!(p.direct() < p.iterative(), "{small}");

    let large = choose(&inputs(BEAM_K40), 1);
    assert_eq!(large.method, LinearMethod::Iterative, "{large}");
    assert_eq!(large.reason, ChoiceReason::PredictedFaster);
    let p = large.predicted.unwrap();
    // Measured at 1.01M DOFs: 545 s direct against 28 s iterative; the model must at least get
    // the order right.
    assert!(p.direct() > 5.0 * p.iterative(), "{large}");
    assert!(large.to_string().starts_with("iterative"), "{large}");
}

#[test]
fn expected_solves_tip_a_mid_size_problem_to_the_factorization() {
    // 133k DOFs: setup and one CG solve beat the factorization (measured 9.0 s on one thread;
    // SA-AMG 0.93 + 0.93 s at 69k and 4.1 + 2.6 s at 227k DOFs), but each further right-hand
    // side costs a CG solve (~1.6 s predicted) against a triangular solve (~0.12 s).
    let once = choose(&inputs(BEAM_K20), 1);
    assert_eq!(once.method, LinearMethod::Iterative, "{once}");
    let many = choose(&inputs(BEAM_K20), 20);
    assert_eq!(many.method, LinearMethod::Direct, "{many}");
    let p = many.predicted.unwrap();
    assert_eq!(p.solves, 20);
    assert!(
        (p.direct() - (p.factorization + 20.0 * p.direct_solve)).abs() <= 1e-12 * p.direct(),
        "totals must add the solves: {many}"
    );
}

#[test]
fn memory_budget_is_a_hard_limit() {
    // The small problem with many solves: the factorization is predicted far faster…
    let mut small = inputs(BEAM_K8);
    let free = choose(&small, 100);
    assert!(free.is_direct(), "{free}");
    // …but one byte short of the factor's size makes it iterative anyway.
    small.memory_budget = Some(small.factor_bytes - 1);
    let limited = choose(&small, 100);
    assert_eq!(limited.method, LinearMethod::Iterative, "{limited}");
    assert_eq!(
        limited.reason,
        ChoiceReason::FactorOverBudget {
            factor_bytes: small.factor_bytes,
            budget: small.factor_bytes - 1
        }
    );
    // Exactly the factor's size fits.
    small.memory_budget = Some(small.factor_bytes);
    assert!(choose(&small, 100).is_direct());
}

#[test]
fn without_an_iteration_estimate_auto_keeps_the_factorization_that_fits() {
    let mut large = inputs(BEAM_K40);
    large.iteration_estimate = false;
    let choice = choose(&large, 1);
    assert!(choice.is_direct(), "{choice}");
    assert_eq!(choice.reason, ChoiceReason::NoIterationEstimate);
    large.memory_budget = Some(1 << 30);
    assert!(!choose(&large, 1).is_direct());
}

#[test]
fn cost_model_scales_with_its_rates_and_threads() {
    let model = CostModel::default();
    let mut i = inputs(BEAM_K20);
    let one = model.predict(&i, 1, 1e-10);
    // 3 iterations per decade over ten decades.
    assert!((one.iterations - 30.0).abs() < 1e-9, "{one:?}");
    let coarser = model.predict(&i, 1, 1e-5);
    assert!((coarser.iterations - 15.0).abs() < 1e-9, "{coarser:?}");
    i.cholesky_threads = 2;
    let two = model.predict(&i, 1, 1e-10);
    assert!(two.factorization < one.factorization);
    let slow = CostModel {
        factor_flops_per_second: ThreadRates {
            one: 1e9,
            two_or_more: 1e9,
        },
        ..model
    };
    let p = slow.predict(&inputs(BEAM_K8), 1, 1e-10);
    assert!((p.factorization - BEAM_K8.2 / 1e9).abs() < 1e-12);
}

#[test]
fn zero_expected_solves_is_an_error() {
    let options = SolverOptions {
        expected_solves: 0,
        ..Default::default()
    };
    let named = |e: Error| matches!(e, Error::InvalidParameter { ref name, .. } if name == "expected_solves");
    assert!(named(
        choose_method(&inputs(BEAM_K8), &options).unwrap_err()
    ));
    let k = dense_spd(4);
    assert!(named(
        tetfem::LinearSolver::analyze(&k, options).unwrap_err()
    ));
}

/// A dense symmetric positive definite n×n matrix (both triangles stored): diagonally dominant.
fn dense_spd(n: usize) -> CscMatrix {
    block_diagonal(1, n)
}

/// `blocks` disconnected dense m×m blocks on the diagonal: each block's factor is dense whatever
/// the ordering, so the factor's structure, and its flops, are known exactly.
fn block_diagonal(blocks: usize, m: usize) -> CscMatrix {
    let n = blocks * m;
    let mut col_ptr = vec![0];
    let mut rows = Vec::new();
    let mut values = Vec::new();
    for j in 0..n {
        let b = j / m;
        for i in b * m..(b + 1) * m {
            rows.push(i);
            values.push(if i == j {
                2.0 * m as f64
            } else {
                1.0 / (1.0 + (i + j) as f64)
            });
        }
        col_ptr.push(rows.len());
    }
    let pattern = faer::sparse::SymbolicSparseColMat::new_checked(n, n, col_ptr, None, rows);
    CscMatrix::from_values(Arc::new(pattern), values).unwrap()
}

/// Operations of a right-looking dense Cholesky of an m×m block, counted one by one as it runs
/// (square roots, divisions, multiplications, subtractions), with the factor for a check.
fn brute_force_cholesky(a: &mut [Vec<f64>]) -> f64 {
    let m = a.len();
    let mut count = 0.0;
    for k in 0..m {
        a[k][k] = a[k][k].sqrt();
        count += 1.0;
        for i in k + 1..m {
            a[i][k] /= a[k][k];
            count += 1.0;
        }
        for j in k + 1..m {
            for i in j..m {
                a[i][j] -= a[i][k] * a[j][k];
                count += 2.0;
            }
        }
    }
    count
}

fn check_flops(blocks: usize, m: usize, supernodal: bool) {
    let k = block_diagonal(blocks, m);
    let cholesky = SparseCholesky::analyze(&k).unwrap();
    assert_eq!(
        cholesky.supernodal_split().is_some(),
        supernodal,
        "{blocks} blocks of {m}: expected a {} factor",
        if supernodal {
            "supernodal"
        } else {
            "simplicial"
        }
    );
    let flops = cholesky.factor_flops();
    let cube = (blocks * m * m * m) as f64 / 3.0;
    // Sums of values of the form integer + 1/3: exact to a few ulps of the total.
    assert!(
        (flops - cube).abs() <= 1e-12 * cube,
        "{blocks}×{m}: {flops} against {cube}"
    );
    let mut brute = 0.0;
    for b in 0..blocks {
        let mut dense: Vec<Vec<f64>> = (0..m)
            .map(|i| {
                (0..m)
                    .map(|j| k.get(b * m + i, b * m + j).unwrap_or(0.0))
                    .collect()
            })
            .collect();
        brute += brute_force_cholesky(&mut dense);
    }
    // The count differs from the model by the divisions and square roots, Σ_columns (b + 2/3)
    // with b the column's entries below the diagonal: m(m − 1)/2 + 2m/3 per block.
    let lower_order = blocks as f64 * ((m * (m - 1)) as f64 / 2.0 + 2.0 * m as f64 / 3.0);
    assert!(
        (brute - flops - lower_order).abs() <= 1e-9 * brute,
        "{blocks}×{m}: counted {brute}, model {flops} + {lower_order}"
    );
}

#[test]
fn factor_flops_of_a_dense_matrix_is_n_cubed_over_three() {
    // One supernode: the formula c³/3 + b·c² + b²·c with b = 0.
    check_flops(1, 120, true);
}

#[test]
fn factor_flops_of_disconnected_cliques_in_a_simplicial_factor() {
    // Small blocks: faer keeps the factor simplicial, counted column by column.
    check_flops(300, 3, false);
}

#[test]
fn auto_solution_agrees_with_the_direct_one() {
    let problem = Cantilever::peer_benchmark([40, 8, 8]);
    let mesh = problem.mesh().unwrap();
    let constraints = problem.constraints(&mesh).unwrap();
    let loads = problem.loads(&mesh).unwrap();
    let solve = |options: SolverOptions| {
        let mut solver =
            StaticSolver::with_options(&mesh, &problem.material, &constraints, options).unwrap();
        let solution = solver.solve(&loads).unwrap();
        let tip = problem
            .tip_deflection(&mesh, &solution.displacement)
            .unwrap();
        (tip, solution.info, *solver.linear_solver().choice())
    };
    let (direct, info, choice) = solve(SolverOptions {
        method: LinearMethod::Direct,
        ..Default::default()
    });
    assert_eq!(info, SolveInfo::Direct);
    assert_eq!(choice.reason, ChoiceReason::Requested);
    // 9.7k DOFs with the default model: the factorization is predicted faster.
    let (auto_small, info, choice) = solve(SolverOptions::default());
    assert_eq!(info, SolveInfo::Direct, "{choice}");
    assert_eq!(choice.reason, ChoiceReason::PredictedFaster);
    assert!(((auto_small - direct) / direct).abs() < 1e-12);
    // A model whose factorization is a thousand times slower makes Auto iterate.
    let model = CostModel::default();
    let slow = |r: ThreadRates| ThreadRates {
        one: r.one / 1000.0,
        two_or_more: r.two_or_more / 1000.0,
    };
    let (auto_iterative, info, choice) = solve(SolverOptions {
        cost_model: CostModel {
            factor_flops_per_second: slow(model.factor_flops_per_second),
            ..model
        },
        ..Default::default()
    });
    let SolveInfo::Iterative { iterations, .. } = info else {
        panic!("{choice}: {info:?}");
    };
    assert_eq!(choice.method, LinearMethod::Iterative);
    assert!(iterations <= 50, "{iterations} iterations");
    // CG stops at relative residual 1e-10; the tip, dominated by the lowest modes, agrees to
    // far better than κ·1e-10 (measured ~1e-12 relative on this beam).
    assert!(
        ((auto_iterative - direct) / direct).abs() < 1e-8,
        "{auto_iterative} vs {direct}"
    );
}
