//! The stabilized P1–P1 tet ([`stabilized_p1`](super::stabilized_p1)) for Neo-Hookean rubber at
//! large deformation: the mixed energy of
//! [`taylor_hood_neo_hookean`](super::taylor_hood_neo_hookean) (Simo & Taylor,
//! W(F, p) = μ/2·(Ī₁ − 3) − p·(J − 1) − p²/(2κ)) on the 4-node tet, with the projection
//! stabilization −(1/2μ)∫(p − Πp)² dV added to the pressure's part.
//!
//! F is constant on the tet and P is linear in p, so every integral is closed-form with the
//! mean corner pressure p̄ = Σp_k/4 (V the rest volume, ∇Nᵢ the shape gradients):
//!
//! ```text
//!   R_u,ia = V·(P(F, p̄)·∇Nᵢ)_a,      R_p,k = −(J − 1)·V/4 − Σ_l C_kl p_l,
//!   G_kia  = (V/4)·(cof F·∇Nᵢ)_a,     K_uu = V·∂P/∂F(F, p̄),
//! ```
//!
//! with C the linear element's pressure block (the pressure mass over κ plus the
//! stabilization, [`pressure_block`]), so the tangent [K_uu −Gᵀ; −G −C] is symmetric, and at
//! F = I, p = 0 it is the linear stabilized P1–P1 element exactly. A homogeneous deformation
//! has a constant pressure, on which the stabilization vanishes: its pressure is −κ(J − 1)
//! at every node, as for the continuum.

use nalgebra::{Matrix3, SMatrix, Vector3};

use super::Tet;
use super::stabilized_p1::{Coupling, PRESSURE_NODES, pressure_block};
use super::taylor_hood_neo_hookean::Point;

/// One element's residuals and tangent blocks at a state (see the [module](self) docs).
#[derive(Debug, Clone, PartialEq)]
pub struct StabilizedElementState {
    /// R_u: the internal nodal forces V·P·∇Nᵢ (force), node-major (3i + a).
    pub force: [f64; 12],
    /// R_p: −(J − 1)·V/4 − Σ_l C_kl p_l per corner (length³).
    pub pressure_residual: [f64; PRESSURE_NODES],
    /// K_uu (force/length), row 3i + a, column 3j + b: symmetric.
    pub stiffness: SMatrix<f64, 12, 12>,
    /// G_kia = (V/4)(cof F·∇Nᵢ)_a (length²).
    pub coupling: Coupling,
}

/// The element state of a 4-node tet with rest data `rest` at node-major displacement `u`
/// (12 values, length) and corner pressures `p` (Pa), for shear modulus `mu` (Pa) and inverse
/// bulk modulus `inverse_bulk` (1/Pa). `None` when J ≤ 0 (the tet is inverted).
pub fn stabilized_neo_hookean(
    rest: &Tet,
    u: &[f64],
    p: &[f64; PRESSURE_NODES],
    mu: f64,
    inverse_bulk: f64,
) -> Option<StabilizedElementState> {
    let gradients = rest.shape_gradients();
    let mut f = Matrix3::identity();
    for (i, g) in gradients.iter().enumerate() {
        f += Vector3::new(u[3 * i], u[3 * i + 1], u[3 * i + 2]) * g.transpose();
    }
    let mean_pressure = p.iter().sum::<f64>() / 4.0;
    let point = Point::new(&f, mu, mean_pressure)?;
    let (cof, piola) = (point.cofactor(), point.piola());
    Some(stabilized_state(
        rest,
        p,
        (mu, inverse_bulk),
        (&piola, &cof, point.j - 1.0),
        |df| point.piola_direction(df),
    ))
}

/// The element state of a 4-node tet from one point's values: the first Piola–Kirchhoff
/// stress `piola` (Pa) at the mean pressure, the matrix `volumetric` (cof F, or R for the
/// corotated strain) whose product with ∇Nᵢ is ∂(volume change)/∂uᵢ, the volume change
/// `change` (J − 1, or tr ε), and dP for a direction dF at fixed p (`piola_direction`, Pa):
/// R_u = V·P·∇Nᵢ, G_kia = (V/4)(volumetric·∇Nᵢ)_a, R_p,k = −change·V/4 − Σ_l C_kl p_l, K_uu =
/// V·∂P/∂F (see the [module](self) docs).
pub(crate) fn stabilized_state(
    rest: &Tet,
    p: &[f64; PRESSURE_NODES],
    (mu, inverse_bulk): (f64, f64),
    (piola, volumetric, change): (&Matrix3<f64>, &Matrix3<f64>, f64),
    piola_direction: impl Fn(&Matrix3<f64>) -> Matrix3<f64>,
) -> StabilizedElementState {
    let volume = rest.volume();
    let gradients = rest.shape_gradients();
    let quarter = volume / 4.0;
    let mut state = StabilizedElementState {
        force: [0.0; 12],
        pressure_residual: [0.0; PRESSURE_NODES],
        stiffness: SMatrix::zeros(),
        coupling: [[[0.0; 3]; 4]; PRESSURE_NODES],
    };
    for (i, g) in gradients.iter().enumerate() {
        let force = piola * g;
        let divergence = volumetric * g;
        for a in 0..3 {
            state.force[3 * i + a] = volume * force[a];
            for row in state.coupling.iter_mut() {
                row[i][a] = quarter * divergence[a];
            }
        }
    }
    for (k, r) in state.pressure_residual.iter_mut().enumerate() {
        let block: f64 = (0..PRESSURE_NODES)
            .map(|l| pressure_block(rest, mu, inverse_bulk, k, l) * p[l])
            .sum();
        *r = -change * quarter - block;
    }
    for (j, gj) in gradients.iter().enumerate() {
        for b in 0..3 {
            let mut df = Matrix3::zeros();
            df.set_row(b, &gj.transpose());
            let dp = piola_direction(&df);
            for (i, gi) in gradients.iter().enumerate() {
                let column = dp * gi;
                for a in 0..3 {
                    state.stiffness[(3 * i + a, 3 * j + b)] = volume * column[a];
                }
            }
        }
    }
    state
}
