//! Backward Euler for nonlinear force models: one linearized solve per step (Baraff & Witkin).

use std::sync::Arc;

use nalgebra::Vector3;

use super::{DivergenceGuard, Energy, State, check_time_step};
use crate::assembly::{Assembler, lumped_mass};
use crate::constraints::{Constraints, DofMap, Restriction, ensure_held};
use crate::error::{Error, Result};
use crate::linsolve::{CholeskyOptions, SparseCholesky};
use crate::loads::Loads;
use crate::material::Material;
use crate::mesh::TetMesh;
use crate::model::ForceModel;
use crate::model::assemble::{internal_force, refill_tangent};
use crate::sparse::CscMatrix;

/// Backward Euler with a nonlinear [`ForceModel`], linearized once per step:
///
/// (M + dt²·K_t(u))·Δv = dt·(f + f_int(u) − dt·K_t(u)·v),  v ← v + Δv,  u ← u + dt·v,
///
/// with lumped mass and K_t the tangent with every element projected onto the PSD cone (so the
/// system is SPD at any deformation). The tangent is refilled on the fixed pattern each step and
/// refactored numerically; the symbolic analysis is done once. Like the linear method it is
/// stable at steps far above the explicit limit and dissipates energy; being one Newton step per
/// time step, it is first-order accurate.
pub struct NonlinearBackwardEuler {
    mesh: Arc<TetMesh>,
    model: Box<dyn ForceModel>,
    assembler: Assembler,
    dofs: DofMap,
    restriction: Restriction,
    mass: Vec<f64>,
    external: Vec<f64>,
    tangent: CscMatrix,
    system: CscMatrix,
    /// Analysed on the first step, with `cholesky_options`.
    cholesky: Option<SparseCholesky>,
    cholesky_options: CholeskyOptions,
    dt: f64,
    /// Set on the first step from the energy of the state it starts from.
    guard: Option<DivergenceGuard>,
}

impl std::fmt::Debug for NonlinearBackwardEuler {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("NonlinearBackwardEuler")
            .field("model", &self.model.name())
            .field("free_dofs", &self.dofs.free_count())
            .field("dt", &self.dt)
            .finish_non_exhaustive()
    }
}

impl NonlinearBackwardEuler {
    /// Sets up the method for `mesh` (fixed DOFs must be zero-valued), `model`, lumped mass of
    /// `material`, constant `loads` plus `gravity` (acceleration), and time step `dt`.
    pub fn new(
        mesh: Arc<TetMesh>,
        material: &Material,
        model: Box<dyn ForceModel>,
        constraints: &Constraints,
        loads: &Loads,
        gravity: Vector3<f64>,
        dt: f64,
    ) -> Result<Self> {
        let dt = check_time_step(dt)?;
        let dofs = DofMap::new(constraints);
        if dofs.prescribed().iter().any(|&v| v != 0.0) {
            return Err(Error::invalid_parameter(
                "constraints",
                "non-zero prescribed displacement",
                "the nonlinear backward Euler supports fixed (zero) constraints only",
            ));
        }
        ensure_held(&mesh, &mesh.face_topology()?, &dofs)?;
        let assembler = Assembler::new(&mesh);
        let restriction = dofs.restriction(assembler.pattern())?;
        let mut all = loads.clone();
        all.add_gravity(&mesh, material, gravity)?;
        let tangent = CscMatrix::zeros(Arc::clone(assembler.pattern()))?;
        let system = CscMatrix::zeros(Arc::clone(restriction.pattern()))?;
        Ok(NonlinearBackwardEuler {
            mass: dofs.restrict(&lumped_mass(&mesh, material))?,
            external: all.as_slice().to_vec(),
            mesh,
            model,
            assembler,
            dofs,
            restriction,
            tangent,
            system,
            cholesky: None,
            cholesky_options: CholeskyOptions::default(),
            dt,
            guard: None,
        })
    }

    /// The same method with the Cholesky factorization of its step system on `options`
    /// (ordering and threads; the default is one thread, see
    /// [`IntegratorOptions::cholesky`](super::IntegratorOptions::cholesky)). The symbolic
    /// analysis runs on the first step.
    pub fn with_cholesky(mut self, options: CholeskyOptions) -> Self {
        self.cholesky_options = options;
        self.cholesky = None;
        self
    }

    /// Number of free DOFs (the length of the state vectors).
    pub fn free_count(&self) -> usize {
        self.dofs.free_count()
    }

    /// The free/constrained DOF map.
    pub fn dofs(&self) -> &DofMap {
        &self.dofs
    }

    /// Kinetic energy ½·vᵀMv plus the model's elastic energy, minus the loads' work potential
    /// ([`Error::DimensionMismatch`] if the state is not on the free DOFs).
    pub fn energy(&self, state: &State) -> Result<f64> {
        Ok(self.energy_terms(state)?.total())
    }

    /// The terms of [`energy`](Self::energy), the loads' potential (gravity included) reported
    /// as `load_potential`.
    pub fn energy_terms(&self, state: &State) -> Result<Energy> {
        state.check_len(self.free_count())?;
        let u = self.dofs.expand(&state.displacement)?;
        let kinetic: f64 = 0.5
            * state
                .velocity
                .iter()
                .zip(&self.mass)
                .map(|(v, m)| m * v * v)
                .sum::<f64>();
        let elastic = crate::model::assemble::energy(&self.mesh, self.model.as_ref(), &u)?;
        let potential: f64 = -self
            .external
            .iter()
            .zip(&u)
            .map(|(f, u)| f * u)
            .sum::<f64>();
        Ok(Energy {
            kinetic,
            elastic,
            gravity_potential: 0.0,
            load_potential: potential,
        })
    }

    /// Advances `state` by one step; [`Error::Diverged`] if the state stops being finite or its
    /// energy runs away (the same [`DivergenceGuard`] as the linear integrators).
    pub fn step(&mut self, state: &mut State) -> Result<()> {
        let n = self.dofs.free_count();
        state.check_len(n)?;
        if self.guard.is_none() {
            self.guard = Some(DivergenceGuard::new(self.energy_terms(state)?));
        }
        let dt = self.dt;
        let u = self.dofs.expand(&state.displacement)?;
        refill_tangent(
            &self.mesh,
            &self.assembler,
            self.model.as_ref(),
            &u,
            true,
            &mut self.tangent,
        )?;
        self.restriction
            .restrict_into(&self.tangent, &mut self.system)?;
        // rhs = dt·(f + f_int − dt·K_t·v), computed before K_t is turned into M + dt²K_t.
        let kv = self.system.mul(&state.velocity)?;
        let forces = internal_force(&self.mesh, self.model.as_ref(), &u)?;
        let mut rhs: Vec<f64> = self
            .dofs
            .free_dofs()
            .iter()
            .zip(&kv)
            .map(|(&dof, kv)| dt * (self.external[dof] + forces[dof] - dt * kv))
            .collect();
        for value in self.system.values_mut() {
            *value *= dt * dt;
        }
        self.system.add_diagonal(1.0, &self.mass)?;
        let cholesky = match &mut self.cholesky {
            Some(cholesky) => cholesky,
            none => none.insert(SparseCholesky::analyze_with(
                &self.system,
                self.cholesky_options,
            )?),
        };
        cholesky.factorize(&self.system)?;
        cholesky.solve_in_place(&mut rhs)?;
        for i in 0..n {
            state.velocity[i] += rhs[i];
            state.displacement[i] += dt * state.velocity[i];
        }
        state.time += dt;
        state.steps += 1;
        state.ensure_finite("")?;
        match &self.guard {
            Some(guard) => guard.check(state, &self.energy_terms(state)?),
            None => Ok(()),
        }
    }
}
