//! St. Venant–Kirchhoff hyperelasticity: Hooke's law on the Green strain.

use nalgebra::{Matrix3, Vector3};

use super::law::{ConstitutiveLaw, Matrix9, tangent_of};
use super::{ForceModel, piola_to_force, tangent_from_piola_derivative};
use crate::fe::element::{Matrix12, Tet, Vector12, rest_shape_matrix};
use crate::fe::material::Material;

/// Ψ(F) = μ·E:E + λ/2·tr(E)² with the Green strain E = ½(FᵀF − I) (energy per rest volume):
/// the linear model's energy with ε replaced by E, so it is rotation-invariant and equal to
/// Hooke's law for small strains, with the material's λ and μ.
///
/// First Piola–Kirchhoff stress P = F·S with the second S = 2μE + λ·tr(E)·I; the tangent is
/// exact, dP = dF·S + F·dS with dE = ½(dFᵀF + FᵀdF). Everything is polynomial in F, so it is
/// finite for any F; but the energy does not grow without bound as a tet is crushed (it falls
/// again past about 58 % compression in one direction, and an inverted tet can be a stable
/// state), so it suits large rotations with moderate strains — use [`NeoHookean`](super::NeoHookean)
/// where tets may be squashed.
///
/// Cauchy stress σ = J⁻¹·F·S·Fᵀ; for an inverted or flat tet (J ≤ 0) the Kirchhoff stress
/// τ = F·S·Fᵀ = J·σ is returned instead (finite, and the same as σ to first order).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StVenantKirchhoff {
    lambda: f64,
    mu: f64,
}

impl StVenantKirchhoff {
    /// The model for `material` (its Lamé λ and shear modulus μ).
    pub fn new(material: &Material) -> Self {
        StVenantKirchhoff {
            lambda: material.lame_lambda(),
            mu: material.shear_modulus(),
        }
    }

    /// Second Piola–Kirchhoff stress S = 2μE + λ·tr(E)·I of a Green strain E (stress units).
    fn second_piola(&self, green: &Matrix3<f64>) -> Matrix3<f64> {
        green * (2.0 * self.mu) + Matrix3::identity() * (self.lambda * green.trace())
    }
}

/// Deformation gradient F and Green strain E = ½(FᵀF − I) of the tet at deformed positions `x`.
fn kinematics(tet: &Tet, x: &[Vector3<f64>; 4]) -> (Matrix3<f64>, Matrix3<f64>) {
    point_kinematics(rest_shape_matrix(x) * tet.rest_inverse())
}

/// F and its Green strain E = ½(FᵀF − I).
fn point_kinematics(f: Matrix3<f64>) -> (Matrix3<f64>, Matrix3<f64>) {
    let green = (f.transpose() * f - Matrix3::identity()) * 0.5;
    (f, green)
}

impl StVenantKirchhoff {
    /// μ·E:E + λ/2·tr(E)² (energy per rest volume).
    fn density(&self, green: &Matrix3<f64>) -> f64 {
        self.mu * green.norm_squared() + 0.5 * self.lambda * green.trace().powi(2)
    }

    /// The map dF ↦ dP = dF·S + F·S(dE) at `f` with Green strain `green`.
    fn piola_direction(
        &self,
        f: Matrix3<f64>,
        green: &Matrix3<f64>,
    ) -> impl Fn(&Matrix3<f64>) -> Matrix3<f64> + '_ {
        let s = self.second_piola(green);
        move |df: &Matrix3<f64>| {
            let dgreen = (df.transpose() * f + f.transpose() * df) * 0.5;
            df * s + f * self.second_piola(&dgreen)
        }
    }

    /// σ = J⁻¹·F·S·Fᵀ, or τ = F·S·Fᵀ where J ≤ 0.
    fn stress(&self, f: &Matrix3<f64>, green: &Matrix3<f64>) -> Matrix3<f64> {
        let kirchhoff = f * self.second_piola(green) * f.transpose();
        let j = f.determinant();
        if j > 0.0 { kirchhoff / j } else { kirchhoff }
    }
}

impl ForceModel for StVenantKirchhoff {
    fn energy(&self, tet: &Tet, _rest: &[Vector3<f64>; 4], x: &[Vector3<f64>; 4]) -> f64 {
        let (_, green) = kinematics(tet, x);
        tet.volume() * self.density(&green)
    }

    fn force(&self, tet: &Tet, _rest: &[Vector3<f64>; 4], x: &[Vector3<f64>; 4]) -> Vector12 {
        let (f, green) = kinematics(tet, x);
        piola_to_force(tet, &(f * self.second_piola(&green)))
    }

    fn tangent(&self, tet: &Tet, _rest: &[Vector3<f64>; 4], x: &[Vector3<f64>; 4]) -> Matrix12 {
        let (f, green) = kinematics(tet, x);
        tangent_from_piola_derivative(tet, self.piola_direction(f, &green))
    }

    fn cauchy_stress(
        &self,
        tet: &Tet,
        _rest: &[Vector3<f64>; 4],
        x: &[Vector3<f64>; 4],
    ) -> Matrix3<f64> {
        let (f, green) = kinematics(tet, x);
        self.stress(&f, &green)
    }

    fn name(&self) -> &'static str {
        "st-venant-kirchhoff"
    }
}

impl ConstitutiveLaw for StVenantKirchhoff {
    fn energy_density(&self, f: &Matrix3<f64>) -> f64 {
        self.density(&point_kinematics(*f).1)
    }

    fn first_piola(&self, f: &Matrix3<f64>) -> Matrix3<f64> {
        let (f, green) = point_kinematics(*f);
        f * self.second_piola(&green)
    }

    fn piola_tangent(&self, f: &Matrix3<f64>) -> Matrix9 {
        let (f, green) = point_kinematics(*f);
        tangent_of(self.piola_direction(f, &green))
    }

    fn cauchy(&self, f: &Matrix3<f64>) -> Matrix3<f64> {
        let (f, green) = point_kinematics(*f);
        self.stress(&f, &green)
    }
}
