//! Rotation of the polar decomposition, robust to degenerate and inverted elements.

use nalgebra::Matrix3;

/// The rotation R (det R = +1) closest to F: from the SVD F = U·Σ·Vᵀ, R = U·Vᵀ, with the sign of
/// the singular direction of the smallest singular value flipped when det(U·Vᵀ) < 0, so that an
/// inverted element gets a proper rotation (and a negative stretch) rather than a reflection.
/// A non-finite or zero F returns the identity rather than NaN.
///
/// A positively oriented F (det F > 0, the case of every tet that is not inverted) takes an
/// iteration instead, several times faster than the SVD and the same polar factor to
/// round-off: the inverse-free Newton–Schulz iteration when F's stretches are near each other
/// (every tet of a corotational body at moderate strain), Higham's scaled Newton iteration
/// otherwise; the SVD remains for inverted, flat and badly conditioned ones.
///
/// R is invariant under F → s·F (s > 0), so F is divided by its largest entry first: the SVD
/// then sees entries of order one whatever the scale of F (unscaled, an F below ~1e-154 squares
/// to zero inside the SVD and comes back as the identity instead of its polar factor).
pub fn rotation(f: &Matrix3<f64>) -> Matrix3<f64> {
    // f64::max compiles to one instruction where `amax` branches per entry.
    let scale = f.iter().fold(0.0_f64, |largest, v| largest.max(v.abs()));
    if !(f.iter().all(|v| v.is_finite()) && scale > 0.0) {
        return Matrix3::identity();
    }
    let f = f / scale;
    if let Some(r) = polar_by_schulz(&f).or_else(|| polar_by_iteration(&f)) {
        return r;
    }
    let svd = f.svd(true, true);
    let (Some(mut u), Some(v_t)) = (svd.u, svd.v_t) else {
        return Matrix3::identity();
    };
    if (u * v_t).determinant() < 0.0 {
        let smallest = (0..3)
            .min_by(|&a, &b| svd.singular_values[a].total_cmp(&svd.singular_values[b]))
            .unwrap_or(2);
        for row in 0..3 {
            u[(row, smallest)] = -u[(row, smallest)];
        }
    }
    u * v_t
}

/// Below this det/‖F‖³ (‖F‖ Frobenius) both iterations give way to the SVD: their inverses or
/// products lose the digits it keeps.
pub(crate) const MIN_RELATIVE_DET: f64 = 1e-6;

/// Whether `f` (of Frobenius norm `norm`) is inverted, flat or NaN: det F ≤ 1e-6·‖F‖³, which
/// neither iteration takes.
fn too_flat(f: &Matrix3<f64>, norm: f64) -> bool {
    let det = f.determinant();
    det.is_nan() || det <= MIN_RELATIVE_DET * norm * norm * norm
}

/// The polar rotation of `f` (entries of order one) by the Newton–Schulz iteration
/// Xₖ₊₁ = Xₖ·(I − Eₖ/2), Eₖ = XₖᵀXₖ − I, from X₀ = F·√3/‖F‖ (its singular values' root mean
/// square 1; Higham, *Functions of Matrices*, 2008, §8.3). Each singular value goes
/// σ ↦ σ(3 − σ²)/2, so near 1 the error δ = σ − 1 becomes −(3/2)δ² + O(δ³): from the strains of
/// a corotational tet (δ ≲ 0.1) four iterations reach round-off, each two 3×3 products and no
/// inverse or square root. `None` (the caller takes Higham's iteration or the SVD) when
/// det `f` ≤ 0, when ‖E‖ ≥ 1 at an iterate (σ² ≥ 2 is possible there), or when ‖E‖ is not
/// below 1e-8 within eight iterations (stretches far apart converge only linearly).
fn polar_by_schulz(f: &Matrix3<f64>) -> Option<Matrix3<f64>> {
    let norm_squared = f.norm_squared();
    if too_flat(f, norm_squared.sqrt()) {
        return None;
    }
    let mut x = f * (3.0 / norm_squared).sqrt();
    for _ in 0..8 {
        let e = x.tr_mul(&x) - Matrix3::identity();
        // The Frobenius norm bounds the spectral one, and sums without a branch.
        let size_squared = e.norm_squared();
        // Far from I the step can overshoot past √3 (σ(3 − σ²)/2 < 0 for σ > √3): leave it
        // to Higham's iteration, which converges from any nonsingular F.
        if size_squared.is_nan() || size_squared >= 1.0 {
            return None;
        }
        x -= x * e * 0.5;
        // ‖E‖ < 1e-8 leaves δ ≈ (3/8)‖E‖² < 4e-17 after this step: round-off.
        if size_squared < 1e-16 {
            return Some(x);
        }
    }
    None
}

/// The polar rotation of `f` (det `f` > 0, entries of order one) by Higham's scaled Newton
/// iteration Xₖ₊₁ = ½(γₖ·Xₖ + Xₖ⁻ᵀ/γₖ), γₖ = (‖Xₖ⁻¹‖/‖Xₖ‖)^½ (N. J. Higham, "Computing the
/// polar decomposition — with applications", 1986): it converges quadratically to R from any
/// nonsingular F, in four or five iterations from the small strains of a corotational tet.
/// `None` (the caller takes the SVD) when det `f` ≤ 0 or it has not converged in 20 iterations
/// (a nearly flat tet).
fn polar_by_iteration(f: &Matrix3<f64>) -> Option<Matrix3<f64>> {
    if too_flat(f, f.norm()) {
        return None;
    }
    let mut x = *f;
    let mut scaled = true;
    for _ in 0..20 {
        let inverse_transpose = x.try_inverse()?.transpose();
        // The scaling speeds up the first iterations; near R (γ → 1) it only adds round-off.
        let gamma = match scaled {
            true => (inverse_transpose.norm() / x.norm()).sqrt(),
            false => 1.0,
        };
        let next = (x * gamma + inverse_transpose / gamma) * 0.5;
        let change = (next - x).norm();
        x = next;
        // ‖R‖ = √3: a change below 1e-9 leaves an error of about its square after one more
        // iteration, below round-off.
        if change < 1e-9 {
            let inverse_transpose = x.try_inverse()?.transpose();
            return Some((x + inverse_transpose) * 0.5);
        }
        if change < 1e-3 {
            scaled = false;
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Rotation3, Vector3};

    /// The iteration and the SVD give the same R for stretched, sheared and rotated F, to a
    /// few ulps of its entries (both are backward stable; 1e-14 allows their round-off).
    #[test]
    fn iteration_agrees_with_the_svd() {
        let stretches = [
            Matrix3::identity(),
            Matrix3::new(1.01, 0.002, 0.0, 0.0, 0.99, 0.003, 0.001, 0.0, 1.02),
            Matrix3::new(2.0, 0.5, 0.1, 0.0, 0.4, 0.3, 0.2, 0.0, 1.5),
            Matrix3::new(1.0, 3.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0),
        ];
        for (k, stretch) in stretches.iter().enumerate() {
            let turn = Rotation3::from_axis_angle(
                &nalgebra::Unit::new_normalize(Vector3::new(1.0, 2.0 - k as f64, 0.5)),
                0.3 + 0.7 * k as f64,
            );
            let f = turn.matrix() * stretch;
            let by_iteration = polar_by_iteration(&(f / f.amax())).expect("det > 0");
            let svd = f.svd(true, true);
            let by_svd = svd.u.unwrap() * svd.v_t.unwrap();
            assert!(
                (by_iteration - by_svd).amax() < 1e-14,
                "F #{k}: {by_iteration} against {by_svd}"
            );
            assert!((by_iteration.determinant() - 1.0).abs() < 1e-14);
        }
    }

    /// Newton–Schulz gives the SVD's R for rotated stretches up to 30 % apart (its range in a
    /// corotational body), to 1e-14 as above, and leaves stretches 5× apart to Higham's
    /// iteration.
    #[test]
    fn schulz_agrees_with_the_svd_and_declines_far_apart_stretches() {
        let mut checked = 0;
        for k in 0..200 {
            let t = k as f64;
            // Deterministic spread of stretches (±30 %), shears and turns up to 3 rad.
            let stretch = Matrix3::new(
                1.0 + 0.3 * (1.3 * t).sin(),
                0.1 * (0.7 * t).cos(),
                0.05 * (2.1 * t).sin(),
                0.0,
                1.0 + 0.3 * (0.9 * t).cos(),
                0.1 * (1.7 * t).sin(),
                0.0,
                0.0,
                1.0 - 0.3 * (0.4 * t).sin(),
            );
            let turn = Rotation3::from_axis_angle(
                &nalgebra::Unit::new_normalize(Vector3::new(t.cos(), t.sin(), 0.3)),
                3.0 * (0.37 * t).sin(),
            );
            let f = (turn.matrix() * stretch) * (1.0 + t);
            let scaled = f / f.amax();
            let Some(by_schulz) = polar_by_schulz(&scaled) else {
                continue;
            };
            checked += 1;
            let svd = f.svd(true, true);
            let by_svd = svd.u.unwrap() * svd.v_t.unwrap();
            assert!(
                (by_schulz - by_svd).amax() < 1e-14,
                "F #{k}: {by_schulz} against {by_svd}"
            );
            assert!((rotation(&f) - by_svd).amax() < 1e-14);
        }
        // Stretches within ±30 % keep ‖XᵀX − I‖ < 1 from the start: every one is iterated.
        assert_eq!(checked, 200, "only {checked} of 200 took Newton–Schulz");
        let far_apart = Matrix3::new(5.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0);
        assert!(polar_by_schulz(&far_apart).is_none());
        assert!((rotation(&far_apart) - Matrix3::identity()).amax() < 1e-14);
    }

    /// An inverted F is left to the SVD (its proper rotation needs the flipped direction).
    #[test]
    fn inverted_f_is_not_iterated() {
        let f = Matrix3::new(-1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0);
        assert!(polar_by_iteration(&f).is_none());
        assert!(polar_by_schulz(&f).is_none());
        assert!((rotation(&f).determinant() - 1.0).abs() < 1e-14);
    }
}
