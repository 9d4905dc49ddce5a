//! Scenes of `mesh.order = 2` (10-node tets): each analysis against the library on the same
//! Tet10 mesh, the cantilever against its converged answer, and the errors of the key.

use crate::common::vtu;
use std::ops::ControlFlow;
use std::path::Path;

use nalgebra::Vector3;
use tetfem::analysis::dynamics::{LinearSystem, MassKind, Rayleigh, critical_time_step};
use tetfem::analysis::modal::lowest_modes;
use tetfem::bc::constraints::Constraints;
use tetfem::bc::loads::Loads;
use tetfem::fe::element::Tet10;
use tetfem::fe::material::Material;
use tetfem::mesh::{BoundaryFace, BoxSplit, TetMesh};
use tetfem::post::output::fields::displacement_magnitude;
use tetfem_cli::scene::{
    DynamicOverrides, RunOptions, Scene, run_dynamic_scene, run_modal_scene, run_static_with,
};

/// The peer cantilever (L = 10, W = H = 1, E = 1e5, ν = 0.3, ρ = 1000, end load 1 N as a
/// uniform traction on x = L, clamped at x = 0) on `cells` of `split`, order 2, with `extra`
/// appended (an `[analysis]`, more loads).
fn cantilever(cells: [usize; 3], split: &str, extra: &str) -> String {
    format!(
        r#"
[mesh]
order = 2

[mesh.box]
max = [10.0, 1.0, 1.0]
cells = [{}, {}, {}]
split = "{split}"

[material]
youngs_modulus = 1e5
poisson_ratio = 0.3
density = 1000.0

[[constraints]]
where = {{ plane = {{ axis = "x", at = 0.0 }} }}

[[loads]]
where = {{ plane = {{ axis = "x", at = 10.0 }} }}
total_force = [0.0, 0.0, -1.0]

[[probes]]
name = "tip"
where = {{ plane = {{ axis = "x", at = 10.0 }} }}
{extra}
"#,
        cells[0], cells[1], cells[2]
    )
}

fn parse(text: &str) -> Scene {
    Scene::parse(text, "<p2>", Path::new(".")).expect("valid scene")
}

/// The same body through the library alone: the Tet10 mesh of the box, the clamp, the end
/// load (and gravity if given), in the scene's order of loads.
struct Library {
    mesh: TetMesh<Tet10>,
    material: Material,
    constraints: Constraints,
    loads: Loads,
    tip: Vec<usize>,
}

fn library(cells: [usize; 3], split: BoxSplit, gravity: Option<Vector3<f64>>) -> Library {
    let linear = TetMesh::box_grid(Vector3::zeros(), Vector3::new(10.0, 1.0, 1.0), cells, split)
        .expect("box");
    let mesh = TetMesh::<Tet10>::from_linear(&linear).expect("Tet10 mesh");
    let material = Material::new(1e5, 0.3, 1000.0).expect("material");
    // Any tolerance far below the node spacing picks the same planes as the scene's default.
    let tol = 1e-9;
    let clamp = mesh.try_nodes_on_plane(0, 0.0, tol).expect("clamp nodes");
    let tip = mesh.try_nodes_on_plane(0, 10.0, tol).expect("tip nodes");
    let mut constraints = Constraints::new(&mesh);
    constraints.fix_axes(&clamp, [true; 3]).expect("clamp");
    let on_tip = |n: &usize| tip.binary_search(n).is_ok();
    let faces: Vec<BoundaryFace> = mesh
        .boundary_faces()
        .expect("faces")
        .into_iter()
        .filter(|f| f.nodes.iter().all(on_tip))
        .collect();
    let mut loads = Loads::new(&mesh);
    loads
        .add_total_force_on_faces(&mesh, &faces, Vector3::new(0.0, 0.0, -1.0))
        .expect("end load");
    if let Some(g) = gravity {
        loads.add_gravity(&mesh, &material, g).expect("gravity");
    }
    Library {
        mesh,
        material,
        constraints,
        loads,
        tip,
    }
}

/// Mean displacement of `nodes`, summed as the scene's probes sum it.
fn mean(u: &[f64], nodes: &[usize]) -> [f64; 3] {
    let mut sum = Vector3::zeros();
    for &n in nodes {
        sum += Vector3::new(u[3 * n], u[3 * n + 1], u[3 * n + 2]);
    }
    (sum / nodes.len() as f64).into()
}

fn no_files() -> RunOptions {
    RunOptions {
        no_files: true,
        ..RunOptions::default()
    }
}

#[test]
fn static_scene_equals_solve_static_on_the_same_tet10_mesh_bit_for_bit() {
    for (split, box_split) in [
        ("mirrored6", BoxSplit::Mirrored6),
        ("lecture6", BoxSplit::Lecture6),
        ("five", BoxSplit::Five),
    ] {
        let scene = parse(&cantilever(
            [6, 2, 2],
            split,
            "[[loads]]\ngravity = [0.0, -2.0, -9.81]\n",
        ));
        let summary = run_static_with(&scene, &no_files()).expect("P2 static scene");
        let lib = library([6, 2, 2], box_split, Some(Vector3::new(0.0, -2.0, -9.81)));
        let solution = tetfem::solve_static(&lib.mesh, &lib.material, &lib.constraints, &lib.loads)
            .expect("library solve");
        let u = &solution.displacement;
        assert_eq!(summary.nodes, lib.mesh.node_count(), "{split}");
        assert_eq!(summary.tets, lib.mesh.tet_count(), "{split}");
        // Bit for bit: the scene runs the same generic solve on the same mesh and loads.
        assert_eq!(summary.probes[0].displacement, mean(u, &lib.tip), "{split}");
        let largest = displacement_magnitude(u).into_iter().fold(0.0, f64::max);
        assert_eq!(summary.max_displacement, largest, "{split}");
        assert_eq!(
            summary.relative_residual, solution.relative_residual,
            "{split}"
        );
    }
}

/// The converged tip deflection of the peer cantilever: Richardson extrapolation of P2 runs
/// (`cargo bench --bench quadratic_cantilever -- 20,2,2 40,4,4 80,8,8`, lecture split)
/// at 20×2×2, 40×4×4 and 80×8×8 cells: −3.982739688e−2, −3.997624764e−2, −4.001844903e−2; the
/// differences shrink by 3.53 (observed rate 1.82), and u₈₀ + Δ/(3.53 − 1) = −4.00351e−2 (with
/// the nominal rate 2 instead, −4.00325e−2). Timoshenko's beam value 0.040306 lies 0.68 %
/// above: the clamp's 3-D constraint stiffens the root.
const CONVERGED_TIP: f64 = -4.0035e-2;

#[test]
fn p2_cantilever_scene_is_within_one_percent_of_the_converged_tip_under_20k_dofs() {
    for (cells, expected_dofs) in [([20, 2, 2], 3000), ([40, 4, 4], 19440)] {
        let scene = parse(&cantilever(cells, "lecture6", ""));
        let summary = run_static_with(&scene, &no_files()).expect("P2 cantilever");
        assert_eq!(summary.free_dofs, expected_dofs);
        let tip = summary.probes[0].displacement[2];
        let error = (tip - CONVERGED_TIP).abs() / CONVERGED_TIP.abs();
        println!(
            "P2 {cells:?}: {} DOFs, tip {tip:.9e}, {:.3} % from {CONVERGED_TIP:e}",
            summary.free_dofs,
            100.0 * error
        );
        // The issue's goal: 1 % at ≤ 20k DOFs (the extrapolation's own spread is 0.007 %).
        assert!(error < 0.01, "{cells:?}: {:.3} %", 100.0 * error);
    }
}

#[test]
fn modal_scene_first_frequency_equals_the_library_on_tet10() {
    for mass in ["lumped", "consistent"] {
        let scene = parse(&cantilever(
            [6, 1, 1],
            "mirrored6",
            &format!("[analysis]\ntype = \"modal\"\nmodes = 3\nmass = \"{mass}\"\n"),
        ));
        let summary = run_modal_scene(&scene, true).expect("P2 modal scene");
        let lib = library([6, 1, 1], BoxSplit::Mirrored6, None);
        let kind = match mass {
            "lumped" => MassKind::Lumped,
            _ => MassKind::Consistent,
        };
        let system = LinearSystem::new(
            &lib.mesh,
            &lib.material,
            &lib.constraints,
            &Loads::new(&lib.mesh),
            Vector3::zeros(),
            kind,
            Rayleigh::default(),
        )
        .expect("system");
        let modes = lowest_modes(&system, 3).expect("modes");
        // Bit for bit: the same K and M on the same DOFs, the same eigensolver.
        for (row, omega) in summary.modes.iter().zip(&modes.omega) {
            assert_eq!(row.omega_rad_per_s, *omega, "{mass} mode {}", row.mode);
        }
    }
}

#[test]
fn explicit_p2_scene_uses_the_library_critical_step_and_the_element_bound_is_below_it() {
    let scene = parse(&cantilever(
        [6, 1, 1],
        "mirrored6",
        "[analysis]\ntype = \"dynamic\"\nmethod = \"explicit\"\ndt = 1e-3\nduration = 0.05\n",
    ));
    let summary = run_dynamic_scene(
        &scene,
        &DynamicOverrides::default(),
        false,
        false,
        &mut |_, _| ControlFlow::Continue(()),
    )
    .expect("explicit P2 scene");
    let lib = library([6, 1, 1], BoxSplit::Mirrored6, None);
    let system = LinearSystem::new(
        &lib.mesh,
        &lib.material,
        &lib.constraints,
        &lib.loads,
        Vector3::zeros(),
        MassKind::Lumped,
        Rayleigh::default(),
    )
    .expect("system");
    let critical = critical_time_step(&system).expect("critical step").dt;
    // Bit for bit: the same HRZ-lumped M and K.
    assert_eq!(summary.critical_step, critical);
    // The element bound never exceeds the assembled step (element eigenvalue theorem).
    let bound = tetfem::analysis::dynamics::element_step_bound_of_type(&lib.mesh, &lib.material)
        .expect("bound")
        .dt_element;
    println!("P2 6×1×1: critical step {critical:e}, element bound {bound:e}");
    assert!(bound <= critical, "{bound:e} > {critical:e}");
    // A stable run below the critical step: energy stays at the load's work scale (an
    // unstable one grows by orders of magnitude in 50 steps).
    assert!(summary.dt < critical);
    let e = &summary.final_energy;
    assert!(e.kinetic.is_finite() && e.kinetic + e.elastic <= 2.0 * e.load_potential.abs());
}

#[test]
fn newmark_p2_scene_conserves_energy() {
    let scene = parse(&cantilever(
        [6, 1, 1],
        "five",
        "[analysis]\ntype = \"dynamic\"\nmethod = \"newmark\"\ndt = 5e-3\nduration = 0.5\n",
    ));
    let summary = run_dynamic_scene(
        &scene,
        &DynamicOverrides::default(),
        false,
        false,
        &mut |_, _| ControlFlow::Continue(()),
    )
    .expect("Newmark P2 scene");
    let e = &summary.final_energy;
    let total = e.kinetic + e.elastic + e.gravity_potential + e.load_potential;
    // The average-acceleration rule conserves the discrete energy of an undamped linear system
    // under a constant load exactly; what is left is round-off and the solves' residuals.
    assert!(
        total.abs() <= 1e-9 * e.kinetic.max(e.elastic),
        "total {total:e}, kinetic {:e}",
        e.kinetic
    );
    assert!(e.kinetic > 0.0);
}

#[test]
fn p2_vtu_has_quadratic_tet_cells() {
    let dir = std::env::temp_dir().join(format!("tetfem-p2-vtu-{}", std::process::id()));
    let text = cantilever(
        [2, 1, 1],
        "five",
        &format!("[output]\ndirectory = \"{}\"\n", dir.display()),
    );
    let mut scene = parse(&text);
    scene.set_stem("p2").expect("stem");
    let summary = run_static_with(&scene, &RunOptions::default()).expect("P2 with files");
    let file = vtu::read_vtu(&dir.join("p2.vtu"));
    let types = file.values("types");
    // Type 24 = VTK_QUADRATIC_TETRA, one per tet.
    assert_eq!(types.len(), summary.tets);
    assert!(types.iter().all(|&t| t == 24.0), "{types:?}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn order_errors_name_the_key_and_line() {
    let bad = cantilever([2, 1, 1], "five", "").replace("order = 2", "order = 3");
    let error = Scene::parse(&bad, "<p2>", Path::new(".")).expect_err("order 3");
    let text = error.to_string();
    assert!(
        text.contains("mesh.order") && text.contains(":3:") && text.contains("order = 3"),
        "{text}"
    );

    // A mesh file's order is its own: order = 2 on a file of 4-node tets names what it holds.
    let file = "[mesh]\norder = 2\n[mesh.gmsh]\nfile = \"l_bracket.msh\"\n[material]\n\
                youngs_modulus = 1e5\npoisson_ratio = 0.3\ndensity = 1.0\n";
    let scenes = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes");
    let error = Scene::parse(file, "<p2>", &scenes).expect_err("order 2 on a linear file");
    let text = error.to_string();
    assert!(
        text.contains("mesh.order") && text.contains(":2:") && text.contains("4-node tets"),
        "{text}"
    );

    // A scene of order 2 is refused by the order-1 builder (e.g. another engine's).
    let scene = parse(&cantilever([2, 1, 1], "five", ""));
    let error = scene.build().expect_err("tet4 build of an order 2 scene");
    assert!(error.to_string().contains("mesh.order"), "{error}");
}
