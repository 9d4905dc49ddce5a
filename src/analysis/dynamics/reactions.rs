//! Support reactions of a dynamic state: the force the constrained DOFs' supports exert on the
//! body so that the equation of motion holds on their rows,
//!
//! r_c = [M·a]_c + [C·v]_c − f_int,c(u) − f_ext,c(t),  C = α·M + β·K,
//!
//! with u, v, a the full displacement, velocity and acceleration at the state's time t (the
//! constrained DOFs at their prescribed values, moving supports at u_c(t), u̇_c(t), ü_c(t); fixed
//! ones at rest), f_int the internal force (−K·u for the linear model, Σₑ fₑ(X + u) for a
//! nonlinear one) and f_ext every load on those rows (gravity and loads with their amplitudes at
//! t). Summed over all DOFs per axis, Σ r + Σ f_ext = Σ M·a + α·Σ M·v: f_int and K·v sum to zero
//! (translations are in K's null space), so the reactions close the global momentum balance of
//! the integrator's state (to its solve's round-off, or Newton's tolerance).
//!
//! With a lumped mass M_cf = 0, so the free DOFs' acceleration never enters. With a consistent
//! mass [M·a]_c = M_cf·a_f + M_cc·a_c needs it: a_f is taken from the free rows' equation of
//! motion at the same state, M_ff·a_f = f(t) + f_int,f − [C·v]_f (what every integrator's state
//! satisfies at its evaluation time: backward Euler's and Newmark's new state, the explicit
//! method's state at the start of its next step), solved by conjugate gradients (the consistent
//! mass is well conditioned: a few tens of iterations to 1e-12), or taken from the linear
//! integrator that made the state ([`SupportReactions::at_with`]), which holds it already.

use nalgebra::{SVector, Vector3};

use super::{InternalForce, LinearSystem, Mass, State};
use crate::analysis::dynamics::time_data::TimeData;
use crate::base::error::{Error, Result};
use crate::bc::amplitude::Amplitude;
use crate::bc::boundary_motion::BoundaryMotion;
use crate::bc::loads::Loads;
use crate::fe::assembly::{Assembler, lumped_mass_of};
use crate::fe::element::ElementType;
use crate::fe::materials::TetMaterials;
use crate::iterative::{BlockJacobi, CgOptions, conjugate_gradient};
use crate::mesh::{Tet4, TetMesh};
use crate::model::project_psd;
use crate::sparse::CscMatrix;

/// One row of a full matrix: (full column, value).
type Row = Vec<(usize, f64)>;

/// The mass on the constrained rows.
#[derive(Debug, Clone)]
enum SupportMass {
    /// The lumped mass of each constrained DOF (mass units).
    Lumped(Vec<f64>),
    /// The consistent mass's rows of the constrained DOFs.
    Consistent(Vec<Row>),
}

/// The bookkeeping of the reaction formula r_c = [M·a]_c + [C·v]_c − f_int,c(u) − f_ext,c(t)
/// (C = α·M + β·K; u, v, a the full displacement, velocity and acceleration at the state's time
/// t; derivation with the source, `src/analysis/dynamics/reactions.rs`) for one [`LinearSystem`]: the full
/// stiffness and mass rows of its constrained DOFs, the loads on them with their amplitudes, and
/// the supports' motion. Built once (one assembly of K and M); each
/// [`at`](Self::at) costs about one product with those rows (plus, for a nonlinear model, the
/// forces of the tets touching a support — on 4-node tets; the whole mesh's on others — and
/// for a consistent mass one CG solve with M_ff, which needs the whole internal force).
#[derive(Debug, Clone)]
pub struct SupportReactions {
    /// The constrained DOFs (full indices), ascending.
    dofs: Vec<usize>,
    stiffness_rows: Vec<Row>,
    mass: SupportMass,
    /// Gravity's nodal loads on the constrained rows (force units), scaled by `gravity_amplitude`.
    gravity: Vec<f64>,
    gravity_amplitude: Amplitude,
    /// The loads without amplitude on the constrained rows.
    constant: Vec<f64>,
    /// The loads with an amplitude on the constrained rows.
    timed: Vec<(Vec<f64>, Amplitude)>,
    motion: BoundaryMotion,
    /// The moving DOFs, in [`BoundaryMotion::dofs`] order.
    moving: Vec<usize>,
    positions: Vec<Vector3<f64>>,
    /// Tets with a constrained node: the only ones whose forces reach the constrained rows.
    support_tets: Vec<usize>,
    /// A consistent mass's preconditioner of M_ff and the last free acceleration (CG's start).
    free_acceleration: Option<(BlockJacobi, Vec<f64>)>,
}

impl SupportReactions {
    /// The reactions of `system`, which was built on `mesh` with `materials`, the loads `loads`
    /// (gravity apart), gravity `gravity` (acceleration) and the time data `data`, exactly as
    /// given to [`LinearSystem::with_time_data`] (or [`LinearSystem::new`] with
    /// `TimeData::default()`); its mass kind, damping and DOF map are taken from `system`.
    ///
    /// Errors: `loads` or `materials` not of `mesh`, or `system` not of `mesh` (naming both DOF
    /// counts).
    #[allow(clippy::too_many_arguments)]
    pub fn new<E: ElementType>(
        system: &LinearSystem,
        mesh: &TetMesh<E>,
        materials: &impl TetMaterials,
        loads: &Loads,
        gravity: Vector3<f64>,
        data: &TimeData,
    ) -> Result<Self> {
        let dof_map = system.dofs();
        if dof_map.full_count() != mesh.dof_count() || loads.as_slice().len() != mesh.dof_count() {
            return Err(Error::invalid_parameter(
                "reactions' system and loads",
                format!(
                    "{} and {} DOFs",
                    dof_map.full_count(),
                    loads.as_slice().len()
                ),
                format!("must be of this mesh ({} DOFs)", mesh.dof_count()),
            ));
        }
        materials.check_tet_count(mesh)?;
        let dofs: Vec<usize> = (0..mesh.dof_count())
            .filter(|&d| dof_map.free_index(d).is_none())
            .collect();
        let assembler = Assembler::new(mesh);
        let rows_of = |full: &CscMatrix| -> Vec<Row> {
            // Symmetric: row c is column c.
            dofs.iter()
                .map(|&c| {
                    let range = full.col_ptr()[c]..full.col_ptr()[c + 1];
                    full.row_idx()[range.clone()]
                        .iter()
                        .copied()
                        .zip(full.values()[range].iter().copied())
                        .collect()
                })
                .collect()
        };
        let stiffness_rows = rows_of(&assembler.stiffness(mesh, materials)?);
        let mass = match system.mass() {
            Mass::Lumped(_) => {
                let m = lumped_mass_of(mesh, materials)?;
                SupportMass::Lumped(dofs.iter().map(|&c| m[c]).collect())
            }
            Mass::Consistent(_) => {
                SupportMass::Consistent(rows_of(&assembler.consistent_mass(mesh, materials)?))
            }
        };
        let on_supports = |full: &[f64]| -> Vec<f64> { dofs.iter().map(|&c| full[c]).collect() };
        let mut gravity_loads = Loads::new(mesh);
        gravity_loads.add_gravity(mesh, materials, gravity)?;
        let timed = data
            .loads
            .iter()
            .map(|(l, a)| {
                Error::check_len("timed loads", mesh.dof_count(), l.as_slice().len())?;
                Ok((on_supports(l.as_slice()), a.clone()))
            })
            .collect::<Result<Vec<_>>>()?;
        let constrained_node = {
            let mut flag = vec![false; mesh.node_count()];
            for &c in &dofs {
                flag[c / 3] = true;
            }
            flag
        };
        let support_tets = mesh
            .tets()
            .iter()
            .enumerate()
            .filter(|(_, tet)| tet.as_ref().iter().any(|&n| constrained_node[n]))
            .map(|(t, _)| t)
            .collect();
        let free_acceleration = match system.mass() {
            Mass::Consistent(m) => Some((BlockJacobi::new(m)?, vec![0.0; system.free_count()])),
            Mass::Lumped(_) => None,
        };
        Ok(SupportReactions {
            gravity: on_supports(gravity_loads.as_slice()),
            gravity_amplitude: data.gravity.clone(),
            constant: on_supports(loads.as_slice()),
            timed,
            moving: data.motion.dofs(),
            motion: data.motion.clone(),
            positions: mesh.nodes().to_vec(),
            stiffness_rows,
            mass,
            support_tets,
            free_acceleration,
            dofs,
        })
    }

    /// The constrained DOFs (full indices, ascending): where [`at`](Self::at) is non-zero.
    pub fn dofs(&self) -> &[usize] {
        &self.dofs
    }

    /// The reactions r_c (force units, N in SI) at `state` of `system` under the elastic force
    /// `force` (the formula of [`SupportReactions`]): full length, zero on the free DOFs — the
    /// layout of [`StaticSolution::reactions`](crate::analysis::statics::StaticSolution::reactions), so
    /// [`reaction_resultant`](crate::analysis::statics::reaction_resultant) sums them per support.
    ///
    /// A nonlinear model's stiffness damping uses its PSD-projected tangent at the state's u (the
    /// implicit methods freeze it at each step's start). With a consistent mass and a nonlinear
    /// model the free rows' load is the system's [`model_load_at`](LinearSystem::model_load_at)
    /// the state's time (what the nonlinear integrators step with).
    ///
    /// Errors: the state or the system is not the one this was built for (length mismatch), a
    /// non-finite state, or the free acceleration's solve failing.
    pub fn at(
        &mut self,
        system: &LinearSystem,
        force: &InternalForce,
        state: &State,
    ) -> Result<Vec<f64>> {
        self.at_with(system, force, state, None)
    }

    /// [`at`](Self::at) with the free DOFs' acceleration `acceleration` of the equation of
    /// motion at `state` where the caller has it (an integrator's
    /// [`linear_acceleration`](super::Integrator::linear_acceleration)): with a consistent mass
    /// it replaces the solve with M_ff, a few tens of CG iterations each a product with M_ff
    /// (on a 36,720-DOF P2 beam about ten times the Newmark step itself). Without it, or
    /// with a lumped mass, the same as [`at`](Self::at).
    ///
    /// Errors: those of [`at`](Self::at), and an `acceleration` not of the free DOF count.
    pub fn at_with(
        &mut self,
        system: &LinearSystem,
        force: &InternalForce,
        state: &State,
        acceleration: Option<&[f64]>,
    ) -> Result<Vec<f64>> {
        state.check_len(system.free_count())?;
        if let Some(a) = acceleration {
            Error::check_len("free acceleration", system.free_count(), a.len())?;
        }
        let dof_map = system.dofs();
        let n = dof_map.full_count();
        Error::check_len("reactions' DOF count", self.positions.len() * 3, n)?;
        let t = state.time;
        let u = system.expand_at(t, &state.displacement)?;
        let mut v = vec![0.0; n];
        let mut a = vec![0.0; n];
        for (&d, &value) in dof_map.free_dofs().iter().zip(&state.velocity) {
            v[d] = value;
        }
        for (&d, [_, rate, acceleration]) in self
            .moving
            .iter()
            .zip(self.motion.evaluate(&self.positions, t)?)
        {
            v[d] = rate;
            a[d] = acceleration;
        }
        let damping = system.damping();
        // −f_int on the constrained rows (K·u for the linear model), and the model's tangent
        // times v for a nonlinear model's stiffness damping (K's rows times v otherwise).
        let mut resisting = vec![0.0; self.dofs.len()];
        let mut stiffness_velocity = vec![0.0; self.dofs.len()];
        match force {
            InternalForce::Linear => {
                for (i, row) in self.stiffness_rows.iter().enumerate() {
                    resisting[i] = row.iter().map(|&(j, k)| k * u[j]).sum();
                    stiffness_velocity[i] = row.iter().map(|&(j, k)| k * v[j]).sum();
                }
            }
            InternalForce::Nonlinear(f) => {
                let mut internal = support_internal_force(f, &u, &self.support_tets)?;
                if let Some(contact) = f.contact() {
                    contact.add_force(&u, &mut internal)?;
                }
                for (r, &c) in resisting.iter_mut().zip(&self.dofs) {
                    *r = -internal[c];
                }
                if damping.beta != 0.0 {
                    let kv = model_tangent_product(f, &u, &v, &self.support_tets)?;
                    for (s, &c) in stiffness_velocity.iter_mut().zip(&self.dofs) {
                        *s = kv[c];
                    }
                }
            }
        }
        if self.free_acceleration.is_some() {
            let a_f = match acceleration {
                Some(a) => a,
                None => self.free_acceleration(system, force, state, &u, &v)?,
            };
            for (&d, &value) in dof_map.free_dofs().iter().zip(a_f) {
                a[d] = value;
            }
        }
        let mut reactions = vec![0.0; n];
        let a_g = self.gravity_amplitude.value(t);
        for (i, &c) in self.dofs.iter().enumerate() {
            let inertia = match &self.mass {
                SupportMass::Lumped(m) => m[i] * (a[c] + damping.alpha * v[c]),
                SupportMass::Consistent(rows) => rows[i]
                    .iter()
                    .map(|&(j, m)| m * (a[j] + damping.alpha * v[j]))
                    .sum(),
            };
            let external = a_g * self.gravity[i]
                + self.constant[i]
                + self
                    .timed
                    .iter()
                    .map(|(f, amplitude)| amplitude.value(t) * f[i])
                    .sum::<f64>();
            reactions[c] = inertia + damping.beta * stiffness_velocity[i] + resisting[i] - external;
        }
        Ok(reactions)
    }

    /// a_f of the free rows' equation of motion at `state` (consistent mass only): M_ff·a_f =
    /// f(t) + f_int,f − [C·v]_f, by CG from the last solution.
    fn free_acceleration(
        &mut self,
        system: &LinearSystem,
        force: &InternalForce,
        state: &State,
        u: &[f64],
        v: &[f64],
    ) -> Result<&[f64]> {
        // The mass's compact copy: a third of the entries each CG product reads, the same bits.
        let Some(m) = system.compact_mass() else {
            return Err(Error::Solver(
                "the free acceleration is needed with a consistent mass only".into(),
            ));
        };
        let damping = system.damping();
        let nf = system.free_count();
        let mut rhs = vec![0.0; nf];
        let mut product = vec![0.0; nf];
        m.product_into(&state.velocity, &mut product);
        match force {
            InternalForce::Linear => {
                // f(t) holds the coupling to the constrained DOFs (−K_fc·u_c − C_fm·u̇_m − M_fm·ü_m).
                let mut buffer = system.load_buffer();
                let f = system.external_load_at(state.time, &mut buffer)?;
                let mut ku = vec![0.0; nf];
                let mut kv = vec![0.0; nf];
                system
                    .stiffness()
                    .product_into(&state.displacement, &mut ku);
                system.stiffness().product_into(&state.velocity, &mut kv);
                for i in 0..nf {
                    rhs[i] = f[i] - ku[i] - damping.alpha * product[i] - damping.beta * kv[i];
                }
            }
            InternalForce::Nonlinear(model) => {
                let mut internal = model.model_internal_force(u)?;
                if let Some(contact) = model.contact() {
                    contact.add_force(u, &mut internal)?;
                }
                let kv = match damping.beta != 0.0 {
                    true => {
                        let tets = model.mesh::<Tet4>().map_or(0, |m| m.tet_count());
                        let all: Vec<usize> = (0..tets).collect();
                        model_tangent_product(model, u, v, &all)?
                    }
                    false => vec![0.0; u.len()],
                };
                // The load at the state's time, the supports' coupling in `internal` already.
                let mut buffer = system.model_load_buffer(true);
                let f = system.model_load_at(state.time, true, &mut buffer)?;
                for (i, &d) in system.dofs().free_dofs().iter().enumerate() {
                    rhs[i] = f[i] + internal[d] - damping.alpha * product[i] - damping.beta * kv[d];
                }
            }
        }
        let Some((preconditioner, a_f)) = self.free_acceleration.as_mut() else {
            return Err(Error::Solver("no free acceleration solver".into()));
        };
        conjugate_gradient(
            m,
            preconditioner,
            &rhs,
            a_f,
            CgOptions {
                // The consistent mass is well conditioned (κ of the Jacobi-scaled P1 mass is a
                // few units): CG reaches this in a few tens of iterations, with a wide margin
                // above its rounding floor (a tolerance at the floor could stagnate and fail a
                // run over its bookkeeping); a_f enters the reactions only through M_cf.
                relative_tolerance: 1e-12,
                max_iterations: 2_000,
            },
        )?;
        Ok(a_f)
    }
}

/// The model's internal force (full length, force units) exact on the constrained rows: on
/// 4-node tets summed over `tets` alone (every tet with a constrained node), in tet order, so
/// those rows get the very bits of the whole mesh's sum at a fraction of its cost (the rows
/// of free nodes away from the supports are left partial); on other elements the whole mesh's.
fn support_internal_force(
    force: &super::NonlinearForce,
    u: &[f64],
    tets: &[usize],
) -> Result<Vec<f64>> {
    use crate::model::ModelElement;
    let Some(mesh) = force.mesh::<Tet4>() else {
        return force.model_internal_force(u);
    };
    Error::check_len("displacement", mesh.dof_count(), u.len())?;
    let models = force.models();
    let mut out = vec![0.0; u.len()];
    for &t in tets {
        Tet4::add_model_force(models.model_of(t), mesh, t, u, &mut out);
    }
    Ok(out)
}

/// Σₑ Kₑ(u)·vₑ over `tets` (full length): each tet's tangent of the nonlinear model at u,
/// PSD-projected as the implicit methods' stiffness damping takes it.
fn model_tangent_product(
    force: &super::NonlinearForce,
    u: &[f64],
    v: &[f64],
    tets: &[usize],
) -> Result<Vec<f64>> {
    // The per-tet tangent is the 4-node tet's (stiffness damping of a nonlinear model on
    // 10-node tets has no per-element tangent here yet).
    let mesh = force.mesh::<Tet4>().ok_or_else(|| {
        Error::invalid_parameter(
            "damping.stiffness",
            "> 0 with a nonlinear model on 10-node tets",
            "the support reactions need each tet's tangent, which only the 4-node tet provides \
             so far: use mass damping (damping.mass), order = 1 or the linear model",
        )
    })?;
    let models = force.models();
    let mut out = vec![0.0; u.len()];
    for &t in tets {
        let nodes = mesh.tets()[t];
        let x = crate::model::assemble::deformed_positions(mesh, t, u)?;
        let k = project_psd(&models.model_of(t).tangent(
            &mesh.element_of(t),
            &mesh.positions_of(t),
            &x,
        ));
        let ve = SVector::<f64, 12>::from_fn(|i, _| v[3 * nodes[i / 3] + i % 3]);
        let kv = k * ve;
        for (i, &node) in nodes.iter().enumerate() {
            for axis in 0..3 {
                out[3 * node + axis] += kv[3 * i + axis];
            }
        }
    }
    Ok(out)
}
