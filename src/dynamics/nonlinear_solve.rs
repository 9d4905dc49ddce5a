//! How the Newton iterations of an implicit step with a nonlinear force model solve their
//! linear systems: a new factorization each iteration, or conjugate gradients preconditioned by
//! one factorization kept across iterations and steps.

use crate::error::{Error, Result};

/// The linear solve J(u')·δ = −r of each Newton iteration of an implicit step with a nonlinear
/// [`InternalForce`](super::InternalForce), J(u') = (s_m + s_c·α)·M + s_c·β·K_T(u) + K_T(u')
/// (see [`StepNewtonOptions`](super::StepNewtonOptions); s_m = 1/dt², s_c = 1/dt for backward
/// Euler). Either way Newton stops by the same test on the nonlinear residual
/// (‖r‖ ≤ tolerance·max(‖r₀‖, ‖f‖)), so the two give the same step to that tolerance; they
/// differ in cost only.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum NonlinearSolve {
    /// Refill J(u') and factor it numerically every Newton iteration (on the symbolic analysis
    /// made once): quadratic convergence, one factorization per iteration. At 133k DOFs a
    /// factorization costs about 70 triangular solve pairs, so this is 25–80× a linear step.
    Refactor,
    /// Conjugate gradients on the exact J(u'), preconditioned by the factor of the rest Newton
    /// matrix J₀ = (s_m + s_c·α)·M + (1 + s_c·β)·K₀ (K₀ = K_ff, the model's tangent at rest),
    /// factored once per time step value. For the corotational model K_T(u) is K₀ rotated
    /// element by element, so J₀⁻¹·J has its eigenvalues near 1 and CG needs few iterations.
    ///
    /// When CG does not reach `forcing`·‖r‖ within `max_cg_iterations` (large rotations
    /// have moved J too far from the factor), or meets a direction of non-positive curvature,
    /// that Newton iteration falls back to [`Refactor`](Self::Refactor)'s factorization of
    /// J(u') (projected onto the positive semi-definite cone if J is not positive definite),
    /// and the new factor then preconditions the following iterations and steps (lagged
    /// refactorization) until the time step changes.
    RestPreconditionedCg {
        /// CG iterations allowed per Newton iteration before falling back to a factorization
        /// (≥ 1).
        max_cg_iterations: usize,
        /// The forcing term η of the inexact Newton iteration: CG stops at
        /// ‖J·δ + r‖ ≤ η·‖r‖ (in (0, 1)). A small η keeps Newton's quadratic convergence, a
        /// large one trades CG iterations for Newton iterations; the step's own tolerance is
        /// unchanged either way.
        forcing: f64,
    },
}

impl Default for NonlinearSolve {
    /// [`RestPreconditionedCg`](Self::RestPreconditionedCg) with 25 CG iterations and
    /// η = 1e-3 (chosen by `benches/corotational.rs`, see `validation/PERFORMANCE.md`).
    fn default() -> Self {
        NonlinearSolve::RestPreconditionedCg {
            max_cg_iterations: 25,
            forcing: 1e-3,
        }
    }
}

impl NonlinearSolve {
    /// [`Error::InvalidParameter`] naming `nonlinear_solve.max_cg_iterations` (0) or
    /// `nonlinear_solve.forcing` (not finite or outside (0, 1)).
    pub fn check(&self) -> Result<()> {
        match *self {
            NonlinearSolve::Refactor => Ok(()),
            NonlinearSolve::RestPreconditionedCg {
                max_cg_iterations,
                forcing,
            } => {
                if max_cg_iterations == 0 {
                    return Err(Error::invalid_parameter(
                        "nonlinear_solve.max_cg_iterations",
                        0,
                        "must be at least 1",
                    ));
                }
                if !(forcing > 0.0 && forcing < 1.0) {
                    return Err(Error::invalid_parameter(
                        "nonlinear_solve.forcing",
                        forcing,
                        "must be finite, > 0 and < 1",
                    ));
                }
                Ok(())
            }
        }
    }

    /// The name scenes use: `refactor` or `rest_preconditioned`.
    pub fn name(&self) -> &'static str {
        match self {
            NonlinearSolve::Refactor => "refactor",
            NonlinearSolve::RestPreconditionedCg { .. } => "rest_preconditioned",
        }
    }
}

impl std::str::FromStr for NonlinearSolve {
    type Err = Error;

    /// `refactor`, or `rest_preconditioned` with the default CG budget and forcing term.
    fn from_str(name: &str) -> Result<Self> {
        match name {
            "refactor" => Ok(NonlinearSolve::Refactor),
            "rest_preconditioned" => Ok(NonlinearSolve::default()),
            other => Err(Error::invalid_parameter(
                "nonlinear_solver",
                other,
                "must be 'refactor' or 'rest_preconditioned'",
            )),
        }
    }
}
