//! The linear 4-node tet: per-tetrahedron kinematics, the element stiffness and masses.
//!
//! A linear tet maps barycentric coordinates b to x = x₀ + Dm·b with the rest shape matrix
//! Dm = [x₁−x₀ x₂−x₀ x₃−x₀]. The displacement is linear inside the tet, so its gradient, the
//! strain and the stress are constant per element.

use nalgebra::{Matrix3, SMatrix, SVector, Vector3};

pub use crate::mesh::geometry::{FACES, rest_shape_matrix, shape_quality, signed_volume};

use super::{ElementType, Weights};
use crate::base::error::{Error, Result};
use crate::fe::material::Material;
use crate::mesh::{Tet4, TetMesh};

/// 12×12 element matrix; DOF order node-major: `[u₀x u₀y u₀z u₁x … u₃z]`.
pub type Matrix12 = SMatrix<f64, 12, 12>;
/// 12-vector of element DOFs (node-major).
pub type Vector12 = SVector<f64, 12>;
/// 6×12 strain–displacement matrix.
pub type Matrix6x12 = SMatrix<f64, 6, 12>;

/// Rest-state data of one linear tetrahedron.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tet {
    rest_inverse: Matrix3<f64>,
    volume: f64,
    gradients: [Vector3<f64>; 4],
}

impl Tet {
    /// Builds the element from its four rest positions (x₀, x₁, x₂, x₃).
    ///
    /// The tet must be positively oriented: det(Dm) > 0. [`crate::mesh::TetMesh`] reorients its
    /// tets on construction, so elements taken from a mesh always satisfy this.
    pub fn new(rest: &[Vector3<f64>; 4]) -> Result<Self> {
        let shape = rest_shape_matrix(rest);
        let det = shape.determinant();
        if !(det.is_finite() && det > 0.0) {
            return Err(Error::invalid_parameter(
                "tet rest positions",
                format!("det(Dm) = {det:e}"),
                "must be finite and > 0 (a positively oriented, non-degenerate tet)",
            ));
        }
        let rest_inverse = shape.try_inverse().ok_or_else(|| {
            Error::invalid_parameter(
                "tet rest positions",
                format!("det(Dm) = {det:e}"),
                "the rest shape matrix must be invertible",
            )
        })?;
        // Rows of Dm⁻¹ are the gradients of the barycentric coordinates b₁, b₂, b₃;
        // b₀ = 1 − b₁ − b₂ − b₃.
        let g1 = rest_inverse.row(0).transpose();
        let g2 = rest_inverse.row(1).transpose();
        let g3 = rest_inverse.row(2).transpose();
        Ok(Tet {
            rest_inverse,
            volume: det / 6.0,
            gradients: [-(g1 + g2 + g3), g1, g2, g3],
        })
    }

    /// Rest volume V = det(Dm)/6 (> 0).
    pub fn volume(&self) -> f64 {
        self.volume
    }

    /// Inverse of the rest shape matrix, Dm⁻¹.
    pub fn rest_inverse(&self) -> &Matrix3<f64> {
        &self.rest_inverse
    }

    /// Gradients ∇N₀…∇N₃ of the four linear shape functions (constant in the tet, units 1/length).
    pub fn shape_gradients(&self) -> &[Vector3<f64>; 4] {
        &self.gradients
    }

    /// Deformation gradient F = Ds·Dm⁻¹ with Ds = [p₁−p₀ p₂−p₀ p₃−p₀] from deformed positions
    /// (the lecture's P).
    pub fn deformation_gradient(&self, deformed: &[Vector3<f64>; 4]) -> Matrix3<f64> {
        rest_shape_matrix(deformed) * self.rest_inverse
    }

    /// Displacement gradient ∇u = Σᵢ uᵢ ⊗ ∇Nᵢ for nodal displacements `u` (node-major).
    pub fn displacement_gradient(&self, u: &Vector12) -> Matrix3<f64> {
        let mut grad = Matrix3::zeros();
        for (i, g) in self.gradients.iter().enumerate() {
            let ui = Vector3::new(u[3 * i], u[3 * i + 1], u[3 * i + 2]);
            grad += ui * g.transpose();
        }
        grad
    }

    /// Linear (Cauchy) strain ε = ½(∇u + ∇uᵀ) for nodal displacements `u`.
    pub fn strain(&self, u: &Vector12) -> Matrix3<f64> {
        let grad = self.displacement_gradient(u);
        (grad + grad.transpose()) * 0.5
    }

    /// Cauchy stress σ = λ·tr(ε)·I + 2μ·ε (Pa in SI) for nodal displacements `u`.
    pub fn stress(&self, material: &Material, u: &Vector12) -> Matrix3<f64> {
        let strain = self.strain(u);
        Matrix3::identity() * (material.lame_lambda() * strain.trace())
            + strain * (2.0 * material.shear_modulus())
    }

    /// Strain–displacement matrix B (6×12) with engineering shear strains:
    /// `B·u = [ε_xx, ε_yy, ε_zz, γ_xy, γ_yz, γ_zx]` with γ = 2ε.
    pub fn strain_displacement(&self) -> Matrix6x12 {
        let mut b = Matrix6x12::zeros();
        for (i, g) in self.gradients.iter().enumerate() {
            let c = 3 * i;
            b[(0, c)] = g.x;
            b[(1, c + 1)] = g.y;
            b[(2, c + 2)] = g.z;
            b[(3, c)] = g.y;
            b[(3, c + 1)] = g.x;
            b[(4, c + 1)] = g.z;
            b[(4, c + 2)] = g.y;
            b[(5, c)] = g.z;
            b[(5, c + 2)] = g.x;
        }
        b
    }

    /// Element stiffness Kₑ = V·Bᵀ·D·B (units force/length), D the engineering-shear
    /// constitutive matrix of [`Material::engineering_stiffness`].
    ///
    /// Evaluated block-wise as Kₐᵦ = V·(λ ∇Nₐ∇Nᵦᵀ + μ ∇Nᵦ∇Nₐᵀ + μ (∇Nₐ·∇Nᵦ) I), which equals
    /// V·BᵀDB exactly (the tests check the identity) at a fraction of the flops.
    pub fn stiffness(&self, material: &Material) -> Matrix12 {
        let lambda = material.lame_lambda() * self.volume;
        let mu = material.shear_modulus() * self.volume;
        let mut k = Matrix12::zeros();
        for a in 0..4 {
            let ga = self.gradients[a];
            for b in a..4 {
                let gb = self.gradients[b];
                let block = ga * gb.transpose() * lambda
                    + gb * ga.transpose() * mu
                    + Matrix3::identity() * (mu * ga.dot(&gb));
                k.fixed_view_mut::<3, 3>(3 * a, 3 * b).copy_from(&block);
                if a != b {
                    k.fixed_view_mut::<3, 3>(3 * b, 3 * a)
                        .copy_from(&block.transpose());
                }
            }
        }
        k
    }

    /// The lecture's force recipe on deformed positions `p`: P = Ds·Dm⁻¹, ε = ½(P + Pᵀ) − I,
    /// σ = D·ε (the lecture's tensor-shear D), and for each of the four faces (a, b, c) the force
    /// σ·n·A, shared one third to each of the face's nodes, with the area vector n·A oriented
    /// into the tet.
    ///
    /// One correction to the slide: it writes n·A = p₁₀ × p₂₀, but that cross product is twice
    /// the triangle's area vector; taken literally the recipe gives exactly twice the elastic
    /// force. Here n·A = ½ (p_b − p_a) × (p_c − p_a).
    ///
    /// For small displacements the result equals the linear elastic force −Kₑ·u up to O(|u|²):
    /// the recipe uses the deformed face normals where the linear model uses the rest ones.
    pub fn lecture_face_forces(
        &self,
        material: &Material,
        deformed: &[Vector3<f64>; 4],
    ) -> [Vector3<f64>; 4] {
        let p = self.deformation_gradient(deformed);
        let strain = (p + p.transpose()) * 0.5 - Matrix3::identity();
        let voigt = SVector::<f64, 6>::new(
            strain[(0, 0)],
            strain[(1, 1)],
            strain[(2, 2)],
            strain[(0, 1)],
            strain[(1, 2)],
            strain[(2, 0)],
        );
        let s = material.tensor_stiffness() * voigt;
        let stress = Matrix3::new(s[0], s[3], s[5], s[3], s[1], s[4], s[5], s[4], s[2]);
        let mut forces = [Vector3::zeros(); 4];
        for (face, opposite) in FACES {
            let [a, b, c] = face;
            let mut area_vector =
                (deformed[b] - deformed[a]).cross(&(deformed[c] - deformed[a])) * 0.5;
            if area_vector.dot(&(deformed[opposite] - deformed[a])) < 0.0 {
                area_vector = -area_vector;
            }
            let face_force = stress * area_vector / 3.0;
            for node in face {
                forces[node] += face_force;
            }
        }
        forces
    }

    /// Consistent mass matrix (12×12): blocks ρV/20·(1 + δᵢⱼ)·I₃ (mass units).
    pub fn consistent_mass(&self, density: f64) -> Matrix12 {
        let scale = density * self.volume / 20.0;
        let mut m = Matrix12::zeros();
        for a in 0..4 {
            for b in 0..4 {
                let value = if a == b { 2.0 * scale } else { scale };
                for axis in 0..3 {
                    m[(3 * a + axis, 3 * b + axis)] = value;
                }
            }
        }
        m
    }

    /// Lumped mass per node, ρV/4 (the row sums of the consistent mass).
    pub fn lumped_mass(&self, density: f64) -> f64 {
        density * self.volume / 4.0
    }
}

/// Von Mises equivalent stress √(3/2 · s:s) of a stress tensor σ, s = σ − tr(σ)/3·I its
/// deviator (same units as σ).
pub fn von_mises(stress: &Matrix3<f64>) -> f64 {
    let deviator = stress - Matrix3::identity() * (stress.trace() / 3.0);
    (1.5 * deviator.component_mul(&deviator).sum()).sqrt()
}

/// The elements of a mesh. They live here, not in [`crate::mesh`], so that the mesh (geometry
/// and topology) knows nothing of elements: data flows mesh → element.
impl TetMesh {
    /// The rest-state element of tet `t`; [`Error::UnknownTet`] if `t >= tet_count()`.
    pub fn element(&self, t: usize) -> Result<Tet> {
        self.check_tet("TetMesh::element", t)?;
        Ok(self.element_of(t))
    }

    /// All rest-state elements, in tet order.
    pub fn elements(&self) -> Vec<Tet> {
        (0..self.tet_count()).map(|t| self.element_of(t)).collect()
    }
}

impl<C: crate::mesh::CellType> TetMesh<C> {
    /// The linear element of tet `t`'s corners, for loops over `0..tet_count()` (panics on a
    /// bad index): the geometry (volume, quality, altitudes) of any cell type.
    #[inline]
    pub(crate) fn element_of(&self, t: usize) -> Tet {
        // Cannot fail: `new` rejected every tet whose quality is below `DEGENERATE_QUALITY` and
        // reoriented the negative ones, which is all `Tet::new` checks.
        Tet::new(&self.corner_positions_of(t))
            .expect("TetMesh invariant: every tet is positively oriented and non-degenerate")
    }
}

/// The linear tet through the element seam: the same values, bit for bit, as [`Tet`]'s own
/// methods (the one-point rule is exact: the gradients are constant).
impl ElementType for Tet4 {
    type Rest = Tet;

    /// ρV/4 per node: the row sums of the consistent mass.
    const LUMPED_MASS: Weights = Weights {
        numerators: &[1.0; 4],
        denominator: 4.0,
    };
    /// ∫Nᵢ dV = V/4.
    const VOLUME_LOAD: Weights = Weights {
        numerators: &[1.0; 4],
        denominator: 4.0,
    };
    /// ∫Nᵢ dA = A/3 on a 3-node triangle.
    const FACE_LOAD: Weights = Weights {
        numerators: &[1.0; 3],
        denominator: 3.0,
    };

    #[inline]
    fn rest(mesh: &TetMesh, t: usize) -> Tet {
        mesh.element_of(t)
    }

    #[inline]
    fn volume(rest: &Tet) -> f64 {
        rest.volume
    }

    /// V·(λ ∇Nᵢ∇Nⱼᵀ + μ ∇Nⱼ∇Nᵢᵀ + μ (∇Nᵢ·∇Nⱼ) I), written as [`Tet::stiffness`] evaluates it
    /// (same products, same sum order), so that the two paths agree to the bit; the identity
    /// term only touches the diagonal, where `Tet::stiffness`'s +0.0 elsewhere changes no sum.
    #[inline(always)]
    fn stiffness_block(
        rest: &Tet,
        lame_lambda: f64,
        shear_modulus: f64,
        i: usize,
        j: usize,
    ) -> [[f64; 3]; 3] {
        let lambda = lame_lambda * rest.volume;
        let mu = shear_modulus * rest.volume;
        let (gi, gj) = (&rest.gradients[i], &rest.gradients[j]);
        let shear = mu * (gi[0] * gj[0] + gi[1] * gj[1] + gi[2] * gj[2]);
        let mut k = [[0.0; 3]; 3];
        for a in 0..3 {
            for b in 0..3 {
                let value = gi[b] * gj[a] * lambda + gj[b] * gi[a] * mu;
                k[a][b] = if a == b { value + shear } else { value };
            }
        }
        k
    }

    /// ρV/20·(1 + δᵢⱼ), as [`Tet::consistent_mass`].
    #[inline]
    fn mass_coefficient(rest: &Tet, density: f64, i: usize, j: usize) -> f64 {
        let scale = density * rest.volume / 20.0;
        if i == j { 2.0 * scale } else { scale }
    }

    /// The constant stress of [`Tet::stress`].
    fn mean_stress(rest: &Tet, material: &Material, u: &[f64]) -> Matrix3<f64> {
        rest.stress(material, &Vector12::from_column_slice(u))
    }

    /// The constant strain of [`Tet::strain`].
    fn mean_strain(rest: &Tet, u: &[f64]) -> Matrix3<f64> {
        rest.strain(&Vector12::from_column_slice(u))
    }

    /// ½ σ:ε, constant in the tet.
    fn strain_energy_density(rest: &Tet, material: &Material, u: &[f64]) -> f64 {
        let u = Vector12::from_column_slice(u);
        0.5 * rest
            .stress(material, &u)
            .component_mul(&rest.strain(&u))
            .sum()
    }
}
