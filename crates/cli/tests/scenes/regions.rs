//! Materials per region: a two-material bar against series springs, a bimaterial cantilever
//! against an independent dense assembly, the uniform map bit-identical to one material, the
//! errors for unclaimed and doubly claimed tets, and `[[materials]]` in scenes.

use std::path::{Path, PathBuf};

use nalgebra::{DMatrix, DVector, Vector3};
use tetfem::analysis::dynamics::{LinearSystem, MassKind, Rayleigh};
use tetfem::analysis::nonlinear::{NewtonOptions, solve_nonlinear_static};
use tetfem::fe::assembly::{Assembler, lumped_mass, lumped_mass_of};
use tetfem::mesh::io::{TetgenOptions, read_gmsh, read_tetgen, write_tetgen};
use tetfem::model::assemble::{internal_force, refill_tangent};
use tetfem::model::{Corotational, ModelKind};
use tetfem::post::output::fields::{cell_strain_energy_density, cell_von_mises};
use tetfem::{
    BoxSplit, Constraints, Error, Loads, Material, MaterialAssignment, MaterialMap, StaticSolver,
    TetMesh, solve_static,
};
use tetfem_cli::scene::{RunOptions, Scene, run_static_with};

const L: f64 = 1.0;
const W: f64 = 0.1;

fn bar(cells: [usize; 3], split: BoxSplit) -> TetMesh {
    TetMesh::box_grid(Vector3::zeros(), Vector3::new(L, W, W), cells, split).unwrap()
}

/// E1 on x ≤ L/2, E2 on x ≥ L/2 by centroid (the interface x = L/2 is a mesh plane).
fn halves(mesh: &TetMesh, left: Material, right: Material) -> MaterialMap {
    let mut a = MaterialAssignment::new(mesh.tet_count());
    a.assign_box(
        mesh,
        "left",
        left,
        Vector3::new(-1.0, -1.0, -1.0),
        Vector3::new(L / 2.0, 1.0, 1.0),
    )
    .unwrap();
    a.assign_box(
        mesh,
        "right",
        right,
        Vector3::new(L / 2.0, -1.0, -1.0),
        Vector3::new(2.0, 1.0, 1.0),
    )
    .unwrap();
    a.finish(None).unwrap()
}

fn clamped(mesh: &TetMesh) -> Constraints {
    let mut c = Constraints::new(mesh);
    c.fix_nodes(&mesh.nodes_on_plane(0, 0.0, 1e-9)).unwrap();
    c
}

fn end_force(mesh: &TetMesh, force: Vector3<f64>) -> Loads {
    let faces = mesh.faces_on_plane(&mesh.boundary_faces().unwrap(), 0, L, 1e-9);
    let mut loads = Loads::new(mesh);
    loads.add_total_force_on_faces(mesh, &faces, force).unwrap();
    loads
}

#[test]
fn two_material_bar_is_two_springs_in_series() {
    let (e1, e2) = (1e9, 4e9);
    let mesh = bar([10, 2, 2], BoxSplit::Mirrored6);
    let map = halves(
        &mesh,
        Material::new(e1, 0.0, 1000.0).unwrap(),
        Material::new(e2, 0.0, 3000.0).unwrap(),
    );
    assert_eq!(map.counts(), vec![10 * 2 * 2 * 3, 10 * 2 * 2 * 3]);
    let force = 1e4;
    let solution = solve_static(
        &mesh,
        &map,
        &clamped(&mesh),
        &end_force(&mesh, Vector3::new(force, 0.0, 0.0)),
    )
    .unwrap();
    let area = W * W;
    let exact = force * (L / 2.0 / (e1 * area) + L / 2.0 / (e2 * area));
    // With ν = 0 the uniaxial field u_x = σx/E (piecewise linear, kink on the mesh plane
    // x = L/2), u_y = u_z = 0 satisfies the clamp exactly and is represented exactly by linear
    // tets, so only round-off remains: κ(K_ff)·ε ≈ 1e4·1e-16 on this 10×2×2 bar; 1e-10
    // relative leaves room for that while a wrong E in one tet moves the end by > 1e-3.
    for n in mesh.nodes_on_plane(0, L, 1e-9) {
        let u = solution.displacement[3 * n];
        assert!(
            ((u - exact) / exact).abs() < 1e-10,
            "node {n}: {u} vs {exact}"
        );
    }
    // And the interface moves by the left spring's stretch alone.
    let left = force * (L / 2.0) / (e1 * area);
    for n in mesh.nodes_on_plane(0, L / 2.0, 1e-9) {
        let u = solution.displacement[3 * n];
        assert!(((u - left) / left).abs() < 1e-10, "node {n}: {u} vs {left}");
    }
}

/// Dense K with every tet's own material, from the element routine alone.
fn dense_stiffness(mesh: &TetMesh, material_of: impl Fn(usize) -> Material) -> DMatrix<f64> {
    let n = mesh.dof_count();
    let mut k = DMatrix::zeros(n, n);
    for (t, tet) in mesh.tets().iter().enumerate() {
        let ke = mesh.element(t).unwrap().stiffness(&material_of(t));
        for i in 0..4 {
            for j in 0..4 {
                for a in 0..3 {
                    for b in 0..3 {
                        k[(3 * tet[i] + a, 3 * tet[j] + b)] += ke[(3 * i + a, 3 * j + b)];
                    }
                }
            }
        }
    }
    k
}

#[test]
fn bimaterial_cantilever_equals_an_independent_dense_assembly() {
    let mesh = bar([8, 2, 2], BoxSplit::Lecture6);
    let (steel, rubberish) = (
        Material::new(200e9, 0.3, 7850.0).unwrap(),
        Material::new(2e9, 0.45, 1200.0).unwrap(),
    );
    let map = halves(&mesh, steel, rubberish);
    let region_k = Assembler::new(&mesh).stiffness(&mesh, &map).unwrap();
    let dense = dense_stiffness(&mesh, |t| map.materials()[map.of_tet()[t] as usize]);
    // Entry by entry: the sparse K holds every non-zero of the dense one (each a sum of at
    // most 24 element entries, so round-off ~1e-15 of the largest).
    let scale = dense.amax();
    for r in 0..mesh.dof_count() {
        for c in 0..mesh.dof_count() {
            let sparse = region_k.get(r, c).unwrap_or(0.0);
            assert!(
                (sparse - dense[(r, c)]).abs() <= 1e-12 * scale,
                "K[{r},{c}] = {sparse} vs dense {}",
                dense[(r, c)]
            );
        }
    }
    // The cantilever: clamp x = 0, a downward end load; solve the dense system with its own
    // Cholesky and compare displacements.
    let constraints = clamped(&mesh);
    let loads = end_force(&mesh, Vector3::new(0.0, 0.0, -1e3));
    let solution = solve_static(&mesh, &map, &constraints, &loads).unwrap();
    let free: Vec<usize> = (0..mesh.dof_count())
        .filter(|&d| constraints.get(d).is_none())
        .collect();
    let k_ff = DMatrix::from_fn(free.len(), free.len(), |i, j| dense[(free[i], free[j])]);
    let f_f = DVector::from_iterator(free.len(), free.iter().map(|&d| loads.as_slice()[d]));
    let u_ref = k_ff.cholesky().expect("K_ff is SPD").solve(&f_f);
    let u_max = u_ref.amax();
    let worst = free
        .iter()
        .enumerate()
        .map(|(i, &d)| (solution.displacement[d] - u_ref[i]).abs())
        .fold(0.0, f64::max);
    // Two backward-stable Cholesky solves of one SPD matrix (κ ≈ 1e6 here: slender beam, E
    // ratio 100) agree to ~κ·ε ≈ 1e-10 of |u|; 1e-9 is the brief's bound.
    assert!(worst <= 1e-9 * u_max, "worst {worst:e} of {u_max:e}");
    // The bimaterial answer is not the all-steel one (the reference would catch a map ignored).
    let steel_only = solve_static(&mesh, &steel, &constraints, &loads).unwrap();
    let tip = mesh.nodes_on_plane(0, L, 1e-9)[0];
    assert!(
        solution.displacement[3 * tip + 2].abs() > 2.0 * steel_only.displacement[3 * tip + 2].abs()
    );
}

#[test]
fn uniform_map_is_bit_identical_to_one_material() {
    let mesh = bar([6, 2, 2], BoxSplit::Mirrored6);
    let material = Material::new(70e9, 0.33, 2700.0).unwrap();
    let map = MaterialMap::uniform(material, mesh.tet_count());
    let constraints = clamped(&mesh);
    let mut loads = end_force(&mesh, Vector3::new(0.0, 1e3, -2e3));
    loads
        .add_gravity(&mesh, &material, Vector3::new(0.0, 0.0, -9.81))
        .unwrap();
    let mut map_loads = end_force(&mesh, Vector3::new(0.0, 1e3, -2e3));
    map_loads
        .add_gravity(&mesh, &map, Vector3::new(0.0, 0.0, -9.81))
        .unwrap();
    assert_eq!(loads.as_slice(), map_loads.as_slice());

    let assembler = Assembler::new(&mesh);
    let k1 = assembler.stiffness(&mesh, &material).unwrap();
    let k2 = assembler.stiffness(&mesh, &map).unwrap();
    assert_eq!(k1.values(), k2.values());
    let m1 = assembler.consistent_mass(&mesh, &material).unwrap();
    let m2 = assembler.consistent_mass(&mesh, &map).unwrap();
    assert_eq!(m1.values(), m2.values());
    assert_eq!(
        lumped_mass(&mesh, &material),
        lumped_mass_of(&mesh, &map).unwrap()
    );

    let u1 = solve_static(&mesh, &material, &constraints, &loads).unwrap();
    let u2 = solve_static(&mesh, &map, &constraints, &loads).unwrap();
    assert_eq!(u1.displacement, u2.displacement);
    assert_eq!(u1.reactions, u2.reactions);
    assert_eq!(
        cell_von_mises(&mesh, &material, &u1.displacement).unwrap(),
        cell_von_mises(&mesh, &map, &u1.displacement).unwrap()
    );
    assert_eq!(
        cell_strain_energy_density(&mesh, &material, &u1.displacement).unwrap(),
        cell_strain_energy_density(&mesh, &map, &u1.displacement).unwrap()
    );
    assert_eq!(
        tetfem::analysis::dynamics::element_step_bound(&mesh, &material),
        tetfem::analysis::dynamics::element_step_bound_of(&mesh, &map).unwrap()
    );

    let system = |m: &dyn Fn() -> LinearSystem| m();
    let s1 = system(&|| {
        LinearSystem::new(
            &mesh,
            &material,
            &constraints,
            &loads,
            Vector3::new(0.0, 0.0, -9.81),
            MassKind::Consistent,
            Rayleigh::default(),
        )
        .unwrap()
    });
    let s2 = system(&|| {
        LinearSystem::new(
            &mesh,
            &map,
            &constraints,
            &loads,
            Vector3::new(0.0, 0.0, -9.81),
            MassKind::Consistent,
            Rayleigh::default(),
        )
        .unwrap()
    });
    assert_eq!(s1.stiffness().values(), s2.stiffness().values());
    assert_eq!(s1.external_load(), s2.external_load());

    // Nonlinear: one corotational model vs one per material of the uniform map.
    let single = Corotational::new(&material);
    let models = ModelKind::Corotational.build_map(&map);
    let u = &u1.displacement;
    assert_eq!(
        internal_force(&mesh, &single, u).unwrap(),
        internal_force(&mesh, &models, u).unwrap()
    );
    let mut t1 = tetfem::CscMatrix::zeros(std::sync::Arc::clone(assembler.pattern())).unwrap();
    let mut t2 = t1.clone();
    refill_tangent(&mesh, &assembler, &single, u, false, &mut t1).unwrap();
    refill_tangent(&mesh, &assembler, &models, u, false, &mut t2).unwrap();
    assert_eq!(t1.values(), t2.values());
    let options = NewtonOptions {
        load_steps: 2,
        ..NewtonOptions::default()
    };
    let n1 = solve_nonlinear_static(&mesh, &single, &constraints, &loads, options).unwrap();
    let n2 = solve_nonlinear_static(&mesh, &models, &constraints, &loads, options).unwrap();
    assert_eq!(n1.displacement, n2.displacement);
}

#[test]
fn nonlinear_statics_takes_each_tets_model() {
    // A small-load corotational solve of the two-material bar: the series-spring stretch to
    // the geometric nonlinearity of a strain of 1e-6 (relative effect ~1e-6).
    let (e1, e2) = (1e9, 4e9);
    let mesh = bar([10, 2, 2], BoxSplit::Mirrored6);
    let map = halves(
        &mesh,
        Material::new(e1, 0.0, 1000.0).unwrap(),
        Material::new(e2, 0.0, 1000.0).unwrap(),
    );
    let force = 1e1;
    let loads = end_force(&mesh, Vector3::new(force, 0.0, 0.0));
    let report = solve_nonlinear_static(
        &mesh,
        &ModelKind::Corotational.build_map(&map),
        &clamped(&mesh),
        &loads,
        NewtonOptions::default(),
    )
    .unwrap();
    let area = W * W;
    let exact = force * (L / 2.0 / (e1 * area) + L / 2.0 / (e2 * area));
    let n = mesh.nodes_on_plane(0, L, 1e-9)[0];
    let u = report.displacement[3 * n];
    // Strain ≤ 1e-7: the corotational answer differs from the linear one by O(strain).
    assert!(((u - exact) / exact).abs() < 1e-5, "{u} vs {exact}");
}

#[test]
fn unclaimed_and_doubly_claimed_tets_are_errors_naming_them() {
    let mesh = bar([4, 1, 1], BoxSplit::Lecture6);
    let m = Material::steel();
    let mut a = MaterialAssignment::new(mesh.tet_count());
    // Cell 0 only (tets 0..6, centroids x < 0.25).
    a.assign_box(
        &mesh,
        "first cell",
        m,
        Vector3::new(0.0, 0.0, 0.0),
        Vector3::new(0.25, 1.0, 1.0),
    )
    .unwrap();
    let err = a.clone().finish(None).unwrap_err().to_string();
    assert!(
        err.contains("tet 6") && err.contains("17 other tets"),
        "{err}"
    );
    // With a default the rest is covered.
    let map = a
        .clone()
        .finish(Some(Material::new(1e9, 0.2, 1.0).unwrap()))
        .unwrap();
    assert_eq!(map.counts(), vec![6, 18]);
    // A second selection overlapping the first names the tet and both.
    let err = a.assign("cell list", m, [7, 3]).unwrap_err().to_string();
    assert!(
        err.contains("tet 3") && err.contains("first cell") && err.contains("cell list"),
        "{err}"
    );
    // ...and keeps nothing of the failed selection: tet 7 is still unclaimed.
    let err = a.finish(None).unwrap_err().to_string();
    assert!(err.contains("tet 6"), "{err}");
    // A map made for another mesh is refused where it is used.
    let other = MaterialMap::uniform(m, 5);
    let err = solve_static(&mesh, &other, &clamped(&mesh), &Loads::new(&mesh)).unwrap_err();
    assert!(matches!(err, Error::InvalidParameter { .. }), "{err}");
    assert!(StaticSolver::new(&mesh, &other, &clamped(&mesh)).is_err());
}

#[test]
fn tetgen_region_attributes_and_gmsh_volumes_select_materials() {
    let mesh = bar([4, 1, 1], BoxSplit::Lecture6);
    let attributes: Vec<f64> = (0..mesh.tet_count())
        .map(|t| if t < 12 { 1.0 } else { 2.0 })
        .collect();
    let dir = out_dir("tetgen_regions");
    std::fs::create_dir_all(&dir).unwrap();
    write_tetgen(
        &dir.join("bar"),
        &mesh,
        &TetgenOptions {
            base: 0,
            node_markers: None,
            tet_attributes: Some(attributes),
        },
    )
    .unwrap();
    let imported = read_tetgen(&dir.join("bar")).unwrap();
    let (a, b) = (
        Material::new(1e9, 0.3, 1.0).unwrap(),
        Material::new(2e9, 0.3, 1.0).unwrap(),
    );
    let map = MaterialMap::from_tetgen_regions(&imported, &[(1.0, a), (2.0, b)], None).unwrap();
    assert_eq!(map.counts(), vec![12, 12]);
    assert!(map.of_tet()[..12].iter().all(|&i| i == 0));
    let err = MaterialMap::from_tetgen_regions(&imported, &[(1.0, a)], None).unwrap_err();
    assert!(err.to_string().contains("tet 12"), "{err}");

    let imported = read_gmsh(&scene_path("l_bracket.msh")).unwrap();
    let map = MaterialMap::from_gmsh_volumes(&imported, &[("steel", a)], None).unwrap();
    assert_eq!(map.counts(), vec![imported.mesh.tet_count()]);
    let err = MaterialMap::from_gmsh_volumes(&imported, &[("clamp", a)], None).unwrap_err();
    assert!(
        err.to_string().contains("steel"),
        "lists the known volumes: {err}"
    );
}

fn scene_path(name: &str) -> PathBuf {
    Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../.."))
        .join("scenes")
        .join(name)
}

fn out_dir(name: &str) -> PathBuf {
    Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join("regions")
        .join(name)
}

const BAR_SCENE: &str = r#"
[mesh.box]
max = [1.0, 0.1, 0.1]
cells = [10, 2, 2]

[[materials]]
youngs_modulus = 1e9
poisson_ratio = 0.0
density = 1000.0
where = { box = { min = [-1, -1, -1], max = [0.5, 1, 1] } }

[[materials]]
youngs_modulus = 4e9
poisson_ratio = 0.0
density = 1000.0
where = { box = { min = [0.5, -1, -1], max = [2, 1, 1] } }

[[constraints]]
where = { plane = { axis = "x", at = 0.0 } }

[[loads]]
where = { plane = { axis = "x", at = 1.0 } }
total_force = [1e4, 0.0, 0.0]

[[probes]]
name = "end"
where = { plane = { axis = "x", at = 1.0 } }
"#;

fn no_files() -> RunOptions {
    RunOptions {
        no_files: true,
        ..RunOptions::default()
    }
}

#[test]
fn scene_with_two_materials_runs_the_series_bar() {
    let scene = Scene::parse(BAR_SCENE, "bar", Path::new(".")).unwrap();
    let built = scene.build().unwrap();
    let library = halves(
        &built.mesh,
        Material::new(1e9, 0.0, 1000.0).unwrap(),
        Material::new(4e9, 0.0, 1000.0).unwrap(),
    );
    assert_eq!(built.materials.of_tet(), library.of_tet());
    assert_eq!(built.materials.materials(), library.materials());
    let summary = run_static_with(&scene, &no_files()).unwrap();
    let exact = 1e4 * (0.5 / (1e9 * 0.01) + 0.5 / (4e9 * 0.01));
    let end = summary.probes[0].displacement[0];
    // Exact up to round-off (see two_material_bar_is_two_springs_in_series).
    assert!(((end - exact) / exact).abs() < 1e-10, "{end} vs {exact}");
}

fn expect_scene_error(text: &str, key: &str, line: usize, words: &[&str]) {
    let scene = Scene::parse(text, "inline", Path::new(".")).unwrap();
    match scene.build() {
        Err(Error::Scene {
            key: k,
            line: l,
            message,
            ..
        }) => {
            assert_eq!((k.as_str(), l), (key, line), "{message}");
            for w in words {
                assert!(message.contains(w), "'{w}' not in: {message}");
            }
        }
        other => panic!("expected a scene error at {key}, got {other:?}"),
    }
}

#[test]
fn scene_region_errors_name_the_key_the_line_and_the_tet() {
    // The right box also claims the left half: tet 0 is claimed twice.
    let overlap = BAR_SCENE.replace("min = [0.5, -1, -1]", "min = [-1, -1, -1]");
    let line = overlap
        .lines()
        .position(|l| l.contains("youngs_modulus = 4e9"))
        .unwrap();
    // The entry's span starts at its `[[materials]]` header, the line above its first key.
    expect_scene_error(
        &overlap,
        "materials[1]",
        line,
        &["tet 0", "materials[0]", "materials[1]"],
    );
    // Only the left half has a material and there is no [material].
    let gap = BAR_SCENE.replace("min = [0.5, -1, -1]", "min = [0.9, -1, -1]");
    let scene = Scene::parse(&gap, "inline", Path::new(".")).unwrap();
    let err = scene.build().unwrap_err().to_string();
    assert!(err.contains("no material") && err.contains("tet "), "{err}");
    // A [material] default covers the gap.
    let with_default =
        format!("{gap}\n[material]\nyoungs_modulus = 2e9\npoisson_ratio = 0.0\ndensity = 1000.0\n");
    let built = Scene::parse(&with_default, "inline", Path::new("."))
        .unwrap()
        .build()
        .unwrap();
    assert_eq!(built.materials.materials().len(), 3);
    // A box holding no centroid.
    let empty = BAR_SCENE.replace(
        "min = [0.5, -1, -1], max = [2, 1, 1]",
        "min = [5, 5, 5], max = [6, 6, 6]",
    );
    let scene = Scene::parse(&empty, "inline", Path::new(".")).unwrap();
    let err = scene.build().unwrap_err().to_string();
    assert!(
        err.contains("materials[1].where") && err.contains("no tet"),
        "{err}"
    );
    // A group on a box mesh, and an invalid value.
    let group = BAR_SCENE.replace(
        "where = { box = { min = [0.5, -1, -1], max = [2, 1, 1] } }",
        "where = { group = \"steel\" }",
    );
    let err = Scene::parse(&group, "inline", Path::new("."))
        .unwrap()
        .build()
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("materials[1].where") && err.contains("Gmsh"),
        "{err}"
    );
    let bad = BAR_SCENE.replace("youngs_modulus = 4e9", "youngs_modulus = -4e9");
    let err = Scene::parse(&bad, "inline", Path::new("."))
        .unwrap()
        .build()
        .unwrap_err()
        .to_string();
    assert!(err.contains("materials[1].youngs_modulus"), "{err}");
    // Neither [material] nor [[materials]].
    let none = "[mesh.box]\nmax = [1.0, 0.1, 0.1]\ncells = [2, 1, 1]\n";
    let err = Scene::parse(none, "inline", Path::new("."))
        .unwrap()
        .build()
        .unwrap_err()
        .to_string();
    assert!(err.contains("no material"), "{err}");
}

#[test]
fn l_bracket_scene_with_two_materials_matches_the_library() {
    let text = std::fs::read_to_string(scene_path("l_bracket.toml")).unwrap();
    // The bracket's horizontal leg (x > 0.05) in aluminium, the rest ([material]) steel.
    let text = text.replace(
        "[[constraints]]",
        "[[materials]]\nyoungs_modulus = 70e9\npoisson_ratio = 0.33\ndensity = 2700.0\nwhere = { box = { min = [0.05, -1, -1], max = [1, 1, 1] } }\n\n[[constraints]]",
    );
    let scene = Scene::parse(&text, "l_bracket", &scene_path("")).unwrap();
    let built = scene.build().unwrap();
    let counts = built.materials.counts();
    assert_eq!(counts.len(), 2);
    assert!(counts.iter().all(|&c| c > 0), "{counts:?}");
    // The same map through the library, and the same solve.
    let imported = read_gmsh(&scene_path("l_bracket.msh")).unwrap();
    let mut a = MaterialAssignment::new(imported.mesh.tet_count());
    a.assign_box(
        &imported.mesh,
        "aluminium",
        Material::new(70e9, 0.33, 2700.0).unwrap(),
        Vector3::new(0.05, -1.0, -1.0),
        Vector3::new(1.0, 1.0, 1.0),
    )
    .unwrap();
    let library = a.finish(Some(Material::steel())).unwrap();
    assert_eq!(built.materials.of_tet(), library.of_tet());
    let u_library = solve_static(&built.mesh, &library, &built.constraints, &built.loads)
        .unwrap()
        .displacement;
    let u_scene = StaticSolver::new(&built.mesh, &built.materials, &built.constraints)
        .unwrap()
        .solve(&built.loads)
        .unwrap()
        .displacement;
    assert_eq!(u_library, u_scene);
    // Softer material somewhere lowers K (in the Loewner order), so the compliance fᵀK⁻¹f under
    // the same load rises strictly; the scene run reports the bimaterial answer.
    let u_steel = solve_static(
        &built.mesh,
        &Material::steel(),
        &built.constraints,
        &built.loads,
    )
    .unwrap()
    .displacement;
    let compliance = |u: &[f64]| -> f64 {
        built
            .loads
            .as_slice()
            .iter()
            .zip(u)
            .map(|(f, u)| f * u)
            .sum()
    };
    let ratio = compliance(&u_scene) / compliance(&u_steel);
    println!("compliance ratio aluminium leg / all steel: {ratio}");
    assert!(ratio > 1.05, "{ratio}");
    let summary = run_static_with(&scene, &no_files()).unwrap();
    let magnitude = tetfem::post::output::fields::displacement_magnitude(&u_scene);
    let largest = magnitude.iter().copied().fold(0.0, f64::max);
    // The same solve inside the runner (direct or iterative by its choice: 1e-6 covers an
    // iterative solve's tolerance).
    assert!(
        ((summary.max_displacement - largest) / largest).abs() < 1e-6,
        "{} vs {largest}",
        summary.max_displacement
    );
}

#[test]
fn dynamic_scene_assembles_each_tets_density_and_stiffness() {
    // The series bar as a dynamic scene, the right half 3× as dense: the scene's system is the
    // library's LinearSystem with the same map, bit for bit (same loads vector, same calls).
    let text = BAR_SCENE.replace(
        "youngs_modulus = 4e9\npoisson_ratio = 0.0\ndensity = 1000.0",
        "youngs_modulus = 4e9\npoisson_ratio = 0.0\ndensity = 3000.0",
    ) + "\n[analysis]\ntype = \"dynamic\"\ndt = 1e-5\nduration = 1e-4\n";
    let scene = Scene::parse(&text, "bar", Path::new(".")).unwrap();
    let tetfem_cli::scene::Analysis::Dynamic(settings) = *scene.analysis() else {
        panic!("expected a dynamic analysis");
    };
    let built = scene.build().unwrap();
    let map = built.materials.clone();
    let (mesh, constraints, other) = (
        built.mesh.clone(),
        built.constraints.clone(),
        built.other_loads.clone(),
    );
    let setup = tetfem_cli::scene::DynamicSetup::from_scene(built, &settings).unwrap();
    let library = LinearSystem::new(
        &mesh,
        &map,
        &constraints,
        &other,
        Vector3::zeros(),
        MassKind::Lumped,
        Rayleigh::default(),
    )
    .unwrap();
    assert_eq!(
        setup.system.stiffness().values(),
        library.stiffness().values()
    );
    let (
        tetfem::analysis::dynamics::Mass::Lumped(m_scene),
        tetfem::analysis::dynamics::Mass::Lumped(m_library),
    ) = (setup.system.mass(), library.mass())
    else {
        panic!("lumped mass expected");
    };
    assert_eq!(m_scene, m_library);
    // Total mass ρ₁V/2 + ρ₂V/2 from the full lumped mass (one axis: each tet gives ρV/4 to
    // each of its four nodes).
    let full = lumped_mass_of(&mesh, &map).unwrap();
    let total: f64 = full.iter().step_by(3).sum();
    let exact = (1000.0 + 3000.0) / 2.0 * (L * W * W);
    // A sum of a few hundred positive terms: round-off ~1e-14 relative.
    assert!(
        ((total - exact) / exact).abs() < 1e-12,
        "{total} vs {exact}"
    );
}

#[test]
fn shipped_bimaterial_bar_scene_stretches_as_two_springs() {
    let mut scene = Scene::load(&scene_path("bimaterial_bar.toml")).unwrap();
    scene.set_output_directory(out_dir("bimaterial_bar"));
    let built = scene.build().unwrap();
    assert_eq!(built.materials.counts(), vec![240, 240]);
    let summary = run_static_with(&scene, &no_files()).unwrap();
    let area = W * W;
    let (steel, aluminium) = (200e9, 70e9);
    let exact_end = 1e5 * (0.5 / (steel * area) + 0.5 / (aluminium * area));
    let exact_interface = 1e5 * 0.5 / (steel * area);
    let end = summary.probes[0].displacement[0];
    let interface = summary.probes[1].displacement[0];
    // Exact up to round-off (see two_material_bar_is_two_springs_in_series).
    assert!(
        ((end - exact_end) / exact_end).abs() < 1e-10,
        "{end} vs {exact_end}"
    );
    assert!(
        ((interface - exact_interface) / exact_interface).abs() < 1e-10,
        "{interface} vs {exact_interface}"
    );
}

#[test]
fn boxed_models_are_accepted_where_dyn_models_were() {
    // `ModelKind::build` returns a Box; callers passed `&boxed` to `&dyn ForceModel` before.
    let mesh = bar([2, 1, 1], BoxSplit::Lecture6);
    let boxed = ModelKind::NeoHookean.build(&Material::steel());
    let u: Vec<f64> = (0..mesh.dof_count()).map(|d| 1e-6 * d as f64).collect();
    assert_eq!(
        internal_force(&mesh, &boxed, &u).unwrap(),
        internal_force(&mesh, boxed.as_ref(), &u).unwrap()
    );
}
