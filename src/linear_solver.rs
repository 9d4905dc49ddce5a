//! The linear solver behind the static and implicit solves: a sparse Cholesky factorization when
//! its factor fits in memory, preconditioned conjugate gradients when it does not.

use crate::amg::DofGeometry;
use crate::error::{Error, Result};
use crate::iterative::{CgOptions, Preconditioner, PreconditionerKind, conjugate_gradient};
use crate::linsolve::{CholeskyOptions, SparseCholesky};
use crate::sparse::CscMatrix;

/// Direct, iterative, or chosen by the predicted memory of the factor.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum LinearMethod {
    /// Cholesky if its factor (known after the symbolic analysis) fits in the memory budget,
    /// conjugate gradients otherwise. The default.
    #[default]
    Auto,
    /// Always the sparse Cholesky factorization.
    Direct,
    /// Always preconditioned conjugate gradients (the preconditioner of
    /// [`SolverOptions::preconditioner`], smoothed-aggregation multigrid by default).
    Iterative,
}

impl std::str::FromStr for LinearMethod {
    type Err = Error;

    fn from_str(name: &str) -> Result<Self> {
        match name {
            "auto" => Ok(LinearMethod::Auto),
            "direct" | "cholesky" => Ok(LinearMethod::Direct),
            "iterative" | "cg" => Ok(LinearMethod::Iterative),
            other => Err(Error::invalid_parameter(
                "linear solver",
                other,
                "must be 'auto', 'direct' (alias 'cholesky') or 'iterative' (alias 'cg')",
            )),
        }
    }
}

/// Options of a [`LinearSolver`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SolverOptions {
    /// Direct, iterative or automatic.
    pub method: LinearMethod,
    /// Ordering and threads of the Cholesky factorization.
    pub cholesky: CholeskyOptions,
    /// Stopping rule of conjugate gradients.
    pub cg: CgOptions,
    /// Preconditioner of conjugate gradients.
    pub preconditioner: PreconditionerKind,
    /// Bytes the Cholesky factor may take under [`LinearMethod::Auto`]; `None` means 60 % of the
    /// memory available when the solver is built (`MemAvailable` in /proc/meminfo; unlimited
    /// where that cannot be read).
    pub memory_budget: Option<usize>,
}

impl Default for SolverOptions {
    fn default() -> Self {
        SolverOptions {
            method: LinearMethod::Auto,
            cholesky: CholeskyOptions::default(),
            cg: CgOptions::default(),
            preconditioner: PreconditionerKind::default(),
            memory_budget: None,
        }
    }
}

/// What one solve did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SolveInfo {
    /// Triangular solves with the Cholesky factor.
    Direct,
    /// Conjugate gradients: iterations and final relative residual.
    Iterative {
        /// Iterations taken.
        iterations: usize,
        /// ‖b − A·x‖/‖b‖ at the end.
        relative_residual: f64,
    },
}

/// A symmetric positive definite system solver, set up for one matrix pattern.
#[derive(Debug)]
pub enum LinearSolver {
    /// Sparse Cholesky, analysed once, refactored per matrix.
    Direct(Box<SparseCholesky>),
    /// Preconditioned CG; the preconditioner is rebuilt per matrix.
    Iterative {
        /// Preconditioner of the current matrix (built by `factorize`: it needs the values).
        preconditioner: Option<Box<dyn Preconditioner>>,
        /// Which one it is (rebuilt on each factorize).
        kind: PreconditionerKind,
        /// Where the matrix's DOFs sit, for the rigid-body modes of smoothed aggregation.
        geometry: Option<Box<DofGeometry>>,
        /// Stopping rule.
        options: CgOptions,
    },
}

impl LinearSolver {
    /// Chooses the method and analyses `matrix`'s pattern (the symbolic Cholesky analysis; the
    /// iterative path needs nothing before the values). Only the pattern is read here. Call
    /// [`factorize`](Self::factorize) before solving.
    pub fn analyze(matrix: &CscMatrix, options: SolverOptions) -> Result<Self> {
        LinearSolver::analyze_with_geometry(matrix, options, None)
    }

    /// As [`analyze`](Self::analyze), with the node, axis and position of each of `matrix`'s
    /// DOFs, from which the smoothed-aggregation preconditioner builds the rigid-body modes
    /// (without it: the three translations, more iterations).
    /// [`Error::DimensionMismatch`] if `geometry` does not describe `matrix.dim()` DOFs.
    pub fn analyze_with_geometry(
        matrix: &CscMatrix,
        options: SolverOptions,
        geometry: Option<DofGeometry>,
    ) -> Result<Self> {
        if let Some(geometry) = &geometry {
            Error::check_len("DofGeometry DOFs", matrix.dim(), geometry.len())?;
        }
        let iterative = |options: SolverOptions| -> Result<Self> {
            Ok(LinearSolver::Iterative {
                preconditioner: None,
                kind: options.preconditioner,
                geometry: geometry.map(Box::new),
                options: options.cg,
            })
        };
        match options.method {
            LinearMethod::Iterative => iterative(options),
            LinearMethod::Direct | LinearMethod::Auto => {
                let cholesky = SparseCholesky::analyze_with(matrix, options.cholesky)?;
                let budget = options
                    .memory_budget
                    .or_else(|| available_memory().map(|m| m / 10 * 6));
                if options.method == LinearMethod::Auto
                    && budget.is_some_and(|b| cholesky.factor_bytes() > b)
                {
                    return iterative(options);
                }
                Ok(LinearSolver::Direct(Box::new(cholesky)))
            }
        }
    }

    /// Prepares for solves with `matrix` (on the analysed pattern): the numeric Cholesky
    /// factorization, reusing the analysis and the factor's storage, or a new preconditioner.
    pub fn factorize(&mut self, matrix: &CscMatrix) -> Result<()> {
        match self {
            LinearSolver::Direct(cholesky) => cholesky.factorize(matrix),
            LinearSolver::Iterative {
                preconditioner,
                kind,
                geometry,
                ..
            } => {
                // The old hierarchy goes first: two at once would double the peak memory.
                *preconditioner = None;
                *preconditioner = Some(kind.build_with_geometry(matrix, geometry.as_deref())?);
                Ok(())
            }
        }
    }

    /// Solves `matrix`·x = b in place (`rhs` holds b on entry, x on return). `matrix` must be the
    /// one last passed to [`factorize`](Self::factorize): CG multiplies by it,
    /// the direct method uses its factor.
    pub fn solve(&mut self, matrix: &CscMatrix, rhs: &mut [f64]) -> Result<SolveInfo> {
        match self {
            LinearSolver::Direct(cholesky) => {
                cholesky.solve_in_place(rhs)?;
                Ok(SolveInfo::Direct)
            }
            LinearSolver::Iterative {
                preconditioner,
                options,
                ..
            } => {
                let Some(preconditioner) = preconditioner else {
                    return Err(Error::Solver(
                        "LinearSolver::solve called before factorize".into(),
                    ));
                };
                let mut x = vec![0.0; rhs.len()];
                let report =
                    conjugate_gradient(matrix, preconditioner.as_ref(), rhs, &mut x, *options)?;
                rhs.copy_from_slice(&x);
                Ok(SolveInfo::Iterative {
                    iterations: report.iterations,
                    relative_residual: report.relative_residual,
                })
            }
        }
    }

    /// Stored values of the Cholesky factor (0 for the iterative method).
    pub fn factor_len(&self) -> usize {
        match self {
            LinearSolver::Direct(cholesky) => cholesky.factor_len(),
            LinearSolver::Iterative { .. } => 0,
        }
    }

    /// Whether this is the direct method.
    pub fn is_direct(&self) -> bool {
        matches!(self, LinearSolver::Direct(_))
    }
}

/// `MemAvailable` from /proc/meminfo, in bytes.
fn available_memory() -> Option<usize> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kib: usize = line.split_whitespace().nth(1)?.parse().ok()?;
    kib.checked_mul(1024)
}
