//! Point probes (`[[probes]] at = [x, y, z]`) and the P2 nodal stress through a scene: a bar
//! hanging under its own weight with ν = 0, whose exact solution (σ_zz = ρg·z from the free
//! end, u_z = ρg(z² − L²)/(2E), no lateral motion, so the clamped top face is exact too) is
//! quadratic: the 10-node tet reproduces it, and its stress, linear in z, at every point.

use crate::common::vtu;

use std::path::Path;

use tetfem::base::error::Error;
use tetfem_cli::scene::{RunOptions, Scene, run_static_with};

const RHO_G: f64 = 7850.0 * 9.81;
const E: f64 = 200e9;
const L: f64 = 1.0;

/// The scene at `order`, writing into `directory` (none: no files).
fn hanging_bar(order: usize, probes: &str, directory: Option<&Path>) -> String {
    let output = match directory {
        Some(d) => format!(
            "[output]\ndirectory = \"{}\"\nvtu_format = \"ascii\"\n",
            d.display()
        ),
        None => String::new(),
    };
    format!(
        r#"
[mesh]
order = {order}

[mesh.box]
max = [0.1, 0.1, {L}]
cells = [2, 2, 8]

[material]
youngs_modulus = {E}
poisson_ratio = 0.0
density = 7850.0

[[constraints]]
where = {{ plane = {{ axis = "z", at = {L} }} }}

[[loads]]
gravity = [0.0, 0.0, -9.81]
{probes}
{output}
"#
    )
}

const PROBES: &str = r#"
[[probes]]
name = "bottom"
where = { plane = { axis = "z", at = 0.0 } }

[[probes]]
name = "inside"
at = [0.03, 0.07, 0.37]
"#;

fn parse(text: &str) -> Scene {
    Scene::parse(text, "<probe>", Path::new(".")).expect("valid scene")
}

#[test]
fn point_probe_gives_u_and_the_linear_stress_inside_a_p2_tet() {
    let z = 0.37;
    let exact_szz = RHO_G * z;
    let exact_uz = RHO_G * (z * z - L * L) / (2.0 * E);
    let mut found = Vec::new();
    for order in [1, 2] {
        let options = RunOptions {
            no_files: true,
            ..RunOptions::default()
        };
        let summary = run_static_with(&parse(&hanging_bar(order, PROBES, None)), &options)
            .expect("static run");
        let inside = &summary.probes[1];
        assert_eq!(inside.name, "inside");
        let s = inside.stress_pa.expect("a point probe reports its stress");
        // The node-set probe keeps its mean displacement and reports no stress.
        assert!(summary.probes[0].stress_pa.is_none());
        eprintln!(
            "order {order}: σ_zz at the point {:.6e} Pa (exact {exact_szz:.6e}), u_z {:.6e} m (exact {exact_uz:.6e})",
            s[2], inside.displacement[2]
        );
        found.push((s, inside.displacement));
    }
    let (s2, u2) = found[1];
    // P2 holds the exact solution: the solve's round-off (κ(K)·ε ~ 1e-12 relative) amplified by
    // 1/h in the stress stays far below 1e-9 of ρgL; the other components are zero.
    assert!(
        (s2[2] - exact_szz).abs() < 1e-9 * RHO_G * L,
        "P2 σ_zz {} vs {exact_szz}",
        s2[2]
    );
    for c in [0, 1, 3, 4, 5] {
        assert!(
            s2[c].abs() < 1e-9 * RHO_G * L,
            "P2 σ component {c} = {}",
            s2[c]
        );
    }
    assert!(
        (u2[2] - exact_uz).abs() < 1e-9 * exact_uz.abs(),
        "P2 u_z {} vs {exact_uz}",
        u2[2]
    );
    // P1's stress is its tet's constant: off by the gradient over the tet (the probe can
    // tell the orders apart, so the P2 check above is not vacuous).
    let (s1, _) = found[0];
    assert!(
        (s1[2] - exact_szz).abs() > 1e-3 * RHO_G * L,
        "P1 σ_zz {} vs {exact_szz}",
        s1[2]
    );
}

#[test]
fn point_probe_columns_and_p2_stress_nodal_in_the_files() {
    let dir = std::env::temp_dir().join(format!("tetfem-point-probe-{}", std::process::id()));
    let scene = parse(&hanging_bar(2, PROBES, Some(&dir)));
    let summary = run_static_with(&scene, &RunOptions::default()).expect("static run");
    let csv_path = summary
        .files
        .iter()
        .find(|f| f.to_string_lossy().ends_with("_probes.csv"))
        .expect("a probes CSV");
    let csv = std::fs::read_to_string(csv_path).expect("probes CSV");
    let header = csv.lines().next().unwrap();
    assert_eq!(
        header,
        "time_s,bottom_ux_m,bottom_uy_m,bottom_uz_m,inside_ux_m,inside_uy_m,inside_uz_m,\
         inside_sxx_pa,inside_syy_pa,inside_szz_pa,inside_sxy_pa,inside_syz_pa,inside_sxz_pa"
    );
    let row: Vec<f64> = csv
        .lines()
        .nth(1)
        .unwrap()
        .split(',')
        .map(|v| v.parse().unwrap())
        .collect();
    assert_eq!(row[9], summary.probes[1].stress_pa.unwrap()[2]);
    let json: serde_json::Value = serde_json::from_str(&summary.to_json()).unwrap();
    assert_eq!(json["units"]["probes.stress_pa"], "Pa");

    // The `.vtu`'s recovered nodal stress: σ_zz = ρg·z at every node, to round-off (P2 now
    // evaluates each tet's stress at its nodes; the average of the tet means was off by
    // ρg·h/2 = 4.8e3 Pa at the bottom and top faces).
    let path = summary
        .files
        .iter()
        .find(|f| f.extension().is_some_and(|e| e == "vtu"))
        .expect("a .vtu");
    let file = vtu::read_vtu(path);
    let points = file.values("Points").to_vec();
    let nodal = file.values("stress_nodal");
    let mut worst: f64 = 0.0;
    for (p, s) in points.chunks_exact(3).zip(nodal.chunks_exact(6)) {
        worst = worst.max((s[2] - RHO_G * p[2]).abs());
        for c in [0, 1, 3, 4, 5] {
            worst = worst.max(s[c].abs());
        }
    }
    std::fs::remove_dir_all(&dir).ok();
    eprintln!(
        "P2 stress_nodal: largest error {worst:.3e} Pa of ρgL = {:.3e} Pa",
        RHO_G * L
    );
    // Measured 9.6e-9 Pa = 1.2e-13 of ρgL (solve round-off; ASCII keeps every digit): 1e-11
    // leaves an 80× margin, far below the old 4.8e3 Pa error.
    assert!(
        worst < 1e-11 * RHO_G * L,
        "stress_nodal off by {worst:e} Pa"
    );
}

#[test]
fn point_probe_outside_the_mesh_or_with_where_too_is_a_named_error() {
    let cases = [
        (
            "[[probes]]\nname = \"out\"\nat = [0.5, 0.05, 0.5]\n",
            "probes[0].at",
            "inside the mesh",
        ),
        (
            "[[probes]]\nname = \"both\"\nat = [0.05, 0.05, 0.5]\nwhere = \"all\"\n",
            "probes[0]",
            "exactly one of",
        ),
        (
            "[[probes]]\nname = \"none\"\n",
            "probes[0]",
            "exactly one of",
        ),
    ];
    for (probes, key, words) in cases {
        let error = parse(&hanging_bar(1, probes, None))
            .build()
            .expect_err("an invalid probe");
        match &error {
            Error::Scene { key: k, .. } => assert_eq!(k, key, "{error}"),
            other => panic!("not a scene error: {other}"),
        }
        assert!(error.to_string().contains(words), "{error}");
    }
}

/// A dynamic run records a point probe's stress too (`<probe>_sxx_pa` … in its CSV). Backward
/// Euler with dt = 100 s on this bar (lowest axial mode ≈ 1.3 kHz, ω·dt ≈ 8e5) lands on the
/// static state within a step (each step keeps 1/(1 + ω²dt²) ≈ 2e-12 of the gap), so the
/// last row must hold the exact σ_zz = ρg·z of the hanging bar at the point.
#[test]
fn a_dynamic_run_records_the_point_probe_stress_in_its_csv() {
    let dir = std::env::temp_dir().join(format!("tetfem-point-dynamic-{}", std::process::id()));
    let text = hanging_bar(2, PROBES, Some(&dir)).replace(
        "[output]",
        "[analysis]\ntype = \"dynamic\"\nmethod = \"backward_euler\"\ndt = 100.0\n\
         duration = 500.0\n\n[output]",
    );
    let summary = tetfem_cli::scene::run_dynamic_scene(
        &parse(&text),
        &Default::default(),
        true,
        false,
        &mut |_, _| std::ops::ControlFlow::Continue(()),
    )
    .expect("dynamic run");
    let csv_path = summary
        .files
        .iter()
        .find(|f| f.extension().is_some_and(|e| e == "csv"))
        .expect("a CSV series");
    let csv = std::fs::read_to_string(csv_path).expect("CSV");
    std::fs::remove_dir_all(&dir).ok();
    let header: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
    let column = |name: &str| header.iter().position(|h| *h == name).expect(name);
    // The node-set probe has no stress columns; the point probe's follow its displacement.
    assert!(!header.iter().any(|h| h.starts_with("bottom_s")));
    assert_eq!(column("inside_sxx_pa"), column("inside_uz_m") + 1);
    let last: Vec<f64> = csv
        .lines()
        .last()
        .unwrap()
        .split(',')
        .map(|v| v.parse().unwrap())
        .collect();
    let szz = last[column("inside_szz_pa")];
    // As the static check above: the exact field to the solve's round-off.
    assert!(
        (szz - RHO_G * 0.37).abs() < 1e-9 * RHO_G * L,
        "σ_zz {szz} vs {}",
        RHO_G * 0.37
    );
    for name in ["inside_sxx_pa", "inside_syy_pa", "inside_sxy_pa"] {
        assert!(last[column(name)].abs() < 1e-9 * RHO_G * L, "{name}");
    }
}
