//! Sparse Cholesky (LLᵀ) over faer: the symbolic analysis (fill-reducing ordering, elimination
//! tree, supernodes) is done once per pattern; numeric factorizations and solves reuse it, and
//! their workspaces are allocated once.

use std::sync::Arc;

use faer::Par;
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt::factor::LltError;
use faer::mat::MatMut;
use faer::sparse::SymbolicSparseColMat;
use faer::sparse::linalg::cholesky::{
    CholeskySymbolicParams, LltRef, SymbolicCholesky, SymmetricOrdering,
    factorize_symbolic_cholesky,
};
use faer::{Conj, Side};

use crate::error::{Error, Result};
use crate::sparse::CscMatrix;

/// Sparse Cholesky factorization A = LLᵀ of a symmetric positive definite [`CscMatrix`].
pub struct SparseCholesky {
    pattern: Arc<SymbolicSparseColMat<usize>>,
    symbolic: SymbolicCholesky<usize>,
    factor: Vec<f64>,
    factor_workspace: MemBuffer,
    solve_workspace: MemBuffer,
    factored: bool,
    par: Par,
}

impl std::fmt::Debug for SparseCholesky {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SparseCholesky")
            .field("dim", &self.dim())
            .field("factor_len", &self.factor_len())
            .field("factored", &self.factored)
            .finish_non_exhaustive()
    }
}

impl SparseCholesky {
    /// Symbolic analysis of `matrix`'s pattern with faer's approximate minimum degree ordering,
    /// single-threaded.
    pub fn analyze(matrix: &CscMatrix) -> Result<Self> {
        Self::analyze_with(matrix, Par::Seq)
    }

    /// Symbolic analysis with a chosen parallelism for the numeric phases.
    pub fn analyze_with(matrix: &CscMatrix, par: Par) -> Result<Self> {
        let symbolic = factorize_symbolic_cholesky(
            SymbolicSparseColMat::as_ref(matrix.pattern()),
            Side::Lower,
            SymmetricOrdering::Amd,
            CholeskySymbolicParams::default(),
        )
        .map_err(|e| Error::Solver(format!("symbolic Cholesky analysis failed: {e:?}")))?;
        let factor_workspace = MemBuffer::try_new(
            symbolic.factorize_numeric_llt_scratch::<f64>(par, Default::default()),
        )
        .map_err(|_| Error::Solver("out of memory for the factorization workspace".into()))?;
        let solve_workspace = MemBuffer::try_new(symbolic.solve_in_place_scratch::<f64>(1, par))
            .map_err(|_| Error::Solver("out of memory for the solve workspace".into()))?;
        let mut factor = Vec::new();
        factor.try_reserve_exact(symbolic.len_val()).map_err(|_| {
            Error::Solver(format!(
                "out of memory for a factor of {} values",
                symbolic.len_val()
            ))
        })?;
        factor.resize(symbolic.len_val(), 0.0);
        Ok(SparseCholesky {
            pattern: Arc::clone(matrix.pattern()),
            symbolic,
            factor,
            factor_workspace,
            solve_workspace,
            factored: false,
            par,
        })
    }

    /// Numeric factorization of `matrix`, which must have the analysed pattern. Reuses the
    /// symbolic analysis and the factor's storage.
    pub fn factorize(&mut self, matrix: &CscMatrix) -> Result<()> {
        self.factored = false;
        if !Arc::ptr_eq(&self.pattern, matrix.pattern())
            && (self.pattern.col_ptr() != matrix.col_ptr()
                || self.pattern.row_idx() != matrix.row_idx())
        {
            return Err(Error::invalid_parameter(
                "matrix",
                "a different sparsity pattern",
                "must have the pattern the factorization was analysed for",
            ));
        }
        if let Some(k) = matrix.values().iter().position(|v| !v.is_finite()) {
            return Err(Error::invalid_parameter(
                "matrix value",
                format!("entry {k} = {}", matrix.values()[k]),
                "must be finite",
            ));
        }
        let stack = MemStack::new(&mut self.factor_workspace);
        self.symbolic
            .factorize_numeric_llt(
                &mut self.factor,
                matrix.as_faer(),
                Side::Lower,
                Default::default(),
                self.par,
                stack,
                Default::default(),
            )
            .map_err(|e| match e {
                LltError::NonPositivePivot { index } => Error::NotPositiveDefinite {
                    pivot: index,
                    dimension: matrix.dim(),
                },
            })?;
        self.factored = true;
        Ok(())
    }

    /// Solves A·x = b in place (`rhs` holds b on entry, x on return).
    pub fn solve_in_place(&mut self, rhs: &mut [f64]) -> Result<()> {
        if !self.factored {
            return Err(Error::Solver(
                "solve called before a successful numeric factorization".into(),
            ));
        }
        if rhs.len() != self.dim() {
            return Err(Error::invalid_parameter(
                "right-hand side length",
                rhs.len(),
                format!("must equal the matrix dimension {}", self.dim()),
            ));
        }
        let n = rhs.len();
        let llt = LltRef::new(&self.symbolic, &self.factor);
        let stack = MemStack::new(&mut self.solve_workspace);
        llt.solve_in_place_with_conj(
            Conj::No,
            MatMut::from_column_major_slice_mut(rhs, n, 1),
            self.par,
            stack,
        );
        Ok(())
    }

    /// Dimension of the factored matrix.
    pub fn dim(&self) -> usize {
        self.pattern.ncols()
    }

    /// Number of stored values of the factor L (its fill).
    pub fn factor_len(&self) -> usize {
        self.symbolic.len_val()
    }
}
