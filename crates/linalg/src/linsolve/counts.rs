//! Row and column counts of the Cholesky factor's pattern, for the rounding-error bound of a
//! factorization (the explicit critical step's inertia certificate uses it).

use faer::sparse::linalg::cholesky::SymbolicCholeskyRaw;

use super::SparseCholesky;

/// The largest row and row-plus-column counts of the factor L's stored pattern (supernodal
/// padding included, so they bound the true counts from above).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FactorCounts {
    /// maxᵢ (entries of row i of L, diagonal included): the most terms any inner product of the
    /// factorization sums (the entry l_ij sums over k ≤ j with l_ik, l_jk ≠ 0).
    pub max_row: usize,
    /// maxᵢ (entries of row i of L + entries of column i of L − 1): the most entries of any row of
    /// the filled symmetric pattern L + Lᵀ, which holds the pattern of L·Lᵀ's rounding error.
    pub max_row_and_column: usize,
}

impl SparseCholesky {
    /// Row and column counts of the factor's pattern, from the symbolic analysis alone
    /// (O(stored row indices) time, 16 bytes per row of scratch).
    pub fn factor_counts(&self) -> FactorCounts {
        let n = self.dim();
        let mut rows = vec![0usize; n];
        let mut columns = vec![0usize; n];
        match self.symbolic.raw() {
            SymbolicCholeskyRaw::Supernodal(sn) => {
                let (begin, end) = (sn.supernode_begin(), sn.supernode_end());
                let (ptr, row_idx) = (sn.col_ptr_for_row_idx(), sn.row_idx());
                for s in 0..sn.n_supernodes() {
                    let width = end[s] - begin[s];
                    let below = &row_idx[ptr[s]..ptr[s + 1]];
                    // The dense diagonal block: row begin + k holds k + 1 of its columns, column
                    // begin + k holds width − k of its rows, plus every row below the block.
                    for k in 0..width {
                        rows[begin[s] + k] += k + 1;
                        columns[begin[s] + k] = width - k + below.len();
                    }
                    for &i in below {
                        rows[i] += width;
                    }
                }
            }
            SymbolicCholeskyRaw::Simplicial(simplicial) => {
                let (ptr, row_idx) = (simplicial.col_ptr(), simplicial.row_idx());
                for j in 0..n {
                    let entries = &row_idx[ptr[j]..ptr[j + 1]];
                    columns[j] = entries.len();
                    for &i in entries {
                        rows[i] += 1;
                    }
                }
            }
        }
        FactorCounts {
            max_row: rows.iter().copied().max().unwrap_or(0),
            max_row_and_column: rows
                .iter()
                .zip(&columns)
                .map(|(r, c)| (r + c).saturating_sub(1))
                .max()
                .unwrap_or(0),
        }
    }
}
