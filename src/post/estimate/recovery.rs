//! Stress recovery: a continuous nodal stress σ* from the discontinuous finite element stress
//! σ_h, the "smoothed" field of the Zienkiewicz–Zhu estimator.

use nalgebra::Matrix3;

use crate::fe::element::PointwiseElement;
pub(crate) use crate::fe::element::pointwise::corners_of;
use crate::fe::material::Material;
use crate::fe::materials::TetMaterials;
use crate::mesh::TetMesh;

/// σ = λ tr(ε) I + 2με of the symmetric part of a displacement gradient.
pub(crate) fn hooke(material: &Material, gradient: &Matrix3<f64>) -> Matrix3<f64> {
    let strain = (gradient + gradient.transpose()) * 0.5;
    Matrix3::identity() * (material.lame_lambda() * strain.trace())
        + strain * (2.0 * material.shear_modulus())
}

/// The node-major displacement of tet `t`'s nodes, written into `element` (3·NODES values).
pub(crate) fn gather<E: PointwiseElement>(
    mesh: &TetMesh<E>,
    t: usize,
    displacement: &[f64],
    element: &mut [f64],
) {
    for (i, &n) in mesh.tets()[t].as_ref().iter().enumerate() {
        element[3 * i..3 * i + 3].copy_from_slice(&displacement[3 * n..3 * n + 3]);
    }
}

/// Recovered nodal stress by volume-weighted averaging: at node n,
/// σ*(n) = Σₑ Vₑ σₕ|ₑ(xₙ) / Σₑ Vₑ over the tets e that hold n, where σₕ|ₑ(xₙ) is tet e's own
/// stress evaluated at the node (constant on P1, linear on P2). Stress units; zero at a node no
/// tet uses. The caller has checked the lengths.
pub fn averaged_nodal_stress<E: PointwiseElement>(
    mesh: &TetMesh<E>,
    materials: &impl TetMaterials,
    displacement: &[f64],
) -> Vec<Matrix3<f64>> {
    averaged_nodal(mesh, displacement, &|t, gradient| {
        hooke(materials.material_of(t), gradient)
    })
}

/// The stress of tet `t` at a displacement gradient ∇u (dimensionless): a symmetric tensor in
/// stress units. Hooke's σ for the linear estimate, a model's second Piola–Kirchhoff S for
/// the estimate of a nonlinear model.
pub(crate) type StressOf<'a> = dyn Fn(usize, &Matrix3<f64>) -> Matrix3<f64> + 'a;

/// [`averaged_nodal_stress`] of any [`StressOf`].
pub(crate) fn averaged_nodal<E: PointwiseElement>(
    mesh: &TetMesh<E>,
    displacement: &[f64],
    stress: &StressOf,
) -> Vec<Matrix3<f64>> {
    let mut sum = vec![Matrix3::zeros(); mesh.node_count()];
    let mut weight = vec![0.0; mesh.node_count()];
    let mut element = vec![0.0; 3 * E::NODES];
    for t in 0..mesh.tet_count() {
        gather(mesh, t, displacement, &mut element);
        let corners = corners_of(mesh, t);
        let volume = corners.volume();
        for (i, &n) in mesh.tets()[t].as_ref().iter().enumerate() {
            let l = E::node_barycentric(i);
            let gradient = E::displacement_gradient_at(&corners, &l, &element);
            sum[n] += stress(t, &gradient) * volume;
            weight[n] += volume;
        }
    }
    sum.into_iter()
        .zip(weight)
        .map(|(s, w)| if w > 0.0 { s / w } else { s })
        .collect()
}

/// Monomials of a complete polynomial of degree `degree` (1 or 2) in the local coordinates
/// `d`, written into `terms`: 1, x, y, z (and x², y², z², xy, yz, zx). Returns their count.
fn monomials(degree: usize, d: &nalgebra::Vector3<f64>, terms: &mut [f64; 10]) -> usize {
    terms[..4].copy_from_slice(&[1.0, d.x, d.y, d.z]);
    if degree < 2 {
        return 4;
    }
    terms[4..].copy_from_slice(&[
        d.x * d.x,
        d.y * d.y,
        d.z * d.z,
        d.x * d.y,
        d.y * d.z,
        d.z * d.x,
    ]);
    10
}

/// The stress σ_h of tet `t` at its sampling points (the degree-2 rule's four points for P2,
/// the centroid for P1: where the element's stress is most accurate) with their positions.
fn samples<E: PointwiseElement>(
    mesh: &TetMesh<E>,
    stress: &StressOf,
    displacement: &[f64],
    t: usize,
    element: &mut [f64],
) -> Vec<(nalgebra::Vector3<f64>, Matrix3<f64>)> {
    const ALPHA: f64 = 0.585_410_196_624_968_5;
    const BETA: f64 = 0.138_196_601_125_010_5;
    gather(mesh, t, displacement, element);
    let corners = corners_of(mesh, t);
    let x = mesh.corner_positions_of(t);
    let points: Vec<[f64; 4]> = if E::DEGREE < 2 {
        vec![[0.25; 4]]
    } else {
        (0..4)
            .map(|q| std::array::from_fn(|i| if i == q { ALPHA } else { BETA }))
            .collect()
    };
    points
        .iter()
        .map(|l| {
            // On a curved tet the point sits on the bent map, not on the corners' plane.
            let p = corners.position(&x, l);
            let gradient = E::displacement_gradient_at(&corners, l, element);
            (p, stress(t, &gradient))
        })
        .collect()
}

/// Recovered nodal stress by superconvergent patch recovery (SPR, Zienkiewicz & Zhu 1992):
/// around each interior corner node, a complete polynomial of the element's degree is fitted
/// by least squares to σ_h at the sampling points of the tets of its patch (centroids for P1,
/// the degree-2 rule's points for P2), and evaluated at every node of the patch; a node's
/// σ* is the mean of the values it received. Boundary nodes thus take their values from the
/// interior patches next to them (no one-sided fit); a node that no interior patch reaches
/// (a mesh one tet thick) keeps the volume-weighted average of [`averaged_nodal_stress`].
///
/// Errors: the mesh's face topology cannot be built (see
/// [`TetMesh::boundary_faces`](crate::mesh::TetMesh::boundary_faces)).
pub fn spr_nodal_stress<E: PointwiseElement>(
    mesh: &TetMesh<E>,
    materials: &impl TetMaterials,
    displacement: &[f64],
) -> crate::base::error::Result<Vec<Matrix3<f64>>> {
    spr_nodal(mesh, displacement, &|t, gradient| {
        hooke(materials.material_of(t), gradient)
    })
}

/// [`spr_nodal_stress`] of any [`StressOf`].
pub(crate) fn spr_nodal<E: PointwiseElement>(
    mesh: &TetMesh<E>,
    displacement: &[f64],
    stress: &StressOf,
) -> crate::base::error::Result<Vec<Matrix3<f64>>> {
    let mut on_boundary = vec![false; mesh.node_count()];
    for face in mesh.boundary_faces()? {
        for n in face.nodes {
            on_boundary[n] = true;
        }
    }
    let mut patches = vec![Vec::new(); mesh.node_count()];
    for (t, tet) in mesh.tets().iter().enumerate() {
        for &n in &tet.as_ref()[..4] {
            patches[n].push(t);
        }
    }
    let mut element = vec![0.0; 3 * E::NODES];
    let tet_samples: Vec<_> = (0..mesh.tet_count())
        .map(|t| samples(mesh, stress, displacement, t, &mut element))
        .collect();
    let mut sum = vec![Matrix3::zeros(); mesh.node_count()];
    let mut count = vec![0usize; mesh.node_count()];
    let mut terms = [0.0; 10];
    for (centre, patch) in patches.iter().enumerate() {
        if on_boundary[centre] || patch.is_empty() {
            continue;
        }
        let origin = mesh.nodes()[centre];
        // Local coordinates scaled by the patch's size keep the normal equations well
        // conditioned whatever the units.
        let size = patch
            .iter()
            .flat_map(|&t| tet_samples[t].iter())
            .map(|(p, _)| (p - origin).amax())
            .fold(0.0, f64::max);
        if size.is_nan() || size <= 0.0 {
            continue;
        }
        let m = monomials(E::DEGREE, &nalgebra::Vector3::zeros(), &mut terms);
        let mut normal = nalgebra::DMatrix::<f64>::zeros(m, m);
        let mut rhs = nalgebra::DMatrix::<f64>::zeros(m, 6);
        let mut points = 0;
        for &t in patch {
            for (p, s) in &tet_samples[t] {
                monomials(E::DEGREE, &((p - origin) / size), &mut terms);
                let component = [
                    s[(0, 0)],
                    s[(1, 1)],
                    s[(2, 2)],
                    s[(0, 1)],
                    s[(1, 2)],
                    s[(0, 2)],
                ];
                for a in 0..m {
                    for b in 0..m {
                        normal[(a, b)] += terms[a] * terms[b];
                    }
                    for (c, value) in component.iter().enumerate() {
                        rhs[(a, c)] += terms[a] * value;
                    }
                }
                points += 1;
            }
        }
        if points < m {
            continue;
        }
        let Some(cholesky) = normal.cholesky() else {
            continue;
        };
        let coefficients = cholesky.solve(&rhs);
        if coefficients.iter().any(|c| !c.is_finite()) {
            continue;
        }
        for &t in patch {
            for &n in mesh.tets()[t].as_ref() {
                monomials(E::DEGREE, &((mesh.nodes()[n] - origin) / size), &mut terms);
                let mut c = [0.0; 6];
                for (k, value) in c.iter_mut().enumerate() {
                    *value = (0..m).map(|a| terms[a] * coefficients[(a, k)]).sum();
                }
                sum[n] += Matrix3::new(c[0], c[3], c[5], c[3], c[1], c[4], c[5], c[4], c[2]);
                count[n] += 1;
            }
        }
    }
    let averaged = averaged_nodal(mesh, displacement, stress);
    Ok(sum
        .into_iter()
        .zip(count)
        .zip(averaged)
        .map(|((s, c), a)| if c > 0 { s / c as f64 } else { a })
        .collect())
}
