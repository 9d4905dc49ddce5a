//! Error norms of a finite element displacement against an exact field, for convergence studies,
//! on any element that evaluates pointwise ([`PointwiseElement`]: the linear and the quadratic
//! tet).

use nalgebra::{Matrix3, Vector3};

use crate::base::error::{Error, Result};
use crate::fe::materials::TetMaterials;
use crate::fe::quadrature::tet_rule;
use crate::mesh::TetMesh;
use crate::post::estimate::PointwiseElement;
use crate::post::estimate::recovery::{corners_of, gather};

/// L2 norm of the displacement error, ‖u_h − u‖ = √(∫ |u_h − u|² dV) (length · length^{3/2}),
/// by the degree-5 tet rule ([`tet_rule`]: exact for |u_h − u|² up to degree 5, so for the
/// polynomial part of the error on P1 and P2).
pub fn l2_error<E: PointwiseElement>(
    mesh: &TetMesh<E>,
    displacement: &[f64],
    exact: impl Fn(&Vector3<f64>) -> Vector3<f64>,
) -> Result<f64> {
    check_length(mesh, displacement)?;
    let rule = tet_rule();
    let mut element = vec![0.0; 3 * E::NODES];
    let mut shape = vec![0.0; E::NODES];
    let mut sum = 0.0;
    for t in 0..mesh.tet_count() {
        gather(mesh, t, displacement, &mut element);
        let corners = corners_of(mesh, t);
        let x = mesh.corner_positions_of(t);
        for q in &rule {
            let l = barycentric(&q.barycentric);
            E::shape_values_at(&l, &mut shape);
            let p = x[0] * l[0] + x[1] * l[1] + x[2] * l[2] + x[3] * l[3];
            let uh = shape
                .iter()
                .enumerate()
                .fold(Vector3::zeros(), |s, (i, n)| {
                    s + Vector3::new(element[3 * i], element[3 * i + 1], element[3 * i + 2]) * *n
                });
            sum += q.weight * corners.volume() * (uh - exact(&p)).norm_squared();
        }
    }
    Ok(sum.sqrt())
}

/// Energy norm of the error, √(∫ (ε_h − ε) : σ(ε_h − ε) dV) (√energy units), where ε is the
/// symmetric part of the exact displacement gradient `exact_gradient` (∂uᵢ/∂xⱼ at row i,
/// column j) and σ(ε) = λ tr(ε) I + 2μ ε, λ and μ those of each tet's material (one
/// [`Material`](crate::fe::material::Material) or a [`MaterialMap`](crate::fe::materials::MaterialMap)).
/// By the degree-5 tet rule, as [`l2_error`].
pub fn energy_error<E: PointwiseElement>(
    mesh: &TetMesh<E>,
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
    let mut element = vec![0.0; 3 * E::NODES];
    let mut sum = 0.0;
    for t in 0..mesh.tet_count() {
        let (lambda, mu) = lame[materials.index_of(t)];
        gather(mesh, t, displacement, &mut element);
        let corners = corners_of(mesh, t);
        let x = mesh.corner_positions_of(t);
        for q in &rule {
            let l = barycentric(&q.barycentric);
            let p = x[0] * l[0] + x[1] * l[1] + x[2] * l[2] + x[3] * l[3];
            let gh = E::displacement_gradient_at(&corners, &l, &element);
            let g = exact_gradient(&p);
            let e = (gh - g + (gh - g).transpose()) * 0.5;
            let stress = Matrix3::identity() * (lambda * e.trace()) + e * (2.0 * mu);
            sum += q.weight * corners.volume() * stress.component_mul(&e).sum();
        }
    }
    Ok(sum.max(0.0).sqrt())
}

/// The four barycentric coordinates (L₀…L₃) of a rule point given by (b₁, b₂, b₃).
fn barycentric(b: &Vector3<f64>) -> [f64; 4] {
    [1.0 - b.x - b.y - b.z, b.x, b.y, b.z]
}

fn check_length<E: PointwiseElement>(mesh: &TetMesh<E>, displacement: &[f64]) -> Result<()> {
    if displacement.len() != mesh.dof_count() {
        return Err(Error::invalid_parameter(
            "displacement.len()",
            displacement.len(),
            format!("must equal the mesh's DOF count {}", mesh.dof_count()),
        ));
    }
    Ok(())
}
