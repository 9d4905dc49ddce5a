//! The force models on the 10-node tet (at its four quadrature points): rigid motions, the
//! tangent against finite differences, the nonlinear patch test, the small-load limit against
//! linear P2, Newton on a large-deflection cantilever, and the 4-node path left as it was.

use nalgebra::{Matrix3, Rotation3, Vector3};
use tetfem::analysis::nonlinear::{NewtonOptions, solve_nonlinear_static};
use tetfem::model::assemble::{energy, internal_force, refill_tangent};
use tetfem::model::{ModelKind, TetModels};
use tetfem::post::output::fields::cell_model_stress;
use tetfem::{
    Assembler, BoxSplit, CellType, Constraints, Loads, Material, Tet10, TetMesh, solve_static,
};

/// The nonlinear models (the linear one is not rotation-invariant).
const NONLINEAR: [ModelKind; 3] = [
    ModelKind::Corotational,
    ModelKind::NeoHookean,
    ModelKind::StVenantKirchhoff,
];

fn steel() -> Material {
    Material::new(200e9, 0.3, 7800.0).unwrap()
}

/// A box of `cells` with the five-tet split, as 10-node tets.
fn quadratic_box(max: [f64; 3], cells: [usize; 3]) -> TetMesh<Tet10> {
    let linear =
        TetMesh::box_grid(Vector3::zeros(), Vector3::from(max), cells, BoxSplit::Five).unwrap();
    TetMesh::<Tet10>::from_linear(&linear).unwrap()
}

/// u = (F − I)·X + c at every node.
fn affine_displacement<C: CellType>(
    mesh: &TetMesh<C>,
    f: &Matrix3<f64>,
    c: Vector3<f64>,
) -> Vec<f64> {
    mesh.nodes()
        .iter()
        .flat_map(|x| {
            let u = (f - Matrix3::identity()) * x + c;
            [u.x, u.y, u.z]
        })
        .collect()
}

fn norm(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}

fn max_abs(v: &[f64]) -> f64 {
    v.iter().fold(0.0, |m, x| m.max(x.abs()))
}

#[test]
fn a_rigid_motion_gives_zero_force_and_stress() {
    let mesh = quadratic_box([1.0, 0.5, 0.5], [2, 1, 1]);
    let material = steel();
    let rotation = Rotation3::from_scaled_axis(Vector3::new(0.4, -0.7, 0.9)).into_inner();
    let u = affine_displacement(&mesh, &rotation, Vector3::new(0.3, -0.2, 0.1));
    // The force scale of a unit strain on this mesh: E·(edge length ~0.5)², and E for stress.
    let force_scale = material.youngs_modulus() * 0.25;
    for kind in NONLINEAR {
        let model = kind.build(&material);
        let force = internal_force(&mesh, &model, &u).unwrap();
        let stresses = cell_model_stress(&mesh, &model, &u).unwrap();
        let worst_stress = stresses.iter().map(|s| s.amax()).fold(0.0, f64::max);
        let e = energy(&mesh, &model, &u).unwrap();
        println!(
            "{}: max |f| / (E h²) = {:.2e}, max |σ| / E = {:.2e}, energy {:.2e}",
            kind.name(),
            max_abs(&force) / force_scale,
            worst_stress / material.youngs_modulus(),
            e
        );
        // Round-off: F = I + ∇u has entries of order one, and the models' stresses are O(E)
        // terms cancelling to zero; 1e-12 leaves ~100 ulps of room.
        assert!(max_abs(&force) <= 1e-12 * force_scale, "{}", kind.name());
        assert!(
            worst_stress <= 1e-12 * material.youngs_modulus(),
            "{}",
            kind.name()
        );
        // The energy scale is E·V (V = 0.25).
        assert!(
            e.abs() <= 1e-12 * material.youngs_modulus() * 0.25,
            "{}",
            kind.name()
        );
    }
}

/// A large, non-homogeneous deformation: a rotation, a stretch and a bend (x² terms, which the
/// quadratic element represents exactly, so F differs at every quadrature point).
fn bent_displacement(mesh: &TetMesh<Tet10>) -> Vec<f64> {
    let rotation = Rotation3::from_scaled_axis(Vector3::new(0.3, 0.5, -0.2)).into_inner();
    mesh.nodes()
        .iter()
        .flat_map(|x| {
            let local = Vector3::new(1.1 * x.x, 0.95 * x.y + 0.1 * x.z, x.z + 0.3 * x.x * x.x);
            let u = rotation * local - x;
            [u.x, u.y, u.z]
        })
        .collect()
}

#[test]
fn the_tangent_is_the_derivative_of_the_force_and_the_force_of_the_energy() {
    let mesh = quadratic_box([1.0, 0.5, 0.5], [1, 1, 1]);
    let material = steel();
    let assembler = Assembler::new(&mesh);
    let u = bent_displacement(&mesh);
    let n = mesh.dof_count();
    for kind in ModelKind::ALL {
        let model = kind.build(&material);
        let mut tangent = assembler.stiffness(&mesh, &material).unwrap();
        refill_tangent(&mesh, &assembler, &model, &u, false, &mut tangent).unwrap();
        let force = internal_force(&mesh, &model, &u).unwrap();
        // Central differences with h = 1e-6 (lengths ~1): truncation O(h²) ~ 1e-12 and
        // round-off ε·|f|/h ~ 1e-10 relative, both far below the 1e-6 asked.
        let h = 1e-6;
        let (mut worst_k, mut worst_f) = (0.0_f64, 0.0_f64);
        for j in 0..n {
            let (mut plus, mut minus) = (u.clone(), u.clone());
            plus[j] += h;
            minus[j] -= h;
            let fp = internal_force(&mesh, &model, &plus).unwrap();
            let fm = internal_force(&mesh, &model, &minus).unwrap();
            let column: Vec<f64> = (0..n).map(|i| (fm[i] - fp[i]) / (2.0 * h)).collect();
            let exact: Vec<f64> = (0..n).map(|i| tangent.get(i, j).unwrap()).collect();
            let difference: Vec<f64> = column.iter().zip(&exact).map(|(a, b)| a - b).collect();
            worst_k = worst_k.max(norm(&difference) / norm(&exact));
            let ep = energy(&mesh, &model, &plus).unwrap();
            let em = energy(&mesh, &model, &minus).unwrap();
            let slope = -(ep - em) / (2.0 * h);
            worst_f = worst_f.max((slope - force[j]).abs() / max_abs(&force));
        }
        println!(
            "{}: tangent vs FD of force {worst_k:.2e}, force vs FD of energy {worst_f:.2e}",
            kind.name()
        );
        assert!(worst_k <= 1e-6, "{}: {worst_k:e}", kind.name());
        assert!(worst_f <= 1e-6, "{}: {worst_f:e}", kind.name());
    }
}

#[test]
fn a_homogeneous_large_deformation_is_reproduced_exactly() {
    let mesh = quadratic_box([1.0, 1.0, 1.0], [2, 2, 2]);
    let material = steel();
    // Stretch, shear and a 41° rotation: strains of 10–20 %.
    let rotation = Rotation3::from_scaled_axis(Vector3::new(0.0, 0.4, 0.6)).into_inner();
    let f = rotation * Matrix3::new(1.2, 0.1, 0.0, 0.0, 0.9, 0.15, 0.05, 0.0, 1.1);
    let exact = affine_displacement(&mesh, &f, Vector3::zeros());
    let on_boundary =
        |x: &Vector3<f64>| (0..3).any(|a| x[a].abs() < 1e-12 || (x[a] - 1.0).abs() < 1e-12);
    let mut constraints = Constraints::new(&mesh);
    let mut interior = Vec::new();
    for (node, x) in mesh.nodes().iter().enumerate() {
        if on_boundary(x) {
            let u = Vector3::new(exact[3 * node], exact[3 * node + 1], exact[3 * node + 2]);
            constraints.prescribe(node, u).unwrap();
        } else {
            interior.push(node);
        }
    }
    assert!(interior.len() >= 7, "interior nodes: {}", interior.len());
    let loads = Loads::new(&mesh);
    for kind in NONLINEAR {
        let model = kind.build(&material);
        // The exact field has zero interior residual (F is the same at every point).
        let force = internal_force(&mesh, &model, &exact).unwrap();
        let interior_force: Vec<f64> = interior
            .iter()
            .flat_map(|&n| force[3 * n..3 * n + 3].to_vec())
            .collect();
        let scale = max_abs(&force);
        // Round-off of sums of O(scale) element forces.
        assert!(max_abs(&interior_force) <= 1e-12 * scale, "{}", kind.name());
        // And Newton from rest finds it.
        let report = solve_nonlinear_static(
            &mesh,
            &model,
            &constraints,
            &loads,
            NewtonOptions::default(),
        )
        .unwrap();
        let error = interior
            .iter()
            .flat_map(|&n| (0..3).map(move |a| 3 * n + a))
            .map(|d| (report.displacement[d] - exact[d]).abs())
            .fold(0.0, f64::max);
        println!(
            "{}: interior force {:.2e} of {:.2e}, Newton error {error:.2e} in {} iterations",
            kind.name(),
            max_abs(&interior_force),
            scale,
            report.iterations
        );
        // Newton's tolerance is on the residual (1e-10 of the reaction scale here): the
        // displacement error it leaves is of that order in relative terms (|u| ~ 0.5).
        assert!(error <= 1e-9, "{}: {error:e}", kind.name());
    }
}

/// A cantilever of 10-node tets (L = 4, 1 × 1 section), clamped at x = 0, with a total tip
/// force −P ẑ on its end face.
struct Cantilever {
    mesh: TetMesh<Tet10>,
    constraints: Constraints,
    unit_load: Loads,
}

fn cantilever(cells: [usize; 3]) -> Cantilever {
    let mesh = quadratic_box([4.0, 1.0, 1.0], cells);
    let mut constraints = Constraints::new(&mesh);
    constraints
        .fix_nodes(&mesh.nodes_on_plane(0, 0.0, 1e-9))
        .unwrap();
    let boundary = mesh.boundary_faces().unwrap();
    let tip = mesh.faces_on_plane(&boundary, 0, 4.0, 1e-9);
    let mut unit_load = Loads::new(&mesh);
    unit_load
        .add_total_force_on_faces(&mesh, &tip, Vector3::new(0.0, 0.0, -1.0))
        .unwrap();
    Cantilever {
        mesh,
        constraints,
        unit_load,
    }
}

fn scaled(loads: &Loads, mesh: &TetMesh<Tet10>, factor: f64) -> Loads {
    let mut out = Loads::new(mesh);
    out.add_scaled(loads, factor).unwrap();
    out
}

#[test]
fn small_loads_agree_with_linear_p2_to_first_order() {
    let beam = cantilever([4, 1, 1]);
    let material = Material::new(1e6, 0.3, 1000.0).unwrap();
    // Tip deflection of the linear beam per unit force: P L³/(3EI) = 64/(3·1e6/12) ≈ 2.6e-4.
    let loads = [1.0, 2.0];
    let linear = solve_static(&beam.mesh, &material, &beam.constraints, &beam.unit_load)
        .unwrap()
        .displacement;
    for kind in NONLINEAR {
        let model = kind.build(&material);
        let options = NewtonOptions {
            load_steps: 1,
            tolerance: 1e-13,
            ..NewtonOptions::default()
        };
        let errors: Vec<f64> = loads
            .iter()
            .map(|&p| {
                let report = solve_nonlinear_static(
                    &beam.mesh,
                    &model,
                    &beam.constraints,
                    &scaled(&beam.unit_load, &beam.mesh, p),
                    options,
                )
                .unwrap();
                let difference: Vec<f64> = report
                    .displacement
                    .iter()
                    .zip(&linear)
                    .map(|(a, b)| a - p * b)
                    .collect();
                norm(&difference) / (p * norm(&linear))
            })
            .collect();
        let ratio = errors[1] / errors[0];
        println!(
            "{}: relative distance to linear P2 {:.3e} at P = 1, {:.3e} at P = 2, ratio {ratio:.3}",
            kind.name(),
            errors[0],
            errors[1]
        );
        // First order: the relative distance is O(P) (the absolute one O(P²)), so doubling P
        // doubles it; ±5 % leaves room for the O(P²) relative term (≈ δ/L ~ 1e-4 here) and
        // Newton's residual (1e-13).
        assert!(errors[0] < 1e-2, "{}: {:e}", kind.name(), errors[0]);
        assert!((ratio - 2.0).abs() < 0.1, "{}: ratio {ratio}", kind.name());
    }
}

#[test]
fn the_linear_model_at_quadrature_points_is_linear_p2() {
    // The linear law (P = C:sym∇u) integrated by the degree-2 rule is the element's linear
    // stiffness: the assembled tangent equals K, and f = −K·u.
    let mesh = quadratic_box([1.0, 0.5, 0.5], [2, 1, 1]);
    let material = steel();
    let assembler = Assembler::new(&mesh);
    let stiffness = assembler.stiffness(&mesh, &material).unwrap();
    let mut tangent = assembler.stiffness(&mesh, &material).unwrap();
    let model = ModelKind::Linear.build(&material);
    let u = bent_displacement(&mesh);
    refill_tangent(&mesh, &assembler, &model, &u, false, &mut tangent).unwrap();
    let scale = stiffness
        .values()
        .iter()
        .fold(0.0_f64, |m, v| m.max(v.abs()));
    let worst = stiffness
        .values()
        .iter()
        .zip(tangent.values())
        .fold(0.0_f64, |m, (a, b)| m.max((a - b).abs()));
    // Round-off of sums of four O(scale) point terms in another order.
    assert!(worst <= 1e-13 * scale, "{worst:e} of {scale:e}");
    let force = internal_force(&mesh, &model, &u).unwrap();
    let mut ku = vec![0.0; u.len()];
    stiffness.mul_vec(&u, &mut ku).unwrap();
    let worst = force
        .iter()
        .zip(&ku)
        .fold(0.0_f64, |m, (f, k)| m.max((f + k).abs()));
    assert!(worst <= 1e-12 * max_abs(&ku), "{worst:e}");
}

#[test]
fn a_cantilever_under_a_large_tip_load_converges_quadratically() {
    let beam = cantilever([8, 2, 2]);
    let material = Material::new(1e6, 0.3, 1000.0).unwrap();
    // Linear beam theory: P L³/(3EI) = 6000·64/(3·1e6/12) = 1.54, 38 % of L = 4.
    let loads = scaled(&beam.unit_load, &beam.mesh, 6000.0);
    for kind in [ModelKind::Corotational, ModelKind::NeoHookean] {
        let model = kind.build(&material);
        let report = solve_nonlinear_static(
            &beam.mesh,
            &model,
            &beam.constraints,
            &loads,
            NewtonOptions {
                load_steps: 6,
                ..NewtonOptions::default()
            },
        )
        .unwrap();
        let last = report.residuals.last().unwrap();
        let tip = beam.mesh.nodes_on_plane(0, 4.0, 1e-9);
        let deflection = tip
            .iter()
            .map(|&n| report.displacement[3 * n + 2])
            .sum::<f64>()
            / tip.len() as f64;
        println!(
            "{}: tip deflection {deflection:.4}, last step residuals {last:?}",
            kind.name()
        );
        // A large deflection: over a quarter of the length (a tip turned by tens of degrees),
        // and below the linear 1.54 (the bent beam stiffens: its load turns towards its axis).
        assert!(
            deflection < -1.0 && deflection > -1.54,
            "{}: {deflection}",
            kind.name()
        );
        // Quadratic convergence: from every iterate of the last step with 1e-5 < rₖ/r₀ < 1e-2
        // (near the solution, and far enough above the round-off floor of the forces, ~1e-11
        // of r₀, for rₖ₊₁ to be measurable), rₖ₊₁/r₀ ≤ 1e2·(rₖ/r₀)²; linear convergence would
        // keep rₖ₊₁/rₖ near a constant instead.
        let r0 = last[0];
        let steps: Vec<(f64, f64)> = last
            .windows(2)
            .map(|w| (w[0] / r0, w[1] / r0))
            .filter(|&(a, _)| a < 1e-2 && a > 1e-5)
            .collect();
        assert!(!steps.is_empty(), "{}: {last:?}", kind.name());
        for (a, b) in steps {
            assert!(b <= 1e2 * a * a, "{}: {a:e} → {b:e}", kind.name());
        }
    }
}

#[test]
fn the_four_node_path_is_the_element_formulas() {
    // The generic assembly on 4-node tets is each model's one-tet formula summed: the same
    // bits as the per-tet ForceModel API (the 4-node code before the element seam).
    let linear = TetMesh::box_grid(
        Vector3::zeros(),
        Vector3::new(1.0, 0.5, 0.5),
        [2, 1, 1],
        BoxSplit::Five,
    )
    .unwrap();
    let material = steel();
    let rotation = Rotation3::from_scaled_axis(Vector3::new(0.3, 0.5, -0.2)).into_inner();
    let u: Vec<f64> = linear
        .nodes()
        .iter()
        .flat_map(|x| {
            let v = rotation * Vector3::new(1.1 * x.x, x.y + 0.1 * x.z, x.z + 0.3 * x.x * x.x) - x;
            [v.x, v.y, v.z]
        })
        .collect();
    for kind in ModelKind::ALL {
        let model = kind.build(&material);
        let mut expected = vec![0.0; linear.dof_count()];
        let mut expected_energy = 0.0;
        for (t, tet) in linear.tets().iter().enumerate() {
            let element = linear.element(t).unwrap();
            let rest = linear.tet_positions(t).unwrap();
            let x = tetfem::model::assemble::deformed_positions(&linear, t, &u).unwrap();
            let f = model.model_of(t).force(&element, &rest, &x);
            expected_energy += model.energy(&element, &rest, &x);
            for (i, &n) in tet.iter().enumerate() {
                for a in 0..3 {
                    expected[3 * n + a] += f[3 * i + a];
                }
            }
        }
        assert_eq!(
            internal_force(&linear, &model, &u).unwrap(),
            expected,
            "{}",
            kind.name()
        );
        // The energy is summed in chunks of 1024 tets: one chunk here, in tet order.
        assert_eq!(
            energy(&linear, &model, &u).unwrap(),
            expected_energy,
            "{}",
            kind.name()
        );
    }
}
