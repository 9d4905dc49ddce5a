//! Time integration of the linear structural system M·ü + C·u̇ + K·u = f on the free DOFs.
//!
//! [`LinearSystem`] holds the matrices; [`State`] the displacement and velocity; each method is
//! an [`Integrator`] in its own file: [`BackwardEuler`] (implicit, first order, unconditionally
//! stable, dissipative), [`Newmark`] (average acceleration: implicit, second order,
//! unconditionally stable, energy-conserving), [`SymplecticEuler`] (explicit, second order in
//! the staggered sense, stable only below [`critical_time_step`]).
//!
//! The elastic force is a parameter of every integrator ([`InternalForce`]): the linear
//! −K_ff·u with all its fast paths, or a nonlinear [`ForceModel`](crate::model::ForceModel),
//! with which the implicit methods iterate Newton per step (written once, in `newton.rs`) and
//! the explicit one evaluates the nonlinear force.

mod backward_euler;
mod checkpoint;
mod damping;
mod element_bound;
mod energy;
mod explicit;
mod explicit_surface;
mod inertia;
pub(crate) mod internal_force;
mod lbfgs;
mod newmark;
pub(crate) mod newton;
mod nodal_rotation;
mod nonlinear_solve;
mod reactions;
mod stability;
mod state;
mod system;
mod time_data;
mod top_eigenvalue;

pub use backward_euler::BackwardEuler;
pub use checkpoint::{
    BARRIER_RECORD, CHECKPOINT_MAGIC, CHECKPOINT_VERSION, Checkpoint, IMPACT_STIFFNESS_RECORD,
    IntegratorHistory, fingerprint_hash,
};
pub use damping::Rayleigh;
pub use element_bound::{
    ElementStepBound, StepBoundElement, element_step_bound, element_step_bound_of,
    element_step_bound_of_type,
};
pub use energy::Energy;
pub use explicit::{EXPLICIT_REMEDY, SymplecticEuler};
pub use explicit_surface::{
    EXPLICIT_SURFACE_DISTANCE_FRACTION, SurfaceStepBound, surface_step_bound,
};
pub use internal_force::{BarrierRecord, ForceWorkspace, InternalForce, NonlinearForce};
pub use newmark::Newmark;
pub use newton::{
    COLUMN_BYTES, INTERACTIVE_STEP_TOLERANCE, NewtonStats, StepNewtonOptions, max_contact_dofs,
};
pub use nonlinear_solve::{
    AUTO_CONTACT_LBFGS_TOLERANCE, AUTO_LBFGS_CORRECTION, AUTO_LBFGS_HISTORY, AUTO_LBFGS_TOLERANCE,
    AUTO_REFACTOR_BELOW, NonlinearSolve,
};
pub use reactions::SupportReactions;
pub use stability::{
    Certificate, CriticalStep, CriticalStepOptions, DivergenceGuard, critical_time_step,
    critical_time_step_with, damped_critical_step, element_critical_step,
};
pub use state::State;
pub use system::{EnergyWorkspace, LinearSystem, Mass, MassKind};
pub use time_data::TimeData;

use crate::base::error::{Error, Result};
use crate::iterative::CgOptions;
use crate::linear_solver::{LinearMethod, LinearSolver, SolverOptions};
use crate::linsolve::CholeskyOptions;
use crate::sparse::CscMatrix;

/// A time-stepping method for a [`LinearSystem`]. `Send` so that a run may live in an
/// object another thread steps (a Python `Simulation`, a [`Transient`](crate::analysis::Transient)
/// moved to a worker).
pub trait Integrator: Send {
    /// Advances `state` by one step of [`time_step`](Self::time_step). On
    /// [`Error::Diverged`] the state holds the values of the failed step (for inspection).
    fn step(&mut self, state: &mut State) -> Result<()>;
    /// The current time step (time units).
    fn time_step(&self) -> f64;
    /// Changes the time step; implicit methods refactor their system matrix on the next step.
    fn set_time_step(&mut self, dt: f64) -> Result<()>;
    /// A short name for reports (`backward-euler`, `newmark`, `explicit`).
    fn name(&self) -> &'static str;
    /// Stored values of the Cholesky factor an implicit method solves with (`None` for methods
    /// without one, 0 on an implicit method's iterative path): what each of its steps reads
    /// twice.
    fn factor_len(&self) -> Option<usize> {
        None
    }
    /// The linear solver of an implicit method (`None` for the explicit one): which method it
    /// took and why ([`LinearSolver::choice`]).
    fn linear_solver(&self) -> Option<&LinearSolver> {
        None
    }
    /// Newton iteration counts so far (`None` with the linear model, and for the explicit
    /// method, which solves nothing).
    fn newton_stats(&self) -> Option<NewtonStats> {
        None
    }
    /// The free DOFs' acceleration a (length/time²) of the equation of motion
    /// M·a + C·v + K·u = f(t) at `state`, when this integrator's last step left `state` with the
    /// linear force: Newmark's a⁺, backward Euler's Δv/dt, each satisfying that equation at the
    /// step's end to its solve's round-off. `None` otherwise (a nonlinear force, whose a holds
    /// Newton's tolerance; the explicit method; a state set from outside): then
    /// [`SupportReactions`] solves for it with the consistent mass, as it does without it.
    fn linear_acceleration(&self, _state: &State) -> Option<std::borrow::Cow<'_, [f64]>> {
        None
    }
    /// What this integrator carries from one step to the next beyond the [`State`] (see
    /// [`Checkpoint`]); with it, [`restore`](Self::restore) continues bit-identically. The
    /// default refuses: an integrator that keeps history must say what it is.
    fn history(&self) -> Result<IntegratorHistory> {
        Err(checkpoint::unsupported(self.name()))
    }
    /// Continues from `state` with the `history` [`history`](Self::history) gave at that
    /// state, on an integrator built as the one that gave it (same system, force, dt and
    /// options): its next step has the bits the original's next step had. Errors: another
    /// method's history, vectors of another length. The default refuses.
    fn restore(&mut self, state: &State, history: &IntegratorHistory) -> Result<()> {
        let _ = (state, history);
        Err(checkpoint::unsupported(self.name()))
    }
}

/// Adds per-chunk partial sums in chunk order: with fixed chunks, the same bits whatever the
/// number of threads that produced them.
pub(crate) fn sum_in_order<const N: usize>(partial: &[[f64; N]]) -> [f64; N] {
    partial.iter().fold([0.0; N], |mut total, p| {
        for (t, p) in total.iter_mut().zip(p) {
            *t += p;
        }
        total
    })
}

/// Validates a time step: finite and > 0.
pub fn check_time_step(dt: f64) -> Result<f64> {
    if dt.is_finite() && dt > 0.0 {
        Ok(dt)
    } else {
        Err(Error::invalid_parameter(
            "dt",
            dt,
            "the time step must be finite and > 0",
        ))
    }
}

/// [`Error::InvalidParameter`] naming `dt` if the implicit step matrix `matrix`, formed with
/// the time step `dt` as `formula` states, has a non-finite entry: dt = 1e200 s makes dt² (or
/// 1/dt²) overflow, which the factorization would report as a bare "matrix value inf".
fn check_step_matrix(matrix: &CscMatrix, dt: f64, formula: &str) -> Result<()> {
    match matrix.values().iter().position(|v| !v.is_finite()) {
        None => Ok(()),
        Some(k) => Err(Error::invalid_parameter(
            "dt",
            format!("{} s", crate::base::error::short_number(dt)),
            format!(
                "the step matrix {formula} overflows with it (entry {k} = {}): the time step is \
                 far outside the time scales of the model's stiffness and mass; use a dt near its \
                 natural periods",
                matrix.values()[k]
            ),
        )),
    }
}

/// [`Error::InvalidParameter`] unless the system's Rayleigh coefficients are finite and ≥ 0
/// ([`LinearSystem::with_damping`] takes any): negative damping feeds energy in, so no
/// integrator accepts it.
fn check_damping(system: &LinearSystem) -> Result<()> {
    let damping = system.damping();
    Rayleigh::new(damping.alpha, damping.beta).map(|_| ())
}

/// Options of the integrators beyond the time step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IntegratorOptions {
    /// Ordering and threads of the implicit methods' Cholesky factorization of their system
    /// matrix, and of its two triangular solves per step (ignored by the explicit method, which
    /// solves nothing). The default is [`CholeskyOptions::default`]: one thread, so that results
    /// do not depend on the machine; `threads: 2` runs the two halves of the elimination tree
    /// in parallel in each solve (and the factorization on rayon's pool), which pays when the
    /// memory bus has bandwidth to spare for a second core. `threads: 0` counts as 1.
    pub cholesky: CholeskyOptions,
    /// How the implicit methods solve their system each step.
    /// - [`LinearMethod::Direct`], the default: one Cholesky factorization per time step value,
    ///   two triangular solves per step.
    /// - [`LinearMethod::Iterative`]: conjugate gradients preconditioned by smoothed-aggregation
    ///   multigrid (with the rigid-body modes when the system has its
    ///   [`geometry`](LinearSystem::geometry)), the hierarchy rebuilt once per time step value:
    ///   for meshes whose factor would not fit in memory. Each step then solves to `cg`'s
    ///   tolerance, so the trajectory matches the direct one to that tolerance, not to the bit.
    /// - [`LinearMethod::Auto`]: chosen by predicted time for [`STEPS_PER_MATRIX`] solves per
    ///   matrix, within the memory budget (see [`LinearSolver`]).
    pub linear_method: LinearMethod,
    /// Stopping rule of conjugate gradients on the iterative path.
    pub cg: CgOptions,
    /// Tolerance and iteration limit of the implicit methods' Newton iterations per step with
    /// a nonlinear [`InternalForce`] (ignored with the linear one).
    pub newton: StepNewtonOptions,
    /// How those Newton iterations solve their linear systems (ignored with the linear
    /// force): [`NonlinearSolve::Auto`] by default (see there), or one path named. All stop
    /// at `newton`'s tolerance on the same residual.
    pub nonlinear_solve: NonlinearSolve,
}

impl Default for IntegratorOptions {
    fn default() -> Self {
        IntegratorOptions {
            cholesky: CholeskyOptions::default(),
            linear_method: LinearMethod::Direct,
            cg: CgOptions::default(),
            newton: StepNewtonOptions::default(),
            nonlinear_solve: NonlinearSolve::default(),
        }
    }
}

/// Steps per system matrix that [`LinearMethod::Auto`] weighs for the implicit methods: a run
/// keeps its time step for many steps, so the factorization is paid once against many cheap
/// solves.
pub const STEPS_PER_MATRIX: usize = 100;

/// What every implicit method builds first: its checked time step, its system matrix (a copy
/// of K_ff, refilled per time step value), the analysed solver of that matrix, and the Newton
/// solver of a nonlinear force (`None` on the linear path).
struct ImplicitParts {
    dt: f64,
    matrix: CscMatrix,
    solver: LinearSolver,
    newton: Option<newton::NewtonSolver>,
}

impl ImplicitParts {
    fn new(
        system: &LinearSystem,
        force: InternalForce,
        dt: f64,
        options: &IntegratorOptions,
    ) -> Result<Self> {
        let dt = check_time_step(dt)?;
        let matrix = system.stiffness().clone();
        let solver = step_solver(system, &matrix, options, &force)?;
        let newton = match force {
            InternalForce::Linear => None,
            InternalForce::Nonlinear(f) => Some(newton::NewtonSolver::new(
                f,
                system,
                options.newton,
                options.nonlinear_solve,
            )?),
        };
        Ok(ImplicitParts {
            dt,
            matrix,
            solver,
            newton,
        })
    }
}

/// The implicit methods' solver of `matrix` (on the pattern of `system`'s K_ff), analysed: for
/// [`STEPS_PER_MATRIX`] solves per matrix with the linear force, one with a nonlinear one (its
/// Newton matrix changes every iteration).
fn step_solver(
    system: &LinearSystem,
    matrix: &CscMatrix,
    options: &IntegratorOptions,
    force: &InternalForce,
) -> Result<LinearSolver> {
    check_damping(system)?;
    let solver_options = SolverOptions {
        method: options.linear_method,
        cholesky: options.cholesky,
        cg: options.cg,
        expected_solves: match force {
            InternalForce::Linear => STEPS_PER_MATRIX,
            InternalForce::Nonlinear(_) => 1,
        },
        ..SolverOptions::default()
    };
    let geometry = match options.linear_method {
        LinearMethod::Direct => None,
        _ => system.geometry().cloned(),
    };
    Ok(LinearSolver::analyze_with_geometry(
        matrix,
        solver_options,
        geometry,
    )?)
}

/// Which integrator, by name (scene files: `backward_euler`, `newmark`, `explicit`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Deserialize, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Method {
    /// [`BackwardEuler`], the default.
    #[default]
    BackwardEuler,
    /// [`Newmark`] average acceleration.
    Newmark,
    /// [`SymplecticEuler`] (explicit).
    Explicit,
}

impl std::str::FromStr for Method {
    type Err = Error;

    fn from_str(name: &str) -> Result<Self> {
        match name {
            "backward-euler" | "be" => Ok(Method::BackwardEuler),
            "newmark" => Ok(Method::Newmark),
            "explicit" | "symplectic-euler" => Ok(Method::Explicit),
            other => Err(Error::invalid_parameter(
                "method",
                other,
                "must be 'backward-euler', 'newmark' or 'explicit'",
            )),
        }
    }
}

impl Method {
    /// Builds the integrator for `system` with time step `dt` and default
    /// [`IntegratorOptions`].
    pub fn integrator(
        self,
        system: std::sync::Arc<LinearSystem>,
        dt: f64,
    ) -> Result<Box<dyn Integrator>> {
        self.integrator_with(system, dt, IntegratorOptions::default())
    }

    /// Builds the integrator for `system` with time step `dt` and chosen `options`.
    pub fn integrator_with(
        self,
        system: std::sync::Arc<LinearSystem>,
        dt: f64,
        options: IntegratorOptions,
    ) -> Result<Box<dyn Integrator>> {
        Ok(match self {
            Method::BackwardEuler => Box::new(BackwardEuler::with_options(system, dt, options)?),
            Method::Newmark => Box::new(Newmark::with_options(system, dt, options)?),
            Method::Explicit => Box::new(SymplecticEuler::new(system, dt)?),
        })
    }

    /// Builds the integrator for `system` with the elastic force `force` (linear or a
    /// nonlinear model), time step `dt` and `options`. With [`InternalForce::Linear`] it is
    /// [`integrator_with`](Self::integrator_with): the same code, the same bits.
    pub fn integrator_with_force(
        self,
        system: std::sync::Arc<LinearSystem>,
        force: InternalForce,
        dt: f64,
        options: IntegratorOptions,
    ) -> Result<Box<dyn Integrator>> {
        Ok(match self {
            Method::BackwardEuler => {
                Box::new(BackwardEuler::with_force(system, force, dt, options)?)
            }
            Method::Newmark => Box::new(Newmark::with_force(system, force, dt, options)?),
            Method::Explicit => Box::new(SymplecticEuler::with_force(system, force, dt)?),
        })
    }
}
