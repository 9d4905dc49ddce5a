//! Coulomb friction as IPC writes it (Li et al. 2020, §5): a lagged, smoothed dissipative
//! potential of the tangential displacement over a time step.
//!
//! Per node i and obstacle o in contact at the step's start x⁰: the normal force λ = κ·Aᵢ·|b′(d)|
//! and the tangent projector P = I − n·nᵀ are frozen there (lagged), and the step adds
//!
//! D(x) = μ·λ·f₀(|P·(x − x⁰)|),  f₀(y) = −y³/(3ε²) + y²/ε + ε/3 for y < ε, y beyond,
//!
//! whose force −∂D/∂x = −μ·λ·f₁(y)·û (f₁ = f₀′ = 2y/ε − y²/ε² below ε, 1 beyond; û the unit
//! slip) is Coulomb's μ·λ against the slip once it exceeds ε = ε_v·dt, and grows smoothly from
//! zero below: static friction is resolved to a creep speed below ε_v. Its Hessian (with the
//! lagged λ and P) is μ·λ·(f₁′(y)·ûûᵀ + (f₁(y)/y)·(P − ûûᵀ)): positive semi-definite as it
//! stands (f₁′ ≥ 0, f₁/y > 0), so Newton's matrix stays SPD without a projection.

use nalgebra::{Matrix3, Vector3};

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_speed_after_friction_solves_its_equation() {
        let epsilon = 1e-3;
        for (speed, c) in [
            (5e-3, 1e-3),
            (1.5e-3, 1e-3),
            (5e-4, 1e-3),
            (5e-4, 1e-9),
            (0.0, 1.0),
        ] {
            let s = speed_after_friction(speed, c, epsilon);
            let f1 = if s >= epsilon {
                1.0
            } else {
                s * f1_over_y(s, epsilon)
            };
            // The root of s + c·f₁(s) = s*, to round-off of the larger term.
            assert!(
                (s + c * f1 - speed).abs() <= 1e-14 * speed.max(c),
                "{speed} {c}: {s}"
            );
            assert!((0.0..=speed).contains(&s));
        }
    }
}

/// The lagged friction data of one time step (built by
/// [`Contact::friction_lag`](super::Contact::friction_lag)).
#[derive(Debug, Clone, Default)]
pub struct FrictionLag {
    /// One entry per node in contact with a frictional obstacle at the step's start.
    pub(crate) points: Vec<LaggedPoint>,
    /// The smoothing distance ε (length).
    pub(crate) epsilon: f64,
}

/// One node's lagged contact with one obstacle.
#[derive(Debug, Clone)]
pub(crate) struct LaggedPoint {
    /// The mesh node.
    pub node: usize,
    /// The obstacle's index (in the contact's order).
    pub obstacle: usize,
    /// Its position at the step's start (length).
    pub start: Vector3<f64>,
    /// μ·λ (force).
    pub limit: f64,
    /// P = I − n·nᵀ at the step's start.
    pub projector: Matrix3<f64>,
}

impl FrictionLag {
    /// Number of lagged contacts.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// Σ μ·λ over the lagged contacts (force): the most tangential force friction can carry.
    pub fn friction_limit(&self) -> f64 {
        self.points.iter().map(|p| p.limit).sum()
    }

    /// Multiplies every lagged μ·λ by `factor` (a prediction of the normal forces a larger
    /// load needs).
    pub(crate) fn scale_limits(&mut self, factor: f64) {
        for p in &mut self.points {
            p.limit *= factor;
        }
    }

    /// The smoothing distance ε (length).
    pub fn epsilon(&self) -> f64 {
        self.epsilon
    }

    /// Sets the smoothing distance ε (length; a stage of the smoothing continuation of the
    /// implicit steps' Newton, which ends at the step's own ε).
    pub(crate) fn set_epsilon(&mut self, epsilon: f64) {
        self.epsilon = epsilon;
    }

    /// Whether no node is in frictional contact.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }
}

/// f₀(y) (length).
pub(crate) fn f0(y: f64, epsilon: f64) -> f64 {
    if y >= epsilon {
        y
    } else {
        -y * y * y / (3.0 * epsilon * epsilon) + y * y / epsilon + epsilon / 3.0
    }
}

/// f₁(y)/y (1/length), finite at y = 0 (→ 2/ε).
pub(crate) fn f1_over_y(y: f64, epsilon: f64) -> f64 {
    if y >= epsilon {
        1.0 / y
    } else {
        2.0 / epsilon - y / (epsilon * epsilon)
    }
}

/// f₁′(y) = 2/ε − 2y/ε² below ε, 0 beyond (1/length; ≥ 0).
pub(crate) fn f1_derivative(y: f64, epsilon: f64) -> f64 {
    if y >= epsilon {
        0.0
    } else {
        2.0 / epsilon - 2.0 * y / (epsilon * epsilon)
    }
}

/// The tangential speed after an explicit step's friction impulse (see
/// [`Contact::apply_friction_impulses`](super::Contact::apply_friction_impulses)): the root s ∈
/// [0, s*] of s + c·f₁(s) = s*, with s* the tangential speed before it (length/time), c = dt·μ·λ/m
/// (length/time: the speed friction's full force μ·λ removes in one step from a node of mass m)
/// and f₁ smoothed below the stick speed `epsilon` (ε_v). Beyond ε_v it is s* − c (Coulomb's
/// μ·λ); below, the smaller root of the quadratic (c/ε²)·s² − (1 + 2c/ε)·s + s* = 0, written
/// without cancellation. Never negative: an impulse brings the speed at most to zero, never
/// reverses it.
pub(crate) fn speed_after_friction(speed: f64, c: f64, epsilon: f64) -> f64 {
    if speed - c >= epsilon {
        return speed - c;
    }
    let a = 1.0 + 2.0 * c / epsilon;
    // a² − 4·c·s*/ε² > 0 here: s* < ε + c gives 4·c·s*/ε² < 4c/ε + 4c²/ε² < a².
    2.0 * speed
        / (a + (a * a - 4.0 * c * speed / (epsilon * epsilon))
            .max(0.0)
            .sqrt())
}

impl LaggedPoint {
    /// The tangential slip P·(x − x⁰) of position `x`.
    pub fn slip(&self, x: &Vector3<f64>) -> Vector3<f64> {
        self.projector * (x - self.start)
    }

    /// The Hessian μ·λ·(f₁′(y)·ûûᵀ + (f₁(y)/y)·(P − ûûᵀ)) of this point's potential at slip
    /// `slip` (y = |slip|, û = slip/y; force/length; PSD as it stands, f₁′ ≥ 0, f₁/y > 0).
    pub(crate) fn stiffness(&self, slip: &Vector3<f64>, epsilon: f64) -> Matrix3<f64> {
        let y = slip.norm();
        let across = f1_over_y(y, epsilon);
        let mut block = across * self.projector;
        if y > 0.0 {
            // Along the slip the curvature is f₁′(y), across it f₁(y)/y; both ≥ 0.
            let along = f1_derivative(y, epsilon);
            let unit = slip / y;
            block += (along - across) * unit * unit.transpose();
        }
        self.limit * block
    }
}
