//! A small reader of the `.vtu` files tetfem writes, for the tests: the XML header parsed with
//! roxmltree, each `DataArray` decoded from its inline ASCII text or from the appended raw
//! binary block (`UInt64` byte count, then little-endian values) that its `offset` points to.
//! Shared by the root crate's tests and (through `#[path]`) the CLI's.
#![allow(dead_code)]

use std::path::Path;

/// One `DataArray`: where it sits, its VTK type, and its values.
#[derive(Debug, Clone)]
pub struct VtuArray {
    /// `Points`, `Cells`, `PointData`, `CellData` or `FieldData`.
    pub section: String,
    /// Its `Name` (`Points` for the unnamed coordinates).
    pub name: String,
    /// `Float64`, `Int64`, `Int32` or `UInt8`.
    pub vtk_type: String,
    pub components: usize,
    /// The values, converted to f64 (exact for the integers a mesh holds).
    pub values: Vec<f64>,
    /// The little-endian bytes of an appended array as stored (empty for ASCII).
    pub raw: Vec<u8>,
}

/// A parsed `.vtu`.
#[derive(Debug, Clone)]
pub struct Vtu {
    pub points: usize,
    pub cells: usize,
    /// Whether the arrays came from an `<AppendedData encoding="raw">` block.
    pub binary: bool,
    pub arrays: Vec<VtuArray>,
}

impl Vtu {
    /// The array called `name` (panics, naming it, if absent).
    pub fn array(&self, name: &str) -> &VtuArray {
        self.arrays
            .iter()
            .find(|a| a.name == name)
            .unwrap_or_else(|| panic!("no DataArray {name}"))
    }

    /// The values of the array called `name`.
    pub fn values(&self, name: &str) -> &[f64] {
        &self.array(name).values
    }

    /// Whether an array called `name` exists.
    pub fn has(&self, name: &str) -> bool {
        self.arrays.iter().any(|a| a.name == name)
    }
}

/// Reads and parses the file at `path`.
pub fn read_vtu(path: &Path) -> Vtu {
    let bytes = std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    parse_vtu(&bytes)
}

/// Parses a `.vtu` file's bytes, checking the binary layout on the way: every appended block
/// lies inside the appended data, the blocks tile it exactly in order, and each holds a whole
/// number of values of its type, as many as its section needs.
pub fn parse_vtu(bytes: &[u8]) -> Vtu {
    let marker = b"<AppendedData";
    let appended_at = bytes.windows(marker.len()).position(|w| w == marker);
    let (header, data) = match appended_at {
        Some(at) => {
            let underscore = at
                + bytes[at..]
                    .iter()
                    .position(|&b| b == b'_')
                    .expect("'_' starts the appended data");
            let header = std::str::from_utf8(&bytes[..at]).expect("the XML header is UTF-8");
            let opening = std::str::from_utf8(&bytes[at..underscore]).unwrap();
            assert!(opening.contains(r#"encoding="raw""#), "{opening}");
            (
                format!("{header}</VTKFile>"),
                Some(&bytes[underscore + 1..]),
            )
        }
        None => (
            std::str::from_utf8(bytes)
                .expect("an ASCII .vtu is UTF-8")
                .to_string(),
            None,
        ),
    };
    let document = roxmltree::Document::parse(&header).expect("well-formed XML");
    let root = document.root_element();
    assert_eq!(root.attribute("byte_order"), Some("LittleEndian"));
    assert_eq!(root.attribute("header_type"), Some("UInt64"));
    let piece = document
        .descendants()
        .find(|n| n.has_tag_name("Piece"))
        .expect("a Piece");
    let points: usize = piece.attribute("NumberOfPoints").unwrap().parse().unwrap();
    let cells: usize = piece.attribute("NumberOfCells").unwrap().parse().unwrap();
    let mut arrays = Vec::new();
    let mut expected_offset = 0usize;
    for node in document
        .descendants()
        .filter(|n| n.has_tag_name("DataArray"))
    {
        let section = node.parent_element().unwrap().tag_name().name().to_string();
        let name = node.attribute("Name").unwrap_or(&section).to_string();
        let vtk_type = node.attribute("type").unwrap().to_string();
        let components: usize = node
            .attribute("NumberOfComponents")
            .map_or(1, |c| c.parse().unwrap());
        let (values, raw) = match node.attribute("format") {
            Some("ascii") => (
                node.text()
                    .unwrap_or("")
                    .split_whitespace()
                    .map(|v| v.parse::<f64>().unwrap())
                    .collect::<Vec<_>>(),
                Vec::new(),
            ),
            Some("appended") => {
                let data = data.expect("appended arrays need an AppendedData block");
                let offset: usize = node.attribute("offset").unwrap().parse().unwrap();
                assert_eq!(offset, expected_offset, "{name}: blocks follow each other");
                let count = u64::from_le_bytes(data[offset..offset + 8].try_into().unwrap());
                let count = usize::try_from(count).unwrap();
                let raw = data[offset + 8..offset + 8 + count].to_vec();
                expected_offset = offset + 8 + count;
                (decode(&vtk_type, &raw, &name), raw)
            }
            other => panic!("{name}: format {other:?}"),
        };
        let tuples = match section.as_str() {
            "Points" | "PointData" => Some(points),
            "CellData" => Some(cells),
            _ => None,
        };
        if let Some(tuples) = tuples {
            assert_eq!(values.len(), tuples * components, "{name}: length");
        }
        arrays.push(VtuArray {
            section,
            name,
            vtk_type,
            components,
            values,
            raw,
        });
    }
    if let Some(data) = data {
        // After the last block: a newline, the closing tags and nothing else.
        let rest = std::str::from_utf8(&data[expected_offset..]).expect("UTF-8 after the blocks");
        assert_eq!(
            rest.split_whitespace().collect::<Vec<_>>(),
            ["</AppendedData>", "</VTKFile>"]
        );
    }
    Vtu {
        points,
        cells,
        binary: data.is_some(),
        arrays,
    }
}

fn decode(vtk_type: &str, raw: &[u8], name: &str) -> Vec<f64> {
    match vtk_type {
        "Float64" => {
            assert_eq!(raw.len() % 8, 0, "{name}");
            raw.chunks_exact(8)
                .map(|b| f64::from_le_bytes(b.try_into().unwrap()))
                .collect()
        }
        "Int64" => {
            assert_eq!(raw.len() % 8, 0, "{name}");
            raw.chunks_exact(8)
                .map(|b| i64::from_le_bytes(b.try_into().unwrap()) as f64)
                .collect()
        }
        "Int32" => {
            assert_eq!(raw.len() % 4, 0, "{name}");
            raw.chunks_exact(4)
                .map(|b| f64::from(i32::from_le_bytes(b.try_into().unwrap())))
                .collect()
        }
        "UInt8" => raw.iter().map(|&b| f64::from(b)).collect(),
        other => panic!("{name}: type {other}"),
    }
}
