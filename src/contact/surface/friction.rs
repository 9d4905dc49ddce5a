//! Lagged smoothed Coulomb friction between surface pairs (IPC, Li et al. 2020, §5): the
//! body–body and self-contact counterpart of the obstacles' friction
//! ([`crate::contact::friction`]).
//!
//! At a time step's start x⁰, each pair k within d̂ (a point–triangle or edge–edge pair of
//! [`super::potential`]) freezes (lags):
//! - its closest points' weights wᵢ (Σᵢ wᵢ = 0): the relative position of the closest points is
//!   r = Σᵢ wᵢ·xᵢ over the pair's four nodes (point minus triangle point, or edge a's point
//!   minus edge b's);
//! - its normal force λ = −κ·m·b′(d) (N; m the edge–edge mollifier, b′ the barrier's
//!   derivative: the barrier's push between the closest points);
//! - its tangent projector P = I − n·nᵀ, n = r⁰/|r⁰|.
//!
//! The step then adds the dissipative potential (J)
//!
//! D(x) = Σₖ μ·λₖ·f₀(|u_T,k|),  u_T = P·Σᵢ wᵢ·(xᵢ − xᵢ⁰),
//!
//! u_T the closest points' relative tangential displacement over the step (m; the relative
//! tangential velocity times dt), f₀ IPC's C¹ mollified |·| with smoothing distance
//! ε = ε_v·dt (ε_v the slip velocity, m/s, below which the pair sticks with a creep;
//! [`crate::contact::friction`]). The force on node i is −μ·λ·(f₁(y)/y)·wᵢ·u_T (y = |u_T|):
//! Coulomb's μ·λ against the slip once y > ε. Σᵢ wᵢ = 0, so each pair's forces sum to zero:
//! friction between bodies is internal and conserves linear momentum. The Hessian
//! μ·λ·wᵢ·wⱼ·(f₁′(y)·ûûᵀ + (f₁(y)/y)·(P − ûûᵀ)) is positive semi-definite as it stands
//! (f₁′ ≥ 0, f₁/y > 0; û = u_T/y), so it needs no projection. A pair with no normal force
//! (λ ≤ 0) is not lagged: friction with zero normal force does nothing.

use nalgebra::{Matrix2, Matrix3, Vector2, Vector3};

use super::boundary::Surface;
use super::bvh::Candidates;
use super::distance::DistanceType;
use super::potential::SurfaceBarrier;
use crate::base::error::{Error, Result};
use crate::contact::barrier;
use crate::contact::friction::{f0, f1_derivative, f1_over_y};

/// The friction data of one time step, lagged at its start ([`SurfaceFrictionLag::new`]).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SurfaceFrictionLag {
    pairs: Vec<LaggedPair>,
    epsilon: f64,
}

/// One pair's lagged data.
#[derive(Debug, Clone, PartialEq)]
struct LaggedPair {
    nodes: [usize; 4],
    weights: [f64; 4],
    /// r⁰ = Σᵢ wᵢ·xᵢ⁰ (m).
    start: Vector3<f64>,
    /// μ·λ (N).
    limit: f64,
    /// P = I − n·nᵀ.
    projector: Matrix3<f64>,
}

impl LaggedPair {
    /// u_T = P·(Σᵢ wᵢ·xᵢ − r⁰) (m).
    fn slip(&self, x: &[Vector3<f64>]) -> Vector3<f64> {
        let r: Vector3<f64> = (0..4).map(|i| self.weights[i] * x[self.nodes[i]]).sum();
        self.projector * (r - self.start)
    }
}

impl SurfaceFrictionLag {
    /// Lags friction coefficient `mu` (≥ 0) over the pairs of `surface` among `found` within
    /// `barrier`'s d̂ at `positions` (m, indexed by node id), with smoothing distance `epsilon`
    /// (m; ε_v·dt). With μ = 0 the lag is empty.
    ///
    /// Errors: `mu` negative or not finite, `epsilon` not finite and > 0
    /// ([`Error::InvalidParameter`] naming the value); those of
    /// [`SurfaceBarrier::active_among`].
    pub fn new(
        barrier: &SurfaceBarrier,
        surface: &Surface,
        positions: &[Vector3<f64>],
        found: &Candidates,
        mu: f64,
        epsilon: f64,
    ) -> Result<Self> {
        check_friction("surface friction coefficient", mu)?;
        if !(epsilon.is_finite() && epsilon > 0.0) {
            return Err(Error::invalid_parameter(
                "surface friction smoothing distance",
                epsilon,
                "must be finite and > 0 (m: the slip velocity times the step)",
            ));
        }
        let mut pairs = Vec::new();
        if mu == 0.0 {
            return Ok(SurfaceFrictionLag { pairs, epsilon });
        }
        let d_hat = barrier.activation_distance;
        for p in barrier.active_among(surface, positions, found)? {
            if p.distance <= 0.0 {
                continue;
            }
            let m = barrier.mollifier_value(surface, &p, positions);
            let normal = -barrier.stiffness * m * barrier::derivative(p.distance, d_hat);
            // No normal force (or a NaN from degenerate data): no friction.
            if normal.is_nan() || normal <= 0.0 {
                continue;
            }
            let x = p.nodes.map(|n| positions[n]);
            let weights = closest_weights(p.kind, &x);
            let start: Vector3<f64> = (0..4).map(|i| weights[i] * x[i]).sum();
            let length = start.norm();
            // Closest points that coincide give no normal: the barrier refuses d = 0 anyway.
            if length.is_nan() || length <= 0.0 {
                continue;
            }
            let n = start / length;
            pairs.push(LaggedPair {
                nodes: p.nodes,
                weights,
                start,
                limit: mu * normal,
                projector: Matrix3::identity() - n * n.transpose(),
            });
        }
        Ok(SurfaceFrictionLag { pairs, epsilon })
    }

    /// The number of lagged pairs (those with a normal force).
    pub fn len(&self) -> usize {
        self.pairs.len()
    }

    /// Whether no pair carries friction.
    pub fn is_empty(&self) -> bool {
        self.pairs.is_empty()
    }

    /// The smoothing distance ε = ε_v·dt (m).
    pub fn epsilon(&self) -> f64 {
        self.epsilon
    }

    /// Σₖ μ·λₖ (N): the largest tangential force friction can carry between the surfaces.
    pub fn friction_limit(&self) -> f64 {
        self.pairs.iter().map(|p| p.limit).sum()
    }

    /// The largest tangential slip |u_T| of a pair at `positions` (m).
    pub fn largest_slip(&self, positions: &[Vector3<f64>]) -> f64 {
        self.pairs
            .iter()
            .fold(0.0, |s, p| s.max(p.slip(positions).norm()))
    }

    /// D(x) = Σₖ μ·λₖ·f₀(|u_T,k|) (J) at `positions` (m, indexed by node id).
    pub fn energy(&self, positions: &[Vector3<f64>]) -> f64 {
        self.pairs
            .iter()
            .map(|p| p.limit * f0(p.slip(positions).norm(), self.epsilon))
            .sum()
    }

    /// Adds ∂D/∂x (N; the friction force is its negative) into `gradient`, a DOF vector
    /// (3·node + axis) of length 3·`positions.len()`.
    pub fn add_gradient(&self, positions: &[Vector3<f64>], gradient: &mut [f64]) -> Result<()> {
        Error::check_len(
            "surface friction gradient",
            3 * positions.len(),
            gradient.len(),
        )?;
        for p in &self.pairs {
            let slip = p.slip(positions);
            let g = p.limit * f1_over_y(slip.norm(), self.epsilon) * slip;
            for (i, &n) in p.nodes.iter().enumerate() {
                for a in 0..3 {
                    gradient[3 * n + a] += p.weights[i] * g[a];
                }
            }
        }
        Ok(())
    }

    /// ∂²D/∂x² (N/m) as (row, column, value) triplets over the DOF vector (duplicates to be
    /// summed): positive semi-definite without projection (see the module docs).
    pub fn hessian_triplets(&self, positions: &[Vector3<f64>]) -> Vec<(usize, usize, f64)> {
        let mut triplets = Vec::with_capacity(144 * self.pairs.len());
        for p in &self.pairs {
            let block = p.limit * self.slip_hessian(&p.slip(positions), &p.projector);
            for (i, &ni) in p.nodes.iter().enumerate() {
                for (j, &nj) in p.nodes.iter().enumerate() {
                    let wij = p.weights[i] * p.weights[j];
                    for a in 0..3 {
                        for b in 0..3 {
                            let value = wij * block[(a, b)];
                            if value != 0.0 {
                                triplets.push((3 * ni + a, 3 * nj + b, value));
                            }
                        }
                    }
                }
            }
        }
        triplets
    }

    /// ∂²f₀(|u_T|)/∂r² for slip `slip` (1/m): f₁′·ûûᵀ + (f₁/y)·(P − ûûᵀ), which at y = 0 is
    /// (2/ε)·P (both coefficients → 2/ε).
    fn slip_hessian(&self, slip: &Vector3<f64>, projector: &Matrix3<f64>) -> Matrix3<f64> {
        let y = slip.norm();
        let over = f1_over_y(y, self.epsilon);
        if y == 0.0 {
            return over * projector;
        }
        let u = slip / y;
        let uu = u * u.transpose();
        f1_derivative(y, self.epsilon) * uu + over * (projector - uu)
    }
}

/// [`Error::InvalidParameter`] naming `what` unless `mu` is finite and ≥ 0 (a friction
/// coefficient, dimensionless).
pub(crate) fn check_friction(what: &str, mu: f64) -> Result<()> {
    if !(mu.is_finite() && mu >= 0.0) {
        return Err(Error::invalid_parameter(
            what,
            mu,
            "must be finite and ≥ 0 (a Coulomb friction coefficient)",
        ));
    }
    Ok(())
}

/// The closest points' weights w (Σ wᵢ = 0) of a pair of type `kind` at `x` (the pair's four
/// points in [`super::distance`]'s order): r = Σ wᵢ·xᵢ joins its closest points. The clamped
/// parameters of the type (unclamped: the type places them inside): those of the distance
/// [`super::distance`] evaluates, to round-off.
fn closest_weights(kind: DistanceType, x: &[Vector3<f64>; 4]) -> [f64; 4] {
    let mut w = [0.0; 4];
    match kind {
        DistanceType::PointPoint(i, j) => {
            w[i] = 1.0;
            w[j] = -1.0;
        }
        DistanceType::PointEdge(i, a, b) => {
            let e = x[b] - x[a];
            let ee = e.norm_squared();
            // Unclamped, as the distance's own: the type says the point falls inside.
            let t = match ee > 0.0 {
                true => (x[i] - x[a]).dot(&e) / ee,
                false => 0.0,
            };
            w[i] = 1.0;
            w[a] = -(1.0 - t);
            w[b] = -t;
        }
        DistanceType::PointPlane => {
            let (e1, e2, d) = (x[2] - x[1], x[3] - x[1], x[0] - x[1]);
            let g = Matrix2::new(e1.dot(&e1), e1.dot(&e2), e1.dot(&e2), e2.dot(&e2));
            let uv = g
                .try_inverse()
                .map(|inv| inv * Vector2::new(e1.dot(&d), e2.dot(&d)))
                .unwrap_or_else(Vector2::zeros);
            w = [1.0, -(1.0 - uv[0] - uv[1]), -uv[0], -uv[1]];
        }
        DistanceType::EdgeEdge => {
            let (a, b, d) = (x[1] - x[0], x[3] - x[2], x[0] - x[2]);
            let g = Matrix2::new(a.dot(&a), -a.dot(&b), -a.dot(&b), b.dot(&b));
            let st = g
                .try_inverse()
                .map(|inv| inv * Vector2::new(-a.dot(&d), b.dot(&d)))
                .unwrap_or_else(Vector2::zeros);
            let (s, t) = (st[0], st[1]);
            w = [1.0 - s, s, -(1.0 - t), -t];
        }
    }
    w
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The weights join the closest points: |Σ wᵢ·xᵢ|² is the squared distance of the type.
    #[test]
    fn weights_give_the_distance_of_their_type() {
        let x = [
            Vector3::new(0.2, 0.3, 0.5),
            Vector3::new(0.0, 0.0, 0.0),
            Vector3::new(1.0, 0.0, 0.1),
            Vector3::new(0.0, 1.0, -0.1),
        ];
        for kind in [
            DistanceType::PointPlane,
            DistanceType::EdgeEdge,
            DistanceType::PointEdge(0, 1, 2),
            DistanceType::PointPoint(0, 3),
        ] {
            let w = closest_weights(kind, &x);
            let r: Vector3<f64> = (0..4).map(|i| w[i] * x[i]).sum();
            let s = super::super::distance::squared_distance(kind, &x);
            // Both solve the same 2×2 system or projection: agreement to round-off of O(1) data.
            assert!((r.norm_squared() - s).abs() < 1e-14, "{kind:?}");
            assert!(w.iter().sum::<f64>().abs() < 1e-15, "{kind:?}");
        }
    }
}
