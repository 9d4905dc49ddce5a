//! The rotation of the deformation at each node, and vectors turned by it: what keeps the rest
//! factor a good preconditioner of the Newton matrix of a body that has turned far from rest
//! ([`NonlinearSolve::RestPreconditionedCg`](super::NonlinearSolve::RestPreconditionedCg)).
//!
//! A body that has turned rigidly by R has the Newton matrix R̄·J₀·R̄ᵀ, R̄ = diag(R, …, R), when
//! the mass is lumped (each node's 3×3 block is mᵢ·I, unchanged by R) and the force is
//! corotational (each tet's stiffness is R·Kₑ·Rᵀ). A bending beam turns by different amounts
//! along its length; taking each node's own rotation Rᵢ (the polar rotation of the
//! volume-weighted F of its tets) leaves J − R̄·J₀·R̄ᵀ of the order of the rotation's change
//! across one tet and of the strain, both small where the corotational model is the right one;
//! what is left (chiefly the stress stiffness of a few bending modes) CG resolves in a few
//! iterations.

use nalgebra::Matrix3;
use rayon::prelude::*;

use super::internal_force::{ForceWorkspace, NonlinearForce};
use crate::base::error::Result;
use crate::model::corotational_lanes::four_rotations;
use crate::model::lanes::LANES;
use crate::model::polar::rotation;

/// A turned node and the free indices of its x, y and z DOFs.
type Block = (usize, [usize; 3]);

/// Per-node rotations Rᵢ of the deformation, for the nodes whose three DOFs are all free.
#[derive(Debug, Clone)]
pub(crate) struct NodalRotations {
    /// The node and the free indices of its x, y and z DOFs, for each node whose three DOFs
    /// are free. A node with a constrained DOF is not turned: its free DOFs cannot carry a
    /// rotated vector without the constrained component.
    blocks: Vec<(usize, [usize; 3])>,
    /// Σₑ Vₑ·Fₑ of every node of the mesh (scratch).
    gradients: Vec<Matrix3<f64>>,
    /// Rᵢ of each block.
    rotations: Vec<Matrix3<f64>>,
}

impl NodalRotations {
    /// The blocks of `force`'s free DOFs, every rotation the identity.
    pub fn new(force: &NonlinearForce) -> Self {
        let node_count = force.node_count();
        let mut free_index = vec![None; 3 * node_count];
        for (i, &dof) in force.free_dofs().iter().enumerate() {
            if let Some(slot) = free_index.get_mut(dof) {
                *slot = Some(i);
            }
        }
        let blocks: Vec<(usize, [usize; 3])> = (0..node_count)
            .filter_map(|node| {
                let x = free_index[3 * node]?;
                let y = free_index[3 * node + 1]?;
                let z = free_index[3 * node + 2]?;
                Some((node, [x, y, z]))
            })
            .collect();
        NodalRotations {
            rotations: vec![Matrix3::identity(); blocks.len()],
            gradients: vec![Matrix3::zeros(); node_count],
            blocks,
        }
    }

    /// Rᵢ = polar rotation of Σₑ Vₑ·Fₑ at free displacements `u` (the identity at rest, and
    /// for a node whose tets are all flat or non-finite).
    pub fn update(
        &mut self,
        force: &NonlinearForce,
        u: &[f64],
        work: &mut ForceWorkspace,
    ) -> Result<()> {
        force.nodal_deformation_gradients(u, work, &mut self.gradients)?;
        let gradients = &self.gradients;
        // Four nodes side by side in SIMD lanes (the same bits as `rotation` of each); with one
        // thread in rayon's pool in this thread (`linalg::parallel::one_thread` says why).
        let turn =
            |(r, blocks): (&mut [Matrix3<f64>], &[Block])| turn_of_nodes(gradients, blocks, r);
        match crate::linalg::parallel::one_thread() {
            true => (self.rotations.chunks_mut(LANES))
                .zip(self.blocks.chunks(LANES))
                .for_each(turn),
            false => (self.rotations.par_chunks_mut(LANES))
                .zip(self.blocks.par_chunks(LANES))
                .for_each(turn),
        }
        Ok(())
    }

    /// Rᵢ of `node`, `None` for a node that is not turned (one of its DOFs constrained).
    pub fn rotation_of(&self, node: usize) -> Option<&Matrix3<f64>> {
        let at = self.blocks.binary_search_by_key(&node, |&(n, _)| n).ok()?;
        self.rotations.get(at)
    }

    /// v ← R̄ᵀ·v (free DOFs): each turned node's block into its rotated frame.
    pub fn to_rotated_frame(&self, v: &mut [f64]) {
        self.turn(v, true);
    }

    /// v ← R̄·v (free DOFs): each turned node's block back from its rotated frame.
    pub fn back_from_rotated_frame(&self, v: &mut [f64]) {
        self.turn(v, false);
    }

    fn turn(&self, v: &mut [f64], transpose: bool) {
        for (r, &(_, [x, y, z])) in self.rotations.iter().zip(&self.blocks) {
            let block = nalgebra::Vector3::new(v[x], v[y], v[z]);
            let turned = match transpose {
                true => r.tr_mul(&block),
                false => r * block,
            };
            v[x] = turned.x;
            v[y] = turned.y;
            v[z] = turned.z;
        }
    }
}

/// `r[k]` ← the polar rotation of `gradients` at the node of `blocks[k]`: four at once in SIMD
/// lanes ([`rotations`]), the others (a last chunk under four, a lane the lanes leave) by
/// [`rotation`], the same bits either way.
fn turn_of_nodes(
    gradients: &[Matrix3<f64>],
    blocks: &[(usize, [usize; 3])],
    r: &mut [Matrix3<f64>],
) {
    let of = |k: usize| gradients[blocks[k].0];
    if let Ok(r) = <&mut [Matrix3<f64>; LANES]>::try_from(&mut *r) {
        *r = four_rotations(&[of(0), of(1), of(2), of(3)]);
        return;
    }
    for (k, r) in r.iter_mut().enumerate() {
        *r = rotation(&of(k));
    }
}
