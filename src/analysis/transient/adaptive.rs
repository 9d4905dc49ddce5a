//! Error-controlled time stepping: [`Transient::run_adaptive`] chooses each step's dt from an
//! estimate of the local truncation error of the implicit methods, so that a run asks for an
//! accuracy ([`AdaptiveStep::tolerance`]) instead of a step, and reports its own estimate of
//! the error of its trajectory ([`AdaptiveReport::estimated_error`]).
//!
//! # The estimate (a posteriori, from values every step has anyway)
//!
//! The state is y = (u, v). A step's local error is estimated in both parts, from the
//! accelerations at the step's two ends (a = the method's own acceleration):
//!
//! - Newmark (β = ¼, γ = ½, the trapezoidal rule on u̇ = v, v̇ = a) — Zienkiewicz & Xie (1991):
//!   e_u ≈ (β − 1/6)·dt²·(a⁺ − a) = dt³/12·ȧ, and on the velocity the trapezoidal rule's
//!   e_v ≈ dt³/12·ä. ȧ and ä are taken as central differences over two steps
//!   (ȧ ≈ (a⁺ − a₋)/(t⁺ − t₋), ä the change of two such over a step) rather than a⁺ − a: the
//!   method keeps the modes it does not resolve (ω·dt ≫ 1) that a sudden load excites,
//!   alternating in sign from step to step with accelerations of the loads' order but
//!   displacements ω²·dt² times smaller, and the central differences cancel them. On the first
//!   step ȧ ≈ (a⁺ − a)/dt; ä from the third step on.
//! - Backward Euler (v⁺ = v + dt·a⁺, u⁺ = u + dt·v⁺): the difference from the trapezoidal rule
//!   from the same start, which is its leading local error dt²/2·ÿ:
//!   e_u ≈ dt/2·(v⁺ − v), e_v ≈ dt/2·(a⁺ − a)·2dt/(dt₋ + dt), a = (v − v₋)/dt₋ the previous
//!   step's mean acceleration (a⁺ − a over the distance of the two steps' midpoints is ȧ; the
//!   factor is 1 at a constant step).
//!
//! Both cost a few vector operations per step, against the 3× of step doubling (a step and two
//! half steps) — and with a factored linear system step doubling would also refactor for the
//! half step. Step doubling was therefore not chosen.
//!
//! # The norm and the control
//!
//! The relative local error of a step is ρ = √((‖e_u‖/S_u)² + (‖e_v‖/S_v)²) (Euclidean norms on
//! the free DOFs), S_u and S_v the largest ‖u‖ and ‖v‖ of the run so far: for an oscillation
//! the two parts are the sine and cosine parts of one phase (Newmark) or amplitude (backward
//! Euler) error, so ρ is that error whatever the phase. The control is error per unit step: a
//! step of dt is accepted when ρ ≤ tol_b·dt/L, so that the accepted steps' errors alive at
//! once add up to at most tol. L is the error's lifetime: the run's duration T without
//! damping, shorter where Rayleigh damping decays the mode the error lives in
//! ([`error_decay`](super::error_decay): L = (1 − e^(−σ·T))/σ, σ from the step's own
//! frequency). tol_b is the budget: what is left of the tolerance spread over the time left,
//! (tol − spent)·T/(T − t) with spent = Σ ρ·L/T over the accepted steps, and never less than
//! tol — a plain ρ ≤ tol·dt/T leaves every step between the rung thresholds below, and spent
//! 0.4–0.6 of the tolerance on the runs of `benches/adaptive_time_step.rs`; with the budget
//! the steps an early part of the run did not need go to the rest. dt moves on a ladder of
//! rungs I/n, n = 1, 2, 3, 4, 6, 8, 12, … (I the output interval; see
//! [`step_ladder`](super::step_ladder)), so that with the linear force every rung's step
//! matrix is factored once and kept for when the run comes back to it. With r = ρ·L/(tol_b·dt)
//! the share of its allowance a step used and p the method's order (1: backward Euler, 2:
//! Newmark; the local error is O(dt^(p+1)), the error per unit step O(dt^p)): a step with
//! r > 1 is rejected and retried from the saved state (state and
//! [`Integrator::history`](crate::analysis::dynamics::Integrator::history) restored: no trace
//! of it remains) on the rung where the model predicts r ≤ ½ (one to four rungs down); after
//! an accepted step the run goes one rung up when the model predicts r ≤ 0.5 there (not right
//! after a rejection), one down when r > 0.9, and stays otherwise.
//!
//! Measured against the earlier continuous control (dt scaled by 0.9·r^(−1/p), which refactored
//! at every change: 110 factorizations and 26 rejections in the damped swing's 657 steps), with
//! `benches/adaptive_time_step.rs` (CPU time against the cheapest fixed dt I/2^k meeting the
//! tolerance): the damped swing 11 factorizations, 8 rejections, 741 steps; the undamped swing
//! at 1e-2 11 501 steps (9 576 before: the rungs cost steps where the error sits between two)
//! and 6 factorizations. With the lifetimes and the budget: the damped swing 581 steps, 3
//! rejections, 10 factorizations; the undamped swing 9 066 steps, the shaken base 2 078 steps
//! (3 534 before; 1 695 of them went to the first 0.05 s, whose errors β damps).
//!
//! From rest, the first steps' u⁺ and local error are both O(dt²): relative to the motion so
//! far they are O(1) whatever dt. The control's S_u is therefore at least an a priori amplitude
//! (the linear static displacement under the loads, or the supports' motion; see
//! `amplitude_floor`); the reported estimate uses the run's own final S_u.
//!
//! Backward Euler's first step has no earlier acceleration for e_v: it is judged by e_u alone.
//!
//! With obstacles (backward Euler), the estimate is of the smooth part of the motion: the
//! barrier's acceleration M⁻¹·f_c(u⁺) is taken out of the step's mean acceleration before
//! e_u = dt²/2·‖a‖ and the differences of e_v, as event-driven integrators leave an impact's
//! impulse out of their error control. The IPC barrier's force grows as 1/gap at an onset, so
//! its jerk is not smooth on any step: with it in the estimate the drop of
//! `tests/core/adaptive_time_step.rs` shrank its steps to 8e-11 s at the impact and stopped;
//! without it the run gets through (at 5 %: 1 968 steps, dt ≥ 1.04e-5 s).
//!
//! # The impact's error: measured, neither estimated nor controlled through dt
//!
//! The impact's own error is left out of the estimate and the control, because with the
//! default barrier stiffness (κ = E/h, `ContactParameters::for_mesh`) it does not fall with dt
//! at any step a run can afford. Measured on that drop by fixed-step backward Euler (centroid
//! error over 80 ms relative to its travel; `contact_impact_resolution` in the tests pins the
//! first two facts):
//! - the landing node stops within about a step (the contact line search keeps a fifth of the
//!   gap per Newton step), so its closest gap is d_min ≈ (0.015–0.023 m/s)·dt from
//!   dt = 1.25e-4 to 1.2e-7 s, and the barrier's frequency there ω_c = √(κ·A·b″(d_min)/m)
//!   grows as 1/dt:
//!   ω_c·dt = 2.4–3.5 at every dt from 5e-4 to 9.8e-7 s (Newmark: 5–7). The resolved closest
//!   gap, where κ·A·b(d) has taken the node's kinetic energy, is ~1e-14 m: no step resolves it;
//! - the centroid's error against the reference at 2.44e-7 s (the test's 2 % reference) is
//!   8.4, 7.3, 7.2, 6.8, 5.3, 6.8, 6.0, 5.4, 1.8 % at dt = 1.25e-4 … 4.9e-7 s (halving), the
//!   rebound's mean velocity 0.159–0.194 m/s without trend, and two references (2.44e-7 and
//!   1.22e-7 s) differ by 4.3 %: the impact's outcome scatters by a few percent with where the
//!   steps fall, like the ~15–46 entries of nodes into d̂ (chatter), and has no limit to
//!   estimate an error against. Not the Newton tolerance: 1e-8 against 1e-12 moves the
//!   centroid by 1e-6 of its travel at dt = 3.9e-6 s.
//!
//! A control that keeps ω_c·dt ≤ 1 while a node is within d̂ therefore chases the gap down (the
//! 8e-11 s stall above), and a share of the budget for the impact cannot be bought with dt.
//! With κ raised 50× the barrier takes the impact at d ≈ d̂/3.5, ω_c·dt falls with dt (0.67 at
//! 1.25e-4 s, 0.04 at 3.9e-6 s) and the centroid converges at first order: 17, 16, 7.4, 4.3,
//! 1.4 % at dt = 1.25e-4, 3.1e-5, 7.8e-6, 2.0e-6, 9.8e-7 s against 4.9e-7 s, which is 1.0 %
//! from 1.2e-7 s — backward Euler damps the barrier's mode over the contact's ~40 periods of
//! it, so 2 % costs ~1e-6 s steps. Estimating the impact therefore needs a resolvable barrier
//! (κ from the impact energy) first; that is a contact model change, not a step rule.
//!
//! # With the impact-aware barrier stiffness
//!
//! [`ContactParameters::impact_fraction`](crate::contact::ContactParameters::impact_fraction)
//! f makes that change as an option (off by default): each implicit step gives every contact
//! node approaching from outside d̂ its own κᵢ = max(κ₀, mᵢ·v_n,ᵢ²/(2·Aᵢ·b(f·d̂))) and leaves
//! the κᵢ of nodes within d̂ as they are ([`crate::contact::impact`]), so a landing node stops
//! near f·d̂ and the barrier stays conservative. Measured on the drop by fixed-step backward
//! Euler at f = ¼ (`benches/adaptive_time_step.rs drop-fixed`; centroid error over 80 ms
//! relative to its travel, against 4.9e-7 s): 15.0, 11.1, 3.8, 0.83, 1.05 % at dt = 1.25e-4,
//! 3.1e-5, 7.8e-6, 2.0e-6, 9.8e-7 s; the closest gap 1.3e-5, 5.3e-6, 1.6e-5, 2.7e-5, 2.8e-5 m
//! (f·d̂ = 4.3e-5 m), ω_c·dt 0.98, 0.56, 0.08, 0.02, 0.01; the rebound 0.176–0.215 m/s
//! (reference 0.213); the total energy never above its start (largest E − E₀ −4.6e-11 J at
//! 9.8e-7 s; backward Euler on a convex potential only loses energy). The one κ of every
//! node that this rule replaced (raised to the largest estimate, kept while any node was
//! within d̂) gave 18.9, 17.3, 4.3, 2.9, 0.93 % at the same steps, but a node landing later
//! and faster raised κ under the nodes already within d̂, adding Δκ·ΣAᵢ·b(dᵢ): its run at
//! 9.8e-7 s ended 5.2e-4 J above its start (largest 6.7e-4 J), its reference 1.2e-3 J
//! (2.4 % of the impact's kinetic energy, 0.049 J).
//!
//! The barrier's acceleration stays out of the full-state estimate with it on too. Measured
//! so with the per-node κᵢ (`benches/adaptive_time_step.rs`, `IMPACT_FRACTION=0.25`, centroid
//! error against the reference at 1/16 of the smallest step, option on in both): at 2 %,
//! estimated 2.47e-2 against a true 2.93e-2 (effectivity 0.84), 8 386 steps; at 5 %,
//! estimated 5.98e-2 against 1.46e-1 (0.41), 2 737 steps, dt 7.8e-6 … 1e-3 s: at 5 % the
//! steps through the landing are long enough for backward Euler to damp the rebound (the
//! fixed steps' 11–15 % above), and that error is the impact's. With the barrier's
//! acceleration put back into the full-state estimate, the drop at 2 % shrank its step to
//! min_dt = 8e-11 s at the landing and stopped: the landing nodes' acceleration (~v·ω_c) and
//! its jerk, against the whole state's S_u and S_v, ask for steps far below what the motion
//! of the body needs.
//!
//! # The impact in the estimate: the body's mean motion
//!
//! With the impact-aware stiffness on (backward Euler), the estimate has a second norm: the
//! body's mass-weighted mean motion (for a free body its centroid), with every force in its
//! acceleration, the barrier's included (`adaptive/translation.rs`: the same e_u, e_v
//! formulas on ū, v̄, ā relative to the largest |ū|, |v̄|). The control judges the larger of
//! the two ρ, and the reported error is the larger of the two accumulated errors. Why this
//! norm: the impact's error a drop is run for is in the rebound, the body's mean velocity,
//! which backward Euler damps when its steps through the landing are long; the barrier's
//! force on one landing node moves the mean by that node's share of the mass only, against
//! the whole body's velocity, so the contact layer's local modes weigh what they move of the
//! body instead of stalling the control, and the κᵢ of the option is what makes the impact
//! converge with dt at all (without it no dt resolves it, above: so without the option the
//! estimate is the full state's alone, unchanged bit for bit). A term for backward Euler's
//! dissipation over the landing (its energy loss per step, the undamped system conserving
//! energy) was the other candidate; not built, as most of what backward Euler dissipates at
//! the impact is the block's internal ringing, which the centroid does not see.
//!
//! Measured on the drop (`benches/adaptive_time_step.rs drop backward-euler TOL 0.08`,
//! `IMPACT_FRACTION=0.25`; centroid error against the reference at 1/16 of the smallest step;
//! CPU against the cheapest fixed step I/2^k meeting the tolerance, in the same run):
//! - 5 %: estimated 5.59e-2 against a true 3.56e-2 (effectivity 1.57), 11 548 steps, 15
//!   rejected, dt 3.3e-7 … 1e-3 s (the landing, 0.028–0.056 s, at 3.3e-7 … 9.8e-7 s), CPU
//!   0.90 s against 0.64 s for the fixed 7.8e-6 s (error 4.6e-2): 1.40×;
//! - 2 %: estimated 2.24e-2, 30 745 steps, 10 rejected, dt 8.1e-8 … 2.5e-4 s, CPU 2.07 s;
//!   true 1.97e-2 against a graded reference (32 fixed steps inside each of the run's steps)
//!   and 1.95e-2 against the uniform one at 2e-8 s (effectivity 1.13–1.15; the run meets 2 %).
//!   First measured against a uniform reference at 5.1e-9 s (3.12e-2, 0.72): that reference
//!   is itself off by 1.2e-2 (15.7 million steps gather more solve and round-off error than
//!   the truncation error they undercut; already 7.2e-4 of the travel away in free fall), and
//!   so were the fixed steps' errors measured against it (`tests/core/adaptive_time_step.rs`,
//!   `contact_drop_effectivity` and its ignored neighbours).
//!
//! The control spends the tolerance per unit time (above), so the landing's ~25 ms take the
//! share of the run's 80 ms their duration gives them: hence steps near 1e-6 s there where a
//! fixed step of 7.8e-6 s meets 5 % over the whole run.
//!
//! A Newton iteration that does not converge (a nonlinear model, contact) rejects the step
//! too, at half the step.
//!
//! # The reported error
//!
//! [`AdaptiveReport::estimated_error`] = max over the accepted steps' ends t of
//! Σ_{t_i ≤ t} ρ_i·e^(−σ_i·(t − t_i)), ρ_i = √((‖e_u‖/S_u)² + (‖e_v‖/S_v)²) with the run's final
//! S_u, S_v: the local errors accumulated, each decayed since its step at the rate σ_i of the
//! mode it lives in ([`error_decay`](super::error_decay); without damping σ = 0 and it is the
//! plain sum: propagation neither damped nor amplified, as for the undamped oscillations these
//! methods keep), relative to the trajectory's amplitude. It estimates max over time of
//! √((‖u − u_exact‖/S_u)² + (‖v − v_exact‖/S_v)²).
//! With the impact-aware stiffness (backward Euler) it is the larger of that sum and the same
//! sum of the mean motion's ρ̄ (relative to its own final scales; see "The impact in the
//! estimate" above).
//!
//! # Times
//!
//! The run ends exactly at its end time, and lands exactly on every multiple of
//! [`AdaptiveStep::output_interval`] from its start (outputs are written there, not
//! interpolated): the time to the next landing is divided into n equal steps,
//! n = ⌈remaining/dt⌉, so that dt stays the same across an interval (no refactorization) and
//! the last step's end is set to the landing time (a round-off correction).

use std::time::Instant;

use super::error_decay::{decay_rate, decayed_maximum, lifetime};
use super::observer::{Flow, Observer, StepView};
use super::run::{RunEnd, Transient};
use super::step_ladder::{Ladder, StepMatrices};
use super::time_step::MAX_STEPS;
use crate::analysis::dynamics::{Method, Rayleigh, State};
use crate::base::error::{Error, Result, short_number};

mod translation;
use translation::{Translation, TranslationTrial};

/// A coarser rung (dt doubled) is taken when the error model predicts there at most this
/// share of the tolerance's allowance: the error per unit step varies over an oscillation
/// (with the phase of the jerk), and the coarser rung must have room for its peaks, or the
/// run goes up and down between two rungs at a rejection each time.
const GROW_BELOW: f64 = 0.5;
/// A step that used more than this share of its allowance moves to the finer rung: the next
/// one would likely be rejected.
const SHRINK_ABOVE: f64 = 0.9;
/// The most rungs a rejection moves down at once (dt ÷ 4).
const MAX_LEVELS_DOWN: i32 = 4;

/// Error-controlled time stepping ([`Transient::run_adaptive`]; see the module doc for the
/// estimate and the control).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AdaptiveStep {
    /// The relative error of the trajectory asked for (dimensionless, 0 < tol < 1): the
    /// accepted steps' local errors, relative to the run's amplitude, add up to at most this.
    pub tolerance: f64,
    /// The smallest step (time units); a step that would need a smaller one to meet the
    /// tolerance is an error. 0: the duration / [`MAX_STEPS`].
    pub min_dt: f64,
    /// The largest step (time units); infinite for none.
    pub max_dt: f64,
    /// Land on every multiple of this from the run's start (time units; the scene's output
    /// interval), or only on the end time (`None`).
    pub output_interval: Option<f64>,
}

impl AdaptiveStep {
    /// `tolerance` with no step bounds and no output interval. Errors: a tolerance not in (0, 1).
    pub fn new(tolerance: f64) -> Result<Self> {
        if !(tolerance > 0.0 && tolerance < 1.0) {
            return Err(Error::invalid_parameter(
                "time_tolerance",
                short_number(tolerance),
                "must be a relative error between 0 and 1 (e.g. 1e-3)",
            ));
        }
        Ok(AdaptiveStep {
            tolerance,
            min_dt: 0.0,
            max_dt: f64::INFINITY,
            output_interval: None,
        })
    }

    /// Whether `method` can adapt its step: the implicit ones. The explicit method's step is
    /// bounded by stability, not accuracy (its error at a stable step is already small), and it
    /// has no error estimate here. This is the one place that says so.
    pub fn check_method(method: Method) -> Result<()> {
        match method {
            Method::BackwardEuler | Method::Newmark => Ok(()),
            Method::Explicit => Err(Error::invalid_parameter(
                "time_tolerance",
                "with method = explicit",
                "error-controlled time stepping needs an implicit method (backward_euler or \
                 newmark); the explicit method's step is set by stability (dt = \"0.9crit\")",
            )),
        }
    }

    /// The step bounds for a run of `duration`, checked.
    fn bounds(&self, duration: f64) -> Result<(f64, f64)> {
        if !(duration.is_finite() && duration > 0.0) {
            return Err(Error::invalid_parameter(
                "duration",
                short_number(duration),
                "an adaptive run needs an end time after its start",
            ));
        }
        let min_dt = match self.min_dt {
            0.0 => duration / MAX_STEPS as f64,
            m => m,
        };
        let max_dt = self.max_dt.min(duration);
        if !(min_dt.is_finite() && min_dt > 0.0 && min_dt <= max_dt) {
            return Err(Error::invalid_parameter(
                "min_dt",
                short_number(self.min_dt),
                format!(
                    "must be finite, > 0 and at most max_dt = {}",
                    short_number(max_dt)
                ),
            ));
        }
        if let Some(i) = self
            .output_interval
            .filter(|i| !(i.is_finite() && *i > 0.0))
        {
            return Err(Error::invalid_parameter(
                "output_interval",
                short_number(i),
                "must be finite and > 0",
            ));
        }
        Ok((min_dt, max_dt))
    }
}

/// What an adaptive run did.
#[derive(Debug, Clone, PartialEq)]
pub struct AdaptiveReport {
    /// Whether it ran to its end time or an observer stopped it.
    pub end: RunEnd,
    /// Steps taken (kept).
    pub accepted: usize,
    /// Steps rejected and retried with a smaller dt (error above the tolerance, or Newton not
    /// converged).
    pub rejected: usize,
    /// The run's estimate of the relative error of its trajectory (see the module doc):
    /// max over t of Σ_{t_i ≤ t} ρ_i·e^(−σ_i·(t − t_i)), ρ_i = √((‖e_u‖/S_u)² + (‖e_v‖/S_v)²)
    /// of the accepted steps (the plain Σ ρ_i without damping; dimensionless). With the
    /// impact-aware barrier stiffness (backward Euler), the larger of that and the same sum of
    /// the body's mean motion (see the module doc).
    pub estimated_error: f64,
    /// The smallest and the largest accepted step (time units).
    pub dt_range: (f64, f64),
    /// How many times dt changed between accepted steps.
    pub dt_changes: usize,
    /// How many step matrices were factored for a new dt, the first included: with the
    /// linear force a dt the run comes back to reuses its kept factor (see
    /// [`step_ladder`](super::step_ladder)); with a nonlinear force, every change of dt.
    pub factorizations: usize,
    /// The accepted steps' (end time, dt), in order: how dt followed the motion.
    pub steps: Vec<(f64, f64)>,
}

/// The accelerations an estimate needs and the scales it is relative to.
struct Estimator {
    method: Method,
    /// The accelerations at the last (up to three) accepted steps' ends, with their times,
    /// oldest first (Newmark: the method's; backward Euler: each step's (v⁺ − v)/dt).
    accelerations: std::collections::VecDeque<(f64, Vec<f64>)>,
    /// Largest ‖u‖ and ‖v‖ so far.
    scale: (f64, f64),
    /// The a priori amplitudes the control's S_u and S_v are at least (see
    /// `Transient::amplitude_floor`); 0 when the run does not start at rest.
    floor: (f64, f64),
    /// Accepted steps' (dt, ‖e_u‖, ‖e_v‖, σ): σ the rate (1/s) the step's error decays at
    /// (see [`error_decay`](super::error_decay)).
    local: Vec<(f64, f64, f64, f64)>,
    /// The run's Rayleigh damping, which decays the errors.
    damping: Rayleigh,
    /// The last accepted step's dt (time units).
    last_dt: Option<f64>,
    /// The mean motion's estimate with the barrier in it (backward Euler with the
    /// impact-aware barrier stiffness; see the module doc), `None` otherwise.
    translation: Option<Translation>,
}

/// One step's estimate, kept if the step is.
struct Trial {
    dt: f64,
    error: (f64, f64),
    acceleration: Vec<f64>,
    scale: (f64, f64),
    /// The rate (1/s) its error decays at.
    decay: f64,
    /// The mean motion's estimate, where the estimator has one.
    translation: Option<TranslationTrial>,
}

fn norm(x: impl Iterator<Item = f64>) -> f64 {
    x.map(|x| x * x).sum::<f64>().sqrt()
}

/// a/b, 0 when b is 0 (no motion yet: no error either).
fn ratio(a: f64, b: f64) -> f64 {
    if b > 0.0 { a / b } else { 0.0 }
}

impl Estimator {
    fn new(method: Method, start: &State, damping: Rayleigh) -> Self {
        let scale = (
            norm(start.displacement.iter().copied()),
            norm(start.velocity.iter().copied()),
        );
        Estimator {
            method,
            accelerations: std::collections::VecDeque::new(),
            scale,
            floor: (0.0, 0.0),
            local: Vec::new(),
            damping,
            last_dt: None,
            translation: None,
        }
    }

    /// The local error of the step `before` → `after` of `dt`; `method_acceleration` is
    /// Newmark's a⁺ (from its history).
    fn trial(
        &self,
        before: &State,
        after: &State,
        dt: f64,
        (method_acceleration, barrier): (Option<Vec<f64>>, Option<Vec<f64>>),
    ) -> Trial {
        let (v, v_new) = (&before.velocity, &after.velocity);
        let scale = (
            self.scale.0.max(norm(after.displacement.iter().copied())),
            self.scale.1.max(norm(v_new.iter().copied())),
        );
        let last = self.accelerations.back().map(|(_, a)| a.as_slice());
        let (error, acceleration) = match (self.method, method_acceleration) {
            (Method::Newmark, Some(a_new)) => {
                // a from v⁺ = v + dt/2·(a + a⁺) when this is the first step.
                let first: Vec<f64>;
                let a = match last {
                    Some(a) => a,
                    None => {
                        first = (0..v.len())
                            .map(|i| 2.0 * (v_new[i] - v[i]) / dt - a_new[i])
                            .collect();
                        &first
                    }
                };
                (self.newmark_error(dt, after.time, a, &a_new), a_new)
            }
            _ => {
                let mut a_new: Vec<f64> = v_new.iter().zip(v).map(|(p, v)| (p - v) / dt).collect();
                let e_u = match barrier {
                    None => 0.5 * dt * norm(v_new.iter().zip(v).map(|(p, v)| p - v)),
                    // The smooth part: the barrier's acceleration at u⁺ taken out.
                    Some(b) => {
                        a_new.iter_mut().zip(&b).for_each(|(a, b)| *a -= b);
                        0.5 * dt * dt * norm(a_new.iter().copied())
                    }
                };
                // a is the previous step's mean acceleration, a⁺ this one's: their midpoints
                // are (dt₋ + dt)/2 apart, so ȧ ≈ (a⁺ − a)·2/(dt₋ + dt) and e_v = dt²/2·ȧ. A
                // short step after a long one (a rejection at an impact) would otherwise keep
                // the long step's share of the difference, an error per unit step that no
                // shorter step lowers.
                let spacing = match self.last_dt {
                    Some(before) if before != dt => 2.0 * dt / (before + dt),
                    _ => 1.0,
                };
                let e_v = match last {
                    Some(a) => 0.5 * dt * norm(a_new.iter().zip(a).map(|(p, a)| p - a)) * spacing,
                    None => 0.0,
                };
                ((e_u, e_v), a_new)
            }
        };
        // The geometric mean of the error's frequency ‖e_v‖/‖e_u‖ and the motion's ‖a⁺‖/S_v
        // (see `error_decay`'s module doc).
        let motion = ratio(
            norm(acceleration.iter().copied()),
            scale.1.max(self.floor.1),
        );
        let decay = decay_rate(self.damping, (ratio(error.1, error.0) * motion).sqrt());
        let translation = (self.translation.as_ref()).map(|t| {
            let states = (
                v.as_slice(),
                after.displacement.as_slice(),
                v_new.as_slice(),
            );
            t.trial(states, dt, self.last_dt)
        });
        Trial {
            dt,
            error,
            acceleration,
            scale,
            decay,
            translation,
        }
    }

    /// Newmark's (‖e_u‖, ‖e_v‖) = dt³/12·(‖ȧ‖, ‖ä‖) for the step ending at `time` with a⁺ =
    /// `a_new` from a = `a`. ȧ and ä are central differences over two steps (a⁺ − a₋ over
    /// t⁺ − t₋, and the change of two such over a step): the trapezoidal rule keeps the modes
    /// it does not resolve (ω·dt ≫ 1) alternating in sign from step to step, with accelerations
    /// of the loads' order but displacements ω²·dt² times smaller, and these differences cancel
    /// them where a⁺ − a would count them in full. On the first step (no a₋) ȧ ≈ (a⁺ − a)/dt
    /// and ä is not estimated, nor on the second.
    fn newmark_error(&self, dt: f64, time: f64, a: &[f64], a_new: &[f64]) -> (f64, f64) {
        let n = self.accelerations.len();
        let at = |k: usize| &self.accelerations[k];
        // One pass, no vectors: this runs every step (the same operations, in the same order,
        // as forming ȧ and ä first).
        let (t0, a0) = match n {
            0 | 1 => (time - dt, a),
            _ => (at(n - 2).0, at(n - 2).1.as_slice()),
        };
        let (mut jerk, mut change) = (0.0, 0.0);
        match n {
            0..=2 => {
                for (x, y) in a_new.iter().zip(a0) {
                    let j = (x - y) / (time - t0);
                    jerk += j * j;
                }
            }
            _ => {
                let ((t1, a1), (t3, a3)) = (at(n - 1), at(n - 3));
                let h = at(n - 1).0 - at(n - 2).0;
                for ((x, y), (p, q)) in a_new.iter().zip(a0).zip(a1.iter().zip(a3)) {
                    let j = (x - y) / (time - t0);
                    let d = (j - (p - q) / (t1 - t3)) / h;
                    jerk += j * j;
                    change += d * d;
                }
            }
        }
        let cube = dt.powi(3) / 12.0;
        (cube * jerk.sqrt(), cube * change.sqrt())
    }

    /// The relative local error the control judges: ρ with S_u at least the a priori floor.
    fn controlled(&self, trial: &Trial) -> f64 {
        let u = ratio(trial.error.0, trial.scale.0.max(self.floor.0));
        let full = u.hypot(ratio(trial.error.1, trial.scale.1.max(self.floor.1)));
        match (&self.translation, &trial.translation) {
            (Some(t), Some(mean)) => full.max(t.controlled(mean)),
            _ => full,
        }
    }

    /// The method's order p: the error per unit step is O(dt^p).
    fn order(&self) -> f64 {
        match self.method {
            Method::Newmark => 2.0,
            _ => 1.0,
        }
    }

    fn accept(&mut self, trial: Trial, time: f64) {
        if self.accelerations.len() == 3 {
            self.accelerations.pop_front();
        }
        self.accelerations.push_back((time, trial.acceleration));
        self.scale = trial.scale;
        self.last_dt = Some(trial.dt);
        let (eu, ev) = trial.error;
        self.local.push((trial.dt, eu, ev, trial.decay));
        if let (Some(t), Some(mean)) = (self.translation.as_mut(), trial.translation) {
            t.accept(mean);
        }
    }

    /// The largest over the run of the accepted steps' errors relative to the final scales,
    /// each decayed since its step (the plain sum without damping): see
    /// [`decayed_maximum`].
    fn global(&self) -> f64 {
        let (su, sv) = self.scale;
        let full = decayed_maximum(
            (self.local.iter())
                .map(|(dt, eu, ev, sigma)| (*dt, ratio(*eu, su).hypot(ratio(*ev, sv)), *sigma)),
        );
        match &self.translation {
            // The larger of the two norms' accumulated errors.
            Some(t) => full.max(decayed_maximum(
                (self.local.iter().zip(t.relative()))
                    .map(|((dt, .., sigma), rho)| (*dt, rho, *sigma)),
            )),
            None => full,
        }
    }
}

/// Where the run must land: the multiples of the output interval, then the end.
struct Landings {
    start: f64,
    end: f64,
    interval: Option<f64>,
    /// Landings passed.
    passed: usize,
}

impl Landings {
    /// The next landing time.
    fn target(&self) -> f64 {
        match self.interval {
            Some(i) => (self.start + (self.passed + 1) as f64 * i).min(self.end),
            None => self.end,
        }
    }
}

impl Transient {
    /// Runs from the current state to `end_time` (time units) with the step chosen by
    /// `control` (see the [module doc](crate::analysis::transient::adaptive) for the estimate
    /// and the rule),
    /// starting from the integrator's current dt. `observer` sees every accepted step (never a
    /// rejected one); its [`StepView::last`] is an estimate (the steps taken plus the time left
    /// over the current dt) until the last step, where it equals `step`. The run lands exactly
    /// on `end_time` and on each multiple of the output interval.
    ///
    /// Errors: the explicit method ([`AdaptiveStep::check_method`]), an end time not after the
    /// state's, bounds out of order, a step that would need less than `min_dt` (naming the
    /// tolerance and the time), more than [`MAX_STEPS`] attempts; a step's own error other than
    /// a Newton iteration not converging (after [`Observer::step_failed`]); the observer's.
    pub fn run_adaptive(
        &mut self,
        end_time: f64,
        control: &AdaptiveStep,
        observer: &mut dyn Observer,
    ) -> Result<AdaptiveReport> {
        AdaptiveStep::check_method(self.method)?;
        let start = self.state.time;
        let duration = end_time - start;
        let (min_dt, max_dt) = control.bounds(duration)?;
        let mut estimator = Estimator::new(self.method, &self.state, self.system.damping());
        estimator.floor = self.amplitude_floor(duration)?;
        estimator.translation = self.translation_estimator(duration)?;
        let mut landings = Landings {
            start,
            end: end_time,
            interval: control.output_interval,
            passed: 0,
        };
        let ladder = Ladder::new(
            control.output_interval.unwrap_or(duration),
            (min_dt, max_dt),
        );
        // The wanted rung: the first step is the coarsest at most the integrator's dt.
        let mut level = ladder.at_most(self.integrator.time_step());
        let mut matrices = StepMatrices::default();
        let mut report = AdaptiveReport {
            end: RunEnd::Finished,
            accepted: 0,
            rejected: 0,
            estimated_error: 0.0,
            dt_range: (f64::INFINITY, 0.0),
            dt_changes: 0,
            factorizations: 0,
            steps: Vec::new(),
        };
        let mut wall = 0.0;
        let mut just_rejected = false;
        // The tolerance spent so far: Σ ρ·L/T over the accepted steps.
        let mut spent = 0.0;
        while report.accepted + report.rejected < MAX_STEPS {
            let time = self.state.time;
            let target = landings.target();
            let (dt, taken) = ladder.step(level, target - time);
            let lands = target - time <= dt * (1.0 + 1e-6);
            self.use_step(dt, &mut matrices)?;
            let saved = (self.state.clone(), self.integrator.history()?);
            let clock = Instant::now();
            let outcome = self.integrator.step(&mut self.state);
            wall += clock.elapsed().as_secs_f64();
            let ideal = match outcome {
                Ok(()) => {
                    let a = match self.method {
                        Method::Newmark => self.integrator.history()?.acceleration,
                        _ => None,
                    };
                    let barrier = match self.method {
                        Method::BackwardEuler => self.barrier_acceleration()?,
                        _ => None,
                    };
                    let trial = estimator.trial(&saved.0, &self.state, dt, (a, barrier));
                    // The error's lifetime replaces the duration where damping decays it.
                    let alive = lifetime(trial.decay, duration);
                    // The tolerance as if what is left of it were spread over the time left,
                    // never less than the tolerance itself (see the module doc's "budget").
                    let budget = ((control.tolerance - spent) * duration
                        / (end_time - time).max(dt))
                    .max(control.tolerance);
                    let share = estimator.controlled(&trial) * alive;
                    let rate = share / (budget * dt);
                    if rate <= 1.0 {
                        Ok((trial, rate, share))
                    } else {
                        Err(levels_down(
                            &ladder,
                            here_of(taken, level),
                            rate,
                            estimator.order(),
                        ))
                    }
                }
                Err(Error::NotConverged { .. }) => Err(1),
                Err(error) => {
                    observer.step_failed(&error)?;
                    return Err(error);
                }
            };
            let here = here_of(taken, level);
            let (trial, rate, share) = match ideal {
                Ok(accepted) => accepted,
                Err(down) => {
                    self.state = saved.0;
                    self.integrator.restore(&self.state, &saved.1)?;
                    report.rejected += 1;
                    just_rejected = true;
                    if ladder.is_finest(here) || dt <= min_dt * (1.0 + 1e-9) {
                        return Err(below_min_dt(control, min_dt, time));
                    }
                    level = ladder.clamp(here + down);
                    continue;
                }
            };
            if lands {
                self.land(target)?;
                landings.passed += 1;
            }
            estimator.accept(trial, self.state.time);
            spent += share / duration;
            let previous = report.steps.last().map(|(_, dt)| *dt);
            report.note_step(self.state.time, dt, previous);
            // No growth right after a rejection: the step that was too long is not tried again
            // at once (it would likely be rejected).
            let grow = !std::mem::take(&mut just_rejected);
            level = ladder.clamp(next_level(&ladder, here, rate, estimator.order(), grow));
            let want = ladder.dt(level);
            let done = lands && self.state.time >= end_time;
            let left = ((end_time - self.state.time) / want).ceil().max(0.0) as usize;
            self.force.note_accepted_step(&self.state)?;
            let view = StepView {
                step: self.state.steps,
                last: self.state.steps + if done { 0 } else { left.max(1) },
                state: &self.state,
                wall: std::mem::take(&mut wall),
                integrator: self.integrator.as_ref(),
                system: &self.system,
                force: &self.force,
            };
            if observer.observe(&view)? == Flow::Stop && !done {
                report.end = RunEnd::Stopped {
                    step: self.state.steps,
                };
                break;
            }
            if done {
                break;
            }
        }
        if report.end == RunEnd::Finished && self.state.time < end_time {
            return Err(Error::invalid_parameter(
                "time_tolerance",
                short_number(control.tolerance),
                format!("took more than {MAX_STEPS} step attempts (MAX_STEPS) before the end time"),
            ));
        }
        report.estimated_error = estimator.global();
        report.factorizations = matrices.factored;
        Ok(report)
    }

    /// Sets the time of the state just stepped to the landing time `target` (a round-off
    /// correction) and tells the integrator, whose history is keyed to the state's time.
    fn land(&mut self, target: f64) -> Result<()> {
        if self.state.time != target {
            let history = self.integrator.history()?;
            self.state.time = target;
            self.integrator.restore(&self.state, &history)?;
        }
        Ok(())
    }
}

impl Transient {
    /// M⁻¹·f_c(u) on the free DOFs, f_c = −∂E_c/∂u the obstacles' barrier force at the
    /// state's displacement (obstacles where the step left them); `None` without obstacles.
    /// What the error estimate of a backward Euler step leaves out (see the module doc).
    fn barrier_acceleration(&self) -> Result<Option<Vec<f64>>> {
        let Some(contact) = self.force.contact() else {
            return Ok(None);
        };
        let full = (self.system).expand_at(self.state.time, &self.state.displacement)?;
        let mut force = vec![0.0; full.len()];
        contact.add_force(&full, &mut force)?;
        let free = self.system.dofs().free_dofs();
        let mut a: Vec<f64> = free.iter().map(|&dof| force[dof]).collect();
        crate::analysis::dynamics::newton::solve_mass(self.system.mass(), &mut a)?;
        Ok(Some(a))
    }

    /// The mean motion's estimator (see the module doc) for backward Euler with the impact-aware
    /// barrier stiffness on; `None` otherwise (the estimate is then the full state's alone,
    /// unchanged).
    fn translation_estimator(&self, duration: f64) -> Result<Option<Translation>> {
        let impact =
            (self.force.contact()).is_some_and(|c| c.parameters().impact_fraction.is_some());
        if !(impact && self.method == Method::BackwardEuler) {
            return Ok(None);
        }
        let free = self.system.dofs().free_dofs();
        let mut weights = vec![0.0; free.len()];
        self.system
            .mass()
            .mul_vec(&vec![1.0; free.len()], &mut weights)?;
        let load = self.system.external_load();
        Ok(Some(Translation::new(free, weights, load, duration)))
    }

    /// The a priori amplitudes (‖u‖, ‖v‖) of a run that starts at rest ((0, 0) otherwise).
    /// Displacement: the linear static displacement under the loads, u_s = K_ff⁻¹·f, or the
    /// largest ‖u_c(t)‖ of the supports' motion at 33 times of the run if larger; velocity:
    /// ω·‖u_s‖ with ω² = fᵀu_s/(u_sᵀ·M·u_s), Rayleigh's quotient of the static shape (close to
    /// the first natural frequency), or the supports' largest mean speed between those times
    /// if larger. For a body held only by obstacles (K_ff singular), the distance ‖M⁻¹·f‖·T²/8
    /// and the speed ‖M⁻¹·f‖·T/2 the loads' acceleration gives in half the run. From rest the
    /// first step's motion and its local error are of the same order in dt (the loads excite
    /// every mode at once), so scales that are only the motion so far would judge them O(1)
    /// whatever dt.
    fn amplitude_floor(&self, duration: f64) -> Result<(f64, f64)> {
        let at_rest = (self.state.displacement.iter())
            .chain(&self.state.velocity)
            .all(|x| *x == 0.0);
        if !at_rest {
            return Ok((0.0, 0.0));
        }
        let mass = self.system.mass();
        let mut floor = match self.system.static_displacement() {
            Ok(u) => {
                let mut mu = vec![0.0; u.len()];
                mass.mul_vec(&u, &mut mu)?;
                let work: f64 = self
                    .system
                    .external_load()
                    .iter()
                    .zip(&u)
                    .map(|(f, u)| f * u)
                    .sum();
                let inertia: f64 = u.iter().zip(&mu).map(|(u, m)| u * m).sum();
                let size = norm(u.into_iter());
                (size, size * ratio(work, inertia).max(0.0).sqrt())
            }
            Err(_) => {
                let mut a = self.system.external_load().to_vec();
                crate::analysis::dynamics::newton::solve_mass(mass, &mut a)?;
                let a = norm(a.into_iter());
                (a * duration * duration / 8.0, a * duration / 2.0)
            }
        };
        if self.system.has_moving_supports() {
            let h = duration / 32.0;
            let mut before = self.system.prescribed_at(self.state.time)?;
            for k in 1..=32 {
                let now = self.system.prescribed_at(self.state.time + h * k as f64)?;
                let speed = norm(now.iter().zip(&before).map(|(a, b)| a - b)) / h;
                floor = (floor.0.max(norm(now.iter().copied())), floor.1.max(speed));
                before = now;
            }
        }
        Ok(floor)
    }
}

impl AdaptiveReport {
    fn note_step(&mut self, time: f64, dt: f64, previous: Option<f64>) {
        self.accepted += 1;
        self.dt_range = (self.dt_range.0.min(dt), self.dt_range.1.max(dt));
        if previous.is_some_and(|p| p != dt) {
            self.dt_changes += 1;
        }
        self.steps.push((time, dt));
    }
}

/// The rung of a step taken on rung `taken` (`None`: off the ladder, at most `level`'s dt).
fn here_of(taken: Option<i32>, level: i32) -> i32 {
    taken.unwrap_or(level)
}

/// The rung wanted after an accepted step on rung `here` that used `rate` of its allowance
/// (ρ·L/(tol_b·dt) ≤ 1, see the module doc), the method of order `order` (the error per unit step ∝ dt^order): one
/// up when `grow` and the model predicts there rate·(dt_up/dt)^order ≤ [`GROW_BELOW`]; one
/// down when rate > [`SHRINK_ABOVE`]; kept otherwise.
fn next_level(ladder: &Ladder, here: i32, rate: f64, order: f64, grow: bool) -> i32 {
    if grow && rate * ladder.ratio(here - 1).powf(-order) <= GROW_BELOW {
        here - 1
    } else if rate > SHRINK_ABOVE {
        here + 1
    } else {
        here
    }
}

/// The rungs down from `here` for a step that used `rate` > 1 of its allowance: to where the
/// model predicts at most half of it, at least one and at most [`MAX_LEVELS_DOWN`].
fn levels_down(ladder: &Ladder, here: i32, rate: f64, order: f64) -> i32 {
    let mut predicted = rate;
    for m in 1..=MAX_LEVELS_DOWN {
        predicted *= ladder.ratio(here + m - 1).powf(order);
        if predicted <= 0.5 {
            return m;
        }
    }
    MAX_LEVELS_DOWN
}

/// The error of a step that cannot meet the tolerance at the smallest step.
fn below_min_dt(control: &AdaptiveStep, min_dt: f64, time: f64) -> Error {
    Error::invalid_parameter(
        "time_tolerance",
        short_number(control.tolerance),
        format!(
            "not met at t = {} s even with the smallest step min_dt = {} s; raise the \
             tolerance or lower min_dt",
            short_number(time),
            short_number(min_dt)
        ),
    )
}
