//! The seam between an element type and the rest of the library.

use nalgebra::Matrix3;

use crate::fe::material::Material;
use crate::mesh::{CellType, TetMesh};

/// The mechanics of one element type on its node layout ([`CellType`]): what assembly, loads and
/// the masses need, and nothing they would have to know about its shape functions.
///
/// Node blocks use the layout of the global matrices: block (i, j) couples node i's three DOFs
/// (rows) with node j's (columns), written `[a][b]` = row 3i + b, column 3j + a.
pub trait ElementType: CellType {
    /// Rest-state data of one element that its matrices are computed from (for the linear tet
    /// its volume and shape gradients, for the quadratic tet the gradients at its quadrature
    /// points).
    type Rest: Send + Sync;

    /// Lumped mass: node i of an element of mass ρV gets ρV·wᵢ (a positive diagonal, Σwᵢ = 1).
    const LUMPED_MASS: Weights;
    /// Consistent load of a uniform body force b: node i gets b·∫Nᵢ dV = b·V·wᵢ.
    const VOLUME_LOAD: Weights;
    /// Consistent load of a uniform traction t on a boundary face of area A: its corners (in
    /// the face's order) then, for cells with edge nodes, the nodes of the edges (0,1), (1,2),
    /// (2,0) of the face get t·∫Nᵢ dA = t·A·wᵢ.
    const FACE_LOAD: Weights;

    /// The rest data of tet `t` of `mesh` (panics on a bad index: for loops over
    /// `0..tet_count()` of a validated mesh).
    fn rest(mesh: &TetMesh<Self>, t: usize) -> Self::Rest;

    /// Rest volume V of the element (length³).
    fn volume(rest: &Self::Rest) -> f64;

    /// Node block Kᵢⱼ of the linear-elastic stiffness (force/length),
    /// Kᵢⱼ = ∫ λ ∇Nᵢ∇Nⱼᵀ + μ ∇Nⱼ∇Nᵢᵀ + μ (∇Nᵢ·∇Nⱼ) I dV, for Lamé λ and shear modulus μ (Pa).
    fn stiffness_block(
        rest: &Self::Rest,
        lame_lambda: f64,
        shear_modulus: f64,
        i: usize,
        j: usize,
    ) -> [[f64; 3]; 3];

    /// ∫Nᵢ dV (length³) of node `i`: a uniform body force b loads node i with b·∫Nᵢ dV. By
    /// default [`VOLUME_LOAD`](Self::VOLUME_LOAD)'s share of the volume (exact on straight tets).
    fn shape_integral(rest: &Self::Rest, i: usize) -> f64 {
        Self::VOLUME_LOAD.share(i, Self::volume(rest))
    }

    /// Consistent mass coefficient mᵢⱼ = ∫ ρ NᵢNⱼ dV (mass units): the node block is mᵢⱼ·I₃.
    fn mass_coefficient(rest: &Self::Rest, density: f64, i: usize, j: usize) -> f64;

    /// Volume average (1/V)∫σ dV of the linear-elastic Cauchy stress σ = λ tr(ε) I + 2με
    /// (stress units) for the element's node-major displacement `u` (3·NODES values).
    fn mean_stress(rest: &Self::Rest, material: &Material, u: &[f64]) -> Matrix3<f64>;

    /// Volume average (1/V)∫ε dV of the linear (small) strain ε = ½(∇u + ∇uᵀ) (dimensionless;
    /// tensor shear components, not engineering γ = 2ε) for the node-major displacement `u`.
    fn mean_strain(rest: &Self::Rest, u: &[f64]) -> Matrix3<f64>;

    /// Volume average (1/V)∫½ σ:ε dV of the strain energy density (energy per volume) for the
    /// element's node-major displacement `u`; times V it is the element's ½ uᵀKₑu.
    fn strain_energy_density(rest: &Self::Rest, material: &Material, u: &[f64]) -> f64;
}

/// Per-node weights of a total (mass, body load, face load) as exact fractions: node i gets
/// `total · numerators[i] / denominator`, written so that a weight of ¼ or ⅓ costs one
/// correctly rounded division, as the linear tet's formulas always did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Weights {
    /// One numerator per node of the element (or of the face, for face loads).
    pub numerators: &'static [f64],
    /// The common denominator.
    pub denominator: f64,
}

impl Weights {
    /// Node `i`'s share of `total`: total·numeratorᵢ/denominator.
    #[inline]
    pub fn share(&self, i: usize, total: f64) -> f64 {
        total * self.numerators[i] / self.denominator
    }
}
