//! Sparse LDLᵀ of a symmetric quasi-definite matrix, without pivoting.
//!
//! A symmetric matrix is *quasi-definite* when, in a block form
//!
//! ```text
//!     A = ⎡ H   Cᵀ ⎤      H (n₁×n₁) symmetric positive definite,
//!         ⎣ C  −G  ⎦      G (n₂×n₂) symmetric positive definite,
//! ```
//!
//! the leading block is positive and the trailing block negative definite. Vanderbei (1995,
//! "Symmetric quasidefinite matrices", SIAM J. Optim. 5(1)) showed that such a matrix is
//! *strongly factorizable*: for every symmetric permutation P, PAPᵀ = LDLᵀ exists with L unit
//! lower triangular and D diagonal, n₁ pivots positive and n₂ negative. So no pivoting is
//! needed, and the fill-reducing ordering can be chosen for sparsity alone — the symbolic
//! analysis of a Cholesky factorization serves unchanged. The mixed displacement–pressure
//! (perturbed-Lagrangian) systems of nearly incompressible elasticity have this form:
//! H = K_dev (positive definite once the supports hold every rigid motion), C = −B (the
//! divergence coupling), G = M_p/κ (the pressure mass over the bulk modulus).
//!
//! When it fails: a trailing block that is not negative definite has no such guarantee. The
//! incompressible limit is the case that matters: κ = ∞ (Poisson's ratio ν = 0.5 exactly)
//! makes G = 0, the matrix an indefinite saddle point, and an LDLᵀ without pivoting may meet a
//! zero pivot or an unbounded one. [`QuasiDefiniteLdlt::factorize`] therefore checks before
//! factoring that every diagonal entry of the trailing block is negative (an error naming the
//! row otherwise: use ν < 0.5, e.g. 0.4999, which the mixed formulation handles without
//! locking), and after factoring that the pivots have the signs the theorem gives (n₁
//! positive, then n₂ negative; an error naming the row otherwise: the leading block was not
//! positive definite, e.g. a body its supports do not hold).
//!
//! Cost: the factor of the whole (n₁+n₂)-square matrix on a nested-dissection or AMD ordering,
//! faer's supernodal LDLᵀ on one thread. The corner pressures of a mixed P2–P1 system add a few
//! per cent to the rows (6 % on the Lamé tube meshes of tetfem's tests); measured there at 60k
//! unknowns, this factorization took 1.3× the time of tetfem's own supernodal Cholesky of the
//! P2 displacement system of the same mesh.

use std::sync::Arc;

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::ldlt::factor::{LdltError, LdltRegularization};
use faer::mat::MatMut;
use faer::perm::PermRef;
use faer::sparse::SymbolicSparseColMat;
use faer::sparse::linalg::cholesky::{
    CholeskySymbolicParams, LdltRef, SymbolicCholesky, SymbolicCholeskyRaw, SymmetricOrdering,
    factorize_symbolic_cholesky,
};
use faer::{Conj, Par, Side};

use crate::error::{Error, Result};
use crate::ordering::{FillOrdering, inverse_permutation, nested_dissection};
use crate::sparse::CscMatrix;

/// A sparse LDLᵀ factorization of a symmetric quasi-definite matrix whose first
/// `positive` rows form the positive definite block and the rest the negative definite one
/// (see the module's documentation for why no pivoting is needed).
pub struct QuasiDefiniteLdlt {
    pattern: Arc<SymbolicSparseColMat<usize>>,
    symbolic: SymbolicCholesky<usize>,
    positive: usize,
    factor: Vec<f64>,
    factor_workspace: MemBuffer,
    solve_workspace: MemBuffer,
    factored: bool,
}

impl std::fmt::Debug for QuasiDefiniteLdlt {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("QuasiDefiniteLdlt")
            .field("dim", &self.dim())
            .field("positive", &self.positive)
            .field("factor_len", &self.factor_len())
            .field("factored", &self.factored)
            .finish_non_exhaustive()
    }
}

impl QuasiDefiniteLdlt {
    /// Symbolic analysis of `matrix`'s pattern (both triangles stored, as every [`CscMatrix`])
    /// on a fill-reducing `ordering`; rows `0..positive` are the positive definite block.
    ///
    /// Errors: `positive` exceeds the dimension; the ordering or the analysis fails.
    pub fn analyze(matrix: &CscMatrix, positive: usize, ordering: FillOrdering) -> Result<Self> {
        let dim = matrix.dim();
        if positive > dim {
            return Err(Error::invalid_parameter(
                "positive block size",
                positive,
                format!("must not exceed the matrix dimension {dim}"),
            ));
        }
        let pattern = SymbolicSparseColMat::as_ref(matrix.pattern());
        let params = CholeskySymbolicParams::default();
        let symbolic = match ordering {
            FillOrdering::Amd => {
                factorize_symbolic_cholesky(pattern, Side::Lower, SymmetricOrdering::Amd, params)
            }
            FillOrdering::NestedDissection => {
                let forward = nested_dissection(matrix.pattern())?;
                let inverse = inverse_permutation(&forward)?;
                // Cannot panic: inverse_permutation checked that `forward` permutes 0..dim.
                let perm = PermRef::new_checked(&forward, &inverse, dim);
                factorize_symbolic_cholesky(
                    pattern,
                    Side::Lower,
                    SymmetricOrdering::Custom(perm),
                    params,
                )
            }
        }
        .map_err(|e| Error::Solver(format!("symbolic LDLᵀ analysis failed: {e:?}")))?;
        let out_of_memory = |what: &str| Error::Solver(format!("out of memory for the {what}"));
        let factor_workspace = MemBuffer::try_new(
            symbolic.factorize_numeric_ldlt_scratch::<f64>(Par::Seq, Default::default()),
        )
        .map_err(|_| out_of_memory("LDLᵀ workspace"))?;
        let solve_workspace =
            MemBuffer::try_new(symbolic.solve_in_place_scratch::<f64>(1, Par::Seq))
                .map_err(|_| out_of_memory("LDLᵀ solve workspace"))?;
        Ok(QuasiDefiniteLdlt {
            pattern: Arc::clone(matrix.pattern()),
            symbolic,
            positive,
            factor: Vec::new(),
            factor_workspace,
            solve_workspace,
            factored: false,
        })
    }

    /// Numeric factorization PAPᵀ = LDLᵀ of `matrix` (the analysed pattern, symmetric values),
    /// with no pivoting and no regularization.
    ///
    /// Errors, each naming the row in `matrix`'s own numbering:
    /// - a diagonal entry of the trailing block that is not negative (a vanishing −G, e.g. an
    ///   incompressible material: κ = ∞ at ν = 0.5) — checked before factoring;
    /// - a zero pivot, or a pivot whose sign is not the block's (the leading block is not
    ///   positive definite, e.g. a body its supports do not hold).
    pub fn factorize(&mut self, matrix: &CscMatrix) -> Result<()> {
        self.factored = false;
        crate::linsolve::check_refill(&self.pattern, matrix, "LDLᵀ")?;
        for row in self.positive..self.dim() {
            let diagonal = matrix.get(row, row).unwrap_or(0.0);
            if diagonal >= 0.0 {
                return Err(Error::invalid_parameter(
                    format!("diagonal of row {row} (trailing block)"),
                    diagonal,
                    "must be negative for an LDLᵀ without pivoting (a quasi-definite matrix); a \
                     zero trailing block is the incompressible limit (bulk modulus ∞, Poisson's \
                     ratio 0.5 exactly): use ν < 0.5, e.g. 0.4999",
                ));
            }
        }
        if self.factor.len() != self.symbolic.len_val() {
            self.factor
                .try_reserve_exact(self.symbolic.len_val())
                .map_err(|_| Error::Solver("out of memory for the LDLᵀ factor".into()))?;
            self.factor.resize(self.symbolic.len_val(), 0.0);
        }
        let stack = MemStack::new(&mut self.factor_workspace);
        let result = self.symbolic.factorize_numeric_ldlt(
            &mut self.factor,
            matrix.as_faer(),
            Side::Lower,
            LdltRegularization::default(),
            Par::Seq,
            stack,
            Default::default(),
        );
        if let Err(LdltError::ZeroPivot { index }) = result {
            return Err(self.pivot_error(index, 0.0));
        }
        let pivots = self.pivots();
        for (index, &pivot) in pivots.iter().enumerate() {
            let row = self.original_index(index);
            let expected_positive = row < self.positive;
            if (pivot > 0.0) != expected_positive || !pivot.is_finite() {
                return Err(self.pivot_error(index, pivot));
            }
        }
        self.factored = true;
        Ok(())
    }

    /// The error for a zero or wrongly signed pivot at permuted index `index`.
    fn pivot_error(&self, index: usize, pivot: f64) -> Error {
        let row = self.original_index(index);
        let block = if row < self.positive {
            "leading (must be positive definite: are all rigid motions held?)"
        } else {
            "trailing (must be negative definite)"
        };
        Error::invalid_parameter(
            format!("LDLᵀ pivot of row {row} of {}", self.dim()),
            pivot,
            format!(
                "has the wrong sign or is zero: the matrix is not quasi-definite, {block} block"
            ),
        )
    }

    /// The diagonal D of the factor, in the permuted order.
    fn pivots(&self) -> Vec<f64> {
        match self.symbolic.raw() {
            SymbolicCholeskyRaw::Supernodal(sn) => {
                let mut d = Vec::with_capacity(self.dim());
                let (begin, end, val) = (
                    sn.supernode_begin(),
                    sn.supernode_end(),
                    sn.col_ptr_for_val(),
                );
                for s in 0..sn.n_supernodes() {
                    let columns = end[s] - begin[s];
                    // A supernode's values are its dense column-major (rows × columns) block,
                    // unit lower triangular on top with D on its diagonal.
                    let rows = (val[s + 1] - val[s]).checked_div(columns).unwrap_or(0);
                    d.extend((0..columns).map(|k| self.factor[val[s] + k * rows + k]));
                }
                d
            }
            // Each column stores its diagonal entry (D) first.
            SymbolicCholeskyRaw::Simplicial(simplicial) => simplicial.col_ptr()[..self.dim()]
                .iter()
                .map(|&start| self.factor[start])
                .collect(),
        }
    }

    /// Solves A·x = b in place (`rhs` holds b on entry, x on return).
    ///
    /// Errors: no successful factorization yet, or `rhs` is not of the matrix's dimension.
    pub fn solve_in_place(&mut self, rhs: &mut [f64]) -> Result<()> {
        if !self.factored {
            return Err(Error::Solver(
                "LDLᵀ solve called before a successful numeric factorization".into(),
            ));
        }
        Error::check_len("right-hand side", self.dim(), rhs.len())?;
        let n = rhs.len();
        let ldlt = LdltRef::new(&self.symbolic, &self.factor);
        let stack = MemStack::new(&mut self.solve_workspace);
        ldlt.solve_in_place_with_conj(
            Conj::No,
            MatMut::from_column_major_slice_mut(rhs, n, 1),
            Par::Seq,
            stack,
        );
        Ok(())
    }

    /// The row of the matrix in its own numbering of permuted index `index`.
    fn original_index(&self, index: usize) -> usize {
        self.symbolic.perm().map_or(index, |perm| {
            perm.arrays().0.get(index).copied().unwrap_or(index)
        })
    }

    /// Dimension of the factored matrix.
    pub fn dim(&self) -> usize {
        self.pattern.ncols()
    }

    /// Rows of the positive definite (leading) block.
    pub fn positive(&self) -> usize {
        self.positive
    }

    /// Number of stored values of the factor L (D on its diagonal), known after the analysis.
    pub fn factor_len(&self) -> usize {
        self.symbolic.len_val()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A dense symmetric matrix as a [`CscMatrix`] (every entry stored).
    fn dense(a: &[Vec<f64>]) -> CscMatrix {
        let n = a.len();
        let col_ptr = (0..=n).map(|j| j * n).collect();
        let row_idx = (0..n).flat_map(|_| 0..n).collect();
        let pattern = SymbolicSparseColMat::new_checked(n, n, col_ptr, None, row_idx);
        let values = (0..n).flat_map(|j| (0..n).map(move |i| a[i][j])).collect();
        CscMatrix::from_values(Arc::new(pattern), values).unwrap()
    }

    /// [2 1 1; 1 3 −1; 1 −1 −0.5]: H = [2 1; 1 3] is positive definite, G = 0.5 > 0.
    fn saddle(g: f64) -> CscMatrix {
        dense(&[
            vec![2.0, 1.0, 1.0],
            vec![1.0, 3.0, -1.0],
            vec![1.0, -1.0, -g],
        ])
    }

    #[test]
    fn solves_a_quasi_definite_system_on_both_orderings() {
        let a = saddle(0.5);
        let x = [1.0, -2.0, 3.0];
        let b = a.mul(&x).unwrap();
        for ordering in [FillOrdering::Amd, FillOrdering::NestedDissection] {
            let mut ldlt = QuasiDefiniteLdlt::analyze(&a, 2, ordering).unwrap();
            ldlt.factorize(&a).unwrap();
            let mut solution = b.clone();
            ldlt.solve_in_place(&mut solution).unwrap();
            for (s, e) in solution.iter().zip(&x) {
                // A 3×3 system of condition ~10: round-off is a few ulps.
                assert!((s - e).abs() < 1e-13, "{solution:?}");
            }
        }
    }

    #[test]
    fn a_vanishing_trailing_block_is_refused_by_row() {
        let a = saddle(0.0);
        let mut ldlt = QuasiDefiniteLdlt::analyze(&a, 2, FillOrdering::Amd).unwrap();
        let message = ldlt.factorize(&a).unwrap_err().to_string();
        assert!(
            message.contains("row 2") && message.contains("0.5"),
            "{message}"
        );
    }

    #[test]
    fn an_indefinite_leading_block_is_refused() {
        // H = [2 1; 1 −3] is indefinite: one pivot of the leading block is negative.
        let a = dense(&[
            vec![2.0, 1.0, 1.0],
            vec![1.0, -3.0, -1.0],
            vec![1.0, -1.0, -0.5],
        ]);
        let mut ldlt = QuasiDefiniteLdlt::analyze(&a, 2, FillOrdering::Amd).unwrap();
        let message = ldlt.factorize(&a).unwrap_err().to_string();
        assert!(message.contains("not quasi-definite"), "{message}");
        assert!(ldlt.solve_in_place(&mut [0.0; 3]).is_err());
    }
}
