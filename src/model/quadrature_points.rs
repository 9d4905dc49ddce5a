//! The force models on the 10-node tet, at its quadrature points.
//!
//! F_q = I + Σₐ uₐ ⊗ ∇Nₐ(ξ_q) at each point ξ_q of the degree-2 rule (4 points, weights V/4:
//! the rule of the element's linear stiffness, and Abaqus's C3D10; on a curved tet the
//! element's degree-6 rule, 24 points weighted V_X·w·det G, `Tet10Rest::points`), then
//! E = Σ_q w_q ψ(F_q), fₐ = −Σ_q w_q P(F_q)·∇Nₐ(ξ_q), and the tangent blocks
//! K_ab = Σ_q w_q ∇Nₐᵀ·(∂P/∂F)(F_q)·∇N_b of the model's [`ConstitutiveLaw`](super::ConstitutiveLaw).
//!
//! Why degree 2: ψ(F) is not a polynomial for these models, so no rule is exact; the degree-2
//! rule is exact for the linear stiffness (∇Nₐ·∇N_b is quadratic), so the tangent at rest is
//! the linear P2 stiffness exactly (small loads agree with linear P2 to first order), it has
//! no spurious zero-energy mode, and it costs 4 law evaluations per element. F is formed from
//! u (not x) so that small strains carry no cancellation of the rest positions.
//!
//! Corotational: R is taken per quadrature point, from the polar decomposition of F_q, and the
//! law there is the corotated-linear energy ψ = μ‖sym(RᵀF) − I‖² + λ/2·tr²(sym(RᵀF) − I) with
//! P = R·(2μ·ε + λ·tr(ε)·I), ε = sym(RᵀF) − I, and its exact tangent (dR included). One R
//! per element (say from the corners' F) would save three SVDs per element, but a bent
//! quadratic tet turns by different angles across it: a point turned by δθ away from the
//! element's R would see a spurious strain of order δθ², and the model would no longer be one
//! hyperelastic law per point (its tangent not the Hessian of its energy). Per point it is both,
//! and on the 4-node tet (one point) it is exactly the per-element model.

use nalgebra::{Matrix3, SMatrix, Vector3};

use super::element_model::ModelElement;
use super::{ForceModel, TetModels, project_psd_of};
use crate::base::error::Result;
use crate::fe::assembly::Assembler;
use crate::fe::element::ElementType;
use crate::fe::element::tet10::{Tet10, Tet10Rest};
use crate::mesh::TetMesh;
use crate::sparse::CscMatrix;

/// The 30×30 element tangent of a 10-node tet.
type Matrix30 = SMatrix<f64, 30, 30>;

/// The rest data and node-major element displacement (30 values) of tet `t`.
fn element(mesh: &TetMesh<Tet10>, t: usize, u: &[f64]) -> (Tet10Rest, [f64; 30]) {
    let mut ue = [0.0; 30];
    for (i, &n) in mesh.tets()[t].iter().enumerate() {
        ue[3 * i..3 * i + 3].copy_from_slice(&u[3 * n..3 * n + 3]);
    }
    (Tet10::rest(mesh, t), ue)
}

/// F = I + Σₐ uₐ ⊗ ∇Nₐ at one point, from that point's shape gradients.
fn deformation_gradient(gradients: &[Vector3<f64>; 10], ue: &[f64; 30]) -> Matrix3<f64> {
    let mut f = Matrix3::identity();
    for (a, g) in gradients.iter().enumerate() {
        f += Vector3::new(ue[3 * a], ue[3 * a + 1], ue[3 * a + 2]) * g.transpose();
    }
    f
}

/// The 30×30 tangent Σ_q w_q ∇Nₐᵀ·A_q·∇N_b (force/length), symmetrized (the Hessian of an
/// energy: averaging removes round-off asymmetry).
fn element_tangent(law: &dyn ForceModel, rest: &Tet10Rest, ue: &[f64; 30]) -> Matrix30 {
    let mut k = Matrix30::zeros();
    let (points, weights) = rest.points();
    for (gradients, &weight) in points.iter().zip(weights) {
        let a = law.piola_tangent(&deformation_gradient(gradients, ue)) * weight;
        // g[(i + 3j), 3b + k] = Σ_l A[(i + 3j), (k + 3l)]·∇N_b[l]: A applied to node b's
        // directions; then K[(3a + i), (3b + k)] = Σ_j ∇Nₐ[j]·g[(i + 3j), 3b + k].
        let mut g = SMatrix::<f64, 9, 30>::zeros();
        for (b, gb) in gradients.iter().enumerate() {
            for kk in 0..3 {
                for l in 0..3 {
                    let column = a.column(kk + 3 * l) * gb[l];
                    let mut target = g.column_mut(3 * b + kk);
                    target += column;
                }
            }
        }
        for (na, ga) in gradients.iter().enumerate() {
            for i in 0..3 {
                for j in 0..3 {
                    let row = g.row(i + 3 * j) * ga[j];
                    let mut target = k.row_mut(3 * na + i);
                    target += row;
                }
            }
        }
    }
    (k + k.transpose()) * 0.5
}

/// The 10-node tet: the model's law at the four points of the degree-2 rule (4 points,
/// weights V/4; why this rule: see the source, `src/model/quadrature_points.rs`).
impl ModelElement for Tet10 {
    fn model_energy(model: &dyn ForceModel, mesh: &TetMesh<Tet10>, t: usize, u: &[f64]) -> f64 {
        let (rest, ue) = element(mesh, t, u);
        let psi = |g: &[Vector3<f64>; 10]| model.energy_density(&deformation_gradient(g, &ue));
        if rest.is_curved() {
            // Curved (isoparametric) tet: the degree-6 rule's points, weights V_X·w·det G.
            let (gradients, weights) = rest.points();
            return (gradients.iter().zip(weights))
                .map(|(g, w)| w * psi(g))
                .sum();
        }
        rest.gradients().iter().map(psi).sum::<f64>() * (rest.volume() / 4.0)
    }

    fn add_model_force(
        model: &dyn ForceModel,
        mesh: &TetMesh<Tet10>,
        t: usize,
        u: &[f64],
        force: &mut [f64],
    ) {
        let (rest, ue) = element(mesh, t, u);
        let nodes = &mesh.tets()[t];
        let (points, weights) = rest.points();
        for (gradients, &weight) in points.iter().zip(weights) {
            let piola = model.first_piola(&deformation_gradient(gradients, &ue)) * weight;
            for (g, &n) in gradients.iter().zip(nodes) {
                let f = piola * g;
                for a in 0..3 {
                    force[3 * n + a] -= f[a];
                }
            }
        }
    }

    fn refill_model_tangent(
        mesh: &TetMesh<Tet10>,
        assembler: &Assembler,
        models: &(impl TetModels + ?Sized),
        u: &[f64],
        project: bool,
        tangent: &mut CscMatrix,
    ) -> Result<()> {
        assembler.reassemble_elements(
            mesh,
            |t| {
                let (rest, ue) = element(mesh, t, u);
                let k = element_tangent(models.model_of(t), &rest, &ue);
                if project { project_psd_of(&k) } else { k }
            },
            tangent,
        )
    }

    /// The mean of σ(F_q) over the four points: the degree-2 rule's volume average.
    fn model_cauchy_stress(
        model: &dyn ForceModel,
        mesh: &TetMesh<Tet10>,
        t: usize,
        u: &[f64],
    ) -> Matrix3<f64> {
        let (rest, ue) = element(mesh, t, u);
        point_mean(&rest, |g| model.cauchy(&deformation_gradient(g, &ue)))
    }

    /// The mean of E(F_q) over the four points (E is quadratic in u: exact for a field
    /// of degree one in ∇u only, as the stress).
    fn mean_green_strain(mesh: &TetMesh<Tet10>, t: usize, u: &[f64]) -> Matrix3<f64> {
        let (rest, ue) = element(mesh, t, u);
        point_mean(&rest, |g| {
            let f = deformation_gradient(g, &ue);
            (f.transpose() * f - Matrix3::identity()) * 0.5
        })
    }
}

/// The volume mean of a tensor `of` the shape-function gradients at the element's points:
/// the degree-2 rule's plain mean on a straight tet, the curved rule's det G-weighted one on a
/// curved tet.
fn point_mean(rest: &Tet10Rest, of: impl Fn(&[Vector3<f64>; 10]) -> Matrix3<f64>) -> Matrix3<f64> {
    if rest.is_curved() {
        let (points, weights) = rest.points();
        let total: f64 = weights.iter().sum();
        return points
            .iter()
            .zip(weights)
            .map(|(g, w)| of(g) * *w)
            .sum::<Matrix3<f64>>()
            / total;
    }
    rest.gradients().iter().map(of).sum::<Matrix3<f64>>() / 4.0
}
