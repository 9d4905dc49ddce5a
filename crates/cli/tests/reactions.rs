//! Reaction forces of linear static scenes: per node in the `.vtu`, per constraint entry in the
//! summary, and in balance with the applied loads.

#[path = "../../../tests/common/vtu.rs"]
mod vtu;

use std::path::Path;

use nalgebra::Vector3;
use tetfem_cli::scene::{RunOptions, Scene, run_static_with};

fn scene(name: &str) -> Scene {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../scenes")
        .join(name);
    let mut scene = Scene::load(&path).unwrap();
    scene.set_output_directory(
        Path::new(env!("CARGO_TARGET_TMPDIR"))
            .join("reactions")
            .join(name),
    );
    scene
}

#[test]
fn reactions_balance_the_applied_loads_in_force_and_moment() {
    // 1ᵀK = 0 and every infinitesimal rotation is in K's null space, so Σ(K·u − f) over all
    // DOFs is −Σf exactly, and over the free DOFs it is the solve's residual (≤ 1e-8 of |f|
    // by the residual check): the reactions balance the loads to that.
    for name in [
        "cantilever_static.toml",
        "hanging_bar.toml",
        "l_bracket.toml",
        "bimaterial_bar.toml",
        "soft_block.toml",
    ] {
        let scene = scene(name);
        let summary = run_static_with(
            &scene,
            &RunOptions {
                no_files: true,
                ..RunOptions::default()
            },
        )
        .unwrap();
        let built = scene.build().unwrap();
        let reactions = summary
            .reactions
            .as_ref()
            .expect("linear scenes report reactions");
        assert_eq!(reactions.len(), built.constraint_dofs.len());
        let applied = Vector3::from(summary.applied_load_n);
        let mut load_moment = Vector3::zeros();
        for (n, p) in built.mesh.nodes().iter().enumerate() {
            let f = &built.loads.as_slice()[3 * n..3 * n + 3];
            load_moment += p.cross(&Vector3::new(f[0], f[1], f[2]));
        }
        let force: Vector3<f64> = reactions.iter().map(|r| Vector3::from(r.force_n)).sum();
        let moment: Vector3<f64> = reactions
            .iter()
            .map(|r| Vector3::from(r.moment_about_origin_nm))
            .sum();
        let (lo, hi) = built.mesh.bounding_box();
        let size = (hi - lo).norm();
        let force_error = (force + applied).norm() / applied.norm();
        let moment_error = (moment + load_moment).norm() / (applied.norm() * size);
        println!("{name}: force balance {force_error:.1e}, moment balance {moment_error:.1e}");
        assert!(force_error < 1e-8, "{name}: {force:?} vs {applied:?}");
        assert!(moment_error < 1e-8, "{name}: {moment:?} vs {load_moment:?}");
    }
}

#[test]
fn the_bimaterial_bar_holds_its_pull() {
    // One clamp, one 100 kN pull along x: the clamp's reaction is −100 kN along x.
    let scene = scene("bimaterial_bar.toml");
    let summary = run_static_with(&scene, &RunOptions::default()).unwrap();
    let reactions = summary.reactions.unwrap();
    let applied = summary.applied_load_n;
    assert!((reactions[0].force_n[0] + applied[0]).abs() < 1e-8 * applied[0].abs());
    // The .vtu carries the nodal reactions, summing to the same resultant.
    let vtu = summary
        .files
        .iter()
        .find(|f| f.extension().is_some_and(|e| e == "vtu"))
        .unwrap();
    let values = vtu::read_vtu(vtu).values("reaction_force").to_vec();
    let sum_x: f64 = values.iter().step_by(3).sum();
    // Stored bit for bit; summed in another order than the resultant.
    assert!((sum_x - reactions[0].force_n[0]).abs() < 1e-9 * sum_x.abs());
}
