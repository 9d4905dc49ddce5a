//! Where a contact step's Newton iterations start, and the continuation of friction's smoothing
//! distance when they fail.
//!
//! IPC's friction (see [`crate::contact::friction`]) is Coulomb's force smoothed over a slip of
//! ε = ε_v·dt: its curvature along the slip is 2·μ·λ/ε at rest and falls to zero at ε. With
//! ε a few micrometres, Newton's quadratic model of a node that slips by millimetres is right
//! only within ε of sticking: a node whose solution is near the stick–slip transition is
//! overshot from one side to the other, and the line search takes steps of a few percent. A
//! block landing on a conveyor (every node starting the step at the belt's full slip, 2 mm,
//! against ε = 7 µm) needed 25 iterations of 1/16 steps and failed; a block landing on a still
//! floor starts where it sticks (zero slip) and converges in 7.
//!
//! Two remedies. A contact step starts from the integrator's prediction where the path there is
//! collision-free and its Φ lower, or its residual trusted (`start_from_prediction`): a node
//! riding a belt then starts at zero slip. And a step whose Newton fails from a start slipping
//! by more than [`GROWTH`]·ε is solved again from that start, first with ε widened to the
//! start's slip, where the model is right, then with ε shrunk by [`GROWTH`] per stage, each
//! stage starting from the last one's solution, down to the step's own ε: the last stage solves
//! the step's equation itself, so the solution is the step's. A step that converges at once is
//! not touched by the continuation.

use super::{NewtonSolver, StepEquation};
use crate::analysis::dynamics::LinearSystem;
use crate::base::error::{Error, Result};
use crate::linear_solver::LinearSolver;
use crate::sparse::CscMatrix;

/// The factor between two stages' smoothing distances: the solution of one stage is within
/// the next one's quadratic range for the nodes that change regime.
const GROWTH: f64 = 8.0;

impl NewtonSolver {
    /// The Newton iterations of [`solve`](Self::solve), friction lagged already: from the
    /// prediction where it is better, at the lagged smoothing distance, and again through the
    /// continuation of the module doc when that fails from a start slipping by more than
    /// [`GROWTH`]·ε. Counts one step whatever the stages.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn iterate(
        &mut self,
        system: &LinearSystem,
        equation: &StepEquation,
        matrix: &mut CscMatrix,
        solver: &mut LinearSolver,
        u_new: &mut [f64],
        step: usize,
        time: f64,
    ) -> Result<usize> {
        self.residual_at_start = false;
        self.start_from_prediction(system, equation, u_new)?;
        let Some((epsilon, slip)) = self.force.friction_smoothing_and_slip(u_new)? else {
            return self.iterate_at_smoothing(system, equation, matrix, solver, u_new, step, time);
        };
        let start = u_new.to_vec();
        // A first try that stalls (its line searches cut every step short) gives way to the
        // continuation at once instead of spending its whole budget: on the 10k-DOF block
        // thrown onto frictional ground the landing's first try gave up after 12 iterations
        // instead of 25 (each a CG that fell back to a factorization); 30 steps ran 90 →
        // 76 factorizations, 0.59 → 0.68–0.80 steps/s side by side at load 5.
        self.abort_on_stall = slip > GROWTH * epsilon;
        let first_try =
            self.iterate_at_smoothing(system, equation, matrix, solver, u_new, step, time);
        self.abort_on_stall = false;
        match first_try {
            Err(Error::Diverged { .. }) if slip > GROWTH * epsilon => {
                u_new.copy_from_slice(&start);
            }
            solved => return solved,
        }
        let mut stage = epsilon;
        while stage * GROWTH < slip {
            stage *= GROWTH;
        }
        let (steps_before, floor) = (self.stats.steps, self.reference_floor);
        let mut iterations = 0;
        let solved = loop {
            self.force.set_friction_smoothing(stage);
            let result =
                self.iterate_at_smoothing(system, equation, matrix, solver, u_new, step, time);
            match result {
                Ok(n) => iterations += n,
                Err(e) => break Err(e),
            }
            if stage == epsilon {
                break Ok(iterations);
            }
            // Later stages start near their solution: converge relative to the first one's
            // forces, not to what the change of ε left.
            self.reference_floor = self.reference_floor.max(self.last_reference);
            stage /= GROWTH;
            if stage < GROWTH.sqrt() * epsilon {
                stage = epsilon;
            }
        };
        self.force.set_friction_smoothing(epsilon);
        self.reference_floor = floor;
        self.stats.steps = steps_before + 1;
        self.stats.last_step = iterations;
        self.stats.max_per_step = self.stats.max_per_step.max(iterations);
        solved
    }

    /// With contact, starts a step's iterations from the integrator's prediction
    /// ([`StepEquation::first_iterate`]) instead of the step's start when the straight path
    /// between them meets no obstacle and the prediction's Φ is lower, or its residual is
    /// trusted as without contact (`guess_is_trusted`: within the step's own forces, or Φ rising
    /// from it back toward the start), then without the start's pass over the tets: on the 10k-DOF
    /// block resting on the ground of `benches/interactive_contact.rs` a calm step made three
    /// such passes and makes two (the force passes' share of its time 27 % → 21 %), the same
    /// iterations and the trajectory as far from the tight one (1.3e-5 of the largest
    /// displacement). A node sliding or sticking on a moving obstacle then starts at its own
    /// speed, not at rest relative to the world (a slip of the belt's whole move). Only at the
    /// step's start: a carried or staged iterate is not where the prediction was made from.
    fn start_from_prediction(
        &mut self,
        system: &LinearSystem,
        equation: &StepEquation,
        u_new: &mut [f64],
    ) -> Result<()> {
        let Some(guess) = equation.first_iterate else {
            return Ok(());
        };
        if self.force.contact().is_none() || u_new != equation.start {
            return Ok(());
        }
        let path: Vec<f64> = guess.iter().zip(u_new.iter()).map(|(g, u)| g - u).collect();
        if self.force.contact_step_limit(u_new, &path)? < 1.0 {
            return Ok(());
        }
        // A guess within the step's own forces, or downhill of the start, is taken without the
        // start's pass (`guess_is_trusted`, as without contact).
        self.residual_into(system, equation, guess, false)?;
        if self.guess_is_trusted(system, equation) {
            u_new.copy_from_slice(guess);
            self.residual_at_start = true;
            return Ok(());
        }
        std::mem::swap(&mut self.residual, &mut self.trial_residual);
        std::mem::swap(&mut self.residual_energy, &mut self.trial_energy);
        self.residual_into(system, equation, u_new, false)?;
        let at_start = self.potential(system, equation, u_new, self.residual_energy)?;
        if self.potential(system, equation, guess, self.trial_energy)? < at_start {
            u_new.copy_from_slice(guess);
            std::mem::swap(&mut self.residual, &mut self.trial_residual);
            std::mem::swap(&mut self.residual_energy, &mut self.trial_energy);
        }
        // The residual at the iterate the iterations begin from is evaluated (see
        // `residual_at_start`).
        self.residual_at_start = true;
        Ok(())
    }
}
