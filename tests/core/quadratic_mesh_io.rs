//! Quadratic (10-node) meshes from files: Gmsh type 11 tets with type 9 triangle groups (MSH 4.1
//! and 2.2) and TetGen `-o2` meshes, written here from the box generator's Tet10 meshes in each
//! format's own node order and read back — the same nodes and cells, the same solutions, the
//! same face sets — and malformed files, whose errors name the file and the line.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use nalgebra::Vector3;
use tetfem::mesh::BoundaryFace;
use tetfem::mesh::io::{
    ImportedMesh, TET10_KEPT_AS_CORNERS, mesh_file_order, parse_gmsh, parse_gmsh_as, read_gmsh,
    read_gmsh_as, read_tetgen, read_tetgen_as,
};
use tetfem::{BoxSplit, Constraints, Error, Loads, Material, Tet10, TetMesh, solve_static};

const SPLITS: [BoxSplit; 3] = [BoxSplit::Lecture6, BoxSplit::Mirrored6, BoxSplit::Five];

/// Gmsh's node k of a 10-node tet is VTK's node `VTK_OF_GMSH[k]`: Gmsh's edges are (0,1),
/// (1,2), (2,0), (3,0), (3,2), (3,1) (`MTetrahedron::edges_tetra`), VTK's (0,1), (1,2), (0,2),
/// (0,3), (1,3), (2,3).
const VTK_OF_GMSH: [usize; 10] = [0, 1, 2, 3, 4, 5, 6, 7, 9, 8];

/// TetGen's extra node k of an `-o2` tet sits on its edge `TETGEN_EDGES[k]` (`edge2ver` with
/// `orgpivot`/`destpivot` of tetgen.cxx: versions 0, 1, 2, 3, 8, 5).
const TETGEN_EDGES: [(usize, usize); 6] = [(2, 3), (0, 3), (0, 1), (1, 2), (1, 3), (0, 2)];

fn tmp(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("tetfem_quadratic_io_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

/// The 10-node cantilever-like box (2 × 1 × 1 on 3 × 2 × 2 cells) of `split`.
fn box_mesh(split: BoxSplit) -> TetMesh<Tet10> {
    let linear = TetMesh::box_grid(
        Vector3::zeros(),
        Vector3::new(2.0, 1.0, 1.0),
        [3, 2, 2],
        split,
    )
    .unwrap();
    TetMesh::<Tet10>::from_linear(&linear).unwrap()
}

/// The 6-node boundary faces of `mesh` whose corners lie on x = `at`: corners, then the edge
/// nodes of (0,1), (1,2), (2,0) (Gmsh's triangle order).
fn tri6_on_plane(mesh: &TetMesh<Tet10>, at: f64) -> Vec<[usize; 6]> {
    let boundary = mesh.boundary_faces().unwrap();
    boundary
        .iter()
        .filter(|f| {
            f.nodes
                .iter()
                .all(|&n| (mesh.nodes()[n].x - at).abs() < 1e-12)
        })
        .map(|f| {
            let cell = &mesh.tets()[f.tet];
            let edge = |a: usize, b: usize| {
                let (la, lb) = (local(cell, a), local(cell, b));
                <Tet10 as tetfem::CellType>::edge_node(cell, la, lb).unwrap()
            };
            let [a, b, c] = f.nodes;
            [a, b, c, edge(a, b), edge(b, c), edge(c, a)]
        })
        .collect()
}

fn local(cell: &[usize; 10], node: usize) -> usize {
    cell[..4].iter().position(|&n| n == node).unwrap()
}

/// The file position of each mesh node: the nodes are written in reverse, so that reading
/// renumbers them (node i has tag n − i).
fn tag_of(n: usize, count: usize) -> usize {
    count - n
}

/// A tet's 10 nodes as written: every other tet with corners 1 and 2 swapped (negatively
/// oriented, which the reader must turn back), in VTK order.
fn written_cell(t: usize, cell: &[usize; 10]) -> [usize; 10] {
    let mut c = *cell;
    if t % 2 == 1 {
        <Tet10 as tetfem::CellType>::swap_corners_1_2(&mut c);
    }
    c
}

/// MSH 4.1 ASCII: one volume entity (physical 1 "body") with all tets as type 11, a surface
/// entity per group of 6-node triangles (type 9).
fn msh41(mesh: &TetMesh<Tet10>, groups: &[(i32, &str, Vec<[usize; 6]>)]) -> String {
    let n = mesh.node_count();
    let mut s = String::from("$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$PhysicalNames\n");
    writeln!(s, "{}", groups.len() + 1).unwrap();
    for (tag, name, _) in groups {
        writeln!(s, "2 {tag} \"{name}\"").unwrap();
    }
    s += "3 1 \"body\"\n$EndPhysicalNames\n$Entities\n";
    writeln!(s, "0 0 {} 1", groups.len()).unwrap();
    for (i, (tag, _, _)) in groups.iter().enumerate() {
        writeln!(s, "{} 0 0 0 2 1 1 1 {tag} 0", i + 1).unwrap();
    }
    s += "1 0 0 0 2 1 1 1 1 0\n$EndEntities\n";
    writeln!(s, "$Nodes\n1 {n} 1 {n}\n3 1 0 {n}").unwrap();
    for k in 1..=n {
        writeln!(s, "{k}").unwrap();
    }
    for k in 1..=n {
        let p = mesh.nodes()[n - k];
        writeln!(s, "{} {} {}", p.x, p.y, p.z).unwrap();
    }
    s += "$EndNodes\n";
    let triangles: usize = groups.iter().map(|g| g.2.len()).sum();
    let total = mesh.tet_count() + triangles;
    writeln!(s, "$Elements\n{} {total} 1 {total}", groups.len() + 1).unwrap();
    writeln!(s, "3 1 11 {}", mesh.tet_count()).unwrap();
    let mut tag = 0;
    for (t, cell) in mesh.tets().iter().enumerate() {
        tag += 1;
        let c = written_cell(t, cell);
        write!(s, "{tag}").unwrap();
        for k in VTK_OF_GMSH {
            write!(s, " {}", tag_of(c[k], n)).unwrap();
        }
        s += "\n";
    }
    for (i, (_, _, tris)) in groups.iter().enumerate() {
        writeln!(s, "2 {} 9 {}", i + 1, tris.len()).unwrap();
        for t in tris {
            tag += 1;
            write!(s, "{tag}").unwrap();
            for &v in t {
                write!(s, " {}", tag_of(v, n)).unwrap();
            }
            s += "\n";
        }
    }
    s + "$EndElements\n"
}

/// MSH 2.2 ASCII of the same mesh and groups.
fn msh22(mesh: &TetMesh<Tet10>, groups: &[(i32, &str, Vec<[usize; 6]>)]) -> String {
    let n = mesh.node_count();
    let mut s = String::from("$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$PhysicalNames\n");
    writeln!(s, "{}", groups.len() + 1).unwrap();
    for (tag, name, _) in groups {
        writeln!(s, "2 {tag} \"{name}\"").unwrap();
    }
    s += "3 1 \"body\"\n$EndPhysicalNames\n$Nodes\n";
    writeln!(s, "{n}").unwrap();
    for k in 1..=n {
        let p = mesh.nodes()[n - k];
        writeln!(s, "{k} {} {} {}", p.x, p.y, p.z).unwrap();
    }
    s += "$EndNodes\n$Elements\n";
    let triangles: usize = groups.iter().map(|g| g.2.len()).sum();
    writeln!(s, "{}", mesh.tet_count() + triangles).unwrap();
    let mut tag = 0;
    for (t, cell) in mesh.tets().iter().enumerate() {
        tag += 1;
        let c = written_cell(t, cell);
        write!(s, "{tag} 11 2 1 1").unwrap();
        for k in VTK_OF_GMSH {
            write!(s, " {}", tag_of(c[k], n)).unwrap();
        }
        s += "\n";
    }
    for (g, _, tris) in groups {
        for t in tris {
            tag += 1;
            write!(s, "{tag} 9 2 {g} {g}").unwrap();
            for &v in t {
                write!(s, " {}", tag_of(v, n)).unwrap();
            }
            s += "\n";
        }
    }
    s + "$EndElements\n"
}

/// The generated mesh's node of each imported node (through the file's tags).
fn original_nodes<C: tetfem::CellType>(imported: &ImportedMesh<C>) -> Vec<usize> {
    let n = imported.mesh.node_count();
    imported
        .node_ids
        .iter()
        .map(|&tag| n - tag as usize)
        .collect()
}

/// Asserts that `imported` is `generated` up to the node renumbering: the same positions and,
/// node for node, the same cells (corners and every edge node in its slot).
fn assert_same_mesh(generated: &TetMesh<Tet10>, imported: &ImportedMesh<Tet10>, what: &str) {
    let original = original_nodes(imported);
    assert_eq!(imported.mesh.node_count(), generated.node_count(), "{what}");
    assert_eq!(imported.mesh.tet_count(), generated.tet_count(), "{what}");
    for (i, p) in imported.mesh.nodes().iter().enumerate() {
        assert_eq!(*p, generated.nodes()[original[i]], "{what}: node {i}");
    }
    for (t, cell) in imported.mesh.tets().iter().enumerate() {
        assert_eq!(
            cell.map(|n| original[n]),
            generated.tets()[t],
            "{what}: tet {t}"
        );
    }
    assert_eq!(
        imported.mesh.reoriented_count(),
        generated.tet_count() / 2,
        "{what}"
    );
}

/// The cantilever on `mesh`: clamped on `clamp`, 1 N down over `tip` faces; the solution.
fn cantilever(mesh: &TetMesh<Tet10>, clamp: &[usize], tip: &[BoundaryFace]) -> Vec<f64> {
    let material = Material::new(1e5, 0.3, 1000.0).unwrap();
    let mut constraints = Constraints::new(mesh);
    constraints.fix_axes(clamp, [true; 3]).unwrap();
    let mut loads = Loads::new(mesh);
    loads
        .add_total_force_on_faces(mesh, tip, Vector3::new(0.0, 0.0, -1.0))
        .unwrap();
    solve_static(mesh, &material, &constraints, &loads)
        .unwrap()
        .displacement
}

fn generated_sets(mesh: &TetMesh<Tet10>) -> (Vec<usize>, Vec<BoundaryFace>) {
    let clamp = mesh.try_nodes_on_plane(0, 0.0, 1e-9).unwrap();
    let tip_nodes = mesh.try_nodes_on_plane(0, 2.0, 1e-9).unwrap();
    let tip = mesh
        .boundary_faces()
        .unwrap()
        .into_iter()
        .filter(|f| f.nodes.iter().all(|n| tip_nodes.binary_search(n).is_ok()))
        .collect();
    (clamp, tip)
}

#[test]
fn gmsh_tet10_files_read_back_as_the_generated_mesh_and_solve_the_same() {
    for split in SPLITS {
        let mesh = box_mesh(split);
        let groups = vec![
            (11, "clamp", tri6_on_plane(&mesh, 0.0)),
            (12, "tip", tri6_on_plane(&mesh, 2.0)),
        ];
        let (clamp, tip) = generated_sets(&mesh);
        let expected = cantilever(&mesh, &clamp, &tip);
        let scale = expected.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        for (format, text) in [
            ("4.1", msh41(&mesh, &groups)),
            ("2.2", msh22(&mesh, &groups)),
        ] {
            let what = format!("{split:?} MSH {format}");
            let path = tmp(&format!("box_{split:?}_{format}.msh"));
            std::fs::write(&path, &text).unwrap();
            assert_eq!(mesh_file_order(&path).unwrap(), 2, "{what}");
            let imported = read_gmsh_as::<Tet10>(&path).unwrap();
            assert_same_mesh(&mesh, &imported, &what);
            assert!(imported.skipped_elements.is_empty(), "{what}");
            let original = original_nodes(&imported);
            // The 6-node groups: their nodes are the generated planes' nodes (edge nodes
            // included), their faces the generated faces.
            let boundary = imported.mesh.boundary_faces().unwrap();
            let group_clamp = imported.group("clamp").unwrap();
            let mut mapped: Vec<usize> = group_clamp.nodes.iter().map(|&n| original[n]).collect();
            mapped.sort_unstable();
            assert_eq!(mapped, clamp, "{what}: clamp nodes");
            let tip_faces = imported.group("tip").unwrap().boundary_faces(&boundary);
            let mut mapped: Vec<[usize; 3]> = tip_faces
                .iter()
                .map(|f| {
                    let mut k = f.nodes.map(|n| original[n]);
                    k.sort_unstable();
                    k
                })
                .collect();
            mapped.sort_unstable();
            let mut want: Vec<[usize; 3]> = tip
                .iter()
                .map(|f| {
                    let mut k = f.nodes;
                    k.sort_unstable();
                    k
                })
                .collect();
            want.sort_unstable();
            assert_eq!(mapped, want, "{what}: tip faces");
            // The same problem through the file's sets: the same displacement at every node
            // (the same equations in another node order: round-off of the solve only).
            let u = cantilever(&imported.mesh, &group_clamp.nodes, &tip_faces);
            let mut worst: f64 = 0.0;
            for (i, &o) in original.iter().enumerate() {
                for a in 0..3 {
                    worst = worst.max((u[3 * i + a] - expected[3 * o + a]).abs());
                }
            }
            eprintln!(
                "{what}: largest difference / largest displacement {:.2e}",
                worst / scale
            );
            // 1e-12 relative: a direct solve of the same K in another ordering differs by
            // round-off (κ ~ 1e4 here times ε), far below any modelling difference.
            assert!(worst <= 1e-12 * scale, "{what}: {worst:e} of {scale:e}");
        }
    }
}

/// The displacement field of the quadratic patch test and its constant body force (as in
/// tests/core/tet10.rs: u quadratic, σ linear, b = −∇·σ).
fn quadratic_field(x: &Vector3<f64>) -> Vector3<f64> {
    Vector3::new(
        1e-3 * (x.x * x.x + 0.5 * x.y * x.z - 0.3 * x.z),
        1e-3 * (0.7 * x.x * x.y - 0.2 * x.z * x.z + 0.1),
        1e-3 * (0.4 * x.y * x.y + 0.6 * x.x * x.z + 0.2 * x.x),
    )
}

#[test]
fn quadratic_patch_test_passes_on_imported_meshes() {
    let material = Material::new(200e9, 0.3, 7850.0).unwrap();
    // ∇·σ = (λ + μ)∇(∇·u) + μΔu with ∇(∇·u) = (3.3, 0, 0)·1e-3, Δu = (2, −0.4, 0.8)·1e-3.
    let (l, m) = (material.lame_lambda(), material.shear_modulus());
    let body =
        -(Vector3::new(3.3e-3, 0.0, 0.0) * (l + m) + Vector3::new(2e-3, -0.4e-3, 0.8e-3) * m);
    for split in SPLITS {
        // Interior corners moved off the grid (edge nodes stay at the new midpoints).
        let linear = TetMesh::box_grid(
            Vector3::zeros(),
            Vector3::new(2.0, 1.0, 1.0),
            [3, 2, 2],
            split,
        )
        .unwrap();
        let (lo, hi) = linear.bounding_box();
        let moved: Vec<Vector3<f64>> = linear
            .nodes()
            .iter()
            .enumerate()
            .map(|(n, p)| {
                let inside = (0..3).all(|a| p[a] > lo[a] + 1e-12 && p[a] < hi[a] - 1e-12);
                let k = n as f64;
                let shift = Vector3::new((1.7 * k).sin(), (2.3 * k).cos(), (0.9 * k).sin());
                if inside { p + shift * 0.08 } else { *p }
            })
            .collect();
        let mesh = TetMesh::<Tet10>::from_linear(&linear.with_nodes(moved).unwrap()).unwrap();
        for (format, text) in [("4.1", msh41(&mesh, &[])), ("2.2", msh22(&mesh, &[]))] {
            let imported = parse_gmsh_as::<Tet10>(Path::new("patch.msh"), text.as_bytes()).unwrap();
            let mesh = &imported.mesh;
            let on_boundary = |p: &Vector3<f64>| {
                (0..3).any(|a| (p[a] - lo[a]).abs() < 1e-12 || (p[a] - hi[a]).abs() < 1e-12)
            };
            let mut constraints = Constraints::new(mesh);
            for (n, p) in mesh.nodes().iter().enumerate() {
                if on_boundary(p) {
                    constraints.prescribe(n, quadratic_field(p)).unwrap();
                }
            }
            let mut loads = Loads::new(mesh);
            loads.add_body_force(mesh, body).unwrap();
            let u = solve_static(mesh, &material, &constraints, &loads)
                .unwrap()
                .displacement;
            let (mut worst, mut largest) = (0.0f64, 0.0f64);
            for (n, p) in mesh.nodes().iter().enumerate() {
                let exact = quadratic_field(p);
                for a in 0..3 {
                    worst = worst.max((u[3 * n + a] - exact[a]).abs());
                    largest = largest.max(exact[a].abs());
                }
            }
            eprintln!(
                "{split:?} MSH {format}: patch error {:.2e}",
                worst / largest
            );
            // Exact up to round-off (κ(K)·ε with κ ~ 1e3); a wrong edge-node order would put
            // the P2 field's nodal values on the wrong nodes and miss by O(1).
            assert!(worst < 1e-10 * largest, "{split:?} {format}: {worst:e}");
        }
    }
}

/// `<prefix>.node`, `.ele` (10 nodes per tet in TetGen's order, a region attribute per tet:
/// 1 for x < 1, else 2) and `.face` (the 6-node boundary triangles, marker 3 on x = 0, 4 on
/// x = 2, 1 elsewhere; with `edge_columns` the three edge nodes after the corners, as TetGen
/// ≥ 1.5 writes them, in the order of its boundary faces: (0,1), (1,2), (2,0)).
fn write_tetgen_o2(prefix: &Path, mesh: &TetMesh<Tet10>, edge_columns: bool) {
    let n = mesh.node_count();
    let mut node = format!("{n} 3 0 0\n");
    for k in 1..=n {
        let p = mesh.nodes()[n - k];
        writeln!(node, "{k} {} {} {}", p.x, p.y, p.z).unwrap();
    }
    let mut ele = format!("{} 10 1\n", mesh.tet_count());
    for (t, cell) in mesh.tets().iter().enumerate() {
        let c = written_cell(t, cell);
        write!(ele, "{}", t + 1).unwrap();
        for &v in &c[..4] {
            write!(ele, " {}", tag_of(v, n)).unwrap();
        }
        for (a, b) in TETGEN_EDGES {
            let e = <Tet10 as tetfem::CellType>::edge_node(&c, a, b).unwrap();
            write!(ele, " {}", tag_of(e, n)).unwrap();
        }
        let centroid_x: f64 = c[..4].iter().map(|&v| mesh.nodes()[v].x).sum::<f64>() / 4.0;
        writeln!(ele, " {}", if centroid_x < 1.0 { 1 } else { 2 }).unwrap();
    }
    let faces: Vec<[usize; 6]> = {
        let mut all = tri6_on_plane(mesh, 0.0);
        all.extend(tri6_on_plane(mesh, 2.0));
        all
    };
    let mut face = format!("{} 1\n", faces.len());
    for (i, f) in faces.iter().enumerate() {
        let marker = if mesh.nodes()[f[0]].x == 0.0 { 3 } else { 4 };
        write!(face, "{}", i + 1).unwrap();
        let columns = if edge_columns { 6 } else { 3 };
        for &v in &f[..columns] {
            write!(face, " {}", tag_of(v, n)).unwrap();
        }
        writeln!(face, " {marker}").unwrap();
    }
    let with = |ext: &str| PathBuf::from(format!("{}.{ext}", prefix.display()));
    std::fs::write(with("node"), node).unwrap();
    std::fs::write(with("ele"), ele).unwrap();
    std::fs::write(with("face"), face).unwrap();
}

#[test]
fn tetgen_o2_meshes_read_back_with_face_markers_and_regions() {
    for split in SPLITS {
        let mesh = box_mesh(split);
        let (clamp, tip) = generated_sets(&mesh);
        let expected = cantilever(&mesh, &clamp, &tip);
        let scale = expected.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        for edge_columns in [true, false] {
            let what = format!("{split:?} TetGen -o2, .face edge columns {edge_columns}");
            let prefix = tmp(&format!("o2_{split:?}_{edge_columns}"));
            write_tetgen_o2(&prefix, &mesh, edge_columns);
            assert_eq!(
                mesh_file_order(&PathBuf::from(format!("{}.ele", prefix.display()))).unwrap(),
                2
            );
            let imported = read_tetgen_as::<Tet10>(&prefix).unwrap();
            assert_same_mesh(&mesh, &imported, &what);
            let original = original_nodes(&imported);
            // Region attributes: the tets of x < 1 carry 1.
            let attributes = imported.tet_attributes.as_ref().unwrap();
            for (t, &a) in attributes.iter().enumerate() {
                let x: f64 = mesh.tets()[t][..4].iter().map(|&v| mesh.nodes()[v].x).sum();
                assert_eq!(a, if x / 4.0 < 1.0 { 1.0 } else { 2.0 }, "{what}: tet {t}");
            }
            // Marker 3's nodes: every node of x = 0, edge nodes included (from the tets).
            let mut mapped: Vec<usize> = imported
                .nodes_with_face_marker(3)
                .iter()
                .map(|&n| original[n])
                .collect();
            mapped.sort_unstable();
            assert_eq!(mapped, clamp, "{what}: marker 3 nodes");
            let boundary = imported.mesh.boundary_faces().unwrap();
            let tip_faces = imported.faces_with_marker(4, &boundary);
            assert_eq!(tip_faces.len(), tip.len(), "{what}");
            let u = cantilever(
                &imported.mesh,
                &imported.nodes_with_face_marker(3),
                &tip_faces,
            );
            let mut worst: f64 = 0.0;
            for (i, &o) in original.iter().enumerate() {
                for a in 0..3 {
                    worst = worst.max((u[3 * i + a] - expected[3 * o + a]).abs());
                }
            }
            // As for Gmsh: the same equations in another node order.
            assert!(worst <= 1e-12 * scale, "{what}: {worst:e} of {scale:e}");
            // Read as 4-node tets: the corners, counted as kept.
            let corners = read_tetgen(&prefix).unwrap();
            assert_eq!(corners.mesh.tet_count(), mesh.tet_count(), "{what}");
            assert_eq!(
                corners.skipped_elements.get(TET10_KEPT_AS_CORNERS),
                Some(&mesh.tet_count()),
                "{what}"
            );
        }
    }
}

fn parse_error<C: tetfem::CellType>(name: &str, text: &str) -> (PathBuf, usize, String) {
    match parse_gmsh_as::<C>(Path::new(name), text.as_bytes()) {
        Err(Error::Parse {
            path,
            line,
            message,
        }) => (path, line, message),
        other => panic!("{name}: expected a parse error, got {other:?}"),
    }
}

/// The unit tet in Gmsh's order: corners (0,0,0), (1,0,0), (0,1,0), (0,0,1), then the
/// midpoints of (0,1), (1,2), (2,0), (3,0), (3,2), (3,1). Line 19 is the element.
const ONE_TET10_22: &str = "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n10\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n5 0.5 0 0\n6 0.5 0.5 0\n7 0 0.5 0\n8 0 0 0.5\n9 0 0.5 0.5\n10 0.5 0 0.5\n$EndNodes\n$Elements\n1\n1 11 2 1 1 1 2 3 4 5 6 7 8 9 10\n$EndElements\n";

#[test]
fn the_gmsh_node_order_is_the_documented_one() {
    // Written by hand from Gmsh's numbering (not by this file's writer): node 9 (Gmsh's 8) is
    // the midpoint of corners 3 and 4 (2,3), node 10 (Gmsh's 9) that of 2 and 4 (1,3).
    let imported = parse_gmsh_as::<Tet10>(Path::new("one.msh"), ONE_TET10_22.as_bytes()).unwrap();
    // In VTK order: corners, (0,1), (1,2), (0,2), (0,3), (1,3) = node 10, (2,3) = node 9.
    assert_eq!(imported.mesh.tets()[0], [0, 1, 2, 3, 4, 5, 6, 7, 9, 8]);
    // Taken as VTK's order the same file is off the midpoints: the swap is needed.
    let swapped = ONE_TET10_22.replace("7 8 9 10\n", "7 8 10 9\n");
    let (_, line, message) = parse_error::<Tet10>("swapped.msh", &swapped);
    assert_eq!(line, 19, "{message}");
    assert!(
        message.contains("edge node") && message.contains("tet 1"),
        "{message}"
    );
    // As 4-node tets: the corners, the edge nodes dropped.
    let corners = parse_gmsh(Path::new("one.msh"), ONE_TET10_22.as_bytes()).unwrap();
    assert_eq!(corners.mesh.tets(), &[[0, 1, 2, 3]]);
    assert_eq!(corners.unused_nodes, 6);
}

#[test]
fn malformed_quadratic_files_name_the_file_and_line() {
    // A curved edge: node 6 (on edge (1,2)) moved off the midpoint by 0.1 × √2 edge lengths
    // across the edge is a curved (isoparametric) tet, read with its node where the file puts it.
    let curved = ONE_TET10_22.replace("6 0.5 0.5 0\n", "6 0.6 0.6 0\n");
    let imported = parse_gmsh_as::<Tet10>(Path::new("curved.msh"), curved.as_bytes()).unwrap();
    assert_eq!(imported.mesh.nodes()[5], Vector3::new(0.6, 0.6, 0.0));
    // Moved 0.3 edge lengths along the edge toward corner 2 (Gmsh's node 2, local 1), the map
    // folds there: the element's line, the tet and the point named.
    let folded = ONE_TET10_22.replace("6 0.5 0.5 0\n", "6 0.8 0.2 0\n");
    let (path, line, message) = parse_error::<Tet10>("curved.msh", &folded);
    assert_eq!(path, PathBuf::from("curved.msh"));
    assert_eq!(line, 19, "{message}");
    assert!(
        message.contains("at node 1 ") && message.contains("Jacobian determinant"),
        "{message}"
    );
    // A 4-node tet after a 10-node one.
    let mixed = ONE_TET10_22
        .replace("$Elements\n1\n", "$Elements\n2\n")
        .replace("$EndElements", "2 4 2 1 1 1 2 3 4\n$EndElements");
    let (_, line, message) = parse_error::<Tet10>("mixed.msh", &mixed);
    assert_eq!(line, 20, "{message}");
    assert!(message.contains("mixes 4-node and 10-node"), "{message}");
    // A 6-node triangle whose mid-side node on (0,1) is not the tet's.
    let tri6 = ONE_TET10_22
        .replace("$Elements\n1\n", "$Elements\n2\n")
        .replace("$EndElements", "2 9 2 5 5 1 2 3 6 6 7\n$EndElements");
    let (_, line, message) = parse_error::<Tet10>("tri6.msh", &tri6);
    assert_eq!(line, 20, "{message}");
    assert!(
        message.contains("mid-side node 6") && message.contains("node 5"),
        "{message}"
    );
    // A linear file read as 10-node tets.
    let linear = "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n4\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n$EndNodes\n$Elements\n1\n1 4 2 1 1 1 2 3 4\n$EndElements\n";
    let (_, line, message) = parse_error::<Tet10>("linear.msh", linear);
    assert_eq!(line, 13, "{message}");
    assert!(message.contains("4-node (linear) tets"), "{message}");
    // MSH 4.1: the curved element's own line (found by reading the section).
    let mesh = box_mesh(BoxSplit::Five);
    // Tet 3's node of edge (1, 2) moved 0.3 edge lengths along its edge toward corner 1: every
    // tet holding that edge folds at that corner.
    let (a, b) = (mesh.tets()[3][1], mesh.tets()[3][2]);
    let moved: Vec<Vector3<f64>> = mesh
        .nodes()
        .iter()
        .enumerate()
        .map(|(n, p)| {
            if n == mesh.tets()[3][5] {
                p + (mesh.nodes()[a] - mesh.nodes()[b]) * 0.3
            } else {
                *p
            }
        })
        .collect();
    // from_cells would refuse it: write the nodes by hand.
    let text = msh41(&mesh, &[]);
    let node = mesh.tets()[3][5];
    let p = mesh.nodes()[node];
    let old = format!("\n{} {} {}\n", p.x, p.y, p.z);
    let q = moved[node];
    let new = format!("\n{} {} {}\n", q.x, q.y, q.z);
    assert_eq!(text.matches(&old).count(), 1);
    let text = text.replacen(&old, &new, 1);
    let (_, line, message) = parse_error::<Tet10>("curved41.msh", &text);
    // The element lines start after the nodes' 2n lines and the section headers: tet 3 (the
    // first tet using the node, found again from the file) sits at its line in the block.
    let first_user = mesh.tets().iter().position(|c| c.contains(&node)).unwrap();
    let elements_line = text.lines().position(|l| l == "$Elements").unwrap() + 1;
    assert_eq!(line, elements_line + 2 + first_user + 1, "{message}");
    assert!(message.contains("edge node"), "{message}");
}

#[test]
fn tetgen_o2_errors_name_the_file_and_line() {
    let mesh = box_mesh(BoxSplit::Five);
    let prefix = tmp("o2_errors");
    write_tetgen_o2(&prefix, &mesh, true);
    let ele_path = PathBuf::from(format!("{}.ele", prefix.display()));
    let face_path = PathBuf::from(format!("{}.face", prefix.display()));
    let ele = std::fs::read_to_string(&ele_path).unwrap();
    // The edge nodes in VTK's order instead of TetGen's: off the midpoints, on the first tet.
    let mut lines: Vec<String> = ele.lines().map(String::from).collect();
    let fields: Vec<&str> = lines[1].split_whitespace().collect();
    let tetgen_order: Vec<&str> = fields[5..11].to_vec();
    // TetGen's (2,3), (0,3), (0,1), (1,2), (1,3), (0,2) → VTK's (0,1), (1,2), (0,2), (0,3),
    // (1,3), (2,3).
    let vtk = [2, 3, 5, 1, 4, 0].map(|k| tetgen_order[k]);
    lines[1] = format!("{} {} {}", fields[..5].join(" "), vtk.join(" "), fields[11]);
    std::fs::write(&ele_path, lines.join("\n") + "\n").unwrap();
    match read_tetgen_as::<Tet10>(&prefix) {
        Err(Error::Parse {
            path,
            line,
            message,
        }) => {
            assert_eq!(path, ele_path);
            assert_eq!(line, 2, "{message}");
            assert!(message.contains("edge node"), "{message}");
        }
        other => panic!("{other:?}"),
    }
    std::fs::write(&ele_path, ele).unwrap();
    // A .face row whose edge nodes are not the tets': its line.
    let face = std::fs::read_to_string(&face_path).unwrap();
    let mut lines: Vec<String> = face.lines().map(String::from).collect();
    let mut fields: Vec<String> = lines[3].split_whitespace().map(String::from).collect();
    fields[4] = fields[1].clone();
    lines[3] = fields.join(" ");
    std::fs::write(&face_path, lines.join("\n") + "\n").unwrap();
    match read_tetgen_as::<Tet10>(&prefix) {
        Err(Error::Parse {
            path,
            line,
            message,
        }) => {
            assert_eq!(path, face_path);
            assert_eq!(line, 4, "{message}");
            assert!(message.contains("edge nodes"), "{message}");
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn linear_files_keep_their_order() {
    // A linear Gmsh file: order 1, read as 4-node tets as before; as 10-node tets an error
    // naming the file.
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/l_bracket.msh");
    assert_eq!(mesh_file_order(&path).unwrap(), 1);
    let linear = read_gmsh(&path).unwrap();
    assert!(!linear.skipped_elements.contains_key(TET10_KEPT_AS_CORNERS));
    match read_gmsh_as::<Tet10>(&path) {
        Err(Error::Parse {
            path: p, message, ..
        }) => {
            assert_eq!(p, path);
            assert!(message.contains("4-node (linear) tets"), "{message}");
        }
        other => panic!("{other:?}"),
    }
    let tetgen = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/tetgen_bar.ele");
    assert_eq!(mesh_file_order(&tetgen).unwrap(), 1);
}

/// Issue 33: a 10-node element line one node tag short shifted mshio's stream of numbers, and
/// the error came where the stream finally failed (190 lines later on the reporter's file);
/// the short line itself is named, with the count it has and the count its type needs.
#[test]
fn a_tet10_line_short_of_a_node_tag_is_named_at_its_line() {
    let mesh = box_mesh(BoxSplit::Lecture6);
    let text = msh41(&mesh, &[]);
    let elements = text.lines().position(|l| l == "$Elements").unwrap();
    // Tet 3 of the block: header, block header, then tets 1, 2, 3.
    let target = elements + 2 + 3;
    let lines: Vec<&str> = text.lines().collect();
    let short_line = lines[target].rsplit_once(' ').unwrap().0.to_string();
    let mut edited: Vec<String> = lines.iter().map(|l| l.to_string()).collect();
    edited[target] = short_line;
    let bad = edited.join("\n") + "\n";
    let (_, line, message) = parse_error::<Tet10>("short.msh", &bad);
    assert_eq!(line, target + 1, "{message}");
    assert!(
        message.contains("9 node tags") && message.contains("Tet10") && message.contains("10"),
        "{message}"
    );
}
