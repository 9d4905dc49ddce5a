//! The linear structural system on the free DOFs: K_ff, M_ff, Rayleigh damping and the external
//! loads (constant in time).

use std::sync::Arc;

use nalgebra::Vector3;

use super::time_data::{TimeData, TimeVarying};
use super::{DivergenceGuard, Energy, Rayleigh, State};
use crate::amg::DofGeometry;
use crate::analysis::problem::Problem;
use crate::base::error::{Error, Result};
use crate::base::vector::dot;
use crate::bc::constraints::{Constraints, DofMap};
use crate::bc::loads::Loads;
use crate::block_sparse::{SymmetricBlockMatrix3, SymmetricWorkspace};
use crate::fe::materials::TetMaterials;
use crate::mesh::TetMesh;
use crate::sparse::CscMatrix;

/// Lumped (diagonal) or consistent mass (scene files: `lumped`, `consistent`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Deserialize, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum MassKind {
    /// ρV/4 per node and axis: diagonal, what explicit methods need. The default.
    #[default]
    Lumped,
    /// ρV/20·(1+δᵢⱼ) blocks on the stiffness pattern.
    Consistent,
}

/// The mass matrix on the free DOFs.
#[derive(Debug, Clone)]
pub enum Mass {
    /// Diagonal entries (mass units).
    Lumped(Vec<f64>),
    /// Sparse, on the pattern of K_ff.
    Consistent(CscMatrix),
}

impl Mass {
    /// y = M·x ([`Error::DimensionMismatch`] unless both have length [`dim`](Self::dim)).
    pub fn mul_vec(&self, x: &[f64], y: &mut [f64]) -> Result<()> {
        Error::check_len("x", self.dim(), x.len())?;
        Error::check_len("y", self.dim(), y.len())?;
        self.product_into(x, y);
        Ok(())
    }

    /// y = M·x for vectors of length `dim()` by construction.
    pub(crate) fn product_into(&self, x: &[f64], y: &mut [f64]) {
        match self {
            Mass::Lumped(m) => {
                for ((y, m), x) in y.iter_mut().zip(m).zip(x) {
                    *y = m * x;
                }
            }
            Mass::Consistent(m) => m.product_into(x, y),
        }
    }

    /// xᵀ·M·x.
    pub fn quadratic_form(&self, x: &[f64]) -> Result<f64> {
        Error::check_len("x", self.dim(), x.len())?;
        Ok(match self {
            Mass::Lumped(m) => m.iter().zip(x).map(|(m, x)| m * x * x).sum(),
            Mass::Consistent(m) => m.quadratic_form(x)?,
        })
    }

    /// Number of free DOFs it acts on.
    pub fn dim(&self) -> usize {
        match self {
            Mass::Lumped(m) => m.len(),
            Mass::Consistent(m) => m.dim(),
        }
    }
}

/// Scratch of [`LinearSystem::energy_with`] (from [`LinearSystem::energy_workspace`]): a
/// vector of the free DOF count for K·u and M·v, and the four-slot vectors of K's block
/// products. A caller that takes energies every step keeps one.
#[derive(Debug, Clone)]
pub struct EnergyWorkspace {
    product: Vec<f64>,
    blocks: SymmetricWorkspace,
}

/// M·ü + C·u̇ + K·u = f on the free DOFs, with C = α·M + β·K and f constant.
#[derive(Debug, Clone)]
pub struct LinearSystem {
    stiffness: CscMatrix,
    /// K_ff again, in 3×3 node blocks: about half the bytes per product.
    stiffness_blocks: SymmetricBlockMatrix3,
    mass: Mass,
    /// The consistent mass without its zero couplings between axes, for products (a third of
    /// its entries; the same bits: [`CscMatrix::without_zeros`]); `None` for a lumped mass.
    mass_product: Option<CscMatrix>,
    damping: Rayleigh,
    gravity_load: Vec<f64>,
    other_load: Vec<f64>,
    external: Vec<f64>,
    dofs: DofMap,
    /// Where the free DOFs sit (from [`new`](Self::new); `None` from
    /// [`from_parts`](Self::from_parts)): the rigid-body modes of the implicit methods'
    /// multigrid preconditioner on their iterative path.
    geometry: Option<DofGeometry>,
    /// Loads with amplitudes and moving supports (`None`: everything constant, the loads are
    /// [`external_load`](Self::external_load) at every time).
    time: Option<Box<TimeVarying>>,
    /// K_fc·u_c of the prescribed displacements that do not move (force units, free rows),
    /// which [`other_load`](Self::other_load) holds with a minus sign; `None` when they are all
    /// zero. A nonlinear force evaluates the supports' elastic coupling itself, on the full
    /// displacement, and takes the loads without it ([`model_load_at`](Self::model_load_at)).
    support_coupling: Option<Vec<f64>>,
}

impl LinearSystem {
    /// Assembles the system of a mesh: K and M restricted to the free DOFs of `constraints`
    /// (checked to hold every rigid mode), gravity `gravity` (acceleration, e.g. (0, 0, −9.81)
    /// m/s²) as its own load, the other `loads` and the constant −K_fc·u_c of prescribed
    /// displacements as the rest.
    ///
    /// `materials`: one [`Material`](crate::fe::material::Material) for every tet, or a
    /// [`MaterialMap`](crate::fe::materials::MaterialMap) (K, M and gravity per tet).
    ///
    /// Any element type: the linear tet, or the quadratic one ([`Tet10`](crate::fe::element::Tet10),
    /// whose lumped mass is HRZ).
    pub fn new<E: crate::fe::element::ElementType>(
        mesh: &TetMesh<E>,
        materials: &impl TetMaterials,
        constraints: &Constraints,
        loads: &Loads,
        gravity: Vector3<f64>,
        mass: MassKind,
        damping: Rayleigh,
    ) -> Result<Self> {
        Self::assemble(
            mesh,
            materials,
            constraints,
            loads,
            gravity,
            mass,
            damping,
            None,
            true,
        )
    }

    /// [`new`](Self::new) with loads and prescribed displacements that follow time: `data`'s
    /// loads scaled by their amplitudes on top of `loads`, gravity scaled by its amplitude,
    /// and the DOFs of `data.motion` (which `constraints` must constrain; their values there
    /// are ignored) moving with it. The integrators then take the load at each step's time
    /// from [`external_load_at`](Self::external_load_at), and
    /// [`expand_at`](Self::expand_at) gives the full displacement with u_c(t).
    ///
    /// [`external_load`](Self::external_load) (and the energies' load potentials) stay the
    /// constant part: f_g + f₀ without the amplitudes' loads and the moving DOFs' coupling.
    /// With constant `data` ([`TimeData::is_constant`]) it is [`new`](Self::new), bit for bit.
    ///
    /// Errors: those of [`new`](Self::new), and [`Error::InvalidParameter`] naming a moving DOF
    /// that is not constrained, or loads of another mesh.
    #[allow(clippy::too_many_arguments)]
    pub fn with_time_data<E: crate::fe::element::ElementType>(
        mesh: &TetMesh<E>,
        materials: &impl TetMaterials,
        constraints: &Constraints,
        loads: &Loads,
        gravity: Vector3<f64>,
        mass: MassKind,
        damping: Rayleigh,
        data: &TimeData,
    ) -> Result<Self> {
        let data = (!data.is_constant()).then_some(data);
        Self::assemble(
            mesh,
            materials,
            constraints,
            loads,
            gravity,
            mass,
            damping,
            data,
            true,
        )
    }

    /// [`new`](Self::new) without the check that the constraints hold every rigid mode: for a
    /// body in free flight or held only by contact with obstacles (a falling block). Time steps
    /// are well posed (the mass holds the rigid modes); [`static_displacement`](Self::static_displacement)
    /// is not (K_ff is singular), and fails in its factorization.
    pub fn new_free_body<E: crate::fe::element::ElementType>(
        mesh: &TetMesh<E>,
        materials: &impl TetMaterials,
        constraints: &Constraints,
        loads: &Loads,
        gravity: Vector3<f64>,
        mass: MassKind,
        damping: Rayleigh,
    ) -> Result<Self> {
        Self::assemble(
            mesh,
            materials,
            constraints,
            loads,
            gravity,
            mass,
            damping,
            None,
            false,
        )
    }

    /// [`new_free_body`](Self::new_free_body) with loads and prescribed displacements that
    /// follow time (see [`with_time_data`](Self::with_time_data)): a body held by contact,
    /// under loads with amplitudes or on moving supports. With constant `data` it is
    /// [`new_free_body`](Self::new_free_body), bit for bit. Errors: those of both.
    #[allow(clippy::too_many_arguments)]
    pub fn new_free_body_with_time_data<E: crate::fe::element::ElementType>(
        mesh: &TetMesh<E>,
        materials: &impl TetMaterials,
        constraints: &Constraints,
        loads: &Loads,
        gravity: Vector3<f64>,
        mass: MassKind,
        damping: Rayleigh,
        data: &TimeData,
    ) -> Result<Self> {
        let data = (!data.is_constant()).then_some(data);
        Self::assemble(
            mesh,
            materials,
            constraints,
            loads,
            gravity,
            mass,
            damping,
            data,
            false,
        )
    }

    /// [`new`](Self::new), with time-varying `data` and the rigid-mode check when `check_held`
    /// is set.
    #[allow(clippy::too_many_arguments)]
    fn assemble<E: crate::fe::element::ElementType>(
        mesh: &TetMesh<E>,
        materials: &impl TetMaterials,
        constraints: &Constraints,
        loads: &Loads,
        gravity: Vector3<f64>,
        mass: MassKind,
        damping: Rayleigh,
        data: Option<&TimeData>,
        check_held: bool,
    ) -> Result<Self> {
        if constraints.dof_count() != mesh.dof_count() || loads.as_slice().len() != mesh.dof_count()
        {
            return Err(Error::invalid_parameter(
                "constraints/loads",
                "another mesh",
                "must be made for this mesh",
            ));
        }
        // Before any allocation: K, M and the step matrix with the least-memory solver (a factor
        // is checked once its size is known, in `LinearSolver::analyze_with_geometry`).
        let estimate = crate::base::memory::StaticEstimate::for_element(
            mesh.node_count(),
            mesh.tet_count(),
            E::NODES,
            crate::base::memory::SolverMemory::Iterative,
        );
        let extra = estimate.dynamic_extra();
        crate::base::memory::MemoryLimits::current().ensure_fits(
            format!(
                "the dynamic system: {} + {} for the mass and step matrices, of which the mesh is \
                 held already",
                estimate.describe(),
                crate::base::memory::format_bytes(extra)
            ),
            estimate.beyond_mesh() + extra,
        )?;
        materials.check_tet_count(mesh)?;
        let problem = match check_held {
            true => Problem::new(mesh, constraints)?,
            false => Problem::with_dofs(mesh, crate::bc::constraints::DofMap::new(constraints))?,
        };
        let k_full = problem.stiffness(materials)?;
        let stiffness = problem.restrict(&k_full)?;
        let mass_kind = mass;
        let mass = match mass {
            MassKind::Lumped => Mass::Lumped(problem.free_lumped_mass(materials)?),
            MassKind::Consistent => Mass::Consistent(problem.free_consistent_mass(materials)?),
        };
        let gravity_loads = problem.gravity_loads(materials, gravity)?;
        let full_mass = match (data, mass_kind) {
            (Some(_), MassKind::Consistent) => Some(problem.consistent_mass(materials)?),
            _ => None,
        };
        let dofs = problem.into_dofs();
        let time = match data {
            Some(data) => Some(Box::new(TimeVarying::new(
                data,
                mesh.nodes(),
                &dofs,
                &k_full,
                full_mass.as_ref(),
            )?)),
            None => None,
        };
        // The moving DOFs' coupling is taken at each time instead (`TimeVarying::load_into`).
        let coupling = match &time {
            Some(time) if time.has_motion() => {
                let mut still = dofs.prescribed().to_vec();
                for &dof in time.moving_dofs() {
                    still[dof] = 0.0;
                }
                k_full.mul(&still)?
            }
            _ => k_full.mul(dofs.prescribed())?,
        };
        let other: Vec<f64> = loads
            .as_slice()
            .iter()
            .zip(&coupling)
            .map(|(f, k)| f - k)
            .collect();
        let support_coupling = match coupling.iter().any(|&k| k != 0.0) {
            true => Some(dofs.restrict(&coupling)?),
            false => None,
        };
        let geometry = dofs.geometry(mesh)?;
        let mut system = Self::from_parts(
            stiffness,
            mass,
            damping,
            dofs.restrict(gravity_loads.as_slice())?,
            dofs.restrict(&other)?,
            dofs,
        )?;
        system.geometry = Some(geometry);
        system.time = time;
        system.support_coupling = support_coupling;
        Ok(system)
    }

    /// A system from its parts (all on the free DOFs of `dofs`).
    pub fn from_parts(
        stiffness: CscMatrix,
        mass: Mass,
        damping: Rayleigh,
        gravity_load: Vec<f64>,
        other_load: Vec<f64>,
        dofs: DofMap,
    ) -> Result<Self> {
        let n = dofs.free_count();
        Rayleigh::new(damping.alpha, damping.beta)?;
        let mass_len = match &mass {
            Mass::Lumped(m) => m.len(),
            Mass::Consistent(m) => m.dim(),
        };
        if stiffness.dim() != n || mass_len != n || gravity_load.len() != n || other_load.len() != n
        {
            return Err(Error::invalid_parameter(
                "system parts",
                format!(
                    "K {}, M {mass_len}, loads {}/{}",
                    stiffness.dim(),
                    gravity_load.len(),
                    other_load.len()
                ),
                format!("must all have the free DOF count {n}"),
            ));
        }
        if let Mass::Lumped(m) = &mass
            && let Some(i) = m.iter().position(|m| !(m.is_finite() && *m > 0.0))
        {
            return Err(Error::invalid_parameter(
                format!("lumped mass of free DOF {i}"),
                m[i],
                "must be finite and > 0 (a node with no tet?)",
            ));
        }
        if let Mass::Consistent(m) = &mass
            && !Arc::ptr_eq(m.pattern(), stiffness.pattern())
        {
            return Err(Error::invalid_parameter(
                "consistent mass",
                "another pattern",
                "must share the stiffness matrix's pattern",
            ));
        }
        let external = gravity_load
            .iter()
            .zip(&other_load)
            .map(|(g, f)| g + f)
            .collect();
        let stiffness_blocks =
            SymmetricBlockMatrix3::from_free_matrix(&stiffness, dofs.free_dofs())?;
        let mass_product = match &mass {
            Mass::Consistent(m) => Some(m.without_zeros()?),
            Mass::Lumped(_) => None,
        };
        Ok(LinearSystem {
            stiffness,
            stiffness_blocks,
            mass,
            mass_product,
            damping,
            gravity_load,
            other_load,
            external,
            dofs,
            geometry: None,
            time: None,
            support_coupling: None,
        })
    }

    /// Number of free DOFs.
    pub fn free_count(&self) -> usize {
        self.dofs.free_count()
    }

    /// K_ff.
    pub fn stiffness(&self) -> &CscMatrix {
        &self.stiffness
    }

    /// K_ff's upper half in 3×3 node blocks, the copy the time steppers multiply with (see
    /// [`SymmetricBlockMatrix3`] for why).
    pub fn stiffness_blocks(&self) -> &SymmetricBlockMatrix3 {
        &self.stiffness_blocks
    }

    /// Node, axis and position of each free DOF (`None` for a system built
    /// [`from_parts`](Self::from_parts)).
    pub fn geometry(&self) -> Option<&DofGeometry> {
        self.geometry.as_ref()
    }

    /// M_ff.
    pub fn mass(&self) -> &Mass {
        &self.mass
    }

    /// y = M·x for vectors of the free DOF count by construction: a consistent mass through its
    /// copy without the zero couplings between axes (a third of the entries read, the same
    /// bits for a finite x), a lumped one entry by entry.
    pub(crate) fn mass_product_into(&self, x: &[f64], y: &mut [f64]) {
        match &self.mass_product {
            Some(m) => m.product_into(x, y),
            None => self.mass.product_into(x, y),
        }
    }

    /// The consistent mass without its zero couplings between axes (`None` for a lumped mass):
    /// the copy products and iterative solves with M_ff read, the same bits as M_ff's for
    /// finite vectors.
    pub(crate) fn compact_mass(&self) -> Option<&CscMatrix> {
        self.mass_product.as_ref()
    }

    /// yₖ = M·xₖ for three vectors in one read of M (see [`mass_product_into`](Self::mass_product_into)):
    /// each yₖ has the bits `mass_product_into` gives it.
    pub(crate) fn mass_product3_into(&self, x: [&[f64]; 3], y: [&mut [f64]; 3]) {
        match &self.mass_product {
            Some(m) => m.product3_into(x, y),
            None => {
                for (x, y) in x.into_iter().zip(y) {
                    self.mass.product_into(x, y);
                }
            }
        }
    }

    /// The Rayleigh damping.
    pub fn damping(&self) -> Rayleigh {
        self.damping
    }

    /// The same system with other damping.
    ///
    /// The coefficients are checked (finite, ≥ 0) when an integrator is built on the system:
    /// negative damping would feed energy in.
    pub fn with_damping(mut self, damping: Rayleigh) -> Self {
        self.damping = damping;
        self
    }

    /// The same system with its loads scaled by `factor` (0 removes them: free vibration).
    pub fn with_load_factor(mut self, factor: f64) -> Self {
        for f in self
            .gravity_load
            .iter_mut()
            .chain(&mut self.other_load)
            .chain(&mut self.external)
        {
            *f *= factor;
        }
        self
    }

    /// Total external load f on the free DOFs (force units).
    pub fn external_load(&self) -> &[f64] {
        &self.external
    }

    /// The external load on the free DOFs at time `t` (force units): with data that follow
    /// time ([`with_time_data`](Self::with_time_data)), a_g(t)·f_g + f₀ + Σ aₖ(t)·fₖ −
    /// K_fm·u_m(t) − C_fm·u̇_m(t) − M_fm·ü_m(t) written into `buffer` (see
    /// [`TimeData`]); otherwise [`external_load`](Self::external_load) itself, `buffer`
    /// untouched (so constant data cost nothing and give the same bits).
    ///
    /// [`Error::DimensionMismatch`] unless `buffer` has the free DOF count when it is needed.
    pub fn external_load_at<'a>(&'a self, t: f64, buffer: &'a mut [f64]) -> Result<&'a [f64]> {
        match &self.time {
            None => Ok(&self.external),
            Some(time) => {
                let damping = (self.damping.alpha, self.damping.beta);
                time.load_into(
                    t,
                    &self.gravity_load,
                    &self.other_load,
                    damping,
                    true,
                    buffer,
                )?;
                Ok(buffer)
            }
        }
    }

    /// The external load on the free DOFs at time `t` that the step equations of a force law
    /// take (force units): for the linear one (`nonlinear` false) exactly
    /// [`external_load_at`](Self::external_load_at); for a nonlinear one the same load without
    /// the supports' elastic coupling −K_fc·u_c (constant supports) and −K_fm·u_m(t) (moving
    /// ones), which its internal force f_int(u_f, u_c(t)) holds already, evaluated on the full
    /// displacement:
    ///
    /// f_nl(t) = a_g(t)·f_g + f₀ + K_fc·u_c + Σ aₖ(t)·fₖ − β·K_fm·u̇_m(t) − M_fm·(ü_m(t) + α·u̇_m(t)).
    ///
    /// With fixed zero supports and constant loads it is [`external_load`](Self::external_load)
    /// itself (`buffer` untouched), so the nonlinear runs of before keep their bits; otherwise
    /// it is written into `buffer`, which must have the free DOF count
    /// ([`model_load_buffer`](Self::model_load_buffer)).
    pub fn model_load_at<'a>(
        &'a self,
        t: f64,
        nonlinear: bool,
        buffer: &'a mut [f64],
    ) -> Result<&'a [f64]> {
        if !nonlinear {
            return self.external_load_at(t, buffer);
        }
        match (&self.time, &self.support_coupling) {
            (None, None) => return Ok(&self.external),
            (Some(time), _) => {
                let damping = (self.damping.alpha, self.damping.beta);
                time.load_into(
                    t,
                    &self.gravity_load,
                    &self.other_load,
                    damping,
                    false,
                    buffer,
                )?;
            }
            (None, Some(_)) => {
                Error::check_len("load buffer", self.free_count(), buffer.len())?;
                buffer.copy_from_slice(&self.external);
            }
        }
        if let Some(coupling) = &self.support_coupling {
            for (f, k) in buffer.iter_mut().zip(coupling) {
                *f += k;
            }
        }
        Ok(buffer)
    }

    /// Whether prescribed displacements pull on the free DOFs: some constant one is not zero,
    /// or some support moves (then a nonlinear force's load [`model_load_at`](Self::model_load_at)
    /// lacks their coupling, which its internal force holds).
    pub fn has_support_coupling(&self) -> bool {
        self.support_coupling.is_some() || self.has_moving_supports()
    }

    /// ‖f(t)‖ of [`external_load_at`](Self::external_load_at) (force units): the scale of the
    /// forces on the free DOFs, the supports' coupling included.
    pub fn load_norm_at(&self, t: f64) -> Result<f64> {
        let mut buffer = self.load_buffer();
        let f = self.external_load_at(t, &mut buffer)?;
        Ok(dot(f, f).sqrt())
    }

    /// A load buffer for [`model_load_at`](Self::model_load_at) with `nonlinear` (the free DOF
    /// count when it is needed, empty otherwise).
    pub fn model_load_buffer(&self, nonlinear: bool) -> Vec<f64> {
        match nonlinear && self.support_coupling.is_some() {
            true => vec![0.0; self.free_count()],
            false => self.load_buffer(),
        }
    }

    /// The full displacement of the constrained DOFs at time `t` (zero on the free DOFs): the
    /// prescribed values, the moving ones at u_c(t) (length, every DOF of the mesh).
    pub fn prescribed_at(&self, t: f64) -> Result<Vec<f64>> {
        let mut full = self.dofs.prescribed().to_vec();
        for &d in self.dofs.free_dofs() {
            full[d] = 0.0;
        }
        if let Some(time) = self.time.as_ref().filter(|t| t.has_motion()) {
            for (&dof, [u, _, _]) in time.moving_dofs().iter().zip(time.motion_at(t)?) {
                full[dof] = u;
            }
        }
        Ok(full)
    }

    /// Whether the loads or prescribed displacements follow time (then the integrators need a
    /// load buffer of the free DOF count for [`external_load_at`](Self::external_load_at)).
    pub fn is_time_varying(&self) -> bool {
        self.time.is_some()
    }

    /// Whether some constrained DOF moves in time.
    pub fn has_moving_supports(&self) -> bool {
        self.time.as_ref().is_some_and(|t| t.has_motion())
    }

    /// A load buffer for [`external_load_at`](Self::external_load_at): the free DOF count when
    /// the data follow time, empty otherwise.
    pub fn load_buffer(&self) -> Vec<f64> {
        match self.time {
            Some(_) => vec![0.0; self.free_count()],
            None => Vec::new(),
        }
    }

    /// The full displacement at time `t` of free values `free`: the constrained DOFs at their
    /// prescribed values, the moving ones at u_c(t) ([`Error::DimensionMismatch`] unless `free`
    /// has the free DOF count).
    pub fn expand_at(&self, t: f64, free: &[f64]) -> Result<Vec<f64>> {
        let mut full = self.dofs.expand(free)?;
        if let Some(time) = self.time.as_ref().filter(|t| t.has_motion()) {
            for (&dof, [u, _, _]) in time.moving_dofs().iter().zip(time.motion_at(t)?) {
                full[dof] = u;
            }
        }
        Ok(full)
    }

    /// The divergence guard of a run starting with energies `start`: the energy check of
    /// [`DivergenceGuard::new`], or with data that follow time ([`is_time_varying`](Self::is_time_varying))
    /// the check of finite values only ([`DivergenceGuard::finite_only`]): moving supports and
    /// loads with amplitudes do work the energies' constant load potentials do not account for.
    /// [`Error::Diverged`] at `step`, `time` if the start's energies are not finite
    /// ([`Energy::check_start`]).
    pub fn divergence_guard(
        &self,
        start: Energy,
        (step, time): (usize, f64),
    ) -> Result<DivergenceGuard> {
        start.check_start(step, time)?;
        Ok(match self.is_time_varying() {
            true => DivergenceGuard::finite_only(start),
            false => DivergenceGuard::new(start),
        })
    }

    /// The gravity part of [`external_load`](Self::external_load) (force units, free DOFs).
    pub fn gravity_load(&self) -> &[f64] {
        &self.gravity_load
    }

    /// The rest of [`external_load`](Self::external_load): the other loads and −K_fc·u_c.
    pub fn other_load(&self) -> &[f64] {
        &self.other_load
    }

    /// The free/constrained DOF map.
    pub fn dofs(&self) -> &DofMap {
        &self.dofs
    }

    /// The energies of `state`; see [`Energy`] and [`energy_with`](Self::energy_with), whose
    /// formulas these are (the scratch allocated here).
    ///
    /// [`Error::DimensionMismatch`] if the state is not on this system's free DOFs.
    pub fn energy(&self, state: &State) -> Result<Energy> {
        self.energy_with(state, &mut self.energy_workspace())
    }

    /// Scratch for [`energy_with`](Self::energy_with), sized for this system.
    pub fn energy_workspace(&self) -> EnergyWorkspace {
        EnergyWorkspace {
            product: vec![0.0; self.free_count()],
            blocks: self.stiffness_blocks.workspace(),
        }
    }

    /// The energies of `state` (energy units, J in SI) with caller-owned scratch, so that a
    /// caller taking them every step (a scene's recorder) allocates nothing:
    ///
    /// - elastic ½·uᵀ·K·u, with K·u from the upper node-block copy of K_ff
    ///   ([`stiffness_blocks`](Self::stiffness_blocks)), the product the time steppers take:
    ///   it reads about half the bytes of the CSC product (each stored off-diagonal block serves
    ///   K_ij and K_ji) and returns uᵀ·(K·u) summed over fixed chunks, the same bits whatever
    ///   the thread count; on a 36,720-DOF P2 beam the CSC product made the recorder's
    ///   energies cost about a fifth of a Newmark step;
    /// - kinetic ½·vᵀ·M·v ([`kinetic_energy_with`](Self::kinetic_energy_with));
    /// - the load potentials −f_g·u and −f·u.
    ///
    /// The elastic energy differs from the CSC product's uᵀ·K·u in its last bits only (another
    /// summation order). [`Error::DimensionMismatch`] if the state is not on this system's
    /// free DOFs or `work` is another system's.
    pub fn energy_with(&self, state: &State, work: &mut EnergyWorkspace) -> Result<Energy> {
        state.check_len(self.free_count())?;
        let twice_elastic = self.stiffness_blocks.mul_vec_with(
            &state.displacement,
            &mut work.product,
            &mut work.blocks,
        )?;
        self.energies(state, twice_elastic, &mut work.product)
    }

    /// [`energy_with`](Self::energy_with) on scratch an integrator holds (`product` of the free
    /// DOF count, `blocks` from K's block copy), by construction of the right sizes.
    pub(crate) fn energy_into(
        &self,
        state: &State,
        product: &mut [f64],
        blocks: &mut SymmetricWorkspace,
    ) -> Result<Energy> {
        state.check_len(self.free_count())?;
        let twice_elastic =
            self.stiffness_blocks
                .product_into(&state.displacement, product, blocks);
        self.energies(state, twice_elastic, product)
    }

    /// The energies of `state` from its uᵀ·K·u, with ½vᵀMv and the potentials computed here.
    fn energies(&self, state: &State, twice_elastic: f64, scratch: &mut [f64]) -> Result<Energy> {
        let u = &state.displacement;
        Ok(Energy {
            kinetic: 0.5 * self.twice_kinetic_into(&state.velocity, scratch),
            elastic: 0.5 * twice_elastic,
            gravity_potential: -dot(&self.gravity_load, u),
            load_potential: -dot(&self.other_load, u),
        })
    }

    /// The kinetic energy ½·vᵀ·M·v of free velocities `velocity` (energy units), with
    /// caller-owned scratch: M·v through the consistent mass's copy without its zero couplings
    /// (a third of its entries, the same bits as the full product for a finite v) or the
    /// lumped diagonal, then vᵀ·(M·v) summed in DOF order. [`Error::DimensionMismatch`] unless
    /// `velocity` has the free DOF count and `work` is this system's.
    pub fn kinetic_energy_with(&self, velocity: &[f64], work: &mut EnergyWorkspace) -> Result<f64> {
        Error::check_len("velocity", self.free_count(), velocity.len())?;
        Error::check_len("energy workspace", self.free_count(), work.product.len())?;
        Ok(0.5 * self.twice_kinetic_into(velocity, &mut work.product))
    }

    /// vᵀ·M·v of [`kinetic_energy_with`](Self::kinetic_energy_with) with its scratch allocated
    /// here (twice the kinetic energy, energy units); [`Error::DimensionMismatch`] unless
    /// `velocity` has the free DOF count.
    pub(crate) fn twice_kinetic(&self, velocity: &[f64]) -> Result<f64> {
        Error::check_len("velocity", self.free_count(), velocity.len())?;
        Ok(self.twice_kinetic_into(velocity, &mut vec![0.0; self.free_count()]))
    }

    /// vᵀ·M·v with `scratch` receiving M·v (both of the free DOF count by construction): the
    /// one formula of the kinetic energy, for the recorder, the integrators' guards and the
    /// nonlinear force's energies.
    pub(crate) fn twice_kinetic_into(&self, velocity: &[f64], scratch: &mut [f64]) -> f64 {
        self.mass_product_into(velocity, scratch);
        dot(velocity, scratch)
    }

    /// Fills `out` (on K_ff's pattern) with a·K + b·M, entry-wise: the system matrices of the
    /// implicit methods, formed without a new sparse sum.
    pub fn combine_into(
        &self,
        stiffness_scale: f64,
        mass_scale: f64,
        out: &mut CscMatrix,
    ) -> Result<()> {
        super::internal_force::combine(
            &self.stiffness,
            stiffness_scale,
            &self.mass,
            mass_scale,
            out,
        )
    }

    /// The load potentials of `state` (the kinetic and elastic terms left zero).
    pub fn energy_potentials(&self, state: &State) -> Result<Energy> {
        state.check_len(self.free_count())?;
        Ok(Energy {
            gravity_potential: -dot(&self.gravity_load, &state.displacement),
            load_potential: -dot(&self.other_load, &state.displacement),
            ..Energy::default()
        })
    }

    /// The load potentials of `state` under a nonlinear force law: those of
    /// [`energy_potentials`](Self::energy_potentials) with the supports' coupling K_fc·u_c
    /// taken out of the load potential, −(f₀ + K_fc·u_c)·u (the model's elastic energy holds
    /// it, evaluated on the full displacement).
    pub fn model_energy_potentials(&self, state: &State) -> Result<Energy> {
        let mut energy = self.energy_potentials(state)?;
        if let Some(coupling) = &self.support_coupling {
            energy.load_potential -= dot(coupling, &state.displacement);
        }
        Ok(energy)
    }

    /// The static solution K_ff⁻¹·f (free DOFs). [`Error::InvalidParameter`] naming the free DOF
    /// if a load is not finite (e.g. after [`with_load_factor`](Self::with_load_factor) with NaN).
    pub fn static_displacement(&self) -> Result<Vec<f64>> {
        if let Some(i) = self.external.iter().position(|f| !f.is_finite()) {
            return Err(Error::invalid_parameter(
                format!("load of free DOF {i}"),
                self.external[i],
                "must be finite (is the load factor NaN or infinite?)",
            ));
        }
        let mut cholesky = crate::linsolve::SparseCholesky::analyze(&self.stiffness)?;
        cholesky.factorize(&self.stiffness)?;
        let mut u = self.external.clone();
        cholesky.solve_in_place(&mut u)?;
        Ok(u)
    }
}
