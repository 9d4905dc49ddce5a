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

/// Issue 33: μ = 1e300 and an activation distance of 1e300 were accepted; both are refused with
/// the allowed range (μ up to 100; d̂ up to the body's bounding-box diagonal, √3 m here), and
/// the values at the ends of the ranges are taken.
#[test]
fn huge_friction_and_activation_distance_are_refused_with_the_range() {
    let plane =
        || Obstacle::half_space("floor", Vector3::new(0.0, 0.0, -0.1), Vector3::z()).unwrap();
    let message = plane().with_friction(1e300).unwrap_err().to_string();
    assert!(message.contains("floor: friction = 1e300"), "{message}");
    assert!(message.contains("between 0 and 100"), "{message}");
    assert!(plane().with_friction(100.0).is_ok());
    let far = ContactParameters {
        activation_distance: 1e300,
        ..parameters()
    };
    let message = Contact::new(&cube(), vec![plane()], far)
        .unwrap_err()
        .to_string();
    assert!(
        message.contains("contact activation_distance = 1e300"),
        "{message}"
    );
    assert!(
        message.contains("at most the body's bounding-box diagonal, 1.732"),
        "{message}"
    );
    let widest = ContactParameters {
        activation_distance: 1.7,
        ..parameters()
    };
    // The floor is 0.1 below the cube, inside d̂ = 1.7: accepted (the barrier acts at once).
    assert!(Contact::new(&cube(), vec![plane()], widest).is_ok());
}
