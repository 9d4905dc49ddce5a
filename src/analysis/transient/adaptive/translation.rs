//! The body's mean motion as a second norm of the adaptive estimate, with the barrier in it:
//! what lets error-controlled backward Euler see an impact's error where the impact-aware
//! barrier stiffness makes the impact resolvable (see the "impact" sections of
//! [`adaptive`](super)'s module doc for why and what was measured).
//!
//! The mean motion is the mass-weighted mean of the free DOFs of each axis,
//! x̄_k = (w_kᵀ·x)/(w_kᵀ·1_k) with w_k = M·1_k (1_k: ones on the free DOFs of axis k; a mass
//! matrix couples a DOF only with DOFs of its own axis, so w = M·1 holds all three): for a
//! free body its centroid's displacement, velocity and acceleration (length, length/time,
//! length/time²). Backward Euler's local error of it, from the same formulas as the full
//! state's but with every force in the acceleration (the barrier's included):
//! e_ū = dt²/2·|ā⁺|, e_v̄ = dt/2·|ā⁺ − ā|·2dt/(dt₋ + dt), ā⁺ = (v̄⁺ − v̄)/dt, ā the previous
//! step's, ū and v̄ relative to their own largest values (|ū|, |v̄| of the body, not ‖u‖ over
//! every DOF). The barrier's acceleration of one landing node enters it only by that node's
//! share of the mass and the whole body's velocity is its scale, so the contact layer's local
//! modes, whose accelerations against the full state's scales asked for steps of 8e-11 s,
//! weigh what they move of the body: measured on the drop of `tests/core/adaptive_time_step.rs`
//! the control takes steps down to 3.3e-7 s (5 %) through the landing and gets through it.

use nalgebra::Vector3;

/// The estimator of the mean motion's local error (module doc).
pub(super) struct Translation {
    /// w = M·1 on the free DOFs (mass units).
    weights: Vec<f64>,
    /// The axis (0, 1, 2) of each free DOF.
    axes: Vec<usize>,
    /// Σ w over each axis's free DOFs (mass units; 1 where an axis has none, whose means are 0).
    totals: Vector3<f64>,
    /// The last accepted step's mean acceleration (length/time²).
    last: Option<Vector3<f64>>,
    /// The largest |ū| and |v̄| so far (length, length/time).
    scale: (f64, f64),
    /// The a priori amplitudes the control's scales are at least: the loads' mean
    /// acceleration |ā_f| over half the run, (|ā_f|·T²/8, |ā_f|·T/2).
    floor: (f64, f64),
    /// Accepted steps' (e_ū, e_v̄).
    local: Vec<(f64, f64)>,
}

/// One step's mean-motion estimate, kept if the step is.
pub(super) struct TranslationTrial {
    error: (f64, f64),
    acceleration: Vector3<f64>,
    scale: (f64, f64),
}

impl Translation {
    /// For free DOFs at full indices `free` (DOF 3·node + axis) with `weights` = M·1 on them,
    /// the loads' mean acceleration from `load` (force on the free DOFs) and a run of
    /// `duration` (time).
    pub(super) fn new(free: &[usize], weights: Vec<f64>, load: &[f64], duration: f64) -> Self {
        let axes: Vec<usize> = free.iter().map(|d| d % 3).collect();
        let mut totals = Vector3::zeros();
        let mut force = Vector3::zeros();
        for ((&k, w), f) in axes.iter().zip(&weights).zip(load) {
            totals[k] += w;
            force[k] += f;
        }
        totals
            .iter_mut()
            .filter(|t| **t <= 0.0)
            .for_each(|t| *t = 1.0);
        let a = force.component_div(&totals).norm();
        Translation {
            weights,
            axes,
            totals,
            last: None,
            scale: (0.0, 0.0),
            floor: (a * duration * duration / 8.0, a * duration / 2.0),
            local: Vec::new(),
        }
    }

    /// The mass-weighted mean of `x` (one value per free DOF) on each axis.
    fn mean(&self, x: &[f64]) -> Vector3<f64> {
        let mut sum = Vector3::zeros();
        for ((&k, w), x) in self.axes.iter().zip(&self.weights).zip(x) {
            sum[k] += w * x;
        }
        sum.component_div(&self.totals)
    }

    /// The local error of the backward Euler step of `dt` from (`v`) to (`u⁺`, `v⁺`), the
    /// previous step `last_dt` long (module doc).
    pub(super) fn trial(
        &self,
        (v, u_new, v_new): (&[f64], &[f64], &[f64]),
        dt: f64,
        last_dt: Option<f64>,
    ) -> TranslationTrial {
        let (v_mean, u_new, v_new) = (self.mean(v), self.mean(u_new), self.mean(v_new));
        let a_new = (v_new - v_mean) / dt;
        let spacing = match last_dt {
            Some(before) if before != dt => 2.0 * dt / (before + dt),
            _ => 1.0,
        };
        let e_u = 0.5 * dt * dt * a_new.norm();
        let e_v = self
            .last
            .map_or(0.0, |a| 0.5 * dt * (a_new - a).norm() * spacing);
        TranslationTrial {
            error: (e_u, e_v),
            acceleration: a_new,
            scale: (
                self.scale.0.max(u_new.norm()),
                self.scale.1.max(v_new.norm()),
            ),
        }
    }

    /// The relative local error the control judges: √((e_ū/S_ū)² + (e_v̄/S_v̄)²) with the scales
    /// at least the floor.
    pub(super) fn controlled(&self, trial: &TranslationTrial) -> f64 {
        let u = super::ratio(trial.error.0, trial.scale.0.max(self.floor.0));
        u.hypot(super::ratio(trial.error.1, trial.scale.1.max(self.floor.1)))
    }

    /// Keeps an accepted step's estimate.
    pub(super) fn accept(&mut self, trial: TranslationTrial) {
        self.last = Some(trial.acceleration);
        self.scale = trial.scale;
        self.local.push(trial.error);
    }

    /// The accepted steps' ρ̄ = √((e_ū/S_ū)² + (e_v̄/S_v̄)²) relative to the final scales, in
    /// order (the full state's steps give each its dt and σ for
    /// [`decayed_maximum`](super::decayed_maximum)).
    pub(super) fn relative(&self) -> impl Iterator<Item = f64> + '_ {
        let (su, sv) = self.scale;
        (self.local.iter()).map(move |(eu, ev)| super::ratio(*eu, su).hypot(super::ratio(*ev, sv)))
    }
}
