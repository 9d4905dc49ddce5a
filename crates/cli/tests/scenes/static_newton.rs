//! Issue 33: a static scene solved by Newton (a nonlinear model or obstacles) takes its load
//! steps and Newton tolerance from `analysis.load_steps` and `analysis.newton_tolerance`
//! (before, both were fixed at 10 and 1e-10: a solve that failed could not be rescued), and
//! reports what the solve took; the keys are refused where no Newton runs.

use std::path::Path;

use tetfem::Error;
use tetfem_cli::scene::{RunOptions, RunSummary, Scene, run_static_with};

/// The rubber cantilever of `scenes/rubber_cantilever_large.toml` (corotational, a tip
/// deflection of 0.235 m on a 0.5 m beam), with `extra` lines in `[analysis]`.
fn rubber_cantilever(model: &str, extra: &str) -> tetfem::Result<Scene> {
    cantilever_analysis("static", model, extra)
}

/// [`rubber_cantilever`] with the analysis type `kind`.
fn cantilever_analysis(kind: &str, model: &str, extra: &str) -> tetfem::Result<Scene> {
    let text = format!(
        "[mesh.box]\nmax = [0.5, 0.05, 0.05]\ncells = [20, 2, 2]\nsplit = \"five\"\n\
         [material]\nyoungs_modulus = 5e6\npoisson_ratio = 0.45\ndensity = 1100.0\n\
         [[constraints]]\nwhere = {{ plane = {{ axis = \"x\", at = 0.0 }} }}\n\
         [[loads]]\nwhere = {{ plane = {{ axis = \"x\", at = 0.5 }} }}\n\
         total_force = [0.0, 0.0, -30.0]\n\
         [[probes]]\nname = \"tip\"\nwhere = {{ plane = {{ axis = \"x\", at = 0.5 }} }}\n\
         [analysis]\ntype = \"{kind}\"\nmodel = \"{model}\"\n{extra}\n"
    );
    Scene::parse(&text, "<test>", Path::new("."))
}

fn run(scene: &Scene) -> RunSummary {
    let options = RunOptions {
        no_files: true,
        ..RunOptions::default()
    };
    run_static_with(scene, &options).unwrap()
}

#[test]
fn load_steps_and_the_newton_tolerance_reach_the_static_solve() {
    let default = run(&rubber_cantilever("corotational", "").unwrap());
    let newton = default.newton.expect("a corotational solve is Newton's");
    assert_eq!((newton.load_steps, newton.tolerance), (10, 1e-10));
    assert!(default.relative_residual <= 1e-10);
    let tip = default.probes[0].displacement[2];

    let one = run(&rubber_cantilever("corotational", "load_steps = 1").unwrap());
    let one_newton = one.newton.unwrap();
    assert_eq!(one_newton.load_steps, 1);
    // One increment takes fewer iterations in all than ten (measured 20 against 74).
    assert!(
        one_newton.iterations < newton.iterations,
        "{one_newton:?} vs {newton:?}"
    );
    // Both stop at ‖r_f‖ ≤ 1e-10·‖f_f‖ on the same equilibrium; the tip's difference is that
    // residual through the tangent's compliance (measured 1.5e-13 relative), 1e-9 leaves the
    // condition number room.
    let difference = (one.probes[0].displacement[2] - tip).abs() / tip.abs();
    assert!(difference < 1e-9, "{difference:e}");

    // A loose tolerance is honoured and reported: the residual is below it.
    let loose = run(&rubber_cantilever("corotational", "newton_tolerance = 1e-3").unwrap());
    assert_eq!(loose.newton.unwrap().tolerance, 1e-3);
    assert!(
        loose.relative_residual <= 1e-3,
        "{}",
        loose.relative_residual
    );
    assert!(loose.newton.unwrap().iterations <= newton.iterations);
}

/// The error of a scene that must be refused, with the key it must name.
fn refused(scene: tetfem::Result<Scene>, key: &str) -> String {
    match scene {
        Err(Error::Scene {
            key: k, message, ..
        }) => {
            assert_eq!(k, format!("analysis.{key}"), "{message}");
            message
        }
        other => panic!("expected an error naming analysis.{key}, got {other:?}"),
    }
}

#[test]
fn the_static_newton_keys_are_refused_where_no_newton_runs_or_out_of_range() {
    // A linear static solve is one linear solve: neither key means anything there.
    let message = refused(rubber_cantilever("linear", "load_steps = 4"), "load_steps");
    assert!(message.contains("corotational"), "{message}");
    refused(
        rubber_cantilever("linear", "newton_tolerance = 1e-6"),
        "newton_tolerance",
    );
    for steps in ["0", "100001"] {
        let message = refused(
            rubber_cantilever("corotational", &format!("load_steps = {steps}")),
            "load_steps",
        );
        assert!(message.contains("1..=100000"), "{message}");
    }
    for tolerance in ["0.0", "1.0", "-1e-8", "nan"] {
        refused(
            rubber_cantilever("corotational", &format!("newton_tolerance = {tolerance}")),
            "newton_tolerance",
        );
    }
    // A dynamic analysis steps in time and has no load steps.
    let message = refused(
        cantilever_analysis(
            "dynamic",
            "corotational",
            "dt = 1e-3\nduration = 1e-2\nload_steps = 3",
        ),
        "load_steps",
    );
    assert!(message.contains("only a static analysis"), "{message}");
}
