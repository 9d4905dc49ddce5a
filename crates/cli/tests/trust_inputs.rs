//! Misleading successes (issue 15, item 5): input that used to run "fine" and give a wrong or
//! meaningless answer now gives an error or a warning naming the culprit.

use std::path::Path;

use nalgebra::Vector3;
use tetfem::warning::Warning;
use tetfem::{BoxSplit, Constraints, Error, Loads, Material, TetMesh, solve_static};
use tetfem_cli::scene::{RunOptions, Scene, run_static_with};

fn bar() -> TetMesh {
    TetMesh::box_grid(
        Vector3::zeros(),
        Vector3::new(4.0, 1.0, 1.0),
        [8, 2, 2],
        BoxSplit::Lecture6,
    )
    .unwrap()
}

const BASE: &str = "title = \"t\"\n\
[mesh.box]\nmax = [4.0, 1.0, 1.0]\ncells = [4, 1, 1]\n\
[material]\nyoungs_modulus = 1e5\npoisson_ratio = 0.3\ndensity = 1000.0\n\
[analysis]\ntype = \"static\"\n";

const CLAMP: &str = "[[constraints]]\nwhere = { plane = { axis = \"x\", at = 0.0 } }\n";
const TIP_PROBE: &str =
    "[[probes]]\nname = \"tip\"\nwhere = { plane = { axis = \"x\", at = 4.0 } }\n";
const TIP_LOAD: &str =
    "[[loads]]\nwhere = { plane = { axis = \"x\", at = 4.0 } }\ntotal_force = [0.0, 0.0, -1.0]\n";

fn scene(extra: &str) -> Result<Scene, Error> {
    Scene::parse(&format!("{BASE}{extra}"), "inline", Path::new("."))
}

fn scene_error(extra: &str) -> (String, String) {
    let err = scene(extra)
        .and_then(|s| s.build().map(|_| ()))
        .unwrap_err();
    match err {
        Error::Scene { key, message, .. } => (key, message),
        other => panic!("expected a scene error, got {other}"),
    }
}

#[test]
fn two_constraints_with_different_values_on_one_dof_are_an_error_naming_both() {
    let mesh = bar();
    let mut constraints = Constraints::new(&mesh);
    constraints.fix_axes(&[0], [true, false, false]).unwrap();
    // The same value again is consistent, not a conflict.
    constraints.prescribe_axis(0, 0, 0.0).unwrap();
    match constraints.prescribe_axis(0, 0, 0.01) {
        Err(Error::ConflictingConstraint {
            node: 0,
            axis: 0,
            first,
            second,
        }) => assert_eq!((first, second), (0.0, 0.01)),
        other => panic!("{other:?}"),
    }
    // The last did not win.
    assert_eq!(constraints.get(0), Some(0.0));
    let (key, message) = scene_error(&format!(
        "{CLAMP}[[constraints]]\nwhere = {{ plane = {{ axis = \"x\", at = 0.0 }} }}\n\
         displacement = [0.01, 0.0, 0.0]\n{TIP_LOAD}{TIP_PROBE}"
    ));
    assert_eq!(key, "constraints[1]");
    assert!(message.contains("constraints[0]"), "{message}");
}

#[test]
fn a_selection_tolerance_must_be_a_finite_non_negative_distance() {
    let mesh = bar();
    for bad in [-1e-9, f64::NAN, f64::INFINITY] {
        assert!(
            matches!(
                mesh.try_nodes_on_plane(0, 0.0, bad),
                Err(Error::InvalidParameter { .. })
            ),
            "{bad}"
        );
        let boundary = mesh.boundary_faces().unwrap();
        assert!(mesh.try_faces_on_plane(&boundary, 0, 0.0, bad).is_err());
    }
    assert_eq!(
        mesh.try_nodes_on_plane(0, 0.0, 0.0).unwrap(),
        mesh.nodes_on_plane(0, 0.0, 0.0)
    );
    for bad in ["-1.0", "nan", "inf"] {
        let (key, message) = scene_error(&format!(
            "[[constraints]]\nwhere = {{ plane = {{ axis = \"x\", at = 0.0, tolerance = {bad} }} }}\n\
             {TIP_LOAD}{TIP_PROBE}"
        ));
        assert_eq!(key, "constraints[0].where.plane", "{bad}");
        assert!(message.contains("tolerance"), "{bad}: {message}");
    }
}

#[test]
fn duplicate_probe_names_are_an_error_naming_both() {
    let (key, message) = scene_error(&format!("{CLAMP}{TIP_LOAD}{TIP_PROBE}{TIP_PROBE}"));
    assert_eq!(key, "probes[1].name");
    assert!(
        message.contains("probes[0]") && message.contains("'tip'"),
        "{message}"
    );
}

#[test]
fn a_load_on_constrained_dofs_only_is_a_warning_naming_it() {
    let on_clamp = "[[loads]]\nwhere = { plane = { axis = \"x\", at = 0.0 } }\ntotal_force = [0.0, 0.0, -1.0]\n";
    let built = scene(&format!("{CLAMP}{TIP_LOAD}{on_clamp}{TIP_PROBE}"))
        .unwrap()
        .build()
        .unwrap();
    let warnings = built.warnings();
    let hits: Vec<&Warning> = warnings
        .iter()
        .filter(|w| matches!(w, Warning::LoadOnFixedDofs { .. }))
        .collect();
    // loads[1] sits on the clamped face (4 nodes of the 4×1×1 grid, only their z DOF
    // loaded); loads[0], on the free end, does not.
    assert_eq!(
        hits,
        vec![&Warning::LoadOnFixedDofs {
            load: "loads[1]".into(),
            dofs: 4
        }]
    );
}

#[test]
fn a_scene_with_no_free_dof_is_a_warning() {
    let all = "[[constraints]]\nwhere = \"all\"\n";
    let built = scene(&format!("{all}{TIP_LOAD}{TIP_PROBE}"))
        .unwrap()
        .build()
        .unwrap();
    assert!(
        built.warnings().contains(&Warning::NoFreeDofs {
            dofs: built.mesh.dof_count()
        }),
        "{:?}",
        built.warnings()
    );
    let built = scene(&format!("{CLAMP}{TIP_LOAD}{TIP_PROBE}"))
        .unwrap()
        .build()
        .unwrap();
    assert!(built.warnings().is_empty(), "{:?}", built.warnings());
}

fn clamped_bar_solve(poisson_ratio: f64) -> tetfem::Result<tetfem::StaticSolution> {
    let mesh = bar();
    let material = Material::new(200e9, poisson_ratio, 7850.0).unwrap();
    let mut constraints = Constraints::new(&mesh);
    constraints
        .fix_nodes(&mesh.nodes_on_plane(0, 0.0, 1e-9))
        .unwrap();
    let mut loads = Loads::new(&mesh);
    let end = mesh.faces_on_plane(&mesh.boundary_faces().unwrap(), 0, 4.0, 1e-9);
    loads
        .add_total_force_on_faces(&mesh, &end, Vector3::new(0.0, 0.0, -1e3))
        .unwrap();
    solve_static(&mesh, &material, &constraints, &loads)
}

#[test]
fn an_inaccurate_direct_solve_is_an_error_naming_the_residual_and_the_cause() {
    // ν = 0.4999999999: λ/μ = 5e9, κ(K) far beyond 1e8; the Cholesky solve used to return a
    // relative residual of order 1e-4 as a success.
    match clamped_bar_solve(0.4999999999) {
        Err(Error::InaccurateSolve {
            relative_residual,
            limit,
            cause,
            ..
        }) => {
            assert!(relative_residual > limit && limit == 1e-8);
            assert!(cause.contains("0.4999999999"), "{cause}");
        }
        other => panic!("{other:?}"),
    }
    // An ordinary material stays far below the limit (κ·1e-16 with κ ~ 1e4 here).
    let ok = clamped_bar_solve(0.3).unwrap();
    assert!(ok.relative_residual < 1e-10, "{}", ok.relative_residual);
}

#[test]
fn a_tiny_displacement_is_reported_not_rounded_to_zero() {
    // A load of 1e-290 N: |u| ~ 1e-292 m, whose square underflows to 0. The summary used to
    // print max |u| = 0 next to a probe reading 1e-292.
    let tiny = "[[loads]]\nwhere = { plane = { axis = \"x\", at = 4.0 } }\n\
                total_force = [0.0, 0.0, -1e-290]\n";
    let options = RunOptions {
        no_files: true,
        ..RunOptions::default()
    };
    let summary = run_static_with(
        &scene(&format!("{CLAMP}{tiny}{TIP_PROBE}")).unwrap(),
        &options,
    )
    .unwrap();
    let probe = summary.probes[0].displacement[2].abs();
    assert!(probe > 0.0);
    // The largest nodal |u| is at least the tip's mean |u_z| (a mean of |u| ≥ |u_z| values).
    assert!(
        summary.max_displacement >= probe,
        "max |u| = {} < probe {probe}",
        summary.max_displacement
    );
}
