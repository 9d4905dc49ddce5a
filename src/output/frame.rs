//! One result frame as a `.vtu`: the fields a FEM user expects to colour by in ParaView.
//!
//! Every result file holds, per node: `displacement` (3), `displacement_magnitude`,
//! `velocity` (3, dynamic frames), `reaction_force` (3, linear static results); per tet:
//! `von_mises`, `strain_energy_density` and `material_id` (the index of its material, `Int32`:
//! ParaView colours it by category); for
//! frames of a run, the time as `TimeValue` field data. With [`FrameExtras::stress_tensors`]
//! (static results and, since frames are binary, dynamic frames too) also per node
//! `stress_nodal` (6: XX, YY, ZZ, XY, YZ, XZ: at each node the volume-weighted average of the
//! stresses of the tets around it evaluated at that node, [`tet_node_stress`] and
//! [`recovered_nodal_stress`]; a 4-node tet's stress is constant, a 10-node tet's linear, so a
//! linear stress field is output exactly) and `von_mises_nodal` (of that average: smooth
//! contours), and per tet `stress` (6, same order; the tet's mean, for a 10-node tet its value at
//! the centroid), `strain` (6, same order, dimensionless, tensor shear components ε_xy — not
//! the engineering γ_xy = 2ε_xy; the linear strain for the linear model, the Green–Lagrange
//! strain ½(FᵀF − I) for the nonlinear ones, [`cell_model_strain`]) and the principal stresses
//! as three scalars `principal_stress_1` ≥ `principal_stress_2` ≥ `principal_stress_3` (not one
//! 3-vector, whose magnitude ParaView would offer and which means nothing). The file's encoding is [`FrameExtras::format`] (binary by default).
//! With [`FrameExtras::error_indicator`] also per tet `error_indicator`: the ZZ estimate η_K of
//! the energy-norm error in that tet (J^½ in SI; see [`estimate`](crate::estimate)).
//! With contact ([`FrameExtras::contact`]) also per node `contact_gap` (length) and
//! `contact_pressure` (Pa in SI). For a mesh read from a file, [`FrameExtras::original_ids`] adds the file's node ids
//! (`original_node_id`) and element ids (`original_element_id`) as `Int64` arrays.

use std::path::Path;

use nalgebra::Matrix3;

use super::fields::{
    cell_model_energy_density, cell_model_strain, cell_model_stress, cell_strain,
    cell_strain_energy_density, cell_stress, displacement_magnitude, principal_stresses,
    recovered_nodal_stress, stress_components, tet_node_model_stress, tet_node_stress, von_mises,
};
use super::{VtuFormat, VtuWriter};
use crate::error::Result;
use crate::estimate::PointwiseElement;
use crate::materials::TetMaterials;
use crate::mesh::{CellType, TetMesh};
use crate::model::{ModelElement, TetModels};

/// What a result frame holds besides the displacement: the optional fields of a run.
#[derive(Debug, Clone, Copy, Default)]
pub struct FrameExtras<'a> {
    /// Nodal velocity (node-major, length/time).
    pub velocity: Option<&'a [f64]>,
    /// Nodal reactions (node-major, force units).
    pub reactions: Option<&'a [f64]>,
    /// The frame's time (time units), written as `TimeValue` field data.
    pub time: Option<f64>,
    /// Also the stress and strain tensors, principal stresses and recovered nodal stresses.
    pub stress_tensors: bool,
    /// Per-tet error indicators η_K of [`estimate`](crate::estimate) (J^½ in SI), written as
    /// the cell field `error_indicator`.
    pub error_indicator: Option<&'a [f64]>,
    /// The mesh file's id of each node and of each tet (see
    /// [`ImportedMesh`](crate::mesh::io::ImportedMesh)), written as the point array
    /// `original_node_id` and the cell array `original_element_id`.
    pub original_ids: Option<OriginalIds<'a>>,
    /// The file's encoding (appended binary unless told).
    pub format: VtuFormat,
    /// With contact: per node the gap and contact pressure
    /// ([`Contact::node_fields`](crate::contact::Contact::node_fields)), written as the point
    /// fields `contact_gap` (length) and `contact_pressure` (pressure, Pa in SI).
    pub contact: Option<ContactFields<'a>>,
}

/// The contact fields of a frame: one value per mesh node each.
#[derive(Debug, Clone, Copy)]
pub struct ContactFields<'a> {
    /// The smallest signed distance to the obstacles (length; > 0 outside).
    pub gap: &'a [f64],
    /// The barrier's pressure −κ·Σ b′(d) (pressure; 0 off the boundary and beyond d̂).
    pub pressure: &'a [f64],
}

/// A mesh file's own numbering of the nodes and the tets of a mesh read from it.
#[derive(Debug, Clone, Copy)]
pub struct OriginalIds<'a> {
    /// The file's id of each mesh node (Gmsh node tag, TetGen point number).
    pub nodes: &'a [u64],
    /// The file's id of each mesh tet (Gmsh element tag, TetGen tet number).
    pub elements: &'a [u64],
}

impl<'a> OriginalIds<'a> {
    /// The ids an imported mesh carries.
    pub fn of<C: crate::mesh::CellType>(imported: &'a crate::mesh::io::ImportedMesh<C>) -> Self {
        OriginalIds {
            nodes: &imported.node_ids,
            elements: &imported.tet_ids,
        }
    }
}

/// Writes `path` (atomically) with the fields of the [module](self) docs, the stresses and the
/// energy density those of the linear model with each tet's material (one
/// [`Material`](crate::material::Material) or a [`MaterialMap`](crate::materials::MaterialMap));
/// see [`write_model_result_vtu`] for a nonlinear run.
pub fn write_result_vtu<E: PointwiseElement>(
    path: &Path,
    mesh: &TetMesh<E>,
    materials: &impl TetMaterials,
    displacement: &[f64],
    velocity: Option<&[f64]>,
) -> Result<()> {
    write_result_frame(
        path,
        mesh,
        materials,
        displacement,
        FrameExtras {
            velocity,
            ..FrameExtras::default()
        },
    )
}

/// As [`write_result_vtu`] for a static solution, with its reactions as the point field
/// `reaction_force` (force units; K·u − f on the constrained DOFs, zero on the free ones).
pub fn write_static_result_vtu<E: PointwiseElement>(
    path: &Path,
    mesh: &TetMesh<E>,
    materials: &impl TetMaterials,
    displacement: &[f64],
    reactions: &[f64],
) -> Result<()> {
    write_result_frame(
        path,
        mesh,
        materials,
        displacement,
        FrameExtras {
            reactions: Some(reactions),
            stress_tensors: true,
            ..FrameExtras::default()
        },
    )
}

/// [`write_result_vtu`] with every optional field: velocity, reactions, time.
pub fn write_result_frame<E: PointwiseElement>(
    path: &Path,
    mesh: &TetMesh<E>,
    materials: &impl TetMaterials,
    displacement: &[f64],
    extras: FrameExtras<'_>,
) -> Result<()> {
    let stresses = cell_stress(mesh, materials, displacement)?;
    let (strains, node_stresses) = match extras.stress_tensors {
        true => (
            cell_strain(mesh, displacement)?,
            tet_node_stress(mesh, materials, displacement)?,
        ),
        false => (Vec::new(), Vec::new()),
    };
    let energy = cell_strain_energy_density(mesh, materials, displacement)?;
    let ids = material_ids(mesh, materials)?;
    let tensors = Tensors {
        stresses: &stresses,
        strains: &strains,
        node_stresses: &node_stresses,
    };
    write_fields(path, mesh, displacement, extras, tensors, &energy, &ids)
}

/// As [`write_result_vtu`], with the stresses and energy density of the force model that
/// produced the displacement (its Cauchy stress, its own energy per rest volume; see
/// [`cell_model_stress`] and [`cell_model_energy_density`]). `material_id` is the material index
/// of `materials` (a [`MaterialMap`](crate::materials::MaterialMap), or one material: all 0).
pub fn write_model_result_vtu<E: ModelElement + PointwiseElement>(
    path: &Path,
    mesh: &TetMesh<E>,
    model: &(impl TetModels + ?Sized),
    materials: &impl TetMaterials,
    displacement: &[f64],
    extras: FrameExtras<'_>,
) -> Result<()> {
    materials.check_tet_count(mesh)?;
    let stresses = cell_model_stress(mesh, model, displacement)?;
    let (strains, node_stresses) = match extras.stress_tensors {
        true => (
            cell_model_strain(mesh, model, displacement)?,
            tet_node_model_stress(mesh, model, displacement)?,
        ),
        false => (Vec::new(), Vec::new()),
    };
    let energy = cell_model_energy_density(mesh, model, displacement)?;
    let ids = material_ids(mesh, materials)?;
    let tensors = Tensors {
        stresses: &stresses,
        strains: &strains,
        node_stresses: &node_stresses,
    };
    write_fields(path, mesh, displacement, extras, tensors, &energy, &ids)
}

/// The material index of every tet, as the `Int32` the `.vtu` holds.
fn material_ids<C: CellType>(mesh: &TetMesh<C>, materials: &impl TetMaterials) -> Result<Vec<i32>> {
    (0..mesh.tet_count())
        .map(|t| {
            let index = materials.index_of(t);
            i32::try_from(index).map_err(|_| {
                crate::error::Error::invalid_parameter(
                    "material index",
                    index,
                    "must be at most 2^31 - 1 (written as VTK Int32)",
                )
            })
        })
        .collect()
}

/// Per-tet stress, and strain and each tet's stress at its nodes (tet-major; both empty
/// unless [`FrameExtras::stress_tensors`]).
struct Tensors<'t> {
    stresses: &'t [Matrix3<f64>],
    strains: &'t [Matrix3<f64>],
    node_stresses: &'t [Matrix3<f64>],
}

fn write_fields<C: CellType>(
    path: &Path,
    mesh: &TetMesh<C>,
    displacement: &[f64],
    extras: FrameExtras<'_>,
    tensors: Tensors<'_>,
    energy: &[f64],
    material_ids: &[i32],
) -> Result<()> {
    let stresses = tensors.stresses;
    let magnitude = displacement_magnitude(displacement);
    let von_mises_cells: Vec<f64> = stresses.iter().map(von_mises).collect();
    let (mut nodal_components, mut von_mises_nodes, mut components) =
        (Vec::new(), Vec::new(), Vec::new());
    let mut principal: Vec<Vec<f64>> = Vec::new();
    let strain_components = stress_components(tensors.strains);
    if extras.stress_tensors {
        let nodal = recovered_nodal_stress(mesh, tensors.node_stresses)?;
        nodal_components = stress_components(&nodal);
        von_mises_nodes = nodal.iter().map(von_mises).collect();
        components = stress_components(stresses);
        // σ₁, σ₂, σ₃ of each tet, split into one scalar array each.
        let all = principal_stresses(stresses);
        principal = (0..3)
            .map(|k| all.iter().skip(k).step_by(3).copied().collect::<Vec<f64>>())
            .collect();
    }
    let mut writer = VtuWriter::new(mesh).format(extras.format);
    if let Some(t) = extras.time {
        writer = writer.field_data("TimeValue", t)?;
    }
    writer = writer
        .point_field("displacement", 3, displacement)?
        .point_field("displacement_magnitude", 1, &magnitude)?;
    if let Some(v) = extras.velocity {
        writer = writer.point_field("velocity", 3, v)?;
    }
    if let Some(r) = extras.reactions {
        writer = writer.point_field("reaction_force", 3, r)?;
    }
    if let Some(c) = extras.contact {
        writer = writer.point_field("contact_gap", 1, c.gap)?.point_field(
            "contact_pressure",
            1,
            c.pressure,
        )?;
    }
    if extras.stress_tensors {
        writer = writer
            .point_field("stress_nodal", 6, &nodal_components)?
            .point_field("von_mises_nodal", 1, &von_mises_nodes)?;
    }
    writer = writer
        .cell_field("von_mises", 1, &von_mises_cells)?
        .cell_field("strain_energy_density", 1, energy)?;
    if extras.stress_tensors {
        writer = writer
            .cell_field("stress", 6, &components)?
            .cell_field("strain", 6, &strain_components)?
            .cell_field("principal_stress_1", 1, &principal[0])?
            .cell_field("principal_stress_2", 1, &principal[1])?
            .cell_field("principal_stress_3", 1, &principal[2])?;
    }
    if let Some(eta) = extras.error_indicator {
        writer = writer.cell_field("error_indicator", 1, eta)?;
    }
    writer = writer.cell_index_field("material_id", material_ids)?;
    if let Some(ids) = extras.original_ids {
        writer = writer
            .point_id_field("original_node_id", ids.nodes)?
            .cell_id_field("original_element_id", ids.elements)?;
    }
    writer.write(path)
}
