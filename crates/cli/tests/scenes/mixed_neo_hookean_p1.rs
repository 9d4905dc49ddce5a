//! The mixed Neo-Hookean backward Euler on 4-node tets (the stabilized P1–P1 element) from a
//! scene: the rubber ball drop of `scenes/rubber_ball_drop.toml` on the ball's 4-node mesh keeps
//! its volume through the impact, stays above the ground and writes the pressure; what the
//! 4-node element does not compute is refused naming the key.

use std::ops::ControlFlow;
use std::path::Path;

use nalgebra::Vector3;
use tetfem::mesh::io::write_gmsh;
use tetfem_cli::scene::{DynamicOverrides, Scene, run_dynamic_scene};
use tetfem_fixtures::ball::Ball;

use crate::common::scratch_dir;

/// The shipped ball drop's physics (R = 10 cm, E = 1 MPa, ν = 0.499, 2 m/s down from 2 mm
/// above the frictionless ground), its mesh file the 4-node ball.
const SCENE: &str = r#"
[mesh.gmsh]
file = "ball.msh"
[material]
youngs_modulus = 1e6
poisson_ratio = 0.499
density = 1000.0
[[loads]]
gravity = [0.0, 0.0, -9.81]
[[probes]]
name = "ball"
where = "all"
[analysis]
type = "dynamic"
formulation = "mixed"
method = "backward_euler"
model = "neo-hookean"
mass = "consistent"
dt = 0.001
duration = 0.03
initial_velocity = [0.0, 0.0, -2.0]
[[obstacles]]
kind = "half_space"
name = "ground"
point = [0.0, 0.0, 0.0]
normal = [0.0, 0.0, 1.0]
[output]
every = 10
vtu_format = "ascii"
"#;

/// The scene `text` in `directory` beside the 4-node ball's mesh file (4 cells, 125 nodes).
fn ball_scene(directory: &Path, text: &str) -> tetfem::Result<Scene> {
    let ball = Ball {
        center: Vector3::new(0.0, 0.0, 0.102),
        radius: 0.1,
    };
    write_gmsh(&directory.join("ball.msh"), &ball.mesh(4)?, &[])?;
    let mut scene = Scene::parse(text, "ball_p1.toml", directory)?;
    scene.set_output_directory(directory.join("out"));
    Ok(scene)
}

#[test]
fn a_p1_p1_ball_drop_scene_keeps_its_volume_above_the_ground() {
    let directory = scratch_dir("mixed_neo_hookean_p1", "drop");
    let scene = ball_scene(&directory, SCENE).unwrap();
    let summary = run_dynamic_scene(
        &scene,
        &DynamicOverrides::default(),
        true,
        false,
        &mut |_, _| ControlFlow::Continue(()),
    )
    .unwrap();
    let change = summary.volume_change.unwrap();
    let peak = summary.contact_forces.as_ref().unwrap()[0].peak_n;
    let (start, end) = (summary.initial_energy.total, summary.final_energy.total);
    let weight = 1000.0 * 9.81 * 4.0 / 3.0 * std::f64::consts::PI * 0.1f64.powi(3);
    let csv = summary
        .files
        .iter()
        .find(|f| f.extension().is_some_and(|e| e == "csv"))
        .unwrap();
    let text = std::fs::read_to_string(csv).unwrap();
    let header: Vec<&str> = text.lines().next().unwrap().split(',').collect();
    let gap = header.iter().position(|h| *h == "smallest_gap_m").unwrap();
    let lowest = (text.lines().skip(1))
        .map(|row| row.split(',').nth(gap).unwrap().parse::<f64>().unwrap())
        .fold(f64::INFINITY, f64::min);
    println!(
        "P1–P1 ball drop scene, {} steps: |V/V0 − 1| ≤ {change:.3e}, peak ground force \
         {peak:.4e} N ({:.1} weights), smallest gap {lowest:.3e} m, energy {start:.4e} → \
         {end:.4e} J, {:?}",
        summary.steps,
        peak / weight,
        summary.newton
    );
    assert_eq!(summary.steps, 30);
    assert_eq!(summary.analysis, "dynamic (mixed)");
    // The issue's 1 % (the library's test measures 5.0e-5 on this mesh over 60 steps).
    assert!(change < 0.01);
    // The barrier keeps every node above the ground at every step.
    assert!(lowest > 0.0);
    // The impact: far more than the ball's weight (41 N for the sphere; the inscribed mesh is
    // lighter) on the ground.
    assert!(peak > 10.0 * weight);
    // Backward Euler dissipates (no barrier energy left out: the CSV's own column).
    assert!(end < start);
    let vtu = summary
        .files
        .iter()
        .find(|f| f.extension().is_some_and(|e| e == "vtu"))
        .unwrap();
    let frame = std::fs::read_to_string(vtu).unwrap();
    assert!(frame.contains("Name=\"pressure\""), "{vtu:?}");
    let _ = std::fs::remove_dir_all(directory);
}

#[test]
fn the_p1_p1_neo_hookean_scene_refuses_what_it_does_not_compute_naming_the_key() {
    let directory = scratch_dir("mixed_neo_hookean_p1", "refusals");
    for (from, to, culprit) in [
        // The Neo-Hookean mixed run is backward Euler only, on either element.
        (
            "method = \"backward_euler\"",
            "method = \"newmark\"",
            "model = \"neo-hookean\"",
        ),
        // Undamped: backward Euler's own dissipation only.
        (
            "mass = \"consistent\"",
            "mass = \"consistent\"\ndamping = { mass = 1.0 }",
            "analysis.damping",
        ),
    ] {
        let message = ball_scene(&directory, &SCENE.replace(from, to))
            .unwrap_err()
            .to_string();
        assert!(message.contains(culprit), "{culprit}: {message}");
    }
    let _ = std::fs::remove_dir_all(directory);
}
