//! St. Venant–Kirchhoff, added as one file in `src/model/` plus its `ModelKind` entry: its
//! identities (Hooke's law at rest, rotation invariance, the reflection blind spot), an exact
//! tangent, and Newton through the unchanged nonlinear statics.

use crate::common;

use common::{Rng, random_tet};
use nalgebra::{Matrix3, Rotation3, Unit, Vector3};
use tetfem::Material;
use tetfem::analysis::nonlinear::{NewtonOptions, solve_nonlinear_static};
use tetfem::fe::element::{Tet, Vector12};
use tetfem::model::{ForceModel, ModelKind, StVenantKirchhoff};
use tetfem_fixtures::cantilever::Cantilever;

fn material() -> Material {
    Material::new(1e4, 0.3, 1000.0).unwrap()
}

fn displaced(x: &[Vector3<f64>; 4], u: &Vector12) -> [Vector3<f64>; 4] {
    [0, 1, 2, 3].map(|i| x[i] + Vector3::new(u[3 * i], u[3 * i + 1], u[3 * i + 2]))
}

fn deformed_by(x: &[Vector3<f64>; 4], f: &Matrix3<f64>) -> [Vector3<f64>; 4] {
    x.map(|p| f * p)
}

#[test]
fn at_rest_the_tangent_is_hookes_stiffness_and_the_state_is_stress_free() {
    let mut rng = Rng::new(81);
    let model = StVenantKirchhoff::new(&material());
    for _ in 0..5 {
        let x = random_tet(&mut rng);
        let tet = Tet::new(&x).unwrap();
        let k = tet.stiffness(&material());
        // At F = I: dP = 2μ·sym(dF) + λ·tr(dF)·I, Hooke's law; equal up to the round-off of
        // the two evaluation orders.
        let difference = (model.tangent(&tet, &x, &x) - k).amax();
        assert!(difference <= 1e-12 * k.amax(), "{difference:e}");
        // F = Ds·Dm⁻¹ is I only to round-off (~1e-16), so E ~ 1e-16: energy ~ E²·(E·V) and
        // force ~ 1e-16·‖Kₑ‖.
        let energy_scale = material().youngs_modulus() * tet.volume();
        assert!(model.energy(&tet, &x, &x).abs() <= 1e-24 * energy_scale);
        assert!(model.force(&tet, &x, &x).amax() <= 1e-12 * k.amax());
    }
}

#[test]
fn rigid_motions_give_no_force_or_stress_and_mirror_images_no_energy() {
    let mut rng = Rng::new(82);
    let model = StVenantKirchhoff::new(&material());
    let rotation = Rotation3::from_axis_angle(
        &Unit::new_normalize(Vector3::new(1.0, 2.0, 3.0)),
        std::f64::consts::FRAC_PI_2,
    )
    .into_inner();
    for _ in 0..5 {
        let x = random_tet(&mut rng);
        let tet = Tet::new(&x).unwrap();
        let scale = tet.stiffness(&material()).amax();
        let moved = x.map(|p| rotation * p + Vector3::new(0.3, -0.2, 0.1));
        // Round-off of FᵀF − I at |F| ~ 1 times the stiffness scale.
        assert!(model.force(&tet, &x, &moved).amax() <= 1e-12 * scale);
        assert!(
            model.cauchy_stress(&tet, &x, &moved).amax() <= 1e-12 * material().youngs_modulus()
        );
        // The known blind spot: FᵀF cannot tell a reflection from the rest state, so a mirror
        // image of the tet (inverted) stores no energy and feels no force.
        let mirrored = deformed_by(&x, &Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, -1.0)));
        assert!(tetfem::fe::element::signed_volume(&mirrored) < 0.0);
        assert!(model.energy(&tet, &x, &mirrored).abs() <= 1e-12 * scale);
    }
}

#[test]
fn force_and_tangent_match_central_differences() {
    let mut rng = Rng::new(83);
    let model = StVenantKirchhoff::new(&material());
    for case in 0..5 {
        let x = random_tet(&mut rng);
        let tet = Tet::new(&x).unwrap();
        // A finite deformation with rotation, stretch and compression.
        let y = displaced(&x, &Vector12::from_fn(|_, _| rng.range(-0.3, 0.3)));
        let direction = Vector12::from_fn(|_, _| rng.range(-1.0, 1.0));
        let force = model.force(&tet, &x, &y);
        let tangent_action = -(model.tangent(&tet, &x, &y) * direction);
        let mut force_errors = Vec::new();
        let mut tangent_errors = Vec::new();
        for level in 0..3 {
            let h = 1e-3 / f64::from(1 << level);
            let (plus, minus) = (
                displaced(&y, &(direction * h)),
                displaced(&y, &(direction * -h)),
            );
            // f = −∂E/∂x along the direction.
            let energy_slope =
                (model.energy(&tet, &x, &plus) - model.energy(&tet, &x, &minus)) / (2.0 * h);
            force_errors
                .push((energy_slope + force.dot(&direction)).abs() / force.dot(&direction).abs());
            let force_slope =
                (model.force(&tet, &x, &plus) - model.force(&tet, &x, &minus)) / (2.0 * h);
            tangent_errors.push((force_slope - tangent_action).amax() / tangent_action.amax());
        }
        println!("case {case}: force errors {force_errors:?}, tangent errors {tangent_errors:?}");
        // Central differences are O(h²): each halving divides the error by 4 (3.2–4.8), unless
        // it already sits at the round-off floor of the quotient (~1e-10 here).
        for errors in [&force_errors, &tangent_errors] {
            for pair in errors.windows(2) {
                assert!(
                    pair[1] < 1e-9 || (pair[0] / pair[1] - 4.0).abs() < 0.8,
                    "case {case}: {errors:?}"
                );
            }
            assert!(errors[0] < 1e-4, "case {case}: {errors:?}");
        }
        let k = model.tangent(&tet, &x, &y);
        assert!((k - k.transpose()).amax() <= 1e-12 * k.amax());
    }
}

#[test]
fn newton_bends_the_cantilever_far_like_the_other_rotation_invariant_models() {
    // Large rotation, small strain: the rotation-invariant models agree to about the strain
    // (a few percent: measured 1.06 % from corotational and 1.13 % from Neo-Hookean).
    let problem = Cantilever {
        end_load: 600.0,
        ..Cantilever::peer_benchmark([20, 2, 2])
    };
    let mesh = problem.mesh().unwrap();
    let constraints = problem.constraints(&mesh).unwrap();
    let loads = problem.loads(&mesh).unwrap();
    let options = NewtonOptions {
        load_steps: 8,
        ..NewtonOptions::default()
    };
    let tip = |kind: ModelKind| {
        let model = kind.build(&problem.material);
        let report =
            solve_nonlinear_static(&mesh, model.as_ref(), &constraints, &loads, options).unwrap();
        let tip_node = mesh
            .nodes()
            .iter()
            .enumerate()
            .filter(|(_, p)| (p.x - problem.length).abs() < 1e-9)
            .map(|(n, _)| n)
            .next()
            .unwrap();
        let u = &report.displacement;
        (
            Vector3::new(u[3 * tip_node], u[3 * tip_node + 1], u[3 * tip_node + 2]),
            report.iterations,
        )
    };
    let (svk, iterations) = tip(ModelKind::StVenantKirchhoff);
    let (corotational, _) = tip(ModelKind::Corotational);
    let (neo_hookean, _) = tip(ModelKind::NeoHookean);
    // The chord from the clamped end to the tip turns this far (the tip slope, which
    // tests/large_deformation.rs measures, is larger still).
    let rotation = (-svk.z).atan2(problem.length + svk.x).to_degrees();
    println!(
        "tip: St. Venant–Kirchhoff {svk:?} ({iterations} Newton iterations, {rotation:.1}°), corotational {corotational:?}, Neo-Hookean {neo_hookean:?}"
    );
    assert!(rotation > 40.0, "chord rotation {rotation}°");
    for other in [corotational, neo_hookean] {
        let difference = (svk - other).norm() / other.norm();
        assert!(difference < 0.03, "{difference}");
    }
}

#[test]
fn every_model_name_parses_back() {
    for kind in ModelKind::ALL {
        assert_eq!(kind.name().parse::<ModelKind>().unwrap(), kind);
        assert_eq!(kind.build(&material()).name(), kind.name());
    }
    let err = "mooney-rivlin"
        .parse::<ModelKind>()
        .unwrap_err()
        .to_string();
    assert!(err.contains("\"st-venant-kirchhoff\""), "{err}");
}
