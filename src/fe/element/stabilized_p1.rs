//! The stabilized equal-order P1–P1 tet: the linear 4-node displacement of [`Tet4`] with a
//! continuous linear pressure on the same four corners, made stable by the polynomial pressure
//! projection of Dohrmann & Bochev (2004, "A stabilized finite element method for the Stokes
//! problem based on polynomial pressure projections", IJNMF 46), for nearly incompressible
//! linear elasticity on 4-node meshes without volumetric locking.
//!
//! The perturbed-Lagrangian form of the linear model is that of
//! [`taylor_hood`](super::taylor_hood) (shear modulus μ, bulk modulus κ = λ + 2μ/3, Pa;
//! p = −κ div u the pressure, positive in compression; σ = 2μ dev ε − p I), with one term more
//! in the pressure equation:
//!
//! ```text
//!   ∫ 2μ dev ε(u) : dev ε(v) dV − ∫ p div v dV                             = f(v),
//!  −∫ q div u dV − ∫ p q / κ dV − (1/μ) ∫ (p − Πp)(q − Πq) dV              = 0,
//! ```
//!
//! Π the L2 projection onto constants per tet (Πp = the tet's mean pressure). Equal-order
//! P1–P1 alone violates the inf-sup condition (its pressure checkerboards and the
//! displacement locks); the added term penalises exactly the part of p that the piecewise
//! constant pressures — which the linear displacement's divergence can match — cannot hold.
//! It vanishes for a pressure constant on the tet, so a homogeneous deformation (affine u,
//! constant p) is reproduced exactly (the patch test), and it is weighted by 1/μ so that it
//! scales as the Schur complement B·K⁻¹·Bᵀ ~ V/μ it stabilizes, independent of κ.
//!
//! Element blocks (V the tet's volume, ∇Nᵢ its constant shape gradients, Lₖ = Nₖ):
//!
//! - K_dev: Kᵢⱼ = V(μ(∇Nᵢ·∇Nⱼ I + ∇Nⱼ∇Nᵢᵀ) − (2μ/3) ∇Nᵢ∇Nⱼᵀ) — [`Tet4`]'s stiffness with λ
//!   replaced by −2μ/3;
//! - B: B_kᵢₐ = ∫ L_k ∂ₐNᵢ dV = (V/4) ∂ₐNᵢ (∫L_k = V/4, ∇Nᵢ constant);
//! - C: C_kl = ∫ L_k L_l dV (1/κ + 1/μ) − (1/μ)(∫L_k)(∫L_l)/V = V(1 + δ_kl)/20·(1/κ + 1/μ)
//!   − V/(16μ),
//!
//! and the system [K_dev −Bᵀ; −B −C] [u; p] = [f; 0] is symmetric quasi-definite for ν < 0.5:
//! C is the pressure mass over κ (positive definite) plus a positive semi-definite term
//! (M_p − M_Π, the mass of p − Πp). The saddle point of the Taylor–Hood element's solve
//! ([`MixedStaticSolver`](crate::MixedStaticSolver)) therefore solves it unchanged — one LDLᵀ
//! without pivoting — with one pressure row per node, 4/3 the rows of the plain P1 system.
//!
//! Why this element rather than MINI (P1 + cubic bubble / P1): MINI's bubble, condensed per
//! element, also adds a positive definite block to C, but one whose size depends on the
//! element's bubble stiffness (a 3×3 inverse per tet, and the bubble's load and stress
//! recovery after the solve); the projection term is a closed-form 4×4 block with the
//! same sparsity, so the element is a few lines on top of [`Tet4`] and the same solver, its
//! stress the linear tet's deviatoric part plus the solved pressure. Both converge at the
//! same orders (O(h²) displacement in L2, O(h) or better pressure); MINI was not built, so
//! no side-by-side measurement of the two is claimed.
//!
//! Measured on Lamé's thick-walled tube in plane strain (`tests/core/mixed_tet4.rs`; 6 × 24 ×
//! 2 cells of the 6-tet split, where the plain linear tet gives 0.988, 0.883, 0.612, 0.478 of
//! Lamé's bore displacement at ν = 0.3, 0.49, 0.499, 0.4999): 0.9944, 0.9937, 0.9936, 0.9936
//! — ν-independent, its 0.64 % error the linear displacement's, falling as h² (0.975, 0.9936,
//! 0.9984 on 3 × 12, 6 × 24, 12 × 48 cells); the pressure's L2 error falls as h^1.45 (16 %,
//! 6.0 %, 2.2 %), its worst tet mean at the bore 0.66, 0.40, 0.22 of |p| where the plain
//! linear tet's −κ tr ε is off by 54×. Cost at ν = 0.4999 (one run, best of 3, load ≈ 6 on
//! 2 cores): 0.64 % error in 0.014 s (2100 unknowns), where Taylor–Hood reaches 0.28 % in
//! 0.034 s on the coarsest mesh and the quadratic displacement tet 0.42 % in 0.13 s; the
//! mixed solve costs about 1.7–2× the plain linear tet's on the same mesh, which is still
//! 33 % off at 24 × 96 cells (where the mixed one is 0.04 % off).

use nalgebra::SMatrix;

use super::{ElementType, Tet, Tet4};

/// Pressure nodes per element: the four corners (every node of the 4-node tet).
pub const PRESSURE_NODES: usize = 4;

/// The element's divergence coupling B_kᵢₐ = (V/4) ∂ₐNᵢ (length²): `coupling[k][i][a]` for
/// corner k (pressure node), displacement node i (0–3) and axis a.
pub type Coupling = [[[f64; 3]; 4]; PRESSURE_NODES];

/// The element's 12×12 deviatoric stiffness (force/length), row 3i + b, column 3j + a:
/// V(μ(∇Nᵢ·∇Nⱼ I + ∇Nⱼ∇Nᵢᵀ) − (2μ/3)∇Nᵢ∇Nⱼᵀ) for shear modulus `shear_modulus` (Pa).
pub fn deviatoric_stiffness(rest: &Tet, shear_modulus: f64) -> SMatrix<f64, 12, 12> {
    let mut k = SMatrix::<f64, 12, 12>::zeros();
    for i in 0..4 {
        for j in i..4 {
            let block =
                Tet4::stiffness_block(rest, -2.0 * shear_modulus / 3.0, shear_modulus, i, j);
            for a in 0..3 {
                for b in 0..3 {
                    k[(3 * i + b, 3 * j + a)] = block[a][b];
                    k[(3 * j + a, 3 * i + b)] = block[a][b];
                }
            }
        }
    }
    k
}

/// The divergence coupling B_kᵢₐ = ∫ L_k ∂ₐNᵢ dV = (V/4) ∂ₐNᵢ (length²), the same for every
/// corner k since ∇Nᵢ is constant on the tet.
pub fn coupling(rest: &Tet) -> Coupling {
    let quarter = rest.volume() / 4.0;
    let row: [[f64; 3]; 4] = std::array::from_fn(|i| {
        let g = rest.shape_gradients()[i];
        [quarter * g.x, quarter * g.y, quarter * g.z]
    });
    [row; PRESSURE_NODES]
}

/// The pressure block C_kl = V(1 + δ_kl)/20·(1/κ + 1/μ) − V/(16μ) (length³/Pa) of corners k
/// and l, for 1/κ `inverse_bulk` and μ `shear_modulus` (see the [module](self) docs): the
/// pressure mass over κ plus the projection stabilization (1/μ)∫(p − Πp)(q − Πq) dV.
pub fn pressure_block(
    rest: &Tet,
    shear_modulus: f64,
    inverse_bulk: f64,
    k: usize,
    l: usize,
) -> f64 {
    let volume = rest.volume();
    let mass = volume * if k == l { 2.0 } else { 1.0 } / 20.0;
    let inverse_shear = 1.0 / shear_modulus;
    mass * (inverse_bulk + inverse_shear) - volume * inverse_shear / 16.0
}
