//! The impact-aware barrier stiffness
//! ([`ContactParameters::impact_fraction`](super::ContactParameters::impact_fraction)): κ
//! raised so that the barrier takes a landing node's kinetic energy at a gap of about f·d̂.
//!
//! Why: with κ₀ = E/h alone a lumped node of mass m landing at normal speed v is stopped where
//! κ₀·A·b(d) = ½·m·v², and b(d) ≈ d̂²·ln(d̂/d) near 0 puts that gap at d̂·e^(−m·v²/(2κ₀·A·d̂²)):
//! on the drop of `tests/core/adaptive_time_step.rs` about d̂·e^(−50), where the barrier's
//! frequency √(κ·A·b″(d)/m) is beyond every affordable step, and the impact's outcome
//! scatters with where the steps fall instead of converging with dt. Solving
//! κ·A·b(f·d̂) = ½·m·v² for κ instead stops it near f·d̂, where the barrier's mode is
//! ω_c ≈ √(κ·A·b″(f·d̂)/m) = |v|·√(b″(f·d̂)/(2·b(f·d̂))) ∝ |v|/d̂: a step dt with ω_c·dt < 1 resolves it.
//!
//! The value in force is kept between steps (a `Stiffness` cell of the contact) and updated at
//! each implicit step's start from that state only ([`next_stiffness`]): while a node is within
//! d̂ it never falls, so the barrier energy a node stored is returned at the same κ on its way
//! out; once no node is within d̂ it is the estimate alone (no barrier energy is stored then,
//! so the change does no work). A rise while some node is within d̂ (a second node landing
//! faster than the first) adds Δκ·Σ Aᵢ·b(dᵢ) to the barrier energy: that is the energy error of
//! the rule, measured on the drop in `tests/core/adaptive_time_step.rs`. The update is
//! idempotent (max of the same estimate twice), so a step that is rejected and retried from
//! its saved start reaches the same κ.

use std::sync::atomic::{AtomicU64, Ordering};

use super::barrier;

/// The barrier stiffness in force (Pa/m), shared by the contact's clones in one run and
/// changed through `&self` (a contact lives inside an `Arc` during a run); a clone copies it.
#[derive(Debug)]
pub(crate) struct Stiffness(AtomicU64);

impl Stiffness {
    pub(crate) fn new(kappa: f64) -> Self {
        Stiffness(AtomicU64::new(kappa.to_bits()))
    }

    pub(crate) fn get(&self) -> f64 {
        f64::from_bits(self.0.load(Ordering::Relaxed))
    }

    pub(crate) fn set(&self, kappa: f64) {
        self.0.store(kappa.to_bits(), Ordering::Relaxed);
    }
}

impl Clone for Stiffness {
    fn clone(&self) -> Self {
        Stiffness::new(self.get())
    }
}

/// One node's stiffness estimate m·v_n²/(2·A·b(f·d̂)) (Pa/m) for its mass `mass`, normal
/// approach speed `approach` (length/time; > 0 approaching), area weight `area` and the
/// barrier's d̂ and fraction f; 0 for a node that is not approaching.
pub fn node_estimate(mass: f64, approach: f64, area: f64, d_hat: f64, fraction: f64) -> f64 {
    // NaN and receding speeds give nothing (NaN > 0 is false).
    match approach > 0.0 {
        true => mass * approach * approach / (2.0 * area * barrier::value(fraction * d_hat, d_hat)),
        false => 0.0,
    }
}

/// The stiffness of the next step (Pa/m): the floor `floor` (κ₀), the largest node estimate
/// `estimate` and the value in force `current`: max(current, estimate) while some node is
/// within d̂ (`any_within`), max(floor, estimate) once none is.
pub fn next_stiffness(floor: f64, current: f64, estimate: f64, any_within: bool) -> f64 {
    match any_within {
        true => current.max(estimate).max(floor),
        false => floor.max(estimate),
    }
}
