//! `tetfem.Material` (isotropic linear elastic) and `tetfem.MaterialMap` (a material per tet).

use pyo3::prelude::*;
use tetfem::fe::material::Material;
use tetfem::fe::materials::{MaterialMap, TetMaterials};

use crate::arrays::{index_vector, indices};
use crate::errors::{OrRaise, invalid};
use crate::mesh::{MeshData, on_cells};

/// An isotropic linear elastic material: Young's modulus E (Pa in SI, finite and > 0),
/// Poisson's ratio ν (in the open interval (−1, 0.5)) and density ρ (kg/m³, finite and > 0).
/// Invalid values raise ``InvalidInputError`` naming the field.
#[pyclass(name = "Material", module = "tetfem", frozen)]
#[derive(Clone, Copy)]
pub struct PyMaterial {
    /// The validated material.
    pub material: Material,
}

#[pymethods]
impl PyMaterial {
    #[new]
    fn new(
        py: Python<'_>,
        youngs_modulus: f64,
        poisson_ratio: f64,
        density: f64,
    ) -> PyResult<Self> {
        let material = Material::new(youngs_modulus, poisson_ratio, density).or_raise(py)?;
        Ok(PyMaterial { material })
    }

    /// Material.steel(): structural steel, E = 200 GPa, ν = 0.3, ρ = 7850 kg/m³.
    #[staticmethod]
    fn steel() -> Self {
        PyMaterial {
            material: Material::steel(),
        }
    }

    /// Young's modulus E (Pa).
    #[getter]
    fn youngs_modulus(&self) -> f64 {
        self.material.youngs_modulus()
    }

    /// Poisson's ratio ν (dimensionless).
    #[getter]
    fn poisson_ratio(&self) -> f64 {
        self.material.poisson_ratio()
    }

    /// Density ρ (kg/m³).
    #[getter]
    fn density(&self) -> f64 {
        self.material.density()
    }

    /// Lamé's first parameter λ (Pa).
    #[getter]
    fn lame_lambda(&self) -> f64 {
        self.material.lame_lambda()
    }

    /// Shear modulus μ (Pa).
    #[getter]
    fn shear_modulus(&self) -> f64 {
        self.material.shear_modulus()
    }

    /// Bulk modulus K (Pa).
    #[getter]
    fn bulk_modulus(&self) -> f64 {
        self.material.bulk_modulus()
    }

    /// P-wave speed √((λ + 2μ)/ρ) (m/s).
    #[getter]
    fn p_wave_speed(&self) -> f64 {
        self.material.p_wave_speed()
    }

    fn __repr__(&self) -> String {
        format!(
            "Material(youngs_modulus={:e}, poisson_ratio={}, density={})",
            self.material.youngs_modulus(),
            self.material.poisson_ratio(),
            self.material.density()
        )
    }
}

/// A material per tet: ``materials`` a list of ``Material``, ``of_tet`` an integer array with
/// the index into ``materials`` of every tet (shape (m,)), ``names`` one name per material (for
/// messages; default ``"material 0"``, ``"material 1"``, …). Build ``of_tet`` with
/// ``Mesh.tets_in_box``, ``Mesh.tets_in_group`` or ``Mesh.tets_with_attribute``.
#[pyclass(name = "MaterialMap", module = "tetfem", frozen)]
pub struct PyMaterialMap {
    /// The map.
    pub map: MaterialMap,
}

#[pymethods]
impl PyMaterialMap {
    #[new]
    #[pyo3(signature = (materials, of_tet, names = None))]
    fn new(
        py: Python<'_>,
        materials: Vec<PyRef<'_, PyMaterial>>,
        of_tet: &Bound<'_, PyAny>,
        names: Option<Vec<String>>,
    ) -> PyResult<Self> {
        let list: Vec<Material> = materials.iter().map(|m| m.material).collect();
        let names =
            names.unwrap_or_else(|| (0..list.len()).map(|i| format!("material {i}")).collect());
        let (of_tet, _) = indices(py, of_tet, "of_tet", None)?;
        let mut index = Vec::with_capacity(of_tet.len());
        for (t, &i) in of_tet.iter().enumerate() {
            match u32::try_from(i) {
                Ok(i) => index.push(i),
                Err(_) => return Err(invalid(py, &format!("of_tet[{t}]"), i, "must be below 2³²")),
            }
        }
        let map = MaterialMap::new(list, names, index).or_raise(py)?;
        Ok(PyMaterialMap { map })
    }

    /// The distinct materials, in index order.
    #[getter]
    fn materials(&self) -> Vec<PyMaterial> {
        self.map
            .materials()
            .iter()
            .map(|&material| PyMaterial { material })
            .collect()
    }

    /// The material names.
    #[getter]
    fn names(&self) -> Vec<String> {
        self.map.names().to_vec()
    }

    /// The material index of every tet, shape (m,), int64.
    #[getter]
    fn of_tet<'py>(&self, py: Python<'py>) -> Bound<'py, PyAny> {
        let of_tet: Vec<usize> = self.map.of_tet().iter().map(|&i| i as usize).collect();
        index_vector(py, &of_tet)
    }

    fn __repr__(&self) -> String {
        format!(
            "MaterialMap({} materials over {} tets)",
            self.map.materials().len(),
            self.map.tet_count()
        )
    }
}

/// The material of every tet of `mesh` from a `Material` (the same for all) or a `MaterialMap`
/// (checked to cover this mesh's tets).
pub fn materials_of(
    py: Python<'_>,
    value: &Bound<'_, PyAny>,
    mesh: &MeshData,
) -> PyResult<MaterialMap> {
    if let Ok(one) = value.cast::<PyMaterial>() {
        return Ok(MaterialMap::uniform(
            one.get().material,
            mesh.mesh.tet_count(),
        ));
    }
    if let Ok(map) = value.cast::<PyMaterialMap>() {
        let map = map.get().map.clone();
        on_cells!(&mesh.mesh, m => map.check_tet_count(m)).or_raise(py)?;
        return Ok(map);
    }
    Err(invalid(
        py,
        "material",
        value
            .get_type()
            .name()
            .map(|n| n.to_string())
            .unwrap_or_default(),
        "must be a tetfem.Material or a tetfem.MaterialMap",
    ))
}
