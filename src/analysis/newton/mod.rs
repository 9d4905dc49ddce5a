//! Newton's method, written once for every nonlinear solve in tetfem: the loop
//! ([`iteration::iterate`] over a [`NewtonSystem`](iteration::NewtonSystem)) and its
//! backtracking line search ([`line_search::Backtracking`]); and how a direction that factors
//! Newton's matrix does it ([`factor_exact_or_projected`]).
//!
//! Two equations are solved with it, each a `NewtonSystem` that supplies its residual, its
//! direction and the line along it, while the loop owns the rules (convergence, the round-off
//! floor, the budget, a strategy's fallback):
//! - a static load step, Σ fₑ(u) + λ·f = 0 (`crate::analysis::nonlinear`; the step equation
//!   without mass, its direction the exact tangent or its PSD projection);
//! - an implicit time step, s_m·M·(u' − ũ) + C·(…) − f_int(u') − f = 0
//!   (`crate::analysis::dynamics::newton`, whose `NewtonSolver` also owns the direction
//!   strategies: refactoring, rest-preconditioned CG, L-BFGS).

pub(crate) mod iteration;
pub(crate) mod line_search;

use crate::base::error::Result;
use crate::linear_solver::LinearSolver;
use crate::sparse::CscMatrix;

/// Newton's matrix factored as every direction that factors it does: the one `form` makes
/// from the exact tangent (`project` false: quadratic convergence) first, and where that is not
/// positive definite (a buckling or compressed hyperelastic element, the barrier's concave
/// part) the one with every element tangent projected onto the PSD cone (a descent direction,
/// at the price of linear convergence while it is needed). `form(project, matrix)` fills
/// `matrix`, which `solver` then factors numerically on its symbolic analysis.
pub(crate) fn factor_exact_or_projected(
    solver: &mut LinearSolver,
    matrix: &mut CscMatrix,
    mut form: impl FnMut(bool, &mut CscMatrix) -> Result<()>,
) -> Result<()> {
    for project in [false, true] {
        form(project, matrix)?;
        match solver.factorize(matrix) {
            Err(tetfem_linalg::Error::NotPositiveDefinite { .. }) if !project => continue,
            other => return Ok(other?),
        }
    }
    Ok(())
}
