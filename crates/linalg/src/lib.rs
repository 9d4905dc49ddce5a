//! tetfem's linear algebra: what the finite element analyses solve with, and nothing of meshes.
//!
//! - [`sparse`]: symmetric matrices in compressed sparse column form ([`CscMatrix`]);
//! - [`block_sparse`]: the same in 3×3 node blocks, for bandwidth-bound products;
//! - [`ordering`]: fill-reducing orderings (METIS nested dissection, AMD);
//! - [`linsolve`]: sparse Cholesky (supernodal, over faer) and its triangular solves;
//! - [`quasi_definite`]: sparse LDLᵀ without pivoting of symmetric quasi-definite matrices
//!   (mixed displacement–pressure systems);
//! - [`iterative`]: preconditioned conjugate gradients and its preconditioners;
//! - [`amg`]: smoothed-aggregation multigrid, with a near-null space built from plain DOF
//!   coordinates ([`amg::DofGeometry`]);
//! - [`linear_solver`]: the choice between the direct and the iterative path, by a measured
//!   cost model within the memory budget;
//! - [`interrupt`]: a caller's "stop now?" test, polled between iterations (Ctrl-C in a front
//!   end);
//! - [`memory`]: the memory the process may still take, checked before large allocations.
//!
//! Every fallible function returns [`Result`]; its [`Error`] names the culprit.
#![warn(missing_docs)]

pub mod amg;
pub mod block_sparse;
pub mod bytes;
pub mod error;
pub mod interrupt;
pub mod iterative;
pub mod linear_solver;
pub mod linsolve;
pub mod memory;
pub mod ordering;
pub mod parallel;
pub mod preconditioner;
pub mod quasi_definite;
pub mod sparse;

pub use error::{Error, Result};
pub use linear_solver::{LinearMethod, LinearSolver, SolverOptions};
pub use linsolve::{CholeskyOptions, NumericFactorization, SparseCholesky, TriangularSolve};
pub use ordering::FillOrdering;
pub use quasi_definite::QuasiDefiniteLdlt;
pub use sparse::CscMatrix;
