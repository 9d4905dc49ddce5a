//! The peak memory a run will need, estimated from its mesh sizes before anything is allocated,
//! and checked against what the process may still take ([`MemoryLimits`], from
//! `tetfem_linalg::memory`, which also keeps back the address space faer's dense kernels
//! reserve per thread), so that a run too large for the machine stops with an
//! [`Error::InsufficientMemory`](crate::Error::InsufficientMemory) instead of being aborted by the allocator halfway.

pub use tetfem_linalg::memory::{
    COARSER_MESH, CacheLevel, DenseKernelReservation, FALLBACK_L3_BYTES, MemoryBound, MemoryLimits,
    cache_size_bytes, cpu_list_len, dense_kernel_reservation, format_bytes, gemm_l3_bytes,
    meminfo_available, physical_cores, soft_limit, status_bytes,
};

use crate::base::error::Result;

/// What the process holds before the run: code, libraries, thread stacks and malloc arenas
/// (bytes). A two-node solve measured 4.7 MB of peak RSS; 16 MB leaves room for more threads.
/// Resident memory only: the dense kernels' address-space reservation is kept back from the
/// address-space bounds instead ([`DenseKernelReservation`]).
pub const PROCESS_BASELINE: u128 = 16_000_000;

/// How a run solves, for the address space it maps beyond its resident estimate (the dense
/// kernels' buffers, [`DenseKernelReservation`], counted by `RLIMIT_AS`/`RLIMIT_DATA` only) and
/// for the hint of its [`Error::InsufficientMemory`](crate::Error::InsufficientMemory)(crate::Error::InsufficientMemory).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RunPath {
    /// Conjugate gradients with smoothed aggregation (static solves, implicit steps, Newton's
    /// linear solves): the coarsest level's supernodal Cholesky runs the dense kernels on one
    /// thread, so one buffer.
    Iterative,
    /// A Cholesky factor of K_ff (`linear_solver = "direct"`, a modal run): the buffers of
    /// every thread of the factorization (the pool's and the calling thread's).
    Direct,
    /// Explicit steps: no factorization, so no buffer (the critical step's inertia check is
    /// skipped, for Gershgorin's bound, when its buffers do not fit).
    Explicit,
}

impl RunPath {
    /// Bytes of dense-kernel buffers this path maps (address space only).
    pub fn dense_kernel_bytes(self) -> u64 {
        let reservation = dense_kernel_reservation();
        match self {
            RunPath::Iterative => reservation.for_threads(1),
            RunPath::Direct => reservation.bytes,
            RunPath::Explicit => 0,
        }
    }

    /// The memory bounds of this process for this path, read now: [`MemoryLimits::current`]
    /// with [`dense_kernel_bytes`](Self::dense_kernel_bytes) kept back from the address-space
    /// bounds.
    pub fn limits(self) -> MemoryLimits {
        MemoryLimits::current().keeping_back(self.dense_kernel_bytes())
    }

    /// What to change when the run does not fit.
    pub fn hint(self) -> &'static str {
        match self {
            RunPath::Iterative | RunPath::Explicit => COARSER_MESH,
            RunPath::Direct => {
                "use the iterative solver (linear_solver = \"iterative\"), which holds no \
                 factor, or a coarser mesh"
            }
        }
    }
}

/// Bytes per stored entry of K of the multigrid hierarchy (see [`StaticEstimate`]).
pub const ITERATIVE_BYTES_PER_ENTRY: u128 = 80;

/// The linear solver the estimate assumes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SolverMemory {
    /// Conjugate gradients with smoothed-aggregation multigrid: the least memory of the two.
    Iterative,
    /// A Cholesky factor of this many bytes, workspace included
    /// ([`SparseCholesky::factor_bytes`](crate::linsolve::SparseCholesky::factor_bytes)).
    Factor(u128),
}

/// Predicted peak memory of a linear static solve (bytes), by part, from the mesh's node count
/// N, tet count T and nodes per tet k (4 for the linear tet, 10 for the quadratic one), before
/// anything is allocated. Sizes follow the data structures, with nnz the stored entries of K
/// from [`stiffness_entries`]:
///
/// - mesh: 24·N (coordinates) + 8k·T (connectivity);
/// - assembly: the pattern (8·nnz row indices, 24·N column starts) and the scatter map (one
///   index per node block of each tet, 8k²·T), K's values (8·nnz), and while the pattern is
///   built the adjacency scratch (the tet's ordered node pairs, 16k(k − 1)·T);
/// - faces: the sorted face list of the face topology check, 4 faces of 8·(nodes per face) + 16
///   bytes per tet (3 face nodes for k = 4, 6 for k = 10) and the neighbour pairs (32·T), held
///   only during the check;
/// - free matrix: K_ff (16·nnz) and, while it is extracted, its growing row and source index
///   arrays (up to 2 × 16·nnz);
/// - solver: the factor ([`SolverMemory::Factor`]) and the symbolic analysis (ordering graph,
///   supernodal structure: 24·nnz, measured at 12–24 bytes per K_ff entry above the factor on
///   beams of 70k–210k DOFs), or the multigrid hierarchy (80·nnz: the finest matrix's copy,
///   the smoothed prolongator, its transpose and the coarse operators) with the DOF geometry and
///   the CG vectors (200 bytes per DOF). The hierarchy was first taken as 48·nnz (3 × K_ff's
///   16·nnz); the CLI's static runs then peaked 23–26 bytes per entry of K above the estimate
///   (issue 33: VmHWM 192 MB against 157.8 MB on a 100×10×10 beam of 36k DOFs, 1.382 GB against
///   1.125 GB at 200×20×20, 266k DOFs; 10.7 GB against 8.57 GB at 1.95M DOFs), so 32 more
///   bytes per entry: 1.06× and 1.07× the first two peaks, and +2.4–2.8 GB on the third
///   (76–88M entries for 5–6 tets per node);
/// - outputs: displacement, reactions and the per-tet fields (48·N + 32·T), the output files'
///   buffers (another 48·N + 32·T).
///
/// The peak is [`PROCESS_BASELINE`], the mesh and the assembly plus the largest of the later
/// phases (they do not overlap: the faces are dropped before K_ff is built, and the outputs come
/// after the solve).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct StaticEstimate {
    /// Nodes N.
    pub nodes: u128,
    /// Tets T.
    pub tets: u128,
    /// Stored entries of K, nnz ([`stiffness_entries`]).
    pub stiffness_entries: u128,
    /// The mesh (bytes).
    pub mesh: u128,
    /// Pattern, scatter map, K and the pattern's scratch (bytes).
    pub assembly: u128,
    /// The face topology check (bytes, temporary).
    pub faces: u128,
    /// K_ff and its extraction (bytes).
    pub free_matrix: u128,
    /// The factor or the multigrid hierarchy and the CG vectors (bytes).
    pub solver: u128,
    /// Solution, reactions and output fields (bytes).
    pub outputs: u128,
}

impl StaticEstimate {
    /// The estimate for a mesh of linear tets (4 nodes each) with `nodes` nodes and `tets` tets
    /// solved with `solver`: [`for_element`](Self::for_element) with k = 4.
    pub fn new(nodes: usize, tets: usize, solver: SolverMemory) -> Self {
        Self::for_element(nodes, tets, 4, solver)
    }

    /// The estimate for a mesh of `nodes` nodes and `tets` tets of `nodes_per_tet` nodes each
    /// (k: 4 or 10, [`CellType::NODES`](crate::mesh::CellType::NODES)) solved with `solver`.
    /// In u128: no product of any two usize counts overflows.
    pub fn for_element(
        nodes: usize,
        tets: usize,
        nodes_per_tet: usize,
        solver: SolverMemory,
    ) -> Self {
        let (n, t, k) = (nodes as u128, tets as u128, nodes_per_tet as u128);
        let nnz = stiffness_entries(n, t, nodes_per_tet);
        let dofs = 3 * n;
        let solver = match solver {
            SolverMemory::Iterative => ITERATIVE_BYTES_PER_ENTRY * nnz + 200 * dofs,
            SolverMemory::Factor(bytes) => bytes + 24 * nnz,
        };
        let face_nodes = if nodes_per_tet > 4 { 6 } else { 3 };
        StaticEstimate {
            nodes: n,
            tets: t,
            stiffness_entries: nnz,
            mesh: 24 * n + 8 * k * t,
            assembly: 16 * nnz + 24 * n + 8 * k * k * t + 16 * k * k.saturating_sub(1) * t,
            faces: 4 * (8 * face_nodes + 16) * t + 32 * t,
            free_matrix: 48 * nnz,
            solver,
            outputs: 96 * n + 64 * t,
        }
    }

    /// The extra memory of a linear dynamic run over this static estimate (bytes): the mass
    /// matrix (or the damping's) and the step matrix, each on K_ff's pattern (16·nnz), and the
    /// state vectors (10 vectors of 8 bytes per DOF).
    pub fn dynamic_extra(&self) -> u128 {
        2 * 16 * self.stiffness_entries + 10 * 8 * 3 * self.nodes
    }

    /// The peak (bytes): mesh + assembly + the largest later phase (K_ff is held through the
    /// solver's phase).
    pub fn peak(&self) -> u128 {
        let free_matrix_held = self.free_matrix / 3;
        let later = self
            .faces
            .max(self.free_matrix)
            .max(free_matrix_held + self.solver)
            .max(free_matrix_held + self.outputs);
        PROCESS_BASELINE + self.mesh + self.assembly + later
    }

    /// The peak less the mesh: what a solve of an existing mesh still allocates (bytes).
    pub fn beyond_mesh(&self) -> u128 {
        self.peak() - self.mesh - PROCESS_BASELINE
    }

    /// One line: the peak and its parts, e.g. "about 21.3 GB (mesh 1.9 GB, assembly …)".
    pub fn describe(&self) -> String {
        format!(
            "about {} for {} nodes and {} tets (mesh {}, pattern and K {}, face check {}, K_ff {}, \
             solver {}, outputs {})",
            format_bytes(self.peak()),
            self.nodes,
            self.tets,
            format_bytes(self.mesh),
            format_bytes(self.assembly),
            format_bytes(self.faces),
            format_bytes(self.free_matrix),
            format_bytes(self.solver),
            format_bytes(self.outputs),
        )
    }

    /// `Ok` if the whole run fits in `limits`, otherwise [`Error::InsufficientMemory`](crate::Error::InsufficientMemory) for
    /// `what` with this estimate's parts.
    pub fn ensure_fits(&self, what: &str, limits: &MemoryLimits) -> Result<()> {
        Ok(limits.ensure_fits(format!("{what}: {}", self.describe()), self.peak())?)
    }
}
/// Stored entries nnz of the full (both triangles) stiffness pattern of a mesh of N `nodes`
/// and T `tets` of `nodes_per_tet` nodes: 3×3 blocks of every node pair that shares a tet.
///
/// - Linear tet (k = 4): nnz = 9·(3N + 2T): N diagonal blocks and about N + T edges each way,
///   by Euler's formula for a tet mesh, V − E + F − T = 1 with F ≈ 2T.
/// - Quadratic tet (k = 10): nnz = 9·(10N + 27T), an upper bound fitted to the patterns
///   assembled on unit boxes of 4³, 8³ and 16³ cells (N the 10-node mesh's node count):
///
///   | split | cells | N | T | measured nnz/9 | 10N + 27T |
///   |---|---|---|---|---|---|
///   | 6-tet | 4³ | 729 | 384 | 17 025 | 17 658 (+3.7 %) |
///   | 6-tet | 8³ | 4 913 | 3 072 | 126 785 | 132 074 (+4.2 %) |
///   | 6-tet | 16³ | 35 937 | 24 576 | 977 793 | 1 022 922 (+4.6 %) |
///   | 5-tet | 4³ | 665 | 320 | 14 657 | 15 290 (+4.3 %) |
///   | 5-tet | 8³ | 4 401 | 2 560 | 107 841 | 113 130 (+4.9 %) |
///   | 5-tet | 16³ | 31 841 | 20 480 | 826 241 | 871 370 (+5.5 %) |
///
///   (both 6-tet splits give the same counts). The excess grows towards the interior value
///   (+5.7 % for the 6-tet split, +6.9 % for the 5-tet one, from the 1/n extrapolation of the
///   per-node counts), because boundary nodes have fewer neighbours. The linear formula would
///   take 9·(3N + 2T), 1/6 of the 16³ P2 pattern.
///
/// Any other k is bounded by the dense element blocks, N + k(k − 1)·T blocks.
pub fn stiffness_entries(nodes: u128, tets: u128, nodes_per_tet: usize) -> u128 {
    let k = nodes_per_tet as u128;
    let blocks = match nodes_per_tet {
        4 => 3 * nodes + 2 * tets,
        10 => 10 * nodes + 27 * tets,
        _ => nodes + k * k.saturating_sub(1) * tets,
    };
    9 * blocks
}

/// Nodes of a structured box of `cells` cubes with `tets_per_cell` tets each whose tets have
/// `nodes_per_tet` nodes: the grid nodes, plus for 10-node tets one node per edge. The edges
/// follow from Euler's formula V − E + F − T = 1 of the (contractible) box with 4T = 2F − F_b
/// and F_b = 4(nx·ny + ny·nz + nz·nx) boundary triangles: E = V + T + F_b/2 − 1, for every
/// split. Saturating, as [`box_counts`].
pub fn box_node_count(cells: [usize; 3], tets_per_cell: usize, nodes_per_tet: usize) -> u128 {
    let (vertices, tets) = box_counts(cells, tets_per_cell);
    if nodes_per_tet <= 4 {
        return vertices;
    }
    let [x, y, z] = cells.map(|c| c as u128);
    let half_boundary = 2u128.saturating_mul(
        x.saturating_mul(y)
            .saturating_add(y.saturating_mul(z))
            .saturating_add(z.saturating_mul(x)),
    );
    let edges = vertices
        .saturating_add(tets)
        .saturating_add(half_boundary)
        .saturating_sub(1);
    vertices.saturating_add(edges)
}

/// Nodes and tets of a structured box of `cells` cubes with `tets_per_cell` tets each, in u128,
/// saturating (three usize factors can exceed even u128).
pub fn box_counts(cells: [usize; 3], tets_per_cell: usize) -> (u128, u128) {
    let [x, y, z] = cells.map(|c| c as u128);
    (
        (x + 1).saturating_mul(y + 1).saturating_mul(z + 1),
        x.saturating_mul(y)
            .saturating_mul(z)
            .saturating_mul(tets_per_cell as u128),
    )
}

/// The static estimate of a box of `cells` cubes (`tets_per_cell` tets each, of
/// `nodes_per_tet` nodes: 4 or 10) before it is meshed; counts beyond usize saturate (the
/// estimate is then beyond any memory anyway).
pub fn box_static_estimate(
    cells: [usize; 3],
    tets_per_cell: usize,
    nodes_per_tet: usize,
    solver: SolverMemory,
) -> StaticEstimate {
    let (_, t) = box_counts(cells, tets_per_cell);
    let n = box_node_count(cells, tets_per_cell, nodes_per_tet);
    let clamp = |v: u128| usize::try_from(v).unwrap_or(usize::MAX);
    let mut estimate = StaticEstimate::for_element(clamp(n), clamp(t), nodes_per_tet, solver);
    if n > usize::MAX as u128 || t > usize::MAX as u128 {
        // The true counts, so that the message names them.
        estimate.nodes = n;
        estimate.tets = t;
    }
    estimate
}

/// `Ok` if a box of `cells` (`tets_per_cell` tets each, of `nodes_per_tet` nodes: 4 or 10)
/// can be solved statically (or, with `dynamic`, integrated) on `path` in the memory
/// available now (the dense kernels' buffers of `path` kept back from the address-space
/// bounds); otherwise [`Error::InsufficientMemory`](crate::Error::InsufficientMemory) with what is needed, what is available and
/// the hint of `path`. Computed from the counts alone, in microseconds, for any `cells`.
pub fn check_box_run(
    cells: [usize; 3],
    tets_per_cell: usize,
    nodes_per_tet: usize,
    dynamic: bool,
    path: RunPath,
) -> Result<()> {
    let estimate =
        box_static_estimate(cells, tets_per_cell, nodes_per_tet, SolverMemory::Iterative);
    let limits = path.limits();
    let what = format!(
        "a {} run on a {}×{}×{} box of {}-node tets",
        if dynamic { "dynamic" } else { "static" },
        cells[0],
        cells[1],
        cells[2],
        nodes_per_tet
    );
    let (what, needed) = if dynamic {
        (
            format!(
                "{what}: {} + {} for the dynamic system",
                estimate.describe(),
                format_bytes(estimate.dynamic_extra())
            ),
            estimate.peak() + estimate.dynamic_extra(),
        )
    } else {
        (format!("{what}: {}", estimate.describe()), estimate.peak())
    };
    Ok(limits.ensure_fits_or(what, needed, path.hint())?)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nnz_formula_is_exact_on_a_box_interior() {
        // 6-tet (Kuhn) split: each interior node has 14 neighbours, so 15 blocks of 9 entries
        // per node; T = 6 per node far from the faces, so 9·(3N + 2T) = 9·15·N exactly.
        let (n, t) = (1_000_000u128, 6_000_000u128);
        assert_eq!(9 * (3 * n + 2 * t), 135 * n);
    }

    #[test]
    fn huge_boxes_do_not_overflow_and_do_not_fit() {
        let limits = MemoryLimits {
            bounds: vec![MemoryBound {
                source: "test bound",
                bytes: 1 << 40,
                address_space: false,
            }],
            dense_kernels: 0,
        };
        let e = box_static_estimate([usize::MAX; 3], 6, 10, SolverMemory::Iterative);
        assert!(e.peak() > 1 << 40);
        let err = e.ensure_fits("test", &limits).unwrap_err().to_string();
        assert!(err.contains("test bound"), "{err}");
    }
}
