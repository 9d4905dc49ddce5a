//! Derived per-node and per-cell fields for output: displacement magnitude, von Mises stress,
//! strain energy density.
//!
//! The `cell_*` functions taking a [`Material`](crate::fe::material::Material) (or a
//! [`MaterialMap`](crate::fe::materials::MaterialMap)) evaluate the linear (small-strain) model; the
//! `cell_model_*` functions evaluate the [`ForceModel`](crate::model::ForceModel) that produced the displacement (its own
//! Cauchy stress and energy), which is what a run with a nonlinear model must report: the linear
//! strain of a rigid rotation is not zero.

use nalgebra::Matrix3;

use crate::base::error::{Error, Result};
use crate::fe::element::ElementType;
use crate::fe::materials::TetMaterials;
use crate::mesh::{CellType, TetMesh};
use crate::model::{ModelElement, TetModels};
use crate::post::estimate::PointwiseElement;

pub use crate::fe::element::von_mises;

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
/// volume average for higher-order elements, [`ElementType::mean_stress`], which for the
/// straight-sided 10-node tet, whose stress is linear, is its value at the centroid). For the
/// stress at the nodes of each tet see [`tet_node_stress`].
///
/// `materials`: one [`Material`](crate::fe::material::Material) for every tet, or a
/// [`MaterialMap`](crate::fe::materials::MaterialMap) (each tet's stress from its own material).
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
    stresses.iter().flat_map(symmetric_components).collect()
}

/// The six independent components of one symmetric tensor in ParaView's order XX, YY, ZZ, XY,
/// YZ, XZ (the upper triangle; the tensor's units).
pub fn symmetric_components(s: &Matrix3<f64>) -> [f64; 6] {
    [
        s[(0, 0)],
        s[(1, 1)],
        s[(2, 2)],
        s[(0, 1)],
        s[(1, 2)],
        s[(0, 2)],
    ]
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

/// Recovered nodal stress from one stress per tet: at each node the volume-weighted average of
/// the stresses of the tets around it, Σₑ Vₑσₑ / Σₑ Vₑ (stress units; zero at a node no tet
/// uses). Smooth where the per-tet stress jumps, for contour plots; it is an average, not a
/// more accurate stress. For a 10-node tet, whose stress varies in the tet, average its values
/// at the nodes instead ([`tet_node_stress`], [`recovered_nodal_stress`]): averaging the tet
/// means flattens a stress gradient.
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

/// `f(t, i, uₑ)` for every node i of every tet t (tet-major: entry `t·NODES + i`), with tet t's
/// node-major element displacement uₑ.
fn per_tet_node<C: CellType>(
    mesh: &TetMesh<C>,
    displacement: &[f64],
    mut f: impl FnMut(usize, usize, &[f64]) -> Matrix3<f64>,
) -> Vec<Matrix3<f64>> {
    let mut element = vec![0.0; 3 * C::NODES];
    let mut values = Vec::with_capacity(mesh.tet_count() * C::NODES);
    for (t, tet) in mesh.tets().iter().enumerate() {
        for (i, &n) in tet.as_ref().iter().enumerate() {
            element[3 * i..3 * i + 3].copy_from_slice(&displacement[3 * n..3 * n + 3]);
        }
        values.extend((0..C::NODES).map(|i| f(t, i, &element)));
    }
    values
}

/// The linear-elastic Cauchy stress σₑ(xᵢ) = λ tr(ε) I + 2με of each tet at each of its own
/// nodes (stress units), from that tet's displacement field alone: tet-major, entry
/// `t·NODES + i` is tet t at its local node i. A 4-node tet's stress is constant, so its four
/// values are its [`cell_stress`] (the same bits); a 10-node tet's strain is linear in the tet
/// and is evaluated at each of its ten nodes, so a stress varying linearly in space is
/// reproduced exactly where the tet mean is not.
///
/// Errors: `displacement` does not hold 3 values per node, or `materials` does not cover the
/// tets.
pub fn tet_node_stress<E: PointwiseElement>(
    mesh: &TetMesh<E>,
    materials: &impl TetMaterials,
    displacement: &[f64],
) -> Result<Vec<Matrix3<f64>>> {
    check_displacement(mesh, displacement)?;
    materials.check_tet_count(mesh)?;
    if E::DEGREE < 2 {
        // Constant in the tet: its mean, by the cell field's own formula (bit-identical).
        let cells = cell_stress(mesh, materials, displacement)?;
        return Ok(cells
            .iter()
            .flat_map(|s| std::iter::repeat_n(*s, E::NODES))
            .collect());
    }
    Ok(per_tet_node(mesh, displacement, |t, i, u| {
        let corners = crate::post::estimate::recovery::corners_of(mesh, t);
        let gradient = E::displacement_gradient_at(&corners, &E::node_barycentric(i), u);
        crate::post::estimate::recovery::hooke(materials.material_of(t), &gradient)
    }))
}

/// `model`'s Cauchy stress of each tet at each of its own nodes (stress units), tet-major as
/// [`tet_node_stress`]: for a 4-node tet its [`cell_model_stress`] at all four nodes (the same
/// bits); for a 10-node tet the model's σ(F) with F = I + ∇u evaluated at each node (the
/// quadrature points' law, [`ConstitutiveLaw::cauchy`](crate::model::ConstitutiveLaw::cauchy),
/// at the node instead of at the points).
///
/// Errors: `displacement` does not hold 3 values per node, or `model` does not cover the tets.
pub fn tet_node_model_stress<E: ModelElement + PointwiseElement>(
    mesh: &TetMesh<E>,
    model: &(impl TetModels + ?Sized),
    displacement: &[f64],
) -> Result<Vec<Matrix3<f64>>> {
    check_displacement(mesh, displacement)?;
    model.check_covers(mesh.tet_count())?;
    if E::DEGREE < 2 {
        let cells = cell_model_stress(mesh, model, displacement)?;
        return Ok(cells
            .iter()
            .flat_map(|s| std::iter::repeat_n(*s, E::NODES))
            .collect());
    }
    Ok(per_tet_node(mesh, displacement, |t, i, u| {
        let corners = crate::post::estimate::recovery::corners_of(mesh, t);
        let gradient = E::displacement_gradient_at(&corners, &E::node_barycentric(i), u);
        model.model_of(t).cauchy(&(Matrix3::identity() + gradient))
    }))
}

/// Recovered nodal stress from each tet's stress at its own nodes ([`tet_node_stress`],
/// tet-major, `NODES` per tet): at node n the volume-weighted average over the tets e that hold
/// it, σ*(n) = Σₑ Vₑ σₑ(xₙ) / Σₑ Vₑ (stress units; zero at a node no tet uses; Vₑ the curved
/// volume of a curved 10-node tet). Where the
/// finite element stress is continuous (a stress field the elements represent exactly) this is
/// that stress; for 4-node tets it equals [`nodal_stress`] of the cell stresses, bit for bit.
///
/// Errors: `node_stresses` does not hold `NODES` tensors per tet.
pub fn recovered_nodal_stress<C: CellType>(
    mesh: &TetMesh<C>,
    node_stresses: &[Matrix3<f64>],
) -> Result<Vec<Matrix3<f64>>> {
    Error::check_len(
        "node_stresses",
        mesh.tet_count() * C::NODES,
        node_stresses.len(),
    )?;
    let mut sum = vec![Matrix3::zeros(); mesh.node_count()];
    let mut weight = vec![0.0; mesh.node_count()];
    for (t, tet) in mesh.tets().iter().enumerate() {
        let shape = crate::fe::element::pointwise::corners_of(mesh, t);
        // A curved 10-node tet weighs by its own (curved) volume; a straight one as always.
        let volume = match shape.map() {
            Some(_) => shape.volume(),
            None => crate::mesh::geometry::signed_volume(&mesh.corner_positions_of(t)),
        };
        for (i, &n) in tet.as_ref().iter().enumerate() {
            sum[n] += node_stresses[t * C::NODES + i] * volume;
            weight[n] += volume;
        }
    }
    Ok(sum
        .into_iter()
        .zip(weight)
        .map(|(s, w)| if w > 0.0 { s / w } else { s })
        .collect())
}
