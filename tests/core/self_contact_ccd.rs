//! Issue 36, continuous collision detection of body–body and self-contact (additive CCD): on
//! collision courses with a closed-form time of impact, the step it returns leaves the
//! triangles apart (by the exact intersection test), keeps the separation it promises, and is
//! not absurdly conservative.

use nalgebra::Vector3;
use tetfem::contact::surface::ccd::pair_step;
use tetfem::contact::surface::distance::{
    edge_edge_squared_distance, point_triangle_squared_distance,
};
use tetfem::contact::surface::{
    Pair, SEPARATION_FRACTION, Surface, candidates, max_step, surface_intersections,
    triangles_intersect,
};

use crate::common::Rng;
use crate::self_contact_fixtures::{folded_beam, two_blocks};

fn v(x: f64, y: f64, z: f64) -> Vector3<f64> {
    Vector3::new(x, y, z)
}

fn moved(t: &[Vector3<f64>; 3], d: &[Vector3<f64>; 3], alpha: f64) -> [Vector3<f64>; 3] {
    std::array::from_fn(|k| t[k] + alpha * d[k])
}

/// Triangle A (apex down) falls at speed 1 onto triangle B rising at speed 0.5; apex 0.3 above
/// B's plane and over its interior: the time of impact is 0.3/1.5 = 0.2 of the step.
#[test]
fn point_onto_triangle_head_on() {
    let b = [v(-1.0, -1.0, 0.0), v(1.0, -1.0, 0.0), v(0.0, 1.0, 0.0)];
    let a = [v(0.1, 0.0, 0.3), v(0.5, 0.5, 1.0), v(-0.5, 0.5, 1.0)];
    let (da, db) = ([v(0.0, 0.0, -1.0); 3], [v(0.0, 0.0, 0.5); 3]);
    let toi = 0.2;
    let x = [a[0], b[0], b[1], b[2]];
    let dx = [da[0], db[0], db[1], db[2]];
    let pair = Pair::PointTriangle {
        node: 0,
        triangle: 0,
    };
    let alpha = pair_step(pair, &x, &dx, SEPARATION_FRACTION, 1.0).unwrap();
    println!("point–triangle: α = {alpha:.6} against the time of impact {toi}");
    // A collision course: at 0.3 of the step the apex is through B (A passes B by t = 1).
    assert!(triangles_intersect(
        &moved(&a, &da, 0.3),
        &moved(&b, &db, 0.3)
    ));
    assert!(!triangles_intersect(
        &moved(&a, &da, alpha),
        &moved(&b, &db, alpha)
    ));
    assert!(alpha < toi && alpha >= 0.5 * toi);
    // The promised separation: at α the gap is ≥ s × 0.3.
    let y: Vec<Vector3<f64>> = (0..4).map(|k| x[k] + alpha * dx[k]).collect();
    let d = point_triangle_squared_distance(&y[0], &y[1], &y[2], &y[3]).sqrt();
    // ACCD's first step lands exactly on s·d₀ on a head-on approach (l_p is the closing
    // speed): equal up to the round-off of the distance, 1e-12 relative.
    assert!(d >= SEPARATION_FRACTION * 0.3 * (1.0 - 1e-12), "{d}");
}

/// Two crossing edges 0.4 apart in z approaching at relative speed 2 (and sliding along
/// each other, which does not change their distance): time of impact 0.2.
#[test]
fn edge_onto_edge_head_on() {
    let x = [
        v(-1.0, 0.0, 0.4),
        v(1.0, 0.0, 0.4),
        v(0.0, -1.0, 0.0),
        v(0.0, 1.0, 0.0),
    ];
    let dx = [
        v(0.3, 0.0, -1.0),
        v(0.3, 0.0, -1.0),
        v(0.0, -0.2, 1.0),
        v(0.0, -0.2, 1.0),
    ];
    let toi = 0.2;
    let alpha = pair_step(
        Pair::EdgeEdge { a: 0, b: 1 },
        &x,
        &dx,
        SEPARATION_FRACTION,
        1.0,
    )
    .unwrap();
    println!("edge–edge: α = {alpha:.6} against the time of impact {toi}");
    assert!(alpha < toi && alpha >= 0.5 * toi);
    let y: Vec<Vector3<f64>> = (0..4).map(|k| x[k] + alpha * dx[k]).collect();
    let d = edge_edge_squared_distance(&y[0], &y[1], &y[2], &y[3]).sqrt();
    // As above, up to round-off.
    assert!(d >= SEPARATION_FRACTION * 0.4 * (1.0 - 1e-12), "{d}");
    // As triangles with the edges as their sides (third vertices away from the contact).
    let ta = [x[0], x[1], v(0.0, 0.0, 2.0)];
    let tb = [x[2], x[3], v(0.0, 0.0, -2.0)];
    let (da, db) = ([dx[0], dx[1], dx[0]], [dx[2], dx[3], dx[2]]);
    assert!(triangles_intersect(
        &moved(&ta, &da, 1.0),
        &moved(&tb, &db, 1.0)
    ));
    assert!(!triangles_intersect(
        &moved(&ta, &da, alpha),
        &moved(&tb, &db, alpha)
    ));
}

/// On whole surfaces moved by random steps that make them cross: the returned fraction leaves
/// no triangle pair intersecting, and every swept candidate pair keeps ≥ s × its start distance.
#[test]
fn surfaces_on_collision_courses_stay_apart() {
    let (blocks, x) = two_blocks(3, 0.004, 0.05);
    let (beam, y) = folded_beam(16, 0.06);
    let mut rng = Rng::new(42);
    for (name, surface, x, push, above) in [
        ("two blocks", blocks, x, v(0.0, 0.0, -0.02), 0.101),
        ("folded beam", beam, y, v(0.0, 0.0, -0.04), 0.06),
    ] {
        // Push the upper block (z above 0.101) or the upper half of the beam (above 0.06)
        // down, with noise.
        let dx: Vec<Vector3<f64>> = x
            .iter()
            .map(|p| if p.z > above { push } else { v(0.0, 0.0, 0.0) } + rng.vector(-2e-3, 2e-3))
            .collect();
        let end: Vec<Vector3<f64>> = x.iter().zip(&dx).map(|(p, d)| p + d).collect();
        assert!(
            !surface_intersections(&surface, &end).unwrap().is_empty(),
            "{name}: no collision course"
        );
        let alpha = max_step(&surface, &x, &dx, SEPARATION_FRACTION).unwrap();
        let at: Vec<Vector3<f64>> = x.iter().zip(&dx).map(|(p, d)| p + alpha * d).collect();
        assert_eq!(
            surface_intersections(&surface, &at).unwrap(),
            vec![],
            "{name}"
        );
        let worst = separation_kept(&surface, &x, &dx, &at);
        println!("{name}: α = {alpha:.4}, smallest kept fraction of a start distance {worst:.3}");
        assert!(worst >= SEPARATION_FRACTION, "{name}: {worst}");
        assert!(alpha > 0.0);
    }
}

/// The smallest d(α)/d(0) over the swept candidate pairs.
fn separation_kept(
    surface: &Surface,
    x: &[Vector3<f64>],
    dx: &[Vector3<f64>],
    at: &[Vector3<f64>],
) -> f64 {
    let found = candidates(surface, x, Some(dx), 0.0).unwrap();
    let pt = |y: &[Vector3<f64>], n: usize, t: usize| {
        let [a, b, c] = surface.triangles()[t].map(|k| y[k]);
        point_triangle_squared_distance(&y[n], &a, &b, &c).sqrt()
    };
    let ee = |y: &[Vector3<f64>], a: usize, b: usize| {
        let ([a0, a1], [b0, b1]) = (
            surface.edges()[a].map(|k| y[k]),
            surface.edges()[b].map(|k| y[k]),
        );
        edge_edge_squared_distance(&a0, &a1, &b0, &b1).sqrt()
    };
    let mut worst = f64::INFINITY;
    for &(n, t) in &found.point_triangle {
        worst = worst.min(pt(at, n, t) / pt(x, n, t));
    }
    for &(a, b) in &found.edge_edge {
        worst = worst.min(ee(at, a, b) / ee(x, a, b));
    }
    worst
}
