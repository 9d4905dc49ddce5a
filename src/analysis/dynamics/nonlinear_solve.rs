//! How the Newton iterations of an implicit step with a nonlinear force model solve their
//! linear systems: a new factorization each iteration, or conjugate gradients preconditioned by
//! one factorization kept across iterations and steps.

use crate::base::error::{Error, Result};

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
    /// turn: its preconditioner is used as it is.) The preconditioner's triangular solves read
    /// the factor rounded to f32 where memory allows the copy
    /// (`LinearSolver::make_single_precision_copy`: half the bytes, 1.27× on the step at 132k
    /// DOFs, the same iterations; computed in f32, a backward-stable solve), a fixed
    /// operator, symmetric positive definite up to f32's rounding, as CG needs.
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
    /// Limited-memory BFGS on the step's potential Φ (the quasi-Newton method of Liu, Bouaziz
    /// & Kavan, "Quasi-Newton methods for real-time simulation of hyperelastic materials",
    /// 2017), its initial inverse Hessian the rest factor turned by the nodes' rotations at the
    /// step's start, H₀ = R̄·J₀⁻¹·R̄ᵀ (as [`RestPreconditionedCg`](Self::RestPreconditionedCg)'s
    /// preconditioner), corrected by the step's last `history` pairs of steps and residual
    /// changes. No tangent is assembled: an iteration is one force evaluation and one pair of
    /// triangular solves (on the factor's f32 copy where memory allows it, as above), about a
    /// linear step's cost, against a tangent assembly (about five force evaluations for the
    /// corotational model) and 3–4 preconditioned CG iterations per
    /// Newton iteration. It converges linearly, not quadratically, so it gains most at the
    /// loose tolerances of animation (`StepNewtonOptions::tolerance`, which the user sets; the
    /// trajectory's distance from Newton's at each tolerance is in `validation/PERFORMANCE.md`).
    ///
    /// In contact with rigid obstacles H₀ also holds the contact nodes' barrier and friction
    /// blocks D (3×3 a node, made at the run's first iterate within d̂ and again after a step
    /// that was cut short or did not halve ‖r‖): H₀ = R̄·(J₀ + E·D·Eᵀ)⁻¹·R̄ᵀ by Woodbury's
    /// identity on the rest factor, with a dense factor of the contact DOFs' size (at most
    /// [`max_contact_dofs`](super::max_contact_dofs), whose factorization costs no more than
    /// J's, and their columns within [`COLUMN_BYTES`](super::COLUMN_BYTES); past either the run
    /// goes on as [`RestPreconditionedCg`](Self::RestPreconditionedCg), which factors J). Two
    /// triangular solve pairs an iteration instead of one, and no factorization: J₀⁻¹'s columns
    /// at the contact DOFs are solved once per DOF the first time it touches, sixteen to a pass
    /// over the factor, and kept (at the landing of the 10k-DOF block of
    /// `benches/interactive_contact.rs`, 675 of them, 0.13–0.16 s).
    ///
    /// Each step starts from an empty history, so a step depends on its state alone. A step
    /// that has not converged within `StepNewtonOptions::max_iterations`, or whose line search
    /// finds no decrease, goes on from where it stands with
    /// [`RestPreconditionedCg`](Self::RestPreconditionedCg) (25 iterations, η = 1e-3) and a
    /// fresh iteration budget (counted in [`NewtonStats::fallbacks`](super::NewtonStats)). With
    /// the iterative linear method (no factor to turn) the steps are preconditioned CG's.
    RestPreconditionedLbfgs {
        /// Correction pairs kept (0: a chord iteration with P⁻¹ alone).
        history: usize,
    },
    /// [`Refactor`](Self::Refactor) below [`AUTO_REFACTOR_BELOW`] free DOFs, where a
    /// factorization is cheap; at and above it [`RestPreconditionedLbfgs`](Self::RestPreconditionedLbfgs)
    /// with [`AUTO_LBFGS_HISTORY`] pairs, with rigid obstacles too: there H₀ holds the contact
    /// nodes' blocks (no factorization) and a step stops at the looser of
    /// `StepNewtonOptions::tolerance` and [`AUTO_CONTACT_LBFGS_TOLERANCE`], where linear
    /// convergence costs less than a factorization a step.
    /// With body–body or self-contact (the surface barrier)
    /// [`Refactor`](Self::Refactor) at every size: its direct path factors the exact Hessian
    /// with the contact pairs' couplings, and Newton converges in a few iterations where the
    /// preconditioned CG on the lumped coupling converges linearly (on two blocks pressed
    /// together at 1,296 DOFs: at most 9 Newton iterations a step against 154,
    /// `tests/core/surface_tangent_scale.rs`). Both chosen by `benches/corotational_step.rs`, see
    /// `validation/PERFORMANCE.md`.
    ///
    /// On the L-BFGS path a step stops at the looser of `StepNewtonOptions::tolerance` and
    /// [`AUTO_LBFGS_TOLERANCE`], or earlier by the correction test of
    /// [`AUTO_LBFGS_CORRECTION`] (the remaining correction estimated from the last two steps'
    /// contraction, against the step's motion): on the swinging cantilever the trajectory is
    /// then within 2.7e-5–4.8e-5 of the largest displacement from the one solved to 1e-8
    /// (2,700–38,808 DOFs), in 2.1–2.2 iterations a step against 2.5–3.05 with the residual
    /// test alone. Name [`RestPreconditionedLbfgs`](Self::RestPreconditionedLbfgs) for the
    /// tolerance as set and no correction test.
    Auto,
}

/// Below this many free DOFs [`NonlinearSolve::Auto`] refactors. Measured on the swinging
/// rubber cantilever (`benches/corotational_step.rs`, 40 steps of 10 ms from rest, one
/// thread, side by side): refactoring and L-BFGS take 1.5 and 1.5 ms per step at 270 DOFs,
/// 2.4 and 2.1 ms at 378, 7.0 and 6.0 ms at 960, 20.6 and 16.1 ms at 2,250 (Newton-CG: 4.0,
/// 4.9, 10.7, 24.4 ms). Below 1,000 DOFs L-BFGS gains at most 15 %, and the exact Newton step
/// (2–4 iterations, quadratic convergence) is the one that cannot be slowed by a model or a
/// load the rest factor knows nothing of; above it L-BFGS's lead grows with the size.
pub const AUTO_REFACTOR_BELOW: usize = 1000;

/// The correction pairs [`NonlinearSolve::Auto`] keeps on the L-BFGS path: on the swinging
/// cantilever 5 and 10 pairs take the same iterations (125 over 20 steps of 10 ms at 18k DOFs,
/// tolerance 1e-3), 0 (the chord iteration) 7 % more, and each pair costs two vectors.
pub const AUTO_LBFGS_HISTORY: usize = 5;

/// The step tolerance (‖r‖ ≤ tolerance·max(‖r₀‖, ‖f‖), dimensionless) below which
/// [`NonlinearSolve::Auto`]'s L-BFGS path does not go: what an animation needs of a trajectory,
/// not what a residual can reach. On the swinging rubber cantilever (20 steps of 10 ms from
/// rest to a 38° tip rotation, `validation/src/bin/corotational_cost.rs --set options`), its
/// largest distance from the trajectory solved by refactoring Newton to 1e-8, over the largest
/// displacement: 7.3e-6 (corotational) and 8.3e-6 (Neo-Hookean) at 2,700 DOFs, 1.2e-5 and
/// 1.2e-5 at 9,720, in 50–53 L-BFGS iterations against 137–146 at 1e-8. At 3e-3 it was
/// 2.5e-5–3.2e-5 in 43, at 1e-2 1.6e-4–4.6e-4 in 31–36 (past the 1e-4 an animation is held to).
pub const AUTO_LBFGS_TOLERANCE: f64 = 1e-3;

/// τ of the correction test of [`NonlinearSolve::Auto`]'s L-BFGS path (dimensionless): from
/// its second accepted step s_k on, a step has converged when the correction still to come,
/// estimated as θ/(1 − θ)·‖s_k‖∞ with θ = ‖s_k‖∞/‖s_{k−1}‖∞ < 1 the observed contraction (the
/// simplified-Newton stopping rule of Hairer & Wanner, *Solving ODEs II*, IV.8), is at most
/// τ·‖u_k − u‖∞, τ of the displacement the step has made (length over length). The residual
/// test weighs the stiff modes' small errors most, the trajectory is made of the soft modes'
/// large motion. On the swinging cantilever (20 steps of 10 ms, 38° tip rotation,
/// `validation/src/bin/corotational_cost.rs --set options`) the residual test alone took 2.65
/// (9,720 DOFs) and 3.05 (38,808) iterations a step, with this test 2.15 and 2.1, at 3.8e-5–4.8e-5
/// of the largest displacement from the refactoring trajectory (the target 1e-4). On the harder
/// swing of `tests/core/corotational_step.rs` (1,800 DOFs, 25 steps of 20 ms to 105°) τ = 1e-4
/// took 154 iterations against 195 at 5.05e-5; τ = 1e-3 there took 109 iterations but left
/// the target (7.5e-4), so τ is not larger. The distance is not monotone in τ (3e-5: 167
/// iterations at 5.7e-5; 1e-5: 184 at 3.3e-5): θ from two L-BFGS steps is a rough estimate.
/// Over a longer swing the distance grows with the path a per-step test lets through: run for
/// 100 steps (the beam swinging back, `--steps 100`, 2 threads) τ = 1e-4 left 1.31e-4 at 2,700
/// DOFs (274 iterations), 8.23e-5 at 9,720 (290) and 7.18e-5 at 38,808 (308); τ = 5e-5 held
/// them to 5.72e-5, 3.54e-5 and 4.94e-5 in 8–11 % more iterations, and took 2.25–2.40
/// iterations a step instead of 2.10–2.20 over the 20-step swing at every size from 2,700 to
/// 132,300 DOFs, most of what the unevaluated last correction (below) saves. Not taken.
///
/// The test is also made on each direction before its line search, with θ = ‖δ‖∞/‖s_{k−1}‖∞:
/// where it holds, the step takes δ whole and stops without evaluating the force there (the
/// order of Hairer and Wanner's own rule), so a step makes about one force pass an iteration
/// instead of one more (the next step starts at its guess without the start's pass where the
/// guess's residual is within the step's own forces, or Φ rises from it toward the start). On the 38° swing the trajectories kept
/// their bits at 2,700–132,300 DOFs (the same iterates: the search had taken those directions
/// whole), at 2.1–2.4 passes a step instead of 3.1–3.2; on the 105° swing, 153 iterations at
/// 5.22e-5 (the reference r₀ then the residual at the guess, see
/// [`StepNewtonOptions::tolerance`](super::StepNewtonOptions)).
pub const AUTO_LBFGS_CORRECTION: f64 = 1e-4;

/// The step tolerance (`StepNewtonOptions::tolerance`, ‖r‖ ≤ tolerance·max(‖r₀‖, ‖f‖),
/// dimensionless) below which [`NonlinearSolve::Auto`] does not go in contact with rigid
/// obstacles (from [`AUTO_REFACTOR_BELOW`] unknowns), where it takes L-BFGS with the contact
/// nodes' blocks in H₀ ([`NonlinearSolve::RestPreconditionedLbfgs`]): the accuracy of a
/// trajectory an animation needs, as [`AUTO_LBFGS_TOLERANCE`] without contact. On
/// `benches/interactive_contact.rs`'s 10k-DOF block (100 steps) the trajectories at 1e-4 stay
/// within 1.31e-5 (the drop onto frictional ground) and 1.26e-5 (the sphere pressing into it)
/// of the largest displacement from the CG path's at 1e-8, which factors J once a contact step,
/// at 3.5× and 2.4× its speed (2 threads, one run each, 2026-12-07). Asked by name
/// (`RestPreconditionedLbfgs`, `RestPreconditionedCg`) a tighter tolerance holds. L-BFGS
/// converges linearly, Newton on J's factor quadratically: on the 10k-DOF rubber block of
/// `benches/interactive_contact.rs` (100 steps, 2 threads, one binary, interleaved rounds) at
/// 1e-4 L-BFGS ran the drop onto frictional ground at 22.2–27.0 steps/s against 13.6–15.8 and
/// the sphere pressing into it at 14.7–16.4 against 13.6–15.9; at 1e-8 the drop at 19.4–24.7
/// against 12.9–13.9 but the press at 10.8–12.8 against 11.3–13.4 (9.3 iterations a step
/// against 7.4: the block's tangent under the sphere is far from the rest one). The value of
/// `StepNewtonOptions::interactive` (see `validation/PERFORMANCE.md`).
pub const AUTO_CONTACT_LBFGS_TOLERANCE: f64 = 1e-4;

/// The CG settings of [`NonlinearSolve::Auto`]'s preconditioned path, and of an L-BFGS step's
/// fallback: 25 iterations, η = 1e-3.
pub(crate) const AUTO_CG: NonlinearSolve = NonlinearSolve::RestPreconditionedCg {
    max_cg_iterations: 25,
    forcing: 1e-3,
};

/// Whether [`NonlinearSolve::Auto`] steps `force` with `free_dofs` unknowns by L-BFGS with the
/// contact nodes' blocks at its floor [`AUTO_CONTACT_LBFGS_TOLERANCE`]: rigid obstacles (no
/// body–body contact) and at least [`AUTO_REFACTOR_BELOW`] unknowns.
fn rigid_contact_lbfgs(free_dofs: usize, force: &super::NonlinearForce) -> bool {
    let rigid_contact = force.contact().is_some() && force.surface_contact().is_none();
    rigid_contact && free_dofs >= AUTO_REFACTOR_BELOW
}

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
            NonlinearSolve::RestPreconditionedLbfgs { history } => match history <= 100 {
                true => Ok(()),
                false => Err(Error::invalid_parameter(
                    "nonlinear_solve.history",
                    history,
                    "must be at most 100 (each pair holds two vectors of the free DOFs)",
                )),
            },
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

    /// What [`Auto`](Self::Auto) is for `free_dofs` unknowns without contact; any other choice
    /// as it is.
    pub fn for_size(self, free_dofs: usize) -> Self {
        self.for_problem(free_dofs, false)
    }

    /// What [`Auto`](Self::Auto) is for `free_dofs` unknowns, with or without contact; any other
    /// choice as it is.
    pub fn for_problem(self, free_dofs: usize, with_contact: bool) -> Self {
        match self {
            NonlinearSolve::Auto if free_dofs < AUTO_REFACTOR_BELOW => NonlinearSolve::Refactor,
            NonlinearSolve::Auto if with_contact => AUTO_CG,
            NonlinearSolve::Auto => NonlinearSolve::RestPreconditionedLbfgs {
                history: AUTO_LBFGS_HISTORY,
            },
            other => other,
        }
    }

    /// What [`Auto`](Self::Auto) is for `force` with `free_dofs` unknowns: with body–body or
    /// self-contact ([`NonlinearForce::surface_contact`](super::NonlinearForce::surface_contact))
    /// [`Refactor`](Self::Refactor) at every size, whose direct path factors the exact J with
    /// the contact pairs' couplings; otherwise [`for_problem`](Self::for_problem). The rest
    /// factor knows neither the barrier's stiffness nor the coupling of bodies that touch, and
    /// the lumped coupling converges linearly: on the 8-block stack (14k DOFs) the
    /// preconditioned CG path did not converge in step 1 (see `validation/block_stack.md`);
    /// on two blocks pressed together at 1,296 DOFs it took 154 Newton iterations in a step
    /// where the coupled factor took 9 (`tests/core/surface_tangent_scale.rs`).
    pub(crate) fn for_force(self, free_dofs: usize, force: &super::NonlinearForce) -> Self {
        match (self, force.surface_contact()) {
            (NonlinearSolve::Auto, Some(_)) => NonlinearSolve::Refactor,
            (solve, _) => solve.for_problem(free_dofs, force.has_contact()),
        }
    }

    /// What [`Auto`](Self::Auto) is for a step on `force` with `free_dofs` unknowns solved to
    /// the step tolerance `tolerance`: with rigid obstacles (no body–body contact), at least
    /// [`AUTO_REFACTOR_BELOW`] unknowns and a tolerance of at least
    /// [`AUTO_CONTACT_LBFGS_TOLERANCE`], [`RestPreconditionedLbfgs`](Self::RestPreconditionedLbfgs)
    /// with the contact nodes' blocks in its H₀ (no factorization a step); otherwise
    /// [`for_force`](Self::for_force). Any other choice as it is.
    pub(crate) fn for_step(
        self,
        free_dofs: usize,
        force: &super::NonlinearForce,
        tolerance: f64,
    ) -> Self {
        match self {
            NonlinearSolve::Auto
                if rigid_contact_lbfgs(free_dofs, force)
                    && tolerance >= AUTO_CONTACT_LBFGS_TOLERANCE =>
            {
                NonlinearSolve::RestPreconditionedLbfgs {
                    history: AUTO_LBFGS_HISTORY,
                }
            }
            solve => solve.for_force(free_dofs, force),
        }
    }

    /// The step tolerance a Newton iteration on `force` with `free_dofs` unknowns stops at
    /// when `requested` is asked: [`Auto`](Self::Auto)'s L-BFGS path without contact at the
    /// looser of `requested` and [`AUTO_LBFGS_TOLERANCE`], and with rigid obstacles (no
    /// body–body contact, at least [`AUTO_REFACTOR_BELOW`] unknowns) at the looser of
    /// `requested` and [`AUTO_CONTACT_LBFGS_TOLERANCE`], where [`for_step`](Self::for_step)
    /// then takes L-BFGS with the contact nodes' blocks; any other at `requested`.
    pub(crate) fn step_tolerance(
        self,
        free_dofs: usize,
        force: &super::NonlinearForce,
        requested: f64,
    ) -> f64 {
        match (self, self.for_force(free_dofs, force)) {
            (NonlinearSolve::Auto, NonlinearSolve::RestPreconditionedLbfgs { .. }) => {
                requested.max(AUTO_LBFGS_TOLERANCE)
            }
            (NonlinearSolve::Auto, _) if rigid_contact_lbfgs(free_dofs, force) => {
                requested.max(AUTO_CONTACT_LBFGS_TOLERANCE)
            }
            _ => requested,
        }
    }

    /// τ of the correction test a Newton iteration on `force` with `free_dofs` unknowns stops
    /// by besides the residual's: [`AUTO_LBFGS_CORRECTION`] on [`Auto`](Self::Auto)'s L-BFGS
    /// path (without contact), none otherwise.
    pub(crate) fn correction_tolerance(
        self,
        free_dofs: usize,
        force: &super::NonlinearForce,
    ) -> Option<f64> {
        match (self, self.for_force(free_dofs, force)) {
            (NonlinearSolve::Auto, NonlinearSolve::RestPreconditionedLbfgs { .. }) => {
                Some(AUTO_LBFGS_CORRECTION)
            }
            _ => None,
        }
    }

    /// The name scenes use: `auto`, `refactor`, `rest_preconditioned` or `rest_lbfgs`.
    pub fn name(&self) -> &'static str {
        match self {
            NonlinearSolve::Auto => "auto",
            NonlinearSolve::Refactor => "refactor",
            NonlinearSolve::RestPreconditionedCg { .. } => "rest_preconditioned",
            NonlinearSolve::RestPreconditionedLbfgs { .. } => "rest_lbfgs",
        }
    }
}

impl std::str::FromStr for NonlinearSolve {
    type Err = Error;

    /// `auto`, `refactor`, `rest_preconditioned` (with the CG budget and forcing term that
    /// `auto` uses) or `rest_lbfgs` (with `auto`'s history).
    fn from_str(name: &str) -> Result<Self> {
        match name {
            "auto" => Ok(NonlinearSolve::Auto),
            "refactor" => Ok(NonlinearSolve::Refactor),
            "rest_preconditioned" => Ok(AUTO_CG),
            "rest_lbfgs" => Ok(NonlinearSolve::RestPreconditionedLbfgs {
                history: AUTO_LBFGS_HISTORY,
            }),
            other => Err(Error::invalid_parameter(
                "nonlinear_solver",
                other,
                "must be 'auto', 'refactor', 'rest_preconditioned' or 'rest_lbfgs'",
            )),
        }
    }
}
