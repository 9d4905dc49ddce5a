//! Contact forces that do not depend on the barrier's reach: a continuation of d̂.
//!
//! The barrier holds every node it pushes at a gap dᵢ ∈ (0, d̂) with a force λᵢ = −κ·Aᵢ·b′(dᵢ),
//! where an exact contact has λᵢ·dᵢ = 0 (a node touches, or is free). Its solution is that of a
//! contact whose obstacles are moved away by about the force-weighted gap Σλd/Σλ, and nodes
//! within d̂ that an exact contact leaves free are pushed: measured on a lens pressed onto a
//! plane by 0.2 % of its radius (`tests/core/contact_exact.rs`), the default d̂ gives +32 % of
//! the exact force of the same mesh and 21 nodes pushed against 11 touching.
//!
//! Why a continuation (an interior-point method's path) and not a smaller d̂ from the start or
//! an augmented Lagrangian: from a state converged under d̂, the solution under d̂/10 is near
//! (the pushed nodes move by less than d̂ towards the obstacle), so Newton takes a few steps
//! from it; a small d̂ from the start must resolve the whole approach inside a thin barrier
//! (measured: Newton does not converge in 30 iterations at d̂/100 on the lens at 0.5 % of R).
//! A shifted-barrier augmented Lagrangian lets iterates penetrate by its shift, which the
//! barrier's guarantee (no iterate inside an obstacle) forbids. Since λᵢ·dᵢ ≈ κ·Aᵢ·d̂² for
//! dᵢ ≪ d̂, each stage divides the gap error by about 100.
//!
//! The rule (frictionless contact; with friction the given d̂ stays and its gap error is
//! reported, see `continue_barrier`): after the last load step converged under the given
//! contact, while its gap error
//! ε = (Σλᵢdᵢ/Σλᵢ)/max|u| is above [`Contact::gap_tolerance`], solve the step again from its
//! solution under d̂ ← d̂/10 (κ kept; friction re-lagged under it), at most
//! [`MAX_BARRIER_STAGES`] times. A stage is not taken where its gaps would near the
//! coordinates' round-off, and is undone when it fails or leaves a worse equilibrium (see
//! `solve_stage`). The load steps before the last keep the given d̂: they are the path to the
//! solution, their obstacles may move (what the given d̂ is sized for), and from gaps a
//! continuation closed to ~1e-13 m the given barrier's first forces (~1e11 N) would swamp the
//! next step's reference.

use crate::base::error::{Error, Result};
use crate::contact::{Contact, ContactParameters};
use crate::model::{ModelElement, TetModels};

use super::{LoadStep, StaticNewton, StepState, norm};
use crate::analysis::dynamics::internal_force::coordinate_scale;

/// The most d̂/10 stages one load step takes (d̂ down to 10⁻⁶ of the given one).
pub const MAX_BARRIER_STAGES: usize = 6;

/// The factor d̂ shrinks by from one stage to the next.
const SHRINK: f64 = 0.1;

/// Where a load step's continuation ended: the barrier's scales and the gap error there.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct BarrierEnd {
    pub parameters: ContactParameters,
    pub gap_error: f64,
}

/// The given contact under d̂·10⁻ᵏ, k = 1 … [`MAX_BARRIER_STAGES`].
fn ladder(contact: &Contact) -> Result<Vec<Contact>> {
    let given = contact.parameters();
    (1..=MAX_BARRIER_STAGES as i32)
        .map(|k| {
            contact.with_parameters(ContactParameters {
                activation_distance: given.activation_distance * SHRINK.powi(k),
                ..given
            })
        })
        .collect()
}

/// The force-weighted gap Σλᵢdᵢ/Σλᵢ (length) of `u` under `contact` (0 when nothing is
/// pushed) and the gap error ε, that over max|u| (dimensionless; 0 at rest).
fn gaps(contact: &Contact, u: &[f64]) -> Result<(f64, f64)> {
    let (work, total) = contact.complementarity(u)?;
    let gap = if total > 0.0 { work / total } else { 0.0 };
    let largest = u.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    Ok((gap, if largest > 0.0 { gap / largest } else { 0.0 }))
}

/// A stage is not taken when the gaps it would leave (the weighted gap × [`SHRINK`]²) fall
/// below this many times the positions' resolution 4ε·max|X|: a gap of a few units in the
/// last place of the coordinates carries a force known to a few digits. Measured on the lens
/// at 0.2 % of R: a stage to gaps of ~3 units of the resolution gave +3.6e-2 of the exact
/// force, where the stage before (~300 units) gave +1.7e-7.
const GAP_RESOLUTION_MULTIPLE: f64 = 1e3;

impl<'a, E: ModelElement, M: TetModels + ?Sized> StaticNewton<'a, E, M> {
    /// The continuation of the load step `at` converged at `u`: stages under ever smaller d̂
    /// until the gap error is at most the contact's tolerance (see the module doc). Records
    /// where it ended in `self.barrier`; the next load step starts under the given contact.
    pub(super) fn continue_barrier(
        &mut self,
        u: &mut Vec<f64>,
        history: &mut Vec<f64>,
        state: &mut StepState<'_>,
        at: &mut LoadStep,
    ) -> Result<()> {
        let Some(given) = self.contact else {
            return Ok(());
        };
        let tolerance = given.gap_tolerance();
        let floor =
            GAP_RESOLUTION_MULTIPLE * 4.0 * f64::EPSILON * coordinate_scale(self.mesh.nodes());
        let (mut gap, gap_error) = gaps(given, u)?;
        let mut end = BarrierEnd {
            parameters: given.parameters(),
            gap_error,
        };
        // With friction the gap a stage closes after the whole load is on would be a slip of
        // its own, resisted by friction: on a cantilever pulled sideways onto a floor (μ = 0.5)
        // the floor's friction turned from along the pull to 0.18 N against it. Friction's
        // path needs the exact contact at every load step; the given d̂ stays, its gap error
        // reported.
        let mut current = given;
        for k in 0..MAX_BARRIER_STAGES {
            if given.has_friction() || end.gap_error <= tolerance || gap * SHRINK * SHRINK < floor {
                break;
            }
            // Built once per solve, at the first stage taken: most solves end within the
            // tolerance under the given contact, or have friction.
            if self.ladder.get().is_none() {
                let _ = self.ladder.set(ladder(given)?);
            }
            let Some(stage) = self.ladder.get().and_then(|l| l.get(k)) else {
                break;
            };
            let before = (u.clone(), state.lag.clone(), history.len());
            let converged = self.solve_stage(stage, (given, current), u, history, state, at)?;
            if !converged {
                // The stage's Newton stopped short of the step's own acceptance (forces from
                // gaps that few digits resolve, or no convergence): the stage before stands.
                (*u, state.lag) = (before.0, before.1);
                history.truncate(before.2);
                break;
            }
            let (stage_gap, gap_error) = gaps(stage, u)?;
            (gap, current) = (stage_gap, stage);
            end = BarrierEnd {
                parameters: stage.parameters(),
                gap_error,
            };
        }
        self.barrier = Some(end);
        Ok(())
    }

    /// The load step `at` solved again from its solution `u` under `stage` (the given contact
    /// `given` under a smaller d̂; `previous` the barrier `u` was solved under), friction
    /// re-lagged under it: `true` when it converged to the tolerance, to the residual the
    /// solve before reached, or below a tenth of the change it made to the obstacles' normal
    /// force; `false` when it stopped short of all three or failed (the caller restores `u`).
    /// The given contact is in place again on return.
    fn solve_stage(
        &mut self,
        stage: &'a Contact,
        (given, previous): (&'a Contact, &Contact),
        u: &mut Vec<f64>,
        history: &mut Vec<f64>,
        state: &mut StepState<'_>,
        at: &mut LoadStep,
    ) -> Result<bool> {
        // The residual the solve before reached: a stage ending above it (at the round-off
        // floor of forces from gaps that few digits resolve) trades the barrier's gap error
        // for an equilibrium error.
        let reached = history.last().copied().unwrap_or(0.0);
        let pushed_before = previous.complementarity(u)?.1;
        stage.set_offsets(given.offsets())?;
        self.contact = Some(stage);
        let solved = (|| {
            if state.lag.is_some() {
                state.lag = Some(Self::relag(stage, u, state)?);
            }
            let mut r = self.residual(u, state.lag.as_ref(), at.factor)?;
            history.push(norm(&r));
            self.settle(u, &mut r, history, state, at)
        })();
        self.contact = Some(given);
        match solved {
            Ok(()) => {
                let last = history.last().copied().unwrap_or(f64::INFINITY);
                // The stage moved the obstacles' normal force by |ΔΣλ|, what the barrier's
                // reach still cost before it; a residual below a tenth of that leaves the
                // solution better than it was.
                let moved = (stage.complementarity(u)?.1 - pushed_before).abs();
                Ok(last
                    <= (at.reference * self.options.tolerance)
                        .max(reached)
                        .max(0.1 * moved))
            }
            // The caller's interrupt ends the solve; any other failure undoes the stage only.
            // E.g. a body that only the obstacles hold, every pushed gap beyond d̂/10: under
            // the stage's barrier nothing holds it, and its tangent is singular.
            Err(e @ Error::Stopped { .. }) => Err(e),
            Err(_) => Ok(false),
        }
    }
}
