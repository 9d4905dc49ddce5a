//! The quadratic 10-node tet (P2): four corners and one node per edge, straight-sided.
//!
//! In barycentric coordinates L₀…L₃ of the corners the shape functions are
//! Nᵢ = Lᵢ(2Lᵢ − 1) at corner i and N₍ᵢⱼ₎ = 4LᵢLⱼ at the node of edge (i, j). Local node order
//! is VTK's (`VTK_QUADRATIC_TETRA`): corners 0–3, then the edges (0,1), (1,2), (0,2), (0,3),
//! (1,3), (2,3) as nodes 4–9. Edge nodes sit at their edges' midpoints, so the map from the
//! reference tet is the corners' affine one and every ∇Lᵢ is constant: the displacement is
//! quadratic and the strain linear inside the tet.
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

/// Rest data of one 10-node tet: its volume and the shape-function gradients at the four
/// quadrature points (1/length).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tet10Rest {
    volume: f64,
    gradients: [[Vector3<f64>; 10]; 4],
}

impl Tet10Rest {
    /// From the straight-sided tet of its corners (the linear element's ∇Lᵢ).
    pub fn new(corners: &Tet) -> Self {
        let dl = corners.shape_gradients();
        let mut gradients = [[Vector3::zeros(); 10]; 4];
        for (q, point) in gradients.iter_mut().enumerate() {
            let l: [f64; 4] = std::array::from_fn(|i| if i == q { RULE_ALPHA } else { RULE_BETA });
            *point = shape_gradients(&l, dl);
        }
        Tet10Rest {
            volume: corners.volume(),
            gradients,
        }
    }

    /// Rest volume (length³).
    pub fn volume(&self) -> f64 {
        self.volume
    }

    /// Shape-function gradients ∇Nₐ (1/length) at the four points of the degree-2 rule, whose
    /// weights are V/4 each: `gradients()[q][a]`.
    pub fn gradients(&self) -> &[[Vector3<f64>; 10]; 4] {
        &self.gradients
    }

    /// Linear strain ε = ½(∇u + ∇uᵀ) at quadrature point `q` (0–3) for the node-major
    /// displacement `u` (30 values).
    pub fn strain_at(&self, q: usize, u: &[f64]) -> Matrix3<f64> {
        let mut grad = Matrix3::zeros();
        for (i, g) in self.gradients[q].iter().enumerate() {
            grad += Vector3::new(u[3 * i], u[3 * i + 1], u[3 * i + 2]) * g.transpose();
        }
        (grad + grad.transpose()) * 0.5
    }
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
        let corners = mesh.corner_positions_of(t);
        // Cannot fail: `from_cells` rejected degenerate corners and reoriented negative ones.
        let tet = Tet::new(&corners)
            .expect("TetMesh invariant: every tet is positively oriented and non-degenerate");
        Tet10Rest::new(&tet)
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
        let weight = rest.volume / 4.0;
        let (lambda, mu) = (lame_lambda * weight, shear_modulus * weight);
        let mut k = [[0.0; 3]; 3];
        for point in &rest.gradients {
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
        density * rest.volume * REFERENCE_MASS[i][j]
    }

    /// The strain is linear, so its volume average is the mean of the degree-2 rule's points.
    fn mean_stress(rest: &Tet10Rest, material: &Material, u: &[f64]) -> Matrix3<f64> {
        hooke(material, &Self::mean_strain(rest, u))
    }

    /// The strain is linear, so its volume average is the mean of the degree-2 rule's points.
    fn mean_strain(rest: &Tet10Rest, u: &[f64]) -> Matrix3<f64> {
        (0..4).map(|q| rest.strain_at(q, u)).sum::<Matrix3<f64>>() / 4.0
    }

    /// ½σ:ε is quadratic: the degree-2 rule integrates it exactly.
    fn strain_energy_density(rest: &Tet10Rest, material: &Material, u: &[f64]) -> f64 {
        (0..4)
            .map(|q| {
                let strain = rest.strain_at(q, u);
                0.5 * hooke(material, &strain).component_mul(&strain).sum()
            })
            .sum::<f64>()
            / 4.0
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
