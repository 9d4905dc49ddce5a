//! The Newton loop itself, written once for every nonlinear solve in tetfem: a static load
//! step (the equation Σ fₑ(u) + λ·f = 0, the step equation without mass) and an implicit time
//! step (with it) both iterate here. What differs between them — the residual, the direction
//! (a factored tangent or a strategy of [`super::direction`]), the line along it — is the
//! [`NewtonSystem`] the loop drives, as MFEM's one `NewtonSolver` drives any `Operator`; the
//! loop owns the rules: when an iterate has converged, when a step is too small to change a
//! force, when a failed search is the round-off floor, when the budget is spent.

use crate::base::error::Result;

/// Below this fraction of the reference the residual is the round-off of the element forces
/// (their O(E·|X|) terms cancel to O(E·strain)): a residual there that no longer halves, or a
/// line search that finds no decrease, is the floor reached.
pub(crate) const ROUND_OFF_FLOOR: f64 = 1e-6;

/// One nonlinear equation r(u) = 0 as the Newton loop sees it, at its current iterate u (whose
/// residual it holds).
pub(crate) trait NewtonSystem {
    /// Computes the Newton direction δ at the current iterate; `first`: the loop's first
    /// iteration.
    fn direction(&mut self, first: bool) -> Result<()>;

    /// Whether every component of δ is below the smallest change of the iterate that changes a
    /// force (the positions' resolution 4ε·max|X|; with moving obstacles 1e-9·d̂): the iterate
    /// then stands (the test that holds at zero load, where r is the forces' round-off and no
    /// step lowers it).
    fn step_is_unresolved(&self) -> bool;

    /// The line search along δ from the current iterate (residual norm `r_norm`, converging
    /// relative to `reference`): whether a fraction was accepted and which (the trial point
    /// is kept for [`accept`](Self::accept)).
    fn search(&mut self, r_norm: f64, reference: f64) -> Result<(bool, f64)>;

    /// Whether a search that found no decrease is the floor of what the equation resolves
    /// beyond the loop's own round-off rule (with contact: δ below 1e-9·d̂ everywhere, which
    /// the barrier does not resolve).
    fn failed_search_is_floor(&self) -> bool {
        false
    }

    /// Makes the accepted trial point (fraction `alpha` of δ) the iterate; returns its
    /// residual norm.
    fn accept(&mut self, alpha: f64) -> f64;

    /// A further move of the iterate just accepted (residual norm `r_norm`) that lowers the
    /// problem's potential, e.g. the contact nodes' local problems; returns the residual norm
    /// of the iterate it leaves. Not asked of an iterate that has converged already. None by
    /// default.
    fn refine(&mut self, r_norm: f64) -> Result<f64> {
        Ok(r_norm)
    }

    /// Another direction strategy when the budget is spent or the search failed (L-BFGS and
    /// CG fall back to a factorization): whether one was taken (the budget is then renewed).
    fn fall_back(&mut self) -> bool {
        false
    }

    /// Whether the step just accepted (fraction `alpha` of δ) shows the iterate converged by a
    /// test on the corrections the system keeps besides the residual's (the implicit step's
    /// L-BFGS path, see `NonlinearSolve::Auto`); none by default.
    fn converged_by_correction(&mut self, _alpha: f64) -> bool {
        false
    }

    /// Takes the direction just computed whole, without evaluating the residual where it leads,
    /// when the system's correction test already shows that iterate converged (Hairer and
    /// Wanner's stop of a simplified Newton method: the correction still to come estimated
    /// from the last accepted step's contraction); returns whether it did. None by default.
    fn take_converged_direction(&mut self) -> bool {
        false
    }

    /// What the caller's interrupt test names while `iteration` (1-based) runs.
    fn describe(&self, iteration: usize) -> String;
}

/// Why the loop stopped short of convergence, with the residual norm it reached (force).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Stall {
    /// The iterations allowed (renewed by each fallback) ran out.
    OutOfIterations { iterations: usize, residual: f64 },
    /// The line search found no decrease above the round-off floor.
    NoDecrease { residual: f64 },
    /// The residual is no longer finite.
    NotFinite,
}

/// Newton's iterations on `system` from residual norm `r_norm` until ‖r‖ ≤
/// `tolerance`·`reference`, the round-off floor or the system's own correction test
/// ([`NewtonSystem::converged_by_correction`] after a step,
/// [`NewtonSystem::take_converged_direction`] before its line search), at most `max_iterations` per direction
/// strategy. Returns the iterations taken, or the [`Stall`] (the caller names its problem in
/// its error); errors of the system's evaluations and of the interrupt test pass through.
pub(crate) fn iterate(
    system: &mut dyn NewtonSystem,
    (mut r_norm, reference): (f64, f64),
    (tolerance, max_iterations): (f64, usize),
) -> Result<std::result::Result<usize, Stall>> {
    let mut iterations = 0;
    let mut budget = max_iterations;
    while r_norm > tolerance * reference {
        // A caller's Ctrl-C between iterations: the iterate is the system's scratch, the
        // caller's state is written only after a converged solve.
        crate::linalg::interrupt::poll(|| system.describe(iterations + 1))?;
        if iterations == budget {
            if !system.fall_back() {
                return Ok(Err(Stall::OutOfIterations {
                    iterations: budget,
                    residual: r_norm,
                }));
            }
            budget += max_iterations;
        }
        system.direction(iterations == 0)?;
        if system.step_is_unresolved() {
            break;
        }
        if system.take_converged_direction() {
            iterations += 1;
            break;
        }
        let (accepted, alpha) = system.search(r_norm, reference)?;
        if !accepted {
            if system.failed_search_is_floor() || r_norm <= ROUND_OFF_FLOOR * reference {
                break;
            }
            if system.fall_back() {
                budget = iterations + max_iterations;
                continue;
            }
            return Ok(Err(Stall::NoDecrease { residual: r_norm }));
        }
        let before = r_norm;
        r_norm = system.accept(alpha);
        // A converged iterate is the step's: a refinement would only move it within the
        // tolerance (on the 10k-DOF drop of `benches/interactive_contact.rs` a calm step's
        // relaxation was 7 % of it, the trajectory as far from the tight one without it).
        if r_norm > tolerance * reference {
            r_norm = system.refine(r_norm)?;
        }
        iterations += 1;
        if !r_norm.is_finite() {
            return Ok(Err(Stall::NotFinite));
        }
        if r_norm <= ROUND_OFF_FLOOR * reference && r_norm > 0.5 * before {
            break;
        }
        if system.converged_by_correction(alpha) {
            break;
        }
    }
    Ok(Ok(iterations))
}
