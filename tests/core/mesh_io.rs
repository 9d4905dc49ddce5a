//! Mesh import/export: round trips, files written by Gmsh itself, and one malformed file per
//! error class, each answered by `Error::Parse` naming the file and line.

use std::path::{Path, PathBuf};

use nalgebra::Vector3;
use tetfem::mesh::io::{
    PhysicalGroup, SKIPPED_EDGES, TetgenOptions, read_gmsh, read_mesh, read_tetgen, write_gmsh,
    write_tetgen,
};
use tetfem::{BoxSplit, Error, TetMesh};

fn tmp(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("mesh_io");
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(name)
}

/// A box mesh with irrational-looking coordinates, so that a lossy float format would show.
fn sample_mesh() -> TetMesh {
    TetMesh::box_grid(
        Vector3::new(-0.1, 0.0, 1.0 / 3.0),
        Vector3::new(0.7, 0.3, 1.0),
        [4, 2, 3],
        BoxSplit::Five,
    )
    .unwrap()
}

fn clamp_group(mesh: &TetMesh) -> PhysicalGroup {
    let faces = mesh.faces_on_plane(&mesh.boundary_faces().unwrap(), 0, -0.1, 1e-12);
    let mut nodes: Vec<usize> = faces.iter().flat_map(|f| f.nodes).collect();
    nodes.sort_unstable();
    nodes.dedup();
    PhysicalGroup {
        dim: 2,
        tag: 7,
        name: Some("clamp face".into()),
        triangles: faces.iter().map(|f| f.nodes).collect(),
        tets: vec![],
        nodes,
    }
}

#[test]
fn msh41_round_trip_is_identical() {
    let mesh = sample_mesh();
    let group = clamp_group(&mesh);
    let path = tmp("round_trip.msh");
    write_gmsh(&path, &mesh, std::slice::from_ref(&group)).unwrap();
    let back = read_gmsh(&path).unwrap();
    assert!(
        back.mesh == mesh,
        "nodes and tets must come back bit for bit"
    );
    assert_eq!(
        back.node_ids,
        (1..=mesh.node_count() as u64).collect::<Vec<_>>()
    );
    assert_eq!(back.groups, vec![group.clone()]);
    assert_eq!(back.unused_nodes, 0);
    assert_eq!(back.skipped_count(), 0);
    // The group's triangles are exactly the boundary faces on x = −0.1, found by name or tag.
    let boundary = back.mesh.boundary_faces().unwrap();
    let by_name = back.group("clamp face").unwrap().boundary_faces(&boundary);
    assert_eq!(by_name.len(), group.triangles.len());
    assert_eq!(back.group("7").unwrap().tag, 7);
    assert!(back.group("nope").is_none());
}

#[test]
fn tetgen_round_trip_is_identical_in_both_bases() {
    let mesh = sample_mesh();
    let markers: Vec<i64> = (0..mesh.node_count() as i64).map(|n| n % 3).collect();
    let attributes: Vec<f64> = (0..mesh.tet_count())
        .map(|t| (t % 2) as f64 + 0.5)
        .collect();
    for base in [0, 1] {
        let prefix = tmp(&format!("round_trip_{base}"));
        let options = TetgenOptions {
            base,
            node_markers: Some(markers.clone()),
            tet_attributes: Some(attributes.clone()),
        };
        write_tetgen(&prefix, &mesh, &options).unwrap();
        let back = read_tetgen(&prefix).unwrap();
        assert!(back.mesh == mesh, "base {base}");
        assert_eq!(back.node_markers.as_ref(), Some(&markers), "base {base}");
        assert_eq!(
            back.tet_attributes.as_ref(),
            Some(&attributes),
            "base {base}"
        );
        assert_eq!(back.node_ids[0], base as u64);
        assert_eq!(
            back.nodes_with_marker(2).len(),
            markers.iter().filter(|&&m| m == 2).count()
        );
        // read_mesh dispatches on the extension.
        assert!(read_mesh(&prefix.with_extension("node")).unwrap().mesh == mesh);
    }
}

#[test]
fn gmsh_written_files_agree_across_formats() {
    // The same geometry and mesh size meshed by Gmsh 4.8 and saved as MSH 4.1 ASCII,
    // MSH 4.1 binary and MSH 2.2 ASCII: all three must give the same mesh and groups.
    let ascii = read_gmsh(&data("l_bracket_ascii41.msh")).unwrap();
    let binary = read_gmsh(&data("l_bracket_bin41.msh")).unwrap();
    let legacy = read_gmsh(&data("l_bracket_v22.msh")).unwrap();
    // Gmsh writes ASCII coordinates with 16 significant digits, binary ones exactly.
    assert_close(&binary.mesh, &ascii.mesh, 1e-15);
    assert_close(&legacy.mesh, &ascii.mesh, 1e-15);
    assert_eq!(binary.groups, ascii.groups);
    assert_eq!(legacy.groups, ascii.groups);
    // The L: 0.1×0.02 plus 0.02×0.08, 0.02 thick. Flat faces are meshed exactly, so the volume
    // agrees to round-off.
    let volume = (0.1 * 0.02 + 0.02 * 0.08) * 0.02;
    assert!((ascii.mesh.volume() - volume).abs() < 1e-9 * volume);
    // Saved with -save_all: points and curves are skipped and counted; the other two files
    // (saved without) hold only the physical groups' elements.
    assert!(ascii.skipped_elements.get("Pnt").copied().unwrap_or(0) > 0);
    assert!(ascii.skipped_elements.get("Lin2").copied().unwrap_or(0) > 0);
    assert_eq!(binary.skipped_count(), 0);
    assert_eq!(legacy.skipped_count(), 0);
    assert!(ascii.unused_nodes == 0 && legacy.unused_nodes == 0);
    // The named groups select the faces they were defined on.
    let boundary = ascii.mesh.boundary_faces().unwrap();
    let clamp = ascii.group("clamp").unwrap().boundary_faces(&boundary);
    let load = ascii.group("load").unwrap().boundary_faces(&boundary);
    assert!(!clamp.is_empty() && !load.is_empty());
    for f in &clamp {
        assert!(
            f.nodes
                .iter()
                .all(|&n| (ascii.mesh.nodes()[n].y - 0.1).abs() < 1e-12)
        );
    }
    for f in &load {
        assert!(
            f.nodes
                .iter()
                .all(|&n| (ascii.mesh.nodes()[n].x - 0.1).abs() < 1e-12)
        );
    }
    let area: f64 = load
        .iter()
        .map(|f| f.area_vector(&ascii.mesh).unwrap().norm())
        .sum();
    assert!((area - 0.02 * 0.02).abs() < 1e-12);
    let steel = ascii.group("steel").unwrap();
    assert_eq!((steel.dim, steel.tets.len()), (3, ascii.mesh.tet_count()));
}

/// Same tets, and nodes equal within `tol` (absolute; the meshes are of size 0.1).
fn assert_close(a: &TetMesh, b: &TetMesh, tol: f64) {
    assert_eq!(a.tets(), b.tets());
    assert_eq!(a.node_count(), b.node_count());
    for (p, q) in a.nodes().iter().zip(b.nodes()) {
        assert!((p - q).amax() <= tol, "{p:?} vs {q:?}");
    }
}

/// Writes `content` to a temporary file and expects `Error::Parse` at `line` of that file,
/// with a message containing `needle`.
fn expect_parse_error(
    name: &str,
    content: &[u8],
    read: fn(&Path) -> tetfem::Result<tetfem::mesh::io::ImportedMesh>,
    line: usize,
    needle: &str,
) {
    let path = tmp(name);
    std::fs::write(&path, content).unwrap();
    match read(&path) {
        Err(Error::Parse {
            path: p,
            line: l,
            message,
        }) => {
            assert_eq!(p, path, "{name}: error must name the file");
            assert_eq!(l, line, "{name}: wrong line in '{message}'");
            assert!(
                message.contains(needle),
                "{name}: '{message}' lacks '{needle}'"
            );
        }
        other => panic!("{name}: expected a parse error, got {other:?}"),
    }
}

const MSH22: &str = "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n4\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n$EndNodes\n$Elements\n2\n1 2 2 5 1 1 2 3\n2 4 2 9 1 1 2 3 4\n$EndElements\n";

#[test]
fn valid_msh22_minimal() {
    let path = tmp("ok22.msh");
    std::fs::write(&path, MSH22).unwrap();
    let m = read_gmsh(&path).unwrap();
    assert_eq!((m.mesh.node_count(), m.mesh.tet_count()), (4, 1));
    assert_eq!(m.group("5").unwrap().triangles, vec![[0, 1, 2]]);
    assert_eq!(m.group("9").unwrap().tets, vec![0]);
}

#[test]
fn malformed_msh22_files_name_file_and_line() {
    let r = read_gmsh as fn(&Path) -> _;
    // Truncated in the middle of $Nodes.
    expect_parse_error("trunc22.msh", &MSH22.as_bytes()[..60], r, 8, "truncated");
    // Wrong count: four nodes announced, five given.
    let wrong = MSH22.replace("4\n1 0 0 0", "3\n1 0 0 0");
    expect_parse_error("count22.msh", wrong.as_bytes(), r, 9, "count");
    // Bad index: the tet refers to node 9.
    let bad = MSH22.replace("1 2 3 4\n$End", "1 2 3 9\n$End");
    expect_parse_error("index22.msh", bad.as_bytes(), r, 14, "node tag 9");
    // Unsupported version.
    let v = MSH22.replace("2.2 0 8", "3.0 0 8");
    expect_parse_error(
        "version.msh",
        v.as_bytes(),
        r,
        2,
        "unsupported MSH version 3.0",
    );
    // Non-numeric coordinate.
    let nn = MSH22.replace("3 0 1 0", "3 0 one 0");
    expect_parse_error("nan22.msh", nn.as_bytes(), r, 8, "'one'");
    // Not a mesh at all, and binary 2.2.
    expect_parse_error("junk.msh", b"hello\n", r, 1, "$MeshFormat");
    let b = MSH22.replace("2.2 0 8", "2.2 1 8");
    expect_parse_error("bin22.msh", b.as_bytes(), r, 2, "binary MSH 2.2");
    // A degenerate (flat) tet is reported at its element line.
    let flat = MSH22.replace("4 0 0 1\n", "4 1 1 0\n");
    expect_parse_error("flat22.msh", flat.as_bytes(), r, 14, "degenerate");
}

const MSH41: &str = "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Nodes\n1 4 1 4\n3 1 0 4\n1\n2\n3\n4\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n$EndNodes\n$Elements\n1 1 1 1\n3 1 4 1\n1 1 2 3 4\n$EndElements\n";

#[test]
fn malformed_msh41_files_name_file_and_line() {
    let r = read_gmsh as fn(&Path) -> _;
    let path = tmp("ok41.msh");
    std::fs::write(&path, MSH41).unwrap();
    assert_eq!(read_gmsh(&path).unwrap().mesh.tet_count(), 1);
    // Truncated inside the node coordinates.
    expect_parse_error("trunc41.msh", &MSH41.as_bytes()[..70], r, 11, "node");
    // Non-numeric coordinate.
    let nn = MSH41.replace("0 1 0\n", "0 x 0\n");
    expect_parse_error("nan41.msh", nn.as_bytes(), r, 13, "node");
    // Bad index: the tet refers to node tag 9; the error names the tet's own line (issue 15).
    let bad = MSH41.replace("1 1 2 3 4\n", "1 1 2 3 9\n");
    expect_parse_error("index41.msh", bad.as_bytes(), r, 19, "node tag 9");
    // Wrong count: the block announces 2 elements but holds one.
    let wrong = MSH41.replace("3 1 4 1\n", "3 1 4 2\n");
    let path = tmp("count41.msh");
    std::fs::write(&path, wrong).unwrap();
    assert!(matches!(read_gmsh(&path), Err(Error::Parse { line, .. }) if line >= 18));
    // Version 4.0 is not read.
    let v = MSH41.replace("4.1 0 8", "4 0 8");
    expect_parse_error("v40.msh", v.as_bytes(), r, 2, "unsupported MSH version 4");
}

const NODE: &str =
    "# comment\n4 3 0 1\n1 0 0 0 5\n2 1 0 0 0\n3 0 1 0 0 # trailing comment\n4 0 0 1 5\n";
const ELE: &str = "1 4 0\n1 1 2 3 4\n";

fn tetgen_case(name: &str, node: &str, ele: &str) -> PathBuf {
    let prefix = tmp(name);
    std::fs::write(prefix.with_extension("node"), node).unwrap();
    std::fs::write(prefix.with_extension("ele"), ele).unwrap();
    prefix
}

fn expect_tetgen_error(name: &str, node: &str, ele: &str, file: &str, line: usize, needle: &str) {
    let prefix = tetgen_case(name, node, ele);
    match read_tetgen(&prefix) {
        Err(Error::Parse {
            path,
            line: l,
            message,
        }) => {
            assert_eq!(path, prefix.with_extension(file), "{name}");
            assert_eq!(l, line, "{name}: '{message}'");
            assert!(
                message.contains(needle),
                "{name}: '{message}' lacks '{needle}'"
            );
        }
        other => panic!("{name}: expected a parse error, got {other:?}"),
    }
}

#[test]
fn tetgen_one_based_with_markers_and_comments() {
    let m = read_tetgen(&tetgen_case("ok_tg", NODE, ELE)).unwrap();
    assert_eq!(m.node_markers, Some(vec![5, 0, 0, 5]));
    assert_eq!(m.nodes_with_marker(5), vec![0, 3]);
    assert_eq!(m.mesh.tets(), &[[0, 1, 2, 3]]);
}

/// Issue 33: a `<prefix>.edge` file beside the mesh was ignored without a word. It is still
/// not read (no selection or load acts on edges), and its rows are counted as skipped, as a
/// Gmsh file's line elements are; node markers match by equality (TetGen's markers are labels:
/// marker 5 does not select a node marked 1 or 4, whatever their bits).
#[test]
fn a_tetgen_edge_file_is_counted_as_skipped() {
    let prefix = tetgen_case("edges_tg", NODE, ELE);
    // A previous run's .edge file would be read as this one's.
    let _ = std::fs::remove_file(prefix.with_extension("edge"));
    let without = read_tetgen(&prefix).unwrap();
    assert!(!without.skipped_elements.contains_key(SKIPPED_EDGES));
    std::fs::write(
        prefix.with_extension("edge"),
        "# edges\n3 1\n1 1 2 5\n2 2 3 0\n\n3 1 4 5\n",
    )
    .unwrap();
    let with = read_tetgen(&prefix).unwrap();
    assert_eq!(with.skipped_elements.get(SKIPPED_EDGES), Some(&3));
    assert_eq!(with.mesh, without.mesh);
    let marked = NODE
        .replace("2 1 0 0 0", "2 1 0 0 1")
        .replace("3 0 1 0 0", "3 0 1 0 4");
    let m = read_tetgen(&tetgen_case("bits_tg", &marked, ELE)).unwrap();
    assert_eq!(m.nodes_with_marker(5), vec![0, 3]);
    assert_eq!(m.nodes_with_marker(1), vec![1]);
    assert_eq!(m.nodes_with_marker(4), vec![2]);
}

#[test]
fn malformed_tetgen_files_name_file_and_line() {
    let cut = NODE.find("4 0 0 1 5").unwrap();
    expect_tetgen_error("tg_trunc", &NODE[..cut], ELE, "node", 6, "truncated");
    let wrong = NODE.replace("4 3 0 1", "3 3 0 1");
    expect_tetgen_error("tg_count", &wrong, ELE, "node", 6, "more points");
    let bad = ELE.replace("1 2 3 4", "1 2 3 7");
    expect_tetgen_error("tg_index", NODE, &bad, "ele", 2, "node index 7");
    let base = NODE.replace("1 0 0 0 5", "2 0 0 0 5");
    expect_tetgen_error("tg_base", &base, ELE, "node", 3, "must be 0 or 1");
    let dim = NODE.replace("4 3 0 1", "4 2 0 1");
    expect_tetgen_error("tg_dim", &dim, ELE, "node", 2, "only 3-D");
    let nn = NODE.replace("2 1 0 0 0", "2 1 0 zero 0");
    expect_tetgen_error("tg_nan", &nn, ELE, "node", 4, "'zero'");
    let inf = NODE.replace("2 1 0 0 0", "2 inf 0 0 0");
    expect_tetgen_error("tg_inf", &inf, ELE, "node", 4, "not finite");
    let seq = ELE.replace("1 1 2 3 4", "3 1 2 3 4");
    expect_tetgen_error("tg_seq", NODE, &seq, "ele", 2, "out of sequence");
    let neg = ELE.replace("1 2 3 4", "1 2 -3 4");
    expect_tetgen_error("tg_neg", NODE, &neg, "ele", 2, "node index");
}

#[test]
fn missing_files_are_io_errors() {
    assert!(matches!(
        read_gmsh(&tmp("does_not_exist.msh")),
        Err(Error::Io { .. })
    ));
    assert!(matches!(
        read_mesh(&tmp("mesh.stl")),
        Err(Error::Parse { .. })
    ));
}

#[test]
fn absurd_counts_are_errors_not_aborts() {
    // A header that announces 10¹² nodes must not make a reader reserve that much memory.
    let r = read_gmsh as fn(&Path) -> _;
    let huge41 = MSH41.replace("3 1 0 4\n", "3 1 0 1000000000000\n");
    let path = tmp("huge41.msh");
    std::fs::write(&path, huge41).unwrap();
    assert!(matches!(read_gmsh(&path), Err(Error::Parse { .. })));
    let huge22 = MSH22.replace("$Nodes\n4\n", "$Nodes\n1000000000000\n");
    expect_parse_error("huge22.msh", huge22.as_bytes(), r, 10, "");
    let node = NODE.replace("4 3 0 1", "1000000000000 3 0 1");
    expect_tetgen_error("tg_huge", &node, ELE, "node", 7, "truncated");
}
