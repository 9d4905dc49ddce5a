//! Stable Neo-Hookean hyperelasticity (Smith, de Goes & Kim 2018).

use nalgebra::{Matrix3, Vector3};

use super::law::{ConstitutiveLaw, Matrix9, tangent_of};
use super::{ForceModel, piola_to_force, tangent_from_piola_derivative};
use crate::fe::element::{Matrix12, Tet, Vector12, rest_shape_matrix};
use crate::fe::material::Material;

/// Ψ(F) = μ/2·(tr(FᵀF) − 3) + λ̂/2·(J − α)² − λ̂/2·(1 − α)², with J = det F, λ̂ = λ + μ and
/// α = 1 + μ/λ̂ (energy per rest volume).
///
/// The choice of λ̂ and α makes the rest state stress-free and the small-strain limit exactly
/// Hooke's law with the material's λ and μ. J enters polynomially (no log J), so the energy, the
/// force and the tangent are finite for inverted tets (J ≤ 0), which are pushed back. P =
/// μF + λ̂(J − α)·cof F; the tangent is exact (cof F differentiated column by column:
/// cof F = [f₁×f₂, f₂×f₀, f₀×f₁]) and may be indefinite; the assembly projects it.
///
/// Cauchy stress σ = J⁻¹·P·Fᵀ = (μ/J)·F·Fᵀ + λ̂(J − α)·I (cof F·Fᵀ = J·I): zero under rigid
/// motions (F = R gives μ + λ̂(1 − α) = 0). For an inverted or flat tet (J ≤ 0), where the
/// Cauchy stress is undefined, the Kirchhoff stress τ = P·Fᵀ = J·σ is returned instead (finite,
/// and the same as σ to first order).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NeoHookean {
    mu: f64,
    lambda_hat: f64,
    alpha: f64,
}

impl NeoHookean {
    /// The model for `material`.
    pub fn new(material: &Material) -> Self {
        let mu = material.shear_modulus();
        let lambda_hat = material.lame_lambda() + mu;
        NeoHookean {
            mu,
            lambda_hat,
            alpha: 1.0 + mu / lambda_hat,
        }
    }
}

fn cofactor(f: &Matrix3<f64>) -> Matrix3<f64> {
    let c = |i: usize| f.column(i).into_owned();
    Matrix3::from_columns(&[c(1).cross(&c(2)), c(2).cross(&c(0)), c(0).cross(&c(1))])
}

fn cofactor_direction(f: &Matrix3<f64>, df: &Matrix3<f64>) -> Matrix3<f64> {
    let c = |m: &Matrix3<f64>, i: usize| -> Vector3<f64> { m.column(i).into_owned() };
    Matrix3::from_columns(&[
        c(df, 1).cross(&c(f, 2)) + c(f, 1).cross(&c(df, 2)),
        c(df, 2).cross(&c(f, 0)) + c(f, 2).cross(&c(df, 0)),
        c(df, 0).cross(&c(f, 1)) + c(f, 0).cross(&c(df, 1)),
    ])
}

impl NeoHookean {
    /// Ψ(F) (energy per rest volume).
    fn density(&self, f: &Matrix3<f64>) -> f64 {
        self.density_at(f, f.determinant())
    }

    /// [`density`](Self::density) with J = det F given (the force pass shares it with P).
    fn density_at(&self, f: &Matrix3<f64>, j: f64) -> f64 {
        let rest = 0.5 * self.lambda_hat * (1.0 - self.alpha).powi(2);
        0.5 * self.mu * (f.norm_squared() - 3.0) + 0.5 * self.lambda_hat * (j - self.alpha).powi(2)
            - rest
    }

    /// P = μF + λ̂(J − α)·cof F.
    fn piola(&self, f: &Matrix3<f64>) -> Matrix3<f64> {
        self.piola_at(f, f.determinant())
    }

    /// [`piola`](Self::piola) with J = det F given.
    fn piola_at(&self, f: &Matrix3<f64>, j: f64) -> Matrix3<f64> {
        f * self.mu + cofactor(f) * (self.lambda_hat * (j - self.alpha))
    }

    /// The map dF ↦ dP at `f`.
    fn piola_direction(&self, f: Matrix3<f64>) -> impl Fn(&Matrix3<f64>) -> Matrix3<f64> + '_ {
        let cof = cofactor(&f);
        let j = f.determinant();
        move |df: &Matrix3<f64>| {
            df * self.mu
                + cof * (self.lambda_hat * cof.component_mul(df).sum())
                + cofactor_direction(&f, df) * (self.lambda_hat * (j - self.alpha))
        }
    }

    /// σ (or τ = J·σ where J ≤ 0, see the type's docs).
    fn stress(&self, f: &Matrix3<f64>) -> Matrix3<f64> {
        let j = f.determinant();
        let left_cauchy_green = f * f.transpose();
        let volumetric = Matrix3::identity() * (self.lambda_hat * (j - self.alpha));
        if j > 0.0 {
            left_cauchy_green * (self.mu / j) + volumetric
        } else {
            left_cauchy_green * self.mu + volumetric * j
        }
    }
}

impl ForceModel for NeoHookean {
    fn energy(&self, tet: &Tet, _rest: &[Vector3<f64>; 4], x: &[Vector3<f64>; 4]) -> f64 {
        tet.volume() * self.density(&(rest_shape_matrix(x) * tet.rest_inverse()))
    }

    fn force(&self, tet: &Tet, _rest: &[Vector3<f64>; 4], x: &[Vector3<f64>; 4]) -> Vector12 {
        piola_to_force(
            tet,
            &self.piola(&(rest_shape_matrix(x) * tet.rest_inverse())),
        )
    }

    /// One F and one det F for both (a line search's trial point needs both): the same bits
    /// as [`force`](ForceModel::force) and [`energy`](ForceModel::energy) apart.
    fn force_and_energy(
        &self,
        tet: &Tet,
        _rest: &[Vector3<f64>; 4],
        x: &[Vector3<f64>; 4],
    ) -> (Vector12, f64) {
        let f = rest_shape_matrix(x) * tet.rest_inverse();
        let j = f.determinant();
        (
            piola_to_force(tet, &self.piola_at(&f, j)),
            tet.volume() * self.density_at(&f, j),
        )
    }

    fn tangent(&self, tet: &Tet, _rest: &[Vector3<f64>; 4], x: &[Vector3<f64>; 4]) -> Matrix12 {
        let f = rest_shape_matrix(x) * tet.rest_inverse();
        tangent_from_piola_derivative(tet, self.piola_direction(f))
    }

    fn cauchy_stress(
        &self,
        tet: &Tet,
        _rest: &[Vector3<f64>; 4],
        x: &[Vector3<f64>; 4],
    ) -> Matrix3<f64> {
        self.stress(&(rest_shape_matrix(x) * tet.rest_inverse()))
    }

    fn name(&self) -> &'static str {
        "neo-hookean"
    }
}

impl ConstitutiveLaw for NeoHookean {
    fn energy_density(&self, f: &Matrix3<f64>) -> f64 {
        self.density(f)
    }

    fn first_piola(&self, f: &Matrix3<f64>) -> Matrix3<f64> {
        self.piola(f)
    }

    fn piola_tangent(&self, f: &Matrix3<f64>) -> Matrix9 {
        tangent_of(self.piola_direction(*f))
    }

    fn cauchy(&self, f: &Matrix3<f64>) -> Matrix3<f64> {
        self.stress(f)
    }
}
