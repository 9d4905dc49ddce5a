//! Transient analysis: the equation of motion M·ü + C·u̇ + f_int(u) = f(t) of a
//! [`Definition`](crate::analysis::Definition) stepped in time by one integrator
//! ([`Transient`]), through one time loop ([`Transient::run`]) that [`Observer`]s watch and may
//! stop. The time step ([`TimeStep`], [`RunLength`]) and the explicit critical step
//! ([`critical_step`]) are defined here once for every front end; an error-controlled run
//! ([`Transient::run_adaptive`], [`AdaptiveStep`]) chooses its own steps.

pub mod adaptive;
mod critical;
pub mod error_decay;
mod observer;
mod run;
mod setup;
pub mod step_ladder;
mod time_step;

pub use adaptive::{AdaptiveReport, AdaptiveStep};
pub use critical::{StepLimit, critical_step};
pub use observer::{Flow, Observer, StepView, Unobserved};
pub use run::{RunEnd, Transient, TransientOptions};
pub use time_step::{MAX_STEPS, RunLength, TimeStep};
