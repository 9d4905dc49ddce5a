//! The start check of several bodies (or one folded body): no two surface triangles may meet
//! at the start, since the barrier is infinite there and no step can separate them.

use nalgebra::Vector3;

use super::boundary::Surface;
use super::intersect::surface_intersections;
use crate::base::error::{Error, Result};

/// [`Error::InvalidParameter`] naming the bodies and one pair of intersecting (or touching)
/// triangles — their indices and mesh nodes — if any two triangles of `surface` meet at
/// `positions` (indexed by node id, m; the exact test of [`surface_intersections`]).
/// `body_of_node[n]` is the body of mesh node n; a pair within one body is reported as that
/// body intersecting itself.
///
/// Errors also: `body_of_node` or `positions` not covering the surface, positions not finite.
pub fn overlapping_bodies(
    surface: &Surface,
    positions: &[Vector3<f64>],
    body_of_node: &[usize],
) -> Result<()> {
    let needed = surface.vertices().last().map_or(0, |&n| n + 1);
    if body_of_node.len() < needed {
        return Err(Error::DimensionMismatch {
            what: "body of each node (indexed by node id)".to_string(),
            expected: needed,
            found: body_of_node.len(),
        });
    }
    let Some(&(a, b)) = surface_intersections(surface, positions)?.first() else {
        return Ok(());
    };
    let (ta, tb) = (surface.triangles()[a], surface.triangles()[b]);
    let (ba, bb) = (body_of_node[ta[0]], body_of_node[tb[0]]);
    let name = match ba == bb {
        true => format!("body {ba} (intersecting itself)"),
        false => format!("bodies {} and {}", ba.min(bb), ba.max(bb)),
    };
    Err(Error::invalid_parameter(
        name,
        format!(
            "triangle {a} (nodes {ta:?}) of body {ba} meets triangle {b} (nodes {tb:?}) of body {bb}"
        ),
        "bodies must start apart: no surface triangles crossing or touching",
    ))
}
