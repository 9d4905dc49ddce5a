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
//! the energy-norm error in that tet (J^½ in SI; see [`estimate`](crate::post::estimate)).
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
use crate::analysis::dynamics::InternalForce;
use crate::base::error::Result;
use crate::fe::materials::TetMaterials;
use crate::mesh::{CellType, TetMesh};
use crate::model::{ModelElement, ModelKind, TetModels};
use crate::post::estimate::PointwiseElement;

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
    /// Per-tet error indicators η_K of [`estimate`](crate::post::estimate) (J^½ in SI), written as
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

/// Writes `path` (atomically) with the fields listed in the book's *Outputs and ParaView*
/// chapter (and with the source, `src/post/output/frame.rs`), the stresses and the
/// energy density those of the linear model with each tet's material (one
/// [`Material`](crate::fe::material::Material) or a [`MaterialMap`](crate::fe::materials::MaterialMap));
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
    result_frame_arrays(mesh, materials, displacement, extras)?
        .writer(mesh)?
        .write(path)
}

/// The arrays [`write_result_frame`] writes, computed and not written: what a distributed run
/// restricts to its piece of the mesh ([`FrameArrays::restrict`]) so that each piece carries
/// the fields of the whole run's frame.
pub fn result_frame_arrays<E: PointwiseElement>(
    mesh: &TetMesh<E>,
    materials: &impl TetMaterials,
    displacement: &[f64],
    extras: FrameExtras<'_>,
) -> Result<FrameArrays> {
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
    frame_arrays(mesh, displacement, extras, tensors, energy, ids)
}

/// As [`write_result_vtu`], with the stresses and energy density of the force model that
/// produced the displacement (its Cauchy stress, its own energy per rest volume; see
/// [`cell_model_stress`] and [`cell_model_energy_density`]). `material_id` is the material index
/// of `materials` (a [`MaterialMap`](crate::fe::materials::MaterialMap), or one material: all 0).
pub fn write_model_result_vtu<E: ModelElement + PointwiseElement>(
    path: &Path,
    mesh: &TetMesh<E>,
    model: &(impl TetModels + ?Sized),
    materials: &impl TetMaterials,
    displacement: &[f64],
    extras: FrameExtras<'_>,
) -> Result<()> {
    model_result_frame_arrays(mesh, model, materials, displacement, extras)?
        .writer(mesh)?
        .write(path)
}

/// The arrays [`write_model_result_vtu`] writes, computed and not written (see
/// [`result_frame_arrays`]).
pub fn model_result_frame_arrays<E: ModelElement + PointwiseElement>(
    mesh: &TetMesh<E>,
    model: &(impl TetModels + ?Sized),
    materials: &impl TetMaterials,
    displacement: &[f64],
    extras: FrameExtras<'_>,
) -> Result<FrameArrays> {
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
    frame_arrays(mesh, displacement, extras, tensors, energy, ids)
}

/// The arrays of one result frame (those of [`write_result_vtu`]), in the order they are
/// written, with the frame's time and encoding: computed by [`result_frame_arrays`] or
/// [`model_result_frame_arrays`], written by [`FrameArrays::writer`].
#[derive(Debug, Clone, PartialEq, Default)]
pub struct FrameArrays {
    /// The frame's time (time units), written as `TimeValue` field data.
    pub time: Option<f64>,
    /// Per-node fields: name, components per node, values (node-major).
    pub point_fields: Vec<(String, usize, Vec<f64>)>,
    /// Per-tet fields: name, components per tet, values (tet-major).
    pub cell_fields: Vec<(String, usize, Vec<f64>)>,
    /// Per-node integer ids (VTK `Int64`): name, values.
    pub point_ids: Vec<(String, Vec<u64>)>,
    /// Per-tet integer ids (VTK `Int64`): name, values.
    pub cell_ids: Vec<(String, Vec<u64>)>,
    /// Per-tet small integers (VTK `Int32`, e.g. `material_id`): name, values.
    pub cell_indices: Vec<(String, Vec<i32>)>,
    /// The file's encoding.
    pub format: VtuFormat,
}

impl FrameArrays {
    /// The arrays of a piece of the mesh: the nodes `nodes` and the tets `tets` (indices into
    /// the frame's mesh, in the piece's order), every array restricted to them.
    /// [`Error::InvalidParameter`](crate::base::error::Error::InvalidParameter) naming a node or tet
    /// beyond an array.
    pub fn restrict(&self, nodes: &[usize], tets: &[usize]) -> Result<FrameArrays> {
        Ok(FrameArrays {
            time: self.time,
            point_fields: self
                .point_fields
                .iter()
                .map(|(name, c, values)| Ok((name.clone(), *c, pick(name, values, *c, nodes)?)))
                .collect::<Result<_>>()?,
            cell_fields: self
                .cell_fields
                .iter()
                .map(|(name, c, values)| Ok((name.clone(), *c, pick(name, values, *c, tets)?)))
                .collect::<Result<_>>()?,
            point_ids: self
                .point_ids
                .iter()
                .map(|(name, values)| Ok((name.clone(), pick(name, values, 1, nodes)?)))
                .collect::<Result<_>>()?,
            cell_ids: self
                .cell_ids
                .iter()
                .map(|(name, values)| Ok((name.clone(), pick(name, values, 1, tets)?)))
                .collect::<Result<_>>()?,
            cell_indices: self
                .cell_indices
                .iter()
                .map(|(name, values)| Ok((name.clone(), pick(name, values, 1, tets)?)))
                .collect::<Result<_>>()?,
            format: self.format,
        })
    }

    /// A writer of `mesh` holding every array (checked for length against `mesh`), in the
    /// frame's encoding; more arrays may be added before writing.
    pub fn writer<'a, C: CellType>(&'a self, mesh: &'a TetMesh<C>) -> Result<VtuWriter<'a, C>> {
        let mut writer = VtuWriter::new(mesh).format(self.format);
        if let Some(t) = self.time {
            writer = writer.field_data("TimeValue", t)?;
        }
        for (name, components, values) in &self.point_fields {
            writer = writer.point_field(name, *components, values)?;
        }
        for (name, components, values) in &self.cell_fields {
            writer = writer.cell_field(name, *components, values)?;
        }
        for (name, values) in &self.cell_indices {
            writer = writer.cell_index_field(name, values)?;
        }
        for (name, values) in &self.point_ids {
            writer = writer.point_id_field(name, values)?;
        }
        for (name, values) in &self.cell_ids {
            writer = writer.cell_id_field(name, values)?;
        }
        Ok(writer)
    }
}

/// The `components` values of each of `items` in `values` (item-major).
fn pick<T: Copy>(name: &str, values: &[T], components: usize, items: &[usize]) -> Result<Vec<T>> {
    let mut picked = Vec::with_capacity(components * items.len());
    for &i in items {
        let range = components * i..components * (i + 1);
        let item = values.get(range).ok_or_else(|| {
            crate::base::error::Error::invalid_parameter(
                format!("index into array '{name}'"),
                i,
                format!("must be below {}", values.len() / components.max(1)),
            )
        })?;
        picked.extend_from_slice(item);
    }
    Ok(picked)
}

/// The material index of every tet, as the `Int32` the `.vtu` holds.
fn material_ids<C: CellType>(mesh: &TetMesh<C>, materials: &impl TetMaterials) -> Result<Vec<i32>> {
    (0..mesh.tet_count())
        .map(|t| {
            let index = materials.index_of(t);
            i32::try_from(index).map_err(|_| {
                crate::base::error::Error::invalid_parameter(
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

/// Computes the arrays of a frame from the stresses, energies and material indices.
fn frame_arrays<C: CellType>(
    mesh: &TetMesh<C>,
    displacement: &[f64],
    extras: FrameExtras<'_>,
    tensors: Tensors<'_>,
    energy: Vec<f64>,
    material_ids: Vec<i32>,
) -> Result<FrameArrays> {
    let stresses = tensors.stresses;
    let mut arrays = FrameArrays {
        time: extras.time,
        format: extras.format,
        ..FrameArrays::default()
    };
    let mut point = |name: &str, components: usize, values: Vec<f64>| {
        arrays
            .point_fields
            .push((name.to_string(), components, values));
    };
    point("displacement", 3, displacement.to_vec());
    point(
        "displacement_magnitude",
        1,
        displacement_magnitude(displacement),
    );
    if let Some(v) = extras.velocity {
        point("velocity", 3, v.to_vec());
    }
    if let Some(r) = extras.reactions {
        point("reaction_force", 3, r.to_vec());
    }
    if let Some(c) = extras.contact {
        point("contact_gap", 1, c.gap.to_vec());
        point("contact_pressure", 1, c.pressure.to_vec());
    }
    if extras.stress_tensors {
        let nodal = recovered_nodal_stress(mesh, tensors.node_stresses)?;
        point("stress_nodal", 6, stress_components(&nodal));
        point("von_mises_nodal", 1, nodal.iter().map(von_mises).collect());
    }
    let mut cell = |name: &str, components: usize, values: Vec<f64>| {
        arrays
            .cell_fields
            .push((name.to_string(), components, values));
    };
    cell("von_mises", 1, stresses.iter().map(von_mises).collect());
    cell("strain_energy_density", 1, energy);
    if extras.stress_tensors {
        cell("stress", 6, stress_components(stresses));
        cell("strain", 6, stress_components(tensors.strains));
        // σ₁, σ₂, σ₃ of each tet, split into one scalar array each.
        let all = principal_stresses(stresses);
        for (k, name) in [
            "principal_stress_1",
            "principal_stress_2",
            "principal_stress_3",
        ]
        .into_iter()
        .enumerate()
        {
            cell(name, 1, all.iter().skip(k).step_by(3).copied().collect());
        }
    }
    if let Some(eta) = extras.error_indicator {
        cell("error_indicator", 1, eta.to_vec());
    }
    arrays
        .cell_indices
        .push(("material_id".to_string(), material_ids));
    if let Some(ids) = extras.original_ids {
        arrays
            .point_ids
            .push(("original_node_id".to_string(), ids.nodes.to_vec()));
        arrays
            .cell_ids
            .push(("original_element_id".to_string(), ids.elements.to_vec()));
    }
    // The lengths are checked here, where a caller's wrong array is still named as before.
    arrays.writer(mesh)?;
    Ok(arrays)
}

/// The outputs whose formula depends on the force model: here, once, so that no front end
/// (scene, Python, PETSc engine) branches on [`InternalForce::Linear`] to pick between the
/// linear model's formula (Hooke's law on the small strain, the ZZ error estimate) and a
/// nonlinear model's own (its Cauchy stress σ(F), its energy density).
impl InternalForce {
    /// The von Mises stress per tet (stress units) at the full displacement `u`: the linear
    /// model's with each tet's material, or the nonlinear model's Cauchy stress.
    ///
    /// Errors: `u` does not hold 3 values per node, or `materials` (the model) does not cover
    /// the tets.
    pub fn cell_von_mises<E: ModelElement>(
        &self,
        mesh: &TetMesh<E>,
        materials: &impl TetMaterials,
        u: &[f64],
    ) -> Result<Vec<f64>> {
        match self {
            InternalForce::Linear => super::fields::cell_von_mises(mesh, materials, u),
            InternalForce::Nonlinear(n) => super::fields::cell_model_von_mises(mesh, n.models(), u),
        }
    }

    /// The Cauchy stress (stress units) at `point` from the full displacement `u`: the linear
    /// model's with the tet's material ([`PointLocation::stress`](crate::post::output::PointLocation::stress)) or the nonlinear model's
    /// ([`PointLocation::model_stress`](crate::post::output::PointLocation::model_stress)).
    ///
    /// Errors: as those two.
    pub fn point_stress<E: PointwiseElement>(
        &self,
        point: &super::PointLocation,
        mesh: &TetMesh<E>,
        materials: &impl TetMaterials,
        u: &[f64],
    ) -> Result<Matrix3<f64>> {
        match self {
            InternalForce::Linear => point.stress(mesh, materials, u),
            InternalForce::Nonlinear(n) => point.model_stress(mesh, n.models(), u),
        }
    }

    /// The arrays of a result frame at the full displacement `u`: [`result_frame_arrays`] for
    /// the linear model, [`model_result_frame_arrays`] (the model's own stresses and energy
    /// density) for a nonlinear one; `materials` gives `material_id` (and the linear model's
    /// stresses).
    ///
    /// Errors: as those two.
    pub fn result_frame_arrays<E: ModelElement + PointwiseElement>(
        &self,
        mesh: &TetMesh<E>,
        materials: &impl TetMaterials,
        u: &[f64],
        extras: FrameExtras<'_>,
    ) -> Result<FrameArrays> {
        match self {
            InternalForce::Linear => result_frame_arrays(mesh, materials, u, extras),
            InternalForce::Nonlinear(n) => {
                model_result_frame_arrays(mesh, n.models(), materials, u, extras)
            }
        }
    }

    /// The ZZ estimate of the energy-norm error of the full displacement `u`:
    /// [`estimate_error`](crate::post::estimate::estimate_error) for the linear model (with or
    /// without obstacles), [`estimate_model_error`](crate::post::estimate::estimate_model_error)
    /// on the second Piola–Kirchhoff stress for a nonlinear one.
    ///
    /// Errors: as those two.
    pub fn estimated_error<E: PointwiseElement>(
        &self,
        mesh: &TetMesh<E>,
        materials: &impl TetMaterials,
        u: &[f64],
    ) -> Result<crate::post::estimate::ErrorEstimate> {
        match self {
            InternalForce::Nonlinear(n) if n.name() != ModelKind::Linear.name() => {
                crate::post::estimate::estimate_model_error(
                    mesh,
                    n.models(),
                    materials,
                    u,
                    crate::post::estimate::Recovery::PatchRecovery,
                )
            }
            _ => crate::post::estimate::estimate_error(mesh, materials, u),
        }
    }

    /// The largest element rotation and strain of the full displacement `u`
    /// ([`largest_rotation_and_strain`](crate::post::adequacy::rotation::largest_rotation_and_strain)),
    /// which say whether the linear model is adequate; `None` for a nonlinear model, which
    /// takes large rotations by construction.
    ///
    /// Errors: as that function.
    pub fn deformation<E: PointwiseElement>(
        &self,
        mesh: &TetMesh<E>,
        u: &[f64],
    ) -> Result<Option<crate::post::adequacy::rotation::Deformation>> {
        match self {
            InternalForce::Linear => Ok(Some(
                crate::post::adequacy::rotation::largest_rotation_and_strain(mesh, u)?,
            )),
            InternalForce::Nonlinear(_) => Ok(None),
        }
    }

    /// For backward Euler with the linear model: how `dt` (time units) resolves the lowest of
    /// `modes` modes that the load excites, and the method's decay per period there
    /// ([`step_resolution`](crate::post::adequacy::time_step::step_resolution)); the load is the
    /// system's external load or, when that is zero, the `initial` displacement (free DOFs).
    /// `None` for another method or a nonlinear model, whose modes the check does not know.
    ///
    /// Errors: as that function.
    pub fn step_resolution(
        &self,
        method: crate::analysis::dynamics::Method,
        system: &crate::analysis::dynamics::LinearSystem,
        initial: &[f64],
        modes: usize,
        dt: f64,
    ) -> Result<Option<crate::post::adequacy::time_step::StepResolution>> {
        match (method, self) {
            (crate::analysis::dynamics::Method::BackwardEuler, InternalForce::Linear) => {
                // The load excites the motion; with no load, the initial displacement does.
                let excitation = match system.external_load().iter().any(|f| *f != 0.0) {
                    true => system.external_load().to_vec(),
                    false => initial.to_vec(),
                };
                Ok(Some(crate::post::adequacy::time_step::step_resolution(
                    system,
                    &excitation,
                    modes,
                    dt,
                )?))
            }
            _ => Ok(None),
        }
    }
}
