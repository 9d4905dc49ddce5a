//! The mesh file's own node and element ids in every result `.vtu` (issue 17, item 3):
//! `original_node_id` (point data) and `original_element_id` (cell data), `Int64`, for Gmsh
//! files whose tags have gaps and are out of order, and for TetGen files numbered from 0 or 1.

use crate::common::vtu;
use std::ops::ControlFlow;
use std::path::{Path, PathBuf};

use tetfem_cli::scene::{RunOptions, Scene, run_dynamic_scene, run_modal_scene, run_static_with};

fn out_dir(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join("original_ids")
        .join(name);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// The unit cube of five tets (corner n at (n & 1, n >> 1 & 1, n >> 2 & 1)) as Gmsh 2.2: corner
/// n has node tag 10·(n + 1); an unused node (tag 45) sits between tags 40 and 50; the tets
/// have element tags 101, 103, 107, 200, 9 (gaps, not ascending) after a triangle (tag 7).
const GMSH: &str = "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n9\n\
10 0 0 0\n20 1 0 0\n30 0 1 0\n40 1 1 0\n45 5 5 5\n50 0 0 1\n60 1 0 1\n70 0 1 1\n80 1 1 1\n\
$EndNodes\n$Elements\n6\n\
7 2 2 0 1 10 30 50\n\
101 4 2 0 1 10 20 30 50\n103 4 2 0 1 40 20 30 80\n107 4 2 0 1 60 20 50 80\n\
200 4 2 0 1 70 30 50 80\n9 4 2 0 1 20 30 50 80\n$EndElements\n";

/// The same cube in Gmsh 4.1 (tags 10·(n + 1) in one block, no unused node; the tets' tags
/// 101, 103, 107, 200, 9).
const GMSH41: &str = "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n\
$Entities\n0 0 0 1\n1 0 0 0 1 1 1 0 0\n$EndEntities\n\
$Nodes\n1 8 10 80\n3 1 0 8\n10\n20\n30\n40\n50\n60\n70\n80\n\
0 0 0\n1 0 0\n0 1 0\n1 1 0\n0 0 1\n1 0 1\n0 1 1\n1 1 1\n$EndNodes\n\
$Elements\n1 5 9 200\n3 1 4 5\n\
101 10 20 30 50\n103 40 20 30 80\n107 60 20 50 80\n200 70 30 50 80\n9 20 30 50 80\n\
$EndElements\n";

const GMSH_NODE_IDS: [i64; 8] = [10, 20, 30, 40, 50, 60, 70, 80];
const GMSH_ELEMENT_IDS: [i64; 5] = [101, 103, 107, 200, 9];

/// The same cube as TetGen files numbered from `base`.
fn write_tetgen_cube(dir: &Path, base: usize) {
    let mut node = "8 3 0 0\n".to_string();
    for n in 0..8 {
        node += &format!("{} {} {} {}\n", n + base, n & 1, n >> 1 & 1, n >> 2 & 1);
    }
    let tets = [
        [0, 1, 2, 4],
        [3, 1, 2, 7],
        [5, 1, 4, 7],
        [6, 2, 4, 7],
        [1, 2, 4, 7],
    ];
    let mut ele = "5 4 0\n".to_string();
    for (t, tet) in tets.iter().enumerate() {
        let [a, b, c, d] = tet.map(|n| n + base);
        ele += &format!("{} {a} {b} {c} {d}\n", t + base);
    }
    std::fs::write(dir.join("cube.node"), node).unwrap();
    std::fs::write(dir.join("cube.ele"), ele).unwrap();
}

/// A scene on `mesh` (a `[mesh.*]` table) clamped at x = 0 and pulled at x = 1, with the
/// `[analysis]` table `analysis`.
fn scene(dir: &Path, mesh: &str, analysis: &str) -> Scene {
    let text = format!(
        "{mesh}\n[material]\nyoungs_modulus = 1e6\npoisson_ratio = 0.25\ndensity = 1000.0\n\
         [[constraints]]\nwhere = {{ plane = {{ axis = \"x\", at = 0.0 }} }}\n\
         [[loads]]\nwhere = {{ plane = {{ axis = \"x\", at = 1.0 }} }}\n\
         total_force = [10.0, 0.0, 0.0]\n\
         [[probes]]\nname = \"end\"\nwhere = {{ plane = {{ axis = \"x\", at = 1.0 }} }}\n\
         {analysis}"
    );
    let mut scene = Scene::parse(&text, "cube.toml", dir).unwrap();
    scene.set_output_directory(dir.join("out"));
    scene
}

/// The `Int64` array `name` of a `.vtu` (panics if it is missing or of another type), read
/// through the tests' own reader (binary or ASCII); binary values are decoded from their bytes,
/// so ids beyond 2^53 would stay exact.
fn int_array(vtu: &Path, name: &str) -> Vec<i64> {
    let file = vtu::read_vtu(vtu);
    let array = file.array(name);
    assert_eq!(array.vtk_type, "Int64", "{name}");
    let expected = match name {
        "original_node_id" => "PointData",
        _ => "CellData",
    };
    assert_eq!(array.section, expected, "{name}");
    match file.binary {
        true => array
            .raw
            .chunks_exact(8)
            .map(|b| i64::from_le_bytes(b.try_into().expect("8 bytes")))
            .collect(),
        false => array.values.iter().map(|&v| v as i64).collect(),
    }
}

fn vtus(files: &[PathBuf]) -> Vec<&PathBuf> {
    files
        .iter()
        .filter(|f| f.extension().is_some_and(|e| e == "vtu"))
        .collect()
}

#[test]
fn gmsh_tags_with_gaps_reach_the_static_and_modal_vtu() {
    let dir = out_dir("gmsh");
    std::fs::write(dir.join("cube.msh"), GMSH).unwrap();
    let mesh = "[mesh.gmsh]\nfile = \"cube.msh\"";
    let summary = run_static_with(
        &scene(&dir, mesh, "[analysis]\ntype = \"static\"\n"),
        &RunOptions::default(),
    )
    .unwrap();
    let files = vtus(&summary.files);
    assert_eq!(files.len(), 1);
    assert_eq!(int_array(files[0], "original_node_id"), GMSH_NODE_IDS);
    assert_eq!(int_array(files[0], "original_element_id"), GMSH_ELEMENT_IDS);

    let modal = scene(
        &out_dir("gmsh_modal"),
        &mesh.replace("cube.msh", "../gmsh/cube.msh"),
        "[analysis]\ntype = \"modal\"\nmodes = 2\n",
    );
    let summary = run_modal_scene(&modal, false).unwrap();
    let files = vtus(&summary.files);
    assert_eq!(files.len(), 2);
    for vtu in files {
        assert_eq!(int_array(vtu, "original_node_id"), GMSH_NODE_IDS);
        assert_eq!(int_array(vtu, "original_element_id"), GMSH_ELEMENT_IDS);
    }
}

#[test]
fn gmsh_41_element_tags_are_kept() {
    let dir = out_dir("gmsh41");
    std::fs::write(dir.join("cube.msh"), GMSH41).unwrap();
    let imported = tetfem::mesh::io::read_gmsh(&dir.join("cube.msh")).unwrap();
    let nodes: Vec<i64> = imported.node_ids.iter().map(|&i| i as i64).collect();
    let elements: Vec<i64> = imported.tet_ids.iter().map(|&i| i as i64).collect();
    assert_eq!(nodes, GMSH_NODE_IDS);
    assert_eq!(elements, GMSH_ELEMENT_IDS);
}

#[test]
fn tetgen_numbers_from_0_and_1_reach_every_dynamic_frame() {
    for base in [0i64, 1] {
        let dir = out_dir(&format!("tetgen{base}"));
        write_tetgen_cube(&dir, base as usize);
        let scene = scene(
            &dir,
            "[mesh.tetgen]\nfile = \"cube.node\"",
            "[analysis]\ntype = \"dynamic\"\ndt = 1e-3\nduration = 3e-3\n",
        );
        let summary = run_dynamic_scene(&scene, &Default::default(), true, false, &mut |_, _| {
            ControlFlow::Continue(())
        })
        .unwrap();
        let files = vtus(&summary.files);
        assert_eq!(files.len(), 4, "frames at steps 0..=3");
        for vtu in files {
            let nodes: Vec<i64> = (base..base + 8).collect();
            let elements: Vec<i64> = (base..base + 5).collect();
            assert_eq!(int_array(vtu, "original_node_id"), nodes);
            assert_eq!(int_array(vtu, "original_element_id"), elements);
        }
    }
}

#[test]
fn box_meshes_have_no_original_ids() {
    let dir = out_dir("box");
    let summary = run_static_with(
        &scene(
            &dir,
            "[mesh.box]\nmax = [1.0, 1.0, 1.0]\ncells = [1, 1, 1]",
            "",
        ),
        &RunOptions::default(),
    )
    .unwrap();
    let file = vtu::read_vtu(vtus(&summary.files)[0]);
    assert!(!file.has("original_node_id") && !file.has("original_element_id"));
}
