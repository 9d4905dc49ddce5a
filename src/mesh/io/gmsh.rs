//! Gmsh `.msh` files: MSH 4.1 ASCII and binary read through the `mshio` crate, MSH 2.2 ASCII
//! through [`super::gmsh22`], MSH 4.1 ASCII written by [`write_gmsh`].
//!
//! Kept: 4-node (type 4) or 10-node (type 11) tetrahedra (the mesh), 3-node (type 2) and 6-node
//! (type 9) triangles (boundary sets of their physical groups), and the physical groups with
//! their names. Other element types are skipped and counted. In MSH 4.1 the physical tags of an
//! element come from its entity in `$Entities`.
//!
//! Gmsh numbers the edges of a 10-node tet (0,1), (1,2), (2,0), (3,0), (3,2), (3,1) (its
//! `MTetrahedron::edges_tetra`): its nodes 8 and 9 are those of edges (2,3) and (1,3), where
//! VTK's (and [`crate::mesh::CellType`]'s quadratic tet's) are (1,3) and (2,3). A 6-node
//! triangle's nodes 3, 4, 5 sit on its edges (0,1), (1,2), (2,0).

use std::collections::{BTreeMap, HashMap};
use std::io::Write;
use std::path::Path;

use mshio::{ElementType, MshFile};
use nalgebra::Vector3;

use super::gmsh41_nodes::{Encoding, TagAt, ascii_elements_fault, element_lines, node_tags};
use super::raw::{RawGroup, RawMesh, RawTriangleMids};
use super::text::{Records, decode, line_of_offset, read_regular_file};
use super::{ImportedMesh, PhysicalGroup, gmsh22};
use crate::base::atomic_file::write_atomically;
use crate::base::error::{Error, Result};
use crate::mesh::{CellType, Tet4, TetMesh};

/// Gmsh's edge nodes of a 10-node tet (element nodes 4–9) in the raw mesh's VTK edge order:
/// VTK edge k is Gmsh node `GMSH_TET10_EDGE_NODE[k]`.
const GMSH_TET10_EDGE_NODE: [usize; 6] = [4, 5, 6, 7, 9, 8];

/// The raw mesh's corners and VTK-ordered edge nodes of a Gmsh 10-node tet's node list.
pub(crate) fn tet10_from_gmsh(nodes: &[usize]) -> ([usize; 4], [usize; 6]) {
    (
        [nodes[0], nodes[1], nodes[2], nodes[3]],
        GMSH_TET10_EDGE_NODE.map(|k| nodes[k]),
    )
}

/// Reads a Gmsh mesh file (MSH 4.1 ASCII or binary, or MSH 2.2 ASCII): reads its bytes and
/// hands them to [`parse_gmsh`]. A path that is not a regular file (a FIFO, a device such as
/// `/dev/urandom`) is an [`Error::Parse`] before anything is read. As 4-node tets: of a
/// quadratic file the corners (see [`read_gmsh_as`]).
pub fn read_gmsh(path: &Path) -> Result<ImportedMesh> {
    read_gmsh_as::<Tet4>(path)
}

/// [`read_gmsh`] as cells of type `C`: `Tet4` for any file (of a quadratic one its corners),
/// `tetfem::Tet10` for a file of 10-node tets (a linear file is an error).
pub fn read_gmsh_as<C: CellType>(path: &Path) -> Result<ImportedMesh<C>> {
    let bytes = read_regular_file(path)?;
    parse_gmsh_as(path, &bytes)
}

/// Parses the contents of a Gmsh mesh file (MSH 4.1 ASCII or binary, or MSH 2.2 ASCII) held in
/// memory. `path` is not opened: it only labels the [`Error::Parse`] errors (use the file the
/// bytes came from, or a placeholder such as `<memory>.msh`). As 4-node tets (see
/// [`parse_gmsh_as`]).
pub fn parse_gmsh(path: &Path, bytes: &[u8]) -> Result<ImportedMesh> {
    parse_gmsh_as::<Tet4>(path, bytes)
}

/// [`parse_gmsh`] as cells of type `C` (see [`read_gmsh_as`]).
pub fn parse_gmsh_as<C: CellType>(path: &Path, bytes: &[u8]) -> Result<ImportedMesh<C>> {
    parse_raw(path, bytes)?.finish(path)
}

/// The file's elements as read (with the line of each), before the mesh is built.
pub(crate) fn read_raw(path: &Path) -> Result<RawMesh> {
    let bytes = read_regular_file(path)?;
    parse_raw(path, &bytes)
}

/// The file's elements as read, with the line of each.
fn parse_raw(path: &Path, bytes: &[u8]) -> Result<RawMesh> {
    let (version, binary, data_size) = format_line(path, bytes)?;
    let raw = match (version.as_str(), binary) {
        ("4.1", _) => {
            // Gmsh writes sizeof(size_t); mshio has no reader for other sizes (it panics).
            let size = match data_size.as_str() {
                "4" => 4,
                "8" => 8,
                other => {
                    return Err(Error::parse(
                        path,
                        2,
                        format!(
                            "data-size '{other}' is not supported: MSH 4.1 needs 4 or 8 (the size of size_t)"
                        ),
                    ));
                }
            };
            check_section_counts(path, bytes, binary, size)?;
            let encoding = match binary.then(|| binary_little_endian(bytes)) {
                None => Encoding::Ascii,
                Some(Some(little_endian)) => Encoding::Binary {
                    size,
                    little_endian,
                },
                Some(None) => {
                    return Err(Error::parse(
                        path,
                        3,
                        "a binary MSH 4.1 file must follow its format line with the integer 1 (4 bytes, to show the byte order)",
                    ));
                }
            };
            return parse_v41(path, bytes, encoding);
        }
        (v, false) if v.starts_with("2.") => gmsh22::parse(path, decode(path, bytes)?)?,
        (v, true) if v.starts_with("2.") => {
            return Err(Error::parse(
                path,
                2,
                format!(
                    "binary MSH {v} is not supported; save as MSH 4.1 (ASCII or binary) or MSH 2.2 ASCII"
                ),
            ));
        }
        (v, _) => {
            return Err(Error::parse(
                path,
                2,
                format!(
                    "unsupported MSH version {v}; supported: 4.1 (ASCII, binary) and 2.2 (ASCII)"
                ),
            ));
        }
    };
    Ok(raw)
}

/// The version, the binary flag and the data-size field from the `$MeshFormat` header's second
/// line.
fn format_line(path: &Path, bytes: &[u8]) -> Result<(String, bool, String)> {
    let mut lines = bytes.split(|&b| b == b'\n');
    let first = lines
        .next()
        .map(String::from_utf8_lossy)
        .unwrap_or_default();
    if first.trim() != "$MeshFormat" {
        return Err(Error::parse(
            path,
            1,
            "not a Gmsh mesh: the file must start with $MeshFormat",
        ));
    }
    let second = lines
        .next()
        .map(String::from_utf8_lossy)
        .unwrap_or_default();
    let fields: Vec<&str> = second.split_whitespace().collect();
    if fields.len() < 3 {
        return Err(Error::parse(
            path,
            2,
            "the format line must read '<version> <file-type> <data-size>' (the file is truncated?)",
        ));
    }
    let binary = match fields[1] {
        "0" => false,
        "1" => true,
        other => {
            return Err(Error::parse(
                path,
                2,
                format!("file-type '{other}' must be 0 (ASCII) or 1 (binary)"),
            ));
        }
    };
    Ok((fields[0].to_string(), binary, fields[2].to_string()))
}

/// Rejects a `$Nodes` or `$Elements` section of an MSH 4.1 file whose header announces no
/// entries: mshio 0.4 computes `count − 1` there, which overflows (a panic where overflow checks
/// are on) on such a header. Either section empty means the file holds no tet anyway. Every
/// line that reads `$Nodes` or `$Elements` is checked, not only the one mshio takes for the
/// section: a zero count after such a line elsewhere only turns a broken file's error into
/// this one.
///
/// The header `<blocks> <count> <min tag> <max tag>` is text in ASCII files and follows the
/// section's line as size_t values of `size` bytes in binary files (in the byte order that the
/// integer 1 after the format line shows).
fn check_section_counts(path: &Path, bytes: &[u8], binary: bool, size: usize) -> Result<()> {
    let little_endian = if binary {
        match binary_little_endian(bytes) {
            Some(le) => le,
            // mshio reports a bad endianness integer itself.
            None => return Ok(()),
        }
    } else {
        true
    };
    for (after, line, tag) in section_starts(bytes, &["$Nodes", "$Elements"]) {
        let what = if tag == "$Nodes" { "nodes" } else { "elements" };
        let rest = &bytes[after..];
        let header: Option<Vec<u64>> = if binary {
            rest.chunks_exact(size)
                .take(4)
                .map(|c| {
                    let mut b = [0u8; 8];
                    if little_endian {
                        b[..size].copy_from_slice(c);
                        Some(u64::from_le_bytes(b))
                    } else {
                        b[8 - size..].copy_from_slice(c);
                        Some(u64::from_be_bytes(b))
                    }
                })
                .collect()
        } else {
            String::from_utf8_lossy(&rest[..rest.len().min(256)])
                .split_whitespace()
                .take(4)
                .map(|f| f.parse().ok())
                .collect()
        };
        if let Some(&[_, 0, min, max]) = header.as_deref()
            && min >= 1
            && max >= min
        {
            return Err(Error::parse(
                path,
                line + 1,
                format!(
                    "the {tag} section announces 0 {what} (header <blocks> <count> <min tag> <max tag> has count 0): the file holds no mesh"
                ),
            ));
        }
    }
    Ok(())
}

/// The byte order of a binary MSH 4.1 file, from the integer 1 that follows the format line
/// (`None` if it is neither 1 little- nor big-endian).
fn binary_little_endian(bytes: &[u8]) -> Option<bool> {
    let mut lines = bytes.splitn(3, |&b| b == b'\n');
    match lines.nth(2).and_then(|rest| rest.get(..4)) {
        Some([1, 0, 0, 0]) => Some(true),
        Some([0, 0, 0, 1]) => Some(false),
        _ => None,
    }
}

/// Every line that reads one of `tags` (wherever mshio might take it for a section start): the
/// byte offset just after it, its 1-based number and the tag.
fn section_starts<'t>(bytes: &[u8], tags: &[&'t str]) -> Vec<(usize, usize, &'t str)> {
    let mut starts = Vec::new();
    let mut offset = 0;
    for (i, line) in bytes.split(|&b| b == b'\n').enumerate() {
        offset += line.len() + 1;
        let text = String::from_utf8_lossy(line);
        if let Some(&tag) = tags.iter().find(|&&t| text.trim() == t) {
            starts.push((offset.min(bytes.len()), i + 1, tag));
        }
    }
    starts
}

/// 1-based line of the first line that reads `tag` (0 if none).
fn line_of(bytes: &[u8], tag: &str) -> usize {
    bytes
        .split(|&b| b == b'\n')
        .position(|l| String::from_utf8_lossy(l).trim() == tag)
        .map_or(0, |i| i + 1)
}

/// `$PhysicalNames` (ASCII even in binary files; it precedes `$Entities` and `$Nodes`).
fn physical_names(path: &Path, bytes: &[u8]) -> Result<HashMap<(usize, i32), String>> {
    let mut names = HashMap::new();
    let Some(start) = line_of_section(bytes) else {
        return Ok(names);
    };
    // Decode only the lines up to the section's end as text.
    let tail = &bytes[start.0..];
    let end = find(tail, b"$EndPhysicalNames").map_or(tail.len(), |e| e + 17);
    let text = String::from_utf8_lossy(&tail[..end]);
    let mut records = Records::new(path, &text, None);
    let offset = start.1 - 1;
    let shift = |e: Error| match e {
        Error::Parse {
            path,
            line,
            message,
        } => Error::Parse {
            path,
            line: line + offset,
            message,
        },
        other => other,
    };
    let result = (|| {
        records.next("$PhysicalNames")?;
        let count: usize = records
            .next("the number of physical names")?
            .number(0, "number of physical names")?;
        for _ in 0..count {
            let r = records.next("a physical name '<dim> <tag> \"name\"'")?;
            let dim: usize = r.number(0, "dimension")?;
            let tag: i32 = r.number(1, "physical tag")?;
            r.field(2, "name")?;
            names.insert((dim, tag), r.rest_after(2).trim_matches('"').to_string());
        }
        let r = records.next("$EndPhysicalNames")?;
        if r.text != "$EndPhysicalNames" {
            return Err(r.error(format!(
                "expected $EndPhysicalNames, found '{}' (wrong count?)",
                r.text
            )));
        }
        Ok(())
    })();
    result.map_err(shift)?;
    Ok(names)
}

/// Byte offset and 1-based line of a `$PhysicalNames` line that comes before `$Nodes`.
fn line_of_section(bytes: &[u8]) -> Option<(usize, usize)> {
    let mut offset = 0;
    for (i, line) in bytes.split(|&b| b == b'\n').enumerate() {
        let text = String::from_utf8_lossy(line);
        match text.trim() {
            "$PhysicalNames" => return Some((offset, i + 1)),
            "$Nodes" | "$Entities" => return None,
            _ => {}
        }
        offset += line.len() + 1;
    }
    None
}

fn find(haystack: &[u8], needle: &[u8]) -> Option<usize> {
    haystack.windows(needle.len()).position(|w| w == needle)
}

type Msh = MshFile<u64, i32, f64>;

fn parse_v41(path: &Path, bytes: &[u8], encoding: Encoding) -> Result<RawMesh> {
    let binary = matches!(encoding, Encoding::Binary { .. });
    // mshio is a nom parser over untrusted input; a panic inside it must not take the caller
    // down, so it is contained here and reported as a parse error.
    let parsed = std::panic::catch_unwind(|| {
        mshio::parse_msh_bytes(bytes).map_err(|e| {
            let offset = e
                .backtrace
                .first()
                .map(|(rest, _)| (rest.as_ptr() as usize).saturating_sub(bytes.as_ptr() as usize))
                .unwrap_or(0);
            let mut parts: Vec<String> = e
                .backtrace
                .iter()
                .rev()
                .map(|(_, k)| k.to_string())
                .collect();
            parts.dedup();
            (offset, parts.join(": "))
        })
    });
    // mshio reports a fault of an element line where its stream of numbers fails, often
    // lines later: on its failure an ASCII section is read line by line to name the line.
    let elements_fault = || {
        section_starts(bytes, &["$Elements"])
            .first()
            .filter(|_| !binary)
            .and_then(|&(start, _, _)| ascii_elements_fault(path, bytes, start))
    };
    let msh: Msh = match parsed {
        Ok(Ok(msh)) => msh,
        Ok(Err((offset, message))) => {
            if let Some(fault) = elements_fault() {
                return Err(fault);
            }
            let at = if binary {
                format!(" (byte offset {offset})")
            } else {
                String::new()
            };
            return Err(Error::parse(
                path,
                line_of_offset(bytes, offset),
                format!("invalid MSH 4.1 data{at}: {message}"),
            ));
        }
        Err(_) => {
            if let Some(fault) = elements_fault() {
                return Err(fault);
            }
            return Err(Error::parse(
                path,
                0,
                "the MSH 4.1 parser failed on this file (malformed data)",
            ));
        }
    };
    convert(path, bytes, encoding, msh)
}

fn convert(path: &Path, bytes: &[u8], encoding: Encoding, msh: Msh) -> Result<RawMesh> {
    let names = physical_names(path, bytes)?;
    // Physical tags of each entity (dim, tag).
    let mut entity_tags: HashMap<(usize, i32), Vec<i32>> = HashMap::new();
    if let Some(e) = &msh.data.entities {
        for p in &e.points {
            entity_tags.insert((0, p.tag), p.physical_tags.clone());
        }
        for c in &e.curves {
            entity_tags.insert((1, c.tag), c.physical_tags.clone());
        }
        for s in &e.surfaces {
            entity_tags.insert((2, s.tag), s.physical_tags.clone());
        }
        for v in &e.volumes {
            entity_tags.insert((3, v.tag), v.physical_tags.clone());
        }
    }
    let Some(nodes) = &msh.data.nodes else {
        return Err(Error::parse(path, 0, "no $Nodes section"));
    };
    let nodes_line = line_of(bytes, "$Nodes");
    let start = section_starts(bytes, &["$Nodes"])
        .first()
        .map_or(bytes.len(), |s| s.0);
    let block_tags = node_tags(path, bytes, start, encoding)?;
    let counts = |b: &[Vec<TagAt>]| b.iter().map(Vec::len).collect::<Vec<_>>();
    let mshio_counts: Vec<usize> = nodes.node_blocks.iter().map(|b| b.nodes.len()).collect();
    if counts(&block_tags) != mshio_counts {
        return Err(Error::parse(
            path,
            nodes_line,
            format!(
                "the $Nodes section at this line has blocks of {:?} nodes, but the section the MSH 4.1 parser read has {:?} (a second $Nodes line?)",
                counts(&block_tags),
                mshio_counts
            ),
        ));
    }
    let mut raw = RawMesh::default();
    let mut tag_index: HashMap<u64, usize> = HashMap::new();
    for (block, tags) in nodes.node_blocks.iter().zip(&block_tags) {
        for (node, &(tag, line)) in block.nodes.iter().zip(tags) {
            if let Some(first) = tag_index.insert(tag, raw.nodes.len()) {
                return Err(Error::parse(
                    path,
                    line,
                    format!(
                        "node tag {tag} appears twice (first on line {}): every node needs its own tag",
                        raw.node_lines[first]
                    ),
                ));
            }
            raw.nodes.push(Vector3::new(node.x, node.y, node.z));
            raw.node_lines.push(line);
            raw.node_ids.push(tag);
        }
    }
    let elements_line = line_of(bytes, "$Elements");
    let lines = element_lines_of(path, bytes, encoding, &msh);
    // The line of element `e` of block `b` (the section's line if the section does not read
    // as mshio read it).
    let line_at = |b: usize, e: usize| {
        lines
            .as_ref()
            .and_then(|l| l.get(b)?.get(e))
            .map_or(elements_line, |&(_, line)| line)
    };
    let mut groups: BTreeMap<(usize, i32), RawGroup> = BTreeMap::new();
    if let Some(elements) = &msh.data.elements {
        for (block_index, block) in elements.element_blocks.iter().enumerate() {
            let dim = usize::try_from(block.entity_dim).unwrap_or(0);
            let physical = entity_tags
                .get(&(dim, block.entity_tag))
                .cloned()
                .unwrap_or_default();
            for (element_index, element) in block.elements.iter().enumerate() {
                let line = line_at(block_index, element_index);
                let mut nodes = Vec::with_capacity(element.nodes.len());
                for &tag in &element.nodes {
                    let index = *tag_index.get(&tag).ok_or_else(|| {
                        Error::parse(
                            path,
                            line,
                            format!(
                                "element {} (entity {dim}:{}) refers to node tag {tag}, which $Nodes does not define",
                                element.element_tag, block.entity_tag
                            ),
                        )
                    })?;
                    nodes.push(index);
                }
                let mut each_group = |f: &mut dyn FnMut(&mut RawGroup)| {
                    for &p in &physical {
                        f(groups.entry((dim, p)).or_insert_with(|| RawGroup {
                            dim,
                            tag: p,
                            name: names.get(&(dim, p)).cloned(),
                            ..RawGroup::default()
                        }));
                    }
                };
                match (block.element_type, nodes.as_slice()) {
                    (ElementType::Tet4, &[a, b, c, d]) => {
                        let t = raw.tets.len();
                        each_group(&mut |g| g.tets.push(t));
                        raw.push_linear([a, b, c, d], line, element.element_tag);
                    }
                    (ElementType::Tet10, n) if n.len() == 10 => {
                        let t = raw.tets.len();
                        each_group(&mut |g| g.tets.push(t));
                        let (corners, edges) = tet10_from_gmsh(n);
                        raw.push_quadratic(corners, edges, line, element.element_tag);
                    }
                    (ElementType::Tri3, &[a, b, c]) => {
                        each_group(&mut |g| g.triangles.push([a, b, c]));
                    }
                    (ElementType::Tri6, &[a, b, c, ab, bc, ca]) => {
                        each_group(&mut |g| {
                            g.triangles.push([a, b, c]);
                            g.other_nodes.extend([ab, bc, ca]);
                        });
                        raw.triangle_mids.push(RawTriangleMids {
                            corners: [a, b, c],
                            mids: [ab, bc, ca],
                            line,
                        });
                    }
                    (other, _) => {
                        each_group(&mut |g| g.other_nodes.extend(&nodes));
                        raw.skip(&format!("{other:?}"), dim == 3, line);
                    }
                }
            }
        }
    }
    raw.groups = groups.into_values().collect();
    Ok(raw)
}

/// The tag and line of every element of the file's `$Elements` section, per block, from one
/// pass over the first line reading `$Elements` at which the section reads as mshio read it
/// (the same block sizes and element tags); `None` if none does.
fn element_lines_of(
    path: &Path,
    bytes: &[u8],
    encoding: Encoding,
    msh: &Msh,
) -> Option<Vec<Vec<TagAt>>> {
    let elements = msh.data.elements.as_ref()?;
    let layout: Vec<(usize, usize)> = elements
        .element_blocks
        .iter()
        .map(|block| {
            let nodes = block.elements.first().map_or(0, |e| e.nodes.len());
            (block.elements.len(), nodes)
        })
        .collect();
    let same_tags = |lines: &Vec<Vec<TagAt>>| {
        lines.iter().zip(&elements.element_blocks).all(|(l, b)| {
            l.iter()
                .zip(&b.elements)
                .all(|(&(tag, _), e)| tag == e.element_tag)
        })
    };
    section_starts(bytes, &["$Elements"])
        .iter()
        .filter_map(|&(start, _, _)| element_lines(path, bytes, start, encoding, &layout))
        .find(same_tags)
}

/// Writes `mesh` as MSH 4.1 ASCII (atomically), with `groups`' triangles as surface physical
/// groups (one surface entity each) and all tets in one volume entity that carries the tags of
/// the volume groups. Volume groups must cover every tet; point and curve groups are not written.
///
/// Node tags are 1…n in mesh order, element tags 1…m (tets first), coordinates in Rust's
/// shortest round-trip formatting: reading the file back gives the identical mesh.
pub fn write_gmsh(path: &Path, mesh: &TetMesh, groups: &[PhysicalGroup]) -> Result<()> {
    let surfaces: Vec<&PhysicalGroup> = groups.iter().filter(|g| g.dim == 2).collect();
    let volumes: Vec<&PhysicalGroup> = groups.iter().filter(|g| g.dim == 3).collect();
    for g in &volumes {
        if g.tets.len() != mesh.tet_count() {
            return Err(Error::invalid_parameter(
                format!("volume group {}", g.label()),
                format!("{} tets", g.tets.len()),
                format!(
                    "the writer puts all tets in one volume, so a volume group must hold all {}",
                    mesh.tet_count()
                ),
            ));
        }
    }
    for g in &surfaces {
        if let Some(t) = g
            .triangles
            .iter()
            .find(|t| t.iter().any(|&n| n >= mesh.node_count()))
        {
            return Err(Error::UnknownNode {
                context: "surface group triangle",
                node: t.iter().copied().max().unwrap_or(0),
                node_count: mesh.node_count(),
            });
        }
    }
    let (lo, hi) = mesh.bounding_box();
    let bbox = format!("{} {} {} {} {} {}", lo.x, lo.y, lo.z, hi.x, hi.y, hi.z);
    write_atomically(path, |out: &mut dyn Write| {
        writeln!(out, "$MeshFormat\n4.1 0 8\n$EndMeshFormat")?;
        let named: Vec<&&PhysicalGroup> = surfaces.iter().chain(&volumes).collect();
        if !named.is_empty() {
            writeln!(out, "$PhysicalNames\n{}", named.len())?;
            for g in &named {
                let name = g.name.clone().unwrap_or_else(|| format!("group{}", g.tag));
                writeln!(out, "{} {} \"{}\"", g.dim, g.tag, name.replace('"', "'"))?;
            }
            writeln!(out, "$EndPhysicalNames")?;
        }
        writeln!(out, "$Entities\n0 0 {} 1", surfaces.len())?;
        for (i, g) in surfaces.iter().enumerate() {
            writeln!(out, "{} {bbox} 1 {} 0", i + 1, g.tag)?;
        }
        write!(out, "1 {bbox} {}", volumes.len())?;
        for g in &volumes {
            write!(out, " {}", g.tag)?;
        }
        writeln!(out, " 0\n$EndEntities")?;
        let n = mesh.node_count();
        writeln!(out, "$Nodes\n1 {n} 1 {n}\n3 1 0 {n}")?;
        for i in 1..=n {
            writeln!(out, "{i}")?;
        }
        for p in mesh.nodes() {
            writeln!(out, "{} {} {}", p.x, p.y, p.z)?;
        }
        writeln!(out, "$EndNodes")?;
        let triangles: usize = surfaces.iter().map(|g| g.triangles.len()).sum();
        let total = mesh.tet_count() + triangles;
        writeln!(out, "$Elements\n{} {total} 1 {total}", 1 + surfaces.len())?;
        writeln!(out, "3 1 4 {}", mesh.tet_count())?;
        let mut tag = 0usize;
        for t in mesh.tets() {
            tag += 1;
            writeln!(
                out,
                "{tag} {} {} {} {}",
                t[0] + 1,
                t[1] + 1,
                t[2] + 1,
                t[3] + 1
            )?;
        }
        for (i, g) in surfaces.iter().enumerate() {
            writeln!(out, "2 {} 2 {}", i + 1, g.triangles.len())?;
            for t in &g.triangles {
                tag += 1;
                writeln!(out, "{tag} {} {} {}", t[0] + 1, t[1] + 1, t[2] + 1)?;
            }
        }
        writeln!(out, "$EndElements")
    })
}

#[cfg(test)]
mod tests {
    use std::fmt::Write as _;

    use super::*;
    use crate::mesh::BoxSplit;
    use crate::mesh::Tet10;

    /// Gmsh's node k of a 10-node tet is VTK's (the mesh's) node `VTK_OF_GMSH[k]`.
    const VTK_OF_GMSH: [usize; 10] = [0, 1, 2, 3, 4, 5, 6, 7, 9, 8];

    /// MSH 4.1 ASCII of the unit box's 10-node tets on `cells`, with every boundary face as a
    /// 6-node triangle of one surface group; the numbers of tets and triangles.
    fn quadratic_box(cells: [usize; 3]) -> (String, usize, usize) {
        let linear = TetMesh::box_grid(
            Vector3::zeros(),
            Vector3::repeat(1.0),
            cells,
            BoxSplit::Lecture6,
        )
        .unwrap();
        let mesh = TetMesh::<Tet10>::from_linear(&linear).unwrap();
        let boundary = mesh.boundary_faces().unwrap();
        let n = mesh.node_count();
        let (tets, tris) = (mesh.tet_count(), boundary.len());
        let mut s = String::from(
            "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Entities\n0 0 1 1\n\
             1 0 0 0 1 1 1 1 2 0\n1 0 0 0 1 1 1 1 1 0\n$EndEntities\n",
        );
        writeln!(s, "$Nodes\n1 {n} 1 {n}\n3 1 0 {n}").unwrap();
        for k in 1..=n {
            writeln!(s, "{k}").unwrap();
        }
        for p in mesh.nodes() {
            writeln!(s, "{} {} {}", p.x, p.y, p.z).unwrap();
        }
        writeln!(s, "$EndNodes\n$Elements\n2 {0} 1 {0}", tets + tris).unwrap();
        writeln!(s, "3 1 11 {tets}").unwrap();
        for (t, cell) in mesh.tets().iter().enumerate() {
            write!(s, "{}", t + 1).unwrap();
            for k in VTK_OF_GMSH {
                write!(s, " {}", cell[k] + 1).unwrap();
            }
            s.push('\n');
        }
        writeln!(s, "2 1 9 {tris}").unwrap();
        for (i, face) in boundary.iter().enumerate() {
            let cell = &mesh.tets()[face.tet];
            let local = |node: usize| cell[..4].iter().position(|&c| c == node).unwrap();
            let [a, b, c] = face.nodes;
            let edge = |p: usize, q: usize| Tet10::edge_node(cell, local(p), local(q)).unwrap();
            let nodes = [a, b, c, edge(a, b), edge(b, c), edge(c, a)];
            write!(s, "{}", tets + i + 1).unwrap();
            for v in nodes {
                write!(s, " {}", v + 1).unwrap();
            }
            s.push('\n');
        }
        s.push_str("$EndElements\n");
        (s, tets, tris)
    }

    /// Issue 33 item 12: reading a quadratic file is linear in its size. Each 6-node triangle
    /// used to find its line by reading the `$Elements` section up to it (a file of 19k tets
    /// took 122 s); the section is now read once for the lines of all elements, whatever the
    /// number of triangles. Counted, not timed.
    #[test]
    fn a_quadratic_file_reads_its_element_lines_in_one_pass() {
        for cells in [[2, 2, 2], [6, 5, 4]] {
            let (text, tets, tris) = quadratic_box(cells);
            super::super::gmsh41_nodes::SECTION_SCANS.with(|n| n.set(0));
            let imported = parse_gmsh_as::<Tet10>(Path::new("box.msh"), text.as_bytes()).unwrap();
            let scans = super::super::gmsh41_nodes::SECTION_SCANS.with(|n| n.get());
            assert_eq!(imported.mesh.tet_count(), tets);
            assert_eq!(imported.groups[0].triangles.len(), tris);
            assert!(
                tris >= 48,
                "{tris} triangles: too few to tell one pass from one per triangle"
            );
            assert_eq!(
                scans, 1,
                "{tris} triangles read with {scans} passes over $Elements"
            );
        }
    }
}
