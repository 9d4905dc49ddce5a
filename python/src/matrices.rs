//! The global matrices of a mesh over all DOFs: `tetfem.stiffness_matrix` and
//! `tetfem.mass_matrix` (SciPy CSR, or the CSR arrays without SciPy).

use pyo3::prelude::*;
use tetfem::analysis::dynamics::MassKind;
use tetfem::fe::assembly::{Assembler, lumped_mass_of};

use crate::errors::OrRaise;
use crate::material::materials_of;
use crate::mesh::{PyMesh, on_cells};
use crate::names;
use crate::sparse::{csr, diagonal};

/// The stiffness matrix K of all DOFs (3·node + axis; N/m in SI) of ``mesh`` with ``material``
/// (a ``Material`` or a ``MaterialMap``): SciPy CSR, or ``(indptr, indices, data, shape)``
/// without SciPy. Assembled with the GIL released.
#[pyfunction]
pub fn stiffness_matrix<'py>(
    py: Python<'py>,
    mesh: &Bound<'py, PyMesh>,
    material: &Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyAny>> {
    let data = &mesh.get().data;
    let materials = materials_of(py, material, data)?;
    let k = py
        .detach(|| on_cells!(&data.mesh, m => Assembler::new(m).stiffness(m, &materials)))
        .or_raise(py)?;
    csr(py, &k)
}

/// The mass matrix M of all DOFs (kg) of ``mesh`` with ``material``: ``mass="lumped"``
/// (diagonal, ρV/4 per node and axis) or ``"consistent"`` (ρV/20·(1+δᵢⱼ) blocks on K's
/// pattern), in the form of ``stiffness_matrix``.
#[pyfunction]
#[pyo3(signature = (mesh, material, mass = "lumped"))]
pub fn mass_matrix<'py>(
    py: Python<'py>,
    mesh: &Bound<'py, PyMesh>,
    material: &Bound<'py, PyAny>,
    mass: &str,
) -> PyResult<Bound<'py, PyAny>> {
    let data = &mesh.get().data;
    let materials = materials_of(py, material, data)?;
    match names::mass(py, mass)? {
        MassKind::Lumped => {
            let m = py
                .detach(|| on_cells!(&data.mesh, m => lumped_mass_of(m, &materials)))
                .or_raise(py)?;
            diagonal(py, &m)
        }
        MassKind::Consistent => {
            let m = py
                .detach(
                    || on_cells!(&data.mesh, m => Assembler::new(m).consistent_mass(m, &materials)),
                )
                .or_raise(py)?;
            csr(py, &m)
        }
    }
}
