//! The stabilized P1–P1 element (4-node tets, `stabilized_p1`): the patch test (an affine
//! displacement with its constant pressure reproduced to round-off), Lamé's thick-walled tube
//! without volumetric locking where the plain linear tet locks, the displacement and pressure
//! converging under refinement, and the reactions balancing the loads; its Neo-Hookean form
//! (`stabilized_p1_neo_hookean`): a homogeneous deformation's closed-form pressure, the
//! tangent against central differences, Cook's membrane under refinement.

use nalgebra::Vector3;
use tetfem::analysis::nonlinear::NewtonOptions;
use tetfem::fe::element::stabilized_p1_neo_hookean::stabilized_neo_hookean;
use tetfem::{
    BoxSplit, ElementType, Material, MixedStaticSolver, Tet4, TetMesh, solve_static,
    solve_static_mixed, solve_static_mixed_nonlinear,
};
use tetfem_fixtures::cook::CookMembrane;
use tetfem_fixtures::tube::LameTube;

// The locking comparison's mesh (on which the plain linear tet gives 0.478 of Lamé's bore
// displacement at ν = 0.4999) and the tube's material.
use super::mixed_tube::{CELLS, linear_tet_pressure_spread, material, pressure_errors};

/// u_r(a) of the mixed 4-node solve over Lamé's, and the solution's nodal pressure.
fn mixed_ratio(tube: &LameTube, mesh: &TetMesh, poisson_ratio: f64) -> (f64, Vec<f64>) {
    let solution = solve_static_mixed(
        mesh,
        &material(poisson_ratio),
        &tube.constraints(mesh).unwrap(),
        &tube.loads(mesh).unwrap(),
    )
    .unwrap();
    let computed = tube.inner_radial_displacement(mesh, &solution.displacement);
    (
        computed / tube.radial_displacement(poisson_ratio, tube.inner),
        solution.pressure,
    )
}

/// u_r(a) of the plain linear-tet solve over Lamé's.
fn linear_ratio(tube: &LameTube, mesh: &TetMesh, poisson_ratio: f64) -> f64 {
    let solution = solve_static(
        mesh,
        &material(poisson_ratio),
        &tube.constraints(mesh).unwrap(),
        &tube.loads(mesh).unwrap(),
    )
    .unwrap();
    tube.inner_radial_displacement(mesh, &solution.displacement)
        / tube.radial_displacement(poisson_ratio, tube.inner)
}

#[test]
fn stabilized_p1_reproduces_an_affine_field_with_its_constant_pressure() {
    // P1–P1 contains u = G·x with p = −κ tr G, and the stabilization (p − Πp) vanishes on it.
    let mesh = TetMesh::box_grid(
        Vector3::zeros(),
        Vector3::new(1.0, 0.8, 0.6),
        [4, 3, 3],
        BoxSplit::Five,
    )
    .unwrap();
    super::mixed_tube::assert_reproduces_an_affine_field(&mesh);
}

#[test]
fn stabilized_p1_tube_does_not_lock_where_the_linear_tet_does() {
    let tube = LameTube::default();
    let mesh = tube.mesh(CELLS, BoxSplit::Lecture6).unwrap();
    let mut ratios = Vec::new();
    for nu in [0.3, 0.49, 0.499, 0.4999] {
        let (mixed, _) = mixed_ratio(&tube, &mesh, nu);
        let linear = linear_ratio(&tube, &mesh, nu);
        println!("ν = {nu}: u_r(a)/exact P1–P1 mixed {mixed:.5}, P1 {linear:.5}");
        ratios.push((nu, mixed, linear));
    }
    let (_, at_049, _) = ratios[1];
    let (_, at_04999, plain_04999) = ratios[3];
    // The precondition: the plain linear tet is ≥ 30 % off on this mesh at 0.4999
    // (measured 0.478).
    assert!(plain_04999 < 0.7, "P1/exact = {plain_04999}");
    // ν-independence: the mixed ratio at 0.4999 within 1 % of that at 0.49 on the same mesh.
    assert!(
        (at_04999 / at_049 - 1.0).abs() < 0.01,
        "mixed {at_049} at 0.49, {at_04999} at 0.4999"
    );
    for &(nu, mixed, _) in &ratios {
        // The target, within 1 % of Lamé at every ν (measured 0.9936–0.9944: the
        // linear displacement's O(h²) error, which refinement removes, see below).
        assert!(
            (mixed - 1.0).abs() < 0.01,
            "ν = {nu}: mixed/exact = {mixed}"
        );
    }
}

#[test]
fn stabilized_p1_tube_converges_under_refinement() {
    let tube = LameTube::default();
    let nu = 0.4999;
    let exact = tube.mean_pressure(nu);
    let mut errors = Vec::new();
    for refinement in [1, 2, 4] {
        // Refined in the plane only: the solution does not vary along z.
        let cells = [3 * refinement, 12 * refinement, 2];
        let mesh = tube.mesh(cells, BoxSplit::Lecture6).unwrap();
        let (ratio, pressure) = mixed_ratio(&tube, &mesh, nu);
        let (l2, worst) = pressure_errors(&mesh, &pressure, exact);
        println!(
            "cells {cells:?}: u_r(a)/exact {ratio:.5}, pressure L2 error {l2:.3e}, worst tet \
             mean {worst:.3e}"
        );
        errors.push(((ratio - 1.0).abs(), l2, worst));
    }
    for pair in errors.windows(2) {
        let displacement_rate = (pair[0].0 / pair[1].0).log2();
        let pressure_rate = (pair[0].1 / pair[1].1).log2();
        println!("rates: displacement {displacement_rate:.2}, pressure L2 {pressure_rate:.2}");
        // The linear displacement's nodal error falls as h² (measured 1.98 and 1.98); 1.8
        // allows a pre-asymptotic step, and 1 (a locked element's stagnation is 0) would not
        // separate it from a first-order element.
        assert!(displacement_rate > 1.8, "{errors:?}");
        // The stabilized linear pressure converges in L2 at least as h (Dohrmann–Bochev's
        // estimate), measured h^1.43 then h^1.47; 1.2 is above first order so that a
        // stagnating (checkerboarding) pressure cannot pass.
        assert!(pressure_rate > 1.2, "{errors:?}");
    }
    // No checkerboard: the worst tet's mean pressure keeps falling under refinement (measured
    // 0.66, 0.40, 0.22 of |p|: the bore's boundary layer, halving with h) ...
    assert!(
        errors[2].2 < errors[1].2 && errors[1].2 < errors[0].2,
        "{errors:?}"
    );
    // ... and on the comparison mesh it is a small fraction of the plain linear tet's
    // −κ tr ε scatter (measured 54× |p| there, the mixed 0.40×): a factor 10 is a clear
    // separation, not a fine margin.
    let spread = linear_tet_pressure_spread(&tube, nu, exact);
    assert!(
        spread > 10.0 * errors[1].2,
        "P1 {spread} vs mixed {errors:?}"
    );
}

#[test]
fn stabilized_p1_reactions_balance_the_internal_pressure() {
    // Σ reactions + Σ loads = 0 along each axis: static equilibrium of the whole quarter tube,
    // the reactions (K_dev·u − Bᵀp on the supports) against the loads summed independently.
    let tube = LameTube::default();
    let mesh = tube.mesh([3, 12, 2], BoxSplit::Lecture6).unwrap();
    let loads = tube.loads(&mesh).unwrap();
    let mut solver =
        MixedStaticSolver::new(&mesh, &material(0.499), &tube.constraints(&mesh).unwrap()).unwrap();
    let solution = solver.solve(&loads).unwrap();
    // One pressure unknown per node of the 4-node mesh.
    assert_eq!(solver.pressure_nodes().count(), mesh.node_count());
    let applied = loads.resultant();
    for axis in 0..3 {
        let reaction: f64 = solution.reactions.iter().skip(axis).step_by(3).sum();
        // Round-off of sums of ~1e5 N terms.
        assert!(
            (reaction + applied[axis]).abs() < 1e-6 * applied.norm(),
            "axis {axis}: reactions {reaction}, loads {}",
            applied[axis]
        );
    }
}

fn newton(load_steps: usize) -> NewtonOptions {
    NewtonOptions {
        load_steps,
        ..NewtonOptions::default()
    }
}

#[test]
fn stabilized_p1_neo_hookean_homogeneous_deformation_has_the_closed_form_pressure() {
    // Every boundary node moved by u = (F − I)·X: the exact solution is that affine field with
    // the constant pressure p = −tr σ/3 = −κ(J − 1) of the model's closed-form Cauchy stress
    // σ = μ·J^(−5/3)·dev(F·Fᵀ) + κ(J − 1)·I, which P1–P1 contains (the stabilization vanishes
    // for a constant pressure).
    let mesh = TetMesh::box_grid(
        Vector3::zeros(),
        Vector3::new(1.0, 0.8, 0.6),
        [4, 3, 3],
        BoxSplit::Five,
    )
    .unwrap();
    super::mixed_neo_hookean::assert_homogeneous_deformation_pressure(&mesh);
}

#[test]
fn stabilized_p1_neo_hookean_tangent_is_the_derivative_of_the_residual() {
    let mesh = TetMesh::box_grid(
        Vector3::zeros(),
        Vector3::new(1.0, 1.0, 1.0),
        [1, 1, 1],
        BoxSplit::Five,
    )
    .unwrap();
    let rest = Tet4::rest(&mesh, 0);
    let (mu, inverse_bulk) = (1.0, 1.0 / 50.0);
    // A deformation with 10–20 % strains and a pressure of the order of μ.
    let u: [f64; 12] = std::array::from_fn(|k| 0.08 * ((k as f64 * 1.7).sin()));
    let p = [0.3, -0.5, 0.8, 0.1];
    let state = stabilized_neo_hookean(&rest, &u, &p, mu, inverse_bulk).unwrap();
    let h = 1e-6;
    let scale = state.stiffness.amax();
    let mut worst: f64 = 0.0;
    for j in 0..12 {
        let (mut plus, mut minus) = (u, u);
        plus[j] += h;
        minus[j] -= h;
        let a = stabilized_neo_hookean(&rest, &plus, &p, mu, inverse_bulk).unwrap();
        let b = stabilized_neo_hookean(&rest, &minus, &p, mu, inverse_bulk).unwrap();
        for i in 0..12 {
            let fd = (a.force[i] - b.force[i]) / (2.0 * h);
            worst = worst.max((fd - state.stiffness[(i, j)]).abs() / scale);
        }
        for k in 0..4 {
            // ∂R_p,k/∂u_j = −G_kj.
            let fd = (a.pressure_residual[k] - b.pressure_residual[k]) / (2.0 * h);
            worst = worst.max((fd + state.coupling[k][j / 3][j % 3]).abs() / scale);
        }
    }
    for k in 0..4 {
        let (mut plus, mut minus) = (p, p);
        plus[k] += h;
        minus[k] -= h;
        let a = stabilized_neo_hookean(&rest, &u, &plus, mu, inverse_bulk).unwrap();
        let b = stabilized_neo_hookean(&rest, &u, &minus, mu, inverse_bulk).unwrap();
        for i in 0..12 {
            // ∂R_u,i/∂p_k = −G_ki (the symmetric partner of the block above).
            let fd = (a.force[i] - b.force[i]) / (2.0 * h);
            worst = worst.max((fd + state.coupling[k][i / 3][i % 3]).abs() / scale);
        }
        for l in 0..4 {
            // ∂R_p,l/∂p_k = −C_lk: written out here from the module's formula, V(1 + δ)/20
            // (1/κ + 1/μ) − V/(16μ), not through the library's function.
            let v = Tet4::volume(&rest);
            let mass = v * if l == k { 2.0 } else { 1.0 } / 20.0;
            let exact = -(mass * (inverse_bulk + 1.0 / mu) - v / (16.0 * mu));
            let fd = (a.pressure_residual[l] - b.pressure_residual[l]) / (2.0 * h);
            worst = worst.max((fd - exact).abs() / scale);
        }
    }
    let asymmetry = (state.stiffness - state.stiffness.transpose()).amax() / scale;
    println!("tangent vs central differences: {worst:.2e}, asymmetry {asymmetry:.2e}");
    // Central differences at h = 1e-6: truncation h²·|∂³R| ~ 1e-12 and round-off
    // ε·|R|/h ~ 1e-10 of the tangent's size; 1e-7 catches any wrong term (a missing one is of
    // the order of the tangent itself).
    assert!(worst < 1e-7, "tangent vs FD: {worst}");
    // The tangent of an energy is symmetric: round-off only.
    assert!(asymmetry < 1e-12, "asymmetry {asymmetry}");
}

#[test]
fn stabilized_p1_cooks_membrane_is_within_one_percent_of_scikit_fem() {
    use crate::mixed_neo_hookean::{SCIKIT_FEM_NEO_HOOKEAN_LIMIT, SCIKIT_FEM_NEO_HOOKEAN_TIP};
    let mut tips = Vec::new();
    let mut unknowns = 0;
    for n in [12, 24, 48] {
        // n × n cells in-plane and one layer one cell of the x-width thick: the load case is
        // plane strain (u independent of z), so every unknown goes in-plane. The mirrored
        // 6-tet split, symmetric cell to cell, bends without the lecture split's one-diagonal
        // bias: at 32 × 32 × 2 cells (13 068 unknowns) it gave 6.85129 mm against the lecture
        // split's 6.76778, and at 48 × 48 × 1 (19 208) 6.88530 against 6.83797.
        let cook = CookMembrane {
            thickness: 48.0 / n as f64,
            ..CookMembrane::default()
        };
        let mesh = cook.mesh(n, 1, BoxSplit::Mirrored6).unwrap();
        let report = solve_static_mixed_nonlinear(
            &mesh,
            &cook.material().unwrap(),
            &cook.constraints(&mesh).unwrap(),
            &cook.loads(&mesh).unwrap(),
            newton(8),
        )
        .unwrap();
        let tip = cook.tip_displacement(&mesh, &report.displacement);
        unknowns = mesh.dof_count() + mesh.node_count();
        println!(
            "P1–P1 n = {n}: {unknowns} unknowns, tip u_y = {tip:.5} mm ({:+.3} % from \
             scikit-fem's finest, {:+.3} % from its limit), {} Newton iterations",
            100.0 * (tip / SCIKIT_FEM_NEO_HOOKEAN_TIP - 1.0),
            100.0 * (tip / SCIKIT_FEM_NEO_HOOKEAN_LIMIT - 1.0),
            report.iterations
        );
        tips.push(tip);
    }
    // Converging from below (the linear tet's residual stiffness).
    assert!(tips[0] < tips[1] && tips[1] < tips[2], "{tips:?}");
    // The target: within 1 % of an independent converged reference at ≤ 20k DOFs,
    // against both the peer's finest value and its extrapolated limit.
    assert!(unknowns <= 20_000, "{unknowns} unknowns");
    for reference in [SCIKIT_FEM_NEO_HOOKEAN_TIP, SCIKIT_FEM_NEO_HOOKEAN_LIMIT] {
        assert!(
            (tips[2] / reference - 1.0).abs() < 0.01,
            "{} vs {reference}",
            tips[2]
        );
    }
}

#[test]
fn incompressible_material_names_the_four_node_mixed_element() {
    // ν = 0.5 points to the mixed formulation on either mesh order, the 4-node one included.
    let message = Material::new(1e6, 0.5, 1000.0).unwrap_err().to_string();
    for word in ["formulation = \"mixed\"", "4-node", "P1–P1", "Taylor–Hood"] {
        assert!(message.contains(word), "no '{word}' in {message}");
    }
}
