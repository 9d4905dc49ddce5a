//! Mesh generation and validation: the lecture's cube split, conformity, orientation, and the
//! errors for each kind of invalid input.

use nalgebra::Vector3;
use tetfem::fe::element::signed_volume;
use tetfem::mesh::{DEGENERATE_QUALITY, box_node_index};
use tetfem::{BoxSplit, Error, TetMesh};

fn unit_cube(split: BoxSplit) -> TetMesh {
    TetMesh::box_grid(
        Vector3::zeros(),
        Vector3::new(1.0, 1.0, 1.0),
        [1, 1, 1],
        split,
    )
    .unwrap()
}

#[test]
fn lecture_split_is_the_lecture_table() {
    let mesh = unit_cube(BoxSplit::Lecture6);
    // The lecture's table with corners 1 + ix + 2·iy + 4·iz, made 0-based; tets 4 and 5 are
    // negatively oriented as written, so the mesh stores them with nodes 2 and 3 swapped.
    let table = [
        [1, 2, 4, 8],
        [1, 2, 8, 5],
        [2, 8, 5, 6],
        [1, 3, 4, 7],
        [1, 7, 8, 5],
        [1, 8, 4, 7],
    ];
    for (t, row) in table.iter().enumerate() {
        let mut expected = row.map(|c| c - 1);
        let as_written = expected.map(|c| mesh.nodes()[c]);
        if signed_volume(&as_written) < 0.0 {
            assert!(
                t == 3 || t == 4,
                "only tets 4 and 5 are negative as written"
            );
            expected.swap(1, 2);
        }
        assert_eq!(mesh.tets()[t], expected, "tet {}", t + 1);
    }
}

#[test]
fn cube_splits_fill_the_cell_exactly() {
    for split in [BoxSplit::Lecture6, BoxSplit::Five] {
        let mesh = unit_cube(split);
        let mut total = 0.0;
        for t in 0..mesh.tet_count() {
            let v = signed_volume(&mesh.tet_positions(t).unwrap());
            assert!(v > 0.0, "{split:?} tet {t} not positively oriented");
            total += v;
        }
        // Volumes are sums of products of 0/1 coordinates: exact up to one rounding.
        assert!(
            (total - 1.0).abs() < 1e-15,
            "{split:?}: volumes sum to {total}"
        );
        // The 6-tet split has six tets of volume 1/6, the 5-tet split a central tet of 1/3.
        let expected = if split == BoxSplit::Lecture6 { 6 } else { 5 };
        assert_eq!(mesh.tet_count(), expected);
    }
}

#[test]
fn box_meshes_are_conforming() {
    for split in [BoxSplit::Lecture6, BoxSplit::Five] {
        for cells in [[1, 1, 1], [2, 1, 1], [3, 2, 1], [2, 3, 4], [5, 4, 3]] {
            let size = Vector3::new(2.0, 1.5, 0.7);
            let mesh = TetMesh::box_grid(
                Vector3::new(-1.0, 0.0, 0.5),
                Vector3::new(-1.0, 0.0, 0.5) + size,
                cells,
                split,
            )
            .unwrap();
            let [nx, ny, nz] = cells;
            // A face shared by three tets would be an error here.
            let topology = mesh.face_topology().unwrap();
            // Conforming: the boundary is exactly the box surface, two triangles per cell face,
            // and every other face is shared by exactly two tets.
            let expected_boundary = 4 * (nx * ny + ny * nz + nz * nx);
            assert_eq!(
                topology.boundary.len(),
                expected_boundary,
                "{split:?} {cells:?}"
            );
            assert_eq!(
                topology.boundary.len() + 2 * topology.neighbours.len(),
                4 * mesh.tet_count()
            );
            // Outward orientation: the area vectors of a closed surface sum to zero, and each
            // points away from the box centre.
            let centre = Vector3::new(-1.0, 0.0, 0.5) + size / 2.0;
            let mut sum = Vector3::zeros();
            let mut area = 0.0;
            for f in &topology.boundary {
                let a = f.area_vector(&mesh).unwrap();
                assert!(a.dot(&(f.centroid(&mesh).unwrap() - centre)) > 0.0);
                sum += a;
                area += a.norm();
            }
            assert!(sum.norm() < 1e-12 * area);
            let surface = 2.0 * (size.x * size.y + size.y * size.z + size.z * size.x);
            assert!((area - surface).abs() < 1e-12 * surface);
            assert!((mesh.volume() - size.x * size.y * size.z).abs() < 1e-12);
        }
    }
}

#[test]
fn node_numbering_and_selection() {
    let cells = [4, 3, 2];
    let mesh = TetMesh::box_grid(
        Vector3::zeros(),
        Vector3::new(4.0, 3.0, 2.0),
        cells,
        BoxSplit::Lecture6,
    )
    .unwrap();
    assert_eq!(mesh.node_count(), 5 * 4 * 3);
    let n = box_node_index(cells, 3, 2, 1);
    assert_eq!(mesh.nodes()[n], Vector3::new(3.0, 2.0, 1.0));
    let face = mesh.nodes_on_plane(0, 0.0, 1e-12);
    assert_eq!(face.len(), 4 * 3);
    assert!(face.iter().all(|&i| mesh.nodes()[i].x == 0.0));
    let inside = mesh.nodes_in_box(Vector3::new(0.5, 0.5, 0.5), Vector3::new(3.5, 2.5, 1.5));
    assert_eq!(inside.len(), 3 * 2);
    let boundary = mesh.boundary_faces().unwrap();
    assert_eq!(
        mesh.faces_on_plane(&boundary, 2, 2.0, 1e-12).len(),
        2 * 4 * 3
    );
}

#[test]
fn negative_tets_are_reoriented() {
    let nodes = vec![Vector3::zeros(), Vector3::x(), Vector3::y(), Vector3::z()];
    let mesh = TetMesh::new(nodes, vec![[0, 2, 1, 3]]).unwrap();
    assert_eq!(mesh.tets()[0], [0, 1, 2, 3]);
    assert!((mesh.volume() - 1.0 / 6.0).abs() < 1e-16);
}

fn tet_nodes() -> Vec<Vector3<f64>> {
    vec![
        Vector3::zeros(),
        Vector3::x(),
        Vector3::y(),
        Vector3::z(),
        Vector3::new(1.0, 1.0, 1.0),
    ]
}

#[test]
fn index_out_of_range_is_an_error() {
    let err = TetMesh::new(tet_nodes(), vec![[0, 1, 2, 3], [1, 2, 3, 9]]).unwrap_err();
    assert!(
        matches!(
            err,
            Error::NodeIndexOutOfRange {
                tet: 1,
                node: 9,
                node_count: 5
            }
        ),
        "{err}"
    );
}

#[test]
fn repeated_node_is_an_error() {
    let err = TetMesh::new(tet_nodes(), vec![[0, 1, 2, 1]]).unwrap_err();
    assert!(
        matches!(
            err,
            Error::RepeatedNode {
                tet: 0,
                node: 1,
                ..
            }
        ),
        "{err}"
    );
}

#[test]
fn non_finite_coordinate_is_an_error() {
    let mut nodes = tet_nodes();
    nodes[3].y = f64::NAN;
    let err = TetMesh::new(nodes.clone(), vec![[0, 1, 2, 3]]).unwrap_err();
    assert!(
        matches!(
            err,
            Error::NonFiniteCoordinate {
                node: 3,
                axis: 1,
                ..
            }
        ),
        "{err}"
    );
    nodes[3].y = f64::INFINITY;
    assert!(matches!(
        TetMesh::new(nodes, vec![[0, 1, 2, 3]]),
        Err(Error::NonFiniteCoordinate { .. })
    ));
}

#[test]
fn degenerate_tet_is_an_error() {
    let mut nodes = tet_nodes();
    // Flat to 1e-12 of the edge length: quality ~1e-12, below the 1e-10 threshold.
    nodes[3] = Vector3::new(0.3, 0.3, 1e-12);
    let err = TetMesh::new(nodes.clone(), vec![[0, 1, 2, 3]]).unwrap_err();
    match err {
        Error::DegenerateTet {
            tet: 0,
            quality,
            threshold,
            ..
        } => {
            assert!(quality < threshold);
            assert_eq!(threshold, DEGENERATE_QUALITY);
        }
        other => panic!("unexpected {other}"),
    }
    // Just above the threshold the tet is poor but accepted.
    nodes[3] = Vector3::new(0.3, 0.3, 1e-8);
    assert!(TetMesh::new(nodes, vec![[0, 1, 2, 3]]).is_ok());
}

#[test]
fn empty_mesh_is_an_error() {
    assert!(matches!(
        TetMesh::new(tet_nodes(), vec![]),
        Err(Error::EmptyMesh { tets: 0, .. })
    ));
    assert!(matches!(
        TetMesh::new(vec![], vec![]),
        Err(Error::EmptyMesh { nodes: 0, .. })
    ));
}

#[test]
fn face_shared_by_three_tets_is_an_error() {
    let mut nodes = tet_nodes();
    nodes.push(Vector3::new(0.2, 0.2, -1.0));
    nodes.push(Vector3::new(0.2, 0.2, 2.0));
    // Three tets on face (0, 1, 2): an overlapping, non-conforming mesh.
    let mesh = TetMesh::new(nodes, vec![[0, 1, 2, 3], [0, 1, 2, 5], [0, 1, 2, 6]]).unwrap();
    assert!(matches!(
        mesh.face_topology(),
        Err(Error::NonManifoldFace {
            face: [0, 1, 2],
            ..
        })
    ));
}

#[test]
fn bad_box_parameters_are_errors() {
    let one = Vector3::new(1.0, 1.0, 1.0);
    assert!(TetMesh::box_grid(Vector3::zeros(), one, [0, 1, 1], BoxSplit::Lecture6).is_err());
    assert!(TetMesh::box_grid(one, Vector3::zeros(), [1, 1, 1], BoxSplit::Lecture6).is_err());
    assert!(
        TetMesh::box_grid(
            Vector3::zeros(),
            Vector3::new(f64::NAN, 1.0, 1.0),
            [1, 1, 1],
            BoxSplit::Five
        )
        .is_err()
    );
}
