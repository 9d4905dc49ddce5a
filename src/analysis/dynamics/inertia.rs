//! The inertia certificate of an upper bound σ on λ_max(M⁻¹K) (M diagonal, K symmetric): a
//! Cholesky factorization of σ·M − K that succeeds proves σ·M − K positive definite, so by
//! Sylvester's law of inertia every eigenvalue of M⁻¹K lies below σ. Used by
//! [`super::critical_time_step`] to make its Lanczos bound provable.

use super::stability::Certificate;
use crate::base::error::Result;
use crate::base::memory::MemoryLimits;
use crate::linsolve::SparseCholesky;
use crate::sparse::CscMatrix;

/// Relative width at which the search for the least certified σ stops: the step 2/√σ is then
/// within 1 − (1 + 1e-3)^(−1/2) ≈ 5e-4 of the step at the largest σ that failed.
const SEARCH_TOLERANCE: f64 = 1e-3;

/// The first raise of σ after a failed factorization (relative), doubled after each further
/// failure: a start vector that missed the top mode leaves θ + δ near a lower eigenvalue, often
/// within a few per cent of λ_max, and a geometric search reaches any λ_max ≤ Gershgorin's
/// bound in ~log₂ of the ratio steps.
const FIRST_RAISE: f64 = 2e-3;

/// Factorizations at most (a failed one stops at its first non-positive pivot); in the worst
/// case ~10 raises reach Gershgorin's bound and ~10 bisections narrow the bracket to 1e-3.
const MAX_FACTORIZATIONS: usize = 40;

/// Share of the available memory the certificate may hold (the rest is the run's): the same
/// 60 % that [`LinearMethod::Auto`](crate::linear_solver::LinearMethod::Auto) allows a factor.
const MEMORY_SHARE: f64 = 0.6;

/// Bytes per stored entry of K of the symbolic analysis (ordering graph, supernodal structure),
/// as in [`crate::base::memory::StaticEstimate`].
const ANALYSIS_BYTES_PER_ENTRY: u128 = 24;

/// The bound found and how it is proven.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Certified {
    /// The upper bound σ ≥ λ_max.
    pub sigma: f64,
    /// What proves it.
    pub certificate: Certificate,
    /// Numeric factorizations performed.
    pub factorizations: usize,
}

/// The least σ in [`candidate`, `gershgorin`] that an inertia check proves to lie above every
/// eigenvalue of M⁻¹K (`mass` the diagonal of M, `stiffness` K on its full symmetric pattern),
/// trying `candidate` first; `gershgorin` (a bound that needs no check) when no smaller σ is
/// proven, when `candidate` is not below it, or when the factor would not fit in `budget` bytes
/// (`None`: 60 % of what [`MemoryLimits::current`] allows).
///
/// A probe at σ factors σ/(1 + η)·M − K with η the factorization's rounding-error bound (see
/// [`rounding_margin`]): its success proves λ_max < σ in exact arithmetic. After a failure σ is
/// raised geometrically (by 0.2 %, 0.4 %, 0.8 %, … of itself) until a probe succeeds or
/// Gershgorin's bound is passed, then the bracket between the largest failure and the least
/// success is bisected (geometric mean) to a relative width of 1e-3.
pub(super) fn certify(
    stiffness: &CscMatrix,
    mass: &[f64],
    candidate: f64,
    gershgorin: f64,
    budget: Option<u64>,
) -> Result<Certified> {
    let fallback = Certified {
        sigma: gershgorin,
        certificate: Certificate::Gershgorin,
        factorizations: 0,
    };
    if candidate >= gershgorin || candidate.is_nan() {
        return Ok(fallback);
    }
    let allowance = match budget.or_else(|| MemoryLimits::current().available()) {
        Some(bytes) => (bytes as f64 * MEMORY_SHARE) as u128,
        None => u128::MAX,
    };
    let (nnz, n) = (stiffness.nnz() as u128, stiffness.dim() as u128);
    // Before the analysis: the shifted values, the analysis and the counts' scratch.
    if (8 + ANALYSIS_BYTES_PER_ENTRY) * nnz + 16 * n > allowance {
        return Ok(fallback);
    }
    let mut shifted = CscMatrix::from_values(
        std::sync::Arc::clone(stiffness.pattern()),
        stiffness.values().iter().map(|k| -k).collect(),
    )?;
    let mut cholesky = SparseCholesky::analyze(&shifted)?;
    if (8 + ANALYSIS_BYTES_PER_ENTRY) * nnz + cholesky.factor_bytes() as u128 > allowance {
        return Ok(fallback);
    }
    // A supernodal factor also maps the dense kernels' buffers, counted by the address-space
    // limits only: if they do not fit there the check is skipped (Gershgorin's bound needs no
    // factor) rather than stopping an explicit run that needs no factor otherwise.
    if cholesky.is_supernodal() {
        let buffers =
            crate::base::memory::dense_kernel_reservation().for_threads(cholesky.threads());
        let fits = MemoryLimits::current()
            .keeping_back(buffers)
            .ensure_fits("", cholesky.factor_bytes() as u128)
            .is_ok();
        if !fits {
            return Ok(fallback);
        }
    }
    let margin = rounding_margin(&cholesky);
    let mut factorizations = 0;
    // σ·M − K at the probe σ/(1 + η), positive definite or not.
    let mut probe = |sigma: f64| -> Result<bool> {
        let shift = sigma / (1.0 + margin);
        for (v, k) in shifted.values_mut().iter_mut().zip(stiffness.values()) {
            *v = -k;
        }
        shifted.add_diagonal(shift, mass)?;
        factorizations += 1;
        match cholesky.factorize(&shifted) {
            Ok(()) => Ok(true),
            Err(tetfem_linalg::Error::NotPositiveDefinite { .. }) => Ok(false),
            Err(e) => Err(e.into()),
        }
    };
    let mut failed: Option<f64> = None;
    let (mut proven, mut proven_by) = (gershgorin, Certificate::Gershgorin);
    let (mut next, mut raise) = (candidate, FIRST_RAISE);
    for _ in 0..MAX_FACTORIZATIONS {
        if next >= proven {
            break;
        }
        if probe(next)? {
            (proven, proven_by) = (next, Certificate::Inertia);
        } else {
            failed = Some(next);
        }
        let Some(low) = failed else {
            // The candidate itself is proven.
            break;
        };
        if proven <= low * (1.0 + SEARCH_TOLERANCE) {
            break;
        }
        next = if proven_by == Certificate::Gershgorin && low * (1.0 + raise) < proven {
            let raised = low * (1.0 + raise);
            raise *= 2.0;
            raised
        } else {
            (low * proven).sqrt()
        };
    }
    Ok(Certified {
        sigma: proven,
        certificate: proven_by,
        factorizations,
    })
}

/// η such that a Cholesky factorization of σ/(1 + η)·M − K that runs to completion in floating
/// point proves λ_max(M⁻¹K) < σ.
///
/// The computed factor L̂ of the matrix Â actually factored satisfies L̂L̂ᵀ = Â + ΔA with
/// |ΔA| ≤ γ_c·|L̂||L̂ᵀ| (Higham, *Accuracy and Stability of Numerical Algorithms*, Thm 10.3, for
/// any order of the sums), γ_c = c·u/(1 − c·u), u = 2⁻⁵³ and c − 1 the most terms of any inner
/// product: c = the largest row count of L plus one. By Cauchy–Schwarz
/// (|L̂||L̂ᵀ|)ᵢⱼ ≤ ‖l̂ᵢ‖‖l̂ⱼ‖ ≤ (1 + γ_c)·√(âᵢᵢâⱼⱼ), and âᵢᵢ ≤ s·mᵢ(1 + 2u) at the shift s (the
/// diagonal of K is positive; forming s·mᵢ − kᵢᵢ rounds twice), so the M-scaled error
/// M^(−1/2)·ΔA·M^(−1/2) has row sums, hence a 2-norm, at most r·γ_c(1 + γ_c)(1 + 2u)·s with r
/// the most entries of a row of L + Lᵀ (ΔA lies on that pattern). Â + ΔA positive definite
/// (it has a Cholesky factor) then gives K ≺ s·M(1 + 2u) + ΔA, so λ_max < s(1 + η) with
/// η = 2u + r·γ_c(1 + γ_c)(1 + 2u). The margin returned is twice that, for blocked kernels'
/// constants. Measured: 2e-10 on a 36 000-DOF beam, far below the 1e-3 the step may lose.
pub(super) fn rounding_margin(cholesky: &SparseCholesky) -> f64 {
    let counts = cholesky.factor_counts();
    let u = f64::EPSILON / 2.0;
    let c = (counts.max_row + 1) as f64;
    let gamma = c * u / (1.0 - c * u).max(0.5);
    let r = counts.max_row_and_column as f64;
    2.0 * (2.0 * u + r * gamma * (1.0 + gamma) * (1.0 + 2.0 * u))
}

#[cfg(test)]
mod tests {
    use super::*;
    use faer::sparse::SymbolicSparseColMat;
    use std::sync::Arc;

    /// The n×n matrix of `pattern` ("dense" or "diagonal") with `diagonal` on its diagonal and
    /// 1 elsewhere on the pattern.
    fn matrix(dense: bool, diagonal: &[f64]) -> CscMatrix {
        let n = diagonal.len();
        let (col_ptr, row_idx): (Vec<usize>, Vec<usize>) = match dense {
            true => (
                (0..=n).map(|j| j * n).collect(),
                (0..n * n).map(|e| e % n).collect(),
            ),
            false => ((0..=n).collect(), (0..n).collect()),
        };
        let values = (0..row_idx.len())
            .map(|e| {
                let j = col_ptr.partition_point(|&p| p <= e) - 1;
                if row_idx[e] == j { diagonal[j] } else { 1.0 }
            })
            .collect();
        let pattern = Arc::new(SymbolicSparseColMat::new_checked(
            n, n, col_ptr, None, row_idx,
        ));
        CscMatrix::from_values(pattern, values).unwrap()
    }

    /// The margin is 2·(2u + r·γ_c(1 + γ_c)(1 + 2u)), γ_c = c·u/(1 − c·u): to first order in u,
    /// 2u·(2 + r·c). A dense 5×5 factor has c = 5 + 1 and r = 5: 64u; a diagonal one c = 2,
    /// r = 1: 8u. The second-order terms are ~r·c²·u² relative ~1e-15 of it, hence the 1e-12.
    /// A sign error in any term (2u − …, γ(1 − γ), σ·(1 − 2u)) moves it by ≥ 4u.
    #[test]
    fn the_rounding_margin_is_the_first_order_bound() {
        let u = f64::EPSILON / 2.0;
        for (dense, expected) in [(true, 64.0), (false, 8.0)] {
            let a = matrix(dense, &[10.0; 5]);
            let margin = rounding_margin(&SparseCholesky::analyze(&a).unwrap()) / u;
            assert!(
                margin >= expected && margin <= expected * (1.0 + 1e-12),
                "dense {dense}: margin {margin}u, expected {expected}u"
            );
        }
    }

    /// The probe factors σ/(1 + η)·M − K, so a σ within the margin above λ_max is never
    /// certified. K = diag(1, …, 5), M = I: λ_max = 5 exactly. A candidate 5(1 + η/2) makes the
    /// probe's last pivot 5(1 + η/2)/(1 + η) − 5 < 0, so the search raises σ (by 0.2 %) until
    /// it is proven; the probe shifted the other way (σ·(1 + η), a sign error) would succeed
    /// and certify σ < 5(1 + η), which this test refuses.
    #[test]
    fn a_candidate_within_the_margin_is_not_certified() {
        let k = matrix(false, &[1.0, 2.0, 3.0, 4.0, 5.0]);
        let mass = [1.0; 5];
        let eta = rounding_margin(&SparseCholesky::analyze(&k).unwrap());
        let candidate = 5.0 * (1.0 + eta / 2.0);
        let certified = certify(&k, &mass, candidate, 10.0, Some(1 << 30)).unwrap();
        assert_eq!(certified.certificate, Certificate::Inertia);
        assert!(
            certified.sigma >= 5.0 * (1.0 + eta),
            "{certified:?}, η = {eta:e}"
        );
        assert!(certified.factorizations >= 2, "{certified:?}");
        // Above the margin the candidate itself is proven at once.
        let above = 5.0 * (1.0 + 2.0 * eta);
        let certified = certify(&k, &mass, above, 10.0, Some(1 << 30)).unwrap();
        assert_eq!((certified.sigma, certified.factorizations), (above, 1));
    }
}
