//! Issue 36, bad input of body–body and self-contact: bodies that overlap at the start are an
//! error naming the bodies and one pair of intersecting triangles; the shortest rest edge is
//! what a too-large d̂ is compared with.

use tetfem::contact::surface::{Surface, overlapping_bodies};
use tetfem::{BoxSplit, TetMesh};

use crate::self_contact_fixtures::{folded_beam, two_blocks};

#[test]
fn overlapping_bodies_name_the_bodies_and_a_triangle_pair() {
    let (blocks, mut x) = two_blocks(2, 0.004, 0.05);
    let n = x.len() / 2;
    let body: Vec<usize> = (0..x.len()).map(|k| usize::from(k >= n)).collect();
    overlapping_bodies(&blocks, &x, &body).unwrap();
    for p in &mut x[n..] {
        p.z -= 0.01;
    }
    let message = overlapping_bodies(&blocks, &x, &body)
        .unwrap_err()
        .to_string();
    assert!(message.contains("bodies 0 and 1"), "{message}");
    assert!(
        message.contains("of body 0 meets triangle")
            || message.contains("of body 1 meets triangle"),
        "{message}"
    );
    println!("{message}");

    let (beam, y) = folded_beam(16, 0.04);
    let message = overlapping_bodies(&beam, &y, &vec![0; y.len()])
        .unwrap_err()
        .to_string();
    assert!(
        message.contains("body 0 (intersecting itself)"),
        "{message}"
    );

    let message = overlapping_bodies(&beam, &y, &[0; 3])
        .unwrap_err()
        .to_string();
    assert!(message.contains("has length 3"), "{message}");
}

#[test]
fn shortest_rest_edge_is_the_grid_spacing() {
    let mesh = TetMesh::box_grid(
        nalgebra::Vector3::zeros(),
        nalgebra::Vector3::new(0.4, 0.3, 0.2),
        [4, 3, 4],
        BoxSplit::Lecture6,
    )
    .unwrap();
    // Cells 0.1 × 0.1 × 0.05: the shortest surface edge is 0.05, up to the round-off of node
    // coordinates near 0.2 (a few 1e-17).
    let shortest = Surface::from_mesh(&mesh).unwrap().shortest_rest_edge();
    assert!((shortest - 0.05).abs() < 1e-15, "{shortest}");
}
