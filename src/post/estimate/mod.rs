//! A posteriori error estimate of a linear-elastic solution: the Zienkiewicz–Zhu (ZZ)
//! recovered-stress estimator, per element and in total, in the energy norm.
//!
//! From the finite element stress σ_h (constant per P1 tet, linear per P2 tet) a continuous
//! stress σ* is recovered at the nodes ([`recovery`]: volume-weighted averaging of each tet's
//! own stress at the node) and interpolated with the element's shape functions. Per tet K
//!
//! η_K² = ∫_K (σ* − σ_h) : C⁻¹ : (σ* − σ_h) dV,  C⁻¹σ = (σ − λ/(3λ + 2μ) tr(σ) I) / (2μ),
//!
//! integrated exactly (degree 2p: the 4-point degree-2 rule for P1, the degree-5 rule of
//! [`quadrature`](crate::fe::quadrature) for P2). η_K has the units of √energy (J^½ in SI): η_K²
//! is an energy, like the energy norm ‖v‖_E² = ∫ ε(v):C:ε(v) dV = vᵀKv. The global estimate
//! is η = (Σ η_K²)^½ and the relative estimate η / (‖u_h‖_E² + η²)^½, which estimates
//! ‖u − u_h‖_E / ‖u‖_E because ‖u‖_E² = ‖u_h‖_E² + ‖u − u_h‖_E² for a conforming Galerkin
//! solution (Galerkin orthogonality, homogeneous or exactly represented Dirichlet data).
//!
//! The reference points are Zienkiewicz & Zhu, "A simple error estimator and adaptive
//! procedure for practical engineering analysis" (IJNME 24, 1987) and MFEM's example 21 (ZZ
//! estimator for elasticity with a flux recovered in the H¹ space). Measured effectivities
//! (η / true error) are in `tests/core/error_estimate.rs` and the book's chapter *Quadratic elements and
//! error estimates* (`docs/src/quadratic.md`):
//! patch recovery ([`Recovery::PatchRecovery`], the default) keeps them in [0.7, 1.5] for P1
//! and P2; plain averaging ([`Recovery::Averaging`]) does for P1 only.
//!
//! [`estimate_error`] measures the linear-elastic (small-strain) stress: for a run with a
//! nonlinear model it is the discretization error of the linearized problem, not of that
//! model; [`estimate_model_error`] ([`model`]) estimates the error of the model's own run, on
//! its second Piola–Kirchhoff stress.
//! Across an interface between materials the exact stress jumps (only the traction is
//! continuous) and the recovered one does not, so η_K overestimates along such interfaces.

pub mod model;
pub mod recovery;

use nalgebra::{Matrix3, Vector3};

/// The element seam of pointwise evaluation, kept here under its earlier path; it lives with
/// the elements (`crate::fe::element::pointwise`), since loads evaluate fields with it too.
pub use crate::fe::element::PointwiseElement;
pub use crate::fe::element::pointwise;
pub use model::{estimate_map_error, estimate_model_error};
use recovery::{corners_of, gather, hooke};

use crate::base::error::{Error, Result};
use crate::fe::element::Tet;
use crate::fe::materials::TetMaterials;
use crate::fe::quadrature::{QuadraturePoint, tet_rule};
use crate::mesh::TetMesh;

/// The error estimate of one displacement field (see the [module](self) docs).
#[derive(Debug, Clone, PartialEq)]
pub struct ErrorEstimate {
    /// η_K per tet, in √energy units (J^½ in SI).
    pub indicators: Vec<f64>,
    /// The global estimate η = (Σ η_K²)^½ (J^½).
    pub estimate: f64,
    /// The energy norm of the finite element solution, ‖u_h‖_E = (u_hᵀKu_h)^½ (J^½).
    pub energy_norm: f64,
}

impl ErrorEstimate {
    /// The relative estimate η / (‖u_h‖_E² + η²)^½ (dimensionless), an estimate of
    /// ‖u − u_h‖_E / ‖u‖_E; 0 for a zero field.
    pub fn relative(&self) -> f64 {
        let total = (self.energy_norm.powi(2) + self.estimate.powi(2)).sqrt();
        if total > 0.0 {
            self.estimate / total
        } else {
            0.0
        }
    }
}

/// The degree-2 rule (4 points at barycentric (α, β, β, β) and permutations, weights ¼), exact
/// for the quadratic integrand of a P1 tet.
fn degree_two_rule() -> Vec<QuadraturePoint> {
    const ALPHA: f64 = 0.585_410_196_624_968_5;
    const BETA: f64 = 0.138_196_601_125_010_5;
    (0..4)
        .map(|q| {
            let l: [f64; 4] = std::array::from_fn(|i| if i == q { ALPHA } else { BETA });
            QuadraturePoint {
                barycentric: Vector3::new(l[1], l[2], l[3]),
                weight: 0.25,
            }
        })
        .collect()
}

/// e:C⁻¹:e for a stress difference e, with Lamé λ and shear modulus μ (energy per volume).
fn complementary_energy(e: &Matrix3<f64>, lambda: f64, mu: f64) -> f64 {
    let trace = e.trace();
    (e.component_mul(e).sum() - lambda / (3.0 * lambda + 2.0 * mu) * trace * trace) / (2.0 * mu)
}

/// The ZZ estimate of `displacement` (node-major, 3 values per node) on `mesh` with each
/// tet's material (one [`Material`](crate::fe::material::Material) or a
/// [`MaterialMap`](crate::fe::materials::MaterialMap)); see the [module](self) docs. O(tets).
///
/// Errors: `displacement` does not hold 3 values per node, a value is not finite, or
/// `materials` does not cover the tets.
pub fn estimate_error<E: PointwiseElement>(
    mesh: &TetMesh<E>,
    materials: &impl TetMaterials,
    displacement: &[f64],
) -> Result<ErrorEstimate> {
    estimate_error_with(mesh, materials, displacement, Recovery::default())
}

/// How the continuous stress σ* is recovered from the element stresses.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum Recovery {
    /// Volume-weighted nodal averaging ([`recovery::averaged_nodal_stress`]).
    Averaging,
    /// Superconvergent patch recovery ([`recovery::spr_nodal_stress`]).
    #[default]
    PatchRecovery,
}

/// [`estimate_error`] with a chosen [`Recovery`].
pub fn estimate_error_with<E: PointwiseElement>(
    mesh: &TetMesh<E>,
    materials: &impl TetMaterials,
    displacement: &[f64],
    recovery: Recovery,
) -> Result<ErrorEstimate> {
    check_displacement(mesh, displacement)?;
    materials.check_tet_count(mesh)?;
    let recovered = match recovery {
        Recovery::Averaging => recovery::averaged_nodal_stress(mesh, materials, displacement),
        Recovery::PatchRecovery => recovery::spr_nodal_stress(mesh, materials, displacement)?,
    };
    let stress = |t: usize, gradient: &Matrix3<f64>| hooke(materials.material_of(t), gradient);
    let (indicators, _) = element_indicators(mesh, materials, displacement, &recovered, &stress);
    let mut element = vec![0.0; 3 * E::NODES];
    let mut energy = 0.0;
    for t in 0..mesh.tet_count() {
        gather(mesh, t, displacement, &mut element);
        let volume = corners_of(mesh, t).volume();
        energy += 2.0
            * volume
            * E::strain_energy_density(&E::rest(mesh, t), materials.material_of(t), &element);
    }
    let estimate = indicators.iter().map(|e| e * e).sum::<f64>().sqrt();
    Ok(ErrorEstimate {
        indicators,
        estimate,
        energy_norm: energy.max(0.0).sqrt(),
    })
}

/// `displacement` holds 3 finite values per node of `mesh`: an error naming the first that
/// does not.
fn check_displacement<E: PointwiseElement>(mesh: &TetMesh<E>, displacement: &[f64]) -> Result<()> {
    Error::check_len("displacement", mesh.dof_count(), displacement.len())?;
    match displacement.iter().position(|v| !v.is_finite()) {
        Some(dof) => Err(Error::invalid_parameter(
            format!("displacement[{dof}]"),
            displacement[dof],
            "must be finite to estimate its error",
        )),
        None => Ok(()),
    }
}

/// Per tet, η_K = (∫_K (σ* − σ_h) : C⁻¹ : (σ* − σ_h) dV)^½ with σ* interpolated from the
/// `recovered` nodal values and σ_h = `stress` of the tet's own displacement gradient, C the
/// tet's linear elasticity; and Σ_K ∫_K σ_h : C⁻¹ : σ_h dV (energy units), the squared norm
/// of the finite element stress in the same metric. Integrated by the degree-2p rule on the
/// straight tet of the corners, each point weighed by det G (the volume element of a curved
/// tet, [`ElementShape::volume_ratio`](crate::fe::element::isoparametric::ElementShape::volume_ratio)).
fn element_indicators<E: PointwiseElement>(
    mesh: &TetMesh<E>,
    materials: &impl TetMaterials,
    displacement: &[f64],
    recovered: &[Matrix3<f64>],
    stress: &recovery::StressOf,
) -> (Vec<f64>, f64) {
    let rule = if E::DEGREE <= 1 {
        degree_two_rule()
    } else {
        tet_rule()
    };
    let mut element = vec![0.0; 3 * E::NODES];
    let mut shape = vec![0.0; E::NODES];
    let mut indicators = Vec::with_capacity(mesh.tet_count());
    let mut stress_norm = 0.0;
    for t in 0..mesh.tet_count() {
        gather(mesh, t, displacement, &mut element);
        let corners = corners_of(mesh, t);
        let material = materials.material_of(t);
        let (lambda, mu) = (material.lame_lambda(), material.shear_modulus());
        let nodes = mesh.tets()[t].as_ref();
        let (mut squared, mut own) = (0.0, 0.0);
        for q in &rule {
            let b = q.barycentric;
            let l = [1.0 - b.x - b.y - b.z, b.x, b.y, b.z];
            E::shape_values_at(&l, &mut shape);
            let smooth: Matrix3<f64> = nodes
                .iter()
                .zip(&shape)
                .map(|(&n, &s)| recovered[n] * s)
                .sum();
            let fe = stress(t, &E::displacement_gradient_at(&corners, &l, &element));
            // dV = det G·dV_X on a curved tet (1 on a straight one, where the sum is the
            // plain rule bit for bit).
            let weight = q.weight * corners.volume_ratio(&l);
            squared += weight * complementary_energy(&(smooth - fe), lambda, mu);
            own += weight * complementary_energy(&fe, lambda, mu);
        }
        let straight_volume = Tet::volume(&corners);
        indicators.push((squared * straight_volume).max(0.0).sqrt());
        stress_norm += own * straight_volume;
    }
    (indicators, stress_norm)
}
