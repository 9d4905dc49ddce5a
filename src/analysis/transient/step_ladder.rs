//! The steps an adaptive run ([`super::adaptive`]) may take, and the factored step matrices it
//! keeps for them.
//!
//! # The ladder
//!
//! dt is one of dt_k = I/n_k, n = 1, 2, 3, 4, 6, 8, 12, 16, … (2^j and 3·2^j; I the output
//! interval, or the run's duration without one), so every step on a rung has the same bits and
//! a run that comes back to a rung comes back to a step matrix it has factored. From a landing
//! time (a multiple of I) every rung lands on the next one; a step is taken on the coarsest
//! rung at most the one wanted that divides the time left to the next landing (2·n_k always
//! does where n_k did, so a rejected step's retry stays on the grid, and a coarser rung waits
//! for its grid). A run whose end is not a multiple of I ends on a step that divides the rest
//! evenly, off the ladder.
//!
//! Neighbouring rungs are 4/3 or 3/2 apart: at a step between two, up to that factor more
//! steps than an exact dt would take (a factor 2 cost the undamped swing 1.6× the steps of the
//! continuous control, measured); they are what makes factorizations reusable.
//!
//! # The step matrices kept
//!
//! An implicit integrator factors its step matrix once per dt value (K_eff = M/dt² + … for
//! Newmark, M/dt + … for backward Euler). With the linear force, the run keeps the integrators
//! of the last [`KEPT`] rungs it left, each with its factor, and moves the integrator's history
//! ([`Integrator::history`], [`Integrator::restore`]) from one to the other when dt changes:
//! a step from a kept integrator has the bits of the same step by one integrator whose dt
//! was set back. A new integrator is built (its step matrix's symbolic analysis included)
//! only while fewer than [`KEPT`] are kept; then the one left longest ago takes the new dt and
//! refactors its numbers only, and the run's first rung is taken by the integrator it was
//! built with. With a nonlinear force (Newton: the tangent is refactored within the steps)
//! the one integrator's dt is set instead.

use std::sync::Arc;

use super::run::Transient;
use crate::analysis::dynamics::{Integrator, InternalForce};
use crate::base::error::Result;

/// How many integrators of rungs the run has left are kept factored (the current one aside):
/// a run moves between neighbouring rungs as the motion changes, and each kept factor costs
/// one factor's memory.
pub const KEPT: usize = 4;

/// The rungs dt_k = `base`/n_k for k in `coarsest..=finest`, n = 1, 2, 3, 4, 6, 8, 12, 16, …
/// (2^j and 3·2^j: neighbours 4/3 or 3/2 apart).
#[derive(Debug, Clone, Copy)]
pub(super) struct Ladder {
    base: f64,
    coarsest: i32,
    finest: i32,
}

/// n_k: 1, 2, 3, 4, 6, 8, 12, … (k = 0, 1, 2, …); k odd: 2^((k+1)/2), k even: 3·2^(k/2 − 1).
fn steps_per_base(level: i32) -> f64 {
    match level {
        ..=0 => 1.0,
        k if k % 2 == 1 => 2f64.powi((k + 1) / 2),
        k => 3.0 * 2f64.powi(k / 2 - 1),
    }
}

/// The rungs a run may use: at most 2·62 (n_k < 2^63).
const LEVELS: i32 = 124;

impl Ladder {
    /// The ladder on `base` (time units) with every rung within [`min_dt`, `max_dt`]; the
    /// coarsest rung is `base` itself when `max_dt` allows it.
    pub(super) fn new(base: f64, (min_dt, max_dt): (f64, f64)) -> Self {
        let mut ladder = Ladder {
            base,
            coarsest: 0,
            finest: LEVELS,
        };
        ladder.coarsest = (0..LEVELS)
            .find(|&k| ladder.dt(k) <= max_dt * (1.0 + 1e-9))
            .unwrap_or(LEVELS);
        ladder.finest = (ladder.coarsest..=LEVELS)
            .take_while(|&k| ladder.dt(k) >= min_dt * (1.0 - 1e-9))
            .last()
            .unwrap_or(ladder.coarsest);
        ladder
    }

    /// dt_k = base/n_k (time units): the same bits whenever the run comes back to rung k.
    pub(super) fn dt(&self, level: i32) -> f64 {
        self.base / steps_per_base(level)
    }

    /// dt_k+1 / dt_k: 2/3 or 3/4.
    pub(super) fn ratio(&self, level: i32) -> f64 {
        steps_per_base(level) / steps_per_base(level + 1)
    }

    /// The coarsest rung at most `dt`, within the ladder.
    pub(super) fn at_most(&self, dt: f64) -> i32 {
        (self.coarsest..=self.finest)
            .find(|&k| self.dt(k) <= dt * (1.0 + 1e-9))
            .unwrap_or(self.finest)
    }

    /// `level` within the ladder.
    pub(super) fn clamp(&self, level: i32) -> i32 {
        level.clamp(self.coarsest, self.finest)
    }

    /// Whether `level` is the finest rung.
    pub(super) fn is_finest(&self, level: i32) -> bool {
        level >= self.finest
    }

    /// The step to take with `remaining` (time units) left to the next landing, at rung
    /// `level` or finer: the coarsest such rung that divides `remaining` into whole steps
    /// (to 1e-6 of one step), with its level; else (`remaining` not on the ladder's grid: the
    /// run's last stretch) `remaining` divided evenly into steps of at most dt_`level`, with
    /// no level.
    pub(super) fn step(&self, level: i32, remaining: f64) -> (f64, Option<i32>) {
        for k in level..=self.finest.max(level) {
            let dt = self.dt(k);
            let n = remaining / dt;
            // To 1e-6 of a step, not of the stretch: a fine rung whose count is off by a
            // fraction of a step does not divide it.
            if n.round() >= 1.0 && (n - n.round()).abs() <= 1e-6 {
                return (dt, Some(k));
            }
        }
        let dt = self.dt(level);
        (remaining / (remaining / dt - 1e-9).ceil().max(1.0), None)
    }
}

/// The integrators of the rungs the run has left, each factored for its dt (see the module
/// doc), and how many step matrices the run has factored.
#[derive(Default)]
pub(super) struct StepMatrices {
    kept: Vec<Box<dyn Integrator>>,
    /// Step matrices factored for a new dt (the first step's included).
    pub(super) factored: usize,
    /// Whether a step was set (the first one is counted even at the integrator's own dt).
    started: bool,
}

impl Transient {
    /// Makes `dt` (time units) the integrator's step: the kept integrator of that dt when
    /// there is one, a new one otherwise, the history moved to it; with a nonlinear force the
    /// one integrator's dt set. Counts a factorization for a dt no kept integrator had.
    pub(super) fn use_step(&mut self, dt: f64, kept: &mut StepMatrices) -> Result<()> {
        let first = !std::mem::replace(&mut kept.started, true);
        if self.integrator.time_step() == dt {
            kept.factored += usize::from(first);
            return Ok(());
        }
        kept.factored += 1;
        if !matches!(self.force, InternalForce::Linear) {
            return self.integrator.set_time_step(dt);
        }
        let history = self.integrator.history()?;
        if first {
            // The integrator the run was built with has the user's dt, which the ladder's
            // rungs rarely are: it takes the first rung's dt itself (a numeric refactorization
            // on its next step, its symbolic analysis kept) rather than being kept unused.
            self.integrator.set_time_step(dt)?;
            return self.integrator.restore(&self.state, &history);
        }
        let next = match kept.kept.iter().position(|i| i.time_step() == dt) {
            Some(k) => {
                kept.factored -= 1;
                kept.kept.remove(k)
            }
            // All kept: the one left longest ago takes the new dt. Its symbolic analysis (the
            // ordering, which does not depend on dt) is kept and only the numbers are
            // refactored: a new integrator's analysis (`LinearSolver::analyze_with_geometry`)
            // was 43 % of the damped swing's adaptive run on the 120-DOF beam of
            // `benches/adaptive_time_step.rs` (perf samples, 28 % of 64 %).
            None if kept.kept.len() >= KEPT => {
                let mut oldest = kept.kept.remove(0);
                oldest.set_time_step(dt)?;
                oldest
            }
            None => self.method.integrator_with_force(
                Arc::clone(&self.system),
                self.force.clone(),
                dt,
                self.solver,
            )?,
        };
        let left = std::mem::replace(&mut self.integrator, next);
        kept.kept.push(left);
        self.integrator.restore(&self.state, &history)
    }
}

#[cfg(test)]
mod tests {
    use super::Ladder;

    #[test]
    fn rungs_divide_the_interval_and_coarser_ones_wait_for_their_grid() {
        let ladder = Ladder::new(0.012, (1e-9, 0.012));
        // n = 1, 2, 3, 4, 6, 8, 12, 16
        assert_eq!(ladder.dt(5), 0.012 / 8.0);
        assert_eq!(ladder.dt(6), 0.012 / 12.0);
        assert_eq!(ladder.at_most(1e-3), 6); // 0.012/12 = 1e-3 is its own
        assert_eq!(ladder.at_most(1.4e-3), 6); // 0.012/8 = 1.5e-3 > 1.4e-3
        // Five twelfths left: the eighth does not divide them, the twelfth does.
        assert_eq!(ladder.step(5, 5.0 * 1e-3), (1e-3, Some(6)));
        // A rest off the grid: divided evenly, no rung.
        let (dt, level) = ladder.step(5, 0.0037);
        assert_eq!(level, None);
        assert!((dt * 3.0 - 0.0037).abs() < 1e-15, "{dt}");
        // max_dt below the base: the coarsest rung is under it.
        assert_eq!(Ladder::new(0.01, (1e-9, 3e-3)).at_most(1.0), 3);
    }
}
