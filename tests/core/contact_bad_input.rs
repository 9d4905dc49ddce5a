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
        impact_fraction: None,
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
        impact_fraction: None,
    };
    let plane = Obstacle::half_space("floor", Vector3::new(0.0, 0.0, -1.0), Vector3::z()).unwrap();
    let message = Contact::new(&cube(), vec![plane], bad)
        .unwrap_err()
        .to_string();
    assert!(message.contains("activation_distance"), "{message}");
}

/// The impact fraction of the barrier stiffness (a fraction of d̂) is refused outside (0, 1),
/// by name and with the range, both by the builder and by a contact built from a literal;
/// the values inside are taken.
#[test]
fn a_bad_impact_fraction_is_refused_by_name() {
    for f in [0.0, 1.0, -0.5, 2.0, f64::NAN, f64::INFINITY] {
        let message = parameters()
            .with_impact_fraction(f)
            .unwrap_err()
            .to_string();
        assert!(message.contains("impact_fraction"), "{f}: {message}");
        assert!(message.contains("(0, 1)"), "{f}: {message}");
        let literal = ContactParameters {
            impact_fraction: Some(f),
            ..parameters()
        };
        let plane = Obstacle::half_space("floor", Vector3::new(0.0, 0.0, -1.0), Vector3::z());
        let message = Contact::new(&cube(), vec![plane.unwrap()], literal)
            .unwrap_err()
            .to_string();
        assert!(message.contains("impact_fraction"), "{f}: {message}");
    }
    for f in [1e-6, 0.25, 0.999] {
        let taken = parameters().with_impact_fraction(f).unwrap();
        assert_eq!(taken.impact_fraction, Some(f));
    }
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

/// A 0.1 m cube of 2×2×2 cells: boundary nodes 50 mm apart, so a small obstacle fits between
/// them.
fn coarse_cube() -> TetMesh {
    TetMesh::box_grid(
        Vector3::zeros(),
        Vector3::repeat(0.1),
        [2, 2, 2],
        BoxSplit::Lecture6,
    )
    .unwrap()
}

fn ball(center_z: f64) -> Obstacle {
    // R = 15 mm over the middle of a top-face quadrant, (25, 25) mm: the nearest top nodes are
    // 35.4 mm away sideways, so every node is outside whatever the height.
    Obstacle::sphere("ball", Vector3::new(0.025, 0.025, center_z), 0.015).unwrap()
}

#[test]
fn an_obstacle_reaching_into_a_face_between_its_nodes_is_refused_with_its_depth() {
    // Issue 33 item 7: the sphere reaches 5 mm below the top face z = 0.1 between nodes; the
    // node check alone accepted it and the body fell through with zero contact force.
    let message = Contact::new(&coarse_cube(), vec![ball(0.11)], parameters())
        .unwrap_err()
        .to_string();
    assert!(message.contains("obstacle ball"), "{message}");
    // The depth is R − (z_c − 0.1) = 15 − 10 mm, exactly 5 mm up to rounding.
    assert!(message.contains("5.000e-3 deep"), "{message}");
    assert!(message.contains("boundary face"), "{message}");
    assert!(message.contains("touching is allowed"), "{message}");
    // The same for a box reaching 5 mm into the face between nodes.
    let block = Obstacle::aligned_box(
        "block",
        Vector3::new(0.01, 0.01, 0.095),
        Vector3::new(0.04, 0.04, 0.2),
    )
    .unwrap();
    let message = Contact::new(&coarse_cube(), vec![block], parameters())
        .unwrap_err()
        .to_string();
    assert!(message.contains("obstacle block"), "{message}");
    assert!(message.contains("5.000e-3 deep"), "{message}");
}

#[test]
fn an_obstacle_wholly_inside_the_body_is_refused() {
    let inner = Obstacle::sphere("inner", Vector3::repeat(0.05), 0.015).unwrap();
    let message = Contact::new(&coarse_cube(), vec![inner], parameters())
        .unwrap_err()
        .to_string();
    assert!(message.contains("obstacle inner"), "{message}");
    assert!(message.contains("wholly inside the body"), "{message}");
    // Its surface is 50 − 15 mm below the nearest face.
    assert!(message.contains("at least 3.500e-2 below"), "{message}");
    let block =
        Obstacle::aligned_box("core", Vector3::repeat(0.04), Vector3::repeat(0.06)).unwrap();
    let message = Contact::new(&coarse_cube(), vec![block], parameters())
        .unwrap_err()
        .to_string();
    assert!(message.contains("obstacle core"), "{message}");
    assert!(message.contains("wholly inside the body"), "{message}");
}

#[test]
fn a_sphere_just_touching_or_just_outside_a_face_is_accepted() {
    // Tangent to the top face at (25, 25, 100) mm: depth 0 up to rounding, so accepted.
    Contact::new(&coarse_cube(), vec![ball(0.115)], parameters()).unwrap();
    // 1 µm above it.
    Contact::new(&coarse_cube(), vec![ball(0.115 + 1e-6)], parameters()).unwrap();
    // 1 µm into it is refused: the tolerance is rounding (1e-9 of the diagonal), not microns.
    let message = Contact::new(&coarse_cube(), vec![ball(0.115 - 1e-6)], parameters())
        .unwrap_err()
        .to_string();
    assert!(message.contains("1.000e-6 deep"), "{message}");
    // Far outside, and a box resting flat on the top face between the nodes (touching over
    // an area: every point of that patch computes to a gap of 0 up to rounding).
    Contact::new(&coarse_cube(), vec![ball(0.5)], parameters()).unwrap();
    let block = Obstacle::aligned_box(
        "block",
        Vector3::new(0.01, 0.01, 0.1),
        Vector3::new(0.04, 0.04, 0.2),
    )
    .unwrap();
    Contact::new(&coarse_cube(), vec![block], parameters()).unwrap();
}
