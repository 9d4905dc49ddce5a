//! A moving obstacle in a static scene (issue 33): `displacement` (optionally with `amplitude`)
//! moves it over the static step's pseudo-time t ∈ [0, 1], load step k of n at t = k/n; the
//! summary's force on it balances the base's reaction; a press too far for its load steps is
//! an error naming `load_steps`.

use tetfem::Error;
use tetfem_cli::scene::{RunOptions, RunSummary, Scene, run_static_with};

/// Young's modulus (Pa) of the column; ν = 0, so a uniform press is uniaxial.
const E: f64 = 1e6;
/// The column's cross-section area (m²).
const AREA: f64 = 0.01;
/// The column's height (m).
const HEIGHT: f64 = 0.4;

/// A 0.1 × 0.1 × 0.4 m column (2×2×8 cells, linear model, ν = 0) fixed at its base z = 0,
/// under a rigid plate 1e-4 m above its top (within d̂ = 4.24e-4 m) moved by `motion`,
/// solved in `load_steps`; a probe on the top face.
fn column(motion: &str, load_steps: usize) -> String {
    format!(
        r#"
[mesh.box]
max = [0.1, 0.1, {HEIGHT}]
cells = [2, 2, 8]

[material]
youngs_modulus = {E}
poisson_ratio = 0.0
density = 1000.0

[[constraints]]
where = {{ plane = {{ axis = "z", at = 0.0 }} }}
fix = ["x", "y", "z"]

[[probes]]
name = "top"
where = {{ plane = {{ axis = "z", at = {HEIGHT} }} }}

[analysis]
load_steps = {load_steps}

[[obstacles]]
kind = "half_space"
name = "plate"
point = [0.0, 0.0, 0.4001]
normal = [0.0, 0.0, -1.0]
{motion}
"#
    )
}

fn run(text: &str) -> tetfem::base::error::Result<RunSummary> {
    let scene: Scene = text.parse()?;
    run_static_with(
        &scene,
        &RunOptions {
            no_files: true,
            ..Default::default()
        },
    )
}

/// The force on the plate (N, z), the base's reaction (N, z) and the top's mean u_z (m).
fn press_numbers(summary: &RunSummary) -> (f64, f64, f64) {
    let plate = summary.contact_forces.as_ref().expect("obstacles")[0].force_n[2];
    let base = summary.reactions.as_ref().expect("reactions")[0].force_n[2];
    let top = summary.probes[0].displacement[2];
    (plate, base, top)
}

#[test]
fn a_plate_moved_down_in_a_static_scene_presses_the_column() {
    // 2 mm down over 4 load steps (each 0.5 mm, a few stages): no amplitude, so a ramp from
    // 0 at t = 0 to 1 at t = 1, the whole displacement at the last load step.
    let summary = run(&column("displacement = [0.0, 0.0, -0.002]", 4)).unwrap();
    let (plate, base, top) = press_numbers(&summary);
    let newton = summary.newton.expect("a Newton solve");
    println!(
        "plate force {plate:.6e} N, base reaction {base:.6e} N, top ū_z {top:.6e} m, {} load steps, {} Newton iterations",
        newton.load_steps, newton.iterations
    );
    assert_eq!(newton.load_steps, 4);
    // The force on the plate is what the base carries (the element forces sum to zero): up to
    // Σ|r_i| ≤ √n·‖r‖; Newton stops each stage at 1e-10 of a reference of at most a few
    // times the plate's force (the residual right after a stage's move), or at the round-off
    // floor 1e-6 of it: √n·1e-6·F bounds both.
    let bound = (summary.free_dofs as f64).sqrt() * 1e-6 * plate.abs();
    assert!((plate - base).abs() <= bound, "{plate} vs {base}");
    // The plate ends 2 mm − 0.1 mm = 1.9 mm below the top's rest height, the top below it by
    // a gap in (0, d̂): −1.9 mm − d̂ < ū_z < −1.9 mm.
    let d_hat = 1e-3 * (0.1f64.powi(2) * 2.0 + HEIGHT * HEIGHT).sqrt();
    assert!(top < -1.9e-3 && top > -1.9e-3 - d_hat, "{top}");
    // Uniaxial (ν = 0): F = E·A·|u|/L for a uniform top; the top nodes' gaps differ by a
    // fraction of d̂, a 2 % spread of u at 2 mm (tests/core/contact_static_moving.rs measures the
    // bracket exactly): 3 %.
    let expected = E * AREA * top.abs() / HEIGHT;
    println!(
        "E·A·|ū|/L = {expected:.6e} N, ratio {:.6}",
        plate / expected
    );
    assert!((plate / expected - 1.0).abs() < 0.03);
}

#[test]
fn an_amplitude_is_taken_at_the_load_steps_pseudo_time() {
    // A ramp from t = 0 to t = 0.5: the plate is down 2 mm from load step 2 of 4 on, and the
    // frictionless elastic end state is the one without amplitude (path-independent), to
    // Newton's tolerance.
    let (full, ..) = press_numbers(&run(&column("displacement = [0.0, 0.0, -0.002]", 4)).unwrap());
    let early = run(&column(
        "displacement = [0.0, 0.0, -0.002]\namplitude = { ramp = { start = 0.0, end = 0.5 } }",
        4,
    ))
    .unwrap();
    let (plate, ..) = press_numbers(&early);
    println!("reached at t = 0.5: {plate:.9e} N; at t = 1: {full:.9e} N");
    // Both stop within √n·1e-6·F of the same equilibrium (see the test above).
    let bound = 2.0 * (early.free_dofs as f64).sqrt() * 1e-6 * full;
    assert!((plate - full).abs() <= bound, "{plate} vs {full}");
    // A table down 2 mm at t = 0.5 and back to 1 mm at t = 1: the end is the 1 mm press,
    // about half the force (the gap is a smaller part of 2 mm than of 1 mm).
    let back = run(&column(
        "displacement = [0.0, 0.0, -0.002]\namplitude = { table = [[0.0, 0.0], [0.5, 1.0], [1.0, 0.5]] }",
        4,
    ))
    .unwrap();
    let (half, ..) = press_numbers(&back);
    let (direct, ..) =
        press_numbers(&run(&column("displacement = [0.0, 0.0, -0.001]", 2)).unwrap());
    println!("down 2 mm and back to 1 mm: {half:.9e} N; 1 mm directly: {direct:.9e} N");
    assert!((half - direct).abs() <= bound, "{half} vs {direct}");
    assert!(half < 0.6 * full && half > 0.4 * full);
}

#[test]
fn a_press_of_ten_percent_in_one_load_step_runs_and_equals_forty_load_steps() {
    // 40 mm (10 % strain) in one load step. Staged it needed ~2000 stages (an error: see
    // tests/core/contact_static_moving.rs); each load step now starts from the column's top
    // carried with the plate, and Newton solves it at once.
    let one = run(&column("displacement = [0.0, 0.0, -0.04]", 1)).unwrap();
    let forty = run(&column("displacement = [0.0, 0.0, -0.04]", 40)).unwrap();
    let ((plate, base, _), (staged, ..)) = (press_numbers(&one), press_numbers(&forty));
    println!("40 mm in 1 load step: {plate:.9e} N (base {base:.9e} N); in 40: {staged:.9e} N");
    // A linear body on a frictionless plate has one equilibrium; both stop within √n·1e-6·F
    // of it (see the first test), and the plate's force is the base's reaction.
    let bound = 2.0 * (one.free_dofs as f64).sqrt() * 1e-6 * staged.abs();
    assert!((plate - staged).abs() <= bound, "{plate} vs {staged}");
    assert!((plate - base).abs() <= bound, "{plate} vs {base}");
}

#[test]
fn a_velocity_in_a_static_scene_is_refused_naming_displacement() {
    let text = column("velocity = [0.0, 0.0, -0.01]", 4);
    let line = text.lines().position(|l| l == "[[obstacles]]").unwrap() + 1;
    match text.parse::<Scene>() {
        Err(Error::Scene {
            key,
            line: at,
            message,
            ..
        }) => {
            println!("{key} (line {at}): {message}");
            assert_eq!(key, "obstacles[0].velocity");
            assert_eq!(at, line);
            assert!(message.contains("give displacement"), "{message}");
        }
        other => panic!("expected a scene error, got {other:?}"),
    }
}

#[test]
fn the_obstacles_file_has_the_plate_where_its_motion_ends() {
    let dir = crate::common::scratch_dir("static_moving_obstacle", "vtp");
    let _ = std::fs::remove_dir_all(&dir);
    let text = format!(
        "{}\n[output]\ndirectory = \"{}\"\n",
        column("displacement = [0.0, 0.0, -0.002]", 4),
        dir.display()
    );
    let scene: Scene = text.parse().unwrap();
    let summary = run_static_with(&scene, &RunOptions::default()).unwrap();
    let vtp = summary
        .files
        .iter()
        .find(|f| f.to_string_lossy().ends_with("_obstacles.vtp"))
        .expect("the obstacles' file");
    let xml = std::fs::read_to_string(vtp).unwrap();
    // The plate's tile: 4 points on its plane, which the motion took from z = 0.4001 m to
    // 0.4001 − 0.002 m at the pseudo-time t = 1 (the file's TimeValue).
    assert!(xml.contains(r#"Name="TimeValue" NumberOfTuples="1" format="ascii">1e0<"#));
    let points = xml.split("<Points>").nth(1).unwrap();
    let block = points.split('>').nth(1).unwrap().split('<').next().unwrap();
    let z: Vec<f64> = block
        .split_whitespace()
        .map(|v| v.parse::<f64>().unwrap())
        .skip(2)
        .step_by(3)
        .collect();
    println!("plate tile z: {z:?}");
    assert_eq!(z.len(), 4);
    // Round-off of 0.4001 − 0.002·a(1) and of the tile's placement: 1e-15 m.
    assert!(z.iter().all(|z| (z - 0.3981).abs() < 1e-15), "{z:?}");
}
