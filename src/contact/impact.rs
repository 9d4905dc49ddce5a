//! The impact-aware barrier stiffness
//! ([`ContactParameters::impact_fraction`](super::ContactParameters::impact_fraction)): each
//! contact node i gets its own κᵢ, raised so that the barrier takes the node's kinetic energy
//! at a gap of about f·d̂.
//!
//! Why: with κ₀ = E/h alone a lumped node of mass m landing at normal speed v is stopped where
//! κ₀·A·b(d) = ½·m·v², and b(d) ≈ d̂²·ln(d̂/d) near 0 puts that gap at d̂·e^(−m·v²/(2κ₀·A·d̂²)):
//! on the drop of `tests/core/adaptive_time_step.rs` about d̂·e^(−50), where the barrier's
//! frequency √(κ·A·b″(d)/m) is beyond every affordable step, and the impact's outcome
//! scatters with where the steps fall instead of converging with dt. Solving
//! κᵢ·Aᵢ·b(f·d̂) = ½·mᵢ·v² for κᵢ instead stops the node near f·d̂, where the barrier's mode is
//! ω_c ≈ √(κᵢ·Aᵢ·b″(f·d̂)/mᵢ) = |v|·√(b″(f·d̂)/(2·b(f·d̂))) ∝ |v|/d̂: a step dt with ω_c·dt < 1
//! resolves it.
//!
//! The rule, at each implicit step's start and from that state only ([`next_stiffness`]): a
//! node outside d̂ of every obstacle takes κᵢ = max(κ₀, its estimate) ([`node_estimate`]; κ₀
//! when it is not approaching); a node within d̂ of one keeps the κᵢ it has. A node's barrier
//! energy κᵢ·Aᵢ·Σ_o b(d_o) is therefore one fixed potential for as long as the node stores any
//! (κᵢ changes only at a step start where b is 0 for it), so the barrier is conservative: the
//! energy a landing node stored is given back in its rebound at the same κᵢ, whatever the other
//! nodes do. One κ for every node (the max of the estimates, kept while any node was within
//! d̂), the rule before this one, was not: a node landing later and faster raised κ under
//! the nodes already within d̂, adding Δκ·Σ Aᵢ·b(dᵢ) to the energy (measured on the drop:
//! `adaptive.rs`'s module doc). The update is a function of the step's start state, its
//! duration and the κᵢ held, so a step that is rejected and retried from its saved start
//! reaches the same κᵢ.
//!
//! Friction's normal force λᵢ = μ·κᵢ·Aᵢ·|b′(dᵢ)| takes the node's own κᵢ too.

use std::sync::atomic::{AtomicU64, Ordering};

use super::barrier;

/// The barrier stiffness κᵢ in force of each contact node (Pa/m), shared by the contact's
/// clones in one run and changed through `&self` (a contact lives inside an `Arc` during a
/// run); a clone copies the values. Empty without an impact fraction: every node is at κ₀.
#[derive(Debug, Default)]
pub(crate) struct NodeStiffness(Vec<AtomicU64>);

impl NodeStiffness {
    /// `count` nodes at `kappa` (Pa/m).
    pub(crate) fn new(count: usize, kappa: f64) -> Self {
        NodeStiffness(
            (0..count)
                .map(|_| AtomicU64::new(kappa.to_bits()))
                .collect(),
        )
    }

    /// κ of node `k` (Pa/m), `floor` where none is kept (no impact fraction).
    pub(crate) fn get(&self, k: usize, floor: f64) -> f64 {
        self.0
            .get(k)
            .map_or(floor, |a| f64::from_bits(a.load(Ordering::Relaxed)))
    }

    /// Sets κ of node `k` (Pa/m); nothing where none is kept.
    pub(crate) fn set(&self, k: usize, kappa: f64) {
        if let Some(a) = self.0.get(k) {
            a.store(kappa.to_bits(), Ordering::Relaxed);
        }
    }

    /// How many nodes it keeps (0 without an impact fraction).
    pub(crate) fn len(&self) -> usize {
        self.0.len()
    }
}

impl Clone for NodeStiffness {
    fn clone(&self) -> Self {
        NodeStiffness(
            (self.0.iter())
                .map(|a| AtomicU64::new(a.load(Ordering::Relaxed)))
                .collect(),
        )
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

/// One node's stiffness for the next step (Pa/m), from the floor `floor` (κ₀), its estimate
/// `estimate` (the largest over the obstacles it approaches) and its value in force `current`:
/// `current` unchanged while the node is within d̂ of an obstacle (`within`: it may store
/// barrier energy at that κ), max(floor, estimate) once it is outside d̂ of every obstacle.
pub fn next_stiffness(floor: f64, current: f64, estimate: f64, within: bool) -> f64 {
    match within {
        true => current,
        false => floor.max(estimate),
    }
}
