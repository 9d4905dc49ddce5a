//! `[[obstacles]]` in scenes: a block resting on the ground carries its weight through contact,
//! and bad obstacle keys are errors naming the key and line.

use tetfem::Error;
use tetfem_cli::scene::{RunOptions, Scene, run_static_with};

/// A 0.2 m rubber block (E = 100 kPa, ρ = 1000 kg/m³) under gravity over the ground z = −1e-4 m
/// (inside the default d̂ ≈ 3.5e-4 m, so the barrier acts from the start), held sideways only by
/// the symmetry planes x = 0 (ux) and y = 0 (uy): the ground alone carries the weight.
fn block_on_ground(model: &str, obstacle: &str) -> String {
    format!(
        r#"
[mesh.box]
max = [0.2, 0.2, 0.2]
cells = [4, 4, 4]

[material]
youngs_modulus = 1e5
poisson_ratio = 0.3
density = 1000.0

[[constraints]]
where = {{ plane = {{ axis = "x", at = 0.0 }} }}
fix = ["x"]

[[constraints]]
where = {{ plane = {{ axis = "y", at = 0.0 }} }}
fix = ["y"]

[[loads]]
gravity = [0.0, 0.0, -9.81]

[analysis]
model = "{model}"

[[obstacles]]
{obstacle}
"#
    )
}

const GROUND: &str =
    "kind = \"half_space\"\nname = \"ground\"\npoint = [0.0, 0.0, -1e-4]\nnormal = [0.0, 0.0, 1.0]";

#[test]
fn a_block_resting_on_the_ground_puts_its_weight_on_it() {
    for model in ["linear", "corotational"] {
        let scene: Scene = block_on_ground(model, GROUND).parse().unwrap();
        let options = RunOptions {
            no_files: true,
            ..Default::default()
        };
        let summary = run_static_with(&scene, &options).unwrap();
        let weight = 1000.0 * 9.81 * 0.2f64.powi(3);
        assert!((summary.applied_load_n[2] + weight).abs() < 1e-12 * weight);
        let json: serde_json::Value = serde_json::from_str(&summary.to_json()).unwrap();
        assert_eq!(json["units"]["contact_forces.force_n"], "N");
        assert_eq!(json["contact_forces"][0]["obstacle"], "ground");
        let forces = summary.contact_forces.expect("a scene with obstacles");
        assert_eq!(forces.len(), 1);
        assert_eq!(forces[0].obstacle, "ground");
        let [fx, fy, fz] = forces[0].force_n;
        // Σ over nodes of the z equations: internal forces sum to zero (a rigid translation
        // costs no energy), no z DOF is fixed, so |F_z − (−W)| = |Σ r_z| ≤ √n·‖r_f‖ and Newton
        // stops at ‖r_f‖ ≤ 1e-10·‖f_f‖ ≤ 1e-10·W (gravity's nodal loads share one sign).
        let bound = (summary.free_dofs as f64).sqrt() * 1e-10 * weight;
        assert!(
            (fz + weight).abs() <= bound,
            "{model}: contact force {fz} N against the weight {weight} N (bound {bound:.1e})"
        );
        // A frictionless plane pushes along its normal only: ∇d = n exactly.
        assert!(fx.abs() <= 1e-12 * weight && fy.abs() <= 1e-12 * weight);
        // The sag is a compression: no node went through the ground.
        assert!(summary.max_displacement > 0.0);
    }
}

fn scene_error(text: &str) -> (String, usize, String) {
    let result = text.parse::<Scene>().and_then(|s| {
        run_static_with(
            &s,
            &RunOptions {
                no_files: true,
                ..Default::default()
            },
        )
        .map(|_| ())
    });
    match result {
        Err(Error::Scene {
            key, line, message, ..
        }) => (key, line, message),
        other => panic!("expected a scene error, got {other:?}"),
    }
}

#[test]
fn bad_obstacles_are_errors_naming_key_and_line() {
    let header = block_on_ground("linear", GROUND)
        .lines()
        .position(|l| l == "[[obstacles]]")
        .unwrap()
        + 1;
    for (obstacle, key, words) in [
        (
            "kind = \"half_space\"\npoint = [0.0, 0.0, -1.0]\nnormal = [0.0, 0.0, 0.0]",
            "obstacles[0].normal",
            "non-zero",
        ),
        (
            "kind = \"sphere\"\ncenter = [0.1, 0.1, -1.0]\nradius = 0.0",
            "obstacles[0].radius",
            "> 0",
        ),
        (
            "kind = \"box\"\nmin = [0.0, 0.0, -1.0]\nmax = [1.0, 0.0, -0.5]",
            "obstacles[0].max",
            "must exceed min",
        ),
        (
            "kind = \"box\"\ncenter = [0.0, 0.0, -1.0]\nhalf_extents = [1.0, 0.0, 0.5]",
            "obstacles[0].half_extents",
            "> 0",
        ),
        (
            &format!("{GROUND}\nfriction = -0.5"),
            "obstacles[0].friction",
            "≥ 0",
        ),
        (
            "kind = \"sphere\"\ncenter = [0.1, 0.1, -1.0]\nradius = 0.5\nnormal = [0.0, 0.0, 1.0]",
            "obstacles[0].normal",
            "center, radius",
        ),
        // The block's bottom face z = 0 lies inside a ground at z = +0.01.
        (
            "kind = \"half_space\"\npoint = [0.0, 0.0, 0.01]\nnormal = [0.0, 0.0, 1.0]",
            "obstacles[0]",
            "inside",
        ),
    ] {
        let text = block_on_ground("linear", obstacle);
        let (got_key, line, message) = scene_error(&text);
        assert_eq!(got_key, key, "{obstacle}: {message}");
        // The entry's span: its header or one of its key lines.
        let last = header + obstacle.lines().count();
        assert!(
            (header..=last).contains(&line),
            "{obstacle}: line {line} not in {header}..={last}"
        );
        assert!(message.contains(words), "{obstacle}: {message}");
    }
    let text = format!(
        "{}[contact]\nstiffness = -1.0\n",
        block_on_ground("linear", GROUND)
    );
    let (key, _, message) = scene_error(&text);
    assert_eq!(key, "contact.stiffness", "{message}");
}

/// Newmark with obstacles runs (the library's rule refuses it no more): the block falls toward
/// the ground 1 mm below for 10 steps (0.5 mm: out of the barrier's reach), with the library's
/// warning naming the pair and the measured behaviour (each impact loses energy).
#[test]
fn newmark_with_obstacles_runs_with_the_librarys_warning() {
    let ground = GROUND.replace("-1e-4", "-1e-3");
    let text = block_on_ground("linear", &ground).replace(
        "[analysis]\n",
        "[analysis]\ntype = \"dynamic\"\nmethod = \"newmark\"\ndt = 1e-3\nduration = 1e-2\n",
    );
    let scene: Scene = text.parse().unwrap();
    let summary = tetfem_cli::scene::run_dynamic_scene(
        &scene,
        &tetfem_cli::scene::DynamicOverrides::default(),
        true,
        false,
        &mut |_, _| std::ops::ControlFlow::Continue(()),
    )
    .unwrap();
    assert_eq!(summary.steps, 10);
    assert!(
        summary
            .warnings
            .iter()
            .any(|w| w.contains("newmark") && w.contains("obstacles") && w.contains("impact")),
        "{:?}",
        summary.warnings
    );
}
