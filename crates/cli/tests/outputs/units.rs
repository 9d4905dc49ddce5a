//! Units and types in the tables: each CSV kind's header names its units (compared with the
//! lists stated here); the JSON summaries' `units` table covers every real-valued field and
//! names only fields that exist.

use std::path::{Path, PathBuf};

use serde_json::Value;
use tetfem_cli::scene::{
    DynamicOverrides, RunOptions, Scene, run_dynamic_scene, run_modal_scene, run_static_with,
};

fn tmp(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join("units")
        .join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn scene(analysis: &str, dir: &Path) -> Scene {
    let text = format!(
        r#"
title = "bar"
[mesh.box]
max = [1.2, 0.3, 0.3]
cells = [4, 1, 1]
[material]
youngs_modulus = 1e6
poisson_ratio = 0.3
density = 1000.0
[[constraints]]
where = {{ plane = {{ axis = "x", at = 0.0 }} }}
[[loads]]
where = {{ plane = {{ axis = "x", at = 1.2 }} }}
total_force = [300.0, 0.0, -200.0]
[[probes]]
name = "tip"
where = {{ plane = {{ axis = "x", at = 1.2 }} }}
[analysis]
{analysis}
[output]
critical_step = true
"#
    );
    let mut scene = Scene::parse(&text, "bar", dir).unwrap();
    scene.set_output_directory(dir.to_path_buf());
    scene
}

fn header(files: &[PathBuf], suffix: &str) -> Vec<String> {
    let csv = files
        .iter()
        .find(|f| f.to_string_lossy().ends_with(suffix))
        .unwrap_or_else(|| panic!("no {suffix} in {files:?}"));
    let text = std::fs::read_to_string(csv).unwrap();
    text.lines()
        .next()
        .unwrap()
        .split(',')
        .map(String::from)
        .collect()
}

/// Paths (`a.b`, array indices dropped) of every real-valued leaf of `value`.
fn real_leaves(value: &Value, path: &str, out: &mut Vec<String>) {
    match value {
        Value::Object(map) => {
            for (key, v) in map {
                let child = if path.is_empty() {
                    key.clone()
                } else {
                    format!("{path}.{key}")
                };
                real_leaves(v, &child, out);
            }
        }
        Value::Array(items) => items.iter().for_each(|v| real_leaves(v, path, out)),
        Value::Number(n) if n.is_f64() => out.push(path.to_string()),
        _ => {}
    }
}

/// Every real field has a unit, and every unit names a field that is there.
fn check_units(json: &str, what: &str) {
    let mut value: Value = serde_json::from_str(json).unwrap();
    let units = value
        .as_object_mut()
        .unwrap()
        .remove("units")
        .unwrap_or_else(|| panic!("{what}: no units table"));
    let units = units.as_object().unwrap();
    let mut leaves = Vec::new();
    real_leaves(&value, "", &mut leaves);
    assert!(!leaves.is_empty(), "{what}");
    for leaf in &leaves {
        assert!(units.contains_key(leaf), "{what}: {leaf} has no unit");
    }
    for key in units.keys() {
        assert!(
            leaves.contains(key),
            "{what}: the unit of {key} names no real field"
        );
    }
}

#[test]
fn csv_headers_name_their_units_and_json_summaries_carry_a_units_table() {
    let dir = tmp("static");
    let summary =
        run_static_with(&scene(r#"type = "static""#, &dir), &RunOptions::default()).unwrap();
    assert_eq!(
        header(&summary.files, "_probes.csv"),
        ["time_s", "tip_ux_m", "tip_uy_m", "tip_uz_m"]
    );
    check_units(&summary.to_json(), "static");

    let dir = tmp("accuracy");
    let summary = run_static_with(
        &scene("type = \"static\"\naccuracy = 0.3", &dir),
        &RunOptions::default(),
    )
    .unwrap();
    check_units(&summary.to_json(), "static with an accuracy target");

    let dir = tmp("dynamic");
    let s = scene(
        "type = \"dynamic\"\nmethod = \"newmark\"\ndt = 1e-3\nduration = 3e-3",
        &dir,
    );
    let summary = run_dynamic_scene(
        &s,
        &DynamicOverrides::default(),
        true,
        false,
        &mut |_, _| std::ops::ControlFlow::Continue(()),
    )
    .unwrap();
    assert_eq!(
        header(&summary.files, ".csv"),
        [
            "time_s",
            "step",
            "wall_seconds_per_step",
            "tip_ux_m",
            "tip_uy_m",
            "tip_uz_m",
            "kinetic_J",
            "elastic_J",
            "gravity_potential_J",
            "load_potential_J",
            "total_J",
            "reaction0_Fx_N",
            "reaction0_Fy_N",
            "reaction0_Fz_N",
            "reaction0_Mx_Nm",
            "reaction0_My_Nm",
            "reaction0_Mz_Nm",
        ]
    );
    check_units(&summary.to_json(), "dynamic");

    let dir = tmp("modal");
    let summary = run_modal_scene(&scene("type = \"modal\"\nmodes = 3", &dir), false).unwrap();
    assert_eq!(
        header(&summary.files, "_modes.csv"),
        [
            "mode",
            "frequency_Hz",
            "period_s",
            "omega_rad_per_s",
            "effective_mass_fraction_x",
            "effective_mass_fraction_y",
            "effective_mass_fraction_z",
        ]
    );
    check_units(&summary.to_json(), "modal");
}
