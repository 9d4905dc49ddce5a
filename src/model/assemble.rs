//! Global internal force, energy and tangent of a force model on a mesh.

use nalgebra::Vector3;

use super::{ForceModel, project_psd};
use crate::assembly::Assembler;
use crate::mesh::TetMesh;
use crate::sparse::CscMatrix;

/// Deformed positions x = X + u of tet `t` from a full displacement vector.
pub fn deformed_positions(mesh: &TetMesh, t: usize, displacement: &[f64]) -> [Vector3<f64>; 4] {
    mesh.tets()[t].map(|n| {
        mesh.nodes()[n]
            + Vector3::new(
                displacement[3 * n],
                displacement[3 * n + 1],
                displacement[3 * n + 2],
            )
    })
}

/// Total elastic energy Σₑ Eₑ at displacement `u` (full length).
pub fn energy(mesh: &TetMesh, model: &dyn ForceModel, u: &[f64]) -> f64 {
    use rayon::prelude::*;
    (0..mesh.tet_count())
        .into_par_iter()
        .map(|t| {
            model.energy(
                &mesh.element(t),
                &mesh.tet_positions(t),
                &deformed_positions(mesh, t, u),
            )
        })
        .sum()
}

/// Internal force vector Σₑ fₑ at displacement `u` (full length, force units).
pub fn internal_force(mesh: &TetMesh, model: &dyn ForceModel, u: &[f64]) -> Vec<f64> {
    let mut force = vec![0.0; mesh.dof_count()];
    for (t, tet) in mesh.tets().iter().enumerate() {
        let f = model.force(
            &mesh.element(t),
            &mesh.tet_positions(t),
            &deformed_positions(mesh, t, u),
        );
        for (i, &n) in tet.iter().enumerate() {
            for a in 0..3 {
                force[3 * n + a] += f[3 * i + a];
            }
        }
    }
    force
}

/// Refills `tangent` (on `assembler`'s pattern) with Σₑ (element tangent), each projected onto
/// the positive semi-definite cone when `project` is set, in parallel, O(nnz), no new pattern.
pub fn refill_tangent(
    mesh: &TetMesh,
    assembler: &Assembler,
    model: &dyn ForceModel,
    u: &[f64],
    project: bool,
    tangent: &mut CscMatrix,
) {
    assembler.reassemble(
        mesh,
        |t| {
            let k = model.tangent(
                &mesh.element(t),
                &mesh.tet_positions(t),
                &deformed_positions(mesh, t, u),
            );
            if project { project_psd(&k) } else { k }
        },
        tangent,
    );
}
