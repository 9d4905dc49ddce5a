//! Contact of the body with rigid obstacles (the lecture's collision forces in f_ext), by the
//! barrier method of IPC (Li et al., "Incremental Potential Contact", SIGGRAPH 2020).
//!
//! Why a barrier: the contact energy E_c = κ·Σᵢ Aᵢ·b(dᵢ) grows without bound as a gap closes,
//! so every state of finite energy is free of penetration, and a Newton line search that (1)
//! never steps past the first time of impact (continuous collision detection,
//! [`Contact::max_step`], times 0.8 where an obstacle is on the way: [`first_step_fraction`]) and (2) accepts only a decrease of the incremental
//! potential keeps every iterate outside every obstacle — at any time step, with no penalty
//! stiffness to tune against the step or the mesh, and no active set to update. Its force and
//! Hessian are smooth and enter the Newton tangent, so Newton keeps its convergence.
//!
//! One idea per file: [`barrier`] (b, b′, b″), [`carry`] (the first iterate of a step whose
//! obstacles move), [`friction`] (IPC's lagged smoothed Coulomb
//! friction), [`impact`] (the impact-aware barrier stiffness, an option), [`obstacle`] (half-space, sphere, box: signed distance, its derivatives, time of
//! impact), [`overlap`] (the start check of the boundary surface against the obstacles),
//! [`parameters`] (d̂ and κ and their default rule), [`set`] (the contact of a mesh's
//! boundary nodes with the obstacles), [`staging`] (moving obstacles in collision-free stages, the fall-back),
//! [`surface`] (body–body and self-contact geometry on a boundary surface: the surface,
//! point–triangle and edge–edge distances, their barrier, the broad phase, additive CCD and an
//! exact intersection test; not yet wired into a solve).
//!
//! Moving obstacles ([`ObstacleMotion`]: a prescribed translation c(t), constant velocity or a
//! displacement times an amplitude) are placed by [`Contact::set_time`]. An implicit step takes
//! them to their placement at t_{n+1}; since that placement can overlap the body's state at t_n,
//! the step starts Newton from the body carried with them ([`carry`]: the nodes they would reach
//! move with them, the rest follow a smooth fraction of the move, the joint path checked by
//! continuous collision detection), so one Newton solve per step keeps every iterate outside.
//! Where no such start exists (a node pinched between two obstacles, or held by a support in an
//! obstacle's path) or Newton does not converge from it, the step falls back to stages, each the
//! largest collision-free fraction (×0.8) of the remaining motion for the body's converged state
//! of the stage before ([`Contact::motion_step_limit`], [`Contact::advance_stage`]).
//!
//! Friction is measured relative to the obstacle (its slip is the body's tangential motion minus
//! the obstacle's). A static solve moves them too, over its pseudo-time t ∈ [0, 1] (load step k
//! of n at t = k/n, see [`crate::analysis::nonlinear::solve_nonlinear_static_with_contact`]), carried (or
//! staged) the same way within each load step.
//!
//! Friction acts in every analysis: as a lagged potential over a time step in the implicit steps
//! and over a load step in the static solve ([`friction`], [`Contact::friction_lag_from`]), and in
//! explicit steps from the normal impulse of the velocity-level contact ([`velocity`],
//! [`Contact::apply_contact_impulses`]): there no node comes nearer an obstacle than the gap it
//! started the step with or d̂, so explicit contact needs no barrier stiffness in its stable step.
//!
//! Spinning obstacles ([`Obstacle::with_spin`], [`Spin`]): a constant angular velocity ω about
//! an axis through a point p that moves with the obstacle's translation, so that its material
//! point at x moves at v(x, t) = ċ(t) + ω × (x − (p + c(t))). Only the spins that leave the shape
//! in place are represented — a half-space about an axis along its normal (a turntable), a
//! sphere about an axis through its centre (a roller) —, so distance, gradient, Hessian, time of
//! impact, the carried start and the stages are those of the translation alone, and the spin
//! enters friction only: the lagged slip of a step of duration Δt is measured from the start
//! point turned with the surface by the exact rotation R(ω·Δt) ([`Obstacle::surface_turn`],
//! [`Contact::friction_lag_toward`]; a static load step turns it by |ω| times its pseudo-time),
//! and the explicit step's friction takes the surface point's mean velocity over the step. A
//! spin that would move the shape (a box, a tilted half-space axis, an axis off a sphere's
//! centre) is refused: rotating shapes would need the distance of a turned shape and continuous
//! collision detection along its arc.

pub mod barrier;
pub mod carry;
pub mod friction;
pub mod impact;
pub mod obstacle;
pub mod overlap;
pub mod parameters;
pub mod set;
pub mod staging;
pub mod surface;
pub mod velocity;

pub use friction::FrictionLag;
pub use obstacle::{MAX_FRICTION, Obstacle, ObstacleMotion, SPIN_TOLERANCE, Shape, Spin};
pub use parameters::ContactParameters;
pub use set::{
    BarrierGaps, Contact, FORCE_ERROR_PER_GAP_ERROR, GAP_ERROR_WARNING, GAP_TOLERANCE, NodesInside,
    contact_faces,
};
pub use staging::{MAX_MOTION_STAGES, MotionStage};

/// The fraction of the collision-free step a line search starts from (IPC's 0.8).
pub const STEP_FRACTION: f64 = 0.8;

/// The step fraction a contact line search starts from, given the first time of impact
/// `limit` ∈ (0, 1] along the Newton step ([`Contact::max_step`]: 1 when the whole step meets no
/// obstacle): [`STEP_FRACTION`]·`limit` when an obstacle is met on the way, so the gap keeps a
/// fifth of its size, and the whole step when none is. Scaling an unobstructed step by 0.8 too
/// (as before) made every contact Newton converge linearly at the rate 0.2 — 11 to 12
/// iterations to 1e-8 in every step, where the full step converges quadratically; the end of an
/// unobstructed step is outside every obstacle, and the line search's decrease test guards the
/// barrier's growth there.
pub fn first_step_fraction(limit: f64) -> f64 {
    match limit >= 1.0 {
        true => 1.0,
        false => STEP_FRACTION * limit,
    }
}
