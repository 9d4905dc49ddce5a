//! The book's chapter of scene keys is the code's: `docs/src/scenes/keys.md` equals what
//! `tetfem_scene::key_docs::chapter` writes now, every key and value of the public schema types
//! has a doc comment, and every key the schema accepts is named in `REFERENCE`.
//!
//! After changing a key, its doc comment or `REFERENCE`, rewrite the chapter with
//! `TETFEM_BLESS=1 cargo test --release -p tetfem-scene --test key_docs`.

use std::path::PathBuf;

use tetfem_scene::key_docs::{
    CHAPTER_PATH, chapter, keys_missing_from_reference, schema, undocumented,
};

/// The chapter's path in this checkout (the workspace root is two folders above the crate).
fn chapter_file() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../..")
        .join(CHAPTER_PATH)
}

#[test]
fn checked_in_chapter_is_the_generated_one() {
    let expected = chapter();
    let path = chapter_file();
    if std::env::var_os("TETFEM_BLESS").is_some() {
        std::fs::write(&path, &expected).expect("write the chapter");
    }
    let found = std::fs::read_to_string(&path).expect("read the chapter");
    // Compared line by line so that a failure names the first line that drifted.
    let drift = expected
        .lines()
        .zip(found.lines())
        .position(|(a, b)| a != b)
        .or((expected.lines().count() != found.lines().count()).then_some(0));
    assert!(
        drift.is_none() && expected == found,
        "{} is not what key_docs::chapter() writes (first differing line {:?}); rewrite it with \
         TETFEM_BLESS=1 cargo test --release -p tetfem-scene --test key_docs",
        path.display(),
        drift.map(|line| line + 1)
    );
}

#[test]
fn every_key_and_value_has_a_doc_comment() {
    assert_eq!(undocumented(), Vec::<String>::new());
}

#[test]
fn every_key_of_the_schema_is_in_the_reference() {
    assert_eq!(keys_missing_from_reference(), Vec::<String>::new());
}

/// The parser must see the schema, not an empty list that would pass the two checks above:
/// the top-level table's keys and a struct variant's fields are where they are declared.
#[test]
fn the_parser_finds_the_schema() {
    let items = schema();
    let scene = items
        .iter()
        .find(|i| i.name == "SceneSpec")
        .expect("SceneSpec parsed");
    let keys: Vec<&str> = scene.entries.iter().map(|e| e.key.as_str()).collect();
    for key in [
        "title",
        "mesh",
        "material",
        "materials",
        "analysis",
        "obstacles",
        "engine",
        "petsc",
    ] {
        assert!(keys.contains(&key), "SceneSpec lacks {key}: {keys:?}");
    }
    let analysis = items
        .iter()
        .find(|i| i.name == "AnalysisSpec")
        .expect("AnalysisSpec parsed");
    assert_eq!(
        analysis.entries[0].key, "type",
        "the rename of `kind` to `type`"
    );
    let selector = items
        .iter()
        .find(|i| i.name == "Selector")
        .expect("Selector parsed");
    let plane = selector
        .entries
        .iter()
        .find(|e| e.key == "plane")
        .expect("Selector::Plane");
    let fields: Vec<&str> = plane.fields.iter().map(|f| f.key.as_str()).collect();
    assert_eq!(fields, ["axis", "at", "tolerance"]);
    assert!(
        items.iter().any(|i| i.name == "PetscSpec"),
        "engine.rs is read too"
    );
}
