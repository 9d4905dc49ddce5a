//! Error-controlled time stepping in a dynamic scene: `[analysis] time_tolerance` runs the
//! library's [`Transient::run_adaptive`](tetfem::analysis::transient::Transient::run_adaptive)
//! with `dt` as its first step, landing on every multiple of the output interval
//! `[output] every`·dt where the frames are written; the summary's `time_stepping` reports the
//! run's own error estimate, its accepted and rejected steps and its smallest and largest step.
//!
//! What cannot combine with the key is refused here only where it is the scene's bookkeeping:
//! checkpoints and `--resume` count in steps, `--steps` asks for a step count. That the explicit
//! method does not adapt is the library's rule ([`AdaptiveStep::check_method`]), reported here
//! at the key's line.

use super::{DynamicOverrides, RunLength, State, step_time};
use crate::{DynamicSettings, Scene};
use tetfem::analysis::transient::{AdaptiveReport, AdaptiveStep};
use tetfem::base::error::{Error, Result};

/// `[analysis] time_tolerance` as the library's control (no step bounds: see the key's entry
/// in the reference; its output interval is set by the run), or `None` when the key is unset.
///
/// Errors ([`Error::Scene`] at the key's line, naming both keys): a tolerance not in (0, 1),
/// `[output] checkpoint_every` > 0 or `--resume` (a checkpoint is taken at a step count, and a
/// resumed run re-counts time as steps of dt), a `--steps` length (the run's step count is the
/// control's, not the user's), the explicit method (the library's rule).
pub(super) fn scene_control(
    scene: &Scene,
    settings: &DynamicSettings,
    overrides: &DynamicOverrides,
    resume: bool,
) -> Result<Option<AdaptiveStep>> {
    let Some(tolerance) = scene
        .spec()
        .analysis
        .as_ref()
        .and_then(|a| a.get_ref().time_tolerance)
    else {
        return Ok(None);
    };
    let refuse = |message: String| Error::Scene {
        source_name: scene.source_name().to_string(),
        key: "analysis.time_tolerance".into(),
        line: crate::restart::key_line(scene.text(), "analysis.time_tolerance").unwrap_or(0),
        message,
    };
    let control = AdaptiveStep::new(tolerance).map_err(|e| refuse(requirement(e)))?;
    if scene.output().checkpoint_every > 0 || resume {
        return Err(refuse(
            "time_tolerance cannot combine with output.checkpoint_every or --resume: \
             checkpoints are taken every N steps and a resume counts time in steps of dt, \
             while an error-controlled run's steps vary; remove one of the two"
                .into(),
        ));
    }
    if let Some(RunLength::Steps(n)) = overrides.length {
        return Err(refuse(format!(
            "time_tolerance cannot combine with --steps {n}: the tolerance chooses the step \
             count; give --duration (or analysis.duration) instead"
        )));
    }
    let method = overrides.method.unwrap_or(settings.method);
    AdaptiveStep::check_method(method).map_err(|e| refuse(requirement(e)))?;
    Ok(Some(control))
}

/// The sentence of a library error for a scene error's message (`time_tolerance = 2: …`, or
/// `time_tolerance with method = explicit: …` for a value that is a condition).
fn requirement(error: Error) -> String {
    match error {
        Error::InvalidParameter {
            name,
            value,
            requirement,
        } if value.starts_with("with ") => format!("{name} {value}: {requirement}"),
        Error::InvalidParameter {
            name,
            value,
            requirement,
        } => format!("{name} = {value}: {requirement}"),
        e => e.to_string(),
    }
}

/// What an error-controlled run did, in its summary (`time_stepping`; absent from the
/// summaries of fixed-step runs).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct TimeStepping {
    /// `analysis.time_tolerance`: the relative trajectory error asked for (1).
    pub tolerance: f64,
    /// The run's own estimate of the relative error of its trajectory (1): the accepted steps'
    /// local errors summed, relative to the run's largest ‖u‖ and ‖v‖ — see
    /// [`AdaptiveReport::estimated_error`].
    pub estimated_error: f64,
    /// Steps kept.
    pub accepted_steps: usize,
    /// Steps rejected and retried shorter.
    pub rejected_steps: usize,
    /// The smallest accepted step (s).
    pub dt_min: f64,
    /// The largest accepted step (s).
    pub dt_max: f64,
    /// How many times dt changed between accepted steps (each refactors the step matrix).
    pub dt_changes: usize,
    /// The times the run landed on exactly and wrote frames at: `[output] every` × dt (s).
    pub output_interval: f64,
}

impl TimeStepping {
    /// The summary of `report` with the control it ran under.
    pub(super) fn of(report: &AdaptiveReport, control: &AdaptiveStep) -> Self {
        TimeStepping {
            tolerance: control.tolerance,
            estimated_error: report.estimated_error,
            accepted_steps: report.accepted,
            rejected_steps: report.rejected,
            dt_min: report.dt_range.0,
            dt_max: report.dt_range.1,
            dt_changes: report.dt_changes,
            output_interval: control.output_interval.unwrap_or(f64::NAN),
        }
    }
}

/// When a run's states are and which of them are frames.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum FrameClock {
    /// A fixed step: t = t₀ + (n − n₀)·dt from the first state (t₀, n₀) ([`step_time`]), a
    /// frame every `every` steps.
    Steps {
        /// The run's first state's (time, step).
        start: (f64, usize),
        /// The step (s).
        dt: f64,
        /// Steps per frame.
        every: usize,
    },
    /// An error-controlled run: the state's own time, a frame at each start + k·interval (the
    /// library lands there exactly, computing the time the same way).
    Landings {
        /// The run's start time (s).
        start: f64,
        /// The output interval (s).
        interval: f64,
        /// The end time (s).
        end: f64,
    },
}

impl FrameClock {
    /// The time of `state` (s).
    pub(super) fn time(&self, state: &State) -> f64 {
        match *self {
            FrameClock::Steps { start, dt, .. } => step_time(start, dt, state),
            FrameClock::Landings { .. } => state.time,
        }
    }

    /// Whether `state` is on the frame grid (the last state is a frame whether or not).
    pub(super) fn is_frame(&self, state: &State) -> bool {
        match *self {
            FrameClock::Steps { every, .. } => state.steps.is_multiple_of(every),
            FrameClock::Landings {
                start, interval, ..
            } => {
                let k = ((state.time - start) / interval).round();
                state.time == start + k * interval
            }
        }
    }

    /// The frames' times of a run of `steps` steps (fixed) or to its end (landings).
    pub(super) fn frame_times(&self, steps: usize) -> Vec<f64> {
        match *self {
            FrameClock::Steps { start, dt, every } => (0..=steps)
                .filter(|k| k.is_multiple_of(every) || *k == steps)
                .map(|k| start.0 + k.saturating_sub(start.1) as f64 * dt)
                .collect(),
            FrameClock::Landings {
                start,
                interval,
                end,
            } => {
                let mut times: Vec<f64> = (0..)
                    .map(|k| start + k as f64 * interval)
                    .take_while(|t| *t < end)
                    .collect();
                times.push(end);
                times
            }
        }
    }
}
