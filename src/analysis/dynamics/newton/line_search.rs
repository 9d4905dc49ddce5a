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
/// the step predicts.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Backtracking {
    /// Φ decides first, with the relaxed second search (contact: no iterate may penetrate).
    potential_first: bool,
}

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
    /// start and `slope` |r·δ| there: returns whether a fraction was accepted, and the last one
    /// tried (the line's last trial is the accepted point).
    pub fn search(
        &self,
        line: &mut dyn LineFunction,
        first_alpha: f64,
        r_norm: f64,
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
                    trial_phi < start || (trial_norm < r_norm && trial_phi <= start + slack)
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
