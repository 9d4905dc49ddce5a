//! The rest factor with the contact nodes' own stiffness: L-BFGS's initial inverse Hessian in
//! contact with rigid obstacles, without a factorization.
//!
//! A rigid obstacle's barrier and friction act node by node, so near a step's solution the
//! Hessian of its potential is, in the nodes' rotated frame,
//!
//! J ≈ J₀ + E·D·Eᵀ,
//!
//! J₀ the rest Newton matrix (factored once for the run), E the columns of the contact nodes'
//! free DOFs and D their 3×3 blocks of barrier and friction Hessian (each turned into its node's
//! frame, Rᵢᵀ·Dᵢ·Rᵢ). The rest factor alone knows nothing of D, whose blocks are tens of times
//! a surface node's elastic stiffness when a node sticks; refactoring J for them costs a
//! factorization a step. Woodbury's identity inverts the sum with the rest factor and one
//! dense matrix of the contact DOFs' size k (D = Q², Q the symmetric square root of each block):
//!
//! (J₀ + E·Q·Q·Eᵀ)⁻¹·v = J₀⁻¹·(v − E·Q·C⁻¹·Q·Eᵀ·J₀⁻¹·v),  C = I + Q·S₀·Q,  S₀ = Eᵀ·J₀⁻¹·E.
//!
//! S₀ depends on the rest factor and the contact DOFs only: its columns J₀⁻¹·e_j are solved
//! once for each DOF the first time it touches, and kept while the rest factor stands (they
//! are the same numbers in every step, so a step still depends on its state alone: entry (i, j)
//! is always read from the column of the smaller index). C (k×k, symmetric positive definite:
//! I plus a congruence of S₀) is factored with D at the run's first iterate in contact, and
//! again where L-BFGS asks (after a poor step, `super::direction::Lbfgs`); applying the
//! inverse then costs two triangular solve pairs on the rest factor and two small products.

use std::collections::BTreeMap;

use faer::linalg::solvers::{Llt, Solve};
use faer::{Mat, Side};
use nalgebra::{Matrix3, SymmetricEigen};

use crate::analysis::dynamics::internal_force::NonlinearForce;
use crate::analysis::dynamics::nodal_rotation::NodalRotations;
use crate::base::error::Result;

/// Most contact DOFs a correction is made for. Its dense factor costs k³/3 flops a run and its
/// columns k triangular solve pairs once: at k = 1,024 about 3.6e8 flops, the order of a
/// factorization of J at 10k DOFs, past which factoring J is the cheaper way to hold the
/// contact's stiffness.
pub const MAX_CONTACT_DOFS: usize = 1024;

/// Most bytes the kept columns J₀⁻¹·e_j may hold (f64 each, the free DOFs long): n·k·8 for k
/// contact DOFs of n. The columns cost k triangular solve pairs, once, the first time each DOF
/// touches: at 10,125 DOFs 675 of them (55 MB) took about 0.8 s at the landing of
/// `benches/interactive_contact.rs`'s block. At 41,472 DOFs its bottom's 1,728 DOFs would take
/// 570 MB and, measured, a landing of 11 s: past this budget factoring J each contact step
/// (the CG path) costs less.
const COLUMN_BYTES: usize = 128 << 20;

/// One contact node of a run: the free indices of its DOFs (1 to 3, in x, y, z order), where
/// they start among the run's contact DOFs, and Q, the root of its turned block (only the
/// leading `count`×`count` part is used).
struct ContactNode {
    dofs: [usize; 3],
    count: usize,
    offset: usize,
    root: Matrix3<f64>,
}

/// The kept columns of J₀⁻¹ at contact DOFs and this run's factored capacitance matrix.
#[derive(Default)]
pub(crate) struct ContactCapacitance {
    /// J₀⁻¹·e_j for each free DOF j met in contact since the rest factor of `key` was made.
    columns: BTreeMap<usize, Vec<f64>>,
    /// The (mass scale, damping stiffness) of the rest factor the columns were solved on.
    key: Option<(f64, f64)>,
    /// This run's contact nodes (empty: no correction).
    nodes: Vec<ContactNode>,
    /// The Cholesky factor of C = I + Q·S₀·Q for this run.
    capacitance: Option<Llt<f64>>,
    /// The contact DOFs of the last S₀ formed and S₀ over them (k×k, column-major).
    block: Option<(Vec<usize>, Vec<f64>)>,
}

/// What [`ContactCapacitance::prepare`] made.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Prepared {
    /// No node is in contact: H₀ is the rest factor's.
    NoContact,
    /// H₀ holds the contact nodes' blocks.
    Corrected,
    /// Too many contact DOFs ([`MAX_CONTACT_DOFS`], or the columns past their memory), or C
    /// did not factor: the run should hold the contact's stiffness another way.
    TooLarge,
}

impl ContactCapacitance {
    /// Drops this run's correction: H₀ is the rest factor's until the next
    /// [`prepare`](Self::prepare).
    pub fn clear(&mut self) {
        self.nodes.clear();
        self.capacitance = None;
    }

    /// Makes the correction for `nodes` (from [`ContactNodes::of`]) of a problem with `n` free
    /// DOFs: the columns not kept yet solved by `solve` (J₀⁻¹ in place, on the rest factor of
    /// `key`: the columns of another one are dropped), C formed and factored.
    pub fn prepare(
        &mut self,
        nodes: ContactNodes,
        n: usize,
        key: (f64, f64),
        solve: &mut dyn FnMut(&mut [f64]) -> Result<()>,
    ) -> Result<Prepared> {
        self.prepare_nodes(nodes.0, n, key, solve)
    }

    /// [`prepare`](Self::prepare) for the contact nodes `nodes`.
    fn prepare_nodes(
        &mut self,
        nodes: Vec<ContactNode>,
        n: usize,
        key: (f64, f64),
        solve: &mut dyn FnMut(&mut [f64]) -> Result<()>,
    ) -> Result<Prepared> {
        self.clear();
        if self.key != Some(key) {
            self.columns.clear();
            self.block = None;
            self.key = Some(key);
        }
        let k = nodes.last().map_or(0, |n| n.offset + n.count);
        if k == 0 {
            return Ok(Prepared::NoContact);
        }
        let new: Vec<usize> = (nodes.iter())
            .flat_map(|node| node.dofs[..node.count].to_vec())
            .filter(|d| !self.columns.contains_key(d))
            .collect();
        if k > MAX_CONTACT_DOFS || (self.columns.len() + new.len()) * n * 8 > COLUMN_BYTES {
            return Ok(Prepared::TooLarge);
        }
        for dof in new {
            let mut column = vec![0.0; n];
            column[dof] = 1.0;
            solve(&mut column)?;
            self.columns.insert(dof, column);
        }
        self.nodes = nodes;
        self.capacitance = self.capacitance_matrix(k).llt(Side::Lower).ok();
        if self.capacitance.is_none() {
            self.nodes.clear();
            return Ok(Prepared::TooLarge);
        }
        Ok(Prepared::Corrected)
    }

    /// S₀ over this run's contact DOFs (k of them), k×k column-major: entry (i, j) = (J₀⁻¹)ᵢⱼ
    /// read from the column of the smaller free index (the same number whichever DOF touched
    /// first). Kept with its DOFs: a body resting or sliding keeps its contact nodes from step
    /// to step.
    fn rest_inverse_block(&mut self, k: usize) -> &[f64] {
        let dofs: Vec<usize> = (self.nodes.iter())
            .flat_map(|node| node.dofs[..node.count].to_vec())
            .collect();
        if self.block.as_ref().is_none_or(|(kept, _)| *kept != dofs) {
            let columns: Vec<&[f64]> = (dofs.iter())
                .map(|d| self.columns.get(d).map_or(&[][..], |c| c.as_slice()))
                .collect();
            let mut s = vec![0.0; k * k];
            for j in 0..k {
                for i in 0..k {
                    let (low, high) = match dofs[i] < dofs[j] {
                        true => (i, j),
                        false => (j, i),
                    };
                    s[j * k + i] = columns[low].get(dofs[high]).copied().unwrap_or(0.0);
                }
            }
            self.block = Some((dofs, s));
        }
        &self.block.as_ref().expect("S₀ kept just above").1
    }

    /// C = I + Q·S₀·Q over this run's contact DOFs (k of them).
    fn capacitance_matrix(&mut self, k: usize) -> Mat<f64> {
        self.rest_inverse_block(k);
        let s = &self.block.as_ref().expect("S₀ formed just above").1;
        // Q block diagonal and S₀ symmetric: S₀·Q by columns, then (S₀·Q)ᵀ·Q = Q·S₀·Q.
        let half = transposed(&scale_columns(&self.nodes, s, k), k);
        let c = scale_columns(&self.nodes, &half, k);
        Mat::from_fn(k, k, |i, j| c[j * k + i] + f64::from(u8::from(i == j)))
    }

    /// v ← (J₀ + E·D·Eᵀ)⁻¹·v (the nodes' rotated frame), `solve` applying J₀⁻¹ in place; J₀⁻¹·v
    /// alone when the run has no correction.
    pub fn apply(
        &self,
        v: &mut [f64],
        solve: &mut dyn FnMut(&mut [f64]) -> Result<()>,
    ) -> Result<()> {
        let Some(capacitance) = &self.capacitance else {
            return solve(v);
        };
        let k = self.nodes.last().map_or(0, |n| n.offset + n.count);
        let mut w = v.to_vec();
        solve(&mut w)?;
        let mut y = Mat::<f64>::zeros(k, 1);
        for node in &self.nodes {
            for p in 0..node.count {
                y[(node.offset + p, 0)] = (0..node.count)
                    .map(|q| node.root[(p, q)] * w[node.dofs[q]])
                    .sum();
            }
        }
        capacitance.solve_in_place(&mut y);
        for node in &self.nodes {
            for p in 0..node.count {
                v[node.dofs[p]] -= (0..node.count)
                    .map(|q| node.root[(p, q)] * y[(node.offset + q, 0)])
                    .sum::<f64>();
            }
        }
        solve(v)
    }
}

/// The contact nodes of a run, with their blocks' roots: what
/// [`ContactCapacitance::prepare`] makes its correction for.
pub(crate) struct ContactNodes(Vec<ContactNode>);

impl ContactNodes {
    /// The contact nodes of `force` at free displacements `u` (see [`contact_nodes`]).
    pub fn of(
        force: &NonlinearForce,
        at: (&[f64], f64),
        rotations: &NodalRotations,
    ) -> Result<Self> {
        Ok(ContactNodes(contact_nodes(force, at, rotations)?))
    }

    /// Whether the correction for them, in a problem of `n` free DOFs, would be larger than
    /// [`MAX_CONTACT_DOFS`] or its columns alone than their memory budget.
    pub fn too_many(&self, n: usize) -> bool {
        let k = self.0.last().map_or(0, |n| n.offset + n.count);
        k > MAX_CONTACT_DOFS || k * n * 8 > COLUMN_BYTES
    }
}

/// The contact nodes of `force` at free displacements `u` with a free DOF: their free indices
/// and the root of their barrier-and-friction block (the barrier counted `barrier_weight`
/// times), turned into the node's frame (Rᵀ·D·R) where
/// `rotations` turns it; a node with a constrained DOF keeps the free part of its block.
fn contact_nodes(
    force: &NonlinearForce,
    (u, barrier_weight): (&[f64], f64),
    rotations: &NodalRotations,
) -> Result<Vec<ContactNode>> {
    let free = force.free_dofs();
    let mut nodes = Vec::new();
    let mut offset = 0;
    for (node, block) in force.contact_node_blocks(u, barrier_weight)? {
        let mut dofs = [0; 3];
        let mut axes = [0; 3];
        let mut count = 0;
        for axis in 0..3 {
            if let Ok(i) = free.binary_search(&(3 * node + axis)) {
                dofs[count] = i;
                axes[count] = axis;
                count += 1;
            }
        }
        if count == 0 {
            continue;
        }
        let turned = match rotations.rotation_of(node) {
            Some(r) => r.transpose() * block * r,
            None => block,
        };
        let mut part = Matrix3::zeros();
        for p in 0..count {
            for q in 0..count {
                part[(p, q)] = turned[(axes[p], axes[q])];
            }
        }
        nodes.push(ContactNode {
            dofs,
            count,
            offset,
            root: symmetric_root(&part),
        });
        offset += count;
    }
    Ok(nodes)
}

/// M·Q for the block diagonal Q of `nodes`' roots (Q symmetric), `m` k×k column-major: each
/// node's columns of `m` combined by its 3×3 root.
fn scale_columns(nodes: &[ContactNode], m: &[f64], k: usize) -> Vec<f64> {
    let mut out = vec![0.0; m.len()];
    for node in nodes {
        for q in 0..node.count {
            let target = &mut out[(node.offset + q) * k..][..k];
            for p in 0..node.count {
                let weight = node.root[(p, q)];
                let source = &m[(node.offset + p) * k..][..k];
                for (t, s) in target.iter_mut().zip(source) {
                    *t += weight * s;
                }
            }
        }
    }
    out
}

/// The transpose of the k×k column-major `m`.
fn transposed(m: &[f64], k: usize) -> Vec<f64> {
    let mut out = vec![0.0; m.len()];
    for j in 0..k {
        for i in 0..k {
            out[i * k + j] = m[j * k + i];
        }
    }
    out
}

/// The symmetric positive semi-definite square root of the symmetric part of `m`, its negative
/// eigenvalues (round-off of a PSD block) taken as zero.
fn symmetric_root(m: &Matrix3<f64>) -> Matrix3<f64> {
    let symmetric = 0.5 * (m + m.transpose());
    let eigen = SymmetricEigen::new(symmetric);
    let roots = eigen.eigenvalues.map(|l| l.max(0.0).sqrt());
    eigen.eigenvectors * Matrix3::from_diagonal(&roots) * eigen.eigenvectors.transpose()
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{DMatrix, DVector};

    /// A symmetric positive definite J₀ of size `n`: a tridiagonal stiffness plus a mass term.
    fn rest_matrix(n: usize) -> DMatrix<f64> {
        DMatrix::from_fn(n, n, |i, j| match i.abs_diff(j) {
            0 => 2.5 + 0.1 * i as f64,
            1 => -1.0,
            3 => 0.3,
            _ => 0.0,
        })
    }

    /// A contact node on the free DOFs `dofs` whose block is `d` (PSD).
    fn node(dofs: &[usize], d: Matrix3<f64>, offset: usize) -> ContactNode {
        let mut all = [0; 3];
        all[..dofs.len()].copy_from_slice(dofs);
        ContactNode {
            dofs: all,
            count: dofs.len(),
            offset,
            root: symmetric_root(&d),
        }
    }

    /// Woodbury's identity: with the blocks made, `apply` inverts J₀ + E·D·Eᵀ (a stiff normal
    /// block, 1e4 of J₀'s diagonal, as a barrier's; a sticking node's tangential pair; a node
    /// with one DOF constrained), to round-off of the dense solves (1e-10 of |v|: the blocks'
    /// 1e4 scale times f64's 1e-16, with room); and without them it is J₀⁻¹ alone, which
    /// misses the blocks by far.
    #[test]
    fn the_corrected_rest_inverse_inverts_the_rest_matrix_plus_the_contact_blocks() {
        let n = 12;
        let j0 = rest_matrix(n);
        let cholesky = j0.clone().cholesky().expect("SPD");
        let mut solve = |v: &mut [f64]| -> Result<()> {
            let x = cholesky.solve(&DVector::from_column_slice(v));
            v.copy_from_slice(x.as_slice());
            Ok(())
        };
        let normal = nalgebra::Vector3::new(0.0, 0.0, 1.0);
        let barrier = 3e4 * normal * normal.transpose();
        let sticking = Matrix3::from_diagonal(&nalgebra::Vector3::new(5e3, 5e3, 0.0));
        let partial = Matrix3::new(4e2, 1e2, 0.0, 1e2, 3e2, 0.0, 0.0, 0.0, 0.0);
        let nodes = vec![
            node(&[3, 4, 5], barrier + sticking, 0),
            node(&[7, 8], partial, 3),
            node(&[9, 10, 11], barrier, 5),
        ];
        let mut full = j0.clone();
        for n in &nodes {
            let d = n.root * n.root;
            for p in 0..n.count {
                for q in 0..n.count {
                    full[(n.dofs[p], n.dofs[q])] += d[(p, q)];
                }
            }
        }
        let mut capacitance = ContactCapacitance::default();
        let made = capacitance.prepare_nodes(nodes, n, (1.0, 0.0), &mut solve);
        assert_eq!(made.unwrap(), Prepared::Corrected);
        let v: Vec<f64> = (0..n).map(|i| (i as f64 * 0.7).sin() + 0.2).collect();
        let miss = |capacitance: &ContactCapacitance,
                    solve: &mut dyn FnMut(&mut [f64]) -> Result<()>| {
            let mut x = v.clone();
            capacitance.apply(&mut x, solve).unwrap();
            let back = &full * DVector::from_column_slice(&x);
            (back - DVector::from_column_slice(&v)).norm() / DVector::from_column_slice(&v).norm()
        };
        let corrected = miss(&capacitance, &mut solve);
        assert!(
            corrected < 1e-10,
            "(J₀ + EDEᵀ)·x misses v by {corrected:e} of |v|"
        );
        capacitance.clear();
        let alone = miss(&capacitance, &mut solve);
        assert!(alone > 0.1, "J₀⁻¹ alone missed v by only {alone:e} of |v|");
    }

    /// S₀'s entries are read from the column of the smaller DOF, so the same contact DOFs
    /// give the same bits whichever touched first; the columns are kept, and dropped with the
    /// rest factor they were solved on.
    #[test]
    fn the_columns_are_kept_per_rest_factor_and_read_in_one_order() {
        let n = 12;
        let cholesky = rest_matrix(n).cholesky().expect("SPD");
        let solves = std::cell::Cell::new(0);
        let mut solve = |v: &mut [f64]| -> Result<()> {
            solves.set(solves.get() + 1);
            let x = cholesky.solve(&DVector::from_column_slice(v));
            v.copy_from_slice(x.as_slice());
            Ok(())
        };
        let d = Matrix3::from_diagonal(&nalgebra::Vector3::new(1e3, 2e3, 3e3));
        let mut first = ContactCapacitance::default();
        first
            .prepare_nodes(vec![node(&[6, 7, 8], d, 0)], n, (1.0, 0.0), &mut solve)
            .unwrap();
        let both = || vec![node(&[0, 1, 2], d, 0), node(&[6, 7, 8], d, 3)];
        first
            .prepare_nodes(both(), n, (1.0, 0.0), &mut solve)
            .unwrap();
        assert_eq!(solves.get(), 6, "each DOF's column solved once");
        let mut second = ContactCapacitance::default();
        second
            .prepare_nodes(both(), n, (1.0, 0.0), &mut solve)
            .unwrap();
        let block = |c: &ContactCapacitance| c.block.as_ref().unwrap().1.clone();
        assert_eq!(block(&first), block(&second));
        first
            .prepare_nodes(both(), n, (2.0, 0.0), &mut solve)
            .unwrap();
        assert_eq!(
            solves.get(),
            18,
            "another rest factor: the columns solved again"
        );
    }
}
