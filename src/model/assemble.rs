//! Global internal force, energy and tangent of a force model on a mesh.
//!
//! Every function takes the full displacement vector u (length 3·nodes, DOF `3·node + axis`)
//! and checks its length before touching it. Generic over the element ([`ModelElement`]: the
//! 4-node tet's closed forms, or the 10-node tet's quadrature points); each is monomorphized
//! per element, so the 4-node tet runs the code it always ran.

use nalgebra::Vector3;

use super::TetModels;
use super::element_model::{ModelElement, corners, positions};
use crate::base::error::{Error, Result};
use crate::fe::assembly::Assembler;
use crate::fe::element::Tet;
use crate::mesh::{CellType, TetMesh};
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

fn check_displacement<C: CellType>(mesh: &TetMesh<C>, u: &[f64]) -> Result<()> {
    Error::check_len("displacement", mesh.dof_count(), u.len())
}

/// Tets per partial sum of [`energy`]: fixed, so that the sum is the same bits whatever the
/// number of threads (rayon's own `sum` splits where the work-stealing happens to).
const ENERGY_CHUNK: usize = 1024;

/// Total elastic energy Σₑ Eₑ at displacement `u` (full length); `model` is one force model
/// for every tet or a [`ModelMap`](super::ModelMap) (one per material). Summed in fixed chunks
/// of tets, in order: the same bits on any number of threads.
pub fn energy<E: ModelElement>(
    mesh: &TetMesh<E>,
    model: &(impl TetModels + ?Sized),
    u: &[f64],
) -> Result<f64> {
    check_displacement(mesh, u)?;
    model.check_covers(mesh.tet_count())?;
    Ok(sum_in_chunks(mesh.tet_count(), |chunk| {
        chunk
            .map(|t| E::model_energy(model.model_of(t), mesh, t, u))
            .sum()
    }))
}

/// [`energy`] with tet `t`'s rest element read from `kept[t]` instead of rebuilt from the
/// nodes (as [`internal_force_and_energy_kept_into`]): the same bits, without an inverse and a
/// determinant per tet and pass.
///
/// Errors: those of [`energy`], or `kept` is not one element per tet.
pub fn energy_kept<E: ModelElement>(
    mesh: &TetMesh<E>,
    kept: &[Tet],
    model: &(impl TetModels + ?Sized),
    u: &[f64],
) -> Result<f64> {
    check_displacement(mesh, u)?;
    Error::check_len("kept rest elements", mesh.tet_count(), kept.len())?;
    model.check_covers(mesh.tet_count())?;
    Ok(sum_in_chunks(mesh.tet_count(), |chunk| {
        E::model_energies_kept(mesh, kept, model, u, chunk)
    }))
}

/// Σ `sum(chunk)` over the chunks of [`ENERGY_CHUNK`] tets of `0..tets`, each `sum` the
/// chunk's terms in order, computed in parallel and added in order: the same bits on any
/// number of threads.
fn sum_in_chunks(tets: usize, sum: impl Fn(std::ops::Range<usize>) -> f64 + Sync) -> f64 {
    use rayon::prelude::*;
    let partial: Vec<f64> = (0..tets.div_ceil(ENERGY_CHUNK))
        .into_par_iter()
        .map(|chunk| sum(chunk * ENERGY_CHUNK..((chunk + 1) * ENERGY_CHUNK).min(tets)))
        .collect();
    partial.iter().sum()
}

/// Internal force vector Σₑ fₑ at displacement `u` (full length, force units), each tet with
/// its own model (see [`energy`]).
pub fn internal_force<E: ModelElement>(
    mesh: &TetMesh<E>,
    model: &(impl TetModels + ?Sized),
    u: &[f64],
) -> Result<Vec<f64>> {
    check_displacement(mesh, u)?;
    model.check_covers(mesh.tet_count())?;
    let mut force = vec![0.0; mesh.dof_count()];
    E::add_model_forces(mesh, model, u, &mut force);
    Ok(force)
}

/// [`internal_force`] and the total elastic energy Σₑ Eₑ (energy units) in one pass over the
/// tets: the same force bits, and the energy summed in tet order (its last bits may differ from
/// [`energy`]'s, which sums fixed chunks).
pub fn internal_force_and_energy<E: ModelElement>(
    mesh: &TetMesh<E>,
    model: &(impl TetModels + ?Sized),
    u: &[f64],
) -> Result<(Vec<f64>, f64)> {
    let mut force = vec![0.0; mesh.dof_count()];
    let energy = internal_force_and_energy_into(mesh, model, u, &mut force)?;
    Ok((force, energy))
}

/// [`internal_force_and_energy`] with the force written into `force` (full length, overwritten):
/// an iteration that evaluates the force many times keeps one buffer instead of allocating (and
/// the kernel zero-filling) a new vector every time.
pub fn internal_force_and_energy_into<E: ModelElement>(
    mesh: &TetMesh<E>,
    model: &(impl TetModels + ?Sized),
    u: &[f64],
    force: &mut [f64],
) -> Result<f64> {
    check_displacement(mesh, u)?;
    Error::check_len("force", mesh.dof_count(), force.len())?;
    model.check_covers(mesh.tet_count())?;
    force.fill(0.0);
    Ok(E::add_model_forces_and_energy(mesh, model, u, force))
}

/// The linear element (Dm⁻¹, V, ∇Nₐ) of every tet's four corners, in tet order: what a force
/// evaluated many times keeps instead of rebuilding each pass (`Tet::new` was 5 % of a
/// corotational backward-Euler run's time, 9,720 DOFs). 176 bytes a tet.
pub fn corner_elements<E: ModelElement>(mesh: &TetMesh<E>) -> Vec<Tet> {
    use rayon::prelude::*;
    (0..mesh.tet_count())
        .into_par_iter()
        .map(|t| mesh.element_of(t))
        .collect()
}

/// [`internal_force_and_energy_into`] with each tet's rest element from `kept` (one per tet,
/// [`corner_elements`] of this mesh): the same bits.
///
/// Errors: those of [`internal_force_and_energy_into`], and `kept` not one element per tet.
pub fn internal_force_and_energy_kept_into<E: ModelElement>(
    mesh: &TetMesh<E>,
    kept: &[Tet],
    model: &(impl TetModels + ?Sized),
    u: &[f64],
    force: &mut [f64],
) -> Result<f64> {
    check_displacement(mesh, u)?;
    Error::check_len("force", mesh.dof_count(), force.len())?;
    Error::check_len("kept rest elements", mesh.tet_count(), kept.len())?;
    model.check_covers(mesh.tet_count())?;
    force.fill(0.0);
    Ok(E::add_model_forces_and_energy_kept(
        mesh, kept, model, u, force,
    ))
}

/// Refills `tangent` (on `assembler`'s pattern) with Σₑ (element tangent), each projected onto
/// the positive semi-definite cone when `project` is set, in parallel, O(nnz), no new pattern;
/// each tet with its own model (see [`energy`]).
pub fn refill_tangent<E: ModelElement>(
    mesh: &TetMesh<E>,
    assembler: &Assembler,
    model: &(impl TetModels + ?Sized),
    u: &[f64],
    project: bool,
    tangent: &mut CscMatrix,
) -> Result<()> {
    check_displacement(mesh, u)?;
    model.check_covers(mesh.tet_count())?;
    E::refill_model_tangent(mesh, assembler, model, u, project, tangent)
}

/// [`refill_tangent`] with each tet's rest element read from `kept` (one per tet) instead of
/// rebuilt from the nodes: the same bits.
///
/// Errors: those of [`refill_tangent`], or `kept` is not one element per tet.
pub fn refill_tangent_kept<E: ModelElement>(
    mesh: &TetMesh<E>,
    kept: &[Tet],
    assembler: &Assembler,
    model: &(impl TetModels + ?Sized),
    (u, project): (&[f64], bool),
    tangent: &mut CscMatrix,
) -> Result<()> {
    check_displacement(mesh, u)?;
    Error::check_len("kept rest elements", mesh.tet_count(), kept.len())?;
    model.check_covers(mesh.tet_count())?;
    E::refill_model_tangent_kept(mesh, kept, assembler, model, (u, project), tangent)
}

/// The volume-weighted sum Aᵢ = Σₑ∋ᵢ Vₑ·Fₑ of the deformation gradients of the tets around each
/// node at displacement `u` (full length), Fₑ = Ds(x)·Dm(X)⁻¹ from each tet's four corners (a
/// 10-node tet's edge nodes take its corner F as well). `out` has one matrix per node; a node
/// in no tet gets zero. Its polar rotation is the node's rotation of the deformation: what
/// [`crate::analysis::dynamics::NonlinearSolve::RestPreconditionedCg`] turns the rest factor by.
///
/// Errors: `u` is not full length, or `out` is not one per node.
pub fn nodal_deformation_gradients<E: ModelElement>(
    mesh: &TetMesh<E>,
    u: &[f64],
    out: &mut [nalgebra::Matrix3<f64>],
) -> Result<()> {
    // The inputs are checked before the rest elements are built (the work a bad call spares).
    check_displacement(mesh, u)?;
    Error::check_len("nodal deformation gradients", mesh.node_count(), out.len())?;
    nodal_deformation_gradients_kept(mesh, &corner_elements(mesh), u, out)
}

/// [`nodal_deformation_gradients`] with each tet's Dm⁻¹ and V from `kept` (one per tet,
/// [`corner_elements`] of this mesh), which a caller evaluating it many times keeps.
///
/// Errors: those of [`nodal_deformation_gradients`], and `kept` not one element per tet.
pub fn nodal_deformation_gradients_kept<E: ModelElement>(
    mesh: &TetMesh<E>,
    kept: &[Tet],
    u: &[f64],
    out: &mut [nalgebra::Matrix3<f64>],
) -> Result<()> {
    check_displacement(mesh, u)?;
    Error::check_len("nodal deformation gradients", mesh.node_count(), out.len())?;
    Error::check_len("kept rest elements", mesh.tet_count(), kept.len())?;
    add_at_nodes(mesh, out, |t| {
        let (_, deformed) = corners(mesh, t, u);
        crate::mesh::geometry::rest_shape_matrix(&deformed)
            * kept[t].rest_inverse()
            * kept[t].volume()
    });
    Ok(())
}

/// `out` ← Σₑ∋ᵢ `weighted(e)` at each node i of each tet (zero where none): the tets' matrices computed in parallel a block at a time and added serially in
/// tet order, so the sums are the same bits as one tet after another on any number of threads.
fn add_at_nodes<E: ModelElement>(
    mesh: &TetMesh<E>,
    out: &mut [nalgebra::Matrix3<f64>],
    weighted: impl Fn(usize) -> nalgebra::Matrix3<f64> + Sync,
) {
    use rayon::prelude::*;
    // 8192 tets' matrices (0.6 MB) stay in the cache between computing and adding them.
    const BLOCK: usize = 8192;
    out.fill(nalgebra::Matrix3::zeros());
    let tets = mesh.tet_count();
    let mut block = vec![nalgebra::Matrix3::zeros(); BLOCK.min(tets)];
    for start in (0..tets).step_by(BLOCK) {
        let end = (start + BLOCK).min(tets);
        let one = |(i, m): (usize, &mut nalgebra::Matrix3<f64>)| *m = weighted(start + i);
        // One thread: in this thread, not handed to the pool's (`linalg::parallel::one_thread`
        // says why); the same bits.
        match crate::linalg::parallel::one_thread() {
            true => block[..end - start].iter_mut().enumerate().for_each(one),
            false => block[..end - start]
                .par_iter_mut()
                .enumerate()
                .for_each(one),
        }
        for (m, cell) in block.iter().zip(&mesh.tets()[start..end]) {
            for &n in cell.as_ref() {
                out[n] += m;
            }
        }
    }
}
