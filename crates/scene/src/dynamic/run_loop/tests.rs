//! The recorder's energies against the plain formulas: ½uᵀKu and ½vᵀMv summed entry by entry
//! over the stored CSC matrices (K_ff and M_ff with its zero couplings), on 4-node and 10-node
//! tets with both masses.

use std::path::Path;

use super::*;
use tetfem::analysis::dynamics::Mass;
use tetfem::linalg::sparse::CscMatrix;

/// A 0.4 × 0.1 × 0.1 m steel bar clamped at x = 0 (`ORDER` and `MASS` replaced per case).
const BAR: &str = r#"
[mesh]
order = ORDER
[mesh.box]
max = [0.4, 0.1, 0.1]
cells = [4, 2, 2]
[material]
youngs_modulus = 200e9
poisson_ratio = 0.3
density = 7850.0
[[constraints]]
where = { plane = { axis = "x", at = 0.0 } }
[[loads]]
where = { plane = { axis = "x", at = 0.4 } }
total_force = [0.0, 0.0, -10e3]
[analysis]
type = "dynamic"
method = "newmark"
mass = "MASS"
dt = 1e-5
duration = 1e-4
"#;

/// xᵀ·A·x summed term by term over A's stored entries, and Σ|xᵢ·Aᵢⱼ·xⱼ| with the term count:
/// the reference and the size of its rounding.
fn plain_quadratic_form(a: &CscMatrix, x: &[f64]) -> (f64, f64, usize) {
    let (mut sum, mut size) = (0.0, 0.0);
    for j in 0..a.dim() {
        for k in a.col_ptr()[j]..a.col_ptr()[j + 1] {
            let term = x[a.row_idx()[k]] * a.values()[k] * x[j];
            sum += term;
            size += term.abs();
        }
    }
    (sum, size, a.nnz())
}

/// `got` against the plain sum `(reference, size, terms)` of a quadratic form halved: both
/// sum the same products in other orders (the recorder's K through its node blocks, in
/// parallel chunks), so they differ by at most the terms' count times an ulp of their
/// absolute sum (the bound of recursive summation, γₙ ≤ n·ε), halved with the form.
fn assert_close(what: &str, got: f64, (reference, size, terms): (f64, f64, usize)) {
    let bound = terms as f64 * f64::EPSILON * 0.5 * size;
    let difference = (got - 0.5 * reference).abs();
    println!(
        "{what}: {got:e} J, plain {:e} J, difference {difference:e} (bound {bound:e})",
        0.5 * reference
    );
    assert!(
        difference <= bound,
        "{what}: {got:e} vs {:e}",
        0.5 * reference
    );
    // Not a trivial state: the form is far from its rounding.
    assert!(
        0.5 * reference.abs() > 1e6 * bound,
        "{what} too small to test"
    );
}

fn recorder_energies<E: SceneElement>(text: &str) {
    let scene = Scene::parse(text, "bar.toml", Path::new(".")).unwrap();
    let Analysis::Dynamic(settings) = *scene.analysis() else {
        panic!("a dynamic scene");
    };
    let built = scene.build_as::<E>().unwrap();
    let setup = DynamicSetup::of_scene(&scene, built, &settings).unwrap();
    let run = DynamicRun {
        title: "bar".into(),
        source: "bar.toml".into(),
        method: settings.method,
        dt: TimeStep::Seconds(settings.dt),
        length: RunLength::Steps(10),
    };
    let clock = FrameClock::Steps {
        start: (0.0, 0),
        dt: settings.dt,
        every: 1,
    };
    let mut recorder = StepRecorder::new(&setup, &run, None, 10, clock, None).unwrap();
    // A state with every DOF moving, of either sign, not an eigenvector of anything.
    let n = setup.system.free_count();
    let state = State {
        displacement: (0..n)
            .map(|i| 1e-4 * (0.37 * i as f64 + 0.1).sin())
            .collect(),
        velocity: (0..n).map(|i| 0.1 * (0.53 * i as f64).cos()).collect(),
        time: 0.0,
        steps: 0,
    };
    for round in 0..2 {
        // Twice: the kept scratch must not carry anything from one record to the next.
        let energy = recorder.record((&state, None), 0.0, false).unwrap();
        let k = plain_quadratic_form(setup.system.stiffness(), &state.displacement);
        assert_close(&format!("elastic, record {round}"), energy.elastic, k);
        let m = match setup.system.mass() {
            Mass::Consistent(m) => plain_quadratic_form(m, &state.velocity),
            Mass::Lumped(d) => {
                let terms = d.iter().zip(&state.velocity).map(|(d, v)| v * d * v);
                let (sum, size) = terms.fold((0.0, 0.0), |(s, a), t| (s + t, a + t.abs()));
                (sum, size, d.len())
            }
        };
        assert_close(&format!("kinetic, record {round}"), energy.kinetic, m);
    }
}

#[test]
fn the_recorders_energies_are_half_of_the_plain_quadratic_forms() {
    for mass in ["consistent", "lumped"] {
        let text = BAR.replace("MASS", mass);
        recorder_energies::<Tet4>(&text.replace("ORDER", "1"));
        recorder_energies::<Tet10>(&text.replace("ORDER", "2"));
    }
}
