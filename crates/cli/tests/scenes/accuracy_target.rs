//! `[analysis] accuracy = a`: the order and cells tetfem chooses for a box scene, the true error
//! of its choice, the DOF cap, file meshes, and bad values.

use std::path::Path;

use tetfem::base::error::Error;
use tetfem_cli::scene::{RunOptions, RunSummary, Scene, run_static_with};

/// The peer cantilever (`docs/src/quadratic.md`) (L = 10, W = H = 1, E = 1e5, ν = 0.3, end load 1) on `cells`
/// with `[mesh] order` and the extra `[analysis]` lines.
fn beam(cells: [usize; 3], order: usize, analysis: &str) -> Scene {
    beam_of(10.0, cells, order, 0.3, analysis)
}

/// [`beam`] of length `length` (the load at its end) with Poisson's ratio `poisson_ratio`.
fn beam_of(
    length: f64,
    cells: [usize; 3],
    order: usize,
    poisson_ratio: f64,
    analysis: &str,
) -> Scene {
    let text = format!(
        r#"title = "accuracy"
[mesh]
order = {order}
[mesh.box]
max = [{length}, 1.0, 1.0]
cells = [{}, {}, {}]
[material]
youngs_modulus = 1e5
poisson_ratio = {poisson_ratio}
density = 1000.0
[[constraints]]
where = {{ plane = {{ axis = "x", at = 0.0 }} }}
[[loads]]
where = {{ plane = {{ axis = "x", at = {length} }} }}
total_force = [0.0, 0.0, -1.0]
[analysis]
type = "static"
{analysis}
"#,
        cells[0], cells[1], cells[2]
    );
    Scene::parse(&text, "accuracy.toml", Path::new(".")).expect("valid scene")
}

fn run(scene: &Scene) -> RunSummary {
    run_static_with(
        scene,
        &RunOptions {
            no_files: true,
            ..Default::default()
        },
    )
    .expect("runs")
}

/// The compliance f·u_h = u_hᵀK u_h = ‖u_h‖_E² of a run (the clamp is homogeneous).
fn compliance(summary: &RunSummary) -> f64 {
    summary
        .estimated_error
        .as_ref()
        .expect("linear run")
        .energy_norm
        .powi(2)
}

#[test]
fn cantilever_target_picks_order_2_and_its_true_error_meets_it() {
    // Why order 2 is the right answer: at equal DOFs (567: P1 on 20×2×2, P2 on 10×1×1 — both
    // 21·3·3 nodes) the linear tets lock in bending and their estimate is several times the
    // quadratic one; at the a-priori rates (e ∝ N^(−p/3)) P1 then needs far more DOFs.
    let p1 = run(&beam([20, 2, 2], 1, ""));
    let p2 = run(&beam([10, 1, 1], 2, ""));
    assert_eq!(3 * p1.nodes, 3 * p2.nodes, "equal DOFs");
    let e1 = p1.estimated_error.as_ref().expect("estimate").relative;
    let e2 = p2.estimated_error.as_ref().expect("estimate").relative;
    println!(
        "equal DOFs {}: P1 estimate {e1:.4}, P2 {e2:.4}",
        3 * p1.nodes
    );
    // 3×: a margin under the measured ratio that already makes P1 need ≥ 3³ = 27× P2's
    // refinement in DOFs at its rate h¹ against h²; a ratio near 1 would make the choice unclear.
    assert!(e1 > 3.0 * e2, "P1 {e1} against P2 {e2}");

    let target = 0.05;
    let chosen = run(&beam([10, 1, 1], 1, &format!("accuracy = {target}")));
    let report = chosen.accuracy.as_ref().expect("accuracy report");
    for t in &report.trials {
        println!(
            "tried order {} cells {:?}: {} DOFs, estimate {:.4}, {:.3} s",
            t.order, t.cells, t.dofs, t.estimate, t.seconds
        );
    }
    println!("{}", report.reason);
    assert_eq!(report.order, 2, "{}", report.reason);
    assert!(report.met, "{}", report.reason);
    assert!(
        report.estimated_error <= target,
        "{}",
        report.estimated_error
    );
    // The summary's estimate is the reported run's.
    let estimate = chosen.estimated_error.as_ref().expect("estimate").relative;
    assert_eq!(estimate, report.estimated_error);
    // Every refinement stays within the ratio 2 per axis.
    let order2: Vec<_> = report.trials.iter().filter(|t| t.order == 2).collect();
    for w in order2.windows(2) {
        for axis in 0..3 {
            let ratio = w[1].cells[axis] as f64 / w[0].cells[axis] as f64;
            assert!(
                ratio > 1.0 && ratio <= 2.0,
                "{:?} → {:?}",
                w[0].cells,
                w[1].cells
            );
        }
    }

    // The true error: ‖u − u_h‖_E² = f·u − f·u_h (Galerkin orthogonality, a(v, v) = f(v) for u
    // and u_h), f·u by Richardson's extrapolation of the P2 compliances on 20×2×2, 40×4×4 and
    // 80×8×8 cells (as tests/core/error_estimate.rs of the root crate).
    let c: Vec<f64> = [2, 4, 8]
        .iter()
        .map(|&k| compliance(&run(&beam([10 * k, k, k], 2, ""))))
        .collect();
    let rate = ((c[1] - c[0]) / (c[2] - c[1])).log2();
    // The compliance's order is twice the energy norm's: between the clamp's singular limit
    // (≈ 1) and the smooth P2 value 4; outside, the levels are not asymptotic.
    assert!(rate > 1.0 && rate < 4.0, "observed order {rate}");
    let reference = c[2] + (c[2] - c[1]) / (2f64.powf(rate) - 1.0);
    let true_relative = ((reference - compliance(&chosen)) / reference).sqrt();
    let effectivity = estimate / true_relative;
    println!(
        "reference compliance {reference:.6e} (order {rate:.2}); chosen run: true error \
         {true_relative:.4}, estimate {estimate:.4}, effectivity {effectivity:.3}"
    );
    // The estimator's effectivity band measured on this cantilever for P1 and P2
    // (tests/core/error_estimate.rs): within it, an estimate ≤ target means a true error ≤ target/0.7.
    assert!(
        (0.7..=1.5).contains(&effectivity),
        "effectivity {effectivity}"
    );
    assert!(true_relative <= target / 0.7, "true error {true_relative}");
}

#[test]
fn unreachable_target_under_a_small_cap_is_reported_not_met() {
    let cap = 5000;
    let summary = run(&beam(
        [10, 1, 1],
        1,
        &format!("accuracy = 0.001\nmax_dofs = {cap}"),
    ));
    let report = summary.accuracy.as_ref().expect("accuracy report");
    println!("{}", report.reason);
    assert!(!report.met);
    assert!(report.estimated_error > 0.001, "{}", report.estimated_error);
    assert!(
        report.trials.iter().all(|t| t.dofs <= cap),
        "{:?}",
        report.trials
    );
    assert!(report.reason.contains("max_dofs"), "{}", report.reason);
    // The best estimate reached is the reported one: the lowest of the chosen order's trials.
    let best = report
        .trials
        .iter()
        .filter(|t| t.order == report.order)
        .map(|t| t.estimate)
        .fold(f64::INFINITY, f64::min);
    assert_eq!(best, report.estimated_error);
    assert!(
        summary.warnings.iter().any(|w| w.contains("not met")),
        "{:?}",
        summary.warnings
    );
}

#[test]
fn file_mesh_reports_whether_the_target_is_met() {
    let scenes = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes");
    let text = std::fs::read_to_string(scenes.join("l_bracket.toml"))
        .expect("scene")
        .replace("[output]", "[analysis]\naccuracy = 0.001\n[output]");
    let scene = Scene::parse(&text, "l_bracket.toml", &scenes).expect("valid scene");
    let summary = run(&scene);
    let report = summary.accuracy.as_ref().expect("accuracy report");
    println!("{} (estimate {:.4})", report.reason, report.estimated_error);
    // One solve of the mesh as given, whose estimate is the summary's.
    assert_eq!(report.trials.len(), 1);
    let estimate = summary.estimated_error.as_ref().expect("estimate").relative;
    assert_eq!(report.estimated_error, estimate);
    // A coarse bracket with a re-entrant corner is far from 0.1 %: not met, and the refinement
    // predicted to meet it is (e/a)^(1/1) per axis at order 1.
    assert!(!report.met);
    let predicted = &report.predictions[0];
    assert!((predicted.refinement - estimate / 0.001).abs() < 1e-9 * predicted.refinement);
    assert!(summary.warnings.iter().any(|w| w.contains("not met")));
}

/// The error of a scene with these `[analysis]` lines.
fn scene_error(analysis: &str) -> Error {
    let text = format!(
        "[mesh.box]\nmax = [1.0, 0.1, 0.1]\ncells = [4, 1, 1]\n[material]\nyoungs_modulus = \
         1e5\npoisson_ratio = 0.3\ndensity = 1.0\n[analysis]\n{analysis}\n"
    );
    Scene::parse(&text, "bad.toml", Path::new(".")).expect_err("refused")
}

#[test]
fn bad_accuracy_values_name_key_and_line() {
    // [analysis] is line 8, its first key line 9, the second line 10.
    for (lines, key, line) in [
        ("accuracy = 0.0", "analysis.accuracy", 9),
        ("accuracy = 1.0", "analysis.accuracy", 9),
        ("accuracy = -0.01", "analysis.accuracy", 9),
        ("accuracy = nan", "analysis.accuracy", 9),
        ("accuracy = \"1 %\"", "analysis.accuracy", 9),
        (
            "type = \"static\"\nmax_dofs = 100000",
            "analysis.max_dofs",
            10,
        ),
        ("accuracy = 0.01\nmax_dofs = 10", "analysis.max_dofs", 10),
        ("accuracy = 0.01\nmax_dofs = 2.5e5", "analysis.max_dofs", 10),
        ("type = \"modal\"\naccuracy = 0.01", "analysis.accuracy", 10),
    ] {
        match scene_error(lines) {
            Error::Scene {
                key: k,
                line: l,
                message,
                ..
            } => {
                assert_eq!((k.as_str(), l), (key, line), "{lines}: {message}");
            }
            other => panic!("{lines}: {other}"),
        }
    }
}

#[test]
fn nonlinear_model_chooses_its_mesh_by_its_own_estimate() {
    let summary = run(&beam(
        [10, 1, 1],
        1,
        "model = \"corotational\"\naccuracy = 0.3",
    ));
    let report = summary.accuracy.as_ref().expect("accuracy report");
    println!("{} ({})", report.reason, report.estimate_of);
    // Both orders are tried with the scene's own model on its cells.
    assert_eq!(
        report.trials[..2]
            .iter()
            .map(|t| t.order)
            .collect::<Vec<_>>(),
        [1, 2],
        "{:?}",
        report.trials
    );
    assert!(
        report.estimate_of.contains("corotational") && report.estimate_of.contains("Piola"),
        "{}",
        report.estimate_of
    );
    // The run reported is the corotational one on the cells and order chosen: its estimate
    // is the chosen trial's, bit for bit (the same run), and of the model itself.
    let estimate = summary.estimated_error.as_ref().expect("estimate");
    assert_eq!(
        estimate.definition,
        tetfem_cli::scene::MODEL_ESTIMATED_ERROR_DEFINITION
    );
    assert_eq!(estimate.relative, report.estimated_error);
    assert_eq!(report.met, report.estimated_error <= 0.3);
    assert!(report.met, "{}", report.reason);
}

/// The ZZ estimate does not see volumetric locking (a locked solution is smooth): at ν = 0.499
/// the 4-node tets lose 38 % of the displacement on the measured curve
/// (`tetfem::fe::locking`), so with a 30 % target the choice passes them over whatever their
/// predicted cost (on this unit cube sheared at its end the two orders' predicted times are
/// within the timer's noise of each other: either could win without the rule), and the 10-node
/// tets are chosen; the summary says why. What
/// makes the rule right here: the 4-node run's compliance at ν = 0.499 on the same cells is
/// more than 30 % below the 10-node run's (it is locked), although its estimate meets the
/// target.
#[test]
fn locking_passes_over_the_order_that_locks() {
    let (length, cells, target) = (1.0, [3, 3, 3], 0.3);
    let accuracy = format!("accuracy = {target}");
    let rubber = run(&beam_of(length, cells, 1, 0.499, &accuracy));
    let report = rubber.accuracy.as_ref().expect("accuracy report");
    println!("ν = 0.499: order {} ({})", report.order, report.reason);
    assert_eq!(report.order, 2);
    assert!(
        report.reason.contains("order 1 passed over"),
        "{}",
        report.reason
    );
    // ν = 0.499 is a point of the curve: the 10-node tets' loss there exactly.
    assert_eq!(report.locking_loss, 0.002385);
    assert!(
        rubber
            .warnings
            .iter()
            .all(|w| !w.starts_with("accuracy: the error estimate"))
    );

    let p1 = run(&beam_of(length, cells, 1, 0.499, ""));
    let p2 = run(&beam_of(length, cells, 2, 0.499, ""));
    let (e1, c1, c2) = (
        p1.estimated_error.as_ref().expect("estimate").relative,
        compliance(&p1),
        compliance(&p2),
    );
    println!("ν = 0.499 on {cells:?}: P1 estimate {e1:.3}, compliance P1 {c1:.4e}, P2 {c2:.4e}");
    assert!(e1 <= target, "the 4-node estimate meets the target: {e1}");
    assert!(
        c1 < (1.0 - target) * c2,
        "P1 compliance {c1} against P2 {c2}"
    );
}
