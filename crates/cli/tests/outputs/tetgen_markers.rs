//! TetGen `.face` markers as face sets, `.ele` region attributes as material regions, and
//! `tetfem info` listing both (issue 17, item 6). The mesh is a hand-written unit cube of five
//! tets whose markers are known by construction.

use std::path::{Path, PathBuf};

use tetfem::mesh::io::read_tetgen;
use tetfem::{Error, TetMaterials};
use tetfem_cli::info::mesh_info;
use tetfem_cli::scene::Scene;

fn out_dir(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join("tetgen_markers")
        .join(name);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// The unit cube's corners, node n at (n & 1, n >> 1 & 1, n >> 2 & 1), numbered from 1 in the
/// file, with node markers 10 + x (10 on x = 0, 11 on x = 1).
const NODE: &str = "# unit cube, 1-based\n8 3 0 1\n\
1 0 0 0 10\n2 1 0 0 11\n3 0 1 0 10\n4 1 1 0 11\n\
5 0 0 1 10\n6 1 0 1 11\n7 0 1 1 10\n8 1 1 1 11\n";

/// Four corner tets (at corners 0, 3, 5, 6, 0-based) with attribute 1 and the central tet
/// (1, 2, 4, 7) with attribute 2.
const ELE: &str = "5 4 1\n\
1 1 2 3 5 1\n2 4 2 3 8 1\n3 6 2 5 8 1\n4 7 3 5 8 1\n5 2 3 5 8 2\n";

/// The 12 boundary triangles (two per cube side): marker 1 on x = 0, 2 on x = 1, 0 elsewhere;
/// and one interior triangle (a face of the central tet) with marker 7.
const FACE: &str = "# faces of the cube\n13 1\n\
1 1 3 5 1\n2 3 5 7 1\n\
3 2 4 8 2\n4 2 6 8 2\n\
5 1 2 5 0\n6 6 2 5 0\n7 4 3 8 0\n8 7 3 8 0\n\
9 1 2 3 0\n10 4 2 3 0\n11 6 5 8 0\n12 7 5 8 0\n\
13 2 3 5 7\n";

/// Writes the cube's three files into `dir` (the `.face` one with `face` as its text).
fn write_cube(dir: &Path, face: &str) -> PathBuf {
    std::fs::write(dir.join("cube.node"), NODE).unwrap();
    std::fs::write(dir.join("cube.ele"), ELE).unwrap();
    std::fs::write(dir.join("cube.face"), face).unwrap();
    dir.join("cube")
}

#[test]
fn face_markers_node_markers_attributes_and_ids_are_read() {
    let prefix = write_cube(&out_dir("read"), FACE);
    let imported = read_tetgen(&prefix).unwrap();
    let counts: Vec<(i64, usize)> = imported.face_marker_counts().into_iter().collect();
    assert_eq!(counts, vec![(0, 8), (1, 2), (2, 2), (7, 1)]);
    let nodes: Vec<(i64, usize)> = imported.node_marker_counts().into_iter().collect();
    assert_eq!(nodes, vec![(10, 4), (11, 4)]);
    assert_eq!(imported.attribute_counts(), vec![(1.0, 4), (2.0, 1)]);
    // The file's 1-based numbers are kept as the original ids.
    assert_eq!(imported.node_ids, (1..=8).collect::<Vec<u64>>());
    assert_eq!(imported.tet_ids, (1..=5).collect::<Vec<u64>>());

    let mesh = &imported.mesh;
    let boundary = mesh.boundary_faces().unwrap();
    assert_eq!(boundary.len(), 12);
    for (marker, x) in [(1, 0.0), (2, 1.0)] {
        let faces = imported.faces_with_marker(marker, &boundary);
        assert_eq!(faces.len(), 2, "marker {marker}");
        for f in &faces {
            assert!(f.nodes.iter().all(|&n| mesh.nodes()[n].x == x), "{f:?}");
        }
    }
    // The interior triangle is no boundary face, but its nodes are a node set.
    assert!(imported.faces_with_marker(7, &boundary).is_empty());
    assert_eq!(imported.nodes_with_face_marker(7), vec![1, 2, 4]);
    assert_eq!(imported.faces_with_marker(0, &boundary).len(), 8);
}

fn scene_text(clamp: &str, extra: &str) -> String {
    format!(
        "[mesh.tetgen]\nfile = \"cube.node\"\n\
         [material]\nyoungs_modulus = 1e6\npoisson_ratio = 0.0\ndensity = 1.0\n\
         [[constraints]]\nwhere = {clamp}\n\
         [[loads]]\nwhere = {{ face_marker = 2 }}\ntotal_force = [500.0, 0.0, 0.0]\n\
         [[probes]]\nname = \"end\"\nwhere = {{ face_marker = 2 }}\n{extra}"
    )
}

#[test]
fn a_scene_clamps_and_loads_face_marker_sets() {
    let dir = out_dir("scene");
    write_cube(&dir, FACE);
    let mut scene =
        Scene::parse(&scene_text("{ face_marker = 1 }", ""), "cube.toml", &dir).unwrap();
    scene.set_output_directory(dir.join("out"));
    let summary = tetfem_cli::run_static(&scene).unwrap();
    // Clamped at x = 0, pulled by 500 N on the unit face x = 1, ν = 0: the exact solution
    // u = (σx/E, 0, 0) with σ = 500 Pa is linear, so linear tets reproduce it to round-off
    // (1e-12 relative: a few ulps through a 24-DOF solve). Had the marker selected other
    // faces, the end would move by another amount or sideways.
    let end = summary.probes[0].displacement;
    let exact = 500.0 / 1e6;
    assert!((end[0] - exact).abs() < 1e-12 * exact, "{end:?}");
    assert!(
        end[1].abs() < 1e-12 * exact && end[2].abs() < 1e-12 * exact,
        "{end:?}"
    );
    // The clamp holds the load: its reaction is −500 N along x (round-off of the 24-DOF
    // solve, 1e-9 N on 500 N).
    let reaction = &summary.reactions.as_ref().unwrap()[0];
    assert!((reaction.force_n[0] + 500.0).abs() < 1e-9, "{reaction:?}");
}

#[test]
fn region_attributes_select_materials_in_a_scene() {
    let dir = out_dir("regions");
    write_cube(&dir, FACE);
    let extra = "[[materials]]\nyoungs_modulus = 3e6\npoisson_ratio = 0.0\ndensity = 1.0\n\
                 where = { attribute = 2 }\n";
    let scene = Scene::parse(&scene_text("{ face_marker = 1 }", extra), "cube.toml", &dir).unwrap();
    let built = scene.build().unwrap();
    // Tet 4 (0-based, the file's tet 5) is the central one with attribute 2. Errors name the
    // line of the entry's table header (15: [[materials]]).
    let moduli: Vec<f64> = (0..5)
        .map(|t| built.materials.materials()[built.materials.index_of(t)].youngs_modulus())
        .collect();
    assert_eq!(moduli, vec![1e6, 1e6, 1e6, 1e6, 3e6]);

    let missing = extra.replace("attribute = 2", "attribute = 3");
    let scene = Scene::parse(
        &scene_text("{ face_marker = 1 }", &missing),
        "cube.toml",
        &dir,
    )
    .unwrap();
    let err = scene.build().unwrap_err();
    let text = err.to_string();
    assert!(
        matches!(&err, Error::Scene { key, line: 15, .. } if key == "materials[0].where.attribute"),
        "{err:?}"
    );
    assert!(text.contains("1 (4 tets), 2 (1 tets)"), "{text}");
}

#[test]
fn a_marker_the_file_lacks_is_an_error_listing_the_markers() {
    let dir = out_dir("missing");
    write_cube(&dir, FACE);
    let scene = Scene::parse(&scene_text("{ face_marker = 5 }", ""), "cube.toml", &dir).unwrap();
    let err = scene.build().unwrap_err();
    let text = err.to_string();
    assert!(
        matches!(&err, Error::Scene { key, line: 7, .. }
            if key == "constraints[0].where.face_marker"),
        "{err:?}"
    );
    assert!(
        text.contains("no face marker 5")
            && text.contains("0 (8 faces), 1 (2 faces), 2 (2 faces), 7 (1 faces)"),
        "{text}"
    );
    // The same for node markers.
    let scene = Scene::parse(&scene_text("{ marker = 12 }", ""), "cube.toml", &dir).unwrap();
    let text = scene.build().unwrap_err().to_string();
    assert!(
        text.contains("constraints[0].where.marker")
            && text.contains("no node marker 12")
            && text.contains("10 (4 nodes), 11 (4 nodes)"),
        "{text}"
    );
    // A face marker whose triangles are all inside the body is no face set for a load.
    let scene = Scene::parse(
        &scene_text("{ face_marker = 1 }", "").replace(
            "where = { face_marker = 2 }\ntotal",
            "where = { face_marker = 7 }\ntotal",
        ),
        "cube.toml",
        &dir,
    )
    .unwrap();
    let text = scene.build().unwrap_err().to_string();
    assert!(
        text.contains("loads[0].where") && text.contains("no boundary face"),
        "{text}"
    );
    // Without a .face file, a face_marker selection says what it needs.
    let bare = out_dir("bare");
    write_cube(&bare, FACE);
    std::fs::remove_file(bare.join("cube.face")).unwrap();
    let scene = Scene::parse(&scene_text("{ face_marker = 1 }", ""), "cube.toml", &bare).unwrap();
    let text = scene.build().unwrap_err().to_string();
    assert!(
        text.contains("needs a TetGen mesh with a .face file"),
        "{text}"
    );
}

#[test]
fn malformed_face_files_name_the_file_and_line() {
    let cases = [
        // (the .face text, the culprit line, a phrase of the message)
        ("2 1\n1 1 3 5 1\n2 3 5 7 one\n", 3, "boundary marker"),
        ("2 1\n1 1 3 5 1\n2 3 5 7\n", 3, "expected 5 fields"),
        ("1 1\n1 1 3 99 1\n", 2, "node index 99 is out of range"),
        ("1 2\n1 1 3 5 1\n", 1, "marker flag is 2"),
        ("1 1\n1 1 3 5 1.5\n", 2, "boundary marker"),
        (
            "1 1\n1 1 3 5 1\n2 3 5 7 1\n",
            3,
            "more faces than the header's count 1",
        ),
        ("2 1\n1 1 3 5 1\n", 0, "face 2 of 2"),
        ("1 1\n3 1 3 5 1\n", 2, "face index 3 is out of sequence"),
    ];
    for (i, (face, line, phrase)) in cases.iter().enumerate() {
        let prefix = write_cube(&out_dir(&format!("bad{i}")), face);
        let err = read_tetgen(&prefix).unwrap_err();
        let text = err.to_string();
        match &err {
            Error::Parse { path, line: l, .. } => {
                assert!(path.ends_with("cube.face"), "case {i}: {err:?}");
                // An early end of file is reported at the last line read or 0: only the
                // file matters there.
                if *line > 0 {
                    assert_eq!(l, line, "case {i}: {text}");
                }
            }
            other => panic!("case {i}: {other:?}"),
        }
        assert!(text.contains(phrase), "case {i}: {text}");
    }
    // A .face file without a marker column is read, and gives no face sets.
    let prefix = write_cube(&out_dir("unmarked"), "1 0\n1 1 3 5\n");
    assert_eq!(read_tetgen(&prefix).unwrap().face_markers, None);
}

#[test]
fn info_lists_markers_and_attributes_with_counts() {
    let prefix = write_cube(&out_dir("info"), FACE);
    let info = mesh_info(&prefix.with_extension("node"), None).unwrap();
    assert_eq!(info.face_markers.get(&0), Some(&8));
    assert_eq!(info.face_markers.get(&7), Some(&1));
    assert_eq!(info.node_markers.get(&11), Some(&4));
    assert_eq!(info.region_attributes, vec![(1.0, 4), (2.0, 1)]);
    let text = info.to_string();
    assert!(
        text.contains("node markers: 10 (4 nodes), 11 (4 nodes)")
            && text.contains("face markers: 0 (8 faces), 1 (2 faces), 2 (2 faces), 7 (1 faces)")
            && text.contains("region attributes: 1 (4 tets), 2 (1 tets)"),
        "{text}"
    );
}

#[test]
fn the_shipped_tetgen_bar_stretches_as_two_springs_in_series() {
    let path =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/tetgen_bimaterial_bar.toml");
    let mut scene = Scene::load(&path).unwrap();
    scene.set_output_directory(out_dir("shipped"));
    let summary = tetfem_cli::run_static(&scene).unwrap();
    // Steel (attribute 1) for x < 0.5, aluminium (attribute 2) beyond, ν = 0, clamped on face
    // marker 1 and pulled by 100 kN on face marker 2 (0.01 m²): the exact displacement is
    // piecewise linear with a kink on a mesh plane, so linear tets reproduce it; 1e-10
    // relative allows the round-off of the 270-DOF solve (relative residual ~3e-14, κ ~1e3).
    // Swapped regions would give 0.5/(70e9·0.01) at the interface instead: 2.9× off.
    let exact_end = 1e5 * (0.5 / (200e9 * 0.01) + 0.5 / (70e9 * 0.01));
    let exact_interface = 1e5 * 0.5 / (200e9 * 0.01);
    let end = summary.probes[0].displacement[0];
    let interface = summary.probes[1].displacement[0];
    println!(
        "end {end:e} (exact {exact_end:e}), interface {interface:e} (exact {exact_interface:e})"
    );
    assert!((end - exact_end).abs() < 1e-10 * exact_end, "{end}");
    assert!(
        (interface - exact_interface).abs() < 1e-10 * exact_interface,
        "{interface}"
    );
}
