//! Derived per-node and per-cell fields for output: displacement magnitude, von Mises stress,
//! strain energy density.
//!
//! The `cell_*` functions taking a [`Material`](crate::material::Material) (or a
//! [`MaterialMap`](crate::materials::MaterialMap)) evaluate the linear (small-strain) model; the
//! `cell_model_*` functions evaluate the [`ForceModel`](crate::model::ForceModel) that produced the displacement (its own
//! Cauchy stress and energy), which is what a run with a nonlinear model must report: the linear
//! strain of a rigid rotation is not zero.

use nalgebra::Matrix3;

use crate::element::ElementType;
use crate::error::{Error, Result};
use crate::materials::TetMaterials;
use crate::mesh::{CellType, TetMesh};
use crate::model::{ModelElement, TetModels};

pub use crate::element::von_mises;

fn check_displacement<C: CellType>(mesh: &TetMesh<C>, displacement: &[f64]) -> Result<()> {
    if displacement.len() != mesh.dof_count() {
        return Err(Error::invalid_parameter(
            "displacement",
            format!("{} values", displacement.len()),
            format!("must hold 3 values per node ({})", mesh.dof_count()),
        ));
    }
    Ok(())
}

/// `f(t, uₑ)` for every tet t with its node-major element displacement uₑ (3 values per node).
fn per_tet<C: CellType, T>(
    mesh: &TetMesh<C>,
    displacement: &[f64],
    mut f: impl FnMut(usize, &[f64]) -> T,
) -> Vec<T> {
    let mut element = vec![0.0; 3 * C::NODES];
    let mut values = Vec::with_capacity(mesh.tet_count());
    for (t, tet) in mesh.tets().iter().enumerate() {
        for (i, &n) in tet.as_ref().iter().enumerate() {
            element[3 * i..3 * i + 3].copy_from_slice(&displacement[3 * n..3 * n + 3]);
        }
        values.push(f(t, &element));
    }
    values
}

/// Cauchy stress σ of every tet for a node-major displacement (constant per linear tet; the
/// volume average for higher-order elements, [`ElementType::mean_stress`]).
///
/// `materials`: one [`Material`](crate::material::Material) for every tet, or a
/// [`MaterialMap`](crate::materials::MaterialMap) (each tet's stress from its own material).
pub fn cell_stress<E: ElementType>(
    mesh: &TetMesh<E>,
    materials: &impl TetMaterials,
    displacement: &[f64],
) -> Result<Vec<Matrix3<f64>>> {
    check_displacement(mesh, displacement)?;
    materials.check_tet_count(mesh)?;
    Ok(per_tet(mesh, displacement, |t, u| {
        E::mean_stress(&E::rest(mesh, t), materials.material_of(t), u)
    }))
}

/// Linear (small) strain ε = ½(∇u + ∇uᵀ) of every tet for a node-major displacement
/// (dimensionless; constant per linear tet, the volume average for higher-order elements,
/// [`ElementType::mean_strain`]). Tensor shear components: ε_xy, not the engineering γ_xy = 2ε_xy.
pub fn cell_strain<E: ElementType>(
    mesh: &TetMesh<E>,
    displacement: &[f64],
) -> Result<Vec<Matrix3<f64>>> {
    check_displacement(mesh, displacement)?;
    Ok(per_tet(mesh, displacement, |t, u| {
        E::mean_strain(&E::rest(mesh, t), u)
    }))
}

/// Von Mises stress of every tet (stress units, Pa in SI).
pub fn cell_von_mises<E: ElementType>(
    mesh: &TetMesh<E>,
    materials: &impl TetMaterials,
    displacement: &[f64],
) -> Result<Vec<f64>> {
    Ok(cell_stress(mesh, materials, displacement)?
        .iter()
        .map(von_mises)
        .collect())
}

/// Strain energy density ½ σ:ε of every tet (energy per volume, J/m³ = Pa in SI; the volume
/// average for higher-order elements); summed with the tet volumes it gives the strain energy
/// ½ uᵀKu.
pub fn cell_strain_energy_density<E: ElementType>(
    mesh: &TetMesh<E>,
    materials: &impl TetMaterials,
    displacement: &[f64],
) -> Result<Vec<f64>> {
    check_displacement(mesh, displacement)?;
    materials.check_tet_count(mesh)?;
    Ok(per_tet(mesh, displacement, |t, u| {
        E::strain_energy_density(&E::rest(mesh, t), materials.material_of(t), u)
    }))
}

/// Cauchy stress σ of every tet as `model` defines it ([`ForceModel::cauchy_stress`](crate::model::ForceModel::cauchy_stress), stress
/// units) at the node-major `displacement`: constant in a 4-node tet, the volume average over
/// the quadrature points of a 10-node one ([`ModelElement::model_cauchy_stress`]).
pub fn cell_model_stress<E: ModelElement>(
    mesh: &TetMesh<E>,
    model: &(impl TetModels + ?Sized),
    displacement: &[f64],
) -> Result<Vec<Matrix3<f64>>> {
    check_displacement(mesh, displacement)?;
    model.check_covers(mesh.tet_count())?;
    Ok((0..mesh.tet_count())
        .map(|t| E::model_cauchy_stress(model.model_of(t), mesh, t, displacement))
        .collect())
}

/// The strain of every tet that goes with `model`'s stress (dimensionless, tensor shear
/// components): the linear strain ε = ½(∇u + ∇uᵀ) for the [linear](crate::model::ModelKind::Linear)
/// model, the Green–Lagrange strain E = ½(FᵀF − I) (F the deformation gradient, referred to
/// the rest configuration) for the nonlinear ones, which equals ε to first order in ∇u and,
/// unlike ε, vanishes under any rigid rotation. Volume averages for higher-order elements.
pub fn cell_model_strain<E: ModelElement>(
    mesh: &TetMesh<E>,
    model: &(impl TetModels + ?Sized),
    displacement: &[f64],
) -> Result<Vec<Matrix3<f64>>> {
    check_displacement(mesh, displacement)?;
    model.check_covers(mesh.tet_count())?;
    let linear = crate::model::ModelKind::Linear.name();
    let linear_strains = per_tet(mesh, displacement, |t, u| {
        (model.model_of(t).name() == linear).then(|| E::mean_strain(&E::rest(mesh, t), u))
    });
    Ok(linear_strains
        .into_iter()
        .enumerate()
        .map(|(t, strain)| strain.unwrap_or_else(|| E::mean_green_strain(mesh, t, displacement)))
        .collect())
}

/// Von Mises stress of `model`'s Cauchy stress in every tet (stress units).
pub fn cell_model_von_mises<E: ModelElement>(
    mesh: &TetMesh<E>,
    model: &(impl TetModels + ?Sized),
    displacement: &[f64],
) -> Result<Vec<f64>> {
    Ok(cell_model_stress(mesh, model, displacement)?
        .iter()
        .map(von_mises)
        .collect())
}

/// `model`'s strain energy density in every tet: its element energy over the rest volume
/// (energy per rest volume, J/m³ = Pa in SI); summed with the rest volumes it gives the model's
/// total elastic energy. For the linear model this is ½σ:ε.
pub fn cell_model_energy_density<E: ModelElement>(
    mesh: &TetMesh<E>,
    model: &(impl TetModels + ?Sized),
    displacement: &[f64],
) -> Result<Vec<f64>> {
    check_displacement(mesh, displacement)?;
    model.check_covers(mesh.tet_count())?;
    Ok((0..mesh.tet_count())
        .map(|t| {
            let energy = E::model_energy(model.model_of(t), mesh, t, displacement);
            energy / E::volume(&E::rest(mesh, t))
        })
        .collect())
}

/// |u| of every node (length units) from a node-major displacement (3 values per node).
///
/// Computed as m·‖u/m‖ with m = max |uᵢ|, so that neither tiny (|u| ~ 1e-200, whose square
/// underflows to 0) nor huge (~1e200, whose square overflows to ∞) components are lost; a
/// non-finite component gives a non-finite |u| (NaN stays NaN, ±∞ gives ∞).
pub fn displacement_magnitude(displacement: &[f64]) -> Vec<f64> {
    displacement
        .chunks_exact(3)
        .map(|u| {
            let largest = u[0].abs().max(u[1].abs()).max(u[2].abs());
            if u.iter().any(|v| v.is_nan()) {
                f64::NAN
            } else if largest == 0.0 || largest.is_infinite() {
                largest
            } else {
                let (x, y, z) = (u[0] / largest, u[1] / largest, u[2] / largest);
                largest * (x * x + y * y + z * z).sqrt()
            }
        })
        .collect()
}

/// The six independent components of each symmetric tensor (stress, or strain: tensor shear
/// components), in ParaView's order for a symmetric tensor: XX, YY, ZZ, XY, YZ, XZ (the
/// tensor's units).
pub fn stress_components(stresses: &[Matrix3<f64>]) -> Vec<f64> {
    stresses
        .iter()
        .flat_map(|s| {
            [
                s[(0, 0)],
                s[(1, 1)],
                s[(2, 2)],
                s[(0, 1)],
                s[(1, 2)],
                s[(0, 2)],
            ]
        })
        .collect()
}

/// The principal stresses σ₁ ≥ σ₂ ≥ σ₃ of each stress tensor (its eigenvalues, stress units),
/// three per tensor.
pub fn principal_stresses(stresses: &[Matrix3<f64>]) -> Vec<f64> {
    stresses
        .iter()
        .flat_map(|s| {
            let mut values: Vec<f64> = nalgebra::SymmetricEigen::new(*s)
                .eigenvalues
                .iter()
                .copied()
                .collect();
            values.sort_by(|a, b| b.total_cmp(a));
            values
        })
        .collect()
}

/// Recovered nodal stress: at each node the volume-weighted average of the stresses of the tets
/// around it, Σₑ Vₑσₑ / Σₑ Vₑ (stress units; zero at a node no tet uses). Smooth where the
/// per-tet stress jumps, for contour plots; it is an average, not a more accurate stress.
///
/// Errors: `stresses` does not hold one tensor per tet.
pub fn nodal_stress<C: CellType>(
    mesh: &TetMesh<C>,
    stresses: &[Matrix3<f64>],
) -> Result<Vec<Matrix3<f64>>> {
    Error::check_len("stresses", mesh.tet_count(), stresses.len())?;
    let mut sum = vec![Matrix3::zeros(); mesh.node_count()];
    let mut weight = vec![0.0; mesh.node_count()];
    for (t, tet) in mesh.tets().iter().enumerate() {
        let volume = crate::mesh::geometry::signed_volume(&mesh.corner_positions_of(t));
        for &n in tet.as_ref() {
            sum[n] += stresses[t] * volume;
            weight[n] += volume;
        }
    }
    Ok(sum
        .into_iter()
        .zip(weight)
        .map(|(s, w)| if w > 0.0 { s / w } else { s })
        .collect())
}
