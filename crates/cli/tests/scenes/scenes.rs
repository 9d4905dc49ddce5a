//! Scenes: every shipped scene parses and its static ones run (against analytic answers where
//! there are some); bad scenes give `Error::Scene` naming the key and the line.

use std::ops::ControlFlow;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use nalgebra::Vector3;
use tetfem::analysis::dynamics::{LinearSystem, MassKind, Rayleigh, State};
use tetfem::analysis::nonlinear::{NewtonOptions, solve_nonlinear_static};
use tetfem::mesh::io::{TetgenOptions, read_gmsh, write_tetgen};
use tetfem::model::ModelKind;
use tetfem::{BoxSplit, Constraints, Error, Loads, Material, TetMesh, solve_static};
use tetfem_cli::scene::{
    Analysis, DynamicOverrides, Method, REFERENCE, RunLength, RunOptions, Scene, run_dynamic_scene,
    run_static_with,
};

fn scene_path(name: &str) -> PathBuf {
    Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../.."))
        .join("scenes")
        .join(name)
}

fn out_dir(name: &str) -> PathBuf {
    Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join("scenes")
        .join(name)
}

fn load(name: &str) -> Scene {
    let mut scene = Scene::load(&scene_path(name)).unwrap();
    scene.set_output_directory(out_dir(name));
    scene
}

#[test]
fn every_shipped_scene_parses_and_builds() {
    let mut names: Vec<String> = std::fs::read_dir(scene_path(""))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".toml"))
        .collect();
    names.sort();
    assert!(names.len() >= 5, "{names:?}");
    for name in &names {
        let scene = load(name);
        // (constrained DOFs, |load resultant|, probes), built on the scene's element order.
        let (constrained, load, probes) = match scene.order() {
            2 => {
                let built = scene
                    .build_as::<tetfem::Tet10>()
                    .unwrap_or_else(|e| panic!("{name}: {e}"));
                let load = built.loads.resultant().norm();
                (built.constraints.count(), load, built.probes.len())
            }
            _ => {
                let built = scene.build().unwrap_or_else(|e| panic!("{name}: {e}"));
                let load = built.loads.resultant().norm();
                (built.constraints.count(), load, built.probes.len())
            }
        };
        // A body held by obstacles alone (a dropped block), or bodies thrown at each other,
        // need no support.
        let free = scene.has_obstacles() || scene.has_surface_contact();
        assert!(constrained > 0 || free, "{name}");
        // A modal scene has no loads and no probes: its answer is the modes. Bodies thrown at
        // each other move by their initial velocities, with no load.
        if !matches!(scene.analysis(), tetfem_cli::scene::Analysis::Modal(_)) {
            assert!(load > 0.0 || scene.has_surface_contact(), "{name}");
            assert!(probes > 0, "{name}");
        }
    }
}

#[test]
fn hanging_bar_matches_the_exact_elongation() {
    let summary = run_static_with(&load("hanging_bar.toml"), &RunOptions::default()).unwrap();
    // 1-D exact: ρ g L² / (2E). The clamp also stops the Poisson contraction of the top, which
    // stiffens the bar near it: the 3-D answer is 1.6 % smaller here. 3 % leaves margin while
    // still failing on a wrong load (×2), density or sign.
    let exact = 7850.0 * 9.81 / (2.0 * 200e9);
    let bottom = summary.probes[0].displacement[2];
    assert!(
        (bottom + exact).abs() < 0.03 * exact,
        "{bottom} vs {}",
        -exact
    );
    assert!(bottom > -exact, "the clamp can only stiffen the bar");
    // Every output exists and is non-empty.
    assert_eq!(summary.files.len(), 5, "{:?}", summary.files);
    for f in &summary.files {
        assert!(std::fs::metadata(f).unwrap().len() > 0, "{f:?}");
    }
    let json: serde_json::Value = serde_json::from_str(&summary.to_json()).unwrap();
    assert_eq!(json["tets"].as_u64(), Some(summary.tets as u64));
}

#[test]
fn cantilever_static_is_near_beam_theory() {
    let summary = run_static_with(
        &load("cantilever_static.toml"),
        &RunOptions {
            no_files: true,
            ..RunOptions::default()
        },
    )
    .unwrap();
    assert!(summary.files.is_empty());
    // Timoshenko tip deflection for the end load plus weight; 40×4×4 linear tets are stiffer
    // (shear locking of linear tets in bending): expect 70–100 % of it.
    let beam = tetfem_fixtures::cantilever::Cantilever::steel_default();
    let (_, timoshenko) = beam.beam_theory_tip();
    let tip = summary.probes[0].displacement[2];
    let ratio = tip / timoshenko;
    assert!(
        (0.7..=1.0).contains(&ratio),
        "tip {tip}, Timoshenko {timoshenko}"
    );
}

#[test]
fn l_bracket_and_soft_block_run() {
    let no_files = RunOptions {
        no_files: true,
        ..RunOptions::default()
    };
    let bracket = run_static_with(&load("l_bracket.toml"), &no_files).unwrap();
    // Pulled along −y at the free end: the load face moves along −y.
    assert!(bracket.probes[0].displacement[1] < 0.0);
    assert!(bracket.relative_residual < 1e-8);
    let block = run_static_with(&load("soft_block.toml"), &no_files).unwrap();
    // Weight and top pressure both push down (−z).
    assert!(block.probes[0].displacement[2] < 0.0);
}

#[test]
fn dynamic_scene_exposes_its_settings() {
    let scene = load("cantilever_dynamic.toml");
    let Analysis::Dynamic(d) = *scene.analysis() else {
        panic!("expected a dynamic analysis");
    };
    assert_eq!(d.method, Method::BackwardEuler);
    assert_eq!((d.dt, d.duration, d.steps()), (1e-4, 0.03, 300));
    assert_eq!(scene.output().every, 10);
    assert!(matches!(
        run_static_with(&scene, &RunOptions::default()),
        Err(Error::Scene { .. })
    ));
}

#[test]
fn reference_scene_parses_with_documented_defaults() {
    let scene: Scene = REFERENCE.parse().unwrap();
    assert_eq!(*scene.analysis(), Analysis::Static);
    let out = scene.output();
    assert!(out.vtu && out.csv && !out.png && out.every == 1);
    assert_eq!(out.png_size, [960, 600]);
    assert_eq!(scene.build().unwrap().probes[0].name, "tip");
    // A minimal scene takes the defaults.
    let minimal: Scene = "[mesh.box]\nmax = [1, 1, 1]\ncells = [1, 1, 1]\n[material]\nyoungs_modulus = 1.0\npoisson_ratio = 0.0\ndensity = 1.0\n"
        .parse()
        .unwrap();
    assert_eq!(minimal.output().directory, Path::new("out/scene"));
    assert!(minimal.output().vtu);
}

/// Parses `text` and expects a scene error at `line` whose key contains `key`.
fn expect_scene_error(text: &str, key: &str, line: usize) {
    let result = text.parse::<Scene>().and_then(|s| s.build().map(|_| ()));
    match result {
        Err(Error::Scene {
            key: k,
            line: l,
            message,
            ..
        }) => {
            assert!(k.contains(key), "key '{k}' lacks '{key}' ({message})");
            assert_eq!(l, line, "key {k}: {message}");
        }
        other => panic!("expected a scene error for {key}, got {other:?}"),
    }
}

const BASE: &str = "[mesh.box]\nmax = [1.0, 0.2, 0.2]\ncells = [5, 1, 1]\n\n[material]\nyoungs_modulus = 1e6\npoisson_ratio = 0.3\ndensity = 1.0\n";

#[test]
fn bad_scenes_name_key_and_line() {
    // Unknown key (a typo) in a table, at the top level, and in an array of tables.
    expect_scene_error(
        &BASE.replace("poisson_ratio", "poisson_ration"),
        "poisson_ration",
        7,
    );
    expect_scene_error(&format!("titel = \"x\"\n{BASE}"), "titel", 1);
    expect_scene_error(
        &format!("{BASE}[[constraints]]\nwhere = \"all\"\nfixx = [\"x\"]\n"),
        "fixx",
        11,
    );
    // Wrong type and a missing key.
    expect_scene_error(&BASE.replace("[5, 1, 1]", "\"five\""), "cells", 3);
    expect_scene_error(&BASE.replace("density = 1.0\n", ""), "density", 5);
    // Invalid values.
    expect_scene_error(&BASE.replace("0.3", "0.5"), "material.poisson_ratio", 5);
    expect_scene_error(
        &format!("{BASE}[analysis]\ntype = \"static\"\ndt = 0.1\n"),
        "analysis.dt",
        9,
    );
    expect_scene_error(
        &format!("{BASE}[analysis]\ntype = \"dynamic\"\ndt = -1.0\nduration = 1.0\n"),
        "analysis.dt",
        9,
    );
    expect_scene_error(
        &format!("{BASE}[analysis]\ntype = \"dynamic\"\ndt = 0.1\nduration = 0.0\n"),
        "analysis.duration",
        9,
    );
    // A selection that matches nothing, a group on a box mesh, a load with two kinds.
    expect_scene_error(
        &format!("{BASE}\n[[constraints]]\nwhere = {{ plane = {{ axis = \"x\", at = 7.0 }} }}\n"),
        "constraints[0].where",
        10,
    );
    expect_scene_error(
        &format!("{BASE}[[loads]]\nwhere = {{ group = \"top\" }}\ntraction = [0, 0, 1]\n"),
        "loads[0].where",
        9,
    );
    expect_scene_error(
        &format!("{BASE}[[loads]]\ngravity = [0, 0, -1]\nbody_force = [0, 0, 1]\n"),
        "loads[0]",
        9,
    );
    expect_scene_error(&format!("{BASE}[output]\nevery = 0\n"), "output.every", 9);
    expect_scene_error(
        &format!("{BASE}[[constraints]]\nwhere = {{ nodes = [0, 99] }}\n"),
        "constraints[0].where",
        9,
    );
}

#[test]
fn unknown_group_lists_the_known_ones() {
    let text = "[mesh.gmsh]\nfile = \"l_bracket.msh\"\n[material]\nyoungs_modulus = 1e9\npoisson_ratio = 0.3\ndensity = 1.0\n[[constraints]]\nwhere = { group = \"clmap\" }\n";
    let err = Scene::parse(text, "inline", &scene_path(""))
        .unwrap()
        .build()
        .unwrap_err();
    let message = err.to_string();
    assert!(
        message.contains("clmap") && message.contains("\"clamp\""),
        "{message}"
    );
}

#[test]
fn tetgen_scene_selects_by_marker() {
    let mesh = TetMesh::box_grid(
        Vector3::zeros(),
        Vector3::new(1.0, 0.2, 0.2),
        [6, 2, 2],
        BoxSplit::Lecture6,
    )
    .unwrap();
    let markers: Vec<i64> = mesh
        .nodes()
        .iter()
        .map(|p| {
            if p.x == 0.0 {
                1
            } else if p.x == 1.0 {
                2
            } else {
                0
            }
        })
        .collect();
    let dir = out_dir("tetgen_scene");
    std::fs::create_dir_all(&dir).unwrap();
    write_tetgen(
        &dir.join("bar"),
        &mesh,
        &TetgenOptions {
            base: 1,
            node_markers: Some(markers),
            tet_attributes: None,
        },
    )
    .unwrap();
    let text = "[mesh.tetgen]\nfile = \"bar.node\"\n[material]\nyoungs_modulus = 1e6\npoisson_ratio = 0.0\ndensity = 1.0\n[[constraints]]\nwhere = { marker = 1 }\nfix = [\"x\"]\n[[constraints]]\nwhere = { nodes = [0] }\n[[constraints]]\nwhere = { nodes = [6] }\nfix = [\"y\", \"z\"]\n[[constraints]]\nwhere = { nodes = [21] }\nfix = [\"y\"]\n[[loads]]\nwhere = { marker = 2 }\ntraction = [1000.0, 0, 0]\n[[probes]]\nname = \"end\"\nwhere = { marker = 2 }\n";
    let mut scene = Scene::parse(text, "inline", &dir).unwrap();
    scene.set_output_directory(dir.join("out"));
    let summary = tetfem_cli::run_static(&scene).unwrap();
    // A free bar (ν = 0, roller-supported) in uniform tension: u = σL/E exactly, as linear
    // tets represent the linear displacement field exactly (round-off only).
    let end = summary.probes[0].displacement[0];
    assert!((end - 1000.0 / 1e6).abs() < 1e-9, "{end}");
}

// ---------------------------------------------------------------------------------------------
// Each shipped scene against the same problem built through the library.

/// Relative agreement of a scene run with its library build. The scene is a front end to the
/// same functions, but it selects nodes and faces through the checked selections, whose order
/// (and so the order in which nodal loads are summed) may differ from the library's: f then
/// differs by round-off, ~1e-16 relative, which the solve amplifies by up to κ(K_ff) ≈ 1e7–1e8
/// on these slender beams (measured: 1.7e-9 on `cantilever_static`). 1e-8 allows that, while
/// any real difference in mesh, split, selection, load or solver shows up at 1e-3 or more
/// (a swapped split: 1.8e-1).
const SAME_PROBLEM_TOL: f64 = 1e-8;

/// The library's split for the scene's `split` key, by name (so that a split added to both
/// enums needs one line here).
fn library_split(scene: &Scene) -> BoxSplit {
    let tetfem_cli::scene::MeshSpec::Box(b) = scene.spec().mesh.get_ref() else {
        panic!("{}: not a box mesh", scene.source_name());
    };
    let name = format!("{:?}", b.split);
    [BoxSplit::Mirrored6, BoxSplit::Lecture6, BoxSplit::Five]
        .into_iter()
        .find(|s| format!("{s:?}") == name)
        .unwrap_or_else(|| panic!("split {name}: add the library split to library_split"))
}

/// The scene's box mesh built with [`TetMesh::box_grid`] from (min, max, cells) and its split.
fn library_box(scene: &Scene, max: [f64; 3], cells: [usize; 3]) -> TetMesh {
    let split = library_split(scene);
    TetMesh::box_grid(Vector3::zeros(), Vector3::from(max), cells, split).unwrap()
}

/// Nodes on the plane x[axis] = at (box grids put them there exactly).
fn on_plane(mesh: &TetMesh, axis: usize, at: f64) -> Vec<usize> {
    mesh.nodes_on_plane(axis, at, 1e-9)
}

/// Mean displacement of `nodes`.
fn mean_of(u: &[f64], nodes: &[usize]) -> Vector3<f64> {
    nodes
        .iter()
        .map(|&n| Vector3::new(u[3 * n], u[3 * n + 1], u[3 * n + 2]))
        .sum::<Vector3<f64>>()
        / nodes.len() as f64
}

fn max_norm(u: &[f64]) -> f64 {
    u.chunks(3)
        .map(|c| Vector3::new(c[0], c[1], c[2]).norm())
        .fold(0.0, f64::max)
}

/// A static scene's probe and max |u| against the library's displacement `u` and probe nodes.
fn assert_same_static(name: &str, u: &[f64], probe: &[usize], options: &RunOptions) {
    let summary = run_static_with(&load(name), options).unwrap();
    let expected = mean_of(u, probe);
    let scale = max_norm(u);
    let got = Vector3::from(summary.probes[0].displacement);
    let probe_error = (got - expected).norm() / scale;
    let max_error = (summary.max_displacement - scale).abs() / scale;
    println!(
        "{name}: probe {probe_error:.1e}, max |u| {max_error:.1e} (relative to max |u| {scale:.4e})"
    );
    assert!(
        probe_error <= SAME_PROBLEM_TOL,
        "{name}: {got} vs {expected}"
    );
    assert!(
        max_error <= SAME_PROBLEM_TOL,
        "{name}: max |u| {}",
        summary.max_displacement
    );
}

fn steel() -> Material {
    Material::new(200e9, 0.3, 7850.0).unwrap()
}

fn clamp_plane(mesh: &TetMesh, axis: usize, at: f64) -> Constraints {
    let mut constraints = Constraints::new(mesh);
    constraints.fix_nodes(&on_plane(mesh, axis, at)).unwrap();
    constraints
}

/// A total force spread over the boundary faces on the plane x[axis] = at.
fn total_force_on_plane(loads: &mut Loads, mesh: &TetMesh, axis: usize, at: f64, f: Vector3<f64>) {
    let faces = mesh.faces_on_plane(&mesh.boundary_faces().unwrap(), axis, at, 1e-9);
    loads.add_total_force_on_faces(mesh, &faces, f).unwrap();
}

#[test]
fn static_scenes_match_their_library_build() {
    let no_files = RunOptions {
        no_files: true,
        ..RunOptions::default()
    };
    let gravity = Vector3::new(0.0, 0.0, -9.81);

    // cantilever_static: clamped at x = 0, 10 kN down on the end face and its weight.
    let scene = load("cantilever_static.toml");
    let mesh = library_box(&scene, [1.0, 0.1, 0.1], [40, 4, 4]);
    let mut loads = Loads::new(&mesh);
    total_force_on_plane(&mut loads, &mesh, 0, 1.0, Vector3::new(0.0, 0.0, -10e3));
    loads.add_gravity(&mesh, &steel(), gravity).unwrap();
    let u = solve_static(&mesh, &steel(), &clamp_plane(&mesh, 0, 0.0), &loads)
        .unwrap()
        .displacement;
    assert_same_static(
        "cantilever_static.toml",
        &u,
        &on_plane(&mesh, 0, 1.0),
        &no_files,
    );

    // hanging_bar: hung from z = 1 under its weight.
    let scene = load("hanging_bar.toml");
    let mesh = library_box(&scene, [0.1, 0.1, 1.0], [2, 2, 20]);
    let mut loads = Loads::new(&mesh);
    loads.add_gravity(&mesh, &steel(), gravity).unwrap();
    let u = solve_static(&mesh, &steel(), &clamp_plane(&mesh, 2, 1.0), &loads)
        .unwrap()
        .displacement;
    assert_same_static("hanging_bar.toml", &u, &on_plane(&mesh, 2, 0.0), &no_files);

    // soft_block: clamped at x = 0, its weight and 5 kPa on the top face (along −n).
    let scene = load("soft_block.toml");
    let rubber = Material::new(1e6, 0.45, 1100.0).unwrap();
    let mesh = library_box(&scene, [0.1, 0.1, 0.1], [8, 8, 8]);
    let mut loads = Loads::new(&mesh);
    loads.add_gravity(&mesh, &rubber, gravity).unwrap();
    for face in mesh.faces_on_plane(&mesh.boundary_faces().unwrap(), 2, 0.1, 1e-9) {
        let normal = face.area_vector(&mesh).unwrap().normalize();
        loads
            .add_traction(&mesh, std::slice::from_ref(&face), -normal * 5e3)
            .unwrap();
    }
    let u = solve_static(&mesh, &rubber, &clamp_plane(&mesh, 0, 0.0), &loads)
        .unwrap()
        .displacement;
    assert_same_static("soft_block.toml", &u, &on_plane(&mesh, 0, 0.1), &no_files);

    // l_bracket: the Gmsh mesh, clamped on group "clamp", 2 kN along −y on group "load".
    let imported = read_gmsh(&scene_path("l_bracket.msh")).unwrap();
    let mesh = &imported.mesh;
    let mut constraints = Constraints::new(mesh);
    let clamp = imported.group("clamp").unwrap();
    constraints.fix_nodes(&clamp.nodes).unwrap();
    let load_group = imported.group("load").unwrap();
    let faces = load_group.boundary_faces(&mesh.boundary_faces().unwrap());
    let mut loads = Loads::new(mesh);
    loads
        .add_total_force_on_faces(mesh, &faces, Vector3::new(0.0, -2000.0, 0.0))
        .unwrap();
    let u = solve_static(mesh, &steel(), &constraints, &loads)
        .unwrap()
        .displacement;
    assert_same_static("l_bracket.toml", &u, &load_group.nodes, &no_files);

    // rubber_cantilever_large: corotational Newton with default options, 30 N down at the end.
    let scene = load("rubber_cantilever_large.toml");
    let rubber = Material::new(5e6, 0.45, 1100.0).unwrap();
    let mesh = library_box(&scene, [0.5, 0.05, 0.05], [20, 2, 2]);
    let mut loads = Loads::new(&mesh);
    total_force_on_plane(&mut loads, &mesh, 0, 0.5, Vector3::new(0.0, 0.0, -30.0));
    let model = ModelKind::Corotational.build(&rubber);
    let u = solve_nonlinear_static(
        &mesh,
        model.as_ref(),
        &clamp_plane(&mesh, 0, 0.0),
        &loads,
        NewtonOptions::default(),
    )
    .unwrap()
    .displacement;
    assert_same_static(
        "rubber_cantilever_large.toml",
        &u,
        &on_plane(&mesh, 0, 0.5),
        &no_files,
    );
}

#[test]
fn dynamic_scene_matches_the_library_integrator() {
    let scene = load("cantilever_dynamic.toml");
    let Analysis::Dynamic(settings) = *scene.analysis() else {
        panic!("expected a dynamic analysis");
    };
    const STEPS: usize = 5;
    let overrides = DynamicOverrides {
        length: Some(RunLength::Steps(STEPS)),
        ..DynamicOverrides::default()
    };
    let summary = run_dynamic_scene(&scene, &overrides, false, false, &mut |_, _| {
        ControlFlow::Continue(())
    })
    .unwrap();
    assert_eq!(summary.steps, STEPS);

    // The library: the same beam, backward Euler at the scene's dt, lumped mass, no damping.
    assert_eq!(settings.method, Method::BackwardEuler);
    assert_eq!(settings.mass, tetfem_cli::scene::MassKind::Lumped);
    assert_eq!(
        (settings.damping.mass, settings.damping.stiffness),
        (0.0, 0.0)
    );
    assert_eq!(settings.initial_velocity, [0.0; 3]);
    let mesh = library_box(&scene, [1.0, 0.1, 0.1], [20, 2, 2]);
    let mut loads = Loads::new(&mesh);
    total_force_on_plane(&mut loads, &mesh, 0, 1.0, Vector3::new(0.0, 0.0, -10e3));
    let system = Arc::new(
        LinearSystem::new(
            &mesh,
            &steel(),
            &clamp_plane(&mesh, 0, 0.0),
            &loads,
            Vector3::zeros(),
            MassKind::Lumped,
            Rayleigh::default(),
        )
        .unwrap(),
    );
    let mut integrator = tetfem::analysis::dynamics::Method::BackwardEuler
        .integrator(Arc::clone(&system), settings.dt)
        .unwrap();
    let mut state = State::at_rest(system.free_count());
    for _ in 0..STEPS {
        integrator.step(&mut state).unwrap();
    }
    let u = system.dofs().expand(&state.displacement).unwrap();
    let expected = mean_of(&u, &on_plane(&mesh, 0, 1.0));
    let got = Vector3::from(summary.probes[0].last);
    let error = (got - expected).norm() / max_norm(&u);
    let energy = system.energy(&state).unwrap().total();
    let energy_error = (summary.final_energy.total - energy).abs() / energy.abs();
    println!("cantilever_dynamic after {STEPS} steps: tip {error:.1e}, energy {energy_error:.1e}");
    assert!(error <= SAME_PROBLEM_TOL, "tip {got} vs {expected}");
    assert!(
        energy_error <= SAME_PROBLEM_TOL,
        "energy {} vs {energy}",
        summary.final_energy.total
    );
    assert!((summary.end_time - STEPS as f64 * settings.dt).abs() <= 1e-15);
}
