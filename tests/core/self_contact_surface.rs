//! Issue 36, the boundary surface of body–body and self-contact (`tetfem::contact::surface`):
//! closed and outward on 4- and 10-node tets, and an error naming the edge of an open or
//! non-manifold surface.

use nalgebra::Vector3;
use tetfem::contact::surface::Surface;
use tetfem::{BoxSplit, Error, Tet10, TetMesh};

fn block() -> TetMesh {
    TetMesh::box_grid(
        Vector3::new(0.1, -0.2, 0.3),
        Vector3::new(0.5, 0.1, 0.5),
        [3, 2, 2],
        BoxSplit::Lecture6,
    )
    .unwrap()
}

/// V − E + F = 2 (a sphere's surface), 2E = 3F (closed), Σ area vectors = 0 and
/// ⅓∮x·n dA = volume (outward: the divergence theorem).
fn check_closed_outward(surface: &Surface, nodes: &[Vector3<f64>], volume: f64) {
    let (v, e, f) = (
        surface.vertices().len() as i64,
        surface.edges().len() as i64,
        surface.triangles().len() as i64,
    );
    assert_eq!(v - e + f, 2);
    assert_eq!(2 * e, 3 * f);
    let mut area_sum = Vector3::zeros();
    let mut flux = 0.0;
    for t in surface.triangles() {
        let [a, b, c] = t.map(|n| nodes[n]);
        let area = 0.5 * (b - a).cross(&(c - a));
        area_sum += area;
        flux += (a + b + c).dot(&area) / 9.0;
    }
    // Both are exact identities up to round-off of O(F) terms of size ~0.01 m².
    assert!(area_sum.norm() < 1e-14, "{area_sum}");
    assert!((flux - volume).abs() < 1e-14, "{flux} vs {volume}");
    let around: usize = surface
        .vertices()
        .iter()
        .map(|&n| surface.triangles_around(n).len())
        .sum();
    assert_eq!(around as i64, 3 * f);
    for &n in surface.vertices() {
        for &t in surface.triangles_around(n) {
            assert!(surface.point_triangle_adjacent(n, t));
        }
    }
}

#[test]
fn linear_block_surface_is_closed_and_outward() {
    let mesh = block();
    let surface = Surface::from_mesh(&mesh).unwrap();
    // A 3×2×2 box has 2·(3·2 + 3·2 + 2·2) = 32 squares, two triangles each.
    assert_eq!(surface.triangles().len(), 64);
    check_closed_outward(&surface, mesh.nodes(), 0.4 * 0.3 * 0.2);
}

#[test]
fn quadratic_block_surface_is_its_linear_subtriangles() {
    let mesh = TetMesh::<Tet10>::from_linear(&block()).unwrap();
    let surface = Surface::from_mesh(&mesh).unwrap();
    assert_eq!(surface.triangles().len(), 4 * 64);
    check_closed_outward(&surface, mesh.nodes(), 0.4 * 0.3 * 0.2);
}

fn edge_error(triangles: Vec<[usize; 3]>, nodes: &[Vector3<f64>]) -> String {
    match Surface::from_triangles(triangles, nodes) {
        Err(e @ Error::InvalidParameter { .. }) => e.to_string(),
        other => panic!("expected an edge error, got {other:?}"),
    }
}

#[test]
fn open_non_manifold_and_flipped_surfaces_name_the_edge() {
    let mesh = block();
    let nodes = mesh.nodes();
    let surface = Surface::from_mesh(&mesh).unwrap();
    let triangles = surface.triangles().to_vec();

    let mut open = triangles.clone();
    let removed = open.remove(0);
    let message = edge_error(open, nodes);
    // It names one of the removed triangle's three edges (the first in sorted order).
    let named = (0..3).any(|k| {
        let (a, b) = (removed[k], removed[(k + 1) % 3]);
        message.contains(&format!("surface edge ({}, {})", a.min(b), a.max(b)))
    });
    assert!(named, "{message}");
    assert!(message.contains("shared by 1 triangle"), "{message}");

    // A third triangle on the edge (a, b) with a node off the surface's sheet.
    let mut seam = triangles.clone();
    let [a, b, c] = seam[0];
    seam.push([b, a, c]);
    let message = edge_error(seam, nodes);
    assert!(message.contains("shared by 3 triangles"), "{message}");

    let mut flipped = triangles.clone();
    flipped[5].swap(1, 2);
    let message = edge_error(flipped, nodes);
    assert!(message.contains("in the same direction"), "{message}");
}
