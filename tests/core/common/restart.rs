//! Comparing a resumed run's bookkeeping with an uninterrupted one's.

use tetfem::analysis::dynamics::{IntegratorHistory, NewtonStats};

/// Asserts `resumed` and `straight` Newton counts are the same run's: every count equal except
/// `factorizations`, which may be one higher. A factor cannot be checkpointed, so a resumed
/// rest-preconditioned Newton factors the rest matrix once more than the run that kept it (the
/// displacements and velocities are still the same bits: each step starts from the rest
/// factor).
pub fn assert_same_newton(resumed: Option<NewtonStats>, straight: Option<NewtonStats>, case: &str) {
    match (resumed, straight) {
        (Some(r), Some(s)) => {
            assert!(
                r.factorizations == s.factorizations || r.factorizations == s.factorizations + 1,
                "{case}: factorizations {} resumed against {} straight",
                r.factorizations,
                s.factorizations
            );
            let counts = |n: NewtonStats| {
                [
                    n.steps,
                    n.total_iterations,
                    n.max_per_step,
                    n.last_step,
                    n.cg_iterations,
                    n.fallbacks,
                ]
            };
            assert_eq!(counts(r), counts(s), "{case}: Newton counts");
        }
        (r, s) => assert_eq!(r.is_some(), s.is_some(), "{case}: Newton counts present"),
    }
}

/// Asserts two integrator histories are the same run's (see [`assert_same_newton`]).
pub fn assert_same_history(resumed: &IntegratorHistory, straight: &IntegratorHistory, case: &str) {
    assert_eq!(resumed.method, straight.method, "{case}: method");
    assert_eq!(resumed.guard, straight.guard, "{case}: divergence guard");
    assert_eq!(
        resumed.acceleration, straight.acceleration,
        "{case}: Newmark's acceleration"
    );
    assert_eq!(
        resumed.previous_acceleration, straight.previous_acceleration,
        "{case}: backward Euler's previous acceleration"
    );
    assert_same_newton(resumed.newton, straight.newton, case);
}
