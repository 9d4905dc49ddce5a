//! Geometry of one tetrahedron from its four corner positions: volume, shape matrix, quality
//! and the local faces. The mesh checks and the elements ([`crate::fe::element`], which re-exports
//! these) both use it.

use nalgebra::{Matrix3, Vector3};

/// The four faces of a tet as local node triples, each listed with the node opposite to it.
pub const FACES: [([usize; 3], usize); 4] = [
    ([0, 1, 2], 3),
    ([0, 1, 3], 2),
    ([0, 2, 3], 1),
    ([1, 2, 3], 0),
];

/// Rest (or deformed) shape matrix [x₁−x₀ x₂−x₀ x₃−x₀].
#[inline]
pub fn rest_shape_matrix(x: &[Vector3<f64>; 4]) -> Matrix3<f64> {
    Matrix3::from_columns(&[x[1] - x[0], x[2] - x[0], x[3] - x[0]])
}

/// Signed volume det[x₁−x₀ x₂−x₀ x₃−x₀]/6 (positive for a positively oriented tet).
pub fn signed_volume(x: &[Vector3<f64>; 4]) -> f64 {
    rest_shape_matrix(x).determinant() / 6.0
}

/// Shape quality 6√2·|V|/l_max³: 1 for a regular tet, 0 for a flat one, scale-free.
pub fn shape_quality(x: &[Vector3<f64>; 4]) -> f64 {
    let mut longest_sq: f64 = 0.0;
    for i in 0..4 {
        for j in i + 1..4 {
            longest_sq = longest_sq.max((x[j] - x[i]).norm_squared());
        }
    }
    let longest = longest_sq.sqrt();
    6.0 * std::f64::consts::SQRT_2 * signed_volume(x).abs() / (longest * longest * longest)
}
