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
//! once for each DOF the first time it touches (16 to a pass over the factor,
//! `SparseCholesky::solve_many_approximate`), and kept while the rest factor stands (they
//! are the same numbers in every step, so a step still depends on its state alone: entry (i, j)
//! is always read from the column of the smaller index). C (k×k, symmetric positive definite:
//! I plus a congruence of S₀) is factored with D at the run's first iterate in contact, and
//! again where L-BFGS asks (after a poor step, `super::direction::Lbfgs`); applying the
//! inverse then costs two triangular solve pairs on the rest factor and two small products.
//!
//! C is formed and factored in f32, as the columns it is made of are kept: H₀ only steers
//! L-BFGS, whose residual test decides the step, and f32 halves what C costs each step (its
//! formation reads S₀'s k² entries, its factorization k³/3 flops at twice f64's lanes). On the
//! 10k-DOF drop and press of `benches/interactive_contact.rs` (k = 675 and about 800) the same
//! iterations a step as in f64 and 1.03–1.17× the steps/s (`validation/PERFORMANCE.md`).

use std::collections::BTreeMap;

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt;
use faer::{MatMut, MatRef, Par};
use nalgebra::{Matrix3, SymmetricEigen};

use crate::analysis::dynamics::internal_force::NonlinearForce;
use crate::analysis::dynamics::nodal_rotation::NodalRotations;
use crate::base::error::Result;

/// Most contact DOFs a correction is made for on a rest factor whose numeric factorization
/// costs `factor_flops` (`LinearSolver::factor_flops`; 1,024 without one): k with k³/3 no more
/// than that, so that C's dense factorization, made at least once a contact step, costs no more
/// than the factorization of J the CG path makes each contact step instead. At
/// `benches/interactive_contact.rs`'s sizes: 515 at 2,187 DOFs (the block's bottom holds
/// 243), 1,509 at 10,125 (675) and 3,963 at 41,472 (1,728; the columns' memory,
/// [`COLUMN_BYTES`], holds 10,565 columns at its 9,528 boundary DOFs).
pub fn max_contact_dofs(factor_flops: Option<f64>) -> usize {
    factor_flops.map_or(1024, |flops| (3.0 * flops.max(0.0)).cbrt() as usize)
}

/// Most bytes the kept columns J₀⁻¹·e_j may hold (f32 each, at the free DOFs of the contact's
/// boundary nodes, the only ones S₀ is ever read at): b·k·4 for k contact DOFs and b boundary
/// DOFs. They are solved on the rest factor's f32 copy, whose results are f32 numbers (the
/// right-hand side e_j needs no scaling), so f32 keeps them whole. The columns cost k
/// triangular solves, once, the first time each DOF touches: at 10,125 DOFs 675 of them took
/// about 0.8 s at the landing of `benches/interactive_contact.rs`'s block one at a time, 67 ms
/// sixteen to a pass over the factor, 64 a group; they hold 9.5 MB (3,534 boundary DOFs; 27 MB
/// n long), and at 41,472 DOFs its bottom's 1,728 DOFs 66 MB (287 MB n long). Past this budget
/// the run factors J instead (the CG path).
pub const COLUMN_BYTES: usize = 384 << 20;

/// Columns J₀⁻¹·e_j solved together: four batches of the multi-column solve, two a thread.
const COLUMN_GROUP: usize = 64;

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
    columns: BTreeMap<usize, Vec<f32>>,
    /// The (mass scale, damping stiffness) of the rest factor the columns were solved on.
    key: Option<(f64, f64)>,
    /// This run's contact nodes (empty: no correction).
    nodes: Vec<ContactNode>,
    /// The Cholesky factor L of C = I + Q·S₀·Q for this run (k×k column-major, f32, L in the
    /// lower triangle; the upper one is not read), empty when the run has no correction. Its
    /// memory is kept from run to run: C is formed at least once a contact step, and a fresh k×k
    /// buffer (4–8 MB in f64 at k = 700–1,000) cost more in page faults than the arithmetic
    /// (on the press of `benches/interactive_contact.rs`, k ≈ 800: forming C 5.1 → 2.3 ms and
    /// factoring it 4.2 → 2.7 ms once the memory was kept, before the formation went
    /// parallel).
    capacitance: Vec<f32>,
    /// The contact DOFs of the last S₀ formed and S₀ over them (k×k, column-major; f32 numbers,
    /// as the columns they are read from).
    block: Option<(Vec<usize>, Vec<f32>)>,
    /// The memory of the block before `block`, for the next one.
    spare: Vec<f32>,
    /// The free DOFs the kept columns hold ([`KeptRows`]); `None`: every free DOF.
    rows: Option<KeptRows>,
}

/// The free DOFs of the contact's boundary nodes, ascending, and each free DOF's place among
/// them (`u32::MAX` for an interior one): the rows of J₀⁻¹·e_j that S₀ can ask for, since a
/// contact DOF is a boundary node's.
struct KeptRows {
    dofs: Vec<usize>,
    place: Vec<u32>,
}

impl KeptRows {
    /// The rows `dofs` (ascending free indices) of a problem with `n` free DOFs.
    fn new(dofs: Vec<usize>, n: usize) -> Self {
        let mut place = vec![u32::MAX; n];
        for (i, &d) in dofs.iter().enumerate() {
            place[d] = i as u32;
        }
        KeptRows { dofs, place }
    }
}

/// What [`ContactCapacitance::prepare`] made.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Prepared {
    /// No node is in contact: H₀ is the rest factor's.
    NoContact,
    /// H₀ holds the contact nodes' blocks.
    Corrected,
    /// Too many contact DOFs ([`max_contact_dofs`], or the columns past their memory), or C
    /// did not factor: the run should hold the contact's stiffness another way.
    TooLarge,
}

impl ContactCapacitance {
    /// Drops this run's correction: H₀ is the rest factor's until the next
    /// [`prepare`](Self::prepare).
    pub fn clear(&mut self) {
        self.nodes.clear();
        self.capacitance.clear();
    }

    /// Keeps the columns at the free DOFs of `force`'s contact boundary nodes only, from the
    /// next column on (made once; without contact every free DOF stays).
    pub fn keep_boundary_rows(&mut self, force: &NonlinearForce) {
        if self.rows.is_some() {
            return;
        }
        let Some(contact) = force.contact() else {
            return;
        };
        let free = force.free_dofs();
        let dofs: Vec<usize> = (contact.nodes().iter())
            .flat_map(|&node| (0..3).map(move |axis| 3 * node + axis))
            .filter_map(|dof| free.binary_search(&dof).ok())
            .collect();
        self.columns.clear();
        self.block = None;
        self.rows = Some(KeptRows::new(dofs, free.len()));
    }

    /// The length of a kept column in a problem of `n` free DOFs.
    pub fn column_length(&self, n: usize) -> usize {
        self.rows.as_ref().map_or(n, |rows| rows.dofs.len())
    }

    /// Makes the correction for `nodes` (from [`ContactNodes::of`]) of a problem with `n` free
    /// DOFs, at most `max_dofs` of them in contact ([`max_contact_dofs`]): the columns not kept
    /// yet solved by `solve_columns` (J₀⁻¹ in place on each n-long
    /// column of its argument, on the rest factor of `key`: the columns of another one are
    /// dropped), C formed and factored.
    pub fn prepare(
        &mut self,
        nodes: ContactNodes,
        (n, max_dofs): (usize, usize),
        key: (f64, f64),
        solve_columns: &mut dyn FnMut(&mut [f64]) -> Result<()>,
    ) -> Result<Prepared> {
        self.prepare_nodes(nodes.0, (n, max_dofs), key, solve_columns)
    }

    /// [`prepare`](Self::prepare) for the contact nodes `nodes`.
    fn prepare_nodes(
        &mut self,
        nodes: Vec<ContactNode>,
        (n, max_dofs): (usize, usize),
        key: (f64, f64),
        solve_columns: &mut dyn FnMut(&mut [f64]) -> Result<()>,
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
        let length = self.column_length(n);
        if k > max_dofs || (self.columns.len() + new.len()) * length * 4 > COLUMN_BYTES {
            return Ok(Prepared::TooLarge);
        }
        // Solved in groups (16 columns share a pass over the rest factor; a group bounds the
        // buffer beside the kept columns), each column's bits its own whatever the group.
        for group in new.chunks(COLUMN_GROUP) {
            let mut block = vec![0.0; group.len() * n];
            for (column, &dof) in block.chunks_exact_mut(n).zip(group) {
                column[dof] = 1.0;
            }
            solve_columns(&mut block)?;
            for (column, &dof) in block.chunks_exact(n).zip(group) {
                // f32 numbers already where the f32 copy solved them (see `COLUMN_BYTES`).
                let kept = match &self.rows {
                    Some(rows) => rows.dofs.iter().map(|&d| column[d] as f32).collect(),
                    None => column.iter().map(|&x| x as f32).collect(),
                };
                self.columns.insert(dof, kept);
            }
        }
        self.nodes = nodes;
        self.capacitance_matrix(k);
        let factored = factor_in_place(&mut self.capacitance, k);
        if !factored {
            self.clear();
            return Ok(Prepared::TooLarge);
        }
        Ok(Prepared::Corrected)
    }

    /// S₀ over this run's contact DOFs (k of them), k×k column-major: entry (i, j) = (J₀⁻¹)ᵢⱼ
    /// read from the column of the smaller free index (the same number whichever DOF touched
    /// first). Kept with its DOFs: a body resting or sliding keeps its contact nodes from step
    /// to step, and where they change (a moving obstacle's nodes come and go) the pairs of DOFs
    /// the last block held are copied from it, the same numbers, instead of read from the
    /// n-long columns, and only what C's formation reads is made (on the press of
    /// `benches/interactive_contact.rs`, k ≈ 800: a changed block 1.1 → 0.6 ms).
    fn rest_inverse_block(&mut self, k: usize) -> &[f32] {
        use rayon::prelude::*;
        let dofs: Vec<usize> = (self.nodes.iter())
            .flat_map(|node| node.dofs[..node.count].to_vec())
            .collect();
        if self.block.as_ref().is_none_or(|(kept, _)| *kept != dofs) {
            let columns: Vec<&[f32]> = (dofs.iter())
                .map(|d| self.columns.get(d).map_or(&[][..], |c| c.as_slice()))
                .collect();
            let last = self.block.take();
            let (kept, last_s) = last.as_ref().map_or((&[][..], &[][..]), |(d, s)| (d, s));
            // Where each DOF stood in the last block: both lists ascend (nodes in ascending
            // order, a node's DOFs in x, y, z order).
            let mut before = vec![None; k];
            let mut at = 0;
            for (i, d) in dofs.iter().enumerate() {
                while at < kept.len() && kept[at] < *d {
                    at += 1;
                }
                if kept.get(at) == Some(d) {
                    before[i] = Some(at);
                }
            }
            // Two buffers taken in turn (see `capacitance`); what C reads is written below.
            let mut s = std::mem::take(&mut self.spare);
            s.resize(k * k, 0.0);
            let starts: Vec<usize> = (self.nodes.iter())
                .flat_map(|node| std::iter::repeat_n(node.offset, node.count))
                .collect();
            let old_k = kept.len();
            let place = self.rows.as_ref().map(|rows| &rows.place[..]);
            // Column i from its node's first row down, in parallel: the lower triangle and the
            // diagonal blocks, all that C's formation reads. Ascending DOFs make i the smaller
            // index below the diagonal, so the reads walk down column i.
            s.par_chunks_exact_mut(k)
                .enumerate()
                .for_each(|(i, column)| {
                    for j in starts[i]..k {
                        column[j] = match (before[i], before[j]) {
                            (Some(a), Some(b)) => last_s[a * old_k + b],
                            _ => {
                                let (low, high) = match dofs[i] < dofs[j] {
                                    true => (i, j),
                                    false => (j, i),
                                };
                                let row = place.map_or(dofs[high], |p| p[dofs[high]] as usize);
                                columns[low].get(row).copied().unwrap_or(0.0)
                            }
                        };
                    }
                });
            if let Some((_, last_s)) = last {
                self.spare = last_s;
            }
            self.block = Some((dofs, s));
        }
        &self.block.as_ref().expect("S₀ kept just above").1
    }

    /// C = I + Q·S₀·Q over this run's contact DOFs (k of them) into `capacitance`, its lower
    /// triangle only (the factorization reads that side; the diagonal blocks are written
    /// whole), a node's columns at a time in parallel: column j (DOF q of node b) is Q·t,
    /// t = S₀·Q's column j = Σ_p Q_b[p, q]·S₀[:, b_p] from node b's rows down. Q is
    /// block-diagonal with blocks of at most 3: its five diagonals, rounded to f32 once, apply it
    /// to t in five passes of whole vectors, each row's terms in the order of its block's
    /// columns (on the drop of `benches/interactive_contact.rs`, k = 675: C formed in 0.29 →
    /// 0.18 ms on two threads, the same bits).
    fn capacitance_matrix(&mut self, k: usize) {
        use rayon::prelude::*;
        self.rest_inverse_block(k);
        let s = &self.block.as_ref().expect("S₀ formed just above").1;
        let nodes = &self.nodes;
        let diagonals = root_diagonals(nodes, k);
        self.capacitance.resize(k * k, 0.0);
        let mut node_columns = Vec::with_capacity(nodes.len());
        let mut rest = self.capacitance.as_mut_slice();
        for node in nodes {
            let (columns, tail) = rest.split_at_mut(node.count * k);
            node_columns.push(columns);
            rest = tail;
        }
        // t of a node's columns, each with two zeros on either side for the off-diagonals.
        let stride = k + 4;
        node_columns.into_par_iter().enumerate().for_each_init(
            || vec![0.0; 3 * stride],
            |t, (b, columns)| {
                let node = &nodes[b];
                let (from, len) = (node.offset, k - node.offset);
                for q in 0..node.count {
                    let t = &mut t[q * stride..][..len + 4];
                    t.fill(0.0);
                    for p in 0..node.count {
                        let weight = node.root[(p, q)] as f32;
                        let source = &s[(from + p) * k + from..][..len];
                        for (t, s) in t[2..].iter_mut().zip(source) {
                            *t += weight * s;
                        }
                    }
                }
                for (q, column) in columns.chunks_exact_mut(k).enumerate() {
                    let t = &t[q * stride..][..len + 4];
                    let out = &mut column[from..];
                    out.fill(0.0);
                    for (d, diagonal) in diagonals.iter().enumerate() {
                        for ((out, q), t) in out.iter_mut().zip(&diagonal[from..]).zip(&t[d..]) {
                            *out += q * t;
                        }
                    }
                    column[from + q] += 1.0;
                }
            },
        );
    }

    /// v ← (J₀ + E·D·Eᵀ)⁻¹·v (the nodes' rotated frame), `solve` applying J₀⁻¹ in place; J₀⁻¹·v
    /// alone when the run has no correction.
    pub fn apply(
        &self,
        v: &mut [f64],
        solve: &mut dyn FnMut(&mut [f64]) -> Result<()>,
    ) -> Result<()> {
        if self.capacitance.is_empty() {
            return solve(v);
        }
        let k = self.nodes.last().map_or(0, |n| n.offset + n.count);
        let mut w = v.to_vec();
        solve(&mut w)?;
        let mut y = vec![0.0f32; k];
        for node in &self.nodes {
            for p in 0..node.count {
                y[node.offset + p] = (0..node.count)
                    .map(|q| node.root[(p, q)] * w[node.dofs[q]])
                    .sum::<f64>() as f32;
            }
        }
        let factor = MatRef::from_column_major_slice(&self.capacitance, k, k);
        let rhs = MatMut::from_column_major_slice_mut(&mut y, k, 1);
        llt::solve::solve_in_place(factor, rhs, Par::Seq, MemStack::new(&mut []));
        for node in &self.nodes {
            for p in 0..node.count {
                v[node.dofs[p]] -= (0..node.count)
                    .map(|q| node.root[(p, q)] * f64::from(y[node.offset + q]))
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

    /// Whether the correction for them, its columns `length` long
    /// ([`ContactCapacitance::column_length`]), would hold more than `max_dofs`
    /// ([`max_contact_dofs`]) or its columns alone more than their memory budget.
    pub fn too_many(&self, length: usize, max_dofs: usize) -> bool {
        let k = self.0.last().map_or(0, |n| n.offset + n.count);
        k > max_dofs || k * length * 4 > COLUMN_BYTES
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

/// Factors the k×k column-major `c` in place (its lower triangle read, L left there) with
/// faer's dense LLᵀ on the global parallelism; `false` where a pivot is not positive.
fn factor_in_place(c: &mut [f32], k: usize) -> bool {
    let par = faer::get_global_parallelism();
    let scratch = llt::factor::cholesky_in_place_scratch::<f32>(k, par, Default::default());
    let mut memory = MemBuffer::new(scratch);
    let matrix = MatMut::from_column_major_slice_mut(c, k, k);
    let regularization = Default::default();
    let stack = MemStack::new(&mut memory);
    llt::factor::cholesky_in_place(matrix, regularization, par, stack, Default::default()).is_ok()
}

/// Q's five diagonals over the contact DOFs (k of them), offsets −2 to 2 in that order:
/// entry i of diagonal d is Q_a[p, p + d − 2] for row i = DOF p of node a, zero where p + d − 2
/// falls outside the node's DOFs. Q·t is then Σ_d diagonal_d ∘ t shifted by d − 2, each row's
/// terms in the order of its block's columns.
fn root_diagonals(nodes: &[ContactNode], k: usize) -> [Vec<f32>; 5] {
    let mut diagonals: [Vec<f32>; 5] = std::array::from_fn(|_| vec![0.0; k]);
    for node in nodes {
        for p in 0..node.count {
            for r in 0..node.count {
                diagonals[r + 2 - p][node.offset + p] = node.root[(p, r)] as f32;
            }
        }
    }
    diagonals
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
    /// with one DOF constrained), to the rounding of the kept columns and of C's factorization
    /// to f32 (2⁻²⁴ ≈ 6e-8 of S₀'s entries, which the residual weighs by the blocks' 1e4
    /// scale: bound 1e-3 of |v|, measured 2.9e-4, 1.0e-4 with C in f64; in a run the columns
    /// come from the factor's f32 copy and are kept whole); and without them it is J₀⁻¹
    /// alone, which misses the blocks by far (> 0.1).
    #[test]
    fn the_corrected_rest_inverse_inverts_the_rest_matrix_plus_the_contact_blocks() {
        let n = 12;
        let j0 = rest_matrix(n);
        let cholesky = j0.clone().cholesky().expect("SPD");
        // J₀⁻¹ on each n-long column of v (one for `apply`, several for `prepare`).
        let mut solve = |v: &mut [f64]| -> Result<()> {
            for v in v.chunks_mut(n) {
                let x = cholesky.solve(&DVector::from_column_slice(v));
                v.copy_from_slice(x.as_slice());
            }
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
        let made = capacitance.prepare_nodes(nodes, (n, 1024), (1.0, 0.0), &mut solve);
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
            corrected < 1e-3,
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
            for v in v.chunks_mut(n) {
                solves.set(solves.get() + 1);
                let x = cholesky.solve(&DVector::from_column_slice(v));
                v.copy_from_slice(x.as_slice());
            }
            Ok(())
        };
        let d = Matrix3::from_diagonal(&nalgebra::Vector3::new(1e3, 2e3, 3e3));
        let mut first = ContactCapacitance::default();
        first
            .prepare_nodes(
                vec![node(&[6, 7, 8], d, 0)],
                (n, 1024),
                (1.0, 0.0),
                &mut solve,
            )
            .unwrap();
        let both = || vec![node(&[0, 1, 2], d, 0), node(&[6, 7, 8], d, 3)];
        first
            .prepare_nodes(both(), (n, 1024), (1.0, 0.0), &mut solve)
            .unwrap();
        assert_eq!(solves.get(), 6, "each DOF's column solved once");
        let mut second = ContactCapacitance::default();
        second
            .prepare_nodes(both(), (n, 1024), (1.0, 0.0), &mut solve)
            .unwrap();
        assert_eq!(block_read(&first), block_read(&second));
        first
            .prepare_nodes(both(), (n, 1024), (2.0, 0.0), &mut solve)
            .unwrap();
        assert_eq!(
            solves.get(),
            18,
            "another rest factor: the columns solved again"
        );
        // The contact nodes change (one stays, two come, one goes, a node with fewer DOFs
        // comes): the pairs kept are copied from the last block, the others read from the
        // columns, the same numbers as a block made at once.
        let e = Matrix3::from_diagonal(&nalgebra::Vector3::new(4e2, 5e2, 6e2));
        let later = || {
            vec![
                node(&[3, 4, 5], e, 0),
                node(&[6, 7, 8], d, 3),
                node(&[10, 11], e, 6),
            ]
        };
        first
            .prepare_nodes(later(), (n, 1024), (2.0, 0.0), &mut solve)
            .unwrap();
        let mut fresh = ContactCapacitance::default();
        fresh
            .prepare_nodes(later(), (n, 1024), (2.0, 0.0), &mut solve)
            .unwrap();
        assert_eq!(block_read(&first), block_read(&fresh));
        assert_eq!(first.capacitance, fresh.capacitance);
        // Columns kept at the boundary's DOFs alone (here all but DOFs 1, 2 and 9): the same S₀
        // and C from a third of the memory.
        let mut boundary = ContactCapacitance::default();
        let dofs: Vec<usize> = (0..n).filter(|d| ![1, 2, 9].contains(d)).collect();
        boundary.rows = Some(KeptRows::new(dofs, n));
        boundary
            .prepare_nodes(later(), (n, 1024), (2.0, 0.0), &mut solve)
            .unwrap();
        assert_eq!(boundary.column_length(n), n - 3);
        assert!(boundary.columns.values().all(|c| c.len() == n - 3));
        assert_eq!(block_read(&boundary), block_read(&fresh));
        assert_eq!(boundary.capacitance, fresh.capacitance);
    }

    /// The entries of S₀ that C's formation reads: each column from its node's first row down.
    fn block_read(c: &ContactCapacitance) -> Vec<f32> {
        let (dofs, s) = c.block.as_ref().unwrap();
        let k = dofs.len();
        let starts = c
            .nodes
            .iter()
            .flat_map(|n| std::iter::repeat_n(n.offset, n.count));
        (starts.enumerate())
            .flat_map(|(i, start)| s[i * k + start..][..k - start].to_vec())
            .collect()
    }
}
