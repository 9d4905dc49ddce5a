//! Dirichlet constraints and the map between full and free DOFs.
//!
//! Constrained DOFs are eliminated, not penalised: the solvers work on the free DOFs only, and
//! prescribed values enter the right-hand side as −K_fc·u_c.

use std::sync::Arc;

use faer::sparse::SymbolicSparseColMat;
use nalgebra::{Matrix6, SymmetricEigen, Vector3, Vector6};

use crate::amg::DofGeometry;
use crate::base::error::{Error, Result};
use crate::linear_solver::LinearMethod;
use crate::mesh::{CellType, FaceTopology, TetMesh};
use crate::sparse::CscMatrix;

/// Prescribed displacements on chosen DOFs (length units).
///
/// A DOF takes one value: constraining it again with the same value is accepted, with another
/// value is [`Error::ConflictingConstraint`] (it used to keep the last silently).
#[derive(Debug, Clone, PartialEq)]
pub struct Constraints {
    prescribed: Vec<Option<f64>>,
    /// DOFs the caller constrained (the unused-node fixes of [`Constraints::new`] are not: a
    /// caller may still prescribe those nodes).
    explicit: Vec<bool>,
}

impl Constraints {
    /// No constraints yet on a mesh's DOFs, except that nodes no tet uses are fixed at zero:
    /// they have no stiffness and no mass, so left free they would make every system matrix
    /// singular. (`TetMesh::warnings` reports them.)
    pub fn new<C: CellType>(mesh: &TetMesh<C>) -> Self {
        let mut prescribed = vec![None; mesh.dof_count()];
        for node in mesh.unused_nodes() {
            prescribed[3 * node..3 * node + 3].fill(Some(0.0));
        }
        let explicit = vec![false; prescribed.len()];
        Constraints {
            prescribed,
            explicit,
        }
    }

    /// Clamps `nodes`: all three displacement components fixed at zero.
    pub fn fix_nodes(&mut self, nodes: &[usize]) -> Result<&mut Self> {
        self.fix_axes(nodes, [true; 3])
    }

    /// Fixes the chosen axes of `nodes` at zero (a roller or symmetry condition when not all
    /// three are chosen). [`Error::ConflictingConstraint`] if one of them is already prescribed
    /// a non-zero value (then nothing is changed).
    pub fn fix_axes(&mut self, nodes: &[usize], axes: [bool; 3]) -> Result<&mut Self> {
        self.check_nodes("fixed nodes", nodes)?;
        for &node in nodes {
            for axis in (0..3).filter(|&a| axes[a]) {
                self.check_conflict(node, axis, 0.0)?;
            }
        }
        for &node in nodes {
            for axis in (0..3).filter(|&a| axes[a]) {
                self.set(3 * node + axis, 0.0);
            }
        }
        Ok(self)
    }

    /// [`Error::ConflictingConstraint`] if DOF `3·node + axis` was constrained by the caller to
    /// a value other than `value`.
    fn check_conflict(&self, node: usize, axis: usize, value: f64) -> Result<()> {
        let dof = 3 * node + axis;
        match self.prescribed[dof] {
            Some(first) if self.explicit[dof] && first != value => {
                Err(Error::ConflictingConstraint {
                    node,
                    axis,
                    first,
                    second: value,
                })
            }
            _ => Ok(()),
        }
    }

    fn set(&mut self, dof: usize, value: f64) {
        self.prescribed[dof] = Some(value);
        self.explicit[dof] = true;
    }

    /// Prescribes the full displacement vector of `node` (a non-homogeneous Dirichlet condition).
    pub fn prescribe(&mut self, node: usize, displacement: Vector3<f64>) -> Result<&mut Self> {
        for axis in 0..3 {
            self.prescribe_axis(node, axis, displacement[axis])?;
        }
        Ok(self)
    }

    /// Prescribes one displacement component of `node` ([`Error::ConflictingConstraint`] if
    /// it is already constrained to another value).
    pub fn prescribe_axis(&mut self, node: usize, axis: usize, value: f64) -> Result<&mut Self> {
        self.check_nodes("prescribed displacement", &[node])?;
        if axis > 2 {
            return Err(Error::invalid_parameter(
                "axis",
                axis,
                "must be 0 (x), 1 (y) or 2 (z)",
            ));
        }
        if !value.is_finite() {
            return Err(Error::invalid_parameter(
                format!("prescribed displacement of node {node}, axis {axis}"),
                value,
                "must be finite",
            ));
        }
        self.check_conflict(node, axis, value)?;
        self.set(3 * node + axis, value);
        Ok(self)
    }

    /// Prescribed value of DOF `3·node + axis`, if constrained.
    pub fn get(&self, dof: usize) -> Option<f64> {
        self.prescribed.get(dof).copied().flatten()
    }

    /// Number of constrained DOFs.
    pub fn count(&self) -> usize {
        self.prescribed.iter().filter(|p| p.is_some()).count()
    }

    /// Number of DOFs of the mesh these constraints were made for.
    pub fn dof_count(&self) -> usize {
        self.prescribed.len()
    }

    fn check_nodes(&self, context: &'static str, nodes: &[usize]) -> Result<()> {
        if nodes.is_empty() {
            return Err(Error::EmptySelection {
                context: context.to_string(),
            });
        }
        let node_count = self.prescribed.len() / 3;
        match nodes.iter().find(|&&n| n >= node_count) {
            Some(&node) => Err(Error::UnknownNode {
                context,
                node,
                node_count,
            }),
            None => Ok(()),
        }
    }
}

/// Numbering of free DOFs and the prescribed values of the constrained ones.
#[derive(Debug, Clone, PartialEq)]
pub struct DofMap {
    /// Free index of each full DOF, `None` if constrained.
    free_index: Vec<Option<usize>>,
    /// Full index of each free DOF, ascending.
    free: Vec<usize>,
    /// Full-length vector: prescribed values on constrained DOFs, zero on free ones.
    prescribed: Vec<f64>,
}

impl DofMap {
    /// Where this map's free DOFs sit on `mesh` (free DOF i is full DOF 3·node + axis): what
    /// the multigrid preconditioner builds the rigid-body modes from.
    /// [`Error::DimensionMismatch`] if the map was made for another number of DOFs.
    pub fn geometry<C: CellType>(&self, mesh: &TetMesh<C>) -> Result<DofGeometry> {
        Error::check_len("DofMap DOFs", mesh.dof_count(), self.full_count())?;
        Ok(DofGeometry::new(mesh.nodes(), self.free_dofs())?)
    }

    /// [`geometry`](Self::geometry) when `method` may take the iterative path (which builds
    /// the rigid-body modes from it), `None` for [`LinearMethod::Direct`].
    pub fn geometry_for_method<C: CellType>(
        &self,
        method: LinearMethod,
        mesh: &TetMesh<C>,
    ) -> Result<Option<DofGeometry>> {
        if method == LinearMethod::Direct {
            Ok(None)
        } else {
            self.geometry(mesh).map(Some)
        }
    }

    /// Numbers the free DOFs in ascending full order.
    pub fn new(constraints: &Constraints) -> Self {
        let mut free_index = Vec::with_capacity(constraints.prescribed.len());
        let mut free = Vec::new();
        let mut prescribed = Vec::with_capacity(constraints.prescribed.len());
        for (dof, value) in constraints.prescribed.iter().enumerate() {
            match value {
                Some(v) => {
                    free_index.push(None);
                    prescribed.push(*v);
                }
                None => {
                    free_index.push(Some(free.len()));
                    free.push(dof);
                    prescribed.push(0.0);
                }
            }
        }
        DofMap {
            free_index,
            free,
            prescribed,
        }
    }

    /// Number of DOFs in total.
    pub fn full_count(&self) -> usize {
        self.free_index.len()
    }

    /// Number of free DOFs.
    pub fn free_count(&self) -> usize {
        self.free.len()
    }

    /// Full indices of the free DOFs.
    pub fn free_dofs(&self) -> &[usize] {
        &self.free
    }

    /// Free index of full DOF `dof` (`None` if constrained or out of range).
    pub fn free_index(&self, dof: usize) -> Option<usize> {
        self.free_index.get(dof).copied().flatten()
    }

    /// Full-length vector holding the prescribed values (zero on free DOFs).
    pub fn prescribed(&self) -> &[f64] {
        &self.prescribed
    }

    /// The free entries of a full-length vector ([`Error::DimensionMismatch`] unless
    /// `full.len()` is [`full_count`](Self::full_count)).
    pub fn restrict(&self, full: &[f64]) -> Result<Vec<f64>> {
        Error::check_len("full-length vector", self.full_count(), full.len())?;
        Ok(self.free.iter().map(|&d| full[d]).collect())
    }

    /// A full-length vector from free values, constrained DOFs set to their prescribed values
    /// ([`Error::DimensionMismatch`] unless `free.len()` is [`free_count`](Self::free_count)).
    pub fn expand(&self, free: &[f64]) -> Result<Vec<f64>> {
        Error::check_len("free-DOF vector", self.free_count(), free.len())?;
        let mut full = self.prescribed.clone();
        for (&d, &v) in self.free.iter().zip(free) {
            full[d] = v;
        }
        Ok(full)
    }

    /// The restriction of matrices on `pattern` (square, of dimension
    /// [`full_count`](Self::full_count)) to the free rows and columns.
    pub fn restriction(&self, pattern: &SymbolicSparseColMat<usize>) -> Result<Restriction> {
        Error::check_len("pattern rows", self.full_count(), pattern.nrows())?;
        Error::check_len("pattern columns", self.full_count(), pattern.ncols())?;
        let mut col_ptr = Vec::with_capacity(self.free.len() + 1);
        let mut row_idx = Vec::new();
        let mut source = Vec::new();
        col_ptr.push(0);
        for &col in &self.free {
            for k in pattern.col_ptr()[col]..pattern.col_ptr()[col + 1] {
                if let Some(row) = self.free_index[pattern.row_idx()[k]] {
                    row_idx.push(row);
                    source.push(k);
                }
            }
            col_ptr.push(row_idx.len());
        }
        let n = self.free.len();
        Ok(Restriction {
            // Valid by construction: columns in order, rows ascending within each (the free
            // numbering preserves the full order), all below n.
            pattern: Arc::new(SymbolicSparseColMat::new_checked(
                n, n, col_ptr, None, row_idx,
            )),
            source,
            full_shape: (pattern.ncols(), pattern.row_idx().len()),
        })
    }
}

/// Gathers the free–free block A_ff of matrices on one full pattern, in O(nnz(A_ff)).
#[derive(Debug, Clone)]
pub struct Restriction {
    pattern: Arc<SymbolicSparseColMat<usize>>,
    /// For each entry of A_ff, its position in the full matrix's values.
    source: Vec<usize>,
    /// Dimension and nnz of the full pattern this was built for.
    full_shape: (usize, usize),
}

impl Restriction {
    /// Pattern of A_ff.
    pub fn pattern(&self) -> &Arc<SymbolicSparseColMat<usize>> {
        &self.pattern
    }

    /// A_ff of `full` as a new matrix.
    pub fn restrict(&self, full: &CscMatrix) -> Result<CscMatrix> {
        let mut out = CscMatrix::zeros(Arc::clone(&self.pattern))?;
        self.restrict_into(full, &mut out)?;
        Ok(out)
    }

    /// Refills `out` (on [`pattern`](Self::pattern)) with A_ff of `full`.
    ///
    /// Errors: `full` does not have the dimension and entry count of the pattern this
    /// restriction was built for, or `out` is not on [`pattern`](Self::pattern).
    pub fn restrict_into(&self, full: &CscMatrix, out: &mut CscMatrix) -> Result<()> {
        let (dim, nnz) = self.full_shape;
        Error::check_len("full matrix dimension", dim, full.dim())?;
        Error::check_len("full matrix stored entries", nnz, full.nnz())?;
        if !Arc::ptr_eq(out.pattern(), &self.pattern) {
            return Err(Error::invalid_parameter(
                "out",
                format!("{} stored entries", out.nnz()),
                "must be on the restriction's pattern (Restriction::pattern)",
            ));
        }
        let values = full.values();
        for (o, &k) in out.values_mut().iter_mut().zip(&self.source) {
            *o = values[k];
        }
        Ok(())
    }
}

/// Checks that the constraints leave no rigid-body motion, so that K_ff is positive definite.
///
/// Why a geometric check and not just the Cholesky pivots: a singular K_ff often factors with a
/// tiny positive pivot in floating point and yields a huge, plausible-looking displacement. Here
/// the mesh is split into face-connected parts; within a part the only stiffness-free motions
/// are the 6 rigid modes, so a part is held when its constrained DOFs (plus nodes it shares with
/// parts already held) see all 6 modes, i.e. the 6×6 Gram matrix of the modes sampled at those
/// DOFs has full rank. Parts hanging on a held part by one node or one edge are correctly found
/// free (they can rotate about it).
pub fn ensure_held<C: CellType>(
    mesh: &TetMesh<C>,
    topology: &FaceTopology,
    dofs: &DofMap,
) -> Result<()> {
    Error::check_len("DOF map", mesh.dof_count(), dofs.full_count())?;
    if let Some(&(a, b)) = topology
        .neighbours
        .iter()
        .find(|&&(a, b)| a.max(b) >= mesh.tet_count())
    {
        return Err(Error::UnknownTet {
            context: "ensure_held: the face topology",
            tet: a.max(b),
            tet_count: mesh.tet_count(),
        });
    }
    let parts = face_connected_parts(mesh.tet_count(), &topology.neighbours);
    let part_count = parts.iter().copied().max().map_or(0, |p| p + 1);
    let mut part_nodes: Vec<Vec<usize>> = vec![Vec::new(); part_count];
    let mut part_tets = vec![(0usize, usize::MAX); part_count];
    for (t, tet) in mesh.tets().iter().enumerate() {
        part_nodes[parts[t]].extend_from_slice(tet.as_ref());
        let entry = &mut part_tets[parts[t]];
        entry.0 += 1;
        entry.1 = entry.1.min(t);
    }
    for nodes in &mut part_nodes {
        nodes.sort_unstable();
        nodes.dedup();
    }
    let mut pinned = vec![false; mesh.node_count()];
    let mut held = vec![false; part_count];
    let mut free_modes = vec![6usize; part_count];
    loop {
        let mut changed = false;
        for part in 0..part_count {
            if held[part] {
                continue;
            }
            free_modes[part] = unheld_modes(mesh, &part_nodes[part], dofs, &pinned);
            if free_modes[part] == 0 {
                held[part] = true;
                changed = true;
                for &n in &part_nodes[part] {
                    pinned[n] = true;
                }
            }
        }
        if !changed {
            break;
        }
    }
    match (0..part_count).find(|&p| !held[p]) {
        Some(part) => Err(Error::NotConstrained {
            tet: part_tets[part].1,
            part_tets: part_tets[part].0,
            free_modes: free_modes[part],
        }),
        None => Ok(()),
    }
}

/// Number of rigid modes of the part spanned by `nodes` that its constrained DOFs do not see.
fn unheld_modes<C: CellType>(
    mesh: &TetMesh<C>,
    nodes: &[usize],
    dofs: &DofMap,
    pinned: &[bool],
) -> usize {
    let positions = || nodes.iter().map(|&n| mesh.nodes()[n]);
    let centroid = positions().sum::<Vector3<f64>>() / nodes.len() as f64;
    let size = positions()
        .map(|p| (p - centroid).norm())
        .fold(0.0, f64::max)
        .max(f64::MIN_POSITIVE);
    let mut gram = Matrix6::zeros();
    for &n in nodes {
        let r = (mesh.nodes()[n] - centroid) / size;
        for axis in 0..3 {
            if !pinned[n] && dofs.free_index(3 * n + axis).is_some() {
                continue;
            }
            // Row of the rigid-mode basis at this DOF: translations e_a, rotations e_k × r.
            let mut row = Vector6::zeros();
            row[axis] = 1.0;
            for k in 0..3 {
                row[3 + k] = Vector3::ith(k, 1.0).cross(&r)[axis];
            }
            gram += row * row.transpose();
        }
    }
    let eigenvalues = SymmetricEigen::new(gram).eigenvalues;
    let largest = eigenvalues.iter().copied().fold(0.0, f64::max);
    // Rank tolerance: the modes are scaled to O(1), so an independent direction has an eigenvalue
    // of order one; a missing one sits at round-off (~1e-16 × DOF count).
    let tolerance = 1e-10 * largest.max(1.0);
    eigenvalues.iter().filter(|&&e| e <= tolerance).count()
}

/// Labels each tet with its face-connected part (union–find over shared faces).
fn face_connected_parts(tet_count: usize, neighbours: &[(usize, usize)]) -> Vec<usize> {
    let mut parent: Vec<usize> = (0..tet_count).collect();
    fn root(parent: &mut [usize], mut x: usize) -> usize {
        while parent[x] != x {
            parent[x] = parent[parent[x]];
            x = parent[x];
        }
        x
    }
    for &(a, b) in neighbours {
        let (ra, rb) = (root(&mut parent, a), root(&mut parent, b));
        if ra != rb {
            parent[ra.max(rb)] = ra.min(rb);
        }
    }
    let mut label = vec![usize::MAX; tet_count];
    let mut next = 0;
    (0..tet_count)
        .map(|t| {
            let r = root(&mut parent, t);
            if label[r] == usize::MAX {
                label[r] = next;
                next += 1;
            }
            label[r]
        })
        .collect()
}
