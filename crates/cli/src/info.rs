//! `tetfem info`: what a mesh file (or a scene's mesh) holds, how good its elements are, and
//! the explicit critical time step for a material.

use std::collections::BTreeMap;
use std::fmt;
use std::path::Path;

use crate::scene::{Scene, SceneElement};
use tetfem::analysis::dynamics::ElementStepBound;
use tetfem::base::error::Result;
use tetfem::fe::element::Tet10;
use tetfem::fe::material::Material;
use tetfem::fe::quality::MeshStatistics;
use tetfem::mesh::io::{ImportedMesh, MeshFile};
use tetfem::mesh::{Tet4, TetMesh};

/// One physical group or marker set of the file.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct GroupInfo {
    /// `"name" (dim D, tag T)`.
    pub label: String,
    /// Nodes in it.
    pub nodes: usize,
    /// Triangles in it.
    pub triangles: usize,
    /// Tets in it.
    pub tets: usize,
}

/// Everything `tetfem info` prints.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct MeshInfo {
    /// The file.
    pub file: String,
    /// The element type of the tets: `"tet4"` (4-node, order 1) or `"tet10"` (10-node,
    /// order 2), as a file holds them or a scene's `mesh.order` makes them.
    pub element: String,
    /// Counts, volume and element quality.
    pub statistics: MeshStatistics,
    /// Gmsh physical groups.
    pub groups: Vec<GroupInfo>,
    /// TetGen node markers (`.node`) and how many nodes carry each.
    pub node_markers: BTreeMap<i64, usize>,
    /// TetGen face markers (`.face`) and how many triangles carry each.
    pub face_markers: BTreeMap<i64, usize>,
    /// TetGen region attributes (`.ele`, the first attribute) and how many tets carry each,
    /// ascending.
    pub region_attributes: Vec<(f64, usize)>,
    /// Skipped elements per type.
    pub skipped_elements: BTreeMap<String, usize>,
    /// Nodes of the file no tet uses.
    pub unused_nodes: usize,
    /// The material the critical step is for, as (E, ν, ρ).
    pub material: Option<(f64, f64, f64)>,
    /// The explicit critical step, when a material is known.
    pub critical_step: Option<ElementStepBound>,
    /// Warnings about the mesh and the material (see [`tetfem::base::warning`]), as sentences.
    pub warnings: Vec<String>,
}

/// Reads a mesh (`.msh`, `.node`/`.ele`) or a scene (`.toml`: its mesh and material) and
/// gathers [`MeshInfo`]; `material` (if given) overrides a scene's for the critical step.
pub fn mesh_info(path: &Path, material: Option<Material>) -> Result<MeshInfo> {
    if path.extension().is_some_and(|e| e == "toml") {
        let scene = Scene::load(path)?;
        return match scene.order() {
            2 => {
                let built = scene.build_as::<Tet10>()?;
                info_of(
                    path,
                    built.mesh,
                    built.imported,
                    material.or(Some(built.material)),
                )
            }
            _ => {
                let built = scene.build()?;
                info_of(
                    path,
                    built.mesh,
                    built.imported,
                    material.or(Some(built.material)),
                )
            }
        };
    }
    // A file's own order decides its element type (a quadratic file read as 10-node tets);
    // the file is parsed once for both.
    let file = MeshFile::read(path)?;
    if file.order() == 2 {
        let imported = file.build_as::<Tet10>()?;
        return info_of(path, imported.mesh.clone(), Some(imported), material);
    }
    let imported = file.build_as::<Tet4>()?;
    info_of(path, imported.mesh.clone(), Some(imported), material)
}

/// [`MeshInfo`] of a mesh of element `E` (statistics and warnings of its corner tets).
fn info_of<E: SceneElement>(
    path: &Path,
    mesh: TetMesh<E>,
    imported: Option<ImportedMesh<E>>,
    material: Option<Material>,
) -> Result<MeshInfo> {
    let groups = imported
        .as_ref()
        .map(|i| {
            i.groups
                .iter()
                .map(|g| GroupInfo {
                    label: g.label(),
                    nodes: g.nodes.len(),
                    triangles: g.triangles.len(),
                    tets: g.tets.len(),
                })
                .collect()
        })
        .unwrap_or_default();
    Ok(MeshInfo {
        file: path.display().to_string(),
        element: E::NAME.to_string(),
        statistics: mesh.statistics(),
        groups,
        node_markers: imported
            .as_ref()
            .map(|i| i.node_marker_counts())
            .unwrap_or_default(),
        face_markers: imported
            .as_ref()
            .map(|i| i.face_marker_counts())
            .unwrap_or_default(),
        region_attributes: imported
            .as_ref()
            .map(|i| i.attribute_counts())
            .unwrap_or_default(),
        skipped_elements: imported
            .as_ref()
            .map(|i| i.skipped_elements.clone())
            .unwrap_or_default(),
        unused_nodes: imported.as_ref().map_or(0, |i| i.unused_nodes),
        material: material.map(|m| (m.youngs_modulus(), m.poisson_ratio(), m.density())),
        critical_step: material.map(|m| E::step_bound(&mesh, &m)).transpose()?,
        warnings: mesh
            .warnings()
            .iter()
            .chain(material.map(|m| m.warnings()).unwrap_or_default().iter())
            .map(ToString::to_string)
            .collect(),
    })
}

impl MeshInfo {
    /// As one line of JSON.
    pub fn to_json(&self) -> String {
        serde_json::to_string(self).unwrap_or_else(|e| format!("{{\"error\":\"{e}\"}}"))
    }
}

impl fmt::Display for MeshInfo {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let s = &self.statistics;
        writeln!(f, "{}", self.file)?;
        writeln!(
            f,
            "  nodes {}, tets {}, DOFs {}",
            s.nodes,
            s.tets,
            3 * s.nodes
        )?;
        writeln!(
            f,
            "  element: {} ({})",
            self.element,
            match self.element.as_str() {
                "tet10" => "10-node quadratic tets, order 2",
                _ => "4-node linear tets, order 1",
            }
        )?;
        writeln!(f, "  volume {:.6e}", s.volume)?;
        writeln!(
            f,
            "  bounding box [{:.4e}, {:.4e}, {:.4e}] – [{:.4e}, {:.4e}, {:.4e}]",
            s.bbox_min[0],
            s.bbox_min[1],
            s.bbox_min[2],
            s.bbox_max[0],
            s.bbox_max[1],
            s.bbox_max[2]
        )?;
        writeln!(
            f,
            "  edge length {:.4e} – {:.4e}",
            s.edge_length.0, s.edge_length.1
        )?;
        writeln!(
            f,
            "  min dihedral angle: worst {:.2}° (tet {}), mean {:.2}° (regular tet: 70.53°)",
            s.min_dihedral_deg.min, s.min_dihedral_deg.min_tet, s.min_dihedral_deg.mean
        )?;
        writeln!(
            f,
            "  max dihedral angle: worst {:.2}° (tet {})",
            s.max_dihedral_deg.max, s.max_dihedral_deg.max_tet
        )?;
        writeln!(
            f,
            "  aspect ratio R/(3r): worst {:.3} (tet {}), mean {:.3} (regular tet: 1)",
            s.aspect_ratio.max, s.aspect_ratio.max_tet, s.aspect_ratio.mean
        )?;
        for warning in &self.warnings {
            writeln!(f, "  warning: {warning}")?;
        }
        for g in &self.groups {
            writeln!(
                f,
                "  group {}: {} nodes, {} triangles, {} tets",
                g.label, g.nodes, g.triangles, g.tets
            )?;
        }
        let list = |counts: Vec<String>| counts.join(", ");
        if !self.node_markers.is_empty() {
            let counts = self.node_markers.iter();
            let counts = counts.map(|(m, n)| format!("{m} ({n} nodes)")).collect();
            writeln!(f, "  node markers: {}", list(counts))?;
        }
        if !self.face_markers.is_empty() {
            let counts = self.face_markers.iter();
            let counts = counts.map(|(m, n)| format!("{m} ({n} faces)")).collect();
            writeln!(f, "  face markers: {}", list(counts))?;
        }
        if !self.region_attributes.is_empty() {
            let counts = self.region_attributes.iter();
            let counts = counts.map(|(a, n)| format!("{a} ({n} tets)")).collect();
            writeln!(f, "  region attributes: {}", list(counts))?;
        }
        if !self.skipped_elements.is_empty() {
            let list: Vec<String> = self
                .skipped_elements
                .iter()
                .map(|(k, v)| format!("{v} {k}"))
                .collect();
            writeln!(f, "  skipped elements: {}", list.join(", "))?;
        }
        if self.unused_nodes > 0 {
            writeln!(f, "  nodes used by no tet (dropped): {}", self.unused_nodes)?;
        }
        match (&self.critical_step, &self.material) {
            (Some(c), Some((e, nu, rho))) => {
                writeln!(
                    f,
                    "  explicit critical step for E = {e:e}, ν = {nu}, ρ = {rho}: {:.4e} s (element bound 2/max ωₑ, tet {}); h_min/c_p = {:.4e} s, c_p = {:.5e}",
                    c.dt_element, c.tet, c.dt_geometric, c.p_wave_speed
                )?;
            }
            _ => writeln!(f, "  explicit critical step: give a material to compute it")?,
        }
        Ok(())
    }
}
