//! The barrier counted more than once in a step equation ([`StepEquation::contact_weight`]):
//! Newmark's end-point contact weighs the barrier by 2 in its incremental potential, so the
//! residual, Φ and the Newton matrix each get (w − 1) more of the contact's force, energy and
//! Hessian than the force law's own evaluation (which counts it once) holds.
//!
//! The contact's Hessian is 3×3 blocks on the nodes' diagonal ([`Contact::add_tangent`]), formed
//! here on a block-diagonal pattern of every DOF and added into the free Newton matrix through
//! a map of its entries, made once.

use std::sync::Arc;

use faer::sparse::SymbolicSparseColMat;

use super::StepEquation;
use crate::analysis::dynamics::internal_force::NonlinearForce;
use crate::base::error::{Error, Result};
use crate::contact::Contact;
use crate::sparse::CscMatrix;

/// The extra contact Hessian's scratch: the block-diagonal matrix of every DOF and, per stored
/// entry, where it goes in the free Newton matrix (`None`: a fixed DOF's row or column).
pub(crate) struct ContactBlocks {
    blocks: CscMatrix,
    target: Vec<Option<usize>>,
}

impl ContactBlocks {
    /// The scratch for `force` (with contact) and Newton matrices on `pattern` (K_ff's).
    pub fn new(force: &NonlinearForce, pattern: &CscMatrix) -> Result<Self> {
        let dofs = force
            .full_displacement(&vec![0.0; force.free_count()])?
            .len();
        let col_ptr: Vec<usize> = (0..=dofs).map(|c| 3 * c).collect();
        let row_idx: Vec<usize> = (0..dofs)
            .flat_map(|c| (0..3).map(move |r| 3 * (c / 3) + r))
            .collect();
        let symbolic = SymbolicSparseColMat::new_checked(dofs, dofs, col_ptr, None, row_idx);
        let blocks = CscMatrix::zeros(Arc::new(symbolic))?;
        let mut free_of = vec![None; dofs];
        for (i, &d) in force.free_dofs().iter().enumerate() {
            free_of[d] = Some(i);
        }
        let (cols, rows) = (pattern.col_ptr(), pattern.row_idx());
        let mut target = Vec::with_capacity(blocks.nnz());
        for c in 0..dofs {
            for k in blocks.col_ptr()[c]..blocks.col_ptr()[c + 1] {
                let r = blocks.row_idx()[k];
                target.push(match (free_of[r], free_of[c]) {
                    (Some(fr), Some(fc)) => {
                        let range = cols[fc]..cols[fc + 1];
                        let at = rows[range.clone()].binary_search(&fr).map_err(|_| {
                            Error::invalid_parameter(
                                "Newton matrix",
                                format!("no entry ({fr}, {fc})"),
                                "must hold every free node's 3×3 diagonal block",
                            )
                        })?;
                        Some(range.start + at)
                    }
                    _ => None,
                });
            }
        }
        Ok(ContactBlocks { blocks, target })
    }

    /// Adds `extra`·∂²E_c/∂u² at free displacements `u` into `matrix` (the free Newton matrix
    /// this scratch was made for), the barrier's curvature term dropped when `project` is set
    /// (as [`Contact::add_tangent`] does).
    pub fn add(
        &mut self,
        force: &NonlinearForce,
        contact: &Contact,
        (u, project, extra): (&[f64], bool, f64),
        matrix: &mut CscMatrix,
    ) -> Result<()> {
        let full = force.full_displacement(u)?;
        self.blocks.values_mut().fill(0.0);
        contact.add_tangent(&full, project, &mut self.blocks)?;
        let values = matrix.values_mut();
        for (k, &v) in self.blocks.values().iter().enumerate() {
            if let Some(p) = self.target[k] {
                values[p] += extra * v;
            }
        }
        Ok(())
    }
}

/// w − 1 of `equation` when the force has contact and the weight is not 1 (`None` otherwise:
/// the force law's own evaluation is the step's).
pub(crate) fn extra_weight(force: &NonlinearForce, equation: &StepEquation) -> Option<f64> {
    (force.contact().is_some() && equation.contact_weight != 1.0)
        .then_some(equation.contact_weight - 1.0)
}

/// The contact force −∂E_c/∂u (force units) on the free DOFs at free displacements `u`, and
/// E_c(u) (energy units); zeros and 0 without contact.
pub(crate) fn contact_force_and_energy(
    force: &NonlinearForce,
    u: &[f64],
) -> Result<(Vec<f64>, f64)> {
    let Some(contact) = force.contact() else {
        return Ok((vec![0.0; u.len()], 0.0));
    };
    let full = force.full_displacement(u)?;
    let mut full_force = vec![0.0; full.len()];
    contact.add_force(&full, &mut full_force)?;
    let energy = contact.energy(&full)?;
    Ok((
        force.free_dofs().iter().map(|&d| full_force[d]).collect(),
        energy,
    ))
}
