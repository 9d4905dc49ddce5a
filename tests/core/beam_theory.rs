//! The closed-form beam references (`tetfem_fixtures::beam_theory`) that other tests and the validation
//! suite compare against, checked against values derived by hand.

use tetfem::Material;
use tetfem_fixtures::beam_theory::RectangularCantilever;
use tetfem_fixtures::cantilever::Cantilever;

/// The peer cantilever of `docs/src/quadratic.md` (`Cantilever::peer_benchmark`): L = 10, W = H = 1, E = 1e5, ν = 0.3.
fn readme_beam() -> RectangularCantilever {
    Cantilever::peer_benchmark([10, 1, 1]).beam()
}

/// Relative difference; the hand values below are exact decimals, so only the module's
/// floating-point evaluation (a handful of operations, ≤ 1e-15 relative) separates them.
fn relative(a: f64, b: f64) -> f64 {
    ((a - b) / b).abs()
}

const ROUND_OFF: f64 = 1e-14;

#[test]
fn section_properties_and_cowper_coefficient() {
    let beam = readme_beam();
    // I = W·H³/12 = 1/12, A = W·H = 1.
    assert!(relative(beam.second_moment(), 1.0 / 12.0) <= ROUND_OFF);
    assert!(relative(beam.area(), 1.0) <= ROUND_OFF);
    // Cowper: κ = 10(1+ν)/(12+11ν) = 13/15.3 at ν = 0.3.
    assert!(relative(beam.shear_coefficient(), 13.0 / 15.3) <= ROUND_OFF);
    // A non-square section: W = 2, H = 0.5 → I = 2·0.125/12, A = 1.
    let flat = RectangularCantilever {
        width: 2.0,
        height: 0.5,
        ..beam
    };
    assert!(relative(flat.second_moment(), 0.25 / 12.0) <= ROUND_OFF);
}

#[test]
fn end_load_tips_are_the_readmes_0_04_and_0_040306() {
    let beam = readme_beam();
    // δ_EB = P·L³/(3·E·I) = 1·1000 / (3·1e5/12) = 1000/25000 = 0.04.
    let eb = beam.euler_bernoulli_end_load(1.0);
    assert!(relative(eb, 0.04) <= ROUND_OFF, "Euler–Bernoulli {eb}");
    // δ_T = δ_EB + P·L/(κ·G·A) with κ = 13/15.3, G = E/(2(1+ν)) = 1e5/2.6:
    // κ·G·A = 13e5/(15.3·2.6) = 13e5/39.78, so P·L/(κGA) = 10·39.78/13e5 = 3.06e-4 exactly and
    // δ_T = 0.040306.
    let timoshenko = beam.timoshenko_end_load(1.0);
    assert!(
        relative(timoshenko, 0.040306) <= ROUND_OFF,
        "Timoshenko {timoshenko}"
    );
    // Linear in the load.
    assert!(relative(beam.timoshenko_end_load(-2.5), -2.5 * 0.040306) <= ROUND_OFF);
}

#[test]
fn uniform_load_tips_match_the_peers_gravity_table() {
    // RESULTS.md, "P1 gravity load": q = ρ·g·W·H = 1000·9.81 = 9810 N/m and
    // EB q·L⁴/(8EI) = 9810·1e4 / (8·1e5/12) = 1471.5.
    let beam = readme_beam();
    let q = 9810.0;
    let eb = beam.euler_bernoulli_uniform_load(q);
    assert!(relative(eb, 1471.5) <= ROUND_OFF, "{eb}");
    // Timoshenko adds q·L²/(2κGA) = 9810·100·39.78/(2·13e5) = 15.0093 (to 6 digits: 981000 ·
    // 39.78 / 2.6e6 = 15.009300).
    let timoshenko = beam.timoshenko_uniform_load(q);
    assert!(
        relative(timoshenko, 1471.5 + 15.0093) <= ROUND_OFF,
        "{timoshenko}"
    );
}

#[test]
fn cantilever_superposes_end_load_and_gravity() {
    // End load 1 and gravity 9.81 together: the sum of the two hand values, downward negative.
    let problem = Cantilever {
        gravity: 9.81,
        ..Cantilever::peer_benchmark([10, 1, 1])
    };
    let (eb, timoshenko) = problem.beam_theory_tip();
    assert!(relative(eb, -(0.04 + 1471.5)) <= ROUND_OFF, "{eb}");
    assert!(
        relative(timoshenko, -(0.040306 + 1471.5 + 15.0093)) <= ROUND_OFF,
        "{timoshenko}"
    );
    // The shear term uses ν through both G and κ: at ν = 0, κ = 10/12 and G = E/2, so
    // P·L/(κGA) = 10/(10/12 · 5e4) = 2.4e-4.
    let beam = RectangularCantilever {
        material: Material::new(1e5, 0.0, 1000.0).unwrap(),
        ..readme_beam()
    };
    assert!(relative(beam.timoshenko_end_load(1.0), 0.04 + 2.4e-4) <= ROUND_OFF);
}
