//! Newton's method, written once for every nonlinear solve in tetfem: the loop
//! ([`iteration::iterate`] over a [`NewtonSystem`](iteration::NewtonSystem)) and its
//! backtracking line search ([`line_search::Backtracking`]).
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
