//! The barrier counted more than once in a step equation ([`StepEquation::contact_weight`]):
//! Newmark's end-point contact weighs the barrier by 2 in its incremental potential, so the
//! residual, Φ and the Newton matrix each get (w − 1) more of the contact's force, energy and
//! Hessian than the force law's own evaluation (which counts it once) holds. "The barrier" is
//! every contact potential of the force: the obstacles' and the surface's (body–body and
//! self-contact), both end-point terms of the same step.
//!
//! The obstacles' Hessian is 3×3 blocks on the nodes' diagonal
//! ([`Contact::add_tangent`](crate::contact::Contact::add_tangent)),
//! formed here on a block-diagonal pattern of every DOF; the surface barrier's couples the four
//! nodes of each pair, formed on the assembly's full pattern (its off-pattern entries lumped
//! onto the diagonal exactly as the force law's own tangent lumps them, so the lumped list the
//! CG correction reads is the same: it is scaled by w there). Each is added into the free
//! Newton matrix through a map of its entries, made once.

use std::sync::Arc;

use faer::sparse::SymbolicSparseColMat;

use super::StepEquation;
use crate::analysis::dynamics::internal_force::NonlinearForce;
use crate::base::error::{Error, Result};
use crate::sparse::CscMatrix;

/// A full-DOF scratch matrix and, per stored entry, where it goes in the free Newton matrix
/// (`None`: a fixed DOF's row or column).
struct Mapped {
    full: CscMatrix,
    target: Vec<Option<usize>>,
}

impl Mapped {
    /// The map of `full`'s entries into `pattern` (K_ff's) for `force`'s free DOFs; an entry
    /// between two free DOFs that `pattern` lacks is an error naming it.
    fn new(force: &NonlinearForce, full: CscMatrix, pattern: &CscMatrix) -> Result<Self> {
        let dofs = full.dim();
        let mut free_of = vec![None; dofs];
        for (i, &d) in force.free_dofs().iter().enumerate() {
            free_of[d] = Some(i);
        }
        let (cols, rows) = (pattern.col_ptr(), pattern.row_idx());
        let mut target = Vec::with_capacity(full.nnz());
        for c in 0..dofs {
            for k in full.col_ptr()[c]..full.col_ptr()[c + 1] {
                let r = full.row_idx()[k];
                target.push(match (free_of[r], free_of[c]) {
                    (Some(fr), Some(fc)) => {
                        let range = cols[fc]..cols[fc + 1];
                        let at = rows[range.clone()].binary_search(&fr).map_err(|_| {
                            Error::invalid_parameter(
                                "Newton matrix",
                                format!("no entry ({fr}, {fc})"),
                                "must hold every entry the contact's Hessian is formed on",
                            )
                        })?;
                        Some(range.start + at)
                    }
                    _ => None,
                });
            }
        }
        Ok(Mapped { full, target })
    }

    /// `matrix` += `extra`·(the scratch's values), through the map.
    fn add_into(&self, extra: f64, matrix: &mut CscMatrix) {
        let values = matrix.values_mut();
        for (k, &v) in self.full.values().iter().enumerate() {
            if let Some(p) = self.target[k] {
                values[p] += extra * v;
            }
        }
    }
}

/// The extra contact Hessian's scratch: the obstacles' block-diagonal matrix of every DOF and
/// the surface barrier's matrix on the assembly's full pattern, each with its map into the free
/// Newton matrix (`None` where the force has no such contact).
pub(crate) struct ContactBlocks {
    obstacles: Option<Mapped>,
    surface: Option<Mapped>,
}

impl ContactBlocks {
    /// The scratch for `force` (with contact) and Newton matrices on `pattern` (K_ff's).
    pub fn new(force: &NonlinearForce, pattern: &CscMatrix) -> Result<Self> {
        let dofs = force
            .full_displacement(&vec![0.0; force.free_count()])?
            .len();
        let obstacles = match force.contact() {
            Some(_) => {
                let col_ptr: Vec<usize> = (0..=dofs).map(|c| 3 * c).collect();
                let row_idx: Vec<usize> = (0..dofs)
                    .flat_map(|c| (0..3).map(move |r| 3 * (c / 3) + r))
                    .collect();
                let symbolic =
                    SymbolicSparseColMat::new_checked(dofs, dofs, col_ptr, None, row_idx);
                let blocks = CscMatrix::zeros(Arc::new(symbolic))?;
                Some(Mapped::new(force, blocks, pattern)?)
            }
            None => None,
        };
        let surface = match force.surface_contact() {
            Some(_) => Some(Mapped::new(force, force.full_zero_tangent()?, pattern)?),
            None => None,
        };
        Ok(ContactBlocks { obstacles, surface })
    }

    /// Adds `extra`·∂²E_c/∂u² at free displacements `u` into `matrix` (the free Newton matrix
    /// this scratch was made for), E_c every contact potential of `force`, the barrier's
    /// curvature term dropped (obstacles) or each pair's block projected to PSD (surface) when
    /// `project` is set, as the force law's own tangent does
    /// ([`crate::contact::Contact::add_tangent`], [`crate::contact::surface::SurfaceContact::add_tangent`]).
    pub fn add(
        &mut self,
        force: &NonlinearForce,
        (u, project, extra): (&[f64], bool, f64),
        matrix: &mut CscMatrix,
    ) -> Result<()> {
        let full = force.full_displacement(u)?;
        if let (Some(mapped), Some(contact)) = (&mut self.obstacles, force.contact()) {
            mapped.full.values_mut().fill(0.0);
            contact.add_tangent(&full, project, &mut mapped.full)?;
            mapped.add_into(extra, matrix);
        }
        if let (Some(mapped), Some(surface)) = (&mut self.surface, force.surface_contact()) {
            mapped.full.values_mut().fill(0.0);
            surface.add_tangent(&full, project, &mut mapped.full)?;
            mapped.add_into(extra, matrix);
        }
        Ok(())
    }
}

/// w − 1 of `equation` when the force has contact (obstacles or surface) and the weight is
/// not 1 (`None` otherwise: the force law's own evaluation is the step's).
pub(crate) fn extra_weight(force: &NonlinearForce, equation: &StepEquation) -> Option<f64> {
    (force.has_contact() && equation.contact_weight != 1.0).then_some(equation.contact_weight - 1.0)
}

/// The contact force −∂E_c/∂u (force units) on the free DOFs at free displacements `u`, and
/// E_c(u) (energy units), E_c the obstacles' barrier plus the surface barrier; zeros and 0
/// without contact.
pub(crate) fn contact_force_and_energy(
    force: &NonlinearForce,
    u: &[f64],
) -> Result<(Vec<f64>, f64)> {
    if !force.has_contact() {
        return Ok((vec![0.0; u.len()], 0.0));
    }
    let full = force.full_displacement(u)?;
    let mut full_force = vec![0.0; full.len()];
    let mut energy = 0.0;
    if let Some(contact) = force.contact() {
        contact.add_force(&full, &mut full_force)?;
        energy = contact.energy(&full)?;
    }
    if let Some(surface) = force.surface_contact() {
        surface.add_force(&full, &mut full_force)?;
        energy += surface.energy(&full)?;
    }
    Ok((
        force.free_dofs().iter().map(|&d| full_force[d]).collect(),
        energy,
    ))
}
