//! The ZZ estimate of a nonlinear model's run (`estimate_model_error`) against the true error
//! of its Green strain, on a manufactured large deformation of the unit cube: the effectivity
//! η / ‖E − E_h‖_C in the band for every nonlinear model, P1 and P2, under refinement;
//! the same estimate for the same deformation turned 30° as a whole (the second
//! Piola–Kirchhoff stress does not see the turn); an inverted tet estimated, a flattened one
//! named.

use std::f64::consts::PI;

use nalgebra::{Matrix3, Rotation3, Unit, Vector3};
use tetfem::analysis::nonlinear::{NewtonOptions, solve_nonlinear_static};
use tetfem::fe::materials::MaterialMap;
use tetfem::fe::quadrature::tet_rule;
use tetfem::model::{ModelKind, ModelMap, TetModels};
use tetfem::post::estimate::{
    PointwiseElement, Recovery, estimate_map_error, estimate_model_error,
};
use tetfem::{BoxSplit, Constraints, Material, Tet10, TetMesh};

use crate::common::manufactured::{barycentric, body_loads, corners};

/// The placement x(X) = R·(X + α·d·φ(X)), φ = sin πX sin πY sin πZ: on the cube's faces a
/// rigid turn R, inside a smooth deformation (Green strains up to 0.081 on the mid plane,
/// printed by the effectivity test).
struct Placement {
    alpha: f64,
    direction: Vector3<f64>,
    rotation: Rotation3<f64>,
}

impl Placement {
    fn new(turn_degrees: f64) -> Self {
        let axis = Unit::new_normalize(Vector3::new(1.0, 1.0, 1.0));
        Placement {
            alpha: 0.03,
            direction: Vector3::new(1.0, 2.0, -1.0).normalize(),
            rotation: Rotation3::from_axis_angle(&axis, turn_degrees.to_radians()),
        }
    }

    fn phi_and_gradient(p: &Vector3<f64>) -> (f64, Vector3<f64>) {
        let s = [(PI * p.x).sin(), (PI * p.y).sin(), (PI * p.z).sin()];
        let c = [(PI * p.x).cos(), (PI * p.y).cos(), (PI * p.z).cos()];
        let gradient = Vector3::new(c[0] * s[1] * s[2], s[0] * c[1] * s[2], s[0] * s[1] * c[2]);
        (s[0] * s[1] * s[2], gradient * PI)
    }

    fn displacement(&self, p: &Vector3<f64>) -> Vector3<f64> {
        let (phi, _) = Self::phi_and_gradient(p);
        self.rotation * (p + self.direction * (self.alpha * phi)) - p
    }

    /// F = R·(I + α·d⊗∇φ).
    fn deformation_gradient(&self, p: &Vector3<f64>) -> Matrix3<f64> {
        let (_, gradient) = Self::phi_and_gradient(p);
        self.rotation.matrix()
            * (Matrix3::identity() + self.direction * gradient.transpose() * self.alpha)
    }

    /// b = −Div P(F(X)) by central differences of P (step h = 1e-5: the truncation error
    /// h²·|P'''| ~ 1e-10·|P| is far below the discretization errors measured, 1e-3 and up).
    fn body_force(&self, law: &dyn tetfem::model::ForceModel, p: &Vector3<f64>) -> Vector3<f64> {
        const H: f64 = 1e-5;
        let mut divergence = Vector3::zeros();
        for j in 0..3 {
            let mut step = Vector3::zeros();
            step[j] = H;
            let plus = law.first_piola(&self.deformation_gradient(&(p + step)));
            let minus = law.first_piola(&self.deformation_gradient(&(p - step)));
            divergence += (plus - minus).column(j) / (2.0 * H);
        }
        -divergence
    }
}

/// E = ½(FᵀF − I).
fn green(f: &Matrix3<f64>) -> Matrix3<f64> {
    (f.transpose() * f - Matrix3::identity()) * 0.5
}

/// ‖E − E_h‖_C = (∫ (E − E_h) : C : (E − E_h) dV)^½ by the degree-5 rule.
fn true_error<E: PointwiseElement>(
    mesh: &TetMesh<E>,
    material: &Material,
    u: &[f64],
    placement: &Placement,
) -> f64 {
    let (lambda, mu) = (material.lame_lambda(), material.shear_modulus());
    let mut element = vec![0.0; 3 * E::NODES];
    let mut sum = 0.0;
    for t in 0..mesh.tet_count() {
        for (i, &n) in mesh.tets()[t].as_ref().iter().enumerate() {
            element[3 * i..3 * i + 3].copy_from_slice(&u[3 * n..3 * n + 3]);
        }
        let (x, tet) = corners(mesh, t);
        for q in &tet_rule() {
            let l = barycentric(&q.barycentric);
            let p = x[0] * l[0] + x[1] * l[1] + x[2] * l[2] + x[3] * l[3];
            let f_h = Matrix3::identity() + E::displacement_gradient_at(&tet.into(), &l, &element);
            let e = green(&placement.deformation_gradient(&p)) - green(&f_h);
            let s = Matrix3::identity() * (lambda * e.trace()) + e * (2.0 * mu);
            sum += q.weight * tet.volume() * s.component_mul(&e).sum();
        }
    }
    sum.sqrt()
}

fn unit_cube(n: usize) -> TetMesh {
    TetMesh::box_grid(
        Vector3::zeros(),
        Vector3::repeat(1.0),
        [n; 3],
        BoxSplit::Lecture6,
    )
    .expect("valid box")
}

/// One solve of the placement on `mesh` with `kind`: (η, true error).
fn estimate_and_truth<E: PointwiseElement + tetfem::model::ModelElement>(
    mesh: &TetMesh<E>,
    kind: ModelKind,
    placement: &Placement,
) -> (f64, f64) {
    let material = Material::new(1e5, 0.3, 1000.0).expect("valid");
    let models = ModelMap::new(kind, &MaterialMap::uniform(material, mesh.tet_count()));
    let mut constraints = Constraints::new(mesh);
    for axis in 0..3 {
        for value in [0.0, 1.0] {
            for node in mesh.nodes_on_plane(axis, value, 1e-9) {
                let u = placement.displacement(&mesh.nodes()[node]);
                constraints.prescribe(node, u).expect("node in range");
            }
        }
    }
    let law = models.model_of(0);
    let loads = body_loads(mesh, |p| placement.body_force(law, p));
    let options = NewtonOptions {
        load_steps: 4,
        ..NewtonOptions::default()
    };
    let solution = solve_nonlinear_static(mesh, &models, &constraints, &loads, options)
        .unwrap_or_else(|e| panic!("{} solves: {e}", kind.name()));
    let estimate = estimate_map_error(
        mesh,
        &models,
        &solution.displacement,
        Recovery::PatchRecovery,
    )
    .expect("estimates");
    let truth = true_error(mesh, &material, &solution.displacement, placement);
    (estimate.estimate, truth)
}

/// The band for the nonlinear recovery estimator's effectivity.
const BAND: (f64, f64) = (0.7, 1.5);

#[test]
fn nonlinear_models_effectivity_within_band_for_p1_and_p2() {
    let placement = Placement::new(0.0);
    let largest_strain = (0..=20)
        .flat_map(|i| (0..=20).map(move |j| (i, j)))
        .map(|(i, j)| {
            let p = Vector3::new(i as f64 / 20.0, j as f64 / 20.0, 0.5);
            green(&placement.deformation_gradient(&p)).abs().max()
        })
        .fold(0.0, f64::max);
    println!("largest Green strain component on the mid plane: {largest_strain:.4}");
    for kind in [
        ModelKind::NeoHookean,
        ModelKind::StVenantKirchhoff,
        ModelKind::Corotational,
    ] {
        for (element, levels) in [("P1", [4, 8]), ("P2", [2, 4])] {
            let mut effectivities = Vec::new();
            for n in levels {
                let linear = unit_cube(n);
                let (eta, truth) = if element == "P1" {
                    estimate_and_truth(&linear, kind, &placement)
                } else {
                    let mesh = TetMesh::<Tet10>::from_linear(&linear).expect("P2 mesh");
                    estimate_and_truth(&mesh, kind, &placement)
                };
                effectivities.push(eta / truth);
                println!(
                    "{} {element} n = {n}: η = {eta:.4e}, true {truth:.4e}, effectivity {:.3}",
                    kind.name(),
                    eta / truth
                );
            }
            for e in &effectivities {
                assert!(
                    (BAND.0..=BAND.1).contains(e),
                    "{} {element}: effectivities {effectivities:.3?} outside {BAND:?}",
                    kind.name()
                );
            }
        }
    }
}

#[test]
fn a_turn_of_the_whole_body_leaves_the_estimate_unchanged() {
    let mesh = unit_cube(4);
    for kind in [ModelKind::NeoHookean, ModelKind::Corotational] {
        let (still, still_truth) = estimate_and_truth(&mesh, kind, &Placement::new(0.0));
        let (turned, turned_truth) = estimate_and_truth(&mesh, kind, &Placement::new(30.0));
        println!(
            "{}: η {still:.6e} still, {turned:.6e} turned 30°; truth {still_truth:.6e}, {turned_truth:.6e}",
            kind.name()
        );
        // The discrete problem turned is the unturned one turned (objective models, turned
        // boundary data and loads), so both solutions agree to the Newton tolerance (1e-10
        // of the load) times the conditioning: 1e-6 leaves that room and is far below what a
        // stress that turned with the body would change (the turn's strain, 1 − cos 30° = 0.13).
        assert!(
            (turned - still).abs() <= 1e-6 * still,
            "{}: η {still} still, {turned} turned",
            kind.name()
        );
        assert!(
            (turned_truth - still_truth).abs() <= 1e-6 * still_truth,
            "{}: true error {still_truth} still, {turned_truth} turned",
            kind.name()
        );
    }
}

#[test]
fn an_inverted_tet_is_estimated_and_a_flattened_one_is_named() {
    let mesh = unit_cube(1);
    let material = Material::new(1e5, 0.3, 1000.0).expect("valid");
    let materials = MaterialMap::uniform(material, mesh.tet_count());
    let recovery = Recovery::PatchRecovery;
    // x = −X on one axis turns every tet inside out (det F = −1): every model here defines P
    // there (the stable Neo-Hookean form, the corotational rotation taking the reflection), so
    // S = F⁻¹P is finite and the estimate too.
    let mut u = vec![0.0; mesh.dof_count()];
    for (n, p) in mesh.nodes().iter().enumerate() {
        u[3 * n] = -2.0 * p.x;
    }
    for kind in [ModelKind::NeoHookean, ModelKind::Corotational] {
        let models = ModelMap::new(kind, &materials);
        let estimate = estimate_model_error(&mesh, &models, &materials, &u, recovery)
            .unwrap_or_else(|e| panic!("{} at det F = -1: {e}", kind.name()));
        assert!(estimate.estimate.is_finite(), "{estimate:?}");
    }
    // x = 0 on one axis (F singular): no S = F⁻¹P for any model.
    for (n, p) in mesh.nodes().iter().enumerate() {
        u[3 * n] = -p.x;
    }
    let models = ModelMap::new(ModelKind::Corotational, &materials);
    let error = estimate_model_error(&mesh, &models, &materials, &u, recovery)
        .expect_err("no S where F is singular");
    let text = error.to_string();
    assert!(
        text.contains("tet 0") && text.contains("det F = 0e0"),
        "{text}"
    );
}
