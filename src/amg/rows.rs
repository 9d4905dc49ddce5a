//! Rectangular sparse matrices by rows (CSR) and the products the multigrid setup needs: the
//! parallel Gustavson product C = A·B, the transpose, and the sum α·A + β·B.

use rayon::prelude::*;

use crate::error::{Error, Result};
use crate::sparse::CscMatrix;

/// A rectangular sparse matrix in compressed sparse row form, column indices sorted in each row
/// (prolongators P, their transposes, and intermediate products of the multigrid setup).
#[derive(Debug, Clone, PartialEq)]
pub struct RowMatrix {
    ncols: usize,
    row_ptr: Vec<usize>,
    col_idx: Vec<usize>,
    values: Vec<f64>,
}

/// Borrowed rows of a matrix: `ptr` of length nrows + 1, then column indices and values.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Rows<'a> {
    pub ptr: &'a [usize],
    pub idx: &'a [usize],
    pub val: &'a [f64],
}

impl<'a> Rows<'a> {
    /// The rows of a symmetric [`CscMatrix`]: its column j is its row j.
    pub fn of_symmetric(matrix: &'a CscMatrix) -> Self {
        Rows {
            ptr: matrix.col_ptr(),
            idx: matrix.row_idx(),
            val: matrix.values(),
        }
    }

    fn nrows(&self) -> usize {
        self.ptr.len() - 1
    }
}

/// Rows per parallel task: large enough that a task's dense marker (one entry per column of the
/// result) is amortised, small enough to balance two to a few dozen threads.
fn chunk_rows(nrows: usize) -> usize {
    (nrows / 64).clamp(256, 16_384)
}

impl RowMatrix {
    /// A matrix from its rows; indices must be in range and sorted within each row.
    pub fn new(
        ncols: usize,
        row_ptr: Vec<usize>,
        col_idx: Vec<usize>,
        values: Vec<f64>,
    ) -> Result<Self> {
        let ok_ptr = !row_ptr.is_empty()
            && row_ptr[0] == 0
            && row_ptr.windows(2).all(|w| w[0] <= w[1])
            && row_ptr.last() == Some(&col_idx.len());
        if !ok_ptr || col_idx.len() != values.len() {
            return Err(Error::invalid_parameter(
                "row_ptr",
                format!("{} pointers, {} indices", row_ptr.len(), col_idx.len()),
                "must start at 0, not decrease, and end at the number of entries (= values)",
            ));
        }
        for i in 0..row_ptr.len() - 1 {
            let row = &col_idx[row_ptr[i]..row_ptr[i + 1]];
            if row.windows(2).any(|w| w[0] >= w[1]) || row.last().is_some_and(|&c| c >= ncols) {
                return Err(Error::invalid_parameter(
                    "col_idx",
                    format!("row {i}"),
                    format!("must be strictly increasing and below {ncols}"),
                ));
            }
        }
        Ok(RowMatrix {
            ncols,
            row_ptr,
            col_idx,
            values,
        })
    }

    /// Number of rows.
    pub fn nrows(&self) -> usize {
        self.row_ptr.len() - 1
    }

    /// Number of columns.
    pub fn ncols(&self) -> usize {
        self.ncols
    }

    /// Number of stored entries.
    pub fn nnz(&self) -> usize {
        self.values.len()
    }

    /// Row pointers (length nrows + 1).
    pub fn row_ptr(&self) -> &[usize] {
        &self.row_ptr
    }

    /// Column indices, sorted within each row.
    pub fn col_idx(&self) -> &[usize] {
        &self.col_idx
    }

    /// Stored values, aligned with [`col_idx`](Self::col_idx).
    pub fn values(&self) -> &[f64] {
        &self.values
    }

    pub(crate) fn rows(&self) -> Rows<'_> {
        Rows {
            ptr: &self.row_ptr,
            idx: &self.col_idx,
            val: &self.values,
        }
    }

    /// y = M·x ([`Error::DimensionMismatch`] unless x has ncols and y nrows entries).
    pub fn mul_vec(&self, x: &[f64], y: &mut [f64]) -> Result<()> {
        Error::check_len("x", self.ncols, x.len())?;
        Error::check_len("y", self.nrows(), y.len())?;
        self.product_into(x, y, false);
        Ok(())
    }

    /// y = M·x, or y += M·x with `accumulate`; rows in parallel, each a sequential sum, so the
    /// bits do not depend on the thread count.
    pub(crate) fn product_into(&self, x: &[f64], y: &mut [f64], accumulate: bool) {
        let row = |(i, yi): (usize, &mut f64)| {
            let mut sum = 0.0;
            for k in self.row_ptr[i]..self.row_ptr[i + 1] {
                sum += self.values[k] * x[self.col_idx[k]];
            }
            if accumulate {
                *yi += sum;
            } else {
                *yi = sum;
            }
        };
        if self.nnz() < 50_000 {
            y.iter_mut().enumerate().for_each(row);
        } else {
            y.par_iter_mut()
                .enumerate()
                .with_min_len(1024)
                .for_each(row);
        }
    }

    /// Mᵀ by a counting sort over the columns, O(nnz).
    pub fn transpose(&self) -> RowMatrix {
        let mut counts = vec![0usize; self.ncols + 1];
        for &c in &self.col_idx {
            counts[c + 1] += 1;
        }
        for c in 0..self.ncols {
            counts[c + 1] += counts[c];
        }
        let row_ptr = counts.clone();
        let mut next = counts;
        let mut col_idx = vec![0; self.nnz()];
        let mut values = vec![0.0; self.nnz()];
        // Rows visited in order, so the transposed rows come out sorted.
        for i in 0..self.nrows() {
            for k in self.row_ptr[i]..self.row_ptr[i + 1] {
                let c = self.col_idx[k];
                col_idx[next[c]] = i;
                values[next[c]] = self.values[k];
                next[c] += 1;
            }
        }
        RowMatrix {
            ncols: self.nrows(),
            row_ptr,
            col_idx,
            values,
        }
    }

    /// The same matrix as a symmetric [`CscMatrix`] (for a square matrix whose pattern and
    /// values are symmetric, its rows are its columns).
    pub(crate) fn into_symmetric_csc(self) -> Result<CscMatrix> {
        use faer::sparse::SymbolicSparseColMat;
        let n = self.nrows();
        if n != self.ncols {
            return Err(Error::Solver(format!(
                "multigrid: a coarse operator is {n}×{}, not square",
                self.ncols
            )));
        }
        let pattern = SymbolicSparseColMat::new_checked(n, n, self.row_ptr, None, self.col_idx);
        CscMatrix::from_values(std::sync::Arc::new(pattern), self.values)
    }

    /// Averages the matrix with its transpose, M ← (M + Mᵀ)/2, so that Galerkin operators are
    /// symmetric to the last bit; the pattern must already be symmetric (Pᵀ·A·P's is).
    pub(crate) fn symmetrize(&mut self) -> Result<()> {
        let transpose = self.transpose();
        if transpose.row_ptr != self.row_ptr || transpose.col_idx != self.col_idx {
            return Err(Error::Solver(
                "multigrid: a coarse operator has an unsymmetric pattern".into(),
            ));
        }
        self.values
            .par_iter_mut()
            .zip(&transpose.values)
            .for_each(|(a, b)| *a = 0.5 * (*a + b));
        Ok(())
    }
}

/// C = A·B by Gustavson's row-by-row algorithm: row i of C accumulates A[i,k]·B[k,:] in a dense
/// marker indexed by column; rows in parallel chunks, each chunk with its own marker.
pub(crate) fn multiply(a: Rows<'_>, b: &RowMatrix) -> RowMatrix {
    let ncols = b.ncols;
    let nrows = a.nrows();
    let chunk = chunk_rows(nrows);
    let starts: Vec<usize> = (0..nrows).step_by(chunk.max(1)).collect();
    let pieces: Vec<(Vec<usize>, Vec<usize>, Vec<f64>)> = starts
        .par_iter()
        .map_init(
            || vec![usize::MAX; ncols],
            |marker, &lo| {
                let hi = (lo + chunk).min(nrows);
                let mut lengths = Vec::with_capacity(hi - lo);
                let mut cols = Vec::new();
                let mut vals = Vec::new();
                let mut sorted: Vec<(usize, f64)> = Vec::new();
                for i in lo..hi {
                    let start = cols.len();
                    for k in a.ptr[i]..a.ptr[i + 1] {
                        let (row, a_ik) = (a.idx[k], a.val[k]);
                        for q in b.row_ptr[row]..b.row_ptr[row + 1] {
                            let c = b.col_idx[q];
                            let at = marker[c];
                            if at != usize::MAX && at >= start && at < cols.len() && cols[at] == c {
                                vals[at] += a_ik * b.values[q];
                            } else {
                                marker[c] = cols.len();
                                cols.push(c);
                                vals.push(a_ik * b.values[q]);
                            }
                        }
                    }
                    sorted.clear();
                    sorted.extend(
                        cols[start..]
                            .iter()
                            .copied()
                            .zip(vals[start..].iter().copied()),
                    );
                    sorted.sort_unstable_by_key(|&(c, _)| c);
                    for (slot, &(c, v)) in sorted.iter().enumerate() {
                        cols[start + slot] = c;
                        vals[start + slot] = v;
                    }
                    lengths.push(cols.len() - start);
                }
                (lengths, cols, vals)
            },
        )
        .collect();
    concatenate(ncols, nrows, pieces)
}

/// C = α·A + β·B for matrices of one shape, row patterns merged.
pub(crate) fn add(alpha: f64, a: &RowMatrix, beta: f64, b: &RowMatrix) -> RowMatrix {
    let nrows = a.nrows();
    let chunk = chunk_rows(nrows);
    let starts: Vec<usize> = (0..nrows).step_by(chunk.max(1)).collect();
    let pieces: Vec<(Vec<usize>, Vec<usize>, Vec<f64>)> = starts
        .par_iter()
        .map(|&lo| {
            let hi = (lo + chunk).min(nrows);
            let (mut lengths, mut cols, mut vals) = (Vec::new(), Vec::new(), Vec::new());
            for i in lo..hi {
                let start = cols.len();
                let (mut p, pe) = (a.row_ptr[i], a.row_ptr[i + 1]);
                let (mut q, qe) = (b.row_ptr[i], b.row_ptr[i + 1]);
                while p < pe || q < qe {
                    let ca = if p < pe { a.col_idx[p] } else { usize::MAX };
                    let cb = if q < qe { b.col_idx[q] } else { usize::MAX };
                    let c = ca.min(cb);
                    let mut v = 0.0;
                    if ca == c {
                        v += alpha * a.values[p];
                        p += 1;
                    }
                    if cb == c {
                        v += beta * b.values[q];
                        q += 1;
                    }
                    cols.push(c);
                    vals.push(v);
                }
                lengths.push(cols.len() - start);
            }
            (lengths, cols, vals)
        })
        .collect();
    concatenate(a.ncols, nrows, pieces)
}

/// Joins per-chunk rows; the output is reserved up front and each chunk is freed once copied,
/// so the peak is about one copy of the result.
fn concatenate(
    ncols: usize,
    nrows: usize,
    pieces: Vec<(Vec<usize>, Vec<usize>, Vec<f64>)>,
) -> RowMatrix {
    let nnz: usize = pieces.iter().map(|p| p.1.len()).sum();
    let mut row_ptr = Vec::with_capacity(nrows + 1);
    row_ptr.push(0);
    let mut col_idx = Vec::with_capacity(nnz);
    let mut values = Vec::with_capacity(nnz);
    for (lengths, cols, vals) in pieces {
        for length in lengths {
            row_ptr.push(row_ptr[row_ptr.len() - 1] + length);
        }
        col_idx.extend_from_slice(&cols);
        values.extend_from_slice(&vals);
    }
    RowMatrix {
        ncols,
        row_ptr,
        col_idx,
        values,
    }
}
