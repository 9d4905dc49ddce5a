//! Misleading successes (issue 15, item 5): input that used to run "fine" and give a wrong or
//! meaningless answer now gives an error or a warning naming the culprit.

use std::path::Path;

use nalgebra::Vector3;
use tetfem::base::warning::Warning;
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

/// The amplitude warnings of a scene (issue 33), with the load of `amplitude` on the free end.
fn amplitude_warnings(analysis: &str, amplitude: &str) -> Vec<Warning> {
    let text = BASE.replace("[analysis]\ntype = \"static\"\n", analysis);
    let load = TIP_LOAD.replace(
        "\ntotal_force",
        &format!("\namplitude = {amplitude}\ntotal_force"),
    );
    Scene::parse(&format!("{text}{CLAMP}{load}"), "inline", Path::new("."))
        .unwrap()
        .build()
        .unwrap()
        .warnings()
}

const DYNAMIC: &str = "[analysis]\ntype = \"dynamic\"\ndt = 1e-3\nduration = 0.5\n";

/// Misleading successes of issue 33: an amplitude zero over the whole run (a table after the
/// run's times, a 0 Hz sine, a ramp starting after it) ran "fine" with the load never acting;
/// a sine far above 1/dt was sampled into an aliased load; a static scene took a time-varying
/// amplitude at t = 1 s without saying so. Each is now a warning naming the key; an amplitude
/// that acts within the run, at a resolvable frequency, gives none.
#[test]
fn amplitudes_that_never_act_or_alias_are_warnings_naming_the_key() {
    let key = "loads[0].amplitude";
    for zero in [
        "{ table = [[1.0, 0.0], [2.0, 1.0]] }",
        "{ table = [[-2.0, 1.0], [-1.0, 0.0]] }",
        "{ sine = { frequency_hz = 0.0 } }",
        "{ ramp = { start = 0.6, end = 1.0 } }",
    ] {
        let warnings = amplitude_warnings(DYNAMIC, zero);
        let expected = Warning::AmplitudeVanishes {
            key: key.into(),
            from: 0.0,
            to: 0.5,
        };
        assert_eq!(warnings, vec![expected.clone()], "{zero}");
        let text = expected.to_string();
        assert!(
            text.contains("loads[0].amplitude is 0 over the whole run (t = 0 to 0.5 s)"),
            "{text}"
        );
    }
    // 2 kHz at dt = 1 ms: half a sample per period.
    let aliased = amplitude_warnings(DYNAMIC, "{ sine = { frequency_hz = 2000.0 } }");
    assert_eq!(
        aliased,
        vec![Warning::AliasedAmplitude {
            key: key.into(),
            frequency_hz: 2000.0,
            dt: 1e-3
        }]
    );
    assert!(
        aliased[0]
            .to_string()
            .contains("Nyquist frequency 1/(2·dt) = 500 Hz"),
        "{}",
        aliased[0]
    );
    for fine in [
        "{ table = [[0.0, 0.0], [0.25, 1.0]] }",
        "{ sine = { frequency_hz = 50.0 } }",
        "{ ramp = { start = 0.4, end = 1.0 } }",
    ] {
        assert_eq!(amplitude_warnings(DYNAMIC, fine), vec![], "{fine}");
    }
    // A static scene takes the ramp at t = 1 s, where it is 0.25.
    let sampled = amplitude_warnings(
        "[analysis]\ntype = \"static\"\n",
        "{ ramp = { start = 0.0, end = 4.0 } }",
    );
    assert_eq!(
        sampled,
        vec![Warning::StaticAmplitude {
            key: key.into(),
            time: 1.0,
            value: 0.25
        }]
    );
    assert!(
        sampled[0]
            .to_string()
            .contains("at t = 1 s, where it is 0.25"),
        "{}",
        sampled[0]
    );
    let constant = amplitude_warnings("[analysis]\ntype = \"static\"\n", "{ constant = 2.0 }");
    assert_eq!(constant, vec![]);
}
