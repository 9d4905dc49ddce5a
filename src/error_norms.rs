//! Error norms of a finite element displacement against an exact field, for convergence studies.

use nalgebra::{Matrix3, Vector3};

use crate::error::{Error, Result};
use crate::materials::TetMaterials;
use crate::mesh::TetMesh;
use crate::quadrature::{shape_values, tet_rule};

/// L2 norm of the displacement error, ‖u_h − u‖ = √(∫ |u_h − u|² dV) (length · length^{3/2}),
/// by the degree-5 tet rule.
pub fn l2_error(
    mesh: &TetMesh,
    displacement: &[f64],
    exact: impl Fn(&Vector3<f64>) -> Vector3<f64>,
) -> Result<f64> {
    check_length(mesh, displacement)?;
    let rule = tet_rule();
    let mut sum = 0.0;
    for (t, tet) in mesh.tets().iter().enumerate() {
        let x = mesh.positions_of(t);
        let volume = mesh.element_of(t).volume();
        let u = tet.map(|n| {
            Vector3::new(
                displacement[3 * n],
                displacement[3 * n + 1],
                displacement[3 * n + 2],
            )
        });
        for q in &rule {
            let n = shape_values(&q.barycentric);
            let p = x[0] * n[0] + x[1] * n[1] + x[2] * n[2] + x[3] * n[3];
            let uh = u[0] * n[0] + u[1] * n[1] + u[2] * n[2] + u[3] * n[3];
            sum += q.weight * volume * (uh - exact(&p)).norm_squared();
        }
    }
    Ok(sum.sqrt())
}

/// Energy norm of the error, √(∫ (ε_h − ε) : σ(ε_h − ε) dV) (√energy units), where ε is the
/// symmetric part of the exact displacement gradient `exact_gradient` (∂uᵢ/∂xⱼ at row i,
/// column j) and σ(ε) = λ tr(ε) I + 2μ ε, λ and μ those of each tet's material (one
/// [`Material`](crate::material::Material) or a [`MaterialMap`](crate::materials::MaterialMap)).
pub fn energy_error(
    mesh: &TetMesh,
    materials: &impl TetMaterials,
    displacement: &[f64],
    exact_gradient: impl Fn(&Vector3<f64>) -> Matrix3<f64>,
) -> Result<f64> {
    check_length(mesh, displacement)?;
    materials.check_tet_count(mesh)?;
    let rule = tet_rule();
    let lame: Vec<(f64, f64)> = materials
        .material_list()
        .iter()
        .map(|m| (m.lame_lambda(), m.shear_modulus()))
        .collect();
    let mut sum = 0.0;
    for (t, tet) in mesh.tets().iter().enumerate() {
        let (lambda, mu) = lame[materials.index_of(t)];
        let x = mesh.positions_of(t);
        let element = mesh.element_of(t);
        let u = crate::element::Vector12::from_fn(|i, _| displacement[3 * tet[i / 3] + i % 3]);
        let strain_h = element.strain(&u);
        for q in &rule {
            let n = shape_values(&q.barycentric);
            let p = x[0] * n[0] + x[1] * n[1] + x[2] * n[2] + x[3] * n[3];
            let g = exact_gradient(&p);
            let e = strain_h - (g + g.transpose()) * 0.5;
            let stress = Matrix3::identity() * (lambda * e.trace()) + e * (2.0 * mu);
            sum += q.weight * element.volume() * stress.component_mul(&e).sum();
        }
    }
    Ok(sum.max(0.0).sqrt())
}

fn check_length(mesh: &TetMesh, displacement: &[f64]) -> Result<()> {
    if displacement.len() != mesh.dof_count() {
        return Err(Error::invalid_parameter(
            "displacement.len()",
            displacement.len(),
            format!("must equal the mesh's DOF count {}", mesh.dof_count()),
        ));
    }
    Ok(())
}
