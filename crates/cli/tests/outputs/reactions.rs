//! Reaction forces of static scenes (linear, and nonlinear models solved by Newton): per node in
//! the `.vtu`, per constraint entry in the summary, and in balance with the applied loads.

use crate::common::vtu;

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
        let moment: Vector3<f64> = reactions.iter().map(|r| Vector3::from(r.moment_nm)).sum();
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

/// The rubber cantilever scene with `model` and its tip load scaled by `scale`.
fn rubber(model: &str, scale: f64) -> Scene {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes");
    let text = std::fs::read_to_string(dir.join("rubber_cantilever_large.toml"))
        .unwrap()
        .replace("model = \"corotational\"", &format!("model = \"{model}\""))
        .replace(
            "[0.0, 0.0, -30.0]",
            &format!("[0.0, 0.0, {:?}]", -30.0 * scale),
        );
    let mut scene = Scene::parse(&text, "rubber.toml", &dir).unwrap();
    scene.set_output_directory(
        Path::new(env!("CARGO_TARGET_TMPDIR"))
            .join("reactions")
            .join(format!("rubber_{model}_{scale}")),
    );
    scene
}

/// The displacement of a static run, read back from its `.vtu` (17 significant digits: the
/// values to round-off).
fn deformed_displacement(summary: &tetfem_cli::scene::RunSummary) -> Vec<f64> {
    let vtu = summary
        .files
        .iter()
        .find(|f| f.extension().is_some_and(|e| e == "vtu"))
        .unwrap();
    vtu::read_vtu(vtu).values("displacement").to_vec()
}

#[test]
fn nonlinear_static_reactions_balance_the_load_to_the_newton_residual() {
    for model in ["corotational", "neo-hookean", "st-venant-kirchhoff"] {
        let scene = rubber(model, 1.0);
        let summary = run_static_with(&scene, &RunOptions::default()).unwrap();
        let reactions = summary.reactions.as_ref().expect("nonlinear reactions");
        let force: Vector3<f64> = reactions.iter().map(|r| Vector3::from(r.force_n)).sum();
        let applied = Vector3::from(summary.applied_load_n);
        // Σₑ fₑ = 0 up to round-off, so Σ R + Σ f is the sum of the free residual's
        // components: per axis at most √n_f·‖r_f‖ = √n_f·(relative residual)·‖f_f‖, and
        // ‖f_f‖ ≤ |Σf| for a load whose nodal forces all point one way. Newton's tolerance
        // (1e-10 of ‖f_f‖, or its round-off floor) sets the balance; 1e-12 |f| of headroom
        // for the round-off of summing the O(E·strain) element forces.
        let bound = ((summary.free_dofs as f64).sqrt() * summary.relative_residual + 1e-12)
            * applied.norm();
        let error = (force + applied).norm();
        println!(
            "{model}: |ΣR + Σf| = {error:.2e} N (bound {bound:.2e}), residual {:.1e}",
            summary.relative_residual
        );
        assert!(error <= bound, "{model}: {force:?} vs {applied:?}");
        // Moments: every model here is objective, so Σₑ xₑ × fₑ = 0 in the deformed positions
        // x = X + u; the clamped nodes do not move, so the reactions' moment about the origin
        // from the reference positions balances the load's moment from the deformed ones, to
        // the same residual bound times the body's size (0.5 m).
        let built = scene.build().unwrap();
        let u = deformed_displacement(&summary);
        let mut load_moment = Vector3::zeros();
        for (n, p) in built.mesh.nodes().iter().enumerate() {
            let f = &built.loads.as_slice()[3 * n..3 * n + 3];
            let x = p + Vector3::new(u[3 * n], u[3 * n + 1], u[3 * n + 2]);
            load_moment += x.cross(&Vector3::new(f[0], f[1], f[2]));
        }
        let moment = Vector3::from(reactions[0].moment_nm);
        let moment_error = (moment + load_moment).norm();
        println!(
            "{model}: |ΣM_R + ΣM_f| = {moment_error:.2e} N·m, M_R,y = {:.4} N·m",
            moment.y
        );
        assert!(
            moment_error <= bound * 0.5,
            "{model}: {moment:?} vs {load_moment:?}"
        );
        // Large deflection: the lever arm of the tip load shortened as the beam bent, so the
        // clamp's moment is below the small-deflection 30 N × 0.5 m = 15 N·m.
        assert!(moment.y < 0.0 && moment.y > -15.0, "{model}: {moment:?}");
        // The .vtu carries the nodal reactions of the nonlinear run.
        let vtu = summary
            .files
            .iter()
            .find(|f| f.extension().is_some_and(|e| e == "vtu"))
            .unwrap();
        let nodal = vtu::read_vtu(vtu).values("reaction_force").to_vec();
        let nodal_sum = nodal
            .chunks_exact(3)
            .fold(Vector3::zeros(), |s: Vector3<f64>, r| {
                s + Vector3::new(r[0], r[1], r[2])
            });
        // The same numbers, summed in another order: round-off of the O(load) terms only.
        assert!(
            (nodal_sum - force).norm() <= 1e-12 * applied.norm().max(1.0) * nodal.len() as f64,
            "{model}: {nodal_sum:?} vs {force:?}"
        );
    }
}

#[test]
fn nonlinear_reactions_tend_to_the_linear_ones_at_small_load() {
    // At a load 1e-3 of the scene's (tip rotation ~1e-3 rad; smaller loads meet Newton's
    // round-off floor before its 1e-10 tolerance), the models differ from the linear one by
    // O(rotation) ~ 1e-3 relative: the clamp's resultants agree to 1e-2 relative, far below
    // any sign or factor error.
    let linear = run_static_with(&rubber("linear", 1e-3), &RunOptions::default()).unwrap();
    let linear = linear.reactions.unwrap();
    for model in ["corotational", "neo-hookean"] {
        let summary = run_static_with(&rubber(model, 1e-3), &RunOptions::default()).unwrap();
        let reactions = summary.reactions.unwrap();
        let (a, b) = (
            Vector3::from(reactions[0].force_n),
            Vector3::from(linear[0].force_n),
        );
        let error = (a - b).norm() / b.norm();
        let (ma, mb) = (
            Vector3::from(reactions[0].moment_nm),
            Vector3::from(linear[0].moment_nm),
        );
        let moment_error = (ma - mb).norm() / (b.norm() * 0.5);
        println!("{model}: force {error:.1e}, moment {moment_error:.1e}");
        assert!(
            error < 1e-2 && moment_error < 1e-2,
            "{model}: {a:?} vs {b:?}"
        );
    }
}

#[test]
fn moments_are_taken_about_the_stated_point() {
    // M_p = Σ (xᵢ − p) × Rᵢ = M_0 − p × F: the same reactions about another point, an exact
    // identity up to the round-off of the sums (1e-12 of |F|·|p|).
    let at_origin = run_static_with(
        &scene("bimaterial_bar.toml"),
        &RunOptions {
            no_files: true,
            ..RunOptions::default()
        },
    )
    .unwrap();
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes");
    let text = std::fs::read_to_string(dir.join("bimaterial_bar.toml")).unwrap().replace(
        "[[constraints]]\nwhere = { plane = { axis = \"x\", at = 0.0 } }",
        "[[constraints]]\nwhere = { plane = { axis = \"x\", at = 0.0 } }\nmoment_about = [0.5, 0.2, -0.3]",
    );
    let moved = Scene::parse(&text, "moved.toml", &dir).unwrap();
    let summary = run_static_with(
        &moved,
        &RunOptions {
            no_files: true,
            ..RunOptions::default()
        },
    )
    .unwrap();
    let (r0, rp) = (
        &at_origin.reactions.unwrap()[0],
        &summary.reactions.unwrap()[0],
    );
    let p = Vector3::new(0.5, 0.2, -0.3);
    assert_eq!(rp.moment_point_m, [0.5, 0.2, -0.3]);
    assert_eq!(r0.moment_point_m, [0.0; 3]);
    let force = Vector3::from(r0.force_n);
    let expected = Vector3::from(r0.moment_nm) - p.cross(&force);
    let error = (Vector3::from(rp.moment_nm) - expected).norm();
    assert!(
        error < 1e-12 * force.norm() * p.norm(),
        "{rp:?} vs {expected:?}"
    );
    // A non-finite point is an error naming the key.
    let bad = text.replace("[0.5, 0.2, -0.3]", "[0.5, nan, 0.0]");
    let err = Scene::parse(&bad, "bad.toml", &dir)
        .and_then(|s| s.build().map(|_| ()))
        .unwrap_err();
    assert!(
        err.to_string().contains("constraints[0].moment_about"),
        "{err}"
    );
}

#[test]
fn a_dof_two_entries_hold_is_counted_once() {
    // The clamp (z = 0, every axis) and the roller (x = 0, x only) share the edge x = z = 0:
    // its x DOFs are held by both. Each DOF's reaction is the first entry's, so the two rows
    // sum to the total: −(applied load) to the solve's residual (1e-8 of |f|, as above).
    let text = r#"
[mesh.box]
max = [1.0, 0.2, 0.2]
cells = [5, 2, 2]

[material]
youngs_modulus = 1e9
poisson_ratio = 0.3
density = 1000.0

[[constraints]]
where = { plane = { axis = "z", at = 0.0 } }

[[constraints]]
where = { plane = { axis = "x", at = 0.0 } }
fix = ["x"]

[[loads]]
where = { plane = { axis = "z", at = 0.2 } }
total_force = [1000.0, 0.0, -500.0]

[analysis]
type = "static"
"#;
    let scene: Scene = text.parse().unwrap();
    let options = RunOptions {
        no_files: true,
        ..RunOptions::default()
    };
    let summary = run_static_with(&scene, &options).unwrap();
    let rows = summary.reactions.unwrap();
    let force: Vector3<f64> = rows.iter().map(|r| Vector3::from(r.force_n)).sum();
    let applied = Vector3::from(summary.applied_load_n);
    println!(
        "rows x: {:.6} + {:.6} N against {:.6} N applied",
        rows[0].force_n[0], rows[1].force_n[0], applied[0]
    );
    assert!(
        (force + applied).norm() < 1e-8 * applied.norm(),
        "{force:?}"
    );
}
