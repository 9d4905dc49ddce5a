//! The stable Neo-Hookean force and energy of four tets side by side, one tet per lane of each
//! arithmetic operation: what [`NeoHookean`](super::NeoHookean)'s
//! [`ForceModel::force_and_energy_4`](super::ForceModel::force_and_energy_4) runs, the same
//! bits lane by lane as [`ForceModel::force_and_energy`](super::ForceModel::force_and_energy)
//! of each tet alone (the operations of [`super::lanes`] are nalgebra's, in its order).
//!
//! The model has no branch (P = μF + λ̂(J − α)·cof F, no inverse, no logarithm), so every
//! lane takes every tet, inverted or not: there is no scalar fallback.

use super::lanes::{
    L, LANES, M, Tets, add, build, column, deformation_gradients, determinant, forces_into, lanes,
    mul, norm_squared, scale, sub,
};
use crate::fe::element::Vector12;

/// The stable Neo-Hookean material constants a kernel needs: μ (shear modulus, stress units),
/// λ̂ = λ + μ (stress units) and α = 1 + μ/λ̂ (dimensionless, the rest volume ratio's shift).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Constants {
    pub mu: f64,
    pub lambda_hat: f64,
    pub alpha: f64,
}

/// The force and energy of the lanes' tets into `out` (one entry per lane), with AVX2 where the
/// CPU has it.
pub(crate) fn force_and_energy(
    tets: &Tets,
    constants: Constants,
    out: &mut [(Vector12, f64); LANES],
) {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU has AVX2, checked just above.
            unsafe { force_and_energy_avx2(tets, constants, out) };
            return;
        }
    }
    force_and_energy_lanes(tets, constants, out);
}

/// [`force_and_energy_lanes`] compiled for AVX2 (no FMA, which would change the bits).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn force_and_energy_avx2(
    tets: &Tets,
    constants: Constants,
    out: &mut [(Vector12, f64); LANES],
) {
    force_and_energy_lanes(tets, constants, out);
}

#[inline(always)]
fn force_and_energy_lanes(tets: &Tets, k: Constants, out: &mut [(Vector12, f64); LANES]) {
    let (f, rest_inverse, volume) = deformation_gradients(tets);
    let j = determinant(&f);
    let cofactor = cofactor(&f);
    // P = μF + λ̂(J − α)·cof F.
    let shift = lanes(|l| j[l] - k.alpha);
    let volumetric = scale(shift, k.lambda_hat);
    let piola = build(|r, c, l| f[r][c][l] * k.mu + cofactor[r][c][l] * volumetric[l]);
    // Ψ = μ/2·(‖F‖² − 3) + λ̂/2·(J − α)² − λ̂/2·(1 − α)² (zero at rest).
    let rest = 0.5 * k.lambda_hat * (1.0 - k.alpha).powi(2);
    let norm_squared = norm_squared(&f);
    let shear = scale(lanes(|l| norm_squared[l] - 3.0), 0.5 * k.mu);
    let bulk = scale(mul(shift, shift), 0.5 * k.lambda_hat);
    let sum = add(shear, bulk);
    let density = lanes(|l| sum[l] - rest);
    forces_into(&piola, (&rest_inverse, volume), mul(volume, density), out);
}

/// cof F = [f₁ × f₂, f₂ × f₀, f₀ × f₁] (columns fᵢ of F), each cross product in nalgebra's
/// order: (a_y·b_z − a_z·b_y, a_z·b_x − a_x·b_z, a_x·b_y − a_y·b_x).
#[inline(always)]
fn cofactor(f: &M) -> M {
    let mut out: M = [[[0.0; LANES]; 3]; 3];
    for (c, (a, b)) in [(1, 2), (2, 0), (0, 1)].into_iter().enumerate() {
        let (a, b) = (column(f, a), column(f, b));
        let cross: [L; 3] = [
            sub(mul(a[1], b[2]), mul(a[2], b[1])),
            sub(mul(a[2], b[0]), mul(a[0], b[2])),
            sub(mul(a[0], b[1]), mul(a[1], b[0])),
        ];
        for r in 0..3 {
            out[r][c] = cross[r];
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use crate::fe::material::Material;
    use crate::model::NeoHookean;
    use crate::model::lanes::test_tets::assert_four_match_one_by_one;

    /// Every lane's force and energy are the scalar path's to the bit (compared as bit
    /// patterns: the lanes do the same operations in the same order), for rest tets of many
    /// shapes deformed by rotations up to 3 rad and stretches up to ±30 %, inverted, flat and
    /// far-stretched ones, and a non-finite one (NaN in both paths, the same NaN lanes).
    #[test]
    fn lanes_repeat_the_scalar_force_and_energy_to_the_bit() {
        let model = NeoHookean::new(&Material::new(1e6, 0.45, 1100.0).unwrap());
        for batch in 0..300 {
            assert_four_match_one_by_one(&model, batch);
        }
    }
}
