//! The quadratic 10-node tet (P2): four corners and one node per edge, straight-sided or
//! curved (isoparametric).
//!
//! In barycentric coordinates L₀…L₃ of the corners the shape functions are
//! Nᵢ = Lᵢ(2Lᵢ − 1) at corner i and N₍ᵢⱼ₎ = 4LᵢLⱼ at the node of edge (i, j). Local node order
//! is VTK's (`VTK_QUADRATIC_TETRA`): corners 0–3, then the edges (0,1), (1,2), (0,2), (0,3),
//! (1,3), (2,3) as nodes 4–9. Where the edge nodes sit at their edges' midpoints the map from
//! the reference tet is the corners' affine one and every ∇Lᵢ is constant: the displacement is
//! quadratic and the strain linear inside the tet (the formulas below, bit for bit).
//!
//! Curved tets (an edge node off its midpoint, as on a circle): the geometry is mapped by the
//! same quadratic shape functions ([`super::isoparametric`]), so ∇N = G⁻ᵀ∇_X N and
//! dV = det G dV_X vary inside the tet and the integrands are rational, not polynomial. The
//! stiffness (and the force models) use Keast's 24-point degree-6 rule [`stiffness_rule`]
//! with weights V_X·w·det G(ξ_q): degree 2 (2k − 2 for P_k) keeps the optimal energy-norm
//! rate (Ciarlet & Raviart 1972), the patch test needs ∫cof(J)∇_ξNₐ dξ exact, a cubic, and
//! degree 6 is MFEM's default for this integrand, so tetfem's curved P2 is MFEM's to 13 digits
//! (the rule's doc says what degrees 3 and 5 left). The mixed Taylor–Hood element keeps the
//! 4-point rule's points ([`Tet10Rest::gradients`], weighted by det G) for its pressure
//! coupling. The mass ∫ρNᵢNⱼ dV, the shape integrals ∫Nᵢ dV (body loads) and the volume go by
//! the 64-point degree-5 rule (the mass needs more than 4 points to be non-singular; det G is
//! a cubic, so the volume is exact).
//! The lumped mass keeps the straight HRZ fractions of the curved volume.
//!
//! - Stiffness: ∇Nᵢ·∇Nⱼ is quadratic, so the 4-point degree-2 rule integrates it exactly.
//! - Consistent mass: ∫NᵢNⱼ dV = V·m̂ᵢⱼ in closed form (see [`REFERENCE_MASS`]).
//! - Lumped mass: row-sum lumping would give each corner −ρV/20, a negative mass; this uses
//!   HRZ instead (the consistent diagonal scaled to the element's mass): ρV/36 per corner and
//!   4ρV/27 per edge node, all positive.
//! - Consistent loads: a uniform body force gives −bV/20 to each corner and bV/5 to each edge
//!   node (∫Nᵢ dV); a uniform traction on a 6-node face gives its corners nothing and each edge
//!   node tA/3.

use nalgebra::{Matrix3, Vector3};

use super::isoparametric::{ElementShape, STIFFNESS_POINTS, curved_rule, stiffness_rule};
use super::{ElementType, Tet, Weights};
use crate::base::error::Result;
use crate::fe::material::Material;
use crate::mesh::TetMesh;

pub use crate::mesh::cell::{EDGES, MIDPOINT_TOLERANCE, Tet10};

/// The degree-2 rule: 4 points at barycentric (α, β, β, β) and its permutations, weights V/4.
const RULE_ALPHA: f64 = 0.585_410_196_624_968_5;
const RULE_BETA: f64 = 0.138_196_601_125_010_5;

/// ∫NᵢNⱼ dV / V on the straight-sided 10-node tet, ×420: corner–same corner 6, corner–other
/// corner 1, corner–edge node on its edge −4, off its edge −6, edge node–itself 32, edges
/// sharing a corner 16, opposite edges 8.
pub const REFERENCE_MASS: [[f64; 10]; 10] = reference_mass();

const fn reference_mass() -> [[f64; 10]; 10] {
    let mut m = [[0.0; 10]; 10];
    let mut i = 0;
    while i < 10 {
        let mut j = 0;
        while j < 10 {
            m[i][j] = match (i < 4, j < 4) {
                (true, true) => {
                    if i == j {
                        6.0
                    } else {
                        1.0
                    }
                }
                (true, false) | (false, true) => {
                    let (corner, edge) = if i < 4 { (i, j - 4) } else { (j, i - 4) };
                    if EDGES[edge].0 == corner || EDGES[edge].1 == corner {
                        -4.0
                    } else {
                        -6.0
                    }
                }
                (false, false) => {
                    let (e, f) = (EDGES[i - 4], EDGES[j - 4]);
                    let shared = (e.0 == f.0) as u8
                        + (e.0 == f.1) as u8
                        + (e.1 == f.0) as u8
                        + (e.1 == f.1) as u8;
                    match shared {
                        2 => 32.0,
                        1 => 16.0,
                        _ => 8.0,
                    }
                }
            } / 420.0;
            j += 1;
        }
        i += 1;
    }
    m
}

/// Rest data of one 10-node tet: its volume, the shape-function gradients at the four
/// quadrature points (1/length) and their weights (length³), and for a curved tet its mass and
/// shape integrals.
#[derive(Debug, Clone, PartialEq)]
pub struct Tet10Rest {
    volume: f64,
    gradients: [[Vector3<f64>; 10]; 4],
    weights: [f64; 4],
    curved: Option<Box<CurvedIntegrals>>,
}

/// What a curved tet integrates once: ∫NᵢNⱼ dV and ∫Nᵢ dV (length³), and its stiffness
/// rule's gradients (1/length) and weights (length³) at the points of [`stiffness_rule`].
#[derive(Debug, Clone, PartialEq)]
struct CurvedIntegrals {
    mass: [[f64; 10]; 10],
    shape: [f64; 10],
    gradients: [[Vector3<f64>; 10]; STIFFNESS_POINTS],
    weights: [f64; STIFFNESS_POINTS],
}

/// Barycentric coordinates of the degree-2 rule's point `q`.
fn rule_point(q: usize) -> [f64; 4] {
    std::array::from_fn(|i| if i == q { RULE_ALPHA } else { RULE_BETA })
}

impl Tet10Rest {
    /// From the straight-sided tet of its corners (the linear element's ∇Lᵢ).
    pub fn new(corners: &Tet) -> Self {
        let dl = corners.shape_gradients();
        let mut gradients = [[Vector3::zeros(); 10]; 4];
        for (q, point) in gradients.iter_mut().enumerate() {
            *point = shape_gradients(&rule_point(q), dl);
        }
        let volume = corners.volume();
        Tet10Rest {
            volume,
            gradients,
            weights: [volume / 4.0; 4],
            curved: None,
        }
    }

    /// From a tet's shape: the straight path ([`Tet10Rest::new`]) when it is straight-sided,
    /// else the isoparametric one (gradients G⁻ᵀ∇_X N and weights V_X·w·det G at the points
    /// of the degree-2 rule and of the degree-6 [`stiffness_rule`]; mass, shape integrals and
    /// volume by the degree-5 rule).
    pub fn of_shape(shape: &ElementShape) -> Self {
        if shape.map().is_none() {
            return Tet10Rest::new(shape);
        }
        let (dl, straight_volume) = (shape.shape_gradients(), Tet::volume(shape));
        let mut gradients = [[Vector3::zeros(); 10]; 4];
        let mut weights = [0.0; 4];
        for q in 0..4 {
            let l = rule_point(q);
            gradients[q] = shape.curve_gradients(&l, shape_gradients(&l, dl));
            weights[q] = straight_volume / 4.0 * shape.volume_ratio(&l);
        }
        let mut integrals = CurvedIntegrals {
            mass: [[0.0; 10]; 10],
            shape: [0.0; 10],
            gradients: [[Vector3::zeros(); 10]; STIFFNESS_POINTS],
            weights: [0.0; STIFFNESS_POINTS],
        };
        for (q, (l, w)) in stiffness_rule().iter().enumerate() {
            integrals.gradients[q] = shape.curve_gradients(l, shape_gradients(l, dl));
            integrals.weights[q] = w * straight_volume * shape.volume_ratio(l);
        }
        let mut volume = 0.0;
        for (l, w) in curved_rule() {
            let dv = w * straight_volume * shape.volume_ratio(l);
            let n = shape_values(l);
            volume += dv;
            for i in 0..10 {
                integrals.shape[i] += dv * n[i];
                for j in 0..10 {
                    integrals.mass[i][j] += dv * n[i] * n[j];
                }
            }
        }
        Tet10Rest {
            volume,
            gradients,
            weights,
            curved: Some(Box::new(integrals)),
        }
    }

    /// Whether the tet is curved (isoparametric).
    pub fn is_curved(&self) -> bool {
        self.curved.is_some()
    }

    /// Quadrature weights (length³) of the four points of [`Tet10Rest::gradients`]: V/4 each
    /// on a straight tet, V_X/4·det G(ξ_q) on a curved one.
    pub fn weights(&self) -> &[f64; 4] {
        &self.weights
    }

    /// The stiffness rule's shape-function gradients (1/length) and weights (length³): the
    /// degree-2 rule's four points on a straight tet ([`Tet10Rest::gradients`],
    /// [`Tet10Rest::weights`]), the degree-6 rule's twenty-four on a curved one (see
    /// [`stiffness_rule`] for why).
    pub fn points(&self) -> (&[[Vector3<f64>; 10]], &[f64]) {
        match &self.curved {
            None => (&self.gradients, &self.weights),
            Some(c) => (&c.gradients, &c.weights),
        }
    }

    /// ∫Nᵢ dV (length³): −V/20 per corner and V/5 per edge node on a straight tet.
    pub fn shape_integral(&self, i: usize) -> f64 {
        match &self.curved {
            None => Tet10::VOLUME_LOAD.share(i, self.volume),
            Some(c) => c.shape[i],
        }
    }

    /// Rest volume (length³).
    pub fn volume(&self) -> f64 {
        self.volume
    }

    /// Shape-function gradients ∇Nₐ (1/length) at the four points of the degree-2 rule, whose
    /// weights are [`Tet10Rest::weights`] (V/4 each on a straight tet): `gradients()[q][a]`.
    pub fn gradients(&self) -> &[[Vector3<f64>; 10]; 4] {
        &self.gradients
    }

    /// Linear strain ε = ½(∇u + ∇uᵀ) at quadrature point `q` (0–3) for the node-major
    /// displacement `u` (30 values).
    pub fn strain_at(&self, q: usize, u: &[f64]) -> Matrix3<f64> {
        strain_of(&self.gradients[q], u)
    }
}

/// ε = ½(∇u + ∇uᵀ) from one point's shape-function gradients and the displacement `u`.
fn strain_of(gradients: &[Vector3<f64>; 10], u: &[f64]) -> Matrix3<f64> {
    let mut grad = Matrix3::zeros();
    for (i, g) in gradients.iter().enumerate() {
        grad += Vector3::new(u[3 * i], u[3 * i + 1], u[3 * i + 2]) * g.transpose();
    }
    (grad + grad.transpose()) * 0.5
}

/// σ = λ tr(ε) I + 2με.
fn hooke(material: &Material, strain: &Matrix3<f64>) -> Matrix3<f64> {
    Matrix3::identity() * (material.lame_lambda() * strain.trace())
        + strain * (2.0 * material.shear_modulus())
}

/// Shape-function values at barycentric coordinates `l` (L₀…L₃, summing to 1).
pub fn shape_values(l: &[f64; 4]) -> [f64; 10] {
    let mut n = [0.0; 10];
    for i in 0..4 {
        n[i] = l[i] * (2.0 * l[i] - 1.0);
    }
    for (k, &(i, j)) in EDGES.iter().enumerate() {
        n[4 + k] = 4.0 * l[i] * l[j];
    }
    n
}

/// Shape-function gradients at barycentric coordinates `l`, from the corners' ∇Lᵢ:
/// ∇Nᵢ = (4Lᵢ − 1)∇Lᵢ, ∇N₍ᵢⱼ₎ = 4(Lⱼ∇Lᵢ + Lᵢ∇Lⱼ).
pub fn shape_gradients(l: &[f64; 4], dl: &[Vector3<f64>; 4]) -> [Vector3<f64>; 10] {
    let mut g = [Vector3::zeros(); 10];
    for i in 0..4 {
        g[i] = dl[i] * (4.0 * l[i] - 1.0);
    }
    for (k, &(i, j)) in EDGES.iter().enumerate() {
        g[4 + k] = (dl[i] * l[j] + dl[j] * l[i]) * 4.0;
    }
    g
}

impl ElementType for Tet10 {
    type Rest = Tet10Rest;

    /// HRZ: ρV/36 per corner, 4ρV/27 per edge node (×108: 3 and 16).
    const LUMPED_MASS: Weights = Weights {
        numerators: &[3.0, 3.0, 3.0, 3.0, 16.0, 16.0, 16.0, 16.0, 16.0, 16.0],
        denominator: 108.0,
    };
    /// ∫Nᵢ dV: −V/20 per corner, V/5 per edge node.
    const VOLUME_LOAD: Weights = Weights {
        numerators: &[-1.0, -1.0, -1.0, -1.0, 4.0, 4.0, 4.0, 4.0, 4.0, 4.0],
        denominator: 20.0,
    };
    /// ∫Nᵢ dA on a 6-node triangle: 0 per corner, A/3 per edge node.
    const FACE_LOAD: Weights = Weights {
        numerators: &[0.0, 0.0, 0.0, 1.0, 1.0, 1.0],
        denominator: 3.0,
    };

    fn rest(mesh: &TetMesh<Tet10>, t: usize) -> Tet10Rest {
        Tet10Rest::of_shape(&super::pointwise::corners_of(mesh, t))
    }

    fn volume(rest: &Tet10Rest) -> f64 {
        rest.volume
    }

    fn stiffness_block(
        rest: &Tet10Rest,
        lame_lambda: f64,
        shear_modulus: f64,
        i: usize,
        j: usize,
    ) -> [[f64; 3]; 3] {
        let mut k = [[0.0; 3]; 3];
        let (gradients, weights) = rest.points();
        for (point, &weight) in gradients.iter().zip(weights) {
            let (lambda, mu) = (lame_lambda * weight, shear_modulus * weight);
            let (gi, gj) = (&point[i], &point[j]);
            let shear = mu * gi.dot(gj);
            for a in 0..3 {
                for b in 0..3 {
                    k[a][b] += gi[b] * gj[a] * lambda + gj[b] * gi[a] * mu;
                }
                k[a][a] += shear;
            }
        }
        k
    }

    fn mass_coefficient(rest: &Tet10Rest, density: f64, i: usize, j: usize) -> f64 {
        match &rest.curved {
            None => density * rest.volume * REFERENCE_MASS[i][j],
            Some(c) => density * c.mass[i][j],
        }
    }

    fn shape_integral(rest: &Tet10Rest, i: usize) -> f64 {
        rest.shape_integral(i)
    }

    /// The strain is linear, so its volume average is the mean of the degree-2 rule's points
    /// (on a curved tet: their weighted mean, the rule's approximation).
    fn mean_stress(rest: &Tet10Rest, material: &Material, u: &[f64]) -> Matrix3<f64> {
        hooke(material, &Self::mean_strain(rest, u))
    }

    /// The strain is linear, so its volume average is the mean of the degree-2 rule's points
    /// (on a curved tet: their weighted mean, the rule's approximation).
    fn mean_strain(rest: &Tet10Rest, u: &[f64]) -> Matrix3<f64> {
        if let Some(c) = &rest.curved {
            let total: f64 = c.weights.iter().sum();
            return (c.gradients.iter().zip(&c.weights))
                .map(|(g, w)| strain_of(g, u) * *w)
                .sum::<Matrix3<f64>>()
                / total;
        }
        (0..4).map(|q| rest.strain_at(q, u)).sum::<Matrix3<f64>>() / 4.0
    }

    /// ½σ:ε is quadratic: the degree-2 rule integrates it exactly (on a curved tet Σ_q w_q ½σ:ε
    /// over V, so that times V it is still ½uᵀKₑu of the stiffness).
    fn strain_energy_density(rest: &Tet10Rest, material: &Material, u: &[f64]) -> f64 {
        let density = |gradients: &[Vector3<f64>; 10]| {
            let strain = strain_of(gradients, u);
            0.5 * hooke(material, &strain).component_mul(&strain).sum()
        };
        if let Some(c) = &rest.curved {
            return (c.gradients.iter().zip(&c.weights))
                .map(|(g, w)| w * density(g))
                .sum::<f64>()
                / rest.volume;
        }
        rest.gradients.iter().map(density).sum::<f64>() / 4.0
    }
}

impl TetMesh<Tet10> {
    /// The 10-node mesh on the tets of a linear mesh: one new node at the midpoint of each
    /// edge (numbered after the corner nodes, in ascending order of the edge's corner pair).
    /// The corners keep their indices, so node sets chosen on `linear` stay valid.
    pub fn from_linear(linear: &TetMesh) -> Result<Self> {
        let mut edges: Vec<(usize, usize)> = linear
            .tets()
            .iter()
            .flat_map(|t| EDGES.map(|(i, j)| (t[i].min(t[j]), t[i].max(t[j]))))
            .collect();
        edges.sort_unstable();
        edges.dedup();
        let corner_count = linear.node_count();
        let mut nodes = linear.nodes().to_vec();
        nodes.extend(
            edges
                .iter()
                .map(|&(a, b)| (linear.nodes()[a] + linear.nodes()[b]) * 0.5),
        );
        let edge_index = |a: usize, b: usize| {
            // Present by construction: every edge of every tet was collected above.
            corner_count + edges.binary_search(&(a.min(b), a.max(b))).unwrap_or(0)
        };
        let tets = linear
            .tets()
            .iter()
            .map(|t| {
                let mut cell = [0; 10];
                cell[..4].copy_from_slice(t);
                for (k, &(i, j)) in EDGES.iter().enumerate() {
                    cell[4 + k] = edge_index(t[i], t[j]);
                }
                cell
            })
            .collect();
        TetMesh::from_cells(nodes, tets)
    }
}

/// The degree-4 six-point rule on a triangle (Dunavant): barycentric points (a, a, 1 − 2a) and
/// their permutations, weights as fractions of the area.
const FACE_RULE: [(f64, f64); 2] = [
    (0.445_948_490_915_965, 0.223_381_589_678_011),
    (0.091_576_213_509_771, 0.109_951_743_655_322),
];

/// ∫Nᵢ dA (length²) over a curved 6-node boundary face with nodes `x` (its corners, then the
/// nodes of its edges (0,1), (1,2), (2,0)), or `None` when the face is straight (every edge
/// node at its midpoint to [`MIDPOINT_TOLERANCE`]: then the closed form
/// [`FACE_LOAD`](ElementType::FACE_LOAD) holds). The area element |∂x/∂ζ₁ × ∂x/∂ζ₂| of the
/// quadratic map is not a polynomial; the degree-4 rule integrates it to O(h⁴) relative.
pub fn curved_face_integrals(x: &[Vector3<f64>; 6]) -> Option<[f64; 6]> {
    const FACE_EDGES: [(usize, usize); 3] = [(0, 1), (1, 2), (2, 0)];
    let straight = FACE_EDGES.iter().enumerate().all(|(k, &(i, j))| {
        (x[3 + k] - (x[i] + x[j]) * 0.5).norm() <= MIDPOINT_TOLERANCE * (x[j] - x[i]).norm()
    });
    if straight {
        return None;
    }
    let mut integrals = [0.0; 6];
    for &(a, w) in &FACE_RULE {
        let b = 1.0 - 2.0 * a;
        for z in [[a, a, b], [a, b, a], [b, a, a]] {
            // N and ∂N/∂ζ₁, ∂N/∂ζ₂ with ζ₀ = 1 − ζ₁ − ζ₂.
            let n = [
                z[0] * (2.0 * z[0] - 1.0),
                z[1] * (2.0 * z[1] - 1.0),
                z[2] * (2.0 * z[2] - 1.0),
                4.0 * z[0] * z[1],
                4.0 * z[1] * z[2],
                4.0 * z[2] * z[0],
            ];
            let d1 = [
                1.0 - 4.0 * z[0],
                4.0 * z[1] - 1.0,
                0.0,
                4.0 * (z[0] - z[1]),
                4.0 * z[2],
                -4.0 * z[2],
            ];
            let d2 = [
                1.0 - 4.0 * z[0],
                0.0,
                4.0 * z[2] - 1.0,
                -4.0 * z[1],
                4.0 * z[1],
                4.0 * (z[0] - z[2]),
            ];
            let t1: Vector3<f64> = (0..6).map(|i| x[i] * d1[i]).sum();
            let t2: Vector3<f64> = (0..6).map(|i| x[i] * d2[i]).sum();
            // The reference triangle's area is ½: dA = |t₁ × t₂| dζ₁dζ₂.
            let da = 0.5 * w * t1.cross(&t2).norm();
            for i in 0..6 {
                integrals[i] += da * n[i];
            }
        }
    }
    Some(integrals)
}
