//! `tetfem.mixed_modal_analysis` and `tetfem.mixed_transient`: the natural modes and the
//! implicit linear time steps of the mixed body from Python (Taylor–Hood P2–P1 on 10-node
//! tets, the stabilized P1–P1 on 4-node tets), the library's `lowest_mixed_modes` and
//! `MixedTransient`.

use numpy::{PyArray1, PyArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use tetfem::analysis::dynamics::Rayleigh;
use tetfem::analysis::mixed_dynamics::MixedTransient;
use tetfem::analysis::mixed_modal::lowest_mixed_modes;
use tetfem::bc::constraints::DofMap;

use crate::arrays;
use crate::cells::on_cells;
use crate::constraints::PyConstraints;
use crate::errors::invalid;
use crate::interrupt::detach_interruptible;
use crate::loads::PyLoads;
use crate::material::materials_of;
use crate::mesh::PyMesh;
use crate::names;
use crate::statics::check_same_mesh;

/// `InvalidInputError` unless the supports are fixed (the mixed dynamic and modal analyses
/// hold them still).
fn fixed_supports(py: Python<'_>, constraints: &PyConstraints) -> PyResult<()> {
    if !constraints.motions.is_empty() {
        return Err(invalid(
            py,
            "constraints",
            "moving supports",
            "fixed supports only in the mixed dynamic and modal analyses",
        ));
    }
    Ok(())
}

/// The ``count`` lowest natural modes of the mixed body (10-node ``mesh``: Taylor–Hood P2–P1;
/// 4-node: the stabilized P1–P1; ν < 0.5, the constraints holding every rigid motion), the
/// pressure condensed exactly: K_eff·φ = ω²·M·φ with K_eff = K_dev + BᵀC⁻¹B (C = M_p/κ for
/// Taylor–Hood, M_p/κ + (1/μ)(M_p − M_Π) for P1–P1) and the consistent mass M. Returns a
/// dict with ``frequencies`` (k,) Hz ascending, ``omega`` (k,) rad/s, ``shapes`` (k, n, 3)
/// M-orthonormal over all nodes (zero on constrained DOFs, m/√kg), ``pressure`` (k, n) each
/// mode's nodal pressure (Pa per unit of modal amplitude, positive in compression),
/// ``residuals`` (k,) scaled eigen-residuals, ``iterations`` and ``free_dofs``. The work runs
/// with the GIL released.
#[pyfunction]
#[pyo3(name = "mixed_modal_analysis", signature = (mesh, material, constraints, count = 6))]
pub fn mixed_modal_analysis_py<'py>(
    py: Python<'py>,
    mesh: &Bound<'py, PyMesh>,
    material: &Bound<'py, PyAny>,
    constraints: PyRef<'py, PyConstraints>,
    count: usize,
) -> PyResult<Bound<'py, PyDict>> {
    let data = &mesh.get().data;
    check_same_mesh(py, data, &constraints, None)?;
    let materials = materials_of(py, material, data)?;
    fixed_supports(py, &constraints)?;
    let fixed = &constraints.constraints;
    let mixed = detach_interruptible(
        py,
        || on_cells!(&data.mesh, m => lowest_mixed_modes(m, &materials, fixed, count)),
    )?;
    let modes = &mixed.modes;
    let node_count = on_cells!(&data.mesh, m => m.node_count());
    let (full, k) = (3 * node_count, modes.shapes.len());
    // The shapes live on the free DOFs, in the order of the constraints' DOF map.
    let dofs = DofMap::new(fixed);
    let mut shapes = vec![0.0; k * full];
    for (i, shape) in modes.shapes.iter().enumerate() {
        for (&dof, &v) in dofs.free_dofs().iter().zip(shape) {
            shapes[i * full + dof] = v;
        }
    }
    let shapes = PyArray1::from_vec(py, shapes).reshape([k, full / 3, 3])?;
    let pressure = PyArray1::from_vec(py, mixed.pressure.concat()).reshape([k, node_count])?;
    let out = PyDict::new(py);
    out.set_item("frequencies", arrays::vector(py, modes.frequencies()))?;
    out.set_item("omega", arrays::vector(py, modes.omega.clone()))?;
    out.set_item("shapes", shapes)?;
    out.set_item("pressure", pressure)?;
    out.set_item("residuals", arrays::vector(py, modes.residuals.clone()))?;
    out.set_item("iterations", modes.iterations)?;
    out.set_item("free_dofs", mixed.free_dofs)?;
    Ok(out)
}

/// ``steps`` implicit steps of ``dt`` (s) of the linear mixed body (10-node ``mesh``:
/// Taylor–Hood P2–P1; 4-node: the stabilized P1–P1) from rest, under ``loads`` held constant
/// from t = 0 (a load with an amplitude enters at its value at ``STATIC_TIME``):
/// M·ü + α·M·u̇ + K_dev·u − Bᵀp = f, B·u + C·p = 0 (C as in ``mixed_modal_analysis``),
/// the pressure without inertia solved with u at every step (one LDLᵀ of the shifted saddle
/// point, factored once). ``method``: ``"newmark"`` (average acceleration, no numerical
/// damping) or ``"backward-euler"`` (first order, damps). ``alpha``: the mass-proportional
/// damping α (1/s, ≥ 0). Returns a dict with ``time`` (steps + 1,) s, ``displacement``
/// (steps + 1, n, 3) m and ``pressure`` (steps + 1, n) Pa (positive in compression), the
/// state at t = 0 first. The work runs with the GIL released.
#[pyfunction]
#[pyo3(name = "mixed_transient", signature = (mesh, material, constraints, loads, dt, steps, method = "newmark", alpha = 0.0))]
#[allow(clippy::too_many_arguments)]
pub fn mixed_transient_py<'py>(
    py: Python<'py>,
    mesh: &Bound<'py, PyMesh>,
    material: &Bound<'py, PyAny>,
    constraints: PyRef<'py, PyConstraints>,
    loads: PyRef<'py, PyLoads>,
    dt: f64,
    steps: usize,
    method: &str,
    alpha: f64,
) -> PyResult<Bound<'py, PyDict>> {
    let data = &mesh.get().data;
    check_same_mesh(py, data, &constraints, Some(&loads))?;
    let materials = materials_of(py, material, data)?;
    let method = names::method(py, method)?;
    fixed_supports(py, &constraints)?;
    let (fixed, all) = (&constraints.constraints, &loads.all);
    let damping = Rayleigh { alpha, beta: 0.0 };
    let (times, displacement, pressure) = detach_interruptible(py, || {
        on_cells!(&data.mesh, m => {
            let mut run = MixedTransient::new(m, &materials, fixed, all, (method, dt, damping))?;
            let mut times = vec![run.time()];
            let mut displacement = run.displacement()?;
            let mut pressure = run.pressure();
            for _ in 0..steps {
                run.step()?;
                times.push(run.time());
                displacement.extend(run.displacement()?);
                pressure.extend(run.pressure());
            }
            Ok((times, displacement, pressure))
        })
    })?;
    let frames = times.len();
    let node_count = on_cells!(&data.mesh, m => m.node_count());
    let out = PyDict::new(py);
    out.set_item("time", arrays::vector(py, times))?;
    out.set_item(
        "displacement",
        PyArray1::from_vec(py, displacement).reshape([frames, node_count, 3])?,
    )?;
    out.set_item(
        "pressure",
        PyArray1::from_vec(py, pressure).reshape([frames, node_count])?,
    )?;
    Ok(out)
}
