//! Large deformation, the edge cases: the polar rotation on degenerate, inverted and badly
//! scaled deformation gradients; the corotational force against the warped-linear formula
//! f = −R·Kₑ·(Rᵀx − X); tangents on inverted tets and where the rotation is not differentiable;
//! the PSD projection; Newton driven by prescribed displacements alone.

use crate::common;

use common::{Rng, random_tet};
use nalgebra::{Matrix3, Rotation3, SymmetricEigen, Unit, Vector3};
use tetfem::analysis::nonlinear::{NewtonOptions, solve_nonlinear_static};
use tetfem::fe::element::{Matrix12, Tet, Vector12, signed_volume};
use tetfem::model::{ForceModel, ModelKind, PSD_TOLERANCE, project_psd, rotation};
use tetfem::{BoxSplit, Constraints, Loads, Material, TetMesh};

fn material() -> Material {
    Material::new(1e4, 0.3, 1000.0).unwrap()
}

fn displaced(x: &[Vector3<f64>; 4], u: &Vector12) -> [Vector3<f64>; 4] {
    [0, 1, 2, 3].map(|i| x[i] + Vector3::new(u[3 * i], u[3 * i + 1], u[3 * i + 2]))
}

/// Deformed positions with deformation gradient `f` about node 0: xᵢ = X₀ + F·(Xᵢ − X₀).
fn deformed_by(x: &[Vector3<f64>; 4], f: &Matrix3<f64>) -> [Vector3<f64>; 4] {
    x.map(|p| x[0] + f * (p - x[0]))
}

fn random_rotation(rng: &mut Rng) -> Matrix3<f64> {
    let axis = Unit::new_normalize(rng.vector(-1.0, 1.0) + Vector3::new(0.0, 0.0, 1e-3));
    Rotation3::from_axis_angle(&axis, rng.range(-3.1, 3.1)).into_inner()
}

/// A gallery of awkward deformation gradients: zero, rank one, flat, inverted (one and three
/// negative stretches, repeated singular values), a 180° rotation, near-degenerate, and the
/// same scaled by 1e-200 and 1e150.
fn awkward_gradients() -> Vec<(String, Matrix3<f64>)> {
    let mut rng = Rng::new(71);
    let q = random_rotation(&mut rng);
    let p = random_rotation(&mut rng);
    let diag = |a: f64, b: f64, c: f64| q * Matrix3::from_diagonal(&Vector3::new(a, b, c)) * p;
    let mut list = vec![
        ("zero".to_string(), Matrix3::zeros()),
        (
            "rank one".into(),
            Vector3::new(1.0, 2.0, 3.0) * Vector3::new(-1.0, 0.5, 2.0).transpose(),
        ),
        ("flat (rank two)".into(), diag(1.5, 0.7, 0.0)),
        ("inverted, one axis".into(), diag(1.0, 1.0, -1.0)),
        ("inverted, repeated".into(), diag(-1.0, -1.0, -1.0)),
        ("inverted, two axes".into(), diag(-0.5, -2.0, 1.0)),
        ("nearly flat, inverted".into(), diag(2.0, 0.5, -1e-12)),
        ("nearly flat".into(), diag(2.0, 0.5, 1e-14)),
        (
            "rotation by 180°".into(),
            Rotation3::from_axis_angle(
                &Unit::new_normalize(Vector3::new(1.0, -2.0, 0.5)),
                std::f64::consts::PI,
            )
            .into_inner(),
        ),
    ];
    for k in 0..6 {
        let f = Matrix3::from_fn(|_, _| rng.range(-1.0, 1.0));
        list.push((format!("random {k} (det {:+.2})", f.determinant()), f));
    }
    let scaled: Vec<(String, Matrix3<f64>)> = list
        .iter()
        .flat_map(|(name, f)| {
            [
                (format!("{name} ×1e-200"), f * 1e-200),
                (format!("{name} ×1e150"), f * 1e150),
            ]
        })
        .collect();
    list.extend(scaled);
    list
}

#[test]
fn polar_rotation_is_a_proper_rotation_for_every_awkward_gradient() {
    let mut worst_orthogonality: f64 = 0.0;
    let mut worst_det: f64 = 0.0;
    let mut worst_symmetry: f64 = 0.0;
    let mut failures = Vec::new();
    for (name, f) in awkward_gradients() {
        let r = rotation(&f);
        assert!(r.iter().all(|v| v.is_finite()), "{name}: R = {r}");
        let orthogonality = (r.transpose() * r - Matrix3::identity()).amax();
        let det = (r.determinant() - 1.0).abs();
        // S = RᵀF must be symmetric (R is the polar factor, up to the sign of the smallest
        // stretch); relative to |F|, as F spans 1e-200 to 1e150.
        let s = r.transpose() * f;
        let symmetry = (s - s.transpose()).amax() / f.amax().max(f64::MIN_POSITIVE);
        println!(
            "{name:<36} |RᵀR − I| {orthogonality:.1e}  |det R − 1| {det:.1e}  |S − Sᵀ|/|F| {symmetry:.1e}"
        );
        // Round-off of a 3×3 SVD: a few ulps per entry.
        let mut problems = Vec::new();
        if orthogonality > 1e-12 {
            problems.push(format!("|RᵀR − I| = {orthogonality:e}"));
        }
        if det > 1e-12 {
            problems.push(format!("det R = {}", r.determinant()));
        }
        if symmetry > 1e-12 {
            problems.push(format!("RᵀF not symmetric ({symmetry:e})"));
        }
        if f.determinant() > 0.0 {
            // A positively oriented F: S is the stretch, positive semi-definite.
            let smallest = SymmetricEigen::new((s + s.transpose()) * 0.5)
                .eigenvalues
                .min();
            if smallest < -1e-12 * f.amax() {
                problems.push(format!("stretch eigenvalue {smallest:e}"));
            }
        }
        if !problems.is_empty() {
            failures.push(format!("{name}: {}", problems.join(", ")));
        }
        worst_orthogonality = worst_orthogonality.max(orthogonality);
        worst_det = worst_det.max(det);
        worst_symmetry = worst_symmetry.max(symmetry);
    }
    println!(
        "worst: |RᵀR − I| {worst_orthogonality:.1e}, |det R − 1| {worst_det:.1e}, |S − Sᵀ|/|F| {worst_symmetry:.1e}"
    );
    assert!(failures.is_empty(), "{failures:#?}");
    // A rotation is its own polar factor, the 180° one (repeated singular values) included.
    let half_turn = Rotation3::from_axis_angle(
        &Unit::new_normalize(Vector3::new(1.0, -2.0, 0.5)),
        std::f64::consts::PI,
    )
    .into_inner();
    assert!((rotation(&half_turn) - half_turn).amax() <= 1e-14);
    // Non-finite input: the identity, never NaN.
    let mut bad = Matrix3::identity();
    bad[(1, 2)] = f64::NAN;
    assert_eq!(rotation(&bad), Matrix3::identity());
}

/// R ⊗ I₄: the 12×12 block-diagonal rotation of the four nodes.
fn block_rotation(r: &Matrix3<f64>) -> Matrix12 {
    let mut big = Matrix12::zeros();
    for i in 0..4 {
        big.fixed_view_mut::<3, 3>(3 * i, 3 * i).copy_from(r);
    }
    big
}

#[test]
fn corotational_force_is_the_warped_linear_force() {
    let model = ModelKind::Corotational.build(&material());
    let mut rng = Rng::new(72);
    let mut worst: f64 = 0.0;
    for case in 0..40 {
        let x = random_tet(&mut rng);
        let tet = Tet::new(&x).unwrap();
        let k = tet.stiffness(&material());
        // Rotation by any angle, stretch up to ±40 %, and every fourth case inverted.
        let mut stretch = Matrix3::identity() + Matrix3::from_fn(|_, _| rng.range(-0.4, 0.4));
        if case % 4 == 3 {
            stretch.set_column(2, &(-stretch.column(2)));
        }
        let f = random_rotation(&mut rng) * stretch;
        let y = deformed_by(&x, &f).map(|p| p + Vector3::new(0.3, -1.0, 2.0));
        let r = rotation(&tet.deformation_gradient(&y));
        let big = block_rotation(&r);
        let rest = Vector12::from_fn(|i, _| x[i / 3][i % 3]);
        let now = Vector12::from_fn(|i, _| y[i / 3][i % 3]);
        // The formula of the issue: f = −R·Kₑ·(Rᵀx − X).
        let expected = -(big * k * (big.transpose() * now - rest));
        let got = model.force(&tet, &x, &y);
        let error = (got - expected).amax() / expected.amax();
        worst = worst.max(error);
        assert!(error <= 1e-11, "case {case}: relative error {error:e}");
    }
    println!("corotational force vs −R·Kₑ·(Rᵀx − X): worst relative difference {worst:.2e}");
}

/// Central-difference check of a model's tangent at `y`: returns the relative errors for
/// h, h/2, h/4 (O(h²)).
fn central_difference_errors(
    model: &dyn ForceModel,
    tet: &Tet,
    x: &[Vector3<f64>; 4],
    y: &[Vector3<f64>; 4],
    direction: &Vector12,
    h0: f64,
) -> Vec<f64> {
    let exact = -(model.tangent(tet, x, y) * direction);
    (0..3)
        .map(|level| {
            let h = h0 / f64::from(1 << level);
            let plus = model.force(tet, x, &displaced(y, &(direction * h)));
            let minus = model.force(tet, x, &displaced(y, &(direction * -h)));
            ((plus - minus) / (2.0 * h) - exact).amax() / exact.amax()
        })
        .collect()
}

#[test]
fn tangents_match_central_differences_on_inverted_tets() {
    let mut rng = Rng::new(73);
    for kind in [ModelKind::Corotational, ModelKind::NeoHookean] {
        let model = kind.build(&material());
        for case in 0..5 {
            let x = random_tet(&mut rng);
            let tet = Tet::new(&x).unwrap();
            // Inverted by a finite amount, away from the set σᵢ + σⱼ = 0 where R is not
            // differentiable: stretches (1.3, 0.8, −0.4) between random rotations.
            let f = random_rotation(&mut rng)
                * Matrix3::from_diagonal(&Vector3::new(1.3, 0.8, -0.4))
                * random_rotation(&mut rng);
            let y = deformed_by(&x, &f);
            assert!(signed_volume(&y) < 0.0);
            let direction = Vector12::from_fn(|_, _| rng.range(-1.0, 1.0));
            let errors = central_difference_errors(model.as_ref(), &tet, &x, &y, &direction, 1e-3);
            println!(
                "{} inverted case {case}: central-difference error {:?}",
                model.name(),
                errors
                    .iter()
                    .map(|e| format!("{e:.2e}"))
                    .collect::<Vec<_>>()
            );
            // O(h²): each halving divides the error by 4 (3.2–4.8 allowed), unless it is
            // already at the round-off floor of the difference quotient (~1e-10 here).
            for pair in errors.windows(2) {
                assert!(
                    pair[1] < 1e-9 || (pair[0] / pair[1] - 4.0).abs() < 0.8,
                    "{} case {case}: {errors:?}",
                    model.name()
                );
            }
            assert!(errors[0] < 1e-4, "{} case {case}: {errors:?}", model.name());
        }
    }
}

#[test]
fn tangents_stay_finite_where_the_rotation_is_not_differentiable() {
    // σ₁ + σ₂ = 0 after the reflection is folded into R: the rotation has no derivative there
    // (two stretches of opposite sign and equal size), so the corotational model drops the
    // rotation term; near it the term is large but finite.
    let x = [Vector3::zeros(), Vector3::x(), Vector3::y(), Vector3::z()];
    let tet = Tet::new(&x).unwrap();
    let scale = tet.stiffness(&material()).amax();
    for kind in [ModelKind::Corotational, ModelKind::NeoHookean] {
        let model = kind.build(&material());
        for (name, stretches) in [
            ("exactly singular", Vector3::new(1.0, 1.0, -1.0)),
            ("1e-9 from singular", Vector3::new(1.0, 1.0, -1.0 + 1e-9)),
            ("flat", Vector3::new(1.0, 1.0, 0.0)),
            ("collapsed to a point", Vector3::new(0.0, 0.0, 0.0)),
        ] {
            let y = deformed_by(&x, &Matrix3::from_diagonal(&stretches));
            let f = model.force(&tet, &x, &y);
            let k = model.tangent(&tet, &x, &y);
            let projected = project_psd(&k);
            println!(
                "{} {name}: |f| {:.2e}, |K| {:.2e}, |K_psd| {:.2e} (|Kₑ| {scale:.2e})",
                model.name(),
                f.amax(),
                k.amax(),
                projected.amax()
            );
            assert!(
                f.iter().all(|v| v.is_finite()),
                "{} {name}: force",
                model.name()
            );
            assert!(
                k.iter().all(|v| v.is_finite()),
                "{} {name}: tangent",
                model.name()
            );
            assert!(
                projected.iter().all(|v| v.is_finite()),
                "{} {name}: projected",
                model.name()
            );
            assert!((k - k.transpose()).amax() <= 1e-12 * k.amax().max(scale));
        }
    }
}

#[test]
fn psd_projection_clamps_only_negative_eigenvalues() {
    let mut rng = Rng::new(74);
    let x = random_tet(&mut rng);
    let tet = Tet::new(&x).unwrap();
    for kind in [ModelKind::Corotational, ModelKind::NeoHookean] {
        let model = kind.build(&material());
        // At rest the tangent is Kₑ (PSD, six zero modes): the projection leaves it alone.
        let at_rest = model.tangent(&tet, &x, &x);
        assert!((at_rest - tet.stiffness(&material())).amax() <= 1e-10 * at_rest.amax());
        assert!((project_psd(&at_rest) - at_rest).amax() <= 1e-10 * at_rest.amax());
        let mut clamped_any = false;
        for _ in 0..20 {
            // Strong compression (down to 30 %) with rotation: indefinite exact tangents.
            let f = random_rotation(&mut rng) * Matrix3::from_diagonal(&rng.vector(0.3, 1.0));
            let k = model.tangent(&tet, &x, &deformed_by(&x, &f));
            let before = SymmetricEigen::new(k).eigenvalues;
            let after = SymmetricEigen::new(project_psd(&k)).eigenvalues;
            let largest = before.amax();
            // Non-negative up to the fast path's tolerance (PSD_TOLERANCE·max diag ≤ ·largest).
            assert!(
                after.min() >= -PSD_TOLERANCE * largest,
                "{}: {}",
                model.name(),
                after.min()
            );
            // The positive part of the spectrum is kept: the sums of positive eigenvalues match.
            let positive =
                |e: &nalgebra::SVector<f64, 12>| e.iter().filter(|&&l| l > 0.0).sum::<f64>();
            assert!((positive(&before) - positive(&after)).abs() <= 1e-10 * largest);
            clamped_any |= before.min() < -1e-8 * largest;
        }
        // The test is only meaningful if some of these tangents were indefinite.
        assert!(clamped_any, "{}: no indefinite tangent met", model.name());
    }
}

#[test]
fn newton_twists_a_block_by_90_degrees_with_prescribed_displacements_only() {
    // A 2×1×1 block, clamped at x = 0, its end face x = 2 turned by 90° about the x axis
    // (pure prescribed displacement, no load): every iteration's tangent is indefinite in
    // places early on, so the PSD fallback is exercised; the answer must be finite, converged,
    // with every tet still positively oriented.
    let mesh = TetMesh::box_grid(
        Vector3::zeros(),
        Vector3::new(2.0, 1.0, 1.0),
        [4, 2, 2],
        BoxSplit::Five,
    )
    .unwrap();
    let mut constraints = Constraints::new(&mesh);
    constraints
        .fix_nodes(&mesh.nodes_on_plane(0, 0.0, 1e-9))
        .unwrap();
    let centre = Vector3::new(2.0, 0.5, 0.5);
    let turn = Rotation3::from_axis_angle(&Vector3::x_axis(), std::f64::consts::FRAC_PI_2);
    for n in mesh.nodes_on_plane(0, 2.0, 1e-9) {
        let p = mesh.nodes()[n];
        constraints
            .prescribe(n, turn * (p - centre) + centre - p)
            .unwrap();
    }
    for kind in [ModelKind::Corotational, ModelKind::NeoHookean] {
        let model = kind.build(&material());
        let options = NewtonOptions {
            load_steps: 6,
            ..NewtonOptions::default()
        };
        let report = solve_nonlinear_static(
            &mesh,
            model.as_ref(),
            &constraints,
            &Loads::new(&mesh),
            options,
        )
        .unwrap();
        let last = report.residuals.last().unwrap();
        let smallest_volume = (0..mesh.tet_count())
            .map(|t| {
                let y = mesh.tets()[t].map(|n| {
                    mesh.nodes()[n]
                        + Vector3::new(
                            report.displacement[3 * n],
                            report.displacement[3 * n + 1],
                            report.displacement[3 * n + 2],
                        )
                });
                signed_volume(&y) / mesh.element(t).unwrap().volume()
            })
            .fold(f64::INFINITY, f64::min);
        println!(
            "{}: {} Newton iterations, smallest V/V₀ {smallest_volume:.3}, last step residuals {:?}",
            model.name(),
            report.iterations,
            last.iter().map(|r| format!("{r:.2e}")).collect::<Vec<_>>()
        );
        assert!(report.displacement.iter().all(|v| v.is_finite()));
        assert!(smallest_volume > 0.0, "{}: a tet inverted", model.name());
        // Converged: the last residual is far below the step's first.
        assert!(
            last[last.len() - 1] <= 1e-8 * last[0],
            "{}: {last:?}",
            model.name()
        );
    }
}

/// A 3 × 1 × 1 bar of 9216 tets (two of the internal force's parallel blocks) and a random
/// displacement of up to 0.05 per DOF drawn from `seed`.
fn bar_with_random_displacement(seed: u64) -> (TetMesh, Vec<f64>) {
    let mesh = TetMesh::box_grid(
        Vector3::zeros(),
        Vector3::new(3.0, 1.0, 1.0),
        [24, 8, 8],
        tetfem::BoxSplit::Mirrored6,
    )
    .unwrap();
    let mut rng = Rng::new(seed);
    let u = (0..mesh.dof_count())
        .map(|_| rng.range(-0.05, 0.05))
        .collect();
    (mesh, u)
}

#[test]
fn the_total_energy_is_the_same_bits_on_any_number_of_threads() {
    // rayon's unordered `sum` differed in the last bit from run to run (seen in the energy
    // column of a nonlinear dynamic CSV); fixed chunks summed in order must not.
    let (mesh, u) = bar_with_random_displacement(91);
    for kind in [
        ModelKind::Corotational,
        ModelKind::NeoHookean,
        ModelKind::StVenantKirchhoff,
    ] {
        let model = kind.build(&material());
        let energies: Vec<u64> = [1, 2, 3, 2, 3]
            .iter()
            .map(|&threads| {
                let pool = rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .unwrap();
                pool.install(|| tetfem::model::assemble::energy(&mesh, model.as_ref(), &u))
                    .unwrap()
                    .to_bits()
            })
            .collect();
        assert!(
            energies.iter().all(|&e| e == energies[0]),
            "{}: {energies:?}",
            kind.name()
        );
    }
}

/// The internal force computes tets in parallel blocks but adds them in tet order: on 1, 2 and
/// 3 threads it has the bits of adding one tet's force after another (9216 tets: two blocks).
#[test]
fn the_internal_force_is_the_serial_sum_bit_for_bit_on_any_number_of_threads() {
    use tetfem::model::ModelElement;
    let (mesh, u) = bar_with_random_displacement(17);
    for kind in [ModelKind::Corotational, ModelKind::NeoHookean] {
        let model = kind.build(&material());
        let mut serial = vec![0.0; mesh.dof_count()];
        for t in 0..mesh.tet_count() {
            <tetfem::Tet4 as ModelElement>::add_model_force(
                model.as_ref(),
                &mesh,
                t,
                &u,
                &mut serial,
            );
        }
        for threads in [1, 2, 3] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let blocked = pool
                .install(|| tetfem::model::assemble::internal_force(&mesh, model.as_ref(), &u))
                .unwrap();
            let same = blocked
                .iter()
                .zip(&serial)
                .all(|(a, b)| a.to_bits() == b.to_bits());
            assert!(same, "{} on {threads} threads", kind.name());
        }
    }
}

/// The support reactions of a corotational state sum the internal force over the tets that
/// touch a support only: with fixed supports, a lumped mass and no damping r_c = −f_int,c − f_g,c,
/// and those rows must carry the very bits of the whole mesh's force (the same tets, added in
/// the same order), at a bent, turned state 10 steps into the swing.
#[test]
fn support_reactions_use_the_whole_mesh_force_bits_on_the_constrained_rows() {
    use tetfem::analysis::dynamics::{
        Integrator, InternalForce, NonlinearSolve, State, SupportReactions, TimeData,
    };
    use tetfem_fixtures::swing::Swing;

    let swing = Swing::new([10, 2, 2], BoxSplit::Lecture6, 1e6).unwrap();
    let force = swing.corotational().unwrap();
    let mut integrator = swing
        .integrator(force.clone(), 0.02, NonlinearSolve::Refactor, 1e-8, 1)
        .unwrap();
    let mut state = State::at_rest(swing.system.free_count());
    for _ in 0..10 {
        integrator.step(&mut state).unwrap();
    }
    // At rest in the supports' rows: the state's v and a there are zero; the free rows' v does
    // not enter a lumped mass's reaction.
    let gravity = Vector3::new(0.0, 0.0, -9.81);
    let mut reactions = SupportReactions::new(
        &swing.system,
        swing.mesh.as_ref(),
        &swing.problem.material,
        &Loads::new(swing.mesh.as_ref()),
        gravity,
        &TimeData::default(),
    )
    .unwrap();
    let at = reactions.at(&swing.system, &force, &state).unwrap();
    let InternalForce::Nonlinear(nonlinear) = &force else {
        panic!("corotational is nonlinear")
    };
    let full = swing
        .system
        .expand_at(state.time, &state.displacement)
        .unwrap();
    let internal = nonlinear.model_internal_force(&full).unwrap();
    let mut weight = Loads::new(swing.mesh.as_ref());
    weight
        .add_gravity(swing.mesh.as_ref(), &swing.problem.material, gravity)
        .unwrap();
    assert!(!reactions.dofs().is_empty());
    for &c in reactions.dofs() {
        let expected = -internal[c] - weight.as_slice()[c];
        assert_eq!(
            at[c].to_bits(),
            expected.to_bits(),
            "DOF {c}: {} against {expected}",
            at[c]
        );
    }
    // The state is far from the rest shape: the supports carry a bending moment.
    let largest = reactions
        .dofs()
        .iter()
        .map(|&c| internal[c].abs())
        .fold(0.0, f64::max);
    assert!(largest > 1.0, "largest support force {largest} N");
}
