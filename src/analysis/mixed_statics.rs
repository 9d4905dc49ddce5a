//! Static equilibrium of the linear model in the mixed displacement–pressure form, on either
//! mixed element ([`MixedElement`]): Taylor–Hood P2–P1 on 10-node tets
//! ([`taylor_hood`](crate::fe::element::taylor_hood)) or the stabilized P1–P1 on 4-node tets
//! ([`stabilized_p1`](crate::fe::element::stabilized_p1)); no volumetric locking as Poisson's
//! ratio approaches 0.5.
//!
//! On the free displacement DOFs f and the corner pressures p the system is
//!
//! ```text
//!   ⎡ K_dev,ff   −B_fᵀ ⎤ ⎡u_f⎤   ⎡ f_f − K_dev,fc·u_c ⎤
//!   ⎣ −B_f       −C    ⎦ ⎣ p ⎦ = ⎣ B_c·u_c            ⎦
//! ```
//!
//! (u_c the prescribed displacements; C = M_p/κ for Taylor–Hood, plus the projection
//! stabilization for P1–P1, positive definite in both), symmetric quasi-definite for ν < 0.5 once the supports
//! hold every rigid motion, so it is factored by an LDLᵀ without pivoting on a nested-dissection
//! ordering ([`QuasiDefiniteLdlt`]), then refined as the displacement solve is
//! ([`RESIDUAL_LIMIT`]).

use std::sync::Arc;
use std::time::{Duration, Instant};

use faer::sparse::SymbolicSparseColMat;

use crate::analysis::problem::Problem;
use crate::analysis::statics::RESIDUAL_LIMIT;
use crate::base::error::{Error, Result};
use crate::base::memory::{RunPath, SolverMemory, StaticEstimate, format_bytes};
use crate::base::warning::Warning;
use crate::bc::constraints::{Constraints, DofMap};
use crate::bc::loads::Loads;
use crate::fe::element::taylor_hood::PressureNodes;
use crate::fe::element::{MixedElement, Tet10};
use crate::fe::materials::TetMaterials;
use crate::linalg::QuasiDefiniteLdlt;
use crate::mesh::{CellType, NodeList, TetMesh};
use crate::ordering::FillOrdering;
use crate::sparse::CscMatrix;

/// Steps of iterative refinement tried when the residual is above [`RESIDUAL_LIMIT`] (as the
/// displacement solve: refinement converges linearly, three steps that do not reach it mean
/// more will not).
const MAX_REFINEMENTS: usize = 3;

/// The result of a mixed static solve.
#[derive(Debug, Clone, PartialEq)]
pub struct MixedStaticSolution {
    /// Displacement of every DOF (length units), prescribed values included.
    pub displacement: Vec<f64>,
    /// Pressure p = −tr σ / 3 at every node (Pa; positive in compression): the solved value
    /// at tet corners, the mean of its edge's corners at an edge node of a 10-node tet (the
    /// linear field there), 0 at nodes of no tet.
    pub pressure: Vec<f64>,
    /// Relative residual ‖A·x − r‖/‖r‖ of the whole saddle-point system (0 when r = 0).
    pub relative_residual: f64,
    /// Reaction forces K_dev·u − Bᵀp − f: non-zero only on constrained DOFs (force units).
    pub reactions: Vec<f64>,
}

/// Wall time of each phase of a mixed static solve.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct MixedTimings {
    /// Pattern, constraint set-up and rigid-mode check.
    pub setup: Duration,
    /// Element matrices and the saddle-point matrix.
    pub assembly: Duration,
    /// Ordering and symbolic analysis of the LDLᵀ.
    pub symbolic: Duration,
    /// Numeric LDLᵀ factorization.
    pub factorization: Duration,
    /// Right-hand side, solves, refinement and reactions of the last solve.
    pub solve: Duration,
}

/// A factored mixed static problem on element `E` (10-node Taylor–Hood by default, or the
/// 4-node stabilized P1–P1): assemble and factor once, solve for any number of load cases.
#[derive(Debug)]
pub struct MixedStaticSolver<E: MixedElement = Tet10> {
    /// K_dev on every DOF (force/length).
    deviatoric: CscMatrix,
    /// The saddle-point matrix on the free DOFs then the pressures.
    system: CscMatrix,
    dofs: DofMap,
    pressure_nodes: PressureNodes,
    /// Per tet: its nodes and its coupling B (for B_c·u_c and Bᵀp).
    tets: Vec<E::Nodes>,
    couplings: Vec<E::Coupling>,
    ldlt: QuasiDefiniteLdlt,
    node_count: usize,
    timings: MixedTimings,
}

impl<E: MixedElement> MixedStaticSolver<E> {
    /// Assembles the mixed system of `mesh` with `materials` (one [`Material`](crate::Material)
    /// or a [`MaterialMap`](crate::MaterialMap); every material's ν < 0.5, so κ is finite),
    /// checks that `constraints` hold every rigid-body mode ([`Error::NotConstrained`]) and
    /// factors it.
    ///
    /// A material boundary inside the body gets a continuous pressure across it (the pressure
    /// space is continuous), an approximation where the bulk moduli differ.
    pub fn new(
        mesh: &TetMesh<E>,
        materials: &impl TetMaterials,
        constraints: &Constraints,
    ) -> Result<Self> {
        crate::analysis::problem::ensure_mesh_dofs(mesh, "constraints", constraints.dof_count())?;
        ensure_mixed_fits(mesh, "the mixed static solve", None)?;
        materials.check_tet_count(mesh)?;
        let mut timings = MixedTimings::default();
        let clock = Instant::now();
        let problem = Problem::new(mesh, constraints)?;
        timings.setup = clock.elapsed();

        let clock = Instant::now();
        let LinearSaddlePoint {
            dofs,
            pressure_nodes,
            couplings,
            deviatoric,
            saddle: system,
            ..
        } = LinearSaddlePoint::assemble(mesh, materials, problem)?;
        timings.assembly = clock.elapsed();

        let clock = Instant::now();
        let mut ldlt =
            QuasiDefiniteLdlt::analyze(&system, dofs.free_count(), FillOrdering::NestedDissection)?;
        timings.symbolic = clock.elapsed();
        let clock = Instant::now();
        ldlt.factorize(&system)?;
        timings.factorization = clock.elapsed();

        Ok(MixedStaticSolver {
            deviatoric,
            system,
            dofs,
            pressure_nodes,
            tets: mesh.tets().to_vec(),
            couplings,
            ldlt,
            node_count: mesh.node_count(),
            timings,
        })
    }

    /// Solves for the displacement and the pressure under `loads`.
    pub fn solve(&mut self, loads: &Loads) -> Result<MixedStaticSolution> {
        let forces = loads.as_slice();
        Error::check_len("loads", self.dofs.full_count(), forces.len())?;
        let clock = Instant::now();
        let free_count = self.dofs.free_count();
        // r_u = f − K_dev·u_c on the free DOFs; r_p = B·u_c.
        let coupling_load = self.deviatoric.mul(self.dofs.prescribed())?;
        let full: Vec<f64> = forces
            .iter()
            .zip(&coupling_load)
            .map(|(f, k)| f - k)
            .collect();
        let mut rhs = self.dofs.restrict(&full)?;
        rhs.extend(self.divergence(self.dofs.prescribed()));
        let mut x = rhs.clone();
        self.ldlt.solve_in_place(&mut x)?;
        let mut relative_residual = self.relative_residual(&x, &rhs)?;
        // Iterative refinement with the same factor, as the displacement solve does.
        let mut refinements = 0;
        while relative_residual > RESIDUAL_LIMIT && refinements < MAX_REFINEMENTS {
            refinements += 1;
            let product = self.system.mul(&x)?;
            let mut correction: Vec<f64> = rhs.iter().zip(&product).map(|(r, a)| r - a).collect();
            self.ldlt.solve_in_place(&mut correction)?;
            let refined: Vec<f64> = x.iter().zip(&correction).map(|(u, d)| u + d).collect();
            let refined_residual = self.relative_residual(&refined, &rhs)?;
            if refined_residual >= relative_residual || refined_residual.is_nan() {
                break;
            }
            x = refined;
            relative_residual = refined_residual;
        }
        if relative_residual > RESIDUAL_LIMIT || !relative_residual.is_finite() {
            return Err(Error::InaccurateSolve {
                relative_residual,
                limit: RESIDUAL_LIMIT,
                refinements,
                cause: "stiffness or element sizes that differ by many orders of magnitude, or \
                        loads and prescribed displacements of wildly different scales"
                    .to_string(),
            });
        }
        let corner_pressure = x.split_off(free_count);
        let displacement = self.dofs.expand(&x)?;
        let pressure_force = self.pressure_force(&corner_pressure);
        let elastic = self.deviatoric.mul(&displacement)?;
        let reactions = (0..forces.len())
            .map(|dof| {
                if self.dofs.free_index(dof).is_some() {
                    0.0
                } else {
                    elastic[dof] - pressure_force[dof] - forces[dof]
                }
            })
            .collect();
        let pressure = nodal_pressure::<E>(
            &self.tets,
            &self.pressure_nodes,
            self.node_count,
            &corner_pressure,
        );
        self.timings.solve = clock.elapsed();
        Ok(MixedStaticSolution {
            displacement,
            pressure,
            relative_residual,
            reactions,
        })
    }

    /// B·u per pressure unknown for a full displacement `u`: ∫ L_k div u dV (length³).
    fn divergence(&self, u: &[f64]) -> Vec<f64> {
        let mut out = vec![0.0; self.pressure_nodes.count()];
        for (tet, b) in self.tets.iter().zip(&self.couplings) {
            let corners = self.pressure_nodes.of_tet(tet.as_ref());
            for (k, &p) in corners.iter().enumerate() {
                for (i, &n) in tet.as_ref().iter().enumerate() {
                    for a in 0..3 {
                        out[p] += E::coupling_entry(b, k, i, a) * u[3 * n + a];
                    }
                }
            }
        }
        out
    }

    /// Bᵀ·p on every DOF: the nodal forces ∫ p div v dV of the corner pressures (force units).
    fn pressure_force(&self, corner: &[f64]) -> Vec<f64> {
        let mut out = vec![0.0; 3 * self.node_count];
        for (tet, b) in self.tets.iter().zip(&self.couplings) {
            let corners = self.pressure_nodes.of_tet(tet.as_ref());
            for (k, &p) in corners.iter().enumerate() {
                for (i, &n) in tet.as_ref().iter().enumerate() {
                    for a in 0..3 {
                        out[3 * n + a] += E::coupling_entry(b, k, i, a) * corner[p];
                    }
                }
            }
        }
        out
    }

    /// ‖A·x − r‖ / ‖r‖ (‖A·x − r‖ when r = 0).
    fn relative_residual(&self, x: &[f64], rhs: &[f64]) -> Result<f64> {
        let product = self.system.mul(x)?;
        let norm = |v: &mut dyn Iterator<Item = f64>| v.map(|a| a * a).sum::<f64>().sqrt();
        let residual = norm(&mut product.iter().zip(rhs).map(|(a, b)| a - b));
        let scale = norm(&mut rhs.iter().copied());
        Ok(if scale > 0.0 {
            residual / scale
        } else {
            residual
        })
    }

    /// The free/constrained displacement DOF numbering.
    pub fn dofs(&self) -> &DofMap {
        &self.dofs
    }

    /// The pressure unknowns (the tets' corner nodes).
    pub fn pressure_nodes(&self) -> &PressureNodes {
        &self.pressure_nodes
    }

    /// The saddle-point matrix: the free displacement DOFs, then the pressure unknowns.
    pub fn system(&self) -> &CscMatrix {
        &self.system
    }

    /// Number of stored values of the LDLᵀ factor.
    pub fn factor_len(&self) -> usize {
        self.ldlt.factor_len()
    }

    /// Wall time per phase so far.
    pub fn timings(&self) -> MixedTimings {
        self.timings
    }
}

/// What to change when a mixed run does not fit: every mixed solve factors its saddle point
/// (an LDLᵀ), so the iterative solver that [`RunPath::Direct`]'s hint names is not a way out.
const MIXED_MEMORY_HINT: &str =
    "use a coarser mesh (a mixed solve always factors its saddle point: it has no iterative path)";

/// Before any allocation: the blocks of the mixed static solve on `mesh` (the element's
/// pattern, 10- or 4-node, with its LDLᵀ taken as the multigrid hierarchy's bytes), plus
/// `extra` (a dynamic run's mass and shifted saddle point, bytes, described with it), against
/// the bounds of a factorizing run: [`Error::InsufficientMemory`] for `what`, naming the size
/// and the bound.
pub(crate) fn ensure_mixed_fits<E: MixedElement>(
    mesh: &TetMesh<E>,
    what: &str,
    extra: Option<(&str, u128)>,
) -> Result<()> {
    let estimate = StaticEstimate::for_element(
        mesh.node_count(),
        mesh.tet_count(),
        E::NODES,
        SolverMemory::Iterative,
    );
    let (described, needed) = match extra {
        Some((name, bytes)) => (
            format!("{} + {} {name}", estimate.describe(), format_bytes(bytes)),
            estimate.beyond_mesh() + bytes,
        ),
        None => (estimate.describe(), estimate.beyond_mesh()),
    };
    Ok(RunPath::Direct.limits().ensure_fits_or(
        format!("{what}: {described}, of which the mesh is held already"),
        needed,
        MIXED_MEMORY_HINT,
    )?)
}

/// The pressure at every node from the corner values `corner` (one per unknown of
/// `pressure_nodes`): the value at corners, the mean of its edge's corners at an edge node of
/// cell type `C` (the linear field there), 0 at nodes of no tet.
pub(crate) fn nodal_pressure<C: CellType>(
    tets: &[C::Nodes],
    pressure_nodes: &PressureNodes,
    node_count: usize,
    corner: &[f64],
) -> Vec<f64> {
    let mut field = vec![0.0; node_count];
    for (&n, &p) in pressure_nodes.nodes().iter().zip(corner) {
        field[n] = p;
    }
    for tet in tets {
        let corners = tet.corners();
        for i in 0..4 {
            for j in i + 1..4 {
                if let Some(edge) = C::edge_node(tet, i, j) {
                    field[edge] = 0.5 * (field[corners[i]] + field[corners[j]]);
                }
            }
        }
    }
    field
}

/// One-shot mixed static solve on element `E`: [`MixedStaticSolver::new`] then
/// [`MixedStaticSolver::solve`].
pub fn solve_static_mixed<E: MixedElement>(
    mesh: &TetMesh<E>,
    materials: &impl TetMaterials,
    constraints: &Constraints,
    loads: &Loads,
) -> Result<MixedStaticSolution> {
    MixedStaticSolver::new(mesh, materials, constraints)?.solve(loads)
}

/// The linear mixed body's blocks on `problem`'s DOFs, which the static solver and the
/// operator of the dynamic and modal analyses share: K_dev (every DOF and free rows and
/// columns, force/length), each tet's coupling B (kept for the divergence and the pressure
/// recovery) and the saddle point A(0) = [K_dev,ff −B_fᵀ; −B_f −C].
pub(crate) struct LinearSaddlePoint<E: MixedElement> {
    pub(crate) dofs: DofMap,
    pub(crate) pressure_nodes: PressureNodes,
    pub(crate) couplings: Vec<E::Coupling>,
    pub(crate) deviatoric: CscMatrix,
    pub(crate) free_deviatoric: CscMatrix,
    pub(crate) saddle: CscMatrix,
}

impl<E: MixedElement> LinearSaddlePoint<E> {
    /// Assembles the blocks of `mesh` with `materials` (μ and 1/κ per material; every ν < 0.5,
    /// so κ is finite), consuming `problem` for its DOF map.
    pub(crate) fn assemble(
        mesh: &TetMesh<E>,
        materials: &impl TetMaterials,
        problem: Problem<'_, E>,
    ) -> Result<Self> {
        let shear: Vec<f64> = materials
            .material_list()
            .iter()
            .map(|m| m.shear_modulus())
            .collect();
        let inverse_bulk: Vec<f64> = materials
            .material_list()
            .iter()
            .map(|m| 1.0 / m.bulk_modulus())
            .collect();
        let mut deviatoric = problem.zero_matrix()?;
        problem.assembler().reassemble_elements(
            mesh,
            |t| E::deviatoric_stiffness(&E::rest(mesh, t), shear[materials.index_of(t)]),
            &mut deviatoric,
        )?;
        let free_deviatoric = problem.restrict(&deviatoric)?;
        let pressure_nodes = PressureNodes::new(mesh);
        // Per tet: B and C (4×4), from one rest each.
        let (couplings, blocks): (Vec<E::Coupling>, Vec<[[f64; 4]; 4]>) = (0..mesh.tet_count())
            .map(|t| {
                let rest = E::rest(mesh, t);
                let material = materials.index_of(t);
                let block = std::array::from_fn(|k| {
                    std::array::from_fn(|l| {
                        E::pressure_block(&rest, shear[material], inverse_bulk[material], k, l)
                    })
                });
                (E::coupling(&rest), block)
            })
            .unzip();
        let dofs = problem.into_dofs();
        let saddle = saddle_point_matrix(
            mesh,
            &free_deviatoric,
            &dofs,
            &pressure_nodes,
            |t, k, i, a| E::coupling_entry(&couplings[t], k, i, a),
            |t, k, l| blocks[t][k][l],
        )?;
        Ok(LinearSaddlePoint {
            dofs,
            pressure_nodes,
            couplings,
            deviatoric,
            free_deviatoric,
            saddle,
        })
    }
}

/// The saddle-point matrix [K_dev,ff −B_fᵀ; −B_f −C] (both triangles, sorted rows): the free
/// displacement DOFs are rows and columns `0..n_f`, pressure unknown k is `n_f + k`.
/// `coupling(t, k, i, a)` is tet t's B_kᵢₐ, `pressure_block(t, k, l)` its C_kl.
pub(crate) fn saddle_point_matrix<C: CellType>(
    mesh: &TetMesh<C>,
    free_deviatoric: &CscMatrix,
    dofs: &DofMap,
    pressure_nodes: &PressureNodes,
    coupling: impl Fn(usize, usize, usize, usize) -> f64,
    pressure_block: impl Fn(usize, usize, usize) -> f64,
) -> Result<CscMatrix> {
    let free_count = dofs.free_count();
    let dim = free_count + pressure_nodes.count();
    // Every (column, row, value) of −B, −Bᵀ and −C, tet by tet.
    let visit = |add: &mut dyn FnMut(usize, usize, f64)| {
        for (t, tet) in mesh.tets().iter().enumerate() {
            let corners = pressure_nodes.of_tet(tet.as_ref());
            for (k, &p) in corners.iter().enumerate() {
                let row = free_count + p;
                for (i, &n) in tet.as_ref().iter().enumerate() {
                    for a in 0..3 {
                        if let Some(free) = dofs.free_index(3 * n + a) {
                            let b = coupling(t, k, i, a);
                            add(free, row, -b);
                            add(row, free, -b);
                        }
                    }
                }
            }
            for (k, &p) in corners.iter().enumerate() {
                for (l, &q) in corners.iter().enumerate() {
                    add(free_count + q, free_count + p, -pressure_block(t, k, l));
                }
            }
        }
    };
    // Bucketed by column in two passes (count, then fill): each column's few entries are
    // sorted on their own, not millions of triplets globally.
    let mut start = vec![0usize; dim + 1];
    visit(&mut |column, _, _| start[column + 1] += 1);
    for column in 0..dim {
        start[column + 1] += start[column];
    }
    let mut fill = start.clone();
    let mut bucket = vec![(0usize, 0.0f64); start[dim]];
    visit(&mut |column, row, value| {
        bucket[fill[column]] = (row, value);
        fill[column] += 1;
    });
    let mut col_ptr = Vec::with_capacity(dim + 1);
    let mut row_idx = Vec::with_capacity(free_deviatoric.nnz() + bucket.len());
    let mut values = Vec::with_capacity(row_idx.capacity());
    col_ptr.push(0);
    for column in 0..dim {
        if column < free_count {
            let range = free_deviatoric.col_ptr()[column]..free_deviatoric.col_ptr()[column + 1];
            row_idx.extend_from_slice(&free_deviatoric.row_idx()[range.clone()]);
            values.extend_from_slice(&free_deviatoric.values()[range]);
        }
        // The added entries of this column have rows above every K_dev row (pressures) or,
        // in a pressure column, are the only ones: appended in sorted order, duplicates summed
        // (in tet order, so the sum does not depend on the sort).
        let entries = &mut bucket[start[column]..start[column + 1]];
        entries.sort_by_key(|&(row, _)| row);
        let first = row_idx.len();
        for &(row, value) in entries.iter() {
            if row_idx.len() > first && row_idx.last() == Some(&row) {
                if let Some(last) = values.last_mut() {
                    *last += value;
                }
            } else {
                row_idx.push(row);
                values.push(value);
            }
        }
        col_ptr.push(row_idx.len());
    }
    // Valid by construction (sorted, in range, square).
    let pattern = SymbolicSparseColMat::new_checked(dim, dim, col_ptr, None, row_idx);
    Ok(CscMatrix::from_values(Arc::new(pattern), values)?)
}

/// The warning of a mixed solve on `mesh` before it starts: on 10-node tets (Taylor–Hood
/// P2–P1) [`Warning::MixedWithoutInteriorCorner`] when no tet has a corner inside the body
/// ([`tets_without_an_interior_corner`](crate::fe::element::taylor_hood::tets_without_an_interior_corner)
/// is every tet); none on 4-node tets (the stabilized P1–P1 element needs no interior corner)
/// or when some tet has one (Boffi's condition is sufficient, not necessary: the scenes warn
/// only when it fails everywhere).
///
/// Errors: those of the mesh's boundary faces.
pub fn mixed_mesh_warnings<E: MixedElement>(mesh: &TetMesh<E>) -> Result<Vec<Warning>> {
    if E::NODES != Tet10::NODES {
        return Ok(Vec::new());
    }
    let without = crate::fe::element::taylor_hood::tets_without_an_interior_corner(mesh)?.len();
    Ok(match without == mesh.tet_count() && without > 0 {
        true => vec![Warning::MixedWithoutInteriorCorner { tets: without }],
        false => Vec::new(),
    })
}
