//! The implicit equation of one time step with a nonlinear force model as a Newton system,
//! written once for every implicit integrator (each supplies its scales and predictor).
//!
//! This module (`src/analysis/dynamics/newton/`) is the step's side of Newton's method
//! ([`NewtonSolver`]: the step equation's residual and Φ, the iterate, counts), its direction
//! strategies, each a type owning its state ([`direction`]: refactoring, rest-preconditioned
//! CG, L-BFGS), and where a contact step starts ([`smoothing`]). The loop and the line search
//! are the one Newton of every nonlinear solve (`crate::analysis::newton`), which a static
//! load step iterates in too.

mod contact_capacitance;
pub use contact_capacitance::{COLUMN_BYTES, max_contact_dofs};
mod direction;
mod node_correction;
mod relaxation;
mod smoothing;
mod weight;

pub(crate) use weight::contact_force_and_energy;

use std::sync::Arc;

use super::internal_force::{ForceWorkspace, NonlinearForce};
use super::{LinearSystem, Mass, NonlinearSolve};
use crate::analysis::newton::iteration::{self, NewtonSystem, Stall};
use crate::analysis::newton::line_search::{self, Backtracking, LineFunction};
use crate::base::error::{Error, Result};
use crate::base::vector::{dot, max_abs, norm};
use crate::contact::{MAX_MOTION_STAGES, MotionStage};
use crate::linear_solver::LinearSolver;
use crate::sparse::CscMatrix;
use direction::{NewtonMatrix, StepDirection};

/// Settings of the Newton iterations of an implicit step with a nonlinear force model.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepNewtonOptions {
    /// A step has converged when ‖r‖ ≤ tolerance·max(‖r₀‖, ‖f‖), r₀ the residual of the
    /// implicit equation at the step's start u' = u (on `NonlinearSolve::Auto`'s L-BFGS path,
    /// at the guess the iterations start from, backward Euler's u + dt·v + dt²·(2a − a₋₁),
    /// where they start there without evaluating the start: the guess's residual within
    /// ‖M·v‖/dt + ‖f‖, or Φ rising from the guess back toward the start) and f the external
    /// load (default 1e-8),
    /// or at the round-off floor of the internal forces: below 1e-6 of that reference, a
    /// residual that no longer halves (the O(E·|X|) terms of an element force cancel to
    /// O(E·strain), and more iterations cannot lower the noise that leaves). On
    /// `NonlinearSolve::Auto`'s L-BFGS path the tolerance is at least
    /// [`AUTO_LBFGS_TOLERANCE`](super::AUTO_LBFGS_TOLERANCE), and the step also stops by the
    /// correction test of [`AUTO_LBFGS_CORRECTION`](super::AUTO_LBFGS_CORRECTION); with rigid
    /// obstacles at least [`AUTO_CONTACT_LBFGS_TOLERANCE`](super::AUTO_CONTACT_LBFGS_TOLERANCE).
    pub tolerance: f64,
    /// Newton iterations allowed per step (default 25); more is [`Error::Diverged`] naming the
    /// step, with the residual reached.
    pub max_iterations: usize,
    /// With rigid obstacles (and no body–body contact), after each accepted Newton step that
    /// leaves the step short of its tolerance and at the step's start, move every node that touches an obstacle or holds lagged friction to
    /// the minimum of its own barrier and friction under the pull the rest of the body exerts
    /// on it now, where that lowers both the step's potential Φ and its residual (default
    /// `true`; see `src/contact/set/relax.rs`). The converged step solves the same equation to the same
    /// tolerance either way; on the 10k-DOF rubber block dropped onto frictional ground
    /// (`benches/interactive_contact.rs`, 100 steps) it took 3.10 Newton iterations a step
    /// instead of 5.95 at tolerance 1e-8 (at most 9 instead of 49) and 1.93 instead of 4.37 at
    /// 1e-4. `false` leaves the iterates to Newton alone. Newmark's local problems count the
    /// barrier twice, as its step equation does (its end-point contact); with body–body
    /// contact nothing is relaxed.
    pub relax_contact_nodes: bool,
}

impl Default for StepNewtonOptions {
    fn default() -> Self {
        StepNewtonOptions {
            tolerance: 1e-8,
            max_iterations: 25,
            relax_contact_nodes: true,
        }
    }
}

impl StepNewtonOptions {
    /// The settings for interactive rates: the default's, with the step tolerance
    /// [`INTERACTIVE_STEP_TOLERANCE`] instead of 1e-8: each step stops at ‖r‖ ≤ 1e-4 of its
    /// reference force, fine for animation, not for a study that converges in dt. What
    /// `NonlinearSolve::Auto` holds in contact with rigid obstacles anyway (its floor
    /// [`AUTO_CONTACT_LBFGS_TOLERANCE`](super::AUTO_CONTACT_LBFGS_TOLERANCE)); for the
    /// other solves, and `Auto` without contact or below its L-BFGS size, the looser test.
    pub fn interactive() -> Self {
        StepNewtonOptions {
            tolerance: INTERACTIVE_STEP_TOLERANCE,
            ..StepNewtonOptions::default()
        }
    }

    /// [`Error::InvalidParameter`] unless the tolerance is finite and in (0, 1) and at least one
    /// iteration is allowed.
    pub fn check(&self) -> Result<()> {
        if !(self.tolerance > 0.0 && self.tolerance < 1.0) {
            return Err(Error::invalid_parameter(
                "newton.tolerance",
                self.tolerance,
                "must be finite, > 0 and < 1",
            ));
        }
        if self.max_iterations == 0 {
            return Err(Error::invalid_parameter(
                "newton.max_iterations",
                0,
                "must be at least 1",
            ));
        }
        Ok(())
    }
}

/// The step tolerance of [`StepNewtonOptions::interactive`] (relative to each step's reference
/// force, see [`StepNewtonOptions::tolerance`]). Against 1e-8 it saves 38 % of the Newton
/// iterations of a contact step (a 10k-DOF rubber cube dropped onto frictional ground,
/// `benches/interactive_contact.rs`, 100 steps: 1.93 a step against 3.10, the contact nodes
/// relaxed) and moved the trajectory by 5.1e-7 m of 6.03e-2 m (3.3e-7 m without the
/// relaxation); `tests/core/interactive_contact.rs` holds the distance on a smaller cube.
pub const INTERACTIVE_STEP_TOLERANCE: f64 = 1e-4;

/// Newton iteration counts of an implicit integrator with a nonlinear model.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
pub struct NewtonStats {
    /// Steps solved.
    pub steps: usize,
    /// Newton iterations (each: one tangent assembly and one linear solve: a numerical
    /// factorization and its triangular solves, or preconditioned CG) over all steps; on the
    /// L-BFGS path, its iterations (each one force evaluation and one turned solve).
    pub total_iterations: usize,
    /// The most iterations one step took.
    pub max_per_step: usize,
    /// Iterations of the last step.
    pub last_step: usize,
    /// Numerical factorizations over all steps: one per Newton iteration with
    /// [`NonlinearSolve::Refactor`]; with [`NonlinearSolve::RestPreconditionedCg`] one per time
    /// step value (the rest matrix) plus one per fallback.
    pub factorizations: usize,
    /// Preconditioned CG iterations over all steps (0 with [`NonlinearSolve::Refactor`]); a
    /// fallback counts its whole budget.
    pub cg_iterations: usize,
    /// Newton iterations whose CG ran out of its budget (or met non-positive curvature) and
    /// fell back to a factorization of the current Newton matrix; on the L-BFGS path, also the
    /// steps that went on with preconditioned CG.
    pub fallbacks: usize,
}

/// The implicit equation of one step in the new displacement u' (free DOFs):
///
/// r(u') = s_m·M·(u' − ũ) + C·(s_c·(u' − u) − v_c) − f_int(u') − f = 0,
///
/// C = α·M + β·K_T(u) the Rayleigh damping with the stiffness part frozen at the tangent of the
/// step's start u (PSD-projected, so it dissipates). Backward Euler: s_m = 1/dt², ũ = u + dt·v,
/// s_c = 1/dt, v_c = 0. Newmark (average acceleration): s_m = 4/dt², ũ = u + dt·v + dt²/4·a,
/// s_c = 2/dt, v_c = v. With C constant over the step it is the gradient of
///
/// Φ(u') = ½s_m·|u' − ũ|²_M + ½s_c·|u' − u|²_C − (C·v_c)·u' + W(u') − f·u',
///
/// which the line search may fall back on.
pub(crate) struct StepEquation<'a> {
    /// s_m (1/time²).
    pub mass_scale: f64,
    /// s_c (1/time).
    pub damping_scale: f64,
    /// ũ (length).
    pub predictor: &'a [f64],
    /// u, the displacement the step starts from; also Newton's first iterate.
    pub start: &'a [f64],
    /// v_c (length/time), `None` for zero.
    pub damping_velocity: Option<&'a [f64]>,
    /// The step dt (time): moving obstacles go to their placement at `time + duration`.
    pub duration: f64,
    /// f, the external load of the step equation (force units, free DOFs): the system's load
    /// at the step's end without the supports' elastic coupling
    /// ([`LinearSystem::model_load_at`]).
    pub load: &'a [f64],
    /// A guess of u' nearer than `start` (length; backward Euler: u + dt·v + dt²·(2a − a₋₁)
    /// with the last two steps' accelerations, or u + dt·v + dt²·a after one step), which the
    /// iterations start from when its residual or its Φ is the smaller one (on the path that
    /// stops by the correction test, also whenever `guess_is_trusted` says so);
    /// `None` to start at `start`. Not taken with contact: `start` is the iterate known to be
    /// free of penetration.
    pub first_iterate: Option<&'a [f64]>,
    /// w, the weight of the contact barrier in the step equation (dimensionless): the residual
    /// holds −w·f_c(u'), Φ holds w·E_c(u') and J w·∂²E_c. Backward Euler 1; Newmark 2, its
    /// contact force taken at the step's end (see [`super::Newmark`]).
    pub contact_weight: f64,
}

/// The Newton solver of an implicit integrator with a nonlinear model: its scratch, the tangent,
/// the iteration counts, and the direction strategy (which owns the strategy's own state).
pub(crate) struct NewtonSolver {
    force: Arc<NonlinearForce>,
    options: StepNewtonOptions,
    /// How each iteration finds its direction ([`NonlinearSolve`] resolved for the problem).
    direction: Box<dyn StepDirection>,
    /// The line search along each direction.
    line_search: Backtracking,
    work: ForceWorkspace,
    tangent: CscMatrix,
    /// K_T(u) of the step's start (projected), when β > 0.
    damping_tangent: Option<CscMatrix>,
    internal: Vec<f64>,
    /// The potential energy (elastic plus contact) at `internal_at`, from the same pass.
    internal_energy: f64,
    /// The potential energies at the points `residual` and `trial_residual` were evaluated at:
    /// the line search's Φ needs no pass of its own over the tets.
    residual_energy: f64,
    trial_energy: f64,
    /// The free displacement `internal` is the force at, when `internal_valid`.
    internal_at: Vec<f64>,
    internal_valid: bool,
    /// `residual` (and `residual_energy`) hold the step equation's residual at the iterate the
    /// iterations begin from: the contact step's predicted start evaluated it (its force is not
    /// cached), so the iterations need no pass of their own there.
    residual_at_start: bool,
    residual: Vec<f64>,
    trial: Vec<f64>,
    trial_residual: Vec<f64>,
    delta: Vec<f64>,
    /// The combination a residual multiplies by M (or by K_T(u) for the damping).
    mixed: Vec<f64>,
    scratch: Vec<f64>,
    stats: NewtonStats,
    /// A floor under the convergence reference max(‖r₀‖, ‖f‖) (force): with contact the step's
    /// inertia scale, and the contact force of a moving obstacle's stage (whose own r₀ is what
    /// the last small move left); 0 without contact.
    reference_floor: f64,
    /// The convergence reference of the last Newton iterations (force).
    last_reference: f64,
    /// The smallest step that changes a force ([`NonlinearForce::step_resolution`], length).
    step_resolution: f64,
    /// The scratch of a contact weight other than 1 ([`StepEquation::contact_weight`]), made
    /// at the first such step.
    contact_blocks: Option<weight::ContactBlocks>,
    /// The weight of the step being solved, for the Newton matrix.
    contact_weight: f64,
    /// The current run of iterations gives up ([`Error::Diverged`]) once [`STALL_STEPS`]
    /// line searches in a row took at most [`STALL_FRACTION`] of the Newton step: set for a
    /// contact step's first try, which friction's smoothing continuation takes over.
    abort_on_stall: bool,
    /// Line searches in a row of the current run that took at most [`STALL_FRACTION`].
    short_steps: usize,
    /// τ of the correction test ([`super::nonlinear_solve::AUTO_LBFGS_CORRECTION`]) when the
    /// step stops by it too (`NonlinearSolve::Auto`'s L-BFGS path).
    correction_tolerance: Option<f64>,
    /// ‖s‖∞ of the current run's last accepted step (length; ∞ before the first).
    last_correction: f64,
    /// J₀'s node blocks for the contact nodes' local problems.
    rest_blocks: relaxation::RestBlocks,
    /// Where the last step ended when its last correction was taken unevaluated
    /// ([`NewtonSystem::take_converged_direction`]; empty otherwise): the force and energy
    /// held are those of the iterate before it.
    untested_end: Vec<f64>,
}

/// The line-search fraction at or below which a Newton step counts as short (see
/// [`NewtonSolver::abort_on_stall`]).
const STALL_FRACTION: f64 = 0.125;

/// Short steps in a row after which a contact step's first try gives up.
const STALL_STEPS: usize = 4;

impl std::fmt::Debug for NewtonSolver {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("NewtonSolver")
            .field("model", &self.force.name())
            .field("options", &self.options)
            .field("stats", &self.stats)
            .finish_non_exhaustive()
    }
}

/// How a residual evaluates the internal force.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Pass {
    /// Over every tet.
    Full,
    /// Carried from the last full pass over the tets at the nodes that moved since
    /// ([`NonlinearForce::force_and_energy_near_into`]): the contact nodes' relaxation.
    Near,
}

impl NewtonSolver {
    /// A solver for `force` on `system` whose linear solves are made as `solve` says (β > 0
    /// keeps a second tangent for the damping).
    pub fn new(
        force: Arc<NonlinearForce>,
        system: &LinearSystem,
        options: StepNewtonOptions,
        solve: NonlinearSolve,
    ) -> Result<Self> {
        options.check()?;
        solve.check()?;
        let n = force.free_count();
        let mut options = options;
        options.tolerance = solve.step_tolerance(n, &force, options.tolerance);
        let correction_tolerance = solve.correction_tolerance(n, &force);
        let solve = solve.for_step(n, &force, options.tolerance);
        let step_resolution = force.step_resolution();
        Error::check_len("nonlinear force free DOFs", system.free_count(), n)?;
        Ok(NewtonSolver {
            work: force.workspace()?,
            direction: direction::choose(solve, &force),
            line_search: Backtracking::for_contact(force.has_contact()),
            tangent: force.zero_tangent()?,
            damping_tangent: match system.damping().beta > 0.0 {
                true => Some(force.zero_tangent()?),
                false => None,
            },
            force,
            options,
            internal: vec![0.0; n],
            internal_at: vec![0.0; n],
            internal_valid: false,
            residual_at_start: false,
            internal_energy: 0.0,
            residual_energy: 0.0,
            trial_energy: 0.0,
            residual: vec![0.0; n],
            trial: vec![0.0; n],
            trial_residual: vec![0.0; n],
            delta: vec![0.0; n],
            mixed: vec![0.0; n],
            scratch: vec![0.0; n],
            stats: NewtonStats::default(),
            reference_floor: 0.0,
            last_reference: 0.0,
            step_resolution,
            contact_blocks: None,
            contact_weight: 1.0,
            abort_on_stall: false,
            short_steps: 0,
            correction_tolerance,
            last_correction: f64::INFINITY,
            rest_blocks: relaxation::RestBlocks::default(),
            untested_end: Vec::new(),
        })
    }

    /// The force law.
    pub fn force(&self) -> &NonlinearForce {
        &self.force
    }

    /// The counts so far.
    pub fn stats(&self) -> NewtonStats {
        self.stats
    }

    /// Sets the counts (a run restored from a checkpoint continues its counts).
    pub fn set_stats(&mut self, stats: NewtonStats) {
        self.stats = stats;
    }

    /// f + f_int(u) − C(u)·v into `out` (C = αM + βK_T(u), K_T projected): the force that
    /// accelerates the state (u, v), for explicit steps and Newmark's initial acceleration;
    /// `f` the external load at the state's time ([`LinearSystem::model_load_at`]), the
    /// force's supports set to that time ([`NonlinearForce::set_time`]).
    pub fn net_force(
        &mut self,
        system: &LinearSystem,
        (u, v): (&[f64], &[f64]),
        f: &[f64],
        out: &mut [f64],
    ) -> Result<()> {
        Error::check_len("load", out.len(), f.len())?;
        let damping = system.damping();
        self.internal_energy =
            self.force
                .force_and_energy_into(u, &mut self.work, &mut self.internal)?;
        self.internal_at.copy_from_slice(u);
        self.internal_valid = true;
        system.mass_product_into(v, &mut self.scratch);
        for i in 0..out.len() {
            out[i] = f[i] + self.internal[i] - damping.alpha * self.scratch[i];
        }
        if damping.beta > 0.0 {
            self.force
                .material_tangent_into(u, true, &mut self.work, &mut self.tangent)?;
            self.tangent.product_into(v, &mut self.scratch);
            for (o, kv) in out.iter_mut().zip(&self.scratch) {
                *o -= damping.beta * kv;
            }
        }
        Ok(())
    }

    /// The energies of `state` (½vᵀMv, the load potentials) with its elastic part from the pass
    /// [`net_force`](Self::net_force) made at `state.displacement`: the model's energy plus, with
    /// contact, the barrier's, so an explicit step's divergence guard needs no second pass over
    /// the tets. Where the last pass was elsewhere, the model's energy is computed afresh.
    pub fn energy_at_net_force(
        &self,
        system: &LinearSystem,
        state: &super::State,
    ) -> Result<super::Energy> {
        if !(self.internal_valid && self.internal_at == state.displacement) {
            return self.force.energy(system, state);
        }
        NonlinearForce::energy_with_elastic(system, state, self.internal_energy)
    }

    /// The energies of `state` with the model's elastic energy (no contact term), for an
    /// implicit step's divergence guard: from the last residual's pass when it was made at
    /// `state.displacement` (the end of the last step) without contact; with rigid obstacles
    /// carried from the last full pass over the tets at the nodes the contact nodes'
    /// relaxation moved since (`NonlinearForce::elastic_energy_near`, a few hundred tets
    /// instead of a pass over all, to round-off of the energy); else a pass of its own.
    /// Before, every implicit corotational step made that pass over the tets for the guard alone.
    ///
    /// Where the last step ended with a correction taken unevaluated
    /// ([`NewtonSystem::take_converged_direction`]), the elastic energy is the one of the
    /// iterate before it, which the correction test put within [`AUTO_LBFGS_CORRECTION`]
    /// (1e-4) of the step's motion of the end: the guard fires at ten times the energy the
    /// start and the loads' work can supply, so that difference cannot decide it, and a pass
    /// of its own would cost as much as the one the stop saved.
    ///
    /// [`AUTO_LBFGS_CORRECTION`]: super::AUTO_LBFGS_CORRECTION
    pub fn elastic_energy_of(
        &mut self,
        system: &LinearSystem,
        state: &super::State,
    ) -> Result<super::Energy> {
        if self.force.has_contact() {
            // The last step's last full pass and its relaxed contact nodes (rigid obstacles).
            let displacement = &state.displacement;
            let elastic = self
                .force
                .elastic_energy_near(displacement, &mut self.work)?;
            return NonlinearForce::energy_with_elastic(system, state, elastic);
        }
        if self.internal_valid && self.untested_end == state.displacement {
            return NonlinearForce::energy_with_elastic(system, state, self.internal_energy);
        }
        self.energy_at_net_force(system, state)
    }

    /// r(u') of `equation` into the residual, or the trial residual when `out_is_trial`.
    fn residual_into(
        &mut self,
        system: &LinearSystem,
        equation: &StepEquation,
        u_new: &[f64],
        out_is_trial: bool,
    ) -> Result<()> {
        self.residual_by(system, equation, u_new, out_is_trial, Pass::Full)
    }

    /// [`residual_into`](Self::residual_into) with the internal force by `pass`.
    fn residual_by(
        &mut self,
        system: &LinearSystem,
        equation: &StepEquation,
        u_new: &[f64],
        out_is_trial: bool,
        pass: Pass,
    ) -> Result<()> {
        let damping = system.damping();
        // A step starts where the last one's final residual was evaluated: its internal force
        // is still here (without contact, whose force also depends on the obstacles' placement
        // and the lagged friction).
        // Nor with moving supports: the same free u is another full displacement at another time.
        let cached = self.force.contact().is_none()
            && !system.has_moving_supports()
            && self.internal_valid
            && self.internal_at.as_slice() == u_new;
        if !cached {
            let (force, work, internal) = (&self.force, &mut self.work, &mut self.internal);
            self.internal_energy = match pass {
                Pass::Full => force.force_and_energy_into(u_new, work, internal)?,
                Pass::Near => force.force_and_energy_near_into(u_new, work, internal)?,
            };
            self.internal_at.copy_from_slice(u_new);
            self.internal_valid = true;
        }
        // The barrier's share beyond the force law's one (Newmark's end-point contact).
        let extra = match weight::extra_weight(&self.force, equation) {
            Some(extra) => Some((extra, weight::contact_force_and_energy(&self.force, u_new)?)),
            None => None,
        };
        let energy = match &extra {
            Some((w, (_, e))) => self.internal_energy + w * e,
            None => self.internal_energy,
        };
        match out_is_trial {
            true => self.trial_energy = energy,
            false => self.residual_energy = energy,
        }
        let (s_m, s_c) = (equation.mass_scale, equation.damping_scale);
        let vc = |i: usize| equation.damping_velocity.map_or(0.0, |v| v[i]);
        // M·(s_m·(u' − ũ) + α·w), w = s_c·(u' − u) − v_c: one mass product.
        for i in 0..u_new.len() {
            let w = s_c * (u_new[i] - equation.start[i]) - vc(i);
            self.mixed[i] = s_m * (u_new[i] - equation.predictor[i]) + damping.alpha * w;
        }
        let out = match out_is_trial {
            true => &mut self.trial_residual,
            false => &mut self.residual,
        };
        system.mass_product_into(&self.mixed, out);
        let f = equation.load;
        for i in 0..u_new.len() {
            out[i] -= self.internal[i] + f[i];
        }
        if let Some((w, (contact_force, _))) = &extra {
            for (o, fc) in out.iter_mut().zip(contact_force) {
                *o -= w * fc;
            }
        }
        if let Some(k) = &self.damping_tangent {
            for i in 0..u_new.len() {
                self.mixed[i] = s_c * (u_new[i] - equation.start[i]) - vc(i);
            }
            k.product_into(&self.mixed, &mut self.scratch);
            for (o, kw) in out.iter_mut().zip(&self.scratch) {
                *o += damping.beta * kw;
            }
        }
        Ok(())
    }

    /// The line search of [`iterate`](Self::iterate) along the Newton step δ from `u_new`
    /// (residual norm `r_norm`) from the step fraction `first_alpha` (see [`Backtracking`]):
    /// returns whether a fraction was accepted, and the last one tried. The trial's residual
    /// is left in `trial_residual`, the trial point in `trial`.
    fn search_line(
        &mut self,
        system: &LinearSystem,
        equation: &StepEquation,
        u_new: &[f64],
        (first_alpha, r_norm, reference): (f64, f64, f64),
    ) -> Result<(bool, f64)> {
        let slope = dot(&self.residual, &self.delta).abs();
        let near_level = line_search::NEAR_SOLUTION * reference;
        let search = self.line_search;
        let mut line = StepLine {
            solver: self,
            system,
            equation,
            u_new,
            start_phi: None,
        };
        search.search(&mut line, first_alpha, (r_norm, near_level), slope)
    }

    /// Φ at the line search's start `u_new` (its energy from the residual's pass), computed at
    /// most once per line search: `cache` holds it after the first call.
    fn start_potential(
        &self,
        cache: &mut Option<f64>,
        system: &LinearSystem,
        equation: &StepEquation,
        u_new: &[f64],
    ) -> Result<f64> {
        if let Some(phi) = *cache {
            return Ok(phi);
        }
        let phi = self.potential(system, equation, u_new, self.residual_energy)?;
        *cache = Some(phi);
        Ok(phi)
    }

    /// Φ(u') of `equation` (see [`StepEquation`]), `energy` the potential energy (elastic plus
    /// contact) at u', from its residual's evaluation.
    fn potential(
        &self,
        system: &LinearSystem,
        equation: &StepEquation,
        u_new: &[f64],
        energy: f64,
    ) -> Result<f64> {
        let damping = system.damping();
        let n = u_new.len();
        let p: Vec<f64> = (0..n).map(|i| u_new[i] - equation.predictor[i]).collect();
        let q: Vec<f64> = (0..n).map(|i| u_new[i] - equation.start[i]).collect();
        let mass = system.mass();
        let mut phi = 0.5 * equation.mass_scale * mass.quadratic_form(&p)?
            + 0.5 * equation.damping_scale * damping.alpha * mass.quadratic_form(&q)?;
        if let Some(k) = &self.damping_tangent {
            phi += 0.5 * equation.damping_scale * damping.beta * k.quadratic_form(&q)?;
        }
        if let Some(vc) = equation.damping_velocity {
            let mut mv = vec![0.0; n];
            mass.product_into(vc, &mut mv);
            phi -= damping.alpha * dot(&mv, u_new);
            if let Some(k) = &self.damping_tangent {
                k.product_into(vc, &mut mv);
                phi -= damping.beta * dot(&mv, u_new);
            }
        }
        let load = dot(equation.load, u_new);
        Ok(phi + energy - load)
    }

    /// Solves `equation` for u' by Newton's method into `u_new` (any length-n buffer; it starts
    /// at u), forming the Newton matrix J = (s_m + s_c·α)·M + s_c·β·K_T(u) + K_T(u') in `matrix`
    /// (on K_ff's pattern) and solving with `solver` (refactored numerically each iteration on
    /// its fixed symbolic analysis). The exact tangent is tried first (quadratic convergence);
    /// where J is not positive definite, the PSD-projected one. A backtracking line search
    /// accepts a step when the residual norm or Φ decreases. Returns the iterations taken;
    /// [`Error::Diverged`] (naming `step` and `time`) when the residual stops being finite or
    /// the iterations run out.
    #[allow(clippy::too_many_arguments)]
    pub fn solve(
        &mut self,
        system: &LinearSystem,
        equation: &StepEquation,
        matrix: &mut CscMatrix,
        solver: &mut LinearSolver,
        u_new: &mut [f64],
        step: usize,
        time: f64,
    ) -> Result<usize> {
        u_new.copy_from_slice(equation.start);
        self.untested_end.clear();
        self.direction.begin_step();
        self.contact_weight = 1.0;
        if weight::extra_weight(&self.force, equation).is_some() {
            if self.contact_blocks.is_none() {
                self.contact_blocks = Some(weight::ContactBlocks::new(&self.force, matrix)?);
            }
            self.contact_weight = equation.contact_weight;
        }
        if let Some(k) = &mut self.damping_tangent {
            self.force
                .material_tangent_into(equation.start, true, &mut self.work, k)?;
        }
        // Friction lags its normal forces and tangent planes at the step's start, once per
        // step (IPC's lagged friction); its smoothing distance is ε_v/s_c (backward Euler:
        // ε_v·dt; Newmark: ε_v·dt/2).
        let force = Arc::clone(&self.force);
        // With contact, a body in free flight has r₀ and f at round-off (no load, or gravity
        // balanced by the ground): converge relative to the inertia scale ‖s_m·M·(u − ũ)‖ too,
        // the force that would stop the body within the step.
        let inertia = match force.has_contact() {
            true => {
                for i in 0..u_new.len() {
                    self.mixed[i] =
                        equation.mass_scale * (equation.start[i] - equation.predictor[i]);
                }
                system.mass_product_into(&self.mixed, &mut self.scratch);
                norm(&self.scratch)
            }
            false => 0.0,
        };
        let Some(contact) = force.contact().filter(|c| c.is_moving()) else {
            self.force
                .begin_step(equation.start, 1.0 / equation.damping_scale)?;
            self.reference_floor = inertia;
            let solved = self
                .iterate(system, equation, matrix, solver, u_new, step, time)
                .and_then(|iterations| {
                    self.force.keep_friction_forces(u_new)?;
                    Ok(iterations)
                });
            self.reference_floor = 0.0;
            self.force.end_friction();
            return solved;
        };
        let solved = self
            .solve_moving(
                contact, inertia, system, equation, matrix, solver, u_new, step, time,
            )
            .and_then(|iterations| {
                self.force.keep_friction_forces(u_new)?;
                Ok(iterations)
            });
        self.reference_floor = 0.0;
        self.force.end_friction();
        solved
    }

    /// [`solve`](Self::solve) with moving obstacles: they go from their placement at `time` to
    /// that at `time + duration` at once, Newton starting from the body carried with them
    /// ([`NonlinearForce::carried_start`]: one solve per step). Where no carried start exists or
    /// Newton does not converge from it, they go there in stages, at most [`MAX_MOTION_STAGES`] (more is
    /// [`Error::Diverged`]: the obstacles move too far per step). Each stage moves them by 0.8
    /// of the largest collision-free fraction of the remaining straight move for the current
    /// iterate ([`Contact::advance_stage`](crate::contact::Contact::advance_stage)) and
    /// solves the step equation there, so the next stage starts from a body that has made
    /// room; the last stage (the whole remaining move fits) is the step's solution.
    #[allow(clippy::too_many_arguments)]
    fn solve_moving(
        &mut self,
        contact: &crate::contact::Contact,
        inertia: f64,
        system: &LinearSystem,
        equation: &StepEquation,
        matrix: &mut CscMatrix,
        solver: &mut LinearSolver,
        u_new: &mut [f64],
        step: usize,
        time: f64,
    ) -> Result<usize> {
        let placed = contact;
        placed.set_time(time);
        let target = contact.offsets_at(time + equation.duration);
        self.force.begin_step_toward(
            equation.start,
            1.0 / equation.damping_scale,
            &target,
            equation.duration,
        )?;
        if let Some(start) = self.force.carried_start(equation.start, &target)? {
            u_new.copy_from_slice(&start);
            placed.set_offsets(target.clone())?;
            match self.iterate_pushed(inertia, system, equation, matrix, solver, u_new, step, time)
            {
                Err(Error::Diverged { .. }) => {
                    // The carried start did not converge: stage the move from the step's start.
                    placed.set_time(time);
                    u_new.copy_from_slice(equation.start);
                }
                solved => return solved,
            }
        }
        let (steps_before, mut iterations) = (self.stats.steps, 0);
        for _ in 0..MAX_MOTION_STAGES {
            let full = self.force.full_displacement(u_new)?;
            let last = match placed.advance_stage(&full, &target)? {
                MotionStage::Blocked => {
                    return Err(Error::Diverged {
                        step,
                        time,
                        reason: "a moving obstacle touches a node it cannot push away (a fixed \
                                 support in its way)"
                            .into(),
                    });
                }
                stage => stage == MotionStage::Last,
            };
            iterations +=
                self.iterate_pushed(inertia, system, equation, matrix, solver, u_new, step, time)?;
            if last {
                // The stages are one step's solve.
                self.stats.steps = steps_before + 1;
                self.stats.last_step = iterations;
                self.stats.max_per_step = self.stats.max_per_step.max(iterations);
                return Ok(iterations);
            }
        }
        Err(Error::Diverged {
            step,
            time,
            reason: format!(
                "the moving obstacles did not reach their placement at t = {:.6e} in {MAX_MOTION_STAGES} stages (each as far as the body makes room for); a smaller dt helps",
                time + equation.duration
            ),
        })
    }

    /// The Newton iterations of a moving-obstacle step from `u_new` with the obstacles where
    /// they now are (at their target, the body carried with them:
    /// [`NonlinearForce::carried_start`]; or at a stage), converged relative to the force the
    /// obstacles exert there (or the inertia scale): the first residual is only what the last
    /// move left.
    #[allow(clippy::too_many_arguments)]
    fn iterate_pushed(
        &mut self,
        inertia: f64,
        system: &LinearSystem,
        equation: &StepEquation,
        matrix: &mut CscMatrix,
        solver: &mut LinearSolver,
        u_new: &mut [f64],
        step: usize,
        time: f64,
    ) -> Result<usize> {
        let Some(contact) = self.force.contact() else {
            return self.iterate(system, equation, matrix, solver, u_new, step, time);
        };
        let full = self.force.full_displacement(u_new)?;
        let mut pushed = vec![0.0; full.len()];
        contact.add_force(&full, &mut pushed)?;
        self.reference_floor = norm(&pushed).max(inertia);
        let solved = self.iterate(system, equation, matrix, solver, u_new, step, time);
        self.reference_floor = 0.0;
        solved
    }

    /// The Newton iterations of [`solve`](Self::solve) at the lagged friction's smoothing
    /// distance as it stands (see [`iterate`](Self::iterate)).
    #[allow(clippy::too_many_arguments)]
    fn iterate_at_smoothing(
        &mut self,
        system: &LinearSystem,
        equation: &StepEquation,
        matrix: &mut CscMatrix,
        solver: &mut LinearSolver,
        u_new: &mut [f64],
        step: usize,
        time: f64,
    ) -> Result<usize> {
        let damping = system.damping();
        let (s_m, s_c) = (equation.mass_scale, equation.damping_scale);
        let diverged = |reason: String| Error::Diverged { step, time, reason };
        self.direction.begin_iterations();
        self.short_steps = 0;
        self.last_correction = f64::INFINITY;
        // On the path that stops by the correction test the iterations begin at the guess
        // without comparing it with the start where the guess is trusted (`guess_is_trusted`:
        // its residual within the step's own forces): the last step's final correction was taken
        // unevaluated (`take_converged_direction`), so the start's residual would cost a pass of
        // its own, the pass the stop saved; r₀ of the reference below is then the residual at
        // the first iterate, as in PETSc's SNES. Another guess is compared with the start as
        // before.
        let guess = equation.first_iterate.filter(|_| !self.force.has_contact());
        let (mut from_guess, mut guess_evaluated) = (false, false);
        if let Some(guess) = guess.filter(|_| self.correction_tolerance.is_some()) {
            self.residual_into(system, equation, guess, false)?;
            if self.guess_is_trusted(system, equation) {
                u_new.copy_from_slice(guess);
                from_guess = true;
            } else {
                // The guess's residual is the comparison's trial below.
                std::mem::swap(&mut self.residual, &mut self.trial_residual);
                std::mem::swap(&mut self.residual_energy, &mut self.trial_energy);
                guess_evaluated = true;
            }
        }
        if !from_guess && !std::mem::take(&mut self.residual_at_start) {
            self.residual_into(system, equation, u_new, false)?;
        }
        let mut r_norm = norm(&self.residual);
        if !r_norm.is_finite() {
            return Err(diverged(
                "a displacement or velocity is no longer finite (the Newton residual is not)"
                    .into(),
            ));
        }
        let reference = r_norm.max(norm(equation.load)).max(self.reference_floor);
        // With prescribed displacements the supports' pull on the free DOFs is in the internal
        // force, not in f: the linear system's load at the step's end (which holds it as
        // −K_fc·u_c) keeps the reference at the forces' scale; it is f itself without them.
        let reference = match system.has_support_coupling() {
            true => reference.max(system.load_norm_at(time + equation.duration)?),
            false => reference,
        };
        self.last_reference = reference;
        if let Some(guess) = guess.filter(|_| !from_guess) {
            if !guess_evaluated {
                self.residual_into(system, equation, guess, true)?;
            }
            let guessed = norm(&self.trial_residual);
            // Φ too, as the line search accepts: the guess is nearer in the soft, large modes a
            // step is mostly made of, while its residual can be the larger one (up to 3.9× r(u)
            // on a swinging beam), dominated by the stiff modes' small errors. Taken by Φ as
            // well, the guess u + dt·v + dt²·a brought an L-BFGS swing to the same distance from
            // the refactoring trajectory (4e-5) in 52 iterations instead of 77 (50×10×10 cells,
            // 20 steps).
            let lower_potential = || -> Result<bool> {
                let start = self.potential(system, equation, u_new, self.residual_energy)?;
                Ok(self.potential(system, equation, guess, self.trial_energy)? < start)
            };
            if guessed < r_norm || lower_potential()? {
                u_new.copy_from_slice(guess);
                std::mem::swap(&mut self.residual, &mut self.trial_residual);
                std::mem::swap(&mut self.residual_energy, &mut self.trial_energy);
                r_norm = guessed;
            }
        }
        let scales = (s_m + s_c * damping.alpha, s_c * damping.beta);
        // The start's contact nodes too: a node that sticks at the step's start and must slip
        // (or the reverse) is put where its own problem says before the first tangent.
        if r_norm > self.options.tolerance * reference {
            r_norm = self.relax_contact_nodes(system, equation, u_new, scales, r_norm)?;
        }
        let limits = (self.options.tolerance, self.options.max_iterations);
        let mut step_system = StepSystem {
            solver: self,
            system,
            equation,
            matrix,
            linear: solver,
            u_new,
            scales,
            step,
            time,
        };
        match iteration::iterate(&mut step_system, (r_norm, reference), limits)? {
            Ok(iterations) => Ok(self.record(iterations)),
            Err(Stall::OutOfIterations {
                iterations,
                residual,
            }) => Err(diverged(format!(
                "Newton did not converge in {iterations} iterations (residual {residual:.3e} of {reference:.3e}); a smaller dt helps"
            ))),
            Err(Stall::NoDecrease { residual }) => Err(diverged(format!(
                "the Newton line search found no decrease (residual {residual:.3e} of {reference:.3e}); a smaller dt helps"
            ))),
            Err(Stall::NotFinite) => {
                Err(diverged("the Newton residual is no longer finite".into()))
            }
        }
    }

    /// The correction test of [`AUTO_LBFGS_CORRECTION`](super::AUTO_LBFGS_CORRECTION) for a
    /// step of size `step` (‖s‖∞, length) after the last accepted one, the iterate it leads to
    /// `moved` (‖u' − u‖∞) from the step's start: θ/(1 − θ)·‖s‖∞ ≤ τ·‖u' − u‖∞ with
    /// θ = ‖s‖∞/‖s₋₁‖∞ < 1 (Hairer & Wanner, *Solving ODEs II*, IV.8). False off the path that
    /// stops by it, and at a run's first step (no contraction seen yet: θ = 0).
    fn correction_converged(&self, step: f64, moved: f64) -> bool {
        let Some(tau) = self.correction_tolerance else {
            return false;
        };
        let theta = step / self.last_correction;
        theta > 0.0 && theta < 1.0 && theta / (1.0 - theta) * step <= tau * moved
    }

    /// Whether the step may begin at its guess g without comparing it with the start u, the
    /// guess's residual r(g) = ∇Φ(g) in `residual`: when ‖r(g)‖ ≤ ‖s_m·M·(u − ũ)‖ + ‖f‖, the
    /// force that would stop the body within the step plus the load, or when Φ rises from g
    /// back toward u, r(g)·(u − g) > 0 (then Φ(u) ≥ Φ(g) + r(g)·(u − g) > Φ(g) where Φ is
    /// convex along the segment). Neither holds where the extrapolated acceleration is off by
    /// more than the step's own forces, in a transient: on `cost_size`'s clamped cube thrown
    /// sideways the first two guesses had 6–8× the start's residual and a higher Φ, and
    /// starting there cost a third iteration each. The first test alone kept 70–100 % of the
    /// 38° swing's steps from the comparison (2,700–132,300 DOFs), the second alone about a
    /// fifth; on the 105° swing of `tests/core/corotational_step.rs` the two together made
    /// 172 passes for 153 iterations in 25 steps, the first alone 178 for 154.
    fn guess_is_trusted(&mut self, system: &LinearSystem, equation: &StepEquation) -> bool {
        let s_m = equation.mass_scale;
        for ((m, u), p) in self
            .mixed
            .iter_mut()
            .zip(equation.start)
            .zip(equation.predictor)
        {
            *m = s_m * (u - p);
        }
        system.mass_product_into(&self.mixed, &mut self.scratch);
        if norm(&self.residual) <= norm(&self.scratch) + norm(equation.load) {
            return true;
        }
        let guess = equation.first_iterate.unwrap_or(equation.start);
        let uphill_back: f64 = (self.residual.iter().zip(equation.start).zip(guess))
            .map(|((r, u), g)| r * (u - g))
            .sum();
        uphill_back > 0.0
    }

    /// Counts a solved step of `iterations` iterations.
    fn record(&mut self, iterations: usize) -> usize {
        self.stats.steps += 1;
        self.stats.total_iterations += iterations;
        self.stats.max_per_step = self.stats.max_per_step.max(iterations);
        self.stats.last_step = iterations;
        iterations
    }

    /// δ ≈ −J(u')⁻¹·r into `delta` by the direction strategy, J = mass_scale·M +
    /// damping_stiffness·K_T(u_start) + K_T(u') formed in `matrix` and solved with `solver`
    /// as the strategy says; `first`: the run's first iteration.
    fn newton_direction(
        &mut self,
        system: &LinearSystem,
        u_new: &[f64],
        scales: (f64, f64),
        matrix: &mut CscMatrix,
        solver: &mut LinearSolver,
        first: bool,
    ) -> Result<()> {
        let contact_extra = match (&mut self.contact_blocks, self.contact_weight) {
            (Some(blocks), w) if w != 1.0 => Some((blocks, w - 1.0)),
            _ => None,
        };
        let mut newton = NewtonMatrix {
            system,
            force: &self.force,
            work: &mut self.work,
            tangent: &mut self.tangent,
            damping_tangent: self.damping_tangent.as_ref(),
            scales,
            matrix,
            solver,
            contact_extra,
        };
        self.direction.direction(
            &mut newton,
            u_new,
            &self.residual,
            &mut self.delta,
            first,
            &mut self.stats,
        )
    }
}

/// The step equation along the Newton line u_new + α·δ, for the line search: the solver's
/// residual and Φ at its trial points.
struct StepLine<'a> {
    solver: &'a mut NewtonSolver,
    system: &'a LinearSystem,
    equation: &'a StepEquation<'a>,
    u_new: &'a [f64],
    /// Φ at `u_new`, computed at most once per search.
    start_phi: Option<f64>,
}

impl LineFunction for StepLine<'_> {
    fn trial(&mut self, alpha: f64) -> Result<f64> {
        let solver = &mut *self.solver;
        for i in 0..self.u_new.len() {
            solver.trial[i] = self.u_new[i] + alpha * solver.delta[i];
        }
        let trial = std::mem::take(&mut solver.trial);
        let evaluated = solver.residual_into(self.system, self.equation, &trial, true);
        solver.trial = trial;
        evaluated?;
        Ok(norm(&solver.trial_residual))
    }

    fn start_potential(&mut self) -> Result<f64> {
        self.solver
            .start_potential(&mut self.start_phi, self.system, self.equation, self.u_new)
    }

    fn trial_potential(&mut self) -> Result<f64> {
        let solver = &*self.solver;
        solver.potential(
            self.system,
            self.equation,
            &solver.trial,
            solver.trial_energy,
        )
    }
}

/// The step equation at the iterate `u_new` as the Newton loop drives it
/// ([`iteration::NewtonSystem`]): the direction by the solver's strategy, the line search with
/// contact's collision-free first fraction, the iterate moved to the accepted trial.
struct StepSystem<'a> {
    solver: &'a mut NewtonSolver,
    system: &'a LinearSystem,
    equation: &'a StepEquation<'a>,
    matrix: &'a mut CscMatrix,
    linear: &'a mut LinearSolver,
    u_new: &'a mut [f64],
    /// (s_m + s_c·α, s_c·β): J's scales of M and of the damping's K_T(u).
    scales: (f64, f64),
    /// The step's index (0-based).
    step: usize,
    /// The time the step starts at.
    time: f64,
}

impl NewtonSystem for StepSystem<'_> {
    fn direction(&mut self, first: bool) -> Result<()> {
        if self.solver.abort_on_stall && self.solver.short_steps >= STALL_STEPS {
            return Err(Error::Diverged {
                step: self.step,
                time: self.time,
                reason: format!(
                    "{STALL_STEPS} line searches in a row took at most {STALL_FRACTION} of the Newton step"
                ),
            });
        }
        self.solver.newton_direction(
            self.system,
            self.u_new,
            self.scales,
            self.matrix,
            self.linear,
            first,
        )
    }

    fn step_is_unresolved(&self) -> bool {
        let resolution = self.solver.step_resolution;
        self.solver.delta.iter().all(|d| d.abs() <= resolution)
    }

    fn search(&mut self, r_norm: f64, reference: f64) -> Result<(bool, f64)> {
        // With contact: never past the first time of impact (IPC's 0.8 of it), and only a
        // decrease of Φ (up to its round-off) is accepted, so no iterate penetrates.
        let first_alpha = match self.solver.force.has_contact() {
            true => crate::contact::first_step_fraction(
                self.solver
                    .force
                    .contact_step_limit(self.u_new, &self.solver.delta)?,
            ),
            false => 1.0,
        };
        self.solver.search_line(
            self.system,
            self.equation,
            self.u_new,
            (first_alpha, r_norm, reference),
        )
    }

    fn failed_search_is_floor(&self) -> bool {
        // With contact only a decrease of Φ is accepted, which round-off can deny a
        // converged iterate: a Newton step below 1e-9 of the barrier's length scale d̂
        // changes nothing the contact can resolve, so the iterate stands.
        let force = &self.solver.force;
        let obstacles = force.contact().map(|c| c.parameters().activation_distance);
        let surface = force
            .surface_contact()
            .map(|s| s.barrier().activation_distance);
        // The smaller reach when both contacts are present: the finer length scale resolved.
        let d_hat = match (obstacles, surface) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        };
        d_hat.is_some_and(|d_hat| self.solver.delta.iter().all(|d| d.abs() <= 1e-9 * d_hat))
    }

    fn accept(&mut self, alpha: f64) -> f64 {
        let solver = &mut *self.solver;
        solver.short_steps = match alpha <= STALL_FRACTION {
            true => solver.short_steps + 1,
            false => 0,
        };
        solver.direction.accepted(
            alpha,
            &solver.delta,
            &solver.residual,
            &solver.trial_residual,
        );
        self.u_new.copy_from_slice(&solver.trial);
        // The smallest gap of every accepted iterate (with contact; nothing without).
        solver.force.note_iterate(self.u_new);
        std::mem::swap(&mut solver.residual, &mut solver.trial_residual);
        std::mem::swap(&mut solver.residual_energy, &mut solver.trial_energy);
        norm(&solver.residual)
    }

    fn fall_back(&mut self) -> bool {
        self.solver.direction.fall_back(&mut self.solver.stats)
    }

    fn refine(&mut self, r_norm: f64) -> Result<f64> {
        self.solver
            .relax_contact_nodes(self.system, self.equation, self.u_new, self.scales, r_norm)
    }

    fn take_converged_direction(&mut self) -> bool {
        let solver = &mut *self.solver;
        let step = max_abs(&solver.delta);
        let moved = moved_from(self.equation.start, self.u_new, Some(&solver.delta));
        if !solver.correction_converged(step, moved) {
            return false;
        }
        for (u, d) in self.u_new.iter_mut().zip(&solver.delta) {
            *u += d;
        }
        solver.force.note_iterate(self.u_new);
        solver.untested_end.clear();
        solver.untested_end.extend_from_slice(self.u_new);
        true
    }

    fn converged_by_correction(&mut self, alpha: f64) -> bool {
        let step = alpha * max_abs(&self.solver.delta);
        let moved = moved_from(self.equation.start, self.u_new, None);
        let converged = self.solver.correction_converged(step, moved);
        self.solver.last_correction = step;
        converged
    }

    fn describe(&self, iteration: usize) -> String {
        format!("Newton iteration {iteration} of step {}", self.step + 1)
    }
}

/// ‖u' − u‖∞ (length), u' the iterate `u_new` moved by the direction `delta` when there is
/// one: how far the iterate a correction test judges is from the step's `start`.
fn moved_from(start: &[f64], u_new: &[f64], delta: Option<&[f64]>) -> f64 {
    let farthest = |m: f64, (u, u0): (f64, &f64)| m.max((u - u0).abs());
    match delta {
        Some(delta) => (u_new.iter().zip(delta).map(|(u, d)| u + d))
            .zip(start)
            .fold(0.0, farthest),
        None => u_new.iter().copied().zip(start).fold(0.0, farthest),
    }
}

/// The lumped or consistent mass solve a = M⁻¹·b in place (Newmark's initial acceleration).
pub(crate) fn solve_mass(mass: &Mass, b: &mut [f64]) -> Result<()> {
    match mass {
        Mass::Lumped(m) => {
            b.iter_mut().zip(m).for_each(|(a, m)| *a /= m);
            Ok(())
        }
        Mass::Consistent(m) => {
            let mut cholesky = crate::linsolve::SparseCholesky::analyze(m)?;
            cholesky.factorize(m)?;
            cholesky.solve_in_place(b)?;
            Ok(())
        }
    }
}
