//! The start check of a body's boundary surface against the obstacles: the barrier acts on the
//! boundary nodes only, so an obstacle that reaches into a face between its nodes, or lies
//! wholly inside the body, would feel no force and let the body pass through it. Both are
//! refused before the run.
//!
//! Per boundary triangle and obstacle, the least signed distance of the triangle to the
//! obstacle (negative: the depth the obstacle reaches into the face):
//!
//! - half-space: d is linear, so its least value is at a corner;
//! - sphere: |c − q| − R with q the point of the triangle nearest the centre c (Ericson,
//!   "Real-Time Collision Detection", §5.1.5);
//! - box: in the box's frame, the least g(p) = maxᵢ(|pᵢ| − hᵢ) over the triangle, a linear
//!   program in the barycentric coordinates (λ₁, λ₂) and the bound t solved exactly by its
//!   vertices (`box_least_gap`); g equals the signed distance wherever g ≤ 0, so its sign
//!   and, inside, its value are the box's.
//!
//! An obstacle that no face reaches is either wholly outside the body or wholly inside it
//! (or in a cavity): its centre's generalized winding number about the closed, outward
//! oriented boundary (Σ solid angles / 4π: 1 inside the material, 0 outside or in a cavity)
//! tells which.

use nalgebra::{Matrix3, Vector3};

use super::{Obstacle, Shape};
use crate::base::error::{Error, Result};
use crate::mesh::BoundaryFace;

/// A depth at most this fraction of the body's bounding-box diagonal counts as touching
/// (accepted): a face tangent to a sphere or flush with a box face computes to a gap of a few
/// rounding errors of the coordinates (~1e-16 relative), either sign.
pub const TOUCH_FRACTION: f64 = 1e-9;

/// [`Error::InvalidParameter`] naming the obstacle, the boundary face and the depth if any
/// boundary triangle (corners `faces` of `nodes`, outward oriented) reaches into an obstacle
/// (each moved by its offset in `offsets`) deeper than [`TOUCH_FRACTION`] of `diagonal`, or if
/// an obstacle lies wholly inside the body.
pub fn check_surface(
    nodes: &[Vector3<f64>],
    faces: &[BoundaryFace],
    obstacles: &[Obstacle],
    offsets: &[Vector3<f64>],
    diagonal: f64,
) -> Result<()> {
    let tolerance = TOUCH_FRACTION * diagonal;
    let corners = |f: &BoundaryFace| f.nodes.map(|n| nodes[n]);
    for (obstacle, offset) in obstacles.iter().zip(offsets) {
        let mut nearest: Option<(f64, &BoundaryFace)> = None;
        for face in faces {
            let gap = least_gap(obstacle, corners(face).map(|x| x - offset));
            if gap < -tolerance {
                return Err(Error::invalid_parameter(
                    format!("obstacle {}", obstacle.name()),
                    format!(
                        "it reaches {:.3e} deep into boundary face {:?} (of tet {}) between \
                         the face's nodes",
                        -gap, face.nodes, face.tet
                    ),
                    "the body's surface must start outside every obstacle (touching is \
                     allowed): move the obstacle out by at least that depth",
                ));
            }
            if nearest.is_none_or(|(g, _)| gap < g) {
                nearest = Some((gap, face));
            }
        }
        if let (Some(center), Some((gap, face))) = (solid_center(obstacle), nearest) {
            let center = center + offset;
            let winding = winding_number(&center, faces.iter().map(corners));
            if winding.abs() > 0.5 {
                return Err(Error::invalid_parameter(
                    format!("obstacle {}", obstacle.name()),
                    format!(
                        "it lies wholly inside the body (its centre {:?}, winding number \
                         {winding:.2}), at least {gap:.3e} below the surface (nearest: \
                         boundary face {:?} of tet {})",
                        center.as_slice(),
                        face.nodes,
                        face.tet
                    ),
                    "an obstacle must start outside the body (a cavity is allowed): the \
                     barrier acts on the surface and would never feel it",
                ));
            }
        }
    }
    Ok(())
}

/// The centre of a bounded obstacle (`None` for a half-space, which no body contains).
fn solid_center(obstacle: &Obstacle) -> Option<Vector3<f64>> {
    match *obstacle.shape() {
        Shape::HalfSpace { .. } => None,
        Shape::Sphere { center, .. } | Shape::Box { center, .. } => Some(center),
    }
}

/// The least signed distance (length) of the triangle `t` to the obstacle at rest, or for a
/// box a value of the same sign that is the signed distance wherever it is ≤ 0.
pub fn least_gap(obstacle: &Obstacle, t: [Vector3<f64>; 3]) -> f64 {
    match *obstacle.shape() {
        Shape::HalfSpace { .. } => t
            .iter()
            .map(|x| obstacle.distance(x))
            .fold(f64::INFINITY, f64::min),
        Shape::Sphere { center, radius } => {
            (closest_point_on_triangle(&center, t) - center).norm() - radius
        }
        Shape::Box {
            center,
            half_extents,
            rotation,
        } => {
            let local = t.map(|x| rotation.inverse() * (x - center));
            // Far from the box (the triangle's bounding ball misses it): positive at once.
            let middle = (local[0] + local[1] + local[2]) / 3.0;
            let reach = local
                .iter()
                .map(|x| (x - middle).norm())
                .fold(0.0, f64::max);
            let gap = obstacle.distance(&(rotation * middle + center));
            if gap > reach {
                gap - reach
            } else {
                box_least_gap(local, &half_extents)
            }
        }
    }
}

/// The point of the triangle `t` nearest `p` (Ericson's region test: a corner, a point of an
/// edge, or the projection into the face).
pub fn closest_point_on_triangle(p: &Vector3<f64>, t: [Vector3<f64>; 3]) -> Vector3<f64> {
    let [a, b, c] = t;
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(&ap), ac.dot(&ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(&bp), ac.dot(&bp));
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return a + ab * (d1 / (d1 - d3));
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(&cp), ac.dot(&cp));
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return a + ac * (d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && d4 - d3 >= 0.0 && d5 - d6 >= 0.0 {
        return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    let denominator = va + vb + vc;
    if denominator.abs() <= f64::MIN_POSITIVE {
        // A degenerate (zero-area) triangle: its corners.
        return *t
            .iter()
            .min_by(|x, y| (*x - p).norm().total_cmp(&(*y - p).norm()))
            .unwrap_or(&a);
    }
    a + ab * (vb / denominator) + ac * (vc / denominator)
}

/// min over the triangle `t` (in the box's frame) of g(p) = maxᵢ(|pᵢ| − hᵢ), `h` the half
/// extents: the linear program min t s.t. ±pᵢ(λ) − t ≤ hᵢ (six rows), λ₁ ≥ 0, λ₂ ≥ 0,
/// λ₁ + λ₂ ≤ 1, with p(λ) = a + λ₁(b − a) + λ₂(c − a). Its feasible set is a polytope in
/// (λ₁, λ₂, t) (λ bounded, t ≥ maxᵢ(−hᵢ)), so the optimum is at a vertex: three active rows.
/// All 84 triples are solved and the least feasible t kept (exact up to rounding).
fn box_least_gap(t: [Vector3<f64>; 3], h: &Vector3<f64>) -> f64 {
    let [a, b, c] = t;
    let (e1, e2) = (b - a, c - a);
    // Rows (coefficients of λ₁, λ₂, t) ≤ right-hand side.
    let mut rows: Vec<(Vector3<f64>, f64)> = Vec::with_capacity(9);
    for i in 0..3 {
        for s in [1.0, -1.0] {
            rows.push((Vector3::new(s * e1[i], s * e2[i], -1.0), h[i] - s * a[i]));
        }
    }
    rows.push((Vector3::new(-1.0, 0.0, 0.0), 0.0));
    rows.push((Vector3::new(0.0, -1.0, 0.0), 0.0));
    rows.push((Vector3::new(1.0, 1.0, 0.0), 1.0));
    let scale = rows.iter().map(|(_, r)| r.abs()).fold(1.0, f64::max);
    let slack = 1e-12 * scale;
    let mut best = f64::INFINITY;
    for i in 0..rows.len() {
        for j in i + 1..rows.len() {
            for k in j + 1..rows.len() {
                let m = Matrix3::from_rows(&[
                    rows[i].0.transpose(),
                    rows[j].0.transpose(),
                    rows[k].0.transpose(),
                ]);
                let Some(inverse) = m.try_inverse() else {
                    continue;
                };
                let x = inverse * Vector3::new(rows[i].1, rows[j].1, rows[k].1);
                if x.iter().all(|v| v.is_finite())
                    && rows.iter().all(|(row, rhs)| row.dot(&x) <= rhs + slack)
                {
                    best = best.min(x[2]);
                }
            }
        }
    }
    if best.is_finite() {
        best
    } else {
        // No vertex found (rounding on a degenerate triangle): the corners' value, an upper
        // bound of the least g.
        t.iter()
            .map(|p| (p.abs() - h).max())
            .fold(f64::INFINITY, f64::min)
    }
}

/// The generalized winding number of the closed triangulated surface `triangles` (outward
/// oriented) about `p`: Σ Ωₖ / 4π with Ωₖ the signed solid angle of triangle k seen from p,
/// tan(Ω/2) = a·(b × c) / (|a||b||c| + (a·b)|c| + (a·c)|b| + (b·c)|a|) (Van Oosterom and
/// Strackee), a, b, c the corners relative to p. 1 inside, 0 outside (dimensionless).
pub fn winding_number(p: &Vector3<f64>, triangles: impl Iterator<Item = [Vector3<f64>; 3]>) -> f64 {
    let mut total = 0.0;
    for t in triangles {
        let [a, b, c] = t.map(|x| x - p);
        let (la, lb, lc) = (a.norm(), b.norm(), c.norm());
        let numerator = a.dot(&b.cross(&c));
        let denominator = la * lb * lc + a.dot(&b) * lc + a.dot(&c) * lb + b.dot(&c) * la;
        total += 2.0 * numerator.atan2(denominator);
    }
    total / (4.0 * std::f64::consts::PI)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tri() -> [Vector3<f64>; 3] {
        [
            Vector3::new(0.0, 0.0, 0.0),
            Vector3::new(1.0, 0.0, 0.0),
            Vector3::new(0.0, 1.0, 0.0),
        ]
    }

    #[test]
    fn closest_point_regions() {
        let t = tri();
        // Above the face: its projection.
        let q = closest_point_on_triangle(&Vector3::new(0.25, 0.25, 2.0), t);
        assert_eq!(q, Vector3::new(0.25, 0.25, 0.0));
        // Beyond a corner, beyond an edge, beyond the hypotenuse.
        assert_eq!(
            closest_point_on_triangle(&Vector3::new(-1.0, -1.0, 1.0), t),
            t[0]
        );
        assert_eq!(
            closest_point_on_triangle(&Vector3::new(0.5, -2.0, 0.0), t),
            Vector3::new(0.5, 0.0, 0.0)
        );
        assert_eq!(
            closest_point_on_triangle(&Vector3::new(1.0, 1.0, 0.0), t),
            Vector3::new(0.5, 0.5, 0.0)
        );
    }

    #[test]
    fn box_gap_is_the_depth_inside_and_positive_outside() {
        let h = Vector3::new(1.0, 1.0, 1.0);
        // A big triangle through the box's centre plane z = 0.5: its deepest point is on
        // the box's axis, 0.5 below the top face (g = max(|x| − 1, |y| − 1, 0.5 − 1) = −0.5).
        let t = [
            Vector3::new(-5.0, -5.0, 0.5),
            Vector3::new(5.0, -5.0, 0.5),
            Vector3::new(0.0, 5.0, 0.5),
        ];
        assert!((box_least_gap(t, &h) + 0.5).abs() < 1e-12);
        // Lifted to z = 1.25: outside (g = 0.25 there, positive).
        let lifted = t.map(|x| x + Vector3::new(0.0, 0.0, 0.75));
        assert!((box_least_gap(lifted, &h) - 0.25).abs() < 1e-12);
        // A small triangle whose corners are all outside but which cuts the box's edge at
        // x = y = 1: its deepest point is the midpoint (0.95, 0.95, 0) of the edge from
        // (0.7, 1.2) to (1.2, 0.7), where g = 0.95 − 1 = −0.05.
        let across = [
            Vector3::new(0.7, 1.2, 0.0),
            Vector3::new(1.2, 0.7, 0.0),
            Vector3::new(1.2, 1.2, 0.0),
        ];
        assert!(across.iter().all(|p| (p.abs() - h).max() > 0.0));
        assert!((box_least_gap(across, &h) + 0.05).abs() < 1e-12);
    }

    #[test]
    fn winding_number_of_a_tetrahedron() {
        // The unit tet's four faces, outward.
        let v = [
            Vector3::new(0.0, 0.0, 0.0),
            Vector3::new(1.0, 0.0, 0.0),
            Vector3::new(0.0, 1.0, 0.0),
            Vector3::new(0.0, 0.0, 1.0),
        ];
        let faces = [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]].map(|f| f.map(|i| v[i]));
        let inside = winding_number(&Vector3::repeat(0.1), faces.into_iter());
        let outside = winding_number(&Vector3::repeat(1.0), faces.into_iter());
        assert!((inside - 1.0).abs() < 1e-12, "{inside}");
        assert!(outside.abs() < 1e-12, "{outside}");
    }
}
