//! Friction in scenes (issue 18): a static block held on the ground by friction against a
//! lateral load (the summary's force on the ground is the load, its tangential part at most
//! μ·N), the same load above μ·N an error naming the load step, an explicit block thrown
//! along frictional ground that stops after Coulomb's slide distance v₀²/(2μg), and the
//! dynamic CSV's force on the ground with its friction part (sticking: the load's ratio;
//! sliding: μ), in backward Euler and explicit steps.

use std::path::PathBuf;

use tetfem::Error;
use tetfem_cli::scene::{DynamicOverrides, RunOptions, Scene, run_dynamic_scene, run_static_with};

const G: f64 = 9.81;
const MU: f64 = 0.5;

/// A 0.1 m rubber cube (E = 1 MPa, ν = 0.3, ρ = 1000 kg/m³, 2×2×2 cells) with no support, its
/// bottom `ground` (m, < 0) above frictional ground — within the activation distance
/// (d̂ = 1e-3 × the diagonal = 1.73e-4 m), so the barrier and friction hold it from the start;
/// `analysis` and `gravity` as given.
fn block(gravity: [f64; 3], ground: f64, analysis: &str, output: &str) -> String {
    format!(
        r#"
[mesh.box]
max = [0.1, 0.1, 0.1]
cells = [2, 2, 2]

[material]
youngs_modulus = 1e6
poisson_ratio = 0.3
density = 1000.0

[[loads]]
gravity = {gravity:?}

[[probes]]
name = "top"
where = {{ plane = {{ axis = "z", at = 0.1 }} }}

[analysis]
{analysis}

[[obstacles]]
kind = "half_space"
name = "ground"
point = [0.0, 0.0, {ground}]
normal = [0.0, 0.0, 1.0]
friction = {MU}

{output}
"#
    )
}

fn no_files() -> RunOptions {
    RunOptions {
        no_files: true,
        ..Default::default()
    }
}

#[test]
fn a_static_block_is_held_by_friction_below_mu_n_and_not_above() {
    let weight = 1000.0 * 0.001 * G;
    let scene: Scene = block([0.3 * G, 0.0, -G], -8.66e-5, "model = \"corotational\"", "")
        .parse()
        .unwrap();
    let summary = run_static_with(&scene, &no_files()).unwrap();
    let forces = summary.contact_forces.expect("a scene with obstacles");
    let [fx, fy, fz] = forces[0].force_n;
    // The block is held by the ground alone: the force on it is the load's resultant, up to
    // what Newton leaves, Σ|r_i| ≤ √n·‖r‖ ≤ √n·1e-10·‖f‖ (or the round-off floor 1e-6·‖f‖
    // that its convergence test accepts): √n·1e-6·W bounds both.
    let bound = (summary.free_dofs as f64).sqrt() * 1e-6 * weight;
    println!("force on the ground ({fx}, {fy}, {fz}) N; load (0.3·W, 0, −W), W = {weight} N");
    assert!(
        (fx - 0.3 * weight).abs() <= bound,
        "{fx} vs {}",
        0.3 * weight
    );
    assert!(fy.abs() <= bound && (fz + weight).abs() <= bound);
    // Friction carries at most μ·N (each node's μ·λᵢ·f₁ ≤ μ·λᵢ).
    assert!(fx.hypot(fy) <= MU * fz.abs() * (1.0 + 1e-12));

    let scene: Scene = block([0.7 * G, 0.0, -G], -8.66e-5, "model = \"corotational\"", "")
        .parse()
        .unwrap();
    match run_static_with(&scene, &no_files()) {
        Err(Error::Solver(message)) => {
            assert!(
                message.contains("no static equilibrium with friction at load step"),
                "{message}"
            )
        }
        other => panic!("expected an error naming the load step, got {other:?}"),
    }
}

#[test]
fn an_explicit_block_thrown_along_frictional_ground_stops_after_coulombs_distance() {
    let dir: PathBuf = crate::common::scratch_dir("contact_friction_scenes", "explicit");
    let _ = std::fs::remove_dir_all(&dir);
    let v0 = 0.3;
    // dt = 1.5e-4 s, about a fifth of the critical step (7.2e-4 s; the barrier's own stable
    // step at the resting gap is larger, see tests/core/contact_friction.rs); stiffness damping
    // β = 2e-4 s (damping ratio ≤ 0.3 at the highest mode) quiets the ringing of the start
    // without slowing a rigid slide (K_T·v = 0 for a translation). 0.1 s: the slide lasts
    // v₀/(μg) = 0.061 s.
    let analysis = format!(
        "type = \"dynamic\"\nmethod = \"explicit\"\ndt = 1.5e-4\nduration = 0.1\nmodel = \"corotational\"\n\
         damping = {{ mass = 0.0, stiffness = 2e-4 }}\ninitial_velocity = [{v0}, 0.0, 0.0]"
    );
    let output = format!(
        "[output]\ndirectory = \"{}\"\nvtu = false\ncsv = true",
        dir.display()
    );
    let scene: Scene = block([0.0, 0.0, -G], -1.25e-4, &analysis, &output)
        .parse()
        .unwrap();
    let summary = run_dynamic_scene(
        &scene,
        &DynamicOverrides::default(),
        true,
        false,
        &mut |_, _| std::ops::ControlFlow::Continue(()),
    )
    .unwrap();
    let csv = summary
        .files
        .iter()
        .find(|f| f.extension().is_some_and(|e| e == "csv"))
        .expect("a CSV");
    let text = std::fs::read_to_string(csv).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let column = header
        .iter()
        .position(|h| h.starts_with("top") && h.contains("ux"))
        .unwrap_or_else(|| panic!("no top x column in {header:?}"));
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect();
    let slid = rows.last().unwrap()[column];
    let expected = v0 * v0 / (2.0 * MU * G);
    println!("slid {slid:.5e} m, Coulomb v₀²/(2μg) = {expected:.5e} m");
    // The slide decelerates at μ·g while the ground carries the weight. The block starts near
    // the gap where the barrier's pressure κ·|b′(d)| carries it (d ≈ 0.72·d̂ = 1.25e-4 m for
    // κ = E/h ≈ 1.7e7 Pa/m): the settling that is left, the lumped areas' uneven share of the
    // weight and the top's rocking (the probe is the top's mean) shift the distance by a few
    // per cent (measured −1.3 %; −5.2 % from 0.5·d̂, where the start pushes 3.5× the weight):
    // 5 % allowed.
    assert!((slid / expected - 1.0).abs() < 0.05, "{slid} vs {expected}");
}

#[test]
fn a_slip_distance_or_velocity_not_above_zero_is_an_error_naming_the_key() {
    for (key, value) in [("slip_distance", "0.0"), ("slip_velocity", "-1e-4")] {
        let text = block(
            [0.0, 0.0, -G],
            -8.66e-5,
            "",
            &format!("[contact]\n{key} = {value}"),
        );
        let result = text
            .parse::<Scene>()
            .and_then(|s| run_static_with(&s, &no_files()).map(|_| ()));
        match result {
            Err(Error::Scene { key: got, line, .. }) => {
                assert_eq!(got, format!("contact.{key}"));
                // The [contact] table's span: its header or its key line.
                let header = text.lines().position(|l| l == "[contact]").unwrap() + 1;
                assert!((header..=header + 1).contains(&line), "line {line}");
            }
            other => panic!("{key} = {value}: expected a scene error, got {other:?}"),
        }
    }
}

/// Runs `analysis` on the block under `gravity` with a CSV, and returns per row the time (s)
/// and the force on the ground, (t, F_x, F_z) (N).
fn ground_force_rows(name: &str, gravity: [f64; 3], analysis: &str) -> Vec<(f64, f64, f64)> {
    let dir: PathBuf = crate::common::scratch_dir("contact_friction_scenes", name);
    let _ = std::fs::remove_dir_all(&dir);
    let output = format!(
        "[output]\ndirectory = \"{}\"\nvtu = false\ncsv = true",
        dir.display()
    );
    let scene: Scene = block(gravity, -1.25e-4, analysis, &output).parse().unwrap();
    let summary = run_dynamic_scene(
        &scene,
        &DynamicOverrides::default(),
        true,
        false,
        &mut |_, _| std::ops::ControlFlow::Continue(()),
    )
    .unwrap();
    let csv = summary
        .files
        .iter()
        .find(|f| f.extension().is_some_and(|e| e == "csv"))
        .expect("a CSV");
    let text = std::fs::read_to_string(csv).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let column = |name: &str| {
        header
            .iter()
            .position(|h| *h == name)
            .unwrap_or_else(|| panic!("no {name} in {header:?}"))
    };
    let (t, fx, fz) = (
        column("time_s"),
        column("contact_ground_fx_N"),
        column("contact_ground_fz_N"),
    );
    let _ = std::fs::remove_dir_all(&dir);
    lines
        .map(|l| {
            let v: Vec<&str> = l.split(',').collect();
            (
                v[t].parse().unwrap(),
                v[fx].parse().unwrap(),
                v[fz].parse().unwrap(),
            )
        })
        .collect()
}

/// The mean of F_x/(−F_z) over the rows with t in `window` (s).
fn mean_ratio(rows: &[(f64, f64, f64)], window: std::ops::Range<f64>) -> f64 {
    let inside: Vec<f64> = rows
        .iter()
        .filter(|(t, _, _)| window.contains(t))
        .map(|&(_, fx, fz)| fx / -fz)
        .collect();
    assert!(!inside.is_empty(), "no rows in {window:?}");
    inside.iter().sum::<f64>() / inside.len() as f64
}

/// The CSV's force on the ground includes friction in dynamics: under a lateral load of
/// 0.3·W (below μ·W) the block sticks and the ground carries F_x/(−F_z) = 0.3, the load's
/// ratio; under 0.8·W it slides and friction carries F_x/(−F_z) = μ. Backward Euler.
#[test]
fn a_backward_euler_block_on_frictional_ground_reports_its_friction_force() {
    // dt = 1 ms, 0.3 s: the start's settling has decayed (backward Euler damps the barrier's
    // ringing), and the sliding block has passed ε_v (1.7e-4 m/s) within a few steps.
    let analysis = "type = \"dynamic\"\nmethod = \"backward_euler\"\ndt = 1e-3\nduration = 0.3\n\
                    model = \"corotational\"";
    for (lateral, expected) in [(0.3, 0.3), (0.8, MU)] {
        let rows = ground_force_rows(
            &format!("tetfem_contact_friction_force_{lateral}"),
            [lateral * G, 0.0, -G],
            analysis,
        );
        let ratio = mean_ratio(&rows, 0.1..0.31);
        println!("lateral {lateral}·W: F_x/(−F_z) = {ratio:.6} (expected {expected})");
        // Measured 0.300436 and 0.499966: what is left of the start's settling, and friction's
        // normal forces lagged at each step's start while F_z is the barrier's at its end.
        // Without the friction force F_x would be ~0; 1 % separates the two by far.
        assert!((ratio - expected).abs() < 0.01 * expected, "{ratio}");
    }
}

/// The same in explicit steps, whose friction is an impulse per node: while the thrown block
/// slides, F_x/(−F_z) = μ.
#[test]
fn an_explicit_sliding_block_reports_its_friction_force() {
    // As in the thrown-block test above: a fifth of the critical step, stiffness damping for
    // the start's ringing; the slide lasts v₀/(μg) = 0.061 s.
    let analysis = "type = \"dynamic\"\nmethod = \"explicit\"\ndt = 1.5e-4\nduration = 0.05\n\
                    model = \"corotational\"\ndamping = { mass = 0.0, stiffness = 2e-4 }\n\
                    initial_velocity = [0.3, 0.0, 0.0]";
    let rows = ground_force_rows(
        "tetfem_contact_friction_force_explicit",
        [0.0, 0.0, -G],
        analysis,
    );
    let ratio = mean_ratio(&rows, 0.01..0.05);
    println!("explicit slide: F_x/(−F_z) = {ratio:.6} (μ = {MU})");
    // Measured 0.499893: each sliding node's impulse removes exactly dt·μ·λᵢ of momentum, λᵢ
    // at the step's start while F_z is at its end (the rocking of the slide); 1 % as above.
    assert!((ratio - MU).abs() < 0.01 * MU, "{ratio}");
}
