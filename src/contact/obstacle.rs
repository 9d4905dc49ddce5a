//! Rigid obstacles: their signed distance, its gradient and Hessian at a point, and the
//! time of impact of a point moving along a straight line (continuous collision detection).

use nalgebra::{Matrix3, Vector3};

use crate::error::{Error, Result};

/// The shape of a rigid obstacle. The body lives where the signed distance is positive.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Shape {
    /// The half-space n·(x − p) ≤ 0 (the ground): the body stays on the side `normal` points to.
    HalfSpace {
        /// A point on the plane (length).
        point: Vector3<f64>,
        /// The unit normal, pointing out of the obstacle into the body's side.
        normal: Vector3<f64>,
    },
    /// The solid ball |x − c| ≤ R: the body stays outside.
    Sphere {
        /// Its centre (length).
        center: Vector3<f64>,
        /// Its radius R > 0 (length).
        radius: f64,
    },
}

/// A rigid, fixed obstacle with a name (the CSV columns and error messages use it).
#[derive(Debug, Clone, PartialEq)]
pub struct Obstacle {
    name: String,
    shape: Shape,
    /// Coulomb's μ ≥ 0 (0: frictionless).
    friction: f64,
}

impl Obstacle {
    /// The half-space below the plane through `point` with normal `normal` (normalized here):
    /// the body must stay where n·(x − p) > 0.
    ///
    /// Errors ([`Error::InvalidParameter`] naming `<name>.normal` or `<name>.point`): a zero or
    /// non-finite normal, a non-finite point.
    pub fn half_space(
        name: impl Into<String>,
        point: Vector3<f64>,
        normal: Vector3<f64>,
    ) -> Result<Self> {
        let name = name.into();
        check_finite(&name, "point", &point)?;
        let length = normal.norm();
        if !(length.is_finite() && length > 0.0) {
            return Err(Error::invalid_parameter(
                format!("obstacle {name}: normal"),
                format!("{:?}", normal.as_slice()),
                "must be a finite, non-zero vector",
            ));
        }
        Ok(Obstacle {
            name,
            shape: Shape::HalfSpace {
                point,
                normal: normal / length,
            },
            friction: 0.0,
        })
    }

    /// The solid ball of radius `radius` around `center`; the body must stay outside.
    ///
    /// Errors ([`Error::InvalidParameter`]): a non-finite centre, a radius that is not finite
    /// and > 0.
    pub fn sphere(name: impl Into<String>, center: Vector3<f64>, radius: f64) -> Result<Self> {
        let name = name.into();
        check_finite(&name, "center", &center)?;
        if !(radius.is_finite() && radius > 0.0) {
            return Err(Error::invalid_parameter(
                format!("obstacle {name}: radius"),
                radius,
                "must be finite and > 0",
            ));
        }
        Ok(Obstacle {
            name,
            shape: Shape::Sphere { center, radius },
            friction: 0.0,
        })
    }

    /// The obstacle with Coulomb friction coefficient `mu` (dimensionless; see
    /// [`super::friction`]). [`Error::InvalidParameter`] unless finite and ≥ 0.
    pub fn with_friction(mut self, mu: f64) -> Result<Self> {
        if !(mu.is_finite() && mu >= 0.0) {
            return Err(Error::invalid_parameter(
                format!("obstacle {}: friction", self.name),
                mu,
                "must be finite and ≥ 0",
            ));
        }
        self.friction = mu;
        Ok(self)
    }

    /// Coulomb's μ (0: frictionless).
    pub fn friction(&self) -> f64 {
        self.friction
    }

    /// Its name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Its shape.
    pub fn shape(&self) -> &Shape {
        &self.shape
    }

    /// The signed distance d(x) (length): positive outside the obstacle, where the body lives.
    /// Half-space: n·(x − p); sphere: |x − c| − R.
    pub fn distance(&self, x: &Vector3<f64>) -> f64 {
        match self.shape {
            Shape::HalfSpace { point, normal } => normal.dot(&(x - point)),
            Shape::Sphere { center, radius } => (x - center).norm() - radius,
        }
    }

    /// ∇d(x), the unit outward normal of the obstacle at the point nearest x (dimensionless).
    /// At a sphere's centre (where it is undefined) it is +z.
    pub fn gradient(&self, x: &Vector3<f64>) -> Vector3<f64> {
        match self.shape {
            Shape::HalfSpace { normal, .. } => normal,
            Shape::Sphere { center, .. } => {
                let r = x - center;
                let length = r.norm();
                if length > 0.0 {
                    r / length
                } else {
                    Vector3::z()
                }
            }
        }
    }

    /// ∇²d(x) (1/length): zero for a half-space, (I − n·nᵀ)/|x − c| for a sphere (positive
    /// semi-definite: the distance to a ball is convex).
    pub fn hessian(&self, x: &Vector3<f64>) -> Matrix3<f64> {
        match self.shape {
            Shape::HalfSpace { .. } => Matrix3::zeros(),
            Shape::Sphere { center, .. } => {
                let r = x - center;
                let length = r.norm();
                if length == 0.0 {
                    return Matrix3::zeros();
                }
                let n = r / length;
                (Matrix3::identity() - n * n.transpose()) / length
            }
        }
    }

    /// The first t ≥ 0 at which the point x + t·dx touches the obstacle (d = 0), `None` if it
    /// never does; x must be outside (d(x) > 0). Exact: a linear equation for a half-space, the
    /// smaller root of |x − c + t·dx|² = R² (in the cancellation-free form) for a sphere.
    pub fn time_of_impact(&self, x: &Vector3<f64>, dx: &Vector3<f64>) -> Option<f64> {
        match self.shape {
            Shape::HalfSpace { point, normal } => {
                let approach = normal.dot(dx);
                (approach < 0.0).then(|| normal.dot(&(x - point)) / -approach)
            }
            Shape::Sphere { center, radius } => {
                let r = x - center;
                let a = dx.norm_squared();
                let b = 2.0 * r.dot(dx);
                let c = r.norm_squared() - radius * radius;
                let discriminant = b * b - 4.0 * a * c;
                if a == 0.0 || b >= 0.0 || discriminant < 0.0 {
                    return None;
                }
                // b < 0: q = (−b + √disc)/2 > 0, and the smaller root is c/q.
                let q = 0.5 * (-b + discriminant.sqrt());
                Some(c / q)
            }
        }
    }
}

fn check_finite(name: &str, key: &str, v: &Vector3<f64>) -> Result<()> {
    if v.iter().all(|x| x.is_finite()) {
        Ok(())
    } else {
        Err(Error::invalid_parameter(
            format!("obstacle {name}: {key}"),
            format!("{:?}", v.as_slice()),
            "must be finite",
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sphere_distance_and_impact() {
        let s = Obstacle::sphere("s", Vector3::new(0.0, 0.0, 1.0), 0.5).unwrap();
        let x = Vector3::new(0.0, 0.0, 2.0);
        assert_eq!(s.distance(&x), 0.5);
        // Moving straight down by 2 reaches the sphere's top (z = 1.5) at t = 0.25 exactly.
        let t = s.time_of_impact(&x, &Vector3::new(0.0, 0.0, -2.0)).unwrap();
        assert!((t - 0.25).abs() < 1e-15);
        assert!(s.time_of_impact(&x, &Vector3::new(0.0, 0.0, 1.0)).is_none());
        let g = Obstacle::half_space("g", Vector3::zeros(), Vector3::new(0.0, 0.0, 2.0)).unwrap();
        assert_eq!(
            g.time_of_impact(&x, &Vector3::new(0.0, 0.0, -4.0)),
            Some(0.5)
        );
        assert!(Obstacle::half_space("g", Vector3::zeros(), Vector3::zeros()).is_err());
        assert!(Obstacle::sphere("s", Vector3::zeros(), 0.0).is_err());
    }
}
