//! Moving obstacles in stages: the fall-back of a solve whose body cannot be carried with the
//! obstacles ([`super::carry`]). A solve that moves the obstacles — an implicit time step, a static
//! load step — takes them from their current placement to a target one; since the target can
//! overlap the body's state at the solve's start (its first iterate), they get there in stages:
//! each moves them [`STEP_FRACTION`] of the largest collision-free fraction of the remaining
//! straight move for the body's current state ([`Contact::motion_step_limit`]), and the caller
//! solves the body's equation there before the next, so every iterate stays outside every
//! obstacle. The dynamic step ([`crate::analysis::dynamics`]) and the static solve
//! ([`crate::analysis::nonlinear::solve_nonlinear_static_with_contact`]) share this.

use nalgebra::Vector3;

use super::{Contact, STEP_FRACTION};
use crate::base::error::Result;

/// The most stages one solve takes to move the obstacles to their target placement; a solve
/// still short of it after these is an error naming what to shorten (the time step, or the load
/// step's share of the motion).
pub const MAX_MOTION_STAGES: usize = 100;

/// Where [`Contact::advance_stage`] put the obstacles.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MotionStage {
    /// Part of the way to the target: solve the body there, then advance again.
    Partial,
    /// At the target: the body's solution there is the solve's.
    Last,
    /// Not moved: a node touches an obstacle whose move would cross it at once (the
    /// collision-free fraction is 0), e.g. a node held by a support in the obstacle's path.
    Blocked,
}

impl Contact {
    /// Moves the obstacles one stage toward `target` (length, one offset per obstacle, in
    /// their order) for the body at full displacement `u` (length): with σ the largest
    /// collision-free fraction of the straight move from the current offsets c
    /// ([`motion_step_limit`](Self::motion_step_limit)), to `target` when σ ≥ 1
    /// ([`MotionStage::Last`]), else to c + [`STEP_FRACTION`]·σ·(target − c)
    /// ([`MotionStage::Partial`]); σ ≤ 0 leaves them ([`MotionStage::Blocked`]). A fixed
    /// obstacle (target = c) is never in the way: σ = 1.
    ///
    /// Errors: `u` or `target` of the wrong length ([`crate::Error::DimensionMismatch`]).
    pub fn advance_stage(&self, u: &[f64], target: &[Vector3<f64>]) -> Result<MotionStage> {
        let sigma = self.motion_step_limit(u, target)?;
        if sigma <= 0.0 {
            return Ok(MotionStage::Blocked);
        }
        let last = sigma >= 1.0;
        let offsets: Vec<_> = match last {
            true => target.to_vec(),
            false => self
                .offsets()
                .iter()
                .zip(target)
                .map(|(c, t)| c + STEP_FRACTION * sigma * (t - c))
                .collect(),
        };
        self.set_offsets(offsets)?;
        Ok(match last {
            true => MotionStage::Last,
            false => MotionStage::Partial,
        })
    }
}
