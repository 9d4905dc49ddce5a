//! `tetfem.Constraints`: Dirichlet conditions (fixed axes, prescribed displacements, linear
//! displacement fields) on nodes of one mesh.

use std::sync::Arc;

use nalgebra::{Matrix3, Vector3};
use pyo3::prelude::*;
use tetfem::bc::amplitude::STATIC_TIME;
use tetfem::bc::boundary_motion::{BoundaryMotion, Motion, RigidMotion};
use tetfem::bc::constraints::Constraints;

use crate::amplitude::amplitude_of;
use crate::arrays::{self, floats, index_vector, indices};
use crate::errors::{OrRaise, invalid};
use crate::mesh::{MeshData, PyMesh, on_cells};
use crate::names;

/// Dirichlet conditions on the nodes of ``mesh``: ``fix`` (zero displacement on chosen axes),
/// ``prescribe`` (given displacements, length units) and ``prescribe_linear`` (a linear field
/// u = A·x + b) and ``prescribe_rigid`` (a rigid motion: rotation about an axis and
/// translation). A DOF given two different values raises ``InvalidInputError`` naming the node,
/// the axis and both values.
///
/// ``prescribe``, ``prescribe_linear`` and ``prescribe_rigid`` take ``amplitude=`` (an
/// ``Amplitude``, a number or an (k, 2) array of (t, a) pairs): the support then moves with
/// a(t) (``tetfem::bc::boundary_motion::BoundaryMotion``): a ``Simulation`` follows it in time
/// (displacement, velocity and acceleration of the support), a static solve takes its value at
/// the pseudo-time t = 1 (a nonlinear one through its load steps, a rigid motion by exact
/// rotations).
#[pyclass(name = "Constraints", module = "tetfem")]
pub struct PyConstraints {
    /// The mesh these constraints are made for.
    pub data: Arc<MeshData>,
    /// The constraints, moving ones at their values at [`STATIC_TIME`].
    pub constraints: Constraints,
    /// Every prescribed motion (constant ones too): what a nonlinear static solve's load steps
    /// follow.
    pub motions: BoundaryMotion,
    /// The motions that change in time: what a `Simulation` moves.
    pub moving: BoundaryMotion,
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

    /// Moves the chosen `axes` of `nodes` by `motion`: prescribed at its value at
    /// [`STATIC_TIME`], kept in `motions` (and in `moving` unless constant). An error leaves
    /// the constraints unchanged.
    fn add_motion(
        &mut self,
        py: Python<'_>,
        nodes: &[usize],
        axes: [bool; 3],
        motion: Motion,
    ) -> PyResult<()> {
        let mut trial = self.constraints.clone();
        let mut motions = self.motions.clone();
        let mut moving = self.moving.clone();
        let mut single = BoundaryMotion::new();
        single.add(nodes, axes, motion.clone()).or_raise(py)?;
        single
            .prescribe_at(self.data.mesh.nodes(), STATIC_TIME, &mut trial)
            .or_raise(py)?;
        if !motion.is_constant() {
            moving.add(nodes, axes, motion.clone()).or_raise(py)?;
        }
        motions.add(nodes, axes, motion).or_raise(py)?;
        self.constraints = trial;
        self.motions = motions;
        self.moving = moving;
        Ok(())
    }
}

#[pymethods]
impl PyConstraints {
    #[new]
    fn new(mesh: &Bound<'_, PyMesh>) -> Self {
        let data = Arc::clone(&mesh.get().data);
        let constraints = on_cells!(&data.mesh, m => Constraints::new(m));
        PyConstraints {
            data,
            constraints,
            motions: BoundaryMotion::new(),
            moving: BoundaryMotion::new(),
        }
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
    /// ``nodes`` (in its order). With ``amplitude``: u(t) = displacement·a(t) (a (3,)
    /// displacement only). Returns self.
    #[pyo3(signature = (nodes, displacement, axes = "xyz", amplitude = None))]
    fn prescribe<'py>(
        mut slf: PyRefMut<'py, Self>,
        nodes: &Bound<'py, PyAny>,
        displacement: &Bound<'py, PyAny>,
        axes: &str,
        amplitude: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<PyRefMut<'py, Self>> {
        let py = slf.py();
        let axes = names::axes(py, axes)?;
        let nodes = slf.nodes_in_order(py, nodes)?;
        if amplitude.is_some_and(|a| !a.is_none()) {
            let amplitude = amplitude_of(py, amplitude)?;
            let displacement = arrays::vector3(py, displacement, "displacement")?;
            let motion = Motion::Uniform {
                displacement,
                amplitude,
            };
            slf.add_motion(py, &nodes, axes, motion)?;
            return Ok(slf);
        }
        let values = arrays::rows_per_item(py, displacement, "displacement", nodes.len())?;
        slf.prescribe_rows(py, &nodes, &values, axes)?;
        Ok(slf)
    }

    /// Moves ``nodes`` rigidly: a rotation by θ(t) = ``angle``·a(t) (rad) about the line
    /// through ``point`` along ``axis`` (any length > 0), then a translation
    /// ``translation``·a(t) (length units): u = p + R(θ)·(x − p) + d·a(t) − x, an exact
    /// rotation (``tetfem::bc::boundary_motion::RigidMotion``). ``amplitude`` defaults to constant
    /// 1; ``axes`` chooses the constrained axes. Returns self.
    #[pyo3(signature = (nodes, axis = None, point = None, angle = 0.0, translation = None, amplitude = None, axes = "xyz"))]
    #[allow(clippy::too_many_arguments)]
    fn prescribe_rigid<'py>(
        mut slf: PyRefMut<'py, Self>,
        nodes: &Bound<'py, PyAny>,
        axis: Option<&Bound<'py, PyAny>>,
        point: Option<&Bound<'py, PyAny>>,
        angle: f64,
        translation: Option<&Bound<'py, PyAny>>,
        amplitude: Option<&Bound<'py, PyAny>>,
        axes: &str,
    ) -> PyResult<PyRefMut<'py, Self>> {
        let py = slf.py();
        let axes = names::axes(py, axes)?;
        let nodes = slf.nodes_in_order(py, nodes)?;
        let vector = |v: Option<&Bound<'py, PyAny>>, name: &str, default: Vector3<f64>| match v {
            Some(v) => arrays::vector3(py, v, name),
            None => Ok(default),
        };
        let axis = vector(axis, "axis", Vector3::z())?;
        let point = vector(point, "point", Vector3::zeros())?;
        let translation = vector(translation, "translation", Vector3::zeros())?;
        let amplitude = amplitude_of(py, amplitude)?;
        let rigid = RigidMotion::new(axis, point, angle, translation, amplitude).or_raise(py)?;
        slf.add_motion(py, &nodes, axes, Motion::Rigid(rigid))?;
        Ok(slf)
    }

    /// Prescribes the linear displacement field u(x) = gradient · x + offset on all three
    /// axes of ``nodes`` (``gradient`` shape (3, 3), dimensionless; ``offset`` length units),
    /// e.g. the boundary values of a patch test. With ``amplitude``: u(x, t) = (gradient · x +
    /// offset)·a(t). Returns self.
    #[pyo3(signature = (nodes, gradient, offset = None, amplitude = None))]
    fn prescribe_linear<'py>(
        mut slf: PyRefMut<'py, Self>,
        nodes: &Bound<'py, PyAny>,
        gradient: &Bound<'py, PyAny>,
        offset: Option<&Bound<'py, PyAny>>,
        amplitude: Option<&Bound<'py, PyAny>>,
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
        if amplitude.is_some_and(|a| !a.is_none()) {
            let amplitude = amplitude_of(py, amplitude)?;
            let matrix = Matrix3::from_row_slice(&a);
            let motion = Motion::linear_field(matrix, b, amplitude).or_raise(py)?;
            slf.add_motion(py, &nodes, [true; 3], motion)?;
            return Ok(slf);
        }
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
