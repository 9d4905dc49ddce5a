//! Force models: the elastic energy, internal force and tangent stiffness of one tet at a
//! deformed configuration. The split follows Vega FEM: a model knows one element's mechanics;
//! [`assemble`] turns it into global forces and a tangent refilled on the existing sparsity
//! pattern; solvers ([`crate::analysis::nonlinear`]) know nothing of the model's formulas.
//!
//! Each model is its law per point ([`ConstitutiveLaw`]: ψ(F), P(F), ∂P/∂F, σ(F)) and its
//! 4-node tet formulas ([`ForceModel`]); [`ModelElement`] puts a model on an element: the 4-node
//! tet's own formulas, or the law at the 10-node tet's quadrature points.
//!
//! - [`LinearModel`]: the Cauchy-strain model of the rest of tetfem (f = −Kₑ·u). Cheap, exact for
//!   small motions, but a rigid rotation produces forces (the lecture's "visual artifacts").
//! - [`Corotational`]: stiffness warping, f = −R·Kₑ·(Rᵀx − X) with R from the polar decomposition
//!   of F: rotation-invariant, linear in the rotated frame.
//! - [`NeoHookean`]: the stable Neo-Hookean energy of Smith, de Goes & Kim (2018), defined for
//!   inverted tets too.
//! - [`StVenantKirchhoff`]: Hooke's law on the Green strain; rotation-invariant, for large
//!   rotations with moderate strains (it softens under strong compression).

mod corotational;
pub(crate) mod corotational_lanes;
mod element_model;
pub(crate) mod lanes;
mod law;
mod linear;
mod map;
mod neo_hookean;
mod neo_hookean_lanes;
pub(crate) mod polar;
mod quadrature_points;
mod st_venant_kirchhoff;

pub mod assemble;

pub use corotational::Corotational;
pub use corotational_lanes::rotations_into;
pub use element_model::ModelElement;
pub use law::{ConstitutiveLaw, Matrix9};
pub use linear::LinearModel;
pub use map::{ModelMap, TetModels};
pub use neo_hookean::NeoHookean;
pub use polar::rotation;
pub use st_venant_kirchhoff::StVenantKirchhoff;

use nalgebra::{Matrix3, SMatrix, SymmetricEigen, Vector3};

use crate::base::error::{Error, Result};
use crate::fe::element::{Matrix12, Tet, Vector12};
use crate::fe::material::Material;

/// One element's hyperelastic (or warped-linear) mechanics: the 4-node tet's own formulas
/// (the methods below, F constant in the tet) and, through its [`ConstitutiveLaw`], any other
/// element's quadrature ([`ModelElement`]).
pub trait ForceModel: ConstitutiveLaw + Sync + Send {
    /// Elastic energy of the tet at deformed positions `x` (energy units).
    fn energy(&self, tet: &Tet, rest: &[Vector3<f64>; 4], x: &[Vector3<f64>; 4]) -> f64;
    /// Internal elastic force on the four nodes, f = −∂E/∂x (node-major 12-vector).
    fn force(&self, tet: &Tet, rest: &[Vector3<f64>; 4], x: &[Vector3<f64>; 4]) -> Vector12;
    /// [`force`](Self::force) and [`energy`](Self::energy) together, for a model whose two
    /// share their costly kinematics (the corotational model's polar decomposition): what a
    /// minimization's line search needs at every trial point.
    fn force_and_energy(
        &self,
        tet: &Tet,
        rest: &[Vector3<f64>; 4],
        x: &[Vector3<f64>; 4],
    ) -> (Vector12, f64) {
        (self.force(tet, rest, x), self.energy(tet, rest, x))
    }

    /// [`force_and_energy`](Self::force_and_energy) of four tets at once (`tets[k]` at rest
    /// `rest[k]`, deformed `x[k]`, its result into `out[k]`), each result the same bits as
    /// that tet's own call: what the force pass of a nonlinear step calls for each four tets of
    /// one model, so that a model may evaluate them side by side (the corotational model's
    /// SIMD lanes). By default, one tet after another.
    fn force_and_energy_4(
        &self,
        tets: [&Tet; 4],
        rest: &[[Vector3<f64>; 4]; 4],
        x: &[[Vector3<f64>; 4]; 4],
        out: &mut [(Vector12, f64); 4],
    ) {
        for (k, out) in out.iter_mut().enumerate() {
            *out = self.force_and_energy(tets[k], &rest[k], &x[k]);
        }
    }
    /// Whether [`force_and_energy_4`](Self::force_and_energy_4) evaluates four tets faster
    /// than four calls of [`force_and_energy`](Self::force_and_energy) (default `false`): the
    /// force pass gathers tets in fours for such a model only (the corotational and the
    /// Neo-Hookean models' SIMD lanes).
    fn evaluates_four(&self) -> bool {
        false
    }
    /// Tangent stiffness −∂f/∂x (12×12, symmetric; may be indefinite: see [`project_psd`]).
    fn tangent(&self, tet: &Tet, rest: &[Vector3<f64>; 4], x: &[Vector3<f64>; 4]) -> Matrix12;
    /// Cauchy (true) stress σ of the tet at deformed positions `x` (stress units, Pa in SI),
    /// the stress this model's force comes from: zero under any rigid motion for the
    /// rotation-invariant models. Outputs (von Mises, `.vtu` fields) take it from here so that
    /// they describe the model that ran.
    fn cauchy_stress(
        &self,
        tet: &Tet,
        rest: &[Vector3<f64>; 4],
        x: &[Vector3<f64>; 4],
    ) -> Matrix3<f64>;
    /// A short name (`linear`, `corotational`, `neo-hookean`, `st-venant-kirchhoff`).
    fn name(&self) -> &'static str;
}

/// The models, by name.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ModelKind {
    /// [`LinearModel`], the default: small deformation.
    #[default]
    Linear,
    /// [`Corotational`].
    Corotational,
    /// [`NeoHookean`].
    NeoHookean,
    /// [`StVenantKirchhoff`].
    StVenantKirchhoff,
}

impl std::str::FromStr for ModelKind {
    type Err = Error;

    fn from_str(name: &str) -> Result<Self> {
        match name {
            "linear" => Ok(ModelKind::Linear),
            "corotational" | "corotated" => Ok(ModelKind::Corotational),
            "neo-hookean" | "neohookean" | "hyperelastic" => Ok(ModelKind::NeoHookean),
            "st-venant-kirchhoff" | "stvk" => Ok(ModelKind::StVenantKirchhoff),
            other => Err(Error::invalid_parameter(
                "model",
                other,
                format!("must be one of {}", ModelKind::listed_names()),
            )),
        }
    }
}

impl ModelKind {
    /// Every model, in the order the docs list them.
    pub const ALL: [ModelKind; 4] = [
        ModelKind::Linear,
        ModelKind::Corotational,
        ModelKind::NeoHookean,
        ModelKind::StVenantKirchhoff,
    ];

    /// The names of [`ALL`](Self::ALL) for an error message: `"linear", "corotational", …`.
    pub fn listed_names() -> String {
        let names: Vec<String> = Self::ALL
            .iter()
            .map(|kind| format!("\"{}\"", kind.name()))
            .collect();
        names.join(", ")
    }

    /// The name scenes and summaries use: `linear`, `corotational`, `neo-hookean`,
    /// `st-venant-kirchhoff`.
    pub fn name(self) -> &'static str {
        match self {
            ModelKind::Linear => "linear",
            ModelKind::Corotational => "corotational",
            ModelKind::NeoHookean => "neo-hookean",
            ModelKind::StVenantKirchhoff => "st-venant-kirchhoff",
        }
    }

    /// Whether this is the small-deformation linear model (σ = C:ε, K constant): what the
    /// linear fast paths (one factorization, modal analysis, the recovery estimate) need.
    pub fn is_linear(self) -> bool {
        self == ModelKind::Linear
    }

    /// One model of this kind per material of `materials`, chosen per tet.
    pub fn build_map(self, materials: &crate::fe::materials::MaterialMap) -> ModelMap {
        ModelMap::new(self, materials)
    }

    /// The model for `material`.
    pub fn build(self, material: &Material) -> Box<dyn ForceModel> {
        match self {
            ModelKind::Linear => Box::new(LinearModel::new(material)),
            ModelKind::Corotational => Box::new(Corotational::new(material)),
            ModelKind::NeoHookean => Box::new(NeoHookean::new(material)),
            ModelKind::StVenantKirchhoff => Box::new(StVenantKirchhoff::new(material)),
        }
    }
}

/// The nearest positive semi-definite matrix: eigenvalues below zero clamped to zero. Keeps the
/// assembled tangent SPD (with constraints) so that Cholesky applies and Newton directions
/// descend; where no eigenvalue is negative the tangent is unchanged (quadratic convergence
/// near a stable equilibrium is kept).
///
/// Fast path: if K + δ·I (δ = [`PSD_TOLERANCE`]·max diag K) has a Cholesky factor, every
/// eigenvalue of K is ≥ −δ and K is returned as it is, for the price of a 12×12 Cholesky
/// instead of a 12×12 symmetric eigendecomposition (about a twentieth). Only elements that fail
/// it (indefinite ones) pay for the eigendecomposition.
pub fn project_psd(matrix: &Matrix12) -> Matrix12 {
    let largest_diagonal = matrix.diagonal().max();
    if largest_diagonal > 0.0 {
        let shifted = matrix + Matrix12::identity() * (PSD_TOLERANCE * largest_diagonal);
        if nalgebra::Cholesky::new(shifted).is_some() {
            return *matrix;
        }
    }
    let eigen = SymmetricEigen::new(*matrix);
    if eigen.eigenvalues.iter().all(|&l| l >= 0.0) {
        return *matrix;
    }
    let clamped = eigen.eigenvalues.map(|l| l.max(0.0));
    eigen.eigenvectors * Matrix12::from_diagonal(&clamped) * eigen.eigenvectors.transpose()
}

/// [`project_psd`] for a symmetric matrix of any fixed size (the 30×30 tangent of the 10-node
/// tet): the same Cholesky fast path, the eigendecomposition (of the rare indefinite element)
/// on a dynamically sized copy.
pub fn project_psd_of<const D: usize>(matrix: &SMatrix<f64, D, D>) -> SMatrix<f64, D, D> {
    let largest_diagonal = matrix.diagonal().max();
    if largest_diagonal > 0.0 {
        let shifted =
            matrix + SMatrix::<f64, D, D>::identity() * (PSD_TOLERANCE * largest_diagonal);
        if nalgebra::Cholesky::new(shifted).is_some() {
            return *matrix;
        }
    }
    let eigen = SymmetricEigen::new(nalgebra::DMatrix::from_column_slice(
        D,
        D,
        matrix.as_slice(),
    ));
    if eigen.eigenvalues.iter().all(|&l| l >= 0.0) {
        return *matrix;
    }
    let clamped = eigen.eigenvalues.map(|l| l.max(0.0));
    let projected = &eigen.eigenvectors
        * nalgebra::DMatrix::from_diagonal(&clamped)
        * eigen.eigenvectors.transpose();
    SMatrix::<f64, D, D>::from_column_slice(projected.as_slice())
}

/// Relative tolerance of [`project_psd`]'s fast path: eigenvalues down to −1e-10·max diag K
/// (round-off of the six rigid-body zero modes, far below any physical stiffness) are accepted
/// as non-negative.
pub const PSD_TOLERANCE: f64 = 1e-10;

/// Element force −V·P·Dm⁻ᵀ from a first Piola–Kirchhoff stress P, distributed to the nodes
/// (nodes 1..3 get the columns of −V·P·Dm⁻ᵀ, node 0 minus their sum).
pub(crate) fn piola_to_force(tet: &Tet, piola: &Matrix3<f64>) -> Vector12 {
    let h = -piola * tet.rest_inverse().transpose() * tet.volume();
    let mut f = Vector12::zeros();
    for i in 0..3 {
        for a in 0..3 {
            f[3 * (i + 1) + a] = h[(a, i)];
            f[a] -= h[(a, i)];
        }
    }
    f
}

/// The change dF of the deformation gradient for nodal displacement direction `dx`.
pub(crate) fn deformation_gradient_direction(tet: &Tet, dx: &Vector12) -> Matrix3<f64> {
    let node = |i: usize| Vector3::new(dx[3 * i], dx[3 * i + 1], dx[3 * i + 2]);
    let d0 = node(0);
    Matrix3::from_columns(&[node(1) - d0, node(2) - d0, node(3) - d0]) * tet.rest_inverse()
}

/// The 12×12 tangent −∂f/∂x of a model given dP(dF) (the directional derivative of its Piola
/// stress), column by column.
pub(crate) fn tangent_from_piola_derivative(
    tet: &Tet,
    dpiola: impl Fn(&Matrix3<f64>) -> Matrix3<f64>,
) -> Matrix12 {
    let mut k = Matrix12::zeros();
    for j in 0..12 {
        let mut direction = Vector12::zeros();
        direction[j] = 1.0;
        let df = deformation_gradient_direction(tet, &direction);
        let column = -piola_to_force(tet, &dpiola(&df));
        k.set_column(j, &column);
    }
    // Exact symmetry (the Hessian of an energy); averaging removes round-off asymmetry.
    (k + k.transpose()) * 0.5
}
