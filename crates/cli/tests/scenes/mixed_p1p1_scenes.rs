//! The stabilized P1–P1 mixed element (`formulation = "mixed"` with `[mesh] order = 1`) in
//! dynamic and modal scenes: the modes are the library's `mixed_modes_model` on the scene's
//! 4-node mesh bit for bit, a Newmark run under gravity conserves the energy and follows the
//! library's `MixedTransient<Tet4>`, the files carry the pressure, and the Neo-Hookean dynamic
//! run (Taylor–Hood's only) is refused naming `[mesh] order`.

use std::ops::ControlFlow;

use tetfem::analysis::dynamics::{Method, Rayleigh};
use tetfem::analysis::mixed_analysis::{mixed_modes_model, mixed_transient_model};
use tetfem::fe::element::Tet4;
use tetfem::model::ModelKind;
use tetfem::{Loads, TetMesh};
use tetfem_cli::scene::{DynamicOverrides, Scene, run_dynamic_scene, run_modal_scene};

use crate::common::scratch_dir;

/// A rubber cantilever 1 × 0.2 × 0.2 m on 4-node tets (E = 1e6 Pa, ν = 0.4999), clamped at
/// x = 0, under gravity, in a mixed Newmark run of 40 steps.
const BEAM: &str = r#"
[mesh]
order = 1
[mesh.box]
max = [1.0, 0.2, 0.2]
cells = [6, 2, 2]
split = "lecture6"
[material]
youngs_modulus = 1e6
poisson_ratio = 0.4999
density = 1000.0
[[constraints]]
where = { plane = { axis = "x", at = 0.0 } }
[[loads]]
gravity = [0.0, 0.0, -9.81]
[[probes]]
name = "tip"
where = { plane = { axis = "x", at = 1.0 } }
[analysis]
type = "dynamic"
formulation = "mixed"
method = "newmark"
mass = "consistent"
dt = 0.02
duration = 0.8
[output]
every = 20
vtu_format = "ascii"
"#;

fn parse(text: &str) -> Scene {
    Scene::parse(text, "beam.toml", std::path::Path::new(".")).unwrap()
}

/// The mean z displacement of the nodes at x = 1 (m).
fn tip(mesh: &TetMesh, u: &[f64]) -> f64 {
    let nodes = mesh.nodes_on_plane(0, 1.0, 1e-9);
    nodes.iter().map(|&n| u[3 * n + 2]).sum::<f64>() / nodes.len() as f64
}

#[test]
fn a_p1p1_newmark_scene_conserves_energy_and_is_the_librarys_run() {
    let mut scene = parse(BEAM);
    let directory = scratch_dir("mixed_p1p1_scenes", "newmark");
    scene.set_output_directory(directory.clone());
    let summary = run_dynamic_scene(
        &scene,
        &DynamicOverrides::default(),
        true,
        false,
        &mut |_, _| ControlFlow::Continue(()),
    )
    .unwrap();
    let end = &summary.final_energy;
    println!(
        "P1–P1 scene: {} steps, {} free DOFs; end energies kinetic {:.4e}, elastic {:.4e}, \
         gravity {:.4e}, total {:.2e} J; tip u_z last {:.6e} m",
        summary.steps,
        summary.free_dofs,
        end.kinetic,
        end.elastic,
        end.gravity_potential,
        end.total,
        summary.probes[0].last[2]
    );
    assert_eq!(summary.analysis, "dynamic (mixed)");
    assert_eq!(summary.steps, 40);
    // Average acceleration conserves kinetic + elastic − fᵀu of the linear undamped body from
    // its start at 0: the solves' round-off against the energies exchanged.
    assert!(end.total.abs() < 1e-9 * end.gravity_potential.abs());
    assert!(end.kinetic > 0.0 && end.elastic > 0.0);

    // The library's run on the scene's mesh: the same steps, so the same tip (the probe's mean
    // is summed in its own node order: round-off apart).
    let built = scene.build_as::<Tet4>().unwrap();
    let mut loads = Loads::new(&built.mesh);
    loads
        .add_gravity(&built.mesh, &built.materials, built.gravity)
        .unwrap();
    let mut run = mixed_transient_model(
        &built.mesh,
        &built.materials,
        ModelKind::Linear,
        (&built.constraints, &loads),
        (Method::Newmark, 0.02, Rayleigh::default()),
    )
    .unwrap();
    for _ in 0..40 {
        run.step().unwrap();
    }
    let library = tip(&built.mesh, &run.displacement().unwrap());
    assert!(
        (summary.probes[0].last[2] / library - 1.0).abs() < 1e-12,
        "{} vs {library}",
        summary.probes[0].last[2]
    );
    // The frames carry the pressure, the CSV its range.
    let vtu = (summary.files.iter())
        .find(|f| f.extension().is_some_and(|e| e == "vtu"))
        .unwrap();
    assert!(
        std::fs::read_to_string(vtu)
            .unwrap()
            .contains("Name=\"pressure\"")
    );
    let csv = (summary.files.iter())
        .find(|f| f.extension().is_some_and(|e| e == "csv"))
        .unwrap();
    let text = std::fs::read_to_string(csv).unwrap();
    assert!(text.starts_with("time_s,kinetic_J") && text.contains("pressure_max_Pa"));
}

#[test]
fn a_p1p1_modal_scene_gives_the_librarys_modes_bit_for_bit() {
    let modal = BEAM
        .replace("type = \"dynamic\"", "type = \"modal\"\nmodes = 3")
        .replace("method = \"newmark\"\n", "")
        .replace("dt = 0.02\nduration = 0.8\n", "")
        .replace("[[loads]]\ngravity = [0.0, 0.0, -9.81]\n", "")
        .replace(
            "[[probes]]\nname = \"tip\"\nwhere = { plane = { axis = \"x\", at = 1.0 } }\n",
            "",
        );
    let mut scene = parse(&modal);
    scene.set_output_directory(scratch_dir("mixed_p1p1_scenes", "modal"));
    let summary = run_modal_scene(&scene, false).unwrap();
    let built = scene.build_as::<Tet4>().unwrap();
    let library = mixed_modes_model(
        &built.mesh,
        &built.materials,
        ModelKind::Linear,
        &built.constraints,
        3,
    )
    .unwrap();
    assert_eq!(summary.analysis, "modal (mixed)");
    assert_eq!(summary.modes.len(), 3);
    for (row, omega) in summary.modes.iter().zip(&library.modes.omega) {
        println!("P1–P1 mode {}: {:.5} Hz", row.mode, row.frequency_hz);
        assert_eq!(row.omega_rad_per_s, *omega);
    }
    let vtu = (summary.files.iter())
        .find(|f| f.extension().is_some_and(|e| e == "vtu"))
        .unwrap();
    assert!(
        std::fs::read_to_string(vtu)
            .unwrap()
            .contains("Name=\"pressure\"")
    );
}
