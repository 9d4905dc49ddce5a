//! Global internal force, energy and tangent of a force model on a mesh.
//!
//! Every function takes the full displacement vector u (length 3·nodes, DOF `3·node + axis`)
//! and checks its length before touching it.

use nalgebra::Vector3;

use super::{TetModels, project_psd};
use crate::assembly::Assembler;
use crate::error::{Error, Result};
use crate::mesh::TetMesh;
use crate::sparse::CscMatrix;

/// Deformed positions x = X + u of tet `t` from a full displacement vector.
///
/// Errors: `t` is not a tet of `mesh`, or `displacement` is not full length.
pub fn deformed_positions(
    mesh: &TetMesh,
    t: usize,
    displacement: &[f64],
) -> Result<[Vector3<f64>; 4]> {
    mesh.check_tet("deformed_positions", t)?;
    check_displacement(mesh, displacement)?;
    Ok(positions(mesh, t, displacement))
}

fn check_displacement(mesh: &TetMesh, u: &[f64]) -> Result<()> {
    Error::check_len("displacement", mesh.dof_count(), u.len())
}

/// x = X + u for tet `t`; `t` and `u`'s length were checked by the caller.
fn positions(mesh: &TetMesh, t: usize, u: &[f64]) -> [Vector3<f64>; 4] {
    mesh.tets()[t].map(|n| mesh.nodes()[n] + Vector3::new(u[3 * n], u[3 * n + 1], u[3 * n + 2]))
}

/// Tets per partial sum of [`energy`]: fixed, so that the sum is the same bits whatever the
/// number of threads (rayon's own `sum` splits where the work-stealing happens to).
const ENERGY_CHUNK: usize = 1024;

/// Total elastic energy Σₑ Eₑ at displacement `u` (full length); `model` is one force model
/// for every tet or a [`ModelMap`](super::ModelMap) (one per material). Summed in fixed chunks
/// of tets, in order: the same bits on any number of threads.
pub fn energy(mesh: &TetMesh, model: &(impl TetModels + ?Sized), u: &[f64]) -> Result<f64> {
    use rayon::prelude::*;
    check_displacement(mesh, u)?;
    model.check_tet_count(mesh)?;
    let tets = mesh.tet_count();
    let partial: Vec<f64> = (0..tets.div_ceil(ENERGY_CHUNK))
        .into_par_iter()
        .map(|chunk| {
            (chunk * ENERGY_CHUNK..((chunk + 1) * ENERGY_CHUNK).min(tets))
                .map(|t| {
                    model.model_of(t).energy(
                        &mesh.element_of(t),
                        &mesh.positions_of(t),
                        &positions(mesh, t, u),
                    )
                })
                .sum::<f64>()
        })
        .collect();
    Ok(partial.iter().sum())
}

/// Internal force vector Σₑ fₑ at displacement `u` (full length, force units), each tet with
/// its own model (see [`energy`]).
pub fn internal_force(
    mesh: &TetMesh,
    model: &(impl TetModels + ?Sized),
    u: &[f64],
) -> Result<Vec<f64>> {
    check_displacement(mesh, u)?;
    model.check_tet_count(mesh)?;
    let mut force = vec![0.0; mesh.dof_count()];
    for (t, tet) in mesh.tets().iter().enumerate() {
        let f = model.model_of(t).force(
            &mesh.element_of(t),
            &mesh.positions_of(t),
            &positions(mesh, t, u),
        );
        for (i, &n) in tet.iter().enumerate() {
            for a in 0..3 {
                force[3 * n + a] += f[3 * i + a];
            }
        }
    }
    Ok(force)
}

/// Refills `tangent` (on `assembler`'s pattern) with Σₑ (element tangent), each projected onto
/// the positive semi-definite cone when `project` is set, in parallel, O(nnz), no new pattern;
/// each tet with its own model (see [`energy`]).
pub fn refill_tangent(
    mesh: &TetMesh,
    assembler: &Assembler,
    model: &(impl TetModels + ?Sized),
    u: &[f64],
    project: bool,
    tangent: &mut CscMatrix,
) -> Result<()> {
    check_displacement(mesh, u)?;
    model.check_tet_count(mesh)?;
    assembler.reassemble(
        mesh,
        |t| {
            let k = model.model_of(t).tangent(
                &mesh.element_of(t),
                &mesh.positions_of(t),
                &positions(mesh, t, u),
            );
            if project { project_psd(&k) } else { k }
        },
        tangent,
    )
}
