//! Element-level identities: symmetry, rigid-body null space, the B-matrix form, renumbering
//! invariance, and the lecture's face-force recipe.

use crate::common;

use common::{Rng, random_tet};
use nalgebra::{SymmetricEigen, Vector3};
use tetfem::fe::element::{Tet, Vector12};
use tetfem::{Material, TetMesh};

fn material() -> Material {
    Material::new(2.5e4, 0.32, 1200.0).unwrap()
}

/// The 6 infinitesimal rigid motions of a tet's nodes: 3 translations, 3 rotations ω × x.
fn rigid_modes(x: &[Vector3<f64>; 4]) -> Vec<Vector12> {
    let mut modes = Vec::new();
    for axis in 0..3 {
        let mut m = Vector12::zeros();
        for node in 0..4 {
            m[3 * node + axis] = 1.0;
        }
        modes.push(m);
    }
    for axis in 0..3 {
        let omega = Vector3::ith(axis, 1.0);
        let mut m = Vector12::zeros();
        for node in 0..4 {
            let v = omega.cross(&x[node]);
            for a in 0..3 {
                m[3 * node + a] = v[a];
            }
        }
        modes.push(m);
    }
    modes
}

#[test]
fn stiffness_is_symmetric_psd_with_exactly_six_rigid_modes() {
    let mut rng = Rng::new(1);
    for _ in 0..20 {
        let x = random_tet(&mut rng);
        let k = Tet::new(&x).unwrap().stiffness(&material());
        let scale = k.amax();
        // Symmetry is exact by construction (each off-diagonal block is stored with its transpose).
        assert_eq!(k, k.transpose());
        let mut eigenvalues: Vec<f64> =
            SymmetricEigen::new(k).eigenvalues.iter().copied().collect();
        eigenvalues.sort_by(f64::total_cmp);
        // Six zero eigenvalues up to round-off of a 12×12 eigensolve (~1e-15 × scale);
        // the remaining six are genuinely positive for a tet of quality > 0.2.
        for (i, &lambda) in eigenvalues.iter().enumerate() {
            if i < 6 {
                assert!(
                    lambda.abs() < 1e-12 * scale,
                    "eigenvalue {i} = {lambda:e} should vanish"
                );
            } else {
                assert!(
                    lambda > 1e-3 * scale,
                    "eigenvalue {i} = {lambda:e} should be positive"
                );
            }
        }
        for mode in rigid_modes(&x) {
            let force = k * mode;
            assert!(
                force.amax() < 1e-12 * scale * mode.amax(),
                "K·rigid = {:e}",
                force.amax()
            );
        }
    }
}

#[test]
fn stiffness_equals_volume_times_bt_d_b() {
    let mut rng = Rng::new(2);
    let mat = material();
    for _ in 0..10 {
        let tet = Tet::new(&random_tet(&mut rng)).unwrap();
        let b = tet.strain_displacement();
        let reference = b.transpose() * mat.engineering_stiffness() * b * tet.volume();
        let k = tet.stiffness(&mat);
        // Two evaluation orders of the same sums: agreement to a few ulps of the largest entry.
        assert!((k - reference).amax() < 1e-13 * k.amax());
    }
}

#[test]
fn lecture_constitutive_matrix_is_hookes_law() {
    let mat = material();
    let d = mat.tensor_stiffness();
    let (lambda, mu) = (mat.lame_lambda(), mat.shear_modulus());
    // Exact algebraic identities of the lecture's D, up to round-off of the divisions.
    for i in 0..3 {
        assert!((d[(i, i)] - (lambda + 2.0 * mu)).abs() < 1e-12 * d[(i, i)]);
        assert!((d[(i + 3, i + 3)] - 2.0 * mu).abs() < 1e-12 * d[(i, i)]);
        for j in 0..3 {
            if i != j {
                assert!((d[(i, j)] - lambda).abs() < 1e-12 * d[(i, i)]);
            }
        }
    }
}

#[test]
fn stiffness_is_invariant_under_node_renumbering() {
    let mut rng = Rng::new(3);
    let mat = material();
    let x = random_tet(&mut rng);
    let k = Tet::new(&x).unwrap().stiffness(&mat);
    let mut permutations = Vec::new();
    for a in 0..4 {
        for b in 0..4 {
            for c in 0..4 {
                for d in 0..4 {
                    let p = [a, b, c, d];
                    let mut s = p;
                    s.sort();
                    if s == [0, 1, 2, 3] {
                        permutations.push(p);
                    }
                }
            }
        }
    }
    assert_eq!(permutations.len(), 24);
    let nodes: Vec<Vector3<f64>> = x.to_vec();
    for p in permutations {
        // Through the mesh, odd permutations are reoriented; the element must still be the same.
        let mesh = TetMesh::new(nodes.clone(), vec![p]).unwrap();
        let stored = mesh.tets()[0];
        let kp = mesh.element(0).unwrap().stiffness(&mat);
        for i in 0..4 {
            for j in 0..4 {
                for a in 0..3 {
                    for b in 0..3 {
                        let got = kp[(3 * i + a, 3 * j + b)];
                        let want = k[(3 * stored[i] + a, 3 * stored[j] + b)];
                        assert!(
                            (got - want).abs() < 1e-12 * k.amax(),
                            "{p:?}: {got} vs {want}"
                        );
                    }
                }
            }
        }
    }
}

#[test]
fn lecture_face_force_recipe_is_minus_k_u_to_first_order() {
    let mut rng = Rng::new(4);
    let mat = material();
    for _ in 0..5 {
        let x = random_tet(&mut rng);
        let tet = Tet::new(&x).unwrap();
        let k = tet.stiffness(&mat);
        let mut direction = Vector12::zeros();
        for i in 0..12 {
            direction[i] = rng.range(-1.0, 1.0);
        }
        let mut errors = Vec::new();
        for level in 0..4 {
            let scale = 1e-3 / f64::from(1 << level);
            let u = direction * scale;
            let deformed =
                [0, 1, 2, 3].map(|n| x[n] + Vector3::new(u[3 * n], u[3 * n + 1], u[3 * n + 2]));
            let recipe = tet.lecture_face_forces(&mat, &deformed);
            let linear = -(k * u);
            let mut error: f64 = 0.0;
            for n in 0..4 {
                for a in 0..3 {
                    error = error.max((recipe[n][a] - linear[3 * n + a]).abs());
                }
            }
            // The two agree to first order: the mismatch is a small fraction of the force.
            assert!(
                error < 1e-2 * linear.amax(),
                "level {level}: error {error:e} vs force {:e}",
                linear.amax()
            );
            errors.push(error);
        }
        // Second order: halving u divides the mismatch by 4 (observed ratio within ±0.3 of 4;
        // the remainder is the next term of the expansion).
        for pair in errors.windows(2) {
            let ratio = pair[0] / pair[1];
            assert!(
                (ratio - 4.0).abs() < 0.3,
                "error ratio {ratio} (errors {errors:?})"
            );
        }
    }
}

#[test]
fn masses_sum_to_density_times_volume() {
    let mut rng = Rng::new(5);
    let tet = Tet::new(&random_tet(&mut rng)).unwrap();
    let rho = 1200.0;
    let consistent = tet.consistent_mass(rho);
    let total_mass = rho * tet.volume();
    // Per axis, the consistent mass sums to ρV; its row sums are the lumped masses.
    assert!((consistent.sum() - 3.0 * total_mass).abs() < 1e-12 * total_mass);
    for row in 0..12 {
        let row_sum: f64 = consistent.row(row).sum();
        assert!((row_sum - tet.lumped_mass(rho)).abs() < 1e-12 * total_mass);
    }
}

#[test]
fn negatively_oriented_or_flat_element_is_an_error() {
    let x = [Vector3::zeros(), Vector3::x(), Vector3::y(), Vector3::z()];
    assert!(Tet::new(&x).is_ok());
    let flipped = [x[0], x[2], x[1], x[3]];
    assert!(matches!(
        Tet::new(&flipped),
        Err(tetfem::Error::InvalidParameter { .. })
    ));
    let flat = [x[0], x[1], x[2], Vector3::new(0.5, 0.5, 0.0)];
    assert!(Tet::new(&flat).is_err());
}

#[test]
fn consistent_mass_is_its_closed_form_and_the_integral_of_shape_products() {
    // Issue 22 item 6: the sums above hold for a lumped diagonal too; the entries do not.
    let mut rng = Rng::new(11);
    let x = random_tet(&mut rng);
    let tet = Tet::new(&x).unwrap();
    let rho = 1200.0;
    let m = tet.consistent_mass(rho);
    let rule = tetfem::fe::quadrature::tet_rule();
    let scale = rho * tet.volume();
    for a in 0..4 {
        for b in 0..4 {
            // Closed form ρV/20·(1 + δ_ab), and ρ∫N_a·N_b dV by the degree-5 rule (exact for
            // this quadratic integrand): both agree with M to round-off of O(1) sums.
            let closed = scale / 20.0 * if a == b { 2.0 } else { 1.0 };
            let integral =
                rho * tetfem::fe::quadrature::integrate(&tet, &x, &rule, |_, n| n[a] * n[b]);
            assert!((integral - closed).abs() < 1e-13 * scale);
            for i in 0..3 {
                for j in 0..3 {
                    let expected = if i == j { closed } else { 0.0 };
                    let entry = m[(3 * a + i, 3 * b + j)];
                    assert!(
                        (entry - expected).abs() < 1e-13 * scale,
                        "M[{a}{i}, {b}{j}] = {entry:e}, closed form {expected:e}"
                    );
                }
            }
        }
    }
}
