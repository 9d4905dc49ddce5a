//! After a solve: `tetfem.estimate_error` (the ZZ estimate of the discretization error) and
//! `tetfem.model_advice` (the linear model's adequacy at a displacement), on any displacement
//! (a `StaticResult`'s, a `Simulation`'s) as numpy arrays.

use pyo3::prelude::*;
use pyo3::types::PyDict;
use tetfem::model::ModelMap;
use tetfem::post::adequacy::rotation::largest_rotation_and_strain;
use tetfem::post::estimate::{Recovery, estimate_map_error};

use crate::arrays;
use crate::errors::{OrRaise, invalid};
use crate::material::materials_of;
use crate::mesh::{MeshData, PyMesh, on_cells};
use crate::names;

/// The displacement (n, 3) of `data`'s nodes, flat node-major; wrong shapes raise
/// `InvalidInputError` naming ``displacement``.
fn displacement_of(
    py: Python<'_>,
    data: &MeshData,
    value: &Bound<'_, PyAny>,
) -> PyResult<Vec<f64>> {
    let (flat, rows) = arrays::floats(py, value, "displacement", Some(3), false)?;
    if rows != data.mesh.node_count() {
        return Err(invalid(
            py,
            "displacement",
            format!("{rows} rows"),
            &format!("must have one row per node ({})", data.mesh.node_count()),
        ));
    }
    Ok(flat)
}

/// The Zienkiewicz–Zhu estimate of the discretization error of ``displacement`` (n, 3), m, on
/// ``mesh`` with ``material``: a dict with ``relative`` η/(‖u_h‖_E² + η²)^½ (the estimated
/// relative energy-norm error, dimensionless), ``eta`` η = (Σ η_K²)^½ (J^½), ``energy_norm``
/// ‖u_h‖_E = (u_hᵀKu_h)^½ (J^½) and ``indicators`` each tet's η_K (m,), J^½: the
/// ``estimated_error`` of a scene's summary. ``model``: the force model the displacement came
/// from; for a nonlinear one the estimate is on its second Piola–Kirchhoff stress S (the
/// Green strain's error; ``energy_norm`` is then (∫ S_h : C⁻¹ : S_h dV)^½).
#[pyfunction]
#[pyo3(signature = (mesh, material, displacement, model = "linear"))]
pub fn estimate_error<'py>(
    py: Python<'py>,
    mesh: &Bound<'py, PyMesh>,
    material: &Bound<'py, PyAny>,
    displacement: &Bound<'py, PyAny>,
    model: &str,
) -> PyResult<Bound<'py, PyDict>> {
    let data = &mesh.get().data;
    let models = ModelMap::new(names::model(py, model)?, &materials_of(py, material, data)?);
    let u = displacement_of(py, data, displacement)?;
    let e = py
        .detach(|| {
            on_cells!(&data.mesh, m => estimate_map_error(m, &models, &u, Recovery::PatchRecovery))
        })
        .or_raise(py)?;
    let d = PyDict::new(py);
    d.set_item("relative", e.relative())?;
    d.set_item("eta", e.estimate)?;
    d.set_item("energy_norm", e.energy_norm)?;
    d.set_item("indicators", arrays::vector(py, e.indicators))?;
    Ok(d)
}

/// Whether the linear model is adequate at ``displacement`` (n, 3), m, on ``mesh``: a dict with
/// ``max_rotation_deg`` (the largest element rotation, degrees, from the polar decomposition of
/// F = I + ∇u at each tet's centroid) and its ``rotation_tet``, ``max_strain`` (the largest
/// |principal Biot strain|, dimensionless) and its ``strain_tet``, ``linear_model_error`` (the
/// linear model's expected relative error at that rotation), ``suggested_model``
/// (``"corotational"`` or ``"neo-hookean"`` past the library's 5 % threshold, else None) and
/// ``warning`` (the sentence scenes print, or None).
#[pyfunction]
pub fn model_advice<'py>(
    py: Python<'py>,
    mesh: &Bound<'py, PyMesh>,
    displacement: &Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyDict>> {
    let data = &mesh.get().data;
    let u = displacement_of(py, data, displacement)?;
    let d = py
        .detach(|| on_cells!(&data.mesh, m => largest_rotation_and_strain(m, &u)))
        .or_raise(py)?;
    let out = PyDict::new(py);
    out.set_item("max_rotation_deg", d.max_rotation_deg)?;
    out.set_item("rotation_tet", d.rotation_tet)?;
    out.set_item("max_strain", d.max_strain)?;
    out.set_item("strain_tet", d.strain_tet)?;
    out.set_item("linear_model_error", d.linear_model_error())?;
    out.set_item("suggested_model", d.suggested_model())?;
    out.set_item("warning", d.warning().map(|w| w.to_string()))?;
    Ok(out)
}
