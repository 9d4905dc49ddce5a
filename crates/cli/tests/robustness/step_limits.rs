//! No hangs from the run length: a dt or duration that would take more than `MAX_STEPS` steps
//! (dt = 1e-300 used to run forever) is rejected at once, naming the key, its value and the
//! limit — in the library, in scene files and on the command line.

use std::path::PathBuf;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use tetfem::Error;
use tetfem_cli::scene::{MAX_STEPS, RunLength, Scene};

const SCENE: &str = r#"
[mesh.box]
max = [1.0, 0.1, 0.1]
cells = [2, 1, 1]
[material]
youngs_modulus = 200e9
poisson_ratio = 0.3
density = 7850.0
[[constraints]]
where = { plane = { axis = "x", at = 0.0 } }
[analysis]
type = "dynamic"
method = "explicit"
dt = DT
duration = 0.01
[output]
vtu = false
"#;

fn requirement(result: tetfem::Result<usize>, key: &str) -> String {
    match result {
        Err(Error::InvalidParameter {
            name, requirement, ..
        }) if name == key => requirement,
        other => panic!("expected an invalid {key}, got {other:?}"),
    }
}

#[test]
fn step_counts_above_the_limit_are_errors_naming_key_and_limit() {
    let limit = MAX_STEPS.to_string();
    assert!(requirement(RunLength::Duration(1e300).steps(1e-4), "duration").contains(&limit));
    assert!(requirement(RunLength::Duration(0.1).steps(1e-300), "duration").contains(&limit));
    assert!(requirement(RunLength::Steps(MAX_STEPS + 1).steps(1e-4), "steps").contains(&limit));
    assert!(requirement(RunLength::Steps(0).steps(1e-4), "steps").contains(&limit));
    // 10⁹ steps of 1e300 end past the largest f64.
    requirement(RunLength::Steps(MAX_STEPS).steps(1e300), "dt");
    // At the limit itself, and a whole number of steps up to round-off.
    assert_eq!(RunLength::Steps(MAX_STEPS).steps(1e-4).unwrap(), MAX_STEPS);
    assert_eq!(RunLength::Duration(1e3).steps(1e-6).unwrap(), MAX_STEPS);
    assert_eq!(RunLength::Duration(0.3).steps(0.1).unwrap(), 3);
}

#[test]
fn a_scene_whose_dt_is_below_the_durations_resolution_is_rejected() {
    match Scene::parse(&SCENE.replace("DT", "1e-300"), "tiny.toml", ".".as_ref()) {
        Err(Error::Scene {
            key, line, message, ..
        }) => {
            assert_eq!(key, "analysis.duration");
            assert!(line > 0);
            assert!(message.contains(&MAX_STEPS.to_string()), "{message}");
        }
        other => panic!("expected a scene error, got {other:?}"),
    }
    assert!(Scene::parse(&SCENE.replace("DT", "1e-5"), "tiny.toml", ".".as_ref()).is_ok());
}

/// Runs the binary with a deadline: a run that would go on forever fails the test after 60 s
/// (a rejected run ends in well under a second) instead of hanging it.
fn tetfem_fails_naming(args: &[&str], key: &str) {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("step-limits");
    std::fs::create_dir_all(&dir).unwrap();
    let scene = dir.join("tiny.toml");
    std::fs::write(&scene, SCENE.replace("DT", "1e-6")).unwrap();
    let args: Vec<String> = args
        .iter()
        .map(|a| a.replace("SCENE", &scene.to_string_lossy()))
        .collect();
    let mut child = Command::new(env!("CARGO_BIN_EXE_tetfem"))
        .args(&args)
        .arg("--out")
        .arg(dir.join("out"))
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let deadline = Instant::now() + Duration::from_secs(60);
    while child.try_wait().unwrap().is_none() {
        if Instant::now() > deadline {
            let _ = child.kill();
            let _ = child.wait();
            panic!("{args:?} was still running after a minute");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    let output = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(1), "{args:?}: {stderr}");
    assert!(
        stderr.contains(&format!("invalid parameter {key} = "))
            && stderr.contains(&MAX_STEPS.to_string()),
        "{args:?}: {stderr}"
    );
}

#[test]
fn the_command_line_rejects_runs_too_long_to_finish() {
    tetfem_fails_naming(&["run", "SCENE", "--dt", "1e-300"], "duration");
    tetfem_fails_naming(&["run", "SCENE", "--duration", "1e300"], "duration");
    tetfem_fails_naming(&["run", "SCENE", "--steps", "2000000000"], "steps");
    // The default run's dynamic part (a tiny mesh, so the static part before it is quick).
    let tiny = ["--cells", "4,1,1", "--dynamic-cells", "4,1,1"];
    tetfem_fails_naming(&[&tiny[..], &["--dt", "1e-300"]].concat(), "duration");
    tetfem_fails_naming(&[&tiny[..], &["--duration", "1e300"]].concat(), "duration");
}
