//! Preconditioned conjugate gradients, for systems whose Cholesky factor would not fit in
//! memory.
//!
//! Three preconditioners:
//! - block Jacobi on the supervariables of the matrix (the free DOFs of one node, a 1×1 to 3×3
//!   block): cheap, parallel, and for elasticity clearly better than point Jacobi because it
//!   captures the coupling of a node's three directions; enough for M + dt²K;
//! - incomplete Cholesky IC(0) with a diagonal shift: 3–4× fewer iterations than block Jacobi
//!   on stiffness matrices, but on slender-beam stiffness matrices (κ ~ 1e8) still hundreds to
//!   thousands of iterations, growing with the mesh;
//! - smoothed-aggregation algebraic multigrid ([`crate::amg`]) with the rigid-body modes: an
//!   iteration count nearly independent of the mesh (`benches/preconditioners.rs`), the
//!   default of the iterative path.

pub use crate::preconditioner::Preconditioner;
use nalgebra::DMatrix;
use rayon::prelude::*;

use crate::amg::{DofGeometry, SmoothedAggregation};
use crate::error::{Error, Result};
use crate::sparse::CscMatrix;

/// Stopping rule of [`conjugate_gradient`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CgOptions {
    /// Stop when ‖b − A·x‖ ≤ tolerance · ‖b‖ (default 1e-10), or when the residual is within
    /// 10× the rounding floor ε·‖|A|·|x|‖ if that is higher: on large slender-beam stiffness
    /// matrices (κ ~ 1e8) it is (ε·‖|A|·|x|‖/‖b‖ = 1.3e-9 at 69k DOFs, where the direct solve's
    /// residual is 6.6e-10).
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
        let starts = crate::sparse::supervariable_starts(matrix);
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

/// Which preconditioner the iterative path of a [`LinearSolver`](crate::linear_solver::LinearSolver) builds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum PreconditionerKind {
    /// [`BlockJacobi`]: parallel and cheapest to build; enough for M + dt²K.
    BlockJacobi,
    /// [`IncompleteCholesky`] IC(0): 3–4× fewer iterations than block Jacobi on stiffness
    /// matrices (measured by `benches/preconditioners.rs`), sequential sweeps.
    IncompleteCholesky,
    /// [`SmoothedAggregation`] algebraic multigrid with the
    /// rigid-body modes (given a [`DofGeometry`]; the translations
    /// without): iteration counts nearly independent of the mesh, the default.
    #[default]
    SmoothedAggregation,
}

impl PreconditionerKind {
    /// Builds this preconditioner for `matrix` (smoothed aggregation without geometry: the
    /// translations only).
    pub fn build(self, matrix: &CscMatrix) -> Result<Box<dyn Preconditioner>> {
        self.build_with_geometry(matrix, None)
    }

    /// Builds this preconditioner for `matrix`; smoothed aggregation takes its rigid-body
    /// modes from `geometry` (one entry per row of `matrix`), the others ignore it.
    pub fn build_with_geometry(
        self,
        matrix: &CscMatrix,
        geometry: Option<&DofGeometry>,
    ) -> Result<Box<dyn Preconditioner>> {
        Ok(match self {
            PreconditionerKind::BlockJacobi => Box::new(BlockJacobi::new(matrix)?),
            PreconditionerKind::IncompleteCholesky => Box::new(IncompleteCholesky::new(matrix)?),
            PreconditionerKind::SmoothedAggregation => {
                Box::new(SmoothedAggregation::new(matrix, geometry)?)
            }
        })
    }
}

impl Preconditioner for BlockJacobi {
    fn dim(&self) -> usize {
        self.starts.last().copied().unwrap_or(0)
    }

    fn apply(&self, r: &[f64], z: &mut [f64]) -> Result<()> {
        BlockJacobi::apply(self, r, z)
    }
}

/// Incomplete Cholesky IC(0) with a diagonal shift: L·Lᵀ ≈ A + α·diag(A), L on the pattern of
/// A's lower triangle (no fill).
///
/// The factorization drops every update that falls outside A's pattern. Elasticity matrices are
/// not M-matrices, so IC(0) can meet a non-positive pivot; the shift α is then raised (0, then
/// 1e-4, doubling) until it succeeds (Manteuffel's remedy). Applying it is one forward and one
/// backward sweep over nnz(L), sequential. On stiffness matrices it captures the coupling that
/// block Jacobi misses, and CG needs several times fewer iterations (measured in the scale study).
#[derive(Debug, Clone)]
pub struct IncompleteCholesky {
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    /// L by columns, the diagonal first in each.
    values: Vec<f64>,
    shift: f64,
}

impl IncompleteCholesky {
    /// Factors A's lower triangle; an error if A has a non-positive diagonal entry (then no
    /// shift can help: the matrix is not positive definite) or if even α = 1 fails.
    pub fn new(matrix: &CscMatrix) -> Result<Self> {
        let n = matrix.dim();
        let (col_ptr, row_idx, values) = (matrix.col_ptr(), matrix.row_idx(), matrix.values());
        let mut lower_ptr = Vec::with_capacity(n + 1);
        let mut lower_rows = Vec::with_capacity(matrix.nnz() / 2 + n);
        let mut lower_values = Vec::with_capacity(matrix.nnz() / 2 + n);
        lower_ptr.push(0);
        for j in 0..n {
            let start = lower_rows.len();
            for k in col_ptr[j]..col_ptr[j + 1] {
                if row_idx[k] >= j {
                    lower_rows.push(row_idx[k]);
                    lower_values.push(values[k]);
                }
            }
            if lower_rows.get(start) != Some(&j)
                || lower_values[start].partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater)
            {
                return Err(Error::Solver(format!(
                    "incomplete Cholesky: diagonal entry {j} is missing, zero, negative or NaN; \
                     the matrix is not positive definite"
                )));
            }
            lower_ptr.push(lower_rows.len());
        }
        let mut factor = IncompleteCholesky {
            col_ptr: lower_ptr,
            row_idx: lower_rows,
            values: Vec::new(),
            shift: 0.0,
        };
        let mut shift = 0.0;
        while shift <= 1.0 {
            factor.values.clone_from(&lower_values);
            factor.shift = shift;
            if factor.factorize() {
                return Ok(factor);
            }
            shift = if shift == 0.0 { 1e-4 } else { 2.0 * shift };
        }
        Err(Error::Solver(
            "incomplete Cholesky failed even with the diagonal shifted by 100 %".into(),
        ))
    }

    /// The diagonal shift α that made the factorization succeed.
    pub fn shift(&self) -> f64 {
        self.shift
    }

    /// Right-looking IC(0) in place; false on a non-positive pivot.
    fn factorize(&mut self) -> bool {
        let (col_ptr, row_idx, values) = (&self.col_ptr, &self.row_idx, &mut self.values);
        let n = col_ptr.len() - 1;
        if self.shift > 0.0 {
            for j in 0..n {
                values[col_ptr[j]] *= 1.0 + self.shift;
            }
        }
        for k in 0..n {
            let (start, end) = (col_ptr[k], col_ptr[k + 1]);
            let pivot = values[start];
            if !(pivot > 0.0 && pivot.is_finite()) {
                return false;
            }
            let diagonal = pivot.sqrt();
            values[start] = diagonal;
            for p in start + 1..end {
                values[p] /= diagonal;
            }
            // Column j > k gets −L[i,k]·L[j,k] at every row i ≥ j that its pattern holds.
            for p in start + 1..end {
                let j = row_idx[p];
                let l_jk = values[p];
                let mut r = col_ptr[j];
                let r_end = col_ptr[j + 1];
                for q in p..end {
                    let i = row_idx[q];
                    while r < r_end && row_idx[r] < i {
                        r += 1;
                    }
                    if r == r_end {
                        break;
                    }
                    if row_idx[r] == i {
                        values[r] -= values[q] * l_jk;
                    }
                }
            }
        }
        true
    }

    /// z = (L·Lᵀ)⁻¹·r ([`Error::DimensionMismatch`] unless both have the matrix's dimension).
    pub fn apply(&self, r: &[f64], z: &mut [f64]) -> Result<()> {
        let n = self.col_ptr.len() - 1;
        Error::check_len("r", n, r.len())?;
        Error::check_len("z", n, z.len())?;
        z.copy_from_slice(r);
        // L·y = r, by columns.
        for j in 0..n {
            let (start, end) = (self.col_ptr[j], self.col_ptr[j + 1]);
            let y = z[j] / self.values[start];
            z[j] = y;
            for p in start + 1..end {
                z[self.row_idx[p]] -= self.values[p] * y;
            }
        }
        // Lᵀ·z = y: row j of Lᵀ is column j of L.
        for j in (0..n).rev() {
            let (start, end) = (self.col_ptr[j], self.col_ptr[j + 1]);
            let mut sum = z[j];
            for p in start + 1..end {
                sum -= self.values[p] * z[self.row_idx[p]];
            }
            z[j] = sum / self.values[start];
        }
        Ok(())
    }
}

impl Preconditioner for IncompleteCholesky {
    fn dim(&self) -> usize {
        self.col_ptr.len() - 1
    }

    fn apply(&self, r: &[f64], z: &mut [f64]) -> Result<()> {
        IncompleteCholesky::apply(self, r, z)
    }
}

/// Solves A·x = b for symmetric positive definite A by preconditioned conjugate gradients,
/// starting from the `x` given (use zeros without a better guess).
pub fn conjugate_gradient(
    matrix: &CscMatrix,
    preconditioner: &dyn Preconditioner,
    rhs: &[f64],
    x: &mut [f64],
    options: CgOptions,
) -> Result<CgReport> {
    Error::check_len(
        "preconditioner dimension",
        matrix.dim(),
        preconditioner.dim(),
    )?;
    conjugate_gradient_with(
        matrix,
        &mut |r, z| preconditioner.apply(r, z),
        rhs,
        x,
        options,
    )
}

/// z = P⁻¹·r as a function of (r, z): a preconditioner that needs mutable scratch.
pub type ApplyPreconditioner<'a> = dyn FnMut(&[f64], &mut [f64]) -> Result<()> + 'a;

/// [`conjugate_gradient`] with the preconditioner given as a function z = P⁻¹·r that may keep
/// mutable scratch (a Cholesky factor of another matrix, whose triangular solves reuse their
/// workspace). P must be symmetric positive definite and `apply` must fill all of z; the
/// caller checks its dimension.
pub fn conjugate_gradient_with(
    matrix: &CscMatrix,
    apply: &mut ApplyPreconditioner<'_>,
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
    apply(&residual, &mut z)?;
    let mut direction = z.clone();
    let mut product = vec![0.0; n];
    let mut rz = dot(&residual, &z);
    let target = options.relative_tolerance * rhs_norm;
    let mut replacements = 0;
    for iteration in 1..=options.max_iterations {
        // A caller's Ctrl-C between iterations (x is the caller's buffer, left part-way: the
        // callers copy it out only on success).
        crate::interrupt::poll(|| format!("conjugate gradient iteration {iteration}"))?;
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
            // Near ε·‖|A|·|x|‖ the computed residual is rounding noise (a backward-stable
            // direct solve lands there too: 6.6e-10 on the 80×16×16 beam, where this bound is
            // 1.3e-9), so a tolerance beneath it is met as well as floating point allows. The
            // same factor 10 of slack as for the tolerance: CG's iterate carries the rounding
            // of all its updates (1.5e-9 there with the translations-only preconditioner).
            if true_residual <= 10.0 * options.relative_tolerance
                || true_residual <= 10.0 * rounding_floor(matrix, x) / rhs_norm
            {
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
        apply(&residual, &mut z)?;
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

/// ε·‖|A|·|x|‖: the size of the rounding error of the computed product A·x, hence the smallest
/// residual ‖b − A·x‖ that can be told apart from zero.
fn rounding_floor(matrix: &CscMatrix, x: &[f64]) -> f64 {
    let (col_ptr, row_idx, values) = (matrix.col_ptr(), matrix.row_idx(), matrix.values());
    let squares: f64 = (0..matrix.dim())
        .into_par_iter()
        .with_min_len(1024)
        .map(|j| {
            let row: f64 = (col_ptr[j]..col_ptr[j + 1])
                .map(|k| (values[k] * x[row_idx[k]]).abs())
                .sum();
            row * row
        })
        .sum();
    f64::EPSILON * squares.sqrt()
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
