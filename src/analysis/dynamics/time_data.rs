//! Loads and prescribed displacements that follow time, as a [`LinearSystem`](super::LinearSystem)
//! holds them: the external load on the free DOFs at a time t is
//!
//! f(t) = a_g(t)·f_g + f₀ + Σₖ aₖ(t)·fₖ − K_fm·u_m(t) − C_fm·u̇_m(t) − M_fm·ü_m(t),
//!
//! f_g the gravity load, f₀ the loads without amplitude (and −K_fc·u_c of the constraints that do
//! not move), fₖ the loads with amplitude aₖ, u_m the moving DOFs' prescribed displacement
//! ([`BoundaryMotion`]) and K_fm, C_fm = α·M_fm + β·K_fm, M_fm (zero for lumped mass) the
//! columns of the full matrices that couple the free rows to the moving DOFs.

use nalgebra::Vector3;

use crate::base::error::{Error, Result};
use crate::bc::amplitude::Amplitude;
use crate::bc::boundary_motion::BoundaryMotion;
use crate::bc::constraints::DofMap;
use crate::bc::loads::Loads;
use crate::sparse::CscMatrix;

/// What a [`LinearSystem`](super::LinearSystem) needs beyond its constant loads to follow time
/// (see [`LinearSystem::with_time_data`](super::LinearSystem::with_time_data)).
#[derive(Debug, Clone, Default)]
pub struct TimeData {
    /// Loads (force units, every DOF of the mesh), each scaled by its amplitude: added to the
    /// constant loads.
    pub loads: Vec<(Loads, Amplitude)>,
    /// The amplitude of the gravity load (default: constant 1).
    pub gravity: Amplitude,
    /// The constrained DOFs that move, and how.
    pub motion: BoundaryMotion,
}

impl TimeData {
    /// Whether it changes nothing: no load with an amplitude, gravity constant 1, no motion.
    pub fn is_constant(&self) -> bool {
        self.loads.is_empty() && self.gravity.is_one() && self.motion.is_empty()
    }
}

/// One column of a full matrix, restricted to the free rows: (free row, value).
type Column = Vec<(usize, f64)>;

/// [`TimeData`] compiled for one system: loads restricted to the free DOFs, the coupling
/// columns of the moving DOFs.
#[derive(Debug, Clone)]
pub(crate) struct TimeVarying {
    gravity: Amplitude,
    loads: Vec<(Vec<f64>, Amplitude)>,
    motion: BoundaryMotion,
    /// The mesh's reference node positions (what the motion is evaluated at).
    positions: Vec<Vector3<f64>>,
    /// The moving DOFs (full indices), in [`BoundaryMotion::dofs`] order.
    moving: Vec<usize>,
    stiffness_columns: Vec<Column>,
    /// `None` with lumped mass (M_fm = 0).
    mass_columns: Option<Vec<Column>>,
}

/// Column `dof` of `full` on the free rows of `dofs`.
fn free_column(full: &CscMatrix, dofs: &DofMap, dof: usize) -> Column {
    let range = full.col_ptr()[dof]..full.col_ptr()[dof + 1];
    full.row_idx()[range.clone()]
        .iter()
        .zip(&full.values()[range])
        .filter_map(|(&row, &value)| dofs.free_index(row).map(|i| (i, value)))
        .collect()
}

impl TimeVarying {
    /// Compiles `data` for the free DOFs of `dofs`; `stiffness` and `mass` (consistent, or
    /// `None` for lumped) are the full matrices. [`Error::InvalidParameter`] naming the DOF if a
    /// moving DOF is not constrained.
    pub fn new(
        data: &TimeData,
        positions: &[Vector3<f64>],
        dofs: &DofMap,
        stiffness: &CscMatrix,
        mass: Option<&CscMatrix>,
    ) -> Result<Self> {
        let moving = data.motion.dofs();
        if let Some(&dof) = moving
            .iter()
            .find(|&&d| d >= dofs.full_count() || dofs.free_index(d).is_some())
        {
            return Err(Error::invalid_parameter(
                format!("moving DOF {dof} (node {}, axis {})", dof / 3, dof % 3),
                "free",
                "must be constrained (a motion prescribes constrained DOFs only)",
            ));
        }
        let loads = data
            .loads
            .iter()
            .map(|(l, a)| Ok((dofs.restrict(l.as_slice())?, a.clone())))
            .collect::<Result<Vec<_>>>()?;
        Ok(TimeVarying {
            gravity: data.gravity.clone(),
            loads,
            motion: data.motion.clone(),
            positions: positions.to_vec(),
            stiffness_columns: moving
                .iter()
                .map(|&d| free_column(stiffness, dofs, d))
                .collect(),
            mass_columns: mass.map(|m| moving.iter().map(|&d| free_column(m, dofs, d)).collect()),
            moving,
        })
    }

    /// The moving DOFs (full indices).
    pub fn moving_dofs(&self) -> &[usize] {
        &self.moving
    }

    /// Whether any constrained DOF moves.
    pub fn has_motion(&self) -> bool {
        !self.moving.is_empty()
    }

    /// [u, u̇, ü] of each moving DOF at `t`.
    pub fn motion_at(&self, t: f64) -> Result<Vec<[f64; 3]>> {
        self.motion.evaluate(&self.positions, t)
    }

    /// f(t) into `out` (free DOFs): see the module's formula. `gravity` and `constant` are the
    /// system's f_g and f₀; (α, β) its Rayleigh coefficients. Without `elastic` the moving
    /// DOFs' elastic coupling −K_fm·u_m(t) is left out (their damping and inertia coupling
    /// kept): the load of a nonlinear force law, whose internal force is evaluated on the full
    /// displacement with u_m(t) in it.
    pub fn load_into(
        &self,
        t: f64,
        gravity: &[f64],
        constant: &[f64],
        damping: (f64, f64),
        elastic: bool,
        out: &mut [f64],
    ) -> Result<()> {
        Error::check_len("load buffer", constant.len(), out.len())?;
        let a_g = self.gravity.value(t);
        for ((o, g), c) in out.iter_mut().zip(gravity).zip(constant) {
            *o = a_g * g + c;
        }
        for (f, amplitude) in &self.loads {
            let a = amplitude.value(t);
            for (o, f) in out.iter_mut().zip(f) {
                *o += a * f;
            }
        }
        if self.moving.is_empty() {
            return Ok(());
        }
        let (alpha, beta) = damping;
        let motion = self.motion_at(t)?;
        for (j, [u, v, a]) in motion.iter().enumerate() {
            // K_fm·u + β·K_fm·u̇ (+ M_fm·(ü + α·u̇) for consistent mass).
            let stiffness_factor = match elastic {
                true => u + beta * v,
                false => beta * v,
            };
            for &(row, k) in &self.stiffness_columns[j] {
                out[row] -= k * stiffness_factor;
            }
            if let Some(columns) = &self.mass_columns {
                let mass_factor = a + alpha * v;
                for &(row, m) in &columns[j] {
                    out[row] -= m * mass_factor;
                }
            }
        }
        Ok(())
    }
}
