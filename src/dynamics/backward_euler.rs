//! Backward (implicit) Euler: first order, unconditionally stable, numerically dissipative.

use std::sync::Arc;

use super::{DivergenceGuard, Integrator, LinearSystem, State, check_time_step};
use crate::error::Result;
use crate::linsolve::SparseCholesky;
use crate::sparse::CscMatrix;

/// Backward Euler on the velocity, as in Baraff–Witkin:
///
/// (M + dt·C + dt²·K)·Δv = dt·(f − K·(u + dt·v) − C·v),  v ← v + Δv,  u ← u + dt·v.
///
/// With C = αM + βK the system matrix is (1 + dt·α)·M + (dt·β + dt²)·K, formed entry-wise on
/// K's pattern and factored once per time step value: the symbolic analysis is done once, a
/// change of dt only refactors numerically. A step is one product with K, one with M, and two
/// triangular solves; it allocates nothing.
#[derive(Debug)]
pub struct BackwardEuler {
    system: Arc<LinearSystem>,
    dt: f64,
    matrix: CscMatrix,
    cholesky: SparseCholesky,
    factored_for: Option<f64>,
    guard: Option<DivergenceGuard>,
    work: Vec<f64>,
    product: Vec<f64>,
    rhs: Vec<f64>,
}

impl BackwardEuler {
    /// An integrator with time step `dt` (analysis now, factorization on the first step).
    pub fn new(system: Arc<LinearSystem>, dt: f64) -> Result<Self> {
        let dt = check_time_step(dt)?;
        let matrix = system.stiffness().clone();
        let cholesky = SparseCholesky::analyze(&matrix)?;
        let n = system.free_count();
        Ok(BackwardEuler {
            system,
            dt,
            matrix,
            cholesky,
            factored_for: None,
            guard: None,
            work: vec![0.0; n],
            product: vec![0.0; n],
            rhs: vec![0.0; n],
        })
    }

    /// Forms (1 + dt·α)·M + (dt·β + dt²)·K and factors it.
    fn factor(&mut self) -> Result<()> {
        let (dt, damping) = (self.dt, self.system.damping());
        let (mass_scale, stiffness_scale) = (1.0 + dt * damping.alpha, dt * damping.beta + dt * dt);
        self.system
            .combine_into(stiffness_scale, mass_scale, &mut self.matrix)?;
        self.cholesky.factorize(&self.matrix)?;
        self.factored_for = Some(dt);
        Ok(())
    }
}

impl Integrator for BackwardEuler {
    fn step(&mut self, state: &mut State) -> Result<()> {
        let n = self.system.free_count();
        state.check_len(n)?;
        if self.factored_for != Some(self.dt) {
            self.factor()?;
        }
        if self.guard.is_none() {
            self.guard = Some(DivergenceGuard::new(
                self.system.energy_using(state, &mut self.work)?,
            ));
        }
        let (dt, damping) = (self.dt, self.system.damping());
        // rhs = dt·(f − K·(u + (dt + β)·v) − α·M·v)
        for ((w, u), v) in self
            .work
            .iter_mut()
            .zip(&state.displacement)
            .zip(&state.velocity)
        {
            *w = u + (dt + damping.beta) * v;
        }
        self.system
            .stiffness()
            .product_into(&self.work, &mut self.product);
        self.system
            .mass()
            .product_into(&state.velocity, &mut self.work);
        let f = self.system.external_load();
        for i in 0..n {
            self.rhs[i] = dt * (f[i] - self.product[i] - damping.alpha * self.work[i]);
        }
        self.cholesky.solve_in_place(&mut self.rhs)?;
        for i in 0..n {
            state.velocity[i] += self.rhs[i];
            state.displacement[i] += dt * state.velocity[i];
        }
        state.time += dt;
        state.steps += 1;
        let energy = self.system.energy_using(state, &mut self.work)?;
        match &self.guard {
            Some(guard) => guard.check(state, &energy),
            None => Ok(()),
        }
    }

    fn time_step(&self) -> f64 {
        self.dt
    }

    fn set_time_step(&mut self, dt: f64) -> Result<()> {
        self.dt = check_time_step(dt)?;
        Ok(())
    }

    fn name(&self) -> &'static str {
        "backward-euler"
    }
}
