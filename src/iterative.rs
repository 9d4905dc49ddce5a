//! Preconditioned conjugate gradients, for systems whose Cholesky factor would not fit in
//! memory.
//!
//! The preconditioner is block Jacobi on the supervariables of the matrix (the free DOFs of one
//! node, a 1×1 to 3×3 block): cheap, parallel, and for elasticity clearly better than point
//! Jacobi because it captures the coupling of a node's three directions. On stiffness matrices
//! alone it still needs many iterations (hundreds to thousands, growing with the mesh); on
//! M + dt²K far fewer.

use nalgebra::DMatrix;
use rayon::prelude::*;

use crate::error::{Error, Result};
use crate::sparse::CscMatrix;

/// Stopping rule of [`conjugate_gradient`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CgOptions {
    /// Stop when ‖b − A·x‖ ≤ tolerance · ‖b‖ (default 1e-10). Much below 1e-10 the floating-point
    /// residual of an ill-conditioned stiffness matrix (κ ~ 1e8 for slender beams) stagnates.
    pub relative_tolerance: f64,
    /// Give up after this many iterations (default 20 000) with [`Error::Solver`].
    pub max_iterations: usize,
}

impl Default for CgOptions {
    fn default() -> Self {
        CgOptions {
            relative_tolerance: 1e-10,
            max_iterations: 20_000,
        }
    }
}

/// What a converged CG run did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CgReport {
    /// Iterations taken.
    pub iterations: usize,
    /// Final ‖b − A·x‖ / ‖b‖, recomputed from x (not the recursively updated residual).
    pub relative_residual: f64,
}

/// Block-Jacobi preconditioner: the inverses of the diagonal blocks of the matrix's
/// supervariables (consecutive columns with identical sparsity).
#[derive(Debug, Clone)]
pub struct BlockJacobi {
    starts: Vec<usize>,
    /// Row-major inverse of each block, concatenated.
    inverses: Vec<f64>,
    offsets: Vec<usize>,
}

impl BlockJacobi {
    /// Extracts and inverts the diagonal blocks; a block that is not invertible (a zero or
    /// negative diagonal) is an error naming its first column.
    pub fn new(matrix: &CscMatrix) -> Result<Self> {
        let n = matrix.dim();
        let (col_ptr, row_idx) = (matrix.col_ptr(), matrix.row_idx());
        let column = |j: usize| &row_idx[col_ptr[j]..col_ptr[j + 1]];
        let mut starts = vec![0];
        for j in 1..n {
            // Supervariables of elasticity have at most 3 columns (one node); cap it so a
            // pathological pattern cannot create a huge dense block.
            if column(j) != column(j - 1) || j - starts[starts.len() - 1] >= 3 {
                starts.push(j);
            }
        }
        starts.push(n);
        let mut inverses = Vec::with_capacity(3 * n);
        let mut offsets = Vec::with_capacity(starts.len());
        for g in 0..starts.len() - 1 {
            let (lo, hi) = (starts[g], starts[g + 1]);
            let size = hi - lo;
            let block =
                DMatrix::from_fn(size, size, |r, c| matrix.get(lo + r, lo + c).unwrap_or(0.0));
            let inverse = block.clone().cholesky().map(|c| c.inverse()).ok_or_else(|| {
                Error::Solver(format!(
                    "block-Jacobi preconditioner: the diagonal block at DOF {lo} is not positive definite"
                ))
            })?;
            offsets.push(inverses.len());
            for r in 0..size {
                for c in 0..size {
                    inverses.push(inverse[(r, c)]);
                }
            }
        }
        Ok(BlockJacobi {
            starts,
            inverses,
            offsets,
        })
    }

    /// z = P⁻¹·r ([`Error::DimensionMismatch`] unless both have the matrix's dimension).
    pub fn apply(&self, r: &[f64], z: &mut [f64]) -> Result<()> {
        let dim = self.starts.last().copied().unwrap_or(0);
        Error::check_len("r", dim, r.len())?;
        Error::check_len("z", dim, z.len())?;
        self.apply_unchecked(r, z);
        Ok(())
    }

    fn apply_unchecked(&self, r: &[f64], z: &mut [f64]) {
        for g in 0..self.starts.len() - 1 {
            let (lo, hi) = (self.starts[g], self.starts[g + 1]);
            let size = hi - lo;
            let inverse = &self.inverses[self.offsets[g]..self.offsets[g] + size * size];
            for i in 0..size {
                z[lo + i] = (0..size).map(|j| inverse[i * size + j] * r[lo + j]).sum();
            }
        }
    }
}

/// Solves A·x = b for symmetric positive definite A by preconditioned conjugate gradients,
/// starting from the `x` given (use zeros without a better guess).
pub fn conjugate_gradient(
    matrix: &CscMatrix,
    preconditioner: &BlockJacobi,
    rhs: &[f64],
    x: &mut [f64],
    options: CgOptions,
) -> Result<CgReport> {
    let n = matrix.dim();
    if rhs.len() != n || x.len() != n {
        return Err(Error::invalid_parameter(
            "conjugate gradient vectors",
            format!("lengths {} and {}", rhs.len(), x.len()),
            format!("must equal the matrix dimension {n}"),
        ));
    }
    if !(options.relative_tolerance > 0.0 && options.relative_tolerance.is_finite()) {
        return Err(Error::invalid_parameter(
            "relative_tolerance",
            options.relative_tolerance,
            "must be finite and > 0",
        ));
    }
    let rhs_norm = dot(rhs, rhs).sqrt();
    if rhs_norm == 0.0 {
        x.fill(0.0);
        return Ok(CgReport {
            iterations: 0,
            relative_residual: 0.0,
        });
    }
    let mut residual = vec![0.0; n];
    matrix.product_into(x, &mut residual);
    residual
        .par_iter_mut()
        .zip(rhs)
        .for_each(|(r, b)| *r = b - *r);
    let mut z = vec![0.0; n];
    preconditioner.apply(&residual, &mut z)?;
    let mut direction = z.clone();
    let mut product = vec![0.0; n];
    let mut rz = dot(&residual, &z);
    let target = options.relative_tolerance * rhs_norm;
    let mut replacements = 0;
    for iteration in 1..=options.max_iterations {
        matrix.product_into(&direction, &mut product);
        let curvature = dot(&direction, &product);
        if curvature.is_nan() || curvature <= 0.0 {
            return Err(Error::Solver(format!(
                "conjugate gradient: non-positive curvature {curvature:e} at iteration {iteration}; \
                 the matrix is not positive definite (unconstrained body or inverted elements?)"
            )));
        }
        let alpha = rz / curvature;
        x.par_iter_mut()
            .zip(&direction)
            .for_each(|(x, p)| *x += alpha * p);
        residual
            .par_iter_mut()
            .zip(&product)
            .for_each(|(r, q)| *r -= alpha * q);
        if dot(&residual, &residual).sqrt() <= target {
            // Confirm with the true residual: the recursive one drifts in floating point.
            matrix.product_into(x, &mut product);
            let true_residual = product
                .iter()
                .zip(rhs)
                .map(|(ax, b)| (b - ax) * (b - ax))
                .sum::<f64>()
                .sqrt()
                / rhs_norm;
            if true_residual <= 10.0 * options.relative_tolerance {
                return Ok(CgReport {
                    iterations: iteration,
                    relative_residual: true_residual,
                });
            }
            // The recursive residual has drifted below what the iterate achieves: replace it.
            // If that keeps happening, the tolerance is below the attainable accuracy
            // (≈ machine epsilon × condition number) and more iterations will not help.
            replacements += 1;
            if replacements > 20 {
                return Err(Error::Solver(format!(
                    "conjugate gradient stagnated at relative residual {true_residual:e} after {iteration} \
                     iterations; the tolerance {:e} is below the accuracy this matrix's conditioning allows",
                    options.relative_tolerance
                )));
            }
            residual
                .par_iter_mut()
                .zip(&product)
                .zip(rhs)
                .for_each(|((r, ax), b)| *r = b - ax);
        }
        preconditioner.apply(&residual, &mut z)?;
        let rz_next = dot(&residual, &z);
        let beta = rz_next / rz;
        rz = rz_next;
        direction
            .par_iter_mut()
            .zip(&z)
            .for_each(|(p, z)| *p = z + beta * *p);
    }
    Err(Error::Solver(format!(
        "conjugate gradient did not reach the relative residual {:e} in {} iterations",
        options.relative_tolerance, options.max_iterations
    )))
}

/// Dot product over fixed chunks, summed in order: the same bits whatever the thread count.
fn dot(a: &[f64], b: &[f64]) -> f64 {
    const CHUNK: usize = 8192;
    let partial: Vec<f64> = a
        .par_chunks(CHUNK)
        .zip(b.par_chunks(CHUNK))
        .map(|(x, y)| x.iter().zip(y).map(|(p, q)| p * q).sum::<f64>())
        .collect();
    partial.iter().sum()
}
