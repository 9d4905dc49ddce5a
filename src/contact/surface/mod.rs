//! Body–body and self-contact geometry on a boundary surface (issue 36): the surface of a tet
//! mesh ([`boundary`]), point–triangle and edge–edge distances with their derivatives
//! ([`distance`]), the barrier potential over every pair within reach ([`potential`]), a
//! bounding-volume hierarchy for the broad phase ([`bvh`]), additive continuous collision
//! detection ([`ccd`]), and an exact triangle–triangle intersection test that shares no code
//! with the barrier ([`intersect`], on the exact orientation predicates of [`predicates`]).
//!
//! Positions are arrays indexed by mesh node id (length units, m); pairs that share a vertex
//! are adjacent by topology and never contact pairs.

pub mod boundary;
pub mod bvh;
pub mod ccd;
pub mod distance;
pub mod intersect;
pub mod potential;
pub mod predicates;

pub use boundary::Surface;
pub use bvh::{Aabb, Bvh, Candidates, candidates};
pub use ccd::{SEPARATION_FRACTION, max_step};
pub use distance::DistanceType;
pub use intersect::{surface_intersections, triangles_intersect};
pub use potential::{ActivePair, Pair, SurfaceBarrier};
