//! Issue 36, the broad phase of body–body and self-contact: the bounding-volume hierarchy
//! returns exactly the brute-force set of overlapping boxes, and so every pair within d̂.

use std::collections::BTreeSet;

use nalgebra::Vector3;
use tetfem::contact::surface::bvh::triangle_pairs;
use tetfem::contact::surface::distance::{
    edge_edge_squared_distance, point_triangle_squared_distance,
};
use tetfem::contact::surface::{Aabb, Pair, Surface, SurfaceBarrier, candidates};

use crate::common::Rng;
use crate::self_contact_fixtures::{folded_beam, jitter, two_blocks};

fn boxes_of(nodes: &[usize], x: &[Vector3<f64>], dx: Option<&[Vector3<f64>]>, margin: f64) -> Aabb {
    let mut points: Vec<Vector3<f64>> = nodes.iter().map(|&n| x[n]).collect();
    if let Some(dx) = dx {
        points.extend(nodes.iter().map(|&n| x[n] + dx[n]));
    }
    Aabb::of_points(&points).inflated(margin)
}

/// (point–triangle, edge–edge) pairs.
type PairLists = (Vec<(usize, usize)>, Vec<(usize, usize)>);

/// Every non-adjacent pair whose boxes overlap, by brute force over all pairs.
fn brute_force(
    surface: &Surface,
    x: &[Vector3<f64>],
    dx: Option<&[Vector3<f64>]>,
    inflation: f64,
) -> PairLists {
    let m = 0.5 * inflation;
    let mut pt = Vec::new();
    for &n in surface.vertices() {
        let p = boxes_of(&[n], x, dx, m);
        for (t, tri) in surface.triangles().iter().enumerate() {
            if !tri.contains(&n) && p.overlaps(&boxes_of(tri, x, dx, m)) {
                pt.push((n, t));
            }
        }
    }
    let mut ee = Vec::new();
    let edges = surface.edges();
    for a in 0..edges.len() {
        for b in a + 1..edges.len() {
            let shared = edges[a].iter().any(|n| edges[b].contains(n));
            if !shared && boxes_of(&edges[a], x, dx, m).overlaps(&boxes_of(&edges[b], x, dx, m)) {
                ee.push((a, b));
            }
        }
    }
    (pt, ee)
}

fn scenes() -> Vec<(&'static str, Surface, Vec<Vector3<f64>>, f64)> {
    let (blocks, mut x) = two_blocks(3, 0.004, 0.05);
    jitter(&mut x, 1e-3, 3);
    let (beam, mut y) = folded_beam(16, 0.06);
    jitter(&mut y, 1e-3, 4);
    vec![
        ("two blocks", blocks, x, 0.01),
        ("folded beam", beam, y, 0.03),
    ]
}

#[test]
fn candidates_are_the_brute_force_box_overlaps_and_cover_every_pair_within_reach() {
    for (name, surface, x, d_hat) in scenes() {
        let found = candidates(&surface, &x, None, d_hat).unwrap();
        let (pt, ee) = brute_force(&surface, &x, None, d_hat);
        assert_eq!(found.point_triangle, pt, "{name}");
        assert_eq!(found.edge_edge, ee, "{name}");
        // The pairs within d̂, by brute force over all pairs, are exactly the active ones.
        let barrier = SurfaceBarrier::new(d_hat, 1.0).unwrap();
        let active: BTreeSet<(bool, usize, usize)> = barrier
            .active_pairs(&surface, &x)
            .unwrap()
            .iter()
            .map(|p| match p.pair {
                Pair::PointTriangle { node, triangle } => (true, node, triangle),
                Pair::EdgeEdge { a, b } => (false, a, b),
            })
            .collect();
        let mut within = BTreeSet::new();
        for &n in surface.vertices() {
            for (t, tri) in surface.triangles().iter().enumerate() {
                let [a, b, c] = tri.map(|k| x[k]);
                if !tri.contains(&n)
                    && point_triangle_squared_distance(&x[n], &a, &b, &c) < d_hat * d_hat
                {
                    within.insert((true, n, t));
                }
            }
        }
        let edges = surface.edges();
        for a in 0..edges.len() {
            for b in a + 1..edges.len() {
                let shared = edges[a].iter().any(|n| edges[b].contains(n));
                let [a0, a1] = edges[a].map(|k| x[k]);
                let [b0, b1] = edges[b].map(|k| x[k]);
                if !shared && edge_edge_squared_distance(&a0, &a1, &b0, &b1) < d_hat * d_hat {
                    within.insert((false, a, b));
                }
            }
        }
        assert!(
            within.len() > 50,
            "{name}: {} pairs within reach",
            within.len()
        );
        assert_eq!(active, within, "{name}");
    }
}

#[test]
fn swept_candidates_are_the_brute_force_swept_box_overlaps() {
    for (name, surface, x, d_hat) in scenes() {
        let mut rng = Rng::new(5);
        let dx: Vec<Vector3<f64>> = x.iter().map(|_| rng.vector(-0.02, 0.02)).collect();
        let found = candidates(&surface, &x, Some(&dx), d_hat).unwrap();
        let (pt, ee) = brute_force(&surface, &x, Some(&dx), d_hat);
        assert_eq!(found.point_triangle, pt, "{name}");
        assert_eq!(found.edge_edge, ee, "{name}");
    }
}

#[test]
fn triangle_pairs_are_the_brute_force_box_overlaps() {
    for (name, surface, x, _) in scenes() {
        let found = triangle_pairs(&surface, &x).unwrap();
        let tris = surface.triangles();
        let mut expected = Vec::new();
        for a in 0..tris.len() {
            for b in a + 1..tris.len() {
                if boxes_of(&tris[a], &x, None, 0.0).overlaps(&boxes_of(&tris[b], &x, None, 0.0)) {
                    expected.push((a, b));
                }
            }
        }
        assert_eq!(found, expected, "{name}");
    }
}
