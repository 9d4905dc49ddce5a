//! The scene keys `analysis.nonlinear_solver` and `analysis.newton_tolerance`: `"refactor"` and
//! `"rest_preconditioned"` run the same corotational swing (the default `"auto"` refactors on a
//! mesh this small) to the same Newton tolerance, the summary's Newton counts tell them apart,
//! a looser tolerance takes fewer iterations and stays near the converged swing, and any other
//! value is an error naming the key and its line.

use std::path::Path;

use tetfem_cli::scene::{DynamicOverrides, RunLength, Scene, run_dynamic_scene};

/// A rubber beam released from horizontal under gravity (corotational backward Euler at
/// 10 ms, ~100× the explicit critical step); `{solver}` is replaced by the key's line.
const SWING: &str = r#"
title = "swing"

[mesh.box]
max = [0.5, 0.05, 0.05]
cells = [10, 2, 2]
split = "five"

[material]
youngs_modulus = 5e5
poisson_ratio = 0.4
density = 1100.0

[[constraints]]
where = { plane = { axis = "x", at = 0.0 } }

[[loads]]
gravity = [0.0, 0.0, -9.81]

[[probes]]
name = "tip"
where = { plane = { axis = "x", at = 0.5 } }

[analysis]
type = "dynamic"
method = "backward_euler"
model = "corotational"
dt = 1e-2
duration = 0.3
{solver}
"#;

fn run(solver_line: &str) -> tetfem_cli::scene::DynamicSummary {
    let text = SWING.replace("{solver}", solver_line);
    let scene = Scene::parse(&text, "swing", Path::new(".")).unwrap();
    run_dynamic_scene(
        &scene,
        &DynamicOverrides {
            length: Some(RunLength::Steps(30)),
            ..Default::default()
        },
        false,
        false,
        &mut |_, _| std::ops::ControlFlow::Continue(()),
    )
    .unwrap()
}

/// |a − b| and |b| (Euclidean).
fn difference_and_size(a: &[f64], b: &[f64]) -> (f64, f64) {
    let difference = a
        .iter()
        .zip(b)
        .map(|(x, y)| (x - y) * (x - y))
        .sum::<f64>()
        .sqrt();
    (difference, b.iter().map(|x| x * x).sum::<f64>().sqrt())
}

/// Both values run; the tips agree to 1e-6 relative (each step's Newton residual is ≤ 1e-8 of
/// its reference on both paths, and backward Euler does not amplify the difference: the library
/// test `tests/core/corotational_step.rs` measures 1e-10 on the same beam), and the refactoring one
/// factors once per Newton iteration while the default factors less often.
#[test]
fn refactor_and_rest_preconditioned_give_the_same_swing() {
    let default = run("nonlinear_solver = \"rest_preconditioned\"");
    let refactor = run("nonlinear_solver = \"refactor\"");
    // The swing has fewer than AUTO_REFACTOR_BELOW free DOFs: the default ("auto") refactors.
    let auto = run("");
    assert!(auto.newton.unwrap().total_iterations > 0);
    assert_eq!(auto.probes[0].last, refactor.probes[0].last);
    assert_eq!(auto.newton, refactor.newton);
    let (a, b) = (default.probes[0].last, refactor.probes[0].last);
    let (difference, size) = difference_and_size(&a, &b);
    let (d, r) = (default.newton.unwrap(), refactor.newton.unwrap());
    println!(
        "tip {a:?} vs {b:?}: {:.2e} relative; default {} Newton its, {} factorizations, {} CG its; refactor {} its, {} factorizations",
        difference / size,
        d.total_iterations,
        d.factorizations,
        d.cg_iterations,
        r.total_iterations,
        r.factorizations
    );
    assert!(difference < 1e-6 * size, "{a:?} vs {b:?}");
    assert_eq!(r.factorizations, r.total_iterations);
    assert!(d.factorizations < r.factorizations, "{d:?} vs {r:?}");
}

/// `"rest_lbfgs"` runs the tangent-free step: the same tip to 1e-6 relative (the same Newton
/// test on the residual, as above) from one factorization, the rest matrix's.
#[test]
fn rest_lbfgs_gives_the_same_swing() {
    let lbfgs = run("nonlinear_solver = \"rest_lbfgs\"");
    let refactor = run("nonlinear_solver = \"refactor\"");
    let (a, b) = (lbfgs.probes[0].last, refactor.probes[0].last);
    let (difference, size) = difference_and_size(&a, &b);
    let stats = lbfgs.newton.unwrap();
    println!(
        "tip {a:?} vs {b:?}: {:.2e} relative; {stats:?}",
        difference / size
    );
    assert!(difference < 1e-6 * size, "{a:?} vs {b:?}");
    assert_eq!(stats.factorizations, 1, "{stats:?}");
    assert_eq!(stats.cg_iterations, 0, "{stats:?}");
}

/// An unknown value is refused when the scene is read, naming its line, the value and the
/// allowed ones.
#[test]
fn an_unknown_nonlinear_solver_names_the_key_and_line() {
    let text = SWING.replace("{solver}", "nonlinear_solver = \"gauss_seidel\"");
    let line = text
        .lines()
        .position(|l| l.starts_with("nonlinear_solver"))
        .unwrap()
        + 1;
    let message = match Scene::parse(&text, "swing", Path::new(".")) {
        Err(e) => e.to_string(),
        Ok(_) => panic!("an unknown nonlinear_solver was accepted"),
    };
    assert!(message.contains("gauss_seidel"), "{message}");
    // The scene errors' form: `swing:LINE: value: what is allowed`.
    assert!(message.contains(&format!("swing:{line}:")), "{message}");
    assert!(message.contains("rest_preconditioned"), "{message}");
    assert!(message.contains("rest_lbfgs"), "{message}");
}

/// `newton_tolerance = 1e-2` on the L-BFGS path: fewer Newton iterations than the default
/// 1e-8 (measured 42 against 226 over 30 steps), and a tip within 2e-3 relative of the
/// converged swing (measured 8.1e-4: each step may stop with its residual at 1e-2 of its
/// reference, and 30 steps of this coarse beam at ~100× the explicit critical step add that
/// up; the cost table's 132k-DOF swing stays within 5.5e-5 over 20 steps. 2e-3 leaves 2.5×).
#[test]
fn a_looser_newton_tolerance_takes_fewer_iterations_near_the_same_swing() {
    let tight = run("nonlinear_solver = \"rest_lbfgs\"");
    let loose = run("nonlinear_solver = \"rest_lbfgs\"\nnewton_tolerance = 1e-2");
    let (a, b) = (loose.probes[0].last, tight.probes[0].last);
    let (difference, size) = difference_and_size(&a, &b);
    let (l, t) = (loose.newton.unwrap(), tight.newton.unwrap());
    println!(
        "tip {a:?} vs {b:?}: {:.2e} relative; {} against {} Newton its",
        difference / size,
        l.total_iterations,
        t.total_iterations
    );
    assert!(l.total_iterations < t.total_iterations, "{l:?} vs {t:?}");
    assert!(difference < 2e-3 * size, "{a:?} vs {b:?}");
}

/// A tolerance outside (0, 1), or one on a static scene, is refused when the scene is read,
/// naming the key, the line of its `[analysis]` table (where every analysis key's error
/// points), the value and the allowed range.
#[test]
fn a_bad_newton_tolerance_names_the_key_and_line() {
    for (line, expected) in [
        ("newton_tolerance = 0.0", "must be finite, > 0 and < 1"),
        ("newton_tolerance = 1.0", "must be finite, > 0 and < 1"),
        ("newton_tolerance = -1e-3", "must be finite, > 0 and < 1"),
        ("newton_tolerance = nan", "must be finite, > 0 and < 1"),
    ] {
        let text = SWING.replace("{solver}", line);
        let at = text.lines().position(|l| l == "[analysis]").unwrap() + 1;
        let message = match Scene::parse(&text, "swing", Path::new(".")) {
            Err(e) => e.to_string(),
            Ok(_) => panic!("{line} was accepted"),
        };
        assert!(
            message.contains(&format!("swing:{at}:")),
            "{line}: {message}"
        );
        assert!(message.contains("newton_tolerance"), "{line}: {message}");
        let value: f64 = line.split(" = ").nth(1).unwrap().parse().unwrap();
        assert!(
            message.contains(&format!("= {value} ")),
            "{line}: {message}"
        );
        assert!(message.contains(expected), "{line}: {message}");
    }
    let text = SWING
        .replace("type = \"dynamic\"", "type = \"static\"")
        .replace("method = \"backward_euler\"\n", "")
        .replace("dt = 1e-2\n", "")
        .replace("duration = 0.3\n", "")
        .replace("{solver}", "newton_tolerance = 1e-2");
    // A static scene with a nonlinear model takes it for each load step's Newton solve
    // (issue 33; crates/cli/tests/scenes/static_newton.rs), a modal one does not.
    let scene = Scene::parse(&text, "swing", Path::new(".")).unwrap();
    assert_eq!(scene.static_newton().tolerance, 1e-2);
    let modal = text
        .replace("type = \"static\"", "type = \"modal\"")
        .replace("model = \"corotational\"\n", "");
    let message = match Scene::parse(&modal, "swing", Path::new(".")) {
        Err(e) => e.to_string(),
        Ok(_) => panic!("a modal scene took newton_tolerance"),
    };
    assert!(message.contains("only a dynamic analysis"), "{message}");
    assert!(message.contains("newton_tolerance"), "{message}");
}

/// A Neo-Hookean block (4³ cells) thrown sideways onto frictional ground (backward Euler,
/// 20 ms); `{relax}` is replaced by the key's line.
const DROP: &str = r#"
title = "drop"

[mesh.box]
min = [0.0, 0.0, 0.05]
max = [0.2, 0.2, 0.25]
cells = [4, 4, 4]

[material]
youngs_modulus = 1e5
poisson_ratio = 0.3
density = 1000.0

[[loads]]
gravity = [0.0, 0.0, -9.81]

[[probes]]
name = "bottom"
where = { plane = { axis = "z", at = 0.05 } }

[analysis]
type = "dynamic"
method = "backward_euler"
model = "neo-hookean"
dt = 0.02
duration = 0.4
initial_velocity = [0.3, 0.0, 0.0]
{relax}

[[obstacles]]
kind = "half_space"
name = "ground"
point = [0.0, 0.0, 0.0]
normal = [0.0, 0.0, 1.0]
friction = 0.5
"#;

/// `relax_contact_nodes = false` leaves the iterates to Newton alone: the same landing and
/// slide (each step solves the same equation to the Newton tolerance 1e-8 of its reference
/// either way; 1e-6 relative leaves the 20 steps' sum of those stops a wide margin) in more
/// Newton iterations (the library's `StepNewtonOptions::relax_contact_nodes`; the 10k-DOF
/// drop of `benches/interactive_contact.rs` took 3.10 against 5.95 a step). `true` is the
/// default. A static scene refuses the key, naming it.
#[test]
fn relax_contact_nodes_takes_fewer_iterations_to_the_same_slide() {
    let run_drop = |relax: &str| {
        let text = DROP.replace("{relax}", relax);
        let scene = Scene::parse(&text, "drop", Path::new(".")).unwrap();
        let overrides = DynamicOverrides::default();
        let proceed = &mut |_, _| std::ops::ControlFlow::Continue(());
        run_dynamic_scene(&scene, &overrides, false, false, proceed).unwrap()
    };
    let default = run_drop("");
    let relaxed = run_drop("relax_contact_nodes = true");
    let plain = run_drop("relax_contact_nodes = false");
    assert_eq!(default.probes[0].last, relaxed.probes[0].last);
    assert_eq!(default.newton, relaxed.newton);
    let (a, b) = (relaxed.probes[0].last, plain.probes[0].last);
    let (difference, size) = difference_and_size(&a, &b);
    let (r, p) = (relaxed.newton.unwrap(), plain.newton.unwrap());
    println!(
        "bottom {a:?} vs {b:?}: {:.2e} relative; {} against {} Newton its",
        difference / size,
        r.total_iterations,
        p.total_iterations
    );
    // It landed (free fall takes 0.1 s) and slid.
    assert!(a[2] < -0.045 && a[0] > 0.0, "{a:?}");
    assert!(difference < 1e-6 * size, "{a:?} vs {b:?}");
    assert!(r.total_iterations < p.total_iterations, "{r:?} vs {p:?}");
    let text = SWING
        .replace("type = \"dynamic\"", "type = \"static\"")
        .replace("method = \"backward_euler\"\n", "")
        .replace("dt = 1e-2\n", "")
        .replace("duration = 0.3\n", "")
        .replace("{solver}", "relax_contact_nodes = false");
    let message = match Scene::parse(&text, "swing", Path::new(".")) {
        Err(e) => e.to_string(),
        Ok(_) => panic!("a static scene took relax_contact_nodes"),
    };
    assert!(message.contains("only a dynamic analysis"), "{message}");
    assert!(message.contains("relax_contact_nodes"), "{message}");
}
