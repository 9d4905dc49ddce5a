//! One result frame as a `.vtu`: the fields a FEM user expects to colour by in ParaView.

use std::path::Path;

use super::VtuWriter;
use super::fields::{
    cell_model_energy_density, cell_model_von_mises, cell_strain_energy_density, cell_von_mises,
    displacement_magnitude,
};
use crate::element::ElementType;
use crate::error::Result;
use crate::materials::TetMaterials;
use crate::mesh::{CellType, TetMesh};
use crate::model::TetModels;

/// Writes `path` (atomically) with point fields `displacement` (3 components),
/// `displacement_magnitude`, optionally `velocity` (3), and cell fields `von_mises` (stress
/// units) and `strain_energy_density` (energy/volume), all from node-major vectors. The cell
/// fields are those of the linear model, each tet with its own material (one
/// [`Material`](crate::material::Material) or a [`MaterialMap`](crate::materials::MaterialMap));
/// see [`write_model_result_vtu`] for a nonlinear run.
pub fn write_result_vtu<E: ElementType>(
    path: &Path,
    mesh: &TetMesh<E>,
    materials: &impl TetMaterials,
    displacement: &[f64],
    velocity: Option<&[f64]>,
) -> Result<()> {
    let von_mises = cell_von_mises(mesh, materials, displacement)?;
    let energy = cell_strain_energy_density(mesh, materials, displacement)?;
    write_fields(path, mesh, displacement, velocity, &von_mises, &energy)
}

/// As [`write_result_vtu`] for a static solution, with its reactions as the point field
/// `reaction_force` (force units; K·u − f on the constrained DOFs, zero on the free ones).
pub fn write_static_result_vtu<E: ElementType>(
    path: &Path,
    mesh: &TetMesh<E>,
    materials: &impl TetMaterials,
    displacement: &[f64],
    reactions: &[f64],
) -> Result<()> {
    let von_mises = cell_von_mises(mesh, materials, displacement)?;
    let energy = cell_strain_energy_density(mesh, materials, displacement)?;
    let magnitude = displacement_magnitude(displacement);
    VtuWriter::new(mesh)
        .point_field("displacement", 3, displacement)?
        .point_field("displacement_magnitude", 1, &magnitude)?
        .point_field("reaction_force", 3, reactions)?
        .cell_field("von_mises", 1, &von_mises)?
        .cell_field("strain_energy_density", 1, &energy)?
        .write(path)
}

/// As [`write_result_vtu`], with the cell fields of the force model that produced the
/// displacement: `von_mises` of its Cauchy stress and its own `strain_energy_density` (energy
/// per rest volume), see [`cell_model_von_mises`] and [`cell_model_energy_density`].
pub fn write_model_result_vtu(
    path: &Path,
    mesh: &TetMesh,
    model: &(impl TetModels + ?Sized),
    displacement: &[f64],
    velocity: Option<&[f64]>,
) -> Result<()> {
    let von_mises = cell_model_von_mises(mesh, model, displacement)?;
    let energy = cell_model_energy_density(mesh, model, displacement)?;
    write_fields(path, mesh, displacement, velocity, &von_mises, &energy)
}

fn write_fields<C: CellType>(
    path: &Path,
    mesh: &TetMesh<C>,
    displacement: &[f64],
    velocity: Option<&[f64]>,
    von_mises: &[f64],
    energy: &[f64],
) -> Result<()> {
    let magnitude = displacement_magnitude(displacement);
    let mut writer = VtuWriter::new(mesh)
        .point_field("displacement", 3, displacement)?
        .point_field("displacement_magnitude", 1, &magnitude)?;
    if let Some(v) = velocity {
        writer = writer.point_field("velocity", 3, v)?;
    }
    writer
        .cell_field("von_mises", 1, von_mises)?
        .cell_field("strain_energy_density", 1, energy)?
        .write(path)
}
