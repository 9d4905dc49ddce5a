//! What the stability map ([`crate::stability_map`]) and the contact stress suite
//! ([`crate::contact_stress`]) both measure of a watched run: the energy record behind their
//! "energy growth" class, with the explicit method's half-step velocity taken into account.

use tetfem::analysis::dynamics::State;

/// The energy record of a run watched step by step: the total energy H at the first measured
/// state, the largest H − W over the run (W the work of moving obstacles; 0 without), and the
/// energy scale.
///
/// The explicit method's stored velocity is the mean over the step that produced the
/// displacement (half a step behind it): its states are measured one step late, at the previous
/// displacement with the mean of the previous and the current stored velocity (to second order
/// the velocity at that displacement's time). The implicit methods' states are measured as
/// they are.
#[derive(Debug, Clone)]
pub struct EnergyRecord {
    explicit: bool,
    previous: Option<State>,
    /// H at the first measured state.
    pub start: Option<f64>,
    /// The largest H − W measured.
    pub highest: f64,
    /// The energy scale: the largest of |H(0)|, kinetic + elastic over the run and |W|.
    pub scale: f64,
}

impl EnergyRecord {
    /// The record of a run from `initial`, by the explicit method if `explicit`.
    pub fn new(explicit: bool, initial: State) -> Self {
        EnergyRecord {
            explicit,
            previous: Some(initial),
            start: None,
            highest: f64::NEG_INFINITY,
            scale: 0.0,
        }
    }

    /// The state whose energy to measure after a step that left `state` (`None`: none yet,
    /// the explicit method's first step); then call [`take`](Self::take) with its energies.
    pub fn measured(&mut self, state: &State) -> Option<State> {
        let measured = match (self.explicit, &self.previous) {
            (false, _) => Some(state.clone()),
            (true, None) => None,
            (true, Some(previous)) => Some(State {
                velocity: previous
                    .velocity
                    .iter()
                    .zip(&state.velocity)
                    .map(|(a, b)| 0.5 * (a + b))
                    .collect(),
                ..previous.clone()
            }),
        };
        if self.explicit {
            self.previous = Some(state.clone());
        }
        measured
    }

    /// Takes a measured state's total energy H (`total`), the obstacles' work W up to now
    /// (`work`) and its energy in motion, kinetic + elastic (`motion`).
    pub fn take(&mut self, total: f64, work: f64, motion: f64) {
        let start = *self.start.get_or_insert(total);
        self.highest = self.highest.max(total - work);
        self.scale = self.scale.max(motion).max(start.abs()).max(work.abs());
    }

    /// The energy growth (max [H − W] − H(0)) / E_scale (negative: dissipated); `None` before
    /// a state was measured.
    pub fn growth(&self) -> Option<f64> {
        self.start
            .map(|start| (self.highest - start) / self.scale.max(f64::MIN_POSITIVE))
    }
}
