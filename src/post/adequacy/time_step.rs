//! Does an implicit step resolve the motion? Steps per period of the lowest mode the load
//! excites, and backward Euler's numerical damping per period at that step.
//!
//! Backward Euler on the undamped oscillator ü + ω²u = 0 (v' = −ω²u, u' = v, both taken at the
//! new time) advances (u, v) by the inverse of [[1, −Δt], [ω²Δt, 1]], whose eigenvalues are
//! 1 ± iωΔt: every step multiplies the amplitude by |1/(1 + iωΔt)| = (1 + (ωΔt)²)^(−½). With
//! N = T/Δt = 2π/(ωΔt) steps per period T, the amplitude after one period is
//!
//! A(N) = (1 + (2π/N)²)^(−N/2),
//!
//! so the decay per period is 1 − A(N): 61 % at N = 20, 39 % at N = 40, 18 % at N = 100,
//! 9.4 % at N = 200, 3.9 % at N = 500 (1 − A ≈ 2π²/N for large N).

use crate::analysis::dynamics::LinearSystem;
use crate::analysis::modal::lowest_modes;
use crate::base::error::{Error, Result};

/// Decay per period above which a backward-Euler run is warned (10 %): the motion it shows
/// has lost more than a tenth of its amplitude each period to the method, not to the physics
/// (fewer than about 190 steps per period).
pub const DECAY_WARNING: f64 = 0.10;

/// Backward Euler's amplitude ratio after one period resolved by `steps_per_period` steps,
/// (1 + (2π/N)²)^(−N/2) (dimensionless, in (0, 1); NaN for N ≤ 0 or NaN).
pub fn backward_euler_amplitude_per_period(steps_per_period: f64) -> f64 {
    if steps_per_period.is_nan() || steps_per_period <= 0.0 {
        return f64::NAN;
    }
    let w_dt = 2.0 * std::f64::consts::PI / steps_per_period;
    // ln A = −(N/2)·ln(1 + (ωΔt)²), with ln_1p for accuracy at large N.
    (-0.5 * steps_per_period * w_dt.powi(2).ln_1p()).exp()
}

/// Backward Euler's relative amplitude loss per period, 1 − [`backward_euler_amplitude_per_period`].
pub fn backward_euler_decay_per_period(steps_per_period: f64) -> f64 {
    1.0 - backward_euler_amplitude_per_period(steps_per_period)
}

/// How well a time step resolves the lowest excited mode.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct StepResolution {
    /// Index of the mode (0 = lowest) taken as the lowest excited one.
    pub mode: usize,
    /// Its period T = 2π/ω (time units).
    pub period: f64,
    /// T / Δt.
    pub steps_per_period: f64,
    /// Backward Euler's amplitude loss per period at that resolution (dimensionless).
    pub backward_euler_decay: f64,
}

impl StepResolution {
    /// [`Warning::BackwardEulerDecay`](crate::base::warning::Warning::BackwardEulerDecay) when
    /// [`decay_too_large`](Self::decay_too_large).
    pub fn warning(&self) -> Option<crate::base::warning::Warning> {
        self.decay_too_large()
            .then_some(crate::base::warning::Warning::BackwardEulerDecay {
                period: self.period,
                steps_per_period: self.steps_per_period,
                decay: self.backward_euler_decay,
                limit: DECAY_WARNING,
            })
    }

    /// Whether [`backward_euler_decay`](Self::backward_euler_decay) passes [`DECAY_WARNING`].
    pub fn decay_too_large(&self) -> bool {
        self.backward_euler_decay.is_nan() || self.backward_euler_decay > DECAY_WARNING
    }
}

/// Relative modal participation below which a mode counts as not excited: |φᵢᵀf| under this
/// fraction of the largest |φⱼᵀf| among the modes computed.
pub const PARTICIPATION_FLOOR: f64 = 1e-3;

/// The resolution of step `dt` for the lowest mode of `system` that `excitation` (a force or
/// displacement pattern on the free DOFs, e.g. the load) excites: the first of the `modes`
/// lowest modes whose participation |φᵢᵀ·excitation| is at least [`PARTICIPATION_FLOOR`] of
/// the largest (the lowest mode when the excitation is zero). Costs one subspace modal
/// solve of `modes` modes (use it on problems a modal analysis can afford).
///
/// Errors: `dt` not finite and positive; `excitation` not one value per free DOF; `modes` out
/// of range; the modal solve's errors.
pub fn step_resolution(
    system: &LinearSystem,
    excitation: &[f64],
    modes: usize,
    dt: f64,
) -> Result<StepResolution> {
    if !(dt.is_finite() && dt > 0.0) {
        return Err(Error::invalid_parameter("dt", dt, "must be finite and > 0"));
    }
    Error::check_len("excitation", system.free_count(), excitation.len())?;
    let computed = lowest_modes(system, modes.min(system.free_count()).max(1))?;
    let participation: Vec<f64> = computed
        .shapes
        .iter()
        .map(|phi| {
            phi.iter()
                .zip(excitation)
                .map(|(a, b)| a * b)
                .sum::<f64>()
                .abs()
        })
        .collect();
    let largest = participation.iter().fold(0.0, |a: f64, &b| a.max(b));
    let mode = participation
        .iter()
        .position(|&p| p >= PARTICIPATION_FLOOR * largest && (largest == 0.0 || p > 0.0))
        .unwrap_or(0);
    let period = 2.0 * std::f64::consts::PI / computed.omega[mode];
    let steps_per_period = period / dt;
    Ok(StepResolution {
        mode,
        period,
        steps_per_period,
        backward_euler_decay: backward_euler_decay_per_period(steps_per_period),
    })
}
