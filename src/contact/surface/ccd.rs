//! Continuous collision detection of a surface moving along a step: additive CCD (Li,
//! Kaufman, Jiang, "Codimensional Incremental Potential Contact", 2021, Algorithm 1).
//!
//! For a pair moving from x by t·Δx, t ∈ [0, 1], with the mean of its four displacements taken
//! off (a common translation does not change a distance), the distance can shrink no faster
//! than l_p = max|Δx_a-side| + max|Δx_b-side| per unit t. ACCD advances t by steps of
//! 0.9·d(t)/l_p (the first by (1 − s)·d₀/l_p), each of which provably keeps the pair apart, and
//! stops before the step after which the distance would fall below s·d₀. The returned t is
//! therefore conservative — no contact on [0, t] and a distance ≥ s·d₀ at t (up to the
//! round-off of a distance) — and, since every step closes most of the remaining gap, close
//! to the first time of impact: about (1 − s) times it on a head-on approach.

use nalgebra::Vector3;

use super::boundary::Surface;
use super::bvh::candidates;
use super::distance::{edge_edge_squared_distance, point_triangle_squared_distance};
use super::potential::{Pair, pairs_of};
use crate::base::error::{Error, Result};

/// s: the fraction of its start distance every pair keeps at the returned step (IPC's line
/// search keeps a fifth of the gap to rigid obstacles, [`crate::contact::STEP_FRACTION`] 0.8).
pub const SEPARATION_FRACTION: f64 = 0.2;

/// ACCD's steps per pair before it returns the (conservative) fraction reached: grazing
/// motions take many small steps, and any stop is safe.
const MAX_ITERATIONS: usize = 10_000;

/// The largest step fraction t ∈ [0, `limit`] that ACCD certifies for `pair` (its four points
/// `x`, moving by t·`dx`; see the module docs), keeping at least `separation` times the start
/// distance. `limit` when the pair cannot close the gap within it.
///
/// Errors ([`Error::InvalidParameter`]): a position or motion not finite; `separation` not in
/// (0, 1) or `limit` not in (0, 1]; a start distance of zero (no fraction of any motion is
/// known to be safe).
pub fn pair_step(
    pair: Pair,
    x: &[Vector3<f64>; 4],
    dx: &[Vector3<f64>; 4],
    separation: f64,
    limit: f64,
) -> Result<f64> {
    if let Some(v) = x
        .iter()
        .chain(dx)
        .find(|v| !v.iter().all(|c| c.is_finite()))
    {
        return Err(Error::invalid_parameter(
            format!("continuous collision detection of {pair:?}: a position or motion"),
            format!("{:?}", v.as_slice()),
            "must be finite",
        ));
    }
    if !(separation > 0.0 && separation < 1.0 && limit > 0.0 && limit <= 1.0) {
        return Err(Error::invalid_parameter(
            "continuous collision detection (separation, limit)",
            format!("({separation}, {limit})"),
            "separation in (0, 1) and limit in (0, 1]",
        ));
    }
    let mean = (dx[0] + dx[1] + dx[2] + dx[3]) / 4.0;
    let p = dx.map(|d| d - mean);
    let l_p = match pair {
        Pair::PointTriangle { .. } => p[0].norm() + p[1].norm().max(p[2].norm()).max(p[3].norm()),
        Pair::EdgeEdge { .. } => p[0].norm().max(p[1].norm()) + p[2].norm().max(p[3].norm()),
    };
    // A pair whose boxes are apart by more than twice what the step can close within the
    // limit (d ≥ gap > 2·limit·l_p / (1 − s)) keeps at least (1 + s)/2 of its distance there,
    // far above s·d: the limit, as the iteration below would find, without a distance.
    if limit * l_p < 0.5 * (1.0 - separation) * pair.box_gap(x) {
        return Ok(limit);
    }
    let distance = |y: &[Vector3<f64>; 4]| {
        match pair {
            Pair::PointTriangle { .. } => {
                point_triangle_squared_distance(&y[0], &y[1], &y[2], &y[3])
            }
            Pair::EdgeEdge { .. } => edge_edge_squared_distance(&y[0], &y[1], &y[2], &y[3]),
        }
        .sqrt()
    };
    let d0 = distance(x);
    if d0 <= 0.0 || !d0.is_finite() {
        return Err(Error::invalid_parameter(
            format!("continuous collision detection of {pair:?}"),
            d0,
            "the start distance must be > 0 (the pair touches or crosses at the start)",
        ));
    }
    if l_p <= 0.0 {
        return Ok(limit);
    }
    let g = separation * d0;
    let mut y = *x;
    let mut t = 0.0;
    let mut step = (1.0 - separation) * d0 / l_p;
    for _ in 0..MAX_ITERATIONS {
        for k in 0..4 {
            y[k] += step * p[k];
        }
        let d = distance(&y);
        if t > 0.0 && d < g {
            return Ok(t);
        }
        if t + step > limit {
            // Safe up to t + step; the limit keeps the separation unless the gap is closing
            // fast there, in which case the last certified checkpoint t is returned.
            let at_limit = std::array::from_fn(|k| x[k] + limit * p[k]);
            return Ok(if distance(&at_limit) >= g { limit } else { t });
        }
        t += step;
        step = 0.9 * d / l_p;
    }
    Ok(t)
}

/// The largest step fraction α ∈ (0, 1] such that `surface`, moving from `positions` by
/// α·`displacement` (both indexed by node id, m), meets no contact on the way and every pair
/// whose swept boxes meet keeps at least `separation` ([`SEPARATION_FRACTION`] is the usual
/// choice) times its start distance at α: the minimum of [`pair_step`] over the broad phase's
/// swept candidates ([`candidates`]).
///
/// Errors: positions or displacement not covering the surface or not finite; `separation`
/// outside (0, 1); a candidate pair at distance zero at the start.
pub fn max_step(
    surface: &Surface,
    positions: &[Vector3<f64>],
    displacement: &[Vector3<f64>],
    separation: f64,
) -> Result<f64> {
    if !(separation > 0.0 && separation < 1.0) {
        return Err(Error::invalid_parameter(
            "continuous collision detection separation",
            separation,
            "must be in (0, 1): the fraction of its start distance a pair keeps",
        ));
    }
    let found = candidates(surface, positions, Some(displacement), 0.0)?;
    let pairs = pairs_of(&found);
    let mut alpha: f64 = 1.0;
    for pair in pairs {
        let nodes = pair.nodes(surface);
        let x = nodes.map(|n| positions[n]);
        let dx = nodes.map(|n| displacement[n]);
        alpha = alpha.min(pair_step(pair, &x, &dx, separation, alpha)?);
    }
    Ok(alpha)
}
