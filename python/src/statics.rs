//! Static equilibrium from Python: `tetfem.solve_static` (linear, or Newton with a nonlinear
//! force model), `tetfem.StaticSolver` (factor once, solve many load cases; K and K_ff) and the
//! `tetfem.StaticResult` they return.

use std::sync::{Arc, Mutex, MutexGuard, TryLockError};

use nalgebra::Matrix3;
use numpy::{PyArray1, PyArrayMethods};
use pyo3::prelude::*;
use tetfem::analysis::nonlinear::NewtonOptions;
use tetfem::analysis::statics::{StaticSolution, StaticSolver};
use tetfem::analysis::{Definition, Static, StaticOptions, StaticPath, static_load_of};
use tetfem::bc::constraints::DofMap;
use tetfem::fe::materials::MaterialMap;
use tetfem::linalg::linear_solver::{SolveInfo, SolverOptions};
use tetfem::post::output::fields::cell_stress;

use crate::arrays::{self, index_vector};
use crate::constraints::PyConstraints;
use crate::contact::{PyObstacle, contact_of};
use crate::errors::{OrRaise, invalid, raise};
use crate::interrupt::detach_interruptible;
use crate::loads::PyLoads;
use crate::material::materials_of;
use crate::mesh::{MeshData, PyMesh, on_cells};
use crate::names;
use crate::sparse::csr;

/// The result of a static solve. Units SI as given (m, Pa, N).
///
/// Attributes: ``displacement`` (n, 3) m; ``stress`` (m, 3, 3) Cauchy stress per tet, Pa;
/// ``von_mises`` (m,) Pa; ``reactions`` (n, 3) N (K·u − f for the linear model, −(Σₑ fₑ(u) +
/// f) for the nonlinear ones; non-zero on constrained DOFs only); ``contact_forces`` (o, 3) N
/// with obstacles (else None); ``relative_residual`` ‖K_ff·u_f − r_f‖/‖r_f‖ (for nonlinear
/// models the final Newton residual ‖r_f‖ over the load norm ‖f_f‖, or ‖r_f‖ in N when there
/// is no load); ``model``; ``solver`` (``"direct"`` or ``"iterative (k iterations)"``,
/// ``"newton (k iterations)"``).
#[pyclass(name = "StaticResult", module = "tetfem", frozen, get_all)]
pub struct StaticResult {
    /// Displacement of every node, shape (n, 3), m.
    displacement: Py<PyAny>,
    /// Cauchy stress of every tet, shape (m, 3, 3), Pa.
    stress: Py<PyAny>,
    /// Von Mises stress of every tet, shape (m,), Pa.
    von_mises: Py<PyAny>,
    /// Reaction forces, shape (n, 3), N: K·u − f for the linear model, −(Σₑ fₑ(u) + f) for
    /// the nonlinear ones; non-zero on constrained DOFs only.
    reactions: Py<PyAny>,
    /// With obstacles: the force the body exerts on each (barrier plus friction), shape
    /// (o, 3), N, in the order given; None without obstacles.
    contact_forces: Option<Py<PyAny>>,
    /// Relative residual of the solve (dimensionless).
    relative_residual: f64,
    /// The force model that ran.
    model: String,
    /// How the equations were solved.
    solver: String,
}

#[pymethods]
impl StaticResult {
    /// The mean displacement of ``nodes`` (m), shape (3,): the probe of scenes.
    fn mean_displacement<'py>(
        &self,
        py: Python<'py>,
        nodes: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let (nodes, _) = arrays::indices(py, nodes, "nodes", None)?;
        let u = self.displacement.bind(py);
        u.get_item((nodes.iter().map(|&n| n as i64).collect::<Vec<_>>(),))?
            .call_method1("mean", (0,))
    }

    fn __repr__(&self) -> String {
        format!(
            "StaticResult(model={}, solver={}, relative_residual={:e})",
            self.model, self.solver, self.relative_residual
        )
    }
}

/// The stresses (m, 3, 3) and von Mises stresses (m,) of tets as numpy arrays.
fn stress_arrays(py: Python<'_>, stress: &[Matrix3<f64>]) -> PyResult<(Py<PyAny>, Py<PyAny>)> {
    let flat: Vec<f64> = stress
        .iter()
        .flat_map(|s| (0..3).flat_map(move |i| (0..3).map(move |j| s[(i, j)])))
        .collect();
    let von_mises: Vec<f64> = stress.iter().map(tetfem::fe::element::von_mises).collect();
    let stress = PyArray1::from_vec(py, flat).reshape([stress.len(), 3, 3])?;
    Ok((
        stress.into_any().unbind(),
        arrays::vector(py, von_mises).unbind(),
    ))
}

fn solver_text(info: &SolveInfo) -> String {
    match info {
        SolveInfo::Direct => "direct".into(),
        SolveInfo::Iterative { iterations, .. } => format!("iterative ({iterations} iterations)"),
    }
}

/// The result of a linear solve, with its stresses.
fn linear_result(
    py: Python<'_>,
    data: &MeshData,
    materials: &MaterialMap,
    solution: StaticSolution,
) -> PyResult<StaticResult> {
    let stress = py
        .detach(|| on_cells!(&data.mesh, m => cell_stress(m, materials, &solution.displacement)))
        .or_raise(py)?;
    let (stress, von_mises) = stress_arrays(py, &stress)?;
    Ok(StaticResult {
        displacement: arrays::rows3(py, solution.displacement)?.unbind(),
        stress,
        von_mises,
        reactions: arrays::rows3(py, solution.reactions)?.unbind(),
        relative_residual: solution.relative_residual,
        model: "linear".into(),
        contact_forces: None,
        solver: solver_text(&solution.info),
    })
}

/// An `InvalidInputError` unless `constraints` and `loads` were made on `mesh`.
pub fn check_same_mesh(
    py: Python<'_>,
    mesh: &Arc<MeshData>,
    constraints: &PyConstraints,
    loads: Option<&PyLoads>,
) -> PyResult<()> {
    let other = |what: &str| {
        raise(
            py,
            "InvalidInputError",
            format!(
                "{what} were made for another mesh: make them with this mesh (Constraints(mesh), Loads(mesh))"
            ),
        )
    };
    if !Arc::ptr_eq(mesh, &constraints.data) {
        return Err(other("the constraints"));
    }
    if let Some(loads) = loads
        && !Arc::ptr_eq(mesh, &loads.data)
    {
        return Err(other("the loads"));
    }
    Ok(())
}

/// Static equilibrium. ``material``: a ``Material`` or a ``MaterialMap``. ``model``:
/// ``"linear"`` (one sparse solve: ``linear_solver`` ``"auto"`` picks the Cholesky factorization
/// or multigrid-preconditioned CG by predicted time, ``"direct"`` / ``"iterative"`` force one),
/// or a nonlinear model ``"corotational"`` / ``"neo-hookean"`` / ``"st-venant-kirchhoff"``
/// (each material its own) solved by Newton's method in ``load_steps`` increments with at most
/// ``max_iterations`` per step; or a list of these names, one per material of ``material`` (a
/// ``MaterialMap``'s, in its order): each material region its own model, e.g. a linear body
/// beside a Neo-Hookean one (Newton unless every one is ``"linear"``; ``model`` in the result
/// is then ``"per-material"`` where they differ). ``obstacles``: a list of ``Obstacle`` the body may touch (with
/// their friction); with any, every model (the linear one too) is solved by Newton with the
/// contact barrier, of activation distance ``contact_distance`` (length; default 1e-3 × the
/// bounding-box diagonal) and stiffness ``contact_stiffness`` (Pa/m; default E/h of the
/// stiffest material), and ``contact_forces`` gives the force on each. Which path runs is the
/// library's one dispatch (``tetfem::analysis::Static``), as in scenes (obstacles on either
/// element order, with moving supports too). Loads and prescribed motions with an
/// ``amplitude`` enter at their value at the pseudo-time t = 1 (``STATIC_TIME``), summed by the
/// library (gravity's ρ from ``material``, as in a ``Simulation``); a nonlinear
/// solve's load steps follow the motions (rigid ones by exact rotations). ``self_contact=True``:
/// the surface barrier between the bodies of a ``Mesh.bodies`` mesh and inside each (as in
/// ``Simulation``), solved by Newton in the load steps; a body the supports leave free must
/// start within the barrier's d̂ of the one it rests on (``self_contact_friction`` > 0 raises:
/// nothing in a static solve lags friction between bodies).
/// ``tolerance``: the relative residual asked for, ‖r_f‖ ≤
/// ``tolerance``·‖f_f‖ (the linear solve's ‖K_ff·u_f − r_f‖/‖r_f‖, or Newton's residual over
/// the load); a solve that ends above it raises ``SolverError`` naming the tolerance and the
/// residual reached (a tolerance below double precision's floor for the matrix cannot be
/// met). ``None`` (the default): the library's own acceptance (Newton to 1e-10 or its
/// round-off floor, CG to 1e-10 or its rounding floor, the direct solve refined to 1e-8),
/// the residual reached in ``relative_residual``. The work runs with the GIL released; Ctrl-C
/// raises ``KeyboardInterrupt`` between two iterations. Raises ``NotConstrainedError`` when
/// the constraints leave a rigid-body motion, ``SolverError`` when the solve fails.
#[pyfunction]
#[pyo3(signature = (mesh, material, constraints, loads, model = names::ModelArg::default(), linear_solver = "auto", load_steps = 10, tolerance = None, max_iterations = 30, obstacles = None, contact_distance = None, contact_stiffness = None, self_contact = false, self_contact_distance = None, self_contact_stiffness = None, self_contact_friction = 0.0))]
#[allow(clippy::too_many_arguments)]
pub fn solve_static(
    py: Python<'_>,
    mesh: &Bound<'_, PyMesh>,
    material: &Bound<'_, PyAny>,
    constraints: PyRef<'_, PyConstraints>,
    loads: PyRef<'_, PyLoads>,
    model: names::ModelArg,
    linear_solver: &str,
    load_steps: usize,
    tolerance: Option<f64>,
    max_iterations: usize,
    obstacles: Option<Vec<PyRef<'_, PyObstacle>>>,
    contact_distance: Option<f64>,
    contact_stiffness: Option<f64>,
    self_contact: bool,
    self_contact_distance: Option<f64>,
    self_contact_stiffness: Option<f64>,
    self_contact_friction: f64,
) -> PyResult<StaticResult> {
    let data = &mesh.get().data;
    check_same_mesh(py, data, &constraints, Some(&loads))?;
    let materials = materials_of(py, material, data)?;
    let (kind, region_models) = names::models(py, &model)?;
    let method = names::linear_solver(py, linear_solver)?;
    if let Some(t) = tolerance.filter(|t| !(t.is_finite() && *t > 0.0 && *t < 1.0)) {
        return Err(invalid(
            py,
            "tolerance",
            t,
            "must be finite, > 0 and < 1 (or None)",
        ));
    }
    let contact = contact_of(
        py,
        data,
        &materials,
        obstacles,
        (contact_distance, contact_stiffness),
        None,
    )?;
    let surface = match self_contact {
        true => Some(crate::bodies::surface_contact_of(
            py,
            (&data.mesh, data.bodies.as_ref()),
            &materials,
            (self_contact_distance, self_contact_stiffness),
            self_contact_friction,
        )?),
        false => None,
    };
    let mut linear = SolverOptions {
        method,
        ..SolverOptions::default()
    };
    if let Some(t) = tolerance {
        // CG accepts a true residual up to 10× its tolerance (its recursive residual
        // drifts): a tenth of the one asked for, so that it stops at or below it.
        linear.cg.relative_tolerance = t / 10.0;
    }
    let newton = NewtonOptions {
        load_steps,
        tolerance: tolerance.unwrap_or(NewtonOptions::default().tolerance),
        max_iterations,
        ..NewtonOptions::default()
    };
    let motions = &constraints.motions;
    let time_data = crate::timed::time_data(Some(&loads), &constraints);
    let constraints = &constraints.constraints;
    let (other, gravity) = (&loads.other, loads.gravity);
    let has_contact = contact.is_some();
    let options = StaticOptions { linear, newton };
    let (solved, stress, load, model_name) = detach_interruptible(py, || -> tetfem::Result<_> {
        on_cells!(&data.mesh, mesh => {
            // The loads as the library sums them (Definition::static_load: constant loads,
            // gravity, amplitude loads at STATIC_TIME), not `loads.all`.
            let mut builder = Definition::builder(mesh.clone(), materials.clone())
                .model(kind)
                .constraints(constraints.clone())?
                .loads(other.clone())?
                .gravity(gravity)?
                .time_data(time_data)
                .motions(motions.clone());
            if let Some(contact) = contact {
                builder = builder.contact(contact);
            }
            if let Some((barrier, body_of_node)) = surface {
                builder = builder.surface_contact(barrier, body_of_node)?;
            }
            if let Some(kinds) = region_models {
                builder = builder.region_models(kinds)?;
            }
            let definition = builder.build()?;
            // The library's one dispatch, as in scenes; the stress is the model's own (the
            // linear one's straight from u).
            let analysis = Static::new(&definition, options)?;
            let solved = analysis.solve()?;
            let stress = analysis.stresses(&solved.displacement)?;
            // The map's name: the one model's, or `per-material` for a list of several.
            let name = analysis.model().name();
            Ok((solved, stress, definition.static_load()?, name))
        })
    })?;
    let (solver, reached) = match &solved.path {
        StaticPath::Linear { info, .. } => (solver_text(info), solved.relative_residual),
        StaticPath::Newton {
            residuals,
            iterations,
        } => {
            // Against Newton's own reference: the load, or without one (prescribed
            // displacements only) the last load step's first residual.
            let last_step = residuals.last().map_or(&[][..], Vec::as_slice);
            let free_load = DofMap::new(constraints)
                .restrict(load.as_slice())
                .or_raise(py)?;
            let loaded = free_load.iter().any(|f| *f != 0.0);
            let reached = match (loaded, last_step.first(), last_step.last()) {
                (false, Some(&first), Some(&last)) => last / first.max(f64::MIN_POSITIVE),
                _ => solved.relative_residual,
            };
            (format!("newton ({iterations} iterations)"), reached)
        }
    };
    check_tolerance(py, tolerance, reached, &solver)?;
    let (stress, von_mises) = stress_arrays(py, &stress)?;
    let contact_forces = match has_contact {
        true => {
            let flat: Vec<f64> = solved
                .obstacle_forces
                .iter()
                .flat_map(|f| [f.x, f.y, f.z])
                .collect();
            Some(arrays::rows3(py, flat)?.unbind())
        }
        false => None,
    };
    Ok(StaticResult {
        solver,
        displacement: arrays::rows3(py, solved.displacement)?.unbind(),
        stress,
        von_mises,
        reactions: arrays::rows3(py, solved.reactions)?.unbind(),
        relative_residual: solved.relative_residual,
        model: model_name.into(),
        contact_forces,
    })
}

/// `SolverError` when a solve asked for `tolerance` ended at a relative residual `reached`
/// above it (`solver`: how it solved, for the message).
fn check_tolerance(
    py: Python<'_>,
    tolerance: Option<f64>,
    reached: f64,
    solver: &str,
) -> PyResult<()> {
    match tolerance {
        Some(t) if reached > t || reached.is_nan() => Err(raise(
            py,
            "SolverError",
            format!(
                "the static solve did not reach tolerance = {t:e}: its relative residual is \
                 {reached:.3e} ({solver}); a tolerance below the rounding floor of double \
                 precision for this matrix (about machine epsilon × its condition number) \
                 cannot be met: ask for {reached:.1e} or more, or leave tolerance = None for \
                 the library's own acceptance"
            ),
        )),
        _ => Ok(()),
    }
}

/// A factored linear static problem: K assembled and K_ff factored once (GIL released), then
/// ``solve(loads)`` for any number of load cases. ``stiffness()`` and ``free_stiffness()``
/// give K (all DOFs, N/m) and K_ff (free DOFs, in the order of ``free_dofs``) as SciPy CSR
/// matrices (or ``(indptr, indices, data, shape)`` without SciPy). While ``solve`` works in one
/// thread, calls from other threads raise ``TetfemError`` (busy).
#[pyclass(name = "StaticSolver", module = "tetfem", frozen)]
pub struct PyStaticSolver {
    data: Arc<MeshData>,
    materials: MaterialMap,
    /// Locked by each call (`try_lock` only: a call never waits while holding the GIL).
    solver: Mutex<StaticSolver>,
}

impl PyStaticSolver {
    /// The solver, or `TetfemError` (busy) while another thread's `solve` uses it.
    fn solver(&self, py: Python<'_>) -> PyResult<MutexGuard<'_, StaticSolver>> {
        match self.solver.try_lock() {
            Ok(guard) => Ok(guard),
            Err(TryLockError::WouldBlock) => Err(raise(
                py,
                "TetfemError",
                "StaticSolver is busy: solve() is running in another thread; wait for it to \
                 return, or use one StaticSolver per thread"
                    .into(),
            )),
            Err(TryLockError::Poisoned(_)) => Err(raise(
                py,
                "TetfemError",
                "StaticSolver is unusable: a solve panicked part-way (a bug: please report it)"
                    .into(),
            )),
        }
    }
}

#[pymethods]
impl PyStaticSolver {
    #[new]
    #[pyo3(signature = (mesh, material, constraints, linear_solver = "auto"))]
    fn new(
        py: Python<'_>,
        mesh: &Bound<'_, PyMesh>,
        material: &Bound<'_, PyAny>,
        constraints: PyRef<'_, PyConstraints>,
        linear_solver: &str,
    ) -> PyResult<Self> {
        let data = Arc::clone(&mesh.get().data);
        check_same_mesh(py, &data, &constraints, None)?;
        let materials = materials_of(py, material, &data)?;
        let options = SolverOptions {
            method: names::linear_solver(py, linear_solver)?,
            ..SolverOptions::default()
        };
        let c = &constraints.constraints;
        let solver = py
            .detach(|| on_cells!(&data.mesh, m => StaticSolver::with_options(m, &materials, c, options)))
            .or_raise(py)?;
        Ok(PyStaticSolver {
            data,
            materials,
            solver: Mutex::new(solver),
        })
    }

    /// The displacement under ``loads`` (a ``StaticResult``; GIL released).
    fn solve(&self, py: Python<'_>, loads: PyRef<'_, PyLoads>) -> PyResult<StaticResult> {
        if !Arc::ptr_eq(&self.data, &loads.data) {
            return Err(raise(
                py,
                "InvalidInputError",
                "the loads were made for another mesh: make them with Loads(mesh) of this solver's mesh".into(),
            ));
        }
        let mut solver = self.solver(py)?;
        let solver = &mut *solver;
        // The library's sum of the loads (as a static analysis takes it), not `loads.all`;
        // gravity's ρ is this solver's material's.
        let time_data = tetfem::analysis::dynamics::TimeData {
            loads: loads.timed.clone(),
            ..Default::default()
        };
        let (other, gravity, materials) = (&loads.other, loads.gravity, &self.materials);
        let solution = detach_interruptible(py, || {
            let load = on_cells!(&self.data.mesh, m => static_load_of(m, materials, other, gravity, &time_data))?;
            solver.solve(&load)
        })?;
        linear_result(py, &self.data, &self.materials, solution)
    }

    /// The stiffness matrix K of all DOFs (3·node + axis), N/m.
    fn stiffness<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        csr(py, self.solver(py)?.stiffness())
    }

    /// The stiffness matrix K_ff of the free DOFs (rows and columns in ``free_dofs`` order), N/m.
    fn free_stiffness<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        csr(py, self.solver(py)?.free_stiffness())
    }

    /// The free DOFs (3·node + axis), ascending int64 array: row i of K_ff is DOF free_dofs[i].
    #[getter]
    fn free_dofs<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        Ok(index_vector(py, self.solver(py)?.dofs().free_dofs()))
    }

    /// Stored values of the Cholesky factor (0 on the iterative path).
    #[getter]
    fn factor_len(&self, py: Python<'_>) -> PyResult<usize> {
        Ok(self.solver(py)?.factor_len())
    }
}
