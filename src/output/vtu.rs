//! VTK XML unstructured grid (`.vtu`, ASCII) of a tet mesh with point and cell fields, for
//! any cell type (its VTK type and node order from [`CellType`]).

use std::io::Write;
use std::path::Path;

use super::write_atomically;
use crate::error::{Error, Result};
use crate::mesh::{CellType, Tet4, TetMesh};

/// Builder for one `.vtu` file: the mesh plus named fields, checked for length when added.
#[derive(Debug, Clone)]
pub struct VtuWriter<'a, C: CellType = Tet4> {
    mesh: &'a TetMesh<C>,
    point_fields: Vec<(String, usize, &'a [f64])>,
    cell_fields: Vec<(String, usize, &'a [f64])>,
    /// Integer per-node and per-tet arrays (VTK `Int64`): ids such as a mesh file's own.
    point_ids: Vec<(String, &'a [u64])>,
    cell_ids: Vec<(String, &'a [u64])>,
    /// Whole-dataset values (VTK `FieldData`): a frequency, a time.
    field_data: Vec<(String, f64)>,
}

impl<'a, C: CellType> VtuWriter<'a, C> {
    /// A file for `mesh` with no fields yet.
    pub fn new(mesh: &'a TetMesh<C>) -> Self {
        VtuWriter {
            mesh,
            point_fields: Vec::new(),
            cell_fields: Vec::new(),
            point_ids: Vec::new(),
            cell_ids: Vec::new(),
            field_data: Vec::new(),
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

    /// Writes the XML to any writer.
    pub fn write_to(&self, out: &mut dyn Write) -> std::io::Result<()> {
        let mesh = self.mesh;
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
        writeln!(out, "      <Points>")?;
        writeln!(
            out,
            r#"        <DataArray type="Float64" NumberOfComponents="3" format="ascii">"#
        )?;
        for p in mesh.nodes() {
            writeln!(out, "{:e} {:e} {:e}", p.x, p.y, p.z)?;
        }
        writeln!(out, "        </DataArray>")?;
        writeln!(out, "      </Points>")?;
        writeln!(out, "      <Cells>")?;
        writeln!(
            out,
            r#"        <DataArray type="Int64" Name="connectivity" format="ascii">"#
        )?;
        for t in mesh.tets() {
            let mut line = String::new();
            for (k, n) in t.as_ref().iter().enumerate() {
                if k > 0 {
                    line.push(' ');
                }
                line.push_str(&n.to_string());
            }
            writeln!(out, "{line}")?;
        }
        writeln!(out, "        </DataArray>")?;
        writeln!(
            out,
            r#"        <DataArray type="Int64" Name="offsets" format="ascii">"#
        )?;
        for c in 1..=mesh.tet_count() {
            writeln!(out, "{}", C::NODES * c)?;
        }
        writeln!(out, "        </DataArray>")?;
        writeln!(
            out,
            r#"        <DataArray type="UInt8" Name="types" format="ascii">"#
        )?;
        for _ in 0..mesh.tet_count() {
            writeln!(out, "{}", C::VTK_CELL_TYPE)?;
        }
        writeln!(out, "        </DataArray>")?;
        writeln!(out, "      </Cells>")?;
        write_fields(out, "PointData", &self.point_fields, &self.point_ids)?;
        write_fields(out, "CellData", &self.cell_fields, &self.cell_ids)?;
        writeln!(out, "    </Piece>")?;
        writeln!(out, "  </UnstructuredGrid>")?;
        writeln!(out, "</VTKFile>")
    }
}

fn write_fields(
    out: &mut dyn Write,
    section: &str,
    fields: &[(String, usize, &[f64])],
    ids: &[(String, &[u64])],
) -> std::io::Result<()> {
    writeln!(out, "      <{section}>")?;
    for (name, components, values) in fields {
        writeln!(
            out,
            r#"        <DataArray type="Float64" Name="{}" NumberOfComponents="{components}" format="ascii">"#,
            xml_escape(name)
        )?;
        for chunk in values.chunks(*components) {
            let line: Vec<String> = chunk.iter().map(|v| format!("{v:e}")).collect();
            writeln!(out, "{}", line.join(" "))?;
        }
        writeln!(out, "        </DataArray>")?;
    }
    for (name, values) in ids {
        writeln!(
            out,
            r#"        <DataArray type="Int64" Name="{}" NumberOfComponents="1" format="ascii">"#,
            xml_escape(name)
        )?;
        for v in *values {
            writeln!(out, "{v}")?;
        }
        writeln!(out, "        </DataArray>")?;
    }
    writeln!(out, "      </{section}>")
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
