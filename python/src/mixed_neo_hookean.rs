//! `tetfem.mixed_neo_hookean_transient`: nearly incompressible Neo-Hookean (or corotational)
//! rubber stepped in time in the mixed displacement–pressure form (Taylor–Hood P2–P1 on 10-node
//! tets, the stabilized P1–P1 on 4-node tets) by backward Euler, optionally against rigid
//! obstacles: the library's `MixedNonlinearEuler` through its checked entry
//! `mixed_nonlinear_euler_model`, after the library's `Combination` of the whole call.

use numpy::{PyArray1, PyArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use tetfem::analysis::combination::{Analysis, Combination, Formulation};
use tetfem::analysis::dynamics::Method;
use tetfem::analysis::mixed_analysis::{MixedStaticElement, mixed_nonlinear_euler_model};
use tetfem::analysis::mixed_nonlinear_dynamics::{MixedBody, MixedNonlinearEuler};
use tetfem::contact::Contact;
use tetfem::fe::materials::MaterialMap;
use tetfem::mesh::TetMesh;
use tetfem::model::ModelKind;
use tetfem::{Constraints, Loads};

use crate::arrays;
use crate::cells::on_cells;
use crate::constraints::PyConstraints;
use crate::contact::{PyObstacle, contact_of};
use crate::errors::{OrRaise, invalid};
use crate::interrupt::detach_interruptible;
use crate::loads::PyLoads;
use crate::material::materials_of;
use crate::mesh::PyMesh;
use crate::names;
use crate::statics::check_same_mesh;

/// What each state of the run records: time (s), displacement (m, every DOF), nodal pressure
/// (Pa), V/V₀ − 1, kinetic and stored energy (J), the smallest gap to an obstacle (m; ∞
/// without), and the Newton iterations of the step that reached it (0 at the start).
#[derive(Default)]
struct History {
    time: Vec<f64>,
    displacement: Vec<f64>,
    pressure: Vec<f64>,
    volume_change: Vec<f64>,
    kinetic: Vec<f64>,
    elastic: Vec<f64>,
    gap: Vec<f64>,
    iterations: Vec<usize>,
}

impl History {
    /// Appends `run`'s current state, reached in `iterations` Newton iterations; `rest` the
    /// undeformed volume (m³).
    fn record<E: MixedBody>(
        &mut self,
        run: &MixedNonlinearEuler<E>,
        rest: f64,
        iterations: usize,
    ) -> tetfem::Result<()> {
        let u = run.displacement();
        self.time.push(run.time());
        self.displacement.extend_from_slice(u);
        self.pressure.extend(run.pressure());
        self.volume_change.push(run.deformed_volume() / rest - 1.0);
        self.kinetic.push(run.kinetic_energy()?);
        self.elastic.push(run.elastic_energy());
        self.gap.push(match run.contact() {
            Some(contact) => contact.smallest_gap(u)?,
            None => f64::INFINITY,
        });
        self.iterations.push(iterations);
        Ok(())
    }
}

/// The run on `mesh` (either element): set up by the library's checked entry, then `steps`
/// steps, every state recorded.
fn run_on<E: MixedStaticElement + MixedBody>(
    mesh: &TetMesh<E>,
    (materials, model): (&MaterialMap, ModelKind),
    (constraints, loads): (&Constraints, &Loads),
    (dt, steps, tolerance): (f64, usize, f64),
    (velocity, contact): (Option<&[f64]>, Option<Contact>),
) -> tetfem::Result<History> {
    let mut run = mixed_nonlinear_euler_model(
        mesh,
        materials,
        model,
        (constraints, loads),
        (dt, tolerance),
    )?;
    if let Some(contact) = contact {
        run = run.with_contact(contact)?;
    }
    if let Some(velocity) = velocity {
        run = run.with_velocity(velocity)?;
    }
    let rest = run.deformed_volume();
    let mut history = History::default();
    history.record(&run, rest, 0)?;
    for _ in 0..steps {
        let iterations = run.step()?;
        history.record(&run, rest, iterations)?;
    }
    Ok(history)
}

/// ``steps`` backward-Euler steps of ``dt`` (s) of nearly incompressible hyperelastic rubber in
/// the mixed displacement–pressure form, from the undeformed state (pressure 0) with
/// ``initial_velocity`` (m/s: shape (3,) for every node or (n, 3); default at rest). ``mesh``:
/// 10-node tets (``order=2``: Taylor–Hood P2–P1) or 4-node tets (``order=1``: the stabilized
/// P1–P1 of Dohrmann–Bochev). ``material``: a ``Material`` or a ``MaterialMap`` (ν < 0.5).
/// ``model``: ``"neo_hookean"`` (default; the energy W = μ/2·(Ī₁ − 3) − p·(J − 1) − p²/(2κ)
/// of Simo–Taylor) or ``"corotational"`` (W = μ‖dev ε‖² − p·tr ε − p²/(2κ), ε = sym(RᵀF) − I,
/// R the polar rotation of F); another model raises. ``constraints``: fixed supports (a
/// moving support raises); ``loads``: constant loads and gravity (a load with an amplitude
/// raises): what combines is the library's rule (``Combination``), which names the pair. Each step solves M·(u⁺ − u − dt·v)/dt² + f_int(u⁺, p⁺) = f with the
/// pressure equation by Newton's method on the quasi-definite saddle tangent (one LDLᵀ per
/// iteration) to ``tolerance`` (relative, in (0, 1)); the consistent mass, no damping but
/// backward Euler's own. ``obstacles``: rigid, still ``Obstacle``s the boundary nodes meet
/// through the IPC barrier (``contact_distance`` d̂, m, and ``contact_stiffness``, Pa/m,
/// default to the scales ``Simulation`` uses), with their Coulomb friction lagged a step as
/// in ``Simulation``; no accepted iterate crosses one. Returns a dict with ``time`` (steps + 1,) s, ``displacement``
/// (steps + 1, n, 3) m, ``pressure`` (steps + 1, n) Pa (positive in compression),
/// ``volume_change`` (steps + 1,) ∫J dV/V₀ − 1, ``kinetic_energy`` and ``elastic_energy``
/// (steps + 1,) J, ``smallest_gap`` (steps + 1,) m (inf without obstacles),
/// ``newton_iterations`` (steps + 1,) per step (0 at the start), ``element`` and ``model``; the state at
/// t = 0 first. Errors raise ``InvalidInputError`` naming the argument, ``SolverError``
/// naming the step (use a smaller ``dt``). The work runs with the GIL released.
#[pyfunction]
#[pyo3(name = "mixed_neo_hookean_transient", signature = (mesh, material, constraints, loads, dt, steps, *, model = "neo_hookean", initial_velocity = None, obstacles = None, contact_distance = None, contact_stiffness = None, tolerance = 1e-8))]
#[allow(clippy::too_many_arguments)]
pub fn mixed_neo_hookean_transient_py<'py>(
    py: Python<'py>,
    mesh: &Bound<'py, PyMesh>,
    material: &Bound<'py, PyAny>,
    constraints: PyRef<'py, PyConstraints>,
    loads: PyRef<'py, PyLoads>,
    dt: f64,
    steps: usize,
    model: &str,
    initial_velocity: Option<&Bound<'py, PyAny>>,
    obstacles: Option<Vec<PyRef<'py, PyObstacle>>>,
    contact_distance: Option<f64>,
    contact_stiffness: Option<f64>,
    tolerance: f64,
) -> PyResult<Bound<'py, PyDict>> {
    let data = &mesh.get().data;
    check_same_mesh(py, data, &constraints, Some(&loads))?;
    let kind = names::model(py, model)?;
    Combination {
        model: kind,
        order: data.mesh.order(),
        analysis: Analysis::Transient(Method::BackwardEuler),
        formulation: Formulation::Mixed,
        moving_supports: !constraints.motions.is_empty(),
        time_varying_loads: !loads.timed.is_empty(),
        obstacles: obstacles.as_ref().is_some_and(|o| !o.is_empty()),
        ..Combination::default()
    }
    .check()
    .or_raise(py)?;
    if !(tolerance > 0.0 && tolerance < 1.0) {
        return Err(invalid(py, "tolerance", tolerance, "must be in (0, 1)"));
    }
    let materials = materials_of(py, material, data)?;
    let n = data.mesh.node_count();
    let velocity = match initial_velocity.filter(|v| !v.is_none()) {
        Some(v) => Some(arrays::rows_per_item(py, v, "initial_velocity", n)?),
        None => None,
    };
    let contact = contact_of(
        py,
        data,
        &materials,
        obstacles,
        (contact_distance, contact_stiffness),
        None,
    )?;
    let (fixed, all) = (&constraints.constraints, &loads.all);
    let (history, element) = detach_interruptible(py, || {
        on_cells!(&data.mesh, m => {
            let setup = (velocity.as_deref(), contact);
            let law = (&materials, kind);
            let history = run_on(m, law, (fixed, all), (dt, steps, tolerance), setup)?;
            Ok((history, element_name(m)))
        })
    })?;
    let frames = history.time.len();
    let out = PyDict::new(py);
    out.set_item("time", arrays::vector(py, history.time))?;
    out.set_item(
        "displacement",
        PyArray1::from_vec(py, history.displacement).reshape([frames, n, 3])?,
    )?;
    out.set_item(
        "pressure",
        PyArray1::from_vec(py, history.pressure).reshape([frames, n])?,
    )?;
    out.set_item("volume_change", arrays::vector(py, history.volume_change))?;
    out.set_item("kinetic_energy", arrays::vector(py, history.kinetic))?;
    out.set_item("elastic_energy", arrays::vector(py, history.elastic))?;
    out.set_item("smallest_gap", arrays::vector(py, history.gap))?;
    let iterations: Vec<u64> = history.iterations.iter().map(|&i| i as u64).collect();
    out.set_item("newton_iterations", arrays::vector(py, iterations))?;
    out.set_item("element", element)?;
    out.set_item("model", kind.name())?;
    Ok(out)
}

/// The mixed element of `mesh`'s cells, by name.
fn element_name<E: MixedStaticElement>(_: &TetMesh<E>) -> &'static str {
    E::MIXED_NAME
}
