//! The Newton direction δ ≈ −J⁻¹·r of one iteration, as a strategy that owns its state: the
//! [`StepDirection`] trait and its three types, chosen from [`NonlinearSolve`] by [`choose`]:
//!
//! - [`Refactor`]: J formed and factored numerically every iteration (the factor lives in the
//!   integrator's [`LinearSolver`], whose symbolic analysis it shares with the linear path;
//!   with surface contact the exact J with the pairs' couplings is factored on its own,
//!   growing pattern, [`CoupledFactor`]);
//! - [`RestPreconditionedCg`]: preconditioned CG on J, the factor that of the rest matrix
//!   J₀ = s·M + (1 + β_s)·K₀ turned by the nodes' rotations, or after a fallback the factor of
//!   the J CG could not solve (lagged for the rest of that step); with a rigid obstacle within
//!   d̂, J factored at the run's first iterate in contact, modified Newton on that factor while
//!   it halves the residual, then CG preconditioned by it, corrected at the nodes whose
//!   diagonal block of J (the barrier's, friction's) has changed since
//!   ([`super::node_correction`]);
//! - [`Lbfgs`]: δ = −H·r with L-BFGS's H (its correction pairs), H₀ the turned rest factor;
//!   when it fails within a step it goes on with its own [`RestPreconditionedCg`] (the same
//!   rest factor and rotations).
//!
//! The loop (`super::NewtonSolver`) keeps only its own state (iterate, residuals, counts) and
//! hands a strategy the [`NewtonMatrix`]: what J is formed from and where it is factored.

use super::NewtonStats;
use super::contact_capacitance::{ContactCapacitance, ContactNodes, Prepared, max_contact_dofs};
use super::node_correction::NodeCorrection;
use super::weight::ContactBlocks;
use crate::analysis::dynamics::internal_force::{ForceWorkspace, NonlinearForce, combine};
use crate::analysis::dynamics::lbfgs::LbfgsMemory;
use crate::analysis::dynamics::nodal_rotation::NodalRotations;
use crate::analysis::dynamics::{LinearSystem, NonlinearSolve};
use crate::analysis::newton::factor_exact_or_projected;
use crate::analysis::nonlinear::lumped::{CoupledFactor, solve_with_lumped};
use crate::base::error::Result;
use crate::iterative::{CgOptions, CgReport};
use crate::linear_solver::LinearSolver;
use crate::sparse::CscMatrix;

/// What the Newton matrix J = mass_scale·M + damping_stiffness·K_T(u_start) + K_T(u') of one
/// iteration is formed from (the force, its scratch and tangents) and where it goes (`matrix`,
/// on K_ff's pattern, factored or preconditioned by `solver`).
pub(crate) struct NewtonMatrix<'a> {
    /// The system: its mass and rest stiffness K₀ = K_ff.
    pub system: &'a LinearSystem,
    /// The force law whose tangent K_T is.
    pub force: &'a NonlinearForce,
    /// The force's scratch.
    pub work: &'a mut ForceWorkspace,
    /// K_T(u') (on the force's pattern).
    pub tangent: &'a mut CscMatrix,
    /// K_T(u_start) of the damping, when β > 0.
    pub damping_tangent: Option<&'a CscMatrix>,
    /// (mass_scale, damping_stiffness): (s_m + s_c·α, s_c·β) (1/time², dimensionless).
    pub scales: (f64, f64),
    /// J, or the rest matrix J₀ whose factor preconditions it.
    pub matrix: &'a mut CscMatrix,
    /// The linear solver of J.
    pub solver: &'a mut LinearSolver,
    /// The barrier's Hessian counted (w − 1) more times in J, with its scratch (see
    /// [`super::StepEquation::contact_weight`]); `None` for w = 1.
    pub contact_extra: Option<(&'a mut ContactBlocks, f64)>,
}

impl NewtonMatrix<'_> {
    /// J into `matrix`, every element tangent projected onto the positive semi-definite cone
    /// when `project` is set.
    fn form(&mut self, u_new: &[f64], project: bool) -> Result<()> {
        let parts = (self.system, self.force, self.damping_tangent, self.scales);
        form_into(
            parts,
            (self.work, self.tangent),
            (u_new, project),
            self.matrix,
        )?;
        add_contact_extra(
            self.force,
            &mut self.contact_extra,
            (u_new, project),
            self.matrix,
        )
    }

    /// Forms J and factors it: the exact tangent first, the projected one if J is not positive
    /// definite.
    fn factor(&mut self, u_new: &[f64]) -> Result<()> {
        let parts = (self.system, self.force, self.damping_tangent, self.scales);
        let (work, tangent) = (&mut *self.work, &mut *self.tangent);
        let extra = &mut self.contact_extra;
        factor_exact_or_projected(self.solver, self.matrix, |project, matrix| {
            form_into(parts, (&mut *work, &mut *tangent), (u_new, project), matrix)?;
            add_contact_extra(parts.1, extra, (u_new, project), matrix)
        })
    }

    /// δ = −J⁻¹·r by a fresh factorization of J (counted), `delta` holding −r on entry. With
    /// surface contact whose tangent lumped entries, `coupled` (when given, on the direct path)
    /// factors the exact J on the pattern with the pairs' couplings
    /// ([`CoupledFactor`]); without it, or where neither the exact nor the projected J is
    /// positive definite there, CG on the exact J preconditioned by the lumped P's factor
    /// ([`solve_with_lumped`]).
    fn factor_and_solve(
        &mut self,
        u_new: &[f64],
        delta: &mut [f64],
        stats: &mut NewtonStats,
        coupled: Option<&mut CoupledFactor>,
    ) -> Result<()> {
        let coupled =
            coupled.filter(|_| self.force.surface_contact().is_some() && self.solver.is_direct());
        if let Some(coupled) = coupled {
            match self.factor_coupled(u_new, stats, coupled)? {
                Factored::Coupled => return coupled.solve(delta),
                Factored::Base => {
                    self.solver.solve(self.matrix, delta)?;
                    return Ok(());
                }
                Factored::Neither => {}
            }
        }
        self.factor(u_new)?;
        stats.factorizations += 1;
        self.solve_factored(delta)
    }

    /// [`factor_and_solve`](Self::factor_and_solve) without surface couplings where `matrix`
    /// holds the exact J at `u_new` already ([`form`](Self::form)ed for the CG that fell back):
    /// that J is factored as it stands, the projected one formed only where it is not positive
    /// definite. The same factor bit for bit as [`factor`](Self::factor)'s, one tangent
    /// assembly fewer: on the 10k-DOF block sliding on the ground
    /// (`benches/interactive_contact.rs`) a third of the Newton iterations fall back, and the
    /// Neo-Hookean tangent is a quarter of the step's time.
    fn factor_formed_and_solve(
        &mut self,
        u_new: &[f64],
        delta: &mut [f64],
        stats: &mut NewtonStats,
    ) -> Result<()> {
        match self.solver.factorize(self.matrix) {
            Err(tetfem_linalg::Error::NotPositiveDefinite { .. }) => {
                self.form(u_new, true)?;
                self.solver.factorize(self.matrix)?;
            }
            other => other?,
        }
        stats.factorizations += 1;
        self.solve_factored(delta)
    }

    /// δ = J⁻¹·`delta` in place by the factor in the solver, with the surface barrier's lumped
    /// entries recovered by CG where it has any ([`solve_with_lumped`]).
    fn solve_factored(&mut self, delta: &mut [f64]) -> Result<()> {
        let lumped = self.weighted_lumped_entries();
        if lumped.is_empty() {
            self.solver.solve(self.matrix, delta)?;
            return Ok(());
        }
        solve_with_lumped(self.solver, self.matrix, &lumped, delta)
    }

    /// The tangent's lumped entries of the surface barrier as J holds them: counted w times
    /// where the barrier is (Newmark's end-point contact, [`super::StepEquation::contact_weight`]):
    /// each of its w evaluations lumps the same entries, so J holds w·v for each.
    fn weighted_lumped_entries(&self) -> Vec<(usize, Option<usize>, f64)> {
        let lumped = self.force.lumped_tangent_entries();
        let weight = 1.0 + self.contact_extra.as_ref().map_or(0.0, |(_, extra)| *extra);
        match weight == 1.0 {
            true => lumped,
            false => lumped
                .into_iter()
                .map(|(r, c, v)| (r, c, weight * v))
                .collect(),
        }
    }

    /// Forms the exact J and factors it: on `coupled`'s pattern when the tangent lumped
    /// entries, else (nothing lumped: J exact on the stiffness pattern) in the solver, as
    /// [`factor`](Self::factor) does. Where the exact J is not positive definite, the projected
    /// one (every element tangent and every pair's 12×12 barrier block projected to PSD, as
    /// IPC does), on the same pattern: s·M + PSD parts is positive definite, so this factor
    /// always exists and its direction descends Φ. [`Factored::Neither`] (the lumped path's CG
    /// on the exact J) only if the projected factorization fails on round-off.
    ///
    /// Before, an indefinite exact J went to that CG at once, stopped at its first direction
    /// of non-positive curvature: on the 8-block stack 43 of 59 factorizations of the first
    /// four steps were indefinite, each CG direction inexact, and the landing step ran out of
    /// its 25 iterations (residual 2.1 of 4.7). With the projected factor the same steps
    /// converge where the stack's contacts are stable (see `validation/block_stack.md`).
    fn factor_coupled(
        &mut self,
        u_new: &[f64],
        stats: &mut NewtonStats,
        coupled: &mut CoupledFactor,
    ) -> Result<Factored> {
        for project in [false, true] {
            self.form(u_new, project)?;
            let lumped = self.weighted_lumped_entries();
            if lumped.is_empty() {
                match self.solver.factorize(self.matrix) {
                    Err(tetfem_linalg::Error::NotPositiveDefinite { .. }) if !project => continue,
                    other => other?,
                }
                stats.factorizations += 1;
                return Ok(Factored::Base);
            }
            if coupled.factor(self.matrix, &lumped)? {
                stats.factorizations += 1;
                return Ok(Factored::Coupled);
            }
        }
        Ok(Factored::Neither)
    }
}

/// Which factor [`NewtonMatrix::factor_coupled`] made.
enum Factored {
    /// The exact J's on the coupled pattern.
    Coupled,
    /// J's on the stiffness pattern, in the solver (nothing lumped).
    Base,
    /// The exact J is indefinite on the coupled pattern: the lumped path's turn.
    Neither,
}

/// The parts J is formed from: the system (M), the force (K_T), the damping's K_T(u_start)
/// and the scales (mass_scale, damping_stiffness).
type MatrixParts<'a> = (
    &'a LinearSystem,
    &'a NonlinearForce,
    Option<&'a CscMatrix>,
    (f64, f64),
);

/// J = mass_scale·M + damping_stiffness·K_T(u_start) + K_T(u') into `matrix` (see
/// [`NewtonMatrix`]), K_T(u') formed in `tangent` with the force's scratch `work`, every element
/// tangent projected onto the PSD cone when `project` is set.
fn form_into(
    (system, force, damping_tangent, scales): MatrixParts,
    (work, tangent): (&mut ForceWorkspace, &mut CscMatrix),
    (u_new, project): (&[f64], bool),
    matrix: &mut CscMatrix,
) -> Result<()> {
    let (mass_scale, damping_stiffness) = scales;
    force.tangent_into(u_new, project, work, tangent)?;
    combine(tangent, 1.0, system.mass(), mass_scale, matrix)?;
    if let Some(k) = damping_tangent {
        for (a, k) in matrix.values_mut().iter_mut().zip(k.values()) {
            *a += damping_stiffness * k;
        }
    }
    Ok(())
}

/// Adds (w − 1)·∂²E_c(u') into J when the step weighs the barrier by w ≠ 1 (`extra`), the
/// barrier's curvature term dropped when `project` is set.
fn add_contact_extra(
    force: &NonlinearForce,
    extra: &mut Option<(&mut ContactBlocks, f64)>,
    (u_new, project): (&[f64], bool),
    matrix: &mut CscMatrix,
) -> Result<()> {
    match extra {
        Some((blocks, w)) => blocks.add(force, (u_new, project, *w), matrix),
        None => Ok(()),
    }
}

/// How one Newton iteration finds its direction; each implementation owns its state.
pub(crate) trait StepDirection: Send {
    /// A new time step (all its stages): state that serves one step only is dropped.
    fn begin_step(&mut self) {}

    /// A new run of iterations (one stage of a step): state of the last run is dropped.
    fn begin_iterations(&mut self) {}

    /// δ ≈ −J(u')⁻¹·r into `delta` (`residual` r at `u_new`; `first`: the run's first
    /// iteration), counting factorizations, CG iterations and fallbacks in `stats`.
    fn direction(
        &mut self,
        newton: &mut NewtonMatrix,
        u_new: &[f64],
        residual: &[f64],
        delta: &mut [f64],
        first: bool,
        stats: &mut NewtonStats,
    ) -> Result<()>;

    /// The line search accepted the step s = alpha·δ, the residual going from `residual` to
    /// `trial_residual` (a quasi-Newton memory keeps the pair).
    fn accepted(&mut self, _alpha: f64, _delta: &[f64], _residual: &[f64], _trial: &[f64]) {}

    /// The iterations ran out or found no decrease: switches to a fallback for the rest of the
    /// run and returns `true` (counted in `stats`), or `false` when there is none.
    fn fall_back(&mut self, _stats: &mut NewtonStats) -> bool {
        false
    }
}

/// The strategy of `solve` (already resolved for the problem's size, see
/// [`NonlinearSolve::for_problem`]) for `force`.
pub(crate) fn choose(solve: NonlinearSolve, force: &NonlinearForce) -> Box<dyn StepDirection> {
    match solve {
        NonlinearSolve::Refactor => Box::new(Refactor::default()),
        NonlinearSolve::RestPreconditionedLbfgs { history } => Box::new(Lbfgs {
            memory: LbfgsMemory::new(history),
            failed: false,
            contact: ContactCapacitance::default(),
            contact_state: ContactState::Free,
            cg: RestPreconditionedCg::new(super::super::nonlinear_solve::AUTO_CG, force),
        }),
        cg => Box::new(RestPreconditionedCg::new(cg, force)),
    }
}

/// Newton's own direction: J formed and factored every iteration (the exact tangent, or the
/// projected one where J is not positive definite).
#[derive(Default)]
pub(crate) struct Refactor {
    /// The exact J's factor on the pattern with the surface pairs' couplings (used with
    /// surface contact only).
    coupled: CoupledFactor,
}

impl StepDirection for Refactor {
    fn direction(
        &mut self,
        newton: &mut NewtonMatrix,
        u_new: &[f64],
        residual: &[f64],
        delta: &mut [f64],
        _first: bool,
        stats: &mut NewtonStats,
    ) -> Result<()> {
        negate(residual, delta);
        newton.factor_and_solve(u_new, delta, stats, Some(&mut self.coupled))
    }
}

/// Inexact Newton: CG on J to the relative tolerance `forcing`, preconditioned by the factor of
/// the rest matrix J₀ (turned by the nodes' rotations on the direct path), at most
/// `max_cg_iterations`; a CG that fails factors J itself, whose factor then preconditions the
/// rest of that step.
///
/// In contact with a rigid obstacle (a node within d̂) a run of iterations factors J at its
/// first iterate in contact instead ([`Self::factor_contact`]) and takes that iteration's exact
/// Newton step; the next directions are −J_k⁻¹·r on that factor without forming J (modified
/// Newton: no tangent assembly, one f32 solve) while each is taken whole and halves ‖r‖, then
/// CG on J preconditioned by the same factor, not turned, to the forcing term of
/// [`contact_forcing`] (Eisenstat–Walker's, `forcing` its floor). On the 10k-DOF block dropped onto
/// frictional ground (`benches/interactive_contact.rs`, 30 steps) factorizations fell from 106
/// to 76 and CG iterations from 5,554 to 3,673. That factor's preconditioner is corrected at
/// the nodes whose diagonal block of J has changed since ([`NodeCorrection`]): 40 steps of
/// that drop went from 3,488 CG iterations, 18 fallbacks and 67 factorizations to 891, none
/// and 44.
pub(crate) struct RestPreconditionedCg {
    max_cg_iterations: usize,
    forcing: f64,
    /// The nodes' rotations that turn the rest factor.
    rotations: NodalRotations,
    /// The (mass scale, damping stiffness) of the rest matrix the solver's current factor is
    /// of (`None`: no factor yet, or a fallback's).
    preconditioner_for: Option<(f64, f64)>,
    /// The current factor is a fallback's (of a Newton matrix, not the rest one). It serves the
    /// rest of its step only: each step starts from the rest factor, so that a step depends on
    /// the state alone (not on which steps came before) and a restarted run continues with the
    /// same bits as an uninterrupted one.
    lagged: bool,
    /// The solver holds the factor of a Newton matrix of this run of iterations, made at its
    /// first iteration because the body touched an obstacle there ([`Self::factor_contact`]).
    run_factor: bool,
    /// The next direction may be the kept factor's own, −J_k⁻¹·r without forming J (modified
    /// Newton): set with a run's factor, cleared for the run when such a direction's step is
    /// not taken whole or does not halve the residual.
    modified: bool,
    /// The last direction was a modified-Newton one.
    last_modified: bool,
    /// ‖r‖ at the run's previous iteration (`None` at its first): the contact CG's forcing
    /// term follows the residual's last contraction ([`contact_forcing`]).
    last_residual: Option<f64>,
    /// The run factor's correction at the nodes whose block of J changed since.
    correction: NodeCorrection,
}

/// The largest relative tolerance of CG on a contact run's J ([`contact_forcing`]).
const CONTACT_FORCING_MAX: f64 = 0.5;

/// The relative change (Frobenius norm) of a node's diagonal block of J since a contact run's
/// factor past which CG's preconditioner solves that node with its current block
/// ([`NodeCorrection`]). The barrier's and friction's blocks change by factors between Newton
/// iterations, the elastic ones by a few percent: on the 10k-DOF block dropped onto frictional
/// ground (`benches/interactive_contact.rs`, 40 steps) CG took 3,488 iterations (18 fallbacks)
/// without the correction, 891 at 0.1, 980 at 0.25 (83 nodes selected a solve on average, at
/// most 225 of 3,375), 1,231 at 0.5, none of them a fallback. Not lower: the local solves
/// are meant for nodes the barrier or friction dominate, where block Jacobi converges (which
/// keeps the two-level preconditioner positive definite); where it does not, CG runs out of
/// its budget and the step factors J, as before.
const CORRECTION_THRESHOLD: f64 = 0.1;

/// The relative tolerance of CG on J preconditioned by a contact run's factor when the residual
/// went from `previous` to `current` in the last iteration: Eisenstat and Walker's second
/// choice η = 0.9·(‖r_k‖/‖r_{k−1}‖)², kept within [`floor`, [`CONTACT_FORCING_MAX`]] (`floor`
/// the strategy's own forcing term, which every CG solved to before).
///
/// Where Newton itself contracts ‖r‖ by only 3–10× an iteration (the barrier's and friction's
/// curvature far from the step's solution; the 10k-DOF block sliding on the ground,
/// `benches/interactive_contact.rs`, from r = 1.1 to 0.27, 0.24, 0.085, 0.012, 8.9e-4, 2.5e-6,
/// 2.4e-9), a direction solved to 1e-3 of ‖r‖ is over-solved: each CG iteration is a
/// triangular solve pair, 15–22 of them an iteration. Near the solution the contraction is
/// quadratic and η falls to the floor again, which keeps the last iterations' rate.
///
/// The cap: on the drop's first 40 steps, 0.5 against 0.1 took 67 against 74 factorizations,
/// 3 476 against 4 528 CG iterations and 18 against 27 fallbacks for 11.15 against 10.95
/// Newton iterations a step; the press (100 steps) 1 499 against 1 486 CG iterations.
fn contact_forcing(previous: Option<f64>, current: f64, floor: f64) -> f64 {
    match previous {
        Some(previous) if previous > 0.0 => {
            let ratio = current / previous;
            (0.9 * ratio * ratio).clamp(floor, CONTACT_FORCING_MAX.max(floor))
        }
        _ => floor,
    }
}

impl RestPreconditionedCg {
    /// The strategy of `settings` (a [`NonlinearSolve::RestPreconditionedCg`]; any other takes
    /// the automatic CG settings) for `force`.
    fn new(settings: NonlinearSolve, force: &NonlinearForce) -> Self {
        let (max_cg_iterations, forcing) = match settings {
            NonlinearSolve::RestPreconditionedCg {
                max_cg_iterations,
                forcing,
            } => (max_cg_iterations, forcing),
            _ => match super::super::nonlinear_solve::AUTO_CG {
                NonlinearSolve::RestPreconditionedCg {
                    max_cg_iterations,
                    forcing,
                } => (max_cg_iterations, forcing),
                _ => (0, 0.0),
            },
        };
        RestPreconditionedCg {
            max_cg_iterations,
            forcing,
            rotations: NodalRotations::new(force),
            preconditioner_for: None,
            lagged: false,
            run_factor: false,
            modified: false,
            last_modified: false,
            last_residual: None,
            correction: NodeCorrection::new(force.free_dofs()),
        }
    }

    /// Whether a run of iterations that starts at `u_new` begins with a factor of its own
    /// Newton matrix instead of the rest one: with a rigid obstacle within d̂ of a node (the
    /// barrier's energy is positive). The rest matrix knows neither the barrier's normal
    /// stiffness κ·Aᵢ·b″(d) nor friction's 2μλ/ε, tens of times the elastic stiffness of a
    /// surface node: CG on it ran out of its budget at most contact iterations.
    fn factor_contact(newton: &NewtonMatrix, u_new: &[f64]) -> Result<bool> {
        Ok(newton.force.contact().is_some()
            && newton.force.surface_contact().is_none()
            && newton.force.contact_energy(u_new)? > 0.0)
    }

    /// Factors the rest Newton matrix J₀ = mass_scale·M + (1 + damping_stiffness)·K₀ into the
    /// solver (through its matrix) unless its factor is there already.
    fn ensure_rest_factor(
        &mut self,
        newton: &mut NewtonMatrix,
        stats: &mut NewtonStats,
    ) -> Result<()> {
        let key = newton.scales;
        if self.preconditioner_for != Some(key) {
            let (mass_scale, damping_stiffness) = key;
            combine(
                newton.system.stiffness(),
                1.0 + damping_stiffness,
                newton.system.mass(),
                mass_scale,
                newton.matrix,
            )?;
            newton.solver.factorize(newton.matrix)?;
            stats.factorizations += 1;
            self.preconditioner_for = Some(key);
            // The rest factor only approximates J (L-BFGS's H₀, CG's preconditioner): its
            // solves may read it rounded to f32, half the bytes (where memory allows a copy).
            newton.solver.make_single_precision_copy()?;
        }
        Ok(())
    }
}

impl RestPreconditionedCg {
    /// CG on J (formed in `newton.matrix`) to `cg`, `delta` holding −r on entry and δ on
    /// success; the linear algebra's [`Error::Solver`](tetfem_linalg::Error::Solver) when CG
    /// fails (the caller falls back to a factorization). Preconditioned by the rest factor
    /// turned by the nodes' rotations (the direct method, no contact run); in a contact run by
    /// its factor of J, not turned (J's own frame), corrected at the nodes whose diagonal
    /// block of J changed since by more than [`CORRECTION_THRESHOLD`] ([`NodeCorrection`]).
    fn solve_cg(
        &mut self,
        newton: &mut NewtonMatrix,
        u_new: &[f64],
        delta: &mut [f64],
        cg: CgOptions,
    ) -> Result<tetfem_linalg::Result<CgReport>> {
        let direct = newton.solver.is_direct();
        if direct && !self.run_factor {
            self.rotations.update(newton.force, u_new, newton.work)?;
            let rotations = &self.rotations;
            let turn = |v: &mut [f64], transpose: bool| match transpose {
                true => rotations.to_rotated_frame(v),
                false => rotations.back_from_rotated_frame(v),
            };
            return Ok(newton
                .solver
                .solve_preconditioned_turned(newton.matrix, delta, cg, &turn));
        }
        if direct && self.correction.select(newton.matrix, CORRECTION_THRESHOLD) > 0 {
            return Ok(self
                .correction
                .solve(newton.solver, newton.matrix, delta, cg));
        }
        Ok(newton.solver.solve_preconditioned(newton.matrix, delta, cg))
    }
}

impl StepDirection for RestPreconditionedCg {
    fn begin_step(&mut self) {
        if self.lagged {
            self.preconditioner_for = None;
            self.lagged = false;
        }
    }

    fn direction(
        &mut self,
        newton: &mut NewtonMatrix,
        u_new: &[f64],
        residual: &[f64],
        delta: &mut [f64],
        first: bool,
        stats: &mut NewtonStats,
    ) -> Result<()> {
        negate(residual, delta);
        self.last_modified = false;
        if first {
            self.run_factor = false;
            self.modified = false;
            self.last_residual = None;
        }
        let residual_norm = norm(residual);
        let previous_residual = self.last_residual.replace(residual_norm);
        if !self.run_factor && Self::factor_contact(newton, u_new)? {
            // J itself at the run's first iterate in contact: this iteration is Newton's own,
            // and the factor preconditions (or, while the residual contracts, replaces) J
            // after it.
            newton.factor(u_new)?;
            stats.factorizations += 1;
            self.correction.remember(newton.matrix);
            // Lagged: the next step starts afresh; CG after this iteration is preconditioned
            // by this factor (not the rest one, which `preconditioner_for` says is there).
            self.lagged = true;
            self.preconditioner_for = Some(newton.scales);
            self.run_factor = true;
            self.modified = true;
            newton.solve_factored(delta)?;
            // CG's preconditioner after this iteration: its solves may read the factor in f32.
            newton.solver.make_single_precision_copy()?;
            return Ok(());
        }
        if self.run_factor && self.modified {
            self.last_modified = true;
            // J_k only approximates J here: its f32 copy serves as well.
            newton.solver.solve_approximate(newton.matrix, delta)?;
            return Ok(());
        }
        self.ensure_rest_factor(newton, stats)?;
        newton.form(u_new, false)?;
        // On a contact run's own factor the forcing term follows Newton's contraction; on the
        // rest factor (no contact) it stays the strategy's.
        let relative_tolerance = match self.run_factor {
            true => contact_forcing(previous_residual, residual_norm, self.forcing),
            false => self.forcing,
        };
        let cg = CgOptions {
            relative_tolerance,
            max_iterations: self.max_cg_iterations,
        };
        let solved = self.solve_cg(newton, u_new, delta, cg)?;
        match solved {
            Ok(report) => {
                stats.cg_iterations += report.iterations;
                Ok(())
            }
            // Out of budget or not positive definite along a direction: factor J itself;
            // its factor preconditions the rest of this step (lagged refactorization).
            Err(tetfem_linalg::Error::Solver(_)) => {
                stats.cg_iterations += self.max_cg_iterations;
                stats.fallbacks += 1;
                self.lagged = true;
                negate(residual, delta);
                newton.factor_formed_and_solve(u_new, delta, stats)?;
                self.correction.remember(newton.matrix);
                Ok(())
            }
            Err(other) => Err(other.into()),
        }
    }

    fn accepted(&mut self, alpha: f64, _delta: &[f64], residual: &[f64], trial: &[f64]) {
        // Modified Newton converges linearly at the rate J_k⁻¹·J leaves: kept while each of its
        // steps is taken whole and at least halves ‖r‖, else the run goes on with CG on the
        // current J preconditioned by the kept factor.
        if self.last_modified && (alpha < 1.0 || norm(trial) > 0.5 * norm(residual)) {
            self.modified = false;
        }
    }

    fn fall_back(&mut self, _stats: &mut NewtonStats) -> bool {
        // A modified-Newton direction along which the search found no decrease: CG on J.
        match self.last_modified {
            true => {
                self.modified = false;
                true
            }
            false => false,
        }
    }
}

/// Quasi-Newton: δ = −H·r with L-BFGS's inverse Hessian H from the run's correction pairs, its
/// H₀ the rest factor turned by the rotations at the run's first iterate (on the direct path;
/// on the iterative one, and after a failure within a run, its preconditioned CG).
///
/// In contact with rigid obstacles H₀ also holds the contact nodes' barrier and friction
/// blocks ([`ContactCapacitance`], Woodbury's identity on the rest factor: no factorization),
/// made at the run's first iterate in contact and made again after an accepted step that was
/// cut short or did not halve ‖r‖ (friction's blocks change by orders of magnitude when a node
/// goes from sticking to slipping). On the 10k-DOF rubber block dropped onto frictional
/// ground (`benches/interactive_contact.rs`, 100 steps, tolerance 1e-8) L-BFGS went from 32.8
/// iterations a step and 114 fallbacks without the blocks to 4.75 and none.
pub(crate) struct Lbfgs {
    /// The correction pairs of the current run.
    memory: LbfgsMemory,
    /// The current run has left L-BFGS for preconditioned CG.
    failed: bool,
    /// The contact nodes' blocks in H₀.
    contact: ContactCapacitance,
    /// Whether H₀ holds them in this run, and whether they are to be made again.
    contact_state: ContactState,
    /// The fallback, whose rest factor and rotations are H₀'s too.
    cg: RestPreconditionedCg,
}

/// Where a run of L-BFGS stands with the contact nodes' blocks in H₀.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum ContactState {
    /// Not made in this run (no node within d̂ so far).
    Free,
    /// Made, and standing.
    Made,
    /// Made, and to be made again at the next direction (the last step was poor).
    Stale,
}

impl Lbfgs {
    /// The contact nodes whose blocks H₀ is to hold from `u_new` on: `Some` where the body is in
    /// contact and the blocks are not standing (the run's first iterate in contact, or after a
    /// poor step); blocks made before that are out of contact now are dropped.
    fn contact_to_hold(
        &mut self,
        newton: &NewtonMatrix,
        u_new: &[f64],
    ) -> Result<Option<ContactNodes>> {
        if self.contact_state == ContactState::Made {
            return Ok(None);
        }
        if !RestPreconditionedCg::factor_contact(newton, u_new)? {
            if self.contact_state == ContactState::Stale {
                // Out of contact since the blocks were made: they are gone.
                self.contact.clear();
                self.contact_state = ContactState::Made;
            }
            return Ok(None);
        }
        let weight = 1.0
            + newton
                .contact_extra
                .as_ref()
                .map_or(0.0, |(_, extra)| *extra);
        let nodes = ContactNodes::of(newton.force, (u_new, weight), &self.cg.rotations)?;
        Ok(Some(nodes))
    }

    /// Makes H₀'s contact blocks for `nodes` (at most `max_dofs` contact DOFs) on the rest
    /// factor; `false` where they cannot be made (the columns past their memory, or C not
    /// factored).
    fn hold_contact(
        &mut self,
        newton: &mut NewtonMatrix,
        nodes: ContactNodes,
        max_dofs: usize,
    ) -> Result<bool> {
        if self.contact_state == ContactState::Free {
            // H₀ gains the contact's stiffness: the pairs made without it go.
            self.memory.clear();
        }
        self.contact_state = ContactState::Made;
        let (solver, matrix) = (&mut *newton.solver, &*newton.matrix);
        let size = (matrix.dim(), max_dofs);
        let mut solve_columns =
            |v: &mut [f64]| -> Result<()> { Ok(solver.solve_approximate_many(matrix, v)?) };
        let made = (self.contact).prepare(nodes, size, newton.scales, &mut solve_columns)?;
        Ok(made != Prepared::TooLarge)
    }
}

impl StepDirection for Lbfgs {
    fn begin_step(&mut self) {
        self.cg.begin_step();
    }

    fn begin_iterations(&mut self) {
        self.memory.clear();
        self.failed = false;
    }

    fn direction(
        &mut self,
        newton: &mut NewtonMatrix,
        u_new: &[f64],
        residual: &[f64],
        delta: &mut [f64],
        first: bool,
        stats: &mut NewtonStats,
    ) -> Result<()> {
        if self.failed || !newton.solver.is_direct() {
            return self
                .cg
                .direction(newton, u_new, residual, delta, first, stats);
        }
        negate(residual, delta);
        if first {
            self.cg.rotations.update(newton.force, u_new, newton.work)?;
            self.contact.clear();
            self.contact_state = ContactState::Free;
        }
        let hold = self.contact_to_hold(newton, u_new)?;
        // Too many contact DOFs for the blocks: this run goes on with the CG path, which
        // factors J, before the rest matrix is factored for nothing (the size's rule, not a
        // failure: no fallback counted).
        // The budget from the factor's flops (a pass over its supernodes): only where the
        // blocks are to be made.
        let hold = hold.map(|h| (h, max_contact_dofs(newton.solver.factor_flops())));
        self.contact.keep_boundary_rows(newton.force);
        let length = self.contact.column_length(u_new.len());
        if hold
            .as_ref()
            .is_some_and(|(h, max_dofs)| h.too_many(length, *max_dofs))
        {
            self.failed = true;
            return self
                .cg
                .direction(newton, u_new, residual, delta, true, stats);
        }
        self.cg.ensure_rest_factor(newton, stats)?;
        if let Some((nodes, max_dofs)) = hold
            && !self.hold_contact(newton, nodes, max_dofs)?
        {
            self.failed = true;
            stats.fallbacks += 1;
            return self
                .cg
                .direction(newton, u_new, residual, delta, true, stats);
        }
        let (rotations, contact) = (&self.cg.rotations, &self.contact);
        let (solver, matrix) = (&mut *newton.solver, &*newton.matrix);
        let mut initial = |v: &mut [f64]| -> Result<()> {
            rotations.to_rotated_frame(v);
            let mut solve =
                |x: &mut [f64]| -> Result<()> { Ok(solver.solve_approximate(matrix, x)?) };
            contact.apply(v, &mut solve)?;
            rotations.back_from_rotated_frame(v);
            Ok(())
        };
        self.memory.apply(delta, &mut initial)
    }

    fn accepted(&mut self, alpha: f64, delta: &[f64], residual: &[f64], trial: &[f64]) {
        if self.failed {
            self.cg.accepted(alpha, delta, residual, trial);
            return;
        }
        if self.contact_state == ContactState::Made
            && (alpha < 1.0 || norm(trial) > 0.5 * norm(residual))
        {
            self.contact_state = ContactState::Stale;
        }
        let n = delta.len();
        let (mut step, mut change) = (self.memory.buffer(n), self.memory.buffer(n));
        for (s, d) in step.iter_mut().zip(delta) {
            *s = alpha * d;
        }
        for ((c, new), old) in change.iter_mut().zip(trial).zip(residual) {
            *c = new - old;
        }
        self.memory.push(step, change);
    }

    fn fall_back(&mut self, stats: &mut NewtonStats) -> bool {
        if self.failed {
            return self.cg.fall_back(stats);
        }
        self.failed = true;
        stats.fallbacks += 1;
        true
    }
}

/// ‖v‖.
fn norm(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}

/// `out` = −r.
fn negate(r: &[f64], out: &mut [f64]) {
    for (d, r) in out.iter_mut().zip(r) {
        *d = -r;
    }
}
