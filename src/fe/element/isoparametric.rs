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
                // The mesh proved det G > 1e-12·6V over the whole tet (`mesh::cell`, a
                // Bernstein certificate), so G inverts at every point a rule can ask for; the
                // zeros only keep a non-finite G from panicking.
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

/// Points of the curved stiffness rule ([`stiffness_rule`]).
pub const STIFFNESS_POINTS: usize = 24;

/// The curved stiffness rule: Keast's 24-point degree-6 rule (Keast 1986, all weights
/// positive), as barycentric (L₀…L₃) and weight (fractions of the reference volume, summing
/// to 1): three orbits of four points (b, a, a, a) with a = 0.2146…, 0.0407…, 0.3223…, and
/// twelve points (a, a, b, c) and permutations with a = (3 − √5)/12, b = (1 + √5)/12,
/// c = (5 + √5)/12, weight 27/560 — the rule MFEM takes for degree 6
/// (`IntRules.Get(TETRAHEDRON, 6)`), its default for the curved P2 stiffness, so the two codes
/// integrate a curved tet at the same points.
///
/// Why degree 6: on a curved tet the stiffness integrand det G·|G⁻ᵀ∇_X N|² is rational, so no
/// rule is exact; the degree only sets how small the quadrature error is. Degree 3 is the
/// least that passes the patch test (∫∇Nₐ dV = ∫ cof(J)∇_ξNₐ dξ exactly, cof(J) quadratic and
/// ∇_ξNₐ linear in ξ; the degree-2 rule of straight tets misses an affine field by 6e-5), but
/// on the plate with a hole (validation/SPEED_ACCURACY.md) the 8-point degree-3 rule left the
/// hole-edge stress 18–29 % of MFEM's own error away from MFEM's curved P2, and the 14-point
/// degree-5 rule (Walkington's, MFEM's for degree 5) still 0.38 % (8×4×2 cells) and 0.10 %
/// (12×6×3) of it: in narrow error bands that sliver put MFEM's points first on the
/// speed–accuracy front. At degree 6 tetfem's curved P2 is MFEM's default curved P2, the same
/// discrete problem: the hole's stress equal to 13 digits (2.5e-14 to 1.1e-13 relative, 4×2×1
/// to 24×12×6 cells; `tests/core/curved_tet10.rs`). The 24 points against 14 cost the curved
/// assembly about 1.3× and the whole static solve 4–13 % (`benches/curved_hole.rs`, the table
/// in `docs/src/quadratic.md`).
pub fn stiffness_rule() -> [([f64; 4], f64); STIFFNESS_POINTS] {
    // The (b, a, a, a) orbits' a and weight: the 33-digit values of the Encyclopaedia of
    // Cubature Formulas (Keast's rule), rounded to f64 (checked in 50-digit arithmetic: every
    // monomial of degree ≤ 6 integrated to 3e-33); b = 1 − 3a.
    const VERTEX_ORBITS: [(f64, f64); 3] = [
        (0.214_602_871_259_152_03, 0.039_922_750_258_167_494),
        (0.040_673_958_534_611_35, 0.010_077_211_055_320_643),
        (0.322_337_890_142_275_5, 0.055_357_181_543_654_724),
    ];
    // The (a, a, b, c) orbit in closed form, rounded to f64: a = (3 − √5)/12,
    // b = (1 + √5)/12, c = 1 − 2a − b = (5 + √5)/12, weight 27/560.
    const PAIR_ORBIT: (f64, f64, f64) = (
        0.063_661_001_875_017_53,
        0.269_672_331_458_315_8,
        27.0 / 560.0,
    );
    let mut rule = [([0.0; 4], 0.0); STIFFNESS_POINTS];
    let mut k = 0;
    for (a, w) in VERTEX_ORBITS {
        for corner in 0..4 {
            let mut l = [a; 4];
            l[corner] = 1.0 - 3.0 * a;
            rule[k] = (l, w);
            k += 1;
        }
    }
    let (a, b, w) = PAIR_ORBIT;
    let c = 1.0 - 2.0 * a - b;
    // b and c at every ordered pair of distinct corners, a at the other two: 12 points.
    for p in 0..4 {
        for q in (0..4).filter(|&q| q != p) {
            let mut l = [a; 4];
            (l[p], l[q]) = (b, c);
            rule[k] = (l, w);
            k += 1;
        }
    }
    rule
}
