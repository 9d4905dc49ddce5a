//! The stabilized P1–P1 tet ([`stabilized_p1`](super::stabilized_p1)) for corotational
//! elasticity at large rotation: the mixed energy of
//! [`taylor_hood_corotational`](super::taylor_hood_corotational)
//! (W(F, p) = μ‖dev ε‖² − p·tr ε − p²/(2κ), ε = sym(RᵀF) − I, R the polar rotation of F) on
//! the 4-node tet, with the projection stabilization −(1/2μ)∫(p − Πp)² dV added to the
//! pressure's part, as [`stabilized_p1_neo_hookean`](super::stabilized_p1_neo_hookean) has it.
//!
//! F is constant on the tet, so one R per tet (the displacement model's, exactly) and every
//! integral is closed-form with the mean corner pressure p̄ = Σp_k/4 (V the rest volume, ∇Nᵢ
//! the shape gradients):
//!
//! ```text
//!   R_u,ia = V·(P(F, p̄)·∇Nᵢ)_a,      R_p,k = −tr ε·V/4 − Σ_l C_kl p_l,
//!   G_kia  = (V/4)·(R·∇Nᵢ)_a,         K_uu = V·∂P/∂F(F, p̄),
//! ```
//!
//! with C the linear element's pressure block ([`pressure_block`]): the tangent
//! [K_uu −Gᵀ; −G −C] is symmetric and at F = I, p = 0 it is the linear stabilized P1–P1
//! element exactly. A homogeneous deformation has a constant pressure, −κ·tr ε at every node.

use nalgebra::{Matrix3, Vector3};

use super::Tet;
use super::stabilized_p1::{PRESSURE_NODES, pressure_block};
use super::stabilized_p1_neo_hookean::{StabilizedElementState, stabilized_state};
use super::taylor_hood_corotational::{CorotatedPoint, PolarRotation};

/// The element state of a 4-node tet with rest data `rest` at node-major displacement `u`
/// (12 values, length) and corner pressures `p` (Pa), for shear modulus `mu` (Pa) and inverse
/// bulk modulus `inverse_bulk` (1/Pa), R from `rotation` (see the [module](self) docs). `None`
/// when `u` has other than 12 values or F is not finite.
pub fn stabilized_corotational(
    rest: &Tet,
    u: &[f64],
    p: &[f64; PRESSURE_NODES],
    (mu, inverse_bulk): (f64, f64),
    rotation: PolarRotation,
) -> Option<StabilizedElementState> {
    if u.len() != 12 {
        return None;
    }
    let gradients = rest.shape_gradients();
    let mut f = Matrix3::identity();
    for (i, g) in gradients.iter().enumerate() {
        f += Vector3::new(u[3 * i], u[3 * i + 1], u[3 * i + 2]) * g.transpose();
    }
    let mean_pressure = p.iter().sum::<f64>() / 4.0;
    let point = CorotatedPoint::new(&f, mu, mean_pressure, rotation)?;
    let piola = point.piola();
    Some(stabilized_state(
        rest,
        p,
        (mu, inverse_bulk),
        (&piola, &point.r, point.trace),
        |df| point.piola_direction(df),
    ))
}

/// V·W(F, p̄) − ½Σ_kl C_kl p_k p_l (energy, force·length): the potential whose derivatives
/// [`stabilized_corotational`] holds (the pressure block's quadratic form standing for the
/// p²/(2κ) term and the stabilization); NaN where F is not finite.
pub fn stabilized_corotational_energy(
    rest: &Tet,
    u: &[f64],
    p: &[f64; PRESSURE_NODES],
    (mu, inverse_bulk): (f64, f64),
    rotation: PolarRotation,
) -> f64 {
    if u.len() != 12 {
        return f64::NAN;
    }
    let mut f = Matrix3::identity();
    for (i, g) in rest.shape_gradients().iter().enumerate() {
        f += Vector3::new(u[3 * i], u[3 * i + 1], u[3 * i + 2]) * g.transpose();
    }
    let mean_pressure = p.iter().sum::<f64>() / 4.0;
    let Some(point) = CorotatedPoint::new(&f, mu, mean_pressure, rotation) else {
        return f64::NAN;
    };
    // W without its p² term (inverse_bulk 0); the pressure block's form replaces it.
    let quadratic: f64 = (0..PRESSURE_NODES)
        .flat_map(|k| (0..PRESSURE_NODES).map(move |l| (k, l)))
        .map(|(k, l)| pressure_block(rest, mu, inverse_bulk, k, l) * p[k] * p[l])
        .sum();
    rest.volume() * point.energy_density(0.0) - 0.5 * quadratic
}
