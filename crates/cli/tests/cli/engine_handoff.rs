//! `engine = "petsc"` and `tetfem run --engine petsc`: the CLI hands the scene to the
//! `tetfem-petsc` binary with the options both share, and refuses what the engine does not
//! take. A stand-in script takes the engine's place here (it records its arguments), so these
//! tests need no PETSc; crates/petsc/tests/mpi.rs runs the real hand-off under mpirun.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use tetfem_cli::scene::{EngineKind, PetscSolver, RunOptions, Scene, run_static_with};

fn scratch(name: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR"))
        .join("engine_handoff")
        .join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("scratch folder");
    dir
}

fn scenes() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes")
}

/// The cantilever scene with `engine = "petsc"` and `extra` appended.
fn petsc_scene(dir: &Path, extra: &str) -> PathBuf {
    let text = std::fs::read_to_string(scenes().join("cantilever_static.toml")).expect("scene");
    let path = dir.join("beam.toml");
    std::fs::write(&path, format!("engine = \"petsc\"\n{text}\n{extra}")).expect("written");
    path
}

/// A stand-in for tetfem-petsc: writes its arguments, one per line, to `args.txt` beside it
/// and exits with status 3.
fn stand_in(dir: &Path) -> PathBuf {
    let script = dir.join("tetfem-petsc");
    let record = dir.join("args.txt");
    std::fs::write(
        &script,
        format!(
            "#!/bin/sh\nfor a in \"$@\"; do echo \"$a\"; done > '{}'\nexit 3\n",
            record.display()
        ),
    )
    .expect("script written");
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        std::fs::set_permissions(&script, std::fs::Permissions::from_mode(0o755))
            .expect("executable");
    }
    script
}

fn tetfem(args: &[&str], engine_binary: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_tetfem"))
        .args(args)
        .env("TETFEM_PETSC_BINARY", engine_binary)
        .output()
        .expect("tetfem runs")
}

#[cfg(unix)]
#[test]
fn a_petsc_scene_is_handed_to_the_engine_with_the_shared_options() {
    let dir = scratch("handoff-args");
    let scene = petsc_scene(&dir, "");
    let script = stand_in(&dir);
    let scene_arg = scene.to_str().expect("utf-8 path");
    let output = tetfem(
        &[
            "run",
            scene_arg,
            "--out",
            "elsewhere",
            "--json",
            "--vtu-format",
            "ascii",
            "--petsc-options",
            "-ksp_rtol 1e-10 -ksp_monitor",
        ],
        &script,
    );
    // exec: the engine's exit status is tetfem's.
    assert_eq!(output.status.code(), Some(3), "{output:?}");
    let args = std::fs::read_to_string(dir.join("args.txt")).expect("the stand-in ran");
    let args: Vec<&str> = args.lines().collect();
    assert_eq!(
        args,
        [
            scene_arg,
            "--out",
            "elsewhere",
            "--json",
            "--vtu-format",
            "ascii",
            "-ksp_rtol",
            "1e-10",
            "-ksp_monitor"
        ]
    );
    // --engine petsc hands a scene that does not name the engine, too.
    std::fs::remove_file(dir.join("args.txt")).expect("removed");
    let plain = scenes().join("cantilever_static.toml");
    let output = tetfem(
        &[
            "run",
            plain.to_str().expect("utf-8"),
            "--engine",
            "petsc",
            "--quiet",
        ],
        &script,
    );
    assert_eq!(output.status.code(), Some(3), "{output:?}");
    let args = std::fs::read_to_string(dir.join("args.txt")).expect("the stand-in ran");
    assert_eq!(args.lines().nth(1), Some("--quiet"));
    // tetfem export --petsc SCENE DIR is tetfem-petsc SCENE --export DIR.
    let output = tetfem(
        &[
            "export",
            "--petsc",
            plain.to_str().expect("utf-8"),
            "system",
        ],
        &script,
    );
    assert_eq!(output.status.code(), Some(3), "{output:?}");
    let args = std::fs::read_to_string(dir.join("args.txt")).expect("the stand-in ran");
    let args: Vec<&str> = args.lines().collect();
    assert_eq!(args, [plain.to_str().expect("utf-8"), "--export", "system"]);
}

#[test]
fn what_the_engine_does_not_take_is_refused_before_the_hand_off() {
    let dir = scratch("handoff-refused");
    let scene = petsc_scene(&dir, "");
    let script = stand_in(&dir);
    let output = tetfem(
        &["run", scene.to_str().expect("utf-8"), "--dt", "1e-4"],
        &script,
    );
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(!output.status.success());
    assert!(
        stderr.contains("--dt") && stderr.contains("PETSc engine"),
        "{stderr}"
    );
    assert!(!dir.join("args.txt").exists(), "the engine was not started");
    // --petsc-options with tetfem's own engine.
    let plain = scenes().join("cantilever_static.toml");
    let output = tetfem(
        &[
            "run",
            plain.to_str().expect("utf-8"),
            "--petsc-options",
            "-ksp_monitor",
        ],
        &script,
    );
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(!output.status.success());
    assert!(stderr.contains("--petsc-options"), "{stderr}");
}

#[test]
fn a_missing_engine_binary_says_how_to_build_it() {
    let dir = scratch("handoff-missing");
    let scene = petsc_scene(&dir, "");
    let missing = dir.join("no-such-engine");
    let output = tetfem(&["run", scene.to_str().expect("utf-8")], &missing);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(!output.status.success());
    assert!(
        stderr.contains("TETFEM_PETSC_BINARY") && stderr.contains("no-such-engine"),
        "{stderr}"
    );
    // Without the variable, the lookup beside tetfem and on PATH ends in the build hint (unless
    // a developer built tetfem-petsc into the same folder, as `cargo build -p tetfem-petsc
    // --features petsc` does).
    let beside = Path::new(env!("CARGO_BIN_EXE_tetfem")).with_file_name("tetfem-petsc");
    if !beside.exists() {
        let output = Command::new(env!("CARGO_BIN_EXE_tetfem"))
            .args(["run", scene.to_str().expect("utf-8")])
            .env_remove("TETFEM_PETSC_BINARY")
            .env("PATH", &dir)
            .output()
            .expect("tetfem runs");
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert!(!output.status.success());
        assert!(
            stderr.contains("--features petsc") && stderr.contains("apt-get install petsc-dev"),
            "{stderr}"
        );
    }
}

#[test]
fn the_scene_keys_are_checked_with_key_and_line_and_in_process_runners_refuse_petsc_scenes() {
    let dir = scratch("handoff-keys");
    let scene = Scene::load(&petsc_scene(
        &dir,
        "[petsc]\nsolver = \"mumps\"\noptions = \"-ksp_rtol 1e-10 -ksp_monitor\"\n",
    ))
    .expect("a valid scene");
    assert_eq!(scene.engine().kind, EngineKind::Petsc);
    assert_eq!(scene.engine().petsc_solver, Some(PetscSolver::Mumps));
    assert_eq!(
        scene.engine().petsc_options,
        [
            ("-ksp_rtol".to_string(), Some("1e-10".to_string())),
            ("-ksp_monitor".to_string(), None)
        ]
    );
    // The in-process runner names the key and its line (`file:1: engine: …`: it was
    // prepended).
    let message = run_static_with(&scene, &RunOptions::default())
        .expect_err("a PETSc scene")
        .to_string();
    assert!(
        message.contains(":1: engine:") && message.contains("tetfem run"),
        "{message}"
    );
    let mut overridden = scene.clone();
    overridden.set_engine(EngineKind::Tetfem);
    assert!(overridden.require_tetfem_engine().is_ok());

    let text = std::fs::read_to_string(scenes().join("cantilever_static.toml")).expect("scene");
    let lines = text.lines().count();
    for (extra, key, line, what) in [
        (
            "[petsc]\noptions = \"ksp_rtol 1e-10\"\n",
            "petsc.options",
            lines + 4,
            "'ksp_rtol' comes before any option name",
        ),
        (
            "[petsc]\nsolver = \"lu\"\n",
            "petsc.solver",
            lines + 4,
            "unknown variant",
        ),
    ] {
        let path = dir.join("bad.toml");
        std::fs::write(&path, format!("engine = \"petsc\"\n{text}\n{extra}")).expect("written");
        let message = Scene::load(&path).expect_err(key).to_string();
        assert!(
            message.contains(&format!(":{line}: {key}")) && message.contains(what),
            "{key}: {message}"
        );
    }
    let path = dir.join("bad_engine.toml");
    std::fs::write(&path, format!("engine = \"mpi\"\n{text}")).expect("written");
    let message = Scene::load(&path).expect_err("engine").to_string();
    assert!(message.contains(":1: engine"), "{message}");
}
