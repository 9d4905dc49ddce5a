//! Prescribed displacements that follow time: a vector times an amplitude, a linear field
//! u = (A·x + b)·a(t), or a rigid motion (an exact rotation about an axis through a point by
//! θ(t) = θ_max·a(t), plus a translation d·a(t)), each on a set of nodes and axes.
//!
//! [`BoundaryMotion`] evaluates the displacement, velocity and acceleration of every moving DOF
//! at a time: statics take the values at one time ([`prescribe_at`](BoundaryMotion::prescribe_at)
//! into [`Constraints`]), dynamics all three each step (through
//! [`LinearSystem`](crate::analysis::dynamics::LinearSystem)'s time data).
//!
//! The rotation is exact, not linearized: a clamp twisted by a large angle moves its nodes on
//! circles, and the linearized u = θ×(x − p) would stretch the clamped section by a factor
//! √(1 + θ²) instead. Under a linear force model a large rotation still gives spurious strain
//! (the linear strain of a rigid rotation is not zero); the corotational model is the one for it.

use nalgebra::{Matrix3, Rotation3, Unit, Vector3};

use crate::base::error::{Error, Result};
use crate::bc::amplitude::Amplitude;
use crate::bc::constraints::Constraints;

/// The largest |angle| (radians) a [`RigidMotion`] takes: the rounding of θ itself, ε·|θ|,
/// is 2.2e-10 rad there (R(θ) moves a node at 1 m by that much); at 1e300° sin and cos of the
/// angle are noise.
pub const MAX_RIGID_ANGLE: f64 = 1e6;

/// A rigid motion of a node set: rotation by θ(t) = `angle`·a(t) about the line through `point`
/// along `axis`, then translation by `translation`·a(t):
///
/// x ↦ p + R(θ)·(x − p) + d·a(t),  u = p + R(θ)·(x − p) + d·a(t) − x.
#[derive(Debug, Clone, PartialEq)]
pub struct RigidMotion {
    axis: Unit<Vector3<f64>>,
    point: Vector3<f64>,
    angle: f64,
    translation: Vector3<f64>,
    amplitude: Amplitude,
}

impl RigidMotion {
    /// A rigid motion: `axis` (any length > 0, normalized here), `point` on it (length units),
    /// `angle` θ_max (radians), `translation` d (length units). [`Error::InvalidParameter`] for
    /// an axis of zero length, a non-finite entry or |angle| > [`MAX_RIGID_ANGLE`].
    pub fn new(
        axis: Vector3<f64>,
        point: Vector3<f64>,
        angle: f64,
        translation: Vector3<f64>,
        amplitude: Amplitude,
    ) -> Result<Self> {
        let all = axis
            .iter()
            .chain(point.iter())
            .chain(translation.iter())
            .chain(std::iter::once(&angle));
        if let Some(bad) = all.copied().find(|v| !v.is_finite()) {
            return Err(Error::invalid_parameter(
                "rigid motion",
                bad,
                "axis, point, angle and translation must be finite",
            ));
        }
        if angle.abs() > MAX_RIGID_ANGLE {
            return Err(Error::invalid_parameter(
                "rigid motion angle",
                format!("{angle:e} rad ({:e}°)", angle.to_degrees()),
                format!(
                    "|angle| must be at most {MAX_RIGID_ANGLE:e} rad ({:.3e}°, {:.3e} turns): beyond it the angle's own round-off passes 2e-10 rad",
                    MAX_RIGID_ANGLE.to_degrees(),
                    MAX_RIGID_ANGLE / std::f64::consts::TAU
                ),
            ));
        }
        let length = axis.norm();
        if length == 0.0 {
            return Err(Error::invalid_parameter(
                "rigid motion axis",
                format!("[{}, {}, {}]", axis.x, axis.y, axis.z),
                "must have a non-zero length",
            ));
        }
        Ok(RigidMotion {
            axis: Unit::new_unchecked(axis / length),
            point,
            angle,
            translation,
            amplitude,
        })
    }

    /// [u, u̇, ü] of the material point `x` at time `t` (length, length/time, length/time²):
    /// with r = R(θ)·(x − p) and k the unit axis, u̇ = θ̇·k×r + d·ȧ and
    /// ü = θ̈·k×r + θ̇²·k×(k×r) + d·ä.
    pub fn at(&self, x: &Vector3<f64>, t: f64) -> [Vector3<f64>; 3] {
        self.at_scaled(x, t, 1.0)
    }

    /// [`at`](Self::at) with the amplitude's value and derivatives times `scale`: the rigid
    /// motion by `scale`·θ(t) and `scale`·d·a(t) (what a load step of a static solve takes).
    pub fn at_scaled(&self, x: &Vector3<f64>, t: f64, scale: f64) -> [Vector3<f64>; 3] {
        let [a, rate, acceleration] = self.amplitude.derivatives(t).map(|v| scale * v);
        let rotation = Rotation3::from_axis_angle(&self.axis, self.angle * a);
        let r = rotation * (x - self.point);
        let k_cross_r = self.axis.cross(&r);
        let (theta_rate, theta_acceleration) = (self.angle * rate, self.angle * acceleration);
        [
            self.point + r + self.translation * a - x,
            k_cross_r * theta_rate + self.translation * rate,
            k_cross_r * theta_acceleration
                + self.axis.cross(&k_cross_r) * (theta_rate * theta_rate)
                + self.translation * acceleration,
        ]
    }
}

/// How a set of nodes moves.
#[derive(Debug, Clone, PartialEq)]
pub enum Motion {
    /// u = d·a(t) (d in length units).
    Uniform {
        /// d.
        displacement: Vector3<f64>,
        /// a(t).
        amplitude: Amplitude,
    },
    /// u = (A·x + b)·a(t) (A dimensionless, b in length units).
    LinearField {
        /// A.
        matrix: Matrix3<f64>,
        /// b.
        offset: Vector3<f64>,
        /// a(t).
        amplitude: Amplitude,
    },
    /// A [`RigidMotion`].
    Rigid(RigidMotion),
}

impl Motion {
    /// A linear field; [`Error::InvalidParameter`] naming the entry if one of A or b is not
    /// finite.
    pub fn linear_field(
        matrix: Matrix3<f64>,
        offset: Vector3<f64>,
        amplitude: Amplitude,
    ) -> Result<Self> {
        for i in 0..3 {
            for j in 0..3 {
                if !matrix[(i, j)].is_finite() {
                    return Err(Error::invalid_parameter(
                        format!("A[{i}][{j}]"),
                        matrix[(i, j)],
                        "must be finite",
                    ));
                }
            }
            if !offset[i].is_finite() {
                return Err(Error::invalid_parameter(
                    format!("b[{i}]"),
                    offset[i],
                    "must be finite",
                ));
            }
        }
        Ok(Motion::LinearField {
            matrix,
            offset,
            amplitude,
        })
    }

    /// [u, u̇, ü] of the material point `x` at time `t`.
    pub fn at(&self, x: &Vector3<f64>, t: f64) -> [Vector3<f64>; 3] {
        self.at_scaled(x, t, 1.0)
    }

    /// [`at`](Self::at) with the amplitude times `scale` (for a rigid motion, the rotation
    /// angle and the translation scaled; for the others, u scaled).
    pub fn at_scaled(&self, x: &Vector3<f64>, t: f64, scale: f64) -> [Vector3<f64>; 3] {
        match self {
            Motion::Uniform {
                displacement,
                amplitude,
            } => amplitude.derivatives(t).map(|a| displacement * (scale * a)),
            Motion::LinearField {
                matrix,
                offset,
                amplitude,
            } => {
                let u = matrix * x + offset;
                amplitude.derivatives(t).map(|a| u * (scale * a))
            }
            Motion::Rigid(rigid) => rigid.at_scaled(x, t, scale),
        }
    }

    /// Whether the motion is the same at all times (then velocity and acceleration are zero).
    pub fn is_constant(&self) -> bool {
        match self {
            Motion::Uniform { amplitude, .. } | Motion::LinearField { amplitude, .. } => {
                amplitude.is_constant()
            }
            Motion::Rigid(r) => r.amplitude.is_constant(),
        }
    }
}

/// One moving set: nodes, the axes they are held in, and their motion.
#[derive(Debug, Clone, PartialEq)]
struct MovingSet {
    nodes: Vec<usize>,
    axes: [bool; 3],
    motion: Motion,
}

/// The moving DOFs of a mesh and how each moves (each DOF in at most one set).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct BoundaryMotion {
    sets: Vec<MovingSet>,
}

impl BoundaryMotion {
    /// No moving DOF.
    pub fn new() -> Self {
        Self::default()
    }

    /// Whether no DOF moves.
    pub fn is_empty(&self) -> bool {
        self.sets.is_empty()
    }

    /// Moves the chosen `axes` of `nodes` by `motion`. [`Error::EmptySelection`] for no node or
    /// axis, [`Error::InvalidParameter`] naming the node and axis if a DOF already moves by
    /// another set.
    pub fn add(&mut self, nodes: &[usize], axes: [bool; 3], motion: Motion) -> Result<&mut Self> {
        if nodes.is_empty() || !axes.iter().any(|a| *a) {
            return Err(Error::EmptySelection {
                context: "moving constraint".into(),
            });
        }
        for set in &self.sets {
            for &node in nodes {
                if let Some(axis) = (0..3).find(|&a| axes[a] && set.axes[a])
                    && set.nodes.binary_search(&node).is_ok()
                {
                    return Err(Error::invalid_parameter(
                        format!("moving constraint of node {node}, axis {axis}"),
                        "two motions",
                        "a DOF may follow one motion only",
                    ));
                }
            }
        }
        let mut nodes = nodes.to_vec();
        nodes.sort_unstable();
        nodes.dedup();
        self.sets.push(MovingSet {
            nodes,
            axes,
            motion,
        });
        Ok(self)
    }

    /// Every moving DOF (3·node + axis) with its motion's index, in set order.
    pub fn dofs(&self) -> Vec<usize> {
        self.sets
            .iter()
            .flat_map(|s| {
                s.nodes
                    .iter()
                    .flat_map(|&n| (0..3).filter(|&a| s.axes[a]).map(move |a| 3 * n + a))
            })
            .collect()
    }

    /// Whether every set's motion is the same at all times.
    pub fn is_constant(&self) -> bool {
        self.sets.iter().all(|s| s.motion.is_constant())
    }

    /// For each of [`dofs`](Self::dofs), in that order, [u, u̇, ü] at time `t` of the nodes at
    /// `positions` (the mesh's reference coordinates). [`Error::UnknownNode`] for a node
    /// beyond `positions`.
    pub fn evaluate(&self, positions: &[Vector3<f64>], t: f64) -> Result<Vec<[f64; 3]>> {
        self.evaluate_scaled(positions, t, 1.0)
    }

    /// [`evaluate`](Self::evaluate) with every amplitude times `scale` (see
    /// [`Motion::at_scaled`]): a load step λ of a static solve takes `scale` = λ.
    pub fn evaluate_scaled(
        &self,
        positions: &[Vector3<f64>],
        t: f64,
        scale: f64,
    ) -> Result<Vec<[f64; 3]>> {
        let mut out = Vec::new();
        for set in &self.sets {
            for &n in &set.nodes {
                let x = positions.get(n).ok_or(Error::UnknownNode {
                    context: "moving constraint",
                    node: n,
                    node_count: positions.len(),
                })?;
                let [u, v, a] = set.motion.at_scaled(x, t, scale);
                for axis in (0..3).filter(|&a| set.axes[a]) {
                    out.push([u[axis], v[axis], a[axis]]);
                }
            }
        }
        Ok(out)
    }

    /// Prescribes the values at time `t` in `constraints` (what a static analysis, at
    /// [`STATIC_TIME`](crate::bc::amplitude::STATIC_TIME), and the start of a dynamic one use);
    /// errors of [`Constraints::prescribe_axis`] (a conflict with another value, naming the
    /// node and axis).
    pub fn prescribe_at(
        &self,
        positions: &[Vector3<f64>],
        t: f64,
        constraints: &mut Constraints,
    ) -> Result<()> {
        for (dof, [u, _, _]) in self.dofs().into_iter().zip(self.evaluate(positions, t)?) {
            constraints.prescribe_axis(dof / 3, dof % 3, u)?;
        }
        Ok(())
    }
}
