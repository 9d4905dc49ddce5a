//! Every ```` ```toml ```` block of the book (`docs/src/**/*.md` and the files its chapters
//! `{{#include}}`) and of the READMEs (`README.md`, `scenes/README.md`, `python/README.md`) is a
//! scene the code accepts, so that a renamed key or value fails here, naming the file, the
//! block's line and the error:
//!
//! - a **whole scene** (a block with a `[mesh]` table, e.g. `[mesh.box]`) is checked against the
//!   key table, then parsed and built as `tetfem run` does before its solve: [`Scene::parse`]
//!   (every key, value and cross-key check), then [`Scene::build`] (`build_as::<Tet10>` for
//!   `mesh.order = 2`: the mesh, materials, constraints, loads and probes, with selections that
//!   match nothing an error). Relative mesh paths are taken from `scenes/`.
//! - a **fragment** (a table or a few keys, no `[mesh]`) is checked against the key table:
//!   every key it names must exist in the table it sits in, and every string given to a key of
//!   named values (`split`, `axis`, `where = "all"`, …) must be one of them. The key table is the
//!   schema [`key_docs::schema`] reads from the serde types, the one the generated chapter
//!   (`docs/src/scenes/keys.md`) prints. Then it is completed by [`BASE`] (the base's tables
//!   that the fragment does not hold are appended) and parsed and built as a whole scene, so
//!   that its values are checked too.
//! - a block whose info string carries `ignore-check` (```` ```toml,ignore-check ````) is not
//!   checked: an example that is wrong on purpose (an error message's cause), or TOML that is
//!   not a scene (a `Cargo.toml` excerpt). The book's introduction says so for contributors.
//!
//! Every ```` ```rust ```` block of the same files must sit in a file that a crate's docs
//! include (`#[doc = include_str!(…)]`), so that `cargo test --release` compiles and runs it as a
//! doctest. (The ```` ```python ```` blocks are run by `python/tests/test_doc_blocks.py`.)

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use tetfem::fe::element::Tet10;
use tetfem::mesh::Tet4;
use tetfem_scene::Scene;
use tetfem_scene::key_docs::{SchemaEntry, SchemaItem, schema};

/// The workspace root (two folders above this crate).
fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// A fenced code block of a Markdown file.
#[derive(Debug, Clone)]
struct Block {
    /// The file, relative to the workspace root.
    file: String,
    /// 1-based line of the opening fence.
    line: usize,
    /// The words of the info string (`toml,ignore-check` → `["toml", "ignore-check"]`).
    info: Vec<String>,
    /// The content, the fence's indentation removed.
    text: String,
}

impl Block {
    /// `file:line` of the block's `n`-th content line (1-based), for messages.
    fn at(&self, n: usize) -> String {
        format!("{}:{}", self.file, self.line + n)
    }
}

/// Every fenced block of `text` (fences of ``` or ~~~, indented or not, as CommonMark).
fn fenced_blocks(file: &str, text: &str) -> Vec<Block> {
    let mut blocks = Vec::new();
    let mut open: Option<(Block, char, usize, usize)> = None;
    for (i, line) in text.lines().enumerate() {
        let indent = line.len() - line.trim_start_matches(' ').len();
        let trimmed = line.trim_start_matches(' ');
        let fence_char = trimmed.chars().next().filter(|c| *c == '`' || *c == '~');
        let fence_len = fence_char.map_or(0, |c| trimmed.chars().take_while(|&x| x == c).count());
        match open.as_mut() {
            // A backtick fence's info string holds no backtick (CommonMark): a line such as
            // ```` ```toml ```` is inline code, not a fence.
            None if fence_len >= 3
                && !(fence_char == Some('`') && trimmed[fence_len..].contains('`')) =>
            {
                let info = trimmed[fence_len..]
                    .split([',', ' '])
                    .filter(|w| !w.is_empty())
                    .map(str::to_string)
                    .collect();
                let block = Block {
                    file: file.to_string(),
                    line: i + 1,
                    info,
                    text: String::new(),
                };
                open = Some((block, fence_char.unwrap_or('`'), fence_len, indent));
            }
            None => {}
            Some((block, c, len, fence_indent)) => {
                let closes = fence_char == Some(*c)
                    && fence_len >= *len
                    && trimmed[fence_len..].trim().is_empty();
                if closes {
                    blocks.extend(open.take().map(|(b, ..)| b));
                } else {
                    let strip = indent.min(*fence_indent);
                    block.text.push_str(&line[strip..]);
                    block.text.push('\n');
                }
            }
        }
    }
    blocks
}

/// The Markdown files the book and the READMEs are made of, relative to the root: the three
/// READMEs, every chapter under `docs/src/`, and every file a chapter `{{#include}}`s.
fn markdown_files() -> Vec<String> {
    let root = root();
    let mut files: BTreeSet<String> = ["README.md", "scenes/README.md", "python/README.md"]
        .into_iter()
        .map(str::to_string)
        .collect();
    let mut folders = vec![PathBuf::from("docs/src")];
    while let Some(folder) = folders.pop() {
        let entries = std::fs::read_dir(root.join(&folder)).expect("read docs/src");
        for entry in entries.map(|e| e.expect("a folder entry").path()) {
            let relative = folder.join(entry.file_name().expect("a file name"));
            if entry.is_dir() {
                folders.push(relative);
            } else if relative.extension().is_some_and(|e| e == "md") {
                let text = std::fs::read_to_string(&entry).expect("read a chapter");
                files.extend(includes(&folder, &text));
                files.insert(relative.to_string_lossy().into_owned());
            }
        }
    }
    files.into_iter().collect()
}

/// The files `{{#include path}}` lines of a chapter in `folder` name, relative to the root
/// (`../` resolved by hand, so that the names match the READMEs' above).
fn includes(folder: &Path, text: &str) -> Vec<String> {
    text.lines()
        .filter_map(|l| l.trim().strip_prefix("{{#include ")?.strip_suffix("}}"))
        .map(|target| {
            let target = target.trim().split(':').next().unwrap_or("");
            let mut parts: Vec<String> = folder
                .components()
                .map(|c| c.as_os_str().to_string_lossy().into_owned())
                .collect();
            for part in target.split('/') {
                match part {
                    ".." => {
                        parts.pop();
                    }
                    "." | "" => {}
                    name => parts.push(name.to_string()),
                }
            }
            parts.join("/")
        })
        .collect()
}

/// Every block of the book and the READMEs whose info string starts with `lang`.
fn blocks_of(lang: &str) -> Vec<Block> {
    markdown_files()
        .iter()
        .flat_map(|file| {
            let text = std::fs::read_to_string(root().join(file))
                .unwrap_or_else(|e| panic!("read {file}: {e}"));
            fenced_blocks(file, &text)
        })
        .filter(|b| b.info.first().is_some_and(|l| l == lang))
        .collect()
}

/// Every ```` ```toml ```` block of the book and the READMEs.
fn toml_blocks() -> Vec<Block> {
    blocks_of("toml")
}

/// Whether a block is marked as not to be checked.
fn ignored(block: &Block) -> bool {
    block.info.iter().any(|w| w == "ignore-check")
}

/// What a fragment is completed with to be a scene: a small static cantilever. Each entry is
/// a top-level key and its text; the fragment's own tables replace the base's.
const BASE: [(&str, &str); 4] = [
    (
        "mesh",
        "[mesh.box]\nmax = [1.0, 0.1, 0.1]\ncells = [10, 2, 2]\n",
    ),
    (
        "material",
        "[material]\nyoungs_modulus = 200e9\npoisson_ratio = 0.3\ndensity = 7850.0\n",
    ),
    (
        "constraints",
        "[[constraints]]\nwhere = { plane = { axis = \"x\", at = 0.0 } }\n",
    ),
    ("loads", "[[loads]]\ngravity = [0.0, 0.0, -9.81]\n"),
];

/// The schema item a Rust type names (`Option<Vec<LoadSpec>>` → `LoadSpec`), if any.
fn item_of<'a>(rust_type: &str, items: &'a [SchemaItem]) -> Option<&'a SchemaItem> {
    rust_type
        .split(|c: char| !(c.is_alphanumeric() || c == '_'))
        .filter_map(|word| items.iter().find(|i| i.name == word))
        .next_back()
}

/// The keys a table of `item` accepts. An enum read `try_from` a table (`MeshSpec` from its
/// `[mesh]` table) accepts the keys of that table's struct: the schema struct whose keys hold
/// every variant's key (`MeshTable`: `box`, `gmsh`, `tetgen`, and `order`).
fn table_keys<'a>(item: &'a SchemaItem, items: &'a [SchemaItem]) -> &'a [SchemaEntry] {
    if !item.variants_are_tables {
        return &item.entries;
    }
    items
        .iter()
        .find(|other| {
            !other.is_enum
                && item
                    .entries
                    .iter()
                    .all(|v| other.entries.iter().any(|k| k.key == v.key))
        })
        .map_or(&item.entries, |table| &table.entries)
}

/// Checks `value`, given at `path` to a key of Rust type `rust_type`, against the schema:
/// unknown keys and unknown named values are pushed to `errors` as `path: what`.
fn check_value(
    path: &str,
    value: &toml::Value,
    rust_type: &str,
    items: &[SchemaItem],
    errors: &mut Vec<String>,
) {
    let Some(item) = item_of(rust_type, items) else {
        return; // numbers, strings, paths, amplitudes: their values are checked by the parse
    };
    match value {
        toml::Value::Array(values) => {
            for (i, v) in values.iter().enumerate() {
                check_value(&format!("{path}[{i}]"), v, rust_type, items, errors);
            }
        }
        toml::Value::String(s) if item.is_enum && !item.variants_are_tables => {
            let names: Vec<&str> = item
                .entries
                .iter()
                .filter(|e| e.rust_type.is_empty() && e.fields.is_empty())
                .map(|e| e.key.as_str())
                .collect();
            if !names.contains(&s.as_str()) {
                errors.push(format!(
                    "{path}: \"{s}\" is not a value of {} ({names:?})",
                    item.name
                ));
            }
        }
        toml::Value::Table(table) => {
            for (key, v) in table {
                let key_path = format!("{path}.{key}");
                let keys = table_keys(item, items);
                let Some(entry) = keys.iter().find(|e| e.key == *key) else {
                    let known: Vec<&str> = keys.iter().map(|e| e.key.as_str()).collect();
                    errors.push(format!(
                        "{key_path}: no such key in {} (its keys: {known:?})",
                        item.name
                    ));
                    continue;
                };
                match (&entry.fields[..], v) {
                    ([], _) => check_value(&key_path, v, &entry.rust_type, items, errors),
                    (fields, toml::Value::Table(inner)) => {
                        check_fields(&key_path, inner, fields, items, errors)
                    }
                    _ => {}
                }
            }
        }
        _ => {}
    }
}

/// The keys of a struct variant's inline table (`plane = { axis, at, tolerance }`).
fn check_fields(
    path: &str,
    table: &toml::Table,
    fields: &[SchemaEntry],
    items: &[SchemaItem],
    errors: &mut Vec<String>,
) {
    for (key, v) in table {
        match fields.iter().find(|f| f.key == *key) {
            Some(field) => {
                check_value(&format!("{path}.{key}"), v, &field.rust_type, items, errors)
            }
            None => errors.push(format!(
                "{path}.{key}: no such key (its keys: {:?})",
                fields.iter().map(|f| &f.key).collect::<Vec<_>>()
            )),
        }
    }
}

/// The 1-based line of the block where `path`'s last key is first written (0 if not found).
fn line_of_key(text: &str, path: &str) -> usize {
    let key = path
        .rsplit('.')
        .next()
        .unwrap_or(path)
        .split('[')
        .next()
        .unwrap_or("");
    let is_ident = |c: char| c.is_alphanumeric() || c == '_';
    text.lines()
        .position(|line| {
            let code = line.split('#').next().unwrap_or("");
            code.match_indices(key).any(|(at, _)| {
                let before = code[..at].chars().next_back().is_none_or(|c| !is_ident(c));
                let after = code[at + key.len()..]
                    .chars()
                    .next()
                    .is_none_or(|c| !is_ident(c));
                before && after
            })
        })
        .map_or(0, |i| i + 1)
}

/// The key-table check of a block's text: `file:line: path: what` for each unknown key.
fn key_errors(block: &Block, table: &toml::Table, items: &[SchemaItem]) -> Vec<String> {
    let mut errors = Vec::new();
    check_value(
        "",
        &toml::Value::Table(table.clone()),
        "SceneSpec",
        items,
        &mut errors,
    );
    errors
        .into_iter()
        .map(|e| {
            let path = e.split(':').next().unwrap_or("");
            format!(
                "{}: {}",
                block.at(line_of_key(&block.text, path)),
                e.trim_start_matches('.')
            )
        })
        .collect()
}

/// The scene a block stands for: itself when it has a `[mesh]` table, else the fragment
/// followed by the [`BASE`] tables it does not hold.
fn completed(text: &str, table: &toml::Table) -> String {
    if table.contains_key("mesh") {
        return text.to_string();
    }
    let mut out = text.to_string();
    for (_, base) in BASE.iter().filter(|(k, _)| !table.contains_key(*k)) {
        out.push('\n');
        out.push_str(base);
    }
    out
}

/// Parses and builds a scene as `tetfem run` does before it solves.
fn parse_and_build(text: &str, source_name: &str) -> tetfem::Result<()> {
    let scene = Scene::parse(text, source_name, &root().join("scenes"))?;
    match scene.order() {
        2 => scene.build_as::<Tet10>().map(|_| ()),
        _ => scene.build_as::<Tet4>().map(|_| ()),
    }
}

/// Every error of one block: TOML syntax, the key table, then the parse and build.
fn block_errors(block: &Block, items: &[SchemaItem]) -> Vec<String> {
    let table: toml::Table = match toml::from_str(&block.text) {
        Ok(t) => t,
        Err(e) => {
            let line = e
                .span()
                .map_or(0, |s| block.text[..s.start].lines().count());
            return vec![format!("{}: not TOML: {}", block.at(line), e.message())];
        }
    };
    let errors = key_errors(block, &table, items);
    if !errors.is_empty() {
        return errors;
    }
    let text = completed(&block.text, &table);
    let kind = match table.contains_key("mesh") {
        true => "the scene",
        false => "the fragment completed by tests/book_blocks.rs's BASE",
    };
    match parse_and_build(&text, &block.file) {
        Ok(()) => Vec::new(),
        Err(tetfem::Error::Scene {
            key, line, message, ..
        }) if line > 0 && line <= block.text.lines().count() => {
            vec![format!("{}: {kind}: {key}: {message}", block.at(line))]
        }
        Err(e) => vec![format!("{}: {kind}: {e}", block.at(0))],
    }
}

/// The check itself: every toml block, or `file:line: error` for each that fails.
#[test]
fn every_toml_block_is_a_scene_the_code_accepts() {
    let items = schema();
    let blocks = toml_blocks();
    let checked: Vec<&Block> = blocks.iter().filter(|b| !ignored(b)).collect();
    let errors: Vec<String> = checked
        .iter()
        .flat_map(|b| block_errors(b, &items))
        .collect();
    let scenes = checked.iter().filter(|b| b.text.contains("[mesh")).count();
    println!(
        "{} toml blocks: {} checked ({scenes} whole scenes), {} marked ignore-check",
        blocks.len(),
        checked.len(),
        blocks.len() - checked.len()
    );
    for b in &checked {
        println!("checked {}", b.at(0));
    }
    assert!(
        errors.is_empty(),
        "toml blocks failing:\n{}",
        errors.join("\n")
    );
}

/// Fences as CommonMark reads them: a backtick run with a backtick after it is inline code, an
/// indented fence's indentation is removed from its lines, `~~~` fences count, and the info
/// string's words are split at commas.
#[test]
fn fences_are_read_as_commonmark_reads_them() {
    let text = "a\n```` ```toml ```` is inline\n  ```toml,ignore-check\n  x = 1\n  ```\n\
                ~~~python\ny\n~~~\n";
    let blocks = fenced_blocks("t.md", text);
    assert_eq!(blocks.len(), 2, "{blocks:?}");
    assert_eq!(blocks[0].line, 3);
    assert_eq!(blocks[0].info, ["toml", "ignore-check"]);
    assert_eq!(blocks[0].text, "x = 1\n");
    assert_eq!((blocks[1].line, &blocks[1].text[..]), (6, "y\n"));
}

/// The walk must see the blocks, not an empty list that passes: the README's scene, the
/// generated chapter's reference scene and the Scenes chapter's example are among them.
#[test]
fn the_walk_finds_the_known_blocks() {
    let blocks = toml_blocks();
    for file in [
        "README.md",
        "docs/src/scenes/keys.md",
        "docs/src/scenes/index.md",
    ] {
        assert!(
            blocks.iter().any(|b| b.file == file && !ignored(b)),
            "no checked toml block found in {file}"
        );
    }
}

/// The checks catch what they are for, on copies of a shipped block: a renamed key (by the key
/// table, at its line), a renamed value, a wrong value (by the parse) and a selection that
/// matches nothing (by the build).
#[test]
fn a_renamed_key_or_a_wrong_value_fails() {
    let items = schema();
    let readme = toml_blocks()
        .into_iter()
        .find(|b| b.file == "README.md")
        .expect("the README's scene");
    assert_eq!(block_errors(&readme, &items), Vec::<String>::new());
    let broken = |from: &str, to: &str| {
        assert!(
            readme.text.contains(from),
            "the README's scene holds {from}"
        );
        let block = Block {
            text: readme.text.replacen(from, to, 1),
            ..readme.clone()
        };
        block_errors(&block, &items).join("\n")
    };
    let renamed = broken("youngs_modulus", "young_modulus");
    let line = readme.line + line_of_key(&readme.text, "youngs_modulus");
    assert!(
        renamed.contains(&format!(
            "README.md:{line}: material.young_modulus: no such key"
        )),
        "{renamed}"
    );
    let value = broken("axis = \"x\"", "axis = \"u\"");
    assert!(value.contains("is not a value of Axis"), "{value}");
    let wrong = broken("poisson_ratio = 0.3", "poisson_ratio = 0.7");
    assert!(
        wrong.contains("README.md:") && wrong.contains("0.7"),
        "{wrong}"
    );
    let nothing = broken("at = 1.0", "at = 7.0");
    assert!(nothing.contains("README.md:"), "{nothing}");
    println!("{renamed}\n{value}\n{wrong}\n{nothing}");
    // A fragment: an unknown key in [petsc], and a known one completed into a scene.
    let fragment = |text: &str| {
        let block = Block {
            text: text.to_string(),
            ..readme.clone()
        };
        block_errors(&block, &items)
    };
    assert_eq!(
        fragment("[petsc]\nsolver = \"gamg\"\n"),
        Vec::<String>::new()
    );
    let unknown = fragment("[petsc]\nsolvers = \"gamg\"\n").join("\n");
    assert!(unknown.contains("petsc.solvers: no such key"), "{unknown}");
}

/// The Markdown files some crate's documentation includes (`#[doc = include_str!("…")]` in a
/// `.rs` file of `src/` or `crates/*/src/`), relative to the root: rustdoc compiles and runs
/// their Rust blocks as that crate's doctests, which `cargo test --release` in CI runs.
fn doctested_files() -> BTreeSet<String> {
    let root = root();
    let mut folders = vec![PathBuf::from("src")];
    for entry in std::fs::read_dir(root.join("crates")).expect("read crates/") {
        let krate = entry.expect("a crate").file_name();
        folders.push(Path::new("crates").join(krate).join("src"));
    }
    let mut files = BTreeSet::new();
    while let Some(folder) = folders.pop() {
        let Ok(entries) = std::fs::read_dir(root.join(&folder)) else {
            continue;
        };
        for path in entries.map(|e| e.expect("a folder entry").path()) {
            let relative = folder.join(path.file_name().expect("a file name"));
            if path.is_dir() {
                folders.push(relative);
            } else if relative.extension().is_some_and(|e| e == "rs") {
                let text = std::fs::read_to_string(&path).expect("read a source file");
                for line in text.lines() {
                    let Some(target) = line
                        .trim()
                        .strip_prefix("#[doc = include_str!(\"")
                        .and_then(|rest| rest.strip_suffix("\")]"))
                    else {
                        continue;
                    };
                    let fake = format!("{{{{#include {target}}}}}");
                    files.extend(includes(&folder, &fake));
                }
            }
        }
    }
    files
}

/// Every Rust block of the book and the READMEs is compiled in CI: it sits in a file that a
/// crate's documentation includes (so `cargo test --release` runs it as a doctest), and no
/// `ignore` attribute keeps rustdoc from compiling it.
#[test]
fn every_rust_block_is_a_doctest() {
    let doctested = doctested_files();
    for file in [
        "README.md",
        "docs/src/library.md",
        "docs/src/quadratic.md",
        "docs/src/dynamics.md",
    ] {
        assert!(doctested.contains(file), "{file} not in {doctested:?}");
    }
    let rust = blocks_of("rust");
    assert!(
        rust.len() >= 6,
        "the README's and the chapters' blocks: {rust:?}"
    );
    let not_compiled: Vec<String> = rust
        .iter()
        .filter(|b| !doctested.contains(&b.file) || b.info.iter().any(|w| w == "ignore"))
        .map(|b| b.at(0))
        .collect();
    println!("{} rust blocks, in {doctested:?}", rust.len());
    assert!(
        not_compiled.is_empty(),
        "Rust blocks no doctest compiles (include the chapter in crates/scene/src/key_docs.rs \
         as the others are): {not_compiled:?}"
    );
}
