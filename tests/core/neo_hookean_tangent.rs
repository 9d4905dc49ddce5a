//! The Neo-Hookean tangent in closed form (Kₑ = V·Gᵀ·A·G with A = ∂P/∂F, issue 39 target 2):
//! against the twelve directional derivatives dF ↦ dP ↦ force the model formed it from before
//! (written out here as the reference), against central differences of the element force, and
//! exactly symmetric; the law's 9×9 A against its directional derivatives too.

use crate::common;

use common::{Rng, random_tet};
use nalgebra::{Matrix3, Rotation3, SMatrix, Unit, Vector3};
use tetfem::Material;
use tetfem::fe::element::{Matrix12, Tet, Vector12};
use tetfem::model::{ConstitutiveLaw, ForceModel, NeoHookean};

/// Rubber-like (ν = 0.45: λ̂ ≈ 11·μ, the volumetric term dominates) and a compressible one.
fn materials() -> [Material; 2] {
    [
        Material::new(1e5, 0.45, 1000.0).unwrap(),
        Material::new(2e9, 0.2, 7850.0).unwrap(),
    ]
}

/// μ, λ̂ = λ + μ and α = 1 + μ/λ̂ of the model's energy (see [`NeoHookean`]).
fn parameters(material: &Material) -> (f64, f64, f64) {
    let mu = material.shear_modulus();
    let lambda_hat = material.lame_lambda() + mu;
    (mu, lambda_hat, 1.0 + mu / lambda_hat)
}

fn cofactor(f: &Matrix3<f64>) -> Matrix3<f64> {
    let c = |i: usize| f.column(i).into_owned();
    Matrix3::from_columns(&[c(1).cross(&c(2)), c(2).cross(&c(0)), c(0).cross(&c(1))])
}

/// dP = μ·dF + λ̂(C:dF)·C + λ̂(J − α)·d(cof F) at `f`, d(cof F) column by column from
/// cof F = [f₁×f₂, f₂×f₀, f₀×f₁]: the directional derivative the model used before.
fn piola_direction(material: &Material, f: &Matrix3<f64>, df: &Matrix3<f64>) -> Matrix3<f64> {
    let (mu, lambda_hat, alpha) = parameters(material);
    let cof = cofactor(f);
    let c = |m: &Matrix3<f64>, i: usize| -> Vector3<f64> { m.column(i).into_owned() };
    let dcof = Matrix3::from_columns(&[
        c(df, 1).cross(&c(f, 2)) + c(f, 1).cross(&c(df, 2)),
        c(df, 2).cross(&c(f, 0)) + c(f, 2).cross(&c(df, 0)),
        c(df, 0).cross(&c(f, 1)) + c(f, 0).cross(&c(df, 1)),
    ]);
    df * mu
        + cof * (lambda_hat * cof.component_mul(df).sum())
        + dcof * (lambda_hat * (f.determinant() - alpha))
}

/// The element tangent as the model formed it before: column j is V·dP(dF_j)·Dm⁻ᵀ spread
/// over the nodes (node 0 minus the sum) for the unit nodal direction j, then symmetrized.
fn directional_tangent(material: &Material, tet: &Tet, f: &Matrix3<f64>) -> Matrix12 {
    let b = tet.rest_inverse();
    let mut k = Matrix12::zeros();
    for j in 0..12 {
        let mut ds = Matrix3::zeros();
        let (node, axis) = (j / 3, j % 3);
        for column in 0..3 {
            ds[(axis, column)] = match node {
                0 => -1.0,
                n if n == column + 1 => 1.0,
                _ => 0.0,
            };
        }
        let h = piola_direction(material, f, &(ds * b)) * b.transpose() * tet.volume();
        for i in 0..3 {
            for a in 0..3 {
                k[(3 * (i + 1) + a, j)] = h[(a, i)];
                k[(a, j)] -= h[(a, i)];
            }
        }
    }
    (k + k.transpose()) * 0.5
}

fn random_rotation(rng: &mut Rng) -> Matrix3<f64> {
    let axis = Unit::new_normalize(rng.vector(-1.0, 1.0) + Vector3::new(0.0, 0.0, 1e-3));
    Rotation3::from_axis_angle(&axis, rng.range(-3.1, 3.1)).into_inner()
}

/// Deformation gradients of every kind the solver meets: stretches in [0.3, 2] between random
/// rotations, one in three with a negative stretch (inverted tets).
fn random_gradient(rng: &mut Rng, case: usize) -> Matrix3<f64> {
    let mut stretches = Vector3::new(
        rng.range(0.3, 2.0),
        rng.range(0.3, 2.0),
        rng.range(0.3, 2.0),
    );
    if case % 3 == 2 {
        stretches.z = -stretches.z;
    }
    random_rotation(rng) * Matrix3::from_diagonal(&stretches) * random_rotation(rng)
}

fn deformed_by(x: &[Vector3<f64>; 4], f: &Matrix3<f64>) -> [Vector3<f64>; 4] {
    x.map(|p| x[0] + f * (p - x[0]))
}

#[test]
fn the_closed_form_tangent_is_the_directional_derivatives_it_replaces_and_exactly_symmetric() {
    let mut rng = Rng::new(39);
    let mut worst = 0.0f64;
    for material in materials() {
        let model = NeoHookean::new(&material);
        for case in 0..60 {
            let x = random_tet(&mut rng);
            let tet = Tet::new(&x).unwrap();
            let y = deformed_by(&x, &random_gradient(&mut rng, case));
            let k = model.tangent(&tet, &x, &y);
            assert!(k == k.transpose(), "case {case}: not exactly symmetric");
            let reference = directional_tangent(&material, &tet, &tet.deformation_gradient(&y));
            let difference = (k - reference).amax() / reference.amax();
            worst = worst.max(difference);
        }
    }
    println!("closed-form Neo-Hookean tangent against the directional one: worst {worst:.2e}");
    // Both are sums of the same products in another order: round-off of a few ulps of the
    // largest term. The terms (μ, λ̂·|cof F|², λ̂|J − α|·|F|, times V·|Dm⁻¹|²) exceed the
    // largest entry by at most ~10× for stretches in [0.3, 2], and each entry sums ≤ ~30 of
    // them: 30·10·2.2e-16 ≈ 7e-14 (measured: 5.9e-16).
    assert!(worst < 1e-13, "worst relative difference {worst:e}");
}

#[test]
fn the_neo_hookean_piola_tangent_is_its_directional_derivative() {
    let mut rng = Rng::new(40);
    let mut worst = 0.0f64;
    for material in materials() {
        let model = NeoHookean::new(&material);
        for case in 0..60 {
            let f = random_gradient(&mut rng, case);
            let a = model.piola_tangent(&f);
            let reference = SMatrix::<f64, 9, 9>::from_fn(|r, c| {
                let mut df = Matrix3::zeros();
                df[c] = 1.0;
                piola_direction(&material, &f, &df)[r]
            });
            assert!(a == a.transpose(), "case {case}: A not exactly symmetric");
            worst = worst.max((a - reference).amax() / reference.amax());
        }
    }
    println!("closed-form ∂P/∂F against the directional one: worst {worst:.2e}");
    // The same sums in another order (≤ 3 terms an entry, each at most ~10× the largest
    // entry for stretches in [0.3, 2]): a few ulps (measured: 2.2e-16).
    assert!(worst < 1e-14, "worst relative difference {worst:e}");
}

#[test]
fn the_neo_hookean_tangent_is_the_central_difference_of_the_force() {
    let mut rng = Rng::new(41);
    for material in materials() {
        let model = NeoHookean::new(&material);
        for case in 0..12 {
            let x = random_tet(&mut rng);
            let tet = Tet::new(&x).unwrap();
            let y = deformed_by(&x, &random_gradient(&mut rng, case));
            let direction = Vector12::from_fn(|_, _| rng.range(-1.0, 1.0));
            let exact = -(model.tangent(&tet, &x, &y) * direction);
            let errors: Vec<f64> = (0..3)
                .map(|level| {
                    let h = 1e-3 / f64::from(1 << level);
                    let shifted = |s: f64| {
                        let mut z = y;
                        for (i, p) in z.iter_mut().enumerate() {
                            *p += Vector3::new(
                                direction[3 * i],
                                direction[3 * i + 1],
                                direction[3 * i + 2],
                            ) * s;
                        }
                        model.force(&tet, &x, &z)
                    };
                    ((shifted(h) - shifted(-h)) / (2.0 * h) - exact).amax() / exact.amax()
                })
                .collect();
            // O(h²): each halving divides the error by 4 (3.2–4.8 allowed), unless it is at
            // the difference quotient's round-off floor (ε·|f|/h ≈ 1e-12·|K|·|y|, ~1e-10).
            for pair in errors.windows(2) {
                assert!(
                    pair[1] < 1e-9 || (pair[0] / pair[1] - 4.0).abs() < 0.8,
                    "case {case}: {errors:?}"
                );
            }
            // The h² term: the third derivative of the force (~|K|/|F|) times h² = 1e-6.
            assert!(errors[0] < 1e-4, "case {case}: {errors:?}");
        }
    }
}
