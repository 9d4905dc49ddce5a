//! Outputs come from the model that ran (issue 15, item 2): the von Mises stress and the strain
//! energy density of a corotational or Neo-Hookean run are that model's, not the linear
//! strain's. A rigid rotation is stress- and energy-free; small motions agree with the linear
//! model to first order.

use std::fmt::Write as _;
use std::path::Path;

use nalgebra::{Matrix3, Rotation3, Vector3};
use tetfem::model::{Corotational, ForceModel, LinearModel, NeoHookean};
use tetfem::post::output::fields::{
    cell_model_energy_density, cell_model_stress, cell_model_von_mises, cell_strain_energy_density,
    cell_stress, cell_von_mises, displacement_magnitude,
};
use tetfem::{BoxSplit, Material, TetMesh};
use tetfem_cli::scene::{RunOptions, Scene, run_static_with};

const E: f64 = 2e7;

fn material() -> Material {
    Material::new(E, 0.3, 1000.0).unwrap()
}

fn mesh() -> TetMesh {
    TetMesh::box_grid(
        Vector3::zeros(),
        Vector3::new(1.0, 0.5, 0.25),
        [3, 2, 2],
        BoxSplit::Five,
    )
    .unwrap()
}

/// u(X) from a map X → u.
fn field(mesh: &TetMesh, u: impl Fn(&Vector3<f64>) -> Vector3<f64>) -> Vec<f64> {
    mesh.nodes().iter().flat_map(|x| u(x).data.0[0]).collect()
}

fn rigid_rotation(mesh: &TetMesh) -> Vec<f64> {
    let r = Rotation3::from_axis_angle(
        &nalgebra::Unit::new_normalize(Vector3::new(1.0, 2.0, 3.0)),
        1.1,
    );
    let shift = Vector3::new(0.3, -0.2, 0.1);
    field(mesh, |x| r * x + shift - x)
}

fn nonlinear_models(material: &Material) -> Vec<Box<dyn ForceModel>> {
    vec![
        Box::new(Corotational::new(material)),
        Box::new(NeoHookean::new(material)),
    ]
}

#[test]
fn a_rigid_rotation_is_stress_and_energy_free_for_both_nonlinear_models() {
    let (mesh, material) = (mesh(), material());
    let u = rigid_rotation(&mesh);
    // The linear strain of a 63° rotation is of order 1 − cos θ ≈ 0.5: the linear model reports
    // a von Mises stress of order E, which is what the outputs showed before.
    let linear = cell_von_mises(&mesh, &material, &u).unwrap();
    assert!(linear.iter().all(|&s| s > 0.1 * E), "{linear:?}");
    for model in nonlinear_models(&material) {
        let stress = cell_model_von_mises(&mesh, model.as_ref(), &u).unwrap();
        let energy = cell_model_energy_density(&mesh, model.as_ref(), &u).unwrap();
        // Exactly zero in exact arithmetic; F = R is computed from positions of order 1, so
        // round-off leaves ~1e-15 in F and ~1e-15·E in σ and in W/E·… (W is quadratic in
        // F − R, so even smaller). 1e-9·E is far above round-off and far below any real stress.
        let worst = stress.iter().fold(0.0f64, |a, &b| a.max(b));
        assert!(worst < 1e-9 * E, "{}: σ_vM = {worst}", model.name());
        let worst = energy.iter().fold(0.0f64, |a, &b| a.max(b.abs()));
        assert!(worst < 1e-9 * E, "{}: W = {worst}", model.name());
    }
}

/// A smooth, non-affine displacement: stretch, shear and bending in every tet differently.
fn general_motion(mesh: &TetMesh, scale: f64) -> Vec<f64> {
    field(mesh, |x| {
        scale
            * Vector3::new(
                0.8 * x.x + 0.3 * x.y * x.y - 0.2 * x.z,
                -0.4 * x.y + 0.5 * x.x * x.z + 0.1 * x.x,
                0.6 * x.z * x.y + 0.7 * x.x * x.x - 0.3 * x.y,
            )
    })
}

fn max_difference(a: &[Matrix3<f64>], b: &[Matrix3<f64>]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).amax())
        .fold(0.0, f64::max)
}

#[test]
fn small_motions_agree_with_the_linear_outputs_to_first_order() {
    let (mesh, material) = (mesh(), material());
    for model in nonlinear_models(&material) {
        let mut stress_gaps = Vec::new();
        let mut energy_gaps = Vec::new();
        let mut stress_sizes = Vec::new();
        for s in [1e-3, 5e-4] {
            let u = general_motion(&mesh, s);
            let linear = cell_stress(&mesh, &material, &u).unwrap();
            let own = cell_model_stress(&mesh, model.as_ref(), &u).unwrap();
            stress_gaps.push(max_difference(&own, &linear));
            stress_sizes.push(linear.iter().map(|m| m.amax()).fold(0.0, f64::max));
            let linear = cell_strain_energy_density(&mesh, &material, &u).unwrap();
            let own = cell_model_energy_density(&mesh, model.as_ref(), &u).unwrap();
            energy_gaps.push(
                own.iter()
                    .zip(&linear)
                    .map(|(a, b)| (a - b).abs())
                    .fold(0.0, f64::max),
            );
        }
        let name = model.name();
        // σ_model − σ_linear = O(s²) (the models differ by terms quadratic in ∇u): halving s
        // divides the gap by 4. The next term is O(s³), a relative 1e-3 change of the ratio at
        // s = 1e-3 with ∇u ~ 1; ±5 % is far tighter than the factor 2 an O(s) error would give.
        let ratio = stress_gaps[0] / stress_gaps[1];
        assert!(
            (ratio - 4.0).abs() < 0.2,
            "{name}: stress gap ratio {ratio}"
        );
        // And the gap is small next to the stress itself (O(s) relative).
        assert!(stress_gaps[0] < 1e-2 * stress_sizes[0], "{name}");
        // W is quadratic in the strain, and the strains differ at O(s²): W gaps are O(s³).
        let ratio = energy_gaps[0] / energy_gaps[1];
        assert!(
            (ratio - 8.0).abs() < 0.4,
            "{name}: energy gap ratio {ratio}"
        );
    }
}

#[test]
fn the_linear_model_outputs_are_the_linear_fields() {
    let (mesh, material) = (mesh(), material());
    let u = general_motion(&mesh, 1e-3);
    let model = LinearModel::new(&material);
    let own = cell_model_stress(&mesh, &model, &u).unwrap();
    let linear = cell_stress(&mesh, &material, &u).unwrap();
    // The same formula from the same displacement: only the subtraction x − X differs (u is
    // recovered from positions of order 1), ~1e-16 relative to the displacement gradient.
    assert!(max_difference(&own, &linear) < 1e-9 * linear[0].amax());
    let own = cell_model_energy_density(&mesh, &model, &u).unwrap();
    let linear = cell_strain_energy_density(&mesh, &material, &u).unwrap();
    for (a, b) in own.iter().zip(&linear) {
        // ½uᵀKu/V against ½σ:ε: the same quadratic form, summed differently.
        assert!((a - b).abs() < 1e-9 * b.abs(), "{a} vs {b}");
    }
}

/// A block whose x = 0 face is turned rigidly by `angle` about the x axis (one constraint per
/// node), everything else free and unloaded: its equilibrium is the rigid rotation.
fn rotated_block_scene(model: &str, angle: f64) -> Scene {
    let mesh = TetMesh::box_grid(
        Vector3::zeros(),
        Vector3::new(1.0, 0.4, 0.4),
        [2, 1, 1],
        BoxSplit::Five,
    )
    .unwrap();
    let rotation = Rotation3::from_axis_angle(&Vector3::x_axis(), angle);
    let mut text = format!(
        "title = \"rotated block\"\n\
         [mesh.box]\nmax = [1.0, 0.4, 0.4]\ncells = [2, 1, 1]\nsplit = \"five\"\n\
         [material]\nyoungs_modulus = {E:e}\npoisson_ratio = 0.3\ndensity = 1000.0\n\
         [analysis]\ntype = \"static\"\nmodel = \"{model}\"\n"
    );
    for n in mesh.nodes_on_plane(0, 0.0, 1e-9) {
        let x = mesh.nodes()[n];
        let u = rotation * x - x;
        writeln!(
            text,
            "[[constraints]]\nwhere = {{ nodes = [{n}] }}\ndisplacement = [{:e}, {:e}, {:e}]",
            u.x, u.y, u.z
        )
        .unwrap();
    }
    text.push_str("[[probes]]\nname = \"end\"\nwhere = { plane = { axis = \"x\", at = 1.0 } }\n");
    Scene::parse(&text, "rotated_block", Path::new(".")).unwrap()
}

#[test]
fn a_rigidly_rotated_block_reports_no_stress_in_the_run_summary() {
    let options = RunOptions {
        no_files: true,
        ..RunOptions::default()
    };
    for model in ["corotational", "neo-hookean"] {
        let summary = run_static_with(&rotated_block_scene(model, 0.5), &options).unwrap();
        // The free end did turn with the clamp (rotation by 0.5 rad about x moves the far
        // corner (1, 0.4, 0.4) by about 0.2 m): the run is not a trivial zero.
        assert!(summary.max_displacement > 0.15, "{model}: {summary:?}");
        // Newton stops at ‖r‖ ≤ 1e-10·‖f‖ (here the reactions of the prescribed face), leaving
        // strains of that order; before the fix the linear strain of the 0.5 rad rotation gave
        // σ_vM of order 0.1·E.
        assert!(
            summary.max_von_mises < 1e-6 * E,
            "{model}: max von Mises {}",
            summary.max_von_mises
        );
    }
}

#[test]
fn displacement_magnitude_neither_underflows_nor_overflows() {
    // Squaring 1e-200 underflows to 0 and squaring 1e200 overflows to ∞.
    let m = displacement_magnitude(&[3e-200, 4e-200, 0.0, 3e200, -4e200, 0.0, 0.0, 0.0, 0.0]);
    // 5·10^k exactly up to the rounding of the scaled sum (a few ulp).
    assert!((m[0] / 5e-200 - 1.0).abs() < 1e-15, "{}", m[0]);
    assert!((m[1] / 5e200 - 1.0).abs() < 1e-15, "{}", m[1]);
    assert_eq!(m[2], 0.0);
    let m = displacement_magnitude(&[1e-293, 0.0, 0.0, f64::INFINITY, 1.0, 0.0]);
    assert_eq!(m[0], 1e-293);
    assert_eq!(m[1], f64::INFINITY);
    assert!(displacement_magnitude(&[f64::NAN, 1.0, 0.0])[0].is_nan());
}
