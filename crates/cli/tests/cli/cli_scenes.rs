//! The `tetfem` binary's subcommands: every shipped scene through `tetfem run` (outputs exist
//! and parse), `--json`, `info`, the default scene's dynamic part, divergence of the explicit
//! method above its critical step, help and bad arguments.

use crate::common;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn tetfem(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_tetfem"))
        .args(args)
        .output()
        .unwrap()
}

fn out_dir(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join("cli_scenes")
        .join(name);
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

fn scene(name: &str) -> String {
    Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../.."))
        .join("scenes")
        .join(name)
        .display()
        .to_string()
}

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

fn expect_success(output: &Output) -> String {
    let stdout = text(&output.stdout);
    assert!(
        output.status.success(),
        "stdout: {stdout}\nstderr: {}",
        text(&output.stderr)
    );
    stdout
}

/// (time, file) of each DataSet of a `.pvd`.
fn parse_pvd(path: &Path) -> Vec<(f64, String)> {
    let source = std::fs::read_to_string(path).unwrap();
    let document = roxmltree::Document::parse(&source).expect("well-formed XML");
    document
        .descendants()
        .filter(|n| n.has_tag_name("DataSet"))
        .map(|n| {
            (
                n.attribute("timestep").unwrap().parse().unwrap(),
                n.attribute("file").unwrap().to_string(),
            )
        })
        .collect()
}

/// Header and rows of a CSV of numbers.
fn parse_csv(path: &Path) -> (Vec<String>, Vec<Vec<f64>>) {
    let source = std::fs::read_to_string(path).unwrap();
    let mut lines = source.lines();
    let header = lines
        .next()
        .unwrap()
        .split(',')
        .map(str::to_string)
        .collect();
    let rows = lines
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect();
    (header, rows)
}

fn column(header: &[String], name: &str) -> usize {
    header
        .iter()
        .position(|c| c == name)
        .unwrap_or_else(|| panic!("no column {name} in {header:?}"))
}

fn json(stdout: &str) -> serde_json::Value {
    serde_json::from_str(stdout.trim()).unwrap_or_else(|e| panic!("{e}: {stdout}"))
}

fn check_vtu(path: &Path, nodes: usize, tets: usize) -> common::VtuSummary {
    let vtu = common::parse_vtu(std::fs::read(path).unwrap());
    assert_eq!((vtu.points, vtu.cells), (nodes, tets), "{}", path.display());
    let displacement = &vtu.array("displacement").expect("displacement").3;
    assert_eq!(displacement.len(), 3 * nodes);
    assert_eq!(vtu.array("von_mises").expect("von_mises").3.len(), tets);
    vtu
}

#[test]
fn static_scenes_run_through_the_cli() {
    for (name, probe) in [
        ("cantilever_static.toml", "tip"),
        ("hanging_bar.toml", "bottom"),
        ("soft_block.toml", "free_face"),
        ("l_bracket.toml", "load_face"),
    ] {
        let dir = out_dir(name);
        let output = tetfem(&[
            "run",
            &scene(name),
            "--out",
            dir.to_str().unwrap(),
            "--json",
        ]);
        let summary = json(&expect_success(&output));
        assert_eq!(summary["analysis"], "static", "{name}");
        let nodes = summary["nodes"].as_u64().unwrap() as usize;
        let tets = summary["tets"].as_u64().unwrap() as usize;
        assert!(
            summary["relative_residual"].as_f64().unwrap() < 1e-8,
            "{name}"
        );
        assert!(
            summary["max_displacement"].as_f64().unwrap() > 0.0,
            "{name}"
        );
        assert_eq!(summary["probes"][0]["name"], probe, "{name}");
        let stem = name.trim_end_matches(".toml");
        let vtu = check_vtu(&dir.join(format!("{stem}.vtu")), nodes, tets);
        let max_u = vtu
            .array("displacement_magnitude")
            .unwrap()
            .3
            .iter()
            .fold(0.0, |a: f64, &b| a.max(b));
        // serde_json parses floats to within an ulp.
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-14 * b.abs();
        let expected = summary["max_displacement"].as_f64().unwrap();
        assert!(close(max_u, expected), "{name}: {max_u} vs {expected}");
        let frames = parse_pvd(&dir.join(format!("{stem}.pvd")));
        assert_eq!(frames, vec![(0.0, format!("{stem}.vtu"))], "{name}");
        let (header, rows) = parse_csv(&dir.join(format!("{stem}_probes.csv")));
        assert_eq!(rows.len(), 1, "{name}");
        let uz = rows[0][column(&header, &format!("{probe}_uz_m"))];
        let expected = summary["probes"][0]["displacement"][2].as_f64().unwrap();
        assert!(close(uz, expected), "{name}: {uz} vs {expected}");
        // Every shipped static scene asks for a PNG.
        assert!(dir.join(format!("{stem}.png")).is_file(), "{name}");
        assert!(dir.join(format!("{stem}_summary.json")).is_file(), "{name}");
    }
}

#[test]
fn dynamic_scene_runs_short_with_frames_series_and_pngs() {
    let dir = out_dir("cantilever_dynamic");
    let output = tetfem(&[
        "run",
        &scene("cantilever_dynamic.toml"),
        "--out",
        dir.to_str().unwrap(),
        "--steps",
        "25",
        "--json",
        "--quiet",
    ]);
    let stdout = expect_success(&output);
    assert_eq!(
        stdout.trim().lines().count(),
        1,
        "one JSON object: {stdout}"
    );
    let summary = json(&stdout);
    assert_eq!(summary["analysis"], "dynamic");
    assert_eq!(summary["method"], "backward-euler");
    assert_eq!(summary["steps"], 25);
    assert_eq!(summary["dt"], 1e-4);
    let critical = summary["critical_step"].as_f64().unwrap();
    assert!(critical > 0.0 && critical < 1e-4, "{critical}");
    assert_eq!(summary["critical_step_source"], "Lanczos iteration");
    let end_time = summary["end_time"].as_f64().unwrap();
    assert!((end_time - 25e-4).abs() < 1e-12, "{end_time}");
    let (nodes, tets) = (
        summary["nodes"].as_u64().unwrap() as usize,
        summary["tets"].as_u64().unwrap() as usize,
    );
    assert_eq!(tets, 20 * 2 * 2 * 6);

    // Frames every 10 steps (the scene's output.every) and at the last step.
    let frames = parse_pvd(&dir.join("cantilever_dynamic.pvd"));
    let steps: Vec<usize> = vec![0, 10, 20, 25];
    assert_eq!(frames.len(), steps.len(), "{frames:?}");
    assert_eq!(summary["frames"], steps.len());
    for (i, ((time, file), step)) in frames.iter().zip(&steps).enumerate() {
        assert!(
            (time - *step as f64 * 1e-4).abs() < 1e-12,
            "{time} vs step {step}"
        );
        if i > 0 {
            assert!(*time > frames[i - 1].0);
        }
        let vtu = check_vtu(&dir.join(file), nodes, tets);
        assert_eq!(vtu.array("velocity").expect("velocity").3.len(), 3 * nodes);
        let png = dir.join(file.replace(".vtu", ".png"));
        let bytes = std::fs::read(&png).unwrap();
        assert_eq!(&bytes[1..4], b"PNG", "{}", png.display());
    }

    // One CSV row per step plus the initial state.
    let (header, rows) = parse_csv(&dir.join("cantilever_dynamic.csv"));
    for c in [
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
    ] {
        column(&header, c);
    }
    // The scene has one [[constraints]] entry: six reaction columns.
    assert_eq!(header.len(), 17);
    assert_eq!(rows.len(), 26);
    let (t, step, wall, uz) = (
        column(&header, "time_s"),
        column(&header, "step"),
        column(&header, "wall_seconds_per_step"),
        column(&header, "tip_uz_m"),
    );
    for (i, row) in rows.iter().enumerate() {
        assert_eq!(row[step], i as f64);
        assert!((row[t] - i as f64 * 1e-4).abs() < 1e-12);
        assert!(row[wall] >= 0.0 && (i == 0 || row[wall] > 0.0));
    }
    // Released from rest under a suddenly applied downward end load: starts at zero, moves down.
    assert_eq!(rows[0][uz], 0.0);
    assert_eq!(rows[0][column(&header, "kinetic_J")], 0.0);
    assert!(rows[25][uz] < 0.0);
    let last = &summary["probes"][0];
    let close = |a: f64, b: f64| (a - b).abs() <= 1e-14 * b.abs();
    assert!(close(last["last"][2].as_f64().unwrap(), rows[25][uz]));
    let min = rows.iter().map(|r| r[uz]).fold(f64::INFINITY, f64::min);
    assert!(close(last["min"][2].as_f64().unwrap(), min));
    // Backward Euler only dissipates: the total energy never rises from step to step.
    let total = column(&header, "total_J");
    for pair in rows.windows(2) {
        assert!(
            pair[1][total] <= pair[0][total] + 1e-12 * pair[0][total].abs().max(1e-9),
            "{} → {}",
            pair[0][total],
            pair[1][total]
        );
    }
    assert!(dir.join("cantilever_dynamic_summary.json").is_file());
}

#[test]
fn explicit_above_its_critical_step_fails_with_a_divergence_message() {
    let dir = out_dir("explicit");
    let dir = dir.to_str().unwrap();
    let run = |dt: &str| {
        tetfem(&[
            "run",
            &scene("cantilever_dynamic.toml"),
            "--out",
            dir,
            "--method",
            "explicit",
            "--dt",
            dt,
            "--steps",
            "400",
            "--json",
        ])
    };
    let output = run("2crit");
    assert!(!output.status.success());
    let stderr = text(&output.stderr);
    assert!(stderr.contains("diverged"), "{stderr}");
    assert!(
        stderr.contains(tetfem::analysis::dynamics::EXPLICIT_REMEDY),
        "the library's remedy: {stderr}"
    );
    assert!(!stderr.contains("panicked"), "{stderr}");
    // The same run below the critical step completes.
    let summary = json(&expect_success(&run("0.9crit")));
    assert_eq!(summary["method"], "explicit");
    assert_eq!(summary["steps"], 400);
    assert!((summary["dt_over_critical"].as_f64().unwrap() - 0.9).abs() < 1e-12);
}

/// An implicit step whose Newton fails is reported with the library's own remedy (a smaller dt)
/// and no explicit-method advice: the CLI prints the error as it is.
#[test]
fn an_implicit_newton_failure_gets_no_explicit_method_advice() {
    let dir = out_dir("newton-failure");
    std::fs::create_dir_all(&dir).unwrap();
    // The rubber beam's swing under 10⁴ g in one step of 1 s: far beyond what Newton's 25
    // iterations reach from rest (the last residual is ~13× the scale it is measured against).
    let source = std::fs::read_to_string(scene("rubber_beam_swing.toml"))
        .unwrap()
        .replace("dt = 5e-3", "dt = 1.0")
        .replace("-9.81", "-1e5");
    let path = dir.join("newton_failure.toml");
    std::fs::write(&path, source).unwrap();
    let output = tetfem(&[
        "run",
        path.to_str().unwrap(),
        "--out",
        dir.to_str().unwrap(),
        "-q",
    ]);
    assert!(!output.status.success());
    let stderr = text(&output.stderr);
    assert!(
        stderr.contains("diverged") && stderr.contains("Newton did not converge"),
        "{stderr}"
    );
    assert!(!stderr.contains("critical step"), "{stderr}");
    assert!(!stderr.contains("explicit"), "{stderr}");
}

#[test]
fn info_prints_the_counts_of_the_file() {
    let path = scene("l_bracket.msh");
    // Count the tets (Gmsh type 4) and nodes of the 4.1 ASCII file directly.
    let source = std::fs::read_to_string(&path).unwrap();
    let mut lines = source.lines();
    let (mut file_nodes, mut file_tets) = (0, 0);
    while let Some(line) = lines.next() {
        if line == "$Nodes" {
            file_nodes = lines
                .next()
                .unwrap()
                .split_whitespace()
                .nth(1)
                .unwrap()
                .parse::<usize>()
                .unwrap();
        }
        if line == "$Elements" {
            let blocks: usize = lines
                .next()
                .unwrap()
                .split_whitespace()
                .next()
                .unwrap()
                .parse()
                .unwrap();
            for _ in 0..blocks {
                let header: Vec<usize> = lines
                    .next()
                    .unwrap()
                    .split_whitespace()
                    .map(|v| v.parse().unwrap())
                    .collect();
                let (kind, count) = (header[2], header[3]);
                if kind == 4 {
                    file_tets += count;
                }
                for _ in 0..count {
                    lines.next();
                }
            }
        }
    }
    assert!(file_nodes > 0 && file_tets > 0);
    let output = tetfem(&["info", &path, "--material", "200e9,0.3,7850"]);
    let stdout = expect_success(&output);
    let unused = stdout
        .lines()
        .find_map(|l| l.trim().strip_prefix("nodes used by no tet (dropped): "))
        .map_or(0, |n| n.parse::<usize>().unwrap());
    let expected = format!(
        "nodes {}, tets {file_tets}, DOFs {}",
        file_nodes - unused,
        3 * (file_nodes - unused)
    );
    assert!(
        stdout.contains(&expected),
        "expected '{expected}' in:\n{stdout}"
    );
    assert!(stdout.contains("min dihedral angle"), "{stdout}");
    assert!(
        stdout.contains("explicit critical step for E = 2e11"),
        "{stdout}"
    );
    assert!(stdout.contains("group \"clamp\""), "{stdout}");
    // Without a material, it says so instead of a step.
    let stdout = expect_success(&tetfem(&["info", &path]));
    assert!(stdout.contains("give a material"), "{stdout}");
    // As JSON.
    let info = json(&expect_success(&tetfem(&[
        "info",
        &path,
        "--json",
        "--material",
        "200e9,0.3,7850",
    ])));
    assert_eq!(info["statistics"]["tets"], file_tets);
    assert!(info["critical_step"]["dt_element"].as_f64().unwrap() > 0.0);
}

#[test]
fn default_run_releases_the_cantilever_and_writes_the_series() {
    let dir = out_dir("default-dynamic");
    let output = tetfem(&[
        "--cells",
        "10,2,2",
        "--dynamic-cells",
        "20,2,2",
        "--periods",
        "1.5",
        "--out",
        dir.to_str().unwrap(),
    ]);
    let stdout = expect_success(&output);
    for expected in [
        "Timoshenko",
        "cantilever.vtu",
        "dynamic cantilever",
        "explicit critical step (Lanczos iteration)",
        "backward-euler: dt =",
        "50.0 × the critical step",
        "per step",
    ] {
        assert!(
            stdout.contains(expected),
            "missing '{expected}' in:\n{stdout}"
        );
    }
    let (header, rows) = parse_csv(&dir.join("cantilever_swing/cantilever_swing.csv"));
    let (uz, kinetic) = (column(&header, "tip_uz_m"), column(&header, "kinetic_J"));
    // Released at rest from the loaded shape: the tip starts down, then rises once the end
    // load is gone (its lowest point is the start), and the beam moves.
    assert!(rows[0][uz] < 0.0 && rows[0][kinetic] == 0.0);
    let highest = rows.iter().map(|r| r[uz]).fold(f64::NEG_INFINITY, f64::max);
    let lowest = rows.iter().map(|r| r[uz]).fold(f64::INFINITY, f64::min);
    assert_eq!(lowest, rows[0][uz]);
    // It swings through to the other side (backward Euler damps, but not that much).
    assert!(highest > -0.5 * rows[0][uz], "{highest} vs {}", rows[0][uz]);
    assert!(rows.iter().any(|r| r[kinetic] > 0.0));
    let frames = parse_pvd(&dir.join("cantilever_swing/cantilever_swing.pvd"));
    assert!(frames.len() >= 10, "{}", frames.len());
    assert!(frames.windows(2).all(|w| w[1].0 > w[0].0));
    assert!(
        dir.join("cantilever_swing")
            .join(&frames[frames.len() - 1].1)
            .is_file()
    );

    // --static-only: no dynamic output.
    let dir = out_dir("default-static-only");
    let stdout = expect_success(&tetfem(&[
        "--cells",
        "10,2,2",
        "--static-only",
        "--out",
        dir.to_str().unwrap(),
    ]));
    assert!(!stdout.contains("dynamic"), "{stdout}");
    assert!(dir.join("cantilever/cantilever.vtu").is_file());
    assert!(!dir.join("cantilever_swing").exists());
}

#[test]
fn help_lists_the_subcommands_and_their_options() {
    let top = expect_success(&tetfem(&["--help"]));
    for word in [
        "run",
        "info",
        "--method",
        "--dt",
        "--periods",
        "--static-only",
        "ParaView",
    ] {
        assert!(top.contains(word), "missing '{word}' in:\n{top}");
    }
    let run = expect_success(&tetfem(&["run", "--help"]));
    for word in [
        "--png",
        "--json",
        "--quiet",
        "--steps",
        "--duration",
        "--out",
        ".pvd",
    ] {
        assert!(run.contains(word), "missing '{word}' in:\n{run}");
    }
    let info = expect_success(&tetfem(&["info", "--help"]));
    assert!(
        info.contains("--material") && info.contains("critical"),
        "{info}"
    );
}

#[test]
fn bad_arguments_fail_cleanly() {
    let static_scene = scene("hanging_bar.toml");
    let dynamic_scene = scene("cantilever_dynamic.toml");
    for (args, expected) in [
        (vec!["run"], "SCENE"),
        (vec!["run", "no/such/scene.toml"], "no/such/scene.toml"),
        (vec!["run", &dynamic_scene, "--dt=-1"], "--dt"),
        (vec!["run", &dynamic_scene, "--dt", "fastcrit"], "--dt"),
        (vec!["run", &dynamic_scene, "--steps", "0"], "--steps"),
        (vec!["run", &dynamic_scene, "--method", "rk4"], "--method"),
        (
            vec!["run", &dynamic_scene, "--steps", "5", "--duration", "1"],
            "--duration",
        ),
        (
            vec!["run", &static_scene, "--steps", "5"],
            "dynamic scenes only",
        ),
        (vec!["run", &static_scene, "--cells", "2,2,2"], "--cells"),
        (vec!["info", "no/such/mesh.msh"], "no/such/mesh.msh"),
        (
            vec!["info", &scene("l_bracket.msh"), "--material", "200e9,0.3"],
            "--material",
        ),
        (
            vec![
                "info",
                &scene("l_bracket.msh"),
                "--material",
                "200e9,0.7,7850",
            ],
            "--material",
        ),
        (vec!["--periods", "0"], "--periods"),
        (vec!["frobnicate"], "frobnicate"),
    ] {
        let output = tetfem(&args);
        let stderr = text(&output.stderr);
        assert!(!output.status.success(), "{args:?} succeeded");
        assert!(
            stderr.contains(expected),
            "{args:?}: '{expected}' not in {stderr}"
        );
        assert!(!stderr.contains("panicked"), "{args:?}: {stderr}");
        assert!(
            output.stdout.is_empty() || !text(&output.stdout).contains("wrote"),
            "{args:?}"
        );
    }
}
