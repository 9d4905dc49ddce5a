//! The book's chapter of scene keys (`docs/src/scenes/keys.md`), generated from the code so
//! that it cannot drift from it: the annotated [`REFERENCE`](crate::REFERENCE) scene, and the
//! doc comments of the scene schema's serde types, read from the source text of `spec.rs` and
//! `engine.rs` (compiled in with `include_str!`, so a change of either changes [`chapter`]).
//!
//! `tests/key_docs.rs` fails when the checked-in chapter differs from [`chapter`] (rewrite it
//! with `TETFEM_BLESS=1 cargo test --release -p tetfem-scene --test key_docs`), when a key or
//! value of a public schema type has no doc comment ([`undocumented`]), and when a key the
//! schema accepts is missing from [`REFERENCE`](crate::REFERENCE)
//! ([`keys_missing_from_reference`]).
//!
//! The parser reads only what rustfmt writes for these files: `///` doc lines, one-line
//! attributes, `struct`/`enum` items at the top level with one field or variant per line.

/// The schema's source files, as the chapter names them, with their text.
const SOURCES: [(&str, &str); 2] = [
    ("crates/scene/src/spec.rs", include_str!("spec.rs")),
    ("crates/scene/src/engine.rs", include_str!("engine.rs")),
];

/// Where the generated chapter lives, relative to the workspace root.
pub const CHAPTER_PATH: &str = "docs/src/scenes/keys.md";

/// One key (a struct field) or value (an enum variant) of a schema type.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SchemaEntry {
    /// Its spelling in a scene file (serde's rename applied).
    pub key: String,
    /// The Rust type of a field or of a tuple variant's content (empty for a unit variant).
    pub rust_type: String,
    /// Its doc comment, lines joined by spaces (empty when it has none).
    pub doc: String,
    /// The fields of a struct variant (an inline table such as `{ plane = { axis, at } }`).
    pub fields: Vec<SchemaEntry>,
}

/// One serde type of the scene schema (a TOML table, or the values of a key).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SchemaItem {
    /// The Rust name of the type.
    pub name: String,
    /// An enum (its entries are values) rather than a struct (its entries are keys).
    pub is_enum: bool,
    /// Declared `pub` (the others are parse helpers re-reading keys of a public type).
    pub public: bool,
    /// An enum read through `#[serde(try_from = …)]` from a table whose sub-tables are its
    /// variants (`[mesh.box]`, …): its entries are keys (snake case), not values.
    pub variants_are_tables: bool,
    /// Its doc comment, lines joined by spaces.
    pub doc: String,
    /// The source file it is declared in (relative to the workspace root).
    pub source: &'static str,
    /// Its keys or values, in declaration order.
    pub entries: Vec<SchemaEntry>,
}

/// Text of a doc comment line (`/// text` → `text`), or `None` for another line.
fn doc_line(line: &str) -> Option<&str> {
    let rest = line.trim_start().strip_prefix("///")?;
    Some(rest.strip_prefix(' ').unwrap_or(rest))
}

/// The value of `name = "…"` inside `#[serde(…)]` attributes, if one sets it.
fn serde_string(attributes: &[String], name: &str) -> Option<String> {
    let pattern = format!("{name} = \"");
    attributes
        .iter()
        .filter(|a| a.starts_with("#[serde("))
        .find_map(|a| {
            let start = a.find(&pattern)? + pattern.len();
            let len = a[start..].find('"')?;
            Some(a[start..start + len].to_string())
        })
}

/// `CamelCase` → `camel_case` (serde's `rename_all = "snake_case"` on variant names).
fn snake_case(name: &str) -> String {
    let mut out = String::new();
    for (i, c) in name.chars().enumerate() {
        if c.is_uppercase() && i > 0 {
            out.push('_');
        }
        out.extend(c.to_lowercase());
    }
    out
}

/// Change of brace depth over a code line (the schema files hold no braces in strings on item
/// or field lines; doc lines are never passed here).
fn brace_delta(line: &str) -> i32 {
    let code = line.split("//").next().unwrap_or("");
    code.matches('{').count() as i32 - code.matches('}').count() as i32
}

/// The entry a field or variant line declares, with its pending doc and attributes.
fn entry_of(
    line: &str,
    in_enum: bool,
    rename_all: bool,
    doc: &[String],
    attrs: &[String],
) -> Option<SchemaEntry> {
    let code = line
        .trim()
        .trim_end_matches(',')
        .trim_end_matches(['{', '}'])
        .trim();
    let code = code
        .strip_prefix("pub(crate) ")
        .or_else(|| code.strip_prefix("pub "))
        .unwrap_or(code);
    let (name, rust_type) = if in_enum {
        match code.split_once('(') {
            Some((name, rest)) => (name.trim(), rest.trim_end_matches(')').trim()),
            None => (code, ""),
        }
    } else {
        let (name, rust_type) = code.split_once(':')?;
        (name.trim(), rust_type.trim())
    };
    if name.is_empty() || !name.chars().all(|c| c.is_alphanumeric() || c == '_') {
        return None;
    }
    let key = serde_string(attrs, "rename").unwrap_or_else(|| {
        if in_enum && rename_all {
            snake_case(name)
        } else {
            name.to_string()
        }
    });
    Some(SchemaEntry {
        key,
        rust_type: rust_type.to_string(),
        doc: doc.join(" "),
        fields: Vec::new(),
    })
}

/// The header of a top-level item line: (`struct`/`enum`, name, public).
fn item_header(line: &str) -> Option<(bool, String, bool)> {
    let public = line.starts_with("pub ");
    let rest = line
        .strip_prefix("pub(crate) ")
        .or_else(|| line.strip_prefix("pub "))
        .unwrap_or(line);
    let (is_enum, rest) = match rest.strip_prefix("struct ") {
        Some(r) => (false, r),
        None => (true, rest.strip_prefix("enum ")?),
    };
    let name: String = rest
        .chars()
        .take_while(|c| c.is_alphanumeric() || *c == '_')
        .collect();
    Some((is_enum, name, public))
}

/// The serde types of one source file: every `struct`/`enum` deriving `Deserialize`.
fn parse_source(source: &'static str, text: &str) -> Vec<SchemaItem> {
    let (mut items, mut doc, mut attrs) = (Vec::new(), Vec::<String>::new(), Vec::<String>::new());
    let (mut depth, mut current): (i32, Option<(SchemaItem, bool)>) = (0, None);
    for line in text.lines() {
        if let Some(d) = doc_line(line) {
            doc.push(d.trim().to_string());
            continue;
        }
        let trimmed = line.trim();
        if trimmed.starts_with("#[") {
            attrs.push(trimmed.to_string());
            continue;
        }
        if depth == 0 && current.is_none() {
            let derives = attrs
                .iter()
                .any(|a| a.starts_with("#[derive(") && a.contains("Deserialize"));
            if let (true, Some((is_enum, name, public))) = (derives, item_header(trimmed)) {
                let variants_are_tables = serde_string(&attrs, "try_from").is_some();
                let rename_all =
                    serde_string(&attrs, "rename_all").is_some() || variants_are_tables;
                let item = SchemaItem {
                    name,
                    variants_are_tables,
                    is_enum,
                    public,
                    doc: doc.join(" "),
                    source,
                    entries: Vec::new(),
                };
                current = Some((item, rename_all));
            }
        } else if let Some((item, rename_all)) = current.as_mut() {
            // Depth 1: a field or a variant; depth 2 in an enum: a struct variant's field.
            let in_variant = depth == 2 && item.is_enum;
            let is_enum_value = item.is_enum && !in_variant;
            let entry = (depth == 1 || in_variant)
                .then(|| entry_of(trimmed, is_enum_value, *rename_all, &doc, &attrs))
                .flatten();
            match (entry, item.entries.last_mut()) {
                (Some(entry), Some(variant)) if in_variant => variant.fields.push(entry),
                (Some(entry), _) => item.entries.push(entry),
                (None, _) => {}
            }
        }
        depth += brace_delta(trimmed);
        if depth == 0
            && current
                .as_ref()
                .is_some_and(|_| trimmed.ends_with('}') || trimmed.ends_with(';'))
        {
            items.extend(current.take().map(|(item, _)| item));
        }
        doc.clear();
        attrs.clear();
    }
    items
}

/// Every serde type of the scene schema, file by file in declaration order.
pub fn schema() -> Vec<SchemaItem> {
    SOURCES
        .iter()
        .flat_map(|&(source, text)| parse_source(source, text))
        .collect()
}

/// `Type.key` of every key or value of a public schema type without a doc comment.
pub fn undocumented() -> Vec<String> {
    let mut missing = Vec::new();
    for item in schema().iter().filter(|i| i.public) {
        for entry in &item.entries {
            if entry.doc.is_empty() {
                missing.push(format!("{}.{}", item.name, entry.key));
            }
            for field in entry.fields.iter().filter(|f| f.doc.is_empty()) {
                missing.push(format!("{}.{}.{}", item.name, entry.key, field.key));
            }
        }
    }
    missing
}

/// Whether `word` occurs in `text` as a whole word (not inside a longer identifier).
fn has_word(text: &str, word: &str) -> bool {
    let is_ident = |c: char| c.is_alphanumeric() || c == '_';
    text.match_indices(word).any(|(at, _)| {
        let before = text[..at].chars().next_back().is_none_or(|c| !is_ident(c));
        let after = text[at + word.len()..]
            .chars()
            .next()
            .is_none_or(|c| !is_ident(c));
        before && after
    })
}

/// `Type.key` of every key a schema struct accepts (public or not) that the
/// [`REFERENCE`](crate::REFERENCE) scene never names.
pub fn keys_missing_from_reference() -> Vec<String> {
    let mut missing = Vec::new();
    for item in schema() {
        let keys = item.entries.iter().filter(|_| !item.is_enum);
        let variant_fields = item.entries.iter().flat_map(|e| e.fields.iter());
        for entry in keys.chain(variant_fields) {
            if !has_word(crate::REFERENCE, &entry.key) {
                missing.push(format!("{}.{}", item.name, entry.key));
            }
        }
    }
    missing
}

/// A doc comment as Markdown for a table cell: intra-doc links reduced to their text, pipes
/// escaped.
fn cell(doc: &str) -> String {
    let mut out = String::with_capacity(doc.len());
    let mut rest = doc;
    while let Some(open) = rest.find("[`") {
        out.push_str(&rest[..open]);
        let after = &rest[open + 1..];
        match after.find("`]") {
            Some(close) => {
                out.push_str(&after[..close + 1]);
                rest = &after[close + 2..];
                // Drop an explicit target `(path)` that follows the link text.
                if rest.starts_with('(') {
                    rest = rest.find(')').map_or(rest, |end| &rest[end + 1..]);
                }
            }
            None => {
                out.push('[');
                rest = after;
            }
        }
    }
    out.push_str(rest);
    out.replace('|', "\\|")
}

/// The Markdown section of one schema type: its doc, then a table of its keys or values.
fn item_section(item: &SchemaItem) -> String {
    let is_value = item.is_enum && !item.variants_are_tables;
    let what = if is_value { "value" } else { "key" };
    let mut out = format!(
        "### `{}`\n\n{} (`{}`)\n\n",
        item.name,
        cell(&item.doc),
        item.source
    );
    out.push_str(&format!("| {what} | type | what |\n| --- | --- | --- |\n"));
    for entry in &item.entries {
        let key = if is_value && entry.rust_type.is_empty() && entry.fields.is_empty() {
            format!("`\"{}\"`", entry.key)
        } else {
            format!("`{}`", entry.key)
        };
        let mut doc = cell(&entry.doc);
        for field in &entry.fields {
            doc.push_str(&format!(
                "<br>`{}` (`{}`): {}",
                field.key,
                cell(&field.rust_type),
                cell(&field.doc)
            ));
        }
        let rust_type = if entry.rust_type.is_empty() {
            String::new()
        } else {
            format!("`{}`", cell(&entry.rust_type))
        };
        out.push_str(&format!("| {key} | {rust_type} | {doc} |\n"));
    }
    out
}

/// The whole chapter, as `docs/src/scenes/keys.md` must hold it.
pub fn chapter() -> String {
    let mut out = String::from(
        "# Every scene key\n\n\
         <!-- Generated by crates/scene/src/key_docs.rs from tetfem_scene::REFERENCE and the doc \
         comments of crates/scene/src/spec.rs and engine.rs: do not edit. Rewrite it with \
         `TETFEM_BLESS=1 cargo test --release -p tetfem-scene --test key_docs`. -->\n\n\
         A scene names only what it needs; every other key takes the default listed here. The \
         first part is the reference scene, `tetfem_scene::REFERENCE`: every key with its default \
         (itself a valid scene; a test parses it). The second part lists the schema's types, one \
         per TOML table or set of values, with the doc comment of each key. Unknown keys, values \
         of the wrong type and invalid values are errors naming the key and its line.\n\n\
         ## The reference scene\n\n```toml\n",
    );
    out.push_str(crate::REFERENCE.trim_end());
    out.push_str("\n```\n\n## The schema, type by type\n\n");
    out.push_str(
        "Private types (parse helpers that re-read keys of a public one) are left out; their keys \
         are checked to appear in the reference scene above.\n",
    );
    for item in schema().iter().filter(|i| i.public) {
        out.push('\n');
        out.push_str(&item_section(item));
    }
    out
}

/// The book's Library guide: its Rust blocks compiled and run as doctests of this crate.
#[cfg(doctest)]
#[doc = include_str!("../../../docs/src/library.md")]
pub struct LibraryGuideDoctests;

/// The book's chapter on quadratic elements: its Rust blocks compiled and run as doctests.
#[cfg(doctest)]
#[doc = include_str!("../../../docs/src/quadratic.md")]
pub struct QuadraticDoctests;

/// The book's chapter on dynamics: its Rust blocks compiled and run as doctests.
#[cfg(doctest)]
#[doc = include_str!("../../../docs/src/dynamics.md")]
pub struct DynamicsDoctests;
