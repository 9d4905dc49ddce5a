//! The `tetfem` binary: default scene run, its `.vtu` output read back, help and errors.

mod common;

use std::path::PathBuf;
use std::process::Command;

use tetfem::cantilever::Cantilever;

fn out_dir(name: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(name);
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
    let text = std::fs::read_to_string(dir.join("cantilever.vtu")).unwrap();
    let vtu = common::parse_vtu(&text);
    let scene = Cantilever {
        cells: [20, 2, 2],
        ..Cantilever::steel_default()
    };
    let solved = scene.solve().unwrap();
    assert_eq!(vtu.points, solved.mesh.node_count());
    assert_eq!(vtu.cells, solved.mesh.tet_count());
    let (section, _, components, values) = vtu.array("displacement").expect("displacement array");
    assert_eq!((section.as_str(), *components), ("PointData", 3));
    // The file holds the library's solution, printed in shortest round-trip form: exact.
    assert_eq!(values, &solved.solution.displacement);
    let (section, _, _, stress) = vtu.array("von_mises_stress").expect("stress array");
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
    assert!(!dir.join("cantilever.vtu").exists());
    let output = Command::new(env!("CARGO_BIN_EXE_tetfem"))
        .args(["--cells", "ten"])
        .output()
        .unwrap();
    assert!(!output.status.success());
}
