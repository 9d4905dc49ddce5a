//! Stability of the explicit method (its critical time step) and the blow-up guard every
//! integrator runs.

use super::{Energy, LinearSystem, Mass, State};
use crate::error::{Error, Result};
use crate::material::Material;
use crate::mesh::TetMesh;

/// The explicit method's critical time step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CriticalStep {
    /// 2/ω_max (time units): symplectic Euler (central differences) is stable below it.
    pub dt: f64,
    /// ω_max, the largest natural angular frequency (rad/time) of M⁻¹K.
    pub omega_max: f64,
    /// Power iterations used.
    pub iterations: usize,
}

/// The critical step 2/ω_max of the explicit method on `system` (lumped mass), with ω_max² the
/// largest eigenvalue of M⁻¹K from power iteration with Rayleigh quotients, stopped when the
/// estimate changes by less than 1e-6 relative (at most 2000 iterations).
///
/// This is the step tetfem uses. The Rayleigh quotient approaches ω_max² from below, so the step
/// is, if anything, slightly optimistic (by the stopping tolerance); [`element_critical_step`]
/// is the cheaper, safe bound (never above the true critical step, typically 10–50 % below it).
pub fn critical_time_step(system: &LinearSystem) -> Result<CriticalStep> {
    let mass = match system.mass() {
        Mass::Lumped(m) => m,
        Mass::Consistent(_) => {
            return Err(Error::invalid_parameter(
                "mass",
                "consistent",
                "the explicit critical step is defined for the lumped mass the explicit method uses",
            ));
        }
    };
    let k = system.stiffness();
    let n = k.dim();
    if n == 0 {
        return Err(Error::invalid_parameter(
            "system",
            "no free DOFs",
            "needs at least one free DOF",
        ));
    }
    // A start vector with every mode in it: alternating signs with an irregular modulation.
    let mut x: Vec<f64> = (0..n)
        .map(|i| if i % 2 == 0 { 1.0 } else { -1.0 } * (1.0 + 0.5 * ((i as f64) * 0.618_033_988_7).fract()))
        .collect();
    let mut kx = vec![0.0; n];
    let mut lambda = 0.0;
    for iteration in 1..=2000 {
        k.product_into(&x, &mut kx);
        let xkx: f64 = x.iter().zip(&kx).map(|(a, b)| a * b).sum();
        let xmx: f64 = x.iter().zip(mass).map(|(a, m)| a * a * m).sum();
        let next = xkx / xmx;
        // x ← M⁻¹K·x, normalised.
        let mut norm: f64 = 0.0;
        for i in 0..n {
            x[i] = kx[i] / mass[i];
            norm = norm.max(x[i].abs());
        }
        if !(norm.is_finite() && norm > 0.0) {
            return Err(Error::Solver("power iteration for ω_max broke down".into()));
        }
        x.iter_mut().for_each(|v| *v /= norm);
        let converged = (next - lambda).abs() <= 1e-6 * next;
        lambda = next;
        if converged {
            let omega_max = lambda.sqrt();
            return Ok(CriticalStep {
                dt: 2.0 / omega_max,
                omega_max,
                iterations: iteration,
            });
        }
    }
    let omega_max = lambda.sqrt();
    Ok(CriticalStep {
        dt: 2.0 / omega_max,
        omega_max,
        iterations: 2000,
    })
}

/// The element bound on the explicit critical step, 2/maxₑ ωₑ with ωₑ² = λ_max(Kₑ)/(ρVₑ/4):
/// never above the true critical step (see [`crate::mesh::critical_time_step`], which
/// computes it together with the geometric estimate).
pub fn element_critical_step(mesh: &TetMesh, material: &Material) -> f64 {
    crate::mesh::critical_time_step(mesh, material).dt_element
}

/// Catches a run that blows up: a non-finite value, or a kinetic + elastic energy far above
/// what the start and the external work can supply.
///
/// In a stable run, kinetic + elastic = (its initial value) + (work of the loads) − (dissipated
/// energy), so it never exceeds E₀ + W. The guard fires when it exceeds 10·(E₀ + |W|) plus a
/// round-off floor: an unstable mode grows geometrically and crosses that within a few dozen
/// steps, while a stable one never comes near it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DivergenceGuard {
    start: Energy,
    factor: f64,
}

impl DivergenceGuard {
    /// A guard for a run starting at `start`.
    pub fn new(start: Energy) -> Self {
        DivergenceGuard {
            start,
            factor: 10.0,
        }
    }

    /// Checks `state` with its energies `energy`; `Err(Diverged)` names the step and time.
    pub fn check(&self, state: &State, energy: &Energy) -> Result<()> {
        state.ensure_finite("")?;
        self.check_energy(state.steps, state.time, energy)
    }

    /// Checks the energies `energy` of the state after `step` steps at `time`, without scanning
    /// the state: for integrators that take the energies in a pass they make anyway (a non-finite
    /// displacement or velocity makes the elastic or kinetic energy non-finite).
    pub fn check_energy(&self, step: usize, time: f64, energy: &Energy) -> Result<()> {
        let motion = energy.kinetic + energy.elastic;
        if !motion.is_finite() {
            return Err(Error::Diverged {
                step,
                time,
                reason: "the kinetic or elastic energy is no longer finite".into(),
            });
        }
        let work = energy.external_work_since(&self.start).abs();
        let allowed = self.factor * (self.start.kinetic + self.start.elastic + work) + 1e-300;
        if motion > allowed {
            return Err(Error::Diverged {
                step,
                time,
                reason: format!(
                    "kinetic + elastic energy {motion:.3e} exceeds {:.0}× what the start and the loads supplied ({:.3e}); \
                     for the explicit method, is dt above the critical step?",
                    self.factor,
                    allowed / self.factor
                ),
            });
        }
        Ok(())
    }
}
