//! The exact triangle–triangle intersection test — the check that no iterate ever intersects,
//! independent of the barrier's distances: it uses the exact orientation predicates of
//! [`super::predicates`] only.
//!
//! Two closed triangles meet if and only if an edge of one meets the other: where they meet,
//! in a segment on the line where their planes cross (or a convex polygon when coplanar), an
//! end of that set lies on the boundary of one triangle and inside the other. So six exact
//! segment–triangle tests decide it. Triangles that only touch (at a point or along a segment)
//! count as intersecting: the sets are closed, and two non-adjacent surface triangles at
//! distance zero are what the barrier must never let happen. Triangles that share a vertex or
//! an edge are checked for meeting anywhere else ([`adjacent_triangles_intersect`]).

use nalgebra::Vector3;

use super::boundary::Surface;
use super::bvh::triangle_pairs;
use super::predicates::{orient2d, orient3d};
use crate::base::error::Result;

/// Whether the closed triangles `t1` and `t2` share a point (exact; see the module docs).
/// Degenerate (zero-area) triangles are outside its contract.
pub fn triangles_intersect(t1: &[Vector3<f64>; 3], t2: &[Vector3<f64>; 3]) -> bool {
    (0..3).any(|k| segment_meets_triangle(&t1[k], &t1[(k + 1) % 3], t2))
        || (0..3).any(|k| segment_meets_triangle(&t2[k], &t2[(k + 1) % 3], t1))
}

/// The pairs (a, b), a < b, of triangles of `surface` that intersect at `positions` (indexed
/// by node id, m): the broad phase's overlapping boxes ([`triangle_pairs`]), each decided
/// exactly — by [`triangles_intersect`] for triangles that share no vertex, and by
/// [`adjacent_triangles_intersect`] (a meeting beyond their shared vertex or edge: a fold) for
/// those that do.
///
/// Errors: positions not covering the surface or not finite.
pub fn surface_intersections(
    surface: &Surface,
    positions: &[Vector3<f64>],
) -> Result<Vec<(usize, usize)>> {
    let tris = surface.triangles();
    Ok(triangle_pairs(surface, positions)?
        .into_iter()
        .filter(|&(a, b)| match surface.triangles_adjacent(a, b) {
            true => adjacent_triangles_intersect(&tris[a], &tris[b], positions),
            false => triangles_intersect(
                &tris[a].map(|n| positions[n]),
                &tris[b].map(|n| positions[n]),
            ),
        })
        .collect())
}

/// Whether triangles `ta` and `tb` (node ids into `positions`) that share one vertex or one
/// edge meet anywhere else (exact). Sharing one vertex v: their common set is a segment from v
/// (or a sector, when coplanar) whose far end lies on the edge opposite v of one of them and
/// in the other, so they meet beyond v exactly when an opposite edge meets the other triangle.
/// Sharing an edge: not coplanar, they meet on that edge only; coplanar, they overlap exactly
/// when their third vertices lie on the same side of it (folded flat onto each other).
/// Triangles sharing no vertex, or all three, are `false`.
pub fn adjacent_triangles_intersect(
    ta: &[usize; 3],
    tb: &[usize; 3],
    positions: &[Vector3<f64>],
) -> bool {
    let shared: Vec<usize> = ta.iter().copied().filter(|n| tb.contains(n)).collect();
    let x = |t: &[usize; 3]| t.map(|n| positions[n]);
    let others = |t: &[usize; 3]| -> Vec<Vector3<f64>> {
        t.iter()
            .filter(|n| !shared.contains(n))
            .map(|&n| positions[n])
            .collect()
    };
    match shared.len() {
        1 => {
            let (oa, ob) = (others(ta), others(tb));
            segment_meets_triangle(&oa[0], &oa[1], &x(tb))
                || segment_meets_triangle(&ob[0], &ob[1], &x(ta))
        }
        2 => {
            let (v, u) = (positions[shared[0]], positions[shared[1]]);
            let (a, b) = (others(ta)[0], others(tb)[0]);
            if orient3d(&v, &u, &a, &b) != 0 {
                return false;
            }
            let normal = (u - v).cross(&(a - v));
            let drop = normal.iamax();
            let (i, j) = ((drop + 1) % 3, (drop + 2) % 3);
            let p = |y: &Vector3<f64>| [y[i], y[j]];
            orient2d(p(&v), p(&u), p(&a)) * orient2d(p(&v), p(&u), p(&b)) > 0
        }
        _ => false,
    }
}

/// Whether the closed segment [a, b] meets the closed triangle `t`.
fn segment_meets_triangle(a: &Vector3<f64>, b: &Vector3<f64>, t: &[Vector3<f64>; 3]) -> bool {
    let (oa, ob) = (
        orient3d(&t[0], &t[1], &t[2], a),
        orient3d(&t[0], &t[1], &t[2], b),
    );
    if oa * ob > 0 {
        return false;
    }
    if oa == 0 && ob == 0 {
        return coplanar_segment_meets_triangle(a, b, t);
    }
    // The line through a and b crosses the plane at a point of [a, b]; it is in the triangle
    // when the line passes no edge on the other side from the rest (Plücker signs not mixed).
    let s = [
        orient3d(a, b, &t[0], &t[1]),
        orient3d(a, b, &t[1], &t[2]),
        orient3d(a, b, &t[2], &t[0]),
    ];
    !(s.contains(&1) && s.contains(&-1))
}

/// The coplanar case in the plane of the two axes other than the one along which the
/// triangle's normal is largest (the projection is exact: coordinates are dropped).
fn coplanar_segment_meets_triangle(
    a: &Vector3<f64>,
    b: &Vector3<f64>,
    t: &[Vector3<f64>; 3],
) -> bool {
    let normal = (t[1] - t[0]).cross(&(t[2] - t[0]));
    let drop = normal.iamax();
    let (i, j) = ((drop + 1) % 3, (drop + 2) % 3);
    let p = |x: &Vector3<f64>| [x[i], x[j]];
    let (a2, b2) = (p(a), p(b));
    let t2 = [p(&t[0]), p(&t[1]), p(&t[2])];
    point_in_triangle(a2, &t2)
        || point_in_triangle(b2, &t2)
        || (0..3).any(|k| segments_meet(a2, b2, t2[k], t2[(k + 1) % 3]))
}

/// Whether the point is in the closed (non-degenerate) triangle, in the plane.
fn point_in_triangle(x: [f64; 2], t: &[[f64; 2]; 3]) -> bool {
    let s = [
        orient2d(t[0], t[1], x),
        orient2d(t[1], t[2], x),
        orient2d(t[2], t[0], x),
    ];
    !(s.contains(&1) && s.contains(&-1))
}

/// Whether the closed segments [a, b] and [c, d] share a point, in the plane.
fn segments_meet(a: [f64; 2], b: [f64; 2], c: [f64; 2], d: [f64; 2]) -> bool {
    let (d1, d2) = (orient2d(c, d, a), orient2d(c, d, b));
    let (d3, d4) = (orient2d(a, b, c), orient2d(a, b, d));
    if d1 * d2 < 0 && d3 * d4 < 0 {
        return true;
    }
    (d1 == 0 && within(c, d, a))
        || (d2 == 0 && within(c, d, b))
        || (d3 == 0 && within(a, b, c))
        || (d4 == 0 && within(a, b, d))
}

/// For x collinear with [p, q]: whether it lies between them (coordinate comparisons, exact).
fn within(p: [f64; 2], q: [f64; 2], x: [f64; 2]) -> bool {
    (0..2).all(|k| p[k].min(q[k]) <= x[k] && x[k] <= p[k].max(q[k]))
}
