//! The Taylor–Hood P2–P1 tet for corotational elasticity at large rotation: the mixed
//! (displacement–pressure) form of [`Corotational`](crate::model::Corotational)'s
//! corotated-linear energy, total Lagrangian, on the element of
//! [`taylor_hood_neo_hookean`](super::taylor_hood_neo_hookean).
//!
//! With R the rotation of the polar decomposition of F (det R = +1), the corotated strain
//! ε = sym(RᵀF) − I (RᵀF is symmetric, so ε = RᵀF − I), the pressure p (Pa, positive in
//! compression) an unknown of its own, shear modulus μ and bulk modulus κ (Pa), the energy per
//! rest volume is
//!
//! ```text
//!   W(F, p) = μ‖dev ε‖² − p·tr ε − p²/(2κ),
//! ```
//!
//! stationary in p where p = −κ·tr ε, which leaves μ‖dev ε‖² + κ/2·tr²ε = μ‖ε‖² + λ/2·tr²ε
//! (κ = λ + 2μ/3): the displacement model's energy, without λ in the displacement's blocks.
//! Because ε is symmetric and dR = R\[w\]× is R times a skew matrix, d tr(RᵀF) = tr(RᵀdF): the
//! volume measure tr ε has the gradient R, as J has cof F in the Neo-Hookean form. Hence
//!
//! ```text
//!   P = 2μ(F − R) + c·R,   c = −(2μ/3)·tr ε − p,
//!   R_u,ia = ∫ (P·∇Nᵢ)_a dV,    R_p,k = ∫ L_k·(−tr ε − p/κ) dV,    G_kia = ∫ L_k (R·∇Nᵢ)_a dV,
//! ```
//!
//! and K_uu the derivative of P at fixed p, rotation terms included as the displacement model
//! has them: dP = 2μ·dF + (c − 2μ)·dR − (2μ/3)·tr(RᵀdF)·R, with dR = R\[w\]×,
//! (tr S·I − S)·w = axial(RᵀdF − dFᵀR), S = RᵀF. The tangent [K_uu −Gᵀ; −G −M_p/κ] is the
//! Hessian of Σ∫W dV − f·u, symmetric, and at F = I, p = 0 it is the linear Taylor–Hood element
//! exactly (c = 0, dR = skew dF, dP = 2μ dev sym dF).
//!
//! **Not PSD-projected.** The displacement model projects each element's tangent onto the
//! positive semi-definite cone, which its plain Newton needs under compression. Here the
//! projection would make K_uu no longer the derivative of R_u (Newton linear, not quadratic)
//! and would not make the saddle tangent any more factorable: the LDLᵀ without pivoting needs
//! K_uu positive definite on the free DOFs, which the exact K_uu is at moderate strain (its
//! rotation term is −(2μ + p + (2μ/3)tr ε)·dR, dominated by −2μ·dR while |p| ≪ μ), the same
//! condition the Neo-Hookean mixed tangent has.
//!
//! **R per quadrature point**, as the displacement model on 10-node tets has it
//! (`model::quadrature_points`): a bent quadratic tet turns by different angles across it, and
//! per point W is one hyperelastic law at each point (its tangent the Hessian of its energy).
//! Integrated with the degree-2 rule of [`Tet10`](super::Tet10) (4 points, weight V/4), exact
//! for the linear limit. The polar rotation is the caller's ([`PolarRotation`]): elements come
//! before the force models in the data flow, and the models own the decomposition
//! (`tetfem::model::rotation`, robust to inverted tets, so that no state here is refused for
//! J ≤ 0; a non-finite F is).

use nalgebra::{Matrix3, SMatrix, Vector3};

use super::taylor_hood::PRESSURE_NODES;
use super::taylor_hood_neo_hookean::{MixedElementState, add_point};
use super::tet10::Tet10Rest;

/// The rotation of F's polar decomposition (det R = +1), supplied by the caller
/// (`tetfem::model::rotation`).
pub type PolarRotation = fn(&Matrix3<f64>) -> Matrix3<f64>;

/// The degree-2 rule's barycentric coordinates (as [`Tet10Rest::gradients`]).
const RULE_ALPHA: f64 = 0.585_410_196_624_968_5;
const RULE_BETA: f64 = 0.138_196_601_125_010_5;

/// The element state of a 10-node tet with rest data `rest` at node-major displacement `u`
/// (30 values, length) and corner pressures `p` (Pa), for shear modulus `mu` (Pa) and inverse
/// bulk modulus `inverse_bulk` (1/Pa), R from `rotation` at each point (see the
/// [module](self) docs). `None` when F is not finite at a quadrature point.
pub fn mixed_corotational(
    rest: &Tet10Rest,
    u: &[f64; 30],
    p: &[f64; PRESSURE_NODES],
    (mu, inverse_bulk): (f64, f64),
    rotation: PolarRotation,
) -> Option<MixedElementState> {
    let mut state = MixedElementState {
        force: [0.0; 30],
        pressure_residual: [0.0; PRESSURE_NODES],
        stiffness: SMatrix::zeros(),
        coupling: [[[0.0; 3]; 10]; PRESSURE_NODES],
    };
    for (q, gradients) in rest.gradients().iter().enumerate() {
        let weight = rest.weights()[q];
        let l = rule_pressure_weights(q);
        let pressure: f64 = l.iter().zip(p).map(|(l, p)| l * p).sum();
        let point =
            CorotatedPoint::new(&deformation_gradient(gradients, u), mu, pressure, rotation)?;
        let piola = point.piola();
        let values = (&piola, &point.r, point.trace, pressure * inverse_bulk);
        add_point(&mut state, gradients, (weight, &l), values, |df| {
            point.piola_direction(df)
        });
    }
    Some(state)
}

/// Σ_q w_q W(F_q, p_q) (energy, force·length) of the state of [`mixed_corotational`]: the
/// potential whose derivatives the state holds (R_u = ∂/∂u, R_p = ∂/∂p).
pub fn mixed_corotational_energy(
    rest: &Tet10Rest,
    u: &[f64; 30],
    p: &[f64; PRESSURE_NODES],
    (mu, inverse_bulk): (f64, f64),
    rotation: PolarRotation,
) -> f64 {
    rest.gradients()
        .iter()
        .zip(rest.weights())
        .enumerate()
        .map(|(q, (gradients, weight))| {
            let pressure: f64 = rule_pressure_weights(q)
                .iter()
                .zip(p)
                .map(|(l, p)| l * p)
                .sum();
            let f = deformation_gradient(gradients, u);
            CorotatedPoint::new(&f, mu, pressure, rotation).map_or(f64::NAN, |point| {
                weight * point.energy_density(inverse_bulk)
            })
        })
        .sum()
}

/// The corner shape functions L_k at quadrature point `q` of the degree-2 rule.
fn rule_pressure_weights(q: usize) -> [f64; PRESSURE_NODES] {
    std::array::from_fn(|k| if k == q { RULE_ALPHA } else { RULE_BETA })
}

/// F = I + Σᵢ uᵢ ⊗ ∇Nᵢ from one point's shape gradients (u, not x: no cancellation of the rest
/// positions at small strain).
fn deformation_gradient(gradients: &[Vector3<f64>; 10], u: &[f64; 30]) -> Matrix3<f64> {
    let mut f = Matrix3::identity();
    for (i, g) in gradients.iter().enumerate() {
        f += Vector3::new(u[3 * i], u[3 * i + 1], u[3 * i + 2]) * g.transpose();
    }
    f
}

/// The kinematics and stress of one point (also the single point of the 4-node stabilized
/// P1–P1 element, whose F is constant).
pub(super) struct CorotatedPoint {
    f: Matrix3<f64>,
    /// R, the polar rotation of F: also ∂tr ε/∂F.
    pub(super) r: Matrix3<f64>,
    /// S = sym(RᵀF).
    s: Matrix3<f64>,
    /// tr ε = tr S − 3.
    pub(super) trace: f64,
    mu: f64,
    pressure: f64,
    /// (tr S·I − S)⁻¹, `None` where two principal stretches sum to zero (a tet flattened
    /// through itself): R is not differentiable there and its term is dropped, as the
    /// displacement model does.
    rotation_system: Option<Matrix3<f64>>,
}

impl CorotatedPoint {
    /// The point at F = `f` with pressure `pressure` (Pa) and shear modulus `mu` (Pa); `None`
    /// when F is not finite.
    pub(super) fn new(
        f: &Matrix3<f64>,
        mu: f64,
        pressure: f64,
        rotation: PolarRotation,
    ) -> Option<Self> {
        if !f.iter().all(|v| v.is_finite()) {
            return None;
        }
        let r = rotation(f);
        let turned = r.transpose() * f;
        let s = (turned + turned.transpose()) * 0.5;
        Some(CorotatedPoint {
            f: *f,
            r,
            s,
            trace: s.trace() - 3.0,
            mu,
            pressure,
            rotation_system: (Matrix3::identity() * s.trace() - s).try_inverse(),
        })
    }

    /// c = −(2μ/3)·tr ε − p: the multiplier of R in P.
    fn volumetric(&self) -> f64 {
        -2.0 * self.mu / 3.0 * self.trace - self.pressure
    }

    /// P = 2μ(F − R) + c·R (Pa).
    pub(super) fn piola(&self) -> Matrix3<f64> {
        (self.f - self.r) * (2.0 * self.mu) + self.r * self.volumetric()
    }

    /// dP for the direction dF at fixed p (see the [module](self) docs).
    pub(super) fn piola_direction(&self, df: &Matrix3<f64>) -> Matrix3<f64> {
        let rt_df = self.r.transpose() * df;
        let w = self.rotation_system.map_or(Vector3::zeros(), |inverse| {
            let a = rt_df - rt_df.transpose();
            inverse * Vector3::new(a[(2, 1)], a[(0, 2)], a[(1, 0)])
        });
        let dr = self.r * w.cross_matrix();
        df * (2.0 * self.mu) + dr * (self.volumetric() - 2.0 * self.mu)
            - self.r * (2.0 * self.mu / 3.0 * rt_df.trace())
    }

    /// W = μ‖dev ε‖² − p·tr ε − p²/(2κ) (energy per rest volume, Pa) for 1/κ `inverse_bulk`.
    pub(super) fn energy_density(&self, inverse_bulk: f64) -> f64 {
        let strain = self.s - Matrix3::identity();
        let deviator = strain - Matrix3::identity() * (self.trace / 3.0);
        self.mu * deviator.norm_squared()
            - self.pressure * self.trace
            - 0.5 * self.pressure * self.pressure * inverse_bulk
    }
}
