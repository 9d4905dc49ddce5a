//! `tetfem.Obstacle`: rigid obstacles (half-space, sphere, box) with Coulomb friction, fixed or
//! moving by a prescribed translation, for the contact of `tetfem.solve_static(...,
//! obstacles=[...])` and `tetfem.Simulation(..., obstacles=[...])`.

use pyo3::prelude::*;
use tetfem::contact::{Contact, ContactParameters, Obstacle, ObstacleMotion, Shape};
use tetfem::fe::materials::MaterialMap;

use crate::amplitude::amplitude_of;
use crate::arrays;
use crate::errors::{OrRaise, invalid};
use crate::mesh::{MeshData, on_cells};

/// A rigid obstacle the body may touch but not enter (length units; SI m). Make one with
/// ``Obstacle.half_space(name, point, normal)`` (the side the normal points to is free),
/// ``Obstacle.sphere(name, center, radius)`` or ``Obstacle.box(name, min, max)`` (an
/// axis-aligned box). ``friction`` is Coulomb's μ (0: frictionless). Invalid geometry raises
/// ``InvalidInputError`` naming the obstacle and its key.
#[pyclass(name = "Obstacle", module = "tetfem", frozen)]
pub struct PyObstacle {
    /// The library's obstacle.
    pub obstacle: Obstacle,
}

impl PyObstacle {
    fn of(py: Python<'_>, obstacle: tetfem::Result<Obstacle>, friction: f64) -> PyResult<Self> {
        let obstacle = obstacle
            .and_then(|o| o.with_friction(friction))
            .or_raise(py)?;
        Ok(PyObstacle { obstacle })
    }
}

#[pymethods]
impl PyObstacle {
    /// The half-space behind the plane through ``point`` with outward ``normal`` (any length):
    /// the body stays on the side the normal points to.
    #[staticmethod]
    #[pyo3(signature = (name, point, normal, friction = 0.0))]
    fn half_space(
        py: Python<'_>,
        name: &str,
        point: &Bound<'_, PyAny>,
        normal: &Bound<'_, PyAny>,
        friction: f64,
    ) -> PyResult<Self> {
        let point = arrays::vector3(py, point, "point")?;
        let normal = arrays::vector3(py, normal, "normal")?;
        Self::of(py, Obstacle::half_space(name, point, normal), friction)
    }

    /// The solid sphere of ``center`` and ``radius`` (> 0).
    #[staticmethod]
    #[pyo3(signature = (name, center, radius, friction = 0.0))]
    fn sphere(
        py: Python<'_>,
        name: &str,
        center: &Bound<'_, PyAny>,
        radius: f64,
        friction: f64,
    ) -> PyResult<Self> {
        let center = arrays::vector3(py, center, "center")?;
        Self::of(py, Obstacle::sphere(name, center, radius), friction)
    }

    /// The solid axis-aligned box [min, max].
    #[staticmethod]
    #[pyo3(name = "box", signature = (name, min, max, friction = 0.0))]
    fn aligned_box(
        py: Python<'_>,
        name: &str,
        min: &Bound<'_, PyAny>,
        max: &Bound<'_, PyAny>,
        friction: f64,
    ) -> PyResult<Self> {
        let min = arrays::vector3(py, min, "min")?;
        let max = arrays::vector3(py, max, "max")?;
        Self::of(py, Obstacle::aligned_box(name, min, max), friction)
    }

    /// The same obstacle moving by a prescribed translation c(t) (its shape at time t is the
    /// shape at rest moved by c(t); a spin is ``spinning``): ``velocity`` v (m/s),
    /// c(t) = v·t; or ``displacement`` D (m) with an optional ``amplitude`` a(t) (an
    /// ``Amplitude``, a number or an (k, 2) table), c(t) = D·a(t); without one a ramp from 0 at
    /// t = 0 to 1 at t = 1 s, so that the obstacle starts where it was made and has moved by D at
    /// ``STATIC_TIME`` (as a scene's static ``displacement``). A static solve follows the
    /// pseudo-time t ∈ (0, 1] of its load steps (a velocity has moved the obstacle by v·1 at
    /// the end); a ``Simulation`` the run's time.
    /// Exactly one of ``velocity`` and ``displacement``; ``amplitude`` only with
    /// ``displacement``; each finite. Errors raise ``InvalidInputError`` naming the keyword.
    #[pyo3(signature = (*, velocity = None, displacement = None, amplitude = None))]
    fn moving(
        &self,
        py: Python<'_>,
        velocity: Option<&Bound<'_, PyAny>>,
        displacement: Option<&Bound<'_, PyAny>>,
        amplitude: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        let motion = match (velocity, displacement) {
            (Some(v), None) if amplitude.is_none() => {
                ObstacleMotion::Velocity(arrays::vector3(py, v, "velocity")?)
            }
            (Some(_), None) => {
                return Err(invalid(
                    py,
                    "amplitude",
                    "given with velocity",
                    "scales a displacement: give displacement with amplitude, or velocity alone",
                ));
            }
            (None, Some(d)) => {
                let displacement = arrays::vector3(py, d, "displacement")?;
                match amplitude.filter(|a| !a.is_none()) {
                    Some(a) => ObstacleMotion::Amplitude {
                        displacement,
                        amplitude: amplitude_of(py, Some(a))?,
                    },
                    None => ObstacleMotion::reaching(displacement).or_raise(py)?,
                }
            }
            (v, _) => {
                return Err(invalid(
                    py,
                    if v.is_some() {
                        "velocity"
                    } else {
                        "displacement"
                    },
                    if v.is_some() {
                        "given with displacement"
                    } else {
                        "None"
                    },
                    "give exactly one of velocity and displacement",
                ));
            }
        };
        let obstacle = self.obstacle.clone().with_motion(motion).or_raise(py)?;
        Ok(PyObstacle { obstacle })
    }

    /// The same obstacle spinning at the constant angular velocity ``omega`` ω (rad/s, a vector
    /// along the axis, right-handed) about the axis through ``axis_point`` p (m; default the
    /// sphere's centre or the half-space's point; it moves with the obstacle's translation): its
    /// surface at x moves at ċ(t) + ω × (x − (p + c(t))), and friction's slip is measured
    /// against it (over a step, the exact turn by |ω|·dt). Only spins that leave the shape in
    /// place: a half-space about an axis along its normal (a turntable), a sphere about an
    /// axis through its centre (a roller); a box cannot spin. A static solve turns it by |ω|·t
    /// over its pseudo-time t ∈ (0, 1]. A zero ``omega`` is no spin. Errors raise
    /// ``InvalidInputError`` naming ``spin`` or ``spin_axis_point``.
    #[pyo3(signature = (omega, axis_point = None))]
    fn spinning(
        &self,
        py: Python<'_>,
        omega: &Bound<'_, PyAny>,
        axis_point: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        let omega = arrays::vector3(py, omega, "omega")?;
        let pivot = match axis_point.filter(|p| !p.is_none()) {
            Some(p) => arrays::vector3(py, p, "axis_point")?,
            None => match *self.obstacle.shape() {
                Shape::Sphere { center, .. } => center,
                Shape::HalfSpace { point, .. } => point,
                Shape::Box { center, .. } => center,
            },
        };
        let obstacle = self.obstacle.clone().with_spin(omega, pivot).or_raise(py)?;
        Ok(PyObstacle { obstacle })
    }

    /// The spin ω (rad/s, a vector) of a spinning obstacle (see ``spinning``), ``None`` for
    /// one that does not turn.
    #[getter]
    fn spin<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyAny>> {
        self.obstacle
            .spin()
            .map(|s| arrays::vector(py, vec![s.omega.x, s.omega.y, s.omega.z]))
    }

    /// The obstacle's offset c(t) (m) at time ``t`` (s): zero for a fixed one.
    fn offset<'py>(&self, py: Python<'py>, t: f64) -> Bound<'py, PyAny> {
        let c = self.obstacle.offset(t);
        arrays::vector(py, vec![c.x, c.y, c.z])
    }

    /// Whether the obstacle moves (see ``moving``).
    #[getter]
    fn is_moving(&self) -> bool {
        self.obstacle.motion().is_some()
    }

    /// The obstacle's name.
    #[getter]
    fn name(&self) -> &str {
        self.obstacle.name()
    }

    /// Coulomb's friction coefficient μ (dimensionless).
    #[getter]
    fn friction(&self) -> f64 {
        self.obstacle.friction()
    }

    /// The signed distance (length units) from ``point`` to the obstacle's surface: > 0
    /// outside, < 0 inside.
    fn distance(&self, py: Python<'_>, point: &Bound<'_, PyAny>) -> PyResult<f64> {
        Ok(self
            .obstacle
            .distance(&arrays::vector3(py, point, "point")?))
    }

    fn __repr__(&self) -> String {
        let motion = match self.obstacle.motion() {
            None => String::new(),
            Some(ObstacleMotion::Velocity(v)) => format!(", velocity=({}, {}, {})", v.x, v.y, v.z),
            Some(ObstacleMotion::Amplitude {
                displacement: d, ..
            }) => {
                format!(", displacement=({}, {}, {}) × a(t)", d.x, d.y, d.z)
            }
        };
        let spin = match self.obstacle.spin() {
            None => String::new(),
            Some(s) => format!(", spin=({}, {}, {})", s.omega.x, s.omega.y, s.omega.z),
        };
        format!(
            "Obstacle({}, friction={}{motion}{spin})",
            self.obstacle.name(),
            self.obstacle.friction()
        )
    }
}

/// The contact of `obstacles` with the body `data` of `materials`: the barrier's default
/// scales ([`ContactParameters::for_mesh`] with the stiffest Young's modulus, which the
/// barrier must hold) unless `distance` (d̂, length) or `stiffness` (κ, Pa/m) are given, and
/// the impact-aware stiffness at the fraction `impact` of d̂ when given
/// ([`ContactParameters::with_impact_fraction`], 0 < f < 1; the library refuses others by
/// name). `None` without obstacles.
pub fn contact_of(
    py: Python<'_>,
    data: &MeshData,
    materials: &MaterialMap,
    obstacles: Option<Vec<PyRef<'_, PyObstacle>>>,
    (distance, stiffness): (Option<f64>, Option<f64>),
    impact: Option<f64>,
) -> PyResult<Option<Contact>> {
    let Some(obstacles) = obstacles.filter(|o| !o.is_empty()) else {
        return Ok(None);
    };
    let stiffest = materials.stiffest_youngs_modulus();
    let obstacles: Vec<Obstacle> = obstacles.iter().map(|o| o.obstacle.clone()).collect();
    // On either element order: on 10-node tets the contact points are the boundary's corner
    // and mid-edge nodes (`Contact::new`).
    py.detach(|| {
        on_cells!(&data.mesh, mesh => {
            let mut parameters = ContactParameters::for_mesh(mesh, stiffest)?;
            parameters.activation_distance = distance.unwrap_or(parameters.activation_distance);
            parameters.stiffness = stiffness.unwrap_or(parameters.stiffness);
            if let Some(f) = impact {
                parameters = parameters.with_impact_fraction(f)?;
            }
            Contact::new(mesh, obstacles, parameters)
        })
    })
    .map(Some)
    .or_raise(py)
}
