//! The Taylor–Hood P2–P1 tet for Neo-Hookean rubber at large deformation: the mixed
//! (displacement–pressure, perturbed-Lagrangian) form of Simo & Taylor (1991, "Quasi-
//! incompressible finite elasticity in principal stretches", CMAME 85), total Lagrangian.
//!
//! Energy per rest volume, with the pressure p (Pa, positive in compression) an unknown of its
//! own, shear modulus μ and bulk modulus κ (Pa):
//!
//! ```text
//!   W(F, p) = μ/2·(Ī₁ − 3) − p·(J − 1) − p²/(2κ),   Ī₁ = J^(−2/3)·tr(FᵀF),  J = det F,
//! ```
//!
//! stationary in p where p = −κ(J − 1) (the volumetric energy κ/2·(J − 1)² eliminated), so the
//! Cauchy stress is σ = μ·J^(−5/3)·dev(F·Fᵀ) − p·I. The first Piola–Kirchhoff stress is
//! P = μ·J^(−2/3)·(F − Ī₁J^(2/3)/3·F⁻ᵀ) − p·cof F (cof F = J·F⁻ᵀ). The element residuals
//! (the derivatives of Π = Σ∫W dV − f·u) are
//!
//! ```text
//!   R_u,ia = ∫ (P·∇Nᵢ)_a dV,          R_p,k = ∫ L_k·(−(J − 1) − p/κ) dV,
//! ```
//!
//! and the tangent is symmetric, [K_uu −Gᵀ; −G −M_p/κ], with G_kia = ∫ L_k (cof F·∇Nᵢ)_a dV
//! (the current divergence coupling; at F = I it is [`coupling`](super::taylor_hood::coupling))
//! and K_uu the derivative of the deviatoric P plus −p·∂cof F/∂F. At F = I, p = 0 it is the
//! linear Taylor–Hood element exactly (μ/2·(Ī₁ − 3) = μ·dev ε : dev ε to second order).
//!
//! The model is not tetfem's displacement Neo-Hookean ([`NeoHookean`](crate::model::NeoHookean),
//! Smith, de Goes & Kim's λ̂/2·(J − α)²): both are Hooke's law to first order and their
//! volumetric parts differ at finite volume change, which a nearly incompressible body does
//! not have (J − 1 ~ p/κ).
//!
//! Integrated with the degree-2 rule of [`Tet10`](super::Tet10) (4 points, weight V/4), which
//! is exact for the linear limit. Every quantity is per rest volume, so J ≤ 0 (an inverted
//! point) makes J^(−2/3) undefined: [`mixed_neo_hookean`] returns `None` there.

use nalgebra::{Matrix3, SMatrix, Vector3};

use super::taylor_hood::{Coupling, PRESSURE_NODES};
use super::tet10::Tet10Rest;

/// The degree-2 rule's barycentric coordinates (as [`Tet10Rest::gradients`]).
const RULE_ALPHA: f64 = 0.585_410_196_624_968_5;
const RULE_BETA: f64 = 0.138_196_601_125_010_5;

/// One element's residuals and tangent blocks at a state (see the [module](self) docs).
#[derive(Debug, Clone, PartialEq)]
pub struct MixedElementState {
    /// R_u: the internal nodal forces ∫ P·∇Nᵢ dV (force), node-major (3i + a).
    pub force: [f64; 30],
    /// R_p: ∫ L_k·(−(J − 1) − p/κ) dV per corner (length³).
    pub pressure_residual: [f64; PRESSURE_NODES],
    /// K_uu (force/length), row 3i + a, column 3j + b: symmetric.
    pub stiffness: SMatrix<f64, 30, 30>,
    /// G_kia = ∫ L_k (cof F·∇Nᵢ)_a dV (length²).
    pub coupling: Coupling,
}

/// The element state of a 10-node tet with rest data `rest` at node-major displacement `u`
/// (30 values, length) and corner pressures `p` (Pa), for shear modulus `mu` and inverse bulk
/// modulus `inverse_bulk` (1/Pa; 0 is the incompressible limit). `None` when J ≤ 0 at a
/// quadrature point (the tet is inverted there).
pub fn mixed_neo_hookean(
    rest: &Tet10Rest,
    u: &[f64; 30],
    p: &[f64; PRESSURE_NODES],
    mu: f64,
    inverse_bulk: f64,
) -> Option<MixedElementState> {
    let mut state = MixedElementState {
        force: [0.0; 30],
        pressure_residual: [0.0; PRESSURE_NODES],
        stiffness: SMatrix::zeros(),
        coupling: [[[0.0; 3]; 10]; PRESSURE_NODES],
    };
    for (q, gradients) in rest.gradients().iter().enumerate() {
        // V/4 on a straight tet; V_X/4·det G at the point on a curved one.
        let weight = rest.weights()[q];
        let l: [f64; PRESSURE_NODES] =
            std::array::from_fn(|k| if k == q { RULE_ALPHA } else { RULE_BETA });
        let pressure: f64 = l.iter().zip(p).map(|(l, p)| l * p).sum();
        let mut f = Matrix3::identity();
        for (i, g) in gradients.iter().enumerate() {
            f += Vector3::new(u[3 * i], u[3 * i + 1], u[3 * i + 2]) * g.transpose();
        }
        let point = Point::new(&f, mu, pressure)?;
        let (cof, piola) = (point.cofactor(), point.piola());
        let values = (&piola, &cof, point.j - 1.0, pressure * inverse_bulk);
        add_point(&mut state, gradients, (weight, &l), values, |df| {
            point.piola_direction(df)
        });
    }
    Some(state)
}

/// Adds one quadrature point of weight `weight` (length³) and corner pressure weights `l` to
/// `state`, from the point's first Piola–Kirchhoff stress P (Pa), the matrix whose product with
/// ∇Nᵢ is ∂(volume change)/∂uᵢ (cof F, or R for the corotated strain), the volume change
/// (J − 1, or tr ε), p/κ (dimensionless) and dP for a direction dF at fixed p
/// (`piola_direction`, Pa): R_u += w·P·∇Nᵢ, G_kia += w·l_k·(volumetric·∇Nᵢ)_a,
/// R_p,k += w·l_k·(−change − p/κ), K_uu += w·∂P/∂F.
pub(super) fn add_point(
    state: &mut MixedElementState,
    gradients: &[Vector3<f64>; 10],
    (weight, l): (f64, &[f64; 4]),
    (piola, volumetric, change, compliance): (&Matrix3<f64>, &Matrix3<f64>, f64, f64),
    piola_direction: impl Fn(&Matrix3<f64>) -> Matrix3<f64>,
) {
    for (i, g) in gradients.iter().enumerate() {
        let force = piola * g;
        let divergence = volumetric * g;
        for a in 0..3 {
            state.force[3 * i + a] += weight * force[a];
            for (k, row) in state.coupling.iter_mut().enumerate() {
                row[i][a] += weight * l[k] * divergence[a];
            }
        }
    }
    for (k, r) in state.pressure_residual.iter_mut().enumerate() {
        *r += weight * l[k] * (-change - compliance);
    }
    for (j, gj) in gradients.iter().enumerate() {
        for b in 0..3 {
            let mut df = Matrix3::zeros();
            df.set_row(b, &gj.transpose());
            let dp = piola_direction(&df);
            for (i, gi) in gradients.iter().enumerate() {
                let column = dp * gi;
                for a in 0..3 {
                    state.stiffness[(3 * i + a, 3 * j + b)] += weight * column[a];
                }
            }
        }
    }
}

/// The kinematics and stress of one quadrature point (also the single point of the 4-node
/// stabilized P1–P1 element, whose F is constant).
pub(super) struct Point {
    f: Matrix3<f64>,
    /// F⁻ᵀ.
    inverse_transpose: Matrix3<f64>,
    pub(super) j: f64,
    /// μ·J^(−2/3).
    scaled_mu: f64,
    /// I₁ = tr(FᵀF).
    i1: f64,
    pressure: f64,
}

impl Point {
    pub(super) fn new(f: &Matrix3<f64>, mu: f64, pressure: f64) -> Option<Self> {
        let j = f.determinant();
        if j <= 0.0 || !j.is_finite() {
            return None;
        }
        Some(Point {
            f: *f,
            inverse_transpose: f.try_inverse()?.transpose(),
            j,
            scaled_mu: mu * j.powf(-2.0 / 3.0),
            i1: f.norm_squared(),
            pressure,
        })
    }

    /// cof F = J·F⁻ᵀ.
    pub(super) fn cofactor(&self) -> Matrix3<f64> {
        self.inverse_transpose * self.j
    }

    /// P = μJ^(−2/3)·(F − I₁/3·F⁻ᵀ) − p·cof F.
    pub(super) fn piola(&self) -> Matrix3<f64> {
        (self.f - self.inverse_transpose * (self.i1 / 3.0)) * self.scaled_mu
            - self.cofactor() * self.pressure
    }

    /// dP for the direction dF at fixed p: with d(J^(−2/3)) = −⅔J^(−2/3)·F⁻ᵀ:dF,
    /// dI₁ = 2F:dF and dF⁻ᵀ = −F⁻ᵀ·dFᵀ·F⁻ᵀ,
    /// dP = μJ^(−2/3)·[dF − ⅔(F⁻ᵀ:dF)(F − I₁/3·F⁻ᵀ) − ⅔(F:dF)F⁻ᵀ + I₁/3·F⁻ᵀdFᵀF⁻ᵀ]
    ///      − p·J·[(F⁻ᵀ:dF)F⁻ᵀ − F⁻ᵀdFᵀF⁻ᵀ].
    pub(super) fn piola_direction(&self, df: &Matrix3<f64>) -> Matrix3<f64> {
        let h = &self.inverse_transpose;
        let h_df = h.component_mul(df).sum();
        let f_df = self.f.component_mul(df).sum();
        let turned = h * df.transpose() * h;
        let deviatoric =
            (df - (self.f - h * (self.i1 / 3.0)) * (2.0 / 3.0 * h_df) - h * (2.0 / 3.0 * f_df)
                + turned * (self.i1 / 3.0))
                * self.scaled_mu;
        deviatoric - (h * h_df - turned) * (self.pressure * self.j)
    }
}
