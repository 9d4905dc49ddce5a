//! Modal scenes (`[analysis] type = "modal"`): the modes are the library's, the effective modal
//! masses are complete and match a rod's analytic values, the files hold what they say, and bad
//! keys are errors naming the key and its line.

use crate::common::vtu;

use std::path::Path;

use tetfem::Error;
use tetfem::analysis::dynamics::{LinearSystem, Rayleigh};
use tetfem::analysis::modal::lowest_modes;
use tetfem_cli::scene::{Analysis, Scene, run_modal_scene};

/// A bar [0, L] × [0, 0.25] × [0, 0.25] clamped at x = 0, E = 1e5, ν = `nu`, ρ = 1000.
fn bar_scene(cells: [usize; 3], length: f64, nu: f64, analysis: &str) -> String {
    format!(
        r#"
title = "clamped bar"
[mesh.box]
min = [0.0, 0.0, 0.0]
max = [{length}, 0.25, 0.25]
cells = [{}, {}, {}]
[material]
youngs_modulus = 1e5
poisson_ratio = {nu}
density = 1000.0
[[constraints]]
where = {{ plane = {{ axis = "x", at = 0.0 }} }}
[analysis]
{analysis}
"#,
        cells[0], cells[1], cells[2]
    )
}

#[test]
fn the_shipped_scene_gives_the_librarys_modes_bit_for_bit() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/l_bracket_modal.toml");
    let scene = Scene::load(&path).unwrap();
    let Analysis::Modal(settings) = *scene.analysis() else {
        panic!("the shipped modal scene is not modal");
    };
    let summary = run_modal_scene(&scene, true).unwrap();
    let built = scene.build().unwrap();
    let system = LinearSystem::new(
        &built.mesh,
        &built.materials,
        &built.constraints,
        &built.other_loads,
        built.gravity,
        settings.mass,
        Rayleigh::default(),
    )
    .unwrap();
    let modes = lowest_modes(&system, settings.modes).unwrap();
    assert_eq!(summary.modes.len(), settings.modes);
    for (row, omega) in summary.modes.iter().zip(&modes.omega) {
        assert_eq!(row.omega_rad_per_s, *omega);
        assert_eq!(row.frequency_hz, omega / (2.0 * std::f64::consts::PI));
        for fraction in row.effective_mass_fraction {
            assert!((0.0..=1.0).contains(&fraction), "{fraction}");
        }
    }
    for cumulative in summary.cumulative_mass_fraction {
        // Round-off above 1 only (a sum of squares of a projection).
        assert!(cumulative <= 1.0 + 1e-12, "{cumulative}");
    }
}

#[test]
fn all_modes_together_carry_the_free_mass() {
    // With a lumped mass, Σ over every mode of Γ_d² = r_fᵀ·M_ff·r_f (the modes are an
    // M-orthonormal basis of the free DOFs): the fractions sum to the free mass over the total,
    // to the round-off of the basis' orthonormality.
    let text = bar_scene(
        [2, 1, 1],
        1.0,
        0.3,
        "type = \"modal\"\nmass = \"lumped\"\nmodes = 24",
    );
    let scene: Scene = text.parse().unwrap();
    let summary = run_modal_scene(&scene, true).unwrap();
    assert_eq!(summary.free_dofs, 24, "2×1×1 cells: 8 free nodes");
    let built = scene.build().unwrap();
    let mass = tetfem::fe::assembly::lumped_mass_of(&built.mesh, &built.materials).unwrap();
    let dofs = tetfem::DofMap::new(&built.constraints);
    for (d, total) in summary.cumulative_mass_fraction.iter().enumerate() {
        let all: f64 = mass.iter().skip(d).step_by(3).sum();
        let free: f64 = (d..mass.len())
            .step_by(3)
            .filter(|&dof| dofs.free_index(dof).is_some())
            .map(|dof| mass[dof])
            .sum();
        let expected = free / all;
        assert!(
            (total - expected).abs() < 1e-12,
            "direction {d}: {total} vs {expected}"
        );
    }
    // With a consistent mass the coupling to the supports leaves a little more out, never
    // more than all of it.
    let text = bar_scene(
        [2, 1, 1],
        1.0,
        0.3,
        "type = \"modal\"\nmass = \"consistent\"\nmodes = 24",
    );
    let summary = run_modal_scene(&text.parse().unwrap(), true).unwrap();
    for total in summary.cumulative_mass_fraction {
        assert!(total > 0.0 && total < 1.0, "{total}");
    }
}

#[test]
fn a_rods_axial_mode_has_its_analytic_frequency_and_effective_mass() {
    // With ν = 0 a clamped-free prismatic bar has axial modes u_x = sin((2k−1)πx/2L): the first
    // at f = c/(4L), c = √(E/ρ), with effective mass fraction 8/π² in x. Linear tets with a
    // consistent mass overestimate ω by O(h²) (measured 0.02 % at 24 cells along the rod); the
    // fraction is a projection on the mode shape, its error O(h²) too. 0.5 % leaves room for the
    // three-dimensional mesh while a wrong mass, factor or normalisation would miss by far more.
    let length = 2.0;
    let text = bar_scene(
        [24, 2, 2],
        length,
        0.0,
        "type = \"modal\"\nmass = \"consistent\"\nmodes = 12",
    );
    let scene: Scene = text.parse().unwrap();
    let summary = run_modal_scene(&scene, true).unwrap();
    let axial = summary
        .modes
        .iter()
        .max_by(|a, b| a.effective_mass_fraction[0].total_cmp(&b.effective_mass_fraction[0]))
        .unwrap();
    let expected_frequency = (1e5f64 / 1000.0).sqrt() / (4.0 * length);
    let expected_fraction = 8.0 / std::f64::consts::PI.powi(2);
    let frequency_error = axial.frequency_hz / expected_frequency - 1.0;
    let fraction_error = axial.effective_mass_fraction[0] / expected_fraction - 1.0;
    println!(
        "axial mode {}: f = {:.6e} Hz (analytic {expected_frequency:.6e}, {frequency_error:+.2e}), x fraction {:.6} (8/π² = {expected_fraction:.6}, {fraction_error:+.2e})",
        axial.mode, axial.frequency_hz, axial.effective_mass_fraction[0]
    );
    assert!(frequency_error.abs() < 5e-3);
    assert!(fraction_error.abs() < 5e-3);
}

#[test]
fn modal_files_hold_normalized_shapes_and_their_frequencies() {
    let dir = std::env::temp_dir().join(format!("tetfem-modal-{}", std::process::id()));
    let text = bar_scene(
        [6, 1, 1],
        1.0,
        0.3,
        &format!(
            "type = \"modal\"\nmodes = 3\n[output]\ndirectory = \"{}\"",
            dir.display()
        ),
    );
    let scene: Scene = text.parse().unwrap();
    let summary = run_modal_scene(&scene, false).unwrap();
    let pvd = std::fs::read_to_string(dir.join("scene_modes.pvd"))
        .or_else(|_| {
            let name = summary
                .files
                .iter()
                .find(|f| f.extension().is_some_and(|e| e == "pvd"))
                .unwrap();
            std::fs::read_to_string(name)
        })
        .unwrap();
    assert_eq!(pvd.matches("<DataSet").count(), 3);
    let vtus: Vec<_> = summary
        .files
        .iter()
        .filter(|f| f.extension().is_some_and(|e| e == "vtu"))
        .collect();
    assert_eq!(vtus.len(), 3);
    for (vtu, row) in vtus.iter().zip(&summary.modes) {
        let name = vtu.file_name().unwrap().to_string_lossy().into_owned();
        assert!(
            name.contains(&format!("{:.4}Hz", row.frequency_hz)),
            "{name}"
        );
        let file = vtu::read_vtu(vtu);
        let array = |name: &str| file.values(name).to_vec();
        assert_eq!(array("frequency_hz"), vec![row.frequency_hz]);
        let shape = array("mode_shape");
        let largest = shape
            .chunks_exact(3)
            .map(|v| (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt())
            .fold(0.0, f64::max);
        // Scaled to 1, then printed with 17 significant digits.
        assert!((largest - 1.0).abs() < 1e-15, "{largest}");
    }
    let csv = std::fs::read_to_string(
        summary
            .files
            .iter()
            .find(|f| f.to_string_lossy().ends_with("_modes.csv"))
            .unwrap(),
    )
    .unwrap();
    let second = csv.lines().nth(1).unwrap();
    assert!(
        second.starts_with("1,"),
        "the mode column is an integer: {second}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

fn scene_error(text: &str) -> (String, usize, String) {
    match text
        .parse::<Scene>()
        .and_then(|s| run_modal_scene(&s, true).map(|_| ()))
    {
        Err(Error::Scene {
            key, line, message, ..
        }) => (key, line, message),
        other => panic!("expected a scene error, got {other:?}"),
    }
}

#[test]
fn bad_modal_keys_are_errors_naming_key_and_line() {
    let analysis_line = bar_scene([2, 1, 1], 1.0, 0.3, "")
        .lines()
        .position(|l| l == "[analysis]")
        .unwrap()
        + 1;
    for (analysis, key, words) in [
        (
            "type = \"modal\"\nmodes = 0",
            "analysis.modes",
            "at least one",
        ),
        (
            "type = \"modal\"\nmodes = 25",
            "analysis.modes",
            "24 free DOFs",
        ),
        (
            "type = \"modal\"\nmodel = \"corotational\"",
            "analysis.model",
            "linear only",
        ),
        ("type = \"modal\"\ndt = 1e-3", "analysis.dt", "dynamic"),
        ("type = \"static\"\nmodes = 4", "analysis.modes", "modal"),
    ] {
        let (got_key, line, message) = scene_error(&bar_scene([2, 1, 1], 1.0, 0.3, analysis));
        assert_eq!(got_key, key, "{analysis}: {message}");
        assert_eq!(line, analysis_line, "{analysis}");
        assert!(message.contains(words), "{analysis}: {message}");
    }
}

#[test]
fn the_binary_runs_a_modal_scene_and_prints_json() {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("modal-cli");
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/l_bracket_modal.toml");
    let output = std::process::Command::new(env!("CARGO_BIN_EXE_tetfem"))
        .args(["run", &scene.to_string_lossy(), "--json", "--out"])
        .arg(&dir)
        .output()
        .unwrap();
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    let summary: serde_json::Value = serde_json::from_slice(&output.stdout).unwrap();
    assert_eq!(summary["analysis"], "modal");
    assert_eq!(summary["modes"].as_array().unwrap().len(), 8);
    assert!(dir.join("l_bracket_modal_modes.pvd").is_file());
    // A dynamic-only option is refused before any work.
    let refused = std::process::Command::new(env!("CARGO_BIN_EXE_tetfem"))
        .args(["run", &scene.to_string_lossy(), "--dt", "1e-3", "--out"])
        .arg(&dir)
        .output()
        .unwrap();
    assert!(!refused.status.success());
    assert!(String::from_utf8_lossy(&refused.stderr).contains("--dt"));
}

#[test]
fn static_and_modal_summaries_report_the_critical_step_when_asked() {
    // The summary's step is the library's critical_time_step of the scene's lumped system, to
    // the bit; without the key there is none (it costs a Lanczos iteration and a factorization).
    let with = |analysis: &str, asked: bool| {
        let mut text = bar_scene([6, 1, 1], 1.0, 0.3, analysis);
        if asked {
            text.push_str("[output]\ncritical_step = true\n");
        }
        text.parse::<Scene>().unwrap()
    };
    let scene = with("type = \"modal\"\nmodes = 2", true);
    let built = scene.build().unwrap();
    let system = LinearSystem::new(
        &built.mesh,
        &built.materials,
        &built.constraints,
        &built.other_loads,
        built.gravity,
        tetfem::analysis::dynamics::MassKind::Lumped,
        Rayleigh::default(),
    )
    .unwrap();
    let expected = tetfem::analysis::dynamics::critical_time_step(&system).unwrap();
    let modal = run_modal_scene(&scene, true)
        .unwrap()
        .critical_step
        .unwrap();
    assert_eq!(modal.seconds, expected.dt);
    assert_eq!(modal.source, expected.certificate.source());
    let options = tetfem_cli::scene::RunOptions {
        no_files: true,
        ..Default::default()
    };
    let static_scene = with("type = \"static\"", true);
    let static_step = tetfem_cli::scene::run_static_with(&static_scene, &options)
        .unwrap()
        .critical_step
        .unwrap();
    assert_eq!(static_step.seconds, expected.dt);
    assert!(
        tetfem_cli::scene::run_static_with(&with("type = \"static\"", false), &options)
            .unwrap()
            .critical_step
            .is_none()
    );
}
