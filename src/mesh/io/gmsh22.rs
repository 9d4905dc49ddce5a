//! Gmsh MSH 2.2 ASCII (the legacy format many tools still write; `mshio` reads only 4.1).
//!
//! Sections used: `$PhysicalNames`, `$Nodes` (`<count>`, then `<tag> <x> <y> <z>`) and
//! `$Elements` (`<count>`, then `<tag> <type> <ntags> <physical> <elementary> … <nodes…>`);
//! other sections are skipped.

use std::collections::{BTreeMap, HashMap};
use std::path::Path;

use nalgebra::Vector3;

use super::gmsh::tet10_from_gmsh;
use super::raw::{RawGroup, RawMesh, RawTriangleMids};
use super::text::{Record, Records};
use crate::base::error::Result;

/// Gmsh element type codes → (name, node count) for the types a 2.2 file may hold.
pub(crate) fn element_type(code: u32) -> Option<(&'static str, usize)> {
    Some(match code {
        1 => ("Lin2", 2),
        2 => ("Tri3", 3),
        3 => ("Qua4", 4),
        4 => ("Tet4", 4),
        5 => ("Hex8", 8),
        6 => ("Pri6", 6),
        7 => ("Pyr5", 5),
        8 => ("Lin3", 3),
        9 => ("Tri6", 6),
        10 => ("Qua9", 9),
        11 => ("Tet10", 10),
        12 => ("Hex27", 27),
        13 => ("Pri18", 18),
        14 => ("Pyr14", 14),
        15 => ("Pnt", 1),
        16 => ("Qua8", 8),
        17 => ("Hex20", 20),
        18 => ("Pri15", 15),
        19 => ("Pyr13", 13),
        _ => return None,
    })
}

/// What the sections read so far hold: the mesh, the physical names, node tags → indices, and
/// the physical groups met in `$Elements` (keyed by dimension and tag).
#[derive(Default)]
struct Parsed {
    raw: RawMesh,
    names: HashMap<(usize, i32), String>,
    tag_index: HashMap<u64, usize>,
    groups: BTreeMap<(usize, i32), RawGroup>,
    seen_nodes: bool,
}

/// Parses the whole text of an MSH 2.2 ASCII file (its `$MeshFormat` already checked).
pub(crate) fn parse(path: &Path, text: &str) -> Result<RawMesh> {
    let mut records = Records::new(path, text, None);
    let mut parsed = Parsed::default();
    while let Some(r) = records.try_next() {
        match r.text {
            "$MeshFormat" => skip_section(&mut records, "$EndMeshFormat")?,
            "$PhysicalNames" => read_physical_names(&mut records, &mut parsed.names)?,
            "$Nodes" => {
                if parsed.seen_nodes {
                    return Err(r.error("a second $Nodes section"));
                }
                parsed.seen_nodes = true;
                read_nodes(&mut records, text.len(), &mut parsed)?;
            }
            "$Elements" => {
                if !parsed.seen_nodes {
                    return Err(r.error("$Elements before $Nodes"));
                }
                read_elements(&mut records, &mut parsed)?;
            }
            other if other.starts_with('$') && !other.starts_with("$End") => {
                let end = format!("$End{}", &other[1..]);
                skip_section(&mut records, &end)?;
            }
            _ => return Err(r.error(format!("unexpected line '{}' outside any section", r.text))),
        }
    }
    if !parsed.seen_nodes {
        return Err(records.error("no $Nodes section"));
    }
    let Parsed {
        mut raw,
        names,
        groups,
        ..
    } = parsed;
    raw.groups = groups
        .into_values()
        .map(|mut g| {
            g.name = names.get(&(g.dim, g.tag)).cloned();
            g
        })
        .collect();
    Ok(raw)
}

/// `$PhysicalNames`: `<count>`, then `<dim> <tag> "name"` per line, up to its end marker.
fn read_physical_names(
    records: &mut Records,
    names: &mut HashMap<(usize, i32), String>,
) -> Result<()> {
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
    expect_end(records, "$EndPhysicalNames")
}

/// `$Nodes`: `<count>`, then `<tag> <x> <y> <z>` per line (a tag at most once), up to its end
/// marker; `text_len` bounds the reservation a forged count could ask for.
fn read_nodes(records: &mut Records, text_len: usize, parsed: &mut Parsed) -> Result<()> {
    let count: usize = records
        .next("the number of nodes")?
        .number(0, "number of nodes")?;
    let raw = &mut parsed.raw;
    raw.nodes.reserve(count.min(text_len));
    for i in 0..count {
        let r = records.next(&format!("node {} of {count}", i + 1))?;
        let tag: u64 = r.number(0, "node tag")?;
        let p = Vector3::new(r.finite(1, "x")?, r.finite(2, "y")?, r.finite(3, "z")?);
        if parsed.tag_index.insert(tag, raw.nodes.len()).is_some() {
            return Err(r.error(format!("node tag {tag} appears twice")));
        }
        raw.nodes.push(p);
        raw.node_lines.push(r.line);
        raw.node_ids.push(tag);
    }
    expect_end(records, "$EndNodes")
}

/// `$Elements`: `<count>`, then `<tag> <type> <ntags> <physical> … <nodes…>` per line (nodes
/// by their `$Nodes` tags), up to its end marker.
fn read_elements(records: &mut Records, parsed: &mut Parsed) -> Result<()> {
    let count: usize = records
        .next("the number of elements")?
        .number(0, "number of elements")?;
    for i in 0..count {
        let r = records.next(&format!("element {} of {count}", i + 1))?;
        let code: u32 = r.number(1, "element type")?;
        let ntags: usize = r.number(2, "number of tags")?;
        let (name, nodes_per) =
            element_type(code).ok_or_else(|| r.error(format!("unknown element type {code}")))?;
        let first = 3usize.saturating_add(ntags);
        r.expect_at_least(first.saturating_add(nodes_per), "tag, type, tags and nodes")?;
        let physical: i32 = if ntags > 0 {
            r.number(3, "physical tag")?
        } else {
            0
        };
        let mut nodes = Vec::with_capacity(nodes_per);
        for k in 0..nodes_per {
            let tag: u64 = r.number(first + k, "node tag")?;
            let index = *parsed
                .tag_index
                .get(&tag)
                .ok_or_else(|| r.error(format!("node tag {tag} is not defined in $Nodes")))?;
            nodes.push(index);
        }
        place_element(parsed, &r, name, physical, &nodes)?;
    }
    expect_end(records, "$EndElements")
}

/// Puts one element of type `name` (nodes as indices) into the mesh: tets into the tets,
/// 6-node triangles' mid-side nodes kept for the quadratic faces, and the element's nodes or
/// cells into its physical group (`physical` ≠ 0); other types are counted as skipped.
fn place_element(
    parsed: &mut Parsed,
    r: &Record,
    name: &'static str,
    physical: i32,
    nodes: &[usize],
) -> Result<()> {
    let dim = match name {
        "Pnt" => 0,
        "Lin2" | "Lin3" => 1,
        "Tri3" | "Tri6" | "Qua4" | "Qua8" | "Qua9" => 2,
        _ => 3,
    };
    let raw = &mut parsed.raw;
    let group = (physical != 0).then(|| {
        parsed
            .groups
            .entry((dim, physical))
            .or_insert_with(|| RawGroup {
                dim,
                tag: physical,
                ..RawGroup::default()
            })
    });
    match name {
        "Tet4" => {
            if let Some(g) = group {
                g.tets.push(raw.tets.len());
            }
            let id = r.number(0, "element tag")?;
            raw.push_linear([nodes[0], nodes[1], nodes[2], nodes[3]], r.line, id);
        }
        "Tet10" => {
            if let Some(g) = group {
                g.tets.push(raw.tets.len());
            }
            let id = r.number(0, "element tag")?;
            let (corners, edges) = tet10_from_gmsh(nodes);
            raw.push_quadratic(corners, edges, r.line, id);
        }
        "Tri3" => {
            if let Some(g) = group {
                g.triangles.push([nodes[0], nodes[1], nodes[2]]);
            }
        }
        "Tri6" => {
            let corners = [nodes[0], nodes[1], nodes[2]];
            let mids = [nodes[3], nodes[4], nodes[5]];
            if let Some(g) = group {
                g.triangles.push(corners);
                g.other_nodes.extend(mids);
            }
            raw.triangle_mids.push(RawTriangleMids {
                corners,
                mids,
                line: r.line,
            });
        }
        _ => {
            if let Some(g) = group {
                g.other_nodes.extend(nodes);
            }
            raw.skip(name, dim == 3, r.line);
        }
    }
    Ok(())
}

fn expect_end(records: &mut Records, end: &str) -> Result<()> {
    let r = records.next(end)?;
    if r.text != end {
        return Err(r.error(format!(
            "expected {end}, found '{}' (the section's count does not match its records)",
            r.text
        )));
    }
    Ok(())
}

fn skip_section(records: &mut Records, end: &str) -> Result<()> {
    loop {
        if records.next(end)?.text == end {
            return Ok(());
        }
    }
}
