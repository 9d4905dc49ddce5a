//! Stability of the explicit method (its critical time step) and the blow-up guard every
//! integrator runs.

use super::top_eigenvalue::top_eigenvalue_bracket;
use super::{Energy, LinearSystem, Mass, State};
use crate::base::error::{Error, Result};
use crate::fe::material::Material;
use crate::mesh::TetMesh;

/// The explicit method's critical time step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CriticalStep {
    /// 2/`omega_max` without damping, [`damped_critical_step`] of `omega_max` with the system's
    /// Rayleigh damping (time units): never above the true critical step (proven, see
    /// [`certificate`](Self::certificate)), and within 1e-3 of it when the certificate is
    /// [`Certificate::Inertia`] (see [`critical_time_step`]); symplectic Euler (central
    /// differences) is stable below it.
    pub dt: f64,
    /// An upper bound on ω_max, the largest natural angular frequency (rad/time) of M⁻¹K.
    pub omega_max: f64,
    /// A lower bound on ω_max (rad/time): √θ, θ the final Rayleigh quotient. The true ω_max lies
    /// in [`omega_max_lower`, `omega_max`].
    pub omega_max_lower: f64,
    /// Products with K the Lanczos iteration made (one a Lanczos step, one a Ritz vector's
    /// residual).
    pub iterations: usize,
    /// What proves `omega_max` ≥ ω_max.
    pub certificate: Certificate,
    /// Numeric factorizations of σ·M − K the inertia check performed (0 for Gershgorin's bound
    /// without a check; 1 when the Lanczos bound is proven at once).
    pub factorizations: usize,
}

/// How [`CriticalStep::omega_max`] is proven to bound ω_max from above.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Certificate {
    /// An inertia check: a sparse Cholesky factorization of σ·M − K (σ = `omega_max`², shrunk
    /// by the factorization's rounding-error bound) succeeded, so σ·M − K is positive definite
    /// and, by Sylvester's law of inertia, every eigenvalue ω² of M⁻¹K is below σ. The step is
    /// then within 1e-3 of 2/ω_max.
    Inertia,
    /// Gershgorin's bound maxᵢ Σⱼ |Kᵢⱼ|/√(mᵢmⱼ) ≥ ω_max², which needs no check but is looser
    /// (the step measured 16–28 % below 2/ω_max on small beams and blocks): used when the factor of K would not fit in
    /// memory, when no inertia check below it succeeded, or when the Lanczos bound already
    /// reached it.
    Gershgorin,
}

impl Certificate {
    /// How the step was found, as summaries write it: `"Lanczos iteration"` (proven by the
    /// inertia check) or `"Gershgorin bound"`.
    pub fn source(self) -> &'static str {
        match self {
            Certificate::Inertia => "Lanczos iteration",
            Certificate::Gershgorin => "Gershgorin bound",
        }
    }
}

/// Choices of [`critical_time_step_with`].
#[derive(Debug, Clone, Default, PartialEq)]
pub struct CriticalStepOptions {
    /// The Lanczos iteration's start vector x (one entry per free DOF; `None`: alternating signs
    /// with an irregular modulation, which has a component along every mode of the meshes
    /// measured). The result is proven whatever the start; a start without a component along
    /// the top mode only costs more factorizations.
    pub start: Option<Vec<f64>>,
    /// Bytes the inertia check may use (`None`: 60 % of the least of MemAvailable, the cgroup
    /// limit and the address-space limits, see [`crate::base::memory::MemoryLimits`]); past it the
    /// step falls back to [`Certificate::Gershgorin`].
    pub memory_budget: Option<u64>,
}

/// Relative width of the bracket [θ, θ + δ] on ω_max² at which the Lanczos iteration stops: the
/// step 2/√(θ + δ) is then within 1 − (1 + 1e-3)^(−1/2) ≈ 5e-4 of the true critical step.
const BRACKET_TOLERANCE: f64 = 1e-3;

/// Limit on the Lanczos iteration's products with K; past it the (safe, looser) bound reached
/// so far is returned.
const MAX_PRODUCTS: usize = 20_000;

/// The critical step 2/ω_max of the explicit method on `system` (lumped mass), rounded down and
/// proven: `dt` ≤ 2/ω_max always, and within 1e-3 of it when the certificate is
/// [`Certificate::Inertia`]. As [`critical_time_step_with`] with the default options.
///
/// With the symmetric form A = M^(−1/2)·K·M^(−1/2) (M diagonal) and z = M^(1/2)·x, the Lanczos
/// iteration from z (restarted every 20 vectors from its Ritz vector,
/// `src/analysis/dynamics/top_eigenvalue.rs`) gives a unit Ritz vector y whose Rayleigh
/// quotient θ = yᵀAy rises towards λ_max = ω_max² from below (θ ≤ λ_max always), and its
/// residual r = A·y − θ·y; some eigenvalue lies within δ = ‖r‖ of θ, but not necessarily the
/// largest (a start with no component along the top mode converges to a lower one). The
/// iteration stops when δ ≤ 1e-3·θ (at most 20 000 products with K) and proposes
/// σ = (θ + δ)(1 + 1e-12) as the upper bound on λ_max, the factor covering round-off in θ and δ
/// (relative ~1e-14). (Power iteration, used before, took 425–575 products where Lanczos takes
/// 53–90: 9,720–69,360 free DOFs, P1 and P2 cantilevers.)
///
/// σ is then proven by an inertia check: σ·M − K has a Cholesky factor (the project's
/// [`SparseCholesky`](crate::linsolve::SparseCholesky) on K's pattern, M being diagonal) exactly
/// when it is positive definite, that is (Sylvester's law of inertia) when σ > λ_max. The
/// factorization is run at σ/(1 + η), η its rounding-error bound (measured 8e-11 to 3e-9 on
/// beams of 3 000–36 000 DOFs), so that success proves σ > λ_max despite round-off. If it fails, σ is raised geometrically and
/// bisected until a factorization succeeds within 1e-3 of the largest σ that failed (9–15
/// factorizations, measured with a start on the second-highest mode). Gershgorin's
/// bound G = maxᵢ Σⱼ |Kᵢⱼ|/√(mᵢmⱼ) ≥ λ_max needs no check and caps every σ: it is the result
/// ([`Certificate::Gershgorin`]) when the factor (with its analysis) would not fit in 60 % of
/// the memory available, or when no σ below G is proven. dt = 2/√σ, lowered by the system's
/// Rayleigh damping as [`damped_critical_step`] states (stiffness damping β makes the top mode
/// less stable: 0.9× the undamped step diverged with β·ω_max = 0.52).
///
/// Cost: one symbolic analysis and usually one numeric factorization of K's size on top of the
/// Lanczos iteration (measured on steel beams of 3 000, 19 440 and 36 300 free DOFs: the check
/// took 15, 180 and 590 ms beside the power iteration's 46, 170 and 410 ms; on a 69,360-DOF
/// beam the check took 1.4 s, the power iteration 1.7 s, Lanczos 0.41 s).
///
/// This is the step tetfem uses. [`element_critical_step`] is the cheaper bound (never above
/// the true critical step, typically 10–50 % below it). Consistent mass is rejected: the
/// explicit method runs on the lumped mass.
pub fn critical_time_step(system: &LinearSystem) -> Result<CriticalStep> {
    critical_time_step_with(system, &CriticalStepOptions::default())
}

/// [`critical_time_step`] with a chosen Lanczos start and memory budget (see
/// [`CriticalStepOptions`]). [`Error::DimensionMismatch`] if the start does not have one entry
/// per free DOF; [`Error::InvalidParameter`] if it is not finite or is zero.
pub fn critical_time_step_with(
    system: &LinearSystem,
    options: &CriticalStepOptions,
) -> Result<CriticalStep> {
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
    // K/M beyond the floating-point range (ρ = 1e-300 kg/m³, E = 1e300 Pa) is a unit error in
    // the input: say so, rather than let the Lanczos iteration break down on infinities.
    if !(gershgorin.is_finite() && gershgorin > 0.0) {
        let (lightest, stiffest) = (
            mass.iter().copied().fold(f64::INFINITY, f64::min),
            k.values().iter().fold(0.0f64, |m, v| m.max(v.abs())),
        );
        return Err(Error::invalid_parameter(
            "stiffness-to-mass ratio",
            format!("ω_max² ≤ {gershgorin:e} rad²/s²"),
            format!(
                "must be a finite number > 0 for an explicit critical step: the lightest lumped \
                 mass is {lightest:e} and the largest stiffness entry {stiffest:e}; check the \
                 density and Young's modulus (and their units)"
            ),
        ));
    }
    let mut z: Vec<f64> = match &options.start {
        Some(start) => {
            Error::check_len("critical step start vector", n, start.len())?;
            if let Some(i) = start.iter().position(|v| !v.is_finite()) {
                return Err(Error::invalid_parameter(
                    "critical step start vector",
                    format!("entry {i} = {}", start[i]),
                    "must be finite",
                ));
            }
            if start.iter().all(|&v| v == 0.0) {
                return Err(Error::invalid_parameter(
                    "critical step start vector",
                    "all zeros",
                    "needs a nonzero entry",
                ));
            }
            start.iter().zip(mass).map(|(x, m)| x * m.sqrt()).collect()
        }
        // A start vector with every mode in it: alternating signs with an irregular modulation.
        None => (0..n)
            .map(|i| {
                let sign = if i % 2 == 0 { 1.0 } else { -1.0 };
                sign * (1.0 + 0.5 * ((i as f64) * 0.618_033_988_7).fract()) * mass[i].sqrt()
            })
            .collect(),
    };
    // The iteration runs on A/s with z scaled to entries of order 1, s the power of two at or
    // below Gershgorin's bound G: a finite ω_max² near the floating-point range (ρ = 1e-300
    // kg/m³ gives G ≈ 1e307) would otherwise overflow in z·z and the residual's squares. Powers
    // of two scale exactly, so every iterate, θ and δ keep the bits of the unscaled iteration.
    let largest = z.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    if !(largest.is_finite() && largest > 0.0) {
        return Err(Error::invalid_parameter(
            "critical step start vector",
            format!("M^(1/2)·start has largest entry {largest:e}"),
            "must be finite and nonzero (check the density's scale)",
        ));
    }
    let start_scale = power_of_two_at_or_below(largest);
    z.iter_mut().for_each(|v| *v /= start_scale);
    let scale = power_of_two_at_or_below(gershgorin);
    let found = top_eigenvalue_bracket(
        (k, &inverse_root),
        z,
        (scale, gershgorin),
        (BRACKET_TOLERANCE, MAX_PRODUCTS),
    )?;
    let bracket = (found.lower, found.upper);
    // Round-off in θ and δ (and in Gershgorin's sums) is ~1e-14 relative; the factor keeps the
    // bounds on the safe side.
    let candidate = bracket.1 * (1.0 + 1e-12);
    let certified = super::inertia::certify(
        k,
        mass,
        candidate,
        gershgorin * (1.0 + 1e-12),
        options.memory_budget,
    )?;
    let omega_max = certified.sigma.sqrt();
    Ok(CriticalStep {
        dt: damped_critical_step(omega_max, system.damping()),
        omega_max,
        omega_max_lower: bracket.0.sqrt(),
        iterations: found.products,
        certificate: certified.certificate,
        factorizations: certified.factorizations,
    })
}

/// The explicit method's critical step (time units) for natural angular frequencies up to
/// `omega_max` (rad/time) with Rayleigh damping C = α·M + β·K:
/// dt = (2/ω)(√(1 + ξ²) − ξ) at ω = `omega_max`, ξ = α/(2ω) + β·ω/2 the damping ratio there;
/// 2/ω without damping.
///
/// Derivation, for the scheme of [`SymplecticEuler`](super::SymplecticEuler)
/// (v⁺ = v + dt·M⁻¹(f − K·u − C·v), u⁺ = u + dt·v⁺): C diagonalizes with M⁻¹K, so each mode
/// (ω, c = α + β·ω² = 2ξω) steps by the matrix [[1 − h²ω², h(1 − ch)], [−hω², 1 − ch]] on
/// (u, v), h = dt, of trace 2 − h²ω² − ch and determinant 1 − ch. Both eigenvalues lie inside the
/// unit circle (Jury) exactly when h²ω² + 2ch < 4, whose positive root in h is the formula.
/// The left side grows with ω at a fixed h, so the step of an upper bound on ω_max is stable
/// for every mode. Stiffness damping thus lowers the step (β·ω_max = 0.5 gives 0.78×2/ω);
/// written as 2/(ω(√(1 + ξ²) + ξ)) to avoid the cancellation of √(1 + ξ²) − ξ at large ξ.
pub fn damped_critical_step(omega_max: f64, damping: super::Rayleigh) -> f64 {
    let xi = damping.ratio_at(omega_max);
    2.0 / (omega_max * (1.0f64.hypot(xi) + xi))
}

/// 2^⌊log₂ x⌋ for a finite x > 0 (clamped to the normal range): a scale that multiplies and
/// divides without rounding.
fn power_of_two_at_or_below(x: f64) -> f64 {
    let exponent = (x.log2().floor() as i64).clamp(-1022, 1023);
    f64::from_bits(((exponent + 1023) as u64) << 52)
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
/// never above the true critical step (see [`element_step_bound`](super::element_step_bound), which
/// computes it together with the geometric estimate).
pub fn element_critical_step(mesh: &TetMesh, material: &Material) -> f64 {
    super::element_step_bound(mesh, material).dt_element
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

    /// A guard that checks only that the energies stay finite: for runs whose supports move,
    /// where the work the supports do is not in the loads' potential the energy bound needs.
    pub fn finite_only(start: Energy) -> Self {
        DivergenceGuard {
            start,
            factor: f64::INFINITY,
        }
    }

    /// The energies of the state the guard was set up from, and the factor over them (plus the
    /// loads' work) that counts as a divergence (∞ for [`finite_only`](Self::finite_only)):
    /// what a [checkpoint](super::Checkpoint) stores to rebuild the same guard.
    pub fn reference(&self) -> (Energy, f64) {
        (self.start, self.factor)
    }

    /// The guard of [`reference`](Self::reference) `(start, factor)`: as it was when the
    /// checkpoint was taken. [`Error::InvalidParameter`] unless the factor is > 1 (∞ allowed)
    /// and the energies are finite.
    pub fn from_reference(start: Energy, factor: f64) -> Result<Self> {
        let energies = [
            start.kinetic,
            start.elastic,
            start.gravity_potential,
            start.load_potential,
        ];
        if factor.is_nan() || factor <= 1.0 || energies.iter().any(|e| !e.is_finite()) {
            return Err(Error::invalid_parameter(
                "divergence guard",
                format!("factor {factor:e}, energies {energies:?}"),
                "the factor must be > 1 and the energies finite",
            ));
        }
        Ok(DivergenceGuard { start, factor })
    }

    /// Checks the energies `energy` of the state after `step` steps at `time` against `guard`,
    /// or, before the first check, sets `guard` up from them: finite values only when
    /// `moving_obstacles` (a moving obstacle does work the loads' potential does not hold).
    pub(crate) fn check_or_start(
        guard: &mut Option<Self>,
        at: (usize, f64),
        energy: Energy,
        moving_obstacles: bool,
    ) -> Result<()> {
        Self::check_or_start_with(guard, at, energy, moving_obstacles, |error| error)
    }

    /// [`check_or_start`](Self::check_or_start) with the check's error passed through `remedy`,
    /// which adds the method's advice (the start's error is the input's: it is not passed).
    pub(crate) fn check_or_start_with(
        guard: &mut Option<Self>,
        (step, time): (usize, f64),
        energy: Energy,
        moving_obstacles: bool,
        remedy: fn(Error) -> Error,
    ) -> Result<()> {
        match guard {
            Some(guard) => guard.check_energy(step, time, &energy).map_err(remedy),
            None => {
                energy.check_start(step, time)?;
                *guard = Some(match moving_obstacles {
                    true => DivergenceGuard::finite_only(energy),
                    false => DivergenceGuard::new(energy),
                });
                Ok(())
            }
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
        if self.factor.is_finite() && motion > allowed {
            return Err(Error::Diverged {
                step,
                time,
                reason: format!(
                    "kinetic + elastic energy {motion:.3e} exceeds {:.0}× what the start and the loads supplied ({:.3e})",
                    self.factor,
                    allowed / self.factor
                ),
            });
        }
        Ok(())
    }
}
