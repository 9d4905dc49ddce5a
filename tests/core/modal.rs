//! Modal analysis and the explicit critical step against a dense symmetric eigen-solve of the
//! same (K, M) on small meshes, and convergence on slender steel beams.

use nalgebra::{DMatrix, DVector, SymmetricEigen, Vector3};
use tetfem::analysis::dynamics::{LinearSystem, Mass, MassKind, Rayleigh, critical_time_step};
use tetfem::analysis::modal::{RESIDUAL_TOLERANCE, lowest_modes};
use tetfem::linalg::sparse::CscMatrix;
use tetfem::{BoxSplit, Material};
use tetfem_fixtures::cantilever::Cantilever;

/// A steel box beam L × W × H (E = 2e11 Pa, ν = 0.3, ρ = 7800 kg/m³) clamped at x = 0.
fn steel_beam(size: [f64; 3], cells: [usize; 3], mass: MassKind) -> LinearSystem {
    let problem = Cantilever {
        length: size[0],
        width: size[1],
        height: size[2],
        cells,
        split: BoxSplit::Lecture6,
        material: Material::new(2e11, 0.3, 7800.0).unwrap(),
        end_load: 1.0,
        gravity: 0.0,
    };
    let mesh = problem.mesh().unwrap();
    let constraints = problem.constraints(&mesh).unwrap();
    let loads = problem.loads(&mesh).unwrap();
    LinearSystem::new(
        &mesh,
        &problem.material,
        &constraints,
        &loads,
        Vector3::zeros(),
        mass,
        Rayleigh::default(),
    )
    .unwrap()
}

/// Small meshes of several aspect ratios (≤ 540 free DOFs): a slender beam (L/H = 20) with two
/// and with one cell through the section, a stubby one (L/H = 4), a cube and a plate.
const SMALL: [([f64; 3], [usize; 3]); 5] = [
    ([10.0, 0.5, 0.5], [20, 2, 2]),
    ([10.0, 0.5, 0.5], [40, 1, 1]),
    ([4.0, 1.0, 1.0], [12, 2, 2]),
    ([1.0, 1.0, 1.0], [3, 3, 3]),
    ([1.0, 1.0, 0.1], [4, 4, 1]),
];

fn dense(a: &CscMatrix) -> DMatrix<f64> {
    let n = a.dim();
    let mut d = DMatrix::zeros(n, n);
    for j in 0..n {
        for e in a.col_ptr()[j]..a.col_ptr()[j + 1] {
            d[(a.row_idx()[e], j)] = a.values()[e];
        }
    }
    d
}

fn dense_mass(system: &LinearSystem) -> DMatrix<f64> {
    match system.mass() {
        Mass::Lumped(m) => DMatrix::from_diagonal(&DVector::from_column_slice(m)),
        Mass::Consistent(m) => dense(m),
    }
}

/// Eigenvalues of the symmetric (L⁻¹·A·L⁻ᵀ), B = L·Lᵀ, ascending.
fn reduced_eigenvalues(a: &DMatrix<f64>, b: &DMatrix<f64>) -> Vec<f64> {
    let l_inv = b.clone().cholesky().unwrap().l().try_inverse().unwrap();
    let c = &l_inv * a * l_inv.transpose();
    let c = (&c + c.transpose()) * 0.5;
    let mut values: Vec<f64> = SymmetricEigen::new(c).eigenvalues.iter().copied().collect();
    values.sort_by(f64::total_cmp);
    values
}

/// ω² of (K, M), ascending, for the low end: the eigenvalues μ = 1/ω² of L_K⁻¹·M·L_K⁻ᵀ
/// (K = L_K·L_Kᵀ). A dense symmetric solve is accurate to ε·(its largest eigenvalue), so this
/// form resolves the lowest ω² to ~ε relative; the form L_M⁻¹·K·L_M⁻ᵀ would carry an error of
/// ε·ω_max² into them, measured 9.9e-10 relative on the 20×2×2 steel beam (ω_max²/ω₁² = 3.9e6).
fn dense_low_eigenvalues(system: &LinearSystem) -> Vec<f64> {
    let mut values: Vec<f64> = reduced_eigenvalues(&dense_mass(system), &dense(system.stiffness()))
        .iter()
        .map(|mu| 1.0 / mu)
        .collect();
    values.sort_by(f64::total_cmp);
    values
}

/// ω_max² of (K, M), from L_M⁻¹·K·L_M⁻ᵀ (accurate to ~ε relative at the top).
fn dense_top_eigenvalue(system: &LinearSystem) -> f64 {
    *reduced_eigenvalues(&dense(system.stiffness()), &dense_mass(system))
        .last()
        .unwrap()
}

#[test]
fn lowest_modes_converge_on_slender_steel_beams() {
    // Issue 15 item 6: before, both failed with "did not converge in 500 subspace iterations".
    for (cells, mass) in [
        ([40, 2, 2], MassKind::Consistent),
        ([80, 4, 4], MassKind::Lumped),
    ] {
        let system = steel_beam([10.0, 0.5, 0.5], cells, mass);
        let modes = lowest_modes(&system, 6).unwrap();
        println!(
            "{cells:?} {mass:?}: {} iterations, f = {:?}, residuals {:?}",
            modes.iterations,
            modes.frequencies(),
            modes.residuals
        );
        // The convergence rate is (ω₆/ω₁₅)² per iteration; measured 8–9 iterations.
        assert!(modes.iterations <= 50, "{} iterations", modes.iterations);
        let k = system.stiffness();
        for (i, (phi, omega)) in modes.shapes.iter().zip(&modes.omega).enumerate() {
            assert!(modes.residuals[i] <= RESIDUAL_TOLERANCE);
            // The reported residual recomputed here from its definition,
            // ‖K·φ − ω²M·φ‖ / ‖(|K| + ω²|M|)·|φ|‖ (the mass entries are ≥ 0, so |M| = M);
            // the same products, but with ω² rounded from ω: that moves the residual by at most
            // 2ε·ω²‖Mφ‖ ≤ 2ε ≈ 4.4e-16 of the scale, hence the absolute 1e-15.
            let kphi = k.mul(phi).unwrap();
            let mut mphi = vec![0.0; phi.len()];
            system.mass().mul_vec(phi, &mut mphi).unwrap();
            let magnitude: Vec<f64> = phi.iter().map(|v| v.abs()).collect();
            let abs_k = CscMatrix::from_values(
                k.pattern().clone(),
                k.values().iter().map(|v| v.abs()).collect(),
            )
            .unwrap();
            let abs_k_phi = abs_k.mul(&magnitude).unwrap();
            let mut m_abs_phi = vec![0.0; phi.len()];
            system.mass().mul_vec(&magnitude, &mut m_abs_phi).unwrap();
            let lambda = omega * omega;
            let norm = |v: &mut dyn Iterator<Item = f64>| v.map(|x| x * x).sum::<f64>().sqrt();
            let residual = norm(&mut kphi.iter().zip(&mphi).map(|(a, b)| a - lambda * b));
            let scale = norm(
                &mut abs_k_phi
                    .iter()
                    .zip(&m_abs_phi)
                    .map(|(a, b)| a + lambda * b),
            );
            let recomputed = residual / scale;
            assert!(
                (recomputed - modes.residuals[i]).abs() <= 1e-3 * modes.residuals[i] + 1e-15,
                "mode {i}: residual {recomputed:e} vs reported {:e}",
                modes.residuals[i]
            );
            // M-orthonormal shapes: products of O(1) values, round-off only.
            for (j, psi) in modes.shapes.iter().enumerate() {
                let product: f64 = psi.iter().zip(&mphi).map(|(a, b)| a * b).sum();
                let expected = if i == j { 1.0 } else { 0.0 };
                assert!((product - expected).abs() < 1e-10, "φ{j}ᵀMφ{i} = {product}");
            }
        }
    }
}

#[test]
fn frequencies_match_a_dense_eigen_solve() {
    for (size, cells) in SMALL {
        for mass in [MassKind::Lumped, MassKind::Consistent] {
            let system = steel_beam(size, cells, mass);
            let exact = dense_low_eigenvalues(&system);
            for count in 1..=12 {
                let modes = lowest_modes(&system, count).unwrap();
                assert_eq!(modes.omega.len(), count);
                for (i, omega) in modes.omega.iter().enumerate() {
                    let reference = exact[i].sqrt();
                    // Issue 15 item 6 asks for 1e-9; measured ≤ 5e-11 (worst: the slender beams).
                    let error = (omega - reference).abs() / reference;
                    assert!(
                        error < 1e-9,
                        "{size:?} {cells:?} {mass:?}, {count} modes: ω{i} = {omega} vs dense \
                         {reference} (relative {error:e})"
                    );
                }
            }
        }
    }
}

#[test]
fn critical_step_is_safe_and_within_1e_3_of_the_dense_limit() {
    for (size, cells) in SMALL {
        let system = steel_beam(size, cells, MassKind::Lumped);
        let omega_max = dense_top_eigenvalue(&system).sqrt();
        let limit = 2.0 / omega_max;
        let step = critical_time_step(&system).unwrap();
        let distance = (step.dt - limit) / limit;
        println!(
            "{size:?} {cells:?}: dt {:.6e}, 2/ω_max {limit:.6e}, relative {distance:+.2e}, {} iterations",
            step.dt, step.iterations
        );
        // Never above the stability limit. The dense ω_max is accurate to ~n·ε ≈ 1e-13
        // relative; before, dt was 7e-7 to 2.5e-6 above it on these meshes.
        assert!(
            distance <= 1e-12,
            "dt {:e} above 2/ω_max {limit:e}",
            step.dt
        );
        assert!(
            distance >= -1e-3,
            "dt {:e} more than 1e-3 below {limit:e}",
            step.dt
        );
        // The reported bracket holds the true ω_max (same round-off allowance).
        assert!(step.omega_max_lower <= omega_max * (1.0 + 1e-12));
        assert!(omega_max <= step.omega_max * (1.0 + 1e-12));
        assert!((step.dt * step.omega_max - 2.0).abs() < 1e-15);
    }
}
