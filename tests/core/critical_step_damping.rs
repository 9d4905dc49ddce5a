//! The explicit critical step with Rayleigh damping (issue 37, item 2: "the explicit critical
//! step must include stiffness damping β"). The explicit method is symplectic Euler,
//! v⁺ = v + dt·M⁻¹(f − K·u − C·v), u⁺ = u + dt·v⁺ with C = α·M + β·K applied to the old
//! velocity; per mode (ω, c = α + β·ω²) the step matrix has trace 2 − dt²ω² − c·dt and
//! determinant 1 − c·dt, and Jury's test gives stability exactly when dt²ω² + 2c·dt < 4, i.e.
//! dt < (2/ω)(√(1 + ξ²) − ξ), ξ = α/(2ω) + β·ω/2: the central-difference bound with C = βK.
//! The tests hold the library's step (`TimeStep::CriticalMultiple`, the one policy every front
//! end uses) to that bound: runs at 0.98× stay bounded and runs at 1.05× diverge, with β = 1e-4
//! and with β = 0, and on one tetrahedron whose ω_max is known in closed form the step equals
//! the formula.

use nalgebra::Vector3;
use tetfem::analysis::Definition;
use tetfem::analysis::dynamics::{Method, Rayleigh};
use tetfem::analysis::transient::{RunEnd, TimeStep, Transient, TransientOptions, Unobserved};
use tetfem::fe::materials::MaterialMap;
use tetfem::{BoxSplit, Constraints, Error, Material, TetMesh};

/// The rubber beam of `scenes/rubber_beam_swing.toml` (0.5 × 0.05 × 0.05 m, 20 × 2 × 2 cells,
/// E = 0.5 MPa, ν = 0.45, ρ = 1100 kg/m³), clamped at x = 0, under gravity: its ω_max is about
/// 5e3 rad/s, so β = 1e-4 s gives ξ ≈ 0.26 at the top mode, the case (theory 0.774×
/// the undamped step).
fn rubber_beam() -> Definition {
    let mesh = TetMesh::box_grid(
        Vector3::zeros(),
        Vector3::new(0.5, 0.05, 0.05),
        [20, 2, 2],
        BoxSplit::Five,
    )
    .unwrap();
    let materials =
        MaterialMap::uniform(Material::new(5e5, 0.45, 1100.0).unwrap(), mesh.tet_count());
    let mut constraints = Constraints::new(&mesh);
    constraints
        .fix_nodes(&mesh.nodes_on_plane(0, 0.0, 1e-9))
        .unwrap();
    Definition::builder(mesh, materials)
        .constraints(constraints)
        .unwrap()
        .gravity(Vector3::new(0.0, 0.0, -9.81))
        .unwrap()
        .build()
        .unwrap()
}

/// `steps` explicit steps of `definition` at `factor` × the library's critical step with
/// damping `damping`, from rest displaced by `start` (repeated over the free DOFs): every mode,
/// the top one included, starts with an amplitude far above round-off, so an unstable mode
/// shows within a few hundred steps. Returns the run's end (or error) and the critical step.
fn explicit_run(
    definition: &Definition,
    damping: Rayleigh,
    factor: f64,
    steps: usize,
    start: &[f64],
) -> (tetfem::Result<RunEnd>, f64) {
    let options = TransientOptions {
        damping,
        ..TransientOptions::new(Method::Explicit, TimeStep::CriticalMultiple(factor))
    };
    let mut run = Transient::new(definition, options).unwrap();
    let limit = run
        .step_limit()
        .expect("a critical multiple finds the step");
    for (i, u) in run.state_mut().displacement.iter_mut().enumerate() {
        *u = start[i % start.len()];
    }
    (run.run((0, steps), &mut Unobserved), limit.dt)
}

/// A 1 µm alternating-sign field: a component along every mode of the beam.
const ALTERNATING: [f64; 2] = [1e-6, -1e-6];

#[test]
fn the_explicit_step_with_stiffness_damping_is_stable_below_and_diverges_above() {
    let beam = rubber_beam();
    let mut steps_of = Vec::new();
    for beta in [0.0, 1e-4] {
        let damping = Rayleigh::new(0.0, beta).unwrap();
        // 20 000 steps at ~0.3 ms: about 6 s of simulated time, several first-mode periods
        // (≈ 0.6 s) and thousands of top-mode periods (≈ 1.2 ms); the divergence guard (10× the
        // start's energy plus the loads' work) would stop a mode growing by any factor > 1 per
        // step long before.
        let (end, dt) = explicit_run(&beam, damping, 0.98, 20_000, &ALTERNATING);
        assert_eq!(end.unwrap(), RunEnd::Finished, "β = {beta}: 0.98× {dt:e} s");
        // Above the bound the top mode grows geometrically: the guard fires.
        let (end, _) = explicit_run(&beam, damping, 1.05, 20_000, &ALTERNATING);
        assert!(
            matches!(end, Err(Error::Diverged { .. })),
            "β = {beta}: 1.05× the step should diverge, got {end:?}"
        );
        steps_of.push(dt);
    }
    // Stiffness damping lowers the step, by about the 0.774× (ξ ≈ 0.26 at ω_max):
    // between 0.7 and 0.85 for ω_max in 3.5e3 … 7e3 rad/s, the range of this mesh's top mode.
    let ratio = steps_of[1] / steps_of[0];
    assert!((0.7..0.85).contains(&ratio), "damped / undamped = {ratio}");
}

/// The tetrahedron's start: mostly along its two lower (shear, ω² = 4μ/ρ) modes, 1e-8 m along
/// the top one. A start on the top mode alone would not do: at 0.98× the critical step the
/// scheme's discrete oscillation of that mode reaches 1/(1 − (ω·dt/2)²) ≈ 25× its starting
/// energy (from a displacement or a velocity start alike), past the divergence guard's 10×,
/// although it is bounded. Here the top mode holds ~1e-4 of the energy.
const TET_START: [f64; 3] = [1e-6, 1e-6, 1e-8];

/// One tetrahedron (0,0,0), (1,0,0), (0,1,0), (0,0,1) m with the first three nodes fixed: the
/// free node's stiffness is V·diag(μ, μ, λ + 2μ) (∇N₄ = (0, 0, 1), so u = N₄·a strains
/// ε_zz = a_z, γ_xz = a_x, γ_yz = a_y) and its lumped mass ρV/4, hence ω_max² = 4(λ + 2μ)/ρ.
#[test]
fn the_damped_step_of_one_tetrahedron_is_the_closed_form_bound() {
    let (e, nu, rho): (f64, f64, f64) = (2e11, 0.3, 7850.0);
    let lame = e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu));
    let mu = e / (2.0 * (1.0 + nu));
    let omega = (4.0 * (lame + 2.0 * mu) / rho).sqrt();
    let mesh = TetMesh::new(
        vec![Vector3::zeros(), Vector3::x(), Vector3::y(), Vector3::z()],
        vec![[0, 1, 2, 3]],
    )
    .unwrap();
    let materials = MaterialMap::uniform(Material::new(e, nu, rho).unwrap(), 1);
    let mut constraints = Constraints::new(&mesh);
    constraints.fix_nodes(&[0, 1, 2]).unwrap();
    let tet = Definition::builder(mesh, materials)
        .constraints(constraints)
        .unwrap()
        .build()
        .unwrap();
    // ξ at ω_max: 0 (undamped), 0.26 (stiffness), 0.05 + 0.26 (mass and stiffness), 3 (heavy).
    for (alpha, beta) in [
        (0.0, 0.0),
        (0.0, 0.52 / omega),
        (0.1 * omega, 0.52 / omega),
        (0.0, 6.0 / omega),
    ] {
        let damping = Rayleigh::new(alpha, beta).unwrap();
        let xi = alpha / (2.0 * omega) + beta * omega / 2.0;
        let theory = 2.0 / omega * ((1.0 + xi * xi).sqrt() - xi);
        let (end, dt) = explicit_run(&tet, damping, 0.98, 5_000, &TET_START);
        assert_eq!(end.unwrap(), RunEnd::Finished, "ξ = {xi}: 0.98× is stable");
        // The library's step is proven ≤ the true one and within 1e-3 of it (the power
        // iteration's bracket, certified by an inertia check), so it lies in
        // [(1 − 1e-3)·theory, theory]; 1e-12 covers the rounding of the closed form itself.
        assert!(
            dt <= theory * (1.0 + 1e-12) && dt >= theory * (1.0 - 1e-3),
            "ξ = {xi}: step {dt:e} s, closed form {theory:e} s"
        );
        let (end, _) = explicit_run(&tet, damping, 1.05, 5_000, &TET_START);
        assert!(
            matches!(end, Err(Error::Diverged { .. })),
            "ξ = {xi}: 1.05× should diverge, got {end:?}"
        );
    }
}
