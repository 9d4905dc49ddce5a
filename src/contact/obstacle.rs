//! Rigid obstacles: their signed distance, its gradient and Hessian at a point, and the
//! time of impact of a point moving along a straight line (continuous collision detection).

use nalgebra::{Matrix3, Rotation3, Vector3};

use crate::base::error::{Error, Result};
use crate::bc::amplitude::Amplitude;

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
    /// A solid box, axis-aligned or turned: the body stays outside.
    Box {
        /// Its centre (length).
        center: Vector3<f64>,
        /// Half its extents along its own axes, each > 0 (length).
        half_extents: Vector3<f64>,
        /// Its axes in world coordinates (the columns); identity for an axis-aligned box.
        rotation: Rotation3<f64>,
    },
}

/// A prescribed rigid translation of an obstacle: its shape at time t is the shape at rest
/// moved by the offset c(t) (length), so d_t(x) = d(x − c(t)). A spin in place is
/// [`Obstacle::with_spin`]; rotations that move the shape are not represented.
#[derive(Debug, Clone, PartialEq)]
pub enum ObstacleMotion {
    /// c(t) = v·t: a constant velocity v (length/time).
    Velocity(Vector3<f64>),
    /// c(t) = D·a(t): a displacement D (length) scaled by an amplitude a(t) (dimensionless).
    Amplitude {
        /// D (length).
        displacement: Vector3<f64>,
        /// a(t).
        amplitude: Amplitude,
    },
}

impl ObstacleMotion {
    /// The displacement D (length) reached at [`STATIC_TIME`](crate::bc::amplitude::STATIC_TIME)
    /// on a ramp from 0 at t = 0: c(t) = D·t up to t = 1, then D. What a static solve makes of
    /// a displacement given without an amplitude (its load steps follow the pseudo-time
    /// t = k/n), for scenes and Python alike.
    pub fn reaching(displacement: Vector3<f64>) -> Result<Self> {
        Ok(ObstacleMotion::Amplitude {
            displacement,
            amplitude: Amplitude::ramp(0.0, crate::bc::amplitude::STATIC_TIME)?,
        })
    }

    /// The offset c(t) (length) at time `t`.
    pub fn offset(&self, t: f64) -> Vector3<f64> {
        match self {
            ObstacleMotion::Velocity(v) => v * t,
            ObstacleMotion::Amplitude {
                displacement,
                amplitude,
            } => displacement * amplitude.value(t),
        }
    }
}

/// The largest Coulomb coefficient an obstacle takes: measured material pairs lie below ~2
/// (rubber on rough surfaces), and at 100 a contact holds a tangential load 100 times its normal
/// one, which is sticking for any load a run sees; 1e300 is an input error (μ·λ overflows).
pub const MAX_FRICTION: f64 = 100.0;

/// A rigid obstacle with a name (the CSV columns and error messages use it), fixed or moving
/// by a prescribed translation ([`with_motion`](Self::with_motion)), and spinning in place or
/// not ([`with_spin`](Self::with_spin)).
#[derive(Debug, Clone, PartialEq)]
pub struct Obstacle {
    name: String,
    shape: Shape,
    /// Coulomb's μ ≥ 0 (0: frictionless).
    friction: f64,
    /// Its prescribed translation (`None`: fixed).
    motion: Option<ObstacleMotion>,
    /// Its spin (`None`: it does not turn).
    spin: Option<Spin>,
}

/// A constant spin of an obstacle: the angular velocity ω (rad/time, a vector along the axis,
/// right-handed) about the axis through the pivot p, a point of the obstacle's placement as given
/// that moves with its translation c(t). The obstacle's material point at x moves at
///
/// v(x, t) = ċ(t) + ω × (x − (p + c(t))),
///
/// and over a step of duration Δt it goes from x to c(t + Δt) + p + R(ω·Δt)·(x − c(t) − p), R
/// the exact rotation by the angle |ω|·Δt about ω (not the first-order x + ω × r·Δt, which
/// spirals outward on large steps).
///
/// Only spins that leave the obstacle's shape in place are represented, so its distance,
/// gradient, Hessian and time of impact do not change and only friction's slip does: a
/// half-space spinning about an axis along its normal (a turntable), a sphere about an axis
/// through its centre (a roller, a ball). See [`Obstacle::with_spin`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Spin {
    /// ω (rad/time).
    pub omega: Vector3<f64>,
    /// p (length), in the obstacle's placement as given (it moves with c(t)).
    pub pivot: Vector3<f64>,
}

/// The relative tolerance of [`Obstacle::with_spin`]'s checks that a spin leaves the shape in
/// place (|ω̂ × n| for a half-space; |p − c| over the radius for a sphere): round-off of unit
/// vectors and coordinates typed in a scene, far below any tilt that would move the shape
/// visibly (1e-9 rad of tilt moves a 1 m turntable's rim by 1 nm).
pub const SPIN_TOLERANCE: f64 = 1e-9;

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
            motion: None,
            spin: None,
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
            motion: None,
            spin: None,
        })
    }

    /// The obstacle with Coulomb friction coefficient `mu` (dimensionless; see
    /// [`super::friction`]). [`Error::InvalidParameter`] unless in [0, [`MAX_FRICTION`]].
    pub fn with_friction(mut self, mu: f64) -> Result<Self> {
        if !(mu.is_finite() && (0.0..=MAX_FRICTION).contains(&mu)) {
            return Err(Error::invalid_parameter(
                format!("obstacle {}: friction", self.name),
                crate::base::error::short_number(mu),
                format!(
                    "must be between 0 and {MAX_FRICTION} (measured pairs lie below ~2; at {MAX_FRICTION} a contact already holds a tangential load {MAX_FRICTION}× its normal one)"
                ),
            ));
        }
        self.friction = mu;
        Ok(self)
    }

    /// Coulomb's μ (0: frictionless).
    pub fn friction(&self) -> f64 {
        self.friction
    }

    /// The obstacle moving by the prescribed translation `motion` (its shape as given is its
    /// placement at the offset c = 0; at time t it is moved by c(t), see [`ObstacleMotion`]).
    /// [`Error::InvalidParameter`] naming `<name>.velocity` or `<name>.displacement` unless
    /// that vector is finite.
    pub fn with_motion(mut self, motion: ObstacleMotion) -> Result<Self> {
        let (key, v) = match &motion {
            ObstacleMotion::Velocity(v) => ("velocity", v),
            ObstacleMotion::Amplitude { displacement, .. } => ("displacement", displacement),
        };
        check_finite(&self.name, key, v)?;
        self.motion = Some(motion);
        Ok(self)
    }

    /// Its prescribed translation (`None`: fixed).
    pub fn motion(&self) -> Option<&ObstacleMotion> {
        self.motion.as_ref()
    }

    /// The obstacle spinning at the constant angular velocity `omega` (rad/time, a vector along
    /// the axis, right-handed) about the axis through `pivot` (length, a point of its placement
    /// as given, moving with its translation): see [`Spin`] for the surface velocity
    /// v(x, t) = ċ(t) + ω × (x − (p + c(t))). A zero `omega` is no spin.
    ///
    /// Allowed: spins that leave the shape in place — a half-space about an axis along its
    /// normal (any pivot: a turntable), a sphere about an axis through its centre (`pivot` the
    /// centre: a roller or ball). Its distance, gradient, Hessian and time of impact are then
    /// those of the still shape, and the spin acts through friction only (the slip is measured
    /// against the surface's motion).
    ///
    /// Errors ([`Error::InvalidParameter`] naming `obstacle <name>: spin` or `spin_axis_point`):
    /// a non-finite vector; a spin that would move the shape (a box, a half-space about a tilted
    /// axis, a sphere about an axis off its centre; tolerance [`SPIN_TOLERANCE`]).
    pub fn with_spin(mut self, omega: Vector3<f64>, pivot: Vector3<f64>) -> Result<Self> {
        check_finite(&self.name, "spin", &omega)?;
        check_finite(&self.name, "spin_axis_point", &pivot)?;
        let rate = omega.norm();
        if rate == 0.0 {
            self.spin = None;
            return Ok(self);
        }
        let allowed = "a spin must leave the obstacle's shape in place: a half_space about an \
                       axis along its normal, a sphere about an axis through its centre \
                       (spin_axis_point = the centre); a box cannot spin";
        let (key, value, fits) = match self.shape {
            Shape::HalfSpace { normal, .. } => (
                "spin",
                format!("{:?} (normal {:?})", omega.as_slice(), normal.as_slice()),
                (omega / rate).cross(&normal).norm() <= SPIN_TOLERANCE,
            ),
            Shape::Sphere { center, radius } => (
                "spin_axis_point",
                format!("{:?} (centre {:?})", pivot.as_slice(), center.as_slice()),
                (pivot - center).norm() <= SPIN_TOLERANCE * radius,
            ),
            Shape::Box { .. } => ("spin", format!("{:?}", omega.as_slice()), false),
        };
        if !fits {
            return Err(Error::invalid_parameter(
                format!("obstacle {}: {key}", self.name),
                value,
                allowed,
            ));
        }
        self.spin = Some(Spin { omega, pivot });
        Ok(self)
    }

    /// Its spin (`None`: it does not turn).
    pub fn spin(&self) -> Option<&Spin> {
        self.spin.as_ref()
    }

    /// The rotational part of the displacement over a step of `duration` (time) of its material
    /// point at `q` (length, relative to its current offset: x − c(t)): (R(ω·Δt) − I)·(q − p),
    /// R the exact rotation by |ω|·Δt about ω (length; zero without a spin). The whole
    /// displacement of that point is this plus the translation c(t + Δt) − c(t).
    pub fn surface_turn(&self, q: &Vector3<f64>, duration: f64) -> Vector3<f64> {
        match self.spin {
            Some(Spin { omega, pivot }) => {
                let r = q - pivot;
                Rotation3::from_scaled_axis(omega * duration) * r - r
            }
            None => Vector3::zeros(),
        }
    }

    /// The offset c(t) (length) of its placement at time `t` (zero for a fixed obstacle).
    pub fn offset(&self, t: f64) -> Vector3<f64> {
        self.motion
            .as_ref()
            .map_or_else(Vector3::zeros, |m| m.offset(t))
    }

    /// The axis-aligned solid box [`min`, `max`]; the body must stay outside.
    ///
    /// Errors ([`Error::InvalidParameter`]): non-finite corners, or a zero or negative extent
    /// (`max` − `min` must be > 0 on every axis).
    pub fn aligned_box(
        name: impl Into<String>,
        min: Vector3<f64>,
        max: Vector3<f64>,
    ) -> Result<Self> {
        let name = name.into();
        check_finite(&name, "min", &min)?;
        check_finite(&name, "max", &max)?;
        Self::oriented_box(
            name,
            0.5 * (min + max),
            0.5 * (max - min),
            Rotation3::identity(),
        )
    }

    /// The solid box of centre `center` and half extents `half_extents` along the axes of
    /// `rotation` (its columns, in world coordinates); the body must stay outside.
    ///
    /// Errors ([`Error::InvalidParameter`]): a non-finite centre, a half extent that is not
    /// finite and > 0.
    pub fn oriented_box(
        name: impl Into<String>,
        center: Vector3<f64>,
        half_extents: Vector3<f64>,
        rotation: Rotation3<f64>,
    ) -> Result<Self> {
        let name = name.into();
        check_finite(&name, "center", &center)?;
        if !half_extents.iter().all(|h| h.is_finite() && *h > 0.0) {
            return Err(Error::invalid_parameter(
                format!("obstacle {name}: extents"),
                format!("{:?}", (2.0 * half_extents).as_slice()),
                "must be finite and > 0 on every axis",
            ));
        }
        Ok(Obstacle {
            name,
            shape: Shape::Box {
                center,
                half_extents,
                rotation,
            },
            friction: 0.0,
            motion: None,
            spin: None,
        })
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
    /// Half-space: n·(x − p); sphere: |x − c| − R; box: with q = |Rᵀ(x − c)| − h per axis,
    /// |max(q, 0)| + min(maxᵢ qᵢ, 0).
    pub fn distance(&self, x: &Vector3<f64>) -> f64 {
        match self.shape {
            Shape::HalfSpace { point, normal } => normal.dot(&(x - point)),
            Shape::Sphere { center, radius } => (x - center).norm() - radius,
            Shape::Box {
                center,
                half_extents,
                rotation,
            } => {
                let q = (rotation.inverse() * (x - center)).abs() - half_extents;
                q.map(|v| v.max(0.0)).norm() + q.max().min(0.0)
            }
        }
    }

    /// For a box: its rotation and the outside part w of the local position Rᵀ(x − c) (per
    /// axis, signed: the excess beyond the face, 0 within the slab); `None` inside or for
    /// other shapes.
    fn box_excess(&self, x: &Vector3<f64>) -> Option<(Rotation3<f64>, Vector3<f64>)> {
        let Shape::Box {
            center,
            half_extents,
            rotation,
        } = self.shape
        else {
            return None;
        };
        let p = rotation.inverse() * (x - center);
        let w = Vector3::from_fn(|i, _| {
            let excess = p[i].abs() - half_extents[i];
            if excess > 0.0 {
                excess.copysign(p[i])
            } else {
                0.0
            }
        });
        (w.norm() > 0.0).then_some((rotation, w))
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
            Shape::Box {
                center,
                half_extents,
                rotation,
            } => match self.box_excess(x) {
                Some((rotation, w)) => rotation * w.normalize(),
                // Inside (a state the barrier never accepts): the nearest face's normal.
                None => {
                    let p = rotation.inverse() * (x - center);
                    let q = p.abs() - half_extents;
                    let axis = q.imax();
                    rotation * (Vector3::ith(axis, 1.0) * p[axis].signum())
                }
            },
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
            // Outside a box the distance is that to a face (flat), an edge (a cylinder's) or a
            // corner (a sphere's): (P − n·nᵀ)/|w|, P the projector on the axes beyond the box.
            Shape::Box { .. } => match self.box_excess(x) {
                Some((rotation, w)) => {
                    let length = w.norm();
                    let n = w / length;
                    let active =
                        Matrix3::from_diagonal(&w.map(|v| if v != 0.0 { 1.0 } else { 0.0 }));
                    let local = (active - n * n.transpose()) / length;
                    rotation.matrix() * local * rotation.matrix().transpose()
                }
                None => Matrix3::zeros(),
            },
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
            Shape::Box {
                center,
                half_extents,
                rotation,
            } => {
                // Slab test in the box's frame: the latest entry into the slabs |pᵢ + t·dpᵢ| ≤ hᵢ
                // before the earliest exit.
                let p = rotation.inverse() * (x - center);
                let dp = rotation.inverse() * dx;
                let (mut enter, mut exit) = (0.0f64, f64::INFINITY);
                for i in 0..3 {
                    if dp[i] == 0.0 {
                        if p[i].abs() > half_extents[i] {
                            return None;
                        }
                        continue;
                    }
                    let a = (-half_extents[i] - p[i]) / dp[i];
                    let b = (half_extents[i] - p[i]) / dp[i];
                    enter = enter.max(a.min(b));
                    exit = exit.min(a.max(b));
                }
                (enter <= exit).then_some(enter)
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

    #[test]
    fn a_spin_turns_the_surface_exactly_and_only_in_place() {
        let table = Obstacle::half_space("t", Vector3::zeros(), Vector3::z()).unwrap();
        let quarter = std::f64::consts::FRAC_PI_2;
        let spun = table
            .clone()
            .with_spin(Vector3::new(0.0, 0.0, quarter), Vector3::new(1.0, 0.0, 0.0))
            .unwrap();
        // A quarter turn about the axis through (1, 0, 0): (2, 0, 5) goes to (1, 1, 5), a
        // displacement (−1, 1, 0) to round-off (the exact rotation, not ω × r·Δt = (0, π/2, 0)).
        let shift = spun.surface_turn(&Vector3::new(2.0, 0.0, 5.0), 1.0);
        assert!(
            (shift - Vector3::new(-1.0, 1.0, 0.0)).amax() < 1e-15,
            "{shift}"
        );
        assert_eq!(table.surface_turn(&Vector3::x(), 1.0), Vector3::zeros());
        // The shape's queries are the still shape's.
        assert_eq!(spun.distance(&Vector3::new(3.0, 2.0, 0.5)), 0.5);
        // A tilted axis, a box, an axis off a sphere's centre: refused, naming the key.
        let tilted = table.with_spin(Vector3::new(0.1, 0.0, 1.0), Vector3::zeros());
        assert!(tilted.unwrap_err().to_string().contains("t: spin ="));
        let b = Obstacle::aligned_box("b", Vector3::zeros(), Vector3::repeat(1.0)).unwrap();
        assert!(b.with_spin(Vector3::z(), Vector3::zeros()).is_err());
        let ball = Obstacle::sphere("s", Vector3::new(0.0, 0.0, 1.0), 0.5).unwrap();
        let off = ball.clone().with_spin(Vector3::x(), Vector3::zeros());
        assert!(
            off.unwrap_err()
                .to_string()
                .contains("s: spin_axis_point =")
        );
        let roller = ball
            .with_spin(Vector3::x(), Vector3::new(0.0, 0.0, 1.0))
            .unwrap();
        assert!(roller.spin().is_some());
    }

    #[test]
    fn box_distance_gradient_hessian_and_impact() {
        let b = Obstacle::aligned_box("b", Vector3::zeros(), Vector3::new(2.0, 1.0, 1.0)).unwrap();
        // Beyond a face, an edge, a corner: 0.5, √2·0.5, √3·0.5.
        for (x, d) in [
            (Vector3::new(1.0, 0.5, 1.5), 0.5),
            (Vector3::new(2.5, 0.5, 1.5), 0.5f64 * 2f64.sqrt()),
            (Vector3::new(2.5, 1.5, 1.5), 0.5f64 * 3f64.sqrt()),
        ] {
            assert!((b.distance(&x) - d).abs() < 1e-15);
            // Gradient and Hessian against central differences (step 1e-6: O(h²) ≈ 1e-12
            // truncation, round-off 1e-16/1e-6 = 1e-10).
            let h = 1e-6;
            for a in 0..3 {
                let e = Vector3::ith(a, h);
                let fd = (b.distance(&(x + e)) - b.distance(&(x - e))) / (2.0 * h);
                assert!((fd - b.gradient(&x)[a]).abs() < 1e-8);
                let fd2 = (b.gradient(&(x + e)) - b.gradient(&(x - e))) / (2.0 * h);
                assert!((fd2 - b.hessian(&x).column(a)).amax() < 1e-6);
            }
        }
        // Straight down onto the top face from 1 above, moving 4: t = 1/4 exactly.
        let t = b.time_of_impact(&Vector3::new(1.0, 0.5, 2.0), &Vector3::new(0.0, 0.0, -4.0));
        assert_eq!(t, Some(0.25));
        // Passing beside it: no impact.
        let beside = b.time_of_impact(&Vector3::new(3.0, 0.5, 2.0), &Vector3::new(0.0, 0.0, -4.0));
        assert!(beside.is_none());
        let flat = Obstacle::aligned_box("b", Vector3::zeros(), Vector3::new(1.0, 0.0, 1.0));
        assert!(flat.unwrap_err().to_string().contains("b: extents"));
    }
}
