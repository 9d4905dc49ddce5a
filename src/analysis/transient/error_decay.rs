//! How long a local error of an adaptive run ([`super::adaptive`]) lives: with Rayleigh damping
//! an error made at t_i in a mode of frequency ω decays as e^(−σ·(t − t_i)), so the trajectory's
//! error at t is E(t) = Σ_{t_i ≤ t} ρ_i·e^(−σ_i·(t − t_i)) rather than the plain sum Σ ρ_i.
//!
//! # The mode a step's error lives in
//!
//! The step's own estimate gives a frequency: Newmark's local errors are dt³/12·(ȧ, ä) on
//! (u, v) and backward Euler's dt²/2·(a, ȧ), so ω_e = ‖e_v‖/‖e_u‖ (1/s) — for one mode of
//! frequency ω, ‖ä‖/‖ȧ‖ = ‖ȧ‖/‖a‖ = ω. For a mixture of modes ω_e leans to the highest ones
//! (ä weighs a mode's amplitude by ω⁴), while the error that lasts may sit in a lower mode: on
//! the shaken base of `tests/core/adaptive_time_step.rs` ω_e was 100–2000 rad/s throughout and
//! the estimate with it 0.44× the true error, which was in the velocity of the second and third
//! bending modes (ζ < 0.02). The motion's own frequency ω_m = ‖a⁺‖/S_v leans the other way (to
//! the first mode once the start's transient has died: 20–60 rad/s there), and with it alone
//! the start's transient was hardly discounted (2 985 steps, 1 166 of them in the first
//! 0.05 s). The decay is taken at their geometric mean ω = √(ω_e·ω_m), which gave estimates
//! 1.13–1.17× the true error on the three damped runs. The modal damping of C = α·M + β·K at ω
//! is ζ = (α/ω + β·ω)/2; the error decays at σ = ζ·ω when ζ ≤ 1, and at the slow root
//! ω·(ζ − √(ζ² − 1)) = ω/(ζ + √(ζ² − 1)) of an overdamped mode (the fast one has died).
//! Without damping σ = 0 and the model is the plain sum.
//!
//! # The control's allowance
//!
//! A run of length T that makes errors at a steady rate r (per unit time) in a mode decaying at
//! σ ends with E = r·(1 − e^(−σ·T))/σ: the error's lifetime L = (1 − e^(−σ·T))/σ (T when σ
//! = 0, 1/σ when σ·T ≫ 1) replaces T in the allowance ρ ≤ tol·dt/L, so the accepted steps'
//! errors that are alive at once add up to at most the tolerance.

use crate::analysis::dynamics::Rayleigh;

/// The rate σ (1/s) at which an error in the mode of frequency `omega` (rad/s) decays under
/// `damping`: ζ·ω for ζ = (α/ω + β·ω)/2 ≤ 1, the overdamped mode's slow root ω/(ζ + √(ζ² − 1))
/// above; 0 for ω = 0 or no damping.
pub(super) fn decay_rate(damping: Rayleigh, omega: f64) -> f64 {
    if !(omega > 0.0 && omega.is_finite()) {
        // No frequency (the first steps, no velocity error yet): the error is assumed to live
        // in the slowest mode, whose decay α/2 the mass term alone gives.
        return 0.5 * damping.alpha;
    }
    let zeta = 0.5 * (damping.alpha / omega + damping.beta * omega);
    if zeta <= 1.0 {
        zeta * omega
    } else {
        omega / (zeta + (zeta * zeta - 1.0).sqrt())
    }
}

/// The lifetime L (s) of an error decaying at `sigma` (1/s) over a run of `duration` (s):
/// (1 − e^(−σ·T))/σ, `duration` itself (the same bits) when σ = 0.
pub(super) fn lifetime(sigma: f64, duration: f64) -> f64 {
    if sigma > 0.0 {
        -(-sigma * duration).exp_m1() / sigma
    } else {
        duration
    }
}

/// Decay rates are grouped in bins a quarter octave wide (σ within 2^(±1/8) ≈ ±9 % of its
/// bin's): each bin's sum decays at one rate, kept per step length (a run has few).
const BINS_PER_OCTAVE: f64 = 4.0;

/// One bin of errors decaying at one rate.
struct Bin {
    key: i64,
    sigma: f64,
    sum: f64,
    /// The last step length and e^(−σ·dt) for it.
    factor: (f64, f64),
}

/// max over the accepted steps' ends of E(t) = Σ ρ_i·e^(−σ_i·(t − t_i)) for the steps
/// `(dt_i, ρ_i, σ_i)` in order (ρ relative, σ in 1/s, dt in s), σ_i grouped in bins (see
/// [`BINS_PER_OCTAVE`]); with every σ_i = 0 the plain sum Σ ρ_i, added in order.
pub(super) fn decayed_maximum(steps: impl Iterator<Item = (f64, f64, f64)>) -> f64 {
    let mut bins: Vec<Bin> = Vec::new();
    let mut worst: f64 = 0.0;
    for (dt, rho, sigma) in steps {
        for bin in bins.iter_mut().filter(|b| b.sigma > 0.0) {
            if bin.factor.0 != dt {
                bin.factor = (dt, (-bin.sigma * dt).exp());
            }
            bin.sum *= bin.factor.1;
        }
        let key = match sigma > 0.0 {
            true => (sigma.log2() * BINS_PER_OCTAVE).round() as i64,
            false => i64::MIN,
        };
        match bins.iter_mut().find(|b| b.key == key) {
            Some(bin) => bin.sum += rho,
            None => bins.push(Bin {
                key,
                sigma: match sigma > 0.0 {
                    true => (key as f64 / BINS_PER_OCTAVE).exp2(),
                    false => 0.0,
                },
                sum: rho,
                factor: (0.0, 1.0),
            }),
        }
        worst = worst.max(bins.iter().map(|b| b.sum).sum());
    }
    worst
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn undamped_is_the_plain_sum_and_damped_decays() {
        let none = Rayleigh::default();
        assert_eq!(decay_rate(none, 100.0), 0.0);
        assert_eq!(lifetime(0.0, 0.3), 0.3);
        let steps = [(0.1, 1.0, 0.0), (0.1, 2.0, 0.0), (0.1, 0.5, 0.0)];
        assert_eq!(decayed_maximum(steps.into_iter()), 3.5);
        // ζ = β·ω/2 = 0.5 at ω = 1e4 with β = 1e-4: σ = ζ·ω = 5e3; overdamped at ω = 1e5
        // (ζ = 5): the slow root 1e5·(5 − √24) ≈ 1.0102e4.
        let beta = Rayleigh::new(0.0, 1e-4).unwrap();
        assert!((decay_rate(beta, 1e4) - 5e3).abs() < 1e-9);
        assert!((decay_rate(beta, 1e5) - 1e5 * (5.0 - 24f64.sqrt())).abs() < 1e-6);
        // L → 1/σ for σ·T ≫ 1.
        assert!((lifetime(1e3, 1.0) - 1e-3).abs() < 1e-15);
        // One error at σ = 2^4 (a bin's centre): after 10 more steps of 0.01 s it has decayed
        // by e^(−1.6), but the maximum is the error itself, at its own step.
        let mut steps = vec![(0.01, 1.0, 16.0)];
        steps.extend(std::iter::repeat_n((0.01, 0.0, 16.0), 10));
        assert_eq!(decayed_maximum(steps.into_iter()), 1.0);
        // Steady: ρ = r·dt each step, the sum tends to r·dt/(1 − e^(−σ·dt)) ≈ r/σ.
        let steady = std::iter::repeat_n((1e-3, 1e-3, 16.0), 100_000);
        let limit = 1e-3 / -(-16.0f64 * 1e-3).exp_m1();
        assert!((decayed_maximum(steady) - limit).abs() < 1e-9 * limit);
    }
}
