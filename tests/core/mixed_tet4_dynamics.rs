//! The stabilized P1–P1 element (4-node tets) in implicit dynamics (`MixedTransient<Tet4>`) and
//! modal analysis (`lowest_mixed_modes` on a 4-node mesh), on the rubber cantilever of
//! `mixed_dynamics.rs` (1 × 0.2 × 0.2 m, clamped at x = 0, ν = 0.4999): the first frequency
//! converging under refinement towards Taylor–Hood's on a fine mesh (an independent element)
//! where the plain linear tet locks, the modes M-orthonormal with their Rayleigh quotients
//! through the condensed product, Newmark's exact energy conservation and its period against
//! the first modal period, and backward Euler settling on the static solution of
//! `MixedStaticSolver<Tet4>`.

use nalgebra::Vector3;
use tetfem::analysis::dynamics::{LinearSystem, MassKind, Method, Rayleigh};
use tetfem::analysis::mixed_dynamics::MixedTransient;
use tetfem::analysis::mixed_modal::{MIXED_RESIDUAL_TOLERANCE, MixedModes, lowest_mixed_modes};
use tetfem::analysis::mixed_operator::MixedOperator;
use tetfem::analysis::modal::lowest_modes;
use tetfem::{Error, Loads, Material, MixedStaticSolver, Tet4, TetMesh};

use super::mixed_dynamics::{beam, clamped, gravity, period, rubber, tip};

/// The three meshes of the refinement study, each halving the cell size.
const MESHES: [[usize; 3]; 3] = [[6, 2, 2], [12, 4, 4], [24, 8, 8]];

/// The P1–P1 modes of the 4-node beam on `cells`, checked converged.
fn p1p1_modes(cells: [usize; 3], material: &Material, count: usize) -> (TetMesh, MixedModes) {
    let (mesh, _) = beam(cells);
    let modes = lowest_mixed_modes(&mesh, material, &clamped(&mesh), count).unwrap();
    assert!(
        modes
            .modes
            .residuals
            .iter()
            .all(|r| *r <= MIXED_RESIDUAL_TOLERANCE)
    );
    (mesh, modes)
}

/// ω₁ of the plain linear tet (displacement, consistent mass) on `cells`.
fn p1_omega(cells: [usize; 3], material: &Material) -> f64 {
    let (mesh, _) = beam(cells);
    let system = LinearSystem::new(
        &mesh,
        material,
        &clamped(&mesh),
        &Loads::new(&mesh),
        Vector3::zeros(),
        MassKind::Consistent,
        Rayleigh::default(),
    )
    .unwrap();
    lowest_modes(&system, 1).unwrap().omega[0]
}

/// `values` as `[a, b, …]` in scientific notation.
fn scientific(values: &[f64]) -> String {
    let items: Vec<String> = values.iter().map(|v| format!("{v:.3e}")).collect();
    format!("[{}]", items.join(", "))
}

#[test]
fn p1p1_first_frequency_converges_at_second_order_to_taylor_hood_where_p1_locks() {
    let material = rubber(0.4999);
    // The reference: Taylor–Hood P2–P1 on the finest mesh, another element (quadratic
    // displacement, no stabilization) whose own error is far below P1–P1's.
    let (_, fine) = beam(MESHES[2]);
    let reference = lowest_mixed_modes(&fine, &material, &clamped(&fine), 1)
        .unwrap()
        .modes
        .omega[0];
    let errors: Vec<f64> = MESHES
        .iter()
        .map(|&cells| {
            let omega = p1p1_modes(cells, &material, 1).1.modes.omega[0];
            println!("P1–P1 {cells:?}: ω₁ {omega:.6} rad/s");
            omega / reference - 1.0
        })
        .collect();
    let rates: Vec<f64> = errors.windows(2).map(|e| (e[0] / e[1]).log2()).collect();
    let p1 = p1_omega(MESHES[2], &material);
    // Taylor–Hood on the 10-node mesh with as many displacement DOFs as P1–P1's finest.
    let (_, equal) = beam(MESHES[1]);
    let taylor_hood = lowest_mixed_modes(&equal, &material, &clamped(&equal), 1)
        .unwrap()
        .modes
        .omega[0];
    println!(
        "ν = 0.4999: Taylor–Hood {:?} ω₁ {reference:.6} rad/s; P1–P1 errors {}, \
         rates {rates:.3?}; on {:?} plain P1 ω₁ {p1:.6} rad/s, error {:.4}; at equal \
         displacement DOFs Taylor–Hood {:?} error {:.3e}",
        MESHES[2],
        scientific(&errors),
        MESHES[2],
        p1 / reference - 1.0,
        MESHES[1],
        taylor_hood / reference - 1.0
    );
    // Linear displacements: the eigenvalue error is O(h²), so ω₁'s too (ω = √λ), and halving
    // h divides it by 4 in the limit. Measured 1.55 then 1.71 (a beam two cells thick is far
    // from the limit); 1.6 on the finer pair says the rate is second order, not first. The
    // reference's own error (Taylor–Hood changes ω₁ by 0.3 % from the mesh before, at fourth
    // order) is a few 1e-4, below the finest P1–P1 error by 100×.
    assert!(errors.iter().all(|e| e.is_finite() && *e > 0.0));
    assert!(errors[0] > errors[1] && errors[1] > errors[2]);
    assert!(rates[1] > 1.6, "rates {rates:?}");
    // Volumetric locking: the plain linear tet on the same mesh is many times further off
    // (measured 1.01, the frequency doubled, against 0.037).
    assert!(p1 / reference - 1.0 > 10.0 * errors[2]);
    // At equal displacement DOFs the quadratic element is the more accurate (measured).
    assert!((taylor_hood / reference - 1.0).abs() < errors[2]);
}

#[test]
fn p1p1_modes_are_mass_orthonormal_with_their_rayleigh_quotients() {
    let material = rubber(0.4999);
    let (mesh, modes) = p1p1_modes(MESHES[1], &material, 4);
    let constraints = clamped(&mesh);
    let mut operator = MixedOperator::<Tet4>::new(&mesh, &material, &constraints, true).unwrap();
    let shapes = &modes.modes.shapes;
    let mut worst_orthogonality: f64 = 0.0;
    let mut worst_quotient: f64 = 0.0;
    for (i, phi) in shapes.iter().enumerate() {
        let m_phi = operator.mass().mul(phi).unwrap();
        for (j, psi) in shapes.iter().enumerate() {
            let product: f64 = psi.iter().zip(&m_phi).map(|(a, b)| a * b).sum();
            let expected = if i == j { 1.0 } else { 0.0 };
            worst_orthogonality = worst_orthogonality.max((product - expected).abs());
        }
        // φᵀK_eff·φ through the product K_dev·φ − Bᵀp (p the implied pressure): another path
        // than the LDLᵀ solves the iteration used.
        let (k_phi, _) = operator.condensed_product(phi).unwrap();
        let quotient: f64 = phi.iter().zip(&k_phi).map(|(a, b)| a * b).sum();
        let omega2 = modes.modes.omega[i] * modes.modes.omega[i];
        worst_quotient = worst_quotient.max((quotient / omega2 - 1.0).abs());
    }
    println!(
        "P1–P1 {:?}: ω {:.5?} rad/s, residuals {}; worst |φᵢᵀMφⱼ − δᵢⱼ| \
         {worst_orthogonality:.2e}, worst |φᵀK_eff·φ/ω² − 1| {worst_quotient:.2e}",
        MESHES[1],
        modes.modes.omega,
        scientific(&modes.modes.residuals)
    );
    // The Rayleigh–Ritz step makes the shapes M-orthonormal to round-off of n-term sums.
    assert!(worst_orthogonality < 1e-10);
    // A converged mode's quotient is ω² to the square of its residual; what is left is the
    // round-off of K_eff·φ through C⁻¹ (κ/μ = 5000 amplifies ε).
    assert!(worst_quotient < 1e-9);
    // Every mode carries its pressure, one value per node of the 4-node mesh.
    assert!(modes.pressure.iter().all(|p| p.len() == mesh.node_count()));
}

/// The P1–P1 body of `cells` released from its static sag under gravity (free vibration).
fn released(
    cells: [usize; 3],
    material: &Material,
    method: Method,
    dt: f64,
) -> MixedTransient<Tet4> {
    let (mesh, _) = beam(cells);
    let constraints = clamped(&mesh);
    let sag = MixedStaticSolver::<Tet4>::new(&mesh, material, &constraints)
        .unwrap()
        .solve(&gravity(&mesh, material))
        .unwrap();
    let mut run = MixedTransient::new(
        &mesh,
        material,
        &constraints,
        &Loads::new(&mesh),
        (method, dt, Rayleigh::default()),
    )
    .unwrap();
    let u0 = run.operator().dofs().restrict(&sag.displacement).unwrap();
    let n = u0.len();
    run.start(u0, vec![0.0; n]).unwrap();
    run
}

#[test]
fn p1p1_newmark_conserves_energy_and_swings_with_its_modal_period() {
    let material = rubber(0.4999);
    let mut run = released(MESHES[1], &material, Method::Newmark, 0.02);
    let start = run.energy().unwrap().total();
    let mut worst: f64 = 0.0;
    for _ in 0..100 {
        run.step().unwrap();
        worst = worst.max((run.energy().unwrap().total() - start).abs() / start);
    }
    let end = run.energy().unwrap();
    println!(
        "P1–P1 Newmark ν = 0.4999: E0 = {start:.6e} J, worst relative drift {worst:.2e} over \
         100 steps, kinetic share at the end {:.3}",
        end.kinetic / end.total()
    );
    // Average acceleration on the linear system conserves ½vᵀMv + ½uᵀK_eff·u exactly: only the
    // solves' round-off (residual ~1e-14, amplified by κ/μ = 5000) accumulates.
    assert!(worst < 1e-9, "drift {worst:e}");
    assert!(end.kinetic > 1e-3 * end.total());

    // Released from its first mode (1 cm at the tip): one mode under average acceleration
    // is a rotation by 2·atan(ω·dt/2) per step, so the period is π·dt/atan(ω₁·dt/2) exactly.
    let (mesh, modes) = p1p1_modes(MESHES[1], &material, 1);
    let dt = 0.01;
    let mut run = MixedTransient::new(
        &mesh,
        &material,
        &clamped(&mesh),
        &Loads::new(&mesh),
        (Method::Newmark, dt, Rayleigh::default()),
    )
    .unwrap();
    let shape = &modes.modes.shapes[0];
    let scale = 0.01 / tip(&mesh, &run.operator().dofs().expand(shape).unwrap());
    let u0: Vec<f64> = shape.iter().map(|v| v * scale).collect();
    let n = u0.len();
    run.start(u0, vec![0.0; n]).unwrap();
    let mut history = vec![tip(&mesh, &run.displacement().unwrap())];
    for _ in 0..400 {
        run.step().unwrap();
        history.push(tip(&mesh, &run.displacement().unwrap()));
    }
    let omega = modes.modes.omega[0];
    let t_newmark = std::f64::consts::PI * dt / (omega * dt / 2.0).atan();
    let t_run = period(&history, dt);
    println!(
        "P1–P1 swing: run period {t_run:.6} s, Newmark's exact {t_newmark:.6} s, modal {:.6} s",
        2.0 * std::f64::consts::PI / omega
    );
    // Linearly interpolated zero crossings of a cosine sampled ~100 times a period: their
    // error is below 1e-4 of the period.
    assert!((t_run / t_newmark - 1.0).abs() < 1e-4);
}

#[test]
fn p1p1_backward_euler_settles_on_the_static_solution() {
    let material = rubber(0.4999);
    let (mesh, _) = beam(MESHES[1]);
    let constraints = clamped(&mesh);
    let loads = gravity(&mesh, &material);
    let statics = MixedStaticSolver::<Tet4>::new(&mesh, &material, &constraints)
        .unwrap()
        .solve(&loads)
        .unwrap();
    // dt = 0.5 s against ω₁ ≈ 6 rad/s: backward Euler multiplies each mode's amplitude by
    // 1/√(1 + (ω·dt)²) ≤ 0.32 per step, so 40 steps leave ≤ 1e-19 of the start's deviation
    // (the whole sag).
    let dt = 0.5;
    let mut run = MixedTransient::new(
        &mesh,
        &material,
        &constraints,
        &loads,
        (Method::BackwardEuler, dt, Rayleigh::default()),
    )
    .unwrap();
    for _ in 0..40 {
        run.step().unwrap();
    }
    let u = run.displacement().unwrap();
    let norm = |v: &mut dyn Iterator<Item = f64>| v.map(|x| x * x).sum::<f64>().sqrt();
    let u_error = norm(&mut u.iter().zip(&statics.displacement).map(|(a, b)| a - b))
        / norm(&mut statics.displacement.iter().copied());
    let pressure = run.pressure();
    let p_error = norm(&mut pressure.iter().zip(&statics.pressure).map(|(a, b)| a - b))
        / norm(&mut statics.pressure.iter().copied());
    println!(
        "P1–P1 backward Euler after 40 steps of {dt} s: tip {:.6e} m (static {:.6e} m), \
         relative differences u {u_error:.2e}, p {p_error:.2e}",
        tip(&mesh, &u),
        tip(&mesh, &statics.displacement)
    );
    // The fixed point of a backward Euler step is K_eff·u = f, the static equation: what is
    // left is the decayed start (≤ 1e-19) and both solves' residuals (≤ 1e-8 each, their
    // limit), amplified by the condition of the saddle point on this mesh.
    assert!(u_error < 1e-7 && p_error < 1e-7, "{u_error:e}, {p_error:e}");
}

#[test]
fn the_p1p1_transient_names_its_element_when_refusing_the_explicit_method() {
    let (mesh, _) = beam([2, 1, 1]);
    let material = rubber(0.49);
    let explicit = MixedTransient::new(
        &mesh,
        &material,
        &clamped(&mesh),
        &Loads::new(&mesh),
        (Method::Explicit, 0.01, Rayleigh::default()),
    );
    assert!(
        matches!(&explicit, Err(Error::InvalidParameter { name, requirement, .. })
            if name.contains("method") && requirement.contains("stabilized P1–P1")),
        "{explicit:?}"
    );
}
