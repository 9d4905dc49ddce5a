//! Support reactions of a dynamic run, per node and per `[[constraints]]` entry: the library's
//! [`SupportReactions`] (r_c = M·a + C·v − f_int − f_ext on the constrained rows) summed over each
//! entry's DOFs into a resultant force (N) and its moment (N·m) about the entry's
//! `moment_about` point, for the CSV columns of every step, the `.vtu` frames and the summary.

use nalgebra::Vector3;

use super::{BuiltScene, ReactionRow};
use tetfem::analysis::dynamics::{InternalForce, LinearSystem, State, SupportReactions};
use tetfem::base::error::Result;
use tetfem::mesh::CellType;

/// One support: its name in the summary, its DOFs and the point its moment is about (m).
#[derive(Debug, Clone)]
struct SupportSet {
    name: String,
    dofs: Vec<usize>,
    point: Vector3<f64>,
}

/// The reactions of a dynamic setup, per node and per support set.
#[derive(Debug, Clone)]
pub struct DynamicReactions {
    supports: SupportReactions,
    sets: Vec<SupportSet>,
}

/// The reactions of one state: per DOF (full length, N, zero on free DOFs) and per support set.
#[derive(Debug, Clone, PartialEq)]
pub struct ReactionsAt {
    /// r on every DOF (N): non-zero on the constrained ones only.
    pub nodal: Vec<f64>,
    /// Each support set's resultant force and moment.
    pub rows: Vec<ReactionRow>,
}

impl DynamicReactions {
    /// The reactions of a scene's dynamic system (built from `built` as
    /// [`DynamicSetup::from_scene`](super::DynamicSetup::from_scene) does): one set per
    /// `[[constraints]]` entry (`constraints[i]`), moments about each entry's `moment_about`.
    pub fn of_scene<C: tetfem::fe::element::ElementType>(
        built: &BuiltScene<C>,
        system: &LinearSystem,
    ) -> Result<Self> {
        let supports = SupportReactions::new(
            system,
            &built.mesh,
            &built.materials,
            &built.other_loads,
            built.gravity,
            &built.time_data,
        )?;
        Ok(Self::of_sets(supports, built))
    }

    /// `supports` summed per `[[constraints]]` entry of `built`.
    pub fn of_sets<C: CellType>(supports: SupportReactions, built: &BuiltScene<C>) -> Self {
        let sets = built
            .constraint_dofs
            .iter()
            .zip(&built.moment_points)
            .enumerate()
            .map(|(i, (dofs, point))| SupportSet {
                name: format!("constraints[{i}]"),
                dofs: dofs.clone(),
                point: *point,
            })
            .collect();
        DynamicReactions { supports, sets }
    }

    /// The reactions of `supports` as one set named `name` (every constrained DOF), moments
    /// about the origin: the default run's clamp.
    pub fn single(supports: SupportReactions, name: &str) -> Self {
        let dofs = supports.dofs().to_vec();
        DynamicReactions {
            supports,
            sets: vec![SupportSet {
                name: name.into(),
                dofs,
                point: Vector3::zeros(),
            }],
        }
    }

    /// The CSV columns, six per set in order: `reaction<i>_Fx_N`, `_Fy_N`, `_Fz_N` (force) and
    /// `reaction<i>_Mx_Nm`, `_My_Nm`, `_Mz_Nm` (moment, N·m), i the set's index (the scene's
    /// `constraints[i]`).
    pub fn columns(&self) -> Vec<String> {
        reaction_columns(self.sets.len())
    }

    /// The reactions at `state` of `system` under `force` on `mesh` (the setup's).
    pub fn at<C: CellType>(
        &mut self,
        mesh: &tetfem::mesh::TetMesh<C>,
        system: &LinearSystem,
        force: &InternalForce,
        state: &State,
    ) -> Result<ReactionsAt> {
        self.at_with(mesh, system, force, (state, None))
    }

    /// [`at`](Self::at) with the free acceleration `acceleration` where the integrator that
    /// made the state has it ([`SupportReactions::at_with`]: no solve with a consistent mass).
    pub fn at_with<C: CellType>(
        &mut self,
        mesh: &tetfem::mesh::TetMesh<C>,
        system: &LinearSystem,
        force: &InternalForce,
        (state, acceleration): (&State, Option<&[f64]>),
    ) -> Result<ReactionsAt> {
        let nodal = self.supports.at_with(system, force, state, acceleration)?;
        let rows = self
            .sets
            .iter()
            .map(|set| {
                let (force, moment) = tetfem::analysis::statics::reaction_resultant(
                    mesh, &nodal, &set.dofs, set.point,
                )?;
                Ok(ReactionRow {
                    constraint: set.name.clone(),
                    force_n: force.into(),
                    moment_point_m: set.point.into(),
                    moment_nm: moment.into(),
                })
            })
            .collect::<Result<Vec<_>>>()?;
        Ok(ReactionsAt { nodal, rows })
    }
}

impl ReactionsAt {
    /// The CSV values in [`DynamicReactions::columns`]' order.
    pub fn csv_values(&self) -> impl Iterator<Item = f64> + '_ {
        self.rows
            .iter()
            .flat_map(|r| r.force_n.into_iter().chain(r.moment_nm))
    }
}

/// The CSV columns of `sets` support sets, six per set in order: `reaction<i>_Fx_N`, `_Fy_N`,
/// `_Fz_N` (force) and `reaction<i>_Mx_Nm`, `_My_Nm`, `_Mz_Nm` (moment, N·m).
pub fn reaction_columns(sets: usize) -> Vec<String> {
    let mut columns = Vec::with_capacity(6 * sets);
    for i in 0..sets {
        for c in ["Fx_N", "Fy_N", "Fz_N", "Mx_Nm", "My_Nm", "Mz_Nm"] {
            columns.push(format!("reaction{i}_{c}"));
        }
    }
    columns
}
