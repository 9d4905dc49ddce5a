//! The element bound on the explicit critical step: 2/maxₑ ωₑ from each tet's own lumped-mass
//! eigenproblem (never above the assembled system's critical step, which
//! [`critical_time_step`](super::critical_time_step) computes), with the geometric rule of thumb
//! minₑ hₑ/c_p beside it. Cheap (one 12×12 eigenproblem per tet) and needs no assembly: what
//! `tetfem info --material` reports.

use crate::fe::material::Material;
use crate::fe::quality::tet_quality;
use crate::mesh::TetMesh;

/// The explicit (central-difference, lumped-mass, undamped) critical time step of a mesh and
/// material.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct ElementStepBound {
    /// Element bound 2/max ωₑ (time units): ωₑ² = λ_max(Kₑ)/(ρVₑ/4) is the largest eigenvalue
    /// of the tet's own lumped-mass problem. By the element eigenvalue theorem the assembled
    /// ω_max ≤ maxₑ ωₑ, so a step below this is stable for the undamped linear system (Dirichlet
    /// constraints only lower ω_max).
    pub dt_element: f64,
    /// The tet that sets `dt_element`.
    pub tet: usize,
    /// The geometric estimate minₑ hₑ/c_p, hₑ the smallest altitude of tet e and
    /// c_p = √((λ+2μ)/ρ) the P-wave speed; the usual rule of thumb, shown for comparison
    /// (it is not a bound: `dt_element` is typically 0.3–0.6 of it on linear tets).
    pub dt_geometric: f64,
    /// The P-wave speed c_p (length/time).
    pub p_wave_speed: f64,
}

/// Computes [`ElementStepBound`] for `mesh` made of `material`: one 12×12 symmetric eigenvalue
/// problem per tet.
pub fn element_step_bound(mesh: &TetMesh, material: &Material) -> ElementStepBound {
    element_step_bound_by(mesh, material)
}

/// [`element_step_bound`] with each tet's own material: ωₑ and hₑ/c_p,e per tet;
/// `p_wave_speed` is then the largest c_p of the materials.
///
/// Errors: `materials` do not cover the mesh's tets.
pub fn element_step_bound_of(
    mesh: &TetMesh,
    materials: &impl crate::fe::materials::TetMaterials,
) -> crate::base::error::Result<ElementStepBound> {
    materials.check_tet_count(mesh)?;
    Ok(element_step_bound_by(mesh, materials))
}

/// [`element_step_bound_of`] for materials checked against the mesh.
fn element_step_bound_by(
    mesh: &TetMesh,
    materials: &impl crate::fe::materials::TetMaterials,
) -> ElementStepBound {
    let speeds: Vec<f64> = materials
        .material_list()
        .iter()
        .map(|m| m.p_wave_speed())
        .collect();
    let c_p = speeds.iter().copied().fold(0.0, f64::max);
    let mut worst_omega_sq: f64 = 0.0;
    let mut tet = 0;
    let mut dt_geometric = f64::INFINITY;
    for t in 0..mesh.tet_count() {
        let material = materials.material_of(t);
        let element = mesh.element_of(t);
        let k = element.stiffness(material);
        let lambda_max = k
            .symmetric_eigenvalues()
            .iter()
            .fold(0.0f64, |a, &b| a.max(b));
        let omega_sq = lambda_max / element.lumped_mass(material.density());
        if omega_sq > worst_omega_sq {
            worst_omega_sq = omega_sq;
            tet = t;
        }
        let q = tet_quality(&element, &mesh.positions_of(t));
        dt_geometric = dt_geometric.min(q.min_altitude / speeds[materials.index_of(t)]);
    }
    ElementStepBound {
        dt_element: 2.0 / worst_omega_sq.sqrt(),
        tet,
        dt_geometric,
        p_wave_speed: c_p,
    }
}

/// [`element_step_bound_of`] for any element type: ωₑ² is the largest eigenvalue of the
/// element's own lumped-mass problem Kₑ·φ = ω²·Mₑ·φ, Mₑ = diag(ρVₑ·wᵢ) with the element's
/// [`LUMPED_MASS`](crate::fe::element::ElementType::LUMPED_MASS) weights (HRZ for the 10-node tet),
/// found as λ_max(Mₑ^(−1/2)·Kₑ·Mₑ^(−1/2)) by a dense symmetric eigensolve of size 3·NODES (30
/// for the 10-node tet). The global lumped mass is the sum of these positive diagonals, so
/// uᵀKu/uᵀMu = Σ uₑᵀKₑuₑ / Σ uₑᵀMₑuₑ ≤ maxₑ ωₑ²: `dt_element` = 2/maxₑ ωₑ is never above the
/// assembled system's critical step. `dt_geometric` is hₑ/c_p of the corner tet, as for the
/// linear tet (the rule of thumb; a quadratic element's node spacing is half of it).
///
/// On the linear tet it agrees with [`element_step_bound_of`] to round-off (that one divides
/// λ_max(Kₑ) by the equal masses ρVₑ/4 instead of scaling Kₑ).
///
/// Errors: `materials` do not cover the mesh's tets.
pub fn element_step_bound_of_type<E: crate::fe::element::ElementType>(
    mesh: &TetMesh<E>,
    materials: &impl crate::fe::materials::TetMaterials,
) -> crate::base::error::Result<ElementStepBound> {
    materials.check_tet_count(mesh)?;
    let speeds: Vec<f64> = materials
        .material_list()
        .iter()
        .map(|m| m.p_wave_speed())
        .collect();
    let n = 3 * E::NODES;
    let mut k = nalgebra::DMatrix::<f64>::zeros(n, n);
    let mut worst_omega_sq: f64 = 0.0;
    let mut tet = 0;
    let mut dt_geometric = f64::INFINITY;
    for t in 0..mesh.tet_count() {
        let material = materials.material_of(t);
        let rest = E::rest(mesh, t);
        let mass = material.density() * E::volume(&rest);
        let inverse_root: Vec<f64> = (0..E::NODES)
            .map(|i| 1.0 / E::LUMPED_MASS.share(i, mass).sqrt())
            .collect();
        let (lambda, mu) = (material.lame_lambda(), material.shear_modulus());
        for i in 0..E::NODES {
            for j in 0..E::NODES {
                let block = E::stiffness_block(&rest, lambda, mu, i, j);
                let s = inverse_root[i] * inverse_root[j];
                for (a, column) in block.iter().enumerate() {
                    for (b, value) in column.iter().enumerate() {
                        k[(3 * i + b, 3 * j + a)] = value * s;
                    }
                }
            }
        }
        // Kₑ is symmetric up to round-off; the eigensolver reads the lower triangle.
        let omega_sq = k
            .clone()
            .symmetric_eigenvalues()
            .iter()
            .fold(0.0f64, |a, &b| a.max(b));
        if omega_sq > worst_omega_sq {
            worst_omega_sq = omega_sq;
            tet = t;
        }
        let q = tet_quality(&mesh.element_of(t), &mesh.corner_positions_of(t));
        dt_geometric = dt_geometric.min(q.min_altitude / speeds[materials.index_of(t)]);
    }
    Ok(ElementStepBound {
        dt_element: 2.0 / worst_omega_sq.sqrt(),
        tet,
        dt_geometric,
        p_wave_speed: speeds.iter().copied().fold(0.0, f64::max),
    })
}

/// An element type with its own bound on the explicit critical step: the one each analysis
/// and front end uses, so that a scene, Python and a Rust caller find the same bits.
pub trait StepBoundElement: crate::fe::element::ElementType {
    /// The element bound of `mesh` with `materials` (see [`ElementStepBound`]).
    ///
    /// Errors: `materials` do not cover the mesh's tets.
    fn step_bound(
        mesh: &TetMesh<Self>,
        materials: &impl crate::fe::materials::TetMaterials,
    ) -> crate::base::error::Result<ElementStepBound>;
}

impl StepBoundElement for crate::fe::element::Tet4 {
    /// [`element_step_bound_of`]: the linear tet's own bound (λ_max(Kₑ) over the equal masses
    /// ρVₑ/4), the bits every run has reported since the first release.
    fn step_bound(
        mesh: &TetMesh,
        materials: &impl crate::fe::materials::TetMaterials,
    ) -> crate::base::error::Result<ElementStepBound> {
        element_step_bound_of(mesh, materials)
    }
}

impl StepBoundElement for crate::fe::element::Tet10 {
    /// [`element_step_bound_of_type`]: Kₑ scaled by the lumped mass shares of the 10 nodes.
    fn step_bound(
        mesh: &TetMesh<crate::fe::element::Tet10>,
        materials: &impl crate::fe::materials::TetMaterials,
    ) -> crate::base::error::Result<ElementStepBound> {
        element_step_bound_of_type(mesh, materials)
    }
}
