//! Energy bookkeeping of a dynamic state.

use crate::base::error::{Error, Result};

/// Energies of a state (energy units, J in SI). The loads are constant, so each has a potential
/// −f·u, and the work they did since the start is minus the change of that potential.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Energy {
    /// Kinetic energy ½·vᵀ·M·v.
    pub kinetic: f64,
    /// Elastic (strain) energy ½·uᵀ·K·u.
    pub elastic: f64,
    /// Gravitational potential −f_g·u (relative to the reference configuration).
    pub gravity_potential: f64,
    /// Potential of the other constant loads, −f·u.
    pub load_potential: f64,
}

impl Energy {
    /// The energies a divergence guard needs, from the sums a time step takes in its passes:
    /// vᵀMv, uᵀKu and −f·u. The guard uses only the sum of the potentials, so the load's is
    /// not split into gravity and the rest (that would take one more vector to read).
    pub(crate) fn for_guard(twice_kinetic: f64, twice_elastic: f64, potential: f64) -> Self {
        Energy {
            kinetic: 0.5 * twice_kinetic,
            elastic: 0.5 * twice_elastic,
            gravity_potential: 0.0,
            load_potential: potential,
        }
    }

    /// Total mechanical energy: kinetic + elastic + both potentials. Conserved without damping
    /// by the exact dynamics and by Newmark; never increasing under backward Euler.
    pub fn total(&self) -> f64 {
        self.kinetic + self.elastic + self.gravity_potential + self.load_potential
    }

    /// Work done by the external loads since the state `start`: −Δ(potentials).
    pub fn external_work_since(&self, start: &Energy) -> f64 {
        -(self.gravity_potential + self.load_potential
            - start.gravity_potential
            - start.load_potential)
    }

    /// `Ok` if these are the energies of a state a run can start from: [`Error::Diverged`] at
    /// `step`, `time` if the kinetic or elastic energy is not finite (½·vᵀ·M·v overflows for an
    /// initial velocity of 1e300 m/s), which would otherwise surface later as a NaN in an output.
    pub fn check_start(&self, step: usize, time: f64) -> Result<()> {
        if (self.kinetic + self.elastic).is_finite() {
            return Ok(());
        }
        Err(Error::Diverged {
            step,
            time,
            reason: format!(
                "the starting state's kinetic energy ({:e}) or elastic energy ({:e}) is not \
                 finite: its velocity or displacement is beyond the floating-point range (check \
                 the initial velocity and its units)",
                self.kinetic, self.elastic
            ),
        })
    }

    /// Size of the energy terms, Σ|term|: a scale for relative comparisons.
    pub fn scale(&self) -> f64 {
        self.kinetic.abs()
            + self.elastic.abs()
            + self.gravity_potential.abs()
            + self.load_potential.abs()
    }
}
