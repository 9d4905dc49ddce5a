//! The audit that no accepted iterate intersects (issue 36): an opt-in check, off by default,
//! that runs the exact triangle–triangle test ([`surface_intersections`], on exact orientation
//! predicates and sharing no code with the barrier's distances) over the whole surface at every
//! Newton iterate a solver accepts, and counts the checks and the intersecting pairs found.
//!
//! The barrier's guarantee rests on its CCD step bound and on the line search accepting only
//! finite potentials; the audit is the independent witness of it. It costs one broad phase and
//! the exact tests per accepted iterate (of the order of the barrier's own evaluation), which
//! is why runs leave it off and tests switch it on
//! ([`SurfaceContact::set_intersection_audit`](super::SurfaceContact::set_intersection_audit)).
//!
//! [`IntersectionAudit`] is a handle: its clones share one record, so a caller keeps one and
//! reads the counts after a solve that owns the contact.

use std::sync::{Arc, Mutex};

use nalgebra::Vector3;

use super::boundary::Surface;
use super::intersect::surface_intersections;

/// What the audit has seen: accepted iterates checked, intersecting triangle pairs found over
/// all of them, and the first such pair (surface triangle indices, with the check's number
/// counted from 1); beside them, the smallest distance the barrier measured at those iterates.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AuditCounts {
    /// Accepted iterates whose whole surface was tested.
    pub checks: usize,
    /// Intersecting pairs of surface triangles, summed over the checks.
    pub hits: usize,
    /// The first intersecting pair (a, b), a < b, and the check it was found at.
    pub first_hit: Option<(usize, usize, usize)>,
    /// Checks that could not run (positions not covering the surface or not finite): each is
    /// a check that proves nothing, so a test asserts it stays 0.
    pub failed: usize,
    /// The smallest distance (m) between two non-adjacent surface primitives over the checked
    /// iterates, as the barrier measures it
    /// ([`SurfaceContact::smallest_distance`](super::SurfaceContact::smallest_distance));
    /// +∞ while no pair came within d̂. Whether self-contact was active at all.
    pub smallest_distance: f64,
}

impl Default for AuditCounts {
    fn default() -> Self {
        AuditCounts {
            checks: 0,
            hits: 0,
            first_hit: None,
            failed: 0,
            smallest_distance: f64::INFINITY,
        }
    }
}

/// A shared record of intersection checks (see the module docs). `Default` is a new, empty
/// record.
#[derive(Debug, Clone, Default)]
pub struct IntersectionAudit {
    record: Arc<Mutex<AuditCounts>>,
}

impl IntersectionAudit {
    /// A new record with nothing checked.
    pub fn new() -> Self {
        Self::default()
    }

    /// The counts so far.
    pub fn counts(&self) -> AuditCounts {
        *self.lock()
    }

    /// Tests every pair of triangles of `surface` at `positions` (indexed by node id, m) for
    /// intersection, exactly, and adds the result to the record. A failed test (positions that
    /// do not cover the surface or are not finite) is counted in `failed`, not raised: the audit
    /// observes a solve and never stops it.
    pub fn check(&self, surface: &Surface, positions: &[Vector3<f64>]) {
        let found = surface_intersections(surface, positions);
        let mut record = self.lock();
        match found {
            Ok(pairs) => {
                record.checks += 1;
                record.hits += pairs.len();
                if record.first_hit.is_none() {
                    let at = record.checks;
                    record.first_hit = pairs.first().map(|&(a, b)| (a, b, at));
                }
            }
            Err(_) => record.failed += 1,
        }
    }

    /// Takes a distance (m) into [`AuditCounts::smallest_distance`].
    pub fn note_distance(&self, distance: f64) {
        let mut record = self.lock();
        record.smallest_distance = record.smallest_distance.min(distance);
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, AuditCounts> {
        // A poisoned lock only means a panic elsewhere while holding plain counts: keep them.
        self.record.lock().unwrap_or_else(|e| e.into_inner())
    }
}
