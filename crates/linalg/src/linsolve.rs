//! Sparse Cholesky (LLᵀ) over faer: the symbolic analysis (fill-reducing ordering, elimination
//! tree, supernodes) is done once per pattern; numeric factorizations and solves reuse it, and
//! their workspaces are allocated once.

mod counts;
mod supernodal;
#[cfg(test)]
mod tuning_tests;

use std::sync::Arc;

use faer::Par;
use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::linalg::cholesky::llt::factor::LltError;
use faer::mat::MatMut;
use faer::perm::PermRef;
use faer::sparse::SymbolicSparseColMat;
use faer::sparse::linalg::cholesky::{
    CholeskySymbolicParams, LltRef, SymbolicCholesky, SymmetricOrdering,
    factorize_symbolic_cholesky,
};
use faer::{Conj, Side};

use crate::error::{Error, Result};
use crate::memory::{COARSER_MESH, MemoryLimits, dense_kernel_reservation};
use crate::ordering::{
    FillOrdering, NestedDissectionOptions, inverse_permutation, nested_dissection_with,
};
use crate::sparse::CscMatrix;
pub use counts::FactorCounts;
use supernodal::{Columns, FactorPlan, FactorWorkspace, SupernodalPlan, SupernodalWorkspace};

/// How to factor: the fill-reducing ordering and the number of threads of the numeric phases.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CholeskyOptions {
    /// Fill-reducing ordering (default: nested dissection).
    pub ordering: FillOrdering,
    /// Threads for the numeric factorization and solves (1 = sequential, the default; 0 counts
    /// as 1). tetfem's supernodal kernels use two at most, one per half of the elimination tree
    /// below its top separators (and both on the top separators' dense blocks), from rayon's
    /// global pool; faer's kernels ([`NumericFactorization::Faer`], simplicial factors) use
    /// this many.
    pub threads: usize,
}

impl Default for CholeskyOptions {
    fn default() -> Self {
        CholeskyOptions {
            ordering: FillOrdering::NestedDissection,
            threads: 1,
        }
    }
}

/// How adjacent supernodes of the factor are amalgamated, as faer's relaxation table: two
/// supernodes of n columns together, whose merged block would hold a fraction z of explicit
/// zeros, are merged when some entry (nₖ, zₖ) has n ≤ nₖ and z ≤ zₖ. Merging pads L with zeros
/// (more memory and flops) but makes the dense blocks larger (faster kernels). This is faer's
/// default table.
pub const DEFAULT_RELAXATION: &[(usize, f64)] =
    &[(4, 1.0), (16, 0.8), (48, 0.1), (usize::MAX, 0.05)];

/// Which kernel performs the two triangular solves of [`SparseCholesky::solve_in_place_with`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TriangularSolve {
    /// faer's `solve_in_place_with_conj`, with the factorization's threads.
    Faer,
    /// tetfem's supernodal kernels on faer's factor; `threads` ≥ 2 runs the two halves of the
    /// elimination tree below its top separators in parallel. A simplicial factor (small
    /// matrices) falls back to faer.
    Supernodal {
        /// 1 = sequential; 2 or more = two threads.
        threads: usize,
    },
    /// The supernodal kernels on the single-precision copy of the factor
    /// ([`SparseCholesky::make_single_precision_copy`]): half the bytes to stream, and the
    /// arithmetic in f32 too (eight values to a 256-bit register, none widened; the right-hand
    /// side scaled by a power of two into f32's range and back, exactly): a backward-stable
    /// solve in f32, with a relative backward error of order n·2⁻²⁴ for columns of length n,
    /// for preconditioners and quasi-Newton steps. An error when the copy is missing or older
    /// than the factor, or the factor is simplicial.
    SupernodalSingle {
        /// 1 = sequential; 2 or more = two threads.
        threads: usize,
    },
}

/// Which kernel performs the numeric factorization of [`SparseCholesky::factorize_with`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum NumericFactorization {
    /// faer's `factorize_numeric_llt`, with the options' threads inside its dense kernels.
    Faer,
    /// tetfem's left-looking supernodal factorization on faer's symbolic structure (the
    /// default): updates formed with a contiguous right factor, and with two threads the two
    /// halves of the elimination tree below its top separators factored concurrently. A
    /// simplicial factor (small matrices) falls back to faer.
    #[default]
    Supernodal,
}

/// Sparse Cholesky factorization A = LLᵀ of a symmetric positive definite [`CscMatrix`].
pub struct SparseCholesky {
    pattern: Arc<SymbolicSparseColMat<usize>>,
    symbolic: SymbolicCholesky<usize>,
    factor: Vec<f64>,
    /// The factor rounded to f32 ([`make_single_precision_copy`](Self::make_single_precision_copy));
    /// valid while `single_current`.
    single: Vec<f32>,
    single_current: bool,
    factor_workspace: MemBuffer,
    solve_workspace: MemBuffer,
    /// Supernode layout and two-thread split of the own triangular solves (`None`: simplicial).
    plan: Option<SupernodalPlan>,
    supernodal_workspace: SupernodalWorkspace,
    /// Update lists and flop-balanced split of the own numeric factorization (with `plan`).
    factor_plan: Option<FactorPlan>,
    factor_plan_workspace: FactorWorkspace,
    threads: usize,
    /// Whether `factor` and the workspaces have their sizes (a 0×0 matrix has an empty factor
    /// but still needs its workspaces, so the factor's length cannot tell).
    allocated: bool,
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
    /// Symbolic analysis of `matrix`'s pattern with the default [`CholeskyOptions`]
    /// (nested dissection, one thread).
    pub fn analyze(matrix: &CscMatrix) -> Result<Self> {
        Self::analyze_with(matrix, CholeskyOptions::default())
    }

    /// Symbolic analysis with chosen ordering and thread count.
    pub fn analyze_with(matrix: &CscMatrix, options: CholeskyOptions) -> Result<Self> {
        Self::analyze_tuned(
            matrix,
            options,
            NestedDissectionOptions::default(),
            DEFAULT_RELAXATION,
        )
    }

    /// Symbolic analysis with chosen METIS settings (used when `options.ordering` is nested
    /// dissection) and supernode relaxation table (see [`DEFAULT_RELAXATION`]; an empty table
    /// merges only supernodes that add no zeros, so the stored factor is the exact nnz(L)).
    /// An error names the first table entry whose zero fraction is outside [0, 1].
    pub fn analyze_tuned(
        matrix: &CscMatrix,
        options: CholeskyOptions,
        dissection: NestedDissectionOptions,
        relaxation: &[(usize, f64)],
    ) -> Result<Self> {
        if let Some((k, &(_, z))) = relaxation
            .iter()
            .enumerate()
            .find(|(_, (_, z))| !(0.0..=1.0).contains(z))
        {
            return Err(Error::invalid_parameter(
                format!("relaxation[{k}].1"),
                z,
                "must be a zero fraction in [0, 1]",
            ));
        }
        let par = match options.threads {
            0 | 1 => Par::Seq,
            n => Par::rayon(n),
        };
        let pattern = SymbolicSparseColMat::as_ref(matrix.pattern());
        let mut params = CholeskySymbolicParams::default();
        params.supernodal_params.relax = Some(relaxation);
        let symbolic = match options.ordering {
            FillOrdering::Amd => {
                factorize_symbolic_cholesky(pattern, Side::Lower, SymmetricOrdering::Amd, params)
            }
            FillOrdering::NestedDissection => {
                let forward = nested_dissection_with(matrix.pattern(), dissection)?;
                let inverse = inverse_permutation(&forward)?;
                // Cannot panic: inverse_permutation checked that `forward` permutes 0..dim.
                let perm = PermRef::new_checked(&forward, &inverse, matrix.dim());
                factorize_symbolic_cholesky(
                    pattern,
                    Side::Lower,
                    SymmetricOrdering::Custom(perm),
                    params,
                )
            }
        }
        .map_err(|e| Error::Solver(format!("symbolic Cholesky analysis failed: {e:?}")))?;
        let plan = SupernodalPlan::new(&symbolic);
        let factor_plan = plan.as_ref().map(FactorPlan::new);
        Ok(SparseCholesky {
            plan,
            supernodal_workspace: SupernodalWorkspace::default(),
            factor_plan,
            factor_plan_workspace: FactorWorkspace::default(),
            threads: options.threads.max(1),
            pattern: Arc::clone(matrix.pattern()),
            symbolic,
            factor: Vec::new(),
            single: Vec::new(),
            single_current: false,
            factor_workspace: MemBuffer::new(StackReq::EMPTY),
            solve_workspace: MemBuffer::new(StackReq::EMPTY),
            allocated: false,
            factored: false,
            par,
        })
    }

    /// Allocates the factor and the workspaces on first use, so that a caller can inspect
    /// [`factor_len`](Self::factor_len) after the analysis and choose another method before any
    /// large allocation.
    fn allocate(&mut self) -> Result<()> {
        if self.allocated {
            return Ok(());
        }
        if self.plan.is_some() {
            // The supernodal kernel multiplies dense blocks with faer's kernels, which map
            // their per-thread buffers on first use and abort the process if the mapping is
            // refused: check them (address-space bounds only) with the factor, before both.
            let buffers = dense_kernel_reservation().for_threads(self.threads);
            MemoryLimits::current()
                .keeping_back(buffers)
                .ensure_fits_or(
                    format!(
                        "the Cholesky factor of {} DOFs ({} stored values and the workspace)",
                        self.dim(),
                        self.factor_len()
                    ),
                    self.factor_bytes() as u128,
                    COARSER_MESH,
                )?;
        }
        let out_of_memory = |what: &str| Error::Solver(format!("out of memory for the {what}"));
        self.solve_workspace =
            MemBuffer::try_new(self.symbolic.solve_in_place_scratch::<f64>(1, self.par))
                .map_err(|_| out_of_memory("solve workspace"))?;
        self.factor
            .try_reserve_exact(self.symbolic.len_val())
            .map_err(|_| out_of_memory("Cholesky factor"))?;
        self.factor.resize(self.symbolic.len_val(), 0.0);
        self.allocated = true;
        Ok(())
    }

    /// Numeric factorization of `matrix`, which must have the analysed pattern. Reuses the
    /// symbolic analysis and the factor's storage. Runs tetfem's supernodal kernel on the
    /// options' threads (two at most); measured side by side with faer's in
    /// `benches/factorization.rs`.
    pub fn factorize(&mut self, matrix: &CscMatrix) -> Result<()> {
        self.factorize_with(matrix, NumericFactorization::Supernodal)
    }

    /// Numeric factorization with a chosen kernel (for comparing them; the factors agree up to
    /// round-off). Only the entries of `matrix` on and below the diagonal of the permuted
    /// matrix are read, so `matrix` must be symmetric.
    pub fn factorize_with(
        &mut self,
        matrix: &CscMatrix,
        kernel: NumericFactorization,
    ) -> Result<()> {
        self.factored = false;
        self.single_current = false;
        check_refill(&self.pattern, matrix, "factorization")?;
        self.allocate()?;
        if let (NumericFactorization::Supernodal, Some(plan), Some(factor_plan)) =
            (kernel, &self.plan, &self.factor_plan)
        {
            let columns = Columns {
                col_ptr: matrix.col_ptr(),
                row_idx: matrix.row_idx(),
                values: matrix.values(),
            };
            factor_plan
                .factorize(
                    plan,
                    columns,
                    &mut self.factor,
                    self.threads,
                    &mut self.factor_plan_workspace,
                )
                .map_err(|pivot| Error::NotPositiveDefinite {
                    pivot: self.original_index(pivot),
                    dimension: matrix.dim(),
                })?;
            self.factored = true;
            return Ok(());
        }
        if self.factor_workspace.is_empty() {
            self.factor_workspace = MemBuffer::try_new(
                self.symbolic
                    .factorize_numeric_llt_scratch::<f64>(self.par, Default::default()),
            )
            .map_err(|_| Error::Solver("out of memory for the factorization workspace".into()))?;
        }
        let stack = MemStack::new(&mut self.factor_workspace);
        let result = self.symbolic.factorize_numeric_llt(
            &mut self.factor,
            matrix.as_faer(),
            Side::Lower,
            Default::default(),
            self.par,
            stack,
            Default::default(),
        );
        if let Err(LltError::NonPositivePivot { index }) = result {
            return Err(Error::NotPositiveDefinite {
                pivot: self.original_index(index),
                dimension: matrix.dim(),
            });
        }
        self.factored = true;
        Ok(())
    }

    /// Solves A·x = b in place (`rhs` holds b on entry, x on return), with tetfem's supernodal
    /// kernels on the options' threads (faer's solve for a simplicial factor). Measured with
    /// `benches/triangular_solve.rs` (10k–430k DOFs): on one thread 1.4–1.7× faster than
    /// faer's solve, and 1.1–1.2× the time of reading the factor's values twice as four
    /// concurrent streams once the factor outgrows the cache; two threads gain only when the
    /// memory bus is not already busy (on an idle machine they ran at the two-thread read's
    /// speed, 2.1× faster than faer's).
    pub fn solve_in_place(&mut self, rhs: &mut [f64]) -> Result<()> {
        let threads = self.threads;
        self.solve_in_place_with(rhs, TriangularSolve::Supernodal { threads })
    }

    /// Solves A·x = b in place with a chosen triangular-solve kernel (for comparing them; the
    /// results agree up to round-off).
    pub fn solve_in_place_with(&mut self, rhs: &mut [f64], kernel: TriangularSolve) -> Result<()> {
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
        if let TriangularSolve::SupernodalSingle { threads } = kernel {
            let (Some(plan), true) = (&self.plan, self.single_current) else {
                return Err(Error::Solver(
                    "single-precision solve without a current single-precision copy of a supernodal factor"
                        .into(),
                ));
            };
            plan.solve_in_place(&self.single, rhs, threads, &mut self.supernodal_workspace);
            return Ok(());
        }
        if let (TriangularSolve::Supernodal { threads }, Some(plan)) = (kernel, &self.plan) {
            plan.solve_in_place(&self.factor, rhs, threads, &mut self.supernodal_workspace);
            return Ok(());
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

    /// Rounds the current factor to f32 and keeps it beside the f64 one for
    /// [`TriangularSolve::SupernodalSingle`] (4 bytes per factor value, allocated once; a
    /// later factorization makes it stale until this is called again). Returns whether a
    /// current copy is there: `false` for a simplicial factor (small matrices, whose solves
    /// faer does) and when the copy would take more than half of the memory still available
    /// ([`MemoryLimits`]) or cannot be allocated — the f64 factor then serves alone, at its
    /// speed. Errors: no factorization yet.
    pub fn make_single_precision_copy(&mut self) -> Result<bool> {
        if !self.factored {
            return Err(Error::Solver(
                "single-precision copy requested before a successful numeric factorization".into(),
            ));
        }
        if self.plan.is_none() {
            return Ok(false);
        }
        if self.single.len() != self.factor.len() {
            let bytes = (self.factor.len() * std::mem::size_of::<f32>()) as u64;
            let crowded = MemoryLimits::current()
                .available()
                .is_some_and(|available| bytes > available / 2);
            self.single = Vec::new();
            if crowded || self.single.try_reserve_exact(self.factor.len()).is_err() {
                return Ok(false);
            }
            self.single.resize(self.factor.len(), 0.0);
        }
        // Rounding to nearest: every value of an SPD factor is far inside f32's range
        // (|Lᵢⱼ| ≤ √Aⱼⱼ), so none overflows or flushes to zero in practice.
        for (single, &value) in self.single.iter_mut().zip(&self.factor) {
            *single = value as f32;
        }
        self.single_current = true;
        Ok(true)
    }

    /// Whether a single-precision copy of the current factor is there
    /// ([`make_single_precision_copy`](Self::make_single_precision_copy)).
    pub fn has_single_precision_copy(&self) -> bool {
        self.single_current
    }

    /// Solves A·x = b in place with the single-precision copy of the factor on the options'
    /// threads ([`TriangularSolve::SupernodalSingle`]).
    pub fn solve_in_place_single(&mut self, rhs: &mut [f64]) -> Result<()> {
        let threads = self.threads;
        self.solve_in_place_with(rhs, TriangularSolve::SupernodalSingle { threads })
    }

    /// Solves A·X = B in place for the columns of `rhs` (column-major, its length a multiple
    /// of the dimension) where only an approximation of A⁻¹ is needed, as
    /// [`LinearSolver::solve_approximate`](crate::LinearSolver::solve_approximate) for one: the
    /// single-precision copy when there is a current one, else the f64 factor. On a supernodal
    /// factor the columns go 16 at a time, each supernode read once a batch (on the f32 copy at
    /// 9,450 DOFs, 1.9× the rate of one-at-a-time solves on one thread, 3.3× on two, where the
    /// batches split between the threads); a column's result does not depend on the others in
    /// `rhs`. Simplicial factors solve column by column.
    pub fn solve_many_approximate(&mut self, rhs: &mut [f64]) -> Result<()> {
        if !self.factored {
            return Err(Error::Solver(
                "solve called before a successful numeric factorization".into(),
            ));
        }
        let n = self.dim();
        let whole = match n {
            0 => rhs.is_empty(),
            n => rhs.len().is_multiple_of(n),
        };
        if !whole {
            return Err(Error::invalid_parameter(
                "right-hand sides' length",
                rhs.len(),
                format!("must be a multiple of the matrix dimension {n}"),
            ));
        }
        if rhs.is_empty() {
            return Ok(());
        }
        let threads = self.threads;
        match (&self.plan, self.single_current) {
            (Some(plan), true) => plan.solve_many_in_place(&self.single, rhs, threads),
            (Some(plan), false) => plan.solve_many_in_place(&self.factor, rhs, threads),
            (None, _) => {
                for column in rhs.chunks_exact_mut(n) {
                    self.solve_in_place(column)?;
                }
            }
        }
        Ok(())
    }

    /// The row of the matrix in its own numbering of permuted index `index`.
    fn original_index(&self, index: usize) -> usize {
        self.symbolic.perm().map_or(index, |perm| {
            perm.arrays().0.get(index).copied().unwrap_or(index)
        })
    }

    /// The factor's values (faer's layout; empty before the first factorization).
    pub fn factor_values(&self) -> &[f64] {
        &self.factor
    }

    /// Whether the factor is supernodal: its numeric factorization then runs faer's dense
    /// kernels, which map [`dense_kernel_reservation`] buffers (known after the analysis).
    pub fn is_supernodal(&self) -> bool {
        self.plan.is_some()
    }

    /// Threads of the numeric factorization (at least 1).
    pub fn threads(&self) -> usize {
        self.threads
    }

    /// Whether the factor is supernodal, and then the fractions of its values in the top of the
    /// elimination tree (solved on one thread) and in the two parallel halves below it.
    pub fn supernodal_split(&self) -> Option<[f64; 3]> {
        self.plan.as_ref().map(SupernodalPlan::split_summary)
    }

    /// Dimension of the factored matrix.
    pub fn dim(&self) -> usize {
        self.pattern.ncols()
    }

    /// Number of stored values of the factor L (its fill, supernodal padding included), known
    /// after the symbolic analysis.
    pub fn factor_len(&self) -> usize {
        self.symbolic.len_val()
    }

    /// Stored values of L on and below the diagonal (supernodal padding included): Σ over
    /// supernodes of c(c + 1)/2 + b·c, c the supernode's columns and b its rows below the
    /// diagonal block — the count PARDISO and CHOLMOD report as nnz(L).
    /// [`factor_len`](Self::factor_len) also counts the unused upper triangles of the dense
    /// diagonal blocks, c(c − 1)/2 each.
    pub fn factor_nnz_lower(&self) -> usize {
        (self.supernodes().into_iter())
            .map(|(c, values)| values - c * c.saturating_sub(1) / 2)
            .sum()
    }

    /// Bytes the numeric factorization will hold: the factor's values (8 bytes each) plus the
    /// workspace of [`factorize`](Self::factorize)'s kernel.
    pub fn factor_bytes(&self) -> usize {
        let workspace = match (&self.plan, &self.factor_plan) {
            (Some(plan), Some(factor_plan)) => factor_plan.workspace_bytes(plan),
            _ => self
                .symbolic
                .factorize_numeric_llt_scratch::<f64>(self.par, Default::default())
                .size_bytes(),
        };
        8 * self.symbolic.len_val() + workspace
    }

    /// Floating-point operations of one numeric factorization (one flop per addition or
    /// multiplication), known after the symbolic analysis:
    ///
    /// Σ over supernodes of c³/3 + b·c² + b²·c, c the supernode's columns and b its rows below
    /// the diagonal block: the dense Cholesky of the c×c block, the triangular solve of the b×c
    /// panel, and the panel's symmetric update of the ancestors. A simplicial factor counts each
    /// column as a supernode of one column, 1/3 + b + b² with b its entries below the diagonal;
    /// the two forms agree exactly, since a supernode's columns counted one by one sum to
    /// ((b + c)³ − b³)/3, the supernodal term. An operation-by-operation count of the elimination
    /// adds Σ_columns (b + 2/3) (the divisions and square roots), of lower order. Used by
    /// [`LinearMethod::Auto`](crate::linear_solver::LinearMethod::Auto) to predict the
    /// factorization's time.
    pub fn factor_flops(&self) -> f64 {
        let term = |c: f64, b: f64| c * c * c / 3.0 + b * c * c + b * b * c;
        (self.supernodes().into_iter())
            .map(|(c, values)| {
                // A supernode's values are its (c + b)×c dense block.
                let rows = values.checked_div(c).unwrap_or(0);
                term(c as f64, rows.saturating_sub(c) as f64)
            })
            .sum()
    }

    /// Per supernode of the factor, its columns c and its stored values (the dense (c + b)×c
    /// block); a simplicial factor's columns each as a supernode of one column (its diagonal
    /// entry first, then its b entries below).
    fn supernodes(&self) -> Vec<(usize, usize)> {
        use faer::sparse::linalg::cholesky::SymbolicCholeskyRaw;
        match self.symbolic.raw() {
            SymbolicCholeskyRaw::Supernodal(sn) => {
                let (begin, end, val) = (
                    sn.supernode_begin(),
                    sn.supernode_end(),
                    sn.col_ptr_for_val(),
                );
                (0..sn.n_supernodes())
                    .map(|s| (end[s] - begin[s], val[s + 1] - val[s]))
                    .collect()
            }
            SymbolicCholeskyRaw::Simplicial(simplicial) => (simplicial.col_ptr().windows(2))
                .map(|w| (1, w[1] - w[0]))
                .collect(),
        }
    }
}

/// [`Error::InvalidParameter`] unless `matrix` is on `pattern` (the one a factorization of kind
/// `what` was analysed for: the same pattern, or an equal one) with every value finite — the
/// check before each numeric factorization of a refilled matrix.
pub(crate) fn check_refill(
    pattern: &Arc<SymbolicSparseColMat<usize>>,
    matrix: &CscMatrix,
    what: &str,
) -> Result<()> {
    if !Arc::ptr_eq(pattern, matrix.pattern())
        && (pattern.col_ptr() != matrix.col_ptr() || pattern.row_idx() != matrix.row_idx())
    {
        return Err(Error::invalid_parameter(
            "matrix",
            "a different sparsity pattern",
            format!("must have the pattern the {what} was analysed for"),
        ));
    }
    if let Some(k) = matrix.values().iter().position(|v| !v.is_finite()) {
        return Err(Error::invalid_parameter(
            "matrix value",
            format!("entry {k} = {}", matrix.values()[k]),
            "must be finite",
        ));
    }
    Ok(())
}
