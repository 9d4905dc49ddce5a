//! Backward Euler for nonlinear force models, set up from a mesh in one call: a thin wrapper of
//! [`BackwardEuler`] with an [`InternalForce::Nonlinear`], kept for its callers. It writes no
//! set-up of its own: the system comes from [`LinearSystem::new`] (the shared
//! [`Problem`](crate::problem::Problem): DOF map, rigid-mode check, pattern, restriction), the
//! force from [`NonlinearForce::new`], the step's matrix, solver
//! and Newton solver from [`BackwardEuler::with_force`] (the implicit methods' shared parts).

use std::sync::Arc;

use nalgebra::Vector3;

use super::{
    BackwardEuler, Energy, Integrator, IntegratorHistory, IntegratorOptions, InternalForce,
    LinearSystem, MassKind, NewtonStats, NonlinearForce, Rayleigh, State, check_time_step,
};
use crate::constraints::{Constraints, DofMap};
use crate::error::{Error, Result};
use crate::linsolve::CholeskyOptions;
use crate::loads::Loads;
use crate::material::Material;
use crate::mesh::TetMesh;
use crate::model::{ForceModel, ModelElement};

/// Backward Euler with a nonlinear [`ForceModel`], lumped mass and no damping: exactly
/// [`BackwardEuler::with_force`] on the [`LinearSystem`] of the mesh (its K_ff is the tangent
/// at rest, its loads `loads` plus gravity) with [`InternalForce::Nonlinear`]. Each step solves
///
/// M·(u⁺ − u − dt·v)/dt² − f_int(u⁺) − f = 0,  v⁺ = (u⁺ − u)/dt,
///
/// by Newton's method to [`StepNewtonOptions`](super::StepNewtonOptions)'s default tolerance,
/// the tangent refilled on the fixed pattern and refactored numerically each iteration (the
/// symbolic analysis done once, on the first step); its first iteration is the linearized step
/// of Baraff & Witkin this type made before it became a wrapper. Stable at steps far above the
/// explicit limit, first-order accurate, dissipative.
pub struct NonlinearBackwardEuler {
    system: Arc<LinearSystem>,
    force: Arc<NonlinearForce>,
    dt: f64,
    options: IntegratorOptions,
    /// Built on the first step, with `options`.
    integrator: Option<BackwardEuler>,
}

impl std::fmt::Debug for NonlinearBackwardEuler {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("NonlinearBackwardEuler")
            .field("model", &self.force.name())
            .field("free_dofs", &self.system.free_count())
            .field("dt", &self.dt)
            .finish_non_exhaustive()
    }
}

impl NonlinearBackwardEuler {
    /// Sets up the method for `mesh` (4-node or 10-node tets; prescribed displacements may be non-zero), `model`, lumped mass of
    /// `material`, constant `loads` plus `gravity` (acceleration), and time step `dt`.
    ///
    /// Errors: dt not finite and > 0; constraints or loads of another mesh
    /// ([`Error::DimensionMismatch`]); constraints that leave a rigid motion free (from
    /// [`LinearSystem::new`]).
    pub fn new<E: ModelElement>(
        mesh: Arc<TetMesh<E>>,
        material: &Material,
        model: Box<dyn ForceModel>,
        constraints: &Constraints,
        loads: &Loads,
        gravity: Vector3<f64>,
        dt: f64,
    ) -> Result<Self> {
        let dt = check_time_step(dt)?;
        Error::check_len(
            "constraints DOFs",
            mesh.dof_count(),
            constraints.dof_count(),
        )?;
        Error::check_len("loads", mesh.dof_count(), loads.as_slice().len())?;
        let system = LinearSystem::new(
            &mesh,
            material,
            constraints,
            loads,
            gravity,
            MassKind::Lumped,
            Rayleigh::default(),
        )?;
        let force = Arc::new(NonlinearForce::new(mesh, model, &system)?);
        Ok(NonlinearBackwardEuler {
            system: Arc::new(system),
            force,
            dt,
            options: IntegratorOptions::default(),
            integrator: None,
        })
    }

    /// The same method with the Cholesky factorization of its step system on `options`
    /// (ordering and threads; the default is one thread, see
    /// [`IntegratorOptions::cholesky`]). The symbolic analysis runs on the first step.
    pub fn with_cholesky(mut self, options: CholeskyOptions) -> Self {
        self.options.cholesky = options;
        self.integrator = None;
        self
    }

    /// Number of free DOFs (the length of the state vectors).
    pub fn free_count(&self) -> usize {
        self.system.free_count()
    }

    /// The free/constrained DOF map.
    pub fn dofs(&self) -> &DofMap {
        self.system.dofs()
    }

    /// The system it integrates (mass, loads, DOF map; K_ff is the tangent at rest).
    pub fn system(&self) -> &Arc<LinearSystem> {
        &self.system
    }

    /// Kinetic energy ½·vᵀMv plus the model's elastic energy, minus the loads' work potential
    /// ([`Error::DimensionMismatch`] if the state is not on the free DOFs).
    pub fn energy(&self, state: &State) -> Result<f64> {
        Ok(self.energy_terms(state)?.total())
    }

    /// The terms of [`energy`](Self::energy), the loads' potential (gravity included) reported
    /// as `load_potential`.
    pub fn energy_terms(&self, state: &State) -> Result<Energy> {
        let e = self.force.energy(&self.system, state)?;
        Ok(Energy {
            gravity_potential: 0.0,
            load_potential: e.gravity_potential + e.load_potential,
            ..e
        })
    }

    /// Newton iteration counts so far (zero before the first step).
    pub fn newton_stats(&self) -> NewtonStats {
        self.integrator
            .as_ref()
            .and_then(Integrator::newton_stats)
            .unwrap_or_default()
    }

    /// Advances `state` by one step; [`Error::Diverged`] if the state stops being finite, its
    /// energy runs away (the same [`DivergenceGuard`](super::DivergenceGuard) as the linear
    /// integrators) or Newton does not converge.
    pub fn step(&mut self, state: &mut State) -> Result<()> {
        self.integrator()?.step(state)
    }

    /// What the method carries between steps (see [`Integrator::history`]): for a
    /// [`Checkpoint`](super::Checkpoint) with the state.
    pub fn history(&self) -> Result<IntegratorHistory> {
        match &self.integrator {
            Some(integrator) => integrator.history(),
            None => Ok(IntegratorHistory {
                method: "backward-euler".into(),
                ..IntegratorHistory::default()
            }),
        }
    }

    /// Continues from `state` with the `history` taken there (see [`Integrator::restore`]).
    pub fn restore(&mut self, state: &State, history: &IntegratorHistory) -> Result<()> {
        self.integrator()?.restore(state, history)
    }

    /// The wrapped integrator, built on first use with `options`.
    fn integrator(&mut self) -> Result<&mut BackwardEuler> {
        Ok(match &mut self.integrator {
            Some(integrator) => integrator,
            none => none.insert(BackwardEuler::with_force(
                Arc::clone(&self.system),
                InternalForce::Nonlinear(Arc::clone(&self.force)),
                self.dt,
                self.options,
            )?),
        })
    }
}
