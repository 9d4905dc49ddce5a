//! Body–body and self-contact geometry on a boundary surface (issue 36): the surface of a tet
//! mesh ([`boundary`]), point–triangle and edge–edge distances with their derivatives
//! ([`distance`]), the barrier potential over every pair within reach ([`potential`]), a
//! bounding-volume hierarchy for the broad phase ([`bvh`]), additive continuous collision
//! detection ([`ccd`]), and an exact triangle–triangle intersection test that shares no code
//! with the barrier ([`intersect`], on the exact orientation predicates of [`predicates`]), and
//! the start check that bodies do not overlap ([`overlap`]), the barrier's default scales
//! ([`scales`]); lagged smoothed Coulomb friction between surface pairs ([`friction`]); and all
//! of it as a term of a nonlinear force over a DOF vector ([`term`]).
//!
//! Positions are arrays indexed by mesh node id (length units, m); pairs that share a vertex
//! are adjacent by topology and never contact pairs.
//!
//! How a time step uses it (the IPC recipe): the incremental potential gains B(x)
//! ([`SurfaceBarrier::energy`]), its gradient ([`SurfaceBarrier::add_gradient`]) and its
//! per-pair PSD-projected Hessian ([`SurfaceBarrier::hessian_triplets`]); the line search
//! starts from the step fraction [`max_step`] certifies along the Newton direction, so that no
//! iterate passes through another part of the surface; [`surface_intersections`] checks the
//! accepted iterates independently (when [`audit`] is on), and [`overlapping_bodies`] the start.
//!
//! Units: B = κ·Σ m·b(d, d̂) with b in m², so κ is in J/m² (N/m). Unlike the rigid-obstacle
//! barrier ([`crate::contact::Contact`], κ·Aᵢ·b with κ in Pa/m), pairs carry no area weight, as
//! in IPC 2020; a point near a triangle edge is counted once per triangle of that edge and an
//! edge–edge pair next to it may count the same contact again, which changes the barrier's
//! strength there, not its guarantee.

pub mod audit;
pub mod boundary;
pub mod bvh;
pub mod ccd;
pub mod distance;
pub mod friction;
pub mod intersect;
pub mod overlap;
pub mod potential;
pub mod predicates;
pub mod scales;
pub mod term;

pub use audit::{AuditCounts, IntersectionAudit};
pub use boundary::Surface;
pub use bvh::{Aabb, Bvh, Candidates, candidates};
pub use ccd::{SEPARATION_FRACTION, max_step};
pub use distance::DistanceType;
pub use friction::SurfaceFrictionLag;
pub use intersect::{surface_intersections, triangles_intersect};
pub use overlap::overlapping_bodies;
pub use potential::{ActivePair, Pair, SurfaceBarrier};
pub use term::{SurfaceContact, TangentFill};
