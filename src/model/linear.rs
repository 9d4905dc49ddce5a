//! The linear (Cauchy strain) model as a force model.

use nalgebra::{Matrix3, Vector3};

use super::ForceModel;
use crate::element::{Matrix12, Tet, Vector12};
use crate::material::Material;

/// f = −Kₑ·u, u = x − X; energy ½uᵀKₑu; tangent Kₑ (constant); stress σ = λ·tr(ε)·I + 2μ·ε
/// of the small strain ε = sym ∇u.
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
