//! TetGen `<prefix>.node` / `<prefix>.ele` files.
//!
//! `.node`: a header `<points> <dimension = 3> <attributes> <markers 0|1>`, then one line per
//! point `<index> <x> <y> <z> [attributes…] [marker]`. `.ele`: a header
//! `<tets> <nodes per tet 4|10> <attributes>`, then `<index> <n₀> … [attributes…]`. Indices
//! start at 0 or 1 — the first point's index tells — and run consecutively; `#` starts a
//! comment. An optional `<prefix>.face`: a header `<faces> <markers 0|1>`, then
//! `<index> <n₀> <n₁> <n₂> [marker] …` (further columns, such as the adjacent tets of `-nn`,
//! are ignored); its markers become face sets.
//!
//! `-o2` meshes: the `.ele` lists 10 nodes per tet, the corners n₀…n₃ and then the edge nodes
//! in TetGen's order of edges (its `edge2ver` table): (n₂,n₃), (n₀,n₃), (n₀,n₁), (n₁,n₂),
//! (n₁,n₃), (n₀,n₂) — not VTK's (n₀,n₁), (n₁,n₂), (n₀,n₂), (n₀,n₃), (n₁,n₃), (n₂,n₃). (Files
//! written with TetGen's `-z1`/`-R`, which swap n₀ and n₁, do not follow it: their edge nodes
//! are refused where the misplaced edge nodes fold the isoparametric map, as they do on the
//! tets tried.) The `.face` of TetGen 1.5 and later lists the three edge
//! nodes of each face after its corners (`<index> <n₀> <n₁> <n₂> <e₀> <e₁> <e₂> [marker]`, in
//! an order that differs between `-f` and boundary faces); older versions list the corners
//! only. The edge nodes are recognized by the column count (at least 7 + the marker flag:
//! without them a row has at most 6 + the marker flag, with `-nn`) and checked to be the tets'
//! edge nodes of the face; the face sets take the edge nodes from the tets.

use std::io::Write;
use std::path::{Path, PathBuf};

use nalgebra::Vector3;

use super::raw::{ListedEdgeNodes, RawMesh};
use super::text::{Records, decode, read_regular_file};
use super::{ImportedMesh, MarkedFace};
use crate::base::atomic_file::write_atomically;
use crate::base::error::{Error, Result};
use crate::mesh::{CellType, Tet4, TetMesh};

/// The edge nodes of a TetGen `-o2` tet (its extra nodes e₀…e₅) in VTK order: VTK edge k is
/// TetGen's extra node `TETGEN_EDGE_NODE[k]` (TetGen's edges (2,3), (0,3), (0,1), (1,2),
/// (1,3), (0,2)).
const TETGEN_EDGE_NODE: [usize; 6] = [2, 3, 5, 1, 4, 0];

/// What [`write_tetgen`] writes besides nodes and tets.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct TetgenOptions {
    /// First index, 0 or 1.
    pub base: usize,
    /// One boundary marker per node (a marker column is written when present).
    pub node_markers: Option<Vec<i64>>,
    /// One regional attribute per tet (an attribute column is written when present).
    pub tet_attributes: Option<Vec<f64>>,
}

fn with_suffix(prefix: &Path, suffix: &str) -> PathBuf {
    let mut s = prefix.as_os_str().to_owned();
    s.push(suffix);
    PathBuf::from(s)
}

/// Reads `<prefix>.node`, `<prefix>.ele` and, if it exists, `<prefix>.face`, and hands their
/// bytes to [`parse_tetgen_with_faces`]; node markers, the first tet attribute and the face
/// markers are kept. A `<prefix>.edge` file is not read: its rows are counted in
/// [`ImportedMesh::skipped_elements`] as [`SKIPPED_EDGES`]. As 4-node tets: of an `-o2` mesh the corners (see [`read_tetgen_as`]).
pub fn read_tetgen(prefix: &Path) -> Result<ImportedMesh> {
    read_tetgen_as::<Tet4>(prefix)
}

/// The element order of `<prefix>.ele`'s tets (1 or 2), from its header alone.
pub(crate) fn file_order(prefix: &Path) -> Result<usize> {
    let ele_path = with_suffix(prefix, ".ele");
    let bytes = read_regular_file(&ele_path)?;
    let text = decode(&ele_path, &bytes)?;
    let (_, per_tet, _) = ele_header(&mut Records::new(&ele_path, text, Some('#')))?;
    Ok(if per_tet == 10 { 2 } else { 1 })
}

/// [`read_tetgen`] as cells of type `C`: `Tet4` for any mesh (of an `-o2` one the corners),
/// `tetfem::Tet10` for an `-o2` mesh (a 4-node `.ele` is an error).
pub fn read_tetgen_as<C: CellType>(prefix: &Path) -> Result<ImportedMesh<C>> {
    let (raw, ele_path) = read_raw(prefix)?;
    raw.finish(&ele_path)
}

/// The [`ImportedMesh::skipped_elements`] entry that counts the rows of a `<prefix>.edge`
/// file: its edges (and their markers) are not read, since no selection or load acts on edges.
pub const SKIPPED_EDGES: &str = "Lin2 (TetGen .edge rows, not read)";

/// The rows of a `.edge` file after its header (records that are not blank or comments), or 0
/// if it is not text: it is counted, not read.
fn edge_rows(path: &Path, bytes: &[u8]) -> usize {
    let Ok(text) = decode(path, bytes) else {
        return 0;
    };
    let mut records = Records::new(path, text, Some('#'));
    let mut rows: usize = 0;
    while records.try_next().is_some() {
        rows += 1;
    }
    rows.saturating_sub(1)
}

/// The files' nodes, tets and faces as read (with the line of each), before the mesh is
/// built, and the `.ele` path that errors about the tets name.
pub(crate) fn read_raw(prefix: &Path) -> Result<(RawMesh, PathBuf)> {
    let node_path = with_suffix(prefix, ".node");
    let ele_path = with_suffix(prefix, ".ele");
    let face_path = with_suffix(prefix, ".face");
    let node_bytes = read_regular_file(&node_path)?;
    let ele_bytes = read_regular_file(&ele_path)?;
    let face_bytes = if face_path.exists() {
        Some(read_regular_file(&face_path)?)
    } else {
        None
    };
    let mut raw = parse_raw(
        &node_path,
        &node_bytes,
        &ele_path,
        &ele_bytes,
        face_bytes.as_deref().map(|b| (face_path.as_path(), b)),
    )?;
    let edge_path = with_suffix(prefix, ".edge");
    if edge_path.exists() {
        let bytes = read_regular_file(&edge_path)?;
        raw.skipped
            .insert(SKIPPED_EDGES.into(), edge_rows(&edge_path, &bytes));
    }
    Ok((raw, ele_path))
}

/// Parses the contents of a TetGen `.node` file and its `.ele` file held in memory; node markers
/// and the first tet attribute are kept. `node_path` and `ele_path` are not opened: they only
/// label the [`Error::Parse`] errors about each part (use the files the bytes came from, or
/// placeholders such as `<memory>.node` / `<memory>.ele`).
pub fn parse_tetgen(
    node_path: &Path,
    node_bytes: &[u8],
    ele_path: &Path,
    ele_bytes: &[u8],
) -> Result<ImportedMesh> {
    parse_tetgen_with_faces(node_path, node_bytes, ele_path, ele_bytes, None)
}

/// As [`parse_tetgen`], with a `.face` file's path and bytes when there is one: its marked
/// triangles become [`ImportedMesh::face_markers`] (a `.face` file without a marker column
/// gives none). Errors name the `.face` file and line of a malformed record, a node index
/// outside the `.node` file's range, or a marker that is not an integer.
pub fn parse_tetgen_with_faces(
    node_path: &Path,
    node_bytes: &[u8],
    ele_path: &Path,
    ele_bytes: &[u8],
    face: Option<(&Path, &[u8])>,
) -> Result<ImportedMesh> {
    parse_tetgen_with_faces_as::<Tet4>(node_path, node_bytes, ele_path, ele_bytes, face)
}

/// [`parse_tetgen_with_faces`] as cells of type `C` (see [`read_tetgen_as`]).
pub fn parse_tetgen_with_faces_as<C: CellType>(
    node_path: &Path,
    node_bytes: &[u8],
    ele_path: &Path,
    ele_bytes: &[u8],
    face: Option<(&Path, &[u8])>,
) -> Result<ImportedMesh<C>> {
    parse_raw(node_path, node_bytes, ele_path, ele_bytes, face)?.finish(ele_path)
}

/// The nodes, tets and faces of the files' bytes, before the mesh is built.
fn parse_raw(
    node_path: &Path,
    node_bytes: &[u8],
    ele_path: &Path,
    ele_bytes: &[u8],
    face: Option<(&Path, &[u8])>,
) -> Result<RawMesh> {
    let mut raw = RawMesh::default();
    let base = read_nodes(node_path, decode(node_path, node_bytes)?, &mut raw)?;
    read_tets(ele_path, decode(ele_path, ele_bytes)?, base, &mut raw)?;
    if let Some((face_path, face_bytes)) = face {
        read_faces(face_path, decode(face_path, face_bytes)?, base, &mut raw)?;
    }
    Ok(raw)
}

fn read_nodes(path: &Path, text: &str, raw: &mut RawMesh) -> Result<usize> {
    let mut records = Records::new(path, text, Some('#'));
    let header = records.next("the header '<points> <dimension> <attributes> <markers>'")?;
    let count: usize = header.number(0, "number of points")?;
    let dimension: usize = header.number(1, "dimension")?;
    if dimension != 3 {
        return Err(header.error(format!(
            "dimension is {dimension}; only 3-D meshes are supported"
        )));
    }
    let attributes: usize = if header.fields.len() > 2 {
        header.number(2, "number of attributes")?
    } else {
        0
    };
    let markers: usize = if header.fields.len() > 3 {
        header.number(3, "marker flag")?
    } else {
        0
    };
    if markers > 1 {
        return Err(header.error(format!("the marker flag is {markers}; it must be 0 or 1")));
    }
    let fields = attributes.checked_add(4 + markers).ok_or_else(|| {
        header.error(format!(
            "{attributes} attributes per point is more than a line can hold"
        ))
    })?;
    // Cap the reservation by the input size: a header may lie about the count.
    raw.nodes.reserve(count.min(text.len()));
    let mut node_markers = Vec::new();
    let mut base = 0;
    for i in 0..count {
        let r = records.next(&format!("point {} of {count}", i + 1))?;
        r.expect_at_least(fields, "index, x, y, z, attributes and marker")?;
        let index: usize = r.number(0, "point index")?;
        if i == 0 {
            if index > 1 {
                return Err(r.error(format!(
                    "the first point index is {index}; it must be 0 or 1"
                )));
            }
            base = index;
        } else if index != base + i {
            return Err(r.error(format!(
                "point index {index} is out of sequence (expected {})",
                base + i
            )));
        }
        let p = Vector3::new(r.finite(1, "x")?, r.finite(2, "y")?, r.finite(3, "z")?);
        if markers == 1 {
            node_markers.push(r.number(4 + attributes, "boundary marker")?);
        }
        raw.nodes.push(p);
        raw.node_lines.push(r.line);
        raw.node_ids.push(index as u64);
    }
    if let Some(extra) = records.try_next() {
        return Err(extra.error(format!(
            "more points than the header's count {count} (wrong count in the header?)"
        )));
    }
    if markers == 1 {
        raw.node_markers = Some(node_markers);
    }
    Ok(base)
}

fn read_tets(path: &Path, text: &str, base: usize, raw: &mut RawMesh) -> Result<()> {
    let mut records = Records::new(path, text, Some('#'));
    let (count, per_tet, attributes) = ele_header(&mut records)?;
    let fields = 1 + per_tet + attributes;
    let node_count = raw.nodes.len();
    raw.tets.reserve(count.min(text.len()));
    let mut tet_attributes = Vec::new();
    for i in 0..count {
        let r = records.next(&format!("tet {} of {count}", i + 1))?;
        r.expect_at_least(fields, "index, nodes and attributes")?;
        let index: usize = r.number(0, "tet index")?;
        if index != base + i {
            return Err(r.error(format!(
                "tet index {index} is out of sequence (expected {}, the .node file's base is {base})",
                base + i
            )));
        }
        let mut tet = [0usize; 10];
        for (k, slot) in tet.iter_mut().enumerate().take(per_tet) {
            let n: usize = r.number(1 + k, "node index")?;
            if n < base || n - base >= node_count {
                return Err(r.error(format!(
                    "node index {n} is out of range (the .node file has points {base}..={})",
                    (base + node_count).saturating_sub(1)
                )));
            }
            *slot = n - base;
        }
        if attributes > 0 {
            tet_attributes.push(r.finite(1 + per_tet, "attribute")?);
        }
        let corners = [tet[0], tet[1], tet[2], tet[3]];
        if per_tet == 10 {
            let edges = TETGEN_EDGE_NODE.map(|k| tet[4 + k]);
            raw.push_quadratic(corners, edges, r.line, index as u64);
        } else {
            raw.push_linear(corners, r.line, index as u64);
        }
    }
    if let Some(extra) = records.try_next() {
        return Err(extra.error(format!(
            "more tets than the header's count {count} (wrong count in the header?)"
        )));
    }
    if attributes > 0 {
        raw.tet_attributes = Some(tet_attributes);
    }
    Ok(())
}

/// The `.ele` header: tets, nodes per tet (4 or 10, default 4), attributes (default 0).
fn ele_header(records: &mut Records) -> Result<(usize, usize, usize)> {
    let header = records.next("the header '<tets> <nodes per tet> <attributes>'")?;
    let count: usize = header.number(0, "number of tets")?;
    let per_tet: usize = if header.fields.len() > 1 {
        header.number(1, "nodes per tet")?
    } else {
        4
    };
    if per_tet != 4 && per_tet != 10 {
        return Err(header.error(format!(
            "{per_tet} nodes per tet; only 4 and 10 are supported"
        )));
    }
    let attributes: usize = if header.fields.len() > 2 {
        header.number(2, "number of attributes")?
    } else {
        0
    };
    if attributes.checked_add(1 + per_tet).is_none() {
        return Err(header.error(format!(
            "{attributes} attributes per tet is more than a line can hold"
        )));
    }
    Ok((count, per_tet, attributes))
}

fn read_faces(path: &Path, text: &str, base: usize, raw: &mut RawMesh) -> Result<()> {
    let mut records = Records::new(path, text, Some('#'));
    let header = records.next("the header '<faces> <markers>'")?;
    let count: usize = header.number(0, "number of faces")?;
    let markers: usize = if header.fields.len() > 1 {
        header.number(1, "marker flag")?
    } else {
        0
    };
    if markers > 1 {
        return Err(header.error(format!("the marker flag is {markers}; it must be 0 or 1")));
    }
    let node_count = raw.nodes.len();
    let mut faces = Vec::with_capacity(count.min(text.len()));
    for i in 0..count {
        let r = records.next(&format!("face {} of {count}", i + 1))?;
        r.expect_at_least(4 + markers, "index, three nodes and the marker")?;
        // An -o2 face of TetGen ≥ 1.5 lists its three edge nodes after the corners.
        let edge_columns = if raw.is_quadratic() && r.fields.len() >= 7 + markers {
            3
        } else {
            0
        };
        let index: usize = r.number(0, "face index")?;
        if index != base + i {
            return Err(r.error(format!(
                "face index {index} is out of sequence (expected {}, the .node file's base is {base})",
                base + i
            )));
        }
        let mut nodes = [0usize; 3];
        for (k, slot) in nodes.iter_mut().enumerate() {
            let n: usize = r.number(1 + k, "node index")?;
            if n < base || n - base >= node_count {
                return Err(r.error(format!(
                    "node index {n} is out of range (the .node file has points {base}..={})",
                    (base + node_count).saturating_sub(1)
                )));
            }
            *slot = n - base;
        }
        if edge_columns == 3 {
            let mut listed = [0usize; 3];
            for (k, slot) in listed.iter_mut().enumerate() {
                let n: usize = r.number(4 + k, "edge node index")?;
                *slot = n.wrapping_sub(base);
            }
            raw.listed_edge_nodes.push(ListedEdgeNodes {
                path: path.to_path_buf(),
                line: r.line,
                corners: nodes,
                listed,
                base,
            });
        }
        if markers == 1 {
            let marker: i64 = r.number(4 + edge_columns, "boundary marker (an integer)")?;
            faces.push(MarkedFace { nodes, marker });
        }
    }
    if let Some(extra) = records.try_next() {
        return Err(extra.error(format!(
            "more faces than the header's count {count} (wrong count in the header?)"
        )));
    }
    if markers == 1 {
        raw.face_markers = Some(faces);
    }
    Ok(())
}

/// Writes `<prefix>.node` and `<prefix>.ele` (each atomically) with indices from
/// `options.base`; coordinates are written with Rust's shortest round-trip formatting, so a
/// read gives back the identical mesh.
pub fn write_tetgen(prefix: &Path, mesh: &TetMesh, options: &TetgenOptions) -> Result<()> {
    if options.base > 1 {
        return Err(Error::invalid_parameter(
            "base",
            options.base,
            "must be 0 or 1",
        ));
    }
    if let Some(m) = &options.node_markers
        && m.len() != mesh.node_count()
    {
        return Err(Error::invalid_parameter(
            "node_markers",
            m.len(),
            format!("must have one marker per node ({})", mesh.node_count()),
        ));
    }
    if let Some(a) = &options.tet_attributes
        && (a.len() != mesh.tet_count() || a.iter().any(|v| !v.is_finite()))
    {
        return Err(Error::invalid_parameter(
            "tet_attributes",
            a.len(),
            format!(
                "must have one finite attribute per tet ({})",
                mesh.tet_count()
            ),
        ));
    }
    let base = options.base;
    write_atomically(&with_suffix(prefix, ".node"), |out: &mut dyn Write| {
        writeln!(out, "# written by tetfem; {base}-based indices")?;
        let has_markers = options.node_markers.is_some() as usize;
        writeln!(out, "{} 3 0 {has_markers}", mesh.node_count())?;
        for (i, p) in mesh.nodes().iter().enumerate() {
            write!(out, "{} {} {} {}", i + base, p.x, p.y, p.z)?;
            if let Some(m) = &options.node_markers {
                write!(out, " {}", m[i])?;
            }
            writeln!(out)?;
        }
        Ok(())
    })?;
    write_atomically(&with_suffix(prefix, ".ele"), |out: &mut dyn Write| {
        writeln!(
            out,
            "# written by tetfem; {base}-based indices, positively oriented tets"
        )?;
        let has_attributes = options.tet_attributes.is_some() as usize;
        writeln!(out, "{} 4 {has_attributes}", mesh.tet_count())?;
        for (i, t) in mesh.tets().iter().enumerate() {
            write!(
                out,
                "{} {} {} {} {}",
                i + base,
                t[0] + base,
                t[1] + base,
                t[2] + base,
                t[3] + base
            )?;
            if let Some(a) = &options.tet_attributes {
                write!(out, " {}", a[i])?;
            }
            writeln!(out)?;
        }
        Ok(())
    })
}
