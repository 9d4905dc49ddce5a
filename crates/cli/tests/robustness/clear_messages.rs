//! Unclear messages found in issue 33, each reproduced: the error now names the key (and its
//! real line), what was found and what is allowed, or what actually went wrong.

use std::ops::ControlFlow;
use std::path::{Path, PathBuf};

use tetfem::Error;
use tetfem_cli::scene::{RunOptions, Scene, run_dynamic_scene, run_static_with};

fn scene(text: &str) -> tetfem::Result<Scene> {
    Scene::parse(text, "<test>", Path::new("."))
}

fn go(_: usize, _: usize) -> ControlFlow<()> {
    ControlFlow::Continue(())
}

const BAR: &str = r#"title = "bar"
[mesh.box]
max = [1.0, 0.1, 0.1]
cells = [4, 1, 1]
[material]
youngs_modulus = 200e9
poisson_ratio = 0.3
density = 7850.0
[[constraints]]
where = { plane = { axis = "x", at = 0.0 } }
"#;

/// `every = 2⁶⁴ − 1` does not fit TOML's integers; the parser's error has no position and was
/// reported at "line 0" under the key "(scene)".
#[test]
fn an_integer_beyond_toml_s_range_is_reported_at_its_key_and_line() {
    let text = format!(
        "{BAR}[analysis]\ntype = \"dynamic\"\nmethod = \"explicit\"\ndt = 1e-7\nduration = 1e-6\n\
         [output]\nvtu = true\nevery = 18446744073709551615\n"
    );
    let line = text.lines().position(|l| l.starts_with("every =")).unwrap() + 1;
    match scene(&text) {
        Err(Error::Scene {
            key,
            line: at,
            message,
            ..
        }) => {
            assert_eq!((key.as_str(), at), ("output.every", line), "{message}");
            assert!(
                message.contains("18446744073709551615") && message.contains("9223372036854775807"),
                "{message}"
            );
        }
        other => panic!("{other:?}"),
    }
}

/// An output folder that is a file: refused before anything is built, naming the path (it was
/// "File exists (os error 17)"), through the library and the command line.
#[test]
fn an_output_path_that_is_a_file_is_an_error_naming_it() {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("clear-messages-out-file");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("out");
    std::fs::write(&file, "not a folder").unwrap();
    let text = format!(
        "{BAR}[[loads]]\nwhere = {{ plane = {{ axis = \"x\", at = 1.0 }} }}\n\
         total_force = [0.0, 0.0, -1.0]\n[analysis]\ntype = \"static\"\n"
    );
    let scene_path = dir.join("bar.toml");
    std::fs::write(&scene_path, &text).unwrap();
    for out in [file.clone(), file.join("below")] {
        let mut s = Scene::load(&scene_path).unwrap();
        s.set_output_directory(out.clone());
        let message = run_static_with(&s, &RunOptions::default())
            .unwrap_err()
            .to_string();
        assert!(
            message.starts_with(&file.display().to_string())
                && message.contains("is a file, not a folder")
                && message.contains(&out.display().to_string()),
            "{message}"
        );
        let cli = std::process::Command::new(env!("CARGO_BIN_EXE_tetfem"))
            .arg("run")
            .arg(&scene_path)
            .arg("--out")
            .arg(&out)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&cli.stderr);
        assert_eq!(cli.status.code(), Some(1), "{stderr}");
        assert!(stderr.contains("is a file, not a folder"), "{stderr}");
    }
    assert_eq!(std::fs::read_to_string(&file).unwrap(), "not a folder");
}

/// An inline table amplitude with rows of three numbers: the error was serde's "data did not
/// match any variant of untagged enum AmplitudeRef"; now the key, the row, what it holds and
/// what is allowed.
#[test]
fn a_table_amplitude_with_three_columns_names_the_row_and_what_is_allowed() {
    let text = format!(
        "{BAR}[[loads]]\nwhere = {{ plane = {{ axis = \"x\", at = 1.0 }} }}\n\
         total_force = [0.0, 0.0, -1.0]\n\
         amplitude = {{ table = [[0.0, 0.0, 1.0], [1.0, 1.0, 1.0]] }}\n\
         [analysis]\ntype = \"dynamic\"\nmethod = \"explicit\"\ndt = 1e-7\nduration = 1e-6\n"
    );
    let line = text
        .lines()
        .position(|l| l.starts_with("amplitude ="))
        .unwrap()
        + 1;
    match scene(&text) {
        Err(Error::Scene {
            key,
            line: at,
            message,
            ..
        }) => {
            assert_eq!((key.as_str(), at), ("loads.amplitude", line), "{message}");
            assert!(!message.contains("untagged"), "{message}");
            assert!(
                message.contains("table: row 1 ([0.0, 0.0, 1.0]) holds 3 values, not two")
                    && message.contains("allowed: the name of an [[amplitudes]] entry"),
                "{message}"
            );
        }
        other => panic!("{other:?}"),
    }
    // Neither a name nor a table.
    let text = text.replace(
        "amplitude = { table = [[0.0, 0.0, 1.0], [1.0, 1.0, 1.0]] }",
        "amplitude = 3.0",
    );
    match scene(&text) {
        Err(Error::Scene { key, message, .. }) => {
            assert_eq!(key, "loads.amplitude", "{message}");
            assert!(
                message.contains("found a float") && message.contains("allowed:"),
                "{message}"
            );
        }
        other => panic!("{other:?}"),
    }
}

/// A block held by nothing but frictional ground, under its weight (a load along the normal),
/// starting 1 mm above it (beyond the activation distance): the message blamed friction
/// ("Friction can carry at most μ·Σλ = -0 N … against an applied load") for a load with no
/// tangential part; it now says the body is unconstrained.
#[test]
fn a_static_contact_body_without_constraints_is_said_to_be_unconstrained() {
    let text = r#"title = "block"
[mesh.box]
min = [0.0, 0.0, 0.001]
max = [0.2, 0.2, 0.201]
cells = [2, 2, 2]
[material]
youngs_modulus = 1e5
poisson_ratio = 0.3
density = 1000.0
[[loads]]
gravity = [0.0, 0.0, -9.81]
[analysis]
type = "static"
model = "neo-hookean"
[[obstacles]]
kind = "half_space"
name = "ground"
point = [0.0, 0.0, 0.0]
normal = [0.0, 0.0, 1.0]
friction = 0.5
"#;
    let s = scene(text).unwrap();
    let options = RunOptions {
        no_files: true,
        ..RunOptions::default()
    };
    let message = run_static_with(&s, &options).unwrap_err().to_string();
    assert!(
        message.contains("The body is unconstrained") && !message.contains("Friction can carry"),
        "{message}"
    );
}

/// An explicit drop onto the ground with a step above the barrier's stable step: nodes ended
/// up inside the ground (first blamed on the start state, then Error::Diverged naming the
/// step). Since issue 35 explicit contact acts on the velocity, so the drop runs at this step
/// (below the body's critical step) with no node through the ground.
#[test]
fn an_explicit_drop_at_a_step_the_barrier_could_not_hold_runs() {
    let text = r#"title = "drop"
[mesh.box]
min = [0.0, 0.0, 0.05]
max = [0.2, 0.2, 0.25]
cells = [3, 3, 3]
[material]
youngs_modulus = 1e5
poisson_ratio = 0.3
density = 1000.0
[[loads]]
gravity = [0.0, 0.0, -9.81]
[analysis]
type = "dynamic"
method = "explicit"
dt = 4e-4
duration = 0.3
[[obstacles]]
kind = "half_space"
name = "ground"
point = [0.0, 0.0, 0.0]
normal = [0.0, 0.0, 1.0]
"#;
    let s = scene(text).unwrap();
    if let Err(e) = run_dynamic_scene(&s, &Default::default(), false, false, &mut go) {
        panic!("{e}");
    }
}
