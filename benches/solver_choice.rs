//! What `LinearMethod::Auto` sees and decides on the scale study's beams (5k×k×k cells): the
//! free DOFs, nnz(K_ff), the Cholesky factor's values and flops from the symbolic analysis, and
//! the cost model's predicted times for one and for ten right-hand sides. No numeric work: the
//! flops printed here are those the cost model's rates were fitted with
//! (`validation/scale_results.txt` holds the measured times).
//!
//! `cargo bench --bench solver_choice -- 8 12 16 20` (k values; default 8 12 16 20).

use tetfem::linalg::linear_solver::{ChoiceInputs, choose_method};
use tetfem::{SolverOptions, SparseCholesky};
use tetfem_fixtures::cantilever::{Cantilever, FreeSystem};

fn main() -> tetfem::Result<()> {
    let ks: Vec<usize> = std::env::args()
        .skip(1)
        .filter_map(|a| a.parse().ok())
        .collect();
    let ks = if ks.is_empty() {
        vec![8, 12, 16, 20]
    } else {
        ks
    };
    println!(
        "| k | free DOFs | nnz(K_ff) | factor values | factor flops | Auto, 1 solve | Auto, 10 solves |"
    );
    println!("|---|---|---|---|---|---|---|");
    for k in ks {
        let problem = Cantilever::peer_benchmark([5 * k, k, k]);
        let mesh = problem.mesh()?;
        let FreeSystem {
            stiffness: k_ff, ..
        } = problem.free_system(&mesh)?;
        let cholesky = SparseCholesky::analyze(&k_ff)?;
        let (factor_len, flops) = (cholesky.factor_len(), cholesky.factor_flops());
        let inputs = ChoiceInputs {
            matrix_entries: k_ff.nnz(),
            factor_len,
            factor_flops: flops,
            factor_bytes: cholesky.factor_bytes(),
            // Unlimited, so that the choice shows the time model alone.
            memory_budget: None,
            cholesky_threads: 1,
            iterative_threads: rayon::current_num_threads(),
            iteration_estimate: true,
        };
        let mut cells = Vec::new();
        for solves in [1, 10] {
            let options = SolverOptions {
                expected_solves: solves,
                ..Default::default()
            };
            cells.push(choose_method(&inputs, &options)?.to_string());
        }
        println!(
            "| {k} | {} | {} | {factor_len} | {flops:.4e} | {} | {} |",
            k_ff.dim(),
            k_ff.nnz(),
            cells[0],
            cells[1]
        );
    }
    Ok(())
}
