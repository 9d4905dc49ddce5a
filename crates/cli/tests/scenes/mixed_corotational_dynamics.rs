//! Issue 40: a dynamic scene with `formulation = "mixed"`, `model = "corotational"` and
//! `method = "backward_euler"` runs the library's mixed backward Euler with the corotational
//! law (`MixedNonlinearEuler::new_with_law(MixedLaw::Corotational, …)`) on either order — the
//! scene decides no physics, so its tip is the library's to the bit — keeps its volume, and
//! Newmark with the corotational mixed model is refused naming the model.

use std::ops::ControlFlow;
use std::path::Path;

use nalgebra::Vector3;
use tetfem::analysis::mixed_nonlinear::MixedLaw;
use tetfem::analysis::mixed_nonlinear_dynamics::{MixedBody, MixedNonlinearEuler};
use tetfem::{BoxSplit, Constraints, Loads, Material, Tet10, TetMesh};
use tetfem_cli::scene::{DynamicOverrides, DynamicSummary, Scene, run_dynamic_scene};

/// A soft rubber cantilever (1 m × 0.1 m × 0.1 m, E = 1 MPa, ν = 0.4999) clamped at x = 0,
/// released from rest under gravity: 10 steps of 10 ms (the tip falls ~0.1 m), on 4-node
/// (`order` 1) or 10-node tets.
fn swing(order: usize) -> String {
    format!(
        "[mesh]\norder = {order}\n[mesh.box]\nmax = [1.0, 0.1, 0.1]\ncells = [{cells}, 1, 1]\n\
         split = \"five\"\n\
         [material]\nyoungs_modulus = 1e6\npoisson_ratio = 0.4999\ndensity = 1000.0\n\
         [[constraints]]\nwhere = {{ plane = {{ axis = \"x\", at = 0.0 }} }}\n\
         [[loads]]\ngravity = [0.0, 0.0, -9.81]\n\
         [[probes]]\nname = \"tip\"\nwhere = {{ plane = {{ axis = \"x\", at = 1.0 }} }}\n\
         [analysis]\ntype = \"dynamic\"\nformulation = \"mixed\"\nmodel = \"corotational\"\n\
         method = \"backward_euler\"\nmass = \"consistent\"\ndt = 0.01\nduration = 0.1\n",
        cells = if order == 1 { 10 } else { 5 }
    )
}

fn run(text: &str) -> tetfem::Result<DynamicSummary> {
    let scene = Scene::parse(text, "<test>", Path::new("."))?;
    run_dynamic_scene(
        &scene,
        &DynamicOverrides::default(),
        false,
        false,
        &mut |_, _| ControlFlow::Continue(()),
    )
}

/// The same run built by hand on `mesh`: the tip's mean z displacement after 10 steps (m).
fn library_tip<E: MixedBody>(mesh: &TetMesh<E>) -> f64 {
    let material = Material::new(1e6, 0.4999, 1000.0).unwrap();
    let mut constraints = Constraints::new(mesh);
    constraints
        .fix_nodes(&mesh.nodes_on_plane(0, 0.0, 1e-9))
        .unwrap();
    let mut loads = Loads::new(mesh);
    loads
        .add_gravity(mesh, &material, Vector3::new(0.0, 0.0, -9.81))
        .unwrap();
    let mut run = MixedNonlinearEuler::new_with_law(
        MixedLaw::Corotational,
        mesh,
        &material,
        &constraints,
        &loads,
        (0.01, 1e-8),
    )
    .unwrap();
    for _ in 0..10 {
        run.step().unwrap();
    }
    let tip = mesh.nodes_on_plane(0, 1.0, 1e-9);
    tip.iter()
        .map(|&n| run.displacement()[3 * n + 2])
        .sum::<f64>()
        / tip.len() as f64
}

#[test]
fn a_mixed_corotational_dynamic_scene_is_the_librarys_run_and_keeps_its_volume() {
    for order in [1, 2] {
        let summary = run(&swing(order)).unwrap();
        let tip = summary.probes[0].last[2];
        let linear = TetMesh::box_grid(
            Vector3::zeros(),
            Vector3::new(1.0, 0.1, 0.1),
            [if order == 1 { 10 } else { 5 }, 1, 1],
            BoxSplit::Five,
        )
        .unwrap();
        let library = if order == 1 {
            library_tip(&linear)
        } else {
            library_tip(&TetMesh::<Tet10>::from_linear(&linear).unwrap())
        };
        let change = summary.volume_change.unwrap();
        println!(
            "order {order}: scene tip {tip:.6} m, library {library:.6} m, |V/V0 − 1| ≤ \
             {change:.2e}, {:?}",
            summary.newton
        );
        assert_eq!(summary.steps, 10);
        // The same mesh, loads, dt and Newton tolerance (the scene's default 1e-8): the same
        // bits up to the order of a sum.
        assert!(
            (tip - library).abs() <= 1e-12 * tip.abs(),
            "{tip} vs {library}"
        );
        // It swung: gravity alone gives g·t²/2 ≈ 0.05 m of free fall in 0.1 s; the clamped
        // beam's tip falls a good part of that.
        assert!(tip < -0.01, "{tip}");
        // The 1 % at ν = 0.4999.
        assert!(change < 0.01, "{change:e}");
        // Backward Euler dissipates.
        assert!(summary.final_energy.total < summary.initial_energy.total);
    }
}

#[test]
fn newmark_with_the_mixed_corotational_model_is_refused_naming_the_model() {
    let text = swing(1).replace("method = \"backward_euler\"", "method = \"newmark\"");
    let message = run(&text).unwrap_err().to_string();
    assert!(message.contains("model"), "{message}");
    assert!(message.contains("corotational"), "{message}");
}
