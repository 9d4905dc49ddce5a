//! The corotational force and energy of four tets side by side, one tet per lane of each
//! arithmetic operation: what [`Corotational`](super::Corotational)'s
//! [`ForceModel::force_and_energy_4`](super::ForceModel::force_and_energy_4) runs, the same
//! bits lane by lane as [`ForceModel::force_and_energy`](super::ForceModel::force_and_energy)
//! of each tet alone.
//!
//! A tet's force is some 700 floating-point operations (F = Ds·Dm⁻¹, the polar rotation by
//! four or so Newton–Schulz iterations, P and −V·P·Dm⁻ᵀ), each 3×3 product a chain of
//! dependent scalar operations: one tet at a time the pass is bound by their latency and runs
//! one operation per instruction. Four tets in the lanes of one vector register (AVX2; two
//! SSE2 registers without it) do four tets' operations per instruction, in the same order and
//! rounding as one tet alone (no fused multiply-add: Rust never contracts a·b + c), so every
//! lane's result is that tet's scalar result to the bit. A lane whose polar decomposition
//! leaves the Newton–Schulz iteration (an inverted, flat or far-stretched tet, a non-finite F:
//! [`super::polar::rotation`]'s other branches) is recomputed on its own by the scalar path.

use nalgebra::Matrix3;

use super::lanes::{
    LANES, M, Tets, add, build, column, deformation_gradients, determinant, dot3, forces_into,
    lanes, mul, norm_squared, product, scale, tr_product,
};
use crate::fe::element::Vector12;

/// The force and energy of the lanes' tets under the corotational model of Lamé parameters
/// (`lambda`, `mu`) (see the module's docs) into `out` (one entry per lane), with AVX2 where
/// the CPU has it. Returns which lanes hold their result: the others left the Newton–Schulz
/// iteration, and the scalar path must compute them.
pub(crate) fn force_and_energy(
    tets: &Tets,
    (lambda, mu): (f64, f64),
    out: &mut [(Vector12, f64); LANES],
) -> [bool; LANES] {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU has AVX2, checked just above.
            return unsafe { force_and_energy_avx2(tets, (lambda, mu), out) };
        }
    }
    force_and_energy_lanes(tets, (lambda, mu), out)
}

/// [`force_and_energy_lanes`] compiled for AVX2 (four f64 lanes a register; no FMA, which
/// would change the bits).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn force_and_energy_avx2(
    tets: &Tets,
    lame: (f64, f64),
    out: &mut [(Vector12, f64); LANES],
) -> [bool; LANES] {
    force_and_energy_lanes(tets, lame, out)
}

#[inline(always)]
fn force_and_energy_lanes(
    tets: &Tets,
    (lambda, mu): (f64, f64),
    out: &mut [(Vector12, f64); LANES],
) -> [bool; LANES] {
    let (f, rest_inverse, volume) = deformation_gradients(tets);
    let (r, converged) = rotation(&f);
    // tr(S) of S = sym(RᵀF): its diagonal is RᵀF's, whose entries are the columns' dot products.
    let mut trace = [0.0; LANES];
    for i in 0..3 {
        trace = add(trace, dot3(column(&r, i), column(&f, i)));
    }
    let trace = lanes(|l| trace[l] - 3.0);
    // P = 2μ(F − R) + λ·tr(S − I)·R.
    let twice_mu = 2.0 * mu;
    let pressure = scale(trace, lambda);
    let f_minus_r = build(|i, j, l| f[i][j][l] - r[i][j][l]);
    let piola = build(|i, j, l| f_minus_r[i][j][l] * twice_mu + r[i][j][l] * pressure[l]);
    // μ‖F − R‖² + λ/2·tr²(S − I).
    let half_lambda = 0.5 * lambda;
    let density = add(
        scale(norm_squared(&f_minus_r), mu),
        mul(scale(trace, half_lambda), trace),
    );
    forces_into(&piola, (&rest_inverse, volume), mul(volume, density), out);
    converged
}

/// The polar rotations of four matrices side by side: for each, `Some(R)` the same bits as
/// [`super::polar::rotation`] where its Newton–Schulz iteration takes it, `None` where the
/// caller must call that function (the matrix is not finite, zero, flat, inverted or its
/// stretches far apart).
pub(crate) fn rotations(f: &[Matrix3<f64>; LANES]) -> [Option<Matrix3<f64>>; LANES] {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU has AVX2, checked just above.
            return unsafe { rotations_avx2(f) };
        }
    }
    rotations_lanes(f)
}

/// The polar rotations of four matrices: each lane's where its Newton–Schulz iteration takes
/// it, [`super::polar::rotation`]'s where not: the same bits as that function of each.
pub(crate) fn four_rotations(f: &[Matrix3<f64>; LANES]) -> [Matrix3<f64>; LANES] {
    let lanes = rotations(f);
    let mut out = [Matrix3::identity(); LANES];
    for (k, (r, lane)) in out.iter_mut().zip(lanes).enumerate() {
        *r = lane.unwrap_or_else(|| super::polar::rotation(&f[k]));
    }
    out
}

/// The polar rotation ([`rotation`](super::rotation)) of each matrix of `f` into `out`, four
/// side by side in SIMD lanes (AVX2 where the CPU has it): the same bits as that function of
/// each, at a fraction of its time (what the nodal rotations of the nonlinear steps take).
///
/// Errors: `out` is not one matrix per matrix of `f`.
pub fn rotations_into(f: &[Matrix3<f64>], out: &mut [Matrix3<f64>]) -> crate::Result<()> {
    crate::Error::check_len("rotations", f.len(), out.len())?;
    for (f, out) in f.chunks(LANES).zip(out.chunks_mut(LANES)) {
        if let (Ok(four), true) = (<&[_; LANES]>::try_from(f), out.len() == LANES) {
            out.copy_from_slice(&four_rotations(four));
            continue;
        }
        for (f, out) in f.iter().zip(out.iter_mut()) {
            *out = super::polar::rotation(f);
        }
    }
    Ok(())
}

/// [`rotations_lanes`] compiled for AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn rotations_avx2(f: &[Matrix3<f64>; LANES]) -> [Option<Matrix3<f64>>; LANES] {
    rotations_lanes(f)
}

#[inline(always)]
fn rotations_lanes(f: &[Matrix3<f64>; LANES]) -> [Option<Matrix3<f64>>; LANES] {
    let (r, converged) = rotation(&build(|i, j, l| f[l][(i, j)]));
    let mut out = [None; LANES];
    for (l, out) in out.iter_mut().enumerate() {
        if converged[l] {
            *out = Some(Matrix3::from_fn(|i, j| r[i][j][l]));
        }
    }
    out
}

/// The polar rotation of each lane's F by [`super::polar`]'s Newton–Schulz iteration, the same
/// operations and stopping rule lane by lane; `false` where that lane's F leaves it (not
/// finite, zero, flat or inverted, ‖E‖ ≥ 1 at an iterate, or not converged in eight
/// iterations): the scalar path decides those.
#[inline(always)]
fn rotation(f: &M) -> (M, [bool; LANES]) {
    let mut usable = [true; LANES];
    for (l, usable) in usable.iter_mut().enumerate() {
        *usable = f.iter().flatten().all(|v| v[l].is_finite());
    }
    // The largest |Fᵢⱼ|, in any order: a maximum of finite values is exact.
    let largest = lanes(|l| f.iter().flatten().fold(0.0_f64, |m, v| m.max(v[l].abs())));
    for (usable, largest) in usable.iter_mut().zip(largest) {
        *usable &= largest > 0.0;
    }
    // Unusable lanes divide by 1 (any finite value: their results are thrown away).
    let divisor = lanes(|l| if usable[l] { largest[l] } else { 1.0 });
    let scaled = build(|i, j, l| f[i][j][l] / divisor[l]);
    let squared = norm_squared(&scaled);
    let norm = lanes(|l| squared[l].sqrt());
    let det = determinant(&scaled);
    for (l, usable) in usable.iter_mut().enumerate() {
        let floor = super::polar::MIN_RELATIVE_DET * norm[l] * norm[l] * norm[l];
        *usable &= !(det[l].is_nan() || det[l] <= floor);
    }
    let start = lanes(|l| (3.0 / squared[l]).sqrt());
    let mut x = build(|i, j, l| scaled[i][j][l] * start[l]);
    // Lanes still iterating; a lane stops when converged (kept usable) or when it fails.
    let mut active = usable;
    let mut converged = [false; LANES];
    for _ in 0..8 {
        if !active.iter().any(|&a| a) {
            break;
        }
        let gram = tr_product(&x, &x);
        let e = build(|i, j, l| gram[i][j][l] - if i == j { 1.0 } else { 0.0 });
        let size_squared = norm_squared(&e);
        let correction = product(&x, &e);
        // A lane takes the step while it iterates and ‖E‖ < 1 (as the scalar loop, which
        // leaves the iteration otherwise); the others keep their X.
        let mut take = [false; LANES];
        for (l, take) in take.iter_mut().enumerate() {
            *take = active[l] && !(size_squared[l].is_nan() || size_squared[l] >= 1.0);
        }
        x = build(|i, j, l| match take[l] {
            true => x[i][j][l] - correction[i][j][l] * 0.5,
            false => x[i][j][l],
        });
        for (l, (converged, active)) in converged.iter_mut().zip(&mut active).enumerate() {
            *converged |= take[l] && size_squared[l] < 1e-16;
            *active = take[l] && !*converged;
        }
    }
    (x, converged)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fe::material::Material;
    use crate::model::Corotational;
    use crate::model::lanes::test_tets::{
        assert_four_match_one_by_one, batch as batch_of_tets, wave,
    };
    use nalgebra::{Rotation3, Unit, Vector3};

    /// Every lane's force and energy are the scalar path's to the bit (compared as bit
    /// patterns: the lanes do the same operations in the same order), for rest tets of many
    /// shapes deformed by rotations up to 3 rad and stretches up to ±30 %, and for inverted,
    /// flat, far-stretched and non-finite tets, which leave the lanes for the scalar path (both
    /// kinds are counted, so neither branch goes untested).
    #[test]
    fn lanes_repeat_the_scalar_force_and_energy_to_the_bit() {
        let model = Corotational::new(&Material::new(1e6, 0.4, 1100.0).unwrap());
        let (mut in_lanes, mut by_scalar) = (0, 0);
        for batch in 0..300 {
            assert_four_match_one_by_one(&model, batch);
            // Which lanes the kernel itself took (the others went to the scalar path).
            let (elements, _, corners) = batch_of_tets(batch);
            let tets = Tets {
                elements: std::array::from_fn(|l| &elements[l]),
                corners: &corners,
            };
            let mut lanes = [(Vector12::zeros(), 0.0); LANES];
            for converged in force_and_energy(&tets, model.lame(), &mut lanes) {
                match converged {
                    true => in_lanes += 1,
                    false => by_scalar += 1,
                }
            }
        }
        assert!(
            in_lanes > 600 && by_scalar > 100,
            "{in_lanes} in lanes, {by_scalar} by the scalar path"
        );
    }

    /// [`rotations_into`] is [`crate::model::polar::rotation`] of each matrix to the bit, in
    /// whole fours (the lanes, or that function where a lane declines) and in the remainder of
    /// a length not a multiple of four; an `out` of another length is a named error.
    #[test]
    fn rotations_into_repeats_the_scalar_rotation_of_each() {
        let f: Vec<Matrix3<f64>> = (0..23)
            .map(|k| {
                let k = k as f64;
                let turn = Rotation3::from_axis_angle(
                    &Unit::new_normalize(Vector3::new(wave(k), wave(k + 0.5), 0.3)),
                    3.0 * wave(k + 1.0),
                );
                let mut stretch = Matrix3::identity()
                    + Matrix3::from_fn(|i, j| 0.2 * wave(k + 2.0 + (3 * i + j) as f64 * 0.1));
                if k as usize % 7 == 3 {
                    stretch[(0, 0)] = -stretch[(0, 0)]; // inverted: the SVD's
                }
                turn.matrix() * stretch
            })
            .collect();
        let mut out = vec![Matrix3::zeros(); f.len()];
        rotations_into(&f, &mut out).unwrap();
        for (k, (f, r)) in f.iter().zip(&out).enumerate() {
            let one = crate::model::polar::rotation(f);
            let bits = |m: &Matrix3<f64>| m.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(r), bits(&one), "matrix {k}");
        }
        let short = rotations_into(&f, &mut out[1..]);
        assert!(
            matches!(short, Err(crate::Error::DimensionMismatch { ref what, .. }) if what == "rotations"),
            "{short:?}"
        );
    }

    /// [`rotations`] gives [`crate::model::polar::rotation`]'s bits wherever it takes a matrix,
    /// and declines the inverted, flat, far-stretched and non-finite ones (which that function
    /// leaves to Higham's iteration or the SVD), over rotated stretches up to ±30 % at scales
    /// from 1e-3 to 1e3.
    #[test]
    fn four_rotations_repeat_the_scalar_rotation_to_the_bit() {
        let (mut taken, mut declined) = (0, 0);
        for batch in 0..200 {
            let f: [Matrix3<f64>; LANES] = std::array::from_fn(|lane| {
                let k = (batch * LANES + lane) as f64;
                let turn = Rotation3::from_axis_angle(
                    &Unit::new_normalize(Vector3::new(wave(k), wave(k + 0.5), 0.3)),
                    3.0 * wave(k + 1.0),
                );
                let mut stretch = Matrix3::identity()
                    + Matrix3::from_fn(|i, j| 0.3 * wave(k + 2.0 + (3 * i + j) as f64 * 0.1));
                match (batch * LANES + lane) % 7 {
                    0 => stretch[(1, 1)] = -stretch[(1, 1)],
                    1 => stretch.set_row(0, &nalgebra::RowVector3::zeros()),
                    2 => stretch[(2, 2)] = 8.0,
                    3 if batch % 5 == 0 => stretch[(0, 1)] = f64::INFINITY,
                    _ => {}
                }
                turn.matrix() * stretch * 10f64.powf(3.0 * wave(k + 3.0))
            });
            for (lane, r) in rotations(&f).into_iter().enumerate() {
                let scalar = crate::model::polar::rotation(&f[lane]);
                match r {
                    Some(r) => {
                        taken += 1;
                        let bits =
                            |m: &Matrix3<f64>| m.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
                        assert_eq!(bits(&r), bits(&scalar), "batch {batch} lane {lane}");
                    }
                    None => declined += 1,
                }
            }
        }
        assert!(
            taken > 400 && declined > 200,
            "{taken} taken, {declined} declined"
        );
    }
}
