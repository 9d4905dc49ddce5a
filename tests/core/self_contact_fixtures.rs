//! Surfaces the self-contact tests share: two blocks near each other (body–body) and a beam
//! folded over onto itself (self-contact), as node positions and their contact surface.

use std::f64::consts::PI;

use nalgebra::{Rotation3, Vector3};
use tetfem::contact::surface::Surface;
use tetfem::{BoxSplit, CellType, Tet10, TetMesh};

use crate::common::Rng;

/// Two 0.1 m blocks of `cells`³ cells: A at [0, 0.1]³, B above it turned by 0.4 rad about z and
/// tilted by `tilt` rad about x, its lowest node `gap` above A's top; node ids of B follow A's.
pub fn two_blocks(cells: usize, gap: f64, tilt: f64) -> (Surface, Vec<Vector3<f64>>) {
    two_of(&block(cells), gap, tilt)
}

/// [`two_blocks`] of 10-node tets (contact on the quadratic faces' linear sub-triangles).
pub fn two_quadratic_blocks(cells: usize, gap: f64, tilt: f64) -> (Surface, Vec<Vector3<f64>>) {
    two_of(
        &TetMesh::<Tet10>::from_linear(&block(cells)).unwrap(),
        gap,
        tilt,
    )
}

fn block(cells: usize) -> TetMesh {
    TetMesh::box_grid(
        Vector3::zeros(),
        Vector3::repeat(0.1),
        [cells; 3],
        BoxSplit::Lecture6,
    )
    .unwrap()
}

fn two_of<C: CellType>(mesh: &TetMesh<C>, gap: f64, tilt: f64) -> (Surface, Vec<Vector3<f64>>) {
    let base = Surface::from_mesh(mesh).unwrap();
    let n = mesh.node_count();
    let turn = Rotation3::from_euler_angles(tilt, 0.0, 0.4);
    let centre = Vector3::repeat(0.05);
    let mut upper: Vec<Vector3<f64>> = mesh.nodes().iter().map(|x| turn * (x - centre)).collect();
    let lowest = upper.iter().map(|x| x.z).fold(f64::INFINITY, f64::min);
    for x in &mut upper {
        *x += Vector3::new(0.05, 0.05, 0.1 + gap - lowest);
    }
    let mut positions = mesh.nodes().to_vec();
    positions.extend(upper);
    let mut triangles = base.triangles().to_vec();
    triangles.extend(base.triangles().iter().map(|t| t.map(|k| k + n)));
    (
        Surface::from_triangles(triangles, &positions).unwrap(),
        positions,
    )
}

/// A 1 × 0.1 × 0.1 m beam of `cells` × 2 × 2 cells bent, from x = 0.45, around a half circle of
/// radius `radius` (centreline) and back over itself: the inner faces of the two straight
/// halves are 2·radius − 0.1 apart. Returns the surface (rest = the straight beam) and the
/// folded positions.
pub fn folded_beam(cells: usize, radius: f64) -> (Surface, Vec<Vector3<f64>>) {
    let mesh = TetMesh::box_grid(
        Vector3::zeros(),
        Vector3::new(1.0, 0.1, 0.1),
        [cells, 2, 2],
        BoxSplit::Lecture6,
    )
    .unwrap();
    let surface = Surface::from_mesh(&mesh).unwrap();
    let a = 0.45;
    let positions = mesh
        .nodes()
        .iter()
        .map(|x| {
            let offset = x.z - 0.05;
            let s = x.x;
            let (c, n) = if s <= a {
                ([s, 0.0], [0.0, 1.0])
            } else if s <= a + PI * radius {
                let theta = (s - a) / radius;
                (
                    [a + radius * theta.sin(), radius - radius * theta.cos()],
                    [-theta.sin(), theta.cos()],
                )
            } else {
                ([a - (s - a - PI * radius), 2.0 * radius], [0.0, -1.0])
            };
            Vector3::new(c[0] + offset * n[0], x.y, c[1] + offset * n[1])
        })
        .collect();
    (surface, positions)
}

/// Moves every position by a random vector in [−size, size)³.
pub fn jitter(positions: &mut [Vector3<f64>], size: f64, seed: u64) {
    let mut rng = Rng::new(seed);
    for x in positions {
        *x += rng.vector(-size, size);
    }
}
