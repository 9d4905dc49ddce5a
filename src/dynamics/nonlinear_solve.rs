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
    /// factored once per time step value, and turned by the rotation of the deformation at
    /// each node: P⁻¹ = R̄·J₀⁻¹·R̄ᵀ, R̄ = diag(Rᵢ), Rᵢ the polar rotation of the volume-weighted F
    /// of the tets around node i (nodes with a constrained DOF are not turned). For the
    /// corotational model K_T(u) is K₀ rotated element by element and a lumped mass is
    /// unchanged by rotations, so P⁻¹·J has its eigenvalues near 1 however far the body has
    /// turned, and CG needs few iterations. (The iterative linear method has no factor to
    /// turn: its preconditioner is used as it is.)
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
    /// [`Refactor`](Self::Refactor) below [`AUTO_REFACTOR_BELOW`] free DOFs, where a
    /// factorization is cheap; [`RestPreconditionedCg`](Self::RestPreconditionedCg) with 25 CG
    /// iterations and η = 1e-3 (chosen by `benches/corotational.rs`, see
    /// `validation/PERFORMANCE.md`) at and above it.
    Auto,
}

/// Below this many free DOFs [`NonlinearSolve::Auto`] refactors: measured on the swinging
/// rubber cantilever (`examples/corotational_step.rs`, 40 steps of 10 ms from rest, one
/// thread), a factorization of 540 DOFs costs less than the CG iterations it saves
/// (refactoring 2.1× faster per step on `scenes/rubber_beam_swing.toml`), while at 1,500 DOFs
/// the preconditioned path is 1.65× faster, and its lead grows with the size.
pub const AUTO_REFACTOR_BELOW: usize = 1000;

impl Default for NonlinearSolve {
    /// [`Auto`](Self::Auto).
    fn default() -> Self {
        NonlinearSolve::Auto
    }
}

impl NonlinearSolve {
    /// [`Error::InvalidParameter`] naming `nonlinear_solve.max_cg_iterations` (0) or
    /// `nonlinear_solve.forcing` (not finite or outside (0, 1)).
    pub fn check(&self) -> Result<()> {
        match *self {
            NonlinearSolve::Refactor | NonlinearSolve::Auto => Ok(()),
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

    /// What [`Auto`](Self::Auto) is for `free_dofs` unknowns; any other choice as it is.
    pub fn for_size(self, free_dofs: usize) -> Self {
        match self {
            NonlinearSolve::Auto if free_dofs < AUTO_REFACTOR_BELOW => NonlinearSolve::Refactor,
            NonlinearSolve::Auto => NonlinearSolve::RestPreconditionedCg {
                max_cg_iterations: 25,
                forcing: 1e-3,
            },
            other => other,
        }
    }

    /// The name scenes use: `auto`, `refactor` or `rest_preconditioned`.
    pub fn name(&self) -> &'static str {
        match self {
            NonlinearSolve::Auto => "auto",
            NonlinearSolve::Refactor => "refactor",
            NonlinearSolve::RestPreconditionedCg { .. } => "rest_preconditioned",
        }
    }
}

impl std::str::FromStr for NonlinearSolve {
    type Err = Error;

    /// `auto`, `refactor`, or `rest_preconditioned` with the CG budget and forcing term that
    /// `auto` uses.
    fn from_str(name: &str) -> Result<Self> {
        match name {
            "auto" => Ok(NonlinearSolve::Auto),
            "refactor" => Ok(NonlinearSolve::Refactor),
            "rest_preconditioned" => Ok(NonlinearSolve::Auto.for_size(AUTO_REFACTOR_BELOW)),
            other => Err(Error::invalid_parameter(
                "nonlinear_solver",
                other,
                "must be 'auto', 'refactor' or 'rest_preconditioned'",
            )),
        }
    }
}
