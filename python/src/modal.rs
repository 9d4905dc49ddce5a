//! Natural modes from Python: `tetfem.modal_analysis` and the `tetfem.ModalResult` it returns.

use numpy::{PyArray1, PyArrayMethods};
use pyo3::prelude::*;
use tetfem::analysis::dynamics::{InternalForce, LinearSystem};
use tetfem::analysis::modal::{Modes, lowest_modes, lowest_modes_with_force};
use tetfem::analysis::{Definition, Modal};
use tetfem::bc::constraints::DofMap;

use crate::arrays;
use crate::constraints::PyConstraints;
use crate::interrupt::detach_interruptible;
use crate::material::materials_of;
use crate::mesh::{MeshData, PyMesh, on_cells};
use crate::names;
use crate::statics::check_same_mesh;

/// The lowest natural modes of a constrained body.
///
/// Attributes: ``frequencies`` (k,) Hz, ascending; ``omega`` (k,) rad/s; ``shapes`` (k, n, 3)
/// mode shapes over all nodes (zero on constrained DOFs), mass-orthonormal (φᵢᵀ·M·φⱼ = δᵢⱼ, so in
/// m/√kg); ``residuals`` (k,) scaled eigen-residuals (dimensionless, each ≤ 1e-13);
/// ``iterations`` of the subspace iteration.
#[pyclass(name = "ModalResult", module = "tetfem", frozen, get_all)]
pub struct ModalResult {
    /// Frequencies f = ω/2π (Hz), ascending.
    frequencies: Py<PyAny>,
    /// Angular frequencies ω (rad/s).
    omega: Py<PyAny>,
    /// Mode shapes, shape (k, n, 3).
    shapes: Py<PyAny>,
    /// Scaled eigen-residual of each mode.
    residuals: Py<PyAny>,
    /// Subspace iterations used.
    iterations: usize,
}

/// The `count` lowest modes of `system` on the mesh of `data` (GIL released); with a `force`,
/// an error unless it is the linear one (modal analysis is linear).
pub fn modes_of(
    py: Python<'_>,
    system: &LinearSystem,
    force: Option<&InternalForce>,
    data: &MeshData,
    count: usize,
) -> PyResult<ModalResult> {
    let modes = detach_interruptible(py, || match force {
        Some(force) => lowest_modes_with_force(system, force, count),
        None => lowest_modes(system, count),
    })?;
    result_of(py, &modes, system.dofs(), data)
}

/// The Python result of `modes` whose shapes live on the free DOFs of `dofs` (mesh of `data`).
fn result_of(
    py: Python<'_>,
    modes: &Modes,
    dofs: &DofMap,
    data: &MeshData,
) -> PyResult<ModalResult> {
    let full = data.mesh.dof_count();
    let mut shapes = vec![0.0; modes.shapes.len() * full];
    for (k, shape) in modes.shapes.iter().enumerate() {
        for (&dof, &v) in dofs.free_dofs().iter().zip(shape) {
            shapes[k * full + dof] = v;
        }
    }
    let shapes = PyArray1::from_vec(py, shapes).reshape([modes.shapes.len(), full / 3, 3])?;
    Ok(ModalResult {
        frequencies: arrays::vector(py, modes.frequencies()).unbind(),
        omega: arrays::vector(py, modes.omega.clone()).unbind(),
        shapes: shapes.into_any().unbind(),
        residuals: arrays::vector(py, modes.residuals.clone()).unbind(),
        iterations: modes.iterations,
    })
}

#[pymethods]
impl ModalResult {
    fn __repr__(&self, py: Python<'_>) -> String {
        let f = self
            .frequencies
            .bind(py)
            .repr()
            .map(|r| r.to_string())
            .unwrap_or_default();
        format!("ModalResult(frequencies={f} Hz)")
    }
}

/// The ``count`` lowest natural modes of the body held by ``constraints`` (subspace iteration
/// with a Cholesky factorization of K_ff, GIL released). ``mass``: ``"lumped"`` or
/// ``"consistent"``. Raises ``NotConstrainedError`` for a free body (rigid-body modes).
#[pyfunction]
#[pyo3(signature = (mesh, material, constraints, count = 6, mass = "lumped"))]
pub fn modal_analysis(
    py: Python<'_>,
    mesh: &Bound<'_, PyMesh>,
    material: &Bound<'_, PyAny>,
    constraints: PyRef<'_, PyConstraints>,
    count: usize,
    mass: &str,
) -> PyResult<ModalResult> {
    let data = &mesh.get().data;
    check_same_mesh(py, data, &constraints, None)?;
    let materials = materials_of(py, material, data)?;
    let mass = names::mass(py, mass)?;
    let c = &constraints.constraints;
    // The library's modal analysis of the definition (its combination rule, its assembly).
    let (modes, dofs) = detach_interruptible(py, || -> tetfem::Result<_> {
        on_cells!(&data.mesh, m => {
            let definition = Definition::builder(m.clone(), materials.clone())
                .constraints(c.clone())?
                .build()?;
            let analysis = Modal::new(&definition, mass)?;
            let outcome = analysis.solve(count)?;
            Ok((outcome.modes, analysis.system().dofs().clone()))
        })
    })?;
    result_of(py, &modes, &dofs, data)
}
