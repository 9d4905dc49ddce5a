//! Rectangular sparse matrices by rows (CSR) and the products the multigrid setup needs: the
//! parallel Gustavson product, fused into the triple product α·E + β·X·Y·Z that never stores
//! X·Y whole (with an optional addend α·E), the transpose, and the transpose product y = Mᵀ·x of the
//! restriction (so that Pᵀ need not be stored beside P).
//!
//! Column indices are `u32` (4 bytes instead of 8: a quarter of each stored entry's 16 bytes),
//! which bounds the number of columns by [`MAX_COLUMNS`]; the finest matrix, a [`CscMatrix`],
//! keeps its `usize` indices and is read through [`Rows`] generically.

use std::ops::Range;

use rayon::prelude::*;

use crate::error::{Error, Result};
use crate::sparse::CscMatrix;

/// Most columns a [`RowMatrix`] can have: its column indices are `u32`.
pub const MAX_COLUMNS: usize = u32::MAX as usize;

/// A column index type of [`Rows`]: `usize` (faer's matrices) or `u32` ([`RowMatrix`]).
pub(crate) trait ColumnIndex: Copy + Send + Sync {
    fn get(self) -> usize;
}

impl ColumnIndex for usize {
    #[inline]
    fn get(self) -> usize {
        self
    }
}

impl ColumnIndex for u32 {
    #[inline]
    fn get(self) -> usize {
        self as usize
    }
}

/// A rectangular sparse matrix in compressed sparse row form, column indices sorted in each row
/// (prolongators P and intermediate products of the multigrid setup). Column indices are `u32`:
/// at most [`MAX_COLUMNS`] columns.
#[derive(Debug, Clone, PartialEq)]
pub struct RowMatrix {
    ncols: usize,
    row_ptr: Vec<usize>,
    col_idx: Vec<u32>,
    values: Vec<f64>,
}

/// Borrowed rows of a matrix: `ptr` of length nrows + 1, then column indices and values.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Rows<'a, I = u32> {
    pub ptr: &'a [usize],
    pub idx: &'a [I],
    pub val: &'a [f64],
}

impl<'a> Rows<'a, usize> {
    /// The rows of a symmetric [`CscMatrix`]: its column j is its row j.
    pub fn of_symmetric(matrix: &'a CscMatrix) -> Self {
        Rows {
            ptr: matrix.col_ptr(),
            idx: matrix.row_idx(),
            val: matrix.values(),
        }
    }
}

impl<I> Rows<'_, I> {
    fn nrows(&self) -> usize {
        self.ptr.len() - 1
    }
}

/// Rows per parallel task: large enough that a task's dense marker (one entry per column of the
/// result) is amortised, small enough to balance two to a few dozen threads.
fn chunk_rows(nrows: usize) -> usize {
    (nrows / 64).clamp(256, 16_384)
}

/// Number of columns as a checked `u32` bound ([`Error::InvalidParameter`] above
/// [`MAX_COLUMNS`]).
pub(crate) fn check_columns(what: &str, ncols: usize) -> Result<()> {
    if ncols > MAX_COLUMNS {
        return Err(Error::invalid_parameter(
            what,
            ncols,
            format!(
                "must be at most {MAX_COLUMNS}: the multigrid stores column indices as u32 \
                 (use the direct method or another preconditioner)"
            ),
        ));
    }
    Ok(())
}

/// The fixed partition of a matrix's rows behind [`RowMatrix::transpose_product_into`]: each
/// part scatters its rows' contributions into its own buffer over the range of columns the part
/// touches, and the buffers are then added in part order.
///
/// The parts depend on the matrix only (not on the thread count), so the sums, and therefore
/// the bits of the result, do not depend on the number of threads.
#[derive(Debug, Clone, Default)]
pub(crate) struct TransposePlan {
    parts: Vec<(Range<usize>, Range<usize>)>,
}

/// Buffers of a [`TransposePlan`], one per part (allocated once per level).
#[derive(Debug, Default)]
pub(crate) struct TransposeScratch {
    buffers: Vec<Vec<f64>>,
}

impl TransposePlan {
    /// Entries per part: above ~50 000 a part's work (two flops per entry) dwarfs the cost of
    /// a rayon task; 16 parts at most keep the buffers (≈ one coarse vector each when the
    /// aggregates follow the node order, as the greedy aggregation's do) small.
    const ENTRIES_PER_PART: usize = 50_000;
    const MAX_PARTS: usize = 16;

    pub(crate) fn new(matrix: &RowMatrix) -> (Self, TransposeScratch) {
        let nrows = matrix.nrows();
        let parts = (matrix.nnz() / Self::ENTRIES_PER_PART).clamp(1, Self::MAX_PARTS);
        let per_part = nrows.div_ceil(parts).max(1);
        let mut plan = TransposePlan::default();
        let mut scratch = TransposeScratch::default();
        for lo in (0..nrows).step_by(per_part) {
            let rows = lo..(lo + per_part).min(nrows);
            let entries = &matrix.col_idx[matrix.row_ptr[rows.start]..matrix.row_ptr[rows.end]];
            let cols = match (entries.iter().min(), entries.iter().max()) {
                (Some(&first), Some(&last)) => first as usize..last as usize + 1,
                _ => 0..0,
            };
            scratch.buffers.push(vec![0.0; cols.len()]);
            plan.parts.push((rows, cols));
        }
        (plan, scratch)
    }
}

impl RowMatrix {
    /// A matrix from its rows; indices must be in range and sorted within each row, and `ncols`
    /// at most [`MAX_COLUMNS`].
    pub fn new(
        ncols: usize,
        row_ptr: Vec<usize>,
        col_idx: Vec<u32>,
        values: Vec<f64>,
    ) -> Result<Self> {
        check_columns("RowMatrix columns", ncols)?;
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
            if row.windows(2).any(|w| w[0] >= w[1])
                || row.last().is_some_and(|&c| c as usize >= ncols)
            {
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

    /// An nrows × ncols matrix with no entries (ncols ≤ [`MAX_COLUMNS`], checked by callers).
    pub(crate) fn empty(nrows: usize, ncols: usize) -> Self {
        RowMatrix {
            ncols,
            row_ptr: vec![0; nrows + 1],
            col_idx: Vec::new(),
            values: Vec::new(),
        }
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
    pub fn col_idx(&self) -> &[u32] {
        &self.col_idx
    }

    /// Stored values, aligned with [`col_idx`](Self::col_idx).
    pub fn values(&self) -> &[f64] {
        &self.values
    }

    /// Bytes of the three arrays (8 per row pointer, 4 per column index, 8 per value).
    pub fn heap_bytes(&self) -> usize {
        8 * self.row_ptr.len() + 4 * self.col_idx.len() + 8 * self.values.len()
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

    /// y = Mᵀ·x ([`Error::DimensionMismatch`] unless x has nrows and y ncols entries), by a
    /// scatter over the rows: no transpose is formed.
    pub fn mul_transpose_vec(&self, x: &[f64], y: &mut [f64]) -> Result<()> {
        Error::check_len("x", self.nrows(), x.len())?;
        Error::check_len("y", self.ncols, y.len())?;
        let (plan, mut scratch) = TransposePlan::new(self);
        self.transpose_product_into(&plan, &mut scratch, x, y);
        Ok(())
    }

    /// y = M·x, or y += M·x with `accumulate`; rows in parallel, each a sequential sum, so the
    /// bits do not depend on the thread count.
    pub(crate) fn product_into(&self, x: &[f64], y: &mut [f64], accumulate: bool) {
        let row = |(i, yi): (usize, &mut f64)| {
            let mut sum = 0.0;
            for k in self.row_ptr[i]..self.row_ptr[i + 1] {
                sum += self.values[k] * x[self.col_idx[k] as usize];
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

    /// y = Mᵀ·x with the parts of `plan` (made for this matrix) scattered in parallel into
    /// `scratch`, then added into y in part order (see [`TransposePlan`]). About as fast as a
    /// product with a stored Mᵀ, without its memory.
    pub(crate) fn transpose_product_into(
        &self,
        plan: &TransposePlan,
        scratch: &mut TransposeScratch,
        x: &[f64],
        y: &mut [f64],
    ) {
        let scatter = |((rows, cols), buffer): (&(Range<usize>, Range<usize>), &mut Vec<f64>)| {
            buffer.fill(0.0);
            for i in rows.clone() {
                let xi = x[i];
                for k in self.row_ptr[i]..self.row_ptr[i + 1] {
                    buffer[self.col_idx[k] as usize - cols.start] += self.values[k] * xi;
                }
            }
        };
        if plan.parts.len() > 1 {
            plan.parts
                .par_iter()
                .zip(scratch.buffers.par_iter_mut())
                .for_each(scatter);
        } else {
            plan.parts
                .iter()
                .zip(scratch.buffers.iter_mut())
                .for_each(scatter);
        }
        y.fill(0.0);
        for ((_, cols), buffer) in plan.parts.iter().zip(&scratch.buffers) {
            y[cols.clone()]
                .iter_mut()
                .zip(buffer)
                .for_each(|(yc, b)| *yc += b);
        }
    }

    /// Mᵀ by a counting sort over the columns, O(nnz); [`Error::InvalidParameter`] if M has more
    /// than [`MAX_COLUMNS`] rows (they become Mᵀ's column indices).
    pub fn transpose(&self) -> Result<RowMatrix> {
        check_columns("RowMatrix rows (columns of the transpose)", self.nrows())?;
        let mut counts = vec![0usize; self.ncols + 1];
        for &c in &self.col_idx {
            counts[c as usize + 1] += 1;
        }
        for c in 0..self.ncols {
            counts[c + 1] += counts[c];
        }
        let row_ptr = counts.clone();
        let mut next = counts;
        let mut col_idx = vec![0u32; self.nnz()];
        let mut values = vec![0.0; self.nnz()];
        // Rows visited in order, so the transposed rows come out sorted; row indices fit in u32
        // (checked above).
        for i in 0..self.nrows() {
            for k in self.row_ptr[i]..self.row_ptr[i + 1] {
                let c = self.col_idx[k] as usize;
                col_idx[next[c]] = i as u32;
                values[next[c]] = self.values[k];
                next[c] += 1;
            }
        }
        Ok(RowMatrix {
            ncols: self.nrows(),
            row_ptr,
            col_idx,
            values,
        })
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
        let row_idx: Vec<usize> = self.col_idx.iter().map(|&c| c as usize).collect();
        drop(self.col_idx);
        let pattern = SymbolicSparseColMat::new_checked(n, n, self.row_ptr, None, row_idx);
        CscMatrix::from_values(std::sync::Arc::new(pattern), self.values)
    }

    /// Averages the matrix with its transpose, M ← (M + Mᵀ)/2, so that Galerkin operators are
    /// symmetric to the last bit; the pattern must already be symmetric (Pᵀ·A·P's is).
    pub(crate) fn symmetrize(&mut self) -> Result<()> {
        let transpose = self.transpose()?;
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

/// Rows of one chunk of a product: the length of each row, then their columns and values.
type Piece = (Vec<usize>, Vec<u32>, Vec<f64>);

/// Rows `lo..hi` of A·B by Gustavson's algorithm: row i accumulates A[i,k]·B[k,:] in a dense
/// `marker` indexed by column (one per task, length B's columns, `usize::MAX` or stale
/// positions; reused across calls), then is sorted by column.
fn multiply_rows<IA: ColumnIndex, IB: ColumnIndex>(
    a: Rows<'_, IA>,
    rows: Range<usize>,
    b: Rows<'_, IB>,
    marker: &mut [usize],
) -> Piece {
    let mut lengths = Vec::with_capacity(rows.len());
    let mut cols: Vec<u32> = Vec::new();
    let mut vals: Vec<f64> = Vec::new();
    let mut sorted: Vec<(u32, f64)> = Vec::new();
    for i in rows {
        let start = cols.len();
        for k in a.ptr[i]..a.ptr[i + 1] {
            let (row, a_ik) = (a.idx[k].get(), a.val[k]);
            for q in b.ptr[row]..b.ptr[row + 1] {
                let c = b.idx[q].get();
                let at = marker[c];
                if at != usize::MAX && at >= start && at < cols.len() && cols[at] as usize == c {
                    vals[at] += a_ik * b.val[q];
                } else {
                    marker[c] = cols.len();
                    // Cannot truncate: every caller's B has at most MAX_COLUMNS columns.
                    cols.push(c as u32);
                    vals.push(a_ik * b.val[q]);
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
}

/// Starts of the row chunks of a parallel product over `nrows` rows.
fn chunk_starts(nrows: usize) -> (Vec<usize>, usize) {
    let chunk = chunk_rows(nrows).max(1);
    ((0..nrows).step_by(chunk).collect(), chunk)
}

/// C = α·E + β·X·Y·Z, fused by chunks of X's rows: each chunk forms its rows of X·Y, multiplies
/// them by Z and adds E's rows, so X·Y (the largest intermediate of the multigrid setup: A·P
/// has several times P's entries) is never stored whole. The flops are those of the two
/// separate products. E (with α) is optional and must have C's shape; Y and Z have at most
/// [`MAX_COLUMNS`] columns (`y_cols` is Y's column count).
pub(crate) fn triple_product<IY: ColumnIndex>(
    addend: Option<(f64, &RowMatrix)>,
    beta: f64,
    x: Rows<'_>,
    y: Rows<'_, IY>,
    y_cols: usize,
    z: &RowMatrix,
) -> RowMatrix {
    let ncols = z.ncols;
    let nrows = x.nrows();
    let (starts, chunk) = chunk_starts(nrows);
    let pieces: Vec<Piece> = starts
        .par_iter()
        .map_init(
            || (vec![usize::MAX; y_cols], vec![usize::MAX; ncols]),
            |(marker_y, marker_z), &lo| {
                let hi = (lo + chunk).min(nrows);
                let (lengths, cols, vals) = multiply_rows(x, lo..hi, y, marker_y);
                let mut ptr = Vec::with_capacity(lengths.len() + 1);
                ptr.push(0);
                for length in lengths {
                    ptr.push(ptr[ptr.len() - 1] + length);
                }
                let xy = Rows {
                    ptr: &ptr,
                    idx: &cols,
                    val: &vals,
                };
                let (lengths, cols, mut vals) = multiply_rows(xy, 0..hi - lo, z.rows(), marker_z);
                vals.iter_mut().for_each(|v| *v *= beta);
                match addend {
                    None => (lengths, cols, vals),
                    Some((alpha, e)) => add_rows(alpha, e, lo, (lengths, cols, vals)),
                }
            },
        )
        .collect();
    concatenate(ncols, nrows, pieces)
}

/// α·E[lo + i, :] + piece row i for each row i of `piece`, patterns merged.
fn add_rows(alpha: f64, e: &RowMatrix, lo: usize, piece: Piece) -> Piece {
    let (piece_lengths, piece_cols, piece_vals) = piece;
    let mut lengths = Vec::with_capacity(piece_lengths.len());
    let mut cols = Vec::with_capacity(piece_cols.len());
    let mut vals = Vec::with_capacity(piece_vals.len());
    let mut q = 0;
    for (r, &length) in piece_lengths.iter().enumerate() {
        let start = cols.len();
        let (mut p, pe) = (e.row_ptr[lo + r], e.row_ptr[lo + r + 1]);
        let qe = q + length;
        while p < pe || q < qe {
            let ce = if p < pe { e.col_idx[p] } else { u32::MAX };
            let cq = if q < qe { piece_cols[q] } else { u32::MAX };
            let c = ce.min(cq);
            let mut v = 0.0;
            if ce == c {
                v += alpha * e.values[p];
                p += 1;
            }
            if cq == c {
                v += piece_vals[q];
                q += 1;
            }
            cols.push(c);
            vals.push(v);
        }
        lengths.push(cols.len() - start);
    }
    (lengths, cols, vals)
}

/// Joins per-chunk rows; the output is reserved up front and each chunk is freed once copied,
/// so the peak is about one copy of the result.
fn concatenate(ncols: usize, nrows: usize, pieces: Vec<Piece>) -> RowMatrix {
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
