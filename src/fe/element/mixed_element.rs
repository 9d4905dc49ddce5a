//! The seam between a mixed displacement–pressure element and the mixed solve
//! ([`MixedStaticSolver`](crate::MixedStaticSolver)): what one tet adds to the saddle point
//! [K_dev −Bᵀ; −B −C] with a continuous linear pressure on its four corners.
//!
//! Two elements implement it: the 10-node Taylor–Hood P2–P1 tet
//! ([`taylor_hood`], C = M_p/κ) and the 4-node stabilized P1–P1 tet
//! ([`stabilized_p1`], C = M_p/κ + the projection stabilization).

use nalgebra::SMatrix;

use super::stabilized_p1_corotational::stabilized_corotational;
use super::stabilized_p1_neo_hookean::{StabilizedElementState, stabilized_neo_hookean};
use super::taylor_hood_corotational::{PolarRotation, mixed_corotational};
use super::taylor_hood_neo_hookean::{MixedElementState, mixed_neo_hookean};
use super::{ElementType, Tet4, Tet10, stabilized_p1, taylor_hood};

/// A mixed element: a displacement element whose four corners also carry the pressure.
pub trait MixedElement: ElementType {
    /// The element's name in messages (e.g. `"Taylor–Hood P2–P1"`).
    const MIXED_NAME: &'static str;

    /// The element's whole deviatoric stiffness (force/length), row 3i + b, column 3j + a.
    type Deviatoric: std::ops::Index<(usize, usize), Output = f64> + Send + Sync;

    /// The element's divergence coupling B (length²), read by [`Self::coupling_entry`].
    type Coupling: Copy + Send + Sync;

    /// K_dev of one element for shear modulus `shear_modulus` (Pa): the linear stiffness with
    /// λ replaced by −2μ/3.
    fn deviatoric_stiffness(rest: &Self::Rest, shear_modulus: f64) -> Self::Deviatoric;

    /// The divergence coupling B_kᵢₐ = ∫ L_k ∂ₐNᵢ dV of one element.
    fn coupling(rest: &Self::Rest) -> Self::Coupling;

    /// B_kᵢₐ of `coupling`: corner k (pressure node), displacement node i, axis a (length²).
    fn coupling_entry(coupling: &Self::Coupling, k: usize, i: usize, a: usize) -> f64;

    /// The pressure block entry C_kl (length³/Pa, positive definite in k, l) of corners k and
    /// l for shear modulus `shear_modulus` (Pa) and 1/κ `inverse_bulk` (1/Pa).
    fn pressure_block(
        rest: &Self::Rest,
        shear_modulus: f64,
        inverse_bulk: f64,
        k: usize,
        l: usize,
    ) -> f64;

    /// The element's Neo-Hookean or corotational state: residuals R_u, R_p and tangent
    /// blocks K_uu, G.
    type State: Send + Sync;

    /// The Neo-Hookean mixed state at node-major displacement `u` (3·NODES values, length)
    /// and corner pressures `p` (Pa) for μ `shear_modulus` (Pa) and 1/κ `inverse_bulk`
    /// (1/Pa); `None` where the tet is inverted.
    fn neo_hookean(
        rest: &Self::Rest,
        u: &[f64],
        p: &[f64; 4],
        shear_modulus: f64,
        inverse_bulk: f64,
    ) -> Option<Self::State>;

    /// The corotational mixed state (W = μ‖dev ε‖² − p·tr ε − p²/(2κ), ε = sym(RᵀF) − I) at
    /// node-major displacement `u` (3·NODES values, length) and corner pressures `p` (Pa) for
    /// `moduli` (μ in Pa, 1/κ in 1/Pa), R of F's polar decomposition from `rotation`; `None`
    /// where F is not finite.
    fn corotational(
        rest: &Self::Rest,
        u: &[f64],
        p: &[f64; 4],
        moduli: (f64, f64),
        rotation: PolarRotation,
    ) -> Option<Self::State>;

    /// R_u of `state`: internal nodal forces (force), node-major.
    fn state_force(state: &Self::State) -> &[f64];

    /// R_p of `state` per corner (length³).
    fn state_pressure_residual(state: &Self::State) -> &[f64; 4];

    /// K_uu of `state` (force/length), in the layout of [`Self::deviatoric_stiffness`].
    fn state_stiffness(state: &Self::State) -> Self::Deviatoric;

    /// G of `state` (length²), read by [`Self::coupling_entry`].
    fn state_coupling(state: &Self::State) -> &Self::Coupling;
}

/// Taylor–Hood P2–P1: C = M_p/κ.
impl MixedElement for Tet10 {
    const MIXED_NAME: &'static str = "Taylor–Hood P2–P1";
    type Deviatoric = SMatrix<f64, 30, 30>;
    type Coupling = taylor_hood::Coupling;

    fn deviatoric_stiffness(rest: &Self::Rest, shear_modulus: f64) -> Self::Deviatoric {
        taylor_hood::deviatoric_stiffness(rest, shear_modulus)
    }

    fn coupling(rest: &Self::Rest) -> Self::Coupling {
        taylor_hood::coupling(rest)
    }

    #[inline]
    fn coupling_entry(coupling: &Self::Coupling, k: usize, i: usize, a: usize) -> f64 {
        coupling[k][i][a]
    }

    /// (1/κ)·V(1 + δ_kl)/20.
    fn pressure_block(rest: &Self::Rest, _: f64, inverse_bulk: f64, k: usize, l: usize) -> f64 {
        inverse_bulk * taylor_hood::pressure_mass(rest, k, l)
    }

    type State = MixedElementState;

    /// [`mixed_neo_hookean`]; `None` also for a `u` of other than 30 values.
    fn neo_hookean(
        rest: &Self::Rest,
        u: &[f64],
        p: &[f64; 4],
        shear_modulus: f64,
        inverse_bulk: f64,
    ) -> Option<Self::State> {
        mixed_neo_hookean(rest, u.try_into().ok()?, p, shear_modulus, inverse_bulk)
    }

    /// [`mixed_corotational`] (R per quadrature point); `None` also for a `u` of other than
    /// 30 values.
    fn corotational(
        rest: &Self::Rest,
        u: &[f64],
        p: &[f64; 4],
        moduli: (f64, f64),
        rotation: PolarRotation,
    ) -> Option<Self::State> {
        mixed_corotational(rest, u.try_into().ok()?, p, moduli, rotation)
    }

    fn state_force(state: &Self::State) -> &[f64] {
        &state.force
    }

    fn state_pressure_residual(state: &Self::State) -> &[f64; 4] {
        &state.pressure_residual
    }

    fn state_stiffness(state: &Self::State) -> Self::Deviatoric {
        state.stiffness
    }

    fn state_coupling(state: &Self::State) -> &Self::Coupling {
        &state.coupling
    }
}

/// Stabilized P1–P1: C = M_p/κ + (1/μ)(M_p − M_Π).
impl MixedElement for Tet4 {
    const MIXED_NAME: &'static str = "stabilized P1–P1";
    type Deviatoric = SMatrix<f64, 12, 12>;
    type Coupling = stabilized_p1::Coupling;

    fn deviatoric_stiffness(rest: &Self::Rest, shear_modulus: f64) -> Self::Deviatoric {
        stabilized_p1::deviatoric_stiffness(rest, shear_modulus)
    }

    fn coupling(rest: &Self::Rest) -> Self::Coupling {
        stabilized_p1::coupling(rest)
    }

    #[inline]
    fn coupling_entry(coupling: &Self::Coupling, k: usize, i: usize, a: usize) -> f64 {
        coupling[k][i][a]
    }

    fn pressure_block(
        rest: &Self::Rest,
        shear_modulus: f64,
        inverse_bulk: f64,
        k: usize,
        l: usize,
    ) -> f64 {
        stabilized_p1::pressure_block(rest, shear_modulus, inverse_bulk, k, l)
    }

    type State = StabilizedElementState;

    /// [`stabilized_neo_hookean`].
    fn neo_hookean(
        rest: &Self::Rest,
        u: &[f64],
        p: &[f64; 4],
        shear_modulus: f64,
        inverse_bulk: f64,
    ) -> Option<Self::State> {
        stabilized_neo_hookean(rest, u, p, shear_modulus, inverse_bulk)
    }

    /// [`stabilized_corotational`] (one R per tet).
    fn corotational(
        rest: &Self::Rest,
        u: &[f64],
        p: &[f64; 4],
        moduli: (f64, f64),
        rotation: PolarRotation,
    ) -> Option<Self::State> {
        stabilized_corotational(rest, u, p, moduli, rotation)
    }

    fn state_force(state: &Self::State) -> &[f64] {
        &state.force
    }

    fn state_pressure_residual(state: &Self::State) -> &[f64; 4] {
        &state.pressure_residual
    }

    fn state_stiffness(state: &Self::State) -> Self::Deviatoric {
        state.stiffness
    }

    fn state_coupling(state: &Self::State) -> &Self::Coupling {
        &state.coupling
    }
}
