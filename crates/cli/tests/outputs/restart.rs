//! Restart of dynamic scenes: for every method a scene can run (backward Euler, Newmark,
//! explicit; the linear model with Rayleigh damping, and backward Euler and Newmark with the
//! corotational model), 200 steps in one go and a run stopped after 150 steps with a
//! checkpoint at 100 (its CSV cut mid-row as a kill would leave it), resumed to 200, give the
//! same CSV rows (the wall-time column aside), the same `.pvd`, the same `.vtu` bytes and the
//! same final state bits (u, v) and history. Bad input: a resume without a checkpoint, with a
//! changed scene, with nothing left to run; `checkpoint_every` negative, fractional, or in a
//! static scene — each an error naming the key and its line (or the file).

use crate::common;

use std::ops::ControlFlow;
use std::path::{Path, PathBuf};
use std::process::Command;

use tetfem::analysis::dynamics::Checkpoint;
use tetfem::base::error::Error;
use tetfem_cli::scene::{
    DynamicOverrides, DynamicSummary, Scene, checkpoint_path, resume_dynamic_scene,
    run_dynamic_scene,
};

/// A steel bar 1 × 0.1 × 0.1 m (8×1×1 cells) clamped at x = 0 under a suddenly applied tip
/// load, Rayleigh damping α = 5 /s, β = 1e-7 s, a frame every 10 steps, probes at the tip;
/// `duration_steps` steps of `dt`, a checkpoint every 100 steps.
fn scene_text(method: &str, model: &str, dt: f64, duration_steps: usize) -> String {
    format!(
        r#"title = "restart test"
[mesh.box]
max = [1.0, 0.1, 0.1]
cells = [8, 1, 1]

[material]
youngs_modulus = 200e9
poisson_ratio = 0.3
density = 7850.0

[[constraints]]
where = {{ plane = {{ axis = "x", at = 0.0 }} }}

[[loads]]
where = {{ plane = {{ axis = "x", at = 1.0 }} }}
total_force = [0.0, 2e5, -1e6]

[[probes]]
name = "tip"
where = {{ plane = {{ axis = "x", at = 1.0 }} }}

[analysis]
type = "dynamic"
method = "{method}"
model = "{model}"
dt = {dt:e}
duration = {duration:e}
damping = {{ mass = 5.0, stiffness = 1e-7 }}

[output]
every = 10
checkpoint_every = 100
"#,
        duration = duration_steps as f64 * dt
    )
}

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("tetfem-restart-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn scene_in(text: &str, dir: &Path) -> Scene {
    let mut scene = Scene::parse(text, "restart.toml", dir).unwrap();
    scene.set_output_directory(dir.to_path_buf());
    scene
}

fn go(_: usize, _: usize) -> ControlFlow<()> {
    ControlFlow::Continue(())
}

fn run(text: &str, dir: &Path) -> DynamicSummary {
    run_dynamic_scene(
        &scene_in(text, dir),
        &DynamicOverrides::default(),
        true,
        false,
        &mut go,
    )
    .unwrap()
}

fn resume(text: &str, dir: &Path) -> tetfem::Result<DynamicSummary> {
    resume_dynamic_scene(
        &scene_in(text, dir),
        &DynamicOverrides::default(),
        false,
        &mut go,
    )
}

/// The CSV's lines without the wall-time column (the third): what two runs can share.
fn csv_rows(dir: &Path) -> Vec<String> {
    std::fs::read_to_string(dir.join("scene.csv"))
        .unwrap()
        .lines()
        .map(|l| {
            let mut cells: Vec<&str> = l.split(',').collect();
            cells.remove(2);
            cells.join(",")
        })
        .collect()
}

fn bits(values: &[f64]) -> Vec<u64> {
    values.iter().map(|v| v.to_bits()).collect()
}

#[test]
fn a_resumed_run_ends_with_the_outputs_and_bits_of_one_uninterrupted_run() {
    // (method, model, dt): the explicit method at about half its critical step (9.68e-6 s on
    // this mesh, measured by the Lanczos iteration of `tetfem run`).
    let cases = [
        ("backward_euler", "linear", 1e-4),
        ("newmark", "linear", 1e-4),
        ("explicit", "linear", 5e-6),
        ("backward_euler", "corotational", 1e-4),
        ("newmark", "corotational", 1e-4),
    ];
    for (method, model, dt) in cases {
        let case = format!("{method}-{model}");
        let whole = scratch(&format!("{case}-whole"));
        let parts = scratch(&format!("{case}-parts"));
        let straight = run(&scene_text(method, model, dt, 200), &whole);
        assert_eq!(straight.steps, 200, "{case}");

        // The interrupted run: 150 steps, its checkpoint at 100; then a half row, as if killed
        // while writing out its CSV.
        run(&scene_text(method, model, dt, 150), &parts);
        let csv = parts.join("scene.csv");
        let mut text = std::fs::read_to_string(&csv).unwrap();
        text.push_str("1.5e-2,151,0.0");
        std::fs::write(&csv, text).unwrap();
        let resumed = resume(&scene_text(method, model, dt, 200), &parts).unwrap();
        assert_eq!(resumed.resumed_from_step, Some(100), "{case}");
        assert_eq!(resumed.steps, 200, "{case}");

        // CSV: rows 0..=200 once each, the same numbers.
        let rows = csv_rows(&parts);
        assert_eq!(rows.len(), 202, "{case}: header + 201 rows");
        for (k, row) in rows[1..].iter().enumerate() {
            assert_eq!(
                row.split(',').nth(1),
                Some(k.to_string().as_str()),
                "{case}: {row}"
            );
        }
        assert_eq!(rows, csv_rows(&whole), "{case}: CSV rows");
        // The .pvd and every frame it lists, byte for byte.
        let pvd = std::fs::read_to_string(parts.join("scene.pvd")).unwrap();
        assert_eq!(
            pvd,
            std::fs::read_to_string(whole.join("scene.pvd")).unwrap(),
            "{case}"
        );
        let frames: Vec<&str> = pvd
            .lines()
            .filter_map(|l| l.split("file=\"").nth(1))
            .map(|f| f.trim_end_matches("\"/>"))
            .collect();
        assert_eq!(frames.len(), 21, "{case}: frames at steps 0, 10, …, 200");
        for f in &frames {
            assert_eq!(
                std::fs::read(parts.join(f)).unwrap(),
                std::fs::read(whole.join(f)).unwrap(),
                "{case}: {f}"
            );
        }
        // The final state, from both runs' checkpoints at step 200: the same bits.
        let scene = scene_in(&scene_text(method, model, dt, 200), &parts);
        let end = Checkpoint::read(&checkpoint_path(scene.output())).unwrap();
        let scene = scene_in(&scene_text(method, model, dt, 200), &whole);
        let reference = Checkpoint::read(&checkpoint_path(scene.output())).unwrap();
        assert_eq!(end.state.steps, 200);
        assert_eq!(
            bits(&end.state.displacement),
            bits(&reference.state.displacement),
            "{case}: u"
        );
        assert_eq!(
            bits(&end.state.velocity),
            bits(&reference.state.velocity),
            "{case}: v"
        );
        common::restart::assert_same_history(&end.history, &reference.history, &case);
        assert!(
            end.state.displacement.iter().any(|u| u.abs() > 1e-5),
            "{case}: it moved"
        );
        // The summary: the whole run's probe ranges, energies and Newton counts.
        assert_eq!(resumed.probes, straight.probes, "{case}");
        assert_eq!(resumed.final_energy, straight.final_energy, "{case}");
        common::restart::assert_same_newton(resumed.newton, straight.newton, &case);
        assert_eq!(resumed.frames, straight.frames, "{case}");
        let _ = std::fs::remove_dir_all(&whole);
        let _ = std::fs::remove_dir_all(&parts);
    }
}

/// A stop (Ctrl-C: the progress callback breaks) writes a checkpoint at the step it stops at,
/// off the `checkpoint_every` grid, and a resume from it ends as the uninterrupted run.
#[test]
fn an_interrupted_run_checkpoints_where_it_stops_and_resumes_from_there() {
    let whole = scratch("stop-whole");
    let parts = scratch("stop-parts");
    let text = scene_text("newmark", "corotational", 1e-4, 200);
    run(&text, &whole);
    let stopped = run_dynamic_scene(
        &scene_in(&text, &parts),
        &DynamicOverrides::default(),
        true,
        false,
        &mut |done, _| match done {
            137 => ControlFlow::Break(()),
            _ => ControlFlow::Continue(()),
        },
    );
    assert!(
        matches!(stopped, Err(Error::Interrupted { step: 137, .. })),
        "{stopped:?}"
    );
    let resumed = resume(&text, &parts).unwrap();
    assert_eq!(resumed.resumed_from_step, Some(137));
    assert_eq!(csv_rows(&parts), csv_rows(&whole));
    let pvd = |dir: &Path| std::fs::read_to_string(dir.join("scene.pvd")).unwrap();
    assert_eq!(pvd(&parts), pvd(&whole));
    let _ = std::fs::remove_dir_all(&whole);
    let _ = std::fs::remove_dir_all(&parts);
}

/// The mesh is part of the fingerprint: the same scene text over a mesh file whose node moved
/// is refused, naming `mesh` and its line.
#[test]
fn a_resume_over_a_changed_mesh_file_names_the_mesh() {
    let dir = scratch("mesh");
    let shipped = concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenes/tetgen_bar");
    for ext in ["node", "ele", "face"] {
        std::fs::copy(format!("{shipped}.{ext}"), dir.join(format!("bar.{ext}"))).unwrap();
    }
    let text = |steps: usize| {
        format!(
            r#"[mesh.tetgen]
file = "bar.node"
[material]
youngs_modulus = 200e9
poisson_ratio = 0.3
density = 7850.0
[[constraints]]
where = {{ face_marker = 1 }}
[[loads]]
where = {{ face_marker = 2 }}
total_force = [1e5, 0.0, 0.0]
[analysis]
type = "dynamic"
dt = 1e-5
duration = {:e}
[output]
checkpoint_every = 10
"#,
            steps as f64 * 1e-5
        )
    };
    run(&text(10), &dir);
    let node = dir.join("bar.node");
    let moved = std::fs::read_to_string(&node).unwrap().replacen(
        "\n2 0.1 0.0 0.0 0",
        "\n2 0.1 0.0 0.001 0",
        1,
    );
    std::fs::write(&node, moved).unwrap();
    let (key, line, message) = scene_error(resume(&text(20), &dir));
    assert_eq!((key.as_str(), line), ("mesh", 1));
    assert!(message.contains("the mesh differs"), "{message}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// The scene's error: its key, line and message.
fn scene_error(result: tetfem::Result<DynamicSummary>) -> (String, usize, String) {
    match result {
        Err(Error::Scene {
            key, line, message, ..
        }) => (key, line, message),
        other => panic!("expected a scene error, got {other:?}"),
    }
}

fn line_of(text: &str, needle: &str) -> usize {
    1 + text.lines().position(|l| l.contains(needle)).unwrap()
}

#[test]
fn a_resume_without_a_checkpoint_names_the_path_it_looked_for() {
    let dir = scratch("missing");
    let text = scene_text("backward_euler", "linear", 1e-4, 20);
    let (key, line, message) = scene_error(resume(&text, &dir));
    assert_eq!(key, "output.checkpoint_every");
    assert_eq!(line, line_of(&text, "checkpoint_every"));
    let path = dir.join("scene_checkpoint.bin");
    assert!(message.contains(&path.display().to_string()), "{message}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_resume_of_a_changed_scene_names_the_key_that_changed() {
    let dir = scratch("changed");
    let text = scene_text("newmark", "linear", 1e-4, 100);
    run(&text, &dir);
    let changed = scene_text("newmark", "linear", 1e-4, 200).replace("200e9", "210e9");
    let (key, line, message) = scene_error(resume(&changed, &dir));
    assert_eq!(key, "material.youngs_modulus");
    assert_eq!(line, line_of(&changed, "youngs_modulus"));
    assert!(
        message.contains("210000000000") && message.contains("200000000000"),
        "{message}"
    );
    // Another method is another key of the scene.
    let other = scene_text("backward_euler", "linear", 1e-4, 200);
    let (key, line, _) = scene_error(resume(&other, &dir));
    assert_eq!(
        (key.as_str(), line),
        ("analysis.method", line_of(&other, "method ="))
    );
    // Comments, spacing and the resumable keys may change.
    let same = format!(
        "# a comment\n{}",
        scene_text("newmark", "linear", 1e-4, 120)
    )
    .replace("checkpoint_every = 100", "checkpoint_every  =  7");
    assert_eq!(resume(&same, &dir).unwrap().steps, 120);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_resume_with_nothing_left_to_run_names_the_duration() {
    let dir = scratch("ended");
    let text = scene_text("explicit", "linear", 5e-6, 100);
    run(&text, &dir);
    let (key, line, message) = scene_error(resume(&text, &dir));
    assert_eq!(key, "analysis.duration");
    assert_eq!(line, line_of(&text, "duration ="));
    assert!(message.contains("step 100"), "{message}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// A checkpoint whose step count disagrees with its time (forged, or damaged and re-summed)
/// resumed with a trajectory shifted in time, exit 0; a NaN time was accepted; a CSV of
/// another run was continued. Each is refused naming the file, the field, its value and what
/// was expected.
#[test]
fn a_resume_cross_checks_the_checkpoints_step_time_and_csv() {
    let dir = scratch("clock");
    let text = scene_text("explicit", "linear", 5e-6, 100);
    let longer = scene_text("explicit", "linear", 5e-6, 120);
    run(&text, &dir);
    let path = checkpoint_path(scene_in(&text, &dir).output());
    let good = Checkpoint::read(&path).unwrap();
    assert_eq!((good.state.steps, good.dt), (100, 5e-6));

    let mut shifted = good.clone();
    shifted.state.steps = 60;
    shifted.write(&path).unwrap();
    let message = resume(&longer, &dir).unwrap_err().to_string();
    assert!(message.contains("checkpoint.bin"), "{message}");
    let time = format!("checkpoint time = {:e} s", good.state.time);
    assert!(message.contains(&time), "{message}");
    assert!(message.contains("step 60 of dt = 5e-6 s"), "{message}");
    assert!(
        message.contains(&format!("is at t = {:e} s", 60.0 * 5e-6)),
        "{message}"
    );

    let mut nan = good.clone();
    nan.state.time = f64::NAN;
    nan.write(&path).unwrap();
    let message = resume(&longer, &dir).unwrap_err().to_string();
    assert!(message.contains("checkpoint.bin"), "{message}");
    assert!(message.contains("time = NaN: must be finite"), "{message}");

    // The CSV of a run with another time step: its row of step 100 is at t = 4e-4 s.
    good.write(&path).unwrap();
    let other = scratch("clock-other");
    run(&scene_text("explicit", "linear", 4e-6, 100), &other);
    std::fs::copy(other.join("scene.csv"), dir.join("scene.csv")).unwrap();
    let message = resume(&longer, &dir).unwrap_err().to_string();
    assert!(message.contains("scene.csv:102"), "{message}");
    let row = format!("time_s = {:e}, step = 100", 100.0 * 4e-6);
    assert!(message.contains(&row), "{message}");
    assert!(
        message.contains(&format!("t = {:e} s", 100.0 * 5e-6)),
        "{message}"
    );
    let _ = std::fs::remove_dir_all(&other);

    // The checkpoint and CSV as written resume.
    run(&text, &dir);
    assert_eq!(resume(&longer, &dir).unwrap().steps, 120);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn checkpoint_every_must_be_a_non_negative_integer_of_a_dynamic_scene() {
    let text = scene_text("newmark", "linear", 1e-4, 10);
    for bad in ["-1", "2.5", "\"10\""] {
        let broken = text.replace(
            "checkpoint_every = 100",
            &format!("checkpoint_every = {bad}"),
        );
        match Scene::parse(&broken, "restart.toml", Path::new(".")) {
            Err(Error::Scene { key, line, .. }) => {
                assert_eq!(key, "output.checkpoint_every", "{bad}");
                assert_eq!(line, line_of(&broken, "checkpoint_every"), "{bad}");
            }
            other => panic!("{bad}: expected a scene error, got {other:?}"),
        }
    }
    let static_scene = text.replace("type = \"dynamic\"", "type = \"static\"");
    let static_scene: String = static_scene
        .lines()
        .filter(|l| {
            !["method", "model", "dt", "duration", "damping"]
                .iter()
                .any(|k| l.starts_with(k))
        })
        .map(|l| format!("{l}\n"))
        .collect();
    match Scene::parse(&static_scene, "restart.toml", Path::new(".")) {
        Err(Error::Scene { key, line, .. }) => {
            assert_eq!(key, "output.checkpoint_every");
            assert_eq!(line, line_of(&static_scene, "checkpoint_every"));
        }
        other => panic!("expected a scene error, got {other:?}"),
    }
}

#[test]
fn the_command_line_resumes_and_refuses_by_name() {
    let dir = scratch("cli");
    let scene = dir.join("bar.toml");
    std::fs::write(&scene, scene_text("backward_euler", "linear", 1e-4, 100)).unwrap();
    let tetfem = |args: &[&str]| {
        Command::new(env!("CARGO_BIN_EXE_tetfem"))
            .args(args)
            .arg(&scene)
            .args(["--out", dir.join("out").to_str().unwrap(), "--quiet"])
            .output()
            .unwrap()
    };
    let missing = tetfem(&["run", "--resume"]);
    assert!(!missing.status.success());
    let stderr = String::from_utf8_lossy(&missing.stderr);
    assert!(stderr.contains("bar_checkpoint.bin"), "{stderr}");
    assert!(tetfem(&["run"]).status.success());
    assert!(dir.join("out/bar_checkpoint.bin").exists());
    std::fs::write(&scene, scene_text("backward_euler", "linear", 1e-4, 130)).unwrap();
    let resumed = tetfem(&["run", "--resume"]);
    assert!(
        resumed.status.success(),
        "{}",
        String::from_utf8_lossy(&resumed.stderr)
    );
    let rows = std::fs::read_to_string(dir.join("out/bar.csv"))
        .unwrap()
        .lines()
        .count();
    assert_eq!(rows, 1 + 131, "header and steps 0..=130");
    let _ = std::fs::remove_dir_all(&dir);
}
