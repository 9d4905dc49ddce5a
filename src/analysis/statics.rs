//! Static equilibrium of the linear model: K_ff·u_f = f_f − K_fc·u_c.

use std::time::{Duration, Instant};

use crate::analysis::problem::Problem;
use crate::base::error::{Error, Result};
use crate::base::memory::{RunPath, SolverMemory, StaticEstimate};
use crate::bc::constraints::{Constraints, DofMap};
use crate::bc::loads::Loads;
use crate::fe::element::ElementType;
use crate::fe::material::Material;
use crate::fe::materials::TetMaterials;
use crate::linear_solver::{LinearMethod, LinearSolver, SolveInfo, SolverOptions};
use crate::mesh::TetMesh;
use crate::sparse::CscMatrix;

/// The largest relative residual ‖K_ff·u_f − r_f‖/‖r_f‖ a direct static solve may return:
/// a backward-stable Cholesky solve of a matrix of condition κ leaves about κ·1e-16, so above
/// 1e-8 (κ ≳ 1e8, after refinement) the displacement has lost half its digits or more.
pub const RESIDUAL_LIMIT: f64 = 1e-8;

/// Steps of iterative refinement tried when a direct solve's residual is above
/// [`RESIDUAL_LIMIT`]; refinement converges linearly with rate ~κ·ε, so if three steps do not
/// reach it, more do not either.
const MAX_REFINEMENTS: usize = 3;

/// Wall time of each phase of a static solve.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct StaticTimings {
    /// Pattern and scatter map.
    pub pattern: Duration,
    /// Element stiffness and scatter into K.
    pub assembly: Duration,
    /// Constraint check and extraction of K_ff.
    pub constraints: Duration,
    /// Symbolic analysis (ordering, elimination tree), or the choice of the iterative method.
    pub symbolic: Duration,
    /// Numeric Cholesky factorization, or the preconditioner's setup.
    pub factorization: Duration,
    /// Right-hand side, triangular solves and residual of the last [`StaticSolver::solve`].
    pub solve: Duration,
}

/// The result of a static solve.
#[derive(Debug, Clone, PartialEq)]
pub struct StaticSolution {
    /// Displacement of every DOF (length units), prescribed values included.
    pub displacement: Vec<f64>,
    /// Relative residual ‖K_ff·u_f − r_f‖ / ‖r_f‖ with r_f = f_f − K_fc·u_c (0 when r_f = 0).
    pub relative_residual: f64,
    /// Reaction forces K·u − f: non-zero only on constrained DOFs (force units).
    pub reactions: Vec<f64>,
    /// How the linear system was solved.
    pub info: SolveInfo,
}

/// A factored static problem: assemble K once, factor K_ff once, solve for any number of load
/// cases.
#[derive(Debug)]
pub struct StaticSolver {
    stiffness: CscMatrix,
    free_stiffness: CscMatrix,
    dofs: DofMap,
    solver: LinearSolver,
    timings: StaticTimings,
    /// What [`Error::InaccurateSolve`] names as the likely cause, from the material.
    likely_cause: String,
}

impl StaticSolver {
    /// Assembles K, checks that `constraints` leave no rigid-body motion
    /// ([`Error::NotConstrained`] otherwise), and factors K_ff. `materials`: one [`Material`]
    /// for every tet, or a [`MaterialMap`](crate::fe::materials::MaterialMap).
    pub fn new<E: ElementType>(
        mesh: &TetMesh<E>,
        materials: &impl TetMaterials,
        constraints: &Constraints,
    ) -> Result<Self> {
        Self::with_options(mesh, materials, constraints, SolverOptions::default())
    }

    /// As [`new`](Self::new), with a chosen linear solver (direct or iterative, ordering, threads).
    pub fn with_options<E: ElementType>(
        mesh: &TetMesh<E>,
        materials: &impl TetMaterials,
        constraints: &Constraints,
        options: SolverOptions,
    ) -> Result<Self> {
        crate::analysis::problem::ensure_mesh_dofs(mesh, "constraints", constraints.dof_count())?;
        // Before any allocation: the rest of the solve with the least-memory solver (a factor
        // is checked once its size is known, in `LinearSolver::analyze_with_geometry`).
        let estimate = StaticEstimate::for_element(
            mesh.node_count(),
            mesh.tet_count(),
            E::NODES,
            SolverMemory::Iterative,
        );
        let path = match options.method {
            LinearMethod::Direct => RunPath::Direct,
            // Auto factors only what fits beside the dense kernels' buffers, and solves
            // iteratively otherwise.
            LinearMethod::Iterative | LinearMethod::Auto => RunPath::Iterative,
        };
        path.limits().ensure_fits_or(
            format!(
                "the static solve: {}, of which the mesh is held already",
                estimate.describe()
            ),
            estimate.beyond_mesh(),
            path.hint(),
        )?;
        materials.check_tet_count(mesh)?;
        let problem = Problem::new(mesh, constraints)?;
        Self::of_problem(problem, materials, options)
    }

    /// Assembles K of a set-up problem with `materials` and factors K_ff.
    pub fn of_problem<E: ElementType>(
        problem: Problem<'_, E>,
        materials: &impl TetMaterials,
        options: SolverOptions,
    ) -> Result<Self> {
        let mut timings = StaticTimings::default();
        (timings.pattern, timings.constraints) = problem.timings();

        let clock = Instant::now();
        let stiffness = problem.stiffness(materials)?;
        timings.assembly = clock.elapsed();

        let clock = Instant::now();
        let free_stiffness = problem.restrict(&stiffness)?;
        timings.constraints += clock.elapsed();

        let clock = Instant::now();
        let geometry = problem
            .dofs()
            .geometry_for_method(options.method, problem.mesh())?;
        let mut solver = LinearSolver::analyze_with_geometry(&free_stiffness, options, geometry)?;
        timings.symbolic = clock.elapsed();

        let clock = Instant::now();
        solver.factorize(&free_stiffness)?;
        timings.factorization = clock.elapsed();
        let likely_cause = likely_cause(materials.material_list());
        Ok(StaticSolver {
            stiffness,
            free_stiffness,
            dofs: problem.into_dofs(),
            solver,
            timings,
            likely_cause,
        })
    }

    /// Solves for the displacement under `loads`.
    pub fn solve(&mut self, loads: &Loads) -> Result<StaticSolution> {
        let forces = loads.as_slice();
        if forces.len() != self.dofs.full_count() {
            return Err(Error::invalid_parameter(
                "loads",
                format!("{} DOFs", forces.len()),
                format!(
                    "must be made for this mesh ({} DOFs)",
                    self.dofs.full_count()
                ),
            ));
        }
        let clock = Instant::now();
        // r = f − K·u_c on the free DOFs (u_c: prescribed values, zero elsewhere).
        let coupling = self.stiffness.mul(self.dofs.prescribed())?;
        let full_rhs: Vec<f64> = forces.iter().zip(&coupling).map(|(f, k)| f - k).collect();
        let rhs = self.dofs.restrict(&full_rhs)?;
        let mut free = rhs.clone();
        let info = self.solver.solve(&self.free_stiffness, &mut free)?;
        if let Some(i) = free.iter().position(|v| !v.is_finite()) {
            return Err(self.out_of_range(i, forces));
        }
        let mut relative_residual = self.relative_residual(&free, &rhs)?;
        if info == SolveInfo::Direct {
            // Iterative refinement with the same factor: u ← u + K⁻¹(r − K·u). Each step costs
            // two triangular solves and gains what the factor's accuracy allows; a step that
            // does not lower the residual is undone and ends the refinement.
            let mut refinements = 0;
            while relative_residual > RESIDUAL_LIMIT && refinements < MAX_REFINEMENTS {
                refinements += 1;
                let product = self.free_stiffness.mul(&free)?;
                let mut correction: Vec<f64> =
                    rhs.iter().zip(&product).map(|(r, ku)| r - ku).collect();
                self.solver.solve(&self.free_stiffness, &mut correction)?;
                let refined: Vec<f64> = free.iter().zip(&correction).map(|(u, d)| u + d).collect();
                let refined_residual = self.relative_residual(&refined, &rhs)?;
                if refined_residual >= relative_residual || refined_residual.is_nan() {
                    break;
                }
                free = refined;
                relative_residual = refined_residual;
            }
            if relative_residual > RESIDUAL_LIMIT {
                return Err(Error::InaccurateSolve {
                    relative_residual,
                    limit: RESIDUAL_LIMIT,
                    refinements,
                    cause: self.likely_cause.clone(),
                });
            }
        }
        let displacement = self.dofs.expand(&free)?;
        let reactions: Vec<f64> = self
            .stiffness
            .mul(&displacement)?
            .iter()
            .zip(forces)
            .enumerate()
            .map(|(dof, (ku, f))| {
                if self.dofs.free_index(dof).is_some() {
                    0.0
                } else {
                    ku - f
                }
            })
            .collect();
        self.timings.solve = clock.elapsed();
        Ok(StaticSolution {
            displacement,
            relative_residual,
            reactions,
            info,
        })
    }

    /// The error for a displacement that left the floating-point range at free DOF `free`:
    /// loads or prescribed displacements far above the stiffness (E = 1e-300 Pa under 1e200 N,
    /// a support moved by 1e308 m), named with the scales so that the user can find the unit
    /// mistake.
    fn out_of_range(&self, free: usize, forces: &[f64]) -> Error {
        let largest = |values: &[f64]| values.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let diagonal: Vec<f64> = (0..self.free_stiffness.dim())
            .map(|i| self.free_stiffness.get(i, i).unwrap_or(0.0))
            .collect();
        Error::invalid_parameter(
            "loads against stiffness",
            format!(
                "loads up to {:e} (force units) and prescribed displacements up to {:e} (length) \
                 on stiffness diagonal entries of {:e} to {:e} (force/length)",
                largest(forces),
                largest(self.dofs.prescribed()),
                diagonal.iter().copied().fold(f64::INFINITY, f64::min),
                largest(&diagonal)
            ),
            format!(
                "the displacement u = K⁻¹(f − K_fc·u_c) leaves the floating-point range (at free \
                 DOF {free}): check the scale and units of the loads, the prescribed \
                 displacements and Young's modulus"
            ),
        )
    }

    /// ‖K_ff·u_f − r_f‖ / ‖r_f‖ (‖K_ff·u_f − r_f‖ when r_f = 0).
    fn relative_residual(&self, free: &[f64], rhs: &[f64]) -> Result<f64> {
        let residual = self.free_stiffness.mul(free)?;
        let residual_norm = norm(residual.iter().zip(rhs).map(|(a, b)| a - b));
        let rhs_norm = norm(rhs.iter().copied());
        Ok(if rhs_norm > 0.0 {
            residual_norm / rhs_norm
        } else {
            residual_norm
        })
    }

    /// The assembled global stiffness K (all DOFs).
    pub fn stiffness(&self) -> &CscMatrix {
        &self.stiffness
    }

    /// K_ff, the stiffness restricted to the free DOFs.
    pub fn free_stiffness(&self) -> &CscMatrix {
        &self.free_stiffness
    }

    /// The free/constrained DOF numbering.
    pub fn dofs(&self) -> &DofMap {
        &self.dofs
    }

    /// Number of stored values of the Cholesky factor (0 when solved iteratively).
    pub fn factor_len(&self) -> usize {
        self.solver.factor_len()
    }

    /// The linear solver in use.
    pub fn linear_solver(&self) -> &LinearSolver {
        &self.solver
    }

    /// Wall time per phase so far.
    pub fn timings(&self) -> StaticTimings {
        self.timings
    }
}

/// One-shot static solve: [`StaticSolver::new`] then [`StaticSolver::solve`].
pub fn solve_static<E: ElementType>(
    mesh: &TetMesh<E>,
    materials: &impl TetMaterials,
    constraints: &Constraints,
    loads: &Loads,
) -> Result<StaticSolution> {
    StaticSolver::new(mesh, materials, constraints)?.solve(loads)
}

/// The likely cause of an inaccurate solve, from the material nearest incompressibility.
fn likely_cause(materials: &[Material]) -> String {
    let material = materials
        .iter()
        .copied()
        .reduce(|a, b| {
            if b.poisson_ratio() > a.poisson_ratio() {
                b
            } else {
                a
            }
        })
        .unwrap_or_else(Material::steel);
    let nu = material.poisson_ratio();
    let ratio = material.lame_lambda() / material.shear_modulus();
    if nu > crate::base::warning::NEARLY_INCOMPRESSIBLE_POISSON {
        format!(
            "Poisson's ratio {nu} is too close to 0.5 (λ/μ = {ratio:.1e}) for the displacement \
             solve: use the mixed displacement–pressure element on 10-node tets \
             (`solve_static_mixed`, scene key `formulation = \"mixed\"`), which solves at any \
             ν < 0.5, or ν ≤ 0.49 (linear tets lock at such ν anyway)"
        )
    } else {
        "stiffness or element sizes that differ by many orders of magnitude (see the mesh \
         quality warnings), or loads and prescribed displacements of wildly different scales"
            .to_string()
    }
}

fn norm(values: impl Iterator<Item = f64>) -> f64 {
    values.map(|v| v * v).sum::<f64>().sqrt()
}

/// Resultant of the reactions on a set of constrained DOFs: the force Σ Rᵢ and its moment
/// Σ (xᵢ − point) × Rᵢ about `point` (force and force·length units), each DOF of `dofs` counted
/// once as given. `reactions` is full length ([`StaticSolution::reactions`]: K·u − f on the
/// constrained DOFs, zero on the free ones).
///
/// Errors: `reactions` is not 3 values per node of `mesh`, or a DOF is out of range.
pub fn reaction_resultant<C: crate::mesh::CellType>(
    mesh: &TetMesh<C>,
    reactions: &[f64],
    dofs: &[usize],
    point: nalgebra::Vector3<f64>,
) -> Result<(nalgebra::Vector3<f64>, nalgebra::Vector3<f64>)> {
    Error::check_len("reactions", mesh.dof_count(), reactions.len())?;
    let mut force = nalgebra::Vector3::zeros();
    let mut moment = nalgebra::Vector3::zeros();
    for &dof in dofs {
        let value = *reactions.get(dof).ok_or(Error::UnknownNode {
            context: "reaction resultant",
            node: dof / 3,
            node_count: mesh.node_count(),
        })?;
        let mut component = nalgebra::Vector3::zeros();
        component[dof % 3] = value;
        force += component;
        moment += (mesh.nodes()[dof / 3] - point).cross(&component);
    }
    Ok((force, moment))
}
