//! The `tetfem` binary: default scene run, its `.vtu` output read back, help and errors.

use crate::common;

use std::path::PathBuf;
use std::process::Command;

use tetfem_fixtures::cantilever::Cantilever;

fn out_dir(name: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR"))
        .join("cli")
        .join(name);
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

#[test]
fn default_scene_writes_a_vtu_that_parses_back() {
    let dir = out_dir("cli-default");
    let output = Command::new(env!("CARGO_BIN_EXE_tetfem"))
        .args(["--cells", "20,2,2", "--out"])
        .arg(&dir)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(
        output.status.success(),
        "stdout: {stdout}\nstderr: {}",
        String::from_utf8_lossy(&output.stderr)
    );
    for expected in [
        "Euler–Bernoulli",
        "Timoshenko",
        "factorization",
        "cantilever.vtu",
    ] {
        assert!(
            stdout.contains(expected),
            "missing '{expected}' in:\n{stdout}"
        );
    }
    let text = std::fs::read(dir.join("cantilever/cantilever.vtu")).unwrap();
    let vtu = common::parse_vtu(&text);
    let scene = Cantilever {
        cells: [20, 2, 2],
        // The default run meshes with the mirrored split (src/bin/tetfem.rs).
        split: tetfem::BoxSplit::Mirrored6,
        ..Cantilever::steel_default()
    };
    let solved = scene.solve().unwrap();
    assert_eq!(vtu.points, solved.mesh.node_count());
    assert_eq!(vtu.cells, solved.mesh.tet_count());
    let (section, _, components, values) = vtu.array("displacement").expect("displacement array");
    assert_eq!((section.as_str(), *components), ("PointData", 3));
    // The file holds the library's solution, printed in shortest round-trip form: exact.
    assert_eq!(values, &solved.solution.displacement);
    let (section, _, _, stress) = vtu.array("von_mises").expect("stress array");
    assert_eq!(
        (section.as_str(), stress.len()),
        ("CellData", solved.mesh.tet_count())
    );
    assert!(stress.iter().all(|s| *s >= 0.0) && stress.iter().any(|s| *s > 0.0));
    let connectivity = &vtu.array("connectivity").unwrap().3;
    assert_eq!(connectivity.len(), 4 * solved.mesh.tet_count());
    assert_eq!(connectivity[..4], solved.mesh.tets()[0].map(|n| n as f64));
}

#[test]
fn help_describes_the_default_scene() {
    let output = Command::new(env!("CARGO_BIN_EXE_tetfem"))
        .arg("--help")
        .output()
        .unwrap();
    assert!(output.status.success());
    let text = String::from_utf8_lossy(&output.stdout);
    assert!(
        text.contains("--cells") && text.contains("cantilever"),
        "{text}"
    );
}

#[test]
fn invalid_arguments_fail_with_a_message_and_no_output() {
    let dir = out_dir("cli-invalid");
    let output = Command::new(env!("CARGO_BIN_EXE_tetfem"))
        .args(["--cells", "0,2,2", "--out"])
        .arg(&dir)
        .output()
        .unwrap();
    assert!(!output.status.success());
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(stderr.contains("cells[0]"), "{stderr}");
    assert!(!dir.join("cantilever").exists());
    let output = Command::new(env!("CARGO_BIN_EXE_tetfem"))
        .args(["--cells", "ten"])
        .output()
        .unwrap();
    assert!(!output.status.success());
}

fn tetfem(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_tetfem"))
        .args(args)
        .output()
        .unwrap()
}

#[test]
fn default_dynamic_run_writes_a_pvd_series_and_a_csv() {
    let dir = out_dir("cli-dynamic");
    let d = dir.to_str().unwrap();
    let output = tetfem(&[
        "--cells",
        "10,1,1",
        "--dynamic-cells",
        "10,1,1",
        "--periods",
        "0.5",
        "--out",
        d,
    ]);
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(
        output.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&output.stderr)
    );
    assert!(
        stdout.contains("explicit critical step") && stdout.contains("per step"),
        "{stdout}"
    );
    // The .pvd lists the frames with increasing times, and every frame exists and parses.
    let dir = dir.join("cantilever_swing");
    let pvd = std::fs::read_to_string(dir.join("cantilever_swing.pvd")).unwrap();
    let doc = roxmltree::Document::parse(&pvd).unwrap();
    let frames: Vec<(f64, String)> = doc
        .descendants()
        .filter(|n| n.has_tag_name("DataSet"))
        .map(|n| {
            (
                n.attribute("timestep").unwrap().parse().unwrap(),
                n.attribute("file").unwrap().to_string(),
            )
        })
        .collect();
    assert!(frames.len() > 2);
    assert!(frames.windows(2).all(|w| w[1].0 > w[0].0));
    for (_, file) in &frames {
        let vtu = common::parse_vtu(std::fs::read(dir.join(file)).unwrap());
        assert!(vtu.array("displacement").is_some() && vtu.array("velocity").is_some());
    }
    // CSV: header with the tip and every energy term, one row per frame.
    let csv = std::fs::read_to_string(dir.join("cantilever_swing.csv")).unwrap();
    let mut lines = csv.lines();
    let header = lines.next().unwrap();
    for column in [
        "time_s",
        "tip_uz_m",
        "kinetic_J",
        "elastic_J",
        "gravity_potential_J",
        "total_J",
        "wall_seconds_per_step",
    ] {
        assert!(header.contains(column), "{header}");
    }
    // One row per step, the initial state included; the last frame is the last step.
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect();
    let last = rows.last().unwrap();
    assert_eq!(
        (last[0], last[1]),
        (frames.last().unwrap().0, (rows.len() - 1) as f64)
    );
    assert!(rows.len() >= frames.len());
}

#[test]
fn explicit_above_its_critical_step_fails_with_a_divergence_message() {
    let dir = out_dir("cli-diverge");
    let output = tetfem(&[
        "--cells",
        "10,1,1",
        "--dynamic-cells",
        "10,1,1",
        "--method",
        "explicit",
        "--dt",
        "1e-4",
        "--out",
        dir.to_str().unwrap(),
    ]);
    assert!(!output.status.success());
    let stderr = String::from_utf8_lossy(&output.stderr);
    // The library's error names the remedy; the CLI adds nothing of its own.
    assert!(
        stderr.contains("diverged") && stderr.contains(tetfem::analysis::dynamics::EXPLICIT_REMEDY),
        "{stderr}"
    );
    assert!(!stderr.contains("hint:"), "{stderr}");
    // The frames written before the blow-up still form a valid collection.
    let pvd = std::fs::read_to_string(dir.join("cantilever_swing/cantilever_swing.pvd")).unwrap();
    assert!(roxmltree::Document::parse(&pvd).is_ok());
}

#[test]
fn every_shipped_scene_runs() {
    for entry in std::fs::read_dir(concat!(
        concat!(env!("CARGO_MANIFEST_DIR"), "/../.."),
        "/scenes"
    ))
    .unwrap()
    {
        let path = entry.unwrap().path();
        if path.extension().and_then(|e| e.to_str()) != Some("toml") {
            continue;
        }
        let dir = out_dir(&format!(
            "cli-scene-{}",
            path.file_stem().unwrap().to_string_lossy()
        ));
        let output = tetfem(&[
            "run",
            path.to_str().unwrap(),
            "--out",
            dir.to_str().unwrap(),
            "--json",
        ]);
        let stdout = String::from_utf8_lossy(&output.stdout);
        assert!(
            output.status.success(),
            "{}: {stdout}\n{}",
            path.display(),
            String::from_utf8_lossy(&output.stderr)
        );
        let summary: serde_json::Value = serde_json::from_str(stdout.trim()).unwrap();
        assert!(summary["title"].is_string(), "{summary}");
        assert!(
            std::fs::read_dir(&dir).unwrap().count() > 0,
            "{}: no files",
            path.display()
        );
    }
}

#[test]
fn info_reports_the_mesh_counts() {
    let path = concat!(
        concat!(env!("CARGO_MANIFEST_DIR"), "/../.."),
        "/scenes/l_bracket.msh"
    );
    let mesh = tetfem::mesh::io::read_mesh(std::path::Path::new(path)).unwrap();
    let output = tetfem(&["info", path, "--material", "200e9,0.3,7850"]);
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(output.status.success(), "{stdout}");
    assert!(
        stdout.contains(&format!("nodes {}", mesh.mesh.node_count())),
        "{stdout}"
    );
    assert!(
        stdout.contains(&format!("tets {}", mesh.mesh.tet_count())),
        "{stdout}"
    );
    assert!(stdout.contains("critical step"), "{stdout}");
    assert!(!tetfem(&["info", "/nonexistent.msh"]).status.success());
    assert!(
        !tetfem(&["info", path, "--material", "1,0.7,1"])
            .status
            .success()
    );
}

/// Ctrl-C (SIGINT) during a dynamic run: the run stops at a step boundary, exits with 130, and
/// leaves a `.pvd` that lists exactly the frames written, each complete, plus the CSV rows up
/// to the stop.
#[test]
fn ctrl_c_stops_a_dynamic_run_with_a_valid_pvd() {
    let dir = out_dir("cli-ctrl-c");
    let scene = concat!(
        concat!(env!("CARGO_MANIFEST_DIR"), "/../.."),
        "/scenes/cantilever_dynamic.toml"
    );
    let mut child = Command::new(env!("CARGO_BIN_EXE_tetfem"))
        .args(["run", scene, "--steps", "1000000", "--quiet", "--out"])
        .arg(&dir)
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let pvd_path = dir.join("cantilever_dynamic.pvd");
    // Wait for a few frames (every 10 steps), then interrupt; a million steps would take hours.
    // A child that died early fails the test instead of leaving it waiting for frames.
    let start = std::time::Instant::now();
    loop {
        if let Some(status) = child.try_wait().unwrap() {
            panic!("the run ended before it was interrupted: {status}");
        }
        let listed = std::fs::read_to_string(&pvd_path)
            .map(|text| text.matches("<DataSet").count())
            .unwrap_or(0);
        if listed >= 3 {
            break;
        }
        if start.elapsed().as_secs() > 120 {
            let _ = child.kill();
            panic!("no frames after two minutes");
        }
        std::thread::sleep(std::time::Duration::from_millis(50));
    }
    let killed = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(killed.success());
    // The run stops at the next step boundary: a minute is far more than one step and frame.
    let stopped = std::time::Instant::now();
    while child.try_wait().unwrap().is_none() {
        if stopped.elapsed().as_secs() > 60 {
            let _ = child.kill();
            panic!("the run did not stop within a minute of Ctrl-C");
        }
        std::thread::sleep(std::time::Duration::from_millis(50));
    }
    let output = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(130), "{stderr}");
    assert!(stderr.contains("interrupted after step"), "{stderr}");

    let pvd = std::fs::read_to_string(&pvd_path).unwrap();
    let doc = roxmltree::Document::parse(&pvd).expect("the .pvd is well-formed XML");
    let frames: Vec<String> = doc
        .descendants()
        .filter(|n| n.has_tag_name("DataSet"))
        .map(|n| n.attribute("file").unwrap().to_string())
        .collect();
    assert!(frames.len() >= 3);
    for file in &frames {
        let text = std::fs::read(dir.join(file)).unwrap();
        let vtu = common::parse_vtu(&text);
        assert!(
            vtu.points > 0 && vtu.array("displacement").is_some(),
            "{file}"
        );
    }
    // Every .vtu on disk is listed (none half-written and left out), and the message counts them.
    let on_disk = std::fs::read_dir(&dir)
        .unwrap()
        .filter(|e| {
            e.as_ref()
                .is_ok_and(|e| e.path().extension().is_some_and(|x| x == "vtu"))
        })
        .count();
    assert_eq!(on_disk, frames.len());
    assert!(
        stderr.contains(&format!("{} frames", frames.len())),
        "{stderr}"
    );
    // The CSV holds the rows up to the stop: the initial state plus ≥ 10 steps per frame after
    // the first.
    let csv = std::fs::read_to_string(dir.join("cantilever_dynamic.csv")).unwrap();
    assert!(
        csv.lines().count() > 10 * (frames.len() - 1),
        "{}",
        csv.lines().count()
    );
}
