//! The internal-force seam of the integrators: which elastic force law a time step uses.
//!
//! Every integrator takes an [`InternalForce`]. [`InternalForce::Linear`] is f_int = −K_ff·u with
//! the [`LinearSystem`]'s constant K_ff: the integrators then run their linear code unchanged
//! (one factorization per dt, the 3×3 node-block products, the fused step loops), so the linear
//! results are the same bits as before the seam existed. [`InternalForce::Nonlinear`] is a
//! [`ForceModel`] (corotational, Neo-Hookean, …) for every tet, or one per material
//! ([`ModelMap`]): f_int(u) = Σₑ fₑ(X + u), each tet with its own model, and the tangent
//! K_T(u) = −∂f_int/∂u on K_ff's own pattern, so the implicit methods refactor numerically on
//! the symbolic analysis they made for K_ff.

use std::sync::Arc;

use super::{Energy, LinearSystem, Mass, State};
use crate::analysis::problem::Problem;
use crate::base::error::{Error, Result};
use crate::base::warning::Warning;
use crate::bc::constraints::Restriction;
use crate::contact::surface::SurfaceContact;
use crate::contact::{Contact, ContactParameters, FrictionLag, GAP_ERROR_WARNING};
use crate::fe::assembly::Assembler;
use crate::fe::element::Tet;
use crate::mesh::TetMesh;
use crate::model::assemble::{energy_kept, internal_force, refill_tangent_kept};
use crate::model::{ForceModel, ModelElement, ModelKind, ModelMap, TetModels};
use crate::sparse::CscMatrix;

/// What the contact barrier did over a dynamic run ([`NonlinearForce::barrier_record`]): a
/// dynamic run keeps the barrier's reach d̂ (a moving body has no equilibrium to continue d̂
/// to, as a static solve does), so its contact forces carry the barrier's gap error, measured
/// at every accepted step: ε = (Σᵢλᵢdᵢ/Σᵢλᵢ)/max|u|, the pushed nodes' force-weighted gap over
/// the largest displacement ([`Contact::barrier_gaps`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BarrierRecord {
    /// d̂ (length) and κ (pressure) of the run's barrier.
    pub parameters: ContactParameters,
    /// The largest gap error over the accepted steps (dimensionless).
    pub gap_error_max: f64,
    /// The gap error of the last accepted step (dimensionless).
    pub gap_error_final: f64,
    /// The smallest signed distance of a contact node to an obstacle over the accepted steps
    /// (length; +∞ before the first).
    pub smallest_step_gap: f64,
    /// The same over every accepted Newton iterate of every step, rejected steps of an
    /// error-controlled run included (length; +∞ when no iterate was taken: the explicit
    /// method solves nothing).
    pub smallest_iterate_gap: f64,
    /// Accepted steps measured.
    pub steps: usize,
    /// The largest total normal force Σλ of the barrier over the accepted steps (force units).
    pub peak_force: f64,
    /// The largest ε·Σλ over the accepted steps (force units): the force error the rule
    /// bounds, over [`FORCE_ERROR_PER_GAP_ERROR`](crate::contact::FORCE_ERROR_PER_GAP_ERROR).
    pub peak_gap_force: f64,
    /// The barrier stiffness in force after the last accepted step (Pa/m): κ, or with an
    /// impact fraction the largest of the nodes' κᵢ that [`Contact::update_impact_stiffness`]
    /// keeps between steps (a resumed run takes each node's own from the checkpoint's
    /// [`IMPACT_STIFFNESS_RECORD`](super::IMPACT_STIFFNESS_RECORD)).
    pub stiffness_in_force: f64,
}

impl BarrierRecord {
    /// The record of a run under `parameters` before its first step.
    pub fn start(parameters: ContactParameters) -> Self {
        BarrierRecord {
            parameters,
            gap_error_max: 0.0,
            gap_error_final: 0.0,
            smallest_step_gap: f64::INFINITY,
            smallest_iterate_gap: f64::INFINITY,
            steps: 0,
            peak_force: 0.0,
            peak_gap_force: 0.0,
            stiffness_in_force: parameters.stiffness,
        }
    }

    fn take_step(&mut self, gaps: &crate::contact::BarrierGaps, stiffness: f64) {
        self.stiffness_in_force = stiffness;
        self.gap_error_max = self.gap_error_max.max(gaps.gap_error);
        self.gap_error_final = gaps.gap_error;
        self.smallest_step_gap = self.smallest_step_gap.min(gaps.smallest_gap);
        self.peak_force = self.peak_force.max(gaps.pushed_force);
        self.peak_gap_force = self.peak_gap_force.max(gaps.gap_error * gaps.pushed_force);
        self.steps += 1;
    }

    /// The gap error the warning judges: max(ε·Σλ)/max(Σλ) over the accepted steps — each
    /// step's gap error weighted by its contact force relative to the run's largest, so that
    /// the force error it bounds is relative to the largest contact force of the run. (Early in
    /// a contact, when the body has barely moved, ε is large but its force is small: the
    /// shipped sphere press read ε = 0.24 at its first touching steps.) 0 when the barrier
    /// pushed nothing.
    pub fn weighted_gap_error(&self) -> f64 {
        match self.peak_force > 0.0 {
            true => self.peak_gap_force / self.peak_force,
            false => 0.0,
        }
    }

    /// The smallest gap over every state measured, steps and iterates (length; +∞ when none).
    pub fn smallest_gap(&self) -> f64 {
        self.smallest_step_gap.min(self.smallest_iterate_gap)
    }

    /// [`Warning::BarrierGapError`] when the force-weighted gap error
    /// ([`weighted_gap_error`](Self::weighted_gap_error)) passed [`GAP_ERROR_WARNING`], where
    /// the measured relation puts the contact force's error above 1 % of the run's largest.
    pub fn warning(&self) -> Option<Warning> {
        let gap_error = self.weighted_gap_error();
        (gap_error > GAP_ERROR_WARNING).then_some(Warning::BarrierGapError {
            gap_error,
            limit: GAP_ERROR_WARNING,
            force_error_per_gap_error: crate::contact::FORCE_ERROR_PER_GAP_ERROR,
            activation_distance: self.parameters.activation_distance,
        })
    }

    /// The record as numbers, for a checkpoint's records: d̂, κ, the largest and last gap
    /// errors, the smallest step and iterate gaps, the step count (as f64: exact below 2⁵³),
    /// the peak force and the peak ε·Σλ; then κ in force, only where it differs from κ (an
    /// impact fraction raised it), so that files of runs without one are unchanged.
    pub fn to_values(&self) -> Vec<f64> {
        let mut values = vec![
            self.parameters.activation_distance,
            self.parameters.stiffness,
            self.gap_error_max,
            self.gap_error_final,
            self.smallest_step_gap,
            self.smallest_iterate_gap,
            self.steps as f64,
            self.peak_force,
            self.peak_gap_force,
        ];
        // κ in force only where it is not κ: the files of runs without an impact fraction
        // stay as they were.
        if self.stiffness_in_force != self.parameters.stiffness {
            values.push(self.stiffness_in_force);
        }
        values
    }

    /// How many numbers [`to_values`](Self::to_values) gives at least (one more with κ in force).
    pub const VALUES: usize = 9;

    /// The record of [`to_values`](Self::to_values)'s numbers ([`VALUES`](Self::VALUES) of them,
    /// κ in force then κ, or one more); `None` for another count.
    pub fn from_values(values: &[f64]) -> Option<Self> {
        let (values, in_force) = match values.len() {
            n if n == Self::VALUES + 1 => (&values[..Self::VALUES], Some(values[Self::VALUES])),
            _ => (values, None),
        };
        let &[
            d_hat,
            kappa,
            max,
            last,
            step_gap,
            iterate_gap,
            steps,
            peak,
            peak_gap,
        ] = values
        else {
            return None;
        };
        Some(BarrierRecord {
            parameters: ContactParameters {
                activation_distance: d_hat,
                stiffness: kappa,
                impact_fraction: None,
            },
            gap_error_max: max,
            gap_error_final: last,
            smallest_step_gap: step_gap,
            smallest_iterate_gap: iterate_gap,
            steps: steps as usize,
            peak_force: peak,
            peak_gap_force: peak_gap,
            stiffness_in_force: in_force.unwrap_or(kappa),
        })
    }
}

/// The elastic force law of a dynamic run.
#[derive(Clone, Default)]
pub enum InternalForce {
    /// f_int = −K_ff·u with the system's constant stiffness: every linear fast path.
    #[default]
    Linear,
    /// A nonlinear [`ForceModel`] (one for every tet, or one per material) on the system's
    /// mesh (see [`NonlinearForce`]).
    Nonlinear(Arc<NonlinearForce>),
}

impl std::fmt::Debug for InternalForce {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            InternalForce::Linear => f.write_str("Linear"),
            InternalForce::Nonlinear(n) => write!(f, "Nonlinear({})", n.name),
        }
    }
}

impl InternalForce {
    /// The force of `model` on `mesh` for `system` (see [`NonlinearForce::new`]); the
    /// linear model's name (`linear`) gives [`InternalForce::Linear`], so that a linear run
    /// takes the fast path whatever the caller asked through.
    pub fn of_model<E: ModelElement>(
        mesh: Arc<TetMesh<E>>,
        model: Box<dyn ForceModel>,
        system: &LinearSystem,
    ) -> Result<Self> {
        if model.name() == "linear" {
            return Ok(InternalForce::Linear);
        }
        Ok(InternalForce::Nonlinear(Arc::new(NonlinearForce::new(
            mesh, model, system,
        )?)))
    }

    /// The force of one model per material (`models`, e.g. [`ModelKind::build_map`] of the
    /// system's [`MaterialMap`](crate::fe::materials::MaterialMap)) on `mesh` for `system` (see
    /// [`NonlinearForce::with_models`]); a map whose every material takes the linear model
    /// gives [`InternalForce::Linear`],
    /// the fast path on the system's K_ff (which holds each tet's own material when the system
    /// was built from the same map).
    pub fn of_models<E: ModelElement>(
        mesh: Arc<TetMesh<E>>,
        models: ModelMap,
        system: &LinearSystem,
    ) -> Result<Self> {
        if models.is_linear() {
            return Ok(InternalForce::Linear);
        }
        Ok(InternalForce::Nonlinear(Arc::new(
            NonlinearForce::with_models(mesh, models, system)?,
        )))
    }

    /// The model's name: `linear`, `corotational`, `neo-hookean`.
    pub fn name(&self) -> &'static str {
        match self {
            InternalForce::Linear => "linear",
            InternalForce::Nonlinear(n) => n.name,
        }
    }

    /// Whether this is a nonlinear model (the implicit methods then iterate Newton per step).
    pub fn is_nonlinear(&self) -> bool {
        matches!(self, InternalForce::Nonlinear(_))
    }

    /// The energies of `state` under this force law: for the linear one exactly
    /// [`LinearSystem::energy`] (elastic ½uᵀK_ff·u), for a nonlinear one the model's elastic
    /// energy Σₑ Eₑ(X + u) (energy units) with the same kinetic term and load potentials.
    pub fn energy(&self, system: &LinearSystem, state: &State) -> Result<Energy> {
        match self {
            InternalForce::Linear => system.energy(state),
            InternalForce::Nonlinear(n) => n.energy(system, state),
        }
    }

    /// [`energy`](Self::energy) with caller-owned scratch (from
    /// [`LinearSystem::energy_workspace`]), for a caller that takes the energies every step: the
    /// linear law's are [`LinearSystem::energy_with`], a nonlinear one's kinetic term is
    /// [`LinearSystem::kinetic_energy_with`]. The same values as [`energy`](Self::energy).
    /// [`Error::DimensionMismatch`] if the state or `work` is not of `system`'s free DOFs.
    pub fn energy_with(
        &self,
        system: &LinearSystem,
        state: &State,
        work: &mut super::EnergyWorkspace,
    ) -> Result<Energy> {
        match self {
            InternalForce::Linear => system.energy_with(state, work),
            InternalForce::Nonlinear(n) => {
                state.check_len(n.free_count())?;
                Ok(Energy {
                    kinetic: system.kinetic_energy_with(&state.velocity, work)?,
                    elastic: n.elastic_energy(&state.displacement)?,
                    ..system.model_energy_potentials(state)?
                })
            }
        }
    }
}

/// A nonlinear force law on the free DOFs of a [`LinearSystem`]: one [`ForceModel`] for every
/// tet, or one per material ([`ModelMap`]), each tet's force and tangent from its own model.
///
/// The system supplies the mass, damping, loads and DOF map. Its K_ff is the model's tangent at
/// rest (for the corotational and Neo-Hookean models it equals the linear stiffness there): it
/// gives the explicit critical step and the symbolic analysis the implicit methods refactor on;
/// the stiffness part of Rayleigh damping uses the tangent at the start of each step instead.
///
/// Prescribed displacements may be non-zero and may move in time: the force is evaluated on the
/// full displacement, the constrained DOFs at u_c(t) of the time last set
/// ([`set_time`](Self::set_time)), and the step equations take the system's loads without the
/// coupling −K_fc·u_c that the linear system folds into them
/// ([`LinearSystem::model_load_at`]), so it is not counted twice.
pub struct NonlinearForce {
    /// The mesh, of 4-node or 10-node tets (its element type erased: see [`ForceMesh`]).
    mesh: Arc<dyn ForceMesh>,
    /// The model of each tet: a boxed [`ForceModel`] or a [`ModelMap`].
    models: Box<dyn TetModels + Send>,
    /// The models' name (`corotational`, `neo-hookean`, …).
    name: &'static str,
    assembler: Assembler,
    restriction: Restriction,
    /// K_ff's pattern (the `Arc` of the system's stiffness): the tangents are handed out on it.
    pattern: Arc<faer::sparse::SymbolicSparseColMat<usize>>,
    free_dofs: Vec<usize>,
    /// The full displacement of the constrained DOFs (length), at the time last set
    /// ([`set_time`](Self::set_time)); zero on the free DOFs' places.
    prescribed: std::sync::RwLock<Vec<f64>>,
    /// Contact with rigid obstacles, when given ([`with_contact`](Self::with_contact)).
    contact: Option<Contact>,
    /// Friction's data lagged at the current step's start ([`begin_step`](Self::begin_step)).
    friction: std::sync::Mutex<Option<FrictionLag>>,
    /// The friction force on each obstacle over the last step
    /// ([`friction_forces`](Self::friction_forces)).
    last_friction_forces: std::sync::Mutex<Option<Vec<nalgebra::Vector3<f64>>>>,
    /// What the barrier did over the run so far, with contact ([`barrier_record`](Self::barrier_record)).
    barrier: std::sync::Mutex<Option<BarrierRecord>>,
    /// Body–body and self-contact of the boundary surface, when given
    /// ([`with_surface_contact`](Self::with_surface_contact)).
    surface: Option<SurfaceContact>,
    /// The free index of each full DOF (`usize::MAX` where constrained).
    free_index: Vec<usize>,
    /// Each mesh node's lumped mass (mass units) for the impact-aware barrier stiffness
    /// ([`begin_impact_step`](Self::begin_impact_step)): formed once, at the first step that
    /// needs it, from the mass of the system this force was built for (it does not change in
    /// a run).
    node_masses: std::sync::OnceLock<Vec<f64>>,
    /// Scratch of [`begin_impact_step`](Self::begin_impact_step): the full displacement and
    /// velocity of the step's start (kept, not allocated per step).
    impact_scratch: std::sync::Mutex<(Vec<f64>, Vec<f64>)>,
}

impl NonlinearForce {
    /// The force of `model` on `mesh` for `system`, which must have been built on `mesh`.
    ///
    /// Errors ([`Error::InvalidParameter`]): the system's DOF map is not of this mesh, or the
    /// restricted assembly pattern
    /// is not the system's K_ff pattern (a system from [`LinearSystem::from_parts`] with
    /// another stiffness).
    pub fn new<E: ModelElement>(
        mesh: Arc<TetMesh<E>>,
        model: Box<dyn ForceModel>,
        system: &LinearSystem,
    ) -> Result<Self> {
        let name = model.name();
        Self::of_tet_models(mesh, Box::new(model), name, system)
    }

    /// The force of one model per material (`models`) on `mesh` for `system`: each tet's force
    /// and tangent from the model of its material, so regions of different stiffness (and
    /// density, through the system's mass) move together.
    ///
    /// Errors: those of [`new`](Self::new), and [`Error::InvalidParameter`] when the map's
    /// material map does not give a material to each of the mesh's tets (naming both counts).
    pub fn with_models<E: ModelElement>(
        mesh: Arc<TetMesh<E>>,
        models: ModelMap,
        system: &LinearSystem,
    ) -> Result<Self> {
        models.check_tet_count(&mesh)?;
        let name = models.name();
        Self::of_tet_models(mesh, Box::new(models), name, system)
    }

    /// The checks and set-up of [`new`](Self::new) and [`with_models`](Self::with_models).
    fn of_tet_models<E: ModelElement>(
        mesh: Arc<TetMesh<E>>,
        models: Box<dyn TetModels + Send>,
        name: &'static str,
        system: &LinearSystem,
    ) -> Result<Self> {
        let dofs = system.dofs();
        if dofs.full_count() != mesh.dof_count() {
            return Err(Error::invalid_parameter(
                "nonlinear force mesh",
                format!("{} DOFs", mesh.dof_count()),
                format!("must be the system's mesh ({} DOFs)", dofs.full_count()),
            ));
        }
        let (assembler, restriction) = Problem::with_dofs(&mesh, dofs.clone())?.into_assembly();
        let pattern = Arc::clone(system.stiffness().pattern());
        let same = restriction.pattern().col_ptr() == pattern.col_ptr()
            && restriction.pattern().row_idx() == pattern.row_idx();
        if !same {
            return Err(Error::invalid_parameter(
                "system stiffness",
                format!("{} stored entries", system.stiffness().nnz()),
                "must be on the pattern of the mesh's assembly restricted to the free DOFs (build the system with LinearSystem::new on this mesh)",
            ));
        }
        let mesh_dofs = mesh.dof_count();
        Ok(NonlinearForce {
            free_dofs: dofs.free_dofs().to_vec(),
            prescribed: std::sync::RwLock::new(dofs.prescribed().to_vec()),
            mesh: Arc::new(KeptMesh::new(mesh)),
            models,
            name,
            assembler,
            restriction,
            pattern,
            contact: None,
            friction: std::sync::Mutex::new(None),
            last_friction_forces: std::sync::Mutex::new(None),
            barrier: std::sync::Mutex::new(None),
            surface: None,
            free_index: {
                let mut index = vec![usize::MAX; mesh_dofs];
                for (k, &d) in dofs.free_dofs().iter().enumerate() {
                    index[d] = k;
                }
                index
            },
            node_masses: std::sync::OnceLock::new(),
            impact_scratch: std::sync::Mutex::new((Vec::new(), Vec::new())),
        })
    }

    /// Adds body–body and self-contact on the mesh's boundary surface (see
    /// [`crate::contact::surface::term`]): the force, tangent and
    /// [`potential_energy`](Self::potential_energy) then include the surface barrier's, and
    /// [`contact_step_limit`](Self::contact_step_limit) bounds every Newton step by its
    /// continuous collision detection, so no iterate of the implicit methods intersects. It
    /// joins obstacle contact ([`with_contact`](Self::with_contact)) when both are given. A
    /// linear model goes through here too (build this force with the linear [`ForceModel`]).
    ///
    /// Errors: the contact is not of this mesh (another node count).
    pub fn with_surface_contact(mut self, surface: SurfaceContact) -> Result<Self> {
        Error::check_len(
            "surface contact nodes (3 DOFs each)",
            self.mesh.dof_count(),
            3 * surface.node_count(),
        )?;
        self.surface = Some(surface);
        Ok(self)
    }

    /// The surface barrier's Hessian entries the last tangent lumped onto the diagonal
    /// ([`SurfaceContact::lumped_entries`]) on the free DOFs: (row, column or `None` where the
    /// column is constrained, v). Empty without surface contact or when every entry was on the
    /// pattern.
    pub(crate) fn lumped_tangent_entries(&self) -> Vec<(usize, Option<usize>, f64)> {
        let Some(surface) = &self.surface else {
            return Vec::new();
        };
        let index = |d: usize| Some(self.free_index[d]).filter(|&k| k != usize::MAX);
        surface
            .lumped_entries()
            .into_iter()
            .filter_map(|(r, c, v)| Some((index(r)?, index(c), v)))
            .collect()
    }

    /// The body–body and self-contact, if any.
    pub fn surface_contact(&self) -> Option<&SurfaceContact> {
        self.surface.as_ref()
    }

    /// Whether any contact — obstacles or surface — is part of the force: the implicit
    /// methods then bound each Newton step by collision detection and accept only a decrease
    /// of the step's potential.
    pub fn has_contact(&self) -> bool {
        self.contact.is_some() || self.surface.is_some()
    }

    /// Adds contact with rigid obstacles (see [`crate::contact`]): the force, tangent and
    /// energy then include the barrier's, and the implicit methods' Newton line search never
    /// steps past the first time of impact. A linear model with contact goes through here
    /// too (build this force with the linear [`ForceModel`]): the linear fast paths factor once
    /// and cannot see contact.
    ///
    /// Errors: the contact is not of this mesh (a boundary node beyond its nodes).
    pub fn with_contact(mut self, contact: Contact) -> Result<Self> {
        contact.check_state(&vec![0.0; self.mesh.dof_count()])?;
        self.barrier = std::sync::Mutex::new(Some(BarrierRecord::start(contact.parameters())));
        self.contact = Some(contact);
        Ok(self)
    }

    /// Starts a time step from free displacements `u` with step `dt` (time): with frictional
    /// contact, lags the normal forces and tangent planes there and sets the smoothing distance
    /// ε = ε_v·`dt` (see [`crate::contact::friction`]); the force, tangent and
    /// [`potential_energy`](Self::potential_energy) include friction until the next call or
    /// [`end_friction`](Self::end_friction). Without friction it does nothing.
    ///
    /// Friction between surfaces (surface contact with μ > 0) is lagged here too
    /// ([`SurfaceContact::begin_friction`], ε = ε_v·`dt`).
    pub fn begin_step(&self, u: &[f64], dt: f64) -> Result<()> {
        match &self.contact {
            Some(contact) => self.begin_step_toward(u, dt, &contact.offsets(), 0.0),
            None => self.begin_surface_friction(u, dt),
        }
    }

    /// Lags the surfaces' friction at free displacements `u` for a step `dt` (nothing without
    /// surface friction).
    fn begin_surface_friction(&self, u: &[f64], dt: f64) -> Result<()> {
        match self.surface.as_ref().filter(|s| s.has_friction()) {
            Some(surface) => surface.begin_friction(&self.full_displacement(u)?, dt),
            None => Ok(()),
        }
    }

    /// [`begin_step`](Self::begin_step) for a step at whose end the obstacles sit at offsets
    /// `target` (length, one per obstacle): friction then opposes the slip relative to each
    /// moving obstacle, turned by its spin over the step's `duration` (time;
    /// [`Contact::friction_lag_toward`]).
    pub fn begin_step_toward(
        &self,
        u: &[f64],
        dt: f64,
        target: &[nalgebra::Vector3<f64>],
        duration: f64,
    ) -> Result<()> {
        self.begin_surface_friction(u, dt)?;
        let Some(contact) = self.contact.as_ref().filter(|c| c.has_friction()) else {
            return Ok(());
        };
        let lag = contact.friction_lag_toward(
            &self.full_displacement(u)?,
            contact.slip_velocity() * dt,
            target,
            duration,
        )?;
        *self.friction_lock() = Some(lag);
        Ok(())
    }

    /// The lagged friction's smoothing distance ε and its largest slip at free displacements
    /// `u` (both length), when a step has lagged friction with at least one node in contact.
    pub(crate) fn friction_smoothing_and_slip(&self, u: &[f64]) -> Result<Option<(f64, f64)>> {
        let lag = self.friction_lock();
        let (Some(contact), Some(lag)) = (&self.contact, lag.as_ref().filter(|l| !l.is_empty()))
        else {
            return Ok(None);
        };
        let slip = contact.largest_slip(lag, &self.full_displacement(u)?)?;
        Ok(Some((lag.epsilon(), slip)))
    }

    /// The rigid obstacles' barrier (its PSD part, counted `barrier_weight` times: Newmark's
    /// end-point contact weighs it by 2) and lagged friction Hessians at free displacements `u`
    /// as 3×3 node blocks (force/length), `(node, block)` with one entry per node, summed over
    /// its obstacles and friction points; empty without contact. The part of the step's
    /// Hessian that sits on the contact nodes' diagonal alone.
    pub(crate) fn contact_node_blocks(
        &self,
        u: &[f64],
        barrier_weight: f64,
    ) -> Result<Vec<(usize, nalgebra::Matrix3<f64>)>> {
        let Some(contact) = &self.contact else {
            return Ok(Vec::new());
        };
        let full = self.full_displacement(u)?;
        let mut blocks = contact.barrier_blocks(&full, true)?;
        for (_, block) in &mut blocks {
            *block *= barrier_weight;
        }
        if let Some(lag) = self.friction_lock().as_ref() {
            blocks.extend(contact.friction_blocks(lag, &full)?);
        }
        blocks.sort_by_key(|&(node, _)| node);
        let mut summed: Vec<(usize, nalgebra::Matrix3<f64>)> = Vec::with_capacity(blocks.len());
        for (node, block) in blocks {
            match summed.last_mut() {
                Some((last, sum)) if *last == node => *sum += block,
                _ => summed.push((node, block)),
            }
        }
        Ok(summed)
    }

    /// Sets the lagged friction's smoothing distance ε (length); nothing without lagged
    /// friction.
    pub(crate) fn set_friction_smoothing(&self, epsilon: f64) {
        if let Some(lag) = self.friction_lock().as_mut() {
            lag.set_epsilon(epsilon);
        }
    }

    /// Whether a run of this force on `system` is driven by work that the energies' constant
    /// load potentials do not hold: moving obstacles, or data that follow time (moving supports,
    /// loads with amplitudes; [`LinearSystem::is_time_varying`]). Its divergence guard then
    /// checks finite values only: the implicit methods' one rule.
    pub(crate) fn does_work_off_the_potentials(&self, system: &super::LinearSystem) -> bool {
        self.contact.as_ref().is_some_and(|c| c.is_moving()) || system.is_time_varying()
    }

    /// Drops the lagged friction (explicit steps and energy evaluations see none).
    pub fn end_friction(&self) {
        *self.friction_lock() = None;
        if let Some(surface) = &self.surface {
            surface.end_friction();
        }
    }

    /// Keeps the friction force the body exerts on each obstacle at free displacements `u`
    /// (an implicit step's solution) with the lagged data of [`begin_step`](Self::begin_step):
    /// the smoothed Coulomb force μ·λ·(f₁(y)/y)·P·(x − x⁰) of each node, its reaction summed
    /// per obstacle ([`Contact::obstacle_friction_forces`]). Does nothing without lagged
    /// friction.
    pub fn keep_friction_forces(&self, u: &[f64]) -> Result<()> {
        let lag = self.friction_lock();
        let (Some(contact), Some(lag)) = (&self.contact, lag.as_ref()) else {
            return Ok(());
        };
        let forces = contact.obstacle_friction_forces(lag, &self.full_displacement(u)?)?;
        *self.last_friction_lock() = Some(forces);
        Ok(())
    }

    /// The friction force the body exerted on each obstacle over the last step (force units,
    /// the obstacles' order): an implicit step's smoothed Coulomb force at its solution, an
    /// explicit step's −Σ m·Δv/dt of its contact impulses, normal and friction
    /// ([`keep_impulse_forces`](Self::keep_impulse_forces)). `None` before the first step and,
    /// in implicit steps, without friction. Add it to [`Contact::obstacle_forces`] (the
    /// barrier's normal force) for the whole force on each obstacle.
    pub fn friction_forces(&self) -> Option<Vec<nalgebra::Vector3<f64>>> {
        self.last_friction_lock().clone()
    }

    /// What the barrier did over the accepted steps and Newton iterates so far
    /// ([`BarrierRecord`]); `None` without contact.
    pub fn barrier_record(&self) -> Option<BarrierRecord> {
        *self.barrier_lock()
    }

    /// Starts the record over (a new run on this force) or sets it to `record` (a resumed
    /// run's, from its checkpoint). Does nothing without contact. With an impact fraction a
    /// new run's nodes start at κ₀, and a resumed run's at the record's stiffness in force
    /// until [`set_node_stiffnesses`](Self::set_node_stiffnesses) gives each its own.
    pub fn set_barrier_record(&self, record: Option<BarrierRecord>) {
        if let Some(contact) = &self.contact {
            let record = record.unwrap_or_else(|| BarrierRecord::start(contact.parameters()));
            contact.set_stiffness_in_force(record.stiffness_in_force);
            *self.barrier_lock() = Some(record);
        }
    }

    /// Each contact node's barrier stiffness κᵢ in force (Pa/m) with an impact fraction
    /// ([`Contact::node_stiffnesses`]): what a checkpoint keeps for a resumed run to continue
    /// with the same bits. `None` without contact or without an impact fraction.
    pub fn node_stiffnesses(&self) -> Option<Vec<f64>> {
        self.contact.as_ref()?.node_stiffnesses()
    }

    /// Sets each contact node's κᵢ from a checkpoint's `values` (Pa/m; see
    /// [`Contact::set_node_stiffnesses`]); nothing without contact or an impact fraction.
    pub fn set_node_stiffnesses(&self, values: &[f64]) -> Result<()> {
        match &self.contact {
            Some(contact) => contact.set_node_stiffnesses(values),
            None => Ok(()),
        }
    }

    /// Takes the accepted step's state at free displacements `u` into the record: its gap
    /// error and smallest gap, the obstacles at their current placement (the step's end, where
    /// the integrator left them). Nothing without contact: a run without obstacles pays
    /// nothing.
    pub fn note_accepted_step(&self, u: &[f64]) -> Result<()> {
        let Some(contact) = &self.contact else {
            return Ok(());
        };
        let gaps = contact.barrier_gaps(&self.full_displacement(u)?)?;
        if let Some(record) = self.barrier_lock().as_mut() {
            record.take_step(&gaps, contact.stiffness());
        }
        Ok(())
    }

    /// Takes an accepted Newton iterate at free displacements `u` (every one, inside a step)
    /// into the record's smallest gap. A measurement only: the length is the solver's own, so
    /// it cannot fail, and it would not stop the solve if it did.
    /// With surface contact, the iterate also goes to its intersection audit
    /// ([`SurfaceContact::note_accepted_iterate`]: nothing unless the audit is on).
    pub(crate) fn note_iterate(&self, u: &[f64]) {
        if let Some(surface) = self
            .surface
            .as_ref()
            .filter(|s| s.intersection_audit().is_some())
        {
            // The free length is the solver's own: a mismatch cannot occur here.
            if let Ok(full) = self.full_displacement(u) {
                surface.note_accepted_iterate(&full);
            }
        }
        let Some(contact) = &self.contact else {
            return;
        };
        let smallest = self
            .full_displacement(u)
            .and_then(|full| contact.smallest_gap(&full));
        if let (Ok(gap), Some(record)) = (smallest, self.barrier_lock().as_mut()) {
            record.smallest_iterate_gap = record.smallest_iterate_gap.min(gap);
        }
    }

    fn barrier_lock(&self) -> std::sync::MutexGuard<'_, Option<BarrierRecord>> {
        // A poisoned lock only means a panic elsewhere while holding plain data: keep it.
        self.barrier.lock().unwrap_or_else(|e| e.into_inner())
    }

    fn friction_lock(&self) -> std::sync::MutexGuard<'_, Option<FrictionLag>> {
        // A poisoned lock only means a panic elsewhere while holding plain data: keep it.
        self.friction.lock().unwrap_or_else(|e| e.into_inner())
    }

    fn last_friction_lock(&self) -> std::sync::MutexGuard<'_, Option<Vec<nalgebra::Vector3<f64>>>> {
        self.last_friction_forces
            .lock()
            .unwrap_or_else(|e| e.into_inner())
    }

    /// Friction in an explicit step ([`Contact::apply_friction_impulses`]): updates the free
    /// velocities `velocity` (length/time) of a step from free displacements `u` at `time`
    /// with step `dt` (time), the lumped mass's `inverse_mass` (1/mass, free DOFs). Does
    /// nothing without frictional contact.
    pub fn apply_friction_impulses(
        &self,
        u: &[f64],
        velocity: &mut [f64],
        inverse_mass: &[f64],
        time: f64,
        dt: f64,
    ) -> Result<()> {
        let Some(contact) = self.contact.as_ref().filter(|c| c.has_friction()) else {
            return Ok(());
        };
        Error::check_len("velocity", self.free_count(), velocity.len())?;
        Error::check_len("inverse mass", self.free_count(), inverse_mass.len())?;
        let full = self.full_displacement(u)?;
        let (mut full_velocity, mut full_inverse) = (vec![0.0; full.len()], vec![0.0; full.len()]);
        for (k, &d) in self.free_dofs.iter().enumerate() {
            full_velocity[d] = velocity[k];
            full_inverse[d] = inverse_mass[k];
        }
        let forces =
            contact.apply_friction_impulses(&full, &mut full_velocity, &full_inverse, time, dt)?;
        *self.last_friction_lock() = Some(forces);
        for (v, &d) in velocity.iter_mut().zip(&self.free_dofs) {
            *v = full_velocity[d];
        }
        Ok(())
    }

    /// Keeps `forces` (force units, one per obstacle in order) as what
    /// [`friction_forces`](Self::friction_forces) reports: an explicit step's contact impulses
    /// ([`Contact::apply_contact_impulses`]), the force the body exerted on each obstacle over
    /// the step besides the barrier's.
    pub fn keep_impulse_forces(&self, forces: Vec<nalgebra::Vector3<f64>>) {
        *self.last_friction_lock() = Some(forces);
    }

    /// The contact, if any.
    pub fn contact(&self) -> Option<&Contact> {
        self.contact.as_ref()
    }

    /// The full displacement of free displacements `u` (prescribed values at constrained DOFs).
    pub fn full_displacement(&self, u: &[f64]) -> Result<Vec<f64>> {
        Error::check_len("displacement", self.free_count(), u.len())?;
        let mut full = vec![0.0; self.mesh.dof_count()];
        self.expand_into(u, &mut full);
        Ok(full)
    }

    /// The largest fraction t ∈ (0, 1] of the step `du` from `u` (free DOFs) that keeps every
    /// boundary node outside every obstacle (1 without contact; see
    /// [`Contact::max_step`]).
    ///
    /// With surface contact, the minimum of that and the surface's bound
    /// ([`SurfaceContact::max_step`], which keeps a fifth of every closing pair's distance),
    /// whose broad phase serves the line search that follows.
    pub fn contact_step_limit(&self, u: &[f64], du: &[f64]) -> Result<f64> {
        if !self.has_contact() {
            return Ok(1.0);
        }
        Error::check_len("step", self.free_count(), du.len())?;
        let full = self.full_displacement(u)?;
        let mut full_step = vec![0.0; full.len()];
        for (&d, &v) in self.free_dofs.iter().zip(du) {
            full_step[d] = v;
        }
        let obstacles = match &self.contact {
            Some(contact) => contact.max_step(&full, &full_step)?,
            None => 1.0,
        };
        match &self.surface {
            Some(surface) => Ok(obstacles.min(surface.max_step(&full, &full_step)?)),
            None => Ok(obstacles),
        }
    }

    /// A first iterate for a step that takes the moving obstacles to `target` (length, one
    /// offset per obstacle) from free displacements `u`: the body carried with them
    /// ([`Contact::carried_start`], free DOFs only), `None` where no collision-free carry is
    /// found (or without contact).
    pub fn carried_start(
        &self,
        u: &[f64],
        target: &[nalgebra::Vector3<f64>],
    ) -> Result<Option<Vec<f64>>> {
        let Some(contact) = &self.contact else {
            return Ok(None);
        };
        let full = self.full_displacement(u)?;
        let mut free = vec![false; full.len()];
        for &d in &self.free_dofs {
            free[d] = true;
        }
        let carried = contact.carried_start(self.mesh.rest_nodes(), &full, target, &free)?;
        Ok(carried.map(|start| self.free_dofs.iter().map(|&d| start[d]).collect()))
    }

    /// The moves of the contact nodes to the minimizers of their local problems at free
    /// displacements `u` ([`Contact::relax_nodes`], the lagged friction included, the barrier
    /// weighted by `barrier_weight`): `(mesh node, move)` pairs (length); none without
    /// obstacle contact.
    pub(crate) fn relax_contact_nodes(
        &self,
        u: &[f64],
        barrier_weight: f64,
        local: impl Fn(usize) -> Option<(nalgebra::Vector3<f64>, nalgebra::Matrix3<f64>)>,
    ) -> Result<Vec<(usize, nalgebra::Vector3<f64>)>> {
        let Some(contact) = &self.contact else {
            return Ok(Vec::new());
        };
        let full = self.full_displacement(u)?;
        let lag = self.friction_lock();
        contact.relax_nodes(lag.as_ref(), &full, barrier_weight, local)
    }

    /// The contact energy E_c(u) (energy units) of free displacements `u`, 0 without contact.
    pub fn contact_energy(&self, u: &[f64]) -> Result<f64> {
        match &self.contact {
            Some(contact) => contact.energy(&self.full_displacement(u)?),
            None => Ok(0.0),
        }
    }

    /// The surface barrier's energy B(X + u) (J) of free displacements `u`, 0 without surface
    /// contact.
    pub fn surface_energy(&self, u: &[f64]) -> Result<f64> {
        match &self.surface {
            Some(surface) => surface.energy(&self.full_displacement(u)?),
            None => Ok(0.0),
        }
    }

    /// The energy whose gradient is −(f_int + f_contact): elastic plus contact (obstacles and
    /// surface), plus the lagged
    /// friction potential during a step (energy units).
    pub fn potential_energy(&self, u: &[f64]) -> Result<f64> {
        let mut total =
            self.elastic_energy(u)? + self.contact_energy(u)? + self.surface_energy(u)?;
        if let (Some(contact), Some(lag)) = (&self.contact, self.friction_lock().as_ref()) {
            total += contact.friction_energy(lag, &self.full_displacement(u)?)?;
        }
        Ok(total)
    }

    /// The model of each tet (one for all, or one per material): what the outputs evaluate
    /// stresses and energy densities with.
    pub fn models(&self) -> &(dyn TetModels + Send) {
        self.models.as_ref()
    }

    /// The models' name: `corotational`, `neo-hookean`, …
    pub fn name(&self) -> &'static str {
        self.name
    }

    /// The smallest Newton step (length) that changes the positions x = X + u the forces are
    /// evaluated at: 4ε times the largest coordinate magnitude of the mesh. A step below it on
    /// every DOF changes no force, so Newton's iterate stands (the test that holds at zero
    /// load, where the residual is the forces' round-off and no step lowers it).
    pub fn step_resolution(&self) -> f64 {
        4.0 * f64::EPSILON * self.mesh.coordinate_scale()
    }

    /// The mesh, if its elements are `E` (`Tet4` or `Tet10`; `None` for the other type).
    pub fn mesh<E: ModelElement>(&self) -> Option<&TetMesh<E>> {
        self.mesh.as_any().downcast_ref::<TetMesh<E>>()
    }

    /// The model's internal force f = −∂E/∂x (force units) at the full displacement `u`
    /// (every DOF, node-major), contact excluded, on whatever element the mesh has.
    pub fn model_internal_force(&self, u: &[f64]) -> Result<Vec<f64>> {
        self.mesh.internal_force(self.models(), u)
    }

    /// Σₑ Vₑ·Fₑ around each node at free displacements `u` into `out` (one per node of the mesh;
    /// see [`crate::model::assemble::nodal_deformation_gradients`]).
    pub(crate) fn nodal_deformation_gradients(
        &self,
        u: &[f64],
        work: &mut ForceWorkspace,
        out: &mut [nalgebra::Matrix3<f64>],
    ) -> Result<()> {
        Error::check_len("displacement", self.free_count(), u.len())?;
        self.expand_into(u, &mut work.full);
        self.mesh.nodal_deformation_gradients(&work.full, out)
    }

    /// Nodes of the mesh.
    pub(crate) fn node_count(&self) -> usize {
        self.mesh.dof_count() / 3
    }

    /// The full DOF (3·node + axis) of each free DOF, in order.
    pub(crate) fn free_dofs(&self) -> &[usize] {
        &self.free_dofs
    }

    /// Number of free DOFs.
    pub fn free_count(&self) -> usize {
        self.free_dofs.len()
    }

    /// Sets the time the force is evaluated at: the moving constrained DOFs of `system` (the
    /// system this force was built for) go to u_c(`t`) ([`LinearSystem::prescribed_at`]).
    /// Without moving supports it does nothing. The integrators call it before each evaluation
    /// at a new time (a step's start for the explicit method, its end for the implicit ones).
    pub fn set_time(&self, system: &LinearSystem, t: f64) -> Result<()> {
        if !system.has_moving_supports() {
            return Ok(());
        }
        let values = system.prescribed_at(t)?;
        Error::check_len(
            "prescribed displacement",
            self.mesh.dof_count(),
            values.len(),
        )?;
        *self.prescribed_lock() = values;
        Ok(())
    }

    /// At an implicit step's start: with an impact fraction on the contact
    /// ([`ContactParameters::impact_fraction`]), sets the barrier stiffness of the step of
    /// duration `dt` (time) from `state` ([`Contact::update_impact_stiffness`]; the constrained
    /// DOFs' velocity taken as zero, each node's mass the largest row sum of M over its free
    /// DOFs, formed once). Without one it does nothing. Call after the obstacles are placed at
    /// the state's time.
    ///
    /// Errors: `state` not of the free DOFs; those of
    /// [`Contact::update_impact_stiffness`].
    pub fn begin_impact_step(&self, system: &LinearSystem, state: &State, dt: f64) -> Result<()> {
        let Some(contact) =
            (self.contact.as_ref()).filter(|c| c.parameters().impact_fraction.is_some())
        else {
            return Ok(());
        };
        state.check_len(self.free_count())?;
        let masses = self.node_masses(system)?;
        let mut scratch = self
            .impact_scratch
            .lock()
            .unwrap_or_else(|e| e.into_inner());
        let (u, velocity) = &mut *scratch;
        let n = self.mesh.dof_count();
        u.resize(n, 0.0);
        velocity.clear();
        velocity.resize(n, 0.0);
        self.expand_into(&state.displacement, u);
        for (&d, &v) in self.free_dofs.iter().zip(&state.velocity) {
            velocity[d] = v;
        }
        contact.update_impact_stiffness(u, velocity, masses, (state.time, dt))?;
        Ok(())
    }

    /// Each mesh node's mass (mass units) as the impact-aware stiffness reads it: the largest
    /// row sum (M_ff·1) over the node's free DOFs, 0 for a node without one. With the lumped
    /// mass (the default) the three are equal, ρV/4 of the tets around the node. With the
    /// consistent mass they differ where a neighbour has some DOFs constrained: the restriction
    /// to the free DOFs drops that neighbour's coupling from the rows of the axes it has
    /// fixed, and for 4-node tets every coupling is positive (ρV/20·(1 + δᵢⱼ)), so the largest
    /// row sum is the one nearest to the node's whole share. A node with its x DOF constrained
    /// and y, z free thus keeps its mass (the DOF of one axis alone would give it none).
    ///
    /// Formed once from `system` (the system this force was built for) and kept.
    fn node_masses(&self, system: &LinearSystem) -> Result<&[f64]> {
        if let Some(masses) = self.node_masses.get() {
            return Ok(masses);
        }
        let ones = vec![1.0; self.free_dofs.len()];
        let mut sums = vec![0.0; ones.len()];
        system.mass().mul_vec(&ones, &mut sums)?;
        let mut masses = vec![0.0f64; self.node_count()];
        for (&d, &m) in self.free_dofs.iter().zip(&sums) {
            masses[d / 3] = masses[d / 3].max(m);
        }
        Ok(self.node_masses.get_or_init(|| masses))
    }

    fn prescribed_lock(&self) -> std::sync::RwLockWriteGuard<'_, Vec<f64>> {
        // A poisoned lock only means a panic elsewhere while holding plain data: keep it.
        self.prescribed.write().unwrap_or_else(|e| e.into_inner())
    }

    /// The full displacement (prescribed values at the constrained DOFs) of free values `u`.
    fn expand_into(&self, u: &[f64], full: &mut [f64]) {
        full.copy_from_slice(&self.prescribed.read().unwrap_or_else(|e| e.into_inner()));
        for (&d, &v) in self.free_dofs.iter().zip(u) {
            full[d] = v;
        }
    }

    /// Scratch for [`force_into`](Self::force_into) and [`tangent_into`](Self::tangent_into):
    /// a full displacement, a full force (kept, not allocated per evaluation) and the
    /// full-pattern tangent.
    pub fn workspace(&self) -> Result<ForceWorkspace> {
        Ok(ForceWorkspace {
            full: vec![0.0; self.mesh.dof_count()],
            full_force: vec![0.0; self.mesh.dof_count()],
            base: ElasticBase::default(),
            full_tangent: CscMatrix::zeros(Arc::clone(self.assembler.pattern()))?,
            free_tangent: CscMatrix::zeros(Arc::clone(self.restriction.pattern()))?,
        })
    }

    /// A matrix of zeros on the full assembly pattern (every DOF, constrained ones too): the
    /// pattern the contact Hessians are formed on before the restriction to the free DOFs.
    pub(crate) fn full_zero_tangent(&self) -> Result<CscMatrix> {
        Ok(CscMatrix::zeros(Arc::clone(self.assembler.pattern()))?)
    }

    /// A matrix of zeros on K_ff's pattern (the one [`tangent_into`](Self::tangent_into) fills).
    pub fn zero_tangent(&self) -> Result<CscMatrix> {
        Ok(CscMatrix::zeros(Arc::clone(&self.pattern))?)
    }

    /// f_int(u) = Σₑ fₑ(X + u) (plus the contact force, with contact) on the free DOFs (force units) into `out`; `u` on the free DOFs.
    pub fn force_into(&self, u: &[f64], work: &mut ForceWorkspace, out: &mut [f64]) -> Result<()> {
        Error::check_len("displacement", self.free_count(), u.len())?;
        Error::check_len("force", self.free_count(), out.len())?;
        self.expand_into(u, &mut work.full);
        let mut full = self.mesh.internal_force(self.models.as_ref(), &work.full)?;
        if let Some(contact) = &self.contact {
            contact.add_force(&work.full, &mut full)?;
            if let Some(lag) = self.friction_lock().as_ref() {
                contact.add_friction_force(lag, &work.full, &mut full)?;
            }
        }
        if let Some(surface) = &self.surface {
            surface.add_force(&work.full, &mut full)?;
        }
        for (o, &d) in out.iter_mut().zip(&self.free_dofs) {
            *o = full[d];
        }
        Ok(())
    }

    /// [`force_into`](Self::force_into), returning the [`potential_energy`](Self::potential_energy)
    /// at `u` from the same pass over the tets (its last bits may differ from
    /// `potential_energy`'s, which sums the tets in another order).
    pub fn force_and_energy_into(
        &self,
        u: &[f64],
        work: &mut ForceWorkspace,
        out: &mut [f64],
    ) -> Result<f64> {
        Error::check_len("displacement", self.free_count(), u.len())?;
        Error::check_len("force", self.free_count(), out.len())?;
        self.expand_into(u, &mut work.full);
        let full = &mut work.full_force;
        let mut energy =
            self.mesh
                .internal_force_and_energy_into(self.models.as_ref(), &work.full, full)?;
        // With rigid obstacles alone the contact nodes' relaxation evaluates points near this
        // one (`force_and_energy_near_into`).
        if self.contact.is_some() && self.surface.is_none() {
            work.base.u.clone_from(&work.full);
            work.base.force.clone_from(full);
            work.base.energy = energy;
        }
        energy += self.add_boundary_terms(&work.full, full)?;
        self.restrict_into(full, out);
        Ok(energy)
    }

    /// [`force_and_energy_into`](Self::force_and_energy_into) at a `u` that differs from the
    /// workspace's last full pass (with rigid obstacles) at few nodes, as the contact nodes'
    /// relaxation moves them: the elastic force and energy carried from that pass over the
    /// tets at the moved nodes alone, fₑ(u) − fₑ(base) and Eₑ(u) − Eₑ(base) added in tet order
    /// (at the 10,125-DOF block of `benches/interactive_contact.rs` its bottom layer, 1,176 of
    /// 16,464 tets), the contact's terms evaluated whole. Equal to the full pass to round-off
    /// of the force's and energy's size, and a full pass where there is no such base, the
    /// tets at the moved nodes are more than an eighth of them, or the element type does not
    /// offer it.
    pub(crate) fn force_and_energy_near_into(
        &self,
        u: &[f64],
        work: &mut ForceWorkspace,
        out: &mut [f64],
    ) -> Result<f64> {
        Error::check_len("displacement", self.free_count(), u.len())?;
        Error::check_len("force", self.free_count(), out.len())?;
        let Some(elastic) = self.elastic_near(u, work) else {
            return self.force_and_energy_into(u, work, out);
        };
        let full_force = &mut work.full_force;
        let energy = elastic + self.add_boundary_terms(&work.full, full_force)?;
        self.restrict_into(full_force, out);
        Ok(energy)
    }

    /// The model's elastic energy at free displacements `u` (energy units) carried from the
    /// workspace's last full pass with rigid obstacles, as
    /// [`force_and_energy_near_into`](Self::force_and_energy_near_into) carries it: an implicit
    /// step's divergence guard at the state the last step left, a few relaxed contact nodes
    /// from that step's last full pass, instead of an energy pass over every tet. Equal to
    /// [`elastic_energy`](Self::elastic_energy) to round-off of the energy's size (the guard
    /// fires at ten times the energy the start and the loads supply, which that cannot decide),
    /// and that pass where there is no such base or too many tets moved.
    pub(crate) fn elastic_energy_near(&self, u: &[f64], work: &mut ForceWorkspace) -> Result<f64> {
        Error::check_len("displacement", self.free_count(), u.len())?;
        match self.elastic_near(u, work) {
            Some(elastic) => Ok(elastic),
            None => self.elastic_energy(u),
        }
    }

    /// The elastic energy at free `u` (its force into `work.full_force`, full DOFs, `u`
    /// expanded into `work.full`) from the workspace's base and the change over the tets at the
    /// nodes that moved since; `None` where there is no base or the change is not offered (see
    /// [`force_and_energy_near_into`](Self::force_and_energy_near_into)).
    fn elastic_near(&self, u: &[f64], work: &mut ForceWorkspace) -> Option<f64> {
        if work.base.u.is_empty() {
            return None;
        }
        self.expand_into(u, &mut work.full);
        let (base, full) = (&work.base, &work.full);
        let moved: Vec<usize> = (0..full.len() / 3)
            .filter(|&n| full[3 * n..3 * n + 3] != base.u[3 * n..3 * n + 3])
            .collect();
        let full_force = &mut work.full_force;
        full_force.clone_from(&base.force);
        let models = self.models.as_ref();
        let change = (self.mesh).internal_force_and_energy_change(
            models,
            &moved,
            (&base.u, full),
            full_force,
        )?;
        Some(base.energy + change)
    }

    /// The free DOFs' entries of the full vector `full` into `out`.
    fn restrict_into(&self, full: &[f64], out: &mut [f64]) {
        for (o, &d) in out.iter_mut().zip(&self.free_dofs) {
            *o = full[d];
        }
    }

    /// Adds the obstacles' and the surfaces' contact forces at the full displacement `full`
    /// into `full_force` and returns their energy.
    fn add_boundary_terms(&self, full: &[f64], full_force: &mut [f64]) -> Result<f64> {
        let mut energy = 0.0;
        if let Some(contact) = &self.contact {
            contact.add_force(full, full_force)?;
            energy += contact.energy(full)?;
            if let Some(lag) = self.friction_lock().as_ref() {
                contact.add_friction_force(lag, full, full_force)?;
                energy += contact.friction_energy(lag, full)?;
            }
        }
        if let Some(surface) = &self.surface {
            surface.add_force(full, full_force)?;
            energy += surface.energy(full)?;
        }
        Ok(energy)
    }

    /// K_T(u) = −∂f_int/∂u (plus the contact Hessian, with contact) on the free DOFs into `out` (on K_ff's pattern, see
    /// [`zero_tangent`](Self::zero_tangent)), every element tangent projected onto the positive
    /// semi-definite cone when `project` is set ([`crate::model::project_psd`]).
    pub fn tangent_into(
        &self,
        u: &[f64],
        project: bool,
        work: &mut ForceWorkspace,
        out: &mut CscMatrix,
    ) -> Result<()> {
        self.tangent_of_into(u, project, true, work, out)
    }

    /// The model's own tangent K_T(u) on the free DOFs into `out`, contact and friction left
    /// out: the stiffness of Rayleigh damping C = α·M + β·K_T, a property of the material. The
    /// barrier's Hessian, orders of magnitude above it near a closing gap and changing from
    /// step to step, would make the damping step-dependent; with Newmark's damping force
    /// carried in its acceleration from the step before, the mismatch put energy in (the
    /// stability map's damped Newmark·ground cells).
    pub fn material_tangent_into(
        &self,
        u: &[f64],
        project: bool,
        work: &mut ForceWorkspace,
        out: &mut CscMatrix,
    ) -> Result<()> {
        self.tangent_of_into(u, project, false, work, out)
    }

    /// [`tangent_into`](Self::tangent_into), with contact's part when `with_contact`.
    fn tangent_of_into(
        &self,
        u: &[f64],
        project: bool,
        with_contact: bool,
        work: &mut ForceWorkspace,
        out: &mut CscMatrix,
    ) -> Result<()> {
        Error::check_len("displacement", self.free_count(), u.len())?;
        if !Arc::ptr_eq(out.pattern(), &self.pattern) {
            return Err(Error::invalid_parameter(
                "tangent",
                format!("{} stored entries", out.nnz()),
                "must be on K_ff's pattern (NonlinearForce::zero_tangent)",
            ));
        }
        self.expand_into(u, &mut work.full);
        self.mesh.refill_tangent(
            &self.assembler,
            self.models.as_ref(),
            &work.full,
            project,
            &mut work.full_tangent,
        )?;
        if let Some(contact) = self.contact.as_ref().filter(|_| with_contact) {
            contact.add_tangent(&work.full, project, &mut work.full_tangent)?;
            if let Some(lag) = self.friction_lock().as_ref() {
                contact.add_friction_tangent(lag, &work.full, &mut work.full_tangent)?;
            }
        }
        if let Some(surface) = self.surface.as_ref().filter(|_| with_contact) {
            surface.add_tangent(&work.full, project, &mut work.full_tangent)?;
        }
        self.restriction
            .restrict_into(&work.full_tangent, &mut work.free_tangent)?;
        out.values_mut().copy_from_slice(work.free_tangent.values());
        Ok(())
    }

    /// The model's elastic energy Σₑ Eₑ(X + u) (energy units) of free displacements `u`.
    pub fn elastic_energy(&self, u: &[f64]) -> Result<f64> {
        Error::check_len("displacement", self.free_count(), u.len())?;
        let mut full = vec![0.0; self.mesh.dof_count()];
        self.expand_into(u, &mut full);
        self.mesh.energy(self.models.as_ref(), &full)
    }

    /// The energies of `state`: ½vᵀMv, the model's elastic energy (the supports at the time
    /// last set), and the system's load potentials −f_g·u and −f·u (f without the supports'
    /// coupling: [`LinearSystem::model_energy_potentials`]).
    pub fn energy(&self, system: &LinearSystem, state: &State) -> Result<Energy> {
        state.check_len(self.free_count())?;
        Self::energy_with_elastic(system, state, self.elastic_energy(&state.displacement)?)
    }

    /// The energies of `state` with its elastic part `elastic` given (energy units): ½vᵀMv
    /// (the system's one formula, [`LinearSystem::kinetic_energy_with`]) and the system's load
    /// potentials computed here.
    pub(crate) fn energy_with_elastic(
        system: &LinearSystem,
        state: &State,
        elastic: f64,
    ) -> Result<Energy> {
        Ok(Energy {
            kinetic: 0.5 * system.twice_kinetic(&state.velocity)?,
            elastic,
            ..system.model_energy_potentials(state)?
        })
    }
}

/// A mesh of any [`ModelElement`] with the element type erased, so that [`NonlinearForce`] (and
/// every integrator holding it) is one type for 4-node and 10-node tets; each method is the
/// [`crate::model::assemble`] function of the same name on the concrete mesh.
trait ForceMesh: Send + Sync {
    fn dof_count(&self) -> usize;
    fn energy(&self, models: &(dyn TetModels + Send), u: &[f64]) -> Result<f64>;
    fn internal_force(&self, models: &(dyn TetModels + Send), u: &[f64]) -> Result<Vec<f64>>;
    fn internal_force_and_energy_into(
        &self,
        models: &(dyn TetModels + Send),
        u: &[f64],
        force: &mut [f64],
    ) -> Result<f64>;
    /// Adds the elastic force changes from `base` to `u` (full vectors that differ at the
    /// nodes `moved` only) of the tets at those nodes into `force`, returning the energy
    /// change; `None` where that is no cheaper than a full pass or the element type does not
    /// offer it.
    fn internal_force_and_energy_change(
        &self,
        models: &(dyn TetModels + Send),
        moved: &[usize],
        points: (&[f64], &[f64]),
        force: &mut [f64],
    ) -> Option<f64>;
    fn refill_tangent(
        &self,
        assembler: &Assembler,
        models: &(dyn TetModels + Send),
        u: &[f64],
        project: bool,
        tangent: &mut CscMatrix,
    ) -> Result<()>;
    fn nodal_deformation_gradients(
        &self,
        u: &[f64],
        out: &mut [nalgebra::Matrix3<f64>],
    ) -> Result<()>;
    fn as_any(&self) -> &dyn std::any::Any;
    fn coordinate_scale(&self) -> f64;
    fn rest_nodes(&self) -> &[nalgebra::Vector3<f64>];
}

/// A mesh with its tets' rest elements kept ([`crate::model::assemble::corner_elements`]): a
/// step's iterations evaluate the force at many points, and each pass rebuilt every tet's
/// Dm⁻¹ and volume from the nodes. The same bits either way.
struct KeptMesh<E: ModelElement> {
    mesh: Arc<TetMesh<E>>,
    elements: Vec<Tet>,
    /// Each node's tets (CSR: `node_tets.0[n]..node_tets.0[n + 1]` into `node_tets.1`), made
    /// at the first force change asked for.
    node_tets: std::sync::OnceLock<(Vec<usize>, Vec<usize>)>,
}

impl<E: ModelElement> KeptMesh<E> {
    fn new(mesh: Arc<TetMesh<E>>) -> Self {
        let elements = crate::model::assemble::corner_elements(&mesh);
        KeptMesh {
            mesh,
            elements,
            node_tets: std::sync::OnceLock::new(),
        }
    }

    /// The tets at any of the nodes `nodes`, ascending.
    fn tets_at(&self, nodes: &[usize]) -> Vec<usize> {
        let (start, tets) = self.node_tets.get_or_init(|| {
            let mut start = vec![0usize; self.mesh.node_count() + 1];
            for tet in self.mesh.tets() {
                for &n in tet.as_ref() {
                    start[n + 1] += 1;
                }
            }
            for n in 0..self.mesh.node_count() {
                start[n + 1] += start[n];
            }
            let mut fill = start.clone();
            let mut tets = vec![0usize; start[self.mesh.node_count()]];
            for (t, tet) in self.mesh.tets().iter().enumerate() {
                for &n in tet.as_ref() {
                    tets[fill[n]] = t;
                    fill[n] += 1;
                }
            }
            (start, tets)
        });
        let mut at: Vec<usize> = (nodes.iter())
            .flat_map(|&n| tets[start[n]..start[n + 1]].iter().copied())
            .collect();
        at.sort_unstable();
        at.dedup();
        at
    }
}

impl<E: ModelElement> ForceMesh for KeptMesh<E> {
    fn dof_count(&self) -> usize {
        self.mesh.dof_count()
    }

    fn energy(&self, models: &(dyn TetModels + Send), u: &[f64]) -> Result<f64> {
        energy_kept(self.mesh.as_ref(), &self.elements, models, u)
    }

    fn internal_force(&self, models: &(dyn TetModels + Send), u: &[f64]) -> Result<Vec<f64>> {
        internal_force(self.mesh.as_ref(), models, u)
    }

    fn internal_force_and_energy_into(
        &self,
        models: &(dyn TetModels + Send),
        u: &[f64],
        force: &mut [f64],
    ) -> Result<f64> {
        crate::model::assemble::internal_force_and_energy_kept_into(
            self.mesh.as_ref(),
            &self.elements,
            models,
            u,
            force,
        )
    }

    fn internal_force_and_energy_change(
        &self,
        models: &(dyn TetModels + Send),
        moved: &[usize],
        points: (&[f64], &[f64]),
        force: &mut [f64],
    ) -> Option<f64> {
        let tets = self.tets_at(moved);
        // Two evaluations a tet on one thread against one on each thread: past an eighth of
        // the tets no cheaper than the full pass.
        if tets.len() * 8 > self.mesh.tet_count() {
            return None;
        }
        E::add_model_force_changes_kept(&self.mesh, &self.elements, models, &tets, points, force)
    }

    fn refill_tangent(
        &self,
        assembler: &Assembler,
        models: &(dyn TetModels + Send),
        u: &[f64],
        project: bool,
        tangent: &mut CscMatrix,
    ) -> Result<()> {
        refill_tangent_kept(
            self.mesh.as_ref(),
            &self.elements,
            assembler,
            models,
            (u, project),
            tangent,
        )
    }

    fn nodal_deformation_gradients(
        &self,
        u: &[f64],
        out: &mut [nalgebra::Matrix3<f64>],
    ) -> Result<()> {
        crate::model::assemble::nodal_deformation_gradients_kept(
            self.mesh.as_ref(),
            &self.elements,
            u,
            out,
        )
    }

    fn as_any(&self) -> &dyn std::any::Any {
        self.mesh.as_ref()
    }

    fn coordinate_scale(&self) -> f64 {
        coordinate_scale(self.mesh.nodes())
    }

    fn rest_nodes(&self) -> &[nalgebra::Vector3<f64>] {
        self.mesh.nodes()
    }
}

/// The largest magnitude of a coordinate of `nodes` (length): a displacement change below
/// a few ε times it is lost when the positions x = X + u are formed, so no force sees it.
pub(crate) fn coordinate_scale(nodes: &[nalgebra::Vector3<f64>]) -> f64 {
    nodes
        .iter()
        .flat_map(|x| x.iter().map(|c| c.abs()))
        .fold(0.0, f64::max)
}

/// A full pass's full displacement, elastic force and elastic energy: where
/// [`NonlinearForce::force_and_energy_near_into`] starts (empty until a pass keeps one).
#[derive(Debug, Clone, Default)]
struct ElasticBase {
    u: Vec<f64>,
    force: Vec<f64>,
    energy: f64,
}

/// Scratch vectors and matrices of [`NonlinearForce`]'s assembly (one per integrator).
#[derive(Debug, Clone)]
pub struct ForceWorkspace {
    full: Vec<f64>,
    full_force: Vec<f64>,
    /// The last full pass's point and elastic part (kept with rigid obstacles alone).
    base: ElasticBase,
    full_tangent: CscMatrix,
    free_tangent: CscMatrix,
}

/// out = a·K + b·M entry-wise on K's pattern (K any matrix on K_ff's pattern, e.g. a tangent):
/// the Newton matrices of the implicit methods.
pub(crate) fn combine(
    stiffness: &CscMatrix,
    stiffness_scale: f64,
    mass: &Mass,
    mass_scale: f64,
    out: &mut CscMatrix,
) -> Result<()> {
    match mass {
        Mass::Consistent(m) => {
            Ok(out.set_linear_combination(stiffness_scale, stiffness, mass_scale, m)?)
        }
        Mass::Lumped(m) => {
            if !Arc::ptr_eq(out.pattern(), stiffness.pattern()) {
                return Err(Error::invalid_parameter(
                    "matrix",
                    "another pattern",
                    "must be on K_ff's pattern",
                ));
            }
            for (a, k) in out.values_mut().iter_mut().zip(stiffness.values()) {
                *a = stiffness_scale * k;
            }
            Ok(out.add_diagonal(mass_scale, m)?)
        }
    }
}

impl InternalForce {
    /// The force of the model `kind`, one per material of `materials` (see
    /// [`ModelKind::build_map`]), on a copy of `mesh` for `system`; the linear kind gives
    /// [`InternalForce::Linear`] without copying the mesh (the fast path). Every front end
    /// builds its force here, so that none branches on the model.
    ///
    /// Errors: those of [`InternalForce::of_models`].
    pub fn of_kind<E: ModelElement>(
        kind: ModelKind,
        mesh: &TetMesh<E>,
        materials: &crate::fe::materials::MaterialMap,
        system: &LinearSystem,
    ) -> Result<Self> {
        match kind {
            // No copy of the mesh for the fast path.
            ModelKind::Linear => Ok(InternalForce::Linear),
            nonlinear => InternalForce::of_models(
                Arc::new(mesh.clone()),
                nonlinear.build_map(materials),
                system,
            ),
        }
    }

    /// The barrier's record of a nonlinear force with contact
    /// ([`NonlinearForce::barrier_record`]); `None` otherwise.
    pub fn barrier_record(&self) -> Option<BarrierRecord> {
        match self {
            InternalForce::Nonlinear(n) => n.barrier_record(),
            InternalForce::Linear => None,
        }
    }

    /// [`NonlinearForce::note_accepted_step`] at `state`'s displacement; nothing without
    /// contact.
    pub fn note_accepted_step(&self, state: &State) -> Result<()> {
        match self {
            InternalForce::Nonlinear(n) => n.note_accepted_step(&state.displacement),
            InternalForce::Linear => Ok(()),
        }
    }

    /// [`NonlinearForce::node_stiffnesses`]; `None` for the linear force.
    pub fn node_stiffnesses(&self) -> Option<Vec<f64>> {
        match self {
            InternalForce::Nonlinear(n) => n.node_stiffnesses(),
            InternalForce::Linear => None,
        }
    }

    /// The contact of a nonlinear force with obstacles ([`NonlinearForce::contact`]); `None`
    /// for the linear force, which has none.
    pub fn contact(&self) -> Option<&Contact> {
        match self {
            InternalForce::Nonlinear(n) => n.contact(),
            InternalForce::Linear => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use nalgebra::Vector3;

    use super::*;
    use crate::analysis::dynamics::{MassKind, Rayleigh};
    use crate::contact::Obstacle;
    use crate::{BoxSplit, Constraints, Loads, Material};

    /// A rubber block (4×4×4 cells, 10 cm) with its underside 0.5 mm above rigid ground, no
    /// constraint, under `model`.
    fn block_on_ground(model: ModelKind) -> NonlinearForce {
        let mesh = TetMesh::box_grid(
            Vector3::new(0.0, 0.0, 5e-4),
            Vector3::new(0.1, 0.1, 0.1005),
            [4, 4, 4],
            BoxSplit::Lecture6,
        )
        .unwrap();
        let rubber = Material::new(1e5, 0.4, 1000.0).unwrap();
        let constraints = Constraints::new(&mesh);
        let loads = Loads::new(&mesh);
        let gravity = Vector3::new(0.0, 0.0, -9.81);
        let system = LinearSystem::new_free_body(
            &mesh,
            &rubber,
            &constraints,
            &loads,
            gravity,
            MassKind::Lumped,
            Rayleigh::default(),
        )
        .unwrap();
        let ground = Obstacle::half_space("ground", Vector3::zeros(), Vector3::z()).unwrap();
        let parameters = ContactParameters::for_mesh(&mesh, rubber.youngs_modulus()).unwrap();
        let contact = Contact::new(&mesh, vec![ground], parameters).unwrap();
        NonlinearForce::new(Arc::new(mesh), model.build(&rubber), &system)
            .unwrap()
            .with_contact(contact)
            .unwrap()
    }

    /// The relaxation's pass (`force_and_energy_near_into`), both models: from a full pass at
    /// u₀ (a smooth field of up to 4 mm), a point with four bottom nodes moved (40 µm from
    /// the ground, the barrier active there) gets the full pass's force and energy to round-off: the same
    /// terms summed in another order, each tet's change fₑ(u) − fₑ(u₀) added to the total, so
    /// a few ulps of the largest force and of the energy apart (bound 1e-12 of each; measured
    /// 1.6e-16–4.3e-16 of |f|∞ and 1.2e-16–2.5e-16 of the energy), and not its bits, and the
    /// elastic energy alone (`elastic_energy_near`) the energy pass's to the same bound; a point
    /// where every node moved gets the full pass, bit for bit.
    #[test]
    fn the_near_pass_is_the_full_pass_where_few_nodes_moved() {
        for model in [ModelKind::NeoHookean, ModelKind::Corotational] {
            let force = block_on_ground(model);
            let n = force.free_count();
            let full = force.full_displacement(&vec![0.0; n]).unwrap();
            assert_eq!(full.len(), n, "no constraint: free DOFs are the mesh's");
            // Upward (z ≥ 0) at every node, so that no node starts in the ground.
            let u0: Vec<f64> = (0..n)
                .map(|i| {
                    let s = 4e-3 * ((i / 3) as f64 * 0.37 + (i % 3) as f64).sin();
                    if i % 3 == 2 { s.abs() } else { s }
                })
                .collect();
            let mut work = force.workspace().unwrap();
            let mut f0 = vec![0.0; n];
            force
                .force_and_energy_into(&u0, &mut work, &mut f0)
                .unwrap();
            // Four nodes of the bottom (z = 5e-4 m at rest), at a corner, pushed toward the
            // ground: their tets are fewer than an eighth of the 384.
            let rest = force.mesh.rest_nodes().to_vec();
            let mut u1 = u0.clone();
            let mut moved = 0;
            for (node, x) in rest.iter().enumerate() {
                if x.z < 1e-3 && x.x < 0.03 && x.y < 0.03 {
                    u1[3 * node + 2] = -4.6e-4;
                    u1[3 * node] += 1e-4;
                    moved += 1;
                }
            }
            assert_eq!(moved, 4);
            assert!(
                force.contact_energy(&u1).unwrap() > 0.0,
                "the barrier is active"
            );
            let mut near = vec![0.0; n];
            let e_near = force
                .force_and_energy_near_into(&u1, &mut work, &mut near)
                .unwrap();
            let mut fresh = force.workspace().unwrap();
            let mut whole = vec![0.0; n];
            let e_whole = force
                .force_and_energy_into(&u1, &mut fresh, &mut whole)
                .unwrap();
            let scale = whole.iter().fold(0.0f64, |m, f| m.max(f.abs()));
            let miss = (near.iter().zip(&whole)).fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
            assert!(
                miss <= 1e-12 * scale,
                "{model:?}: {miss:e} of |f| {scale:e}"
            );
            assert!(
                (e_near - e_whole).abs() <= 1e-12 * e_whole.abs(),
                "{model:?}: energy {e_near} vs {e_whole}"
            );
            assert!(near != whole, "{model:?}: the near pass was the full pass");
            // The elastic energy alone (the divergence guard's), from the same base: the
            // energy pass's to the same round-off.
            let elastic = force.elastic_energy(&u1).unwrap();
            let carried = force.elastic_energy_near(&u1, &mut work).unwrap();
            assert!(
                (carried - elastic).abs() <= 1e-12 * elastic.abs(),
                "{model:?}: elastic energy {carried} vs {elastic}"
            );
            assert!(
                (e_whole - elastic - force.contact_energy(&u1).unwrap()).abs()
                    <= 1e-12 * e_whole.abs(),
                "{model:?}: the pass's energy is the elastic one and the barrier's"
            );
            // Every node moved: the full pass itself.
            let u2: Vec<f64> = u1.iter().map(|u| u * 1.01).collect();
            force
                .force_and_energy_into(&u0, &mut work, &mut f0)
                .unwrap();
            let e_near = force
                .force_and_energy_near_into(&u2, &mut work, &mut near)
                .unwrap();
            let e_whole = force
                .force_and_energy_into(&u2, &mut fresh, &mut whole)
                .unwrap();
            let same = near == whole && e_near.to_bits() == e_whole.to_bits();
            assert!(
                same,
                "{model:?}: every node moved, yet not the full pass's bits"
            );
        }
    }
}
