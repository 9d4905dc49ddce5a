//! Bad contact input is an error naming the culprit (issue 18, "Bad input").

use nalgebra::Vector3;
use tetfem::contact::{Contact, ContactParameters, Obstacle};
use tetfem::{BoxSplit, TetMesh};

fn cube() -> TetMesh {
    TetMesh::box_grid(
        Vector3::zeros(),
        Vector3::repeat(1.0),
        [2, 2, 2],
        BoxSplit::Lecture6,
    )
    .unwrap()
}

fn parameters() -> ContactParameters {
    ContactParameters {
        activation_distance: 1e-3,
        stiffness: 1e6,
    }
}

#[test]
fn a_body_starting_inside_an_obstacle_names_its_nodes_and_distances() {
    // The plane z = 0.25 cuts the cube: the nine nodes of its base are 0.25 below it.
    let ground =
        Obstacle::half_space("ground", Vector3::new(0.0, 0.0, 0.25), Vector3::z()).unwrap();
    let message = Contact::new(&cube(), vec![ground], parameters())
        .unwrap_err()
        .to_string();
    assert!(message.contains("obstacle ground"), "{message}");
    assert!(message.contains("9 boundary nodes"), "{message}");
    assert!(message.contains("node 0 at -2.500e-1"), "{message}");
}

#[test]
fn zero_sizes_and_bad_friction_are_refused_by_name() {
    let zero_normal = Obstacle::half_space("floor", Vector3::zeros(), Vector3::zeros());
    assert!(
        zero_normal
            .unwrap_err()
            .to_string()
            .contains("floor: normal")
    );
    let zero_radius = Obstacle::sphere("ball", Vector3::zeros(), 0.0);
    assert!(
        zero_radius
            .unwrap_err()
            .to_string()
            .contains("ball: radius")
    );
    for mu in [-0.1, f64::NAN, f64::INFINITY] {
        let plane = Obstacle::half_space("floor", Vector3::zeros(), Vector3::z()).unwrap();
        let message = plane.with_friction(mu).unwrap_err().to_string();
        assert!(message.contains("floor: friction"), "{mu}: {message}");
    }
    let bad = ContactParameters {
        activation_distance: 0.0,
        stiffness: 1.0,
    };
    let plane = Obstacle::half_space("floor", Vector3::new(0.0, 0.0, -1.0), Vector3::z()).unwrap();
    let message = Contact::new(&cube(), vec![plane], bad)
        .unwrap_err()
        .to_string();
    assert!(message.contains("activation_distance"), "{message}");
}
