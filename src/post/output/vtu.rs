//! VTK XML unstructured grid (`.vtu`) of a tet mesh with point and cell fields, for any cell
//! type (its VTK type and node order from [`CellType`]), in appended raw binary (the default:
//! compact and fast) or in ASCII ([`VtuFormat`]).
//!
//! Binary layout (VTK's "appended raw" encoding): the XML header declares each `DataArray`
//! with `format="appended"` and an `offset`; after `<AppendedData encoding="raw">` and a `_`
//! come the arrays one after the other, each as a little-endian `UInt64` byte count followed
//! by its values, little-endian (`Float64` coordinates and fields, `Int64` connectivity and
//! offsets, `UInt8` cell types). `UInt64` headers (`header_type="UInt64"`, read by VTK ≥ 6,
//! ParaView ≥ 4 and meshio) because a `UInt32` count caps an array at 4 GiB, which a field of
//! a 90-million-node mesh exceeds. `FieldData` (one value each: a time, a frequency) stays
//! inline ASCII so that it can be read with `grep`.

use std::io::Write;
use std::path::Path;

use super::write_atomically;
use crate::base::error::{Error, Result};
use crate::mesh::{CellType, Tet4, TetMesh};

/// How a [`VtuWriter`] encodes its arrays.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum VtuFormat {
    /// Appended raw binary (VTK's `<AppendedData encoding="raw">`: each array a little-endian
    /// `UInt64` byte count, so that an array may exceed 4 GiB, then its little-endian values):
    /// about half the ASCII size (8 bytes per f64 against ~20 characters), and written without formatting
    /// numbers (3.8× faster on the default run's frames, `docs/src/scenes/amplitudes.md`).
    #[default]
    Binary,
    /// Numbers as text in the XML (`{:e}`, the shortest representation that reads back to the
    /// same f64): readable by eye and by any XML tool, larger and slower to write.
    Ascii,
}

impl VtuFormat {
    /// The format named `name`: `"binary"` or `"ascii"` (the spelling of the scene key
    /// `output.vtu_format`); `None` otherwise.
    pub fn from_name(name: &str) -> Option<Self> {
        match name {
            "binary" => Some(VtuFormat::Binary),
            "ascii" => Some(VtuFormat::Ascii),
            _ => None,
        }
    }

    /// `"binary"` or `"ascii"`.
    pub fn name(self) -> &'static str {
        match self {
            VtuFormat::Binary => "binary",
            VtuFormat::Ascii => "ascii",
        }
    }
}

/// Builder for one `.vtu` file: the mesh plus named fields, checked for length when added.
#[derive(Debug, Clone)]
pub struct VtuWriter<'a, C: CellType = Tet4> {
    mesh: &'a TetMesh<C>,
    point_fields: Vec<(String, usize, &'a [f64])>,
    cell_fields: Vec<(String, usize, &'a [f64])>,
    /// Integer per-node and per-tet arrays (VTK `Int64`): ids such as a mesh file's own.
    point_ids: Vec<(String, &'a [u64])>,
    cell_ids: Vec<(String, &'a [u64])>,
    /// Small integer per-tet arrays (VTK `Int32`): indices such as a tet's material.
    cell_indices: Vec<(String, &'a [i32])>,
    /// Whole-dataset values (VTK `FieldData`): a frequency, a time.
    field_data: Vec<(String, f64)>,
    format: VtuFormat,
}

/// One `DataArray` of the piece, whatever its encoding.
enum Array<'b> {
    Points,
    Connectivity,
    Offsets,
    Types,
    /// A field's values and its components per tuple.
    Field(&'b [f64], usize),
    /// Integer ids, one per node or per tet (written as `Int64`).
    Ids(&'b [u64]),
    /// Small integers, one per tet (written as `Int32`).
    Indices(&'b [i32]),
}

impl<'a, C: CellType> VtuWriter<'a, C> {
    /// A file for `mesh` with no fields yet, in the default [`VtuFormat::Binary`].
    pub fn new(mesh: &'a TetMesh<C>) -> Self {
        VtuWriter {
            mesh,
            point_fields: Vec::new(),
            cell_fields: Vec::new(),
            point_ids: Vec::new(),
            cell_ids: Vec::new(),
            cell_indices: Vec::new(),
            field_data: Vec::new(),
            format: VtuFormat::default(),
        }
    }

    /// Adds a per-node integer array (one value per node, written as VTK `Int64`), e.g. the
    /// node ids of the mesh file. [`Error::InvalidParameter`] unless there is one value per
    /// node, each at most `i64::MAX`.
    pub fn point_id_field(mut self, name: &str, values: &'a [u64]) -> Result<Self> {
        check_ids(name, values, self.mesh.node_count(), "node")?;
        self.point_ids.push((name.to_string(), values));
        Ok(self)
    }

    /// Adds a per-tet integer array (one value per tet, VTK `Int64`), e.g. the element ids of
    /// the mesh file; checked as [`point_id_field`](Self::point_id_field).
    pub fn cell_id_field(mut self, name: &str, values: &'a [u64]) -> Result<Self> {
        check_ids(name, values, self.mesh.tet_count(), "tet")?;
        self.cell_ids.push((name.to_string(), values));
        Ok(self)
    }

    /// Adds a per-tet integer array of small values (one per tet, VTK `Int32`), e.g. each
    /// tet's material index: ParaView colours it by its discrete values (categories), which a
    /// `Float64` field would not offer. [`Error::InvalidParameter`] unless there is one value
    /// per tet.
    pub fn cell_index_field(mut self, name: &str, values: &'a [i32]) -> Result<Self> {
        if values.len() != self.mesh.tet_count() {
            return Err(Error::invalid_parameter(
                format!("field '{name}'"),
                format!("{} values", values.len()),
                format!("needs one value per tet ({} tets)", self.mesh.tet_count()),
            ));
        }
        self.cell_indices.push((name.to_string(), values));
        Ok(self)
    }

    /// Chooses the encoding of the arrays ([`VtuFormat::Binary`] unless told).
    pub fn format(mut self, format: VtuFormat) -> Self {
        self.format = format;
        self
    }

    /// Adds one value for the whole dataset (VTK `FieldData`, e.g. a mode's frequency in Hz),
    /// which ParaView shows in its information panel. [`Error::InvalidParameter`] unless it is
    /// finite.
    pub fn field_data(mut self, name: &str, value: f64) -> Result<Self> {
        if !value.is_finite() {
            return Err(Error::invalid_parameter(
                format!("field data {name}"),
                value,
                "must be finite",
            ));
        }
        self.field_data.push((name.to_string(), value));
        Ok(self)
    }

    /// Adds a per-node field with `components` values per node (1 for a scalar, 3 for a vector
    /// such as the displacement, node-major).
    pub fn point_field(mut self, name: &str, components: usize, values: &'a [f64]) -> Result<Self> {
        check_field(name, components, values, self.mesh.node_count(), "node")?;
        self.point_fields
            .push((name.to_string(), components, values));
        Ok(self)
    }

    /// Adds a per-tet field with `components` values per tet.
    pub fn cell_field(mut self, name: &str, components: usize, values: &'a [f64]) -> Result<Self> {
        check_field(name, components, values, self.mesh.tet_count(), "tet")?;
        self.cell_fields
            .push((name.to_string(), components, values));
        Ok(self)
    }

    /// Writes the file atomically (see [`write_atomically`]).
    pub fn write(&self, path: &Path) -> Result<()> {
        write_atomically(path, |out| self.write_to(out))
    }

    /// Writes the file to any writer (XML, with the appended binary block in
    /// [`VtuFormat::Binary`]).
    pub fn write_to(&self, out: &mut dyn Write) -> std::io::Result<()> {
        let mesh = self.mesh;
        // Appended offsets count from the byte after `_`: each block is its 8-byte header and
        // its data.
        let mut next_offset = 0usize;
        let mut appended: Vec<Array<'a>> = Vec::new();
        let mut open = |out: &mut dyn Write,
                        indent: &str,
                        attributes: String,
                        array: Array<'a>|
         -> std::io::Result<()> {
            match self.format {
                VtuFormat::Ascii => {
                    writeln!(out, r#"{indent}<DataArray {attributes} format="ascii">"#)?;
                    self.write_ascii(out, &array)?;
                    writeln!(out, "{indent}</DataArray>")
                }
                VtuFormat::Binary => {
                    writeln!(
                        out,
                        r#"{indent}<DataArray {attributes} format="appended" offset="{next_offset}"/>"#
                    )?;
                    next_offset += 8 + self.byte_len(&array);
                    appended.push(array);
                    Ok(())
                }
            }
        };
        writeln!(out, r#"<?xml version="1.0"?>"#)?;
        writeln!(
            out,
            r#"<VTKFile type="UnstructuredGrid" version="1.0" byte_order="LittleEndian" header_type="UInt64">"#
        )?;
        writeln!(out, "  <UnstructuredGrid>")?;
        if !self.field_data.is_empty() {
            writeln!(out, "    <FieldData>")?;
            for (name, value) in &self.field_data {
                writeln!(
                    out,
                    r#"      <DataArray type="Float64" Name="{}" NumberOfTuples="1" format="ascii">{value:e}</DataArray>"#,
                    xml_escape(name)
                )?;
            }
            writeln!(out, "    </FieldData>")?;
        }
        writeln!(
            out,
            r#"    <Piece NumberOfPoints="{}" NumberOfCells="{}">"#,
            mesh.node_count(),
            mesh.tet_count()
        )?;
        let indent = "        ";
        writeln!(out, "      <Points>")?;
        open(
            out,
            indent,
            r#"type="Float64" NumberOfComponents="3""#.into(),
            Array::Points,
        )?;
        writeln!(out, "      </Points>")?;
        writeln!(out, "      <Cells>")?;
        open(
            out,
            indent,
            r#"type="Int64" Name="connectivity""#.into(),
            Array::Connectivity,
        )?;
        open(
            out,
            indent,
            r#"type="Int64" Name="offsets""#.into(),
            Array::Offsets,
        )?;
        open(
            out,
            indent,
            r#"type="UInt8" Name="types""#.into(),
            Array::Types,
        )?;
        writeln!(out, "      </Cells>")?;
        for (section, fields, ids, indices) in [
            (
                "PointData",
                &self.point_fields,
                &self.point_ids,
                &Vec::new(),
            ),
            (
                "CellData",
                &self.cell_fields,
                &self.cell_ids,
                &self.cell_indices,
            ),
        ] {
            writeln!(out, "      <{section}>")?;
            for (name, components, values) in fields {
                open(
                    out,
                    indent,
                    format!(
                        r#"type="Float64" Name="{}" NumberOfComponents="{components}""#,
                        xml_escape(name)
                    ),
                    Array::Field(values, *components),
                )?;
            }
            for (name, values) in ids {
                open(
                    out,
                    indent,
                    format!(
                        r#"type="Int64" Name="{}" NumberOfComponents="1""#,
                        xml_escape(name)
                    ),
                    Array::Ids(values),
                )?;
            }
            for (name, values) in indices {
                open(
                    out,
                    indent,
                    format!(
                        r#"type="Int32" Name="{}" NumberOfComponents="1""#,
                        xml_escape(name)
                    ),
                    Array::Indices(values),
                )?;
            }
            writeln!(out, "      </{section}>")?;
        }
        writeln!(out, "    </Piece>")?;
        writeln!(out, "  </UnstructuredGrid>")?;
        if self.format == VtuFormat::Binary {
            writeln!(out, r#"  <AppendedData encoding="raw">"#)?;
            out.write_all(b"_")?;
            for array in &appended {
                self.write_binary(out, array)?;
            }
            writeln!(out)?;
            writeln!(out, "  </AppendedData>")?;
        }
        writeln!(out, "</VTKFile>")
    }

    /// Bytes of `array`'s values in binary (without the block header).
    fn byte_len(&self, array: &Array<'_>) -> usize {
        let tets = self.mesh.tet_count();
        match array {
            Array::Points => 24 * self.mesh.node_count(),
            Array::Connectivity => 8 * C::NODES * tets,
            Array::Offsets => 8 * tets,
            Array::Types => tets,
            Array::Field(values, _) => 8 * values.len(),
            Array::Ids(values) => 8 * values.len(),
            Array::Indices(values) => 4 * values.len(),
        }
    }

    fn write_ascii(&self, out: &mut dyn Write, array: &Array<'_>) -> std::io::Result<()> {
        let mesh = self.mesh;
        match array {
            Array::Points => {
                for p in mesh.nodes() {
                    writeln!(out, "{:e} {:e} {:e}", p.x, p.y, p.z)?;
                }
            }
            Array::Connectivity => {
                for t in mesh.tets() {
                    let line: Vec<String> = t.as_ref().iter().map(|n| n.to_string()).collect();
                    writeln!(out, "{}", line.join(" "))?;
                }
            }
            Array::Offsets => {
                for c in 1..=mesh.tet_count() {
                    writeln!(out, "{}", C::NODES * c)?;
                }
            }
            Array::Types => {
                for _ in 0..mesh.tet_count() {
                    writeln!(out, "{}", C::VTK_CELL_TYPE)?;
                }
            }
            Array::Field(values, components) => {
                for chunk in values.chunks(*components) {
                    let line: Vec<String> = chunk.iter().map(|v| format!("{v:e}")).collect();
                    writeln!(out, "{}", line.join(" "))?;
                }
            }
            Array::Ids(values) => {
                for v in values.iter() {
                    writeln!(out, "{v}")?;
                }
            }
            Array::Indices(values) => {
                for v in values.iter() {
                    writeln!(out, "{v}")?;
                }
            }
        }
        Ok(())
    }

    fn write_binary(&self, out: &mut dyn Write, array: &Array<'_>) -> std::io::Result<()> {
        let mesh = self.mesh;
        out.write_all(&(self.byte_len(array) as u64).to_le_bytes())?;
        let mut bytes = Vec::with_capacity(self.byte_len(array));
        match array {
            Array::Points => {
                for p in mesh.nodes() {
                    for v in [p.x, p.y, p.z] {
                        bytes.extend_from_slice(&v.to_le_bytes());
                    }
                }
            }
            Array::Connectivity => {
                for t in mesh.tets() {
                    for &n in t.as_ref() {
                        bytes.extend_from_slice(&(n as i64).to_le_bytes());
                    }
                }
            }
            Array::Offsets => {
                for c in 1..=mesh.tet_count() {
                    bytes.extend_from_slice(&((C::NODES * c) as i64).to_le_bytes());
                }
            }
            Array::Types => bytes.resize(mesh.tet_count(), C::VTK_CELL_TYPE),
            Array::Field(values, _) => {
                for v in values.iter() {
                    bytes.extend_from_slice(&v.to_le_bytes());
                }
            }
            // Checked ≤ i64::MAX when added, so the cast keeps the value.
            Array::Ids(values) => {
                for &v in values.iter() {
                    bytes.extend_from_slice(&(v as i64).to_le_bytes());
                }
            }
            Array::Indices(values) => {
                for &v in values.iter() {
                    bytes.extend_from_slice(&v.to_le_bytes());
                }
            }
        }
        out.write_all(&bytes)
    }
}

fn check_ids(name: &str, values: &[u64], count: usize, per: &str) -> Result<()> {
    if values.len() != count {
        return Err(Error::invalid_parameter(
            format!("field '{name}'"),
            format!("{} values", values.len()),
            format!("needs one value per {per} ({count} {per}s)"),
        ));
    }
    if let Some(&v) = values.iter().find(|&&v| v > i64::MAX as u64) {
        return Err(Error::invalid_parameter(
            format!("field '{name}'"),
            v,
            "must be at most 2^63 - 1 (written as VTK Int64)",
        ));
    }
    Ok(())
}

fn check_field(
    name: &str,
    components: usize,
    values: &[f64],
    count: usize,
    per: &str,
) -> Result<()> {
    if components == 0 || values.len() != components * count {
        return Err(Error::invalid_parameter(
            format!("field '{name}'"),
            format!("{} values with {components} components", values.len()),
            format!(
                "needs {components} values per {per} ({count} {per}s), and at least one component"
            ),
        ));
    }
    if let Some(i) = values.iter().position(|v| !v.is_finite()) {
        return Err(Error::invalid_parameter(
            format!("field '{name}'"),
            format!("value {i} = {}", values[i]),
            "must be finite (ParaView cannot read NaN from ASCII VTK)",
        ));
    }
    Ok(())
}

fn xml_escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}
