//! Scenes of `mesh.order = 2` with a nonlinear model: static Newton and backward Euler on
//! 10-node tets, against the library on the same mesh and against the beam's geometry.

use std::ops::ControlFlow;
use std::path::Path;

use nalgebra::Vector3;
use tetfem::analysis::nonlinear::{NewtonOptions, solve_nonlinear_static};
use tetfem::bc::constraints::Constraints;
use tetfem::bc::loads::Loads;
use tetfem::fe::element::Tet10;
use tetfem::fe::material::Material;
use tetfem::mesh::{BoxSplit, TetMesh};
use tetfem::model::ModelKind;
use tetfem_cli::scene::{DynamicOverrides, RunOptions, Scene, run_dynamic_scene, run_static_with};

/// A soft cantilever (L = 4, 1 × 1 section, E = 1e6, ν = 0.3) of 8×2×2 five-tet cells at order
/// 2, clamped at x = 0, with a total end force of 6 kN down (linear beam theory: a tip
/// deflection of 1.54, 38 % of L), and `analysis` appended.
fn cantilever(analysis: &str) -> String {
    format!(
        r#"
[mesh]
order = 2

[mesh.box]
max = [4.0, 1.0, 1.0]
cells = [8, 2, 2]
split = "five"

[material]
youngs_modulus = 1e6
poisson_ratio = 0.3
density = 1000.0

[[constraints]]
where = {{ plane = {{ axis = "x", at = 0.0 }} }}

[[loads]]
where = {{ plane = {{ axis = "x", at = 4.0 }} }}
total_force = [0.0, 0.0, -6000.0]

[[probes]]
name = "tip"
where = {{ plane = {{ axis = "x", at = 4.0 }} }}

{analysis}
"#
    )
}

fn parse(text: &str) -> Scene {
    Scene::parse(text, "<p2-nonlinear>", Path::new(".")).expect("valid scene")
}

fn no_files() -> RunOptions {
    RunOptions {
        no_files: true,
        ..RunOptions::default()
    }
}

#[test]
fn p2_corotational_static_scene_runs_and_is_the_library_solve() {
    let scene = parse(&cantilever(
        "[analysis]\ntype = \"static\"\nmodel = \"corotational\"\n",
    ));
    let summary = run_static_with(&scene, &no_files()).expect("P2 corotational scene");
    let tip = summary.probes[0].displacement;

    // The same solve through the library on the same Tet10 mesh.
    let linear = TetMesh::box_grid(
        Vector3::zeros(),
        Vector3::new(4.0, 1.0, 1.0),
        [8, 2, 2],
        BoxSplit::Five,
    )
    .expect("box");
    let mesh = TetMesh::<Tet10>::from_linear(&linear).expect("Tet10 mesh");
    let material = Material::new(1e6, 0.3, 1000.0).expect("material");
    let mut constraints = Constraints::new(&mesh);
    constraints
        .fix_nodes(&mesh.nodes_on_plane(0, 0.0, 1e-9))
        .expect("clamp");
    let boundary = mesh.boundary_faces().expect("faces");
    let faces = mesh.faces_on_plane(&boundary, 0, 4.0, 1e-9);
    let mut loads = Loads::new(&mesh);
    loads
        .add_total_force_on_faces(&mesh, &faces, Vector3::new(0.0, 0.0, -6000.0))
        .expect("load");
    let model = ModelKind::Corotational.build(&material);
    let report = solve_nonlinear_static(
        &mesh,
        &model,
        &constraints,
        &loads,
        NewtonOptions::default(),
    )
    .expect("library Newton");
    let tip_nodes = mesh.nodes_on_plane(0, 4.0, 1e-9);
    let mut expected = Vector3::zeros();
    for &n in &tip_nodes {
        expected += Vector3::from_column_slice(&report.displacement[3 * n..3 * n + 3]);
    }
    expected /= tip_nodes.len() as f64;
    let difference = (Vector3::from(tip) - expected).norm() / expected.norm();
    println!("scene tip {tip:?}, library {expected:?}, relative difference {difference:.2e}");
    // The scene's Newton converges to the same solution within its tolerance (1e-10 of the
    // load, relative; a one-material ModelMap against one model changes no formula).
    assert!(difference <= 1e-8, "{difference:e}");

    // The bent beam keeps its length: the chord from the root's centre to the tip's is shorter
    // than L = 4 (an arc), and not by more than 10 % at this deflection; the linear model's
    // tip would move straight down (chord √(4² + 1.54²) = 4.29).
    let chord =
        (Vector3::new(4.0, 0.5, 0.5) + Vector3::from(tip) - Vector3::new(0.0, 0.5, 0.5)).norm();
    println!("chord {chord:.4}");
    assert!(chord < 4.0 && chord > 3.6, "chord {chord}");
    assert!(tip[2] < -1.0, "tip {tip:?}");
}

#[test]
fn p2_models_agree_with_each_other_at_moderate_strain() {
    // Corotational and Neo-Hookean differ only at finite strain: on this beam (strains of a few
    // per cent) their tips agree to 1 %, as on 4-node tets (0.13 % up to 60°, `docs/src/large-deformation.md`).
    let tips: Vec<[f64; 3]> = ["corotational", "neo-hookean"]
        .iter()
        .map(|model| {
            let scene = parse(&cantilever(&format!(
                "[analysis]\ntype = \"static\"\nmodel = \"{model}\"\n"
            )));
            run_static_with(&scene, &no_files())
                .expect("P2 static scene")
                .probes[0]
                .displacement
        })
        .collect();
    let difference =
        (Vector3::from(tips[0]) - Vector3::from(tips[1])).norm() / Vector3::from(tips[0]).norm();
    println!(
        "corotational {:?}, neo-hookean {:?}: {difference:.3e}",
        tips[0], tips[1]
    );
    assert!(difference < 0.01, "{difference:e}");
}

#[test]
fn p2_backward_euler_scene_with_a_nonlinear_model_runs_and_dissipates() {
    let scene = parse(&cantilever(
        "[analysis]\ntype = \"dynamic\"\nmethod = \"backward_euler\"\nmodel = \"neo-hookean\"\n\
         dt = 2e-3\nduration = 0.04\n",
    ));
    let summary = run_dynamic_scene(
        &scene,
        &DynamicOverrides::default(),
        false,
        false,
        &mut |_, _| ControlFlow::Continue(()),
    )
    .expect("P2 Neo-Hookean backward Euler scene");
    let e = &summary.final_energy;
    let total = e.kinetic + e.elastic + e.gravity_potential + e.load_potential;
    println!(
        "kinetic {:.4e}, elastic {:.4e}, load potential {:.4e}, total {total:.4e}",
        e.kinetic, e.elastic, e.load_potential
    );
    // From rest (total 0) under a constant load, backward Euler only removes energy:
    // the total stays ≤ 0, up to Newton's residuals (1e-9 of the energies, with room).
    assert!(total <= 1e-9 * e.kinetic.max(e.elastic), "total {total:e}");
    assert!(e.kinetic > 0.0 && e.elastic > 0.0);
}

/// A P2 scene with an obstacle out of reach (2 m below a body whose activation distance is
/// 1e-3 of its diagonal) runs through the contact Newton solve on the corner and mid-edge
/// nodes, and gives the displacement of the same scene without it: the barrier is zero there.
#[test]
fn p2_scene_with_an_obstacle_out_of_reach_runs_as_without_it() {
    let without = cantilever("[analysis]\ntype = \"static\"\nmodel = \"corotational\"\n");
    let with = cantilever(
        "[analysis]\ntype = \"static\"\nmodel = \"corotational\"\n\n[[obstacles]]\n\
         kind = \"half_space\"\npoint = [0.0, 0.0, -2.0]\nnormal = [0.0, 0.0, 1.0]\n",
    );
    let options = tetfem_cli::scene::RunOptions {
        no_files: true,
        ..Default::default()
    };
    let run = |text: &str| {
        let scene = Scene::parse(text, "<p2-nonlinear>", Path::new(".")).expect("P2 scene");
        tetfem_cli::scene::run_static_with(&scene, &options).expect("P2 run")
    };
    let (a, b) = (run(&without), run(&with));
    let forces = b.contact_forces.expect("a scene with obstacles");
    assert_eq!(forces[0].force_n, [0.0; 3]);
    // Both Newton solves stop at their tolerance (1e-10 of the load by default): the same
    // displacement to 1e-8 of it.
    let gap = (a.max_displacement - b.max_displacement).abs();
    assert!(
        gap <= 1e-8 * a.max_displacement,
        "{gap:e} of {:e}",
        a.max_displacement
    );
}
