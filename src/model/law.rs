//! The constitutive law of a force model at one material point: what the element-generic
//! quadrature ([`super::ModelElement`]) integrates, with no element in it.

use nalgebra::{Matrix3, SMatrix};

/// A 9×9 matrix on 3×3 tensors flattened column-major (entry (i, j) of a tensor at index
/// i + 3j, nalgebra's storage order): the derivative ∂P/∂F of a stress by a deformation gradient.
pub type Matrix9 = SMatrix<f64, 9, 9>;

/// A hyperelastic (or corotated-linear) law per point: energy density, stresses and the
/// stress derivative as functions of the deformation gradient F = ∂x/∂X (dimensionless).
///
/// An element integrates it at its quadrature points ξ_q with weights w_q (volume units):
/// E = Σ_q w_q ψ(F_q), nodal force f_a = −Σ_q w_q P(F_q)·∇N_a(ξ_q), tangent block
/// K_ab = Σ_q w_q ∇N_aᵀ·(∂P/∂F)(F_q)·∇N_b, with F_q = Σ_a x_a ⊗ ∇N_a(ξ_q).
pub trait ConstitutiveLaw {
    /// Strain energy density ψ(F) per rest volume (energy/volume, J/m³ = Pa in SI); zero at
    /// F = I.
    fn energy_density(&self, f: &Matrix3<f64>) -> f64;

    /// First Piola–Kirchhoff stress P = ∂ψ/∂F (stress units, force per rest area).
    fn first_piola(&self, f: &Matrix3<f64>) -> Matrix3<f64>;

    /// The derivative A = ∂P/∂F at `f` (stress units) as a [`Matrix9`]: column i + 3j is
    /// dP for dF = eᵢ⊗eⱼ. Symmetric for a law with an energy (A = ∂²ψ/∂F²).
    fn piola_tangent(&self, f: &Matrix3<f64>) -> Matrix9;

    /// Cauchy (true) stress σ = J⁻¹·P·Fᵀ (stress units), or what the model reports in its
    /// place where J ≤ 0 (see each model).
    fn cauchy(&self, f: &Matrix3<f64>) -> Matrix3<f64>;
}

/// The [`Matrix9`] of a directional derivative dF ↦ dP, one unit direction per column.
pub(crate) fn tangent_of(dpiola: impl Fn(&Matrix3<f64>) -> Matrix3<f64>) -> Matrix9 {
    let mut a = Matrix9::zeros();
    for c in 0..9 {
        let mut direction = Matrix3::zeros();
        direction[c] = 1.0;
        a.set_column(
            c,
            &nalgebra::SVector::<f64, 9>::from_column_slice(dpiola(&direction).as_slice()),
        );
    }
    a
}
