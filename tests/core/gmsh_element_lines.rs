//! Issue 15 item 1, last part: an MSH 4.1 element that names a node tag no node has is an error
//! at the element's own line (ASCII), or at the line count up to the element's byte offset
//! (binary), not at the `$Elements` line; duplicate node tags name the duplicate's line in both
//! encodings.

use std::path::{Path, PathBuf};

use tetfem::Error;
use tetfem::mesh::io::read_gmsh;

fn tmp(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("gmsh_element_lines");
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

fn parse_error(name: &str, content: &[u8]) -> (usize, String) {
    let path = tmp(name);
    std::fs::write(&path, content).unwrap();
    match read_gmsh(&path) {
        Err(Error::Parse { line, message, .. }) => (line, message),
        other => panic!("{name}: expected a parse error, got {other:?}"),
    }
}

/// 1-based line of the first line of `text` that equals `wanted`.
fn line_of(text: &str, wanted: &str) -> usize {
    1 + text.lines().position(|l| l == wanted).unwrap()
}

/// Two unit-corner tets sharing a face (nodes 1–5), a triangle block before them, element tags
/// that also occur as node tags and coordinates elsewhere in the file (so a search for the tag
/// text alone would find the wrong line).
fn ascii(tet_block: &str) -> String {
    format!(
        "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Nodes\n1 5 1 5\n3 1 0 5\n1\n2\n3\n4\n5\n\
         0 0 0\n1 0 0\n0 1 0\n0 0 1\n1 1 1\n$EndNodes\n$Elements\n2 4 1 4\n\
         2 1 2 2\n1 1 2 3\n2 2 3 4\n3 1 4 2\n{tet_block}$EndElements\n"
    )
}

#[test]
fn ascii_missing_tag_names_the_elements_own_line() {
    let good = ascii("3 1 2 3 4\n4 2 3 4 5\n");
    let path = tmp("good.msh");
    std::fs::write(&path, &good).unwrap();
    assert_eq!(read_gmsh(&path).unwrap().mesh.tet_count(), 2);
    // The second tet (tag 4) names node 9; its line is the last element line.
    let bad = ascii("3 1 2 3 4\n4 2 3 4 9\n");
    let (line, message) = parse_error("missing_second.msh", bad.as_bytes());
    let expected = line_of(&bad, "4 2 3 4 9");
    // Before this change the error named the $Elements line.
    assert_ne!(expected, line_of(&bad, "$Elements"));
    assert_eq!(line, expected, "{message}");
    assert!(
        message.contains("element 4") && message.contains("node tag 9"),
        "{message}"
    );
    // The first tet of the block (tag 3, naming node 9), and a triangle of the first block (tag 2).
    let bad = ascii("3 1 2 3 9\n4 2 3 4 5\n");
    let (line, message) = parse_error("missing_first.msh", bad.as_bytes());
    assert_eq!(line, line_of(&bad, "3 1 2 3 9"), "{message}");
    let bad = ascii("3 1 2 3 4\n4 2 3 4 5\n").replace("2 2 3 4\n", "2 2 3 7\n");
    let (line, message) = parse_error("missing_triangle.msh", bad.as_bytes());
    assert_eq!(line, line_of(&bad, "2 2 3 7"), "{message}");
    assert!(message.contains("node tag 7"), "{message}");
    // Extra blank space and several elements on one line are still tokens of the same section:
    // the line of the element's tag is named.
    let bad =
        ascii("3 1 2 3 4\n\n   4 2 3 4 9\n").replace("1 1 2 3\n2 2 3 4\n", "1 1 2 3 2 2 3 4\n");
    let (line, message) = parse_error("spacing.msh", bad.as_bytes());
    assert_eq!(line, line_of(&bad, "   4 2 3 4 9"), "{message}");
}

/// The same mesh in binary MSH 4.1 (little-endian, 8-byte size_t), with node tags listed as
/// `tags` and the tet block's node tags as `tets`.
fn binary(tags: &[u64], tets: &[[u64; 4]]) -> (Vec<u8>, Vec<usize>) {
    let mut b = b"$MeshFormat\n4.1 1 8\n".to_vec();
    b.extend(1i32.to_le_bytes());
    b.extend(b"\n$EndMeshFormat\n$Nodes\n");
    let size_t = |b: &mut Vec<u8>, v: u64| b.extend(v.to_le_bytes());
    let int = |b: &mut Vec<u8>, v: i32| b.extend(v.to_le_bytes());
    let n = tags.len() as u64;
    for v in [1, n, 1, n.max(*tags.iter().max().unwrap())] {
        size_t(&mut b, v);
    }
    int(&mut b, 3);
    int(&mut b, 1);
    int(&mut b, 0);
    size_t(&mut b, n);
    let mut tag_offsets = Vec::new();
    for &t in tags {
        tag_offsets.push(b.len());
        size_t(&mut b, t);
    }
    let points = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 1.0],
    ];
    for k in 0..tags.len() {
        let p: [f64; 3] = points.get(k).copied().unwrap_or([1.0, 1.0, 1.0 + k as f64]);
        for c in p {
            b.extend(c.to_le_bytes());
        }
    }
    b.extend(b"\n$EndNodes\n$Elements\n");
    let m = tets.len() as u64;
    for v in [1, m, 1, m] {
        size_t(&mut b, v);
    }
    int(&mut b, 3);
    int(&mut b, 1);
    int(&mut b, 4);
    size_t(&mut b, m);
    let mut offsets = Vec::new();
    for (t, tet) in tets.iter().enumerate() {
        offsets.push(b.len());
        size_t(&mut b, t as u64 + 1);
        for &v in tet {
            size_t(&mut b, v);
        }
    }
    b.extend(b"\n$EndElements\n");
    // Return the element offsets, then the node tag offsets.
    offsets.extend(tag_offsets);
    (b, offsets)
}

/// 1 + the newlines before `offset`: the line a binary position is reported at.
fn binary_line(bytes: &[u8], offset: usize) -> usize {
    1 + bytes[..offset].iter().filter(|&&b| b == b'\n').count()
}

#[test]
fn binary_missing_tag_names_the_line_count_at_the_elements_offset() {
    // Node tag 10 is the byte 0x0A, a newline: the element data before the last tet holds two of
    // them, so the last tet's line count differs from the $Elements line's and from the line
    // after it.
    let tags: Vec<u64> = (1..=10).collect();
    let good = [[1, 2, 3, 4], [2, 3, 4, 10], [4, 3, 10, 2]];
    let (bytes, _) = binary(&tags, &good);
    let path = tmp("good_binary.msh");
    std::fs::write(&path, &bytes).unwrap();
    assert_eq!(read_gmsh(&path).unwrap().mesh.tet_count(), 3);
    let bad = [[1, 2, 3, 4], [2, 3, 4, 10], [4, 3, 10, 2], [1, 2, 3, 99]];
    let (bytes, offsets) = binary(&tags, &bad);
    let expected = binary_line(&bytes, offsets[3]);
    let elements_line = 1 + bytes
        .split(|&b| b == b'\n')
        .position(|l| l == b"$Elements")
        .unwrap();
    // The two 0x0A tags in the elements before it (and none in the section header).
    assert_eq!(expected, elements_line + 1 + 2);
    let (line, message) = parse_error("missing_binary.msh", &bytes);
    assert_eq!(line, expected, "{message}");
    assert!(
        message.contains("element 4") && message.contains("node tag 99"),
        "{message}"
    );
}

#[test]
fn binary_duplicate_node_tag_names_the_duplicates_line() {
    // Tags 1, 10, 3, 10: the second 10 is the duplicate; the first 10 is itself a newline byte,
    // so the duplicate's line count is one past the first's.
    let tags = [1, 10, 3, 10];
    let (bytes, offsets) = binary(&tags, &[[1, 10, 3, 4]]);
    let (line, message) = parse_error("dup_binary.msh", &bytes);
    let (first, second) = (offsets[1 + 1], offsets[1 + 3]);
    assert_eq!(line, binary_line(&bytes, second), "{message}");
    assert!(
        message.contains("node tag 10 appears twice")
            && message.contains(&format!("first on line {}", binary_line(&bytes, first))),
        "{message}"
    );
}

/// Measurement (run with `--ignored --nocapture`): reading an ASCII MSH 4.1 box of 40³ cells
/// (68 921 nodes, 384 000 tets). The node-tag reader counted the lines from the file's start
/// for every tag (O(nodes × file size)); it now counts them incrementally.
#[test]
#[ignore]
fn reading_a_large_msh41_file() {
    use nalgebra::Vector3;
    use tetfem::{BoxSplit, TetMesh};
    let mesh = TetMesh::box_grid(
        Vector3::zeros(),
        Vector3::new(1.0, 1.0, 1.0),
        [40, 40, 40],
        BoxSplit::Mirrored6,
    )
    .unwrap();
    let path = tmp("large41.msh");
    tetfem::mesh::io::write_gmsh(&path, &mesh, &[]).unwrap();
    let started = std::time::Instant::now();
    let read = read_gmsh(&path).unwrap();
    println!(
        "{} nodes, {} tets, {:.1} MB: read in {:.3} s",
        read.mesh.node_count(),
        read.mesh.tet_count(),
        std::fs::metadata(&path).unwrap().len() as f64 / 1e6,
        started.elapsed().as_secs_f64()
    );
    assert_eq!(read.mesh.tet_count(), mesh.tet_count());
}

/// Issue 33: a file cut before `$EndElements` was reported as mshio's "Tag" (the next tag it
/// expected) at the file's end; the message now says what is missing.
#[test]
fn a_missing_end_elements_is_named() {
    let full = ascii("3 1 2 3 4\n4 2 3 4 5\n");
    let cut = full.replace("$EndElements\n", "");
    let (line, message) = parse_error("no_end.msh", cut.as_bytes());
    assert_eq!(line, cut.lines().count(), "{message}");
    assert!(
        message.contains("$EndElements") && message.contains("truncated"),
        "{message}"
    );
    // A block announcing more elements than it has runs into the end marker: named there.
    let short = full.replace("3 1 4 2\n", "3 1 4 3\n");
    let (line, message) = parse_error("short_block.msh", short.as_bytes());
    assert_eq!(line, line_of(&short, "$EndElements"), "{message}");
    assert!(message.contains("announces 3 elements"), "{message}");
}

/// Issue 33: the only tet of a file repeating a node left 3 used nodes, reported as "empty
/// mesh: 3 nodes and 1 tetrahedra"; the tet and its line are named instead.
#[test]
fn a_tet_with_a_repeated_node_is_named_at_its_line() {
    let text = "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n4\n1 0 0 0\n2 1 0 0\n3 0 1 0\n\
                4 0 0 1\n$EndNodes\n$Elements\n1\n7 4 2 1 1 1 2 3 3\n$EndElements\n";
    let (line, message) = parse_error("repeated.msh", text.as_bytes());
    assert_eq!(line, line_of(text, "7 4 2 1 1 1 2 3 3"), "{message}");
    assert!(
        message.contains("appears more than once") && !message.contains("empty mesh"),
        "{message}"
    );
}
