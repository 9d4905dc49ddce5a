//! The linear solver behind the static and implicit solves: a sparse Cholesky factorization or
//! preconditioned conjugate gradients, chosen by predicted time within a memory budget.

use crate::amg::DofGeometry;
use crate::error::{Error, Result};
use crate::iterative::{
    CgOptions, CgReport, Preconditioner, PreconditionerKind, conjugate_gradient,
    conjugate_gradient_with,
};
use crate::linsolve::{CholeskyOptions, SparseCholesky};
use crate::memory::{MemoryLimits, dense_kernel_reservation};
use crate::sparse::CscMatrix;

/// Direct, iterative, or chosen by predicted time within the memory budget.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(
    feature = "serde",
    derive(serde::Deserialize, serde::Serialize),
    serde(rename_all = "snake_case")
)]
pub enum LinearMethod {
    /// The faster of the two by the [`CostModel`]'s predicted time for
    /// [`SolverOptions::expected_solves`] right-hand sides, among those that fit: the Cholesky
    /// only if its factor (known after the symbolic analysis) fits the memory budget. The
    /// default. [`LinearSolver::choice`] says which method was taken and why.
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
    /// memory available when the solver is built: the least of `MemAvailable`, the cgroup's
    /// limit less its usage and `RLIMIT_AS`/`RLIMIT_DATA` less what the process holds (see
    /// [`MemoryLimits`]; unlimited where none can be read). A hard limit: Auto never factors
    /// above it. [`LinearMethod::Direct`] factors whenever the factor fits the whole available
    /// memory, and is [`Error::InsufficientMemory`] otherwise.
    pub memory_budget: Option<usize>,
    /// Right-hand sides the caller expects to solve per factorization (per matrix), at least 1
    /// (default 1). [`LinearMethod::Auto`] weighs the factorization, paid once, against the
    /// solves: a triangular solve costs a small fraction of a CG solve, so several load cases of
    /// one static problem, or the steps of a time stepper that reuses its matrix, favour the
    /// Cholesky. A Newton iteration that refactors for every solve is 1.
    pub expected_solves: usize,
    /// The rates behind [`LinearMethod::Auto`]'s predicted times.
    pub cost_model: CostModel,
}

impl Default for SolverOptions {
    fn default() -> Self {
        SolverOptions {
            method: LinearMethod::Auto,
            cholesky: CholeskyOptions::default(),
            cg: CgOptions::default(),
            preconditioner: PreconditionerKind::default(),
            memory_budget: None,
            expected_solves: 1,
            cost_model: CostModel::default(),
        }
    }
}

/// A rate measured with one thread and with two (the machine of the measurements has two
/// cores). More than two threads are assumed no faster than two: the prediction then errs on the
/// slow side for both methods alike.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ThreadRates {
    /// With one thread.
    pub one: f64,
    /// With two or more threads.
    pub two_or_more: f64,
}

impl ThreadRates {
    /// The rate for `threads` threads (0 counts as 1).
    pub fn at(&self, threads: usize) -> f64 {
        if threads >= 2 {
            self.two_or_more
        } else {
            self.one
        }
    }
}

/// Predicted wall times of the two methods, from sizes known before any numeric work:
///
/// - direct: T_d = F / R_f + s · |L| · t_s, with F the factorization's flops
///   ([`SparseCholesky::factor_flops`]), |L| the factor's stored values
///   ([`SparseCholesky::factor_len`]) and s the expected solves;
/// - iterative (CG + SA-AMG with the rigid-body modes): T_i = nnz · t_a + s · m · nnz · t_c,
///   with nnz the matrix's stored entries (both triangles) and m = d · log10(1/tol) the
///   iterations for CG's relative tolerance tol.
///
/// The defaults were fitted to the scale study (`validation/scale_results.txt`: cantilever beams
/// of 5k×k×k cells, METIS ordering, CG to 1e-10) on its 2-core machine; see the comments on each
/// constant in [`CostModel::default`]. On another machine both methods speed up or slow down
/// roughly together (both are bound by memory bandwidth and flop rate alike), so the choice
/// moves less than the times; a caller with measurements of its own can set the fields.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CostModel {
    /// R_f, speed of the numeric Cholesky factorization (flop/s), at the Cholesky's threads.
    pub factor_flops_per_second: ThreadRates,
    /// t_s, time of one solve (forward and backward substitution) per stored factor value (seconds).
    pub solve_seconds_per_factor_value: ThreadRates,
    /// t_a, SA-AMG setup time per stored matrix entry (seconds), at rayon's thread count.
    pub amg_setup_seconds_per_entry: ThreadRates,
    /// t_c, time of one CG iteration (a product with the matrix and a V-cycle) per stored matrix
    /// entry (seconds), at rayon's thread count.
    pub iteration_seconds_per_entry: ThreadRates,
    /// d, CG iterations per decade of residual reduction with SA-AMG and the rigid-body modes
    /// (dimensionless).
    pub iterations_per_decade: f64,
}

impl Default for CostModel {
    fn default() -> Self {
        // Fitted to validation/scale_results.txt (commit 186ade2: METIS ordering, CG to 1e-10;
        // flops and nnz(K_ff) of those beams from `cargo bench --bench solver_choice`),
        // sizes from k = 12 (31k DOFs) up, where the rates have settled. Ratios time/size:
        CostModel {
            // Numeric factorization, flops / time, with tetfem's supernodal kernel (scale study
            // of commit 36bb369; the same symbolic analyses, so the same flops). 1 thread,
            // k = 12, 16, 20, 24, 30, 40: 16.5, 21.8, 22.8, 21.3, 24.1, 24.5 Gflop/s; 21 weighs
            // the sizes near the crossover with the iterative method. 2 threads, k = 20, 30:
            // 30.6, 39.7 Gflop/s. (faer's kernel measured 15.1–19.5 and 22.1–27.2.)
            factor_flops_per_second: ThreadRates {
                one: 21e9,
                two_or_more: 33e9,
            },
            // Solve time / factor values. 1 thread: 1.15, 1.08, 0.97, 1.15, 0.87, 1.32 ns
            // (median 1.1); 2 threads, k = 20, 30: 0.69, 0.50 ns.
            solve_seconds_per_factor_value: ThreadRates {
                one: 1.1e-9,
                two_or_more: 0.6e-9,
            },
            // AMG setup time / nnz(K_ff), 2 threads, k = 12, 16, 24, 30, 40: 437, 320, 425,
            // 418, 440 ns (the fused products of the later setup measured the same to within the
            // noise, side by side at k = 20). No one-thread runs: the setup and the cycle move
            // more bytes than they compute, so one thread is taken slower by the ratio of the
            // study's triad bandwidths, 26.3 / 17.0 GB/s = 1.55.
            amg_setup_seconds_per_entry: ThreadRates {
                one: 650e-9,
                two_or_more: 420e-9,
            },
            // CG solve time / (iterations · nnz(K_ff)), 2 threads, k = 12, 16, 24, 30, 40: 15.1,
            // 11.0, 9.5, 8.1, 7.1 ns (falling as the coarse levels' share shrinks; median 9.5).
            // One thread: × 1.55 as above.
            iteration_seconds_per_entry: ThreadRates {
                one: 15e-9,
                two_or_more: 9.5e-9,
            },
            // 28–30 iterations to 1e-10 at every size from 10k to 1.01M DOFs: 3 per decade.
            iterations_per_decade: 3.0,
        }
    }
}

/// Predicted times of both methods for one problem (seconds; see [`CostModel`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PredictedTimes {
    /// Right-hand sides the totals are for ([`SolverOptions::expected_solves`]).
    pub solves: usize,
    /// F / R_f: the numeric Cholesky factorization.
    pub factorization: f64,
    /// |L| · t_s: one direct solve.
    pub direct_solve: f64,
    /// nnz · t_a: the SA-AMG setup.
    pub amg_setup: f64,
    /// m: CG iterations per solve.
    pub iterations: f64,
    /// m · nnz · t_c: one CG solve.
    pub iterative_solve: f64,
}

impl PredictedTimes {
    /// Factorization and all the solves, direct (seconds).
    pub fn direct(&self) -> f64 {
        self.factorization + self.solves as f64 * self.direct_solve
    }

    /// Setup and all the solves, iterative (seconds).
    pub fn iterative(&self) -> f64 {
        self.amg_setup + self.solves as f64 * self.iterative_solve
    }
}

/// What [`LinearMethod::Auto`] decides from: sizes from the symbolic analysis and the matrix,
/// the memory budget, and the threads each method would run on.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ChoiceInputs {
    /// Stored entries of the matrix (both triangles).
    pub matrix_entries: usize,
    /// [`SparseCholesky::factor_len`].
    pub factor_len: usize,
    /// [`SparseCholesky::factor_flops`].
    pub factor_flops: f64,
    /// [`SparseCholesky::factor_bytes`], the factor and its workspace.
    pub factor_bytes: usize,
    /// The budget in bytes (`None`: unlimited).
    pub memory_budget: Option<usize>,
    /// Threads of the Cholesky ([`CholeskyOptions::threads`]).
    pub cholesky_threads: usize,
    /// Threads of the iterative path (rayon's pool).
    pub iterative_threads: usize,
    /// Whether the cost model's iteration estimate applies: smoothed aggregation with the
    /// rigid-body modes. Block Jacobi, IC(0) and SA with the translations only need iterations
    /// that grow with the mesh (hundreds to thousands), which it cannot predict.
    pub iteration_estimate: bool,
}

impl CostModel {
    /// The predicted times for `inputs` with `solves` right-hand sides, CG to relative
    /// tolerance `tolerance` (at least one iteration).
    pub fn predict(&self, inputs: &ChoiceInputs, solves: usize, tolerance: f64) -> PredictedTimes {
        let nnz = inputs.matrix_entries as f64;
        let decades = if tolerance > 0.0 && tolerance < 1.0 {
            -tolerance.log10()
        } else {
            0.0
        };
        let iterations = (self.iterations_per_decade * decades).max(1.0);
        let (tc, ti) = (inputs.cholesky_threads, inputs.iterative_threads);
        PredictedTimes {
            solves,
            factorization: inputs.factor_flops / self.factor_flops_per_second.at(tc),
            direct_solve: inputs.factor_len as f64 * self.solve_seconds_per_factor_value.at(tc),
            amg_setup: nnz * self.amg_setup_seconds_per_entry.at(ti),
            iterations,
            iterative_solve: iterations * nnz * self.iteration_seconds_per_entry.at(ti),
        }
    }
}

/// Why a [`LinearSolver`] uses its method.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ChoiceReason {
    /// The caller asked for it ([`LinearMethod::Direct`] or [`LinearMethod::Iterative`]).
    Requested,
    /// Auto: the factor and its workspace would exceed the memory budget (bytes).
    FactorOverBudget {
        /// [`SparseCholesky::factor_bytes`].
        factor_bytes: usize,
        /// The budget.
        budget: usize,
    },
    /// Auto: this method's predicted time is the lower (ties go to the direct method, whose
    /// time varies less).
    PredictedFaster,
    /// Auto: the factor fits and the cost model has no iteration estimate for the iterative
    /// path (see [`ChoiceInputs::iteration_estimate`]).
    NoIterationEstimate,
}

/// Which method a [`LinearSolver`] uses, why, and the predicted times when they were computed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MethodChoice {
    /// [`LinearMethod::Direct`] or [`LinearMethod::Iterative`].
    pub method: LinearMethod,
    /// Why.
    pub reason: ChoiceReason,
    /// The predicted times of both methods (`None` when the iterative method was requested: no
    /// symbolic analysis is run then).
    pub predicted: Option<PredictedTimes>,
}

impl MethodChoice {
    /// Whether the choice is the direct method.
    pub fn is_direct(&self) -> bool {
        self.method == LinearMethod::Direct
    }
}

impl std::fmt::Display for MethodChoice {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let name = if self.is_direct() {
            "direct (sparse Cholesky)"
        } else {
            "iterative (preconditioned CG)"
        };
        write!(f, "{name}: ")?;
        match self.reason {
            ChoiceReason::Requested => write!(f, "requested")?,
            ChoiceReason::FactorOverBudget {
                factor_bytes,
                budget,
            } => write!(
                f,
                "the Cholesky factor would take {:.3} GB, over the {:.3} GB memory budget",
                factor_bytes as f64 * 1e-9,
                budget as f64 * 1e-9
            )?,
            ChoiceReason::PredictedFaster => write!(f, "predicted faster")?,
            ChoiceReason::NoIterationEstimate => write!(
                f,
                "the factor fits and the iterations of this preconditioner cannot be predicted"
            )?,
        }
        if let Some(p) = &self.predicted {
            write!(
                f,
                " (predicted for {} solve{}: direct {:.3} s = factorization {:.3} s + {:.3} s per \
                 solve; iterative {:.3} s = setup {:.3} s + {:.3} s per solve of {:.0} iterations)",
                p.solves,
                if p.solves == 1 { "" } else { "s" },
                p.direct(),
                p.factorization,
                p.direct_solve,
                p.iterative(),
                p.amg_setup,
                p.iterative_solve,
                p.iterations
            )?;
        }
        Ok(())
    }
}

/// [`LinearMethod::Auto`]'s decision (and the report of the other two) as a pure function of
/// its inputs: memory first (a factor over the budget is never chosen), then the predicted times
/// of [`SolverOptions::cost_model`] for [`SolverOptions::expected_solves`] right-hand sides.
/// [`Error::InvalidParameter`] if `expected_solves` is 0.
pub fn choose_method(inputs: &ChoiceInputs, options: &SolverOptions) -> Result<MethodChoice> {
    if options.expected_solves == 0 {
        return Err(Error::invalid_parameter(
            "expected_solves",
            0,
            "must be at least 1",
        ));
    }
    // A NaN or negative flop count would make every predicted time NaN, and NaN compares
    // false both ways, so the choice would silently fall to one side.
    if !(inputs.factor_flops.is_finite() && inputs.factor_flops >= 0.0) {
        return Err(Error::invalid_parameter(
            "factor_flops",
            inputs.factor_flops,
            "must be finite and non-negative",
        ));
    }
    let predicted = options.cost_model.predict(
        inputs,
        options.expected_solves,
        options.cg.relative_tolerance,
    );
    let choice = |method, reason| MethodChoice {
        method,
        reason,
        predicted: Some(predicted),
    };
    Ok(match options.method {
        LinearMethod::Direct => choice(LinearMethod::Direct, ChoiceReason::Requested),
        LinearMethod::Iterative => choice(LinearMethod::Iterative, ChoiceReason::Requested),
        LinearMethod::Auto => match inputs.memory_budget {
            Some(budget) if inputs.factor_bytes > budget => choice(
                LinearMethod::Iterative,
                ChoiceReason::FactorOverBudget {
                    factor_bytes: inputs.factor_bytes,
                    budget,
                },
            ),
            _ if !inputs.iteration_estimate => {
                choice(LinearMethod::Direct, ChoiceReason::NoIterationEstimate)
            }
            _ if predicted.iterative() < predicted.direct() => {
                choice(LinearMethod::Iterative, ChoiceReason::PredictedFaster)
            }
            _ => choice(LinearMethod::Direct, ChoiceReason::PredictedFaster),
        },
    })
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

/// A symmetric positive definite system solver, set up for one matrix pattern: the method
/// ([`choice`](Self::choice)) and its state.
#[derive(Debug)]
pub struct LinearSolver {
    backend: Backend,
    choice: MethodChoice,
}

#[derive(Debug)]
enum Backend {
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
    /// (without it: the three translations, more iterations, and [`LinearMethod::Auto`] then
    /// chooses the Cholesky whenever it fits: see [`ChoiceReason::NoIterationEstimate`]).
    /// [`Error::DimensionMismatch`] if `geometry` does not describe `matrix.dim()` DOFs;
    /// [`Error::InvalidParameter`] if `options.expected_solves` is 0.
    pub fn analyze_with_geometry(
        matrix: &CscMatrix,
        options: SolverOptions,
        geometry: Option<DofGeometry>,
    ) -> Result<Self> {
        if let Some(geometry) = &geometry {
            Error::check_len("DofGeometry DOFs", matrix.dim(), geometry.len())?;
        }
        if options.expected_solves == 0 {
            return Err(Error::invalid_parameter(
                "expected_solves",
                0,
                "must be at least 1",
            ));
        }
        let iteration_estimate =
            options.preconditioner == PreconditionerKind::SmoothedAggregation && geometry.is_some();
        let iterative = |choice: MethodChoice| -> Result<Self> {
            Ok(LinearSolver {
                backend: Backend::Iterative {
                    preconditioner: None,
                    kind: options.preconditioner,
                    geometry: geometry.map(Box::new),
                    options: options.cg,
                },
                choice,
            })
        };
        if options.method == LinearMethod::Iterative {
            // No symbolic analysis: it would cost time and the choice is made.
            return iterative(MethodChoice {
                method: LinearMethod::Iterative,
                reason: ChoiceReason::Requested,
                predicted: None,
            });
        }
        let cholesky = SparseCholesky::analyze_with(matrix, options.cholesky)?;
        // A supernodal factor maps the dense kernels' buffers too (address space only).
        let buffers = match cholesky.is_supernodal() {
            true => dense_kernel_reservation().for_threads(cholesky.threads()),
            false => 0,
        };
        let limits = MemoryLimits::current().keeping_back(buffers);
        if options.method == LinearMethod::Direct {
            // Requested, so no fallback: stop here rather than be aborted by the allocator.
            limits.ensure_fits_or(
                format!(
                    "the Cholesky factor of {} free DOFs ({} stored values and the workspace)",
                    matrix.dim(),
                    cholesky.factor_len()
                ),
                cholesky.factor_bytes() as u128,
                "use the iterative solver (linear_solver = \"iterative\"), which holds no \
                 factor, or a coarser mesh",
            )?;
        }
        let inputs = ChoiceInputs {
            matrix_entries: matrix.nnz(),
            factor_len: cholesky.factor_len(),
            factor_flops: cholesky.factor_flops(),
            factor_bytes: cholesky.factor_bytes(),
            memory_budget: options.memory_budget.or_else(|| {
                limits
                    .available()
                    .map(|m| usize::try_from(m / 10 * 6).unwrap_or(usize::MAX))
            }),
            cholesky_threads: options.cholesky.threads,
            iterative_threads: rayon::current_num_threads(),
            iteration_estimate,
        };
        let choice = choose_method(&inputs, &options)?;
        if choice.is_direct() {
            Ok(LinearSolver {
                backend: Backend::Direct(Box::new(cholesky)),
                choice,
            })
        } else {
            drop(cholesky);
            iterative(choice)
        }
    }

    /// Prepares for solves with `matrix` (on the analysed pattern): the numeric Cholesky
    /// factorization, reusing the analysis and the factor's storage, or a new preconditioner.
    pub fn factorize(&mut self, matrix: &CscMatrix) -> Result<()> {
        match &mut self.backend {
            Backend::Direct(cholesky) => cholesky.factorize(matrix),
            Backend::Iterative {
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
        match &mut self.backend {
            Backend::Direct(cholesky) => {
                cholesky.solve_in_place(rhs)?;
                Ok(SolveInfo::Direct)
            }
            Backend::Iterative {
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

    /// Keeps a single-precision copy of the direct method's current factor for
    /// [`solve_approximate`](Self::solve_approximate) and the preconditioned solves
    /// ([`SparseCholesky::make_single_precision_copy`]); returns whether there is one (never
    /// for the iterative method, a simplicial factor, or too little memory). The next
    /// [`factorize`](Self::factorize) makes it stale, and those solves read the f64 factor
    /// again.
    pub fn make_single_precision_copy(&mut self) -> Result<bool> {
        match &mut self.backend {
            Backend::Direct(cholesky) => cholesky.make_single_precision_copy(),
            Backend::Iterative { .. } => Ok(false),
        }
    }

    /// [`solve`](Self::solve) for a caller that needs an approximation of A⁻¹·b only (a
    /// preconditioner, a quasi-Newton method's initial Hessian): the triangular solves read
    /// the single-precision copy of the factor when there is a current one (1.6× faster
    /// measured at 132k DOFs; the result that of A perturbed by about 1e-7·cond relative),
    /// else the f64 factor, or the iterative method's CG.
    pub fn solve_approximate(&mut self, matrix: &CscMatrix, rhs: &mut [f64]) -> Result<()> {
        match &mut self.backend {
            Backend::Direct(cholesky) => solve_as_preconditioner(cholesky, rhs),
            Backend::Iterative { .. } => self.solve(matrix, rhs).map(|_| ()),
        }
    }

    /// [`solve_approximate`](Self::solve_approximate) for the columns of `rhs` (column-major,
    /// `matrix.dim()` long each): on the direct method's supernodal factor 16 columns share each
    /// pass over the factor ([`SparseCholesky::solve_many_approximate`]); the iterative method
    /// solves them one by one.
    pub fn solve_approximate_many(&mut self, matrix: &CscMatrix, rhs: &mut [f64]) -> Result<()> {
        match &mut self.backend {
            Backend::Direct(cholesky) => cholesky.solve_many_approximate(rhs),
            Backend::Iterative { .. } => {
                let n = matrix.dim().max(1);
                for column in rhs.chunks_mut(n) {
                    self.solve_approximate(matrix, column)?;
                }
                Ok(())
            }
        }
    }

    /// Solves `matrix`·x = b in place by conjugate gradients preconditioned with what the last
    /// [`factorize`](Self::factorize) prepared for *another* matrix P on the same pattern (the
    /// Cholesky factor's two triangular solves, or the multigrid hierarchy): one factorization
    /// reused for a family of nearby matrices, as a nonlinear step's tangents near its rest
    /// matrix; the factor's single-precision copy when there is a current one
    /// ([`make_single_precision_copy`](Self::make_single_precision_copy)). Starts from x = 0
    /// and stops by `options` ([`CgOptions`]); an
    /// [`Error::Solver`] when `matrix` is not positive definite along a search direction or CG
    /// does not converge in `options.max_iterations` (the caller then factors `matrix` itself).
    pub fn solve_preconditioned(
        &mut self,
        matrix: &CscMatrix,
        rhs: &mut [f64],
        options: CgOptions,
    ) -> Result<CgReport> {
        Error::check_len("right-hand side", matrix.dim(), rhs.len())?;
        let mut x = vec![0.0; rhs.len()];
        let report = match &mut self.backend {
            Backend::Direct(cholesky) => {
                Error::check_len("factor dimension", matrix.dim(), cholesky.dim())?;
                conjugate_gradient_with(
                    matrix,
                    &mut |r, z| {
                        z.copy_from_slice(r);
                        solve_as_preconditioner(cholesky, z)
                    },
                    rhs,
                    &mut x,
                    options,
                )?
            }
            Backend::Iterative { preconditioner, .. } => {
                let Some(preconditioner) = preconditioner else {
                    return Err(Error::Solver(
                        "LinearSolver::solve_preconditioned called before factorize".into(),
                    ));
                };
                conjugate_gradient(matrix, preconditioner.as_ref(), rhs, &mut x, options)?
            }
        };
        rhs.copy_from_slice(&x);
        Ok(report)
    }

    /// [`solve_preconditioned`](Self::solve_preconditioned) with the factor turned by an
    /// orthogonal map Q: P⁻¹ = Q·F⁻¹·Qᵀ, F the matrix last factored, `turn(v, true)` setting
    /// v ← Qᵀ·v and `turn(v, false)` v ← Q·v. For a family of matrices Q·F·Qᵀ + (small), as the
    /// Newton matrices of a body that has turned away from the state F was made at. The direct
    /// method only: [`Error::Solver`] for the iterative one (no factor to turn).
    pub fn solve_preconditioned_turned(
        &mut self,
        matrix: &CscMatrix,
        rhs: &mut [f64],
        options: CgOptions,
        turn: &dyn Fn(&mut [f64], bool),
    ) -> Result<CgReport> {
        Error::check_len("right-hand side", matrix.dim(), rhs.len())?;
        let Backend::Direct(cholesky) = &mut self.backend else {
            return Err(Error::Solver(
                "a turned preconditioner needs the direct method's factor".into(),
            ));
        };
        Error::check_len("factor dimension", matrix.dim(), cholesky.dim())?;
        let mut x = vec![0.0; rhs.len()];
        let report = conjugate_gradient_with(
            matrix,
            &mut |r, z| {
                z.copy_from_slice(r);
                turn(z, true);
                solve_as_preconditioner(cholesky, z)?;
                turn(z, false);
                Ok(())
            },
            rhs,
            &mut x,
            options,
        )?;
        rhs.copy_from_slice(&x);
        Ok(report)
    }

    /// Stored values of the Cholesky factor (0 for the iterative method).
    pub fn factor_len(&self) -> usize {
        match &self.backend {
            Backend::Direct(cholesky) => cholesky.factor_len(),
            Backend::Iterative { .. } => 0,
        }
    }

    /// Floating-point operations of one numeric factorization
    /// ([`SparseCholesky::factor_flops`]), known after the symbolic analysis; `None` for the
    /// iterative method.
    pub fn factor_flops(&self) -> Option<f64> {
        match &self.backend {
            Backend::Direct(cholesky) => Some(cholesky.factor_flops()),
            Backend::Iterative { .. } => None,
        }
    }

    /// Bytes of the Cholesky factor and its workspace ([`SparseCholesky::factor_bytes`]; 0 for
    /// the iterative method).
    pub fn factor_bytes(&self) -> usize {
        match &self.backend {
            Backend::Direct(cholesky) => cholesky.factor_bytes(),
            Backend::Iterative { .. } => 0,
        }
    }

    /// Whether this is the direct method.
    pub fn is_direct(&self) -> bool {
        matches!(self.backend, Backend::Direct(_))
    }

    /// Which method this solver uses and why (its [`Display`](std::fmt::Display) is one
    /// readable line).
    pub fn choice(&self) -> &MethodChoice {
        &self.choice
    }
}

/// A solve with the factor where only an approximation of A⁻¹ is needed (a preconditioner, an
/// initial inverse Hessian): by its single-precision copy when there is a current one
/// ([`SparseCholesky::make_single_precision_copy`]), else by the f64 factor. Either way a
/// fixed symmetric positive definite operator, as preconditioned CG requires.
fn solve_as_preconditioner(cholesky: &mut SparseCholesky, rhs: &mut [f64]) -> Result<()> {
    match cholesky.has_single_precision_copy() {
        true => cholesky.solve_in_place_single(rhs),
        false => cholesky.solve_in_place(rhs),
    }
}
