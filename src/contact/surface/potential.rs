//! The barrier potential of body–body and self-contact over a surface:
//!
//! B(x) = κ·Σₖ mₖ(x)·b(dₖ(x), d̂),
//!
//! k over the point–triangle and edge–edge pairs that share no vertex and lie closer than d̂,
//! dₖ their distance (length), b IPC's log barrier ([`crate::contact::barrier`], length²),
//! mₖ = 1 for point–triangle pairs and IPC's mollifier for edge–edge pairs (zero as the edges
//! turn parallel, [`edge_edge_mollifier`]), κ the stiffness (energy per length², J/m² = N/m).
//! Every term depends on differences of positions only, so its forces sum to zero and turn
//! nothing: barrier forces are internal (momentum and angular momentum are conserved).
//!
//! With s = d², the chain rule through φ(s) = b(√s): φ′ = b′/(2d), φ″ = (b″ − b′/d)/(4d²);
//! a term's gradient is φ′∇s and its Hessian φ″∇s∇sᵀ + φ′∇²s (with the mollifier's product
//! rule for edge–edge pairs). Each pair's 12×12 Hessian block can be projected to the nearest
//! positive semi-definite matrix (negative eigenvalues set to zero), so Newton's tangent stays
//! positive definite.

use nalgebra::{SymmetricEigen, Vector3};

use super::boundary::Surface;
use super::bvh::{Candidates, candidates};
use super::distance::{
    DistanceType, Gradient12, Hessian12, edge_edge_mollifier, edge_edge_type, mollifier_threshold,
    point_triangle_type, squared_distance, squared_distance_derivatives,
};
use crate::base::error::{Error, Result};
use crate::contact::barrier;

/// Which primitives a contact pair joins.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Pair {
    /// A surface node and a triangle (its index in [`Surface::triangles`]).
    PointTriangle {
        /// The point's mesh node.
        node: usize,
        /// The triangle's index.
        triangle: usize,
    },
    /// Two edges (indices in [`Surface::edges`]), a < b.
    EdgeEdge {
        /// The first edge's index.
        a: usize,
        /// The second edge's index.
        b: usize,
    },
}

/// Every candidate pair of `found` as a [`Pair`]: point–triangle pairs, then edge–edge pairs,
/// each in `found`'s order.
pub(crate) fn pairs_of(found: &Candidates) -> impl Iterator<Item = Pair> + '_ {
    let points = found.point_triangle.iter();
    let edges = found.edge_edge.iter();
    points
        .map(|&(node, triangle)| Pair::PointTriangle { node, triangle })
        .chain(edges.map(|&(a, b)| Pair::EdgeEdge { a, b }))
}

impl Pair {
    /// The pair's four mesh nodes in the order of [`super::distance`]: (point, triangle) or
    /// (edge a, edge b). The triangle or edges must be `surface`'s (checked where candidates
    /// enter, [`SurfaceBarrier::active_among`]).
    pub(crate) fn nodes(&self, surface: &Surface) -> [usize; 4] {
        match *self {
            Pair::PointTriangle { node, triangle } => {
                let [a, b, c] = surface.triangles()[triangle];
                [node, a, b, c]
            }
            Pair::EdgeEdge { a, b } => {
                let ([a0, a1], [b0, b1]) = (surface.edges()[a], surface.edges()[b]);
                [a0, a1, b0, b1]
            }
        }
    }

    /// A lower bound (length) of the pair's distance at `x` (its four points): the distance
    /// between the axis-aligned boxes of its two primitives (the point and the triangle, or the
    /// two edges), which every point of either lies in. A few comparisons where the distance
    /// itself takes its type's projections: the narrow phase and the CCD skip with it the
    /// candidates that are far apart (most of them: the broad phase's boxes are inflated by
    /// d̂ and by twice the Newton step's largest move).
    pub(crate) fn box_gap(&self, x: &[Vector3<f64>; 4]) -> f64 {
        let split = match self {
            Pair::PointTriangle { .. } => 1,
            Pair::EdgeEdge { .. } => 2,
        };
        let (a, b) = x.split_at(split);
        let mut gap2 = 0.0;
        for axis in 0..3 {
            let lo = |s: &[Vector3<f64>]| s.iter().fold(f64::INFINITY, |m, v| m.min(v[axis]));
            let hi = |s: &[Vector3<f64>]| s.iter().fold(f64::NEG_INFINITY, |m, v| m.max(v[axis]));
            let apart = (lo(b) - hi(a)).max(lo(a) - hi(b)).max(0.0);
            gap2 += apart * apart;
        }
        gap2.sqrt()
    }

    /// The type of the pair's distance at `x` (the pair's four points).
    pub fn distance_type(&self, x: &[Vector3<f64>; 4]) -> DistanceType {
        match self {
            Pair::PointTriangle { .. } => point_triangle_type(&x[0], &x[1], &x[2], &x[3]),
            Pair::EdgeEdge { .. } => edge_edge_type(&x[0], &x[1], &x[2], &x[3]),
        }
    }
}

/// A pair within reach at one state.
#[derive(Debug, Clone, PartialEq)]
pub struct ActivePair {
    /// The primitives.
    pub pair: Pair,
    /// Their mesh nodes: (point, triangle) or (edge a, edge b), as in [`super::distance`].
    pub nodes: [usize; 4],
    /// The type of their closest features.
    pub kind: DistanceType,
    /// Their distance d (length).
    pub distance: f64,
}

/// The barrier's two scales, and the friction between the surfaces it pushes apart.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurfaceBarrier {
    /// d̂ (length, m): pairs closer than this are pushed apart.
    pub activation_distance: f64,
    /// κ (energy per length², J/m²).
    pub stiffness: f64,
    /// μ, the Coulomb coefficient between surface pairs (dimensionless, ≥ 0; default 0: no
    /// friction). Lagged once per implicit time step ([`super::friction`]); static solves
    /// and explicit steps would see none, so `Combination::check` refuses μ > 0 there.
    pub friction: f64,
    /// ε_v, the slip velocity (m/s) below which a pair sticks (with a creep); `None`: the
    /// obstacles' default, [`crate::contact::set::SLIP_FRACTION`] of the mesh's bounding-box
    /// diagonal per second ([`super::SurfaceContact::new`] resolves it).
    pub slip_velocity: Option<f64>,
}

/// Every pair's local (12) gradient or (12×12) Hessian, before scaling by κ.
type Local<T> = Vec<([usize; 4], T)>;

impl SurfaceBarrier {
    /// The barrier with activation distance `activation_distance` (m) and stiffness
    /// `stiffness` (J/m²); [`Error::InvalidParameter`] unless both are finite and > 0.
    pub fn new(activation_distance: f64, stiffness: f64) -> Result<Self> {
        for (name, value) in [
            ("surface barrier activation_distance", activation_distance),
            ("surface barrier stiffness", stiffness),
        ] {
            if !(value.is_finite() && value > 0.0) {
                return Err(Error::invalid_parameter(
                    name,
                    value,
                    "must be finite and > 0",
                ));
            }
        }
        Ok(SurfaceBarrier {
            activation_distance,
            stiffness,
            friction: 0.0,
            slip_velocity: None,
        })
    }

    /// The barrier with friction coefficient `mu` between the surfaces (dimensionless; 0 turns
    /// friction off). [`Error::InvalidParameter`] naming the value unless finite and ≥ 0.
    pub fn with_friction(mut self, mu: f64) -> Result<Self> {
        super::friction::check_friction("surface barrier friction", mu)?;
        self.friction = mu;
        Ok(self)
    }

    /// The barrier with friction's slip velocity ε_v = `slip_velocity` (m/s): relative
    /// tangential speeds below it count as sticking. [`Error::InvalidParameter`] naming the
    /// value unless finite and > 0.
    pub fn with_slip_velocity(mut self, slip_velocity: f64) -> Result<Self> {
        if !(slip_velocity.is_finite() && slip_velocity > 0.0) {
            return Err(Error::invalid_parameter(
                "surface barrier slip_velocity",
                slip_velocity,
                "must be finite and > 0 (m/s)",
            ));
        }
        self.slip_velocity = Some(slip_velocity);
        Ok(self)
    }

    /// The mollifier's value mₖ of pair `p` at `positions` (1 for a point–triangle pair): the
    /// factor of its normal force κ·m·|b′(d)| that friction lags.
    pub(crate) fn mollifier_value(
        &self,
        surface: &Surface,
        p: &ActivePair,
        positions: &[Vector3<f64>],
    ) -> f64 {
        self.mollifier(surface, p, positions).0
    }

    /// The pairs of `surface` closer than d̂ at `positions` (indexed by node id, m), found by
    /// the broad phase ([`candidates`]), in its order.
    pub fn active_pairs(
        &self,
        surface: &Surface,
        positions: &[Vector3<f64>],
    ) -> Result<Vec<ActivePair>> {
        self.active(surface, positions, None)
    }

    /// The pairs among `found` closer than d̂ at `positions`: `found` computed once for a
    /// stretch of positions — e.g. [`candidates`] swept along a line-search direction and
    /// inflated by d̂, which holds every pair within d̂ anywhere along it — saves the broad
    /// phase at each evaluation.
    ///
    /// Errors: positions not covering the surface or not finite; a candidate naming a node,
    /// triangle or edge `surface` does not have ([`Error::InvalidParameter`]).
    pub fn active_among(
        &self,
        surface: &Surface,
        positions: &[Vector3<f64>],
        found: &Candidates,
    ) -> Result<Vec<ActivePair>> {
        self.active(surface, positions, Some(found))
    }

    fn active(
        &self,
        surface: &Surface,
        positions: &[Vector3<f64>],
        found: Option<&Candidates>,
    ) -> Result<Vec<ActivePair>> {
        let computed;
        let found = match found {
            Some(f) => {
                surface.check_positions("surface barrier", positions)?;
                check_candidates(surface, positions.len(), f)?;
                f
            }
            None => {
                computed = candidates(surface, positions, None, self.activation_distance)?;
                &computed
            }
        };
        let pairs = pairs_of(found);
        let d_hat2 = self.activation_distance * self.activation_distance;
        // Boxes apart by more than d̂ (with a relative 1e-9 for the distance's round-off) hold
        // a pair that is not active: skipped without its distance.
        let far = self.activation_distance * (1.0 + 1e-9);
        Ok(pairs
            .filter_map(|pair| {
                let nodes = pair.nodes(surface);
                let x = nodes.map(|n| positions[n]);
                if pair.box_gap(&x) > far {
                    return None;
                }
                let kind = pair.distance_type(&x);
                let s = squared_distance(kind, &x);
                (s < d_hat2).then(|| ActivePair {
                    pair,
                    nodes,
                    kind,
                    distance: s.sqrt(),
                })
            })
            .collect())
    }

    /// B(x) (J): +∞ when a pair touches or crosses (d = 0). Errors: positions not covering
    /// the surface or not finite.
    pub fn energy(&self, surface: &Surface, positions: &[Vector3<f64>]) -> Result<f64> {
        self.energy_with(surface, positions, None)
    }

    /// [`energy`](Self::energy) over the pairs among `found` (see
    /// [`active_among`](Self::active_among)).
    pub fn energy_among(
        &self,
        surface: &Surface,
        positions: &[Vector3<f64>],
        found: &Candidates,
    ) -> Result<f64> {
        self.energy_with(surface, positions, Some(found))
    }

    fn energy_with(
        &self,
        surface: &Surface,
        positions: &[Vector3<f64>],
        found: Option<&Candidates>,
    ) -> Result<f64> {
        let active = self.active(surface, positions, found)?;
        Ok(self.energy_of_active(surface, positions, &active))
    }

    /// [`energy`](Self::energy) over `active`, the pairs [`active_among`](Self::active_among)
    /// found at `positions` (J): a caller that evaluates the energy, force and tangent at one
    /// state finds the active pairs once.
    pub(crate) fn energy_of_active(
        &self,
        surface: &Surface,
        positions: &[Vector3<f64>],
        active: &[ActivePair],
    ) -> f64 {
        let d_hat = self.activation_distance;
        let mut total = 0.0;
        for p in active {
            if p.distance <= 0.0 {
                return f64::INFINITY;
            }
            let m = self.mollifier(surface, p, positions).0;
            total += m * barrier::value(p.distance, d_hat);
        }
        self.stiffness * total
    }

    /// Adds ∂B/∂x (N; the contact force is its negative) into `gradient`, a DOF vector
    /// (3·node + axis) of length 3·`positions.len()`.
    ///
    /// Errors: a length mismatch; positions not covering the surface or not finite; a pair at
    /// distance 0 (touching or crossing: no force is defined), [`Error::InvalidParameter`]
    /// naming its nodes.
    pub fn add_gradient(
        &self,
        surface: &Surface,
        positions: &[Vector3<f64>],
        gradient: &mut [f64],
    ) -> Result<()> {
        self.add_gradient_with(surface, positions, None, gradient)
    }

    /// [`add_gradient`](Self::add_gradient) over the pairs among `found` (see
    /// [`active_among`](Self::active_among)).
    pub fn add_gradient_among(
        &self,
        surface: &Surface,
        positions: &[Vector3<f64>],
        found: &Candidates,
        gradient: &mut [f64],
    ) -> Result<()> {
        self.add_gradient_with(surface, positions, Some(found), gradient)
    }

    fn add_gradient_with(
        &self,
        surface: &Surface,
        positions: &[Vector3<f64>],
        found: Option<&Candidates>,
        gradient: &mut [f64],
    ) -> Result<()> {
        Error::check_len(
            "surface barrier gradient",
            3 * positions.len(),
            gradient.len(),
        )?;
        let active = self.active(surface, positions, found)?;
        self.add_gradient_of_active(surface, positions, &active, gradient)
    }

    /// [`add_gradient`](Self::add_gradient) over `active`, the pairs
    /// [`active_among`](Self::active_among) found at `positions` (N), `gradient` of length
    /// 3·`positions.len()`. Errors: a pair at distance 0.
    pub(crate) fn add_gradient_of_active(
        &self,
        surface: &Surface,
        positions: &[Vector3<f64>],
        active: &[ActivePair],
        gradient: &mut [f64],
    ) -> Result<()> {
        for (nodes, g) in self.local_terms(surface, positions, active, false)?.0 {
            for (i, n) in nodes.iter().enumerate() {
                for a in 0..3 {
                    gradient[3 * n + a] += self.stiffness * g[3 * i + a];
                }
            }
        }
        Ok(())
    }

    /// ∂²B/∂x² as (row, column, value) triplets over the DOF vector (3·node + axis; duplicates
    /// are to be summed), each pair's 12×12 block projected to positive semi-definite when
    /// `project` (N/m). Errors as [`add_gradient`](Self::add_gradient).
    pub fn hessian_triplets(
        &self,
        surface: &Surface,
        positions: &[Vector3<f64>],
        project: bool,
    ) -> Result<Vec<(usize, usize, f64)>> {
        self.hessian_triplets_with(surface, positions, None, project)
    }

    /// [`hessian_triplets`](Self::hessian_triplets) over the pairs among `found` (see
    /// [`active_among`](Self::active_among)).
    pub fn hessian_triplets_among(
        &self,
        surface: &Surface,
        positions: &[Vector3<f64>],
        found: &Candidates,
        project: bool,
    ) -> Result<Vec<(usize, usize, f64)>> {
        self.hessian_triplets_with(surface, positions, Some(found), project)
    }

    fn hessian_triplets_with(
        &self,
        surface: &Surface,
        positions: &[Vector3<f64>],
        found: Option<&Candidates>,
        project: bool,
    ) -> Result<Vec<(usize, usize, f64)>> {
        let active = self.active(surface, positions, found)?;
        self.hessian_triplets_of_active(surface, positions, &active, project)
    }

    /// [`hessian_triplets`](Self::hessian_triplets) over `active`, the pairs
    /// [`active_among`](Self::active_among) found at `positions` (N/m). Errors: a pair at
    /// distance 0.
    pub(crate) fn hessian_triplets_of_active(
        &self,
        surface: &Surface,
        positions: &[Vector3<f64>],
        active: &[ActivePair],
        project: bool,
    ) -> Result<Vec<(usize, usize, f64)>> {
        let blocks = self.local_terms(surface, positions, active, true)?.1;
        let mut triplets = Vec::with_capacity(144 * blocks.len());
        for (nodes, mut h) in blocks {
            if project {
                h = project_psd(h);
            }
            for i in 0..12 {
                for j in 0..12 {
                    let value = self.stiffness * h[(i, j)];
                    if value != 0.0 {
                        triplets.push((3 * nodes[i / 3] + i % 3, 3 * nodes[j / 3] + j % 3, value));
                    }
                }
            }
        }
        Ok(triplets)
    }

    /// The smallest distance (m) of a pair within d̂, +∞ when none is within reach.
    pub fn smallest_distance(&self, surface: &Surface, positions: &[Vector3<f64>]) -> Result<f64> {
        Ok(self
            .active_pairs(surface, positions)?
            .iter()
            .fold(f64::INFINITY, |d, p| d.min(p.distance)))
    }

    /// The mollifier's value, gradient and Hessian for an edge–edge pair (1 and zeros for a
    /// point–triangle pair).
    fn mollifier(
        &self,
        surface: &Surface,
        p: &ActivePair,
        positions: &[Vector3<f64>],
    ) -> (f64, Gradient12, Hessian12) {
        match p.pair {
            Pair::EdgeEdge { a, b } => {
                // Candidates were checked against the surface: both edges exist.
                let rest = |e| surface.rest_edge_length2(e).unwrap_or(f64::NAN);
                let threshold = mollifier_threshold(rest(a), rest(b));
                edge_edge_mollifier(&p.nodes.map(|n| positions[n]), threshold)
            }
            Pair::PointTriangle { .. } => (1.0, Gradient12::zeros(), Hessian12::zeros()),
        }
    }

    /// Each pair of `active`'s gradient and (when `hessian`) Hessian of mₖ·b(dₖ), unscaled by
    /// κ.
    fn local_terms(
        &self,
        surface: &Surface,
        positions: &[Vector3<f64>],
        active: &[ActivePair],
        hessian: bool,
    ) -> Result<(Local<Gradient12>, Local<Hessian12>)> {
        let d_hat = self.activation_distance;
        let (mut gradients, mut hessians) = (Vec::new(), Vec::new());
        for p in active {
            let d = p.distance;
            if d <= 0.0 {
                return Err(Error::invalid_parameter(
                    format!("surface contact pair {:?} (nodes {:?})", p.pair, p.nodes),
                    d,
                    "distance must be > 0: the surfaces touch or cross",
                ));
            }
            let x = p.nodes.map(|n| positions[n]);
            let s = squared_distance_derivatives(p.kind, &x);
            let (b, b1, b2) = (
                barrier::value(d, d_hat),
                barrier::derivative(d, d_hat),
                barrier::second_derivative(d, d_hat),
            );
            let phi1 = b1 / (2.0 * d);
            let phi2 = (b2 - b1 / d) / (4.0 * d * d);
            let (m, mg, mh) = self.mollifier(surface, p, positions);
            let gradient = m * phi1 * s.gradient + b * mg;
            if hessian {
                let cross = mg * s.gradient.transpose();
                let h = m * (phi2 * s.gradient * s.gradient.transpose() + phi1 * s.hessian)
                    + phi1 * (cross + cross.transpose())
                    + b * mh;
                hessians.push((p.nodes, h));
            } else {
                gradients.push((p.nodes, gradient));
            }
        }
        Ok((gradients, hessians))
    }
}

/// [`Error::InvalidParameter`] naming the first candidate whose node, triangle or edge is not
/// `surface`'s (or whose node is beyond `node_count` positions).
fn check_candidates(surface: &Surface, node_count: usize, found: &Candidates) -> Result<()> {
    let (triangles, edges) = (surface.triangles().len(), surface.edges().len());
    for &(node, t) in &found.point_triangle {
        if node >= node_count || t >= triangles {
            return Err(Error::invalid_parameter(
                "surface barrier candidate (node, triangle)",
                format!("({node}, {t})"),
                format!("a node below {node_count} and a triangle below {triangles}"),
            ));
        }
    }
    for &(a, b) in &found.edge_edge {
        if a >= edges || b >= edges {
            return Err(Error::invalid_parameter(
                "surface barrier candidate (edge, edge)",
                format!("({a}, {b})"),
                format!("edges below {edges}"),
            ));
        }
    }
    Ok(())
}

/// The nearest positive semi-definite matrix (Frobenius norm) to a symmetric `h`: its
/// eigen-decomposition with the negative eigenvalues set to zero.
pub fn project_psd(h: Hessian12) -> Hessian12 {
    let symmetric = 0.5 * (h + h.transpose());
    let mut eigen = SymmetricEigen::new(symmetric);
    if eigen.eigenvalues.iter().all(|&l| l >= 0.0) {
        return symmetric;
    }
    eigen.eigenvalues.iter_mut().for_each(|l| *l = l.max(0.0));
    eigen.recompose()
}
