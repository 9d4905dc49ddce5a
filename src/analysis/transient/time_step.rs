//! The time step of a transient analysis and the length of its run: a step in time units or a
//! multiple of the explicit critical step ([`TimeStep`]), a number of steps or a duration
//! ([`RunLength`]), at most [`MAX_STEPS`] steps. Scenes (`dt = "50crit"`), Python (`dt="0.9crit"`)
//! and Rust callers parse and resolve them here, once.

use crate::base::error::{Error, Result, short_number};

/// A time step: in time units, or as a multiple of the explicit critical step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum TimeStep {
    /// A step in time units (s in SI).
    Seconds(f64),
    /// This many times the explicit critical step of the system (e.g. 50 for 50 × dt_crit).
    CriticalMultiple(f64),
}

impl std::str::FromStr for TimeStep {
    type Err = Error;

    /// `"2e-5"` (time units) or `"50crit"` (50 × the explicit critical step); either must be
    /// finite and > 0.
    fn from_str(text: &str) -> Result<Self> {
        let text = text.trim();
        let (number, critical) = match text.strip_suffix("crit") {
            Some(n) => (n.trim(), true),
            None => (text, false),
        };
        let value: f64 = number.parse().map_err(|_| {
            Error::invalid_parameter(
                "dt",
                text,
                "must be a time step like 2e-5 (s) or a multiple of the explicit critical step like 50crit",
            )
        })?;
        if !(value.is_finite() && value > 0.0) {
            return Err(Error::invalid_parameter(
                "dt",
                text,
                "must be finite and > 0",
            ));
        }
        Ok(if critical {
            TimeStep::CriticalMultiple(value)
        } else {
            TimeStep::Seconds(value)
        })
    }
}

impl TimeStep {
    /// The step in time units: `dt` itself, or its multiple of the critical step that
    /// `critical` finds (called only then). Errors: a step that is not finite and > 0
    /// ([`check_time_step`](crate::analysis::dynamics::check_time_step)), or `critical`'s.
    pub fn seconds(self, critical: impl FnOnce() -> Result<f64>) -> Result<f64> {
        let dt = match self {
            TimeStep::Seconds(dt) => dt,
            TimeStep::CriticalMultiple(f) => f * critical()?,
        };
        crate::analysis::dynamics::check_time_step(dt)
    }
}

/// How long to run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum RunLength {
    /// A number of steps (1 to [`MAX_STEPS`]).
    Steps(usize),
    /// A simulated time (time units, ≥ dt): ⌈duration/dt⌉ steps, at most [`MAX_STEPS`].
    Duration(f64),
}

/// The most steps a dynamic run may take: 10⁹. At a microsecond per step on the smallest mesh
/// that is a quarter of an hour, on a real mesh days: a larger count is a unit mistake in dt or
/// the duration (dt = 1e-300 would otherwise run forever), rejected before any work.
pub const MAX_STEPS: usize = 1_000_000_000;

impl RunLength {
    /// The number of steps at `dt` (time units): `n` itself, or ⌈duration/dt⌉ (less a 1e-9
    /// slack, so that a duration that is a whole number of steps up to round-off takes that
    /// number). Errors name the key (`steps`, `duration`, or `dt` when the end time n·dt
    /// overflows), its value and the limit: 1 ≤ steps ≤ [`MAX_STEPS`], dt ≤ duration.
    pub fn steps(self, dt: f64) -> Result<usize> {
        let dt = crate::analysis::dynamics::check_time_step(dt)?;
        let steps = match self {
            RunLength::Steps(n) if (1..=MAX_STEPS).contains(&n) => n,
            RunLength::Steps(n) => {
                return Err(Error::invalid_parameter(
                    "steps",
                    n,
                    format!("must be at least 1 and at most {MAX_STEPS} (MAX_STEPS)"),
                ));
            }
            RunLength::Duration(d) if !(d.is_finite() && d >= dt) => {
                return Err(Error::invalid_parameter(
                    "duration",
                    short_number(d),
                    format!("must be finite and at least dt = {dt:e}"),
                ));
            }
            RunLength::Duration(d) => {
                let steps = (d / dt - 1e-9).ceil();
                if steps > MAX_STEPS as f64 {
                    return Err(Error::invalid_parameter(
                        "duration",
                        short_number(d),
                        format!(
                            "takes ⌈duration/dt⌉ = {steps:e} steps at dt = {dt:e}, above the limit of {MAX_STEPS} steps (MAX_STEPS); choose a larger dt or a shorter duration"
                        ),
                    ));
                }
                steps as usize
            }
        };
        if !(steps as f64 * dt).is_finite() {
            return Err(Error::invalid_parameter(
                "dt",
                short_number(dt),
                format!("the end time {steps} steps × dt overflows"),
            ));
        }
        Ok(steps)
    }
}
