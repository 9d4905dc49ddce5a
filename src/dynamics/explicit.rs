//! Explicit symplectic (semi-implicit) Euler with lumped mass.

use std::sync::Arc;

use super::{DivergenceGuard, Energy, Integrator, LinearSystem, Mass, State, check_time_step};
use crate::error::{Error, Result};

/// Symplectic Euler, M·(v⁺ − v)/dt = f − K·u − C·v, then u⁺ = u + dt·v⁺: the velocity form of
/// central differences. No linear solve (the mass is lumped), one product with K per step; stable
/// only for dt < 2/ω_max ([`super::critical_time_step`]). An explicit run above the critical
/// step is allowed — the [`DivergenceGuard`] stops it with [`Error::Diverged`] once it blows up.
///
/// As in every leapfrog scheme the velocity it stores lives half a step behind the displacement
/// (v⁺ is the mean velocity over the step that produced u⁺); the velocity at the displacement's
/// time is v − dt/2·M⁻¹(K·u − f) to second order.
#[derive(Debug)]
pub struct SymplecticEuler {
    system: Arc<LinearSystem>,
    dt: f64,
    inverse_mass: Vec<f64>,
    guard: Option<DivergenceGuard>,
    work: Vec<f64>,
    product: Vec<f64>,
}

impl SymplecticEuler {
    /// An integrator with time step `dt`; the system must have lumped mass.
    pub fn new(system: Arc<LinearSystem>, dt: f64) -> Result<Self> {
        let dt = check_time_step(dt)?;
        let inverse_mass = match system.mass() {
            Mass::Lumped(m) => m.iter().map(|m| 1.0 / m).collect(),
            Mass::Consistent(_) => {
                return Err(Error::invalid_parameter(
                    "mass",
                    "consistent",
                    "the explicit method needs lumped mass (a consistent mass would need a solve per step)",
                ));
            }
        };
        let n = system.free_count();
        Ok(SymplecticEuler {
            system,
            dt,
            inverse_mass,
            guard: None,
            work: vec![0.0; n],
            product: vec![0.0; n],
        })
    }
}

impl Integrator for SymplecticEuler {
    fn step(&mut self, state: &mut State) -> Result<()> {
        let n = self.system.free_count();
        state.check_len(n)?;
        let (dt, damping) = (self.dt, self.system.damping());
        let f = self.system.external_load();
        // K·u (and K·(u + β·v) with stiffness damping); K·u also gives this state's elastic
        // energy, so the guard costs no extra product without β.
        self.system
            .stiffness()
            .product_into(&state.displacement, &mut self.product);
        let energy = Energy {
            kinetic: 0.5
                * state
                    .velocity
                    .iter()
                    .zip(&self.inverse_mass)
                    .map(|(v, w)| v * v / w)
                    .sum::<f64>(),
            elastic: 0.5
                * state
                    .displacement
                    .iter()
                    .zip(&self.product)
                    .map(|(u, k)| u * k)
                    .sum::<f64>(),
            ..self.system.energy_potentials(state)?
        };
        match &self.guard {
            Some(guard) => guard.check(state, &energy)?,
            None => self.guard = Some(DivergenceGuard::new(energy)),
        }
        if damping.beta != 0.0 {
            self.system
                .stiffness()
                .product_into(&state.velocity, &mut self.work);
            for (p, kv) in self.product.iter_mut().zip(&self.work) {
                *p += damping.beta * kv;
            }
        }
        for i in 0..n {
            let acceleration =
                (f[i] - self.product[i]) * self.inverse_mass[i] - damping.alpha * state.velocity[i];
            state.velocity[i] += dt * acceleration;
            state.displacement[i] += dt * state.velocity[i];
        }
        state.time += dt;
        state.steps += 1;
        state.ensure_finite("; is dt above the critical step?")
    }

    fn time_step(&self) -> f64 {
        self.dt
    }

    fn set_time_step(&mut self, dt: f64) -> Result<()> {
        self.dt = check_time_step(dt)?;
        Ok(())
    }

    fn name(&self) -> &'static str {
        "explicit"
    }
}
