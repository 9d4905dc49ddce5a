//! The contact of a body's surface nodes with a set of rigid obstacles: the barrier energy, its
//! force and tangent on the full DOF vector, the step limit of continuous collision detection,
//! and the check that the body starts outside every obstacle.

mod relax;

use nalgebra::{Matrix3, Vector3};

use super::barrier;
use super::friction::{FrictionLag, LaggedPoint, f0, f1_over_y, speed_after_friction};
use super::{ContactParameters, Obstacle};
use crate::base::error::{Error, Result};
use crate::mesh::{BoundaryFace, CellType, NodeList, TetMesh};
use crate::sparse::CscMatrix;

/// The default gap error of a static frictionless contact solution (see
/// [`Contact::with_gap_tolerance`]; with friction the static solve keeps the given d̂):
/// the barrier's force-weighted gap at most 1e-8 of the largest displacement, so that the
/// contact force is within about that of the exact (node-to-obstacle) contact of the mesh.
pub const GAP_TOLERANCE: f64 = 1e-8;

/// The contact force's error per unit of gap error when the barrier keeps its reach (no
/// continuation): the barrier's force on the body exceeds the exact contact of the mesh by
/// between 2.2 and 5.9 times the gap error ε = (Σλᵢdᵢ/Σλᵢ)/max|u|, measured on the lens of
/// `tests/core/contact_exact.rs` pressed by 0.2 %, 0.5 % and 1 % of its radius under d̂, d̂/2
/// and d̂/4 (`tests/core/barrier_reach.rs`); the ratio grows as ε shrinks, 6 bounds it.
pub const FORCE_ERROR_PER_GAP_ERROR: f64 = 6.0;

/// The gap error above which a dynamic run's contact forces may be off the exact contact of
/// the mesh by more than 1 %: 0.01 / [`FORCE_ERROR_PER_GAP_ERROR`] ≈ 1.7e-3 (a warning, see
/// [`Warning::BarrierGapError`](crate::base::warning::Warning::BarrierGapError)).
pub const GAP_ERROR_WARNING: f64 = 0.01 / FORCE_ERROR_PER_GAP_ERROR;

/// The barrier's gaps at one state ([`Contact::barrier_gaps`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BarrierGaps {
    /// The force-weighted gap Σᵢλᵢdᵢ/Σᵢλᵢ of the nodes the barrier pushes (length; 0 when it
    /// pushes none).
    pub weighted_gap: f64,
    /// The gap error ε: the weighted gap over max|u| (dimensionless; 0 at rest), as the static
    /// solve reports it.
    pub gap_error: f64,
    /// The barrier's total normal force Σᵢλᵢ on the body (force units; 0 when it pushes none).
    pub pushed_force: f64,
    /// The smallest signed distance of a contact node to an obstacle (length; ≤ 0 for a node on
    /// or inside one; +∞ without contact nodes).
    pub smallest_gap: f64,
}

/// Node-versus-obstacle contact of a mesh's boundary nodes with rigid obstacles:
///
/// E_c(u) = κ·Σᵢ Aᵢ·Σ_o b(d_o(Xᵢ + uᵢ)),
///
/// i over the boundary nodes, Aᵢ a third of the area of the boundary triangles around node i at
/// rest (so the contact pressure −κ·b′(d) does not depend on the surface mesh), b the IPC
/// barrier with activation distance d̂ ([`barrier`]). Each term involves one
/// node, so the Hessian is 3×3 blocks on the diagonal: entries the assembly pattern has already.
#[derive(Debug, Clone)]
pub struct Contact {
    obstacles: Vec<Obstacle>,
    parameters: ContactParameters,
    /// Boundary nodes, ascending.
    nodes: Vec<usize>,
    /// Their rest positions.
    rest: Vec<Vector3<f64>>,
    /// Their lumped rest areas Aᵢ (length²).
    areas: Vec<f64>,
    /// ε_v (length/time): slip below this speed counts as sticking (friction's smoothing).
    slip_velocity: f64,
    /// ε_d (length): in a static solve, slip below this distance per load step counts as
    /// sticking (`None`: [`STATIC_SLIP_FRACTION`] × d̂).
    slip_distance: Option<f64>,
    /// Each obstacle's current offset c (length; see [`set_time`](Self::set_time)).
    placement: Placement,
    /// The gap error a static solve drives its barrier to (dimensionless).
    gap_tolerance: f64,
    /// With an impact fraction, each contact node's barrier stiffness κᵢ in force (Pa/m, in
    /// the order of `nodes`; see [`update_impact_stiffness`](Contact::update_impact_stiffness));
    /// empty without one (every node at κ).
    kappa: super::impact::NodeStiffness,
}

/// The obstacles' current offsets, behind a lock so that a shared contact (inside an
/// `Arc<NonlinearForce>`) can be moved through time; a clone copies the offsets.
#[derive(Debug, Default)]
struct Placement(std::sync::Mutex<Vec<Vector3<f64>>>);

impl Placement {
    fn get(&self) -> Vec<Vector3<f64>> {
        // A poisoned lock only means a panic elsewhere while holding plain data: keep it.
        self.0.lock().unwrap_or_else(|e| e.into_inner()).clone()
    }

    fn set(&self, offsets: Vec<Vector3<f64>>) {
        *self.0.lock().unwrap_or_else(|e| e.into_inner()) = offsets;
    }
}

impl Clone for Placement {
    fn clone(&self) -> Self {
        Placement(std::sync::Mutex::new(self.get()))
    }
}

/// The default ε_v: this fraction of the bounding-box diagonal per unit time.
pub const SLIP_FRACTION: f64 = 1e-3;

/// The default ε_d of a static solve: this fraction of the activation distance d̂.
pub const STATIC_SLIP_FRACTION: f64 = 0.1;

/// How many offending nodes an error lists.
const LISTED: usize = 5;

/// Boundary nodes inside or on an obstacle (see [`Contact::nodes_inside`]).
#[derive(Debug, Clone, PartialEq)]
pub struct NodesInside {
    /// The obstacle's name.
    pub obstacle: String,
    /// Each node inside or on it, with its signed distance (length; ≤ 0, or NaN).
    pub nodes: Vec<(usize, f64)>,
}

/// "N boundary nodes inside or on it (node a at d, …)", the first five nodes named.
impl std::fmt::Display for NodesInside {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let listed: Vec<String> = self
            .nodes
            .iter()
            .take(LISTED)
            .map(|(n, d)| format!("node {n} at {d:.3e}"))
            .collect();
        write!(
            f,
            "{} boundary nodes inside or on it ({}{})",
            self.nodes.len(),
            listed.join(", "),
            if self.nodes.len() > LISTED {
                ", …"
            } else {
                ""
            }
        )
    }
}

impl Contact {
    /// The contact of `mesh`'s boundary nodes with `obstacles` under `parameters`.
    ///
    /// Errors: no obstacle; two obstacles with one name; parameters not finite and > 0, an
    /// activation distance above the mesh's bounding-box diagonal; the body at rest inside an
    /// obstacle or within reach of d ≤ 0 (see [`check_state`](Self::check_state)); an obstacle
    /// that reaches into a boundary face between its nodes or lies wholly inside the body (see
    /// [`super::overlap`]).
    ///
    /// Any cell type: on 10-node tets the contact points are the boundary's corner and
    /// mid-edge nodes, each boundary face split into its four straight sub-triangles
    /// ([`contact_faces`]) for the nodes' area shares (A/12 at a corner, A/4 at a mid-edge
    /// node of a face of area A) and the overlap check.
    pub fn new<C: CellType>(
        mesh: &TetMesh<C>,
        obstacles: Vec<Obstacle>,
        parameters: ContactParameters,
    ) -> Result<Self> {
        parameters.check()?;
        // A barrier reaching farther than the body is large pushes from everywhere (the
        // default d̂ is 1e-3 of the diagonal); 1e300 is an input error, not a model.
        let (min, max) = mesh.bounding_box();
        let diagonal = (max - min).norm();
        if parameters.activation_distance > diagonal {
            return Err(Error::invalid_parameter(
                "contact activation_distance",
                crate::base::error::short_number(parameters.activation_distance),
                format!(
                    "must be at most the body's bounding-box diagonal, {} (the default is {} of it, {})",
                    crate::base::error::short_number(diagonal),
                    super::parameters::ACTIVATION_FRACTION,
                    crate::base::error::short_number(
                        super::parameters::ACTIVATION_FRACTION * diagonal
                    )
                ),
            ));
        }
        if obstacles.is_empty() {
            return Err(Error::invalid_parameter(
                "contact obstacles",
                0,
                "need at least one obstacle",
            ));
        }
        for (k, o) in obstacles.iter().enumerate() {
            if obstacles[..k].iter().any(|p| p.name() == o.name()) {
                return Err(Error::invalid_parameter(
                    "obstacle name",
                    o.name(),
                    "must be unique",
                ));
            }
        }
        let mut areas = vec![0.0; mesh.node_count()];
        let faces = contact_faces(mesh)?;
        for face in &faces {
            let third = face.area_vector(mesh)?.norm() / 3.0;
            for &n in &face.nodes {
                areas[n] += third;
            }
        }
        let nodes: Vec<usize> = (0..mesh.node_count()).filter(|&n| areas[n] > 0.0).collect();
        let (min, max) = mesh.bounding_box();
        let mut contact = Contact {
            slip_velocity: SLIP_FRACTION * (max - min).norm(),
            slip_distance: None,
            rest: nodes.iter().map(|&n| mesh.nodes()[n]).collect(),
            areas: nodes.iter().map(|&n| areas[n]).collect(),
            nodes,
            placement: Placement(std::sync::Mutex::new(
                obstacles.iter().map(|o| o.offset(0.0)).collect(),
            )),
            obstacles,
            parameters,
            gap_tolerance: GAP_TOLERANCE,
            kappa: super::impact::NodeStiffness::default(),
        };
        contact.kappa = contact.kept_stiffness(parameters);
        contact.check_state(&vec![0.0; mesh.dof_count()])?;
        // The nodes are outside; the faces between them and the obstacles' interiors next.
        super::overlap::check_surface(
            mesh.nodes(),
            &faces,
            &contact.obstacles,
            &contact.offsets(),
            (max - min).norm(),
        )?;
        Ok(contact)
    }

    /// The contact with friction's stick speed ε_v = `slip_velocity` (length/time; default
    /// 10⁻³ of the bounding-box diagonal per unit time): tangential speeds below it are
    /// resolved as sticking, with a creep below ε_v. [`Error::InvalidParameter`] unless finite
    /// and > 0.
    pub fn with_slip_velocity(mut self, slip_velocity: f64) -> Result<Self> {
        if !(slip_velocity.is_finite() && slip_velocity > 0.0) {
            return Err(Error::invalid_parameter(
                "friction slip_velocity",
                slip_velocity,
                "must be finite and > 0",
            ));
        }
        self.slip_velocity = slip_velocity;
        Ok(self)
    }

    /// ε_v (length/time).
    pub fn slip_velocity(&self) -> f64 {
        self.slip_velocity
    }

    /// The contact with friction's stick distance ε_d = `slip_distance` (length) for static
    /// solves: a node whose slip over a load step stays below ε_d sticks (its friction force
    /// μ·λ·f₁(y) grows smoothly from 0 with the slip y and reaches μ·λ at ε_d), so a sticking
    /// contact creeps at most ε_d per load step. Default [`STATIC_SLIP_FRACTION`]·d̂ = d̂/10: with
    /// the default 10 load steps a sticking node creeps at most d̂ in all, the scale of the
    /// barrier's own gap error, while the friction stiffness 2μλ/ε_d stays within a small
    /// factor of the barrier's normal stiffness (Newton's matrix stays well conditioned).
    /// [`Error::InvalidParameter`] unless finite and > 0.
    pub fn with_slip_distance(mut self, slip_distance: f64) -> Result<Self> {
        if !(slip_distance.is_finite() && slip_distance > 0.0) {
            return Err(Error::invalid_parameter(
                "friction slip_distance",
                slip_distance,
                "must be finite and > 0",
            ));
        }
        self.slip_distance = Some(slip_distance);
        Ok(self)
    }

    /// ε_d (length): the static solve's stick distance per load step (see
    /// [`with_slip_distance`](Self::with_slip_distance)).
    pub fn slip_distance(&self) -> f64 {
        self.slip_distance
            .unwrap_or(STATIC_SLIP_FRACTION * self.parameters.activation_distance)
    }

    /// The obstacles.
    pub fn obstacles(&self) -> &[Obstacle] {
        &self.obstacles
    }

    /// Whether an obstacle moves ([`Obstacle::with_motion`]) or spins ([`Obstacle::with_spin`]:
    /// its shape stays, but friction's slip is measured against its turning surface, so a step
    /// needs its duration: the moving obstacles' path of the solvers).
    pub fn is_moving(&self) -> bool {
        self.obstacles
            .iter()
            .any(|o| o.motion().is_some() || o.spin().is_some())
    }

    /// Each obstacle's offset c(t) (length) at time `t`, in the obstacles' order.
    pub fn offsets_at(&self, t: f64) -> Vec<Vector3<f64>> {
        self.obstacles.iter().map(|o| o.offset(t)).collect()
    }

    /// The obstacles' current offsets (length): where every method of this contact places them.
    pub fn offsets(&self) -> Vec<Vector3<f64>> {
        self.placement.get()
    }

    /// Places the obstacles at time `t` (time): every method then sees obstacle o at its
    /// offset c_o(t). The contact starts at t = 0.
    pub fn set_time(&self, t: f64) {
        self.placement.set(self.offsets_at(t));
    }

    /// Places the obstacles at `offsets` (length, one per obstacle, in their order; an
    /// intermediate placement of a staged step). [`Error::DimensionMismatch`] on another count.
    pub fn set_offsets(&self, offsets: Vec<Vector3<f64>>) -> Result<()> {
        Error::check_len("obstacle offsets", self.obstacles.len(), offsets.len())?;
        self.placement.set(offsets);
        Ok(())
    }

    /// Continuous collision detection for the obstacles' own motion: the largest fraction
    /// σ ∈ (0, 1] of the straight move of every obstacle from its current offset to `target`
    /// (length, one per obstacle) that keeps every boundary node at full displacement `u`
    /// outside every obstacle (1 when none is reached). A translation of the obstacle by Δc is
    /// the motion −Δc of the point relative to it, so this is
    /// [`Obstacle::time_of_impact`] of x − c along −Δc; exact for these shapes.
    pub fn motion_step_limit(&self, u: &[f64], target: &[Vector3<f64>]) -> Result<f64> {
        self.check_full(u)?;
        Error::check_len("obstacle offsets", self.obstacles.len(), target.len())?;
        let offsets = self.offsets();
        let mut sigma: f64 = 1.0;
        for k in 0..self.nodes.len() {
            let x = self.position(k, u);
            for (o, obstacle) in self.obstacles.iter().enumerate() {
                let shift = target[o] - offsets[o];
                if shift == Vector3::zeros() {
                    continue;
                }
                if let Some(hit) = obstacle.time_of_impact(&(x - offsets[o]), &-shift) {
                    sigma = sigma.min(hit);
                }
            }
        }
        Ok(sigma)
    }

    /// The contact with the gap error `tolerance` a static solve drives its barrier to (see
    /// [`complementarity`](Self::complementarity) and
    /// [`solve_nonlinear_static_with_contact`](crate::analysis::nonlinear::solve_nonlinear_static_with_contact);
    /// default [`GAP_TOLERANCE`]). [`Error::InvalidParameter`] naming `contact gap_tolerance`
    /// unless finite and in (0, 1).
    pub fn with_gap_tolerance(mut self, tolerance: f64) -> Result<Self> {
        if !(tolerance.is_finite() && tolerance > 0.0 && tolerance < 1.0) {
            return Err(Error::invalid_parameter(
                "contact gap_tolerance",
                tolerance,
                "must be finite and in (0, 1)",
            ));
        }
        self.gap_tolerance = tolerance;
        Ok(self)
    }

    /// The gap error a static solve drives its barrier to (dimensionless; see
    /// [`with_gap_tolerance`](Self::with_gap_tolerance)).
    pub fn gap_tolerance(&self) -> f64 {
        self.gap_tolerance
    }

    /// d̂ and κ (κ₀ with an impact fraction; the values in force are
    /// [`node_stiffnesses`](Self::node_stiffnesses)).
    pub fn parameters(&self) -> ContactParameters {
        self.parameters
    }

    /// The per-node stiffnesses kept under `parameters`: one per contact node at κ₀ with an
    /// impact fraction, none without.
    fn kept_stiffness(&self, parameters: ContactParameters) -> super::impact::NodeStiffness {
        let count = match parameters.impact_fraction {
            Some(_) => self.nodes.len(),
            None => 0,
        };
        super::impact::NodeStiffness::new(count, parameters.stiffness)
    }

    /// The `k`-th contact node's barrier stiffness in force (Pa/m): κ without an impact
    /// fraction.
    fn kappa_of(&self, k: usize) -> f64 {
        self.kappa.get(k, self.parameters.stiffness)
    }

    /// The largest barrier stiffness in force over the contact nodes (Pa/m):
    /// [`ContactParameters::stiffness`] without an impact fraction, with one the largest κᵢ
    /// of the last [`update_impact_stiffness`](Self::update_impact_stiffness).
    pub fn stiffness(&self) -> f64 {
        (0..self.kappa.len())
            .map(|k| self.kappa_of(k))
            .fold(self.parameters.stiffness, f64::max)
    }

    /// Each contact node's barrier stiffness κᵢ in force (Pa/m, in the order of
    /// [`nodes`](Self::nodes)) with an impact fraction, what a resumed run needs to continue
    /// with the same bits; `None` without one (every node at κ).
    pub fn node_stiffnesses(&self) -> Option<Vec<f64>> {
        (self.kappa.len() > 0).then(|| (0..self.kappa.len()).map(|k| self.kappa_of(k)).collect())
    }

    /// Sets every contact node's κᵢ (Pa/m) from `values` (one per contact node, as
    /// [`node_stiffnesses`](Self::node_stiffnesses) gives them: a resumed run's, from its
    /// checkpoint). Nothing without an impact fraction. [`Error::InvalidParameter`] naming the
    /// count for another number of values, or a value not finite and > 0.
    pub fn set_node_stiffnesses(&self, values: &[f64]) -> Result<()> {
        if self.kappa.len() == 0 {
            return Ok(());
        }
        Error::check_len("contact node stiffnesses", self.kappa.len(), values.len())?;
        if let Some(k) = values.iter().position(|v| !(v.is_finite() && *v > 0.0)) {
            return Err(Error::invalid_parameter(
                format!("contact node stiffness {k}"),
                values[k],
                "must be finite and > 0 (Pa/m)",
            ));
        }
        for (k, &v) in values.iter().enumerate() {
            self.kappa.set(k, v);
        }
        Ok(())
    }

    /// Sets every contact node's κᵢ to `kappa` (Pa/m) where an impact fraction is on (a new
    /// run's κ₀, or a checkpoint's one stiffness in force where it holds no per-node values);
    /// without one κ stays the parameters' own.
    pub(crate) fn set_stiffness_in_force(&self, kappa: f64) {
        if kappa.is_finite() && kappa > 0.0 {
            for k in 0..self.kappa.len() {
                self.kappa.set(k, kappa);
            }
        }
    }

    /// With an impact fraction f ([`ContactParameters::impact_fraction`]), sets each contact
    /// node's barrier stiffness for a step from its start state ([`super::impact`]): a node
    /// within d̂ of an obstacle keeps its κᵢ; one outside d̂ of every obstacle takes
    /// κᵢ = max(κ₀, max_o mᵢ·v_n,ᵢ,ₒ²/(2·Aᵢ·b(f·d̂))) (Pa/m; v_n,ᵢ,ₒ > 0 its approach speed to
    /// obstacle o). Returns the largest κᵢ ([`stiffness`](Self::stiffness)); without an impact
    /// fraction returns κ and changes nothing. `u`, `velocity`: full
    /// displacement and velocity (length, length/time); `mass`: each mesh node's lumped mass
    /// (mass units, one per node); `duration`: the step (time; the
    /// obstacles' approach is measured against their mean velocity from their current
    /// placement to the one at the current time + `duration`, set by
    /// [`set_time`](Self::set_time) before).
    ///
    /// Errors: lengths that do not match the mesh; a node on or inside an obstacle.
    pub fn update_impact_stiffness(
        &self,
        u: &[f64],
        velocity: &[f64],
        mass: &[f64],
        (time, duration): (f64, f64),
    ) -> Result<f64> {
        let Some(fraction) = self.parameters.impact_fraction else {
            return Ok(self.stiffness());
        };
        self.check_full(u)?;
        Error::check_len("contact velocity", u.len(), velocity.len())?;
        Error::check_len("contact node masses", u.len() / 3, mass.len())?;
        let d_hat = self.parameters.activation_distance;
        let now = self.offsets();
        let obstacle_velocity: Vec<Vector3<f64>> = match duration > 0.0 {
            true => (self.offsets_at(time + duration).iter().zip(&now))
                .map(|(after, before)| (after - before) / duration)
                .collect(),
            false => vec![Vector3::zeros(); now.len()],
        };
        // Per node: whether it is within d̂ of an obstacle, and its largest estimate.
        let mut nodes = vec![(false, 0.0f64); self.nodes.len()];
        self.for_each_gap(u, |k, o, x, d| {
            let (within, estimate) = &mut nodes[k];
            *within |= d < d_hat;
            let n = self.nodes[k];
            let v = Vector3::new(velocity[3 * n], velocity[3 * n + 1], velocity[3 * n + 2]);
            let approach = -self.obstacles[o]
                .gradient(x)
                .dot(&(v - obstacle_velocity[o]));
            *estimate = estimate.max(super::impact::node_estimate(
                mass[n],
                approach,
                self.areas[k],
                d_hat,
                fraction,
            ));
        });
        for (k, (within, estimate)) in nodes.into_iter().enumerate() {
            // A node within d̂ keeps its κᵢ: it may hold barrier energy at it, which a change
            // would add to or take from the run.
            let next = super::impact::next_stiffness(
                self.parameters.stiffness,
                self.kappa_of(k),
                estimate,
                within,
            );
            self.kappa.set(k, next);
        }
        Ok(self.stiffness())
    }

    /// The same contact (nodes, obstacles and their placement, friction's scales) under other
    /// barrier scales `parameters`: what a solve that changes d̂ or κ between its stages takes
    /// (a smaller d̂ brings the barrier's equilibrium gaps nearer zero). A state outside every
    /// obstacle stays admissible under any d̂ and κ: gaps are checked against zero, not d̂.
    ///
    /// Errors: `parameters` not finite and > 0, or a d̂ above this contact's (the constructor
    /// bounded that one by the body's size).
    pub fn with_parameters(&self, parameters: ContactParameters) -> Result<Contact> {
        parameters.check()?;
        if parameters.activation_distance > self.parameters.activation_distance {
            return Err(Error::invalid_parameter(
                "contact activation_distance",
                crate::base::error::short_number(parameters.activation_distance),
                format!(
                    "must be at most the contact's own, {}",
                    crate::base::error::short_number(self.parameters.activation_distance)
                ),
            ));
        }
        let mut contact = self.clone();
        // Friction's stick distance stays what it was (its default follows d̂).
        contact.slip_distance = Some(self.slip_distance());
        contact.parameters = parameters;
        contact.kappa = contact.kept_stiffness(parameters);
        Ok(contact)
    }

    /// The boundary nodes that take part, ascending.
    pub fn nodes(&self) -> &[usize] {
        &self.nodes
    }

    /// Length of the full displacement vectors this contact reads (3 per mesh node).
    pub(super) fn check_full(&self, u: &[f64]) -> Result<()> {
        let needed = self.nodes.last().map_or(0, |n| 3 * n + 3);
        if u.len() < needed || !u.len().is_multiple_of(3) {
            return Err(Error::invalid_parameter(
                "contact displacement",
                format!("{} entries", u.len()),
                format!("must be the full displacement of the mesh (≥ {needed}, 3 per node)"),
            ));
        }
        Ok(())
    }

    fn position(&self, k: usize, u: &[f64]) -> Vector3<f64> {
        let n = self.nodes[k];
        self.rest[k] + Vector3::new(u[3 * n], u[3 * n + 1], u[3 * n + 2])
    }

    /// [`Error::InvalidParameter`] naming the obstacle and the first nodes (with their signed
    /// distances) that are not strictly outside it at full displacement `u`.
    pub fn check_state(&self, u: &[f64]) -> Result<()> {
        match self.nodes_inside(u)? {
            None => Ok(()),
            Some(inside) => Err(Error::invalid_parameter(
                format!("obstacle {}", inside.obstacle),
                inside.to_string(),
                "the body must start strictly outside every obstacle (signed distance > 0)",
            )),
        }
    }

    /// The first obstacle (in order) that boundary nodes are inside or on at full displacement
    /// `u`, with those nodes and their signed distances; `None` when every node is strictly
    /// outside every obstacle.
    pub fn nodes_inside(&self, u: &[f64]) -> Result<Option<NodesInside>> {
        self.check_full(u)?;
        let mut inside: Vec<Vec<(usize, f64)>> = vec![Vec::new(); self.obstacles.len()];
        self.for_each_gap(u, |k, o, _, d| {
            if d.is_nan() || d <= 0.0 {
                inside[o].push((self.nodes[k], d));
            }
        });
        Ok(self
            .obstacles
            .iter()
            .zip(inside)
            .find(|(_, nodes)| !nodes.is_empty())
            .map(|(obstacle, nodes)| NodesInside {
                obstacle: obstacle.name().to_string(),
                nodes,
            }))
    }

    /// E_c(u) (energy units) at full displacement `u`; +∞ if a node is on or inside an obstacle.
    pub fn energy(&self, u: &[f64]) -> Result<f64> {
        self.check_full(u)?;
        let d_hat = self.parameters.activation_distance;
        let mut total = 0.0;
        self.for_each_gap(u, |k, _, _, d| {
            if d < d_hat {
                total += self.kappa_of(k) * self.areas[k] * barrier::value(d, d_hat);
            }
        });
        Ok(total)
    }

    /// Adds the contact force −∂E_c/∂u (force units) at full displacement `u` into `force`
    /// (full length). [`Error::InvalidParameter`] if a node is on or inside an obstacle.
    pub fn add_force(&self, u: &[f64], force: &mut [f64]) -> Result<()> {
        self.check_full(u)?;
        Error::check_len("contact force", u.len(), force.len())?;
        self.for_each_active(u, |n, _, obstacle, x, d, (area, kappa)| {
            let f = -kappa
                * area
                * barrier::derivative(d, self.parameters.activation_distance)
                * obstacle.gradient(x);
            for a in 0..3 {
                force[3 * n + a] += f[a];
            }
        })
    }

    /// The contact force on each obstacle, Σᵢ κ·Aᵢ·b′(dᵢ)·∇d (force units; the reaction of
    /// the body's contact force), in the obstacles' order.
    pub fn obstacle_forces(&self, u: &[f64]) -> Result<Vec<Vector3<f64>>> {
        let mut forces = vec![Vector3::zeros(); self.obstacles.len()];
        self.for_each_active(u, |_, o, obstacle, x, d, (area, kappa)| {
            forces[o] += kappa
                * area
                * barrier::derivative(d, self.parameters.activation_distance)
                * obstacle.gradient(x);
        })?;
        Ok(forces)
    }

    /// The barrier's complementarity at `u`: (Σᵢ λᵢ·dᵢ, Σᵢ λᵢ) over every node and obstacle
    /// it pushes, λᵢ = −κ·Aᵢ·b′(dᵢ) the node's normal force (force units) and dᵢ its gap
    /// (length); the first in energy units. An exact contact has λᵢ·dᵢ = 0 (a node is touching
    /// or free); the barrier holds each pushed node at a gap dᵢ ∈ (0, d̂), so
    /// Σλd/Σλ is the force-weighted gap by which its solution misses the exact one — what
    /// [`crate::analysis::nonlinear`]'s continuation of d̂ drives down.
    pub fn complementarity(&self, u: &[f64]) -> Result<(f64, f64)> {
        let (mut work, mut total) = (0.0, 0.0);
        self.for_each_active(u, |_, _, _, _, d, (area, kappa)| {
            let lambda =
                -kappa * area * barrier::derivative(d, self.parameters.activation_distance);
            work += lambda * d;
            total += lambda;
        })?;
        Ok((work, total))
    }

    /// The barrier's gaps at full displacement `u` with the obstacles at their current placement
    /// ([`BarrierGaps`]): its complementarity over the nodes it pushes (a node on or inside an
    /// obstacle pushes nothing here; it is the smallest gap) and the smallest gap. One pass over
    /// the contact nodes and obstacles; never an error for a node inside (a measurement).
    pub fn barrier_gaps(&self, u: &[f64]) -> Result<BarrierGaps> {
        self.check_full(u)?;
        let d_hat = self.parameters.activation_distance;
        let (mut work, mut total, mut smallest) = (0.0, 0.0, f64::INFINITY);
        self.for_each_gap(u, |k, _, _, d| {
            smallest = smallest.min(if d.is_nan() { f64::NEG_INFINITY } else { d });
            if d > 0.0 && d < d_hat {
                let lambda = -self.kappa_of(k) * self.areas[k] * barrier::derivative(d, d_hat);
                work += lambda * d;
                total += lambda;
            }
        });
        let weighted_gap = if total > 0.0 { work / total } else { 0.0 };
        let largest = u.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        Ok(BarrierGaps {
            weighted_gap,
            gap_error: if largest > 0.0 {
                weighted_gap / largest
            } else {
                0.0
            },
            pushed_force: total,
            smallest_gap: smallest,
        })
    }

    /// The smallest signed distance of a contact node to an obstacle at full displacement `u`,
    /// the obstacles at their current placement (length; ≤ 0 for a node on or inside one, −∞
    /// for a NaN position; +∞ without contact nodes).
    pub fn smallest_gap(&self, u: &[f64]) -> Result<f64> {
        self.check_full(u)?;
        let mut smallest = f64::INFINITY;
        self.for_each_gap(u, |_, _, _, d| {
            smallest = smallest.min(if d.is_nan() { f64::NEG_INFINITY } else { d });
        });
        Ok(smallest)
    }

    /// Per boundary node (ascending, as [`nodes`](Self::nodes)): the smallest gap over the
    /// obstacles (length) and the contact pressure −κ·Σ_o b′(d_o) (Pa).
    pub fn gaps_and_pressures(&self, u: &[f64]) -> Result<(Vec<f64>, Vec<f64>)> {
        self.check_full(u)?;
        let d_hat = self.parameters.activation_distance;
        let mut gaps = vec![f64::INFINITY; self.nodes.len()];
        let mut pressures = vec![0.0; self.nodes.len()];
        self.for_each_gap(u, |k, _, _, d| {
            gaps[k] = gaps[k].min(d);
            pressures[k] -= self.kappa_of(k) * barrier::derivative(d, d_hat);
        });
        Ok((gaps, pressures))
    }

    /// Per mesh node, for the `.vtu` fields `contact_gap` and `contact_pressure`: the gap, the
    /// smallest signed distance to the obstacles at their current placement (length; every
    /// node, interior ones too), and the contact pressure −κ·Σ_o b′(d_o) (Pa: the barrier
    /// force κ·Aᵢ·|b′| over the node's area share Aᵢ; 0 off the boundary). `rest` the mesh's
    /// node positions, `u` the full displacement.
    pub fn node_fields(&self, rest: &[Vector3<f64>], u: &[f64]) -> Result<(Vec<f64>, Vec<f64>)> {
        Error::check_len("contact node fields", 3 * rest.len(), u.len())?;
        let offsets = self.offsets();
        let mut gaps: Vec<f64> = rest
            .iter()
            .enumerate()
            .map(|(n, x)| {
                let x = x + Vector3::new(u[3 * n], u[3 * n + 1], u[3 * n + 2]);
                self.obstacles
                    .iter()
                    .zip(&offsets)
                    .map(|(o, c)| o.distance(&(x - c)))
                    .fold(f64::INFINITY, f64::min)
            })
            .collect();
        let mut pressures = vec![0.0; rest.len()];
        let (boundary_gaps, boundary_pressures) = self.gaps_and_pressures(u)?;
        for (k, &n) in self.nodes.iter().enumerate() {
            gaps[n] = boundary_gaps[k];
            pressures[n] = boundary_pressures[k];
        }
        Ok((gaps, pressures))
    }

    /// Whether any obstacle has friction (μ > 0).
    pub fn has_friction(&self) -> bool {
        self.obstacles.iter().any(|o| o.friction() > 0.0)
    }

    /// The friction data of a step starting at full displacement `u` (see
    /// [`super::friction`]): per node within d̂ of an obstacle with μ > 0, the normal force
    /// λ = κ·Aᵢ·|b′(d)| and the tangent projector there, with smoothing distance `epsilon`
    /// (length; ε_v·dt).
    /// Obstacles that spin do not turn here (a step of zero duration): steps with spinning
    /// obstacles take [`friction_lag_toward`](Self::friction_lag_toward).
    pub fn friction_lag(&self, u: &[f64], epsilon: f64) -> Result<FrictionLag> {
        self.friction_lag_toward(u, epsilon, &self.offsets(), 0.0)
    }

    /// [`friction_lag`](Self::friction_lag) for a step of `duration` (time; pseudo-time in a
    /// static solve) that ends with the obstacles at `target` (length, one offset per
    /// obstacle): the slip is measured relative to the motion of each obstacle's material point
    /// under the node, P·((x − x⁰) − (c_target − c) − (R(ω·Δt) − I)·(x⁰ − c − p)) with the
    /// obstacle's spin ω about p ([`Obstacle::surface_turn`]; zero without one), so a node
    /// carried along by a moving or turning obstacle does not slip.
    pub fn friction_lag_toward(
        &self,
        u: &[f64],
        epsilon: f64,
        target: &[Vector3<f64>],
        duration: f64,
    ) -> Result<FrictionLag> {
        Error::check_len("obstacle offsets", self.obstacles.len(), target.len())?;
        if !(epsilon.is_finite() && epsilon > 0.0) {
            return Err(Error::invalid_parameter(
                "friction smoothing distance",
                epsilon,
                "must be finite and > 0",
            ));
        }
        let mut points = Vec::new();
        let d_hat = self.parameters.activation_distance;
        self.for_each_active(u, |n, o, obstacle, x, d, (area, kappa)| {
            if obstacle.friction() > 0.0 {
                let normal_force = -kappa * area * barrier::derivative(d, d_hat);
                let g = obstacle.gradient(x);
                points.push(LaggedPoint {
                    node: n,
                    obstacle: o,
                    // In world coordinates: where the node would be if it moved with the
                    // obstacle's surface (x is relative to the obstacle's current offset).
                    start: x + obstacle.surface_turn(x, duration) + target[o],
                    limit: obstacle.friction() * normal_force,
                    projector: Matrix3::identity() - g * g.transpose(),
                });
            }
        })?;
        Ok(FrictionLag { points, epsilon })
    }

    /// The friction data of a static load step (fixed obstacles at their current placement):
    /// the normal forces λ and tangent planes at full displacement `normal_at` (the lag of the
    /// current pass), the slip measured from the positions at full displacement `start` (the
    /// load step's start), smoothing distance `epsilon` (length; ε_d). With `normal_at` =
    /// `start` it is [`friction_lag`](Self::friction_lag).
    pub fn friction_lag_from(
        &self,
        normal_at: &[f64],
        start: &[f64],
        epsilon: f64,
    ) -> Result<FrictionLag> {
        self.check_full(start)?;
        Error::check_len("friction start", normal_at.len(), start.len())?;
        let mut lag = self.friction_lag(normal_at, epsilon)?;
        for p in &mut lag.points {
            // World positions: the obstacles do not move within a static solve.
            p.start = self.lagged_position(p, start)?;
        }
        Ok(lag)
    }

    /// [`friction_lag_from`](Self::friction_lag_from) for a static load step whose obstacles
    /// move from the offsets `from` (at the load step's start) to `to` (its end; length, one
    /// per obstacle): the slip is measured relative to each obstacle o, from the start position
    /// carried along by its move, P·((x − x⁰) − (c_to − c_from)), so a node that the obstacle
    /// carries along does not slip; with a spin, the start position also turns with the
    /// obstacle's surface over the load step's `duration` (pseudo-time),
    /// (R(ω·Δt) − I)·(x⁰ − c_from − p) ([`Obstacle::surface_turn`]). With `from` = `to` and no
    /// spin it is `friction_lag_from`.
    pub fn friction_lag_moving(
        &self,
        normal_at: &[f64],
        start: &[f64],
        (from, to): (&[Vector3<f64>], &[Vector3<f64>]),
        epsilon: f64,
        duration: f64,
    ) -> Result<FrictionLag> {
        Error::check_len("obstacle offsets", self.obstacles.len(), from.len())?;
        Error::check_len("obstacle offsets", self.obstacles.len(), to.len())?;
        let mut lag = self.friction_lag_from(normal_at, start, epsilon)?;
        for p in &mut lag.points {
            let relative = p.start - from[p.obstacle];
            p.start += to[p.obstacle] - from[p.obstacle]
                + self.obstacles[p.obstacle].surface_turn(&relative, duration);
        }
        Ok(lag)
    }

    /// The friction force on each obstacle (force units; the reaction of the body's friction
    /// force μ·λ·(f₁(y)/y)·P·(x − x⁰)), in the obstacles' order, at full displacement `u`
    /// with the lagged data `lag`.
    pub fn obstacle_friction_forces(
        &self,
        lag: &FrictionLag,
        u: &[f64],
    ) -> Result<Vec<Vector3<f64>>> {
        self.check_full(u)?;
        let mut forces = vec![Vector3::zeros(); self.obstacles.len()];
        for p in &lag.points {
            let slip = p.slip(&self.lagged_position(p, u)?);
            forces[p.obstacle] += p.limit * f1_over_y(slip.norm(), lag.epsilon) * slip;
        }
        Ok(forces)
    }

    /// Friction in an explicit step, as an implicit velocity update per node. An explicit
    /// friction force would be a damper of coefficient ≈ μ·λ/ε_v, stable only for
    /// dt < 2·m/(μ·λ/ε_v) — far below the elastic critical step. With lumped mass each node's
    /// friction involves that node alone, so it is solved exactly for the end-of-step velocity:
    /// per boundary node i within d̂ of an obstacle o with μ > 0 at full displacement `u`
    /// (obstacles at their current placement), with λ = κ·Aᵢ·|b′(d)| the barrier's normal force
    /// there and v_t the tangential part of the node's velocity relative to the obstacle's
    /// material point under it (its mean velocity over the step: (c_o(`time` + `dt`) −
    /// c_o(`time`))/`dt` plus the spin's exact turn [`Obstacle::surface_turn`] over `dt`, divided
    /// by `dt`), the update
    ///
    /// m·(v_t⁺ − v_t) = −dt·μ·λ·f₁(|v_t⁺|)·v̂_t
    ///
    /// (f₁ smoothed below ε_v, [`slip_velocity`](Self::slip_velocity); its root
    /// `speed_after_friction`) keeps the direction and only shrinks the speed, at most to zero:
    /// it never reverses it and never adds energy, whatever dt, so the explicit method's
    /// stable step is unchanged. Sliding faster than ε_v feels exactly μ·λ; a node held below
    /// μ·λ creeps at the speed where μ·λ·f₁ balances its load.
    ///
    /// `velocity` (length/time) and `inverse_mass` (1/mass) are full length (3 per node);
    /// `inverse_mass` is 0 on fixed DOFs, which the update leaves alone (on a node with a fixed
    /// DOF the change −(1 − s⁺/s)·v_t is applied to its free DOFs only, still dissipative: the
    /// fixed components of v are zero). Errors: lengths, a node inside an obstacle, `dt` not
    /// finite and > 0.
    ///
    /// Returns the friction force the body exerted on each obstacle over the step (force
    /// units, the obstacles' order): −Σᵢ mᵢ·Δvᵢ/dt over its nodes, the reaction of the
    /// impulses.
    pub fn apply_friction_impulses(
        &self,
        u: &[f64],
        velocity: &mut [f64],
        inverse_mass: &[f64],
        time: f64,
        dt: f64,
    ) -> Result<Vec<Vector3<f64>>> {
        self.check_full(u)?;
        Error::check_len("friction velocity", u.len(), velocity.len())?;
        Error::check_len("friction inverse mass", u.len(), inverse_mass.len())?;
        if !(dt.is_finite() && dt > 0.0) {
            return Err(Error::invalid_parameter(
                "friction time step",
                dt,
                "must be finite and > 0",
            ));
        }
        let obstacle_velocity: Vec<Vector3<f64>> = self
            .offsets_at(time + dt)
            .iter()
            .zip(self.offsets_at(time))
            .map(|(end, start)| (end - start) / dt)
            .collect();
        let (d_hat, epsilon) = (self.parameters.activation_distance, self.slip_velocity);
        let mut forces = vec![Vector3::zeros(); self.obstacles.len()];
        self.for_each_active(u, |n, o, obstacle, x, d, (area, kappa)| {
            let mu = obstacle.friction();
            let dofs = 3 * n..3 * n + 3;
            let inverse = inverse_mass[dofs.clone()]
                .iter()
                .copied()
                .fold(0.0, f64::max);
            if mu <= 0.0 || inverse <= 0.0 {
                return;
            }
            let normal = obstacle.gradient(x);
            let relative = Vector3::from_column_slice(&velocity[dofs.clone()])
                - obstacle_velocity[o]
                - obstacle.surface_turn(x, dt) / dt;
            let tangential = relative - normal * normal.dot(&relative);
            let speed = tangential.norm();
            if speed == 0.0 {
                return;
            }
            let limit = mu * kappa * area * barrier::derivative(d, d_hat).abs();
            let after = speed_after_friction(speed, dt * limit * inverse, epsilon);
            let change = (after / speed - 1.0) * tangential;
            for a in 0..3 {
                if inverse_mass[3 * n + a] > 0.0 {
                    velocity[3 * n + a] += change[a];
                    forces[o][a] -= change[a] / (inverse_mass[3 * n + a] * dt);
                }
            }
        })?;
        Ok(forces)
    }

    fn lagged_position(&self, p: &LaggedPoint, u: &[f64]) -> Result<Vector3<f64>> {
        let k = self
            .nodes
            .binary_search(&p.node)
            .map_err(|_| Error::invalid_parameter("friction lag", p.node, "not a contact node"))?;
        Ok(self.position(k, u))
    }

    /// The largest slip |P·(x − x⁰)| of the lagged contacts at full displacement `u` (length; 0
    /// without any).
    pub(crate) fn largest_slip(&self, lag: &FrictionLag, u: &[f64]) -> Result<f64> {
        self.check_full(u)?;
        let mut largest: f64 = 0.0;
        for p in &lag.points {
            largest = largest.max(p.slip(&self.lagged_position(p, u)?).norm());
        }
        Ok(largest)
    }

    /// The friction potential Σ μ·λ·f₀(|P·(x − x⁰)|) (energy units) at full displacement `u`.
    pub fn friction_energy(&self, lag: &FrictionLag, u: &[f64]) -> Result<f64> {
        self.check_full(u)?;
        let mut total = 0.0;
        for p in &lag.points {
            let y = p.slip(&self.lagged_position(p, u)?).norm();
            total += p.limit * f0(y, lag.epsilon);
        }
        Ok(total)
    }

    /// Adds the friction force −μ·λ·(f₁(y)/y)·P·(x − x⁰) (force units) into `force`.
    pub fn add_friction_force(
        &self,
        lag: &FrictionLag,
        u: &[f64],
        force: &mut [f64],
    ) -> Result<()> {
        self.check_full(u)?;
        Error::check_len("friction force", u.len(), force.len())?;
        for p in &lag.points {
            let slip = p.slip(&self.lagged_position(p, u)?);
            let f = -p.limit * f1_over_y(slip.norm(), lag.epsilon) * slip;
            for a in 0..3 {
                force[3 * p.node + a] += f[a];
            }
        }
        Ok(())
    }

    /// Adds the friction Hessian μ·λ·(f₁′(y)·ûûᵀ + (f₁(y)/y)·(P − ûûᵀ)) (PSD as it stands,
    /// f₁′ ≥ 0; see [`super::friction`]) into `matrix`
    /// (full assembly pattern).
    pub fn add_friction_tangent(
        &self,
        lag: &FrictionLag,
        u: &[f64],
        matrix: &mut CscMatrix,
    ) -> Result<()> {
        add_node_blocks(matrix, self.friction_blocks(lag, u)?)
    }

    /// The friction Hessian's node blocks at full displacement `u` (see
    /// [`add_friction_tangent`](Self::add_friction_tangent)): `(node, block)` pairs
    /// (force/length), one per lagged point.
    pub(crate) fn friction_blocks(
        &self,
        lag: &FrictionLag,
        u: &[f64],
    ) -> Result<Vec<(usize, Matrix3<f64>)>> {
        self.check_full(u)?;
        let mut blocks = Vec::with_capacity(lag.points.len());
        for p in &lag.points {
            let slip = p.slip(&self.lagged_position(p, u)?);
            blocks.push((p.node, p.stiffness(&slip, lag.epsilon)));
        }
        Ok(blocks)
    }

    /// Adds the contact Hessian ∂²E_c/∂u² at full displacement `u` into `matrix`, a matrix on
    /// the full assembly pattern (every node's 3×3 diagonal block stored). Per node and
    /// obstacle: κ·Aᵢ·(b″·∇d∇dᵀ + b′·∇²d); with `project` the second term — negative
    /// semi-definite, as b′ ≤ 0 and ∇²d ⪰ 0 — is dropped, leaving the PSD part.
    pub fn add_tangent(&self, u: &[f64], project: bool, matrix: &mut CscMatrix) -> Result<()> {
        self.check_full(u)?;
        Error::check_len("contact tangent", u.len(), matrix.dim())?;
        add_node_blocks(matrix, self.barrier_blocks(u, project)?)
    }

    /// The barrier Hessian's node blocks at full displacement `u` (see
    /// [`add_tangent`](Self::add_tangent)): `(node, block)` pairs (force/length), one per node
    /// and obstacle within d̂.
    pub(crate) fn barrier_blocks(
        &self,
        u: &[f64],
        project: bool,
    ) -> Result<Vec<(usize, Matrix3<f64>)>> {
        let d_hat = self.parameters.activation_distance;
        let mut blocks: Vec<(usize, Matrix3<f64>)> = Vec::new();
        self.for_each_active(u, |n, _, obstacle, x, d, (area, kappa)| {
            let scale = kappa * area;
            let g = obstacle.gradient(x);
            let mut block = barrier::second_derivative(d, d_hat) * g * g.transpose();
            if !project {
                block += barrier::derivative(d, d_hat) * obstacle.hessian(x);
            }
            blocks.push((n, scale * block));
        })?;
        Ok(blocks)
    }

    /// Continuous collision detection: the largest fraction t ∈ (0, 1] such that every node
    /// stays outside every obstacle along u + s·du for s ∈ [0, t), from `u` with every gap > 0
    /// (1 when no node reaches an obstacle within the step). Exact for these shapes (see
    /// [`Obstacle::time_of_impact`]); a line search scales it by 0.8 as IPC does, so the gap
    /// keeps at least a fifth of its size along a straight approach.
    ///
    /// A non-finite entry of `du` is [`Error::InvalidParameter`] naming its DOF: no fraction of
    /// such a step is known to be safe (a NaN would otherwise meet no obstacle and pass as 1).
    pub fn max_step(&self, u: &[f64], du: &[f64]) -> Result<f64> {
        self.check_full(u)?;
        Error::check_len("contact step", u.len(), du.len())?;
        if let Some(dof) = du.iter().position(|v| !v.is_finite()) {
            return Err(Error::invalid_parameter(
                format!("contact step du[{dof}]"),
                du[dof],
                "must be finite to bound the step by the first time of impact",
            ));
        }
        let offsets = self.offsets();
        let mut t: f64 = 1.0;
        for k in 0..self.nodes.len() {
            let n = self.nodes[k];
            let x = self.position(k, u);
            let dx = Vector3::new(du[3 * n], du[3 * n + 1], du[3 * n + 2]);
            for (obstacle, offset) in self.obstacles.iter().zip(&offsets) {
                if let Some(hit) = obstacle.time_of_impact(&(x - offset), &dx) {
                    t = t.min(hit);
                }
            }
        }
        Ok(t)
    }

    /// Calls `visit(node, obstacle index, obstacle, position, gap, (area, κ))` for each node
    /// within d̂ of an obstacle (κ the node's barrier stiffness in force), the position
    /// relative to the obstacle's current offset (x − c: where the obstacle's own distance,
    /// gradient and Hessian are evaluated);
    /// [`Error::InvalidParameter`] (via [`check_state`](Self::check_state)) if a node is on or
    /// inside one.
    fn for_each_active(
        &self,
        u: &[f64],
        mut visit: impl FnMut(usize, usize, &Obstacle, &Vector3<f64>, f64, (f64, f64)),
    ) -> Result<()> {
        self.check_full(u)?;
        let d_hat = self.parameters.activation_distance;
        // Nothing is visited after the first node found inside: the call is an error then.
        let mut inside = false;
        self.for_each_gap(u, |k, o, x, d| {
            if d.is_nan() || d <= 0.0 {
                inside = true;
            } else if !inside && d < d_hat {
                let weights = (self.areas[k], self.kappa_of(k));
                visit(self.nodes[k], o, &self.obstacles[o], x, d, weights);
            }
        });
        match inside {
            true => self.check_state(u),
            false => Ok(()),
        }
    }

    /// Calls `visit(k, o, x, d)` for each contact node `k` (an index into
    /// [`nodes`](Self::nodes)) and each obstacle `o`, node by node: `x` the node's position at
    /// full displacement `u` relative to the obstacle's current offset (x − c, where the
    /// obstacle's own distance, gradient and Hessian are evaluated), `d` its signed distance
    /// (length; NaN for a NaN position). The one loop under every gap-reading measure; `u`
    /// checked by the caller.
    fn for_each_gap(&self, u: &[f64], mut visit: impl FnMut(usize, usize, &Vector3<f64>, f64)) {
        let offsets = self.offsets();
        for k in 0..self.nodes.len() {
            let x = self.position(k, u);
            for (o, obstacle) in self.obstacles.iter().enumerate() {
                let relative = x - offsets[o];
                visit(k, o, &relative, obstacle.distance(&relative));
            }
        }
    }
}

/// Adds 3×3 blocks on the diagonal node blocks of `matrix` (a matrix on the full assembly
/// pattern): `(node, block)` pairs.
fn add_node_blocks(matrix: &mut CscMatrix, blocks: Vec<(usize, Matrix3<f64>)>) -> Result<()> {
    let col_ptr = matrix.col_ptr().to_vec();
    for (n, block) in blocks {
        for c in 0..3 {
            let col = 3 * n + c;
            let range = col_ptr[col]..col_ptr[col + 1];
            for r in 0..3 {
                let row = 3 * n + r;
                let k = matrix.row_idx()[range.clone()]
                    .binary_search(&row)
                    .map_err(|_| {
                        Error::invalid_parameter(
                            "contact tangent",
                            format!("no entry ({row}, {col})"),
                            "must be on the full assembly pattern (node blocks stored)",
                        )
                    })?;
                matrix.values_mut()[range.start + k] += block[(r, c)];
            }
        }
    }
    Ok(())
}

/// The triangles of `mesh`'s boundary that carry its contact points, outward oriented: the
/// boundary faces themselves on 4-node tets; on cells with edge nodes (10-node tets) each face
/// (n₀, n₁, n₂) with its mid-edge nodes m₀₁, m₁₂, m₂₀ as the four sub-triangles (n₀, m₀₁, m₂₀),
/// (m₀₁, n₁, m₁₂), (m₂₀, m₁₂, n₂), (m₀₁, m₁₂, m₂₀) of its straight-sided shape.
///
/// Errors: those of [`TetMesh::boundary_faces`].
pub fn contact_faces<C: CellType>(mesh: &TetMesh<C>) -> Result<Vec<BoundaryFace>> {
    let faces = mesh.boundary_faces()?;
    let mut out = Vec::with_capacity(faces.len());
    for face in faces {
        let cell = &mesh.tets()[face.tet];
        let corners = cell.corners();
        let local = face
            .nodes
            .map(|n| corners.iter().position(|&c| c == n).unwrap_or(0));
        let mid = |a: usize, b: usize| C::edge_node(cell, local[a], local[b]);
        let [n0, n1, n2] = face.nodes;
        match (mid(0, 1), mid(1, 2), mid(2, 0)) {
            (Some(m01), Some(m12), Some(m20)) => {
                for nodes in [
                    [n0, m01, m20],
                    [m01, n1, m12],
                    [m20, m12, n2],
                    [m01, m12, m20],
                ] {
                    out.push(BoundaryFace {
                        tet: face.tet,
                        nodes,
                    });
                }
            }
            _ => out.push(face),
        }
    }
    Ok(out)
}

/// What the velocity-level contact of explicit steps reads per node ([`super::velocity`]).
impl Contact {
    /// The rest position (length) and the lumped area share Aᵢ (length²) of the `k`-th contact
    /// node, in the order of [`nodes`](Self::nodes).
    pub(crate) fn rest_and_area(&self, k: usize) -> (Vector3<f64>, f64) {
        (self.rest[k], self.areas[k])
    }
}
