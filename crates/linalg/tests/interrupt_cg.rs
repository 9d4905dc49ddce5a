//! The interrupt hook as the Krylov solver sees it: CG polls before each iteration, stops with
//! `Error::Stopped` naming the iteration when the caller's check says so, and runs unchanged
//! with a check that never fires. (An integration test: the hook sits below the solvers, so its
//! own unit tests cannot name them.)

use std::cell::Cell;
use std::rc::Rc;

use tetfem_linalg::CscMatrix;
use tetfem_linalg::Error;
use tetfem_linalg::interrupt::with_check;
use tetfem_linalg::iterative::{BlockJacobi, CgOptions, conjugate_gradient};

/// The 1-D Laplacian tridiag(−1, 2, −1) of size n: CG needs n/2 or more iterations.
fn laplacian(n: usize) -> CscMatrix {
    let (mut col_ptr, mut rows, mut values) = (vec![0], Vec::new(), Vec::new());
    for j in 0..n {
        for (i, v) in [(j.wrapping_sub(1), -1.0), (j, 2.0), (j + 1, -1.0)] {
            if i < n {
                rows.push(i);
                values.push(v);
            }
        }
        col_ptr.push(rows.len());
    }
    let pattern = faer::sparse::SymbolicSparseColMat::new_checked(n, n, col_ptr, None, rows);
    CscMatrix::from_values(std::sync::Arc::new(pattern), values).expect("a valid pattern")
}

#[test]
fn conjugate_gradient_stops_at_the_iteration_the_check_says() {
    let a = laplacian(200);
    let p = BlockJacobi::new(&a).expect("positive diagonal");
    let b = vec![1.0; 200];
    let solve = || conjugate_gradient(&a, &p, &b, &mut vec![0.0; 200], CgOptions::default());
    let iterations = solve().expect("converges").iterations;
    assert!(iterations > 50, "{iterations}");
    // The check says stop at its 10th call: CG polls before each iteration, so it stops
    // before its 10th, long before convergence.
    let calls = Rc::new(Cell::new(0));
    let counted = Rc::clone(&calls);
    let stopped = with_check(
        move || {
            counted.set(counted.get() + 1);
            counted.get() == 10
        },
        solve,
    );
    match stopped {
        Err(Error::Stopped { during }) => {
            assert_eq!(during, "conjugate gradient iteration 10")
        }
        other => panic!("expected Stopped, got {other:?}"),
    }
    // With a check that never stops, the same iterations as without one.
    let unchanged = with_check(|| false, solve).expect("converges").iterations;
    assert_eq!(unchanged, iterations);
}
