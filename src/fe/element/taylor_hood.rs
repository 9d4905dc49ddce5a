//! The Taylor–Hood P2–P1 tet: the quadratic 10-node displacement of [`Tet10`] with a
//! continuous linear pressure on its four corners, for nearly incompressible linear elasticity
//! without volumetric locking.
//!
//! Perturbed-Lagrangian form of the linear model (shear modulus μ, bulk modulus
//! κ = λ + 2μ/3, Pa): find u and p with
//!
//! ```text
//!   ∫ 2μ dev ε(u) : dev ε(v) dV − ∫ p div v dV = f(v)     for every v,
//!  −∫ q div u dV − ∫ p q / κ dV               = 0         for every q,
//! ```
//!
//! so p = −κ div u is the pressure (positive in compression, p = −tr σ / 3) and the stress is
//! σ = 2μ dev ε − p I. With element blocks
//!
//! - K_dev: Kᵢⱼ = ∫ μ(∇Nᵢ·∇Nⱼ I + ∇Nⱼ∇Nᵢᵀ) − (2μ/3) ∇Nᵢ∇Nⱼᵀ dV — the linear stiffness of
//!   [`Tet10`] with λ replaced by −2μ/3, since 2μ dev ε : dev ε = 2μ ε:ε − (2μ/3)(tr ε)²;
//! - B: B_kᵢₐ = ∫ L_k ∂ₐNᵢ dV (L_k the corner's barycentric coordinate, the linear pressure's
//!   shape function) — the divergence of node i's displacement along axis a tested by q = L_k;
//! - M_p: ∫ L_k L_l dV = V(1 + δ_kl)/20, the pressure mass,
//!
//! the system is [K_dev −Bᵀ; −B −M_p/κ] [u; p] = [f; 0], symmetric quasi-definite for ν < 0.5.
//! Every integrand is at most quadratic on the straight-sided tet, so the degree-2 rule of
//! [`Tet10`] integrates K_dev and B exactly.
//!
//! Why this element: P2–P1 satisfies the inf-sup (LBB) condition on tet meshes, under a mild
//! condition on the tets at the boundary (Boffi 1997, "Three-dimensional finite element
//! methods for the Stokes problem"; a mesh of one layer of tets may violate it), so the
//! pressure does not checkerboard and the displacement converges at the P2 rate uniformly in
//! κ. The saddle point is solved whole, without condensation, by one quasi-definite LDLᵀ
//! ([`QuasiDefiniteLdlt`](crate::linalg::QuasiDefiniteLdlt)) with a few per cent more rows
//! than the P2 system (the corner pressures: 6 % on the Lamé tube meshes).
//!
//! Measured on Lamé's thick-walled tube in plane strain (`tests/core/mixed_tube.rs`, the
//! `locking` bin of the validation crate; 6 × 24 × 2 cells): the radial displacement at the
//! bore is 0.9993 of Lamé's at every ν from 0.3 to 0.4999, where the linear tet on the same
//! mesh gives 0.988, 0.883, 0.612, 0.478 at ν = 0.3, 0.49, 0.499, 0.4999 and the plain
//! quadratic tet 0.9993 to 0.9958; the pressure's L2 error falls at rate 2.4–2.6 under
//! refinement with every tet's mean within 0.4 % of the exact constant (the linear tet's
//! −κ tr ε scatters by 54×). The whole mixed solve costs about 1.5× the quadratic tet's
//! displacement solve of the same mesh.

use nalgebra::SMatrix;

use super::tet10::Tet10Rest;
use super::{ElementType, Tet10};
use crate::mesh::{CellType, NodeList, TetMesh};

/// Pressure nodes per element: the four corners.
pub const PRESSURE_NODES: usize = 4;

/// The degree-2 rule's barycentric coordinates: point q has L_q = α and the other three β
/// (the same rule as [`Tet10Rest::gradients`]).
const RULE_ALPHA: f64 = 0.585_410_196_624_968_5;
const RULE_BETA: f64 = 0.138_196_601_125_010_5;

/// The element's divergence coupling B_kᵢₐ = ∫ L_k ∂ₐNᵢ dV (length²): `coupling[k][i][a]`
/// for corner k (pressure node), displacement node i (0–9) and axis a.
pub type Coupling = [[[f64; 3]; 10]; PRESSURE_NODES];

/// The deviatoric stiffness node block Kᵢⱼ (force/length) of the 10-node tet for shear
/// modulus `shear_modulus` (Pa): ∫ μ(∇Nᵢ·∇Nⱼ I + ∇Nⱼ∇Nᵢᵀ) − (2μ/3)∇Nᵢ∇Nⱼᵀ dV, in the layout
/// of [`ElementType::stiffness_block`].
pub fn deviatoric_block(rest: &Tet10Rest, shear_modulus: f64, i: usize, j: usize) -> [[f64; 3]; 3] {
    Tet10::stiffness_block(rest, -2.0 * shear_modulus / 3.0, shear_modulus, i, j)
}

/// The element's whole 30×30 deviatoric stiffness (force/length), row 3i + b, column 3j + a.
pub fn deviatoric_stiffness(rest: &Tet10Rest, shear_modulus: f64) -> SMatrix<f64, 30, 30> {
    let mut k = SMatrix::<f64, 30, 30>::zeros();
    for i in 0..10 {
        for j in i..10 {
            let block = deviatoric_block(rest, shear_modulus, i, j);
            for a in 0..3 {
                for b in 0..3 {
                    k[(3 * i + b, 3 * j + a)] = block[a][b];
                    k[(3 * j + a, 3 * i + b)] = block[a][b];
                }
            }
        }
    }
    k
}

/// The divergence coupling B_kᵢₐ = ∫ L_k ∂ₐNᵢ dV (length²), exact by the degree-2 rule (the
/// integrand is linear × linear).
pub fn coupling(rest: &Tet10Rest) -> Coupling {
    let mut b = [[[0.0; 3]; 10]; PRESSURE_NODES];
    for (q, gradients) in rest.gradients().iter().enumerate() {
        // V/4 on a straight tet; V_X/4·det G at the point on a curved one.
        let weight = rest.weights()[q];
        for (k, row) in b.iter_mut().enumerate() {
            let l = if k == q { RULE_ALPHA } else { RULE_BETA };
            for (node, g) in row.iter_mut().zip(gradients) {
                for a in 0..3 {
                    node[a] += weight * l * g[a];
                }
            }
        }
    }
    b
}

/// The pressure mass ∫ L_k L_l dV = V(1 + δ_kl)/20 (length³) of corners k and l.
pub fn pressure_mass(rest: &Tet10Rest, k: usize, l: usize) -> f64 {
    rest.volume() * if k == l { 2.0 } else { 1.0 } / 20.0
}

/// Volume average (1/V)∫ div u dV of the element's node-major displacement `u` (30 values):
/// the trace of [`ElementType::mean_strain`], dimensionless.
pub fn mean_divergence(rest: &Tet10Rest, u: &[f64]) -> f64 {
    Tet10::mean_strain(rest, u).trace()
}

/// The pressure unknowns of a 10-node mesh: one per node that is a corner of some tet, in
/// ascending node order. `index[node]` is its pressure unknown (`None` for edge nodes and
/// unused nodes), `node[p]` the node of unknown p.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PressureNodes {
    index: Vec<Option<usize>>,
    node: Vec<usize>,
}

impl PressureNodes {
    /// The corner nodes of `mesh`'s tets (of either cell type: every node of a 4-node mesh
    /// that some tet uses).
    pub fn new<C: CellType>(mesh: &TetMesh<C>) -> Self {
        let mut is_corner = vec![false; mesh.node_count()];
        for tet in mesh.tets() {
            for n in tet.corners() {
                is_corner[n] = true;
            }
        }
        let mut index = vec![None; mesh.node_count()];
        let mut node = Vec::new();
        for (n, &corner) in is_corner.iter().enumerate() {
            if corner {
                index[n] = Some(node.len());
                node.push(n);
            }
        }
        PressureNodes { index, node }
    }

    /// Number of pressure unknowns.
    pub fn count(&self) -> usize {
        self.node.len()
    }

    /// The pressure unknown of `node` (`None` unless it is a corner of some tet).
    pub fn index_of(&self, node: usize) -> Option<usize> {
        self.index.get(node).copied().flatten()
    }

    /// The node of each pressure unknown, ascending.
    pub fn nodes(&self) -> &[usize] {
        &self.node
    }

    /// The pressure unknowns of tet `tet` (its four corners), for a tet of the mesh this was
    /// made from.
    pub fn of_tet(&self, tet: &[usize]) -> [usize; PRESSURE_NODES] {
        // Every corner has an unknown by construction.
        std::array::from_fn(|k| self.index[tet[k]].unwrap_or(usize::MAX))
    }
}

/// The tets of `mesh` none of whose four corners is inside the body (every corner on a
/// boundary face), ascending. P2–P1 is stable on meshes where every tet has an interior corner
/// (Boffi 1997's sufficient condition); a tet without one has pressure modes its displacement
/// barely controls (a mesh one tet thick has nothing else).
pub fn tets_without_an_interior_corner<C: CellType>(
    mesh: &TetMesh<C>,
) -> crate::Result<Vec<usize>> {
    let mut on_boundary = vec![false; mesh.node_count()];
    for face in mesh.boundary_faces()? {
        for n in face.nodes {
            on_boundary[n] = true;
        }
    }
    Ok(mesh
        .tets()
        .iter()
        .enumerate()
        .filter(|(_, tet)| tet.corners().iter().all(|&n| on_boundary[n]))
        .map(|(t, _)| t)
        .collect())
}
