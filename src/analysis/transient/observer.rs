//! What a transient run shows after each step, and how whoever watches may stop it: frames,
//! CSV rows, checkpoints, progress bars and Python callbacks are each an [`Observer`] of one
//! time loop ([`Transient::run`](super::Transient::run)), never a loop of their own.

use crate::analysis::dynamics::{Integrator, InternalForce, LinearSystem, State};
use crate::base::error::{Error, Result};

/// The run after one step, as an [`Observer`] sees it.
pub struct StepView<'a> {
    /// The step just taken (1, 2, …; a resumed run counts on from its checkpoint's step).
    pub step: usize,
    /// The run's last step: `step == last` on the last call.
    pub last: usize,
    /// The state after the step (free DOFs; time in time units).
    pub state: &'a State,
    /// Wall time of the step alone (s), observers' own work excluded.
    pub wall: f64,
    /// The integrator that took it (its history is what a checkpoint stores).
    pub integrator: &'a dyn Integrator,
    /// The system M·ü + C·u̇ + f_int(u) = f(t) on the free DOFs.
    pub system: &'a LinearSystem,
    /// The elastic force law: energies, stresses and reactions are the model's.
    pub force: &'a InternalForce,
}

/// Whether the run goes on after an observer has seen a step.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Flow {
    /// Take the next step.
    Continue,
    /// Stop here, at a step boundary: the state is this step's, whole.
    Stop,
}

/// Watches a transient run step by step.
pub trait Observer {
    /// Called after every step with the state it left; [`Flow::Stop`] ends the run there, an
    /// error ends it with that error.
    fn observe(&mut self, view: &StepView<'_>) -> Result<Flow>;

    /// Called once when a step fails (the error is then the run's), before the run returns:
    /// where an observer finishes what it wrote so far (whole rows, whole frames). Nothing by
    /// default; its own error replaces the step's.
    fn step_failed(&mut self, _error: &Error) -> Result<()> {
        Ok(())
    }
}

/// A closure observes: `|view| Ok(Flow::Continue)`.
impl<F: FnMut(&StepView<'_>) -> Result<Flow>> Observer for F {
    fn observe(&mut self, view: &StepView<'_>) -> Result<Flow> {
        self(view)
    }
}

/// Observes nothing and never stops: a run to its last step.
#[derive(Debug, Clone, Copy, Default)]
pub struct Unobserved;

impl Observer for Unobserved {
    fn observe(&mut self, _view: &StepView<'_>) -> Result<Flow> {
        Ok(Flow::Continue)
    }
}
