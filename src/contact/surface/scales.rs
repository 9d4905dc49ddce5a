//! The surface barrier's default scales, one rule for every front end (scenes, Python): the
//! activation distance d̂ a tenth of the shortest surface edge at rest (so the barrier never
//! reaches across an element; [`Warning::SurfaceBarrierReach`](crate::base::warning::Warning)
//! flags a d̂ above that edge), and the stiffness κ = E·h̄ (J/m²), E the stiffest material's
//! Young's modulus (Pa) and h̄ the mean surface edge at rest (m): a pair pushed to a tenth of
//! d̂ then resists with a force of the order of E·h̄² · (d̂ ln-barrier slope)/d̂, an element's
//! own stiffness times the gap, which keeps the Newton steps of a touching body well scaled.

use super::boundary::Surface;
use super::potential::SurfaceBarrier;
use crate::base::error::Result;

/// d̂'s default as a fraction of the shortest surface edge at rest.
pub const DEFAULT_DISTANCE_PER_SHORTEST_EDGE: f64 = 0.1;

impl SurfaceBarrier {
    /// The barrier of `surface` with `distance` (d̂, m) and `stiffness` (κ, J/m²) where given,
    /// each default from the surface at rest otherwise: d̂ = 0.1·(shortest edge) and
    /// κ = `youngs_modulus`·(mean edge), `youngs_modulus` the stiffest body's E (Pa).
    /// Errors: a given or derived value that is not finite and > 0
    /// ([`Error::InvalidParameter`](crate::base::error::Error) naming it, as
    /// [`SurfaceBarrier::new`]).
    pub fn scaled_to(
        surface: &Surface,
        youngs_modulus: f64,
        distance: Option<f64>,
        stiffness: Option<f64>,
    ) -> Result<SurfaceBarrier> {
        let edges = surface.edges().len();
        let mean = (0..edges)
            .filter_map(|e| surface.rest_edge_length2(e))
            .map(f64::sqrt)
            .sum::<f64>()
            / edges.max(1) as f64;
        let distance =
            distance.unwrap_or(DEFAULT_DISTANCE_PER_SHORTEST_EDGE * surface.shortest_rest_edge());
        SurfaceBarrier::new(distance, stiffness.unwrap_or(youngs_modulus * mean))
    }
}
