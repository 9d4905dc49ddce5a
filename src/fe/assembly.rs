//! Global assembly: the sparsity pattern is built once from the mesh, with a scatter map from
//! each element's n×n node blocks (n nodes per element: 4 for the linear tet, 10 for the
//! quadratic) to their places in the global value array, so that K (or the consistent mass, or
//! a refilled tangent) is re-assembled in O(nnz) with no sorting. Every routine here is generic
//! over the element type ([`ElementType`]) and monomorphized for each, so the linear tet's
//! loops keep their constant trip counts.

use std::sync::Arc;

use faer::sparse::SymbolicSparseColMat;

use crate::base::error::{Error, Result};
use crate::fe::element::{ElementType, Matrix12};
use crate::fe::material::Material;
use crate::fe::materials::TetMaterials;
use crate::mesh::{CellType, TetMesh};
use crate::sparse::CscMatrix;

/// Global sparsity pattern of a mesh (both triangles, 3×3 node blocks) and the element scatter
/// map.
///
/// Layout: column `3n + a` (node n, axis a) holds rows `3m + b` for every node m adjacent to n
/// (sharing a tet, n itself included) in ascending order, all three axes b. So the 3×3 block of
/// node pair (m, n) starts at `9·adj_ptr[n] + 3·pos(m)` and its column a is `3·deg(n)` further on.
#[derive(Debug, Clone)]
pub struct Assembler {
    pattern: Arc<SymbolicSparseColMat<usize>>,
    /// For tet t and local nodes (i, j) of its n: start of the block (row node i, column
    /// node j), at `n²·t + n·i + j`.
    block_start: Vec<usize>,
    /// For each node n: 3·deg(n), the distance between consecutive columns of one block.
    column_stride: Vec<usize>,
    /// Contiguous node ranges whose columns are filled in parallel, each with the tets touching it.
    partitions: Vec<Partition>,
    /// The tets listed in more than one partition, ascending, and for each tet its place in
    /// that list (`usize::MAX`: in one partition only): [`reassemble_computing_once`]
    /// computes their element matrices once, ahead of the fill.
    ///
    /// [`reassemble_computing_once`]: Self::reassemble_computing_once
    shared: SharedTets,
    /// Node count, tet count and a hash of the connectivity (nodes per tet included) of the
    /// mesh this was built from: the scatter map is only valid for that mesh, and a different
    /// one would write out of bounds or, worse, into the wrong entries.
    fingerprint: (usize, usize, u64),
}

/// The largest scratch (bytes) [`Assembler::reassemble_computing_once`] keeps for the
/// straddling tets' element matrices: 64 MiB, 58k tets' 12×12 matrices (the 10k-DOF cube of
/// `benches/interactive_contact.rs` needs 9.8 MB at 2 threads), small beside the factor of any
/// mesh with that many straddling tets, and never allocated unchecked on a larger one.
pub const SHARED_SCRATCH_LIMIT: usize = 64 << 20;

/// The tets that straddle partitions ([`Assembler::shared`]) and the scratch their element
/// matrices are kept in between the two passes of
/// [`Assembler::reassemble_computing_once`], reused from call to call rather than allocated
/// per assembly (on the 10k-DOF cube of `benches/interactive_contact.rs` at 2 threads up to
/// 8 539 straddling tets: 9.8 MB of 12×12 matrices).
#[derive(Debug, Default)]
struct SharedTets {
    tets: Vec<usize>,
    slot: Vec<usize>,
    scratch: std::sync::Mutex<Vec<Matrix12>>,
}

impl Clone for SharedTets {
    fn clone(&self) -> Self {
        SharedTets {
            tets: self.tets.clone(),
            slot: self.slot.clone(),
            scratch: std::sync::Mutex::default(),
        }
    }
}

impl SharedTets {
    /// The tets of `tet_count` listed in more than one of `partitions`.
    fn of(partitions: &[Partition], tet_count: usize) -> Self {
        let mut listed = vec![0u8; tet_count];
        for part in partitions {
            for &t in &part.tets {
                listed[t] = listed[t].saturating_add(1);
            }
        }
        let tets: Vec<usize> = (0..tet_count).filter(|&t| listed[t] > 1).collect();
        let mut slot = vec![usize::MAX; tet_count];
        for (k, &t) in tets.iter().enumerate() {
            slot[t] = k;
        }
        SharedTets {
            tets,
            slot,
            scratch: std::sync::Mutex::default(),
        }
    }
}

/// FNV-1a over the tets' node indices: one pass, a few ms per million tets.
fn connectivity_hash<C: CellType>(mesh: &TetMesh<C>) -> u64 {
    let mut hash = 0xcbf2_9ce4_8422_2325u64;
    if C::NODES != 4 {
        hash = (hash ^ C::NODES as u64).wrapping_mul(0x0100_0000_01b3);
    }
    for tet in mesh.tets() {
        for &n in tet.as_ref() {
            hash = (hash ^ n as u64).wrapping_mul(0x0100_0000_01b3);
        }
    }
    hash
}

/// A contiguous range of nodes; its columns form one contiguous range of the value array, so
/// threads filling different partitions never write to the same place (no atomics, no locks).
#[derive(Debug, Clone)]
struct Partition {
    nodes: std::ops::Range<usize>,
    values: std::ops::Range<usize>,
    /// Tets with at least one node in `nodes` (a tet straddling two partitions is listed in
    /// both and its element matrix computed twice; with contiguous node numbering that is a thin
    /// layer).
    tets: Vec<usize>,
}

impl Assembler {
    /// Builds the pattern and scatter map of `mesh`: O(nnz) memory, no global sort.
    pub fn new<C: CellType>(mesh: &TetMesh<C>) -> Self {
        let node_count = mesh.node_count();
        let per_tet = C::NODES;
        // Node adjacency in CSR form: count an upper bound (n per incident tet), fill, sort and
        // deduplicate each node's list.
        let mut bound = vec![0usize; node_count + 1];
        for tet in mesh.tets() {
            for &n in tet.as_ref() {
                bound[n + 1] += per_tet;
            }
        }
        for n in 0..node_count {
            bound[n + 1] += bound[n];
        }
        let mut scratch = vec![0usize; bound[node_count]];
        let mut fill = bound.clone();
        for tet in mesh.tets() {
            let tet = tet.as_ref();
            for &n in tet {
                scratch[fill[n]..fill[n] + per_tet].copy_from_slice(tet);
                fill[n] += per_tet;
            }
        }
        let mut adj_ptr = vec![0usize; node_count + 1];
        let mut adjacency = Vec::with_capacity(scratch.len() / 2);
        for n in 0..node_count {
            let list = &mut scratch[bound[n]..bound[n + 1]];
            list.sort_unstable();
            let start = adjacency.len();
            for &m in list.iter() {
                if adjacency.len() == start || *adjacency.last().unwrap_or(&usize::MAX) != m {
                    adjacency.push(m);
                }
            }
            adj_ptr[n + 1] = adjacency.len();
        }
        drop(scratch);

        let dofs = 3 * node_count;
        let mut col_ptr = Vec::with_capacity(dofs + 1);
        let mut row_idx = Vec::with_capacity(9 * adjacency.len());
        col_ptr.push(0);
        for n in 0..node_count {
            let neighbours = &adjacency[adj_ptr[n]..adj_ptr[n + 1]];
            for _axis in 0..3 {
                for &m in neighbours {
                    row_idx.extend_from_slice(&[3 * m, 3 * m + 1, 3 * m + 2]);
                }
                col_ptr.push(row_idx.len());
            }
        }
        let column_stride: Vec<usize> = (0..node_count)
            .map(|n| 3 * (adj_ptr[n + 1] - adj_ptr[n]))
            .collect();
        let mut block_start = Vec::with_capacity(per_tet * per_tet * mesh.tet_count());
        for tet in mesh.tets() {
            let tet = tet.as_ref();
            for &row_node in tet {
                for &col_node in tet {
                    let neighbours = &adjacency[adj_ptr[col_node]..adj_ptr[col_node + 1]];
                    // Present by construction: col_node's list holds every node of its tets.
                    let pos = neighbours.binary_search(&row_node).unwrap_or(0);
                    block_start.push(9 * adj_ptr[col_node] + 3 * pos);
                }
            }
        }
        let partitions = partition(mesh, &col_ptr);
        let shared = SharedTets::of(&partitions, mesh.tet_count());
        // Valid by construction (sorted, in range); the check costs one pass over the indices.
        let pattern = SymbolicSparseColMat::new_checked(dofs, dofs, col_ptr, None, row_idx);
        Assembler {
            pattern: Arc::new(pattern),
            block_start,
            column_stride,
            partitions,
            shared,
            fingerprint: (node_count, mesh.tet_count(), connectivity_hash(mesh)),
        }
    }

    /// An error unless `mesh` has the connectivity this assembler was built from (node
    /// positions may differ: they do not enter the pattern).
    pub fn check_mesh<C: CellType>(&self, mesh: &TetMesh<C>) -> Result<()> {
        let (nodes, tets, hash) = self.fingerprint;
        if mesh.node_count() != nodes || mesh.tet_count() != tets || connectivity_hash(mesh) != hash
        {
            return Err(Error::invalid_parameter(
                "mesh",
                format!("{} nodes, {} tets", mesh.node_count(), mesh.tet_count()),
                format!(
                    "must have the connectivity the Assembler was built from ({nodes} nodes, {tets} tets)"
                ),
            ));
        }
        Ok(())
    }

    fn check_matrix(&self, matrix: &CscMatrix) -> Result<()> {
        if Arc::ptr_eq(matrix.pattern(), &self.pattern) {
            Ok(())
        } else {
            Err(Error::invalid_parameter(
                "matrix",
                format!("{} stored entries", matrix.nnz()),
                "must be on this Assembler's pattern (made by it, or sharing its Arc)",
            ))
        }
    }

    /// The shared pattern; every matrix this assembler produces uses this `Arc`.
    pub fn pattern(&self) -> &Arc<SymbolicSparseColMat<usize>> {
        &self.pattern
    }

    /// Number of stored entries.
    pub fn nnz(&self) -> usize {
        self.pattern.row_idx().len()
    }

    /// Adds the 12×12 element matrix `ke` of tet `t` into `values` (the value array of a matrix
    /// on [`pattern`](Self::pattern)).
    ///
    /// Errors: `mesh` is not the one this assembler was built from, `t` is not one of its tets,
    /// or `values.len()` is not [`nnz`](Self::nnz).
    pub fn scatter(
        &self,
        mesh: &TetMesh,
        t: usize,
        ke: &Matrix12,
        values: &mut [f64],
    ) -> Result<()> {
        self.check_mesh(mesh)?;
        mesh.check_tet("Assembler::scatter", t)?;
        Error::check_len("values", self.nnz(), values.len())?;
        let tet = &mesh.tets()[t];
        for j in 0..4 {
            let stride = self.column_stride[tet[j]];
            for i in 0..4 {
                let start = self.block_start[16 * t + 4 * i + j];
                for a in 0..3 {
                    let column = start + a * stride;
                    for b in 0..3 {
                        values[column + b] += ke[(3 * i + b, 3 * j + a)];
                    }
                }
            }
        }
        Ok(())
    }

    /// Assembles Σₑ (12×12 element matrix of linear tet e) on the shared pattern (in parallel,
    /// see [`reassemble`](Self::reassemble)); [`assemble_entries`](Self::assemble_entries) for
    /// any element type.
    pub fn assemble(
        &self,
        mesh: &TetMesh,
        element_matrix: impl Fn(usize) -> Matrix12 + Sync,
    ) -> Result<CscMatrix> {
        let mut matrix = CscMatrix::zeros(Arc::clone(&self.pattern))?;
        self.reassemble(mesh, element_matrix, &mut matrix)?;
        Ok(matrix)
    }

    /// Refills `matrix` (which must be on this pattern) with Σₑ (element matrix of tet e), in
    /// O(nnz) with no allocation. Node ranges are filled in parallel on rayon's pool; the result
    /// does not depend on the thread count (each entry sums its contributions in tet order).
    ///
    /// Errors: `matrix` is not on this assembler's pattern, or `mesh` is not the one it was
    /// built from.
    pub fn reassemble(
        &self,
        mesh: &TetMesh,
        element_matrix: impl Fn(usize) -> Matrix12 + Sync,
        matrix: &mut CscMatrix,
    ) -> Result<()> {
        self.fill(mesh, matrix, |t, tet, target| {
            let ke = element_matrix(t);
            target.add_element(t, tet, |i, j, b, a| ke[(3 * i + b, 3 * j + a)]);
        })
    }

    /// [`reassemble`](Self::reassemble) for element matrices that are costly to compute (a
    /// nonlinear model's tangent): a tet whose nodes lie in two or more of the node ranges
    /// filled in parallel has its matrix computed once, in a parallel pass ahead of the fill,
    /// instead of once per range. The same bits as `reassemble` (the same matrices, added in
    /// the same order) for an `element_matrix` that gives the same bits at every call.
    ///
    /// With 4 ranges per thread a range of a cube's nodes is a few node layers, and a tet
    /// straddling two is computed twice: on the 10k-DOF cube at 2 threads
    /// (`benches/interactive_contact.rs`) the Neo-Hookean tangent was computed for
    /// 1.52× the tets (25 003 element tangents for 16 464 tets; 1.22× at 1 thread).
    ///
    /// The straddling tets' matrices are kept in a scratch of 1,152 bytes a tet; where that
    /// would pass [`SHARED_SCRATCH_LIMIT`] (a large mesh whose node order cuts many tets at
    /// the ranges' edges) this is `reassemble`, whose extra cost is the duplicates' compute
    /// and no memory.
    ///
    /// Errors: those of `reassemble`.
    pub fn reassemble_computing_once(
        &self,
        mesh: &TetMesh,
        element_matrix: impl Fn(usize) -> Matrix12 + Sync,
        matrix: &mut CscMatrix,
    ) -> Result<()> {
        use rayon::prelude::*;
        let scratch_bytes = self.shared.tets.len() * std::mem::size_of::<Matrix12>();
        if self.shared.tets.is_empty() || scratch_bytes > SHARED_SCRATCH_LIMIT {
            return self.reassemble(mesh, element_matrix, matrix);
        }
        // A concurrent assembly on the same assembler (rare) computes into its own scratch.
        let mut own = Vec::new();
        let mut guard = self.shared.scratch.try_lock().ok();
        let computed = guard.as_deref_mut().unwrap_or(&mut own);
        self.shared
            .tets
            .par_iter()
            .map(|&t| element_matrix(t))
            .collect_into_vec(computed);
        let computed = &*computed;
        let slot = &self.shared.slot;
        self.fill(mesh, matrix, |t, tet, target| {
            let fresh;
            let ke = match slot[t] {
                usize::MAX => {
                    fresh = element_matrix(t);
                    &fresh
                }
                k => &computed[k],
            };
            target.add_element(t, tet, |i, j, b, a| ke[(3 * i + b, 3 * j + a)]);
        })
    }

    /// Refills `matrix` (which must be on this pattern) with Σₑ (element matrix of tet e) for
    /// any element type: `element_matrix(t)` is tet t's 3n×3n matrix (row 3i + b, column
    /// 3j + a for local nodes i, j and axes b, a), e.g. the 30×30 tangent of a 10-node tet.
    /// Filled as [`reassemble`](Self::reassemble) (in parallel, the same bits on any thread
    /// count).
    ///
    /// Errors: `matrix` is not on this assembler's pattern, or `mesh` is not the one it was
    /// built from.
    pub fn reassemble_elements<C: CellType, M: std::ops::Index<(usize, usize), Output = f64>>(
        &self,
        mesh: &TetMesh<C>,
        element_matrix: impl Fn(usize) -> M + Sync,
        matrix: &mut CscMatrix,
    ) -> Result<()> {
        self.fill(mesh, matrix, |t, tet, target| {
            let ke = element_matrix(t);
            target.add_element(t, tet.as_ref(), |i, j, b, a| ke[(3 * i + b, 3 * j + a)]);
        })
    }

    /// Assembles a matrix on the shared pattern from element matrices of any element type,
    /// given entry by entry: `entry(t, i, j, b, a)` is row 3i + b, column 3j + a of tet t's
    /// element matrix (local nodes i, j; axes b, a). Filled as [`reassemble`](Self::reassemble).
    ///
    /// Errors: `mesh` is not the one this assembler was built from.
    pub fn assemble_entries<C: CellType>(
        &self,
        mesh: &TetMesh<C>,
        entry: impl Fn(usize, usize, usize, usize, usize) -> f64 + Sync,
    ) -> Result<CscMatrix> {
        let mut matrix = CscMatrix::zeros(Arc::clone(&self.pattern))?;
        self.fill(mesh, &mut matrix, |t, tet, target| {
            target.add_element(t, tet.as_ref(), |i, j, b, a| entry(t, i, j, b, a));
        })?;
        Ok(matrix)
    }

    /// Refills `matrix` (which must be on this pattern) with the linear stiffness
    /// K = Σₑ ∫ BₑᵀDBₑ dV (force/length) of any element type: each node block
    /// Kᵢⱼ = ∫ λ ∇Nᵢ∇Nⱼᵀ + μ ∇Nⱼ∇Nᵢᵀ + μ (∇Nᵢ·∇Nⱼ) I dV (i ≤ j) of
    /// [`ElementType::stiffness_block`] is added straight into the matrix, and Kⱼᵢ = Kᵢⱼᵀ from
    /// the same values, with no element matrix in between. For the linear tet these are the
    /// same values, bit for bit, as [`reassemble`](Self::reassemble) with
    /// [`Tet::stiffness`](crate::fe::element::Tet::stiffness).
    ///
    /// Errors: `matrix` is not on this assembler's pattern, or `mesh` is not the one it was
    /// built from.
    ///
    /// `materials` gives each tet its material: one [`Material`] for all, or a
    /// [`MaterialMap`](crate::fe::materials::MaterialMap) (then also an error unless it covers the
    /// mesh's tets). λ and μ are computed once per material and read per tet.
    pub fn refill_stiffness<E: ElementType>(
        &self,
        mesh: &TetMesh<E>,
        materials: &impl TetMaterials,
        matrix: &mut CscMatrix,
    ) -> Result<()> {
        materials.check_tet_count(mesh)?;
        let lame: Vec<(f64, f64)> = materials
            .material_list()
            .iter()
            .map(|m| (m.lame_lambda(), m.shear_modulus()))
            .collect();
        self.fill(mesh, matrix, |t, tet, target| {
            let (lame_lambda, shear_modulus) = lame[materials.index_of(t)];
            let rest = E::rest(mesh, t);
            target.add_symmetric(t, tet.as_ref(), |i, j| {
                E::stiffness_block(&rest, lame_lambda, shear_modulus, i, j)
            });
        })
    }

    /// Zeroes `matrix` and calls `add_tet(t, nodes of t, target)` for every tet, in tet order
    /// within each partition, the partitions in parallel.
    ///
    /// Each partition's values are zeroed just ahead of the first tet that writes them (up to the
    /// highest node of the current tet) rather than in a pass of their own, so that the scatter
    /// finds them in cache: with the usual locality of node numbering that front runs a mesh
    /// layer ahead, where a separate pass would stream the whole partition (tens of MB) out to
    /// memory and back. Every value is zeroed once, before any tet adds to it.
    fn fill<C: CellType>(
        &self,
        mesh: &TetMesh<C>,
        matrix: &mut CscMatrix,
        add_tet: impl Fn(usize, &C::Nodes, &mut Target<'_>) + Sync,
    ) -> Result<()> {
        use rayon::prelude::*;
        self.check_matrix(matrix)?;
        self.check_mesh(mesh)?;
        let col_ptr = self.pattern.col_ptr();
        let mut rest = matrix.values_mut();
        let mut slices = Vec::with_capacity(self.partitions.len());
        for part in &self.partitions {
            let (head, tail) = rest.split_at_mut(part.values.len());
            slices.push(head);
            rest = tail;
        }
        self.partitions
            .par_iter()
            .zip(slices)
            .for_each(|(part, values)| {
                let offset = part.values.start;
                let mut target = Target {
                    values,
                    offset,
                    nodes: part.nodes.clone(),
                    block_start: &self.block_start,
                    column_stride: &self.column_stride,
                };
                // Nodes part.nodes.start..zeroed have zeroed columns.
                let mut zeroed = part.nodes.start;
                for &t in &part.tets {
                    let tet = &mesh.tets()[t];
                    let top = tet
                        .as_ref()
                        .iter()
                        .filter(|n| part.nodes.contains(n))
                        .max()
                        .map_or(zeroed, |&n| n + 1);
                    if top > zeroed {
                        target.values[col_ptr[3 * zeroed] - offset..col_ptr[3 * top] - offset]
                            .fill(0.0);
                        zeroed = top;
                    }
                    add_tet(t, tet, &mut target);
                }
                target.values[col_ptr[3 * zeroed] - offset..].fill(0.0);
            });
        Ok(())
    }

    /// Global linear stiffness K = Σₑ ∫ BₑᵀDBₑ dV (force/length), see
    /// [`refill_stiffness`](Self::refill_stiffness) (each tet with its own material).
    pub fn stiffness<E: ElementType>(
        &self,
        mesh: &TetMesh<E>,
        materials: &impl TetMaterials,
    ) -> Result<CscMatrix> {
        let mut matrix = CscMatrix::zeros(Arc::clone(&self.pattern))?;
        self.refill_stiffness(mesh, materials, &mut matrix)?;
        Ok(matrix)
    }

    /// Global consistent mass M = Σₑ ∫ ρₑ NᵢNⱼ dV·I₃ (mass units; ρₑV/20·(1+δᵢⱼ) for the
    /// linear tet), on the same pattern as K, ρₑ the density of tet e's material.
    pub fn consistent_mass<E: ElementType>(
        &self,
        mesh: &TetMesh<E>,
        materials: &impl TetMaterials,
    ) -> Result<CscMatrix> {
        materials.check_tet_count(mesh)?;
        let mut matrix = CscMatrix::zeros(Arc::clone(&self.pattern))?;
        self.fill(mesh, &mut matrix, |t, tet, target| {
            let rest = E::rest(mesh, t);
            let density = materials.material_of(t).density();
            // The off-axis entries of each block get +0.0, as the 12×12 matrices always gave.
            target.add_element(t, tet.as_ref(), |i, j, b, a| {
                if a == b {
                    E::mass_coefficient(&rest, density, i, j)
                } else {
                    0.0
                }
            });
        })?;
        Ok(matrix)
    }
}

/// One partition's share of a matrix being filled: its slice of the values and the scatter map.
struct Target<'a> {
    values: &'a mut [f64],
    /// Index of `values[0]` in the whole value array.
    offset: usize,
    /// The nodes whose columns `values` holds.
    nodes: std::ops::Range<usize>,
    block_start: &'a [usize],
    column_stride: &'a [usize],
}

impl Target<'_> {
    /// Adds the element matrix of tet `t` (nodes `tet`), given entry by entry as
    /// `entry(i, j, b, a)` = row 3i + b, column 3j + a, to the columns this partition holds.
    #[inline(always)]
    fn add_element(
        &mut self,
        t: usize,
        tet: &[usize],
        entry: impl Fn(usize, usize, usize, usize) -> f64,
    ) {
        let n = tet.len();
        let starts = &self.block_start[n * n * t..n * n * (t + 1)];
        for j in 0..n {
            if !self.nodes.contains(&tet[j]) {
                continue;
            }
            let stride = self.column_stride[tet[j]];
            for i in 0..n {
                let start = starts[n * i + j] - self.offset;
                for a in 0..3 {
                    // One bounds check per column of the block: its three rows are adjacent.
                    let column = &mut self.values[start + a * stride..][..3];
                    for b in 0..3 {
                        column[b] += entry(i, j, b, a);
                    }
                }
            }
        }
    }

    /// Adds a symmetric element matrix given by its node blocks Kᵢⱼ for i ≤ j, each as
    /// `block(i, j)[a][b]` = row 3i + b, column 3j + a; Kⱼᵢ = Kᵢⱼᵀ is added from the same values.
    #[inline(always)]
    fn add_symmetric(
        &mut self,
        t: usize,
        tet: &[usize],
        block: impl Fn(usize, usize) -> [[f64; 3]; 3],
    ) {
        let n = tet.len();
        let starts = &self.block_start[n * n * t..n * n * (t + 1)];
        for i in 0..n {
            for j in i..n {
                let held_i = self.nodes.contains(&tet[i]);
                let held_j = self.nodes.contains(&tet[j]);
                if !(held_i || held_j) {
                    continue;
                }
                let k = block(i, j);
                if held_j {
                    let stride = self.column_stride[tet[j]];
                    let start = starts[n * i + j] - self.offset;
                    for a in 0..3 {
                        let column = &mut self.values[start + a * stride..][..3];
                        for b in 0..3 {
                            column[b] += k[a][b];
                        }
                    }
                }
                if i != j && held_i {
                    let stride = self.column_stride[tet[i]];
                    let start = starts[n * j + i] - self.offset;
                    for a in 0..3 {
                        let column = &mut self.values[start + a * stride..][..3];
                        for b in 0..3 {
                            column[b] += k[b][a];
                        }
                    }
                }
            }
        }
    }
}

/// Lumped (diagonal) mass per DOF: each tet gives its nodes their shares ρV·wᵢ of its mass
/// ([`ElementType::LUMPED_MASS`]: ρV/4 each for the linear tet), on all three axes.
pub fn lumped_mass<E: ElementType>(mesh: &TetMesh<E>, material: &Material) -> Vec<f64> {
    lumped_mass_by(mesh, material)
}

/// As [`lumped_mass`] with each tet's own density ρₑ (mass units).
///
/// Errors: `materials` does not cover the mesh's tets.
pub fn lumped_mass_of<E: ElementType>(
    mesh: &TetMesh<E>,
    materials: &impl TetMaterials,
) -> Result<Vec<f64>> {
    materials.check_tet_count(mesh)?;
    Ok(lumped_mass_by(mesh, materials))
}

/// [`lumped_mass_of`] for materials checked against the mesh.
fn lumped_mass_by<E: ElementType>(mesh: &TetMesh<E>, materials: &impl TetMaterials) -> Vec<f64> {
    let mut mass = vec![0.0; mesh.dof_count()];
    for (t, tet) in mesh.tets().iter().enumerate() {
        let element_mass = materials.material_of(t).density() * E::volume(&E::rest(mesh, t));
        for (i, &n) in tet.as_ref().iter().enumerate() {
            let share = E::LUMPED_MASS.share(i, element_mass);
            for axis in 0..3 {
                mass[3 * n + axis] += share;
            }
        }
    }
    mass
}

/// Convenience: the global stiffness of `mesh` with one material, or one per tet (builds a
/// fresh [`Assembler`]).
pub fn stiffness_matrix<E: ElementType>(
    mesh: &TetMesh<E>,
    materials: &impl TetMaterials,
) -> Result<CscMatrix> {
    Assembler::new(mesh).stiffness(mesh, materials)
}

/// Splits the nodes into contiguous ranges of roughly equal value counts, a few per thread for
/// load balance, each with the tets that touch it.
fn partition<C: CellType>(mesh: &TetMesh<C>, col_ptr: &[usize]) -> Vec<Partition> {
    let node_count = mesh.node_count();
    let nnz = col_ptr[3 * node_count];
    // Small meshes: one partition (no duplicated element work, no fork-join overhead).
    let count = if nnz < 200_000 {
        1
    } else {
        (4 * rayon::current_num_threads()).clamp(1, node_count)
    };
    let mut bounds = vec![0usize];
    for n in 0..node_count {
        let filled = col_ptr[3 * (n + 1)];
        if filled * count >= bounds.len() * nnz && bounds.len() < count {
            bounds.push(n + 1);
        }
    }
    if *bounds.last().unwrap_or(&0) != node_count {
        bounds.push(node_count);
    }
    let mut part_of = vec![0usize; node_count];
    for p in 0..bounds.len() - 1 {
        part_of[bounds[p]..bounds[p + 1]].fill(p);
    }
    let mut tets = vec![Vec::new(); bounds.len() - 1];
    let mut seen = vec![usize::MAX; C::NODES];
    for (t, tet) in mesh.tets().iter().enumerate() {
        let tet = tet.as_ref();
        for (k, &n) in tet.iter().enumerate() {
            let p = part_of[n];
            if !seen[..k].contains(&p) {
                tets[p].push(t);
            }
            seen[k] = p;
        }
    }
    tets.into_iter()
        .enumerate()
        .map(|(p, tets)| Partition {
            nodes: bounds[p]..bounds[p + 1],
            values: col_ptr[3 * bounds[p]]..col_ptr[3 * bounds[p + 1]],
            tets,
        })
        .collect()
}
