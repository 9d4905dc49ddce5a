//! Scenes on quadratic mesh files: the order comes from the file, the run equals the box scene
//! of the same 10-node mesh and the library on the file, `mesh.order` disagreeing with the
//! file is an error naming the key and line, and `tetfem info` names the element type.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use nalgebra::Vector3;
use tetfem::mesh::io::read_gmsh_as;
use tetfem::{BoxSplit, Constraints, Loads, Material, Tet10, TetMesh, solve_static};
use tetfem_cli::info::mesh_info;
use tetfem_cli::scene::{RunOptions, Scene, run_static_with};

fn scenes() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes")
}

fn no_files() -> RunOptions {
    RunOptions {
        no_files: true,
        ..RunOptions::default()
    }
}

/// MSH 2.2 of a 10-node mesh (Gmsh's node order: its nodes 8 and 9 on edges (2,3) and (1,3))
/// with the 6-node boundary triangles on x = 0 (physical 1 "clamp") and x = `length` (2 "tip").
fn msh22(mesh: &TetMesh<Tet10>, length: f64) -> String {
    let edge = |cell: &[usize; 10], a: usize, b: usize| {
        let local = |n: usize| cell[..4].iter().position(|&c| c == n).unwrap();
        <Tet10 as tetfem::CellType>::edge_node(cell, local(a), local(b)).unwrap()
    };
    let mut triangles = Vec::new();
    for face in mesh.boundary_faces().unwrap() {
        let x: Vec<f64> = face.nodes.iter().map(|&n| mesh.nodes()[n].x).collect();
        let group = if x.iter().all(|&v| v == 0.0) {
            1
        } else if x.iter().all(|&v| v == length) {
            2
        } else {
            continue;
        };
        let cell = &mesh.tets()[face.tet];
        let [a, b, c] = face.nodes;
        triangles.push((
            group,
            [
                a,
                b,
                c,
                edge(cell, a, b),
                edge(cell, b, c),
                edge(cell, c, a),
            ],
        ));
    }
    let mut s = String::from(
        "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$PhysicalNames\n2\n2 1 \"clamp\"\n2 2 \"tip\"\n$EndPhysicalNames\n$Nodes\n",
    );
    writeln!(s, "{}", mesh.node_count()).unwrap();
    for (i, p) in mesh.nodes().iter().enumerate() {
        writeln!(s, "{} {} {} {}", i + 1, p.x, p.y, p.z).unwrap();
    }
    writeln!(
        s,
        "$EndNodes\n$Elements\n{}",
        mesh.tet_count() + triangles.len()
    )
    .unwrap();
    let mut tag = 0;
    for cell in mesh.tets() {
        tag += 1;
        write!(s, "{tag} 11 2 9 9").unwrap();
        for k in [0, 1, 2, 3, 4, 5, 6, 7, 9, 8] {
            write!(s, " {}", cell[k] + 1).unwrap();
        }
        s += "\n";
    }
    for (group, t) in &triangles {
        tag += 1;
        write!(s, "{tag} 9 2 {group} {group}").unwrap();
        for v in t {
            write!(s, " {}", v + 1).unwrap();
        }
        s += "\n";
    }
    s + "$EndElements\n"
}

/// The peer cantilever (L = 10, W = H = 1, E = 1e5, ν = 0.3, end load 1 N) with `mesh`.
fn cantilever(mesh: &str, clamp: &str, tip: &str) -> String {
    format!(
        "{mesh}\n[material]\nyoungs_modulus = 1e5\npoisson_ratio = 0.3\ndensity = 1000.0\n\n\
         [[constraints]]\nwhere = {clamp}\n\n[[loads]]\nwhere = {tip}\ntotal_force = [0.0, 0.0, -1.0]\n\n\
         [[probes]]\nname = \"tip\"\nwhere = {tip}\n"
    )
}

#[test]
fn a_quadratic_gmsh_file_runs_as_order_2_like_the_box_scene() {
    let dir = std::env::temp_dir().join(format!("tetfem_p2_file_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for (split, name) in [
        (BoxSplit::Mirrored6, "mirrored6"),
        (BoxSplit::Lecture6, "lecture6"),
        (BoxSplit::Five, "five"),
    ] {
        let linear = TetMesh::box_grid(
            Vector3::zeros(),
            Vector3::new(10.0, 1.0, 1.0),
            [6, 2, 2],
            split,
        )
        .unwrap();
        let mesh = TetMesh::<Tet10>::from_linear(&linear).unwrap();
        let file = dir.join(format!("beam_{name}.msh"));
        std::fs::write(&file, msh22(&mesh, 10.0)).unwrap();
        let boxed = cantilever(
            &format!(
                "[mesh]\norder = 2\n[mesh.box]\nmax = [10.0, 1.0, 1.0]\ncells = [6, 2, 2]\nsplit = \"{name}\""
            ),
            "{ plane = { axis = \"x\", at = 0.0 } }",
            "{ plane = { axis = \"x\", at = 10.0 } }",
        );
        let from_file = cantilever(
            &format!("[mesh.gmsh]\nfile = \"{}\"", file.display()),
            "{ group = \"clamp\" }",
            "{ group = \"tip\" }",
        );
        let boxed = Scene::parse(&boxed, "<box>", Path::new(".")).unwrap();
        let from_file = Scene::parse(&from_file, "<file>", Path::new(".")).unwrap();
        // No order key: the file's 10-node tets make it order 2.
        assert_eq!(from_file.order(), 2, "{name}");
        let a = run_static_with(&boxed, &no_files()).unwrap();
        let b = run_static_with(&from_file, &no_files()).unwrap();
        assert_eq!((a.nodes, a.tets), (b.nodes, b.tets), "{name}");
        let (ua, ub) = (a.probes[0].displacement, b.probes[0].displacement);
        let scale = ua.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let diff = (0..3).fold(0.0f64, |m, k| m.max((ua[k] - ub[k]).abs()));
        eprintln!(
            "{name}: tip {ua:?} (box) vs {ub:?} (file), relative {:.1e}",
            diff / scale
        );
        // The same nodes in the same order, the same cells and the same sets (Tri6 groups
        // against planes): the same equations, so the same answer up to summation order
        // (1e-12 relative leaves room for it; a wrong face or node set misses by O(1)).
        assert!(diff <= 1e-12 * scale, "{name}: {ua:?} vs {ub:?}");
        assert!(ua[2] < 0.0, "{name}: the tip goes down");
    }
}

#[test]
fn the_shipped_quadratic_bracket_equals_the_library_on_its_file() {
    let scene = Scene::load(&scenes().join("l_bracket_p2.toml")).unwrap();
    assert_eq!(scene.order(), 2);
    let summary = run_static_with(&scene, &no_files()).unwrap();
    // The same problem through the library on the file read as 10-node tets.
    let imported = read_gmsh_as::<Tet10>(&scenes().join("l_bracket_p2.msh")).unwrap();
    let mesh = &imported.mesh;
    let material = Material::new(200e9, 0.3, 7850.0).unwrap();
    let mut constraints = Constraints::new(mesh);
    constraints
        .fix_axes(&imported.group("clamp").unwrap().nodes, [true; 3])
        .unwrap();
    let boundary = mesh.boundary_faces().unwrap();
    let load = imported.group("load").unwrap();
    let mut loads = Loads::new(mesh);
    loads
        .add_total_force_on_faces(
            mesh,
            &load.boundary_faces(&boundary),
            Vector3::new(0.0, -2000.0, 0.0),
        )
        .unwrap();
    let u = solve_static(mesh, &material, &constraints, &loads)
        .unwrap()
        .displacement;
    let mut mean = Vector3::zeros();
    for &n in &load.nodes {
        mean += Vector3::new(u[3 * n], u[3 * n + 1], u[3 * n + 2]);
    }
    mean /= load.nodes.len() as f64;
    assert_eq!(summary.nodes, mesh.node_count());
    // The scene runs the same generic solve on the same mesh, sets and loads: the same bits.
    assert_eq!(summary.probes[0].displacement, <[f64; 3]>::from(mean));
    // The load face's nodes include the 6-node triangles' edge nodes.
    let corners: std::collections::BTreeSet<usize> =
        load.triangles.iter().flatten().copied().collect();
    assert!(
        load.nodes.len() > corners.len(),
        "{} vs {}",
        load.nodes.len(),
        corners.len()
    );
    // The quadratic bracket bends further than the coarse-ish linear one on its own mesh
    // (l_bracket.msh, finer): the linear tets are stiffer (they lock in bending).
    let linear = Scene::load(&scenes().join("l_bracket.toml")).unwrap();
    let p1 = run_static_with(&linear, &no_files()).unwrap();
    eprintln!(
        "load face: P2 {:?} ({} nodes), P1 {:?} ({} nodes)",
        summary.probes[0].displacement, summary.nodes, p1.probes[0].displacement, p1.nodes
    );
    assert!(summary.probes[0].displacement[1] < p1.probes[0].displacement[1]);
}

#[test]
fn mesh_order_must_match_the_file() {
    let base = |order: usize, file: &str| {
        format!(
            "title = \"t\"\n[mesh]\norder = {order}\n[mesh.gmsh]\nfile = \"{file}\"\n[material]\n\
             youngs_modulus = 1e5\npoisson_ratio = 0.3\ndensity = 1.0\n"
        )
    };
    // order = 1 on the quadratic file: names the key, its line and what the file holds.
    let error = Scene::parse(&base(1, "l_bracket_p2.msh"), "<s>", &scenes()).unwrap_err();
    let text = error.to_string();
    assert!(
        text.contains("mesh.order") && text.contains(":3:") && text.contains("10-node tets"),
        "{text}"
    );
    // order = 2 on it is what the file holds: accepted.
    let scene = Scene::parse(&base(2, "l_bracket_p2.msh"), "<s>", &scenes()).unwrap();
    assert_eq!(scene.order(), 2);
    // order = 2 on the linear bracket: an error naming the 4-node tets.
    let error = Scene::parse(&base(2, "l_bracket.msh"), "<s>", &scenes()).unwrap_err();
    assert!(error.to_string().contains("4-node tets"), "{error}");
    // A missing file: parsing succeeds on the key's order; the build names the file.
    let scene = Scene::parse(&base(2, "no_such.msh"), "<s>", &scenes()).unwrap();
    let error = scene.build_as::<Tet10>().unwrap_err();
    assert!(error.to_string().contains("no_such.msh"), "{error}");
}

#[test]
fn info_names_the_element_type() {
    let p2 = mesh_info(&scenes().join("l_bracket_p2.msh"), None).unwrap();
    assert_eq!(p2.element, "tet10");
    assert!(
        p2.to_string()
            .contains("element: tet10 (10-node quadratic tets, order 2)"),
        "{p2}"
    );
    let p1 = mesh_info(&scenes().join("l_bracket.msh"), None).unwrap();
    assert_eq!(p1.element, "tet4");
    // The quadratic file's nodes: every node is a tet's (corners and edge nodes), none dropped.
    assert_eq!(p2.unused_nodes, 0);
    let scene = mesh_info(&scenes().join("l_bracket_p2.toml"), None).unwrap();
    assert_eq!(scene.element, "tet10");
    assert_eq!(scene.statistics.nodes, p2.statistics.nodes);
}

/// Issue 33 item 12: a scene parsed its mesh file once for the order and again to build it
/// (twice the reading time, 122 s each on a 19k-tet quadratic file before the reader was made
/// linear). The parse is kept for the build: a scene whose file is gone by then still builds,
/// from the one parse, the mesh the file held. A second build (the parse taken) reads the file
/// again, and so names the missing file.
#[test]
fn a_scene_parses_its_mesh_file_once() {
    let dir = std::env::temp_dir().join(format!("tetfem_p2_once_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("bracket.msh");
    std::fs::copy(scenes().join("l_bracket_p2.msh"), &file).unwrap();
    let text = format!(
        "title = \"t\"\n[mesh.gmsh]\nfile = \"{}\"\n[material]\nyoungs_modulus = 1e5\n\
         poisson_ratio = 0.3\ndensity = 1.0\n",
        file.display()
    );
    let scene = Scene::parse(&text, "<s>", Path::new(".")).unwrap();
    assert_eq!(scene.order(), 2);
    std::fs::remove_file(&file).unwrap();
    let built = scene.build_as::<Tet10>().unwrap();
    let direct = read_gmsh_as::<Tet10>(&scenes().join("l_bracket_p2.msh")).unwrap();
    assert_eq!(built.mesh, direct.mesh);
    let error = scene.build_as::<Tet10>().unwrap_err();
    assert!(error.to_string().contains("bracket.msh"), "{error}");
}
