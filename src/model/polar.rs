//! Rotation of the polar decomposition, robust to degenerate and inverted elements.

use nalgebra::Matrix3;

/// The rotation R (det R = +1) closest to F: from the SVD F = U·Σ·Vᵀ, R = U·Vᵀ, with the sign of
/// the singular direction of the smallest singular value flipped when det(U·Vᵀ) < 0, so that an
/// inverted element gets a proper rotation (and a negative stretch) rather than a reflection.
/// A non-finite or zero F returns the identity rather than NaN.
///
/// R is invariant under F → s·F (s > 0), so F is divided by its largest entry first: the SVD
/// then sees entries of order one whatever the scale of F (unscaled, an F below ~1e-154 squares
/// to zero inside the SVD and comes back as the identity instead of its polar factor).
pub fn rotation(f: &Matrix3<f64>) -> Matrix3<f64> {
    let scale = f.amax();
    if !(f.iter().all(|v| v.is_finite()) && scale > 0.0) {
        return Matrix3::identity();
    }
    let svd = (f / scale).svd(true, true);
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
