//! Symmetric sparse matrices in compressed sparse column form, both triangles stored.
//!
//! Both triangles are kept so that a product A·x is one pass over the columns and the restriction
//! to free DOFs is a plain gather; faer's Cholesky reads the lower triangle only.

use std::sync::Arc;

use faer::sparse::{SparseColMatRef, SymbolicSparseColMat};

use crate::error::{Error, Result};

/// A square sparse matrix (CSC, sorted row indices, both triangles of a symmetric matrix stored)
/// whose pattern may be shared with other matrices: values are refilled in place, and matrices on
/// the same pattern combine entry by entry ([`CscMatrix::set_linear_combination`]).
#[derive(Debug, Clone)]
pub struct CscMatrix {
    pattern: Arc<SymbolicSparseColMat<usize>>,
    values: Vec<f64>,
}

/// One chunk of each of the three outputs of [`CscMatrix::product3_into`].
type ChunkOf3<'a> = (&'a mut [f64], (&'a mut [f64], &'a mut [f64]));

impl CscMatrix {
    /// A matrix of zeros on `pattern`, which must be square.
    pub fn zeros(pattern: Arc<SymbolicSparseColMat<usize>>) -> Result<Self> {
        let nnz = pattern.row_idx().len();
        CscMatrix::from_values(pattern, vec![0.0; nnz])
    }

    /// A matrix on `pattern` (square) with the given values (one per stored entry).
    pub fn from_values(
        pattern: Arc<SymbolicSparseColMat<usize>>,
        values: Vec<f64>,
    ) -> Result<Self> {
        if pattern.nrows() != pattern.ncols() {
            return Err(Error::invalid_parameter(
                "pattern",
                format!("{}×{}", pattern.nrows(), pattern.ncols()),
                "must be square",
            ));
        }
        if values.len() != pattern.row_idx().len() {
            return Err(Error::invalid_parameter(
                "values.len()",
                values.len(),
                format!("must equal the pattern's nnz {}", pattern.row_idx().len()),
            ));
        }
        Ok(CscMatrix { pattern, values })
    }

    /// Number of rows (= columns).
    #[inline]
    pub fn dim(&self) -> usize {
        self.pattern.ncols()
    }

    /// Number of stored entries (both triangles).
    #[inline]
    pub fn nnz(&self) -> usize {
        self.values.len()
    }

    /// The shared pattern.
    #[inline]
    pub fn pattern(&self) -> &Arc<SymbolicSparseColMat<usize>> {
        &self.pattern
    }

    /// Column pointers (length dim + 1).
    #[inline]
    pub fn col_ptr(&self) -> &[usize] {
        self.pattern.col_ptr()
    }

    /// Row indices, sorted within each column.
    #[inline]
    pub fn row_idx(&self) -> &[usize] {
        self.pattern.row_idx()
    }

    /// Stored values, aligned with [`row_idx`](Self::row_idx).
    #[inline]
    pub fn values(&self) -> &[f64] {
        &self.values
    }

    /// Mutable stored values (the pattern stays fixed).
    #[inline]
    pub fn values_mut(&mut self) -> &mut [f64] {
        &mut self.values
    }

    /// A faer view of this matrix, for factorizations and faer's own kernels.
    pub fn as_faer(&self) -> SparseColMatRef<'_, usize, f64> {
        SparseColMatRef::new(SymbolicSparseColMat::as_ref(&self.pattern), &self.values)
    }

    /// Entry (row, col), zero where the pattern has no entry.
    ///
    /// Returns `None` if `row` or `col` is out of range.
    #[inline]
    pub fn get(&self, row: usize, col: usize) -> Option<f64> {
        if row >= self.dim() || col >= self.dim() {
            return None;
        }
        let range = self.col_ptr()[col]..self.col_ptr()[col + 1];
        Some(
            self.row_idx()[range.clone()]
                .binary_search(&row)
                .map_or(0.0, |k| self.values[range.start + k]),
        )
    }

    /// y = A·x, rows computed in parallel on rayon's pool for large matrices.
    ///
    /// Each yᵢ is one sequential sum over column i (the matrix is symmetric, so column i is
    /// row i), so the result is the same bit for bit whatever the number of threads.
    ///
    /// [`Error::DimensionMismatch`] if `x` or `y` does not have length [`dim`](Self::dim).
    pub fn mul_vec(&self, x: &[f64], y: &mut [f64]) -> Result<()> {
        Error::check_len("x", self.dim(), x.len())?;
        Error::check_len("y", self.dim(), y.len())?;
        self.product_into(x, y);
        Ok(())
    }

    /// y = A·x for callers whose vectors have length `dim()` by construction (panics otherwise).
    #[doc(hidden)]
    pub fn product_into(&self, x: &[f64], y: &mut [f64]) {
        use rayon::prelude::*;
        let (col_ptr, row_idx, values) = (self.col_ptr(), self.row_idx(), &self.values);
        let row = |(j, yj): (usize, &mut f64)| {
            let mut sum = 0.0;
            for k in col_ptr[j]..col_ptr[j + 1] {
                sum += values[k] * x[row_idx[k]];
            }
            *yj = sum;
        };
        // Below ~1e5 stored entries the fork-join overhead outweighs the gain.
        if self.nnz() < 100_000 {
            y.iter_mut().enumerate().for_each(row);
        } else {
            y.par_iter_mut()
                .enumerate()
                .with_min_len(1024)
                .for_each(row);
        }
    }

    /// yₖ = A·xₖ for three vectors in one read of the matrix: each entry loaded once serves
    /// all three sums. Each yₖ gets the bits [`product_into`](Self::product_into) gives it
    /// (the same sequential sum over each column, in the same order), whatever the number of
    /// threads; a product that is memory-bound costs about one product instead of three.
    /// For callers whose vectors have length `dim()` by construction (panics otherwise).
    #[doc(hidden)]
    pub fn product3_into(&self, x: [&[f64]; 3], y: [&mut [f64]; 3]) {
        use rayon::prelude::*;
        const CHUNK: usize = 1024;
        let (col_ptr, row_idx, values) = (self.col_ptr(), self.row_idx(), &self.values);
        let chunk = |(c, (y0, (y1, y2))): (usize, ChunkOf3<'_>)| {
            for i in 0..y0.len() {
                let j = c * CHUNK + i;
                let mut sums = [0.0; 3];
                for k in col_ptr[j]..col_ptr[j + 1] {
                    let (a, r) = (values[k], row_idx[k]);
                    sums[0] += a * x[0][r];
                    sums[1] += a * x[1][r];
                    sums[2] += a * x[2][r];
                }
                (y0[i], y1[i], y2[i]) = (sums[0], sums[1], sums[2]);
            }
        };
        let [y0, y1, y2] = y;
        // The threshold of `product_into`: below it the fork-join overhead outweighs the gain.
        if self.nnz() < 100_000 {
            let pairs = y1.chunks_mut(CHUNK).zip(y2.chunks_mut(CHUNK));
            y0.chunks_mut(CHUNK).zip(pairs).enumerate().for_each(chunk);
        } else {
            let pairs = y1.par_chunks_mut(CHUNK).zip(y2.par_chunks_mut(CHUNK));
            y0.par_chunks_mut(CHUNK)
                .zip(pairs)
                .enumerate()
                .for_each(chunk);
        }
    }

    /// The same matrix without its stored entries that are exactly zero, on a pattern of its
    /// own: for products only. A consistent mass on the stiffness pattern stores the zero
    /// couplings between axes, two thirds of its entries, which a product would read for
    /// nothing. Each column keeps its entries in order, so for a finite x its
    /// [`product_into`](Self::product_into) gives the same bits as this matrix's: every skipped
    /// term is ±0, and a sum that starts at +0 is never −0 (round to nearest gives
    /// a + (−a) = +0), so adding ±0 to it changes nothing. (For an x with an infinity or a NaN
    /// the skipped 0·x would have been NaN.)
    pub fn without_zeros(&self) -> Result<CscMatrix> {
        let n = self.dim();
        let (col_ptr, row_idx) = (self.col_ptr(), self.row_idx());
        let mut pointers = Vec::with_capacity(n + 1);
        let (mut rows, mut values) = (Vec::new(), Vec::new());
        pointers.push(0);
        for j in 0..n {
            for k in col_ptr[j]..col_ptr[j + 1] {
                if self.values[k] != 0.0 {
                    rows.push(row_idx[k]);
                    values.push(self.values[k]);
                }
            }
            pointers.push(rows.len());
        }
        let pattern = SymbolicSparseColMat::new_checked(n, n, pointers, None, rows);
        CscMatrix::from_values(Arc::new(pattern), values)
    }

    /// A·x as a new vector ([`Error::DimensionMismatch`] if `x.len() != dim()`).
    pub fn mul(&self, x: &[f64]) -> Result<Vec<f64>> {
        let mut y = vec![0.0; self.dim()];
        self.mul_vec(x, &mut y)?;
        Ok(y)
    }

    /// xᵀ·A·x ([`Error::DimensionMismatch`] if `x.len() != dim()`).
    pub fn quadratic_form(&self, x: &[f64]) -> Result<f64> {
        Ok(self.mul(x)?.iter().zip(x).map(|(a, b)| a * b).sum())
    }

    /// Sets self = a·A + b·B entry-wise; all three must share one pattern (same `Arc`).
    pub fn set_linear_combination(
        &mut self,
        a: f64,
        lhs: &CscMatrix,
        b: f64,
        rhs: &CscMatrix,
    ) -> Result<()> {
        if !Arc::ptr_eq(&self.pattern, &lhs.pattern) || !Arc::ptr_eq(&self.pattern, &rhs.pattern) {
            return Err(Error::invalid_parameter(
                "matrix pattern",
                "different patterns",
                "a linear combination needs matrices on one shared pattern",
            ));
        }
        for ((out, x), y) in self.values.iter_mut().zip(&lhs.values).zip(&rhs.values) {
            *out = a * x + b * y;
        }
        Ok(())
    }

    /// Adds `diagonal[i]` to entry (i, i) for every i. Every diagonal entry must be in the
    /// pattern (it is for assembled stiffness and mass patterns).
    pub fn add_diagonal(&mut self, scale: f64, diagonal: &[f64]) -> Result<()> {
        if diagonal.len() != self.dim() {
            return Err(Error::invalid_parameter(
                "diagonal.len()",
                diagonal.len(),
                format!("must equal the matrix dimension {}", self.dim()),
            ));
        }
        for (j, d) in diagonal.iter().enumerate() {
            let range = self.pattern.col_ptr()[j]..self.pattern.col_ptr()[j + 1];
            let k = self.pattern.row_idx()[range.clone()]
                .binary_search(&j)
                .map_err(|_| {
                    Error::invalid_parameter(
                        "pattern",
                        format!("column {j}"),
                        "has no diagonal entry",
                    )
                })?;
            self.values[range.start + k] += scale * d;
        }
        Ok(())
    }
}

/// Starts of the matrix's supervariables (runs of up to three consecutive columns with identical
/// patterns: a node's DOFs in elasticity), followed by `dim()`.
pub(crate) fn supervariable_starts(matrix: &CscMatrix) -> Vec<usize> {
    let n = matrix.dim();
    let (col_ptr, row_idx) = (matrix.col_ptr(), matrix.row_idx());
    let column = |j: usize| &row_idx[col_ptr[j]..col_ptr[j + 1]];
    let mut starts = vec![0];
    for j in 1..n {
        // Capped at 3 columns (one node) so a pathological pattern cannot make a huge block.
        if column(j) != column(j - 1) || j - starts[starts.len() - 1] >= 3 {
            starts.push(j);
        }
    }
    starts.push(n);
    starts
}
