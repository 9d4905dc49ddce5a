//! The state of a dynamic run.

use crate::base::error::{Error, Result};

/// Displacement u and velocity v on the free DOFs (length and length/time units), and the time.
#[derive(Debug, Clone, PartialEq)]
pub struct State {
    /// Displacement of each free DOF.
    pub displacement: Vec<f64>,
    /// Velocity of each free DOF.
    pub velocity: Vec<f64>,
    /// Time.
    pub time: f64,
    /// Steps taken.
    pub steps: usize,
}

impl State {
    /// At rest in the reference configuration, at time 0.
    pub fn at_rest(free_dofs: usize) -> Self {
        State {
            displacement: vec![0.0; free_dofs],
            velocity: vec![0.0; free_dofs],
            time: 0.0,
            steps: 0,
        }
    }

    /// Released from rest at the given displacement, at time 0.
    pub fn released_from(displacement: Vec<f64>) -> Self {
        let n = displacement.len();
        State {
            displacement,
            velocity: vec![0.0; n],
            time: 0.0,
            steps: 0,
        }
    }
}

impl State {
    /// [`Error::DimensionMismatch`] unless displacement and velocity both have `free_dofs`
    /// entries (the free DOF count of the system or integrator it is used with).
    pub fn check_len(&self, free_dofs: usize) -> Result<()> {
        Error::check_len("state.displacement", free_dofs, self.displacement.len())?;
        Error::check_len("state.velocity", free_dofs, self.velocity.len())
    }

    /// `Err(Diverged)` naming this step if any displacement or velocity is NaN or infinite;
    /// `hint` is appended to the reason.
    pub fn ensure_finite(&self, hint: &str) -> Result<()> {
        if self
            .displacement
            .iter()
            .chain(&self.velocity)
            .all(|v| v.is_finite())
        {
            return Ok(());
        }
        Err(crate::base::error::Error::Diverged {
            step: self.steps,
            time: self.time,
            reason: format!("a displacement or velocity is no longer finite{hint}"),
        })
    }
}
