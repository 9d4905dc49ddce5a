//! `tetfem.Simulation`: time integration of M·ü + C·u̇ + K·u = f (or a nonlinear force model)
//! with any of the library's methods, stepped from Python with the GIL released.

use std::path::PathBuf;
use std::sync::{Arc, Mutex, MutexGuard, TryLockError};
use std::thread::ThreadId;

use pyo3::prelude::*;
use pyo3::types::PyDict;
use tetfem::analysis::Definition;
use tetfem::analysis::dynamics::{
    Checkpoint, Energy, IntegratorHistory, IntegratorOptions, InternalForce, LinearSystem, Mass,
    NewtonStats, Rayleigh, State, StepNewtonOptions,
};
use tetfem::analysis::transient::{
    AdaptiveStep, Flow, Observer, StepView, Transient, TransientOptions, critical_step,
};
use tetfem::bc::loads::Loads;
use tetfem::fe::materials::MaterialMap;

use crate::arrays;
use crate::constraints::PyConstraints;
use crate::contact::{PyObstacle, contact_of};
use crate::errors::{OrRaise, invalid, raise};
use crate::interrupt::detach_interruptible;
use crate::loads::PyLoads;
use crate::material::materials_of;
use crate::mesh::{MeshData, PyMesh, on_cells};
use crate::modal::{ModalResult, modes_of};
use crate::names;
use crate::sparse::{csr, diagonal};
use crate::statics::check_same_mesh;

/// Energies as a dict: kinetic, elastic, gravity_potential, load_potential, total (J).
fn energy_dict<'py>(py: Python<'py>, e: &Energy) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("kinetic", e.kinetic)?;
    d.set_item("elastic", e.elastic)?;
    d.set_item("gravity_potential", e.gravity_potential)?;
    d.set_item("load_potential", e.load_potential)?;
    d.set_item("total", e.total())?;
    Ok(d)
}

/// A dynamic run (``damping`` defaults to (0.0, 0.0): none). ``method``: ``"backward-euler"`` (implicit, first order, stable at any step,
/// dissipative), ``"newmark"`` (average acceleration: implicit, second order, conserves energy)
/// or ``"explicit"`` (symplectic Euler: stable only below ``critical_time_step``). ``dt``: the
/// time step in s, or a multiple of the explicit critical step as text (``"0.9crit"``).
/// ``model``: ``"linear"``, ``"corotational"``, ``"neo-hookean"`` or ``"st-venant-kirchhoff"``
/// (each material its own; the implicit methods then iterate Newton per step), or a list of
/// these, one per material of ``material`` (a ``MaterialMap``'s, in its order): each region its
/// own model, e.g. a linear block meeting a Neo-Hookean one (``model`` then reads
/// ``"per-material"`` where they differ). ``mass``: ``"lumped"`` or ``"consistent"``. ``damping``: Rayleigh
/// (α in 1/s, β in s), C = α·M + β·K. ``loads``: gravity is tracked as its own potential, the
/// other loads are constant, those added with an ``amplitude`` follow it in time (and
/// ``Constraints`` with an ``amplitude`` or ``prescribe_rigid`` move the supports), as the
/// scene runner's ``TimeData``. The run starts at time 0 from ``initial_displacement`` (n, 3), m
/// (default zero) and ``initial_velocity`` (3,) or (n, 3), m/s (default zero); both are taken on
/// the free DOFs. ``linear_solver`` (implicit methods): ``"auto"``, ``"direct"`` or
/// ``"iterative"``. With a nonlinear model (implicit methods), ``nonlinear_solver``: how each
/// Newton iteration solves, ``"auto"`` (default), ``"rest_lbfgs"``, ``"rest_preconditioned"`` or
/// ``"refactor"`` (the scenes' ``analysis.nonlinear_solver``), and ``newton_tolerance`` each
/// step's tolerance, ‖r‖ ≤ t·max(‖r₀‖, ‖f‖), 0 < t < 1 (default 1e-8; ``analysis.newton_tolerance``).
/// ``relax_contact_nodes`` (default True; ``analysis.relax_contact_nodes``): with obstacles,
/// each node in contact moved to its own barrier's and friction's minimum after every Newton
/// step (the same solution in fewer iterations). ``contact_impact_fraction`` f (0 < f < 1, default off; the scenes'
/// ``[contact] impact_fraction``): the obstacles' impact-aware barrier stiffness of the
/// implicit methods, each landing node its own κᵢ = max(κ, mᵢ·vₙ²/(2·Aᵢ·b(f·d̂))) (Pa/m) so
/// that it stops near f·d̂, where a step resolves the impact. ``self_contact=True`` puts the
/// surface barrier between the bodies of a ``Mesh.bodies`` mesh and inside each (body–body and
/// self-contact: no iterate intersects); ``self_contact_distance`` is its d̂ (m, default a
/// tenth of the shortest surface edge at rest) and ``self_contact_stiffness`` its κ (J/m², default the stiffest E times the mean surface
/// edge), ``self_contact_friction`` Coulomb's μ between the surfaces (lagged per step of
/// backward Euler and Newmark; the explicit method refuses μ > 0); the methods that carry it
/// are the library's rule (others raise naming it). Give
/// each body its own velocity with ``initial_velocity=v[mesh.body_of_node]``. Steps run with the GIL released; Ctrl-C stops ``run`` and ``step`` with
/// ``KeyboardInterrupt`` between steps or inside a step's iterations, the state left at the
/// last completed step. While ``run`` or ``step`` works in one thread, every call from another
/// thread raises ``TetfemError`` ("busy"): use one Simulation per thread.
#[pyclass(name = "Simulation", module = "tetfem", frozen)]
pub struct PySimulation {
    data: Arc<MeshData>,
    materials: MaterialMap,
    system: Arc<LinearSystem>,
    force: InternalForce,
    /// The method's name (the integrator's, kept here so that it reads without the lock).
    method: &'static str,
    /// The support reactions' inputs (see `reactions`).
    reactions: crate::sim_reactions::Reactions,
    /// The integrator and the state, locked by each call that reads or steps them (with
    /// `try_lock` only: a call never waits for a step, so no thread waits for the lock while
    /// holding the GIL that the stepping thread needs).
    stepping: Mutex<Stepping>,
    /// The thread whose `run` or `step` is in progress: calls from other threads are refused
    /// for its whole duration, also between its steps (while its callback runs), so that two
    /// runs never interleave their steps.
    runner: Mutex<Option<ThreadId>>,
    /// What `run`'s callback reads: the state after the step it is called for (set by the
    /// run's observer before each call, cleared when the run returns). The library's loop holds
    /// `stepping` for the whole run, so reads from the callback (the runner's thread) come
    /// from here.
    seen: Mutex<Option<Arc<Seen>>>,
}

/// The run as its callback sees it after a step: the state, the time step and what the
/// integrator carries (for a checkpoint taken in the callback; `None` if it takes none).
struct Seen {
    state: State,
    dt: f64,
    history: Option<IntegratorHistory>,
    newton: Option<NewtonStats>,
}

/// The integrator and state for a read: the run's own when no run holds them, else (inside
/// `run`'s callback) what the callback was called after.
enum Reading<'a> {
    Live(MutexGuard<'a, Stepping>),
    Seen(Arc<Seen>),
}

impl Reading<'_> {
    fn state(&self) -> &State {
        match self {
            Reading::Live(guard) => guard.state(),
            Reading::Seen(seen) => &seen.state,
        }
    }

    fn dt(&self) -> f64 {
        match self {
            Reading::Live(guard) => guard.dt(),
            Reading::Seen(seen) => seen.dt,
        }
    }

    fn newton_stats(&self) -> Option<NewtonStats> {
        match self {
            Reading::Live(guard) => guard.integrator().newton_stats(),
            Reading::Seen(seen) => seen.newton,
        }
    }

    /// The checkpoint of this state (see `Simulation.checkpoint`) under `fingerprint`.
    fn checkpoint(
        &self,
        method: &str,
        fingerprint: Vec<(String, String)>,
    ) -> tetfem::Result<Checkpoint> {
        match self {
            Reading::Live(guard) => {
                Checkpoint::take(guard.integrator(), guard.state(), fingerprint, Vec::new())
            }
            Reading::Seen(seen) => Ok(Checkpoint {
                state: seen.state.clone(),
                dt: seen.dt,
                history: seen.history.clone().ok_or_else(|| {
                    tetfem::Error::invalid_parameter(
                        "method",
                        method,
                        "this integrator does not take or restore checkpoints",
                    )
                })?,
                fingerprint,
                records: Vec::new(),
            }),
        }
    }
}

/// `Simulation.run`'s observer of the library's time loop: after each step, the energy row;
/// with a callback, the state it may read ([`PySimulation::seen`]) and the call (attached to
/// the interpreter), whose `False` stops the run and whose exception is kept for the caller
/// (the run then stops at that step).
struct RunObserver<'a> {
    sim: &'a PySimulation,
    this: &'a Py<PySimulation>,
    callback: Option<&'a Py<PyAny>>,
    counts: Vec<usize>,
    /// time, kinetic, elastic, gravity_potential, load_potential, total.
    columns: [Vec<f64>; 6],
    /// The exception the callback raised.
    raised: Option<PyErr>,
}

impl Observer for RunObserver<'_> {
    fn observe(&mut self, view: &StepView<'_>) -> tetfem::Result<Flow> {
        let state = view.state;
        let energy = self.sim.force.energy(&self.sim.system, state)?;
        self.counts.push(state.steps);
        let row = [
            state.time,
            energy.kinetic,
            energy.elastic,
            energy.gravity_potential,
            energy.load_potential,
            energy.total(),
        ];
        for (column, value) in self.columns.iter_mut().zip(row) {
            column.push(value);
        }
        if let Some(callback) = self.callback {
            *lock_ignoring_poison(&self.sim.seen) = Some(Arc::new(Seen {
                state: state.clone(),
                dt: view.integrator.time_step(),
                history: view.integrator.history().ok(),
                newton: view.integrator.newton_stats(),
            }));
            let this = self.this;
            let answer = Python::attach(|py| -> PyResult<bool> {
                let answer = callback.bind(py).call1((this.bind(py),))?;
                Ok(answer.is(pyo3::types::PyBool::new(py, false).as_any()))
            });
            match answer {
                Ok(false) => {}
                Ok(true) => return Ok(Flow::Stop),
                Err(error) => {
                    self.raised = Some(error);
                    return Ok(Flow::Stop);
                }
            }
        }
        // Ctrl-C between steps (inside a step the solvers poll it themselves).
        if view.step < view.last {
            tetfem::linalg::interrupt::poll(|| {
                format!("Simulation.run after step {}", state.steps)
            })?;
        }
        Ok(Flow::Continue)
    }
}

/// What a step changes: the library's transient run (its integrator's factor and history,
/// and the state).
type Stepping = Transient;

/// Marks the current thread as the Simulation's runner until dropped, then restores the
/// runner before it (a `run` inside a callback of the same thread's `run` nests).
struct RunnerGuard<'a> {
    runner: &'a Mutex<Option<ThreadId>>,
    previous: Option<ThreadId>,
}

impl Drop for RunnerGuard<'_> {
    fn drop(&mut self) {
        *lock_ignoring_poison(self.runner) = self.previous;
    }
}

/// The runner slot's lock. It is held for a read or a write of the slot only (never across a
/// call), so waiting for it is short and cannot deadlock; a panic cannot leave the slot half
/// written (an `Option<ThreadId>` is written whole), so a poisoned lock is still valid.
fn lock_ignoring_poison<T>(mutex: &Mutex<T>) -> MutexGuard<'_, T> {
    mutex
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// The `TetfemError` of a call made while another thread runs the Simulation.
fn busy(py: Python<'_>, what: &str) -> PyErr {
    raise(
        py,
        "TetfemError",
        format!(
            "Simulation is busy: {what} is running in another thread; wait for it to return \
             (read the state from run's callback meanwhile), or use one Simulation per thread"
        ),
    )
}

impl PySimulation {
    /// The explicit critical step (s): the library's one policy, as the scene runner's.
    fn critical(
        system: &LinearSystem,
        data: &MeshData,
        materials: &MaterialMap,
    ) -> tetfem::Result<f64> {
        Ok(on_cells!(&data.mesh, m => critical_step(system, m, materials))?.dt)
    }

    /// What a checkpoint of this run stores to recognise it: the method, the model and the
    /// free DOF count.
    fn fingerprint(&self, state: &State) -> Vec<(String, String)> {
        vec![
            ("method".into(), self.method.into()),
            ("model".into(), self.model().into()),
            ("free DOFs".into(), state.displacement.len().to_string()),
        ]
    }

    /// The integrator and the state, for a call of this thread: `TetfemError` (busy) when
    /// another thread's `run` or `step` is in progress.
    /// Inside `run`'s callback (this thread's run holds the lock), the `TetfemError` of a call
    /// that would change or step the Simulation.
    fn stepping(&self, py: Python<'_>) -> PyResult<MutexGuard<'_, Stepping>> {
        match self.try_stepping(py)? {
            Some(guard) => Ok(guard),
            None if lock_ignoring_poison(&self.seen).is_some() => Err(raise(
                py,
                "TetfemError",
                "Simulation.run's callback reads the state after each step but cannot change \
                 or step the Simulation: return False to stop the run, then change it"
                    .into(),
            )),
            // A step is in progress: another thread's that started after the runner check,
            // or this thread's own when a Python signal handler calls back in during it.
            None => Err(busy(py, "a step")),
        }
    }

    /// The integrator and state to read: as [`stepping`](Self::stepping), but inside `run`'s
    /// callback the state the callback was called after.
    fn reading(&self, py: Python<'_>) -> PyResult<Reading<'_>> {
        if let Some(guard) = self.try_stepping(py)? {
            return Ok(Reading::Live(guard));
        }
        match lock_ignoring_poison(&self.seen).clone() {
            Some(seen) => Ok(Reading::Seen(seen)),
            None => Err(busy(py, "a step")),
        }
    }

    /// The lock of the integrator and the state if free (`None`: held, by a step or this
    /// thread's run); `TetfemError` (busy) when another thread's `run` or `step` is in progress.
    fn try_stepping(&self, py: Python<'_>) -> PyResult<Option<MutexGuard<'_, Stepping>>> {
        let current = std::thread::current().id();
        if lock_ignoring_poison(&self.runner).is_some_and(|runner| runner != current) {
            return Err(busy(py, "run() or step()"));
        }
        match self.stepping.try_lock() {
            Ok(guard) => Ok(Some(guard)),
            Err(TryLockError::WouldBlock) => Ok(None),
            Err(TryLockError::Poisoned(_)) => Err(raise(
                py,
                "TetfemError",
                "Simulation is unusable: a step panicked part-way (a bug: please report it)".into(),
            )),
        }
    }

    /// Marks this thread as the runner (see [`RunnerGuard`]): `TetfemError` (busy) when
    /// another thread is.
    fn claim(&self, py: Python<'_>) -> PyResult<RunnerGuard<'_>> {
        let current = std::thread::current().id();
        let mut runner = lock_ignoring_poison(&self.runner);
        if runner.is_some_and(|other| other != current) {
            return Err(busy(py, "run() or step()"));
        }
        let previous = runner.replace(current);
        Ok(RunnerGuard {
            runner: &self.runner,
            previous,
        })
    }

    /// One step and `after` of the state it leaves, with the GIL released and Ctrl-C honoured
    /// inside (see [`detach_interruptible`]); with the time and step count after it.
    fn advance<T: Send>(
        &self,
        py: Python<'_>,
        after: impl Send + FnOnce(&State) -> tetfem::Result<T>,
    ) -> PyResult<(T, f64, usize)> {
        let mut guard = self.stepping(py)?;
        let transient = &mut *guard;
        let value = detach_interruptible(py, || {
            transient.step()?;
            after(transient.state())
        })?;
        let state = transient.state();
        Ok((value, state.time, state.steps))
    }

    /// The free-DOF entries of `value`, given as (3,) for every node or (n, 3), finite.
    fn free_values(
        &self,
        py: Python<'_>,
        value: &Bound<'_, PyAny>,
        name: &str,
    ) -> PyResult<Vec<f64>> {
        let values = arrays::rows_per_item(py, value, name, self.data.mesh.node_count())?;
        self.system.dofs().restrict(&values).or_raise(py)
    }

    /// A free-DOF vector as an (n, 3) array over all nodes, zero on constrained DOFs.
    fn scatter<'py>(&self, py: Python<'py>, free: &[f64]) -> PyResult<Bound<'py, PyAny>> {
        let mut full = vec![0.0; self.data.mesh.dof_count()];
        for (&dof, &v) in self.system.dofs().free_dofs().iter().zip(free) {
            full[dof] = v;
        }
        arrays::rows3(py, full)
    }
}

/// The Newton settings of the implicit steps: the library's defaults with `tolerance` (when
/// given) and the contact nodes' relaxation, checked by the library
/// ([`StepNewtonOptions::check`]) whatever the model.
fn newton_options(
    py: Python<'_>,
    tolerance: Option<f64>,
    relax_contact_nodes: bool,
) -> PyResult<StepNewtonOptions> {
    let default = StepNewtonOptions::default();
    let options = StepNewtonOptions {
        tolerance: tolerance.unwrap_or(default.tolerance),
        relax_contact_nodes,
        ..default
    };
    options.check().or_raise(py)?;
    Ok(options)
}

#[pymethods]
impl PySimulation {
    #[new]
    #[pyo3(signature = (mesh, material, constraints, loads = None, *, dt, method = "backward-euler", model = names::ModelArg::default(), mass = "lumped", damping = (0.0, 0.0), initial_displacement = None, initial_velocity = None, linear_solver = "auto", nonlinear_solver = "auto", newton_tolerance = None, relax_contact_nodes = true, obstacles = None, contact_distance = None, contact_stiffness = None, contact_impact_fraction = None, self_contact = false, self_contact_distance = None, self_contact_stiffness = None, self_contact_friction = 0.0))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        py: Python<'_>,
        mesh: &Bound<'_, PyMesh>,
        material: &Bound<'_, PyAny>,
        constraints: PyRef<'_, PyConstraints>,
        loads: Option<PyRef<'_, PyLoads>>,
        dt: &Bound<'_, PyAny>,
        method: &str,
        model: names::ModelArg,
        mass: &str,
        damping: (f64, f64),
        initial_displacement: Option<&Bound<'_, PyAny>>,
        initial_velocity: Option<&Bound<'_, PyAny>>,
        linear_solver: &str,
        nonlinear_solver: &str,
        newton_tolerance: Option<f64>,
        relax_contact_nodes: bool,
        obstacles: Option<Vec<PyRef<'_, PyObstacle>>>,
        contact_distance: Option<f64>,
        contact_stiffness: Option<f64>,
        contact_impact_fraction: Option<f64>,
        self_contact: bool,
        self_contact_distance: Option<f64>,
        self_contact_stiffness: Option<f64>,
        self_contact_friction: f64,
    ) -> PyResult<Self> {
        let data = Arc::clone(&mesh.get().data);
        check_same_mesh(py, &data, &constraints, loads.as_deref())?;
        let materials = materials_of(py, material, &data)?;
        let method = names::method(py, method)?;
        let (kind, region_models) = names::models(py, &model)?;
        let mass = names::mass(py, mass)?;
        let options = IntegratorOptions {
            linear_method: names::linear_solver(py, linear_solver)?,
            nonlinear_solve: nonlinear_solver.parse().or_raise(py)?,
            newton: newton_options(py, newton_tolerance, relax_contact_nodes)?,
            ..IntegratorOptions::default()
        };
        let rayleigh = Rayleigh::new(damping.0, damping.1).or_raise(py)?;
        let dt = names::time_step(py, dt)?;
        let empty = on_cells!(&data.mesh, m => Loads::new(m));
        let (other, gravity) = match &loads {
            Some(l) => (&l.other, l.gravity),
            None => (&empty, nalgebra::Vector3::zeros()),
        };
        let contact = contact_of(
            py,
            &data,
            &materials,
            obstacles,
            (contact_distance, contact_stiffness),
            contact_impact_fraction,
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
        let c = &constraints.constraints;
        let time_data = crate::timed::time_data(loads.as_deref(), &constraints);
        let n = data.mesh.node_count();
        // The initial values' shapes are checked before the assembly.
        let initial_u = match initial_displacement {
            Some(u) => {
                let (values, rows) = arrays::floats(py, u, "initial_displacement", Some(3), false)?;
                if rows != n {
                    return Err(invalid(
                        py,
                        "initial_displacement.shape",
                        format!("({rows}, 3)"),
                        &format!("must be ({n}, 3): one row per node"),
                    ));
                }
                Some(values)
            }
            None => None,
        };
        let initial_v = match initial_velocity {
            Some(v) => Some(arrays::rows_per_item(py, v, "initial_velocity", n)?),
            None => None,
        };
        let options = TransientOptions {
            method,
            dt,
            mass,
            damping: rayleigh,
            solver: options,
        };
        // The library's transient set-up, as the scene runner's: the system (without the
        // rigid-mode check when obstacles may hold the body), the linear fast path or each
        // material's model, with obstacles every model with the contact barrier.
        let mut transient = py
            .detach(|| {
                on_cells!(&data.mesh, m => {
                    let mut builder = Definition::builder(m.clone(), materials.clone())
                        .model(kind)
                        .constraints(c.clone())?
                        .loads(other.clone())?
                        .gravity(gravity)?
                        .time_data(time_data.clone());
                    if let Some(contact) = contact {
                        builder = builder.contact(contact);
                    }
                    if let Some((barrier, body_of_node)) = surface.clone() {
                        builder = builder.surface_contact(barrier, body_of_node)?;
                    }
                    if let Some(kinds) = region_models.clone() {
                        builder = builder.region_models(kinds)?;
                    }
                    Transient::new(&builder.build()?, options)
                })
            })
            .or_raise(py)?;
        let system = Arc::clone(transient.system());
        let state = transient.state_mut();
        if let Some(u) = initial_u {
            state.displacement = system.dofs().restrict(&u).or_raise(py)?;
        }
        if let Some(v) = initial_v {
            state.velocity = system.dofs().restrict(&v).or_raise(py)?;
        }
        Ok(PySimulation {
            reactions: crate::sim_reactions::Reactions::new(other.clone(), gravity, time_data),
            data,
            materials,
            force: transient.force().clone(),
            system,
            method: transient.integrator().name(),
            stepping: Mutex::new(transient),
            runner: Mutex::new(None),
            seen: Mutex::new(None),
        })
    }

    /// Advances one time step (GIL released). On ``DivergedError`` the state
    /// holds the failed step's values, for inspection; on ``KeyboardInterrupt`` (Ctrl-C
    /// inside the step's iterations) the state of the step before.
    fn step(&self, py: Python<'_>) -> PyResult<()> {
        let _runner = self.claim(py)?;
        self.advance(py, |_| Ok(())).map(|_| ())
    }

    /// Writes a checkpoint of the run to ``path`` (a small binary file, written atomically):
    /// the state (u, v, time, step count), what the method carries from one step to the next
    /// and the time step, with the method, model and free DOF count as its fingerprint.
    /// ``restore(path)`` on a Simulation built the same way continues bit for bit as if never
    /// interrupted. Raises ``TetfemIOError`` when the file cannot be written.
    fn checkpoint(&self, py: Python<'_>, path: PathBuf) -> PyResult<()> {
        let reading = self.reading(py)?;
        let fingerprint = self.fingerprint(reading.state());
        let checkpoint = reading.checkpoint(self.method, fingerprint).or_raise(py)?;
        drop(reading);
        py.detach(|| checkpoint.write(&path)).or_raise(py)
    }

    /// Continues from the checkpoint at ``path`` (see ``checkpoint``): the state, the
    /// method's history and the time step become the checkpoint's. A checkpoint of another
    /// method, model or free DOF count raises ``InvalidInputError`` naming the entry and both
    /// values; a damaged file ``TetfemError`` naming the byte offset.
    fn restore(&self, py: Python<'_>, path: PathBuf) -> PyResult<()> {
        let checkpoint = py.detach(|| Checkpoint::read(&path)).or_raise(py)?;
        let mut guard = self.stepping(py)?;
        for (name, ours) in self.fingerprint(guard.state()) {
            let theirs = checkpoint.fingerprint_entry(&name).unwrap_or("none");
            if theirs != ours {
                return Err(invalid(
                    py,
                    &format!("checkpoint {name}"),
                    theirs,
                    &format!(
                        "this Simulation has {name} = {ours}: restore a checkpoint of a Simulation built the same way"
                    ),
                ));
            }
        }
        let (integrator, state) = guard.parts_mut();
        integrator.set_time_step(checkpoint.dt).or_raise(py)?;
        *state = checkpoint.restore(integrator).or_raise(py)?;
        Ok(())
    }

    /// Takes ``steps`` steps (the library's time loop, ``Transient::run``, as a scene's run) and
    /// returns the energy history after each step as numpy arrays of that length: ``time`` (s,
    /// float64), ``step`` (int64), ``kinetic``, ``elastic``, ``gravity_potential``,
    /// ``load_potential``, ``total`` (J, float64). ``callback(simulation)`` is called after each
    /// step (with the GIL); it reads the state that step left (``time``, ``steps``, ``dt``,
    /// ``displacement``, ``velocity``, ``energy()``, ``von_mises()``, ``reactions()``,
    /// ``checkpoint(path)``) but cannot change or step the Simulation (``TetfemError``: return
    /// ``False``, change it, run again); if it returns ``False`` the run stops there (the arrays
    /// are then shorter); an exception it raises propagates, the run stopped at that step. Ctrl-C raises
    /// ``KeyboardInterrupt`` between steps or inside a step's iterations (within 0.05 s and
    /// one iteration), the Simulation left at the last completed step (``steps`` and ``time``
    /// those of that step; the history up to it is lost with the return value, so record it
    /// in a callback when it matters). While it runs, calls from other threads raise
    /// ``TetfemError`` (busy).
    #[pyo3(signature = (steps, callback = None))]
    fn run<'py>(
        slf: &Bound<'py, Self>,
        steps: usize,
        callback: Option<Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let py = slf.py();
        let sim = slf.get();
        let _runner = sim.claim(py)?;
        let mut guard = sim.stepping(py)?;
        let transient = &mut *guard;
        let (this, callback) = (slf.clone().unbind(), callback.map(Bound::unbind));
        let mut observer = RunObserver {
            sim,
            this: &this,
            callback: callback.as_ref(),
            counts: Vec::new(),
            columns: Default::default(),
            raised: None,
        };
        let first = transient.state().steps;
        // The library's time loop, detached from the interpreter (the observer attaches for
        // the callback); Ctrl-C inside a step's iterations or between steps.
        let ran = detach_interruptible(py, || {
            transient.run((first, first.saturating_add(steps)), &mut observer)
        });
        *lock_ignoring_poison(&sim.seen) = None;
        drop(guard);
        ran?;
        if let Some(error) = observer.raised.take() {
            return Err(error);
        }
        let (counts, columns) = (observer.counts, observer.columns);
        let d = PyDict::new(py);
        let names = [
            "time",
            "kinetic",
            "elastic",
            "gravity_potential",
            "load_potential",
            "total",
        ];
        for (name, column) in names.into_iter().zip(columns) {
            d.set_item(name, arrays::vector(py, column))?;
        }
        d.set_item("step", arrays::index_vector(py, &counts))?;
        Ok(d)
    }

    /// Runs from the current state to ``end_time`` (s) with error-controlled time stepping
    /// (implicit methods): each step's dt is chosen from an estimate of its local error so that
    /// the trajectory's relative error stays within ``tolerance`` (0 < tol < 1), starting from
    /// the current ``dt``; the library's ``Transient::run_adaptive``, as the scene key
    /// ``analysis.time_tolerance`` runs it. ``output_interval`` (s): land exactly on every
    /// multiple of it from the current time (default: only on ``end_time``); ``min_dt`` (s, 0:
    /// the duration / 1e9) and ``max_dt`` (s) bound the step. Returns a dict: ``time`` and
    /// ``dt`` (float64 arrays: each accepted step's end time and length), ``estimated_error``
    /// (the run's own estimate of its relative trajectory error), ``accepted_steps``,
    /// ``rejected_steps``, ``dt_changes``, ``dt_min``, ``dt_max`` (s). Afterwards ``dt`` is the
    /// last step's. Raises ``InvalidInputError`` for the explicit method, a tolerance out of
    /// range or one not met at ``min_dt`` (naming ``time_tolerance``); Ctrl-C raises
    /// ``KeyboardInterrupt`` at a step boundary or inside a step.
    #[pyo3(signature = (end_time, tolerance, *, output_interval = None, min_dt = 0.0, max_dt = f64::INFINITY))]
    fn run_adaptive<'py>(
        slf: &Bound<'py, Self>,
        end_time: f64,
        tolerance: f64,
        output_interval: Option<f64>,
        min_dt: f64,
        max_dt: f64,
    ) -> PyResult<Bound<'py, PyDict>> {
        let py = slf.py();
        let sim = slf.get();
        let _runner = sim.claim(py)?;
        let mut control = AdaptiveStep::new(tolerance).or_raise(py)?;
        control.output_interval = output_interval;
        control.min_dt = min_dt;
        control.max_dt = max_dt;
        let mut guard = sim.stepping(py)?;
        let transient = &mut *guard;
        let report = detach_interruptible(py, || {
            // Ctrl-C between steps (inside a step the solvers poll it themselves).
            let mut observer = |_: &StepView<'_>| -> tetfem::Result<Flow> {
                tetfem::linalg::interrupt::poll(|| "an adaptive run".into())?;
                Ok(Flow::Continue)
            };
            transient.run_adaptive(end_time, &control, &mut observer)
        })?;
        let d = PyDict::new(py);
        let (times, dts): (Vec<f64>, Vec<f64>) = report.steps.iter().copied().unzip();
        d.set_item("time", arrays::vector(py, times))?;
        d.set_item("dt", arrays::vector(py, dts))?;
        d.set_item("estimated_error", report.estimated_error)?;
        d.set_item("accepted_steps", report.accepted)?;
        d.set_item("rejected_steps", report.rejected)?;
        d.set_item("dt_changes", report.dt_changes)?;
        d.set_item("dt_min", report.dt_range.0)?;
        d.set_item("dt_max", report.dt_range.1)?;
        Ok(d)
    }

    /// The energies of the current state as a dict (J): kinetic ½vᵀMv, elastic (½uᵀKu
    /// for the linear model), gravity_potential, load_potential (−f·u) and their total.
    fn energy<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let reading = self.reading(py)?;
        let state = reading.state();
        let e = py
            .detach(|| self.force.energy(&self.system, state))
            .or_raise(py)?;
        energy_dict(py, &e)
    }

    /// Simulated time (s).
    #[getter]
    fn time(&self, py: Python<'_>) -> PyResult<f64> {
        Ok(self.reading(py)?.state().time)
    }

    /// Steps taken.
    #[getter]
    fn steps(&self, py: Python<'_>) -> PyResult<usize> {
        Ok(self.reading(py)?.state().steps)
    }

    /// The time step (s); setting it makes implicit methods refactor on the next step.
    #[getter]
    fn dt(&self, py: Python<'_>) -> PyResult<f64> {
        Ok(self.reading(py)?.dt())
    }

    #[setter]
    fn set_dt(&self, py: Python<'_>, dt: f64) -> PyResult<()> {
        self.stepping(py)?
            .integrator_mut()
            .set_time_step(dt)
            .or_raise(py)
    }

    /// The Newton counts of the implicit steps so far, as a dict of ints: ``steps``,
    /// ``total_iterations``, ``max_per_step``, ``last_step`` (the last step's iterations),
    /// ``factorizations``, ``cg_iterations`` and ``fallbacks`` (a CG or an L-BFGS run that gave
    /// way to a factorization); ``None`` where the steps iterate no Newton (the linear model
    /// without obstacles, the explicit method). What ``nonlinear_solver`` and
    /// ``newton_tolerance`` cost.
    #[getter]
    fn newton_stats<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        let Some(stats) = self.reading(py)?.newton_stats() else {
            return Ok(None);
        };
        let dict = PyDict::new(py);
        for (key, value) in [
            ("steps", stats.steps),
            ("total_iterations", stats.total_iterations),
            ("max_per_step", stats.max_per_step),
            ("last_step", stats.last_step),
            ("factorizations", stats.factorizations),
            ("cg_iterations", stats.cg_iterations),
            ("fallbacks", stats.fallbacks),
        ] {
            dict.set_item(key, value)?;
        }
        Ok(Some(dict))
    }

    /// The method's name (``backward-euler``, ``newmark``, ``explicit``).
    #[getter]
    fn method(&self) -> &'static str {
        self.method
    }

    /// The force model's name (``linear``, ``corotational``, ``neo-hookean``, …; ``per-material``
    /// for a list of different models).
    #[getter]
    fn model(&self) -> &'static str {
        self.force.name()
    }

    /// Number of free DOFs.
    #[getter]
    fn free_count(&self) -> usize {
        self.system.free_count()
    }

    /// Displacement of every node, shape (n, 3), m (prescribed values on constrained DOFs,
    /// moving supports at the current time).
    #[getter]
    fn displacement<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let (u, time) = {
            let reading = self.reading(py)?;
            (reading.state().displacement.clone(), reading.state().time)
        };
        arrays::rows3(py, self.system.expand_at(time, &u).or_raise(py)?)
    }

    /// Sets the displacement (shape (n, 3), m) of the free DOFs; the constrained ones keep
    /// their prescribed values. Time and step count are unchanged.
    #[setter]
    fn set_displacement(&self, py: Python<'_>, value: &Bound<'_, PyAny>) -> PyResult<()> {
        // Read before the lock: converting `value` may run Python code (an array-like's
        // methods) that reads this Simulation.
        let values = self.free_values(py, value, "displacement")?;
        self.stepping(py)?.state_mut().displacement = values;
        Ok(())
    }

    /// Velocity of every node, shape (n, 3), m/s (zero on constrained DOFs).
    #[getter]
    fn velocity<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let v = self.reading(py)?.state().velocity.clone();
        self.scatter(py, &v)
    }

    /// Sets the velocity (shape (3,) for every node or (n, 3), m/s) of the free DOFs.
    #[setter]
    fn set_velocity(&self, py: Python<'_>, value: &Bound<'_, PyAny>) -> PyResult<()> {
        let values = self.free_values(py, value, "velocity")?;
        self.stepping(py)?.state_mut().velocity = values;
        Ok(())
    }

    /// The explicit method's critical time step (s): 2/ω_max by Lanczos iteration for a lumped
    /// mass, the element bound for a consistent one.
    #[getter]
    fn critical_time_step(&self, py: Python<'_>) -> PyResult<f64> {
        py.detach(|| Self::critical(&self.system, &self.data, &self.materials))
            .or_raise(py)
    }

    /// Von Mises stress of every tet at the current state, shape (m,), Pa: the Cauchy stress
    /// of the model that runs.
    fn von_mises<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let u = {
            let reading = self.reading(py)?;
            self.system
                .expand_at(reading.state().time, &reading.state().displacement)
                .or_raise(py)?
        };
        let mesh = &self.data.mesh;
        let v =
            on_cells!(mesh, m => self.force.cell_von_mises(m, &self.materials, &u)).or_raise(py)?;
        Ok(arrays::vector(py, v))
    }

    /// The support reactions at the current state, shape (n, 3), N: the force each support
    /// exerts on the body so that the equation of motion holds on its rows, r_c = M·a + C·v −
    /// f_int(u) − f_ext(t) (moving supports and loads with amplitudes at the current time;
    /// zero on free DOFs), as the scene runner's reaction columns. Summed over all nodes,
    /// Σr + Σf_ext = Σ M·a + α·Σ M·v. The first call assembles the constrained rows of K and M.
    fn reactions<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let reading = self.reading(py)?;
        let state = reading.state();
        let r = py
            .detach(|| {
                self.reactions.at(
                    &self.data,
                    &self.materials,
                    &self.system,
                    &self.force,
                    state,
                )
            })
            .or_raise(py)?;
        drop(reading);
        arrays::rows3(py, r)
    }

    /// The stiffness K_ff on the free DOFs (N/m), SciPy CSR or (indptr, indices, data, shape).
    fn free_stiffness<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        csr(py, self.system.stiffness())
    }

    /// The mass matrix on the free DOFs (kg), lumped (diagonal) or consistent, in the form of
    /// ``free_stiffness``.
    fn free_mass<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        match self.system.mass() {
            Mass::Lumped(d) => diagonal(py, d),
            Mass::Consistent(m) => csr(py, m),
        }
    }

    /// The free DOFs (3·node + axis), ascending: row i of the free matrices is DOF free_dofs[i].
    #[getter]
    fn free_dofs<'py>(&self, py: Python<'py>) -> Bound<'py, PyAny> {
        arrays::index_vector(py, self.system.dofs().free_dofs())
    }

    /// The ``count`` lowest natural modes (a ``ModalResult``) of this simulation's system.
    #[pyo3(signature = (count = 6))]
    fn modes(&self, py: Python<'_>, count: usize) -> PyResult<ModalResult> {
        modes_of(py, &self.system, Some(&self.force), &self.data, count)
    }

    fn __repr__(&self, py: Python<'_>) -> String {
        match self.reading(py) {
            Ok(reading) => format!(
                "Simulation(method={}, model={}, dt={:e} s, t={:e} s, {} steps)",
                self.method,
                self.force.name(),
                reading.dt(),
                reading.state().time,
                reading.state().steps
            ),
            Err(_) => format!(
                "Simulation(method={}, model={}, busy: running in another thread)",
                self.method,
                self.force.name()
            ),
        }
    }
}
