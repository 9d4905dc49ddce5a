//! Derived per-node and per-cell fields for output: displacement magnitude, von Mises stress,
//! strain energy density.

use nalgebra::Matrix3;

use crate::element::Vector12;
use crate::error::{Error, Result};
use crate::material::Material;
use crate::mesh::TetMesh;

pub use crate::element::von_mises;

fn check_displacement(mesh: &TetMesh, displacement: &[f64]) -> Result<()> {
    if displacement.len() != mesh.dof_count() {
        return Err(Error::invalid_parameter(
            "displacement",
            format!("{} values", displacement.len()),
            format!("must hold 3 values per node ({})", mesh.dof_count()),
        ));
    }
    Ok(())
}

fn element_displacement(tet: &[usize; 4], displacement: &[f64]) -> Vector12 {
    Vector12::from_fn(|i, _| displacement[3 * tet[i / 3] + i % 3])
}

/// Cauchy stress σ of every tet (constant per linear tet) for a node-major displacement.
pub fn cell_stress(
    mesh: &TetMesh,
    material: &Material,
    displacement: &[f64],
) -> Result<Vec<Matrix3<f64>>> {
    check_displacement(mesh, displacement)?;
    Ok(mesh
        .tets()
        .iter()
        .enumerate()
        .map(|(t, tet)| {
            mesh.element_of(t)
                .stress(material, &element_displacement(tet, displacement))
        })
        .collect())
}

/// Von Mises stress of every tet (stress units, Pa in SI).
pub fn cell_von_mises(
    mesh: &TetMesh,
    material: &Material,
    displacement: &[f64],
) -> Result<Vec<f64>> {
    Ok(cell_stress(mesh, material, displacement)?
        .iter()
        .map(von_mises)
        .collect())
}

/// Strain energy density ½ σ:ε of every tet (energy per volume, J/m³ = Pa in SI); summed with
/// the tet volumes it gives the strain energy ½ uᵀKu.
pub fn cell_strain_energy_density(
    mesh: &TetMesh,
    material: &Material,
    displacement: &[f64],
) -> Result<Vec<f64>> {
    check_displacement(mesh, displacement)?;
    Ok(mesh
        .tets()
        .iter()
        .enumerate()
        .map(|(t, tet)| {
            let element = mesh.element_of(t);
            let u = element_displacement(tet, displacement);
            let strain = element.strain(&u);
            0.5 * element.stress(material, &u).component_mul(&strain).sum()
        })
        .collect())
}

/// |u| of every node (length units) from a node-major displacement (3 values per node).
pub fn displacement_magnitude(displacement: &[f64]) -> Vec<f64> {
    displacement
        .chunks_exact(3)
        .map(|u| (u[0] * u[0] + u[1] * u[1] + u[2] * u[2]).sqrt())
        .collect()
}
