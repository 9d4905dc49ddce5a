//! The check that a shipped quadratic Gmsh file is the one its fixture writes, and reads back.

use tetfem::{Tet10, TetMesh};

/// `scenes/<file>` equals `text` (the fixture's Gmsh file; `TETFEM_BLESS=1` rewrites it from
/// `text`), and reads back as `linear`'s 10-node mesh (a wrong edge order would fail the
/// midpoint check or move nodes) with every group of `groups` holding faces.
pub fn assert_shipped_gmsh(file: &str, text: &str, linear: &TetMesh, groups: &[&str]) {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scenes")
        .join(file);
    if std::env::var_os("TETFEM_BLESS").is_some() {
        std::fs::write(&path, text).unwrap();
    }
    let shipped = std::fs::read_to_string(&path).unwrap();
    assert!(
        shipped == text,
        "{} differs from the fixture's mesh: bless it",
        path.display()
    );
    let imported = tetfem::mesh::io::read_gmsh_as::<Tet10>(&path).unwrap();
    let expected = TetMesh::<Tet10>::from_linear(linear).unwrap();
    assert_eq!(imported.mesh.nodes(), expected.nodes());
    assert_eq!(imported.mesh.tets(), expected.tets());
    for name in groups {
        let group = imported
            .groups
            .iter()
            .find(|g| g.name.as_deref() == Some(*name));
        assert!(
            group.is_some_and(|g| !g.triangles.is_empty()),
            "group {name}"
        );
    }
}
