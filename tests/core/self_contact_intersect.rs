//! Issue 36, the exact triangle–triangle intersection test (the "no intersection, ever" check,
//! independent of the barrier) and its exact orientation predicates: crossing, separated,
//! touching at a point (reported as intersecting: the triangles are closed), coplanar cases,
//! and configurations one unit in the last place apart.

use nalgebra::Vector3;
use tetfem::contact::surface::predicates::{orient2d, orient3d};
use tetfem::contact::surface::{surface_intersections, triangles_intersect};

use crate::common::Rng;
use crate::self_contact_fixtures::{folded_beam, two_blocks};

fn v(x: f64, y: f64, z: f64) -> Vector3<f64> {
    Vector3::new(x, y, z)
}

fn flat() -> [Vector3<f64>; 3] {
    [v(0.0, 0.0, 0.0), v(1.0, 0.0, 0.0), v(0.0, 1.0, 0.0)]
}

/// Both orders and every cyclic relabelling give the same answer.
fn check(t1: [Vector3<f64>; 3], t2: [Vector3<f64>; 3], expected: bool, what: &str) {
    for k in 0..3 {
        let r1 = [t1[k], t1[(k + 1) % 3], t1[(k + 2) % 3]];
        let r2 = [t2[(k + 1) % 3], t2[(k + 2) % 3], t2[k]];
        assert_eq!(triangles_intersect(&r1, &r2), expected, "{what}");
        assert_eq!(triangles_intersect(&r2, &r1), expected, "{what} (swapped)");
    }
}

#[test]
fn known_configurations() {
    let t = flat();
    check(
        t,
        [v(0.2, 0.2, -1.0), v(0.3, 0.2, 1.0), v(0.2, 0.4, 1.0)],
        true,
        "piercing",
    );
    check(
        t,
        [v(0.2, 0.2, 0.1), v(0.3, 0.2, 1.0), v(0.2, 0.4, 1.0)],
        false,
        "above",
    );
    // A vertex exactly on the face: touching at a point is reported as intersecting.
    check(
        t,
        [v(0.2, 0.2, 0.0), v(0.3, 0.2, 1.0), v(0.2, 0.4, 1.0)],
        true,
        "vertex on face",
    );
    let up = f64::from_bits(0.0f64.to_bits() + 1); // the smallest positive double
    check(
        t,
        [v(0.2, 0.2, up), v(0.3, 0.2, 1.0), v(0.2, 0.4, 1.0)],
        false,
        "vertex 1 ulp above",
    );
    // Edge on edge, crossing at the single point (0.5, 0, 0).
    check(
        t,
        [v(0.5, 0.0, 0.0), v(0.5, -1.0, 1.0), v(0.5, -1.0, -1.0)],
        true,
        "edge touch",
    );
    check(
        t,
        [v(0.5, -1e-300, 0.0), v(0.5, -1.0, 1.0), v(0.5, -1.0, -1.0)],
        false,
        "edge touch missed by 1e-300",
    );
    // Coplanar: overlapping, one inside the other, sharing only a corner point, apart.
    check(
        t,
        [v(0.5, 0.5, 0.0), v(-0.5, 0.5, 0.0), v(0.5, -0.5, 0.0)],
        true,
        "coplanar overlap",
    );
    check(
        t,
        [v(0.1, 0.1, 0.0), v(0.2, 0.1, 0.0), v(0.1, 0.2, 0.0)],
        true,
        "coplanar inside",
    );
    check(
        t,
        [v(1.0, 0.0, 0.0), v(2.0, 0.0, 0.0), v(1.0, 1.0, 0.0)],
        true,
        "coplanar corner",
    );
    check(
        t,
        [v(0.6, 0.6, 0.0), v(2.0, 0.6, 0.0), v(0.6, 2.0, 0.0)],
        false,
        "coplanar apart",
    );
    // Parallel planes 1e-12 apart.
    check(
        t,
        [v(0.1, 0.1, 1e-12), v(0.2, 0.1, 1e-12), v(0.1, 0.2, 1e-12)],
        false,
        "parallel",
    );
}

#[test]
fn orient3d_is_exact_where_floating_point_is_not() {
    let mut rng = Rng::new(41);
    let mut undecided_by_floats = 0;
    for _ in 0..500 {
        // Coordinates k/8 with |k| ≤ 800: a + b − c is exact, so d lies on the plane exactly.
        let grid =
            |rng: &mut Rng| v(0.0, 0.0, 0.0).map(|_| (rng.range(-800.0, 800.0)).round() / 8.0);
        let (a, b, c) = (grid(&mut rng), grid(&mut rng), grid(&mut rng));
        let d = a + b - c;
        assert_eq!(orient3d(&a, &b, &c, &d), 0);
        let n = (b - a).cross(&(c - a)); // exact: products of small multiples of 1/8
        if n.z == 0.0 {
            continue;
        }
        // One unit in the last place up in z: d moves to the side of +z, and the sign is
        // −sign(n_z) (d on the side opposite to the normal is positive).
        let mut e = d;
        e.z = f64::from_bits(if e.z >= 0.0 {
            e.z.to_bits() + 1
        } else {
            e.z.to_bits() - 1
        });
        if e.z == d.z {
            continue;
        }
        let expected = if n.z > 0.0 { -1 } else { 1 };
        assert_eq!(orient3d(&a, &b, &c, &e), expected);
        let naive = (a - e).dot(&(b - e).cross(&(c - e)));
        if naive.signum() as i8 != expected || naive == 0.0 {
            undecided_by_floats += 1;
        }
    }
    // The exact path matters: plain floating point gets some of these signs wrong.
    println!("plain floating point wrong on {undecided_by_floats} of 500");
    assert!(undecided_by_floats > 0);
    // And it agrees with plain floating point where the determinant is large.
    for _ in 0..1000 {
        let [a, b, c, d] = [0; 4].map(|_| rng.vector(-1.0, 1.0));
        let naive = (a - d).dot(&(b - d).cross(&(c - d)));
        if naive.abs() > 1e-6 {
            assert_eq!(orient3d(&a, &b, &c, &d), naive.signum() as i8);
        }
    }
    assert_eq!(orient2d([0.0, 0.0], [1.0, 0.0], [0.5, 1e-300]), 1);
    // Points on y = x are collinear exactly, whatever doubles 0.1, 0.2, 0.3 are:
    // (x₁ − x₃)(y₂ − y₃) − (y₁ − y₃)(x₂ − x₃) = 0 term by term.
    assert_eq!(orient2d([0.1, 0.1], [0.2, 0.2], [0.3, 0.3]), 0);
}

#[test]
fn no_intersections_on_the_fixtures_and_some_after_a_push() {
    let (blocks, mut x) = two_blocks(3, 0.004, 0.05);
    assert_eq!(surface_intersections(&blocks, &x).unwrap(), vec![]);
    // Push the upper block 1 cm down into the lower one: its bottom crosses the top face.
    let n = x.len() / 2;
    for p in &mut x[n..] {
        p.z -= 0.01;
    }
    let found = surface_intersections(&blocks, &x).unwrap();
    println!("pushed blocks: {} intersecting triangle pairs", found.len());
    assert!(!found.is_empty());
    for &(a, b) in &found {
        // Every pair found joins the two bodies (each block alone stays intact).
        let [ta, tb] = [a, b].map(|t| blocks.triangles()[t][0] >= n);
        assert_ne!(ta, tb);
    }
    let (beam, y) = folded_beam(16, 0.06);
    assert_eq!(surface_intersections(&beam, &y).unwrap(), vec![]);
    // Folded tighter than its thickness, the beam's halves cross each other.
    let (beam, y) = folded_beam(16, 0.04);
    assert!(!surface_intersections(&beam, &y).unwrap().is_empty());
}

#[test]
fn adjacent_triangles_meet_only_where_folded() {
    let x = vec![
        v(0.0, 0.0, 0.0),    // 0: shared vertex
        v(1.0, 0.0, 0.0),    // 1
        v(0.0, 1.0, 0.0),    // 2
        v(0.3, 0.3, 1.0),    // 3
        v(0.3, 0.3, -1.0),   // 4: 3–4 pierces (0, 1, 2) at (0.3, 0.3, 0)
        v(-1.0, -1.0, 1.0),  // 5
        v(-1.0, -1.0, -1.0), // 6: 5–6 passes outside it
        v(0.5, 0.5, 0.0),    // 7: coplanar, same side of edge 0–1 as 2
        v(0.5, -0.5, 0.0),   // 8: coplanar, the other side
        v(0.5, 0.5, 1e-300), // 9: off the plane by a denormal's worth
    ];
    let touch = |a: [usize; 3], b: [usize; 3]| {
        let one = tetfem::contact::surface::intersect::adjacent_triangles_intersect(&a, &b, &x);
        let other = tetfem::contact::surface::intersect::adjacent_triangles_intersect(&b, &a, &x);
        assert_eq!(one, other);
        one
    };
    assert!(
        touch([0, 1, 2], [0, 3, 4]),
        "crossing beyond the shared vertex"
    );
    assert!(
        !touch([0, 1, 2], [0, 5, 6]),
        "meeting at the shared vertex only"
    );
    assert!(touch([0, 1, 2], [1, 0, 7]), "folded flat onto each other");
    assert!(!touch([0, 1, 2], [1, 0, 8]), "a flat surface");
    assert!(!touch([0, 1, 2], [1, 0, 9]), "folded, but not flat");
    assert!(
        !touch([0, 1, 2], [3, 4, 5]),
        "not adjacent: not this test's question"
    );
}
