//! The geometry of a curved (isoparametric) 10-node tet, written as the straight tet of its
//! corners bent by its edge nodes' offsets from their edges' midpoints.
//!
//! The quadratic map of the ten nodes, x(L) = Σₐ Nₐ(L) xₐ, reproduces the corners' affine map
//! X(L) = Σᵢ Lᵢ xᵢ exactly when every edge node is at its midpoint, so in general
//! x = X + Σₖ 4LᵢLⱼ dₖ with dₖ = x₍ᵢⱼ₎ − ½(xᵢ + xⱼ) the offset of the node of edge k = (i, j).
//! Taking the straight tet's position X as the reference coordinate, its gradient is
//! G = ∂x/∂X = I + Σₖ 4 dₖ ⊗ (Lⱼ∇Lᵢ + Lᵢ∇Lⱼ) (∇Lᵢ the straight tet's constant gradients,
//! 1/length): then a shape function's gradient is ∇ₓN = G⁻ᵀ ∇_X N and the volume element
//! dV = det G dV_X. On a straight tet G = I; such tets never come here (they keep the affine
//! path, bit for bit), so the two paths differ only where the geometry does.

use std::ops::Deref;

use nalgebra::{Matrix3, Vector3};

use super::Tet;
use crate::mesh::cell::{EDGES, is_straight};

/// The bend of a curved 10-node tet: its edge nodes' offsets dₖ (length) from their edges'
/// midpoints, in [`EDGES`] order.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CurvedMap {
    offsets: [Vector3<f64>; 6],
}

impl CurvedMap {
    /// The map of the ten node positions `x` (local order), or `None` for a straight-sided tet
    /// (every edge node at its midpoint to [`crate::mesh::cell::MIDPOINT_TOLERANCE`]).
    pub fn of(x: &[Vector3<f64>; 10]) -> Option<Self> {
        if is_straight(x) {
            return None;
        }
        Some(CurvedMap {
            offsets: std::array::from_fn(|k| {
                let (i, j) = EDGES[k];
                x[4 + k] - (x[i] + x[j]) * 0.5
            }),
        })
    }

    /// G = ∂x/∂X (dimensionless) at barycentric `l`, for the straight tet's gradients `dl`.
    pub fn gradient(&self, dl: &[Vector3<f64>; 4], l: &[f64; 4]) -> Matrix3<f64> {
        let mut g = Matrix3::identity();
        for (d, &(i, j)) in self.offsets.iter().zip(EDGES.iter()) {
            g += d * ((dl[i] * l[j] + dl[j] * l[i]) * 4.0).transpose();
        }
        g
    }

    /// x(L) − X(L) = Σₖ 4LᵢLⱼ dₖ (length): how far the curved tet's point lies from the
    /// straight one's.
    pub fn displacement(&self, l: &[f64; 4]) -> Vector3<f64> {
        self.offsets
            .iter()
            .zip(EDGES.iter())
            .map(|(d, &(i, j))| d * (4.0 * l[i] * l[j]))
            .sum()
    }
}

/// One tet's geometry for evaluations at points: the straight tet of its corners (which it
/// dereferences to) and, for a curved 10-node tet, its bend.
#[derive(Debug, Clone, PartialEq)]
pub struct ElementShape {
    corners: Tet,
    map: Option<CurvedMap>,
}

impl Deref for ElementShape {
    type Target = Tet;

    fn deref(&self) -> &Tet {
        &self.corners
    }
}

/// A straight tet's shape (no bend).
impl From<Tet> for ElementShape {
    fn from(corners: Tet) -> Self {
        ElementShape { corners, map: None }
    }
}

impl ElementShape {
    /// The shape of straight corners `corners` bent by `map` (`None`: straight-sided).
    pub fn new(corners: Tet, map: Option<CurvedMap>) -> Self {
        ElementShape { corners, map }
    }

    /// The bend of a curved tet (`None` for a straight one).
    pub fn map(&self) -> Option<&CurvedMap> {
        self.map.as_ref()
    }

    /// The position (length) of barycentric point `l`.
    pub fn position(&self, x: &[Vector3<f64>; 4], l: &[f64; 4]) -> Vector3<f64> {
        let straight = x[0] * l[0] + x[1] * l[1] + x[2] * l[2] + x[3] * l[3];
        match &self.map {
            None => straight,
            Some(map) => straight + map.displacement(l),
        }
    }

    /// dV / dV_X = det G at `l` (1 for a straight tet): the curved tet's volume element over
    /// the straight one's.
    pub fn volume_ratio(&self, l: &[f64; 4]) -> f64 {
        match &self.map {
            None => 1.0,
            Some(map) => map
                .gradient(self.corners.shape_gradients(), l)
                .determinant(),
        }
    }

    /// Volume (length³): the straight tet's, or for a curved one V_X·∫det G by the degree-5
    /// rule (det G is a cubic in L, integrated exactly).
    pub fn volume(&self) -> f64 {
        match &self.map {
            None => self.corners.volume(),
            Some(_) => {
                curved_rule()
                    .iter()
                    .map(|q| q.1 * self.volume_ratio(&q.0))
                    .sum::<f64>()
                    * self.corners.volume()
            }
        }
    }

    /// Gradients ∇ₓN (1/length) of a curved tet's shape functions at `l`, from their straight
    /// gradients `straight` (∇_X N): G⁻ᵀ∇_X N; unchanged on a straight tet.
    pub fn curve_gradients<const N: usize>(
        &self,
        l: &[f64; 4],
        straight: [Vector3<f64>; N],
    ) -> [Vector3<f64>; N] {
        match &self.map {
            None => straight,
            Some(map) => {
                let g = map.gradient(self.corners.shape_gradients(), l);
                // Invertible: the mesh checked det G > 0 at the nodes and the rule's points.
                let inverse_t = g.try_inverse().unwrap_or_else(Matrix3::zeros).transpose();
                straight.map(|v| inverse_t * v)
            }
        }
    }
}

/// The degree-5 rule ([`crate::fe::quadrature::tet_rule`]) as barycentric (L₀…L₃) and weight
/// (fractions of the volume), built once.
pub fn curved_rule() -> &'static [([f64; 4], f64)] {
    static RULE: std::sync::OnceLock<Vec<([f64; 4], f64)>> = std::sync::OnceLock::new();
    RULE.get_or_init(|| {
        crate::fe::quadrature::tet_rule()
            .iter()
            .map(|q| {
                let b = q.barycentric;
                ([1.0 - b.x - b.y - b.z, b.x, b.y, b.z], q.weight)
            })
            .collect()
    })
}

/// Gauss–Jacobi nodes and weights on [0, 1], 2 points, for the weights (1 − t)², (1 − t), 1.
const JACOBI: [([f64; 2], [f64; 2]); 3] = [
    (
        [0.122_514_822_655_441_5, 0.544_151_844_011_225_3],
        [0.232_547_451_253_508, 0.100_785_882_079_825_32],
    ),
    (
        [0.155_051_025_721_682_17, 0.644_948_974_278_317_9],
        [0.318_041_381_743_977_17, 0.181_958_618_256_022_83],
    ),
    (
        [0.211_324_865_405_187_13, 0.788_675_134_594_812_9],
        [0.5, 0.5],
    ),
];

/// The curved stiffness rule: 8 points, barycentric (L₀…L₃) and weight (fractions of the
/// reference volume, summing to 1), exact for degree 3, all weights positive — the collapsed
/// product b₁ = u, b₂ = v(1 − u), b₃ = w(1 − u)(1 − v) of 2-point Gauss–Jacobi rules for the
/// collapse's weights (1 − u)² and (1 − v).
///
/// Why degree 3: on a curved tet the stiffness integrand is rational, but the patch test needs
/// only ∫∇Nₐ dV = ∫ cof(J)∇_ξNₐ dξ exactly (a constant stress must give zero force on every
/// interior node), and cof(J) is quadratic and ∇_ξNₐ linear in ξ: degree 3. The degree-2 rule
/// of straight tets misses it (measured: a 6e-5 relative error of an affine field).
pub fn stiffness_rule() -> [([f64; 4], f64); 8] {
    let mut rule = [([0.0; 4], 0.0); 8];
    let mut k = 0;
    for i in 0..2 {
        for j in 0..2 {
            for m in 0..2 {
                let (u, v, w) = (JACOBI[0].0[i], JACOBI[1].0[j], JACOBI[2].0[m]);
                let b = [u, v * (1.0 - u), w * (1.0 - u) * (1.0 - v)];
                rule[k] = (
                    [1.0 - b[0] - b[1] - b[2], b[0], b[1], b[2]],
                    6.0 * JACOBI[0].1[i] * JACOBI[1].1[j] * JACOBI[2].1[m],
                );
                k += 1;
            }
        }
    }
    rule
}
