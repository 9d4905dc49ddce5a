//! Every file tetfem reads must be a regular file (issue 33, item 5): a FIFO given as the scene
//! file or as the checkpoint used to block forever, a checkpoint that is a link to /dev/zero
//! read gigabytes. Each input kind — the scene file, a mesh file the scene names, the
//! checkpoint, the `.pvd` and CSV a resume continues — given as a FIFO and as a symbolic link
//! to /dev/zero is refused at once with an error naming the path. And a resume whose `.pvd` is
//! missing or damaged, or lists a frame file that is missing, is refused naming the file
//! (it used to drop the earlier frames silently).

use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

const STEM: &str = "run";

/// A small explicit run: 20 steps, a frame every 5, a checkpoint every 10.
const SCENE: &str = r#"
title = "input files"
[mesh.box]
max = [1.0, 0.1, 0.1]
cells = [4, 1, 1]
[material]
youngs_modulus = 200e9
poisson_ratio = 0.3
density = 7850.0
[[constraints]]
where = { plane = { axis = "x", at = 0.0 } }
[[loads]]
where = { plane = { axis = "x", at = 1.0 } }
total_force = [0.0, 0.0, -10e3]
[analysis]
type = "dynamic"
method = "explicit"
dt = 1e-7
duration = 2e-6
[output]
every = 5
checkpoint_every = 10
"#;

fn folder(name: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(format!("input-files-{name}"));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Runs `tetfem run <args>`; fails if it takes over 30 s (a read blocked on a FIFO, or
/// gigabytes read from /dev/zero, would). Returns (exit code, stderr).
fn tetfem(args: &[&std::ffi::OsStr]) -> (Option<i32>, String) {
    let mut child = Command::new(env!("CARGO_BIN_EXE_tetfem"))
        .arg("run")
        .args(args)
        .arg("--quiet")
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let deadline = Instant::now() + Duration::from_secs(30);
    let status = loop {
        if let Some(status) = child.try_wait().unwrap() {
            break status;
        }
        if Instant::now() > deadline {
            let _ = child.kill();
            let _ = child.wait();
            panic!("tetfem run {args:?} still running after 30 s");
        }
        std::thread::sleep(Duration::from_millis(10));
    };
    let mut stderr = String::new();
    child
        .stderr
        .take()
        .unwrap()
        .read_to_string(&mut stderr)
        .unwrap();
    (status.code(), stderr)
}

/// Replaces `path` by a FIFO (`fifo`) or a symbolic link to /dev/zero; false if the system
/// cannot make one (no `mkfifo`), and the case is skipped.
fn make_stream(path: &Path, fifo: bool) -> bool {
    let _ = std::fs::remove_file(path);
    if fifo {
        Command::new("mkfifo")
            .arg(path)
            .status()
            .is_ok_and(|s| s.success())
    } else {
        std::os::unix::fs::symlink("/dev/zero", path).is_ok()
    }
}

/// The error of a run refused for `path`: exit status 1, the path named, "regular file" said.
fn assert_refused(args: &[&std::ffi::OsStr], path: &Path) {
    let (code, stderr) = tetfem(args);
    assert_eq!(code, Some(1), "{stderr}");
    assert!(
        stderr.contains(&path.display().to_string()) && stderr.contains("regular file"),
        "{}: {stderr}",
        path.display()
    );
}

/// Writes the scene and runs it to its checkpoint at step 10 (of 20), then a frame at 15 and the
/// end at 20: the folder a resume continues. Returns (scene path, output folder).
fn checkpointed_run(dir: &Path) -> (PathBuf, PathBuf) {
    let scene = dir.join(format!("{STEM}.toml"));
    std::fs::write(&scene, SCENE).unwrap();
    let out = dir.join("out");
    let (code, stderr) = tetfem(&[scene.as_os_str(), "--out".as_ref(), out.as_os_str()]);
    assert_eq!(code, Some(0), "{stderr}");
    assert!(out.join(format!("{STEM}_checkpoint.bin")).is_file());
    (scene, out)
}

/// `--resume` of `scene` into `out`, to 30 steps.
fn resume_args<'a>(scene: &'a Path, out: &'a Path) -> Vec<&'a std::ffi::OsStr> {
    vec![
        scene.as_os_str(),
        "--resume".as_ref(),
        "--steps".as_ref(),
        "30".as_ref(),
        "--out".as_ref(),
        out.as_os_str(),
    ]
}

#[test]
fn a_scene_file_that_is_a_fifo_or_a_link_to_dev_zero_is_refused_at_once() {
    let dir = folder("scene");
    for fifo in [true, false] {
        let scene = dir.join(format!("stream-{fifo}.toml"));
        if make_stream(&scene, fifo) {
            assert_refused(
                &[
                    scene.as_os_str(),
                    "--out".as_ref(),
                    dir.join("out").as_os_str(),
                ],
                &scene,
            );
        }
    }
}

#[test]
fn a_mesh_file_a_scene_names_that_is_a_stream_is_refused_at_once() {
    let dir = folder("mesh");
    for fifo in [true, false] {
        let mesh = dir.join(format!("stream-{fifo}.msh"));
        if !make_stream(&mesh, fifo) {
            continue;
        }
        let scene = dir.join(format!("mesh-{fifo}.toml"));
        let text = SCENE.replace(
            "[mesh.box]\nmax = [1.0, 0.1, 0.1]\ncells = [4, 1, 1]",
            &format!(
                "[mesh.gmsh]\nfile = \"{}\"",
                mesh.file_name().unwrap().to_str().unwrap()
            ),
        );
        std::fs::write(&scene, text).unwrap();
        assert_refused(
            &[
                scene.as_os_str(),
                "--out".as_ref(),
                dir.join("out").as_os_str(),
            ],
            &mesh,
        );
    }
}

#[test]
fn a_checkpoint_that_is_a_fifo_or_a_link_to_dev_zero_is_refused_at_once() {
    let dir = folder("checkpoint");
    let (scene, out) = checkpointed_run(&dir);
    let checkpoint = out.join(format!("{STEM}_checkpoint.bin"));
    for fifo in [true, false] {
        if make_stream(&checkpoint, fifo) {
            assert_refused(&resume_args(&scene, &out), &checkpoint);
        }
    }
}

#[test]
fn a_pvd_or_csv_that_is_a_stream_is_refused_on_resume() {
    for file in [format!("{STEM}.pvd"), format!("{STEM}.csv")] {
        for fifo in [true, false] {
            let dir = folder(&format!("resume-{file}-{fifo}"));
            let (scene, out) = checkpointed_run(&dir);
            let path = out.join(&file);
            if make_stream(&path, fifo) {
                assert_refused(&resume_args(&scene, &out), &path);
            }
        }
    }
}

/// The frames a `.pvd` lists (file names).
fn listed(pvd: &Path) -> Vec<String> {
    let text = std::fs::read_to_string(pvd).unwrap();
    text.lines()
        .filter_map(|l| l.split("file=\"").nth(1))
        .map(|rest| rest.split('"').next().unwrap().to_string())
        .collect()
}

/// A resume continues the `.pvd`: a missing or damaged one, or a listed frame file that is
/// gone, would leave a collection without the frames before the checkpoint (0, 5, 10) — it
/// is refused naming the file, and the folder is left as it was.
#[test]
fn a_resume_without_its_earlier_frames_is_refused_naming_the_file() {
    let dir = folder("pvd-missing");
    let (scene, out) = checkpointed_run(&dir);
    let pvd = out.join(format!("{STEM}.pvd"));
    let frames = listed(&pvd);
    assert_eq!(frames.len(), 5, "{frames:?}"); // steps 0, 5, 10, 15, 20
    let text = std::fs::read_to_string(&pvd).unwrap();

    // Missing.
    std::fs::remove_file(&pvd).unwrap();
    let (code, stderr) = tetfem(&resume_args(&scene, &out));
    assert_eq!(code, Some(1), "{stderr}");
    assert!(
        stderr.contains(&pvd.display().to_string()) && stderr.contains("missing"),
        "{stderr}"
    );

    // Garbled: no DataSet line survives.
    std::fs::write(&pvd, "<?xml version=\"1.0\"?>\n<VTKFile garbage").unwrap();
    let (code, stderr) = tetfem(&resume_args(&scene, &out));
    assert_eq!(code, Some(1), "{stderr}");
    assert!(
        stderr.contains(&pvd.display().to_string())
            && stderr.contains("lists 0 frames up to the checkpoint")
            && stderr.contains("wrote 5"),
        "{stderr}"
    );
    assert_eq!(
        std::fs::read_to_string(&pvd).unwrap(),
        "<?xml version=\"1.0\"?>\n<VTKFile garbage"
    );

    // A listed frame file before the checkpoint is gone.
    std::fs::write(&pvd, &text).unwrap();
    let gone = out.join(&frames[1]);
    std::fs::remove_file(&gone).unwrap();
    let (code, stderr) = tetfem(&resume_args(&scene, &out));
    assert_eq!(code, Some(1), "{stderr}");
    assert!(
        stderr.contains(&gone.display().to_string()) && stderr.contains("missing"),
        "{stderr}"
    );
    // The collection is untouched by the refused resume.
    assert_eq!(std::fs::read_to_string(&pvd).unwrap(), text);
}

/// The intact folder resumes: the check refuses only what is wrong.
#[test]
fn an_intact_folder_resumes() {
    let dir = folder("pvd-intact");
    let (scene, out) = checkpointed_run(&dir);
    let (code, stderr) = tetfem(&resume_args(&scene, &out));
    assert_eq!(code, Some(0), "{stderr}");
    // Frames 0, 5, 10 kept; 15, 20 (written after the checkpoint) rewritten; 25, 30 added.
    assert_eq!(listed(&out.join(format!("{STEM}.pvd"))).len(), 7);
}
