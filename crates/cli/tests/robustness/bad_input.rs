//! The catalogue of bad input: one test per entry, each answered by a specific `Error` variant
//! whose fields (and message) name the culprit — or, for input that is valid but suspect, by a
//! specific `Warning`.

use std::path::Path;

use nalgebra::Vector3;
use tetfem::analysis::dynamics::{
    LinearSystem, MassKind, Method, Rayleigh, State, check_time_step,
};
use tetfem::base::warning::Warning;
use tetfem::mesh::BoxSplit;
use tetfem::{Constraints, Error, Loads, Material, TetMesh, solve_static};
use tetfem_cli::scene::Scene;

fn v(x: f64, y: f64, z: f64) -> Vector3<f64> {
    Vector3::new(x, y, z)
}

/// The unit corner tet's nodes.
fn corner_nodes() -> Vec<Vector3<f64>> {
    vec![v(0., 0., 0.), v(1., 0., 0.), v(0., 1., 0.), v(0., 0., 1.)]
}

fn material() -> Material {
    Material::new(1e5, 0.3, 1000.0).unwrap()
}

fn bar() -> TetMesh {
    TetMesh::box_grid(v(0., 0., 0.), v(4., 1., 1.), [4, 1, 1], BoxSplit::Lecture6).unwrap()
}

fn clamped(mesh: &TetMesh) -> Constraints {
    let mut constraints = Constraints::new(mesh);
    constraints
        .fix_nodes(&mesh.nodes_on_plane(0, 0.0, 1e-9))
        .unwrap();
    constraints
}

#[test]
fn degenerate_tet_is_rejected_with_its_index_and_quality() {
    let mut nodes = corner_nodes();
    nodes.push(v(1., 1., 0.)); // coplanar with nodes 0, 1, 2
    let err = TetMesh::new(nodes, vec![[0, 1, 2, 3], [0, 1, 2, 4]]).unwrap_err();
    match &err {
        Error::DegenerateTet {
            tet: 1,
            nodes: [0, 1, 2, 4],
            quality,
            ..
        } => assert_eq!(*quality, 0.0),
        other => panic!("expected DegenerateTet for tet 1, got {other:?}"),
    }
    assert!(err.to_string().contains("tet 1"), "{err}");
}

#[test]
fn sliver_tet_is_degenerate_below_the_threshold_and_warned_about_above_it() {
    // The corners of a unit square, two opposite ones lifted by `h`: a sliver (no short edge,
    // almost no volume). V = h/3 and l_max = √2, so the shape quality 6√2·V/l_max³ = h.
    let sliver = |h: f64| vec![v(0., 0., 0.), v(1., 0., h), v(1., 1., 0.), v(0., 1., h)];
    match TetMesh::new(sliver(1e-12), vec![[0, 1, 2, 3]]) {
        Err(Error::DegenerateTet {
            tet: 0, quality, ..
        }) => assert!(quality < 1e-10),
        other => panic!("expected DegenerateTet, got {other:?}"),
    }
    // h = 1e-3 is a valid but poor element: a warning naming it, with its dihedral angle.
    let mesh = TetMesh::new(sliver(1e-3), vec![[0, 1, 2, 3]]).unwrap();
    let warnings = mesh.warnings();
    match warnings.as_slice() {
        [
            Warning::PoorElements {
                count: 1,
                worst_tet: 0,
                worst_dihedral_deg,
                ..
            },
        ] => assert!(*worst_dihedral_deg < 1.0, "{worst_dihedral_deg}"),
        other => panic!("expected one PoorElements warning, got {other:?}"),
    }
}

#[test]
fn poor_elements_warning_states_the_critical_step_penalty() {
    // A bar of good tets with one node pushed nearly onto the plane of three neighbours: the
    // flattened tets have small altitudes, and the warning's factor is the ratio of the smallest
    // altitude to the median tet's.
    let mesh = bar();
    let mut nodes = mesh.nodes().to_vec();
    let good = mesh.warnings();
    assert!(
        good.is_empty(),
        "a regular box mesh has no warnings: {good:?}"
    );
    let (lo, hi) = (
        nodes.iter().map(|p| p.x).fold(f64::INFINITY, f64::min),
        nodes.iter().map(|p| p.x).fold(0.0, f64::max),
    );
    assert_eq!((lo, hi), (0.0, 4.0));
    // Node (1, 0, 0) moved to x = 1.97: the tets between x = 1 and 2 that use it shrink to 3 %
    // of their length along x.
    let moved = nodes
        .iter()
        .position(|p| (p - v(1., 0., 0.)).norm() < 1e-12)
        .unwrap();
    nodes[moved].x = 1.97;
    let distorted = TetMesh::new(nodes, mesh.tets().to_vec()).unwrap();
    let factor = distorted
        .warnings()
        .iter()
        .find_map(|w| match w {
            Warning::PoorElements { dt_factor, .. } => Some(*dt_factor),
            _ => None,
        })
        .expect("a PoorElements warning");
    assert!(factor < 0.1, "dt factor {factor}");
    let message = distorted.warnings()[0].to_string();
    assert!(message.contains("critical step"), "{message}");
}

#[test]
fn inverted_tet_overlapping_its_neighbour_is_rejected() {
    // Tets 0 and 1 share the face (0, 1, 2) and both lie above it: tet 1 is folded over tet 0.
    let mut nodes = corner_nodes();
    nodes.push(v(0.2, 0.2, 0.5));
    let mesh = TetMesh::new(nodes, vec![[0, 1, 2, 3], [0, 2, 1, 4]]).unwrap();
    let err = mesh.face_topology().unwrap_err();
    match &err {
        Error::InvertedTet {
            tet: 1,
            neighbour: 0,
            face: [0, 1, 2],
        } => {}
        other => panic!("expected InvertedTet, got {other:?}"),
    }
    assert!(err.to_string().contains("tets 1 and 0"), "{err}");
    // Every solver checks the topology before it assembles.
    let mut constraints = Constraints::new(&mesh);
    constraints.fix_nodes(&[0, 1, 2]).unwrap();
    let solved = solve_static(&mesh, &material(), &constraints, &Loads::new(&mesh));
    assert!(matches!(solved, Err(Error::InvertedTet { tet: 1, .. })));
}

#[test]
fn negatively_oriented_tets_alone_are_reoriented_with_a_warning_when_mixed() {
    let mesh = bar();
    let mut tets = mesh.tets().to_vec();
    tets[3].swap(0, 1);
    let reoriented = TetMesh::new(mesh.nodes().to_vec(), tets).unwrap();
    assert_eq!(reoriented.reoriented_count(), 1);
    assert!(
        reoriented.warnings().contains(&Warning::MixedOrientation {
            reoriented: 1,
            tets: mesh.tet_count()
        }),
        "{:?}",
        reoriented.warnings()
    );
    // Same volume and same solution as the original.
    assert!((reoriented.volume() - mesh.volume()).abs() < 1e-12);
}

#[test]
fn duplicate_tet_is_rejected_naming_both() {
    let mesh = bar();
    let mut tets = mesh.tets().to_vec();
    tets.push(tets[5]);
    let duplicated = TetMesh::new(mesh.nodes().to_vec(), tets).unwrap();
    let last = mesh.tet_count();
    match duplicated.face_topology() {
        Err(Error::DuplicateTet { first: 5, tet, .. }) => assert_eq!(tet, last),
        other => panic!("expected DuplicateTet, got {other:?}"),
    }
    // Also when the repeat is given with the other orientation (reoriented on construction).
    let mut single = vec![[0, 1, 2, 3], [0, 2, 1, 3]];
    single.rotate_left(0);
    let twice = TetMesh::new(corner_nodes(), single).unwrap();
    assert!(matches!(
        twice.face_topology(),
        Err(Error::DuplicateTet {
            first: 0,
            tet: 1,
            nodes: [0, 1, 2, 3]
        })
    ));
}

#[test]
fn unused_nodes_are_allowed_warned_about_and_left_out_of_the_solve() {
    let mesh = bar();
    let mut nodes = mesh.nodes().to_vec();
    nodes.push(v(10., 10., 10.));
    nodes.push(v(11., 10., 10.));
    let with_unused = TetMesh::new(nodes, mesh.tets().to_vec()).unwrap();
    assert_eq!(
        with_unused.warnings(),
        vec![Warning::UnusedNodes {
            count: 2,
            first: mesh.node_count()
        }]
    );
    // The solve ignores them: same tip displacement as without, and zero displacement there.
    let mut loads = Loads::new(&with_unused);
    loads
        .add_gravity(&with_unused, &material(), v(0., 0., -9.81))
        .unwrap();
    let solution = solve_static(&with_unused, &material(), &clamped(&with_unused), &loads).unwrap();
    let mut plain_loads = Loads::new(&mesh);
    plain_loads
        .add_gravity(&mesh, &material(), v(0., 0., -9.81))
        .unwrap();
    let plain = solve_static(&mesh, &material(), &clamped(&mesh), &plain_loads).unwrap();
    for (a, b) in plain.displacement.iter().zip(&solution.displacement) {
        // Same matrix, same ordering of the used DOFs: equal to round-off.
        assert!(
            (a - b).abs()
                <= 1e-12
                    * plain
                        .displacement
                        .iter()
                        .fold(0.0f64, |m, x| m.max(x.abs()))
        );
    }
    assert!(
        solution.displacement[3 * mesh.node_count()..]
            .iter()
            .all(|&u| u == 0.0)
    );
}

#[test]
fn out_of_range_node_index_in_a_tet_is_rejected() {
    match TetMesh::new(corner_nodes(), vec![[0, 1, 2, 7]]) {
        Err(Error::NodeIndexOutOfRange {
            tet: 0,
            node: 7,
            node_count: 4,
        }) => {}
        other => panic!("expected NodeIndexOutOfRange, got {other:?}"),
    }
}

#[test]
fn out_of_range_tet_index_is_an_error_not_a_panic() {
    let mesh = bar();
    let n = mesh.tet_count();
    assert!(matches!(
        mesh.element(n),
        Err(Error::UnknownTet { tet, tet_count, .. }) if tet == n && tet_count == n
    ));
    assert!(matches!(
        mesh.tet_positions(usize::MAX),
        Err(Error::UnknownTet { .. })
    ));
}

#[test]
fn repeated_node_in_a_tet_is_rejected() {
    match TetMesh::new(corner_nodes(), vec![[0, 1, 1, 3]]) {
        Err(Error::RepeatedNode {
            tet: 0, node: 1, ..
        }) => {}
        other => panic!("expected RepeatedNode, got {other:?}"),
    }
}

#[test]
fn non_finite_coordinates_are_rejected_naming_node_and_axis() {
    for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
        let mut nodes = corner_nodes();
        nodes[2].z = bad;
        match TetMesh::new(nodes, vec![[0, 1, 2, 3]]) {
            Err(Error::NonFiniteCoordinate {
                node: 2, axis: 2, ..
            }) => {}
            other => panic!("expected NonFiniteCoordinate for {bad}, got {other:?}"),
        }
    }
}

#[test]
fn non_finite_material_parameters_are_rejected() {
    for (e, nu, rho, field) in [
        (f64::NAN, 0.3, 1.0, "youngs_modulus"),
        (f64::INFINITY, 0.3, 1.0, "youngs_modulus"),
        (1.0, f64::NAN, 1.0, "poisson_ratio"),
        (1.0, 0.3, f64::NAN, "density"),
        (1.0, 0.3, f64::INFINITY, "density"),
    ] {
        match Material::new(e, nu, rho) {
            Err(Error::InvalidMaterial { field: f, .. }) => assert_eq!(f, field),
            other => panic!("expected InvalidMaterial({field}), got {other:?}"),
        }
    }
}

#[test]
fn non_finite_loads_are_rejected() {
    let mesh = bar();
    let mut loads = Loads::new(&mesh);
    let err = loads.add_nodal_force(3, v(0., f64::NAN, 0.)).unwrap_err();
    assert!(
        matches!(err, Error::InvalidParameter { ref name, .. } if name.contains("nodal force")),
        "{err}"
    );
    let err = loads
        .add_gravity(&mesh, &material(), v(0., 0., f64::INFINITY))
        .unwrap_err();
    assert!(err.to_string().contains("gravity"), "{err}");
    let end = mesh.faces_on_plane(&mesh.boundary_faces().unwrap(), 0, 4.0, 1e-9);
    let err = loads
        .add_traction(&mesh, &end, v(f64::NAN, 0., 0.))
        .unwrap_err();
    assert!(err.to_string().contains("traction"), "{err}");
    let err = loads
        .add_total_force_on_faces(&mesh, &end, v(0., 0., f64::NEG_INFINITY))
        .unwrap_err();
    assert!(err.to_string().contains("total force"), "{err}");
    // Nothing was added by the failed calls.
    assert!(loads.as_slice().iter().all(|&f| f == 0.0));
}

#[test]
fn non_finite_prescribed_displacement_is_rejected() {
    let mesh = bar();
    let mut constraints = Constraints::new(&mesh);
    let err = constraints.prescribe(2, v(0., f64::NAN, 0.)).unwrap_err();
    assert!(err.to_string().contains("node 2, axis 1"), "{err}");
}

#[test]
fn youngs_modulus_must_be_positive() {
    for e in [0.0, -1.0, -0.0] {
        assert!(matches!(
            Material::new(e, 0.3, 1.0),
            Err(Error::InvalidMaterial {
                field: "youngs_modulus",
                ..
            })
        ));
    }
}

#[test]
fn poisson_ratio_must_lie_in_the_open_interval_minus_one_to_one_half() {
    for nu in [-1.0, -1.5, 0.5, 0.7] {
        assert!(
            matches!(
                Material::new(1.0, nu, 1.0),
                Err(Error::InvalidMaterial {
                    field: "poisson_ratio",
                    ..
                })
            ),
            "ν = {nu}"
        );
    }
    // The ends just inside are valid.
    assert!(Material::new(1.0, -0.999, 1.0).is_ok());
    assert!(Material::new(1.0, 0.4999, 1.0).is_ok());
}

#[test]
fn density_must_be_positive() {
    for rho in [0.0, -7850.0] {
        assert!(matches!(
            Material::new(1.0, 0.3, rho),
            Err(Error::InvalidMaterial {
                field: "density",
                ..
            })
        ));
    }
}

#[test]
fn poisson_ratio_close_to_one_half_is_allowed_with_a_locking_warning() {
    let rubber = Material::new(1e6, 0.499, 1000.0).unwrap();
    match rubber.warnings().as_slice() {
        [
            w @ Warning::NearlyIncompressible {
                poisson_ratio,
                expected_loss,
            },
        ] => {
            assert_eq!(*poisson_ratio, 0.499);
            // ν = 0.499 is a point of the measured curve: its losses exactly.
            assert_eq!(*expected_loss, [0.38049, 0.002385]);
            assert!(w.to_string().contains("lock"), "{w}");
            assert!(w.to_string().contains("38.05 %"), "{w}");
        }
        other => panic!("expected NearlyIncompressible, got {other:?}"),
    }
    assert!(material().warnings().is_empty());
    // And it does lock: the tip deflection of a bent bar under ν = 0.499 is well below the
    // ν = 0.3 one scaled by beam theory's ν-independence (Euler–Bernoulli deflection depends on
    // E only), which is the effect the warning describes.
    let mesh = bar();
    let tip = |m: &Material| {
        let mut loads = Loads::new(&mesh);
        loads.add_gravity(&mesh, m, v(0., 0., -1.0)).unwrap();
        let s = solve_static(&mesh, m, &clamped(&mesh), &loads).unwrap();
        let node = mesh.nodes_on_plane(0, 4.0, 1e-9)[0];
        s.displacement[3 * node + 2] / m.density()
    };
    let soft = Material::new(1e6, 0.3, 1000.0).unwrap();
    let ratio = tip(&rubber) / tip(&soft);
    assert!(ratio < 0.9, "ν = 0.499 deflects {ratio} of ν = 0.3");
}

#[test]
fn constraint_on_a_node_that_does_not_exist_is_rejected() {
    let mesh = bar();
    let mut constraints = Constraints::new(&mesh);
    let n = mesh.node_count();
    match constraints.fix_nodes(&[0, n + 3]) {
        Err(Error::UnknownNode {
            node, node_count, ..
        }) => assert_eq!((node, node_count), (n + 3, n)),
        other => panic!("expected UnknownNode, got {other:?}"),
    }
    assert_eq!(constraints.count(), 0, "a failed call adds nothing");
    assert!(matches!(
        constraints.prescribe_axis(n, 0, 1.0),
        Err(Error::UnknownNode { .. })
    ));
}

#[test]
fn load_or_constraint_on_an_empty_set_is_rejected() {
    let mesh = bar();
    let nowhere = mesh.nodes_on_plane(0, 99.0, 1e-9);
    assert!(nowhere.is_empty());
    assert!(matches!(
        Constraints::new(&mesh).fix_nodes(&nowhere),
        Err(Error::EmptySelection { .. })
    ));
    let no_faces = mesh.faces_on_plane(&mesh.boundary_faces().unwrap(), 0, 99.0, 1e-9);
    let mut loads = Loads::new(&mesh);
    match loads.add_total_force_on_faces(&mesh, &no_faces, v(1., 0., 0.)) {
        Err(Error::EmptySelection { context }) => assert!(context.contains("force"), "{context}"),
        other => panic!("expected EmptySelection, got {other:?}"),
    }
    assert!(matches!(
        loads.add_traction(&mesh, &no_faces, v(1., 0., 0.)),
        Err(Error::EmptySelection { .. })
    ));
}

#[test]
fn unconstrained_body_is_rejected_with_six_free_modes() {
    let mesh = bar();
    let mut loads = Loads::new(&mesh);
    loads.add_nodal_force(0, v(1., 0., 0.)).unwrap();
    match solve_static(&mesh, &material(), &Constraints::new(&mesh), &loads) {
        Err(Error::NotConstrained {
            free_modes: 6,
            part_tets,
            ..
        }) => assert_eq!(part_tets, mesh.tet_count()),
        other => panic!("expected NotConstrained with 6 modes, got {other:?}"),
    }
}

#[test]
fn partially_constrained_body_is_rejected_with_the_modes_left() {
    let mesh = bar();
    let loads = Loads::new(&mesh);
    // One node clamped: the three rotations about it are free.
    let mut one_node = Constraints::new(&mesh);
    one_node.fix_nodes(&[0]).unwrap();
    assert!(matches!(
        solve_static(&mesh, &material(), &one_node, &loads),
        Err(Error::NotConstrained { free_modes: 3, .. })
    ));
    // A plane held only in x (rollers): y, z translations and the rotation about x are free.
    let mut rollers = Constraints::new(&mesh);
    rollers
        .fix_axes(&mesh.nodes_on_plane(0, 0.0, 1e-9), [true, false, false])
        .unwrap();
    assert!(matches!(
        solve_static(&mesh, &material(), &rollers, &loads),
        Err(Error::NotConstrained { free_modes: 3, .. })
    ));
    // Two nodes clamped: the rotation about the line through them is free.
    let mut two_nodes = Constraints::new(&mesh);
    two_nodes.fix_nodes(&[0, 1]).unwrap();
    assert!(matches!(
        solve_static(&mesh, &material(), &two_nodes, &loads),
        Err(Error::NotConstrained { free_modes: 1, .. })
    ));
}

fn system(mesh: &TetMesh) -> std::sync::Arc<LinearSystem> {
    std::sync::Arc::new(
        LinearSystem::new(
            mesh,
            &material(),
            &clamped(mesh),
            &Loads::new(mesh),
            v(0., 0., -9.81),
            MassKind::Lumped,
            Rayleigh::default(),
        )
        .unwrap(),
    )
}

#[test]
fn time_step_must_be_positive_and_finite_for_every_method() {
    let mesh = bar();
    let system = system(&mesh);
    for dt in [0.0, -1e-3, f64::NAN, f64::INFINITY] {
        assert!(check_time_step(dt).is_err(), "dt = {dt}");
        for method in [Method::BackwardEuler, Method::Newmark, Method::Explicit] {
            match method.integrator(system.clone(), dt) {
                Err(Error::InvalidParameter { name, .. }) => assert_eq!(name, "dt"),
                Err(other) => {
                    panic!("{method:?}, dt = {dt}: expected InvalidParameter(dt), got {other}")
                }
                Ok(_) => panic!("{method:?} accepted dt = {dt}"),
            }
        }
    }
    // And changing it later is checked too.
    let mut integrator = Method::Newmark.integrator(system, 1e-3).unwrap();
    assert!(integrator.set_time_step(-1.0).is_err());
    assert_eq!(integrator.time_step(), 1e-3);
}

#[test]
fn state_of_the_wrong_size_is_rejected_by_every_integrator() {
    let mesh = bar();
    let system = system(&mesh);
    for method in [Method::BackwardEuler, Method::Newmark, Method::Explicit] {
        let mut integrator = method.integrator(system.clone(), 1e-4).unwrap();
        let mut state = State::at_rest(system.free_count() + 1);
        match integrator.step(&mut state) {
            Err(Error::DimensionMismatch {
                expected, found, ..
            }) => assert_eq!(
                (expected, found),
                (system.free_count(), system.free_count() + 1)
            ),
            other => panic!("{method:?}: expected DimensionMismatch, got {other:?}"),
        }
    }
}

fn scene(text: &str) -> tetfem::Result<Scene> {
    Scene::parse(text, "<test>", Path::new("."))
}

const BASE: &str = r#"
[mesh.box]
min = [0.0, 0.0, 0.0]
max = [1.0, 0.2, 0.2]
cells = [5, 1, 1]

[material]
youngs_modulus = 1e5
poisson_ratio = 0.3
density = 1000.0

[[constraints]]
where = { plane = { axis = "x", at = 0.0 } }
"#;

/// Runs the base scene as a dynamic analysis with these `[analysis]` lines (no files written)
/// and checks that it fails with an error naming `key`.
fn assert_dynamic_scene_rejects(analysis: &str, key: &str) {
    let text = format!("{BASE}\n[analysis]\ntype = \"dynamic\"\n{analysis}\n");
    let result = scene(&text).and_then(|s| {
        tetfem_cli::scene::run_dynamic_scene(&s, &Default::default(), false, false, &mut |_, _| {
            std::ops::ControlFlow::Continue(())
        })
    });
    match result {
        Err(Error::Scene { key: k, .. }) => assert!(k.contains(key), "{analysis}: {k}"),
        Err(Error::InvalidParameter { name, .. }) => assert_eq!(name, key, "{analysis}"),
        other => panic!("{analysis}: expected an error naming {key}, got {other:?}"),
    }
}

#[test]
fn zero_or_negative_duration_is_rejected() {
    for duration in ["0.0", "-1.0"] {
        assert_dynamic_scene_rejects(
            &format!("method = \"backward_euler\"\ndt = 0.01\nduration = {duration}"),
            "duration",
        );
    }
}

#[test]
fn zero_or_negative_dt_in_a_scene_is_rejected() {
    for dt in ["0.0", "-0.01"] {
        assert_dynamic_scene_rejects(
            &format!("method = \"newmark\"\ndt = {dt}\nduration = 1.0"),
            "dt",
        );
    }
}

#[test]
fn empty_mesh_is_rejected() {
    assert!(matches!(
        TetMesh::new(Vec::new(), Vec::new()),
        Err(Error::EmptyMesh { nodes: 0, tets: 0 })
    ));
    assert!(matches!(
        TetMesh::new(corner_nodes(), Vec::new()),
        Err(Error::EmptyMesh { nodes: 4, tets: 0 })
    ));
}

#[test]
fn scene_key_with_the_wrong_type_names_key_and_line() {
    let text = BASE.replace("poisson_ratio = 0.3", "poisson_ratio = \"0.3\"");
    match scene(&text) {
        Err(Error::Scene { key, line, .. }) => {
            assert!(key.contains("poisson_ratio"), "{key}");
            let expected = text
                .lines()
                .position(|l| l.starts_with("poisson_ratio"))
                .unwrap()
                + 1;
            assert_eq!(line, expected);
        }
        other => panic!("expected a scene error, got {other:?}"),
    }
    let text = BASE.replace("cells = [5, 1, 1]", "cells = 5");
    assert!(matches!(scene(&text), Err(Error::Scene { key, .. }) if key.contains("cells")));
}

#[test]
fn oversized_box_grid_is_an_error_not_an_abort() {
    for cells in [
        [usize::MAX, 1, 1],
        [1 << 22, 1 << 22, 1 << 22],
        [1 << 40, 1, 1],
    ] {
        match TetMesh::box_grid(v(0., 0., 0.), v(1., 1., 1.), cells, BoxSplit::Five) {
            Err(Error::InvalidParameter { name, .. }) => assert_eq!(name, "cells"),
            other => panic!("{cells:?}: expected InvalidParameter(cells), got {other:?}"),
        }
    }
}

#[test]
fn generated_box_meshes_carry_no_warnings() {
    // The generator orients its mirrored cells itself, so that the mixed-orientation warning
    // stays meaningful for imported meshes.
    for split in [BoxSplit::Lecture6, BoxSplit::Five] {
        let mesh = TetMesh::box_grid(v(0., 0., 0.), v(2., 1., 1.), [4, 3, 2], split).unwrap();
        assert_eq!(mesh.reoriented_count(), 0, "{split:?}");
        assert!(
            mesh.warnings().is_empty(),
            "{split:?}: {:?}",
            mesh.warnings()
        );
    }
}

/// Issue 33: an initial velocity of 1e300 m/s wrote a NaN reaction field (blamed on ParaView)
/// instead of naming the input: ½·vᵀ·M·v overflows, and the run now stops before its first
/// frame with `Diverged` at step 0 naming the starting state and the initial velocity.
#[test]
fn an_initial_velocity_beyond_the_floating_point_range_is_named_at_step_0() {
    let text = format!(
        "{BASE}\n[analysis]\ntype = \"dynamic\"\nmethod = \"backward_euler\"\ndt = 0.01\n\
         duration = 0.1\ninitial_velocity = [0.0, 0.0, 1e300]\n"
    );
    let result = scene(&text).and_then(|s| {
        tetfem_cli::scene::run_dynamic_scene(&s, &Default::default(), false, false, &mut |_, _| {
            std::ops::ControlFlow::Continue(())
        })
    });
    match result {
        Err(err @ Error::Diverged { step: 0, .. }) => {
            let message = err.to_string();
            assert!(
                message.contains("starting state") && message.contains("initial velocity"),
                "{message}"
            );
        }
        other => panic!("expected Diverged at step 0, got {other:?}"),
    }
}

/// Issue 33: E = 1e-300 Pa under a 1e200 N load gave a `-inf` field blamed on ParaView (then
/// "linear solver: the solution is not finite"); u = K⁻¹f overflows, and the error now names
/// both scales and the inputs to check.
#[test]
fn loads_too_large_for_the_stiffness_name_both_scales_and_the_units() {
    let mesh = bar();
    let material = Material::new(1e-300, 0.3, 1000.0).unwrap();
    let mut loads = Loads::new(&mesh);
    for node in mesh.nodes_on_plane(0, 4.0, 1e-9) {
        loads.add_nodal_force(node, v(0., 0., -1e200)).unwrap();
    }
    match solve_static(&mesh, &material, &clamped(&mesh), &loads) {
        Err(err @ Error::InvalidParameter { .. }) => {
            let message = err.to_string();
            for word in ["loads up to 1e200", "Young's modulus", "units"] {
                assert!(message.contains(word), "no '{word}' in {message}");
            }
        }
        other => panic!("expected InvalidParameter, got {other:?}"),
    }
}
