//! The linear (Cauchy strain) model as a force model.

use nalgebra::{Matrix3, Vector3};

use super::ForceModel;
use super::law::{ConstitutiveLaw, Matrix9, tangent_of};
use crate::fe::element::{Matrix12, Tet, Vector12};
use crate::fe::material::Material;

/// f = −Kₑ·u, u = x − X; energy ½uᵀKₑu; tangent Kₑ (constant); stress σ = λ·tr(ε)·I + 2μ·ε
/// of the small strain ε = sym ∇u.
///
/// Per point ([`ConstitutiveLaw`]): ε = sym(F) − I, ψ = ½σ:ε, P = σ, ∂P/∂F = C (Hooke's
/// tensor): integrated exactly by an element's stiffness rule, it is that element's linear
/// model.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LinearModel {
    material: Material,
}

impl LinearModel {
    /// The model for `material`.
    pub fn new(material: &Material) -> Self {
        LinearModel {
            material: *material,
        }
    }
}

fn displacement(rest: &[Vector3<f64>; 4], x: &[Vector3<f64>; 4]) -> Vector12 {
    Vector12::from_fn(|i, _| x[i / 3][i % 3] - rest[i / 3][i % 3])
}

impl ForceModel for LinearModel {
    fn energy(&self, tet: &Tet, rest: &[Vector3<f64>; 4], x: &[Vector3<f64>; 4]) -> f64 {
        let u = displacement(rest, x);
        0.5 * u.dot(&(tet.stiffness(&self.material) * u))
    }

    fn force(&self, tet: &Tet, rest: &[Vector3<f64>; 4], x: &[Vector3<f64>; 4]) -> Vector12 {
        -(tet.stiffness(&self.material) * displacement(rest, x))
    }

    fn tangent(&self, tet: &Tet, _rest: &[Vector3<f64>; 4], _x: &[Vector3<f64>; 4]) -> Matrix12 {
        tet.stiffness(&self.material)
    }

    fn cauchy_stress(
        &self,
        tet: &Tet,
        rest: &[Vector3<f64>; 4],
        x: &[Vector3<f64>; 4],
    ) -> Matrix3<f64> {
        tet.stress(&self.material, &displacement(rest, x))
    }

    fn name(&self) -> &'static str {
        "linear"
    }
}

impl LinearModel {
    /// σ = λ·tr(ε)·I + 2μ·ε of the small strain ε = sym(F) − I.
    fn hooke(&self, f: &Matrix3<f64>) -> Matrix3<f64> {
        let strain = (f + f.transpose()) * 0.5 - Matrix3::identity();
        Matrix3::identity() * (self.material.lame_lambda() * strain.trace())
            + strain * (2.0 * self.material.shear_modulus())
    }
}

impl ConstitutiveLaw for LinearModel {
    fn energy_density(&self, f: &Matrix3<f64>) -> f64 {
        let strain = (f + f.transpose()) * 0.5 - Matrix3::identity();
        0.5 * self.hooke(f).component_mul(&strain).sum()
    }

    fn first_piola(&self, f: &Matrix3<f64>) -> Matrix3<f64> {
        self.hooke(f)
    }

    /// Hooke's tensor C (independent of F): dP = λ·tr(dF)·I + μ(dF + dFᵀ).
    fn piola_tangent(&self, _f: &Matrix3<f64>) -> Matrix9 {
        let (lambda, mu) = (self.material.lame_lambda(), self.material.shear_modulus());
        tangent_of(|df| Matrix3::identity() * (lambda * df.trace()) + (df + df.transpose()) * mu)
    }

    fn cauchy(&self, f: &Matrix3<f64>) -> Matrix3<f64> {
        self.hooke(f)
    }
}
