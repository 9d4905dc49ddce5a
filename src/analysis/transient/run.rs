//! [`Transient`]: a definition stepped in time by one integrator, through one time loop that
//! [`Observer`]s watch.

use std::sync::Arc;
use std::time::Instant;

use super::critical::{StepLimit, critical_step};
use super::observer::{Flow, Observer, StepView};
use super::time_step::TimeStep;
use crate::analysis::dynamics::{
    BarrierRecord, Energy, Integrator, IntegratorOptions, InternalForce, LinearSystem, MassKind,
    Method, Rayleigh, State, StepBoundElement, surface_step_bound,
};
use crate::analysis::{Analysis, Definition};
use crate::base::error::Result;
use crate::base::warning::Warning;
use crate::model::ModelElement;

/// How a [`Transient`] steps: the method, the step, the mass, the damping and the solvers.
#[derive(Debug, Clone, PartialEq)]
pub struct TransientOptions {
    /// The integrator: backward Euler (the default), Newmark or explicit.
    pub method: Method,
    /// The time step: in time units, or a multiple of the explicit critical step
    /// ([`critical_step`]).
    pub dt: TimeStep,
    /// Lumped (the default; the explicit method needs it) or consistent mass.
    pub mass: MassKind,
    /// Rayleigh damping C = α·M + β·K (none by default).
    pub damping: Rayleigh,
    /// The implicit methods' linear solver and Newton options.
    pub solver: IntegratorOptions,
}

impl TransientOptions {
    /// `method` at step `dt`, lumped mass, no damping, the solvers' defaults.
    pub fn new(method: Method, dt: TimeStep) -> Self {
        TransientOptions {
            method,
            dt,
            mass: MassKind::Lumped,
            damping: Rayleigh::default(),
            solver: IntegratorOptions::default(),
        }
    }
}

/// How a [`Transient::run`] ended when no step failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RunEnd {
    /// Every step was taken.
    Finished,
    /// An observer stopped the run after this step.
    Stopped {
        /// The last step taken.
        step: usize,
    },
}

/// A transient analysis: M·ü + C·u̇ + f_int(u) = f(t) stepped from an initial state by one
/// integrator. Whatever watches the run (frames, CSV rows, checkpoints, progress, callbacks)
/// is an [`Observer`] of [`run`](Self::run), the one time loop.
///
/// ```
/// use nalgebra::Vector3;
/// use tetfem::analysis::transient::{TimeStep, Transient, TransientOptions, Unobserved};
/// use tetfem::analysis::{Definition, dynamics::Method};
/// use tetfem::fe::materials::MaterialMap;
/// use tetfem::{BoxSplit, Constraints, Material, TetMesh};
/// # fn main() -> tetfem::Result<()> {
/// // A steel bar 1 × 0.2 × 0.2 m clamped at x = 0, released under gravity.
/// let size = Vector3::new(1.0, 0.2, 0.2);
/// let mesh = TetMesh::box_grid(Vector3::zeros(), size, [5, 1, 1], BoxSplit::Mirrored6)?;
/// let steel = MaterialMap::uniform(Material::new(200e9, 0.3, 7800.0)?, mesh.tet_count());
/// let mut constraints = Constraints::new(&mesh);
/// constraints.fix_nodes(&mesh.nodes_on_plane(0, 0.0, 1e-9))?;
/// let definition = Definition::builder(mesh, steel)
///     .constraints(constraints)?
///     .gravity(Vector3::new(0.0, 0.0, -9.81))?
///     .build()?;
/// // Newmark at 10 × the explicit critical step: stable, energy kept.
/// let options = TransientOptions::new(Method::Newmark, TimeStep::CriticalMultiple(10.0));
/// let mut run = Transient::new(&definition, options)?;
/// run.run((0, 20), &mut Unobserved)?;
/// assert_eq!(run.state().steps, 20);
/// # Ok(()) }
/// ```
pub struct Transient {
    pub(super) system: Arc<LinearSystem>,
    pub(super) force: InternalForce,
    pub(super) integrator: Box<dyn Integrator>,
    pub(super) state: State,
    limit: Option<StepLimit>,
    warnings: Vec<Warning>,
    /// The method the integrator implements (an adaptive run needs an implicit one).
    pub(super) method: Method,
    /// The integrator's solver options: an adaptive run builds one integrator per step value
    /// it keeps factored (`adaptive.rs`).
    pub(super) solver: IntegratorOptions,
}

impl std::fmt::Debug for Transient {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Transient")
            .field("method", &self.integrator.name())
            .field("dt", &self.integrator.time_step())
            .field("model", &self.force.name())
            .field("free_dofs", &self.system.free_count())
            .field("state.steps", &self.state.steps)
            .finish()
    }
}

impl Transient {
    /// The transient analysis of `definition` with `options`, at rest in the reference
    /// configuration at time 0 (set another start with [`state_mut`](Self::state_mut)).
    ///
    /// Errors: the library's combination rule ([`Definition::check`] with
    /// [`Analysis::Transient`]), then those of the system, the force law
    /// ([`Definition::transient_system`], [`Definition::transient_force`]), the critical step
    /// when `dt` is a multiple of it, and the integrator.
    pub fn new<C: ModelElement + StepBoundElement>(
        definition: &Definition<C>,
        options: TransientOptions,
    ) -> Result<Self> {
        let warnings = definition.check(Analysis::Transient(options.method))?;
        let system = Arc::new(definition.transient_system(options.mass, options.damping)?);
        let force = definition.transient_force(&system)?;
        let mut limit = None;
        let dt = options.dt.seconds(|| {
            let mut found = critical_step(&system, &definition.mesh, &definition.materials)?;
            // The explicit method with surface contact: the barrier's stiffness at the
            // smallest distance the run may reach lowers the stable step (see
            // [`surface_step_bound`]); the body's own step would be refused.
            if let (Method::Explicit, InternalForce::Nonlinear(n)) = (options.method, &force)
                && let Some(surface) = n.surface_contact()
            {
                let bound = surface_step_bound(&system, surface, found.dt)?;
                found = StepLimit {
                    dt: bound.dt,
                    source: "surface barrier bound",
                };
            }
            limit = Some(found);
            Ok(found.dt)
        })?;
        let state = State::at_rest(system.free_count());
        let mut run = Self::from_parts(system, force, state, options.method, dt, options.solver)?;
        run.limit = limit;
        run.warnings = warnings;
        Ok(run)
    }

    /// A transient analysis of an assembled `system` with `force`, from `initial`, stepped by
    /// `method` at `dt` (time units) with `solver`: for front ends that keep their system
    /// between runs (a scene's set-up runs several step sizes on one assembly).
    ///
    /// Errors: those of the integrator (an invalid dt).
    pub fn from_parts(
        system: Arc<LinearSystem>,
        force: InternalForce,
        initial: State,
        method: Method,
        dt: f64,
        solver: IntegratorOptions,
    ) -> Result<Self> {
        let integrator =
            method.integrator_with_force(Arc::clone(&system), force.clone(), dt, solver)?;
        // A new run: the barrier's record starts over (a front end may run one force twice).
        if let InternalForce::Nonlinear(n) = &force {
            n.set_barrier_record(None);
        }
        Ok(Transient {
            system,
            force,
            integrator,
            state: initial,
            limit: None,
            warnings: Vec::new(),
            method,
            solver,
        })
    }

    /// Takes one step; its wall time (s). On an error the state holds what the integrator
    /// left (the failed step's values for [`Error::Diverged`](crate::Error::Diverged)).
    pub fn step(&mut self) -> Result<f64> {
        let clock = Instant::now();
        self.integrator.step(&mut self.state)?;
        Ok(clock.elapsed().as_secs_f64())
    }

    /// The time loop: steps `first + 1 ..= last` (`first` is the step the state is at: 0, or a
    /// checkpoint's), `observer` shown each. Ends when the last step is taken, when the
    /// observer says [`Flow::Stop`] (the state is then that step's), or with the first error: a
    /// step's (after [`Observer::step_failed`]) or the observer's.
    pub fn run(
        &mut self,
        (first, last): (usize, usize),
        observer: &mut dyn Observer,
    ) -> Result<RunEnd> {
        for step in first + 1..=last {
            let wall = match self.step() {
                Ok(wall) => wall,
                Err(error) => {
                    observer.step_failed(&error)?;
                    return Err(error);
                }
            };
            self.force.note_accepted_step(&self.state)?;
            let view = StepView {
                step,
                last,
                state: &self.state,
                wall,
                integrator: self.integrator.as_ref(),
                system: &self.system,
                force: &self.force,
            };
            if observer.observe(&view)? == Flow::Stop {
                return Ok(RunEnd::Stopped { step });
            }
        }
        Ok(RunEnd::Finished)
    }

    /// The energies of the current state (J): kinetic, elastic (the model's), gravity's and
    /// the other loads' potentials.
    pub fn energy(&self) -> Result<Energy> {
        self.force.energy(&self.system, &self.state)
    }

    /// The current state (free DOFs).
    pub fn state(&self) -> &State {
        &self.state
    }

    /// The current state, to set a start (displacement, velocity) or restore a checkpoint's.
    pub fn state_mut(&mut self) -> &mut State {
        &mut self.state
    }

    /// The integrator (its name, step, Newton counts, checkpointed history).
    pub fn integrator(&self) -> &dyn Integrator {
        self.integrator.as_ref()
    }

    /// The integrator, to change its step or restore its history from a checkpoint.
    pub fn integrator_mut(&mut self) -> &mut dyn Integrator {
        self.integrator.as_mut()
    }

    /// The integrator and the state together (a checkpoint restores both).
    pub fn parts_mut(&mut self) -> (&mut dyn Integrator, &mut State) {
        (self.integrator.as_mut(), &mut self.state)
    }

    /// The system on the free DOFs.
    pub fn system(&self) -> &Arc<LinearSystem> {
        &self.system
    }

    /// The elastic force law.
    pub fn force(&self) -> &InternalForce {
        &self.force
    }

    /// The time step (time units).
    pub fn dt(&self) -> f64 {
        self.integrator.time_step()
    }

    /// The critical step found when the step was given as a multiple of it.
    pub fn step_limit(&self) -> Option<StepLimit> {
        self.limit
    }

    /// The combination rule's warnings about the definition.
    pub fn warnings(&self) -> &[Warning] {
        &self.warnings
    }

    /// What the contact barrier did over the run's accepted steps and Newton iterates
    /// ([`BarrierRecord`]: gap errors, smallest gaps); `None` without contact.
    pub fn barrier_record(&self) -> Option<BarrierRecord> {
        self.force.barrier_record()
    }
}
