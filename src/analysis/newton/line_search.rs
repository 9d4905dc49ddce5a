//! The backtracking line search of the Newton loop along its direction δ, as a type
//! ([`Backtracking`], its acceptance rule chosen once) over a [`LineFunction`]: what the search
//! evaluates on the line (the residual norm and the potential Φ at a trial point), which the
//! loop supplies.

use crate::base::error::Result;

/// The values along the line u + α·δ a line search reads.
pub(crate) trait LineFunction {
    /// Evaluates the trial point u + α·δ (it becomes the last trial) and returns its residual
    /// norm (force).
    fn trial(&mut self, alpha: f64) -> Result<f64>;

    /// Φ at the line's start u (energy).
    fn start_potential(&mut self) -> Result<f64>;

    /// Φ at the last trial point (energy).
    fn trial_potential(&mut self) -> Result<f64>;
}

/// Backtracking from a first fraction, halving up to [`HALVINGS`] times. Without contact a
/// decrease of the residual norm or of Φ is accepted. With contact (`potential_first`) a
/// decrease of Φ, or of the residual with Φ not above its round-off (1e-12 of |Φ|); and a
/// second search, only when the first found nothing: round-off can hide Φ's decrease near the
/// solution (a model's energy sums terms far larger than its change, e.g. Neo-Hookean's ln J),
/// so it accepts a residual decrease whose Φ rises by at most the first-order change α·|r·δ|
/// the step predicts. A step that lands near the solution (a trial residual below
/// [`NEAR_SOLUTION`] of the step's forces, `near_level`) and halves the residual is accepted
/// first, whatever Φ does: Φ's round-off there can exceed the decrease it should show by far
/// more than the step's first-order change (a block settling on a frictional floor: the Newton
/// step took the residual from 4.1e-6 N to 1.0e-10 N, a decrease of Φ of ~3e-17 J predicted,
/// while Φ, a sum of terms that cancel to 1.6e-4 J, moved by +2.4e-14 J; a 10-node
/// Neo-Hookean block pressed on a floor: 1.5e-4 N to 1.5e-11 N, Φ = −5.4e-11 J moved by
/// +8.4e-14 J, the noise of its elements' ln J and tr C − 3 at μ·V ≈ 70 J each), and such a
/// landing is Newton's own quadratic convergence, which no step outside the solution's basin
/// shows. Judged by Φ there, a step is accepted or not by Φ's noise: tiny fractions whose Φ
/// happens to fall.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Backtracking {
    /// Φ decides first, with the relaxed second search (contact: no iterate may penetrate).
    potential_first: bool,
}

/// The residual, relative to the step's forces, below which a contact step's trial point is
/// near its solution (see [`Backtracking`]).
pub(crate) const NEAR_SOLUTION: f64 = 1e-3;

/// Halvings of the step fraction per search (down to 2⁻³⁰ ≈ 1e-9 of the first fraction).
pub(crate) const HALVINGS: usize = 30;

impl Backtracking {
    /// The search of a problem with (`true`) or without contact.
    pub fn for_contact(with_contact: bool) -> Self {
        Backtracking {
            potential_first: with_contact,
        }
    }

    /// Searches `line` from the fraction `first_alpha`, `r_norm` the residual norm at its
    /// start and `slope` |r·δ| there, `near_level` [`NEAR_SOLUTION`] of the step's forces
    /// (force): returns whether a fraction was accepted, and the last one tried (the line's
    /// last trial is the accepted point).
    pub fn search(
        &self,
        line: &mut dyn LineFunction,
        first_alpha: f64,
        (r_norm, near_level): (f64, f64),
        slope: f64,
    ) -> Result<(bool, f64)> {
        let mut alpha = first_alpha;
        for relaxed in [false, true] {
            if relaxed && !self.potential_first {
                break;
            }
            alpha = first_alpha;
            for _ in 0..HALVINGS {
                let trial_norm = line.trial(alpha)?;
                let better = if self.potential_first {
                    let start = line.start_potential()?;
                    let trial_phi = line.trial_potential()?;
                    let slack = match relaxed {
                        false => 1e-12 * start.abs(),
                        true => (1e-12 * start.abs()).max(alpha * slope),
                    };
                    trial_norm <= near_level.min(0.5 * r_norm)
                        || trial_phi < start
                        || (trial_norm < r_norm && trial_phi <= start + slack)
                } else {
                    trial_norm < r_norm || line.trial_potential()? < line.start_potential()?
                };
                if better {
                    return Ok((true, alpha));
                }
                alpha *= 0.5;
            }
        }
        Ok((false, alpha))
    }
}
