//! Quadrature on the reference tetrahedron by the collapsed (Duffy / Stroud conical) product of
//! Gauss–Legendre rules: exact for polynomials of degree ≤ 2n − 3 with n points per direction
//! (the collapse adds degree 2 through its Jacobian), all weights positive.

use nalgebra::Vector3;

use crate::fe::element::Tet;

/// Gauss–Legendre nodes and weights on [−1, 1], 4 points (exact to degree 7).
const GAUSS_NODES: [f64; 4] = [
    -0.861_136_311_594_052_6,
    -0.339_981_043_584_856_3,
    0.339_981_043_584_856_3,
    0.861_136_311_594_052_6,
];
const GAUSS_WEIGHTS: [f64; 4] = [
    0.347_854_845_137_453_9,
    0.652_145_154_862_546_1,
    0.652_145_154_862_546_1,
    0.347_854_845_137_453_9,
];

/// A quadrature point in barycentric coordinates (b₁, b₂, b₃; b₀ = 1 − b₁ − b₂ − b₃) with its
/// weight as a fraction of the tet's volume (the weights sum to 1).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct QuadraturePoint {
    /// Barycentric coordinates b₁, b₂, b₃.
    pub barycentric: Vector3<f64>,
    /// Weight relative to the volume.
    pub weight: f64,
}

/// The 64-point collapsed Gauss rule, exact for polynomials of degree ≤ 5 on any tet.
pub fn tet_rule() -> Vec<QuadraturePoint> {
    let mut points = Vec::with_capacity(64);
    for (i, &xu) in GAUSS_NODES.iter().enumerate() {
        let u = 0.5 * (xu + 1.0);
        for (j, &xv) in GAUSS_NODES.iter().enumerate() {
            let v = 0.5 * (xv + 1.0);
            for (k, &xw) in GAUSS_NODES.iter().enumerate() {
                let w = 0.5 * (xw + 1.0);
                // b₁ = u, b₂ = v(1−u), b₃ = w(1−u)(1−v); dV_ref = (1−u)²(1−v) du dv dw, and the
                // reference tet has volume 1/6 (hence the factor 6 to make weights sum to 1).
                let jacobian = (1.0 - u) * (1.0 - u) * (1.0 - v);
                let weight =
                    6.0 * jacobian * GAUSS_WEIGHTS[i] * GAUSS_WEIGHTS[j] * GAUSS_WEIGHTS[k] / 8.0;
                points.push(QuadraturePoint {
                    barycentric: Vector3::new(u, v * (1.0 - u), w * (1.0 - u) * (1.0 - v)),
                    weight,
                });
            }
        }
    }
    points
}

/// The four linear shape-function values N₀…N₃ at barycentric point `b`.
pub fn shape_values(b: &Vector3<f64>) -> [f64; 4] {
    [1.0 - b.x - b.y - b.z, b.x, b.y, b.z]
}

/// ∫_tet f dV by [`tet_rule`], for the tet with rest positions `x` and element data `tet`.
pub fn integrate(
    tet: &Tet,
    x: &[Vector3<f64>; 4],
    rule: &[QuadraturePoint],
    f: impl Fn(&Vector3<f64>, &[f64; 4]) -> f64,
) -> f64 {
    rule.iter()
        .map(|q| {
            let n = shape_values(&q.barycentric);
            let p = x[0] * n[0] + x[1] * n[1] + x[2] * n[2] + x[3] * n[3];
            q.weight * f(&p, &n)
        })
        .sum::<f64>()
        * tet.volume()
}
