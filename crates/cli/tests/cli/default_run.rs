//! The default run (`tetfem` with no subcommand) through the scene runner: its static part
//! writes what a static scene writes, its printed and JSON numbers (tip beside beam theory,
//! energies, frames, end time) and its options (`--frames`, `--png`, `--duration`, `--method`,
//! `--json`); and the options of `tetfem run` no other test exercises (`--method newmark`,
//! `--png`, `--duration`, warnings in `--json`).

use crate::common;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use serde_json::Value;

fn tetfem(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_tetfem"))
        .args(args)
        .output()
        .unwrap()
}

fn out_dir(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join("default_run")
        .join(name);
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

fn expect_success(output: &Output) -> String {
    let stdout = String::from_utf8_lossy(&output.stdout).into_owned();
    assert!(
        output.status.success(),
        "stdout: {stdout}\nstderr: {}",
        String::from_utf8_lossy(&output.stderr)
    );
    stdout
}

/// The one JSON object a `--json` run prints.
fn json_run(args: &[&str]) -> Value {
    let stdout = expect_success(&tetfem(args));
    serde_json::from_str(stdout.trim()).unwrap_or_else(|e| panic!("{e}: {stdout}"))
}

/// Width and height of a PNG file, after checking its signature and that IHDR comes first.
fn png_size(path: &Path) -> (u32, u32) {
    let bytes = std::fs::read(path).unwrap();
    assert!(bytes.len() > 33, "{}: too short", path.display());
    assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n", "{}", path.display());
    assert_eq!(&bytes[12..16], b"IHDR", "{}", path.display());
    let be =
        |at: usize| u32::from_be_bytes([bytes[at], bytes[at + 1], bytes[at + 2], bytes[at + 3]]);
    (be(16), be(20))
}

fn files_with_extension(dir: &Path, extension: &str) -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == extension))
        .collect();
    files.sort();
    files
}

fn number(value: &Value) -> f64 {
    value
        .as_f64()
        .unwrap_or_else(|| panic!("not a number: {value}"))
}

/// Mean z-displacement of the tip nodes (x = L) in the static JSON summary.
fn tip(summary: &Value) -> f64 {
    let probe = summary["static"]["probes"]
        .as_array()
        .unwrap()
        .iter()
        .find(|p| p["name"] == "tip")
        .expect("a tip probe");
    number(&probe["displacement"][2])
}

#[test]
fn static_part_writes_what_a_static_scene_writes() {
    let dir = out_dir("static-files");
    let stdout = expect_success(&tetfem(&[
        "--cells",
        "20,2,2",
        "--static-only",
        "--png",
        "--quiet",
        "--out",
        dir.to_str().unwrap(),
    ]));
    let folder = dir.join("cantilever");
    // The .vtu holds the four fields of a static scene's result.
    let vtu = common::parse_vtu(std::fs::read(folder.join("cantilever.vtu")).unwrap());
    for (name, section, components) in [
        ("displacement", "PointData", 3),
        ("displacement_magnitude", "PointData", 1),
        ("von_mises", "CellData", 1),
        ("strain_energy_density", "CellData", 1),
    ] {
        let (s, _, c, _) = vtu.array(name).unwrap_or_else(|| panic!("no {name}"));
        assert_eq!((s.as_str(), *c), (section, components), "{name}");
    }
    // |u| per node is the norm of the displacement there (both printed round-trip: the
    // tolerance only absorbs the two roundings of the norm).
    let u = &vtu.array("displacement").unwrap().3;
    let magnitude = &vtu.array("displacement_magnitude").unwrap().3;
    for (n, m) in magnitude.iter().enumerate() {
        let norm = (u[3 * n].powi(2) + u[3 * n + 1].powi(2) + u[3 * n + 2].powi(2)).sqrt();
        assert!(
            (m - norm).abs() <= 1e-15 * norm.max(1e-300),
            "{m} vs {norm}"
        );
    }
    // The one-frame .pvd names the .vtu.
    let pvd = std::fs::read_to_string(folder.join("cantilever.pvd")).unwrap();
    assert!(pvd.contains("file=\"cantilever.vtu\""), "{pvd}");
    // The probes CSV holds the tip's mean displacement: the same as the summary's.
    let csv = std::fs::read_to_string(folder.join("cantilever_probes.csv")).unwrap();
    let mut lines = csv.lines();
    assert_eq!(lines.next(), Some("time_s,tip_ux_m,tip_uy_m,tip_uz_m"));
    let row: Vec<f64> = lines
        .next()
        .unwrap()
        .split(',')
        .map(|v| v.parse().unwrap())
        .collect();
    let summary: Value = serde_json::from_str(
        &std::fs::read_to_string(folder.join("cantilever_summary.json")).unwrap(),
    )
    .unwrap();
    // Both are the mean of the tip nodes' u_z, possibly summed in another order: equal to a few
    // ulps (1e-15 relative), where a different probe or field would differ in the first digits.
    let summary_tip = number(&summary["probes"][0]["displacement"][2]);
    assert!(
        (row[3] - summary_tip).abs() <= 1e-15 * summary_tip.abs(),
        "CSV {} vs summary {summary_tip}",
        row[3]
    );
    assert!(row[3] < 0.0, "the end load pushes the tip down: {}", row[3]);
    // The summary lists the files, and they exist; --png drew the static picture.
    let listed: Vec<PathBuf> = summary["files"]
        .as_array()
        .unwrap()
        .iter()
        .map(|f| PathBuf::from(f.as_str().unwrap()))
        .collect();
    assert_eq!(listed.len(), 5, "{listed:?}");
    assert!(listed.iter().all(|f| f.is_file()), "{listed:?}");
    assert_eq!(png_size(&folder.join("cantilever.png")), (960, 600));
    assert!(stdout.contains("cantilever_summary.json"), "{stdout}");
}

#[test]
fn scene_path_solves_the_library_cantilever() {
    // The embedded scene and `Cantilever` build the same mesh, clamp and loads: the library's
    // solution on the same mesh. The tolerance absorbs a different summation order of the
    // nodal loads (round-off of the solve, residual ~1e-10 relative).
    let dir = out_dir("library");
    let out = json_run(&[
        "--cells",
        "20,2,2",
        "--static-only",
        "--json",
        "--out",
        dir.to_str().unwrap(),
    ]);
    let solved = tetfem_fixtures::cantilever::Cantilever {
        cells: [20, 2, 2],
        // The default run meshes with the mirrored split (DEFAULT_SPLIT in src/bin/tetfem.rs).
        split: tetfem::BoxSplit::Mirrored6,
        ..tetfem_fixtures::cantilever::Cantilever::steel_default()
    }
    .solve()
    .unwrap();
    let tip = tip(&out);
    assert!(
        (tip - solved.tip_deflection).abs() <= 1e-9 * solved.tip_deflection.abs(),
        "{tip} vs {}",
        solved.tip_deflection
    );
    assert_eq!(
        number(&out["static"]["nodes"]) as usize,
        solved.mesh.node_count()
    );
    assert_eq!(
        number(&out["static"]["factor_len"]) as usize,
        solved.factor_len
    );
}

#[test]
fn tip_approaches_euler_bernoulli_from_the_stiff_side() {
    // Euler–Bernoulli for the default beam, computed here: end load P·L³/(3EI) plus weight
    // q·L⁴/(8EI), q = ρ·g·W·H, I = W·H³/12.
    let (length, width, height) = (1.0f64, 0.1f64, 0.1f64);
    let (e, rho, g, p) = (200e9, 7850.0, 9.81, 10e3);
    let i = width * height.powi(3) / 12.0;
    let q = rho * g * width * height;
    let euler_bernoulli =
        -(p * length.powi(3) / (3.0 * e * i) + q * length.powi(4) / (8.0 * e * i));
    let mut ratios = Vec::new();
    for cells in ["20,2,2", "40,4,4"] {
        let dir = out_dir(&format!("tip-{cells}"));
        let out = json_run(&[
            "--cells",
            cells,
            "--static-only",
            "--json",
            "--out",
            dir.to_str().unwrap(),
        ]);
        let printed = number(&out["beam_theory_tip"]["euler_bernoulli"]);
        // Closed forms evaluated in a different order: round-off only.
        assert!(
            (printed - euler_bernoulli).abs() <= 1e-12 * euler_bernoulli.abs(),
            "{printed} vs {euler_bernoulli}"
        );
        ratios.push(tip(&out) / euler_bernoulli);
        // The text report prints the same tip and ratio.
        let text = expect_success(&tetfem(&[
            "--cells",
            cells,
            "--static-only",
            "--quiet",
            "--out",
            dir.to_str().unwrap(),
        ]));
        assert!(
            text.contains(&format!("tetfem           {:+.6e} m", tip(&out))),
            "{text}"
        );
        assert!(
            text.contains(&format!("(tetfem / EB = {:.4})", ratios.last().unwrap())),
            "{text}"
        );
    }
    // A conforming displacement method is stiffer than the continuum (its strain energy, hence
    // its compliance, is bounded by the exact one, and the 3D beam is more compliant than
    // Euler–Bernoulli by shear): the ratio stays below 1 and grows as the mesh is refined.
    // Linear tets lock in bending, so at 2 cells through the height the ratio is far from 1;
    // it is still positive (the tip goes down).
    assert!(
        0.0 < ratios[0] && ratios[0] < ratios[1] && ratios[1] < 1.0,
        "{ratios:?}"
    );
}

#[test]
fn newmark_and_explicit_keep_the_total_energy_of_the_start() {
    // The book's claim (`docs/src/getting-started.md`): "Newmark and explicit end with the total energy of the start to
    // 1e-3". Undamped, constant loads: the trapezoidal rule conserves this quadratic energy
    // exactly, so Newmark gets a round-off bound (solves to a relative residual ~1e-10). Central
    // differences conserve a shadow energy instead; the true one oscillates by an amount set by
    // the share of energy in the mesh's highest modes, so explicit is checked on the default
    // dynamic mesh (40×4×4, which the claim is about) at its default 0.9 × the critical step,
    // over half a period to keep the test short.
    for (method, cells, periods, bound) in [
        ("newmark", "10,1,1", "1", 1e-9),
        ("explicit", "40,4,4", "0.5", 1e-3),
    ] {
        let dir = out_dir(&format!("energy-{method}"));
        let out = json_run(&[
            "--cells",
            "4,1,1",
            "--dynamic-cells",
            cells,
            "--method",
            method,
            "--periods",
            periods,
            "--frames",
            "2",
            "--json",
            "--out",
            dir.to_str().unwrap(),
        ]);
        let dynamic = &out["dynamic"];
        assert_eq!(dynamic["method"], method);
        let start = number(&dynamic["initial_energy"]["total"]);
        let end = number(&dynamic["final_energy"]["total"]);
        assert!(
            (end - start).abs() <= bound * start.abs(),
            "{method}: {start} → {end}"
        );
        // It moved: released from the loaded shape, the tip rose.
        let tip = &dynamic["probes"][0];
        assert!(
            number(&tip["max"][2]) > number(&tip["min"][2])
                && number(&dynamic["final_energy"]["kinetic"]) > 0.0,
            "{tip}"
        );
    }
}

#[test]
fn frames_gives_about_that_many_frames() {
    let dir = out_dir("frames");
    let requested = 7usize;
    let out = json_run(&[
        "--cells",
        "4,1,1",
        "--dynamic-cells",
        "10,1,1",
        "--periods",
        "1",
        "--frames",
        &requested.to_string(),
        "--json",
        "--out",
        dir.to_str().unwrap(),
    ]);
    let dynamic = &out["dynamic"];
    let steps = number(&dynamic["steps"]) as usize;
    let frames = number(&dynamic["frames"]) as usize;
    // A frame every ⌈S/F⌉ steps, at step 0 and at the last step: 1 + ⌈S/⌈S/F⌉⌉ frames, which is
    // between 1 + F/2 and 1 + F when S ≥ F.
    assert!(steps >= requested, "{steps}");
    let every = steps.div_ceil(requested);
    assert_eq!(frames, 1 + steps.div_ceil(every), "steps {steps}");
    assert!(
        (1 + requested / 2..=1 + requested).contains(&frames),
        "{frames}"
    );
    let folder = dir.join("cantilever_swing");
    assert_eq!(files_with_extension(&folder, "vtu").len(), frames);
    let pvd = std::fs::read_to_string(folder.join("cantilever_swing.pvd")).unwrap();
    assert_eq!(pvd.matches("<DataSet").count(), frames);
}

#[test]
fn png_renders_the_static_picture_and_every_frame() {
    let dir = out_dir("png");
    let out = json_run(&[
        "--cells",
        "4,1,1",
        "--dynamic-cells",
        "10,1,1",
        "--periods",
        "0.5",
        "--frames",
        "3",
        "--png",
        "--json",
        "--out",
        dir.to_str().unwrap(),
    ]);
    assert_eq!(
        png_size(&dir.join("cantilever").join("cantilever.png")),
        (960, 600)
    );
    let frames = number(&out["dynamic"]["frames"]) as usize;
    let pngs = files_with_extension(&dir.join("cantilever_swing"), "png");
    assert_eq!(pngs.len(), frames, "{pngs:?}");
    for png in &pngs {
        assert_eq!(png_size(png), (960, 600), "{}", png.display());
    }
}

#[test]
fn duration_sets_the_last_time_within_one_step() {
    let dir = out_dir("duration");
    let duration = 4e-3;
    let out = json_run(&[
        "--cells",
        "4,1,1",
        "--dynamic-cells",
        "10,1,1",
        "--duration",
        "4e-3",
        "--periods",
        "100",
        "--json",
        "--out",
        dir.to_str().unwrap(),
    ]);
    let dynamic = &out["dynamic"];
    let (end, dt) = (number(&dynamic["end_time"]), number(&dynamic["dt"]));
    // ⌈T/dt⌉ steps: the end is at or past T by less than one step (1e-12: the sum of steps).
    assert!(
        end >= duration * (1.0 - 1e-12) && end < duration + dt,
        "end {end}, dt {dt}"
    );
    // --duration wins over --periods (100 periods would be ~1 s).
    assert!(number(&out["first_mode_period"]) * 100.0 > 10.0 * duration);
}

fn scene_path(name: &str) -> String {
    Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../.."))
        .join("scenes")
        .join(name)
        .display()
        .to_string()
}

#[test]
fn run_newmark_and_duration_override_the_scene() {
    let dir = out_dir("run-newmark");
    let scene = scene_path("cantilever_dynamic.toml");
    let out = json_run(&[
        "run",
        &scene,
        "--method",
        "newmark",
        "--duration",
        "2.05e-3",
        "--json",
        "--out",
        dir.to_str().unwrap(),
    ]);
    assert_eq!(out["method"], "newmark");
    let (end, dt) = (number(&out["end_time"]), number(&out["dt"]));
    // The scene's dt = 1e-4: ⌈2.05e-3/1e-4⌉ = 21 steps, ending at 2.1e-3 (within one dt).
    assert_eq!(number(&out["steps"]) as usize, 21);
    assert!(end >= 2.05e-3 && end < 2.05e-3 + dt, "{end}");
    // A suddenly applied constant load from rest, undamped: the total energy (with the load's
    // potential) starts at 0 and Newmark's trapezoidal rule conserves it exactly, so what is
    // left is round-off of the solves (relative residual ~1e-10) on the exchanged energies
    // (elastic + kinetic); the book only claims 1e-3.
    let start = number(&out["initial_energy"]["total"]);
    let end = &out["final_energy"];
    let exchanged = number(&end["elastic"]) + number(&end["kinetic"]);
    assert!(exchanged > 0.0, "{end}");
    assert!(
        (number(&end["total"]) - start).abs() <= 1e-9 * exchanged,
        "{start} → {end}"
    );
}

#[test]
fn run_png_renders_a_static_scene_that_asks_for_none() {
    let dir = out_dir("run-png");
    let scene = dir.join("no_png.toml");
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(
        &scene,
        r#"[mesh.box]
max = [1.0, 0.1, 0.1]
cells = [6, 1, 1]

[material]
youngs_modulus = 200e9
poisson_ratio = 0.3
density = 7850.0

[[constraints]]
where = { plane = { axis = "x", at = 0.0 } }

[[loads]]
gravity = [0.0, 0.0, -9.81]

[output]
png = false
png_size = [400, 300]
"#,
    )
    .unwrap();
    let out = dir.join("out");
    let scene = scene.to_str().unwrap();
    expect_success(&tetfem(&[
        "run",
        scene,
        "--quiet",
        "--out",
        out.to_str().unwrap(),
    ]));
    assert!(files_with_extension(&out, "png").is_empty());
    expect_success(&tetfem(&[
        "run",
        scene,
        "--png",
        "--quiet",
        "--out",
        out.to_str().unwrap(),
    ]));
    assert_eq!(png_size(&out.join("no_png.png")), (400, 300));
}

#[test]
fn json_lists_the_warnings_of_a_nearly_incompressible_scene() {
    let dir = out_dir("run-warning");
    std::fs::create_dir_all(&dir).unwrap();
    let scene = dir.join("rubbery.toml");
    std::fs::write(
        &scene,
        r#"[mesh.box]
max = [1.0, 0.1, 0.1]
cells = [4, 1, 1]

[material]
youngs_modulus = 1e6
poisson_ratio = 0.49
density = 1000.0

[[constraints]]
where = { plane = { axis = "x", at = 0.0 } }

[[loads]]
gravity = [0.0, 0.0, -9.81]
"#,
    )
    .unwrap();
    let output = tetfem(&[
        "run",
        scene.to_str().unwrap(),
        "--json",
        "--out",
        dir.join("out").to_str().unwrap(),
    ]);
    let stdout = expect_success(&output);
    let summary: Value = serde_json::from_str(stdout.trim()).unwrap();
    let warnings = summary["warnings"].as_array().unwrap();
    assert!(
        warnings
            .iter()
            .any(|w| w.as_str().is_some_and(|w| w.contains("0.49"))),
        "{summary}"
    );
    // Warnings also go to stderr (stdout holds the JSON only).
    assert!(
        String::from_utf8_lossy(&output.stderr).contains("0.49"),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
}
