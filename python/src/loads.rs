//! `tetfem.Loads`: gravity, body forces, tractions, pressures, total forces on faces and nodal
//! forces on one mesh, as one consistent nodal force vector.

use std::sync::Arc;

use nalgebra::Vector3;
use pyo3::prelude::*;
use tetfem::bc::amplitude::{Amplitude, STATIC_TIME};
use tetfem::bc::loads::Loads;

use crate::amplitude::amplitude_of;
use crate::arrays;
use crate::errors::{OrRaise, invalid};
use crate::material::materials_of;
use crate::mesh::{MeshData, PyMesh, on_cells};

/// External loads on ``mesh``, accumulated in the order they are added (SI units in the
/// docstrings; any consistent units work). Gravity is also kept apart (``gravity``), as the
/// dynamic system tracks its potential separately; every ``add_*`` returns self.
///
/// Every ``add_*`` takes ``amplitude=``: the load times a(t), an ``Amplitude``, a number or an
/// (k, 2) array of (t, a) pairs (a table). A ``Simulation`` scales it by a(t) at each step's
/// time (``tetfem::analysis::dynamics::TimeData``); a static solve takes a(1) (the pseudo-time
/// ``STATIC_TIME``), which is what ``forces`` and ``resultant`` hold.
#[pyclass(name = "Loads", module = "tetfem")]
pub struct PyLoads {
    /// The mesh these loads are made for.
    pub data: Arc<MeshData>,
    /// Every load, gravity included, in the order added (what `forces` and `resultant` show;
    /// a static solve takes the library's sum of `other`, `gravity` and `timed` instead).
    pub all: Loads,
    /// Every load but gravity (what a dynamic system takes beside `gravity`).
    pub other: Loads,
    /// The sum of the gravity accelerations added without amplitude (m/s²).
    pub gravity: Vector3<f64>,
    /// The loads with an amplitude (gravity with one too), each apart with its amplitude (in
    /// `all` at its value at [`STATIC_TIME`], in neither `other` nor `gravity`).
    pub timed: Vec<(Loads, Amplitude)>,
}

impl PyLoads {
    /// Applies `add` to both force vectors (`all` first; an error leaves both unchanged).
    fn add_to_both(
        &mut self,
        py: Python<'_>,
        add: impl Fn(&mut Loads) -> tetfem::Result<()>,
    ) -> PyResult<()> {
        let mut all = self.all.clone();
        let mut other = self.other.clone();
        add(&mut all).or_raise(py)?;
        add(&mut other).or_raise(py)?;
        self.all = all;
        self.other = other;
        Ok(())
    }

    /// Adds the load `add` makes with `amplitude` (an `amplitude=` keyword): without one, to
    /// both force vectors; with one, apart (for dynamics) and at a([`STATIC_TIME`]) into
    /// `all` (as the scene builder does: static solves take the value at the pseudo-time 1).
    fn add_with(
        &mut self,
        py: Python<'_>,
        amplitude: Option<&Bound<'_, PyAny>>,
        add: impl Fn(&mut Loads) -> tetfem::Result<()>,
    ) -> PyResult<()> {
        let amplitude = amplitude_of(py, amplitude)?;
        if amplitude.is_one() {
            return self.add_to_both(py, add);
        }
        let mut single = on_cells!(&self.data.mesh, m => Loads::new(m));
        add(&mut single).or_raise(py)?;
        self.add_timed(py, single, amplitude)
    }

    /// Keeps `single` with its `amplitude` and adds its value at [`STATIC_TIME`] to `all`.
    fn add_timed(&mut self, py: Python<'_>, single: Loads, amplitude: Amplitude) -> PyResult<()> {
        self.all
            .add_scaled(&single, amplitude.value(STATIC_TIME))
            .or_raise(py)?;
        self.timed.push((single, amplitude));
        Ok(())
    }
}

#[pymethods]
impl PyLoads {
    #[new]
    fn new(mesh: &Bound<'_, PyMesh>) -> Self {
        let data = Arc::clone(&mesh.get().data);
        let all = on_cells!(&data.mesh, m => Loads::new(m));
        let other = all.clone();
        PyLoads {
            data,
            all,
            other,
            gravity: Vector3::zeros(),
            timed: Vec::new(),
        }
    }

    /// Gravity: the body force ρ·g (``acceleration`` g in m/s², e.g. (0, 0, −9.81)), ρ from
    /// ``material`` (a ``Material`` or a ``MaterialMap``: each tet's density). With an
    /// ``amplitude``, gravity times a(t) is a load like the others (not in ``gravity``).
    #[pyo3(signature = (acceleration, material, amplitude = None))]
    fn add_gravity<'py>(
        mut slf: PyRefMut<'py, Self>,
        acceleration: &Bound<'py, PyAny>,
        material: &Bound<'py, PyAny>,
        amplitude: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<PyRefMut<'py, Self>> {
        let py = slf.py();
        let g = arrays::vector3(py, acceleration, "acceleration")?;
        let materials = materials_of(py, material, &slf.data)?;
        let data = Arc::clone(&slf.data);
        let amplitude = amplitude_of(py, amplitude)?;
        if !amplitude.is_one() {
            let mut single = on_cells!(&data.mesh, m => Loads::new(m));
            on_cells!(&data.mesh, m => single.add_gravity(m, &materials, g)).or_raise(py)?;
            slf.add_timed(py, single, amplitude)?;
            return Ok(slf);
        }
        let mut all = slf.all.clone();
        on_cells!(&data.mesh, m => all.add_gravity(m, &materials, g)).or_raise(py)?;
        slf.all = all;
        slf.gravity += g;
        Ok(slf)
    }

    /// A uniform body force density b (N/m³) on the whole body.
    #[pyo3(signature = (force_density, amplitude = None))]
    fn add_body_force<'py>(
        mut slf: PyRefMut<'py, Self>,
        force_density: &Bound<'py, PyAny>,
        amplitude: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<PyRefMut<'py, Self>> {
        let py = slf.py();
        let b = arrays::vector3(py, force_density, "force_density")?;
        let data = Arc::clone(&slf.data);
        slf.add_with(
            py,
            amplitude,
            |l| on_cells!(&data.mesh, m => l.add_body_force(m, b).map(|_| ())),
        )?;
        Ok(slf)
    }

    /// A uniform traction t (Pa, a force per area) on boundary ``faces`` (shape (f, 3), rows of
    /// ``Mesh.boundary_faces()``, e.g. from ``Mesh.faces_on_plane``).
    #[pyo3(signature = (faces, traction, amplitude = None))]
    fn add_traction<'py>(
        mut slf: PyRefMut<'py, Self>,
        faces: &Bound<'py, PyAny>,
        traction: &Bound<'py, PyAny>,
        amplitude: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<PyRefMut<'py, Self>> {
        let py = slf.py();
        let t = arrays::vector3(py, traction, "traction")?;
        let data = Arc::clone(&slf.data);
        let faces = data.faces_of(py, faces, "faces")?;
        slf.add_with(
            py,
            amplitude,
            |l| on_cells!(&data.mesh, m => l.add_traction(m, &faces, t).map(|_| ())),
        )?;
        Ok(slf)
    }

    /// A total force (N) spread as a uniform traction over boundary ``faces`` (traction =
    /// force / total area).
    #[pyo3(signature = (faces, force, amplitude = None))]
    fn add_total_force<'py>(
        mut slf: PyRefMut<'py, Self>,
        faces: &Bound<'py, PyAny>,
        force: &Bound<'py, PyAny>,
        amplitude: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<PyRefMut<'py, Self>> {
        let py = slf.py();
        let f = arrays::vector3(py, force, "force")?;
        let data = Arc::clone(&slf.data);
        let faces = data.faces_of(py, faces, "faces")?;
        slf.add_with(
            py,
            amplitude,
            |l| on_cells!(&data.mesh, m => l.add_total_force_on_faces(m, &faces, f).map(|_| ())),
        )?;
        Ok(slf)
    }

    /// A pressure p (Pa) on boundary ``faces``, acting against each face's outward normal
    /// (p > 0 pushes into the body).
    #[pyo3(signature = (faces, pressure, amplitude = None))]
    fn add_pressure<'py>(
        mut slf: PyRefMut<'py, Self>,
        faces: &Bound<'py, PyAny>,
        pressure: f64,
        amplitude: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<PyRefMut<'py, Self>> {
        let py = slf.py();
        if !pressure.is_finite() {
            return Err(invalid(py, "pressure", pressure, "must be finite"));
        }
        let data = Arc::clone(&slf.data);
        let faces = data.faces_of(py, faces, "faces")?;
        slf.add_with(py, amplitude, |l| {
            for face in &faces {
                on_cells!(&data.mesh, m => {
                    let normal = face.area_vector(m)?.normalize();
                    l.add_traction(m, std::slice::from_ref(face), -normal * pressure)?;
                });
            }
            Ok(())
        })?;
        Ok(slf)
    }

    /// A point force (N) on each of ``nodes``: ``force`` of shape (3,) for every node, or (k, 3)
    /// with one row per node of ``nodes`` (in its order).
    #[pyo3(signature = (nodes, force, amplitude = None))]
    fn add_nodal_force<'py>(
        mut slf: PyRefMut<'py, Self>,
        nodes: &Bound<'py, PyAny>,
        force: &Bound<'py, PyAny>,
        amplitude: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<PyRefMut<'py, Self>> {
        let py = slf.py();
        let (nodes, _) = arrays::indices(py, nodes, "nodes", None)?;
        let values = arrays::rows_per_item(py, force, "force", nodes.len())?;
        slf.add_with(py, amplitude, |l| {
            for (i, &n) in nodes.iter().enumerate() {
                let f = Vector3::new(values[3 * i], values[3 * i + 1], values[3 * i + 2]);
                l.add_nodal_force(n, f)?;
            }
            Ok(())
        })?;
        Ok(slf)
    }

    /// The nodal forces of every load (gravity included), shape (n, 3), N; loads with an
    /// amplitude at its value at t = 1: the forces a static solve takes, summed here in the
    /// order of the ``add_*`` calls (a static solve takes the library's sum of the same forces,
    /// constant loads, then gravity with the solve's material, then the amplitude loads: equal
    /// to round-off).
    #[getter]
    fn forces<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        arrays::rows3(py, self.all.as_slice().to_vec())
    }

    /// The sum of the gravity accelerations added without amplitude, shape (3,), m/s².
    #[getter]
    fn gravity<'py>(&self, py: Python<'py>) -> Bound<'py, PyAny> {
        arrays::vector(py, vec![self.gravity.x, self.gravity.y, self.gravity.z])
    }

    /// The resultant (sum of all nodal forces), shape (3,), N.
    #[getter]
    fn resultant<'py>(&self, py: Python<'py>) -> Bound<'py, PyAny> {
        let r = self.all.resultant();
        arrays::vector(py, vec![r.x, r.y, r.z])
    }

    fn __repr__(&self) -> String {
        let r = self.all.resultant();
        format!("Loads(resultant [{:e}, {:e}, {:e}] N)", r.x, r.y, r.z)
    }
}
