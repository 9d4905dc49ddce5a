//! Stability of the explicit method (its critical time step) and the blow-up guard every
//! integrator runs.

use super::{Energy, LinearSystem, Mass, State};
use crate::error::{Error, Result};
use crate::material::Material;
use crate::mesh::TetMesh;

/// The explicit method's critical time step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CriticalStep {
    /// 2/`omega_max` (time units): at or below the true critical step 2/ω_max, within 1e-3 of
    /// it (see [`critical_time_step`]); symplectic Euler (central differences) is stable below it.
    pub dt: f64,
    /// An upper bound on ω_max, the largest natural angular frequency (rad/time) of M⁻¹K.
    pub omega_max: f64,
    /// A lower bound on ω_max (rad/time): √θ, θ the final Rayleigh quotient. The true ω_max lies
    /// in [`omega_max_lower`, `omega_max`].
    pub omega_max_lower: f64,
    /// Power iterations used.
    pub iterations: usize,
}

/// Relative width of the bracket [θ, θ + δ] on ω_max² at which the power iteration stops: the
/// step 2/√(θ + δ) is then within 1 − (1 + 1e-3)^(−1/2) ≈ 5e-4 of the true critical step.
const BRACKET_TOLERANCE: f64 = 1e-3;

/// Power-iteration limit; past it the (safe, looser) bound reached so far is returned.
const MAX_POWER_ITERATIONS: usize = 20_000;

/// The critical step 2/ω_max of the explicit method on `system` (lumped mass), rounded down:
/// `dt` ≤ 2/ω_max, and within 1e-3 of it once the iteration has converged.
///
/// With the symmetric form A = M^(−1/2)·K·M^(−1/2) (M diagonal) and z = M^(1/2)·x, power
/// iteration z ← A·z gives Rayleigh quotients θ = zᵀAz/zᵀz that rise towards λ_max = ω_max² from
/// below (θ ≤ λ_max always), and residuals r = A·z − θ·z. For a symmetric matrix, some
/// eigenvalue lies within δ = ‖r‖/‖z‖ = ‖M^(−1/2)(Kx − θMx)‖/‖M^(1/2)x‖ of θ. Writing z in
/// eigenvectors, z = Σ cⱼφⱼ with Σcⱼ² = 1: δ² = Σ cⱼ²(λⱼ − θ)² ≥ c_max²(λ_max − θ)², so
/// λ_max ≤ θ + δ/|c_max|. **Assumption:** the iterate is dominated by the top eigenvector
/// (|c_max| → 1), which the power method delivers whenever the start vector has a component
/// along it — the start alternates in sign from DOF to DOF, as the top mode of a mesh does, so
/// it has one on every mesh we know of. Then λ_upper = θ + δ bounds λ_max from above. It is
/// also capped by the rigorous Gershgorin bound maxᵢ Σⱼ |Kᵢⱼ|/√(mᵢmⱼ) ≥ λ_max. The iteration
/// stops when δ ≤ 1e-3·θ (at most 20 000 iterations), and dt = 2/√(λ_upper·(1 + 1e-12)), the
/// factor covering round-off in θ and δ (relative ~1e-14).
///
/// This is the step tetfem uses. [`element_critical_step`] is the cheaper bound that needs no
/// assumption (never above the true critical step, typically 10–50 % below it). Consistent
/// mass is rejected: the explicit method runs on the lumped mass.
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
    let inverse_root: Vec<f64> = mass.iter().map(|m| 1.0 / m.sqrt()).collect();
    let gershgorin = gershgorin_bound(system.stiffness(), &inverse_root);
    // A start vector with every mode in it: alternating signs with an irregular modulation.
    let mut z: Vec<f64> = (0..n)
        .map(|i| {
            let sign = if i % 2 == 0 { 1.0 } else { -1.0 };
            sign * (1.0 + 0.5 * ((i as f64) * 0.618_033_988_7).fract()) * mass[i].sqrt()
        })
        .collect();
    let (mut x, mut kx, mut az) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    let mut bracket: (f64, f64) = (0.0, gershgorin);
    let mut iterations = MAX_POWER_ITERATIONS;
    for iteration in 1..=MAX_POWER_ITERATIONS {
        // A·z = M^(−1/2)·K·(M^(−1/2)·z)
        for i in 0..n {
            x[i] = inverse_root[i] * z[i];
        }
        k.product_into(&x, &mut kx);
        for i in 0..n {
            az[i] = inverse_root[i] * kx[i];
        }
        let zz: f64 = z.iter().map(|v| v * v).sum();
        let theta = z.iter().zip(&az).map(|(a, b)| a * b).sum::<f64>() / zz;
        let delta = (az
            .iter()
            .zip(&z)
            .map(|(a, v)| (a - theta * v).powi(2))
            .sum::<f64>()
            / zz)
            .sqrt();
        if !(theta.is_finite() && delta.is_finite() && theta > 0.0) {
            return Err(Error::Solver(format!(
                "power iteration for ω_max broke down at iteration {iteration} \
                 (Rayleigh quotient {theta:e}, residual {delta:e})"
            )));
        }
        bracket = (theta, (theta + delta).min(gershgorin));
        if delta <= BRACKET_TOLERANCE * theta {
            iterations = iteration;
            break;
        }
        // z ← A·z, normalised by its largest entry.
        let norm = az.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        for i in 0..n {
            z[i] = az[i] / norm;
        }
    }
    // Round-off in θ and δ is ~1e-14 relative; the factor keeps the bound on the safe side.
    let omega_max = (bracket.1 * (1.0 + 1e-12)).sqrt();
    Ok(CriticalStep {
        dt: 2.0 / omega_max,
        omega_max,
        omega_max_lower: bracket.0.sqrt(),
        iterations,
    })
}

/// Gershgorin's bound on λ_max(M^(−1/2)·K·M^(−1/2)): maxᵢ Σⱼ |Kᵢⱼ|·sᵢ·sⱼ with sᵢ = 1/√mᵢ.
fn gershgorin_bound(k: &crate::sparse::CscMatrix, inverse_root: &[f64]) -> f64 {
    let (col_ptr, row_idx, values) = (k.col_ptr(), k.row_idx(), k.values());
    (0..k.dim())
        .map(|j| {
            (col_ptr[j]..col_ptr[j + 1])
                .map(|e| values[e].abs() * inverse_root[row_idx[e]])
                .sum::<f64>()
                * inverse_root[j]
        })
        .fold(0.0, f64::max)
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
