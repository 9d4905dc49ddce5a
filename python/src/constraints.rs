//! `tetfem.Constraints`: Dirichlet conditions (fixed axes, prescribed displacements, linear
//! displacement fields) on nodes of one mesh.

use std::sync::Arc;

use pyo3::prelude::*;
use tetfem::constraints::Constraints;

use crate::arrays::{self, floats, index_vector, indices};
use crate::errors::{OrRaise, invalid};
use crate::mesh::{MeshData, PyMesh, on_cells};
use crate::names;

/// Dirichlet conditions on the nodes of ``mesh``: ``fix`` (zero displacement on chosen axes),
/// ``prescribe`` (given displacements, length units) and ``prescribe_linear`` (a linear field
/// u = A·x + b). A DOF given two different values raises ``InvalidInputError`` naming the node,
/// the axis and both values.
#[pyclass(name = "Constraints", module = "tetfem")]
pub struct PyConstraints {
    /// The mesh these constraints are made for.
    pub data: Arc<MeshData>,
    /// The constraints.
    pub constraints: Constraints,
}

impl PyConstraints {
    /// Node indices as given (order kept, for per-node values), each checked to exist.
    fn nodes_in_order(&self, py: Python<'_>, nodes: &Bound<'_, PyAny>) -> PyResult<Vec<usize>> {
        let (list, _) = indices(py, nodes, "nodes", None)?;
        let count = self.data.mesh.node_count();
        if let Some(&bad) = list.iter().find(|&&n| n >= count) {
            return Err(invalid(
                py,
                "nodes",
                bad,
                &format!("node {bad} does not exist (the mesh has {count} nodes)"),
            ));
        }
        if list.is_empty() {
            return Err(invalid(py, "nodes", "[]", "must select at least one node"));
        }
        Ok(list)
    }

    /// Prescribes `values[i]` (one row of three per node) on the chosen axes of `nodes[i]`.
    fn prescribe_rows(
        &mut self,
        py: Python<'_>,
        nodes: &[usize],
        values: &[f64],
        axes: [bool; 3],
    ) -> PyResult<()> {
        // Checked on a copy first, so that an error leaves the constraints unchanged.
        let mut trial = self.constraints.clone();
        for (i, &n) in nodes.iter().enumerate() {
            for axis in (0..3).filter(|&a| axes[a]) {
                trial
                    .prescribe_axis(n, axis, values[3 * i + axis])
                    .or_raise(py)?;
            }
        }
        self.constraints = trial;
        Ok(())
    }
}

#[pymethods]
impl PyConstraints {
    #[new]
    fn new(mesh: &Bound<'_, PyMesh>) -> Self {
        let data = Arc::clone(&mesh.get().data);
        let constraints = on_cells!(&data.mesh, m => Constraints::new(m));
        PyConstraints { data, constraints }
    }

    /// Fixes the chosen axes of ``nodes`` at zero (all three: a clamp; fewer: a roller or a
    /// symmetry condition). Returns self.
    #[pyo3(signature = (nodes, axes = "xyz"))]
    fn fix<'py>(
        mut slf: PyRefMut<'py, Self>,
        nodes: &Bound<'py, PyAny>,
        axes: &str,
    ) -> PyResult<PyRefMut<'py, Self>> {
        let py = slf.py();
        let axes = names::axes(py, axes)?;
        let nodes = slf.data.nodes_of(py, nodes, "nodes")?;
        slf.constraints.fix_axes(&nodes, axes).or_raise(py)?;
        Ok(slf)
    }

    /// Prescribes the displacement (length units) of the chosen axes of ``nodes``:
    /// ``displacement`` of shape (3,) for all of them, or (k, 3) with one row per node of
    /// ``nodes`` (in its order). Returns self.
    #[pyo3(signature = (nodes, displacement, axes = "xyz"))]
    fn prescribe<'py>(
        mut slf: PyRefMut<'py, Self>,
        nodes: &Bound<'py, PyAny>,
        displacement: &Bound<'py, PyAny>,
        axes: &str,
    ) -> PyResult<PyRefMut<'py, Self>> {
        let py = slf.py();
        let axes = names::axes(py, axes)?;
        let nodes = slf.nodes_in_order(py, nodes)?;
        let values = arrays::rows_per_item(py, displacement, "displacement", nodes.len())?;
        slf.prescribe_rows(py, &nodes, &values, axes)?;
        Ok(slf)
    }

    /// Prescribes the linear displacement field u(x) = gradient · x + offset on all three
    /// axes of ``nodes`` (``gradient`` shape (3, 3), dimensionless; ``offset`` length units),
    /// e.g. the boundary values of a patch test. Returns self.
    #[pyo3(signature = (nodes, gradient, offset = None))]
    fn prescribe_linear<'py>(
        mut slf: PyRefMut<'py, Self>,
        nodes: &Bound<'py, PyAny>,
        gradient: &Bound<'py, PyAny>,
        offset: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<PyRefMut<'py, Self>> {
        let py = slf.py();
        let nodes = slf.nodes_in_order(py, nodes)?;
        let (a, rows) = floats(py, gradient, "gradient", Some(3), false)?;
        if rows != 3 {
            return Err(invalid(
                py,
                "gradient.shape",
                format!("({rows}, 3)"),
                "must be (3, 3)",
            ));
        }
        let b = match offset {
            Some(o) => arrays::vector3(py, o, "offset")?,
            None => nalgebra::Vector3::zeros(),
        };
        let points = slf.data.mesh.nodes();
        let values: Vec<f64> = nodes
            .iter()
            .flat_map(|&n| {
                let x = points[n];
                [0, 1, 2]
                    .map(|i| a[3 * i] * x[0] + a[3 * i + 1] * x[1] + a[3 * i + 2] * x[2] + b[i])
            })
            .collect();
        slf.prescribe_rows(py, &nodes, &values, [true; 3])?;
        Ok(slf)
    }

    /// Number of constrained DOFs.
    #[getter]
    fn count(&self) -> usize {
        self.constraints.count()
    }

    /// The constrained DOFs (3·node + axis), ascending int64 array.
    #[getter]
    fn constrained_dofs<'py>(&self, py: Python<'py>) -> Bound<'py, PyAny> {
        let dofs: Vec<usize> = (0..self.constraints.dof_count())
            .filter(|&d| self.constraints.get(d).is_some())
            .collect();
        index_vector(py, &dofs)
    }

    fn __repr__(&self) -> String {
        format!(
            "Constraints({} of {} DOFs constrained)",
            self.constraints.count(),
            self.constraints.dof_count()
        )
    }
}
