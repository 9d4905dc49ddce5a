//! The contact nodes' local problems: each node that touches an obstacle (or holds lagged
//! friction) moved to the minimum of its own barrier and friction with the rest of the step's
//! potential frozen to a quadratic, one node at a time.
//!
//! Newton's quadratic model of friction is right only within the smoothing distance ε of
//! sticking (a few micrometres); a node whose solution sticks while the iterate slips (or the
//! reverse) sends the global step across the stick–slip switch, and the line search cuts every
//! node's step for it. The local problem of node i,
//!
//! ψᵢ(δ) = aᵢ·δ + ½·δᵀ·Aᵢ·δ + cᵢ(xᵢ + δ),  aᵢ = gᵢ − ∇cᵢ(xᵢ),
//!
//! (gᵢ the gradient of the step's potential Φ at the node, Aᵢ its diagonal block of the step
//! matrix without contact, cᵢ the node's barrier and lagged friction) holds the switch exactly:
//! its minimizer says whether the node sticks or slips under the pull the rest of the body
//! exerts on it now. Three unknowns, solved by Newton with a backtracking line search on ψᵢ
//! that keeps every gap positive.

use nalgebra::{Matrix3, Vector3};

use super::super::barrier;
use super::super::friction::{FrictionLag, LaggedPoint, f0, f1_over_y};
use super::Contact;
use crate::base::error::Result;

/// Newton iterations of one node's local problem.
const LOCAL_ITERATIONS: usize = 20;

/// Halvings of one local line search.
const LOCAL_HALVINGS: usize = 30;

/// One node's contact terms: the obstacles (index, offset, κ·A) and its lagged friction points.
struct NodeTerms<'a> {
    obstacles: Vec<(usize, Vector3<f64>, f64)>,
    friction: Vec<&'a LaggedPoint>,
    epsilon: f64,
    d_hat: f64,
}

impl NodeTerms<'_> {
    /// c(x), ∇c(x) and the PSD part of ∇²c(x) (the barrier's b′·∇²d dropped); `None` where a
    /// gap is not positive.
    fn evaluate(
        &self,
        contact: &Contact,
        x: &Vector3<f64>,
    ) -> Option<(f64, Vector3<f64>, Matrix3<f64>)> {
        let (mut e, mut g, mut h) = (0.0, Vector3::zeros(), Matrix3::zeros());
        for &(o, offset, weight) in &self.obstacles {
            let obstacle = &contact.obstacles[o];
            let relative = x - offset;
            let d = obstacle.distance(&relative);
            // On or inside the obstacle, or a NaN position: no finite energy.
            if d.is_nan() || d <= 0.0 {
                return None;
            }
            if d < self.d_hat {
                let n = obstacle.gradient(&relative);
                e += weight * barrier::value(d, self.d_hat);
                g += weight * barrier::derivative(d, self.d_hat) * n;
                h += weight * barrier::second_derivative(d, self.d_hat) * n * n.transpose();
            }
        }
        for p in &self.friction {
            let slip = p.slip(x);
            let y = slip.norm();
            e += p.limit * f0(y, self.epsilon);
            g += p.limit * f1_over_y(y, self.epsilon) * slip;
            h += p.stiffness(&slip, self.epsilon);
        }
        Some((e, g, h))
    }
}

impl Contact {
    /// The moves δᵢ (length) of the contact nodes that touch an obstacle or hold lagged
    /// friction at full displacement `u` to the minimizers of their local problems (see the
    /// module's docs), the barrier counted `barrier_weight` times (Newmark's end-point contact:
    /// 2) and friction once. `local(node)` gives gᵢ (force: ∂Φ/∂xᵢ at `u`, contact included)
    /// and Aᵢ (force/length, SPD), `None` for a node that is not wholly free. Nodes whose local
    /// problem does not decrease are left out.
    pub(crate) fn relax_nodes(
        &self,
        lag: Option<&FrictionLag>,
        u: &[f64],
        barrier_weight: f64,
        local: impl Fn(usize) -> Option<(Vector3<f64>, Matrix3<f64>)>,
    ) -> Result<Vec<(usize, Vector3<f64>)>> {
        self.check_full(u)?;
        let offsets = self.offsets();
        let d_hat = self.parameters.activation_distance;
        // Each contact node's lagged points (the nodes are sorted).
        let mut lagged: Vec<Vec<&LaggedPoint>> = vec![Vec::new(); self.nodes.len()];
        for p in lag.map_or(&[][..], |lag| &lag.points) {
            if let Ok(k) = self.nodes.binary_search(&p.node) {
                lagged[k].push(p);
            }
        }
        let mut moves = Vec::new();
        for (k, friction) in lagged.into_iter().enumerate() {
            let node = self.nodes[k];
            let x = self.position(k, u);
            let near = self
                .obstacles
                .iter()
                .zip(&offsets)
                .any(|(o, offset)| o.distance(&(x - offset)) < d_hat);
            if !near && friction.is_empty() {
                continue;
            }
            let Some((g, a)) = local(node) else {
                continue;
            };
            let weight = barrier_weight * self.kappa_of(k) * self.areas[k];
            let terms = NodeTerms {
                obstacles: (0..self.obstacles.len())
                    .map(|o| (o, offsets[o], weight))
                    .collect(),
                friction,
                epsilon: lag.map_or(0.0, |l| l.epsilon),
                d_hat,
            };
            if let Some(delta) = self.solve_local(&terms, &x, g, &a) {
                moves.push((node, delta));
            }
        }
        Ok(moves)
    }

    /// The minimizer of ψ(δ) = a·δ + ½δᵀAδ + c(x + δ) (see the module's docs) from δ = 0;
    /// `None` if no decrease was found.
    fn solve_local(
        &self,
        terms: &NodeTerms,
        x: &Vector3<f64>,
        g: Vector3<f64>,
        a_block: &Matrix3<f64>,
    ) -> Option<Vector3<f64>> {
        let (c0, grad_c0, _) = terms.evaluate(self, x)?;
        let linear = g - grad_c0;
        let psi = |delta: &Vector3<f64>| -> Option<(f64, Vector3<f64>, Matrix3<f64>)> {
            let (c, gc, hc) = terms.evaluate(self, &(x + delta))?;
            let value = linear.dot(delta) + 0.5 * delta.dot(&(a_block * delta)) + c - c0;
            Some((value, linear + a_block * delta + gc, a_block + hc))
        };
        let mut delta = Vector3::zeros();
        let (mut value, mut gradient, mut hessian) = psi(&delta)?;
        let scale = g.norm().max(grad_c0.norm());
        for _ in 0..LOCAL_ITERATIONS {
            if gradient.norm() <= 1e-8 * scale {
                break;
            }
            // A (SPD) plus the PSD contact Hessian: not positive definite only through a
            // caller's A; the moves so far stand.
            let Some(factor) = hessian.cholesky() else {
                break;
            };
            let step = factor.solve(&(-gradient));
            let slope = gradient.dot(&step);
            // The Newton decrement −slope/2 below round-off of ψ's terms: nothing to gain.
            if slope.is_nan() || slope >= -1e-14 * value.abs().max(c0.abs()) {
                break;
            }
            let mut alpha = 1.0;
            let mut taken = false;
            for _ in 0..LOCAL_HALVINGS {
                let trial = delta + alpha * step;
                if let Some((v, gr, h)) = psi(&trial)
                    && v <= value + 1e-4 * alpha * slope
                {
                    (delta, value, gradient, hessian) = (trial, v, gr, h);
                    taken = true;
                    break;
                }
                alpha *= 0.5;
            }
            if !taken {
                break;
            }
        }
        (value < 0.0).then_some(delta)
    }
}

#[cfg(test)]
mod tests {
    use nalgebra::{Matrix3, Vector3};

    use super::super::super::barrier;
    use super::super::super::friction::{FrictionLag, LaggedPoint, f1_over_y};
    use crate::contact::{Contact, ContactParameters, Obstacle};
    use crate::mesh::{BoxSplit, TetMesh};

    /// A unit cube of one cell resting d̂/2 above a half-space with friction, its contact, and
    /// contact node 0's index among the contact nodes (the node at the origin corner).
    fn cube_on_ground() -> (Contact, usize) {
        let lift = 0.5 * 1e-3 * 3f64.sqrt();
        let mesh = TetMesh::box_grid(
            Vector3::new(0.0, 0.0, lift),
            Vector3::new(1.0, 1.0, 1.0 + lift),
            [1, 1, 1],
            BoxSplit::Mirrored6,
        )
        .unwrap();
        let ground = Obstacle::half_space("ground", Vector3::zeros(), Vector3::z())
            .unwrap()
            .with_friction(0.5)
            .unwrap();
        let parameters = ContactParameters::for_mesh(&mesh, 1e5).unwrap();
        let contact = Contact::new(&mesh, vec![ground], parameters).unwrap();
        let k = contact.nodes.iter().position(|&n| n == 0).unwrap();
        (contact, k)
    }

    /// Node 0's move under the pull a (the gradient of Φ without contact, force units) with
    /// A = `stiffness`·I, a lagged friction limit μ·λ = `limit` (smoothing ε) and the barrier
    /// weighted by `barrier_weight`, and the stationarity residual a + A·δ + ∇c(x + δ) at that
    /// move computed afresh.
    fn relaxed(
        pull: Vector3<f64>,
        stiffness: f64,
        (limit, epsilon): (f64, f64),
        barrier_weight: f64,
    ) -> (Vector3<f64>, Vector3<f64>, f64) {
        let (contact, k) = cube_on_ground();
        let u = vec![0.0; 24];
        let x = contact.position(k, &u);
        let lag = FrictionLag {
            points: vec![LaggedPoint {
                node: 0,
                obstacle: 0,
                start: x,
                limit,
                projector: Matrix3::identity() - Vector3::z() * Vector3::z().transpose(),
            }],
            epsilon,
        };
        let d_hat = contact.parameters.activation_distance;
        let weight = barrier_weight * contact.kappa_of(k) * contact.areas[k];
        // ∇c at a position: the barrier along z and the lagged friction.
        let gradient_c = |y: &Vector3<f64>| {
            let slip = Vector3::new(y.x - x.x, y.y - x.y, 0.0);
            weight * barrier::derivative(y.z, d_hat) * Vector3::z()
                + limit * f1_over_y(slip.norm(), epsilon) * slip
        };
        let g = pull + gradient_c(&x);
        let a = stiffness * Matrix3::identity();
        let moves = contact
            .relax_nodes(Some(&lag), &u, barrier_weight, |n| {
                (n == 0).then_some((g, a))
            })
            .unwrap();
        assert_eq!(moves.len(), 1, "node 0 alone is offered a local problem");
        let (node, delta) = moves[0];
        assert_eq!(node, 0);
        let stationarity = pull + a * delta + gradient_c(&(x + delta));
        (delta, stationarity, g.norm().max(limit))
    }

    #[test]
    fn a_node_pulled_below_the_friction_limit_sticks() {
        let (epsilon, limit) = (1e-6, 1.0);
        let (delta, stationarity, scale) =
            relaxed(Vector3::new(0.6, 0.0, 0.0), 1e3, (limit, epsilon), 1.0);
        // Local Newton stops at ‖∇ψ‖ ≤ 1e-8 of the forces' scale.
        assert!(stationarity.norm() <= 1e-7 * scale, "{stationarity}");
        // Below μ·λ the tangential balance k·y + μ·λ·f₁(y) = 0.6 needs f₁(y) < 1: y < ε.
        let slip = Vector3::new(delta.x, delta.y, 0.0).norm();
        assert!(slip < epsilon, "slip {slip:e} m, ε {epsilon:e} m");
        assert!(
            delta.x < 0.0,
            "friction holds against the pull, not with it"
        );
    }

    #[test]
    fn a_node_pulled_beyond_the_friction_limit_slips_by_the_excess() {
        let (epsilon, limit, stiffness) = (1e-6, 1.0, 1e3);
        let pull = 3.0;
        let (delta, stationarity, scale) = relaxed(
            Vector3::new(pull, 0.0, 0.0),
            stiffness,
            (limit, epsilon),
            1.0,
        );
        assert!(stationarity.norm() <= 1e-7 * scale, "{stationarity}");
        // Slipping, friction is Coulomb's μ·λ: k·y = pull − μ·λ, y = 2 mm ≫ ε, against the
        // pull; to the local stopping test (1e-8 of the forces over k).
        let expected = -(pull - limit) / stiffness;
        assert!(
            (delta.x - expected).abs() <= 1e-7 * scale / stiffness,
            "{} against {expected}",
            delta.x
        );
        assert!(delta.y.abs() <= 1e-7 * scale / stiffness);
    }

    #[test]
    fn a_node_pressed_into_the_ground_keeps_a_positive_gap() {
        // 10 kN down on a barrier whose d̂ is 1.7 mm: the gap closes towards zero, never past;
        // the barrier counted once (backward Euler) and twice (Newmark's end-point contact),
        // the stationarity residual weighing it the same.
        let lift = 0.5 * 1e-3 * 3f64.sqrt();
        let mut gaps = Vec::new();
        for barrier_weight in [1.0, 2.0] {
            let pull = Vector3::new(0.0, 0.0, 1e4);
            let (delta, stationarity, scale) = relaxed(pull, 1.0, (1.0, 1e-6), barrier_weight);
            assert!(
                lift + delta.z > 0.0 && delta.z < 0.0,
                "gap {:e}",
                lift + delta.z
            );
            // The local Newton stops at ‖∇ψ‖ ≤ 1e-8 of the forces' scale or, where the
            // barrier's curvature at a 24–50 µm gap makes the Newton decrement fall below ψ's
            // round-off first, a little above it: measured 1.0e-8 and 1.4e-7 of the scale,
            // a move of under 1e-10 m still to come.
            assert!(stationarity.norm() <= 1e-6 * scale, "{stationarity}");
            gaps.push(lift + delta.z);
        }
        // Twice the barrier holds the same load at a wider gap.
        assert!(gaps[1] > gaps[0], "{gaps:?}");
    }
}
