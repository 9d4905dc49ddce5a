//! Rayleigh damping C = α·M + β·K.

use crate::base::error::{Error, Result};

/// Rayleigh damping coefficients: C = α·M + β·K (α in 1/time, β in time). The default is zero
/// (no damping): only the integrator's own numerical dissipation remains.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Rayleigh {
    /// Mass-proportional coefficient α (1/time).
    pub alpha: f64,
    /// Stiffness-proportional coefficient β (time).
    pub beta: f64,
}

impl Rayleigh {
    /// Validated coefficients: both finite and ≥ 0.
    pub fn new(alpha: f64, beta: f64) -> Result<Self> {
        for (name, value) in [("alpha", alpha), ("beta", beta)] {
            if !(value.is_finite() && value >= 0.0) {
                return Err(Error::invalid_parameter(
                    format!("Rayleigh {name}"),
                    value,
                    "must be finite and ≥ 0",
                ));
            }
        }
        Ok(Rayleigh { alpha, beta })
    }

    /// The coefficients giving damping ratio ζ at the two angular frequencies ω₁ and ω₂ (rad/time):
    /// ζ(ω) = α/(2ω) + βω/2 with α = 2ζω₁ω₂/(ω₁+ω₂), β = 2ζ/(ω₁+ω₂).
    pub fn from_damping_ratio(ratio: f64, omega1: f64, omega2: f64) -> Result<Self> {
        if !(ratio.is_finite() && ratio >= 0.0) {
            return Err(Error::invalid_parameter(
                "damping ratio",
                ratio,
                "must be finite and ≥ 0",
            ));
        }
        for (name, w) in [("omega1", omega1), ("omega2", omega2)] {
            if !(w.is_finite() && w > 0.0) {
                return Err(Error::invalid_parameter(name, w, "must be finite and > 0"));
            }
        }
        Rayleigh::new(
            2.0 * ratio * omega1 * omega2 / (omega1 + omega2),
            2.0 * ratio / (omega1 + omega2),
        )
    }

    /// Damping ratio at angular frequency ω: α/(2ω) + β·ω/2.
    pub fn ratio_at(&self, omega: f64) -> f64 {
        self.alpha / (2.0 * omega) + self.beta * omega / 2.0
    }
}
