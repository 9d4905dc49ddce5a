//! Several bodies in one mesh (issue 36, item 1: `tetfem::mesh::Bodies`): placement, numbering,
//! per-body fields, and one DOF space in which bodies that share no node solve as if alone.

use std::f64::consts::FRAC_PI_2;

use nalgebra::{Rotation3, Vector3};
use tetfem::mesh::{Bodies, Placement};
use tetfem::{BoxSplit, Constraints, Loads, Material, TetMesh, solve_static};

fn beam() -> TetMesh {
    TetMesh::box_grid(
        Vector3::zeros(),
        Vector3::new(1.0, 0.2, 0.1),
        [8, 2, 1],
        BoxSplit::Mirrored6,
    )
    .unwrap()
}

/// The beam twice: as meshed, and turned a quarter about z then moved by (3, 1, 0.5) m.
fn two_beams() -> (Bodies, Placement) {
    let placed = Placement::translated(Vector3::new(3.0, 1.0, 0.5))
        .unwrap()
        .rotated(Vector3::z(), FRAC_PI_2)
        .unwrap();
    let bodies = Bodies::new(vec![(beam(), Placement::identity()), (beam(), placed)]).unwrap();
    (bodies, placed)
}

#[test]
fn bodies_are_numbered_one_after_the_other_and_placed_rigidly() {
    let (bodies, _) = two_beams();
    let one = beam();
    let (n, t) = (one.node_count(), one.tet_count());
    assert_eq!(bodies.count(), 2);
    assert_eq!(bodies.mesh().node_count(), 2 * n);
    assert_eq!(bodies.mesh().tet_count(), 2 * t);
    assert_eq!(bodies.node_range(1).unwrap(), n..2 * n);
    assert_eq!(bodies.tet_range(1).unwrap(), t..2 * t);
    // A quarter turn about z maps (x, y, z) to (−y, x, z); then + (3, 1, 0.5). Exact up to
    // the rotation matrix's round-off (cos(π/2) ≈ 6e-17): 1e-15 m on coordinates ≤ 3.2 m.
    for (k, x) in one.nodes().iter().enumerate() {
        let expected = Vector3::new(3.0 - x.y, 1.0 + x.x, 0.5 + x.z);
        assert!((bodies.mesh().nodes()[n + k] - expected).norm() < 1e-15);
        assert_eq!(bodies.mesh().nodes()[k], *x);
    }
    // Body 1's tets are body 0's shifted by n: the same cells, none reoriented (a rotation
    // keeps every orientation), and the volume twice the beam's (0.02 m³; round-off).
    for (a, b) in one.tets().iter().zip(&bodies.mesh().tets()[t..]) {
        assert_eq!(a.map(|v| v + n), *b);
    }
    assert_eq!(bodies.mesh().reoriented_count(), 0);
    assert!((bodies.mesh().volume() - 2.0 * one.volume()).abs() < 1e-14);
    let (tets, nodes) = (bodies.tet_bodies(), bodies.node_bodies());
    assert!(tets[..t].iter().all(|&b| b == 0) && tets[t..].iter().all(|&b| b == 1));
    assert!(nodes[..n].iter().all(|&b| b == 0) && nodes[n..].iter().all(|&b| b == 1));
}

#[test]
fn two_bodies_in_one_dof_space_solve_as_each_alone_turned_with_its_placement() {
    // Each beam clamped at its own x = 0 end and pulled and bent at its far end by the same
    // force in its own axes. Linear isotropic elasticity is equivariant under rotation, so
    // body 1's displacement is R·(body 0's) node by node; the bodies share no node, so the one
    // system is two. Tolerance: 1e-10 of the largest displacement (two Cholesky solves of the
    // same matrix up to a permutation of its DOFs' axes: round-off of ~1e4 × machine ε).
    let (bodies, placed) = two_beams();
    let one = beam();
    let n = one.node_count();
    let mesh = bodies.mesh();
    let clamp = one.nodes_on_plane(0, 0.0, 1e-12);
    let end = one.nodes_on_plane(0, 1.0, 1e-12);
    let mut constraints = Constraints::new(mesh);
    let clamped: Vec<usize> = clamp.iter().flat_map(|&k| [k, k + n]).collect();
    constraints.fix_nodes(&clamped).unwrap();
    let mut loads = Loads::new(mesh);
    let force = Vector3::new(50.0, 0.0, -20.0);
    for &k in &end {
        loads.add_nodal_force(k, force).unwrap();
        loads
            .add_nodal_force(k + n, placed.rotation * force)
            .unwrap();
    }
    let material = Material::new(1e7, 0.3, 1000.0).unwrap();
    let u = solve_static(mesh, &material, &constraints, &loads)
        .unwrap()
        .displacement;
    let rotation: Rotation3<f64> = placed.rotation;
    let largest = u.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    assert!(largest > 1e-6, "the load bends the beams: {largest}");
    for k in 0..n {
        let first = Vector3::new(u[3 * k], u[3 * k + 1], u[3 * k + 2]);
        let m = k + n;
        let second = Vector3::new(u[3 * m], u[3 * m + 1], u[3 * m + 2]);
        assert!(
            (second - rotation * first).norm() <= 1e-10 * largest,
            "node {k}: {second:?} vs R·{first:?}"
        );
    }
}

#[test]
fn each_body_gets_its_own_rigid_velocity() {
    let (bodies, _) = two_beams();
    let n = beam().node_count();
    let velocities = [Vector3::new(1.0, 0.0, 0.0), Vector3::new(0.0, -2.0, 0.5)];
    let v = bodies.velocity(&velocities).unwrap();
    assert_eq!(v.len(), 6 * n);
    for k in 0..2 * n {
        let expected = velocities[usize::from(k >= n)];
        assert_eq!(&v[3 * k..3 * k + 3], expected.as_slice());
    }
}

#[test]
fn bad_bodies_are_errors_naming_what_is_wrong() {
    let none: Vec<(TetMesh, Placement)> = Vec::new();
    let message = Bodies::new(none).unwrap_err().to_string();
    assert!(message.contains("bodies"), "{message}");
    let message = Placement::identity()
        .rotated(Vector3::zeros(), 1.0)
        .unwrap_err()
        .to_string();
    assert!(message.contains("rotation axis"), "{message}");
    let message = Placement::identity()
        .rotated(Vector3::x(), f64::NAN)
        .unwrap_err()
        .to_string();
    assert!(message.contains("rotation angle"), "{message}");
    let message = Placement::translated(Vector3::new(f64::INFINITY, 0.0, 0.0))
        .unwrap_err()
        .to_string();
    assert!(message.contains("translation"), "{message}");
    let (bodies, _) = two_beams();
    let message = bodies
        .velocity(&[Vector3::zeros()])
        .unwrap_err()
        .to_string();
    assert!(message.contains("one per body (2)"), "{message}");
    let message = bodies.node_range(2).unwrap_err().to_string();
    assert!(
        message.contains("body") && message.contains('2'),
        "{message}"
    );
}

#[test]
fn bodies_placed_into_each_other_are_refused_naming_both() {
    use tetfem::contact::surface::{Surface, overlapping_bodies};
    // The beam and a copy turned a quarter about z through its origin: they cross near the
    // origin (the copy spans x ∈ [−0.2, 0], y ∈ [0, 1]; the beam x ∈ [0, 1], y ∈ [0, 0.2]),
    // touching along the plane x = 0 — reported, as touching triangles are. Moved 0.5 m
    // along −x the copy is clear of the beam: no error.
    let turned = Placement::identity()
        .rotated(Vector3::z(), FRAC_PI_2)
        .unwrap();
    for (shift, overlaps) in [(0.0, true), (-0.5, false)] {
        let placed = Placement {
            translation: Vector3::new(shift, 0.0, 0.0),
            ..turned
        };
        let bodies = Bodies::new(vec![(beam(), Placement::identity()), (beam(), placed)]).unwrap();
        let surface = Surface::from_mesh(bodies.mesh()).unwrap();
        let result = overlapping_bodies(&surface, bodies.mesh().nodes(), &bodies.node_bodies());
        match overlaps {
            true => {
                let message = result.unwrap_err().to_string();
                assert!(message.contains("bodies 0 and 1"), "{message}");
            }
            false => result.unwrap(),
        }
    }
}
